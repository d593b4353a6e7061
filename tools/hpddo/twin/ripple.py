"""The ripple acquisition mode of the twin (issue 23, docs/ripple-counting.md, "The twin's ripple
mode"): the armature current sampled once per PWM period at a fixed phase, in one burst per window of the bench log.

What the burst carries, per sample at time t (the middle of the on-time of its PWM period):

* the mean current of the window, with the inrush shape: i(t) = I + c (w_mean - w(t)),
  c = conduction fraction x Ke / R_loop (the electrical balance at constant V), w(t) the
  output-shaft speed inside the window (below);
* the commutation ripple at f = N n_motor (N ripples per motor revolution): amplitude
  `ripple` (% of the current: the brushes) + coil_emf_pct of E / R_loop (the winding),
  with its second harmonic; the sub-harmonic family of rotor asymmetry at f/2, f/3, f/6,
  each sub*_pct of E / R_loop, so it grows with speed and can overtake the main line where
  the current is small and the speed high; the EMF parts scaled by the conduction
  fraction (no current, no ripple: coasting with the drive off shows none);
* a damaged commutator (`bar_fault_pct`): while segment 0 carries the current (under either
  brush) the loop resistance is raised by that share, so the current is divided by 1 + share
  there: lines at twice the rotation frequency and its multiples;
* brush bounce (white, % of the current), an interference line at a fixed frequency, the
  sample timing jitter times the on-time slope (Vs - E - R i) / La, the ADC's noise and
  its quantisation (codes clipped to 0..full scale: the shunt channel is single ended),
  after the channel's offset (`current_offset`, as on the log's current).

The speed inside a window: the plant gives the shaft angle and speed at the window's
boundaries (w0, w1) and the angle travelled; the profile is w1 + (w0 - w1) exp(-t/tau)
with tau such that the angle matches (a first-order approach, which is what a step of
duty or load gives), or a quadratic through the same three facts where no tau fits. This
is an approximation of the plant's own steps (stated in docs/twin.md, Limits).

The random draws come from a stream of their own, so the bench log, its truth and every
file written without the ripple mode stay the same bytes.
"""
from __future__ import annotations

import math

import numpy as np

from . import ripple_free
from .params import Bench, offset_share

SEED_TAG = 23  # the burst stream's seed: SeedSequence([seed, protocol offset, 23])


def _angle_profile(w0, w1, dtheta, T, tau_s):
    """Angle travelled (rad) and speed (rad/s) at the times tau_s (0..T) inside a window."""
    dw = w0 - w1
    m = dtheta - w1 * T
    if abs(dw) > 1e-9 and 0.0 < m / dw < T * (1 - 1e-6):
        g = m / dw
        lo, hi = 1e-7, 1e4  # tau (s): g(tau) = tau (1 - exp(-T / tau)) rises from 0 to T
        for _ in range(80):
            mid = math.sqrt(lo * hi)
            if mid * -math.expm1(-T / mid) < g:
                lo = mid
            else:
                hi = mid
        tc = math.sqrt(lo * hi)
        e = np.exp(-tau_s / tc)
        return w1 * tau_s + dw * tc * (1 - e), w1 + dw * e
    # quadratic speed w0 + a t + b t^2 with w(T) = w1 and the integral dtheta
    A = np.array([[T, T * T], [T * T / 2, T ** 3 / 3]])
    a, b = np.linalg.solve(A, [w1 - w0, dtheta - w0 * T])
    return w0 * tau_s + a * tau_s ** 2 / 2 + b * tau_s ** 3 / 3, w0 + a * tau_s + b * tau_s ** 2


def _on_segment(theta_m, ripples_per_rev: int):
    """1 where commutator segment 0 lies under a brush at the motor angle theta_m (rad), else 0: with
    two brushes half a turn apart and ripples_per_rev / 2 segments, each segment spans 2 pi / segments
    and passes under brush A from angle 0 and under brush B from pi."""
    seg = 2 * math.pi / max(1, ripples_per_rev // 2)
    a = np.mod(theta_m, 2 * math.pi)
    return ((a < seg) | ((a >= math.pi) & (a < math.pi + seg))).astype(float)


def synthesise(bench: Bench, res, duty, params: dict, rng):
    """The bursts of a simulated run: (t0 per window, list of integer code arrays, meta)."""
    n = len(duty)
    T = 1.0 / res.rate_hz
    fs = params["sample_hz"]
    nb = int(round((params["burst_s"] or T) * fs))
    nb = max(1, min(nb, int(math.floor(T * fs + 1e-9))))
    lsb_V = bench.adc_vref_V / (2 ** bench.adc_bits)
    full = 2 ** bench.adc_bits - 1
    a_per_code = lsb_V / bench.i_gain_V_per_A
    N = bench.ripples_per_rev
    G = bench.gear_ratio
    la = bench.effect_si("inductance")
    brush = bench.effect_si("ripple")
    coil = params["coil_emf_pct"] / 100.0
    subs = ((2, params["sub2_pct"] / 100.0), (3, params["sub3_pct"] / 100.0), (6, params["sub6_pct"] / 100.0))
    h2 = params["harmonic2_pct"] / 100.0
    bar_fault = params.get("bar_fault_pct", 0.0) / 100.0
    bounce = params["bounce_pct"] / 100.0
    f_int, a_int = params["interference_hz"], params["interference_mA"] / 1000.0
    jit = params["jitter_us"] * 1e-6
    ph = rng.uniform(0, 2 * math.pi, size=5)  # main, f/2, f/3, f/6, interference
    free = ripple_free.is_free(params)  # free-running sampling (twin/ripple_free.py)
    comb_ph = rng.uniform(0, 2 * math.pi, size=64) if free else None
    t0s, codes = [], []
    for k in range(n):
        d = float(duty[k])
        tau = ripple_free.sample_times(nb, fs, d, params)  # synchronous: the middle of each on-time
        ang, w = _angle_profile(res.w_bound[k], res.w_bound[k + 1], res.theta[k + 1] - res.theta[k], T, tau)
        theta_m = G * (res.theta[k] + ang)
        r_loop = res.ra[k] + bench.r_shunt_ohm + d * bench.r_dson_ohm
        cond = res.cond[k]
        i = np.maximum(0.0, res.i_mean[k] + cond * res.ke[k] / r_loop * (res.w_mean[k] - w))
        e_over_r = cond * res.ke[k] * w / r_loop
        main = brush * i + coil * e_over_r
        x = N * theta_m + ph[0]
        sig = i + main * (np.cos(x) + h2 * np.cos(2 * x))
        if bar_fault:  # the damaged segment carries the current under brush A, then under brush B
            sig = sig / (1.0 + bar_fault * _on_segment(theta_m, N))
        for j, (div, a) in enumerate(subs):
            if a:
                sig = sig + a * e_over_r * np.cos(N * theta_m / div + ph[1 + j])
        t_abs = k * T + tau
        sig = ripple_free.added_current(bench, res, k, d, w, t_abs, sig, params, comb_ph)
        # the current channel's offset, as on the log's current (sensors.measure)
        sig = sig + bench.effect_si("current_offset") * offset_share(bench.form("current_offset"), t_abs, res.tc[k],
                                                                     bench.ambient_C)
        if a_int:
            sig = sig + a_int * np.sin(2 * math.pi * f_int * t_abs + ph[4])
        if bench.noise:
            sig = sig + bounce * res.i_mean[k] * rng.standard_normal(nb)
            if la > 0 and d > 0 and not free:  # the jitter of a sample timed within the PWM period
                slope = (bench.supply_V - res.ke[k] * w - r_loop * i) / la
                sig = sig + slope * jit * rng.standard_normal(nb)
        code = sig * bench.i_gain_V_per_A / lsb_V
        if bench.noise:
            code = code + bench.adc_noise_lsb * rng.standard_normal(nb)
        codes.append(np.clip(np.round(code), 0, full).astype(np.int64))
        t0s.append(k * T + float(tau[0]))
    meta = {"sample_hz": f"{fs:g}", "a_per_code": repr(a_per_code), "pwm_hz": f"{fs:g}",
            "sample_phase": "middle of the on-time", "burst_s": repr(nb / fs), **ripple_free.meta(params)}
    return np.array(t0s), codes, meta
