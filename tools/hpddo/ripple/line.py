"""Which line of the current's spectrum is the ripple: the spectrum of a window, the power of a
line, the sub-harmonic family weighed beside it (count.estimate_window searches with them), and
the line's identity over a whole recording (`identity_of_recording`)."""
from __future__ import annotations

import math

import numpy as np

from . import sync
from .options import REASONS, Options


#: the share of the windows that must agree on one ripples per revolution for it to be named (hpddo ripple
#: --calibrate), and for the combs to check the figure given where nothing else sets the speed's scale
CALIBRATE_AGREE = 0.8
#: ... and the fewest windows that must show it
CALIBRATE_MIN_WINDOWS = 5

FAMILY = (2, 3, 6)  # the sub-harmonics f/2, f/3, f/6 of rotor asymmetry
ALTERNATIVES = (2.0, 3.0, 1.5, 0.5, 1 / 3, 2 / 3)
# the weight of each sub-harmonic's power in a candidate's evidence: small enough that the main
# line's own second harmonic (2 f, whose f/2 is the main line) does not rival the main line
FAMILY_WEIGHT = 0.25


def spectrum(x, fs, pad=8):
    n = len(x)
    t = np.arange(n)
    xd = x - np.polyval(np.polyfit(t, x, 1), t)
    nfft = 1 << int(math.ceil(math.log2(n * pad)))
    a = np.abs(np.fft.rfft(xd * np.hanning(n), nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    return f, a


def line_power(f_grid, p_max, f):
    """Power of the strongest bin within half a resolution of f (p_max: the max-filtered spectrum)."""
    return np.interp(f, f_grid, p_max, left=0.0, right=0.0)


def comb_windows(est) -> np.ndarray:
    """The windows of an estimate (count.estimate's DataFrame) whose lines form a rotation comb (`multiple` > 0),
    not those named `damaged`: a damaged commutator's even lines are not the comb."""
    return (est["multiple"].to_numpy(int) > 0) & (est["key"].to_numpy() != "damaged")


def damaged_windows(est) -> np.ndarray:
    """The windows of an estimate named `damaged`: a rotation comb whose health lines name a damaged commutator.
    Their spacing is no rotation's to trust, and where the commutator is damaged the other windows' combs may
    take the fault's even lines too (a worn segment: 163 windows damaged, 78 of the rest at 3 for a 6-ripple
    motor, hpddo.studies.ripple_line): a figure is confirmed over the comb windows and these together, which
    agree on none."""
    return est["key"].to_numpy() == "damaged"


def figure_confirmed(at: int, shown: int) -> bool:
    """Whether windows whose lines form a rotation comb confirm a ripples per revolution: at least
    CALIBRATE_MIN_WINDOWS of them place the line at it (at) and they are CALIBRATE_AGREE of all such
    windows (shown), the rule by which hpddo ripple --calibrate names a figure."""
    return at >= CALIBRATE_MIN_WINDOWS and at >= CALIBRATE_AGREE * shown


def figure_shown(ests, opts: Options) -> tuple:
    """Whether the rotation combs of recordings (speed_of_log's estimates) confirm the ripples per revolution
    given (figure_confirmed, over their comb windows together, the damaged ones among them: damaged_windows).
    Returns (confirmed, windows at the figure, comb windows with the damaged)."""
    at = shown = 0
    for est in ests:
        comb = comb_windows(est)
        shown += int(comb.sum()) + int(damaged_windows(est).sum())
        at += int((comb & (est["multiple"].to_numpy(int) == opts.ripples_per_rev)).sum())
    return figure_confirmed(at, shown), at, shown


def other_figure(est, opts: Options):
    """Over an estimate's comb windows (comb_windows: not those named `damaged`), the commonest multiple other
    than opts.ripples_per_rev: (that multiple, the comb windows showing it, the comb windows showing any other
    than the figure given, all comb windows with the damaged ones: damaged_windows); None where every comb window
    shows the figure given."""
    m = est["multiple"].to_numpy(int)
    shown = comb_windows(est)
    other = shown & (m != opts.ripples_per_rev)
    if not other.any():
        return None
    vals, counts = np.unique(m[other], return_counts=True)
    top = int(vals[np.argmax(counts)])  # (the smallest of equally common ones)
    return top, int((shown & (m == top)).sum()), int(other.sum()), int(shown.sum()) + int(damaged_windows(est).sum())


def with_damage_said(est, opts: Options):
    """est (changed in place and returned) with the reason of each window whose own comb names a sub-multiple of
    the figure given (`multiple`: 3 for 6, 2 for 6) amended where windows of the same recording are named
    `damaged` (damaged_windows): a damaged commutator's lines make such combs (a worn segment on the twin: 22
    windows 'the ripple is 3 per revolution, not the 6 given' beside 163 damaged, where the motor's figure
    was the 6 given, hpddo.studies.ripple_line), so the window's figure is one of two the data cannot tell apart."""
    n_bad = int(damaged_windows(est).sum())
    if not n_bad:
        return est
    m = est["multiple"].to_numpy(int)
    sub = ((est["key"].to_numpy() == "multiple") & (m > 0) & (m < opts.ripples_per_rev)
           & (opts.ripples_per_rev % np.maximum(m, 1) == 0))
    if sub.any():
        tail = (f"; but {n_bad} of this recording's windows are named damaged, and a damaged commutator's lines "
                f"can make such a comb for a {opts.ripples_per_rev}-ripple motor: this window cannot tell which")
        est.loc[est.index[sub], "reason"] = est["reason"][sub].astype(str) + tail
    return est


def identity_of_recording(est, opts: Options, scale_checked: bool = True):
    """The line's identity over a whole recording: where most of the windows whose lines form a
    rotation comb (est's `multiple` > 0; not those named `damaged`) put the strongest line at another multiple than
    opts.ripples_per_rev, the user's figure is wrong for this motor, and a window without a comb of
    its own cannot show that its line is the ripple (its prior, (V - I Ra) / Ke with a Ke calibrated
    under the same figure, agrees with any multiple): every confident row without its own comb at
    ripples_per_rev is then `multiple`, not confident, with the multiple the comb windows show, and so is a
    confident row whose own comb shows the figure given: the recording's combs outweigh it.
    scale_checked: whether anything besides the ripple sets the speed's scale (the user's Ke, a model's M2, a
    speed range). Where nothing does (Ke calibrated from the ripple under the figure given, or no prior), the
    counts scale with the figure given and only the combs can check it, by the rule --calibrate names a figure
    by (figure_confirmed), the windows at the figure counted where their line agrees with the prior (not `far`:
    one that is far contradicts the Ke the prior was calibrated with): where the recording's combs do not
    confirm it, every confident row is `unchecked`, not confident. One or two comb windows do not: a
    free-running burst's PWM residue can put a comb at half the rotation frequency under a window or two, and a
    5-bar motor's one comb window at the figure given did not stop a Ke calibrated on its once-per-revolution
    line (10x the motor's) from counting that line confidently (independent commutator simulation,
    docs/ripple-independent.md).
    est: speed_of_log's DataFrame. Returns a copy."""
    est = with_damage_said(est.copy(), opts)
    m = est["multiple"].to_numpy(int)
    shown = comb_windows(est)
    at = shown & (m == opts.ripples_per_rev)
    fig = other_figure(est, opts)
    if fig is not None and fig[2] > 0.5 * fig[3]:  # most comb windows show another figure
        top, n_top, n_other, n_shown = fig
        # every confident row: a window's own comb at the figure given does not outweigh the recording's (a
        # free-running burst's PWM residue put a comb at half the rotation frequency under 2 of 16 comb windows of
        # a 6-ripple motor given 12, in the independent commutator simulation; the 14 others showed other figures)
        demote = est["confident"].to_numpy(bool).copy()  # (a view of the column, which demote changes)
        head = (f"{REASONS['multiple']}: the ripple is {top} per revolution, not the {opts.ripples_per_rev} given, in "
                f"{n_top} of the {n_shown} windows of this recording whose lines form a rotation comb"
                if figure_confirmed(n_top, n_shown) else
                f"{REASONS['multiple']}: {n_other} of the {n_shown} windows of this recording whose "
                f"lines form a rotation comb show another number than the {opts.ripples_per_rev} given ({top} the "
                f"commonest, in {n_top}); too few agree on one to name the motor's")
        return demoted(est, demote, "multiple", [head + ("; this window shows none of its own" if k == 0
                                                        else f"; this window's own shows {k}") for k in m[demote]])
    # ... and a comb window at the figure whose line the prior puts out of its reach (`far`) checks the figure but
    # contradicts the prior's Ke, calibrated under it from other windows: it confirms neither
    far = at & (est["key"].to_numpy() == "far")
    n_bad = int(damaged_windows(est).sum())
    if not scale_checked and not figure_confirmed(int((at & ~far).sum()), int(shown.sum()) + n_bad):
        said = (f"none of the {len(est)} windows shows a comb" if not shown.any() and not n_bad else
                f"{int(at.sum())} of the {int(shown.sum()) + n_bad} windows whose lines form a comb show it"
                + (f" ({n_bad} of them named damaged)" if n_bad else "")
                + (f", {int(far.sum())} of them with their line far from the prior (its Ke, calibrated from the "
                   "ripple, is not the motor's)" if far.any() else "")
                + f"; {CALIBRATE_MIN_WINDOWS} in agreement with the prior and {CALIBRATE_AGREE:.0%} of the comb "
                  "windows needed")
        est = demoted(est, est["confident"].to_numpy(bool).copy(), "unchecked",
                      f"{REASONS['unchecked']} ({opts.ripples_per_rev} given; {said})")
    return est


#: the fewest confident windows whose counts and back-EMF speeds check the figure given against a Ke
PRIOR_CHECK_MIN_WINDOWS = 5
#: the counted speeds' spread (max / min) over which the back-EMF speed's slope against them is fitted with an
#: intercept (a voltage the prior does not know, a brush drop, taken out); under it, the ratio of the two speeds
#: with the prior's own allowance for that voltage (m2_prior_sd_rpm, one sd each side)
PRIOR_CHECK_SPAN = 1.3
#: the slope's interval, in standard errors (under it, the windows' residuals are not independent: a half figure
#: apart is the margin the decision takes)
PRIOR_CHECK_Z = 2.0


def implied_figures(rpm, rpm_prior, sd_below, sd_above, n_given: int):
    """The ripples per revolution that a back-EMF prior implies for windows counted under n_given, n_given x prior /
    count: (point, lo, hi), point None where only an interval is known; None where too few windows
    (PRIOR_CHECK_MIN_WINDOWS). Under the figure N_true the count is the true speed times N_true / n_given, and a
    right Ke's prior the true speed and what a brush drop takes. Over counts spread PRIOR_CHECK_SPAN or more, the
    prior's slope against the count (least squares with an intercept, which takes the brush drop) is
    n_given / N_true: the point, and PRIOR_CHECK_Z standard errors either side. Over fewer, the drop and the scale
    cannot be told apart: the ratio prior / count with the prior's own one-sd allowance each side (sd_below: a
    voltage the winding does not see; sd_above: Ra's error), the median over windows, as an interval alone."""
    rpm, pr = np.asarray(rpm, float), np.asarray(rpm_prior, float)
    sd_lo, sd_hi = np.asarray(sd_below, float), np.asarray(sd_above, float)
    ok = np.isfinite(rpm) & np.isfinite(pr) & (rpm > 0) & (pr > 0) & np.isfinite(sd_lo) & np.isfinite(sd_hi)
    if int(ok.sum()) < PRIOR_CHECK_MIN_WINDOWS:
        return None
    x, y = rpm[ok], pr[ok]
    point = None
    if x.max() >= PRIOR_CHECK_SPAN * x.min():
        a = np.vstack([x, np.ones_like(x)]).T
        coef, *_ = np.linalg.lstsq(a, y, rcond=None)
        resid = y - a @ coef
        s2 = float(resid @ resid) / (len(x) - 2)
        se = math.sqrt(s2 / float(((x - x.mean()) ** 2).sum()))
        s_lo, s_hi = coef[0] - PRIOR_CHECK_Z * se, coef[0] + PRIOR_CHECK_Z * se
        point = n_given / coef[0] if coef[0] > 0 else None
    else:
        s_lo = float(np.median((y - sd_lo[ok]) / x))
        s_hi = float(np.median((y + sd_hi[ok]) / x))
    # n_given / slope: the smaller slope, the larger figure; a slope down to 0 or under bounds nothing above
    hi = n_given / s_lo if s_lo > 0 else math.inf
    lo = n_given / s_hi if s_hi > 0 else math.inf
    return point, lo, hi


def prior_checks_figure(ests, sds, opts: Options, ke: float, ke_from: str) -> list:
    """Where a Ke the user gave (or a model's M2) is all that checks the ripples per revolution given: whether the
    back-EMF speeds agree with the counts under it, over a motor's recordings together (ests: speed_of_log's
    DataFrames with `rpm_prior`; sds: the prior's sd (n, 2) RPM, below and above, of each), so that a sweep's
    spread of speeds checks a steady run's too. Where the figures the prior implies (implied_figures, over the
    confident windows) leave out the one given and the nearest they point to would move the count by more than
    FIGURE_CHECK_REL, the Ke and the figure disagree: one of them is wrong and the data cannot tell which (a
    symmetric rotor shows no comb), so every confident row is `ke_or_figure`, not confident. (On the twin with its
    rotor made symmetric, Ke given right, 5 and 7 given for 6 were counted 620 windows of 990 confident, 15-22 %
    off, before this check.) Where they agree but cannot tell the figure from those neighbours (too few windows,
    one operating point, a low speed: on the twin's low-duty steps 7 given for 6 agreed with the right Ke, 72
    windows confident 14 % off), every confident row is `unchecked`. Recordings whose combs confirm the figure are left as they are: there the data check
    the figure and a disagreement is Ke's. ke (V s/rad) and where it came from (ke_from), for the reason. Returns
    copies, in order."""
    from .options import FIGURE_CHECK_REL

    ests = [e.copy() for e in ests]
    n = opts.ripples_per_rev
    confirmed, _, _ = figure_shown(ests, opts)
    conf = [e["confident"].to_numpy(bool).copy() for e in ests]  # (views of the columns, which the lines below change)
    n_conf = int(sum(c.sum() for c in conf))
    if confirmed or not n_conf:
        return ests
    sd = [np.asarray(d, float) for d in sds]
    got = implied_figures(np.concatenate([e["rpm"].to_numpy(float)[c] for e, c in zip(ests, conf)]),
                          np.concatenate([e["rpm_prior"].to_numpy(float)[c] for e, c in zip(ests, conf)]),
                          np.concatenate([d[c, 0] for d, c in zip(sd, conf)]),
                          np.concatenate([d[c, 1] for d, c in zip(sd, conf)]), n)
    said = f"{n} given; the back-EMF speeds under Ke {ke:.4g} V s/rad (from {ke_from})"
    if got is None:
        return _demoted(ests, conf, "unchecked", f"{REASONS['unchecked']} ({said} over {n_conf} confident windows: "
                        f"{PRIOR_CHECK_MIN_WINDOWS} needed to check the figure)")
    point, lo, hi = got
    span = ((f"{point:.2f} " if point is not None else "")
            + (f"({lo:.1f}..{hi:.1f})" if math.isfinite(hi) else f"(over {lo:.1f})"))
    if point is not None:  # a slope: the figure nearest to it, where the interval leaves out the one given
        nearest = int(round(point))
        disagree = not lo <= n <= hi and nearest != n
    else:  # an interval alone: every figure within half a step of the one given left out
        nearest = math.ceil(lo - 0.5) if lo > n else math.floor(hi + 0.5)
        disagree = not (lo <= n + 0.5 and hi >= n - 0.5)
    if disagree and nearest >= 1 and abs(nearest / n - 1.0) > FIGURE_CHECK_REL:
        mid = point if point is not None else (math.sqrt(lo * hi) if math.isfinite(hi) else lo)
        return _demoted(ests, conf, "ke_or_figure", (
            f"{REASONS['ke_or_figure']} ({said} put it at {span} over {n_conf} windows, {nearest} the nearest: either "
            f"the figure is {nearest} or that Ke is {(mid / n - 1) * 100:+.0f} % off the motor's; an encoder or "
            f"tachometer run (hpddo ripple --calibrate), or a speed range no more than {FIGURE_CHECK_REL * 100:g} % "
            "wide, would tell)"))
    # ... and where they agree, whether they tell the figure from the nearest that would move the count by more than
    # FIGURE_CHECK_REL: a slope within one figure that points at the one given, or an interval short of halfway to
    # those neighbours (one operating point: the ratio within a brush drop's allowance holds 5, 6 and 7 for 6)
    below, above = math.ceil(n * (1.0 - FIGURE_CHECK_REL)) - 1, math.floor(n * (1.0 + FIGURE_CHECK_REL)) + 1
    if (disagree or (point is not None and nearest == n and hi - lo < 1.0)
            or (lo > below + 0.5 and hi < above - 0.5)):
        return ests
    return _demoted(ests, conf, "unchecked", (
        f"{REASONS['unchecked']} ({said} put it at {span} over {n_conf} windows, which holds "
        f"{below if lo <= below + 0.5 else above} as well: one operating point, or a low speed, cannot tell the figure "
        "from a brush drop; count this recording beside a sweep of the same motor)"))


def _demoted(ests, conf, key: str, reason: str) -> list:
    """ests with their rows conf (a boolean array each) not confident, under key and reason (demoted)."""
    return [demoted(e, c, key, reason) for e, c in zip(ests, conf)]


def demoted(est, rows, key: str, reason):
    """est (an estimate DataFrame, changed in place and returned) with its rows (a boolean array) not confident,
    under key and reason (one text, or one a row)."""
    idx = est.index[rows]
    est.loc[idx, "confident"] = False
    est.loc[idx, "confidence"] = 0.0
    est.loc[idx, "key"] = key
    est.loc[idx, "reason"] = reason
    return est


#: the reasons a window keeps where the declared PWM does not show (sync.pwm_unseen): they do not rest on the
#: spectrum's lines
KEPT_WHERE_UNSEEN = ("coasting", "floor", "few_cycles", sync.KEY_FOLD, "stall", "creep")


def unseen_demoted(est, unseen: dict | None, pwm_hz: float):
    """est (an estimate DataFrame) where the declared PWM does not show (sync.pwm_unseen's result, not None): every
    window whose key rests on the spectrum's lines (confident, or not for a line's sake: `multiple`, `damaged`,
    `rival` ... read off lines that may be the PWM's) `pwm_unseen` (demoted), with the figures and what to declare;
    those of KEPT_WHERE_UNSEEN as they are. Returns a copy where it changes."""
    if unseen is None:
        return est
    rows = ~est["key"].isin(KEPT_WHERE_UNSEEN).to_numpy()
    if not rows.any():
        return est
    return demoted(est.copy(), rows, sync.KEY_UNSEEN, sync.unseen_reason(unseen, pwm_hz))
