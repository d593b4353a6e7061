"""Issue 23: the twin's ripple mode (off by default, the same bytes) and the host's speed from
the commutation ripple, each twin recording with the statement the estimator must make
(docs/ripple-counting.md). The figures themselves come from `python -m hpddo.studies.ripple`
(docs/ripple-accuracy.md)."""
import dataclasses
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from hpddo.logs import ripple as rf
from hpddo.logs.errors import USER_ERRORS
from hpddo.ripple.calibrate import KE_DOUBT_MAX, calibrate_ke
from hpddo.ripple.count import _current_spread
from hpddo.ripple.encoder import check_ratio, span_reference
from hpddo.ripple.log import speed_of_bench, speed_of_log
from hpddo.ripple.options import Options
from hpddo.ripple.prior import m2_prior_rpm, m2_prior_sd_rpm, rpm_per_amp
from hpddo.ripple.spans import steady_spans
from hpddo.ripple.stall import STANDING_CONFIDENCE, standing
from hpddo.studies import ripple as study
from hpddo.twin import generate, params

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENARIOS = {s.name: s for s in study.SCENARIOS}



def _refused(argv, status, capsys) -> str:
    """Runs the command line, which must end with status (2: argparse's usage error, a
    SystemExit), and returns the last line it wrote to stderr."""
    from hpddo import cli
    if status == 2:
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        assert exc.value.code == 2
    else:
        assert cli.main(argv) == status
    return capsys.readouterr().err.strip().splitlines()[-1]

def _scenario(name, **changes):
    return study.run_scenario(dataclasses.replace(SCENARIOS[name], **changes))


def test_ripple_mode_is_off_by_default_and_leaves_the_bundled_bytes(tmp_path):
    g = generate.generate(params.preset("default"), "sweep", 2.0, 1, out_dir=tmp_path, preset_name="default")
    assert g["bursts"] is None and "ripple" not in g["paths"] and "ripple" not in g["info"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv", "sweep.truth.csv", "sweep.truth.json"]
    for name in ("sweep.csv", "sweep.truth.csv", "sweep.truth.json"):
        assert (tmp_path / name).read_bytes() == (ROOT / "data" / "default" / name).read_bytes(), name


def test_burst_file_is_written_read_back_and_deterministic(tmp_path):
    rparams = params.ripple_burst(sample_hz=8000.0)
    a = generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path / "a", time_scale=0.05,
                          ripple=rparams)
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path / "b", time_scale=0.05,
                      ripple=rparams)
    pa, pb = tmp_path / "a" / "load.ripple.csv", tmp_path / "b" / "load.ripple.csv"
    assert pa.read_bytes() == pb.read_bytes()
    b = rf.read(pa)
    assert b.sample_hz == 8000.0 and len(b) == len(a["log"])
    assert all(len(c) == 4000 for c in b.codes)  # one sample per PWM period over each 0.5 s window
    assert np.array_equal(b.seq, a["log"]["seq"].to_numpy())
    assert a["info"]["ripple"]["sample_hz"] == 8000.0
    assert a["info"]["bench"]["pwm_hz"] == 8000.0  # the PWM runs at the sample rate in the ripple mode
    i_mean = np.array([b.current_A(k).mean() for k in range(len(b))])
    clean = np.ones(len(b), bool)
    clean[[gl["row"] for gl in a["info"]["glitches"]]] = False  # the log's glitches are not in the bursts
    assert np.all(np.abs(i_mean - a["log"]["i_A"].to_numpy())[clean] < 0.01)  # the bursts carry the log's current


def test_a_bad_burst_file_is_a_user_error_with_its_line(tmp_path):
    p = tmp_path / "x.ripple.csv"
    p.write_text("# format=hpddo-ripple 1\n# sample_hz=10000\n# a_per_code=0.01\nseq,t_s,n,codes\n0,0.0,3,1 2\n")
    with pytest.raises(USER_ERRORS) as exc:
        rf.read(p)
    assert ":5:" in str(exc.value)


def test_a_burst_file_reads_as_a_bench_logs_grammar_does(tmp_path):
    """A byte-order mark before its first line is read past, as in a bench log (it was refused: "missing metadata
    format"); a key given twice is refused with its line, as in a bench log (the last value won)."""
    text = "# format=hpddo-ripple 1\n# sample_hz=10000\n# a_per_code=0.01\nseq,t_s,n,codes\n0,0.0,3,1 2 3\n"
    p = tmp_path / "x.ripple.csv"
    p.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert rf.read(p).sample_hz == 10000.0
    p.write_text(text.replace("# a_per_code=0.01\n", "# a_per_code=0.01\n# sample_hz=20000\n"))
    with pytest.raises(USER_ERRORS) as exc:
        rf.read(p)
    assert ":4: metadata sample_hz given again (first on line 2)" in str(exc.value)
    p.write_text(text + "0,0.5,3,1 2 3\n")  # two bursts of one log row (seq 0): every burst at seq 0 was taken,
    with pytest.raises(USER_ERRORS) as exc:  # and the gear ratio said to be another than the nameplate's
        rf.read(p)
    assert ":6: seq 0 given again (first on line 5)" in str(exc.value)


def test_twin_cli_ripple_hz_writes_the_bursts(tmp_path):
    out = tmp_path / "r"
    subprocess.run([sys.executable, "-m", "hpddo", "twin", "--protocol", "sweep", "--time-scale", "0.02",
                    "--ripple-hz", "10000", "--out", str(out), "--quiet"], check=True,
                   env={"PYTHONPATH": str(ROOT / "tools"), "PATH": "/usr/bin:/bin"})
    assert rf.read(out / "sweep.ripple.csv").sample_hz == 10000.0


@pytest.mark.slow
def test_default_bench_confident_speeds_within_one_percent_and_coasting_said():
    r = _scenario("default", protocols=("sweep", "load"), time_scale=0.3)
    assert r["rms_vs_truth_pct"] < 1.0 and r["max_vs_truth_pct"] < 5.0
    assert r["rms_vs_encoder_pct"] < 1.0 and r["max_vs_encoder_pct"] < 5.0  # a span against the encoder over it
    assert r["confident_in_spans"] > 0  # the study counts as hpddo ripple does: the slow rows over spans
    assert r["max_vs_encoder_own_window_pct"] > 5.0  # one 5 RPM window's encoder reading steps by 12 %
    assert r["confident_share_above_both_floors"] >= 0.9
    assert r["reasons"]["coasting"] > 0  # duty 0 rows: the drive off, said so
    assert "agrees with the data" in r["ratio_check"]["statement"]


@pytest.mark.slow
def test_subharmonics_overtaking_the_main_line_with_the_prior():
    """The f/2 line (3 x the rotation) outgrows the commutation line: where a window's lines form the rotation
    comb, the data show 3 ripples per revolution, not the 6 given, and the window says so, never confident
    (docs/ripple-line.md, "Limits"); no confident window is more than 5 % off."""
    r = _scenario("subharmonics", time_scale=0.3)
    assert r["reasons"].get("multiple", 0) > 0
    assert r["confident"] == 0 or r["max_vs_truth_pct"] < 5.0


@pytest.mark.slow
def test_subharmonics_without_a_prior_is_said_ambiguous_not_guessed():
    r = _scenario("subharmonics_no_prior", time_scale=0.3)
    assert r["reasons"].get("ambiguous", 0) > 0
    assert r["confident"] == 0 or r["max_vs_truth_pct"] < 5.0


@pytest.mark.slow
def test_low_current_is_said_under_the_floor():
    r = _scenario("low_current", time_scale=0.3)
    assert r["confident"] == 0
    assert r["reasons"]["floor"] == r["windows"] - r["reasons"]["coasting"]


@pytest.mark.slow
def test_interference_line_is_not_taken_for_the_ripple():
    r = _scenario("interference", time_scale=0.3)
    assert r["confident_share_above_floor"] >= 0.9 and r["max_vs_truth_pct"] < 5.0


@pytest.mark.slow
def test_wrong_gear_ratio_is_said_with_the_measured_one():
    r = _scenario("wrong_gear", time_scale=0.3)
    chk = r["ratio_check"]
    assert "not the nameplate's 4.4:1" in chk["statement"]
    assert abs(chk["gear_ratio_measured"] / study.WRONG_GEAR - 1) < 0.0005  # 98.777:1 told from 99:1


# each twin protocol, short enough for seconds, at the seed and length where a confident count was
# once far off (the estimator of 53c462f: unseen x0.4 seed 2 and load x0.25 seed 2 about 100 % off):
# unseen at duty 0.3 under load (22-24 RPM at 0.39 A, the prior off by 65 %, the count on the main
# line's second harmonic), load at a step beside a current glitch (the median of three priors took
# the speed before the step), a stiff gearbox whose shaft stands at duty 0.2 (a fixed 50 Hz line
# counted as 113 RPM under a too weak prior, in a first fix)
FIVE_PERCENT_CASES = {
    "sweep": dict(protocols=("sweep",), time_scale=0.25, seed=4),
    "load": dict(protocols=("load",), time_scale=0.25, seed=2),
    "unseen": dict(protocols=("unseen",), time_scale=0.4, seed=2),
    "hot": dict(protocols=("hot",), time_scale=0.1, seed=1),
    "stiff_gearbox_sweep": dict(protocols=("sweep",), time_scale=0.25, bench={"tc_gen_nm": 0.12}),
}


@pytest.mark.parametrize("case", sorted(FIVE_PERCENT_CASES))
def test_no_confident_estimate_more_than_five_percent_off_on_each_protocol(case):
    r = _scenario("default", **FIVE_PERCENT_CASES[case])
    assert r["confident_share_above_floor"] >= 0.5  # not passed by saying nothing
    worst = max(r["max_vs_encoder_pct"], r["max_vs_truth_pct"])
    assert worst < 5.0, (f"{case}: a confident count {r['max_vs_encoder_pct']:.2f} % off the encoder, "
                         f"{r['max_vs_truth_pct']:.2f} % off the truth")
    assert r["confident_at_standstill"] == 0, f"{case}: {r['confident_at_standstill']} confident where the shaft stands"


def test_the_prior_is_weak_at_low_speed_and_high_current_and_strong_at_high_speed():
    opts = Options(6, 4.4)
    ke = 0.39
    v, i = np.array([3.4, 9.4]), np.array([0.39, 0.5])  # duty 0.3 under load, duty 0.8 free
    sd = m2_prior_sd_rpm(v, i, 4.5, ke, opts)
    rel = sd / m2_prior_rpm(v, i, 4.5, ke)[:, None]
    assert np.all(sd[:, 0] > sd[:, 1])  # a brush drop only puts the speed below the prior
    assert rel[0, 0] > 0.3 and rel[1, 0] < 0.15  # over a third of the prior at duty 0.3 loaded, a tenth at 0.8 free


def test_the_current_shows_a_speed_change_that_the_fixed_band_cannot():
    """_current_spread: the ripple family fitted out, a steady window's quarters agree to well
    under the 3 % of a steady count; a current step in the first 30 ms (a fast transient whose
    line lay outside the band) is seen."""
    fs, n, f = 10000.0, 5000, 15.0  # 34 RPM at 26.4 ripples per output revolution
    t = np.arange(n) / fs
    ripple = (0.05 * np.sin(2 * np.pi * f * t) + 0.015 * np.sin(2 * np.pi * 2 * f * t)
              + 0.03 * np.sin(2 * np.pi * f / 2 * t) + 0.03 * np.sin(2 * np.pi * f / 6 * t))
    noise = np.random.default_rng(1).normal(0.0, 0.01, n)
    per_a = rpm_per_amp(4.5, 0.38)
    steady = 0.55 + ripple + noise
    assert _current_spread(steady, fs, f, 34.0, per_a) < 0.01
    step = steady - 0.3 * (t < 0.03)  # the current low while the shaft still turns fast
    assert _current_spread(step, fs, f, 34.0, per_a) > 0.03


def test_ratio_check_names_the_ripples_per_revolution_when_off_by_a_family_factor():
    import pandas as pd

    df = pd.DataFrame({"confident": [True] * 4, "f_Hz": [2 * 26.4 * 100 / 60.0] * 4})  # twice 6 x 4.4 per rev
    chk = check_ratio(df, np.full(4, 100.0), 0.5, Options(6, 4.4))
    assert "ripples per motor revolution" in chk["statement"]


def test_ratio_check_weighs_the_encoders_resolution():
    """A slow run's few encoder counts are not a wrong gear: 118 windows at 4-6 RPM with a 0.62 RPM
    encoder step (the twin's: 193.6 counts per output revolution over 0.5 s) agree with the
    nameplate whatever their quantisation does to the ratio; a 1 % gear error over fast windows
    with the same encoder is named."""
    import pandas as pd

    step = 60.0 / (193.6 * 0.5)
    rng = np.random.default_rng(7)
    for n, lo, hi, gear_error, agrees in ((118, 4.0, 6.0, 0.0, True), (200, 90.0, 110.0, 0.01, False)):
        true = rng.uniform(lo, hi, n)
        reading = np.round(true / step) * step  # whole counts per window
        df = pd.DataFrame({"confident": [True] * n, "f_Hz": true * 6 * 4.4 * (1 + gear_error) / 60.0})
        chk = check_ratio(df, reading, 0.5, Options(6, 4.4))
        assert abs(chk["encoder_step_rpm"] - step) < 1e-6  # read from the readings
        assert ("agrees with the data" in chk["statement"]) == agrees, chk["statement"]
        if agrees:
            assert "the encoder's resolution" in chk["statement"] and chk["tolerance"] > 0.001
        else:
            assert "not the nameplate's 4.4:1" in chk["statement"]
    # the header's step, where given, is the one used
    chk = check_ratio(df, reading, 0.5, Options(6, 4.4), encoder_step_rpm=0.05)
    assert chk["encoder_step_rpm"] == 0.05


def test_hpddo_ripple_on_twin_logs_scores_and_checks_the_ratio(tmp_path, capsys):
    from hpddo import cli

    logs = tmp_path / "logs"
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=logs, time_scale=0.3,
                      ripple=params.ripple_burst())
    out = tmp_path / "out"
    # the sidecars given with the log (as a shell glob gives them) are left out with a note
    argv = [str(p) for p in sorted(logs.glob("*.csv"))] + ["--ripples-per-rev", "6", "--gear-ratio", "4.4",
                                                          "--out", str(out), "--quiet"]
    assert cli.main(["ripple"] + argv) == 0
    printed = capsys.readouterr()
    assert "left out" in printed.err and "the current bursts beside its log" in printed.err
    assert "the gear ratio 4.4:1 agrees with the data" in printed.out
    import json
    s = json.loads((out / "summary.json").read_text())["load"]
    assert s["rms_vs_encoder_pct"] < 1.0 and s["max_vs_encoder_pct"] < 5.0  # the log's encoder glitch left out
    assert (out / "load.ripple_speed.csv").read_text().startswith("seq,t_s,rpm_ripple,confidence,confident,reason")


def test_hpddo_ripple_refuses_two_logs_of_one_condition(tmp_path, capsys):
    """Two logs of one condition would write one OUT/<condition>.ripple_speed.csv and one summary entry: one
    count was lost without a word (a fuzzing helper's copies of a twin log). Refused before any output, as train
    and diagnose refuse them."""
    from hpddo import cli

    for d in ("a", "b"):
        generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path / d, time_scale=0.05,
                          ripple=params.ripple_burst())
    status = cli.main(["ripple", str(tmp_path / "a" / "load.csv"), str(tmp_path / "b" / "load.csv"),
                       "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--out", str(tmp_path / "o")])
    assert status == 1 and "are both condition 'load'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_hpddo_ripple_without_bursts_is_a_user_error(tmp_path, capsys):
    from hpddo import cli

    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path, time_scale=0.05)
    status = cli.main(["ripple", str(tmp_path / "load.csv"), "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                       "--out", str(tmp_path / "o")])
    assert status == 1 and "no current bursts beside it" in capsys.readouterr().err


@pytest.mark.slow
def test_spinup_windows_are_not_confident_and_the_count_beats_one_fft_peak():
    r = _scenario("spinup")
    assert r["reasons"]["changing"] > 0  # the speed changing inside a window is said
    assert r["max_vs_truth_pct"] < 5.0
    assert r["changing_count_median_abs_err_pct"] < r["changing_fft_median_abs_err_pct"]
    assert r["spinup_fft_mean_err_pct"] > 3.0  # one FFT peak reads the speed the shaft reaches: high


def _line_power(x, fs, f):
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x)))) ** 2
    freqs = np.fft.rfftfreq(len(x), 1 / fs)
    sel = np.abs(freqs - f) <= 2 * fs / len(x)
    return spec[sel].max()


def test_burst_lines_sit_where_the_shaft_puts_them():
    """The main line at N G n / 60, the f/2 family line overtaking it when the asymmetry is large."""
    bench = params.preset("default")
    for sub2, main_wins in ((1.0, True), (12.0, False)):
        g = generate.generate(bench, "sweep", 2.0, 1, time_scale=0.2, ripple=params.ripple_burst(sub2_pct=sub2))
        t0, codes, meta = g["bursts"]
        k = int(np.flatnonzero(g["log"]["duty"].to_numpy() == 1.0)[-1])  # a steady window at full duty
        x = codes[k] * float(meta["a_per_code"])
        f = bench.ripples_per_rev * bench.gear_ratio * g["truth"]["rpm_true"][k] / 60.0
        fs = float(meta["sample_hz"])
        spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x)))) ** 2
        top = np.fft.rfftfreq(len(x), 1 / fs)[int(np.argmax(spec))]
        assert (abs(top / f - 1) < 0.01) == main_wins, (sub2, top, f)
        assert (_line_power(x, fs, f) > _line_power(x, fs, f / 2)) == main_wins


# --- item 4: the ripple as the reference of train, diagnose and evaluate (hpddo.ripple.reference)

def _twin_logs(out, protocols=("sweep", "load"), time_scale=0.2, seed=1):
    for prot in protocols:
        generate.generate(params.preset("default"), prot, 2.0, seed, out_dir=out, time_scale=time_scale,
                          ripple=params.ripple_burst())
    return [out / f"{p}.csv" for p in protocols]


@pytest.mark.slow
def test_reference_swap_puts_the_confident_ripple_speed_in_rpm_ref_and_counts_the_rest(tmp_path):
    from hpddo.logs import benchlog, dataset
    from hpddo.ripple import reference

    (path,) = _twin_logs(tmp_path, ("sweep",))
    log = benchlog.read_log(path)
    ref = reference.Ripple(6, 4.4)
    df, meta, weight, rec = ref(path, log.df, {**log.meta, "encoder_counts_per_rev": "48.4"})
    assert "encoder_counts_per_rev" not in meta and meta["ra_ohm"] == log.meta["ra_ohm"]  # rpm_ref is no encoder
    est, _, _ = speed_of_log(path, log.df, log.meta, ref.options())
    conf = est["confident"].to_numpy()
    rows = est["row"].to_numpy()
    got = df["rpm_ref"].to_numpy()
    still = standing(est, log.df["duty"].to_numpy()[rows], log.df["v_V"].to_numpy()[rows], ref.options())
    assert np.array_equal(got[rows[conf]], est["rpm"].to_numpy()[conf])  # the ripple speed where confident
    assert (got[rows[still]] == 0).all() and (weight[rows[still]] == STANDING_CONFIDENCE).all()  # standing: 0
    assert np.isnan(got[rows[~conf & ~still]]).all()                     # and NaN elsewhere
    assert np.array_equal(weight[rows[conf]], est["confidence"].to_numpy()[conf])
    assert (weight[rows[~conf & ~still]] == 0).all()
    enc = log.df["rpm_ref"].to_numpy()
    assert np.nanmax(np.abs(got - enc)) > 0  # the encoder's column is set aside, not kept
    # the counts: every row kept or left out by its reason; the sweep's duty-0 rows are coasting, and
    # the shaft stands in every one of them (the twin's truth under 0.14 RPM there): labelled 0 RPM
    assert rec["kept"] == int(conf.sum() + still.sum()) and rec["kept"] + rec["left_out"] == len(log.df)
    assert sum(rec["left_out_by_reason"].values()) == rec["left_out"]
    assert rec["standing_labelled"] == int(still.sum()) == int((log.df["duty"] == 0).sum()) > 0
    assert "coasting" not in rec["left_out_by_reason"]
    assert rec["encoder_set_aside"] and rec["ke_from"].startswith("ripple")
    # through the loader: the glitch filter after the swap, the weight following the rows it keeps
    r = dataset.load_recording(path, reference=ref)
    assert r.reference == rec and len(r.weight) == r.n
    assert r.n == len(log.df) - len(r.removed)
    kept = np.isfinite(r.df["rpm_ref"].to_numpy())
    assert (r.weight[kept] > 0).all() and (r.weight[~kept] == 0).all()
    pooled = reference.pooled({r.name: r.reference})
    assert pooled["left_out"] == rec["left_out"] and pooled["weights"] == reference.WEIGHTS_NOTE


@pytest.mark.slow
def test_the_reference_counts_a_runs_logs_as_one_motors_so_a_combless_log_keeps_its_labels(tmp_path):
    """--reference ripple reads the ripple of a run's logs as hpddo ripple does (speed_of_bench): the twin's long
    recording (one duty under one load, no window with a rotation comb) is `unchecked` read alone, Ke calibrated
    from the ripple; read beside a load run whose combs confirm the figure, its rows are labelled, and right."""
    from hpddo.logs import dataset
    from hpddo.ripple import reference

    load, = _twin_logs(tmp_path, ("load",), time_scale=0.1)
    long, = _twin_logs(tmp_path, ("long",), time_scale=0.02)
    ref = reference.Ripple(6, 4.4)
    (alone,) = dataset.load_recordings([long], reference=ref)
    assert alone.reference["kept"] <= alone.reference["standing_labelled"]
    assert alone.reference["left_out_by_reason"].get("unchecked", 0) > 0.9 * alone.reference["rows"]
    _, beside = dataset.load_recordings([load, long], reference=ref)
    assert beside.reference["kept"] > 0.9 * beside.reference["rows"], beside.reference["left_out_by_reason"]
    assert "other recordings" in beside.reference["ke_from"]
    truth = np.genfromtxt(tmp_path / "long.truth.csv", delimiter=",", names=True)["rpm_true"]
    label = beside.df["rpm_ref"].to_numpy()
    true = truth[beside.df["seq"].to_numpy()]
    counted = np.isfinite(label) & (label > 0)  # (a standing row's label is 0 RPM)
    assert counted.sum() > 0.9 * beside.reference["rows"]
    assert (np.abs(label[counted] / true[counted] - 1) < 0.05).all()


def test_the_loader_parses_each_log_once_with_the_ripple_as_reference(tmp_path, monkeypatch):
    """load_recordings with the ripple as the reference reads each file once (the count over the run's logs and
    the recordings are made from the same parse), and gives what counting and loading one after the other
    give: the same rows, labels, weights and records."""
    from hpddo.logs import benchlog, dataset
    from hpddo.ripple import reference

    paths = _twin_logs(tmp_path, ("load", "sweep"), time_scale=0.05)
    ref = reference.Ripple(6, 4.4)
    apart = [dataset.load_recording(p, reference=ref.over(paths)) for p in paths]
    reads = []
    real = benchlog.read_log
    monkeypatch.setattr(benchlog, "read_log", lambda p: reads.append(p) or real(p))
    got = dataset.load_recordings(paths, reference=ref)
    assert sorted(map(str, reads)) == sorted(map(str, paths))
    for a, b in zip(apart, got):
        assert a.df.equals(b.df) and a.reference == b.reference and np.array_equal(a.weight, b.weight)


def test_reference_options_are_checked_before_any_work(tmp_path, capsys):
    from hpddo import cli

    log = str(tmp_path / "x.csv")
    for sub, argv, said in (
            ("train", [log, "--out", str(tmp_path / "t"), "--reference", "ripple"], "needs --ripples-per-rev"),
            ("diagnose", [log, "--out", str(tmp_path / "d"), "--gear-ratio", "4.4"], "applies to --reference ripple"),
            ("evaluate", ["--model", str(tmp_path), log, "--out", str(tmp_path / "e"), "--reference", "ripple",
                          "--gear-ratio", "4.4"], "needs --ripples-per-rev")):
        assert cli.main([sub] + argv) == 1, sub
        assert said in capsys.readouterr().err, sub


def test_reference_ripple_without_bursts_is_a_user_error(tmp_path, capsys):
    from hpddo import cli

    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path, time_scale=0.05)
    status = cli.main(["train", str(tmp_path / "load.csv"), "--out", str(tmp_path / "m"), "--reference", "ripple",
                       "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--quiet"])
    assert status == 1 and "no current bursts beside it" in capsys.readouterr().err
    assert not (tmp_path / "m").exists()


@pytest.mark.slow
def test_train_from_the_ripple_alone_scores_against_the_encoder_like_a_model_from_the_encoder(tmp_path, capsys):
    """M2 and M3 trained with --reference ripple, evaluated against the encoder on a recording
    neither saw: within 10 % of the same models trained from the encoder (the issue's target;
    the figures on the full benches are in docs/ripple-training.md, "Figures")."""
    import json

    from hpddo import cli

    logs = _twin_logs(tmp_path / "bench", time_scale=0.3)
    (new,) = _twin_logs(tmp_path / "new", ("load",), time_scale=0.3, seed=2)
    rip = ["--reference", "ripple", "--ripples-per-rev", "6", "--gear-ratio", "4.4"]
    rmse = {}
    for which, extra in (("encoder", []), ("ripple", rip)):
        m = tmp_path / f"m_{which}"
        assert cli.main(["train", *map(str, logs), "--out", str(m), "--epochs", "300", "--quiet", *extra]) == 0
        metrics = json.loads((m / "metrics.json").read_text())
        ev = tmp_path / f"e_{which}"
        assert cli.main(["evaluate", "--model", str(m), str(new), "--out", str(ev), "--quiet"]) == 0
        rmse[which] = json.loads((ev / "metrics.json").read_text())["rmse_rpm"]
        if which == "ripple":
            r = metrics["reference"]
            assert r["reference"] == "ripple" and r["kept"] + r["left_out"] == r["rows"]
            assert r["standing_labelled"] > 0 and set(r["recordings"]) == {"sweep", "load"}
            assert "reference" not in json.loads((ev / "metrics.json").read_text())  # scored against the encoder
        else:
            assert "reference" not in metrics
    printed = capsys.readouterr().out
    assert "reference ripple" in printed and "rows kept" in printed and "left out (" in printed
    for model in ("M2", "M3"):
        enc, rip_ = rmse["encoder"][model]["average"], rmse["ripple"][model]["average"]
        assert rip_ <= 1.10 * enc, (model, rip_, enc)


def _span_run(tmp_path, protocol, time_scale, seed=1, **bench_changes):
    """A twin recording in the ripple mode and its ripple speed through speed_of_log (the counts over
    spans of steady windows included), the prior's Ke given (the sweep's calibrated figure), with the truth."""
    import pandas as pd

    bench = dataclasses.replace(params.preset("default"), **bench_changes)
    g = generate.generate(bench, protocol, 2.0, seed, out_dir=tmp_path, time_scale=time_scale,
                          ripple=params.ripple_burst(), preset_name="default")
    path = tmp_path / f"{protocol}.csv"
    df = pd.read_csv(path, comment="#")
    est, _, _ = speed_of_log(path, df, {"ra_ohm": "4.50"}, Options(6, 4.4), ke_vs_per_rad=0.3757)
    rows = est["row"].to_numpy()
    return est, df.iloc[rows].reset_index(drop=True), g["truth"]["rpm_true"].to_numpy()[rows]


@pytest.mark.slow
def test_counts_over_steady_windows_give_the_slow_rows_within_one_percent_of_the_encoder(tmp_path):
    est, log, true = _span_run(tmp_path, "sweep", 0.5)
    slow = log["duty"].to_numpy() == 0.2
    span = est["span"].to_numpy()
    conf = est["confident"].to_numpy()
    assert slow.sum() >= 50 and (conf & slow).sum() >= 0.8 * slow.sum()  # 4-6 RPM: a window alone holds ~1 cycle
    assert np.all(span[conf & slow] > 1)
    # the encoder's 0.62 RPM steps are 12 % at 5 RPM in one window: compare the span's count with the
    # encoder's counts summed over the same span
    starts = np.flatnonzero(conf & slow & (np.r_[True, np.diff(est["rpm"].to_numpy()) != 0]))
    assert len(starts) >= 2
    for a in starts:
        e = a + span[a]
        enc = log["rpm_ref"].to_numpy()[a:e].mean()
        assert abs(est["rpm"].to_numpy()[a] / enc - 1) < 0.01, (a, est["rpm"].to_numpy()[a], enc)
        assert abs(est["rpm"].to_numpy()[a] / true[a:e].mean() - 1) < 0.01
    err = np.abs(est["rpm"].to_numpy()[conf] / true[conf] - 1)
    assert err.max() < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("protocol,time_scale,changes", [("unseen", 0.5, {}), ("sweep", 0.5, {"tc_gen_nm": 0.12}),
                                                         ("sweep", 0.5, {"j_kgm2": 3.0e-3})])
def test_counts_over_steady_windows_no_confident_count_five_percent_off(tmp_path, protocol, time_scale, changes):
    est, _, true = _span_run(tmp_path, protocol, time_scale, **changes)
    conf = est["confident"].to_numpy()
    assert conf.sum() > 0.5 * len(est)
    assert not np.any(conf & (true <= 0)), "a confident count where the shaft stands"
    moving = conf & (true > 0)
    worst = float(np.max(np.abs(est["rpm"].to_numpy()[moving] / true[moving] - 1)))
    assert worst < 0.05, f"{protocol} {changes}: a confident count {worst:.2%} off the truth"


def test_steady_spans_stay_within_one_duty_and_leave_the_first_window_after_a_change():
    fs, n = 1000.0, 500
    keys = ["few_cycles"] * 12
    keys[5] = "changing"
    duty = np.array([0.2] * 8 + [0.3] * 4)
    b = rf.Bursts({}, fs, 0.01, np.arange(12), np.arange(12) * n / fs, [np.zeros(n, int)] * 12)
    spans = steady_spans(b, duty, keys, Options(6, 4.4))
    assert spans == [(1, 5), (6, 8), (9, 12)]  # not row 0 or 8 (a duty change), not across the changing row 5
    assert steady_spans(b, duty, keys, Options(6, 4.4, span_max_s=1.0)) == [(1, 3), (3, 5), (6, 8), (9, 12)]
    assert steady_spans(b, duty, keys, Options(6, 4.4, span_max_s=0.0)) == []
    gap = rf.Bursts({}, fs, 0.01, np.arange(12), np.arange(12) * 2 * n / fs, [np.zeros(n, int)] * 12)
    assert steady_spans(gap, duty, keys, Options(6, 4.4)) == []  # bursts not contiguous: no span


def _model_with_brush_drop(folder):
    """The bundled default model with a brush drop of 0.3 V among its named effects, written as hpddo
    train writes a model folder (export.model_header)."""
    from hpddo import schema
    from hpddo.model import export
    model = export.read_model_header((ROOT / "models" / "default" / "model_default.h").read_text())
    bit, field = schema.EFFECT_BITS["brush_drop"]
    phys = dataclasses.replace(model.physics, **{field: 0.3}, effects=model.physics.effects | bit)
    folder.mkdir()
    (folder / "model_brush.h").write_text(export.model_header(dataclasses.replace(model, physics=phys), "brush",
                                                              {"command": "test_ripple", "data": "hand-made"}))
    return phys


def test_hpddo_ripple_takes_a_trained_models_m2_with_its_effects_as_the_prior(tmp_path, capsys):
    import json

    import pandas as pd

    from hpddo import cli
    from hpddo.model import physics as ph

    logs = tmp_path / "logs"
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=logs, time_scale=0.3,
                      ripple=params.ripple_burst())
    phys = _model_with_brush_drop(tmp_path / "model")
    out = tmp_path / "out"
    assert cli.main(["ripple", str(logs / "load.csv"), "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                     "--model", str(tmp_path / "model"), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "from model" in printed and "(M2 with brush_drop)" in printed
    s = json.loads((out / "summary.json").read_text())["load"]
    assert s["prior_model"]["effects"] == ["brush_drop"] and s["ke_prior_vs_per_rad"] == pytest.approx(0.415295, 1e-5)
    assert s["rms_vs_encoder_pct"] < 1.0 and s["max_vs_encoder_pct"] < 5.0
    assert s["confident"] >= 0.9 * s["above_floor"]
    # the prior is the model's M2 with its brush drop: (V - I Ra - brush drop) / Ke, not (V - I Ra) / Ke
    est = pd.read_csv(out / "load.ripple_speed.csv")
    log = pd.read_csv(logs / "load.csv", comment="#")
    v, i = log["v_V"].to_numpy(), log["i_A"].to_numpy()
    want = ph.physics_rpm(phys, v, i, np.zeros_like(i), phys.t_ref_C)
    assert np.allclose(est["rpm_prior"].to_numpy(), want, rtol=1e-5, equal_nan=True)
    plain = m2_prior_rpm(v, i, phys.ra_ohm, phys.ke_vs_per_rad)
    assert np.nanmax(plain - want) > 3.0  # 0.3 V over Ke: 6.9 RPM where the drive is on


def test_hpddo_ripple_model_option_refuses_a_bad_folder_in_one_line(tmp_path, capsys):
    from hpddo import cli

    logs = tmp_path / "logs"
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=logs, time_scale=0.05,
                      ripple=params.ripple_burst())
    base = [str(logs / "load.csv"), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--quiet"]

    def err(*extra, status=1):
        out = tmp_path / f"out{len(list(tmp_path.iterdir()))}"
        line = _refused(["ripple"] + base + ["--out", str(out)] + list(extra), status, capsys)
        assert not out.exists() or not any(out.iterdir()), "no partial output"
        return line

    assert "no such model folder" in err("--model", str(tmp_path / "nowhere"))
    (tmp_path / "empty").mkdir()
    assert "expected one model header" in err("--model", str(tmp_path / "empty"))
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "model_x.h").write_text("// not a model\nstatic const uint32_t kChecksum = 0x12345678u;\n")
    assert "model_x.h: not a model header of hpddo train" in err("--model", str(bad))
    _model_with_brush_drop(tmp_path / "good")
    assert "not allowed with argument" in err("--model", str(tmp_path / "good"), "--ke-vs-per-rad", "0.4", status=2)
    assert "--ra-ohm does not apply with --model" in err("--model", str(tmp_path / "good"), "--ra-ohm", "4.5")
    assert "--name applies to --model only" in err("--name", "brush")


REFERENCE_COMMANDS = ("train", "diagnose", "evaluate")


def _reference_argv(sub, log, out, *extra):
    """A command line of hpddo train, diagnose or evaluate with --reference ripple on one log."""
    head = ["--model", str(out.parent / "scored")] if sub == "evaluate" else []
    return [sub, *head, str(log), "--out", str(out), "--reference", "ripple", "--ripples-per-rev", "6",
            "--gear-ratio", "4.4", *extra]


def test_reference_ripple_takes_a_models_m2_as_the_prior_as_hpddo_ripple_does(tmp_path, capsys):
    """--prior-model DIR of train, diagnose and evaluate (one option definition, cli/options.py) is
    hpddo ripple's --model: the same prior, so the same counts, confidences and left-out rows; and it
    is used: against the prior calibrated from the ripple, the confidences (the rows' weights) and
    the prior's Ke differ."""
    import pandas as pd

    from hpddo import cli
    from hpddo.cli import diagnose, evaluate, options, train
    from hpddo.logs import benchlog

    (path,) = _twin_logs(tmp_path / "logs", ("sweep",), time_scale=0.3)
    phys = _model_with_brush_drop(tmp_path / "model")
    out = tmp_path / "ripple"
    assert cli.main(["ripple", str(path), "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                     "--model", str(tmp_path / "model"), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    by_ripple = pd.read_csv(out / "sweep.ripple_speed.csv")
    log = benchlog.read_log(path)
    parsers = {"train": train.parser(), "diagnose": diagnose.parser(), "evaluate": evaluate.parser()}
    swaps = {}
    for sub in REFERENCE_COMMANDS:
        argv = _reference_argv(sub, path, tmp_path / sub, "--prior-model", str(tmp_path / "model"))[1:]
        if sub != "evaluate":
            argv += ["--ra-ohm", "4.9"]  # the Ra of the model identified; the prior's is the model's
        ref = options.reference_of(parsers[sub].parse_args(argv))
        assert ref.model.physics.effect_names() == ["brush_drop"] and ref.model.physics.brush_V == pytest.approx(0.3)
        assert ref.ra_ohm is None and ref.ke_vs_per_rad is None, sub
        swaps[sub] = ref(path, log.df, log.meta)
    df, _, weight, rec = swaps["train"]
    for sub in ("diagnose", "evaluate"):
        assert swaps[sub][0].equals(df) and np.array_equal(swaps[sub][2], weight) and swaps[sub][3] == rec, sub
    assert rec["ke_from"] == "model " + str(tmp_path / "model") + " (M2 with brush_drop)"
    assert rec["prior_model"]["effects"] == ["brush_drop"]
    assert rec["prior_model"]["ke_vs_per_rad"] == pytest.approx(phys.ke_vs_per_rad)
    # the same figures as hpddo ripple --model: the confident counts are the rows' reference speeds
    conf = by_ripple["confident"].to_numpy()
    rpm = df["rpm_ref"].to_numpy()
    assert np.allclose(rpm[conf], by_ripple["rpm_ripple"].to_numpy()[conf], rtol=1e-5)
    assert np.allclose(weight[conf], by_ripple["confidence"].to_numpy()[conf], rtol=1e-5)
    assert np.isnan(rpm[~conf & (log.df["duty"].to_numpy() > 0)]).all()
    # and not the prior calibrated from the ripple: other confidences, another Ke
    plain = options.reference_of(parsers["train"].parse_args(_reference_argv("train", path, tmp_path / "t")[1:]))
    assert plain.model is None
    df0, _, weight0, rec0 = plain(path, log.df, log.meta)
    assert rec0["ke_from"].startswith("ripple") and rec0["prior_model"] is None
    assert abs(rec0["ke_prior_vs_per_rad"] / rec["ke_prior_vs_per_rad"] - 1) > 0.05
    both = np.isfinite(rpm) & np.isfinite(df0["rpm_ref"].to_numpy()) & (rpm > 0)
    assert both.sum() > 100 and np.abs(weight[both] - weight0[both]).max() > 0.01  # the prior weighs the line
    # the counts themselves hardly depend on the prior once it picks the same line
    assert np.abs(rpm[both] / df0["rpm_ref"].to_numpy()[both] - 1).max() < 0.01


def test_reference_ripple_prior_model_refused_in_one_line_before_any_work(tmp_path, capsys):
    from hpddo import cli

    log = tmp_path / "load.csv"
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=tmp_path, time_scale=0.05,
                      ripple=params.ripple_burst())
    _model_with_brush_drop(tmp_path / "good")
    (tmp_path / "empty").mkdir()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "model_x.h").write_text("// not a model\nstatic const uint32_t kChecksum = 0x12345678u;\n")

    def err(argv, status=1):
        line = _refused(argv, status, capsys)
        assert not (tmp_path / "out").exists(), "no output"
        return line

    for sub in REFERENCE_COMMANDS:
        def ref(*extra):
            return _reference_argv(sub, log, tmp_path / "out", *extra)
        assert f"{tmp_path / 'nowhere'}: no such model folder" in err(ref("--prior-model", str(tmp_path / "nowhere")))
        assert "expected one model header" in err(ref("--prior-model", str(tmp_path / "empty")))
        assert "model_x.h: not a model header of hpddo train" in err(ref("--prior-model", str(bad)))
        assert "expected one model header model_other.h" in err(ref("--prior-model", str(tmp_path / "good"),
                                                                    "--prior-name", "other"))
        assert "not allowed with argument" in err(ref("--prior-model", str(tmp_path / "good"),
                                                      "--ke-vs-per-rad", "0.4"), status=2)
        assert "--prior-name applies to --prior-model only" in err(ref("--prior-name", "brush"))
        encoder = [a for a in ref("--prior-model", str(tmp_path / "good")) if a not in ("--reference", "ripple")]
        encoder = [a for a in encoder if a not in ("--ripples-per-rev", "6", "--gear-ratio", "4.4")]
        assert "--prior-model applies to --reference ripple only" in err(encoder), sub
    # hpddo ripple spells it --model, and takes --prior-model as the others spell it
    argv = ["ripple", str(log), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--out", str(tmp_path / "out")]
    assert "no such model folder" in err(argv + ["--prior-model", str(tmp_path / "nowhere")])


@pytest.mark.slow
def test_train_diagnose_and_evaluate_record_the_prior_model(tmp_path, capsys):
    """End to end: each command counts the ripple with the model's M2 as the prior, says so and
    records it (metrics.json, diagnosis.json), and train's provenance repeats the option."""
    import json

    from hpddo import cli

    logs = _twin_logs(tmp_path / "logs", time_scale=0.3)
    _model_with_brush_drop(tmp_path / "prior")
    prior = ["--prior-model", str(tmp_path / "prior")]
    m = tmp_path / "scored"
    argv = _reference_argv("train", logs[0], m, "--epochs", "50", "--quiet", *prior)
    assert cli.main(argv[:2] + [str(logs[1])] + argv[2:]) == 0
    assert cli.main(_reference_argv("diagnose", logs[0], tmp_path / "d", "--no-hybrid", "--bootstrap", "0",
                                    "--quiet", *prior)) == 0
    assert cli.main(_reference_argv("evaluate", logs[1], tmp_path / "e", "--quiet", *prior)) == 0
    printed = capsys.readouterr().out
    assert printed.count(f"from model {tmp_path / 'prior'} (M2 with brush_drop)") == 4  # 2 + 1 + 1 recordings
    for f in (m / "metrics.json", tmp_path / "d" / "diagnosis.json", tmp_path / "e" / "metrics.json"):
        r = json.loads(f.read_text())["reference"]
        assert r["prior_model"]["folder"] == str(tmp_path / "prior") and r["prior_model"]["effects"] == ["brush_drop"]
        assert all(x["ke_from"].startswith("model ") for x in r["recordings"].values()), f
    assert f"--prior-model {tmp_path / 'prior'}" in (m / "model_default.h").read_text()


def test_a_span_is_scored_against_the_encoder_over_the_same_span():
    import pandas as pd

    est = pd.DataFrame({"span": [1, 3, 3, 3, 1], "span_first": [0, 1, 1, 1, 4], "confident": True,
                        "f_Hz": [10.0, 2.2, 2.2, 2.2, 10.0]})
    ref = np.array([22.7, 4.96, np.nan, 5.58, 22.7])  # a glitch left out of the span's mean
    assert np.allclose(span_reference(est, ref), [22.7, 5.27, 5.27, 5.27, 22.7])
    assert np.allclose(span_reference(est.drop(columns=["span_first"]), ref), ref, equal_nan=True)
    # the ratio check takes the span as one count: its windows' own encoder steps do not trim it
    chk = check_ratio(est, np.array([22.7, 4.96, 4.96, 5.58, 22.7]), 0.5, Options(6, 4.4))
    assert chk["left_out"] == 0 and chk["windows"] == 5


def test_standing_is_the_back_emf_of_open_terminals_with_the_drive_off():
    """0 RPM from the back-EMF only where the drive is off (duty 0), no current flows (the terminals
    are open, so V is the back-EMF) and |V| is under the threshold."""
    import pandas as pd

    est = pd.DataFrame({"key": ["coasting", "coasting", "coasting", "", "coasting"],
                        "i_mean_A": [0.008, 0.008, 0.30, 0.4, 0.008]})
    duty = np.array([0.0, 0.0, 0.0, 0.2, 0.0])
    v = np.array([0.004, 0.05, 0.0, 0.0, np.nan])  # turning (50 mV of back-EMF); braked (current); driven; no V
    assert standing(est, duty, v, Options(6, 4.4)).tolist() == [True, False, False, False, False]
    assert not standing(est, duty, v, Options(6, 4.4, standing_V=0.0)).any()


def test_step_position_places_each_window_in_its_step_of_duty_and_load():
    import pandas as pd

    log = pd.DataFrame({"duty": [0.3, 0.3, 0.3, 0.5, 0.5, 0.5, 0.5], "load": [0, 0, 0, 0, 0, 1, 1]})
    assert study.step_position(log).tolist() == ["first", "within", "last", "first", "last", "first", "within"]
    assert study.step_position(log.drop(columns=["load"])).tolist()[3:] == ["first", "within", "within", "within"]


def test_the_unseen_quarter_breakdown_accounts_for_every_row_left(capsys):
    """The study's breakdown of the rows above the current floor without a confident speed
    (docs/ripple-step-windows.md, "Unseen at a quarter length, the rows lost"): every such row is
    placed once, by its place in the step and its reason."""
    (r,) = study.over_seeds([1], [0.25], protocols=("unseen",))
    pos = r["uncovered_above_floor_by_position"]
    assert sum(sum(v.values()) for v in pos.values()) == sum(r["uncovered_above_floor"].values()) > 0
    assert "changing" in pos["first"] and "changing" not in pos["within"]  # a change inside a steady step is none
    assert 0 < r["uncovered_above_floor_under_speed_floor"] <= sum(r["uncovered_above_floor"].values())
    assert r["max_vs_truth_pct"] < 5.0 and r["confident_at_standstill"] == 0
    table = study.uncovered_table([r])
    assert table.count("\n") == 2 and table.splitlines()[2].startswith("| unseen | 0.25 | 200 |")


def test_settled_tails_count_a_step_window_after_the_step_within_the_bound():
    """count_settled_tails (off by default): a `changing` window counted again over its tail after the
    step, the head's speed from the back-EMF. On unseen at a quarter length (5 s steps) it lifts
    changing windows (most of them the first of a step) and nothing else changes; the lifted speeds
    are the window's mean within 2 % of the truth (0.46 % at most over seeds 1-6,
    docs/ripple-step-windows.md, "Settled tails (off by default)"),
    and a tail of fewer cycles is refused."""
    g = generate.generate(params.preset("default"), "unseen", 2.0, 1, time_scale=0.25, ripple=params.ripple_burst())
    t0, codes, bmeta = g["bursts"]
    log, true = g["log"], g["truth"]["rpm_true"].to_numpy()
    b = rf.Bursts(bmeta, float(bmeta["sample_hz"]), float(bmeta["a_per_code"]), log["seq"].to_numpy(), t0, codes)
    off, ke, _ = speed_of_log("unseen.csv", log, g["meta"], Options(6, 4.4), bursts=b)
    on, ke_on, _ = speed_of_log("unseen.csv", log, g["meta"], Options(6, 4.4, settled_tail=True), bursts=b)
    assert "tail_start" not in off and ke_on == ke
    lifted = np.isfinite(on["tail_start"].to_numpy())
    assert lifted.sum() >= 5 and (off["key"].to_numpy()[lifted] == "changing").all()
    assert on["confident"].to_numpy()[lifted].all() and not off["confident"].to_numpy()[lifted].any()
    assert on.drop(columns=["tail_start"])[~lifted].equals(off[~lifted])  # the other rows as they were
    err = np.abs(on["rpm"].to_numpy()[lifted] / true[lifted] - 1)
    assert err.max() < 0.02, err
    # the tail's cycles: at least tail_min_cycles, so a higher bar lifts fewer rows
    strict, _, _ = speed_of_log("unseen.csv", log, g["meta"],
                                   Options(6, 4.4, settled_tail=True, tail_min_cycles=15.0), bursts=b)
    assert np.isfinite(strict["tail_start"].to_numpy()).sum() < lifted.sum()


def test_ratio_check_with_the_windows_in_clusters_is_a_sentence_not_a_crash():
    """Issue 33: confident windows whose ripples per encoder revolution fall into two clusters, each
    more than TRIM from their median, left no window after the trim and raised ZeroDivisionError,
    which aborted a multi-log run. Now the check says why it is not made."""
    import pandas as pd

    ref = np.full(8, 100.0)
    f = np.r_[np.full(4, 0.8), np.full(4, 1.2)] * 6 * 4.4 * 100 / 60.0
    chk = check_ratio(pd.DataFrame({"confident": [True] * 8, "f_Hz": f}), ref, 0.5, Options(6, 4.4))
    assert chk["windows"] == 0 and chk["left_out"] == 8
    assert "do not agree" in chk["statement"] and "not checked" in chk["statement"]
    assert "21.12 to 31.68" in chk["statement"]


@pytest.mark.slow
def test_a_low_duty_run_with_standing_steps_gives_no_confident_speed_where_the_shaft_stands(monkeypatch):
    """Duties 0.12-0.3 on the twin, where the shaft stands at 0.12 and 0.18 with the drive on (static
    friction) under the twin's default 5 mA of 50 Hz, and Ke calibrated from the ripple: the hum was counted as
    114 RPM in every standing window and set Ke at 0.043 V s/rad (true 0.355). No confident window stands
    or is more than 5 % off, the standing steps are stalls, and Ke's stated doubt holds the truth at the run's
    end. Alone the run is `unchecked` (no comb); beside a load run of the motor its turning steps are confident."""
    from hpddo import bench as hb

    segs = tuple(hb.Segment(10.0, d, 0) for d in (0.12, 0.18, 0.24, 0.3))
    monkeypatch.setitem(hb.PROTOCOLS, "sweep", dataclasses.replace(hb.PROTOCOLS["sweep"], segments=segs))
    bench = params.preset("default")
    g = generate.generate(bench, "sweep", 2.0, 1, ripple=params.ripple_burst())
    t0, codes, bmeta = g["bursts"]
    log, truth = g["log"], g["truth"]
    b = rf.Bursts(bmeta, float(bmeta["sample_hz"]), float(bmeta["a_per_code"]), log["seq"].to_numpy(), t0, codes)
    opts = Options(bench.ripples_per_rev, bench.gear_ratio)
    # alone, no window of the run shows a rotation comb, so nothing checks the figure its Ke is calibrated under:
    # no window is confident (`unchecked` where the count holds); beside a load run of the motor whose combs
    # confirm the figure, the run is counted with that run's Ke (speed_of_bench)
    alone, _, _ = speed_of_log("low.csv", log, g["meta"], opts, bursts=b)
    assert not alone["confident"].any() and (alone["key"].to_numpy()[40:] == "unchecked").mean() > 0.9
    g_load = generate.generate(bench, "load", 2.0, 1, time_scale=0.25, ripple=params.ripple_burst())
    lt0, lcodes, lmeta = g_load["bursts"]
    lb = rf.Bursts(lmeta, float(lmeta["sample_hz"]), float(lmeta["a_per_code"]), g_load["log"]["seq"].to_numpy(),
                   lt0, lcodes)
    _, (est, ke, ke_from) = speed_of_bench([("load.csv", g_load["log"], g_load["meta"], lb),
                                            ("low.csv", log, g["meta"], b)], opts)
    true = truth["rpm_true"].to_numpy()
    conf = est["confident"].to_numpy()
    assert (true[:40] < 1).all() and (true[40:] > 10).all()  # the twin's shaft: standing, then turning
    assert conf[40:].mean() > 0.9 and not conf[:40].any()
    assert (np.abs(est["rpm"].to_numpy()[conf] / true[conf] - 1) < 0.05).all()
    assert (est["key"].to_numpy()[:40] == "stall").mean() > 0.9
    doubt = float(ke_from.split("to +-")[1].rstrip("%)")) / 100
    ke_true = float(truth["ke_vs_per_rad"].iloc[-1])
    assert abs(ke / ke_true - 1) <= doubt <= KE_DOUBT_MAX, (ke, ke_true, ke_from)


@pytest.mark.slow
@pytest.mark.parametrize("protocol", ["load", "hot"])
def test_ke_from_the_ripple_states_a_doubt_that_holds_the_truth_on_the_twins_runs(protocol):
    """calibrate_ke's stated relative doubt holds the twin's true Ke at the run's median, where a brush drop
    and a winding warmer than the Ra given both put E = V - I Ra above Ke w: on the load run Ke is 8.7-11.9 %
    above the truth and the doubt added in quadrature said 10.5 %; on the warm-up (Ra 10-22 % over the log's)
    13.6 % above and 10.1 % said. Seed 2, a quarter length."""
    g = generate.generate(params.preset("default"), protocol, 2.0, 2, time_scale=0.25, ripple=params.ripple_burst())
    t0, codes, bmeta = g["bursts"]
    log = g["log"]
    b = rf.of_meta(bmeta, log["seq"].to_numpy(), t0, codes)
    ke, n, doubt = calibrate_ke(b, log["duty"].to_numpy(), log["v_V"].to_numpy(), log["i_A"].to_numpy(),
                                float(g["meta"]["ra_ohm"]), Options(6, 4.4))
    truth = float(g["truth"]["ke_vs_per_rad"].median())
    assert n > 20 and abs(ke / truth - 1) <= doubt <= KE_DOUBT_MAX, (ke, truth, doubt)


def test_the_references_line_says_no_prior_where_no_window_gave_ke():
    """A burst file whose codes are all zero gives no window a line and no back-EMF prior: the reference's line
    says so, never "prior Ke nan V s/rad" (hpddo evaluate --reference ripple printed it; found by a fuzzing
    helper), and its record holds no NaN."""
    from hpddo.ripple import reference

    rec = {"ripples_per_rev": 6, "gear_ratio": 4.4, "ke_prior_vs_per_rad": None, "ke_from": "ripple (0 windows)",
           "kept": 0, "rows": 120, "left_out": 120, "left_out_by_reason": {"floor": 120}}
    said = reference.line("load", rec)
    assert "no back-EMF prior (ripple (0 windows))" in said and "nan" not in said, said
    rec["ke_prior_vs_per_rad"] = 0.0123
    assert "prior Ke 0.0123 V s/rad from ripple (0 windows)" in reference.line("load", rec)


def test_a_reversed_shafts_ripple_speed_takes_the_back_emfs_sign(tmp_path, capsys):
    """The ripple counts a speed, not its direction. A twin log run in reverse (V, I, rpm_ref and the burst codes
    negated): the count was labelled +179 RPM where the encoder read -179, and train --reference ripple wrote a
    model with M2 Ke 0.099 V s/rad (0.37 from the encoder) without a warning (a fuzzing helper's). The label takes
    the terminal voltage's sign (reference.direction): the same speeds as the encoder, signs and all."""
    import pandas as pd

    from hpddo import cli
    from hpddo.logs import benchlog
    from hpddo.ripple import reference

    fwd = tmp_path / "fwd"
    generate.generate(params.preset("default"), "load", 2.0, 1, out_dir=fwd, time_scale=0.3,
                      ripple=params.ripple_burst())
    rev = tmp_path / "rev"
    rev.mkdir()
    log = benchlog.read_log(fwd / "load.csv")
    df = log.df.copy()
    for c in ("v_V", "i_A", "rpm_ref"):
        df[c] = -df[c]
    benchlog.write_log(rev / "load.csv", df, log.meta, exact=True)
    lines = (fwd / "load.ripple.csv").read_text().splitlines()
    out = [ln if not ln[:1].isdigit() else ",".join(ln.split(",", 3)[:3] + [" ".join(str(-int(v)) for v in
                                                                               ln.split(",", 3)[3].split())])
           for ln in lines]
    (rev / "load.ripple.csv").write_text("\n".join(out) + "\n")
    assert cli.main(["ripple", str(rev / "load.csv"), "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                     "--out", str(tmp_path / "o"), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert "against the encoder RMS" in said and "the gear ratio 4.4:1 agrees with the data" in said, said
    est = pd.read_csv(tmp_path / "o" / "load.ripple_speed.csv")
    conf = est[est["confident"]]
    assert len(conf) > 10 and (conf["rpm_ripple"] < 0).all()
    ref = reference.Ripple(ripples_per_rev=6, gear_ratio=4.4)
    swapped, _, _, _ = ref(rev / "load.csv", df, log.meta)
    got, enc = swapped["rpm_ref"].to_numpy(), df["rpm_ref"].to_numpy()
    ok = np.isfinite(got) & (np.abs(enc) > 20)
    assert ok.sum() > 10 and np.all(np.abs(got[ok] / enc[ok] - 1) < 0.05)
