"""Issue 21, item 8: fast logs. On the twin's 100 Hz sweep with the shaft's inertia (J 3e-4 kg m^2,
friction B 4 mN m s/rad and Tc 95 mN m with the generator coupled, La 2.5 mH), the residual follows
dV/dt and the diagnosis names dynamics with the speed's measured lag, J, B and Tc with intervals that
hold the twin's values, and the held-out RMSE before and after the boards' observer; never "no library
effect explains it". A 2 Hz log: dynamics not determined by these recordings, and what would."""
from __future__ import annotations

import re

import pytest

from hpddo.cli import diagnose as diagnose_cli
from hpddo.diagnosis import core
from hpddo.model import dynamics
from hpddo.logs import benchlog, dataset
from hpddo.twin import generate, params

BENCH = params.with_effects(params.preset("ideal"), inductance=2.5)
J_TRUE = BENCH.j_kgm2
B_TRUE = BENCH.b_motor_nms + BENCH.b_gen_nms   # load state 0: the generator turns, its circuit open
TC_TRUE = BENCH.tc_motor_nm + BENCH.tc_gen_nm


def _run(tmp_path, rate_hz):
    generate.generate(BENCH, "sweep", rate_hz=rate_hz, seed=3, time_scale=0.1, out_dir=tmp_path)
    return core.diagnose([tmp_path / "sweep.csv"], core.Options(bootstrap=0, hybrid=False))


@pytest.fixture(scope="module")
def fast(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("fast"), 100.0)


def test_a_fast_run_with_inertia_names_dynamics_with_the_lag_and_the_family(fast):
    res = fast.to_json()
    v = res["verdict"]
    assert "The residual follows dV/dt" in v and "Named: dynamics" in v, v
    assert "No library effect explains" not in v and "no library effect explains" not in v, v
    lag = re.search(r"The speed lags the duty steps by (\d+) ms", v)
    assert lag and 15 <= int(lag.group(1)) <= 40, v   # measured: 27 ms (the twin's true speed: 19 ms median)
    dyn = res["dynamics"]
    assert dyn["speed_from"] == "encoder periods" and dyn["steps"] >= 6
    q = {x["field"]: x for x in dyn["quantities"]}
    for field, truth in (("j_kgm2", J_TRUE), ("b_nms_per_rad", B_TRUE), ("tc_nm", TC_TRUE)):
        assert q[field]["determined"], q[field]
        assert q[field]["lo"] <= truth <= q[field]["hi"], (field, q[field], truth)
    assert abs(q["j_kgm2"]["value"] / J_TRUE - 1) < 0.3, q["j_kgm2"]   # measured +26 % on this seed
    assert abs(q["b_nms_per_rad"]["value"] / B_TRUE - 1) < 0.05 and abs(q["tc_nm"]["value"] / TC_TRUE - 1) < 0.05
    # La's rise (La / R, 0.5 ms) is over within a 10 ms row: not determined, with what would
    assert not q["la_H"]["determined"] and "1 kHz" in q["la_H"]["needs"]
    before, after = dyn["rmse_rpm"]["before"], dyn["rmse_rpm"]["after"]
    assert after < 0.8 * before, dyn["rmse_rpm"]          # measured 15.6 -> 9.6 RPM
    assert f"goes from {before:.3g} to {after:.3g} RPM" in v
    assert dyn["text"] in diagnose_cli.summary(fast)


def test_a_2_hz_log_leaves_dynamics_not_determined_and_says_what_would(tmp_path):
    d = _run(tmp_path, 2.0)
    dyn = d.to_json()["dynamics"]
    assert not dyn["fast_recordings"] and not dyn["quantities"]
    assert "not determined by these recordings" in dyn["text"] and dynamics.NEEDS in dyn["text"]
    assert "Named: dynamics" not in d.verdict


def test_a_bad_encoder_period_is_refused_with_its_line(tmp_path):
    g = generate.generate(BENCH, "sweep", rate_hz=100.0, seed=3, time_scale=0.02)
    log = g["log"].copy()
    log[dataset.ENC_PERIOD_COLUMN] = log[dataset.ENC_PERIOD_COLUMN].astype(object)
    log.loc[7, dataset.ENC_PERIOD_COLUMN] = "-0.002"
    path = benchlog.write_log(tmp_path / "sweep.csv", log, g["meta"])
    rec = dataset.load_recording(path)
    with pytest.raises(benchlog.BenchLogError) as exc:
        dataset.enc_period_s(rec)
    assert exc.value.line == len(g["meta"]) + 2 + 7 and "enc_period_s" in str(exc.value)


def test_the_report_page_shows_the_dynamics_and_their_table(fast):
    from hpddo.reports import diagnosis as diagnosis_report
    res = fast.to_json()
    html = diagnosis_report.page(res, diagnosis_report.figures(res, fast.plot()))
    assert "<h2>Dynamics (fast logs)</h2>" in html
    for q in res["dynamics"]["quantities"]:
        assert f'<td class="l">{q["quantity"]}</td>' in html
    assert "not determined by these recordings" in html   # La at 100 Hz


def test_an_undetermined_quantity_keeps_no_value_the_quantity_cannot_take():
    """A fuzzing helper's metrics.json held La = -3.1 mH, not determined: a negative inductance is no value of La.
    An undetermined quantity keeps its fitted value only within its physical range; a determined one is as before."""
    import numpy as np

    boot = np.full(dynamics.BOOT, 2.0e-3)
    neg = dynamics._interval("la_H", -3.1e-3, boot, "too fast for the rows")
    assert neg.value is None and not neg.determined and "not determined" in neg.text()
    pos = dynamics._interval("la_H", 2.5e-3, boot, "too fast for the rows")
    assert pos.value == 2.5e-3 and not pos.determined
    spread = dynamics._interval("la_H", -1.0e-3, np.linspace(-3e-3, 1e-3, dynamics.BOOT), clusters=6)
    assert spread.value is None and spread.lo is None and not spread.determined, spread
    held = dynamics._interval("j_kgm2", 3.0e-4, np.linspace(2.9e-4, 3.1e-4, dynamics.BOOT), clusters=6)
    assert held.determined and held.lo <= 3.0e-4 <= held.hi
