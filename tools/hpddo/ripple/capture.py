"""The ripple speed of a capture without a bench log (issue 33, docs/ripple-captures.md): a
current-only burst file (hpddo import writes one from a scope's CSV, a sound card's WAV or a
MATLAB .mat), with no voltage, duty or Ra for the back-EMF prior. The prior is then the user's
speed range, or none (the comb alone picks the line, and says ambiguous where it cannot).
Without a range, or with one wider than options.FIGURE_CHECK_REL, nothing but the combs can check the ripples per
revolution given, so the recording's windows are confident only where its combs confirm that figure
(ripple.line.identity_of_recording, as for a bench log without Ke or a range).

* the speed range as the prior, and no confident count outside it (ripple/speed_range.py);
* `speed_of_bursts`: every window counted (ripple.count.estimate, ripple.spans.count_steady_spans), no duty
  (every window taken as driven), no stall (that needs the back-EMF).
"""
from __future__ import annotations

import numpy as np

from . import sync
from .count import estimate
from .line import identity_of_recording, unseen_demoted
from .options import Options
from .spans import count_steady_spans
from .speed_range import range_checks_figure, range_prior, within_range


def speed_of_bursts(bursts, opts: Options, rpm_range=None, source: str = "bursts"):
    """The ripple speed of every burst of a capture without a bench log: estimate's DataFrame
    (after count_steady_spans and within_range) with `t_s` (the burst's first sample: the start of
    the window it covers) and `rpm_prior`. The free-running average removed first (sync.prepare:
    InputError where it cannot be)."""
    b = sync.prepare(bursts, source)
    n = len(b)
    prior, sd = range_prior(rpm_range, n)
    duty = np.ones(n)  # no duty recorded: every window taken as driven (the floor still applies)
    est = estimate(b, duty, prior, opts, sd, None)
    est = count_steady_spans(b, duty, est, opts, None)
    # the speed's scale and the line's identity: with no prior, the strongest line of a window without a comb may be
    # any line (a supply's, a harmonic): only the recording's combs check the figure (a 976 Hz PWM line, undeclared,
    # was counted as the ripple of 12 comb-less windows, 5 of them 5-8 % off, confidently); a speed range checks it
    # only where it is too narrow to hold a count under another figure (range_checks_figure)
    est = identity_of_recording(est, opts, scale_checked=range_checks_figure(rpm_range))
    est = within_range(est, rpm_range)
    est = unseen_demoted(est, sync.pwm_unseen(bursts), bursts.pwm_hz)
    est.insert(1, "t_s", np.asarray(b.t_s, float))
    est["rpm_prior"] = np.nan if prior is None else prior
    est["stall"] = False
    est["rpm_bound"] = np.nan
    return est
