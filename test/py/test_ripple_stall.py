"""Issue 23: a stall (ripple.count_stalls; docs/ripple-counting.md, "Speed from the ripple", step 6;
its figures docs/ripple-accuracy.md, "Stall"): the drive on, the current above the floor and the
shaft standing, named with the bound the data give; a slowly turning shaft is not called one."""
import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from hpddo.logs import ripple as rf
from hpddo.ripple.log import speed_of_log
from hpddo.ripple.options import Options, REASONS
from hpddo.ripple.stall import count_stalls, standing
from hpddo.studies import ripple as study

FS = 2000.0        # samples per second of the synthetic bursts
WINDOW_S = 0.5
OPTS = Options(6, 4.4)
PER_REV_OUT = 6 * 4.4   # ripples per output revolution
RPM_PER_A = 116.0       # Ra / Ke of the bench (4.5 ohm, 0.37 V s/rad) in RPM per A


def _bursts(rpm, windows=20, i_A=0.30, ripple_A=0.015, seed=1, step_A=0.0):
    """Contiguous bursts of a shaft turning at rpm (output), duty 0.2: the mean current i_A (plus
    step_A from the middle window on), a commutation ripple of ripple_A (5 % of 0.3 A, a third of the
    twin's brushes) at N G rpm / 60 Hz, the twin's brush bounce (2 % of I, white) and 10 mA ADC steps."""
    rng = np.random.default_rng(seed)
    n = int(FS * WINDOW_S)
    t = np.arange(windows * n) / FS
    f = PER_REV_OUT * rpm / 60.0
    i = i_A + step_A * (t >= t[-1] / 2) + ripple_A * np.cos(2 * math.pi * f * t + 0.3)
    i = i + 0.02 * i_A * rng.standard_normal(len(t))
    a_per_code = 0.009765625
    codes = np.round(i / a_per_code).astype(np.int64)
    b = rf.Bursts({}, FS, a_per_code, np.arange(windows), np.arange(windows) * WINDOW_S,
                  [codes[k * n:(k + 1) * n] for k in range(windows)])
    return b, np.full(windows, 0.2)


def _est(b, prior_rpm=8.0, sd_above_rpm=8.4, key="not_found"):
    """estimate()'s columns that count_stalls reads: every window failed its count (key), the prior and
    its upper sd as the stiff gearbox's at duty 0.2 (m2_prior_sd_rpm)."""
    n = len(b)
    return pd.DataFrame({"seq": b.seq, "rpm": np.nan, "rpm_fft": np.nan, "f_Hz": np.nan, "cycles": np.nan,
                         "snr": 1.0, "confidence": 0.0, "reason": REASONS.get(key, ""), "key": key,
                         "confident": False, "i_mean_A": [b.current_A(k).mean() for k in range(n)],
                         "rpm_prior_used": prior_rpm, "prior_sd_below": 15.0, "prior_sd_above": sd_above_rpm})


def test_a_stall_is_named_with_the_bound_the_data_give():
    b, duty = _bursts(0.0)
    est = count_stalls(b, duty, _est(b), OPTS, RPM_PER_A)
    stall = est["stall"].to_numpy()
    # the first window (after the duty changed) is no part of a span; the 19 others, 9.5 s, are one span
    assert not stall[0] and stall[1:].all()
    assert (est["rpm"].to_numpy()[1:] == 0).all() and (est["key"].to_numpy()[1:] == "stall").all()
    assert not est["confident"].any()  # a stall is not a count of the ripple
    i = est["i_mean_A"].to_numpy()[1:]
    bound = 60.0 * OPTS.stall_cycles / (PER_REV_OUT * 19 * WINDOW_S) + RPM_PER_A * (i.max() - i.min())
    assert np.allclose(est["rpm_bound"].to_numpy()[1:], bound)
    assert 0.7 < bound < OPTS.stall_max_rpm  # 3 cycles over 9.5 s: 0.72 RPM, and the windows' current steps
    assert np.allclose(est["confidence"].to_numpy()[1:], 1 - bound / (2 * OPTS.stall_max_rpm))
    reason = est["reason"].to_numpy()[1]
    assert reason.startswith("stall:") and f"|n| < {bound:.2f} RPM" in reason and "9.5 s (19 windows)" in reason
    assert np.isnan(est["rpm_bound"].to_numpy()[0])
    # off: no stall, the columns there
    off = count_stalls(b, duty, _est(b), dataclasses.replace(OPTS, stall_max_rpm=0.0), RPM_PER_A)
    assert not off["stall"].any() and off["rpm_bound"].isna().all()
    assert not count_stalls(b, duty, _est(b), OPTS, None)["stall"].any()  # no Ra / Ke: no bound


@pytest.mark.parametrize("rpm", [3.0, 1.5, 1.0])
def test_a_slow_turn_is_not_called_a_stall(rpm):
    # 3 RPM: unseen x0.25 at duty 0.2 (0.7 ripple cycles a window); 1 RPM: 4.2 cycles over the span,
    # just over the 3 the bound allows for (0.72 RPM)
    b, duty = _bursts(rpm)
    est = count_stalls(b, duty, _est(b), OPTS, RPM_PER_A)
    assert not est["stall"].any()


def test_the_bound_is_right_a_shaft_at_the_bound_shows_its_line():
    # a shaft turning exactly at the bound a span of 19 windows states (stall_cycles over it) is seen
    rpm = 60.0 * OPTS.stall_cycles / (PER_REV_OUT * 19 * WINDOW_S)
    for seed in (1, 2, 3):
        b, duty = _bursts(rpm, seed=seed)
        assert not count_stalls(b, duty, _est(b), OPTS, RPM_PER_A)["stall"].any(), seed


def test_no_stall_where_the_prior_lets_the_shaft_turn_fast_enough_for_a_count():
    b, duty = _bursts(0.0)
    # the prior 18 RPM + 1 sd (hypot(6.4, 0.15 x 18) = 6.9) = 24.9 RPM, over the speed floor 22.7 RPM
    assert not count_stalls(b, duty, _est(b, prior_rpm=18.0, sd_above_rpm=6.4), OPTS, RPM_PER_A)["stall"].any()
    # the same with the prior's weight halved: a stall
    opts = dataclasses.replace(OPTS, stall_prior_z=0.5)
    assert count_stalls(b, duty, _est(b, prior_rpm=18.0, sd_above_rpm=6.4), opts, RPM_PER_A)["stall"][1:].all()
    # no prior: no stall
    assert not count_stalls(b, duty, _est(b, prior_rpm=np.nan), OPTS, RPM_PER_A)["stall"].any()


def test_a_current_step_inside_the_span_widens_the_bound_past_a_stall():
    # a 10 mA step of the current at constant duty: the back-EMF moved by Ra dI, 1.2 RPM of speed
    b, duty = _bursts(0.0, step_A=0.010)
    est = count_stalls(b, duty, _est(b), OPTS, RPM_PER_A)
    assert not est["stall"].any()


def test_a_window_with_a_count_is_no_part_of_a_stall_span():
    b, duty = _bursts(0.0)
    est = _est(b)
    est.loc[10, ["key", "confident"]] = ["", True]  # a confident count in the middle: two runs of 9 windows
    out = count_stalls(b, duty, est, OPTS, RPM_PER_A)
    assert not out["stall"][10]
    # 9 windows (4.5 s) bound the mean speed to 3 cycles / (26.4 x 4.5 s) = 1.5 RPM: over stall_max_rpm
    assert not out["stall"].any()


@pytest.mark.slow
def test_the_stiff_gearbox_stall_is_named_and_unseen_slow_turn_is_not():
    r = study.run_scenario(dataclasses.replace({s.name: s for s in study.SCENARIOS}["low_speed_high_load"],
                                               protocols=("sweep",)))
    assert r["stalls"] >= 50 and r["false_stalls"] == 0 and r["stall_where_shaft_stands"] == r["stalls"]
    assert r["stall_bound_rpm_max"] <= Options(6, 4.4).stall_max_rpm
    assert r["covered_share_above_floor"] > r["confident_share_above_floor"]
    assert r["confident_at_standstill"] == 0
    # unseen at a quarter length: duty 0.2 turns the shaft at 3.1-3.7 RPM (0.7 ripple cycles a window)
    u = study.run_scenario(dataclasses.replace(study.SCENARIOS[0], protocols=("unseen",), time_scale=0.25, seed=1))
    assert u["stalls"] == 0 and u["false_stalls"] == 0


@pytest.mark.slow
def test_the_ripple_reference_labels_a_stall_zero_rpm_weighted_by_its_confidence(tmp_path, capsys):
    from hpddo import cli
    from hpddo.logs import benchlog
    from hpddo.ripple import reference
    from hpddo.twin import generate, params

    bench = dataclasses.replace(params.preset("default"), tc_gen_nm=0.12)  # the stiff gearbox: stands at duty 0.2
    g = generate.generate(bench, "sweep", 2.0, 1, out_dir=tmp_path, ripple=params.ripple_burst(),
                          preset_name="default")
    path = tmp_path / "sweep.csv"
    log = benchlog.read_log(path)
    ref = reference.Ripple(6, 4.4)
    df, _, weight, rec = ref(path, log.df, log.meta)
    est, _, _ = speed_of_log(path, log.df, log.meta, ref.options())
    rows = est["row"].to_numpy()
    stall = est["stall"].to_numpy()
    assert stall.sum() >= 50 and rec["stall_labelled"] == int(stall.sum())
    got = df["rpm_ref"].to_numpy()
    assert (got[rows[stall]] == 0).all()
    assert np.array_equal(weight[rows[stall]], est["confidence"].to_numpy()[stall])
    assert (weight[rows[stall]] > 0.5).all() and (weight[rows[stall]] <= 1).all()
    assert (g["truth"]["rpm_true"].to_numpy()[rows[stall]] == 0).all()  # the shaft stands there
    assert (log.df["rpm_ref"].to_numpy()[rows[stall]] == 0).all()      # and the encoder reads 0, as the label
    assert "stall" not in rec["left_out_by_reason"]
    assert rec["kept"] == int(est["confident"].sum() + stall.sum()
                              + standing(est, log.df["duty"].to_numpy()[rows], log.df["v_V"].to_numpy()[rows],
                                            ref.options()).sum())
    assert "a stall" in reference.line("sweep", rec)
    assert reference.pooled({"sweep": rec})["stall_labelled"] == rec["stall_labelled"]
    # hpddo ripple writes the stall and its bound, and says how many
    assert cli.main(["ripple", str(path), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--out",
                     str(tmp_path / "out"), "--quiet"]) == 0
    assert f"a stall (0 RPM within its bound) on {int(stall.sum())}" in capsys.readouterr().out
    written = pd.read_csv(tmp_path / "out" / "sweep.ripple_speed.csv")
    assert np.array_equal(written["stall"].to_numpy(bool), stall)
    assert (written["rpm_ripple"].to_numpy()[stall] == 0).all()
    assert np.allclose(written["rpm_bound"].to_numpy()[stall], est["rpm_bound"].to_numpy()[stall], rtol=1e-5)
    assert written["rpm_bound"].isna().to_numpy()[~stall].all()
