"""hpddo compare (docs/compare.md): the classical observers recover the true speed where
the physics is exact, tuning and training never see a test row, eq. 26 holds on every
sample, and the tables' JSON keeps its schema."""
import dataclasses
import json
import math
import pathlib

import numpy as np
import pandas as pd
import pytest

from hpddo import cli
from hpddo.studies.compare import config, methods, observers, tables, text, training
from hpddo.logs import dataset
from hpddo.model import identify, network

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick

ROOT = pathlib.Path(__file__).resolve().parents[2]
DEFAULT = [ROOT / "data" / "default" / f"{n}.csv" for n in ("sweep", "load", "long")]
VALIDATION = [ROOT / "data" / "validation" / f"{n}.csv" for n in ("hot", "unseen")]

# Noise-free twin, every effect off (docs/compare.md, "Tests"): the bounds on the test rows.
EKF_RMSE_BOUND_RPM = 0.01      # the EKF follows the exact quasi-static current measurement
SMO_RMSE_BOUND_RPM = 1.5       # the SMO's slew (k per sample) lags the duty and load steps
SMO_STEADY_BOUND_RPM = 0.05    # and settles on the true speed between them
QUICK_SECONDS_LIMIT = 120      # --quick: under 60 s on an idle 2-core machine; margin for a busy one


@pytest.fixture(scope="module")
def ideal(tmp_path_factory):
    """sweep and load on the noise-free twin with every effect off, loaded and identified."""
    out = tmp_path_factory.mktemp("ideal")
    for prot in ("sweep", "load"):
        assert cli.main(["twin", "--protocol", prot, "--preset", "ideal", "--no-noise", "--quiet",
                         "--out", str(out)]) == 0
    recs = dataset.load_recordings([out / "sweep.csv", out / "load.csv"])
    ra, _ = identify.ra_from_logs(recs, None)
    return out, recs, identify.m2_params(recs, ra)


def truth_rpm(folder, rec):
    t = pd.read_csv(folder / f"{rec.source.stem}.truth.csv").set_index("t_s")["rpm_true"]
    return t.reindex(rec.df["t_s"].to_numpy()).to_numpy(float)


def test_classical_observers_recover_the_true_speed_on_an_exact_twin(ideal, tmp_path):
    folder, recs, m2 = ideal
    tuned = observers.tune_observers({"ideal": (recs, m2)}, tmp_path / "tune")["ideal"]
    est = observers.run_observers(tuned, recs, tmp_path / "run", None)
    for r, e in zip(recs, est):
        truth = truth_rpm(folder, r)
        test = np.arange(r.n) >= r.n_train
        rms = {m: math.sqrt(np.mean((e[m][test] - truth[test]) ** 2)) for m in ("EKF", "SMO")}
        assert rms["EKF"] <= EKF_RMSE_BOUND_RPM, (r.name, rms)
        assert rms["SMO"] <= SMO_RMSE_BOUND_RPM, (r.name, rms)
        # steady rows: the true speed has not moved over the last 4 samples
        steady = test.copy()
        for lag in range(1, 5):
            steady[lag:] &= np.abs(truth[lag:] - truth[:-lag]) < 0.01
        steady[:4] = False
        assert steady.sum() > 20
        assert np.max(np.abs(e["SMO"][steady] - truth[steady])) <= SMO_STEADY_BOUND_RPM, r.name
        assert np.max(np.abs(e["EKF"][steady] - truth[steady])) <= EKF_RMSE_BOUND_RPM, r.name
    # the friction of the torque balance is physical (never driving)
    assert tuned["motor"]["b_nms_per_rad"] >= 0 and tuned["motor"]["tc_nm"] >= 0


def _planted(rec: dataset.Recording) -> dataset.Recording:
    """rec with a marker in every test row: absurd V, I, speed, temperature and duty."""
    df = rec.df.copy()
    rows = df.index >= rec.n_train
    df.loc[rows, "v_V"] = 11.5
    df.loc[rows, "i_A"] = 0.123
    df.loc[rows, "rpm_ref"] = 12345.0
    if "temp_C" in df:
        df.loc[rows, "temp_C"] = 99.0
    df.loc[rows, "duty"] = 0.37
    return dataclasses.replace(rec, df=df)


def test_tuning_and_training_never_see_a_test_row(tmp_path):
    """A marker planted in every test row changes none of what is identified, tuned or
    trained on: the observers' parameters (the tuner's whole output), M2, the rows of
    the residual network and of the pure network, the lookup table."""
    from hpddo.evaluation import baseline
    recs = dataset.load_recordings(DEFAULT[:2])  # sweep, load: about 1000 training rows
    marked = [_planted(r) for r in recs]
    assert not all(a.df.equals(b.df) for a, b in zip(recs, marked))
    ra, _ = identify.ra_from_logs(recs, None)
    out = {}
    for name, rs in (("clean", recs), ("marked", marked)):
        m2 = identify.m2_params(rs, ra)
        tuned = observers.tune_observers({name: (rs, m2)}, tmp_path / name, coarse=True)[name]
        x, e = methods._x_e(rs, m2)
        xn, yn = methods.stack_rows(rs, lambda r: (methods.nn_features(r), methods.reference(r)))
        lk = baseline.Lookup.fit(rs)
        out[name] = (m2, tuned, x, e, xn, yn, lk.to_json())
    (m2a, ta, xa, ea, xna, yna, la), (m2b, tb, xb, eb, xnb, ynb, lb) = out["clean"], out["marked"]
    assert m2a == m2b
    assert ta == tb  # every tuned parameter, the identified friction and the training score, to the bit
    for a, b in ((xa, xb), (ea, eb), (xna, xnb), (yna, ynb)):
        np.testing.assert_array_equal(a, b)
    assert la == lb
    # the tuner's logs hold the training rows alone: the marker is in none of them
    for log in (tmp_path / "marked").rglob("*.train.csv"):
        text = log.read_text()
        assert "12345" not in text and ",0.123" not in text


def test_eq26_counts_what_the_clamp_prevents():
    ref = np.array([100.0, 100.0, 100.0, np.nan])
    n2 = np.array([105.0, 95.0, 100.0, 100.0])
    clamp = 3.0
    raw = np.array([-20.0, 2.0, 5.0, 1.0])
    ok = tables.eq26(n2 + np.clip(raw, -clamp, clamp), n2, ref, clamp)
    assert ok["violations"] == 0 and ok["samples"] == 3
    bad = tables.eq26(n2 + raw, n2, ref, clamp)
    assert bad["violations"] == 2 and bad["largest_excess_rpm"] == pytest.approx(7.0)  # |85 - 100| - (5 + 3)


def test_pure_network_file_replays_what_python_computes(tmp_path):
    """The float32 network of compare_observers against the float64 numpy network."""
    recs = dataset.load_recordings(DEFAULT[:1])
    x, y = methods.stack_rows(recs, lambda r: (methods.nn_features(r), methods.reference(r)))
    scaler, net = training.fit_network(x, y, (8,), 5, 1, standardise_target=True)
    mlp = observers.write_mlp(scaler, net, tmp_path / "nn.mlp")
    tuned = {"motor": {"ke_vs_per_rad": 0.4, "ra_ohm": 4.5, "b_nms_per_rad": 0.0, "tc_nm": 0.1},
             "ekf": {"j_kgm2": 1e-3, "q_w": 1.0, "q_t": 1e-6, "r_A2": 1e-6},
             "smo": {"k_V": 1.0, "phi_A": 0.5, "tau_s": 0.1}}
    est = observers.run_observers(tuned, recs, tmp_path / "run", mlp)[0]["pure NN"]
    want = net.predict(scaler.transform(methods.nn_features(recs[0])))
    assert np.max(np.abs(est - want)) < 1e-3 * max(1.0, np.max(np.abs(want)))


# ---- the whole command, --quick, on the bundled recordings

@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    import time
    out = tmp_path_factory.mktemp("compare") / "out"
    t0 = time.perf_counter()
    code = cli.main(["compare", *map(str, DEFAULT), "--validation", *map(str, VALIDATION),
                     "--effects", "thermal_ra,current_offset,magnet_thermal", "--quick", "--quiet", "--out", str(out)])
    return code, out, time.perf_counter() - t0


TABLES = ("table7", "table8", "table9", "table10", "ood")
CONDITIONS = ["sweep", "load", "long", "average"]


def _rmse_block(block: dict, conds=CONDITIONS):
    for method, row in block.items():
        assert list(row) == conds, (method, list(row))
        for v in row.values():
            assert isinstance(v, (int, float)) and math.isfinite(v) and v >= 0, (method, row)


def test_quick_comparison_runs_in_time_and_writes_every_table(quick):
    code, out, seconds = quick
    assert code == 0
    assert seconds < QUICK_SECONDS_LIMIT
    for t in TABLES:
        assert (out / f"{t}.json").is_file()
    page = (out / "report" / "index.html").read_text()
    for title in ("Table 7", "Table 8", "Table 9", "Table 10", "Section 4.10", "(paper)"):
        assert title in page


def test_tables_json_schema(quick):
    _, out, _ = quick
    t = {n: json.loads((out / f"{n}.json").read_text()) for n in TABLES}
    for name, table in t.items():
        assert table["command"].startswith("hpddo compare ") and "--out" in table["command"], name
        assert table["settings"]["quick"] is True and table["settings"]["epochs"] == config.QUICK_EPOCHS
        assert "paper" in table and "title" in table
    t7 = t["table7"]
    methods = ["M1", "M2", "M2 + effects", "EKF", "SMO", "pure NN", "M3", "M3 gated", "lookup"]
    assert t7["methods"] == methods
    for part in ("chronological", "leave_one_out"):
        assert list(t7[part]["rmse_rpm"]) == methods
        _rmse_block(t7[part]["rmse_rpm"])
    assert list(t7["validation"]["rmse_rpm"]) == methods
    _rmse_block(t7["validation"]["rmse_rpm"], ["hot", "unseen", "average"])
    for tuned in [t7["tuned"]["chronological"], *t7["tuned"]["leave_one_out"].values()]:
        assert set(tuned["ekf"]) == {"j_kgm2", "q_w", "q_t", "r_A2"}
        assert set(tuned["smo"]) == {"k_V", "phi_A", "tau_s"}
        assert all(v > 0 for v in [*tuned["ekf"].values(), *tuned["smo"].values()])
    assert set(t["table8"]["rmse_rpm"]) == {"shuffled 5-fold CV", "chronological 80/20"}
    _rmse_block(t["table8"]["rmse_rpm"])
    rows9 = t["table9"]["rows"]
    assert list(rows9) == ["(8)", "(16, 8)"]
    assert rows9["(8)"]["params"] == 57 and rows9["(16, 8)"]["params"] == 241  # the paper's counts
    assert rows9["(16, 8)"]["bytes"] == 4 * 241
    _rmse_block({k: v["rmse_rpm"] for k, v in rows9.items()})
    assert list(t["table10"]["rows"]) == list(config.FEATURE_SETS)
    assert t["table10"]["rows"]["without lags"]["features"] == ["v_V", "i_A", "n_M2"]
    _rmse_block({k: v["rmse_rpm"] for k, v in t["table10"]["rows"].items()})
    # the chronological M3 of Table 8 is the one of Table 10's full set
    assert t["table8"]["rmse_rpm"]["chronological 80/20"] == t["table10"]["rows"]["full"]["rmse_rpm"]
    assert set(t["ood"]["runs"]) == {"sweep", "load", "long"}


def test_eq26_holds_on_every_sample(quick):
    _, out, _ = quick
    ood = json.loads((out / "ood.json").read_text())
    for name, run in ood["runs"].items():
        for level in ("clamped", "clamped + fallback", "clamped + fallback + gate"):
            chk = run["eq26"][level]
            assert chk["violations"] == 0 and chk["samples"] > 1000, (name, level, chk)
        for cond, s in run["shares"].items():
            assert 0 <= s["clamped"] <= 1 and 0 <= s["fallback"] <= 1 and 0 <= s["gated"] <= 1
        assert run["rmse_rpm"]["clamped"]["average"] <= run["rmse_rpm"]["unconstrained"]["average"] + 1e-9
    native = json.loads((out / "table7.json").read_text())["checks"]["eq. 26 on the native M3 gated"]
    assert native["violations"] == 0 and native["samples"] > 3000
    # the float64 rules of Tables 8-10 and 4.10 agree with the native replay of the board
    agree = json.loads((out / "table7.json").read_text())["checks"]
    assert agree["M3 gated: largest |float64 rules - native replay| (RPM)"] < 0.01


def test_a_log_without_encoder_is_refused_in_one_line(tmp_path, capsys):
    log = tmp_path / "blind.csv"
    log.write_text("t_s,duty,v_V,i_A\n" + "".join(f"{k * 0.5},0.5,6.0,0.2\n" for k in range(40)))
    code = cli.main(["compare", str(log), str(DEFAULT[0]), "--ra-ohm", "4.5", "--quick", "--quiet",
                     "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith("hpddo compare: ") and "blind.csv" in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_lockstep_training_is_network_train():
    """Networks trained together (network.train_lockstep), of other inputs and widths
    padded into one shape, are the ones network.train gives each on its own rows: same
    initialisation, permutations, batches and Adam steps; the padding stays zero."""
    from hpddo.model import network
    rng = np.random.default_rng(0)
    z1, z2, z3 = rng.normal(size=(1030, 5)), rng.normal(size=(455, 3)), rng.normal(size=(300, 4))
    y1, y2, y3 = np.sin(z1[:, 0]) + z1[:, 1] ** 2, np.cos(z2[:, 2]), z3[:, 0]  # short last batches
    for hiddens in ([(16, 8)] * 3, [(16, 8), (32, 16), (8, 4)], [(8,), (64,), (16,)]):
        cfg = network.AdamConfig(hidden=hiddens[0], max_iter=20, seed=1)
        got = network.train_lockstep([z1, z2, z3], [y1, y2, y3], cfg, hiddens)
        for (z, y), g, h in zip(((z1, y1), (z2, y2), (z3, y3)), got, hiddens):
            ref, _ = network.train(z, y, network.AdamConfig(hidden=h, max_iter=20, seed=1))
            assert [w.shape for w in g.coefs_] == [w.shape for w in ref.coefs_]
            for a, b in zip(ref.coefs_ + ref.intercepts_, g.coefs_ + g.intercepts_):
                np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)


def test_docs_quote_the_committed_figures():
    """docs/compare.md holds the tables `python -m hpddo.studies.compare docs/figures` prints from
    the committed JSON of the run it quotes (figures measured, not typed)."""
    tables = text.markdown(ROOT / "docs" / "figures")
    doc = (ROOT / "docs" / "compare.md").read_text()
    for line in tables.splitlines():
        assert line in doc, line


def test_the_papers_average_stands_only_under_a_table_of_its_conditions():
    """The paper's average is over its three conditions: under a table of two of them it was printed in the
    average column as if it were theirs (a fuzzing helper's load + sweep run). It stands under a table of the
    same conditions, in every rendering (the report's rows, the printed text, the markdown)."""
    from hpddo.reports.compare import paper_value, rmse_rows
    from hpddo.studies.compare.text import _md_rmse, rmse_text

    paper = {"M3": {"load": 3.51, "long": 5.0, "sweep": 4.19, "average": 4.11}}
    two = {"M3": {"load": 1.0, "sweep": 2.0, "average": 1.5}}
    three = {"M3": {"load": 1.0, "long": 3.0, "sweep": 2.0, "average": 2.0}}
    assert paper_value(paper["M3"], "average", ["load", "sweep", "average"]) is None
    assert paper_value(paper["M3"], "average", ["load", "long", "sweep", "average"]) == 4.11
    cols, rows = rmse_rows(two, paper)
    assert rows[1]["values"] == [3.51, 4.19, None]
    assert rmse_rows(three, paper)[1][1]["values"][-1] == 4.11
    assert "4.11" not in rmse_text("t", two, paper) and "4.11" in rmse_text("t", three, paper)
    assert "4.11" not in "\n".join(_md_rmse(two, paper)) and "4.11" in "\n".join(_md_rmse(three, paper))
