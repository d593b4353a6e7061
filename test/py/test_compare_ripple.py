"""Ripple counting as a peer of hpddo compare (issue 23 item 6, docs/ripple-compare.md): alone and
fused with M2, on twin recordings in the ripple mode; the rows it is scored on stated; the
options refused where they cannot apply."""
import json
import math
import pathlib

import numpy as np
import pandas as pd
import pytest

from hpddo import cli
from hpddo.cli import compare, options
from hpddo.logs import dataset
from hpddo.model import identify
from hpddo.bench import HARDWARE
from hpddo.ripple.options import Options
from hpddo.studies.compare import ripple_peer

pytestmark = pytest.mark.slow  # runs the twin and hpddo compare: not in scripts/test.sh --quick

ROOT = pathlib.Path(__file__).resolve().parents[2]
# the twin's motor, the bench's (tools/hpddo/bench.py): 3 segments, two brushes; 25GA371 1:4.4
RIPPLES_PER_REV, GEAR = str(HARDWARE.ripples_per_rev), f"{HARDWARE.gear_ratio:g}"


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """sweep and load (training) and unseen (never seen) on the twin in the ripple mode at 10
    kHz, a quarter of their length (the seeds are the tests' own)."""
    out = tmp_path_factory.mktemp("ripple_bench")
    for prot, seed, sub in (("sweep", 3, "."), ("load", 3, "."), ("unseen", 4, "v")):
        assert cli.main(["twin", "--protocol", prot, "--ripple-hz", "10000", "--time-scale", "0.25", "--seed",
                         str(seed), "--quiet", "--out", str(out / sub)]) == 0
    return out


def truth_rpm(path: pathlib.Path, rec) -> np.ndarray:
    t = pd.read_csv(path.with_suffix(".truth.csv")).set_index("t_s")["rpm_true"]
    return t.reindex(rec.df["t_s"].to_numpy()).to_numpy(float)


def test_alone_and_fused_speeds_per_row(bench):
    recs = dataset.load_recordings([bench / "sweep.csv", bench / "load.csv"])
    ra, _ = identify.ra_from_logs(recs, None)
    m2 = identify.m2_params(recs, ra)
    opts = Options(int(RIPPLES_PER_REV), float(GEAR))
    for rec in recs:
        s = ripple_peer.speeds(rec, opts, ra, m2.ke_vs_per_rad)
        assert s.alone_rpm.shape == (rec.n,) and s.with_m2_prior_rpm.shape == (rec.n,)
        conf = np.isfinite(s.alone_rpm)
        assert conf.sum() > 0.1 * rec.n, rec.name
        # the count where confident is the encoder's speed within 1 % RMS (the twin's encoder
        # counts over the same window as the bursts)
        ref = rec.df["rpm_ref"].to_numpy(float)
        ok = conf & (ref > 10)
        rel = (s.alone_rpm[ok] - ref[ok]) / ref[ok]
        assert math.sqrt(np.mean(rel ** 2)) < 0.01, (rec.name, math.sqrt(np.mean(rel ** 2)))
        # the fusion: the count where it is confident, the physics elsewhere
        m2_rpm = np.linspace(1.0, 2.0, rec.n)
        fused = ripple_peer.estimates(s, m2_rpm)[ripple_peer.FUSED]
        c2 = np.isfinite(s.with_m2_prior_rpm)
        assert np.array_equal(fused[c2], s.with_m2_prior_rpm[c2]) and np.array_equal(fused[~c2], m2_rpm[~c2])
        assert np.isfinite(fused).all()
        # the count's stated uncertainty (the EKF's weight on it) is there exactly where the count
        # is, and describes its error against the true window-mean speed
        sd = s.with_m2_prior_sd_rpm
        assert np.array_equal(np.isfinite(sd), c2) and (sd[c2] > 0).all()
        truth = truth_rpm(bench / f"{rec.name}.csv", rec)
        ok2 = c2 & np.isfinite(truth)
        z = (s.with_m2_prior_rpm[ok2] - truth[ok2]) / sd[ok2]
        assert 0.2 < math.sqrt(np.mean(z ** 2)) < 1.5, (rec.name, math.sqrt(np.mean(z ** 2)))
        # coverage: the share of rows with an encoder reading that have a confident count
        cov = ripple_peer.coverage([rec], [s])
        labelled = np.isfinite(ref)
        assert cov["ripple_coverage"][rec.name] == round((labelled & conf).sum() / labelled.sum(), 4)
        assert f"{100 * cov['ripple_coverage']['all']:.1f} %" in cov["ripple_note"]


def test_compare_scores_the_ripple_beside_the_observers(bench, tmp_path):
    out = tmp_path / "cmp"
    code = cli.main(["compare", str(bench / "sweep.csv"), str(bench / "load.csv"), "--validation",
                     str(bench / "v" / "unseen.csv"), "--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR,
                     "--quick", "--quiet", "--out", str(out)])
    assert code == 0
    t7 = json.loads((out / "table7.json").read_text())
    assert t7["methods"][-4:] == [ripple_peer.ALONE, ripple_peer.FUSED, ripple_peer.EKF, "lookup"]
    assert t7["settings"]["ripple"] == {"ripples_per_rev": 6, "gear_ratio": 4.4, "ke_vs_per_rad": None,
                                        "prior_model": None}
    assert all(v["ke_from"].startswith(("ripple (", "ripple of the motor's other recordings ("))
               for v in t7["ripple_prior"].values())
    for part in ("chronological", "validation", "leave_one_out"):
        block = t7[part]
        rm = block["rmse_rpm"]
        assert ripple_peer.ALONE in rm and ripple_peer.FUSED in rm, part
        assert 0 < block["ripple_coverage"]["all"] <= 1 and block["ripple_note"], part
        for cond, v in rm[ripple_peer.FUSED].items():
            # where the count is confident it is far closer to the encoder than the physics: the
            # fusion is never worse than M2 by more than the count's own error
            assert v <= rm["M2"][cond] + rm[ripple_peer.ALONE][cond] + 1e-9, (part, cond)
        assert ripple_peer.EKF in rm, part
        for cond, v in rm[ripple_peer.EKF].items():
            assert math.isfinite(v), (part, cond)
    # the load run turns at every row above the current floor: a count on every row, under
    # 1 % of its speed; the EKF that takes it as a measurement follows it there
    assert (t7["chronological"]["rmse_rpm"][ripple_peer.EKF]["load"]
            < 0.5 * t7["chronological"]["rmse_rpm"]["EKF"]["load"])
    assert t7["chronological"]["ripple_coverage"]["load"] > 0.95
    assert t7["chronological"]["rmse_rpm"][ripple_peer.ALONE]["load"] < 2.0
    summary = (out / "summary.txt").read_text()
    assert summary.count("a confident count on") == 3
    page = (out / "report" / "index.html").read_text()
    assert "a confident count on" in page and ripple_peer.FUSED in page


def test_the_peer_is_refused_without_its_bursts_or_with_half_its_options(bench, tmp_path, capsys):
    default = [str(ROOT / "data" / "default" / f"{n}.csv") for n in ("sweep", "load")]
    code = cli.main(["compare", *default, "--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR,
                     "--quick", "--quiet", "--out", str(tmp_path / "a")])
    err = capsys.readouterr().err
    assert code == 1 and "sweep.csv: no current bursts beside it (sweep.ripple.csv)" in err and err.count("\n") == 1
    assert not (tmp_path / "a").exists()
    code = cli.main(["compare", str(bench / "sweep.csv"), str(bench / "load.csv"), "--ripples-per-rev", "6",
                     "--quick", "--quiet", "--out", str(tmp_path / "b")])
    err = capsys.readouterr().err
    assert code == 1 and "--ripples-per-rev N and --gear-ratio G" in err and not (tmp_path / "b").exists()
    code = cli.main(["compare", str(bench / "sweep.csv"), str(bench / "load.csv"), "--floor-a", "0.2",
                     "--quick", "--quiet", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert code == 1 and "apply to the ripple peer only" in err and not (tmp_path / "c").exists()


def _on_rows(by_ripple: pd.DataFrame, rec) -> np.ndarray:
    """hpddo ripple's confident counts (its <condition>.ripple_speed.csv) on a recording's
    cleaned rows, by seq; NaN elsewhere."""
    conf = by_ripple[by_ripple["confident"]]
    return pd.Series(conf["rpm_ripple"].to_numpy(float), index=conf["seq"].to_numpy(np.int64)).reindex(
        rec.df["seq"].to_numpy(np.int64)).to_numpy(float)


def test_the_alone_peer_takes_a_models_m2_as_the_prior_as_hpddo_ripple_does(bench, tmp_path, capsys):
    """--prior-model DIR of hpddo compare (the option of train, diagnose and evaluate, cli/options.py)
    is hpddo ripple's --model for the alone row: per row the same confident counts, so the same
    RMSE in Table 7; the fused row keeps the comparison's M2 as its prior; the prior recorded."""
    from hpddo.evaluation import metrics
    from test_ripple import _model_with_brush_drop

    phys = _model_with_brush_drop(tmp_path / "prior")
    logs = {"sweep": bench / "sweep.csv", "load": bench / "load.csv", "unseen": bench / "v" / "unseen.csv"}
    by_ripple = {}
    for name, path in logs.items():
        out = tmp_path / f"ripple_{name}"
        assert cli.main(["ripple", str(path), "--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR,
                         "--model", str(tmp_path / "prior"), "--out", str(out), "--quiet"]) == 0
        by_ripple[name] = pd.read_csv(out / f"{name}.ripple_speed.csv")
    capsys.readouterr()
    out = tmp_path / "cmp"
    assert cli.main(["compare", str(logs["sweep"]), str(logs["load"]), "--validation", str(logs["unseen"]),
                     "--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR, "--prior-model",
                     str(tmp_path / "prior"), "--quick", "--epochs", "5", "--quiet", "--out", str(out)]) == 0
    t7 = json.loads((out / "table7.json").read_text())
    want_model = {"folder": str(tmp_path / "prior"), "effects": ["brush_drop"], "ra_ohm": float(phys.ra_ohm),
                  "ke_vs_per_rad": float(phys.ke_vs_per_rad)}  # JSON gives a float back as it was
    assert t7["settings"]["ripple"] == {"ripples_per_rev": 6, "gear_ratio": 4.4, "ke_vs_per_rad": None,
                                        "prior_model": want_model}
    assert f"--prior-model {tmp_path / 'prior'}" in t7["command"]
    for name in logs:
        assert t7["ripple_prior"][name] == {"ke_prior_vs_per_rad": pytest.approx(phys.ke_vs_per_rad),
                                            "ke_from": f"model {tmp_path / 'prior'} (M2 with brush_drop)"}, name

    recs = dataset.load_recordings([logs["sweep"], logs["load"]])
    vrecs = dataset.load_recordings([logs["unseen"]], 0.0)
    ra, _ = identify.ra_from_logs(recs, None)
    m2 = identify.m2_params(recs, ra)
    opts = Options(int(RIPPLES_PER_REV), float(GEAR))
    prior = options.prior_model_of(compare.parser().parse_args(
        [str(logs["sweep"]), "--out", str(out), "--prior-model", str(tmp_path / "prior")]))
    for part, rs in (("chronological", recs), ("validation", vrecs)):
        for rec in rs:
            theirs = _on_rows(by_ripple[rec.name], rec)
            s = ripple_peer.speeds(rec, opts, ra, m2.ke_vs_per_rad, prior_model=prior)
            plain = ripple_peer.speeds(rec, opts, ra, m2.ke_vs_per_rad)
            assert s.alone_ke_from == t7["ripple_prior"][rec.name]["ke_from"]
            assert plain.alone_ke_from.startswith("ripple (")
            # the fused row's prior stays the comparison's M2: the same count as without --prior-model
            assert np.array_equal(s.with_m2_prior_rpm, plain.with_m2_prior_rpm, equal_nan=True), rec.name
            # the alone count is hpddo ripple --model's, row by row (its CSV keeps 6 digits)
            assert np.array_equal(np.isfinite(s.alone_rpm), np.isfinite(theirs)), rec.name
            assert np.allclose(s.alone_rpm, theirs, rtol=1e-5, equal_nan=True), rec.name
            assert np.isfinite(theirs).sum() > 0.3 * rec.n, rec.name
            # and Table 7's alone row is its RMSE over the rows scored: to the table's 6 digits with
            # the counts at full precision, and within the CSV's rounding (1e-3 RPM a row) with its
            ref = rec.df["rpm_ref"].to_numpy(float)
            mask = np.arange(rec.n) >= rec.n_train
            got = t7[part]["rmse_rpm"][ripple_peer.ALONE][rec.name]
            assert got == metrics.figure(metrics.rmse((s.alone_rpm - ref)[mask])), (part, rec.name)
            assert got == pytest.approx(metrics.rmse((theirs - ref)[mask]), abs=1e-3), (part, rec.name)


def test_the_prior_model_is_refused_in_one_line_before_any_work(bench, tmp_path, capsys):
    from test_ripple import _model_with_brush_drop, _refused

    _model_with_brush_drop(tmp_path / "good")
    (tmp_path / "empty").mkdir()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "model_x.h").write_text("// not a model\nstatic const uint32_t kChecksum = 0x12345678u;\n")

    def err(*extra, status=1, ripple=True):
        argv = ["compare", str(bench / "sweep.csv"), str(bench / "load.csv"), "--quick", "--quiet", "--out",
                str(tmp_path / "out"), *(["--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR] if ripple
                                         else []), *extra]
        line = _refused(argv, status, capsys)
        assert not (tmp_path / "out").exists(), "no output"
        return line

    assert f"{tmp_path / 'nowhere'}: no such model folder" in err("--prior-model", str(tmp_path / "nowhere"))
    assert "expected one model header" in err("--prior-model", str(tmp_path / "empty"))
    assert "model_x.h: not a model header of hpddo train" in err("--prior-model", str(bad))
    assert "expected one model header model_other.h" in err("--prior-model", str(tmp_path / "good"),
                                                            "--prior-name", "other")
    assert "not allowed with argument" in err("--prior-model", str(tmp_path / "good"), "--ke-vs-per-rad", "0.4",
                                              status=2)
    assert "--prior-name applies to --prior-model only" in err("--prior-name", "brush")
    assert "--prior-model apply to the ripple peer only" in err("--prior-model", str(tmp_path / "good"),
                                                                ripple=False)
    # the folder is read before any log: a missing log is not what is refused
    line = _refused(["compare", str(tmp_path / "no.csv"), str(tmp_path / "nor.csv"), "--out", str(tmp_path / "out"),
                     "--ripples-per-rev", RIPPLES_PER_REV, "--gear-ratio", GEAR, "--prior-model", str(bad)], 1, capsys)
    assert "model_x.h: not a model header of hpddo train" in line and not (tmp_path / "out").exists()
