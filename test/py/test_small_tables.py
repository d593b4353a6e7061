"""Small steady-state dyno tables (tens to 150 rows, one per operating point, no
temperature): hpddo train identifies M1 and M2 and exports a physics-only model (the
network's weights 0, the novelty gate closed), which the native replay runs as M3 = M2,
status "gated", confidence 0; the default nameplate of M1 is said, and hpddo evaluate
scores such a model."""
import contextlib
import io
import json
import math
import re

import numpy as np
import pandas as pd
import pytest

import gen_weights
from hpddo.model import gate, train
from hpddo.cli import evaluate as evaluate_cli
from twin_benches import KE_VS_PER_RAD, RA_OHM, dyno_table

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick
NOTE = "labelled training rows, at least 200 (one batch) are needed; the model is physics only (M3 = M2)"


def _train(argv) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = gen_weights.main([*map(str, argv), "--quiet", "--epochs", "5"])
    return rc, out.getvalue()


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """{rows: (log, out folder, stdout)}: 60 rows with the default nameplate, 150 with one given."""
    d = tmp_path_factory.mktemp("small")
    runs = {}
    for rows, extra in ((60, []), (150, ["--rated-v", "24", "--rated-rpm", "3000"])):
        log = dyno_table(d / f"dyno{rows}.csv", rows)
        out = d / f"out{rows}"
        rc, text = _train([log, "--out", out, *extra])
        assert rc == 0, text
        runs[rows] = (log, out, text)
    return runs


def _metrics(out):
    return json.loads((out / "metrics.json").read_text())


@pytest.mark.parametrize("rows", [60, 150])
def test_a_small_table_trains_a_physics_only_model(trained, rows):
    log, out, text = trained[rows]
    n_train = int(0.8 * rows)
    m = _metrics(out)
    ident = m["identification"]
    assert ident["residual"] == f"not trained: {n_train} {NOTE}"
    assert f"note: M3 (16, 8) not trained: {n_train} {NOTE}" in text
    assert ident["ke_m2_vs_per_rad"] == pytest.approx(KE_VS_PER_RAD, rel=0.02)
    assert ident["clamp_rpm"] == 0 and ident["final_loss"] is None
    assert m["source"].startswith("native replay")
    assert m["rmse_rpm"]["M3"] == m["rmse_rpm"]["M2"]
    assert m["rmse_rpm"]["M2"][f"dyno{rows}"] < 5.0
    header = (out / "model_default.h").read_text()
    assert m["model_checksum"] == "0x" + re.search(r"kChecksum = 0x([0-9a-f]{8})u", header).group(1)
    assert "closed: no residual network trained" in header and "training: none" in header


@pytest.mark.parametrize("rows", [60, 150])
def test_the_replay_runs_physics_only_gated_with_confidence_0(trained, rows):
    _, out, _ = trained[rows]
    est = pd.read_csv(out / "work" / "estimates" / f"dyno{rows}.estimates.csv", dtype={"status": str})
    assert len(est) == rows
    valid = est["status"] != "invalid"
    assert valid.all()
    assert set(est["status"]) == {"gated"}
    assert (est["confidence"] == 0).all() and (est["residual_rpm"] == 0).all()
    assert (est["rpm_m3"] == est["rpm_m2"]).all()
    golden = pd.read_csv(out / "golden_default.csv")
    ok = golden["status"] != 3  # the fault rows at the end: invalid readings
    assert ok.sum() >= 12 and (golden.loc[ok, "status"] == 4).all()
    assert (golden["confidence"] == 0).all() and (golden.loc[ok, "rpm"] == golden.loc[ok, "rpm_m2"]).all()


def test_the_default_nameplate_is_said(trained):
    _, out60, text60 = trained[60]
    note = "M1 uses the default nameplate 12 V, 1000 RPM; give --rated-v and --rated-rpm for your motor"
    assert f"note: {note}" in text60
    assert _metrics(out60)["identification"]["nameplate"] == {"rated_V": 12.0, "rated_rpm": 1000.0,
                                                              "source": "default", "note": note}
    _, out150, text150 = trained[150]
    assert "default nameplate" not in text150
    assert _metrics(out150)["identification"]["nameplate"] == {"rated_V": 24.0, "rated_rpm": 3000.0,
                                                               "source": "given"}
    assert _metrics(out150)["identification"]["ke_m1_vs_per_rad"] == pytest.approx(24.0 / (3000 * math.pi / 30))


def test_evaluate_scores_a_physics_only_model(trained, tmp_path):
    _, out60, _ = trained[60]
    log150, _, _ = trained[150]
    with contextlib.redirect_stdout(io.StringIO()):
        assert evaluate_cli.main(["--model", str(out60), str(log150), "--out", str(tmp_path / "ev")]) == 0
    m = _metrics(tmp_path / "ev")
    assert m["rmse_rpm"]["M3"] == m["rmse_rpm"]["M2"] and m["test_rows"]["all"] == 150
    assert m["gated_share"]["all"] == 1


def test_the_physics_only_residual_never_corrects():
    """The closed gate weighs every input 0 (also one on a prototype, at distance 0),
    so the correction is 0 whatever the network; below one batch the pipeline takes it."""
    res = train.physics_only(48, train.TrainConfig())
    g = np.array([[0, 0, 0, 0, 0], [12.0, 0.5, 250.0, 0.5, 250.0], [1e6, -1e6, 3, 4, 5]], np.float32)
    assert (gate.weight(res.gate, g) == 0).all()
    corr, w = train.correction(res, g)
    assert (corr == 0).all() and (w == 0).all()
    assert res.note == f"not trained: 48 {NOTE}" and not res.trained


@pytest.mark.parametrize("rows", [60, 150])
@pytest.mark.parametrize("ra", [RA_OHM * 0.9, RA_OHM, RA_OHM * 1.1])
def test_the_diagnosis_of_a_dyno_table_names_no_effect_and_finds_a_wrong_ra(tmp_path, ra, rows):
    """A 60- or 150-row steady-state table (sorted by voltage, as dyno tables are) of a
    motor with no effect: with the Ra reading right, nothing is named; 10 % off, nothing is
    named either and the verdict gives the Ra the table supports, closer to the true 4.5 ohm
    than the reading (60 rows: the prior still pulls; 150: within 3 %). Every row is held out
    once (cross-validation over operating points): the chronological 20 % of a sorted table
    is only its highest voltages, which did not show a wrong Ra in 60 rows."""
    from hpddo.diagnosis import core, ranking
    log = dyno_table(tmp_path / f"dyno{rows}.csv", rows)
    res = core.diagnose([log], core.Options(bootstrap=0, hybrid=False, ra_ohm=ra)).to_json()
    assert res["thresholds"]["held_out"].startswith("every row once"), res["thresholds"]
    assert res["missing_effects"] == [], res["verdict"]
    if rows == 60 and ra < RA_OHM and not res["ra_fit"]["mismatch"]:
        # 60 rows, the reading 10 % low: with a brush drop fitted alongside, the data alone hold the
        # reading (issue 21: a wrong Ra is claimed only where no alternative the held-out test
        # could not tell from it reconciles the reading), so the verdict says the two explain alike
        assert res["ra_fit"]["confounded_with"] and res["ra_fit"]["data_alone"]["determined"], res["ra_fit"]
        assert "that a wrong Ra (with Ke, the named effects and" in res["verdict"], res["verdict"]
        return
    if rows == 60 and ra > RA_OHM and not res["ra_fit"]["mismatch"]:
        # 60 rows, the reading 10 % high: with the table's noise floor taken from what the model
        # leaves out of fold (2.08 RPM; the tachometer's is 2.0) rather than from neighbouring
        # rows (1.78), the wrong Ra's held-out gain is z = 2.3, below Z_MIN: not named, and the
        # interval from the data alone holds the true Ra and reaches the reading's band
        alone = res["ra_fit"]["data_alone"]
        assert alone["lo"] <= RA_OHM <= alone["hi"] and alone["hi"] >= ra * (1 - ranking.RA_TOLERANCE), alone
        # (or, where a physical brush drop alongside holds the reading too, that the two are not told
        # apart: either way no wrong instruction)
        assert ("consistent with the reading" in res["ra_fit"]["statement"]
                or "not told apart from" in res["ra_fit"]["statement"]), res["ra_fit"]
        assert "--ra-ohm" not in res["verdict"], res["verdict"]
        return
    if rows == 150 and ra > RA_OHM and not res["ra_fit"]["mismatch"]:
        # 150 rows, the reading 10 % high: an alternative fitted alongside (an offset of the current)
        # holds the reading within its band, so no instruction is given (an instruction must survive
        # every alternative): the wrong Ra and that alternative are said not told apart
        assert res["ra_fit"]["confounded_with"] and "--ra-ohm" not in res["verdict"], res["ra_fit"]
        return
    if ra < RA_OHM and not res["ra_fit"]["mismatch"]:
        # the reading 10 % low: a winding warmer than the reading's (each row's settled rise, r i^2 Ra,
        # with copper's coefficient) holds the reading too, so the two are said not told apart and no
        # instruction is given; only a reading above what the rows show rules the heating out
        assert "thermal_ra" in res["ra_fit"]["confounded_with"], res["ra_fit"]
        assert "--ra-ohm" not in res["verdict"], res["verdict"]
        return
    assert res["ra_fit"]["mismatch"] == (ra != RA_OHM), res["ra_fit"]
    if ra != RA_OHM:
        sup = res["ra_fit"]["supported_ohm"]
        assert abs(sup - RA_OHM) < 0.5 * abs(ra - RA_OHM), res["ra_fit"]
        if rows == 150:
            assert sup == pytest.approx(RA_OHM, rel=0.03)
        assert res["verdict"].startswith("The Ra you gave")


def test_a_table_says_how_few_operating_points_its_bootstrap_draws_from(tmp_path):
    """Six voltage levels are six operating points to resample: the inclusion of a named
    effect (or of the wrong Ra) is printed with that caveat, and the HTML says it."""
    from hpddo.cli import diagnose as diagnose_cli
    from hpddo.diagnosis import core
    log = dyno_table(tmp_path / "dyno60.csv", 60)
    d = core.diagnose([log], core.Options(bootstrap=2, hybrid=False, ra_ohm=RA_OHM * 0.9))
    res = d.to_json()
    assert res["thresholds"]["bootstrap_blocks"] == 6
    # a wrong Ra is said: named, or not told apart from an effect that holds the reading
    assert res["ra_fit"]["mismatch"] or res["ra_fit"]["confounded_with"], res["ra_fit"]
    from hpddo.reports import diagnosis as report
    (tmp_path / "out").mkdir()
    report.write(tmp_path / "out", res, d.plot())
    html = (tmp_path / "out" / "index.html").read_text()
    assert "draw from 6 operating points,\ntoo few for the inclusion to mean much" in html
    assert "every row once, 5 folds of whole operating points" in html
    assert "Ra: 4.05 ohm given" in diagnose_cli.summary(d)
