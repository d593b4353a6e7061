"""The paper's three protocols (section 3.6.1) as piecewise-constant schedules.

A schedule is a list of segments ``(duration_s, duty, load)``. Segment boundaries are
rounded to whole sample periods so that every logged row has one duty and one load
state in force ("PWM duty command in force during the sample").
"""
from __future__ import annotations

import numpy as np

PROTOCOLS = ("sweep", "load", "long")

SWEEP_STEP_S = 30.0
SWEEP_DUTIES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 0.8, 0.6, 0.4, 0.2, 0.0)
LOAD_DUTY = 0.8
LOAD_DWELL_S = 25.0
LOAD_SEQUENCE = (0, 1, 2, 0, 2, 1, 0, 1, 2, 1, 0, 2)
LONG_DUTY = 0.8
LONG_LOAD = 2  # 0.01 ohm
LONG_S = 3600.0


def schedule(protocol: str, time_scale: float = 1.0):
    """Segments of ``protocol``; ``time_scale`` < 1 shortens every segment (tests)."""
    if time_scale <= 0:
        raise ValueError("time_scale must be > 0")
    if protocol == "sweep":
        segs = [(SWEEP_STEP_S, d, 0) for d in SWEEP_DUTIES]
    elif protocol == "load":
        segs = [(LOAD_DWELL_S, LOAD_DUTY, k) for k in LOAD_SEQUENCE]
    elif protocol == "long":
        segs = [(LONG_S, LONG_DUTY, LONG_LOAD)]
    else:
        raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(PROTOCOLS)})")
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
