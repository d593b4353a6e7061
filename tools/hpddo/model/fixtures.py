"""Small hand-made models and sample streams for the core's unit tests.

They exist so that hpddo_core is tested against independently computed expectations
(numpy float32, observer_ref.py) before, and beside, any trained model. Every stage and
every observer status is reached by the streams below.
"""
from __future__ import annotations

import numpy as np

from . import gate
from . import physics as ph
from .observer_ref import Limits, ModelData, ReferenceObserver

SEED = 20261121
RAMP_ROWS = 40  # the stream's ramp: every other row stands for the tiny models' gate's training rows


def _layers(rng, sizes):
    return [(rng.normal(0, 0.8, (o, i)).astype(np.float32), rng.normal(0, 0.3, o).astype(np.float32))
            for i, o in zip(sizes[:-1], sizes[1:])]


def tiny_model(hidden=(4, 3), seed=SEED, out_gain=8.0) -> ModelData:
    """A 5-h1-h2-1 (or 5-h1-1) model with every effect term on and a thermal network."""
    rng = np.random.default_rng(seed)
    bits = sum(b for b, _ in ph.EFFECT_BITS.values())
    p = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.406, t_ref_C=31.0, ra_tc_per_K=0.00393,
                         ke_tc_per_K=-0.002, brush_V=0.8, ke_sat_per_A=0.03, i_offset_A=0.012,
                         v_gain=0.015, la_H=0.0032, th_r_K_per_W=6.0, th_tau_s=900.0, t_amb_C=31.0,
                         effects=bits)
    mean = np.array([8.0, 0.5, 180.0, 0.5, 180.0], np.float32)
    scale = np.array([3.0, 0.3, 60.0, 0.3, 60.0], np.float32)
    lo = np.array([0.0, -0.1, -10.0, -0.1, -10.0], np.float32)
    hi = np.array([13.0, 2.0, 320.0, 2.0, 320.0], np.float32)
    layers = _layers(rng, (5, *hidden, 1))
    layers[-1] = (layers[-1][0] * np.float32(out_gain), layers[-1][1])  # residuals of a few RPM, some clamped
    model = ModelData(physics=p, scaler_mean=mean, scaler_scale=scale, layers=layers, env_lo=lo, env_hi=hi,
                      clamp_rpm=6.0, gate=gate.open_gate(5), limits=Limits())
    model.gate = _gate_of_ramp(model)
    return model


def _gate_of_ramp(model: ModelData) -> gate.GateData:
    """The gate fitted (gate.fit, the training rule) to the features of every other one of
    the first RAMP_ROWS samples of tiny_stream (the ramp), as if they were the training
    rows: the ramp's other samples lie between them (a weight between 0 and 1), the rest
    of the stream near them (1) or far away (0)."""
    obs = ReferenceObserver(model)
    xs = [obs.step(*s)["x"] for s in tiny_stream()[:RAMP_ROWS]]
    return gate.fit(np.asarray(xs[::2], np.float64))


def tiny_stream(seed=SEED):
    """(v_V, i_A, temp_C or None, dt_s, seq or None) covering ok, clamped, fallback, invalid,
    seq gaps, absent and out-of-range temperatures, the thermal estimate, and the bounds:
    a denormal period, a la di/dt beyond the speed range, a lost seq cycle seen from the
    period, and full-scale current held until the winding reaches its limit."""
    rng = np.random.default_rng(seed + 1)
    out = []
    seq = 100
    for k in range(40):  # a ramp with temperature read
        v = 2.0 + 0.25 * k + rng.normal(0, 0.05)
        i = 0.2 + 0.02 * k + rng.normal(0, 0.01)
        out.append((v, i, 31.0 + 0.5 * k, 0.5, seq)); seq += 1
    for k in range(20):  # no temperature: the thermal estimate takes over
        out.append((9.6 + rng.normal(0, 0.1), 0.9 + rng.normal(0, 0.05), None, 0.5, seq)); seq += 1
    out.append((9.6, 0.9, 300.0, 0.5, seq)); seq += 1       # temperature out of sensor range
    out.append((9.6, 0.9, None, 0.5, seq + 3)); seq += 4    # seq gap: lags reset
    out.append((float("nan"), 0.9, 40.0, 0.5, seq)); seq += 1  # invalid voltage
    out.append((9.6, float("inf"), 40.0, 0.5, seq)); seq += 1  # invalid current
    out.append((55.0, 0.9, 40.0, 0.5, seq)); seq += 1        # beyond the voltage channel
    out.append((9.6, 0.9, 40.0, 0.0, seq)); seq += 1         # zero period
    out.append((9.6, 0.9, 40.0, 0.5, seq)); seq += 1         # recovers
    out.append((12.5, 2.5, 40.0, 0.5, seq)); seq += 1        # outside the envelope: fallback
    out.append((12.0, 1.9, 40.0, 0.5, seq)); seq += 1
    for k in range(10):  # without seq, large swings
        out.append((rng.uniform(0, 12.5), rng.uniform(-0.05, 1.8), 45.0, 0.01, None))
    out.append((9.0, 0.8, 45.0, 0.5, 65535))
    out.append((9.0, 0.8, 45.0, 0.5, 0))  # wraps without a gap
    # The bounds (docs/core.md): a denormal period is used but starts a new segment;
    # a 12 us period with a current step gives la di/dt beyond the speed range: invalid.
    seq = 1
    out.append((9.2, 0.85, 45.0, 1e-40, seq)); seq += 1
    out.append((9.0, 0.1, 45.0, 0.5, seq)); seq += 1
    out.append((9.0, 1.9, 45.0, 1.2e-5, seq)); seq += 1
    out.append((9.0, 1.0, 45.0, 0.5, seq)); seq += 1       # recovers
    # 65536 samples lost: seq follows on 16 bits, but the period shows the gap.
    out.append((9.4, 1.2, 45.0, 65537 * 0.5, seq)); seq += 1
    out.append((9.5, 1.1, 45.0, 0.5, seq)); seq += 1
    # Full-scale current held for 200 s without a case reading: the winding estimate
    # reaches the insulation limit and stays there, then decays once the current falls.
    for _ in range(40):
        out.append((12.0, 10.0, None, 5.0, seq)); seq += 1
    for _ in range(6):
        out.append((9.6, 0.9, None, 5.0, seq)); seq += 1
    return out


FIXTURES = {  # name: (hidden sizes, weight seed, output gain)
    "tiny": ((4, 3), SEED, 20.0),
    "tiny1": ((6,), SEED + 7, 0.25),
}


# The dynamic family's fixture (test/fixtures/dynamics/): the deployed model (models/default) with a
# slow shaft named, so that the board's observer filters the back-EMF speed visibly at the bench's
# 2 Hz and at 100 Hz. A 5 g m^2 (50,000 g cm^2) flywheel-like inertia with the twin's friction
# (twin/params.py: B 4 mN m s/rad, Tc 95 mN m) and an observer of 1 s. The UNO is built with it
# (test/firmware: firmware.uno.*dynamics*) and the ESP8266's host board runs it (test_upload.py).
DYNAMICS_DIR = "dynamics"
DYNAMICS_SHAFT = dict(j_kgm2=5e-3, b_nms_per_rad=4e-3, tc_nm=0.095, tau_obs_s=1.0)


def with_dynamics(model: ModelData, shaft=None) -> ModelData:
    """model with the dynamic family named (DYNAMICS_SHAFT unless given); the rest unchanged."""
    import dataclasses
    from . import dynamics_ref
    return dataclasses.replace(model, dynamics=dynamics_ref.dynamics_params(**(shaft or DYNAMICS_SHAFT)))


def golden_samples(rows) -> list:
    """The samples (v, i, temp or None, dt, seq or None) of a golden table's input columns (a
    numpy structured array with the names of export.GOLDEN_INPUTS)."""
    return [(float(r["v_V"]), float(r["i_A"]), None if np.isnan(r["temp_C"]) else float(r["temp_C"]),
             float(r["dt_s"]), int(r["seq"]) if r["has_seq"] else None) for r in rows]


def short_log(seed=SEED):
    """A 240-row labelled log for the replay tests: duty steps, a seq gap, a stretch
    without temperature. Speeds follow the plain back-EMF model plus noise."""
    import pandas as pd
    rng = np.random.default_rng(seed + 2)
    n = 240
    t = np.arange(n) * 0.5
    duty = np.repeat([0.2, 0.4, 0.6, 0.8, 1.0, 0.8, 0.6, 0.4], n // 8)
    i = 0.25 + 0.4 * duty + rng.normal(0, 0.01, n)
    v = 12.0 * duty + rng.normal(0, 0.02, n)
    rpm = (v - 4.5 * i) / 0.406 * ph.RPM_PER_RAD_S + rng.normal(0, 1.0, n)
    temp = np.round((31.0 + 0.1 * t) * 16) / 16
    temp[100:140] = np.nan
    seq = np.arange(n)
    seq[150:] += 3  # three samples lost on the link
    df = pd.DataFrame(dict(t_s=t, duty=duty, v_V=v, i_A=i, rpm_ref=rpm, temp_C=temp, seq=seq))
    return df, {"condition": "short", "sample_rate_hz": "2", "ra_ohm": "4.5", "note": "test fixture"}


BAD_DUTY_LOG = """# condition=bad
# sample_rate_hz=2
t_s,duty,v_V,i_A,rpm_ref
0.0,0.2,2.4,0.3,20.0
0.5,0.2,2.4,0.3,20.0
1.0,1.2,2.4,0.3,20.0
"""
