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
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..logs import ripple as rf
from ..logs.errors import InputError
from .comb import MAINS_HZ

MIN_PER_BIN = 32   # samples a phase bin holds on average: its mean carries the commutation ripple and the
#                    noise over sqrt(32) into the subtracted average, where fewer, finer bins follow the PWM
#                    current's kinks better (490 Hz at 9.6 kHz, 0.5 s, 1.4 A peak to peak and a 50 mA ripple:
#                    8 per bin leaves 0.3 mA of PWM and 9.3 mA of leaked ripple rms, 16: 0.5 and 4.9,
#                    32: 1.0 and 3.8, 64: 2.3 and 2.0; test_ripple_captures)
MIN_BINS = 16      # fewer bins cannot follow the PWM current's shape (its two exponential phases)
MAX_BINS = 512     # finer bins than this gain nothing at a kink of the PWM current (8 us at 490 Hz x 256)
PWM_HARMONICS = 20  # the PWM harmonics whose aliases are checked: a PWM current's harmonic h falls as 1 / h^2
#                     (its kinks), the 20th at 1/400 of the first

KEY = "fixed_line"
REASON = "the line sits at a multiple of the PWM or mains frequency (a fixed line of the supply, not the shaft's)"
KEY_FOLD = "pwm_fold"
REASON_FOLD = "free-running burst too short to remove the PWM-synchronous average"


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


def fixed_lines(bursts, f_hz: float, either_mains: bool = False) -> list:
    """The supply's fixed lines nearest f_hz as (Hz, what): the PWM's harmonics (and where they alias at
    sample_hz) up to f_hz's neighbourhood, and the mains frequency's multiple nearest f_hz, where the file
    declares them (whatever the declared mains frequency: a file may declare any positive one, 1 mHz too,
    whose multiples near a line in the kHz are millions: the nearest is computed, not listed). With
    either_mains, where the file declares no mains frequency, the nearest multiple of every mains
    frequency (comb.MAINS_HZ: 50 and 60 Hz), since hum is in a current whether the file says so or not."""
    fs = bursts.sample_hz
    out = []
    if math.isfinite(bursts.pwm_hz) and bursts.pwm_hz > 0:
        for h in range(1, PWM_HARMONICS + 1):
            f = h * bursts.pwm_hz
            alias = abs((f + fs / 2) % fs - fs / 2)
            what = f"{h} x the PWM's {bursts.pwm_hz:g} Hz" + ("" if abs(alias - f) < 1e-9 else f", aliased at {fs:g} S/s")
            out.append((alias, what))
    if math.isfinite(bursts.mains_hz):
        mains = [(bursts.mains_hz, "the mains' {:g} Hz".format(bursts.mains_hz))]
    elif either_mains:
        mains = [(m, f"{m:g} Hz, a mains frequency (the file declares none)") for m in MAINS_HZ]
    else:
        mains = []
    for m, name in mains:
        h = max(1, round(f_hz / m)) if math.isfinite(f_hz) else 1
        out.append((h * m, f"{h} x {name}"))
    return out


def fixed_line(bursts, k: int, f_hz: float, resolution_hz: float, placed: bool = True):
    """Why window k cannot be confident on a line at f_hz (its spectrum resolving resolution_hz):
    (key, reason), or None. A refused fold (prepare), or a line within one resolution (and 0.2 %,
    the comb grid's step) of a PWM or mains line (fixed_lines). Where the file declares no mains
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
    for f, what in fixed_lines(bursts, f_hz, either_mains=not placed):
        if abs(f_hz - f) <= tol:
            return KEY, f"{REASON} ({f_hz:.1f} Hz, {what} at {f:.1f} Hz)"
    return None
