"""Issue 33, "any sampling, real captures": the burst format's sampling, offset and coupling
declarations, the PWM-synchronous average removed from free-running bursts, no confident line
at a PWM or mains multiple, the twin's free-running mode, Ra optional, and `hpddo import` from
CSV, WAV and .mat into a speed with its confidence (docs/ripple-captures.md)."""
import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hpddo import cli
from hpddo.logs import capture_import as ci
from hpddo.logs import ripple as rf
from hpddo.logs.errors import InputError
from hpddo.ripple.count import estimate_window
from hpddo.ripple.log import speed_of_log
from hpddo.ripple.options import Options
from hpddo.ripple import sync
from hpddo.twin import generate, params, plant, ripple_free

BENCH = params.preset("default")
OPTS = Options(BENCH.ripples_per_rev, BENCH.gear_ratio)


def _free_run(seed=1, mains_hz=0.0, protocol="load", time_scale=0.1, out_dir=None, pwm_hz=490.196):
    rpar = {**params.ripple_burst(sample_hz=9600), **ripple_free.ripple_free(pwm_hz=pwm_hz, mains_hz=mains_hz)}
    g = generate.generate(BENCH, protocol, 2.0, seed, time_scale=time_scale, ripple=rpar, out_dir=out_dir)
    t0, codes, meta = g["bursts"]
    return g, rf.of_meta(meta, g["log"]["seq"].to_numpy(), t0, codes)


def _errors(g, b):
    df, _, _ = speed_of_log("load.csv", g["log"], g["meta"], OPTS, None, None, bursts=b)
    c = df["confident"].to_numpy()
    return c, df["rpm"].to_numpy()[c] / g["truth"]["rpm_true"].to_numpy()[c] - 1, df


def test_pwm_waveform_is_the_plants_period_mean_and_its_ripple_follows_l_over_r():
    """The free-running twin's PWM current is the plant's periodic solution: its mean over a period is
    pwm_cycle's mean current, and its peak-to-peak grows with the period over La (halving La, the
    ripple roughly doubles while discontinuous conduction does not set in)."""
    la = BENCH.effect_si("inductance")
    ph = (np.arange(20000) + 0.5) / 20000
    for d, e in ((0.3, 2.0), (0.6, 5.0), (0.9, 6.0)):
        w = plant.pwm_waveform(ph, d, e, 0.3, BENCH.ra_ohm, la, BENCH)
        assert w.mean() == pytest.approx(plant.pwm_cycle(d, e, 0.3, BENCH.ra_ohm, la, BENCH)[0], rel=1e-6)
        assert (w >= 0).all()
    fast = dataclasses.replace(BENCH, pwm_hz=20000.0)
    p1 = np.ptp(plant.pwm_waveform(ph, 0.9, 6.0, 0.3, BENCH.ra_ohm, la, fast))
    p2 = np.ptp(plant.pwm_waveform(ph, 0.9, 6.0, 0.3, BENCH.ra_ohm, la / 2, fast))
    assert p2 / p1 == pytest.approx(2.0, rel=0.05)


def test_free_running_bursts_counted_after_the_pwm_average_is_removed_and_not_before():
    """Free-running sampling at 9.6 kHz under the 490 Hz PWM: read as a synchronous file (no declaration),
    the PWM's lines are the strongest, and they were once counted as the ripple, confidently and 36-88 % off;
    with Ke calibrated from the ripple, the recording's combs do not confirm the figure there, and no window is
    confident more than 5 % off. Declared, the PWM-synchronous average is removed, and the windows are
    confident and right."""
    g, b = _free_run()
    assert b.sampling == rf.FREE and b.pwm_hz == pytest.approx(490.196)
    before = dataclasses.replace(b, sampling=rf.SYNCHRONOUS, pwm_hz=float("nan"))
    c0, e0, _ = _errors(g, before)
    assert (np.abs(e0) < 0.05).all(), e0  # the PWM's lines are not counted as the ripple with confidence
    c1, e1, _ = _errors(g, b)
    assert c1.mean() > 0.8 and np.abs(e1).max() < 0.05 and np.sqrt(np.mean(e1 ** 2)) < 0.01


@pytest.mark.parametrize("true_hz, declared_hz", [(976.5625, 490.196), (490.196, 976.5625)])
def test_a_pwm_declared_at_another_frequency_than_the_drives_is_named_with_the_one_the_data_show(true_hz, declared_hz):
    """An UNO's pins 5 and 6 run their PWM at 976.5625 Hz, the others at 490.196: declared at the other, the
    PWM's lines were neither removed nor known as fixed lines, and the windows said `multiple` (81 of 165) and
    `damaged` (24) off those lines (none confident). The declared PWM's synchronous average holds nothing, a
    steady line does: every window read off the lines is `pwm_unseen`, whose reason names the frequency the
    data show (sync.pwm_unseen); declared right, none is."""
    g, b = _free_run(protocol="sweep", time_scale=0.25, pwm_hz=true_hz)
    wrong = dataclasses.replace(b, pwm_hz=declared_hz)
    _, _, df = _errors(g, wrong)
    assert not df["confident"].any()
    keys = set(df["key"])
    assert "pwm_unseen" in keys and not keys & {"multiple", "damaged", "rival", "ambiguous"}, keys
    said = df.loc[df["key"] == "pwm_unseen", "reason"].iloc[0]
    named = float(said.split("declare pwm_hz=")[1].split()[0])
    assert named == pytest.approx(true_hz, rel=2e-4), said
    # (a fuzzing helper's capture: the steady line was the ripple of a steady speed, and declared as the PWM it hid
    # every window: the reason says a steady line may be the ripple)
    assert "a motor at a steady speed shows its ripple as a steady line too" in said, said
    _, _, right = _errors(g, b)
    assert "pwm_unseen" not in set(right["key"]) and right["confident"].mean() > 0.6
    # --calibrate names no figure from lines that may be the PWM's
    from hpddo.ripple import calibrate as rcal
    duty, ref = g["log"]["duty"].to_numpy(float), g["log"]["rpm_ref"].to_numpy(float)
    c = rcal.calibrate(wrong, duty, OPTS, ref)
    assert c["ripples_per_rev"] == 0 and c["statement"].startswith("the ripples per revolution are not determined: "
                                                                    + sync.REASON_UNSEEN), c["statement"]
    assert rcal.calibrate(b, duty, OPTS, ref)["ripples_per_rev"] == BENCH.ripples_per_rev


def test_mains_comb_never_gives_a_confident_window_on_its_lines():
    """With a rectified-mains comb (50 Hz) declared, no confident window sits within the mains' drift
    (sync.MAINS_DRIFT_REL) of a multiple of 50 Hz; one within a resolution of it is confident only where the joint
    fit (sync.beside_mains) tells the two apart, and then within 1 % of the truth; no confident window is more than
    5 % off. The load run of seed 2 turns near 51 Hz of ripple for a third of its windows."""
    g, b = _free_run(seed=2, mains_hz=50.0)
    c, e, df = _errors(g, b)
    assert np.abs(e).max() < 0.05
    f = df["f_Hz"].to_numpy()[c]
    res = 1.0 / 0.5
    off = np.abs(f - 50.0 * np.round(f / 50.0))
    assert (off > sync.MAINS_DRIFT_REL * f).all()
    near = off <= res + 0.002 * f
    assert near.any() and (np.abs(e[near]) < 0.01).all(), e[near]
    assert df.loc[df["key"] == sync.KEY, "reason"].str.contains("mains' 50 Hz").all()


def _hum_and_line(hum_A, hum_hz, line_A, line_hz, noise_A, seed, fs=9600.0, n=3840):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    return (1.0 + hum_A * np.sin(2 * np.pi * hum_hz * t + rng.uniform(0, 2 * np.pi))
            + line_A * np.sin(2 * np.pi * line_hz * t + rng.uniform(0, 2 * np.pi))
            + 0.3 * line_A * np.sin(2 * np.pi * line_hz * 5 / 6 * t)  # rotation lines beside it
            + 0.2 * line_A * np.sin(2 * np.pi * line_hz * 7 / 6 * t)
            + noise_A * rng.standard_normal(n))


@settings(max_examples=150, deadline=None, derandomize=True)
@given(h=st.integers(1, 6), drift=st.floats(-1.0, 1.0), hum=st.floats(-3.0, -0.5), line=st.floats(-2.5, -1.0),
       offset=st.floats(0.0, 3.0), sign=st.sampled_from([-1, 1]), noise=st.floats(-3.5, -1.5),
       present=st.booleans(), seed=st.integers(0, 2 ** 16))
def test_a_line_beside_a_mains_multiple_is_told_from_it_only_where_it_is(h, drift, hum, line, offset, sign, noise,
                                                                         present, seed):
    """A burst of 0.4 s (a resolution of 2.5 Hz) holding hum at a multiple of 50 Hz, drifted within the mains'
    allowance, and a shaft's line 0-3 Hz from it (or none), with rotation lines beside it and white noise: where the
    joint fit calls the line apart from the mains line, a line is there, outside the drift allowance, and the fit
    puts it within 3 % of its frequency (its precision, under the 5 % target: the rotation lines and a strong hum leak
    into the fit; over 4,000 such draws 3 were more than 1 % off, the worst 2.3 %, and none called apart without a
    line). The count must also agree with the fit within sync.MAINS_AGREE_REL to be confident."""
    f_m = 50.0 * h
    f_hum = f_m * (1 + sync.MAINS_DRIFT_REL * drift)
    f_line = f_m + sign * offset
    x = _hum_and_line(10 ** hum, f_hum, 10 ** line if present else 0.0, f_line, 10 ** noise, seed)
    fit = sync.beside_mains(x, 9600.0, f_line if present else f_m + sign * 1.0, f_m, 2.5)
    if fit["apart"]:
        assert present and abs(f_line - f_m) > fit["drift_hz"], fit
        assert abs(fit["f_hz"] / f_line - 1) < 0.03, fit


def test_fixed_line_with_the_samples_lets_a_line_beside_the_mains_through_and_not_the_mains_line():
    b = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.001", "mains_hz": "50"}, [0], [0.0],
                   [np.zeros(3840, np.int64)])
    both = _hum_and_line(0.05, 50.0, 0.05, 51.2, 0.002, 1)
    assert sync.fixed_line(b, 0, 51.2, 2.5, x=both) is None
    key, why = sync.fixed_line(b, 0, 51.2 * 1.01, 2.5, x=both)  # a count 1 % off the fit: the mains pulls it
    assert key == sync.KEY and "pulls the count" in why
    hum = _hum_and_line(0.05, 50.03, 0.0, 51.2, 0.002, 2)
    key, why = sync.fixed_line(b, 0, 50.6, 2.5, x=hum)
    assert key == sync.KEY and "not clear of the mains line" in why
    assert sync.fixed_line(b, 0, 51.2, 2.5)[0] == sync.KEY  # without the samples: within a resolution, refused


def test_a_hum_with_no_line_beside_it_is_said_so_not_given_an_infinite_error():
    """Hum alone at 50 Hz, a count at 51.2 Hz: where the joint fit finds no line of its own (its least at the
    search's edge), the reason says that; a fuzzing round's reason read "the line is at 295.94 +- inf Hz"."""
    b = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.001", "mains_hz": "50"}, [0], [0.0],
                   [np.zeros(3840, np.int64)])
    reasons = [sync.fixed_line(b, 0, 51.2, 2.5, x=_hum_and_line(0.05, 50.0, 0.0, 51.2, 0.002, s)) for s in range(8)]
    assert all(key == sync.KEY and "inf" not in why for key, why in reasons), reasons
    assert sum("no line of its own" in why for _, why in reasons) >= 3, reasons


def test_fixed_line_names_pwm_harmonics_their_aliases_and_mains():
    b = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.01", "pwm_hz": "490.196", "mains_hz": "60"},
                   [0], [0.0], [np.zeros(4800, np.int64)])
    assert sync.fixed_line(b, 0, 980.4, 2.0)[0] == sync.KEY  # 2 x PWM
    alias = abs(((20 * 490.196) + 4800) % 9600 - 4800)  # the 20th harmonic, folded
    assert "aliased" in sync.fixed_line(b, 0, alias, 2.0)[1]
    assert "mains' 60 Hz" in sync.fixed_line(b, 0, 180.5, 2.0)[1]
    assert sync.fixed_line(b, 0, 211.0, 2.0) is None
    plain = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.01"}, [0], [0.0], [np.zeros(10, np.int64)])
    assert sync.fixed_line(plain, 0, 150.0, 2.0) is None  # nothing declared, nothing assumed


def test_a_mains_frequency_of_any_size_is_checked_by_its_nearest_multiple():
    """A file may declare any positive mains frequency. The check takes the multiple nearest the line,
    computed: listing every multiple between the line's bounds took 42 s for four windows at 1 mHz
    (about 27 million of them near 200 kHz; found by fuzzing hpddo ripple, 311 s for one file)."""
    b = rf.of_meta({"sample_hz": "1000000", "a_per_code": "0.01", "mains_hz": "0.001"}, [0], [0.0],
                   [np.zeros(300, np.int64)])
    assert len(sync.fixed_lines(b, 200000.0)) == 1
    key, why = sync.fixed_line(b, 0, 200000.0004, 2.0)
    assert key == sync.KEY and "200000000 x the mains' 0.001 Hz" in why
    b60 = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.01", "mains_hz": "60"}, [0], [0.0], [np.zeros(10, np.int64)])
    assert sync.fixed_lines(b60, 181.0) == [(180.0, "3 x the mains' 60 Hz")]


def test_free_running_without_pwm_hz_is_refused_and_a_short_burst_said_too_short():
    b = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.01", "sampling": "free"}, [0], [0.0],
                   [np.arange(4800) % 7])
    with pytest.raises(InputError, match="without pwm_hz"):
        sync.prepare(b, "x.ripple.csv")
    short = dataclasses.replace(b, pwm_hz=490.196, codes=[np.arange(400) % 7, np.arange(4800) % 7],
                                seq=np.array([0, 1]), t_s=np.array([0.0, 1.0]))
    p = sync.prepare(short)
    assert "too short" in p.refusal(0) and p.refusal(1) == ""
    r = estimate_window(p, 0, 1.0, None, OPTS)
    assert r["key"] != ""  # never confident on a burst whose PWM average could not be removed
    assert sync.phase_bins(400) == 0 and sync.phase_bins(4800) == 150


def test_remove_pwm_average_takes_out_a_pwm_waveform_and_keeps_a_ripple():
    """A 490 Hz PWM current of 1.4 A peak to peak plus a 50 mA ripple at 87 Hz, sampled free at 9.6 kHz:
    after the fold the ripple is what remains (the residual under 10 % of the ripple's rms)."""
    fs, pwm, n = 9600.0, 490.196, 4800
    t = np.arange(n) / fs
    la = BENCH.effect_si("inductance")
    pwm_i = plant.pwm_waveform(t * pwm, 0.3, 2.0, 0.3, BENCH.ra_ohm, la, dataclasses.replace(BENCH, pwm_hz=pwm))
    ripple = 0.05 * np.cos(2 * np.pi * 87.3 * t)
    rest, bins = sync.remove_pwm_average(pwm_i + ripple, fs, pwm)
    assert bins == 150 and np.ptp(pwm_i) > 10 * np.ptp(ripple)
    basis = np.column_stack([np.ones(n), np.cos(2 * np.pi * 87.3 * t), np.sin(2 * np.pi * 87.3 * t)])
    coef, *_ = np.linalg.lstsq(basis, rest, rcond=None)
    assert np.hypot(coef[1], coef[2]) == pytest.approx(0.05, rel=0.05)  # the ripple kept
    resid = rest - basis @ coef  # what is left of the PWM: its shape's kinks, the bins' share of the ripple
    assert np.std(resid) < 0.15 * np.std(ripple) and np.std(resid) < 0.01 * np.std(pwm_i)


def test_offset_signed_codes_and_ac_coupling(tmp_path):
    """An offset (offset_code) and signed codes: negative currents are read, not clipped; an
    AC-coupled capture (coupling=ac) has no floor on its (absent) mean current."""
    codes = [np.array([-5, -3, 0, 2], np.int64), np.array([10, 11], np.int64)]
    p = rf.write(tmp_path / "x.ripple.csv", {"sample_hz": "1000", "a_per_code": "0.5", "offset_code": "2.5",
                                             "coupling": "ac"}, [0, 1], [0.0, 0.004], codes)
    b = rf.read(p)
    assert b.current_A(0).tolist() == [-3.75, -2.75, -1.25, -0.25]
    assert b.coupling == rf.AC and not sync.holds_mean(b)
    t = np.arange(4800) / 9600
    x = np.round(100 * np.cos(2 * np.pi * 80 * t)).astype(np.int64)  # zero mean: an AC-coupled ripple
    ac = rf.of_meta({"sample_hz": "9600", "a_per_code": "0.001", "coupling": "ac"}, [0], [0.0], [x])
    assert estimate_window(ac, 0, 1.0, None, OPTS)["key"] == ""
    dc = dataclasses.replace(ac, coupling=rf.DC)
    assert estimate_window(dc, 0, 1.0, None, OPTS)["key"] == "floor"
    neg = dataclasses.replace(dc, offset_code=500.0)  # -0.5 A mean: braking, the ripple still counted
    assert estimate_window(neg, 0, 1.0, None, OPTS)["key"] == ""


@pytest.mark.parametrize("meta, fault", [
    ({"sampling": "sometimes"}, "expected one of synchronous, free"),
    ({"pwm_hz": "-1"}, "pwm_hz=-1 must be > 0 (0: no PWM)"),
    ({"mains_hz": "-50"}, "mains_hz=-50 must be > 0 (0: no mains)"),
    ({"offset_code": "nan"}, "offset_code='nan' is not a finite number"),
    ({"coupling": "AC"}, "expected one of dc, ac"),
])
def test_bad_declarations_are_user_errors_naming_the_line(tmp_path, meta, fault):
    p = tmp_path / "x.ripple.csv"
    body = "".join(f"# {k}={v}\n" for k, v in meta.items())
    p.write_text(f"# format=hpddo-ripple 1\n# sample_hz=100\n# a_per_code=1\n{body}seq,t_s,n,codes\n0,0,2,1 2\n")
    with pytest.raises(rf.RippleFileError) as exc:
        rf.read(p)
    assert fault in str(exc.value) and str(p) in str(exc.value)
    assert f"{p}:4:" in str(exc.value) or "expected one of" in str(exc.value)


def test_twin_cli_free_running_writes_the_declarations(tmp_path, capsys):
    out = tmp_path / "tw"
    assert cli.main(["twin", "--protocol", "load", "--ripple-hz", "9600", "--free-running", "--mains-hz", "50",
                     "--time-scale", "0.05", "--out", str(out), "--quiet"]) == 0
    b = rf.read(out / "load.ripple.csv")
    assert (b.sampling, b.pwm_hz, b.mains_hz) == (rf.FREE, pytest.approx(490.196), 50.0)
    # hpddo ripple on it, with the log's encoder: the nameplate's gear ratio agrees (the issue: 85.638:1 said
    # where the nameplate's 98.777:1 was right, the PWM counted as the ripple)
    assert cli.main(["ripple", str(out / "load.csv"), "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                     "--out", str(tmp_path / "o"), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert "the gear ratio 4.4:1 agrees with the data" in said, said
    with pytest.raises(SystemExit):
        cli.main(["twin", "--protocol", "load", "--free-running", "--out", str(tmp_path / "x")])
    assert "--free-running applies to the ripple mode" in capsys.readouterr().err


def test_ra_is_optional_the_speed_range_is_the_prior(tmp_path, capsys):
    """hpddo ripple on a log without ra_ohm (and no --ra-ohm) counts with the speed range as the prior
    (or none), where it refused before; a confident count outside the range is not confident."""
    g, _ = _free_run(out_dir=tmp_path / "logs")
    log = tmp_path / "logs" / "load.csv"
    log.write_text("".join(l for l in log.read_text().splitlines(True) if not l.startswith("# ra_ohm=")))
    assert cli.main(["ripple", str(log), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--rpm-range", "80", "250",
                     "--out", str(tmp_path / "o"), "--quiet"]) == 0
    import pandas as pd
    est = pd.read_csv(tmp_path / "o" / "load.ripple_speed.csv")
    c = est["confident"].to_numpy()
    e = est["rpm_ripple"].to_numpy()[c] / g["truth"]["rpm_true"].to_numpy()[c] - 1
    assert c.mean() > 0.8 and np.abs(e).max() < 0.05
    assert "no back-EMF prior (no Ra: the speed range given is the prior)" in capsys.readouterr().out
    assert cli.main(["ripple", str(log), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--rpm-range", "150", "250",
                     "--out", str(tmp_path / "o2"), "--quiet"]) == 0
    est = pd.read_csv(tmp_path / "o2" / "load.ripple_speed.csv")
    c = est["confident"].to_numpy()
    rpm = est["rpm_ripple"].to_numpy()
    assert c.any() and ((rpm[c] >= 150) & (rpm[c] <= 250)).all()  # the windows at 116-130 RPM are not confident
    out = est["reason"].fillna("").str.startswith("the count lies outside the speed range")
    assert out.any() and (rpm[out] < 150).all()
    assert cli.main(["ripple", str(log), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--rpm-range", "4", "2",
                     "--out", str(tmp_path / "o3")]) == 1
    assert "LO must be under HI" in capsys.readouterr().err


def test_a_capture_without_a_range_is_confident_only_where_its_combs_confirm_the_figure():
    """A current-only capture without a speed range has no prior: the strongest line of a window without a rotation
    comb may be any line. Twelve windows of a 6-ripple motor at 9.0-10.5k RPM (no rotation lines) beside an
    undeclared 976.6 Hz PWM line 14x the ripple's power: the PWM line was counted in every window, 5 of them 5-8 %
    off, confidently; now none is confident (`unchecked`, as a bench log without Ke or a range). With rotation
    lines, the recording's combs confirm the 6 given and the windows are confident and right."""
    from hpddo.ripple.capture import speed_of_bursts
    from hpddo.studies import ripple_line as synth

    fs, rots = 9600.0, np.linspace(150.0, 175.0, 12)
    for lines, confident in (({6: 0.08, 12: 0.024}, False), ({1: 0.004, 2: 0.003, 3: 0.005, 6: 0.08, 12: 0.024}, True)):
        extra = [] if confident else [(976.5625, 0.3), (1953.125, 0.1)]
        xs = [synth.synthetic_current(r, lines, fs=fs, extra=extra, seed=k) for k, r in enumerate(rots)]
        est = speed_of_bursts(synth.synthetic_bursts(xs, fs=fs), Options(6, 1.0))
        c = est["confident"].to_numpy()
        if confident:  # (but where the line falls on a multiple of 50 or 60 Hz, hum the file does not rule out)
            assert c.sum() >= 9 and (est["key"][~c] == sync.KEY).all(), est["reason"].tolist()
            assert np.allclose(est["rpm"][c], rots[c] * 60, rtol=0.01)
        else:
            assert not c.any() and (est["key"] == "unchecked").all(), est["key"].tolist()


@pytest.mark.parametrize("rpm_range, confident", [((700.0, 2000.0), False), ((960.0, 1000.0), True)])
def test_a_speed_range_wider_than_a_count_under_another_figure_does_not_check_the_figure(rpm_range, confident):
    """speed_range.range_checks_figure: a symmetric 12-ripple rotor (no rotation lines, no comb) at 978 RPM whose ripple's
    second harmonic is 3x its fundamental (an independent simulator's capture): under 700..2000 RPM the strongest line
    was counted as the ripple, 1956 RPM, 12 of 12 windows confident; a 14-ripple motor given 7 was counted at twice its
    speed the same way. A range that holds a count under another figure does not check the figure: no window is
    confident (`unchecked`). One no more than 5 % wide does, and the windows are confident and right."""
    from hpddo.ripple.capture import speed_of_bursts
    from hpddo.studies import ripple_line as synth

    fs, rot = 20000.0, 978.0 / 60.0
    xs = [synth.synthetic_current(rot, {12: 0.02, 24: 0.06}, fs=fs, noise=0.001, seed=k) for k in range(12)]
    est = speed_of_bursts(synth.synthetic_bursts(xs, fs=fs), Options(12, 1.0), rpm_range=rpm_range)
    c = est["confident"].to_numpy()
    if confident:
        assert c.sum() >= 10 and np.allclose(est["rpm"][c], 978.0, rtol=0.01), est["reason"].tolist()
    else:
        assert not c.any() and (est["key"] == "unchecked").all(), est["key"].tolist()


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """One free-running twin run (9.6 kHz, 490 Hz PWM, 50 Hz mains) written as a scope's CSV (time and
    volts of a 0.1 V/A probe), a sound card's 16-bit WAV (an offset of -1000 codes) and a .mat with fs."""
    from scipy.io import savemat, wavfile

    d = tmp_path_factory.mktemp("capture")
    g, b = _free_run(seed=3, mains_hz=50.0)
    x = np.concatenate([b.current_A(k) for k in range(len(b))])
    t = np.arange(len(x)) / 9600.0
    np.savetxt(d / "scope.csv", np.c_[t, 0.1 * x], delimiter=",", header="Time (s),CH1 (V)", comments="",
               fmt="%.7g")
    wavfile.write(d / "card.wav", 9600, (np.round(x / 0.0005) - 1000).astype(np.int16))
    savemat(d / "lab.mat", {"i_motor": x, "fs": 9600.0})
    return d, g["truth"]["rpm_true"].to_numpy()


@pytest.mark.parametrize("name, flags", [
    ("scope.csv", ["--a-per-unit", "10"]),
    ("card.wav", ["--a-per-unit", "0.0005"]),
    ("lab.mat", ["--a-per-unit", "1"]),
])
def test_import_then_ripple_gives_the_speed_with_its_confidence(capture, tmp_path, capsys, name, flags):
    d, true = capture
    out = tmp_path / (name.split(".")[0] + ".ripple.csv")
    assert cli.main(["import", str(d / name), *flags, "--pwm-hz", "490.196", "--mains-hz", "50",
                     "--out", str(out), "--quiet"]) == 0
    b = rf.read(out)
    assert len(b) == len(true) and b.sample_hz == pytest.approx(9600, rel=1e-5)
    assert b.meta["source"] == name and len(b.meta["source_sha256"]) == 64
    assert cli.main(["ripple", str(out), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--rpm-range", "80",
                     "250", "--out", str(tmp_path / "o"), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert "RPM (median of the confident" in said and "confidence" in said
    import pandas as pd
    est = pd.read_csv(tmp_path / "o" / (out.name[:-len(rf.SUFFIX)] + ".ripple_speed.csv"))
    c = est["confident"].to_numpy()
    e = est["rpm_ripple"].to_numpy()[c] / true[c] - 1
    assert c.mean() >= 0.5 and np.abs(e).max() < 0.05, (c.mean(), np.abs(e).max())


@pytest.mark.parametrize("text, args, fault", [
    ("t,i\n0,1\n0.001,x\n", [], "x.csv:3: column 'i': 'x' is not a finite number"),
    ("t,i\n" + "".join(f"{k * 0.001 + (0.0005 if k == 30 else 0):g},{k}\n" for k in range(40)), [],
     "x.csv:32: time column 't' not uniform"),
    ("t,i\n" + "".join(f"{0.001 * (40 - k):g},{k}\n" for k in range(40)), [], "x.csv:3: time column 't' not increasing"),
    ("a,b,c\n" + "1,2,3\n" * 40, [], "3 columns (a, b, c): give --column"),
    ("i\n" + "1\n" * 40, [], "the file does not carry its sample rate: give --sample-hz"),
    ("i\n" + "1\n" * 40, ["--column", "j"], "no column 'j'"),
    ("i\n1\n2\n", ["--sample-hz", "100"], "2 samples: fewer than 16"),
    ("t,i\n" + "".join(f"{k * 0.001:g},1\n" for k in range(20)) + "\n" + "".join(f"{k * 0.001:g},1\n" for k in
     range(20, 40)), [], "x.csv:22: column 'i': '' is not a finite number"),  # a blank line inside: its own line
    ("t,i\n0,1\n0.001,2,3\n", [], "not a CSV table: Error tokenizing data. C error: Expected 2 fields in line 3"),
    ("t,i\n" + "".join(f"{k * 0.001:g},1\n" for k in range(40)), ["--sample-hz", "2000"],
     "--sample-hz 2000 but its time column 't' gives 1000 Hz"),
])
def test_import_bad_csv_is_a_user_error_naming_file_line_and_fault(tmp_path, capsys, text, args, fault):
    p = tmp_path / "x.csv"
    p.write_text(text)
    out = tmp_path / "x.ripple.csv"
    assert cli.main(["import", str(p), "--a-per-unit", "1", "--pwm-hz", "0", "--out", str(out), *args]) == 1
    err = capsys.readouterr().err
    assert fault in err and err.startswith("hpddo import: ") and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_import_bad_wav_mat_and_names(tmp_path, capsys):
    from scipy.io import savemat

    (tmp_path / "a.wav").write_bytes(b"RIFF1234WAVEjunk")
    savemat(tmp_path / "b.mat", {"u": np.ones(50), "v": np.ones(50)})
    savemat(tmp_path / "c.mat", {"u": np.ones((5, 5))})
    (tmp_path / "d.xyz").write_text("1\n")
    for name, more, fault in (("a.wav", [], "not a WAV file scipy can read"),
                              ("b.mat", ["--sample-hz", "1000"], "2 numeric vectors (u, v): give --variable"),
                              ("c.mat", ["--variable", "u"], "'u' is not a numeric vector"),
                              ("d.xyz", [], "unknown capture type '.xyz'"),
                              ("none.csv", [], "no such file")):
        assert cli.main(["import", str(tmp_path / name), "--a-per-unit", "1", "--pwm-hz", "0",
                         "--out", str(tmp_path / "o.ripple.csv"), *more]) == 1, name
        assert fault in capsys.readouterr().err, name
    np.savetxt(tmp_path / "e.csv", np.arange(40.0))
    assert cli.main(["import", str(tmp_path / "e.csv"), "--a-per-unit", "1", "--pwm-hz", "0", "--sample-hz", "100",
                     "--out", str(tmp_path / "o.csv")]) == 1
    assert "ends in .ripple.csv" in capsys.readouterr().err


def test_import_reads_blank_separated_text_and_trailing_blank_lines(tmp_path):
    t = np.arange(100) / 1000.0
    np.savetxt(tmp_path / "daq.txt", np.c_[t, 0.2 + 0.01 * np.sin(2 * np.pi * 50 * t)])  # numpy's blank separator
    (tmp_path / "daq.txt").write_text((tmp_path / "daq.txt").read_text() + "\n\n")
    cap = ci.read(tmp_path / "daq.txt")
    assert len(cap.values) == 100 and cap.sample_hz == pytest.approx(1000.0) and cap.source == "column '1'"


def test_float_values_quantised_at_their_own_step():
    codes, step = ci.to_codes(np.array([0.0, 0.0039, 0.0078, -0.0117]), False)
    assert step == pytest.approx(0.0039) and codes.tolist() == [0, 1, 2, -3]
    codes, step = ci.to_codes(np.array([3, -2, 7]), True)
    assert step == 1.0 and codes.tolist() == [3, -2, 7]
    x = np.random.default_rng(1).standard_normal(1000)
    codes, step = ci.to_codes(x, False)
    assert np.abs(codes * step - x).max() <= step / 2 + 1e-15 and step <= np.ptp(x) / 2 ** 24 * (1 + 1e-9)


def test_the_commonest_reason_is_said_in_full(tmp_path, capsys):
    """hpddo ripple prints, beside the count of each reason, the commonest one's reason in full: a capture of 12
    comb-less windows beside an undeclared 976.6 Hz line 14x the ripple's power, with a speed range, has no confident
    window, and the line says why (the two lines the window could not tell apart) and what may help (the mains)."""
    from hpddo.studies import ripple_line as synth

    fs = 9600.0
    xs = [synth.synthetic_current(r, {6: 0.08, 12: 0.024}, fs=fs, extra=[(976.5625, 0.3), (1953.125, 0.1)], seed=k)
          for k, r in enumerate(np.linspace(150.0, 175.0, 12))]
    p = rf.write(tmp_path / "cap.ripple.csv", {"sample_hz": "9600", "a_per_code": "0.001"}, list(range(12)),
                 [0.5 * k for k in range(12)], [np.round(x / 0.001).astype(np.int64) for x in xs])
    assert cli.main(["ripple", str(p), "--ripples-per-rev", "6", "--gear-ratio", "1", "--rpm-range", "8000", "11500",
                     "--out", str(tmp_path / "o")]) == 0
    said = capsys.readouterr()
    assert "confident 0 (0.0%)" in said.out
    assert "  no estimate: rival 12\n  rival (12 windows), window 0 for one: " in said.err
    assert "power does not name the ripple" in said.err and "976.8 Hz or 900.0 Hz" in said.err


@pytest.mark.parametrize("name, per", [("time_ms", 1e-3), ("Time (us)", 1e-6), ("t", 1.0)])
def test_a_time_column_in_the_unit_its_name_states(tmp_path, name, per):
    """capture_import.time_unit: a scope's "time_ms" column was read as seconds, its 20 kS/s as 20 S/s (every
    window then too short for a cycle). A name that states ms, us or ns is read in that unit, and the import says
    so; one that states none is in seconds, as documented."""
    t = np.arange(200) / 20000.0
    p = tmp_path / "cap.csv"
    p.write_text(f"{name},current\n" + "\n".join(f"{x / per:.9g},{0.5 + 0.01 * k % 3:.4f}" for k, x in enumerate(t)))
    cap = ci.read_csv(p, column="current", time_column=name)
    assert cap.sample_hz == pytest.approx(20000.0, rel=1e-6)
    assert ("by its name" in cap.rate_from) == (per != 1.0), cap.rate_from


def test_a_capture_shorter_than_a_window_is_one_window_of_its_length(tmp_path, capsys):
    """A capture of 120 samples at 10 kHz (12 ms) under the default 0.5 s windows is one window, and it is said
    and written as 12 ms long (it was "1 windows of 0.5 s" and # burst_s=0.5; found by a fuzzing helper)."""
    np.savetxt(tmp_path / "c.csv", np.sin(np.arange(120) / 3.0))
    out = tmp_path / "c.ripple.csv"
    assert cli.main(["import", str(tmp_path / "c.csv"), "--a-per-unit", "1", "--pwm-hz", "0", "--sample-hz", "10000",
                     "--out", str(out)]) == 0
    assert "1 windows of 0.012 s, 120 samples at 10000 Hz" in capsys.readouterr().out
    assert "# burst_s=0.012\n" in out.read_text()


def test_a_current_no_motor_draws_is_refused_before_anything_is_written(tmp_path, capsys):
    """--a-per-unit 1e300 (or an offset of 1e300) made currents of 1e300 A: the spectrum overflowed (numpy's
    warnings printed) and every window read a made-up reason (a fuzzing helper's). Over logs.ripple.MAX_CURRENT_A
    the import refuses before it writes, and the burst file's reader refuses such a file with its line."""
    from hpddo.logs import ripple as rf

    np.savetxt(tmp_path / "c.csv", np.sin(np.arange(2000) / 3.0))
    out = tmp_path / "c.ripple.csv"
    for flags in (["--a-per-unit", "1e300"], ["--a-per-unit", "1", "--offset", "1e300"]):
        assert cli.main(["import", str(tmp_path / "c.csv"), *flags, "--pwm-hz", "0", "--sample-hz", "10000",
                         "--out", str(out)]) == 1
        err = capsys.readouterr().err
        assert "c.csv: --a-per-unit" in err and "over any motor's 1e+06 A" in err and not out.exists(), err
    out.write_text("# format=hpddo-ripple 1\n# sample_hz=10000\n# a_per_code=1e300\nseq,t_s,n,codes\n0,0.0,3,1 2 3\n")
    with pytest.raises(rf.RippleFileError, match=r":3: a_per_code=1e300 and offset_code=0 make currents of 3e\+300 A"):
        rf.read(out)



def test_a_changing_windows_reason_says_each_figure_with_its_threshold(tmp_path):
    """A capture whose speed sweeps 7 % a window: every window is `changing`, and its reason gives the quarters'
    spread with what is allowed, and says the current's share is not read where no Ra or Ke is known (it printed
    'from the current, Ra dI / Ke, 0.0%', never computed; found by a fuzzing helper)."""
    import pandas as pd

    fs, n = 10000.0, 50000
    t = np.arange(n) / fs
    ph = 2 * np.pi * (150.0 * t + 180.0 / (2 * t[-1]) * t ** 2)  # the commutation line from 150 to 330 Hz
    rot = ph / 6
    x = (0.5 + 0.05 * np.cos(ph) + 0.004 * np.cos(rot) + 0.003 * np.cos(2 * rot) + 0.005 * np.cos(3 * rot)
         + np.random.default_rng(1).normal(0, 0.002, n))
    np.savetxt(tmp_path / "chirp.csv", x)
    cap = tmp_path / "chirp.ripple.csv"
    assert cli.main(["import", str(tmp_path / "chirp.csv"), "--a-per-unit", "1", "--pwm-hz", "0", "--sample-hz",
                     "10000", "--out", str(cap), "--quiet"]) == 0
    assert cli.main(["ripple", str(cap), "--ripples-per-rev", "6", "--gear-ratio", "1", "--out", str(tmp_path / "o"),
                     "--quiet"]) == 0
    est = pd.read_csv(tmp_path / "o" / "chirp.ripple_speed.csv")
    changing = est[est["reason"].str.startswith("the speed changed inside the window")]
    assert len(changing) >= 5
    assert changing["reason"].str.contains(r"quarters spread [0-9.]+%, [0-9.]+% allowed with the count's noise; "
                                           r"the current's share not read: no Ra or Ke").all()
