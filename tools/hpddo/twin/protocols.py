"""The paper's three protocols (section 3.6.1) as piecewise-constant schedules,
from the bench description (hpddo/bench.py).

A schedule is a list of segments ``(duration_s, duty, load)``. Segment boundaries are
rounded to whole sample periods so that every logged row has one duty and one load
state in force ("PWM duty command in force during the sample").
"""
from __future__ import annotations

import numpy as np

from .. import bench

# The protocols are declared once, in hpddo/bench.py (shared with the UNO firmware).
PROTOCOLS = tuple(bench.PROTOCOLS)

SWEEP_STEP_S = bench.PROTOCOLS["sweep"].step_s()
SWEEP_DUTIES = tuple(s.duty for s in bench.PROTOCOLS["sweep"].segments)
LOAD_DUTY = bench.PROTOCOLS["load"].segments[0].duty
LOAD_DWELL_S = bench.PROTOCOLS["load"].step_s()
LOAD_SEQUENCE = tuple(s.load for s in bench.PROTOCOLS["load"].segments)
LONG_DUTY = bench.PROTOCOLS["long"].segments[0].duty
LONG_LOAD = bench.PROTOCOLS["long"].segments[0].load
LONG_S = bench.PROTOCOLS["long"].duration_s


def schedule(protocol: str, time_scale: float = 1.0):
    """Segments of ``protocol``; ``time_scale`` < 1 shortens every segment (tests)."""
    if time_scale <= 0:
        raise ValueError("time_scale must be > 0")
    if protocol not in bench.PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(PROTOCOLS)})")
    segs = [(g.duration_s, g.duty, g.load) for g in bench.PROTOCOLS[protocol].segments]
    return [(dur * time_scale, duty, load) for dur, duty, load in segs]


def per_sample(segments, rate_hz: float):
    """Duty and load for each sample period: arrays of length n_samples."""
    ts = 1.0 / rate_hz
    counts = []
    acc_t = 0.0
    acc_n = 0
    for dur, _, _ in segments:
        acc_t += dur
        n_end = max(int(round(acc_t / ts)), acc_n + 1)
        counts.append(n_end - acc_n)
        acc_n = n_end
    duty = np.concatenate([np.full(c, d) for c, (_, d, _) in zip(counts, segments)])
    load = np.concatenate([np.full(c, k, dtype=np.int64) for c, (_, _, k) in zip(counts, segments)])
    return duty, load
