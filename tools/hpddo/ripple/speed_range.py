"""The user's speed range (hpddo ripple --rpm-range LO HI, issue 33): the back-EMF prior's stand-in
where there is none (no Ra, a current-only capture), and a bound on every confident count.

* `range_prior`: the range [lo, hi] RPM as the prior of the count (ripple.count): centred, with half the
  range as its sd on each side (a line at either end weighs exp(-1/2) of the centre's, beside Ke's
  relative error), so a line well outside is `far`;
* `within_range`: a confident window whose count lies outside the range is not confident (key
  `outside_range`): the user said the shaft does not turn so.
"""
from __future__ import annotations

import numpy as np

from .line import demoted
from .options import FIGURE_CHECK_REL

KEY_RANGE = "outside_range"
REASON_RANGE = "the count lies outside the speed range given (--rpm-range)"


def range_checks_figure(rpm_range) -> bool:
    """Whether the speed range (lo, hi RPM, or None) is narrow enough to check the ripples per revolution given
    (options.FIGURE_CHECK_REL): a wider one holds a count under another figure too."""
    if rpm_range is None:
        return False
    lo, hi = (abs(float(x)) for x in rpm_range)
    lo, hi = min(lo, hi), max(lo, hi)
    return lo > 0 and hi / lo - 1.0 <= FIGURE_CHECK_REL


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
    return demoted(est, out, KEY_RANGE, [f"{REASON_RANGE} ({r:.1f} RPM, not in {lo:g}..{hi:g})" for r in rpm[out]])
