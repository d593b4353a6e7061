"""Which line of the current's spectrum is the ripple: the spectrum of a window, the power of a
line, the sub-harmonic family weighed beside it (count.estimate_window searches with them), and
the line's identity over a whole recording (`identity_of_recording`)."""
from __future__ import annotations

import math

import numpy as np

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


def figure_confirmed(at: int, shown: int) -> bool:
    """Whether windows whose lines form a rotation comb confirm a ripples per revolution: at least
    CALIBRATE_MIN_WINDOWS of them place the line at it (at) and they are CALIBRATE_AGREE of all such
    windows (shown), the rule by which hpddo ripple --calibrate names a figure."""
    return at >= CALIBRATE_MIN_WINDOWS and at >= CALIBRATE_AGREE * shown


def figure_shown(ests, opts: Options) -> tuple:
    """Whether the rotation combs of recordings (speed_of_log's estimates) confirm the ripples per revolution
    given (figure_confirmed, over their comb windows together). Returns (confirmed, windows at the figure,
    comb windows)."""
    at = shown = 0
    for est in ests:
        comb = comb_windows(est)
        shown += int(comb.sum())
        at += int((comb & (est["multiple"].to_numpy(int) == opts.ripples_per_rev)).sum())
    return figure_confirmed(at, shown), at, shown


def other_figure(est, opts: Options):
    """Over an estimate's comb windows (comb_windows: not those named `damaged`), the commonest multiple other
    than opts.ripples_per_rev: (that multiple, the comb windows showing it, the comb windows showing any other
    than the figure given, all comb windows); None where every comb window shows the figure given."""
    m = est["multiple"].to_numpy(int)
    shown = comb_windows(est)
    other = shown & (m != opts.ripples_per_rev)
    if not other.any():
        return None
    vals, counts = np.unique(m[other], return_counts=True)
    top = int(vals[np.argmax(counts)])  # (the smallest of equally common ones)
    return top, int((shown & (m == top)).sum()), int(other.sum()), int(shown.sum())


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
    est = est.copy()
    m = est["multiple"].to_numpy(int)
    shown = comb_windows(est)
    at = shown & (m == opts.ripples_per_rev)
    fig = other_figure(est, opts)
    if fig is not None and fig[2] > 0.5 * fig[3]:  # most comb windows show another figure
        top, n_top, n_other, n_shown = fig
        # every confident row: a window's own comb at the figure given does not outweigh the recording's (a
        # free-running burst's PWM residue put a comb at half the rotation frequency under 2 of 16 comb windows of
        # a 6-ripple motor given 12, in the independent commutator simulation; the 14 others showed other figures)
        demote = est["confident"].to_numpy(bool).copy()  # (a view of the column, which the lines below change)
        idx = est.index[demote]
        est.loc[idx, "confident"] = False
        est.loc[idx, "confidence"] = 0.0
        est.loc[idx, "key"] = "multiple"
        head = (f"{REASONS['multiple']}: the ripple is {top} per revolution, not the {opts.ripples_per_rev} given, in "
                f"{n_top} of the {n_shown} windows of this recording whose lines form a rotation comb"
                if figure_confirmed(n_top, n_shown) else
                f"{REASONS['multiple']}: {n_other} of the {n_shown} windows of this recording whose "
                f"lines form a rotation comb show another number than the {opts.ripples_per_rev} given ({top} the "
                f"commonest, in {n_top}); too few agree on one to name the motor's")
        for j, k in zip(idx, m[demote]):
            est.at[j, "reason"] = head + ("; this window shows none of its own" if k == 0
                                          else f"; this window's own shows {k}")
        return est
    # ... and a comb window at the figure whose line the prior puts out of its reach (`far`) checks the figure but
    # contradicts the prior's Ke, calibrated under it from other windows: it confirms neither
    far = at & (est["key"].to_numpy() == "far")
    if not scale_checked and not figure_confirmed(int((at & ~far).sum()), int(shown.sum())):
        idx = est.index[est["confident"].to_numpy(bool)]
        est.loc[idx, "confident"] = False
        est.loc[idx, "confidence"] = 0.0
        est.loc[idx, "key"] = "unchecked"
        said = (f"none of the {len(est)} windows shows a comb" if not shown.any() else
                f"{int(at.sum())} of the {int(shown.sum())} windows whose lines form a comb show it"
                + (f", {int(far.sum())} of them with their line far from the prior (its Ke, calibrated from the "
                   "ripple, is not the motor's)" if far.any() else "")
                + f"; {CALIBRATE_MIN_WINDOWS} in agreement with the prior and {CALIBRATE_AGREE:.0%} of the comb "
                  "windows needed")
        est.loc[idx, "reason"] = f"{REASONS['unchecked']} ({opts.ripples_per_rev} given; {said})"
    return est
