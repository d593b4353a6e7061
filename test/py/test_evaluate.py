"""hpddo evaluate: a trained model scored on every row of recordings it never saw, beside
the lookup baseline; the scores of hpddo.evaluation.metrics; the lookup table itself."""
import json
import pathlib

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT

from hpddo.evaluation import baseline, metrics
from hpddo.logs import dataset
from hpddo.model import train
from hpddo.cli import evaluate as cli
from hpddo.model.identify import m2_params, ra_from_logs

MODEL = ROOT / "models" / "default"
VALIDATION = [ROOT / "data" / "validation" / f"{n}.csv" for n in ("unseen", "hot")]
TRAINING = [ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval") / "out"
    assert cli.main(["--model", str(MODEL), *map(str, VALIDATION), "--out", str(out)]) == 0
    return out


def test_every_row_is_scored_and_written(evaluated):
    m = json.loads((evaluated / "metrics.json").read_text())
    recs = dataset.load_recordings(VALIDATION, 0.0)
    for r in recs:
        est = pd.read_csv(evaluated / "work" / "estimates" / f"{r.file_stem}.estimates.csv")
        assert len(est) == r.n and set(est["part"]) == {"test"}
        assert m["test_rows"][r.name] == r.n
    assert set(m["rmse_rpm"]) == {"M1", "M2", "M3", "lookup"}
    assert (evaluated / "report" / "index.html").is_file()
    assert json.loads((evaluated / ".hpddo-output.json").read_text())["tool"] == "evaluate"


def test_scores_are_the_rmse_of_the_replayed_rows_against_the_encoder(evaluated):
    """An independent recomputation: the physics model in Python (float64) on every row,
    and the RMSE of the replay's M3 column, against the log's encoder."""
    m = json.loads((evaluated / "metrics.json").read_text())
    train_recs = dataset.load_recordings(TRAINING)
    p = m2_params(train_recs, ra_from_logs(train_recs, None)[0])
    for r in dataset.load_recordings(VALIDATION, 0.0):
        est = pd.read_csv(evaluated / "work" / "estimates" / f"{r.file_stem}.estimates.csv")
        ref = r.df["rpm_ref"].to_numpy(float)
        n2 = train.physics_rpm(r, p)
        assert np.max(np.abs(est["rpm_m2"].to_numpy() - n2)) < 0.02
        m3 = float(np.sqrt(np.mean((est["rpm_m3"].to_numpy() - ref) ** 2)))
        assert m["rmse_rpm"]["M3"][r.name] == pytest.approx(m3, rel=1e-5)
        m2 = float(np.sqrt(np.mean((n2 - ref) ** 2)))
        assert m["rmse_rpm"]["M2"][r.name] == pytest.approx(m2, rel=1e-3)


def test_the_lookup_knows_no_operating_point_it_was_not_trained_on(evaluated):
    """On the unseen duty/load pairs memory fails: the lookup is far worse than physics;
    on the hot run (training pairs) it is not."""
    rm = json.loads((evaluated / "metrics.json").read_text())["rmse_rpm"]
    assert rm["lookup"]["unseen"] > 3 * rm["M2"]["unseen"]
    assert rm["lookup"]["hot"] < rm["M2"]["hot"]


def test_a_missing_or_foreign_model_folder_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["--model", str(tmp_path / "nope"), str(VALIDATION[0]), "--out", str(out)]) == 1
    assert "no such model folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert cli.main(["--model", str(tmp_path / "empty"), str(VALIDATION[0]), "--out", str(out)]) == 1
    assert "expected one model header" in capsys.readouterr().err
    assert not out.exists()


def test_lookup_predicts_the_nearest_training_operating_point():
    lk = baseline.Lookup(duty=np.array([0.2, 0.6, 0.8, 0.8]), load=np.array([0, 0, 1, 2]),
                         rpm=np.array([20.0, 140.0, 150.0, 120.0]), rows=np.array([5, 5, 5, 5]))
    got = lk.predict([0.3, 0.5, 0.1, 0.5, 0.9, 0.7], [0, 0, 0, 1, 2, 3])
    # same load, nearest duty; load 3 never trained: nearest duty over every load (0.6)
    assert got.tolist() == [20.0, 140.0, 20.0, 150.0, 120.0, 140.0]


def test_lookup_file_round_trips_and_fits_the_training_means(tmp_path):
    recs = dataset.load_recordings(TRAINING)
    lk = baseline.Lookup.fit(recs)
    path = tmp_path / baseline.FILE
    path.write_text(lk.to_json())
    back = baseline.Lookup.read(path)
    assert np.array_equal(back.duty, lk.duty) and np.array_equal(back.load, lk.load)
    assert np.allclose(back.rpm, lk.rpm, rtol=1e-8)
    load = pd.concat([r.part("train") for r in recs])
    at = load[np.isclose(load["duty"], 0.6) & (load["load"] == 0)]
    k = np.flatnonzero((lk.load == 0) & np.isclose(lk.duty, 0.6))[0]
    assert lk.rpm[k] == pytest.approx(at["rpm_ref"].mean(), rel=1e-12) and lk.rows[k] == len(at)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(Exception, match="not a lookup table"):
        baseline.Lookup.read(tmp_path / "bad.json")


def test_metrics_pool_conditions_and_keep_any_condition_name():
    name = 'quote"back\\slash\ttab'
    est = pd.DataFrame({"rpm_m1": [1.0, 2.0, 3.0], "rpm_m2": [1.0, 1.0, 1.0], "rpm_m3": [0.0, 0.0, 0.0],
                        "status": ["ok", "clamped", "invalid"]})
    ref = np.array([0.0, 0.0, np.nan])
    m = metrics.score([(name, ref, est, np.array([True, True, True])),
                       (name, ref, est, np.array([False, True, True]))], "test")
    back = json.loads(json.dumps(m))
    assert back["test_rows"][name] == 5 and back["test_rows"]["all"] == 5
    # M1 errors over the labelled scored rows: 1, 2 and 2
    assert back["rmse_rpm"]["M1"][name] == pytest.approx(np.sqrt((1 + 4 + 4) / 3), rel=1e-6)
    assert back["clamped_share"][name] == pytest.approx(0.4) and back["invalid_share"]["all"] == pytest.approx(0.4)
    assert "lookup" not in back["rmse_rpm"]


@pytest.mark.slow
def test_leave_one_out_trains_without_the_recording_it_scores(tmp_path):
    """hpddo train --leave-one-out: per recording, a model trained on the others only,
    scored on every row of the one left out; the figures land in metrics.json."""
    import gen_weights
    logs = [ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "sweep")]
    out = tmp_path / "m"
    assert gen_weights.main([*map(str, logs), "--out", str(out), "--epochs", "3", "--quiet",
                             "--leave-one-out"]) == 0
    loo = json.loads((out / "metrics.json").read_text())["leave_one_out"]
    assert set(loo["recordings"]) == {"load", "sweep"}
    for held, other in (("load", "sweep"), ("sweep", "load")):
        trained = json.loads((out / "leave_one_out" / held / "model" / "metrics.json").read_text())
        assert trained["recordings"] == [other]
        est = pd.read_csv(out / "leave_one_out" / held / "evaluation" / "estimates" / f"{held}.estimates.csv")
        rec = dataset.load_recording(ROOT / "data" / "default" / f"{held}.csv", 0.0)
        assert len(est) == rec.n and set(est["part"]) == {"test"}
        m3 = float(np.sqrt(np.mean((est["rpm_m3"].to_numpy() - rec.df["rpm_ref"].to_numpy()) ** 2)))
        assert loo["recordings"][held]["M3"] == pytest.approx(m3, rel=1e-5)
    avg = np.mean([loo["recordings"][c]["M2"] for c in ("load", "sweep")])
    assert loo["average"]["M2"] == pytest.approx(avg, rel=1e-5)
    # a rerun into the same folder is allowed (the tool wrote everything in it)
    assert gen_weights.main([*map(str, logs), "--out", str(out), "--epochs", "3", "--quiet",
                             "--leave-one-out"]) == 0


def test_a_fold_whose_others_cannot_be_fitted_is_said_not_scored(tmp_path, capsys):
    """train --leave-one-out with a recording that has no encoder speeds beside one that has: the model on both
    trains, the fold trained on the unlabelled one alone cannot be. The whole run ended in that fold's refusal,
    nothing written (a fuzzing helper's); the fold is now said not scored, with why, and the model is written."""
    import gen_weights
    from hpddo.logs import benchlog

    log = benchlog.read_log(ROOT / "data" / "default" / "load.csv")
    meta = dict(log.meta, condition="load_norpm")
    unlabelled = benchlog.write_log(tmp_path / "load_norpm.csv", log.df.drop(columns=["rpm_ref"]), meta, exact=True)
    out = tmp_path / "m"
    assert gen_weights.main([str(unlabelled), str(ROOT / "data" / "default" / "sweep.csv"), "--out", str(out),
                             "--epochs", "3", "--quiet", "--leave-one-out"]) == 0
    printed = capsys.readouterr().out
    assert "(sweep: not scored: the others alone cannot be fitted: " in printed, printed
    loo = json.loads((out / "metrics.json").read_text())["leave_one_out"]
    assert set(loo["not_scored"]) == {"sweep"} and loo["recordings"]["sweep"]["M2"] is None
    assert loo["average"]["M2"] is None


def test_leave_one_out_of_one_recording_is_refused_before_any_work(tmp_path, capsys):
    import gen_weights
    out = tmp_path / "m"
    assert gen_weights.main([str(ROOT / "data" / "default" / "sweep.csv"), "--out", str(out), "--quiet",
                             "--leave-one-out"]) == 1
    assert "at least two recordings" in capsys.readouterr().err and not out.exists()


def test_a_recording_without_encoder_readings_gets_estimates_and_no_scores(tmp_path, capsys):
    text = VALIDATION[1].read_text().splitlines()
    meta = [ln for ln in text if ln.startswith("#")]
    df = pd.read_csv(VALIDATION[1], comment="#").drop(columns=["rpm_ref"]).iloc[:120]
    log = tmp_path / "plain.csv"
    log.write_text("\n".join(meta) + "\n" + df.to_csv(index=False))
    out = tmp_path / "out"
    assert cli.main(["--model", str(MODEL), str(log), "--out", str(out)]) == 0
    assert "nothing to score" in capsys.readouterr().out
    m = json.loads((out / "metrics.json").read_text())
    assert all(v[c] is None for v in m["rmse_rpm"].values() for c in v)
    (est_path,) = (out / "work" / "estimates").glob("*.estimates.csv")
    est = pd.read_csv(est_path)
    assert len(est) == 120 and est["rpm_m3"].notna().all()
    assert (out / "report" / "index.html").is_file()


@pytest.mark.slow
def test_a_thermal_model_on_a_log_without_temperature_is_warned_about(tmp_path, capsys):
    """A model with thermal effects scored on a hot run whose temp_C column is gone takes
    the case at its ambient on every row and errs more: said, with what to do."""
    import gen_weights
    model = tmp_path / "m"
    assert gen_weights.main([*map(str, TRAINING), "--out", str(model), "--epochs", "3", "--quiet",
                             "--effects", "thermal_ra,magnet_thermal"]) == 0
    df = dataset.load_recording(VALIDATION[1], 0.0, glitch_filter=False).df.drop(columns=["temp_C"])
    log = tmp_path / "hot_no_temp.csv"
    log.write_text("# condition=hot_no_temp\n" + df.to_csv(index=False))
    capsys.readouterr()
    out = tmp_path / "e"
    assert cli.main(["--model", str(model), str(log), str(VALIDATION[1]), "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    warned = [ln for ln in err.splitlines() if "no temp_C" in ln]
    assert len(warned) == 1 and str(log) in warned[0] and "thermal_ra, magnet_thermal" in warned[0], err
    m = json.loads((out / "metrics.json").read_text())
    assert any("no temp_C" in w for w in m["warnings"])
    # the warning is about a real loss: the same run with its temperature scores better
    assert m["rmse_rpm"]["M2"]["hot_no_temp"] > 1.5 * m["rmse_rpm"]["M2"]["hot"]
    # a plain model has nothing to warn about
    capsys.readouterr()
    assert cli.main(["--model", str(MODEL), str(log), "--out", str(tmp_path / "e2"), "--quiet"]) == 0
    assert "no temp_C" not in capsys.readouterr().err


def test_a_recording_without_encoder_speeds_has_no_rmse_and_no_part_in_the_average():
    """metrics.score: a condition whose scored rows carry no rpm_ref has no RMSE (null, "-" in the
    table), and the average is over the conditions that have one, not null for all."""
    import numpy as np
    import pandas as pd

    from hpddo.evaluation import metrics

    n = 50
    est = pd.DataFrame({"rpm_m1": np.full(n, 110.0), "rpm_m2": np.full(n, 102.0), "rpm_m3": np.full(n, 101.0),
                        "status": ["ok"] * n})
    ref = np.full(n, 100.0)
    m = metrics.score([("with", ref, est, np.ones(n, bool)), ("without", np.full(n, np.nan), est, np.ones(n, bool))],
                      "test")
    assert m["rmse_rpm"]["M2"] == {"with": 2, "without": None, "average": 2}
    assert m["rmse_rpm"]["M1"]["average"] == 10 and m["test_rows"]["without"] == n
    text = metrics.table(m)
    row = next(ln for ln in text.splitlines() if ln.startswith("without"))
    assert row.split()[1:4] == ["-", "-", "-"] and "nan" not in text
    none = metrics.score([("without", np.full(n, np.nan), est, np.ones(n, bool))], "test")
    assert none["rmse_rpm"]["M3"]["average"] is None


def test_a_recording_of_a_few_rows_is_scored_whole(tmp_path):
    """evaluate scores every row and splits none, so a recording needs a row, not the ten a train/test split
    needs (it was refused: "at least 10 are needed to split train/test")."""
    lines = (ROOT / "data" / "validation" / "unseen.csv").read_text().splitlines()
    n_head = next(k for k, ln in enumerate(lines) if not ln.startswith("#")) + 1
    short = tmp_path / "short.csv"
    short.write_text("\n".join(lines[:n_head] + lines[n_head + 200: n_head + 203]) + "\n")
    out = tmp_path / "out"
    assert cli.main(["--model", str(MODEL), str(short), "--out", str(out), "--quiet"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["test_rows"]["unseen"] == 3 and np.isfinite(m["rmse_rpm"]["M3"]["unseen"]), m
