"""The ripple speed of a capture without a bench log (issue 33, docs/ripple-captures.md): a
current-only burst file (hpddo import writes one from a scope's CSV, a sound card's WAV or a
MATLAB .mat), with no voltage, duty or Ra for the back-EMF prior. The prior is then the user's
speed range, or none (the comb alone picks the line, and says ambiguous where it cannot).

* `range_prior`: the range [lo, hi] RPM as the prior of model.ripple: centred, with half the
  range as its sd on each side (a line at either end weighs exp(-1/2) of the centre's, beside Ke's
  relative error), so a line well outside is `far`;
* `within_range`: a confident window whose count lies outside the range is not confident (key
  `outside_range`): the user said the shaft does not turn so;
* `speed_of_bursts`: every window counted (model.ripple.estimate, count_steady_spans), no duty
  (every window taken as driven), no stall (that needs the back-EMF).
"""
from __future__ import annotations

import numpy as np

from . import ripple as rp
from . import ripple_sync

KEY_RANGE = "outside_range"
REASON_RANGE = "the count lies outside the speed range given (--rpm-range)"


def range_prior(rpm_range, n: int):
    """The prior (RPM per window) and its sd (n, 2) from the user's range (lo, hi); (None, None)
    without one."""
    if rpm_range is None:
        return None, None
    lo, hi = (float(v) for v in rpm_range)
    return np.full(n, 0.5 * (lo + hi)), np.full((n, 2), 0.5 * (hi - lo))


def within_range(est, rpm_range):
    """est with its confident rows outside [lo, hi] RPM made not confident (KEY_RANGE); a copy."""
    if rpm_range is None:
        return est
    lo, hi = (float(v) for v in rpm_range)
    est = est.copy()
    rpm = est["rpm"].to_numpy(float)
    out = est["confident"].to_numpy(bool) & ~((rpm >= lo) & (rpm <= hi))
    idx = est.index[out]
    est.loc[idx, "confident"] = False
    est.loc[idx, "key"] = KEY_RANGE
    est.loc[idx, "reason"] = [f"{REASON_RANGE} ({r:.1f} RPM, not in {lo:g}..{hi:g})" for r in rpm[out]]
    est.loc[idx, "confidence"] = 0.0
    return est


def speed_of_bursts(bursts, opts: rp.Options, rpm_range=None, source: str = "bursts"):
    """The ripple speed of every burst of a capture without a bench log: estimate's DataFrame
    (after count_steady_spans and within_range) with `t_s` (the burst's first sample: the start of
    the window it covers) and `rpm_prior`. The free-running average removed first (ripple_sync.prepare:
    InputError where it cannot be)."""
    b = ripple_sync.prepare(bursts, source)
    n = len(b)
    prior, sd = range_prior(rpm_range, n)
    duty = np.ones(n)  # no duty recorded: every window taken as driven (the floor still applies)
    est = rp.estimate(b, duty, prior, opts, sd, None)
    est = rp.count_steady_spans(b, duty, est, opts, None)
    est = within_range(est, rpm_range)
    est.insert(1, "t_s", np.asarray(b.t_s, float))
    est["rpm_prior"] = np.nan if prior is None else prior
    est["stall"] = False
    est["rpm_bound"] = np.nan
    return est
