"""Any valid bench log, no traceback (issue 31, item 1): Hypothesis writes valid logs of every
shape (docs/bench-log.md): channels constant, stuck, clipped or coarse; one operating point
per log or per row; tables with and without `kind`; duplicated rows; one-row groups; values
from milliamps to kiloamps-scale within the format. The reader, the diagnosis (and its
printed summary) and M2's identification must each either give a result (every
determined interval finite, holding its value) or refuse the input with one of the tools' user errors
(logs.errors.USER_ERRORS: file, line and fault); any other exception is a bug. A verdict
never carries an exception's text."""
import math
import pathlib
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from hpddo.cli import diagnose as diagnose_cli
from hpddo.diagnosis import core
from hpddo.logs import dataset
from hpddo.logs.errors import USER_ERRORS
from hpddo.model import identify

pytestmark = pytest.mark.slow

# the shapes a channel may take (besides following the motor)
V_SHAPES = ("follows", "fixed supply", "clipped", "coarse")
I_SHAPES = ("follows", "stuck", "clipped", "coarse", "noisy")
DUTY_SHAPES = ("fixed", "sorted steps", "held steps", "per row random")


@st.composite
def log_spec(draw):
    """One recording's shape and numbers."""
    return {
        "rows": draw(st.integers(min_value=3, max_value=160)),
        "duty": draw(st.sampled_from(DUTY_SHAPES)),
        "v": draw(st.sampled_from(V_SHAPES)),
        "i": draw(st.sampled_from(I_SHAPES)),
        "kind": draw(st.sampled_from((None, "steady_state", "time_series"))),
        "rate": draw(st.sampled_from((None, 1.0, 2.0, 100.0))),
        "rpm": draw(st.sampled_from(("all", "some empty", "none"))),
        "temp": draw(st.sampled_from((None, "constant", "rising"))),
        "load": draw(st.booleans()),
        "duplicate": draw(st.booleans()),
        "seed": draw(st.integers(min_value=0, max_value=2 ** 16)),
    }


RA_OHM = 4.5  # the motor's at scale 1


def write_log(path: pathlib.Path, s: dict, k: float = 1.0) -> pathlib.Path:
    """The bench log of spec s at path, a motor of size k (its current 1 / k times, its Ra k
    times the unit motor's): valid by docs/bench-log.md whatever its physics."""
    rng = np.random.default_rng(s["seed"])
    n = s["rows"]
    ra, ke = RA_OHM * k, 0.4
    if s["duty"] == "fixed":
        duty = np.full(n, 0.8)
    elif s["duty"] == "sorted steps":
        duty = np.sort(rng.choice([0.2, 0.4, 0.6, 0.8, 1.0], n))
    elif s["duty"] == "held steps":
        duty = np.repeat(rng.choice([0.0, 0.3, 0.6, 0.9], max(1, n // 5 + 1)), 5)[:n]
    else:
        duty = rng.uniform(0.0, 1.0, n).round(3)
    load = rng.integers(0, 3, n) if s["load"] else np.zeros(n, int)
    v = 12.0 * duty * (1.0 if s["v"] != "fixed supply" else 0.0) + (12.0 if s["v"] == "fixed supply" else 0.0)
    i = (0.1 + 0.3 * load + 0.05 * rng.random(n)) / max(k, 1e-9) * (duty > 0)
    rpm = np.maximum((v - i * ra) / ke, 0.0) * 60 / (2 * math.pi) + rng.normal(0, 1.0, n)
    v = v + rng.normal(0, 0.01, n)
    if s["v"] == "clipped":
        v = np.minimum(v, 7.0)
    if s["v"] == "coarse":
        v = np.round(v / 2.0) * 2.0
    if s["i"] == "stuck":
        i = np.full(n, 0.123)
    elif s["i"] == "clipped":
        i = np.minimum(i, np.percentile(i, 40))
    elif s["i"] == "coarse":
        i = np.round(i / (0.5 / max(k, 1e-9))) * (0.5 / max(k, 1e-9))
    elif s["i"] == "noisy":
        i = i + rng.normal(0, 0.5 / max(k, 1e-9), n)
    rows = np.arange(n)
    if s["duplicate"] and n > 4:  # rows repeated value for value (a new t_s: it must increase)
        rows = np.sort(np.concatenate([rows, rng.choice(n, n // 3)]))
    dt = 1.0 / s["rate"] if s["rate"] else 1.0
    meta = [f"# condition={path.stem}"]
    if s["kind"]:
        meta.append(f"# kind={s['kind']}")
    if s["rate"]:
        meta.append(f"# sample_rate_hz={s['rate']:g}")
    cols = ["t_s", "duty", "v_V", "i_A", "rpm_ref"] + (["temp_C"] if s["temp"] else []) + (["load"] if s["load"] else [])
    lines = meta + [",".join(cols)]
    for t, r in enumerate(rows):
        cell_rpm = "" if s["rpm"] == "none" or (s["rpm"] == "some empty" and r % 3 == 0) else f"{rpm[r]:.6g}"
        row = [f"{t * dt:.6g}", f"{duty[r]:.6g}", f"{v[r]:.6g}", f"{i[r]:.6g}", cell_rpm]
        if s["temp"]:
            row.append(f"{30.0 + (0.0 if s['temp'] == 'constant' else 0.05 * t):.4g}")
        if s["load"]:
            row.append(str(int(load[r])))
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


# words of a Python exception's message that a verdict must never carry
EXCEPTION_TEXT = re.compile(r"out of bounds|zero-size array|has no attribute|object is not|Traceback|"
                            r"division by zero|cannot convert|index \d+ is")


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
