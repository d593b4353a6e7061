"""The protocols as piecewise-constant schedules, from the bench description
(hpddo/bench.py): the paper's three training protocols (section 3.6.1) and hpddo's
validation protocols (``unseen``, ``hot``).

A schedule is a list of segments ``(duration_s, duty, load)``. Segment boundaries are
rounded to whole sample periods so that every logged row has one duty and one load
state in force ("PWM duty command in force during the sample").
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .. import bench

# The protocols are declared once, in hpddo/bench.py (shared with the UNO firmware).
# PROTOCOLS: the training protocols (what ``--protocol all`` runs, data/default);
# VALIDATION_PROTOCOLS: hpddo's own (``--protocol validation``, data/validation).
PROTOCOLS = bench.TRAINING_PROTOCOLS
VALIDATION_PROTOCOLS = bench.VALIDATION_PROTOCOLS
KNOWN = PROTOCOLS + VALIDATION_PROTOCOLS

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
        raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(KNOWN)})")
    segs = [(g.duration_s, g.duty, g.load) for g in bench.PROTOCOLS[protocol].segments]
    return [(dur * time_scale, duty, load) for dur, duty, load in segs]


def bench_for(protocol: str, b):
    """The twin bench ``b`` under ``protocol``'s conditions: its ambient temperature
    (``Protocol.ambient_C``) replaces the bench's when the protocol declares one. The
    plant starts winding and case at that ambient and sinks heat to it; the DS18B20's
    reading at t = 0 is it."""
    ambient_C = bench.PROTOCOLS[protocol].ambient_C
    if ambient_C is None:
        return b
    return dataclasses.replace(b, ambient_C=float(ambient_C))


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
