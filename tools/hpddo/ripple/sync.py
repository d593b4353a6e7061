"""Any sampling (issue 33, docs/ripple-captures.md): what the ripple count needs from a burst
file that declares how its samples sit against the PWM (hpddo.logs.ripple: `sampling`,
`pwm_hz`, `mains_hz`).

* `prepare`: a free-running burst (`sampling=free`) holds the PWM's own current ripple at
  every phase of the PWM period, aliased all over the band (a 490 Hz PWM at 9.6 kHz puts its
  harmonics at 490, 980, ... and their mirrors), far stronger than the commutation ripple.
  That part is periodic with the PWM, the commutation ripple is not, so the PWM-synchronous
  average is removed: each sample's PWM phase (t pwm_hz, modulo 1; the ratio sample_hz /
  pwm_hz is generally not an integer, so over a burst the samples fall at every phase), the
  samples folded into phase bins and averaged per bin over the burst, that mean (linearly
  interpolated between the bins' centres, around the period) subtracted from each sample.
  A burst too short for it (fewer than MIN_BINS bins of MIN_PER_BIN samples) is refused with
  the reason; a free-running file without pwm_hz is refused as a whole (InputError).
* `fixed_line`: a line at a multiple of the PWM frequency (or the alias of one, within the
  first PWM_HARMONICS harmonics) or of the mains frequency is a fixed line of the supply, not
  the shaft's: the window is never confident on it (estimate_window calls it with its
  candidate line).
* `beside_mains`: a line within a resolution of a mains multiple is not that multiple where one
  least-squares fit of the burst with both (the mains line at its declared frequency, within
  the mains' drift, and the shaft's line free) puts the shaft's line clear of the mains' and
  where the count agrees with it. A window's spectrum resolves 1 / T; two lines closer than that
  are told apart by their fit, as far as the noise lets (its standard error, from the fit).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..logs import ripple as rf
from ..logs.errors import InputError
from .comb import mains_of

MIN_PER_BIN = 32   # samples a phase bin holds on average: its mean carries the commutation ripple and the
#                    noise over sqrt(32) into the subtracted average, where fewer, finer bins follow the PWM
#                    current's kinks better (490 Hz at 9.6 kHz, 0.5 s, 1.4 A peak to peak and a 50 mA ripple:
#                    8 per bin leaves 0.3 mA of PWM and 9.3 mA of leaked ripple rms, 16: 0.5 and 4.9,
#                    32: 1.0 and 3.8, 64: 2.3 and 2.0; test_ripple_captures)
MIN_BINS = 16      # fewer bins cannot follow the PWM current's shape (its two exponential phases)
MAX_BINS = 512     # finer bins than this gain nothing at a kink of the PWM current (8 us at 490 Hz x 256)
PWM_HARMONICS = 20  # the PWM harmonics whose aliases are checked: a PWM current's harmonic h falls as 1 / h^2
#                     (its kinks), the 20th at 1/400 of the first

#: the joint fit of a line beside a mains multiple (beside_mains)
MAINS_APART_Z = 5.0       # the shaft's line lies this many of its standard errors beyond the mains line's drift
MAINS_AGREE_REL = 0.005   # the count agrees with the joint fit within 0.5 % (a tenth of the 5 % a confident
#                           window may be off): further, the mains line pulls the count
MAINS_SEARCH_RES = 1.5    # the shaft's line is sought within 1.5 resolutions of the line found
MAINS_GRID = 10           # grid steps per resolution for the shaft's line (then a parabola through the best three)
MAINS_DRIFT_REL = 0.004   # the mains line's frequency is fitted within 0.4 % of the declared multiple (50 +- 0.2 Hz,
#                           the limits a grid keeps in normal operation; comb.FIXED_REL_TOL's 0.1 % is the usual
#                           drift): a line nearer than that to the multiple is never told from it
HANN_NOISE_BW = 1.5       # the Hann window's equivalent noise bandwidth, in bins: the fit's weights widen its
#                           standard error by about this much over an unweighted fit's

KEY = "fixed_line"
REASON = "the line sits at a multiple of the PWM or mains frequency (a fixed line of the supply, not the shaft's)"
KEY_FOLD = "pwm_fold"
REASON_FOLD = "free-running burst too short to remove the PWM-synchronous average"
KEY_UNSEEN = "pwm_unseen"
REASON_UNSEEN = ("the PWM frequency declared (pwm_hz) does not show in the bursts and a steady line elsewhere does: "
                 "wherever the PWM's lines are, they were neither removed nor known as fixed lines")

#: the least share of a free-running burst's variance its PWM-synchronous average holds where the PWM is at the
#: frequency declared (the twin, 9.6 kHz, 0.5 s: 0.91-0.97 at 490 Hz, 0.20-0.62 at 3.9 kHz; 490.196 declared for a
#: 976.5625 Hz PWM, an UNO's pins 5 and 6: -0.02; 976.5625 declared for 490.196: 0.006)
PWM_SHOWN_MIN = 0.05
#: a line that is the strongest of a raw burst at one frequency (within a resolution) in this share of the
#: bursts or more is steady: the supply's, or a shaft that never changes speed
STEADY_SHARE = 0.5
UNSEEN_MIN_BURSTS = 3  # fewer bursts that can fold tell nothing of the PWM
UNSEEN_REFINE_BURSTS = 5  # the bursts whose fold places the steady line's frequency


def holds_mean(bursts) -> bool:
    """Whether the bursts' mean is the mean current (not an AC-coupled capture, coupling=ac)."""
    return bursts.coupling != rf.AC


def phase_bins(n: int) -> int:
    """The phase bins for a burst of n samples: as many as MIN_PER_BIN each allows, at most MAX_BINS;
    0 where fewer than MIN_BINS fit."""
    b = min(MAX_BINS, n // MIN_PER_BIN)
    return b if b >= MIN_BINS else 0


def remove_pwm_average(x, sample_hz: float, pwm_hz: float):
    """x (one burst, float, free-running at sample_hz) less its PWM-synchronous average:
    (the rest, the number of bins used); (None, 0) where the burst is too short (phase_bins)."""
    x = np.asarray(x, float)
    n = len(x)
    nb = phase_bins(n)
    if nb == 0:
        return None, 0
    phase = (np.arange(n) * (pwm_hz / sample_hz)) % 1.0
    k = np.minimum((phase * nb).astype(np.int64), nb - 1)
    count = np.bincount(k, minlength=nb)
    total = np.bincount(k, weights=x, minlength=nb)
    used = count > 0
    centres = (np.flatnonzero(used) + 0.5) / nb
    means = total[used] / count[used]
    if used.sum() == 1:
        return x - means[0], int(used.sum())
    return x - np.interp(phase, centres, means, period=1.0), int(used.sum())


def pwm_share(x, sample_hz: float, pwm_hz: float) -> float:
    """The share of a burst's variance (about its mean) that its PWM-synchronous average at pwm_hz holds; NaN
    where the burst is too short to fold (phase_bins) or constant. Under 0 where the interpolated average adds
    more than it takes (no waveform at pwm_hz)."""
    x = np.asarray(x, float)
    x = x - x.mean() if len(x) else x
    rest, _ = remove_pwm_average(x, sample_hz, pwm_hz)
    v = float(x @ x) if len(x) else 0.0
    if rest is None or not (v > 0 and math.isfinite(v)):
        return math.nan
    return (v - float(rest @ rest)) / v


def strongest_hz(x, sample_hz: float) -> float:
    """The frequency of a burst's strongest spectral line (Hann window, the mean removed), from 2 resolutions
    up; NaN where the burst holds none."""
    x = np.asarray(x, float)
    n = len(x)
    if n < 8:
        return math.nan
    a = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n)))
    f = np.fft.rfftfreq(n, 1.0 / sample_hz)
    band = f >= 2.0 * sample_hz / n
    if not band.any() or not np.isfinite(a[band]).all() or a[band].max() <= 0:
        return math.nan
    return float(f[band][np.argmax(a[band])])


def pwm_unseen(bursts) -> dict | None:
    """Whether a free-running file's declared PWM frequency is not the PWM's: its synchronous average holds
    under PWM_SHOWN_MIN of the variance in the median burst (of UNSEEN_MIN_BURSTS or more that fold) while
    the raw bursts' strongest line sits at one frequency in STEADY_SHARE of them or more (a PWM at another
    frequency: 490.196 Hz declared for an UNO's 976.5625 Hz pins on the twin, no window confident but 81
    named `multiple` and 24 `damaged` from the PWM's lines). Returns {"share", "bursts", "steady_hz",
    "steady_in"}, or None where the declared PWM shows, nothing steady does, or the file is not free-running
    under a PWM. Where the declared PWM's ripple is only too small to show (a fast PWM behind the winding's
    L / R), the shaft's line is the steady one only at one speed throughout."""
    if bursts.sampling != rf.FREE or not (math.isfinite(bursts.pwm_hz) and bursts.pwm_hz > 0):
        return None
    fs = bursts.sample_hz
    shares = np.array([pwm_share(c, fs, bursts.pwm_hz) for c in bursts.codes])
    ok = np.isfinite(shares)
    if ok.sum() < UNSEEN_MIN_BURSTS or float(np.median(shares[ok])) >= PWM_SHOWN_MIN:
        return None
    f1 = np.array([strongest_hz(c, fs) for c, k in zip(bursts.codes, ok) if k])
    res = np.array([fs / len(c) for c, k in zip(bursts.codes, ok) if k])
    have = np.isfinite(f1)
    if not have.any():
        return None
    f1, res = f1[have], res[have]
    near = np.abs(f1[:, None] - f1[None, :]) <= res[None, :]  # burst j's line within burst j's resolution of i's
    j = int(np.argmax(near.sum(axis=1)))
    n_at = int(near[j].sum())
    if n_at < STEADY_SHARE * int(ok.sum()):
        return None
    # the steady line's frequency to a twentieth of a resolution, where its synchronous average holds most: the
    # frequency to declare (a spectrum's bin put an UNO's 976.5625 Hz at 976.0, where a fold drifts a quarter
    # period over a 0.5 s burst)
    codes = [c for c, k in zip(bursts.codes, ok) if k]
    at = [codes[i] for i in np.flatnonzero(have)[near[j]][:UNSEEN_REFINE_BURSTS]]
    r = float(np.max(res[near[j]]))
    grid = float(np.median(f1[near[j]])) + r * np.linspace(-1.0, 1.0, 41)
    held = np.array([np.nanmean([pwm_share(c, fs, f) for c in at]) for f in grid])
    k = int(np.nanargmax(held)) if np.isfinite(held).any() else len(grid) // 2
    return {"share": float(np.median(shares[ok])), "bursts": int(ok.sum()), "steady_hz": float(grid[k]),
            "steady_share": float(held[k]), "steady_in": n_at}


def unseen_reason(unseen: dict, pwm_hz: float) -> str:
    """The reason of a window, or of a recording, where the declared PWM does not show (pwm_unseen's result):
    the figures and what to declare."""
    return (
        f"{REASON_UNSEEN} ({rf.PWM_HZ}={pwm_hz:.7g}: its synchronous average holds {unseen['share']:.1%} of the "
        f"current's variance in the median burst; the strongest line is steady in {unseen['steady_in']} of "
        f"{unseen['bursts']} bursts, and a synchronous average at {unseen['steady_hz']:.6g} Hz holds "
        f"{unseen['steady_share']:.0%}: where the driver's PWM runs there, or aliases there at this sample rate, "
        f"declare {rf.PWM_HZ}={unseen['steady_hz']:.6g} (an UNO's pins 5 and 6 run at 976.5625 Hz, 3, 9, 10 and 11 "
        f"at 490.196); a motor at a steady speed shows its ripple as a steady line too, so declare it only where the "
        f"PWM is known to be there; where the PWM's ripple is filtered out of the band, {rf.PWM_HZ}=0)")


def prepare(bursts, source: str = "bursts"):
    """The bursts as the count needs them: synchronous ones as they are; free-running ones with the
    PWM-synchronous average removed from each burst (codes then floats, in codes), a burst too short
    for it marked refused (Bursts.refused). InputError where a free-running file declares no pwm_hz, or
    where there is no burst at all."""
    if len(bursts) == 0:
        raise InputError(f"{source}: no bursts (the header and no rows): nothing to count")
    if bursts.sampling != rf.FREE or bursts.pwm_hz == 0:  # synchronous, or no PWM at all (a DC supply)
        return bursts
    if not (math.isfinite(bursts.pwm_hz) and bursts.pwm_hz > 0):
        raise InputError(f"{source}: {rf.SAMPLING}={rf.FREE} without {rf.PWM_HZ}: the PWM's own current ripple "
                         f"cannot be told from the commutation ripple; declare # {rf.PWM_HZ}=HZ (the UNO's default "
                         "analogWrite: 490.196)")
    codes, refused = [], []
    for c in bursts.codes:
        rest, nb = remove_pwm_average(np.asarray(c, float), bursts.sample_hz, bursts.pwm_hz)
        if rest is None:
            codes.append(np.asarray(c, float))
            refused.append(f"{REASON_FOLD} ({len(c)} samples, fewer than {MIN_BINS} phase bins of {MIN_PER_BIN})")
        else:
            # the burst's mean is kept: the floor and the current's own changes read it
            codes.append(rest + float(np.mean(c)))
            refused.append("")
    return dataclasses.replace(bursts, codes=codes, refused=tuple(refused))


def pwm_lines(bursts) -> list:
    """The PWM's harmonics up to PWM_HARMONICS as (Hz, what), where they alias at sample_hz; [] without a PWM."""
    fs = bursts.sample_hz
    out = []
    if math.isfinite(bursts.pwm_hz) and bursts.pwm_hz > 0:
        for h in range(1, PWM_HARMONICS + 1):
            f = h * bursts.pwm_hz
            alias = abs((f + fs / 2) % fs - fs / 2)
            what = f"{h} x the PWM's {bursts.pwm_hz:g} Hz" + ("" if abs(alias - f) < 1e-9 else f", aliased at {fs:g} S/s")
            out.append((alias, what))
    return out


def mains_lines(bursts, f_hz: float, either_mains: bool = False) -> list:
    """The mains frequency's multiple nearest f_hz as (Hz, what), where the file declares a mains frequency
    (whatever it is: a file may declare any positive one, 1 mHz too, whose multiples near a line in the kHz
    are millions: the nearest is computed, not listed). With either_mains, where the file declares none, the
    nearest multiple of every mains frequency (comb.MAINS_HZ: 50 and 60 Hz), since hum is in a current
    whether the file says so or not (comb.mains_of: none where it declares mains_hz=0, no mains)."""
    if math.isfinite(bursts.mains_hz) and bursts.mains_hz > 0:
        mains = [(bursts.mains_hz, "the mains' {:g} Hz".format(bursts.mains_hz))]
    elif either_mains:
        mains = [(m, f"{m:g} Hz, a mains frequency (the file declares none)") for m in mains_of(bursts)]
    else:
        mains = []
    out = []
    for m, name in mains:
        h = max(1, round(f_hz / m)) if math.isfinite(f_hz) else 1
        out.append((h * m, f"{h} x {name}"))
    return out


def fixed_lines(bursts, f_hz: float, either_mains: bool = False) -> list:
    """The supply's fixed lines nearest f_hz as (Hz, what): pwm_lines, then mains_lines."""
    return pwm_lines(bursts) + mains_lines(bursts, f_hz, either_mains)


def beside_mains(x, fs: float, f_line: float, f_mains: float, res_hz: float) -> dict:
    """One burst x (A, at fs) fitted by least squares, Hann-weighted (the other lines' leakage held down),
    as an offset, a slope, a sinusoid at the mains multiple f_mains (its frequency within the mains'
    drift, MAINS_DRIFT_REL) and one sinusoid near f_line (within MAINS_SEARCH_RES resolutions): the
    shaft's line told from the mains' where the two lie closer than the spectrum resolves. Returns
    {f_hz: the shaft's line, se_hz: its standard error, drift_hz: the mains line's allowance,
    apart: whether f_hz lies MAINS_APART_Z standard errors beyond that allowance}. The standard error
    is the profile's curvature at the minimum with the residual's variance (times HANN_NOISE_BW for the
    weights); a residual that holds other lines or coloured noise makes it an estimate, which the
    margin (MAINS_APART_Z) allows for."""
    x = np.asarray(x, float)
    n = len(x)
    drift = MAINS_DRIFT_REL * f_mains
    out = {"f_hz": math.nan, "se_hz": math.inf, "drift_hz": drift, "apart": False}
    if n < 16 or not (math.isfinite(f_line) and f_line > 0 and res_hz > 0):
        return out
    t = (np.arange(n) - (n - 1) / 2.0) / fs
    w = np.hanning(n + 2)[1:-1]
    f1 = f_line + res_hz * np.arange(-MAINS_SEARCH_RES * MAINS_GRID, MAINS_SEARCH_RES * MAINS_GRID + 1) / MAINS_GRID
    f1 = f1[f1 > 0]
    f2 = f_mains + drift * np.linspace(-1.0, 1.0, 9)

    def tones(fr):
        ph = 2 * math.pi * np.outer(t, fr)
        return np.cos(ph), np.sin(ph)

    base = np.column_stack([np.ones(n), t])
    wb = w[:, None] * base                      # n x 2
    g_bb = base.T @ wb                          # 2 x 2
    y_b = wb.T @ x
    xx = float(w @ (x * x))

    def rss_of(f1, f2):
        """The weighted residual's sum of squares at each pair (f1, f2): F1 x F2."""
        c1, s1 = tones(f1)
        c2, s2 = tones(f2)
        T1 = np.stack([c1, s1], axis=-1)            # n x F1 x 2
        T2 = np.stack([c2, s2], axis=-1)            # n x F2 x 2
        F1, F2 = len(f1), len(f2)
        A1, A2 = T1.reshape(n, 2 * F1), T2.reshape(n, 2 * F2)
        wA1 = w[:, None] * A1
        g_b1 = (wb.T @ A1).reshape(2, F1, 2).transpose(1, 0, 2)       # F1 x 2 x 2
        g_b2 = (wb.T @ A2).reshape(2, F2, 2).transpose(1, 0, 2)       # F2 x 2 x 2
        g_11 = np.einsum("nfk,nfl->fkl", wA1.reshape(n, F1, 2), T1)
        g_22 = np.einsum("nfk,nfl->fkl", (w[:, None] * A2).reshape(n, F2, 2), T2)
        g_12 = (wA1.T @ A2).reshape(F1, 2, F2, 2).transpose(0, 2, 1, 3)  # F1 x F2 x 2 x 2
        y_1 = ((w * x) @ A1).reshape(F1, 2)
        y_2 = ((w * x) @ A2).reshape(F2, 2)
        # per pair (f1, f2) the normal equations of [offset, slope, cos f1, sin f1, cos f2, sin f2]
        G = np.zeros((F1, F2, 6, 6))
        G[:, :, :2, :2] = g_bb
        G[:, :, :2, 2:4] = g_b1[:, None]
        G[:, :, 2:4, :2] = np.swapaxes(g_b1, 1, 2)[:, None]
        G[:, :, :2, 4:] = g_b2[None]
        G[:, :, 4:, :2] = np.swapaxes(g_b2, 1, 2)[None]
        G[:, :, 2:4, 2:4] = g_11[:, None]
        G[:, :, 4:, 4:] = g_22[None]
        G[:, :, 2:4, 4:] = g_12
        G[:, :, 4:, 2:4] = np.swapaxes(g_12, 2, 3)
        Y = np.zeros((F1, F2, 6))
        Y[:, :, :2] = y_b
        Y[:, :, 2:4] = y_1[:, None]
        Y[:, :, 4:] = y_2[None]
        ridge = 1e-12 * np.trace(G, axis1=2, axis2=3)[..., None, None] * np.eye(6)
        coef = np.linalg.solve(G + ridge, Y[..., None])[..., 0]
        return xx - np.einsum("abk,abk->ab", coef, Y)

    rss = rss_of(f1, f2)
    j, i = np.unravel_index(int(np.argmin(rss)), rss.shape)
    if j == 0 or j == len(f1) - 1:  # the least at the search's edge: no line of its own found here
        out["f_hz"] = float(f1[j])
        return out
    # then finer about the least, in both frequencies (a mains line a tenth of a grid step off leaves a part of
    # itself as large as a weak ripple)
    df2 = f2[1] - f2[0]
    f1 = np.linspace(f1[j - 1], f1[j + 1], 2 * MAINS_GRID + 1)
    f2 = np.clip(f2[i] + df2 * np.linspace(-1.0, 1.0, 2 * MAINS_GRID + 1), f_mains - drift, f_mains + drift)
    profile = rss_of(f1, f2).min(axis=1)  # each f1 with the mains frequency at its best
    j = int(np.argmin(profile))
    if j == 0 or j == len(f1) - 1:  # the least at the search's edge: no line of its own found here
        out["f_hz"] = float(f1[j])
        return out
    a, b, c = profile[j - 1], profile[j], profile[j + 1]
    h = f1[1] - f1[0]
    curv = (a - 2 * b + c) / (h * h)
    if not curv > 0:
        out["f_hz"] = float(f1[j])
        return out
    d = 0.5 * (a - c) / (a - 2 * b + c)
    f_hat = float(f1[j] + d * h)
    s_min = max(float(b - 0.25 * (a - c) * d), 0.0)
    var = s_min / max(float(w.sum()) - 6.0, 1.0)   # the residual's variance per unit weight
    se = math.sqrt(HANN_NOISE_BW * 2.0 * var / curv)
    out.update(f_hz=f_hat, se_hz=se, apart=abs(f_hat - f_mains) > drift + MAINS_APART_Z * se)
    return out


def fixed_line(bursts, k: int, f_hz: float, resolution_hz: float, placed: bool = True, x=None,
               agree_hz: float | None = None):
    """Why window k cannot be confident on a line at f_hz (its spectrum resolving resolution_hz):
    (key, reason), or None. A refused fold (prepare), or a line within one resolution (and 0.2 %,
    the comb grid's step) of a PWM or mains line (fixed_lines). Near a mains line, where the window's
    samples x are given, the line is the shaft's where a joint fit of both (beside_mains) puts it clear
    of the mains line and within agree_hz of f_hz (the count agrees with the fit; None: MAINS_AGREE_REL
    of f_hz). Where the file declares no mains
    frequency and nothing places the line (placed False: no rotation comb around it, which leaves the
    mains' multiples out, and no back-EMF prior or speed range, whose spread a fixed line far from the
    shaft's speed leaves), a line at a multiple of 50 or 60 Hz is taken for hum too: alone it cannot
    be told from the hum of a standing shaft (twin: 5 mA at 50 Hz with the drive on and the shaft
    standing, counted as 114 RPM). Where a comb places the line, or a prior that holds it and refuses a
    standing shaft (0 RPM further than max_prior_z of the prior's sd: estimate_window's line_placed),
    undeclared mains are not assumed: on the twin's recordings a quarter to half of the windows' lines sit
    within a resolution of a multiple of 50 or 60 Hz. A prior whose spread holds 0 RPM does not place a
    line: a stall at 3.3 A where V - I Ra is small against Ra's error times I (the independent commutator
    simulation, studies/ripple_independent.py) put the prior at -60 RPM and its spread past 300 RPM, and the
    50 Hz hum was counted, confident, as 300 RPM."""
    why = bursts.refusal(k)
    if why:
        return KEY_FOLD, why
    if not math.isfinite(f_hz):
        return None
    tol = resolution_hz + 0.002 * f_hz
    for f, what in pwm_lines(bursts):
        if abs(f_hz - f) <= tol:
            return KEY, f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz)"
    for f, what in mains_lines(bursts, f_hz, either_mains=not placed):
        if abs(f_hz - f) > tol:
            continue
        if x is None:
            return KEY, f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz)"
        fit = beside_mains(x, bursts.sample_hz, f_hz, f, resolution_hz)
        agree = MAINS_AGREE_REL * f_hz if agree_hz is None else agree_hz
        if not fit["apart"] and not math.isfinite(fit["se_hz"]):  # (a fuzzing round printed "295.94 +- inf Hz")
            return KEY, (f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz; fitted beside it, no line of its own "
                         f"within {MAINS_SEARCH_RES} resolutions of the count)")
        if not fit["apart"]:
            return KEY, (f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz; fitted beside it, the line is at "
                         f"{fit['f_hz']:.2f} +- {fit['se_hz']:.2g} Hz: not clear of the mains line's "
                         f"{fit['drift_hz']:.2g} Hz drift)")
        if abs(fit["f_hz"] - f_hz) > agree:
            return KEY, (f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz: the mains line pulls the count; fitted "
                         f"beside it, the line is at {fit['f_hz']:.2f} Hz)")
    return None
