"""Any valid bench log, no traceback (issue 31, item 1): Hypothesis writes valid logs of every
shape (docs/bench-log.md): channels constant, stuck, clipped or coarse; one operating point
per log or per row; tables with and without `kind`; duplicated rows; one-row groups; values
from milliamps to kiloamps-scale within the format. The reader, the diagnosis (and its
printed summary) and M2's identification must each either give a result (every
determined interval finite, holding its value) or refuse the input with one of the tools' user errors
(logs.errors.USER_ERRORS: file, line and fault); any other exception is a bug. A verdict
never carries an exception's text."""
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from valid_logs import EXCEPTION_TEXT, RA_OHM, log_spec, write_log

from hpddo.cli import diagnose as diagnose_cli
from hpddo.diagnosis import core
from hpddo.logs import dataset
from hpddo.logs.errors import USER_ERRORS
from hpddo.model import identify
from hpddo.reports import diagnosis as report

pytestmark = pytest.mark.slow


def _refuse_constant(name):
    raise AssertionError(f"diagnosis.json holds {name}: not JSON")


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(specs=st.lists(log_spec(), min_size=1, max_size=3), size=st.sampled_from((1e-3, 1.0, 1e2)),
       ra_given=st.sampled_from((None, 0.5, 1.0, 1.15, 2.3)))
def test_no_traceback_on_any_valid_log(tmp_path_factory, specs, size, ra_given):
    """size: the motor's, tiny to huge within the format; ra_given: the Ra passed, times the true one
    (None: none given)."""
    d = tmp_path_factory.mktemp("logs")
    paths = [write_log(d / f"rec{k}.csv", s, size) for k, s in enumerate(specs)]
    ra = None if ra_given is None else ra_given * RA_OHM * size
    try:
        recs = dataset.load_recordings(paths)
    except USER_ERRORS as exc:
        event(f"refused by the reader: {str(exc)[-60:]}")
        return  # refused with its file, line and fault
    for r in recs:
        assert dataset.kind(r)[0] in dataset.KINDS
    try:
        identify.m2_params(recs, identify.ra_from_logs(recs, ra)[0])
    except USER_ERRORS:
        pass
    try:
        res = core.diagnose(paths, core.Options(ra_ohm=ra, bootstrap=0, hybrid=False))
    except USER_ERRORS as exc:
        event(f"refused by the diagnosis: {str(exc)[:40]}")
        return
    event("diagnosed")
    assert not EXCEPTION_TEXT.search(res.verdict), res.verdict
    diagnose_cli.summary(res)  # the printed summary too
    js = res.to_json()
    # diagnosis.json as the report writes it: strict JSON (no NaN or Infinity, which JSON.parse refuses)
    json.loads(report.summary(js), parse_constant=_refuse_constant)
    for iv in js.get("intervals", []):
        if iv["determined"]:
            assert math.isfinite(iv["value"]) and iv["lo"] <= iv["value"] <= iv["hi"], iv


def test_a_dyno_table_of_one_supply_per_log_is_read_as_tables_without_a_saturated_channel(tmp_path):
    """The real-table shape of the issue: one log per supply voltage (the voltage fixed, the duty
    at 1), settled points at a made-up 1 s clock, no kind line: read as steady-state tables (and
    said so, with the line that declares the other), no voltage channel called saturated, no
    traceback."""
    paths = []
    rng = np.random.default_rng(1)
    for volts in (6, 8, 10, 12):
        lines = [f"# condition=dyno{volts}V", "t_s,duty,v_V,i_A,rpm_ref"]
        for k in range(20):
            i = 0.1 + 0.05 * k
            rpm = (volts - 4.5 * i - 1.2) / 0.4 * 60 / (2 * math.pi)
            lines.append(f"{k},1,{volts},{i + rng.normal(0, 0.002):.4f},{rpm + rng.normal(0, 2):.2f}")
        p = tmp_path / f"dyno{volts}.csv"
        p.write_text("\n".join(lines) + "\n")
        paths.append(p)
    recs = dataset.load_recordings(paths)
    for r in recs:
        kind, how = dataset.kind(r)
        assert kind == "steady_state" and how.startswith("detected") and "# kind=time_series" in how, how
    res = core.diagnose(paths, core.Options(ra_ohm=4.5, bootstrap=0, hybrid=False))
    js = res.to_json()
    assert not [c for c in js["channels"] if c["fault"] == "saturated"], js["channels"]
    assert "saturated" not in res.verdict
    assert "read as time series" not in diagnose_cli.summary(res)


def test_the_bundled_time_series_are_not_taken_for_tables():
    """The twin's 2 Hz recordings hold their operating points for many rows: read as time series
    (most of their consecutive rows hold their point), the line that would declare a table said."""
    from conftest import ROOT
    for folder, names in (("default", ("sweep", "load", "long")), ("validation", ("hot", "unseen"))):
        for name in names:
            rec = dataset.load_recordings([ROOT / "data" / folder / f"{name}.csv"])[0]
            kind, how = dataset.kind(rec)
            assert kind == "time_series" and "# kind=steady_state" in how, (name, how)
            assert dataset.hold_share(rec) > 0.6, name
