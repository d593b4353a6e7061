"""A shaft that stands: a stall (the drive on, current flowing, no ripple line over a span and a
back-EMF prior too low for a count; `count_stalls`) and the standing shaft of the drive off
(`standing`: no current, the open terminals' back-EMF under a few mV)."""
from __future__ import annotations

import math

import numpy as np

from .line import spectrum
from .options import REASONS, Options
from .spans import steady_spans


#: the reasons after the spans under which a shaft may stand: no line, too few cycles, a rival line, or a
#: fixed line far from the prior (interference while the shaft stands)
STALL_KEYS = ("few_cycles", "not_found", "ambiguous", "rival", "far")


def _upper_speed(prior_rpm: float, sd_above_rpm: float, rel_sd: float, z: float) -> float:
    """The speed n above the prior p that lies z of the prior's sd from it, where that sd grows with
    n as in prior.prior_like: (n - p)^2 = z^2 (sd_above^2 + (rel_sd n)^2), the larger root; inf where
    Ke's relative error alone lets every speed within z sd (z rel_sd >= 1)."""
    a = 1.0 - (z * rel_sd) ** 2
    if a <= 0:
        return math.inf
    p = prior_rpm
    disc = p * p - a * (p * p - (z * sd_above_rpm) ** 2)
    return (p + math.sqrt(max(disc, 0.0))) / a


def speed_floor_rpm(window_s: float, opts: Options) -> float:
    """The output speed at which window_s seconds of current hold opts.min_cycles ripples, RPM:
    under it a window's own count cannot be confident (22.7 RPM for 0.5 s windows and 26.4
    ripples per output revolution)."""
    return opts.min_cycles / window_s / (opts.ripples_per_rev * opts.gear_ratio) * 60.0


def count_stalls(bursts, duty, est, opts: Options, rpm_per_A=None):
    """A stall where the data determine it: the drive on, the current above the floor, and the
    shaft standing (a jammed pump or gear). A standing rotor commutates nothing, so there is no
    ripple to count; these windows fail their count (STALL_KEYS) one at a time and over a span.
    Over each span of steady windows (steady_spans with STALL_KEYS: the same nonzero duty, bursts
    contiguous, not the first window after a change of duty), two facts of physics, both required:

    1. the back-EMF prior cannot turn the shaft fast enough for a window's count: the span's
       prior (the median of its windows' priors) plus opts.stall_prior_z of its upper sd
       (sqrt(sd_above^2 + (prior_rel_sd n)^2), m2_prior_sd_rpm) lies under the speed floor
       (speed_floor_rpm of the span's median burst);
    2. the span's current holds no ripple line: in its spectrum (trend removed, Hann window) the
       strongest bin from stall_cycles / S (S the span's length, s) to the ripple frequency of the
       highest speed the prior allows (max_prior_z sd above it, at least the speed floor) is under
       opts.stall_snr times the band's median power. A shaft turning at n makes a line at
       N G n / 60 Hz with N G n S / 60 cycles over the span; one of stall_cycles or more would
       stand out, so the span's mean speed is |n| < 60 stall_cycles / (N G S).

    A window's own speed may differ from the span's mean; at the span's constant duty a change
    of the speed is a change of the back-EMF, -Ra dI, so the windows' mean currents bound it:
    the bound adds rpm_per_A x (max - min of the windows' mean currents). A span is a stall
    where that bound (`rpm_bound`, RPM) is at most opts.stall_max_rpm: each of its windows takes
    rpm 0, `stall` True, key "stall", the bound, a reason that says what was seen, and the
    confidence 1 - bound / (2 stall_max_rpm) (0.5..1). `confident` stays False: a stall is not a
    count of the ripple (the consumers of counted speeds, check_ratio, count_sd_rpm, span_reference,
    are unchanged); the ripple reference labels it (reference.swap). Needs a prior and rpm_per_A
    (Ra / Ke). Where 2. finds a line, but none at opts.creep_cycles ripples a window or faster, the span
    is a creep (_creep): key "creep", `rpm_bound` the speed of creep_cycles ripples a window, never
    confident. Without a prior and rpm_per_A, or with opts.stall_max_rpm 0, est is returned with `stall` False and
    `rpm_bound` NaN everywhere. est: estimate()'s DataFrame (after count_steady_spans). Returns a copy."""
    est = est.copy()
    est["stall"] = False
    est["rpm_bound"] = np.nan
    if not opts.stall_max_rpm > 0 or rpm_per_A is None or not np.isfinite(rpm_per_A) or duty is None:
        return est
    fs = bursts.sample_hz
    per_rev_out = opts.ripples_per_rev * opts.gear_ratio
    keys = est["key"].to_numpy()
    prior = est["rpm_prior_used"].to_numpy(float)
    sd_above = est["prior_sd_above"].to_numpy(float)
    i_mean = est["i_mean_A"].to_numpy(float)
    duty = np.asarray(duty, float)
    for a, e in steady_spans(bursts, duty, keys, opts, STALL_KEYS):
        if not (np.isfinite(prior[a:e]).all() and np.isfinite(i_mean[a:e]).all() and (i_mean[a:e] >= opts.floor_A).all()):
            continue
        lengths = np.array([len(c) for c in bursts.codes[a:e]])
        S = float(lengths.sum()) / fs
        rpm_floor = speed_floor_rpm(float(np.median(lengths)) / fs, opts)
        pr, sa = float(np.median(prior[a:e])), float(np.median(sd_above[a:e]))
        n_up = pr + opts.stall_prior_z * math.hypot(sa, opts.prior_rel_sd * max(pr, 0.0))
        if not n_up < rpm_floor:  # 1. the prior lets the shaft turn fast enough for a window's count
            continue
        n_hi = max(_upper_speed(pr, sa, opts.prior_rel_sd, opts.max_prior_z), rpm_floor)
        f_min, f_max = opts.stall_cycles / S, min(n_hi * per_rev_out / 60.0, 0.45 * fs)
        f, p = spectrum(np.concatenate([bursts.current_A(k) for k in range(a, e)]), fs, pad=4)
        band = (f >= f_min) & (f <= f_max)
        if band.sum() < 16:
            continue
        med = max(float(np.median(p[band])), 1e-30)
        snr = float(p[band].max() / med)
        if snr >= opts.stall_snr:  # 2. a line in the band: something turns (a creep where too slowly for a count)
            _creep(est, a, e, f, p, med, f_max, float(np.median(lengths)) / fs, S, float(duty[a]), pr, n_up,
                   rpm_floor, per_rev_out, rpm_per_A * float(i_mean[a:e].max() - i_mean[a:e].min()), opts)
            continue
        bound = 60.0 * opts.stall_cycles / (per_rev_out * S) + rpm_per_A * float(i_mean[a:e].max() - i_mean[a:e].min())
        if bound > opts.stall_max_rpm:
            continue
        idx = est.index[a:e]
        reason = (f"{REASONS['stall']}: at duty {duty[a]:g} with {1000 * float(i_mean[a:e].mean()):.0f} mA over "
                  f"{S:.1f} s ({e - a} windows) the strongest line from {f_min:.2f} to {f_max:.1f} Hz is "
                  f"{snr:.1f}x the band's median power (under {opts.stall_snr:g}); the prior {pr:.1f} RPM + "
                  f"{opts.stall_prior_z:g} sd = {n_up:.1f} RPM, under the speed floor {rpm_floor:.1f} RPM; "
                  f"|n| < {bound:.2f} RPM")
        est.loc[idx, ["rpm", "f_Hz", "cycles"]] = 0.0
        est.loc[idx, "snr"] = snr
        est.loc[idx, "confidence"] = 1.0 - bound / (2.0 * opts.stall_max_rpm)
        est.loc[idx, "key"] = "stall"
        est.loc[idx, "reason"] = reason
        est.loc[idx, "stall"] = True
        est.loc[idx, "rpm_bound"] = bound
    return est


def _creep(est, a, e, f, p, med, f_max, window_s, S, duty, pr, n_up, rpm_floor, per_rev_out, move_rpm, opts):
    """count_stalls' creep: the span a .. e (S s) holds a ripple line (a bin of f, p at least stall_snr x
    med), but none from opts.creep_cycles ripples a window (window_s) up to f_max, and its prior is
    under the speed floor (count_stalls' 1.): the shaft turns, slower than creep_cycles ripples a
    window. Its windows take key "creep", the bound 60 creep_cycles / (N G window_s) + move_rpm (the
    windows' own speeds about the span's mean, Ra dI / Ke) in `rpm_bound`, and stay not confident
    (their rpm NaN: a bound, not a count). Nothing where the line lies at creep_cycles a window or
    faster (a count the windows failed: their own reasons stand) or opts.creep_cycles is 0."""
    f_creep = opts.creep_cycles / window_s
    fast = (f >= f_creep) & (f <= f_max)
    if not opts.creep_cycles > 0 or not fast.any() or float(p[fast].max()) >= opts.stall_snr * med:
        return
    slow = (f >= opts.stall_cycles / S) & (f < f_creep)
    j = int(np.argmax(np.where(slow, p, -np.inf)))
    bound = 60.0 * f_creep / per_rev_out + move_rpm
    idx = est.index[a:e]
    est.loc[idx, ["rpm", "f_Hz", "cycles", "confidence"]] = [math.nan, math.nan, math.nan, 0.0]
    est.loc[idx, "snr"] = float(p[j] / med)
    est.loc[idx, "key"] = "creep"
    est.loc[idx, "reason"] = (
        f"{REASONS['creep']}: at duty {duty:g} over {S:.1f} s ({e - a} windows) the strongest line, "
        f"{f[j]:.2f} Hz ({60.0 * f[j] / per_rev_out:.2f} RPM), is {p[j] / med:.0f}x the band's median power, none "
        f"from {f_creep:.1f} Hz ({opts.creep_cycles:g} ripples a window) to {f_max:.1f} Hz reaches "
        f"{opts.stall_snr:g}x; the prior {pr:.1f} RPM + {opts.stall_prior_z:g} sd = {n_up:.1f} RPM, under the speed "
        f"floor {rpm_floor:.1f} RPM; |n| < {bound:.2f} RPM")
    est.loc[idx, "rpm_bound"] = bound


STANDING = "standing"
STANDING_REASON = ("standing: the drive off (duty 0) and no current, so the open terminals show the back-EMF, "
                   "and |V| is under the threshold: 0 RPM from the back-EMF, not counted")
STANDING_CONFIDENCE = 1.0  # the back-EMF bounds the speed to |V| / Ke, under a quarter RPM: no count is surer


def standing(est, duty, v_V, opts: Options) -> np.ndarray:
    """The windows where the shaft stands by the back-EMF, one bool per row of est (estimate()'s
    rows; duty and v_V per window): the drive off (duty 0, est's `coasting`), no armature current
    (the burst's mean under opts.floor_A), so nothing flows through the winding and the terminals
    are open, and the terminal voltage, which is then the back-EMF Ke w, under opts.standing_V in
    magnitude. A speed measurement from the back-EMF where the ripple has nothing to count (no
    current, no ripple), valid for a driver that leaves the terminals open when off (the bench's
    low-side switch with its freewheel diode, which conducts only while current flows); a driver
    that brakes (shorts the terminals) makes V = 0 while the shaft turns, and drives current,
    which the current condition refuses where it is above the floor. Used by the ripple
    reference (reference.swap) to label those rows 0 RPM with STANDING_CONFIDENCE."""
    duty = np.asarray(duty, float)
    v = np.asarray(v_V, float)
    i = est["i_mean_A"].to_numpy(float)
    if not opts.standing_V > 0:
        return np.zeros(len(est), bool)
    return ((est["key"].to_numpy() == "coasting") & (duty == 0.0) & np.isfinite(v) & (np.abs(v) < opts.standing_V)
            & np.isfinite(i) & (np.abs(i) < opts.floor_A))
