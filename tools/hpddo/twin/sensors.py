"""Measurement chain of the bench: what the acquisition board logs from the true plant.

* Voltage: divider + level shift into the 10-bit ADC (``v_div_gain``, ``v_shift_V``),
  gain error ``v_gain``, offset ``v_offset``. Current: the 0.5 ohm shunt into the ADC, offset
  ``current_offset``, commutation ``ripple`` on the current.
* Oversampling: the ADC converts free running (9615 conversions/s, the two channels
  alternating), so each channel gets N = 9615 / 2 / rate conversions per sample period
  (2404 at 2 Hz, 4 at 1 kHz) and the logged value is their mean. Each conversion is
  an integer code of (signal + ADC noise); the conversions fall at phases of the PWM
  period that drift from one to the next (9.8 conversions per PWM period), which is
  modelled as random phase: the within-period variance of the PWM waveform enters as
  noise. The mean of N codes is therefore the true sample mean plus Gaussian noise
  of sigma = sqrt(noise^2 + waveform variance) / sqrt(N) (in LSB), rounded to 1/N LSB
  and clipped to the code range.
* Encoder: 11 pulses per motor revolution in quadrature = 44 counts per motor
  revolution, counted over the sample period; rpm_ref is output-shaft RPM
  (counts / 44 / 4.4 / T * 60).
* DS18B20 on the case: a new 12-bit reading (0.0625 C steps) every 750 ms; each row
  carries the latest finished reading.
* Glitches: a few single samples where one channel is corrupted (listed in the truth).
"""
from __future__ import annotations

import math

import numpy as np

from .. import bench as _hw
from .. import schema
from ..logs import dataset
from ..model import libm
from .params import Bench, offset_share, v_gain_share


# The encoder's period as the acquisition board measures it: each count's edge time-stamped by
# micros() (4 us steps on the 16 MHz UNO), the row carrying the time between the last two edges at or
# before its end; none (empty) when the older edge is more than ENCODER_TIMEOUT_S before the end.
ENCODER_TICK_S = 4e-6
ENCODER_TIMEOUT_S = 0.1


def _hermite_angle(th0, th1, w0, w1, h, s):
    """The angle at s (0..1 of a step of h) of the cubic that matches th and w at both ends."""
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * th0 + (s3 - 2 * s2 + s) * h * w0 + (-2 * s3 + 3 * s2) * th1
            + (s3 - s2) * h * w1)


def encoder_period_s(theta_m, w_m, Ts, counts_per_rev, off):
    """Per row, the time between the last two encoder edges at or before the row's end (NaN: none
    within ENCODER_TIMEOUT_S). theta_m, w_m: the motor shaft's angle (rad) and speed (rad/s) at the
    n + 1 row boundaries; an edge where theta_m / 2 pi x counts_per_rev + off crosses an integer; the
    angle within a row is the cubic through both ends' angle and speed (the speed never negative)."""
    c = theta_m / (2 * math.pi) * counts_per_rev + off   # counts, at the boundaries
    n = len(c) - 1
    scale = counts_per_rev / (2 * math.pi)

    def edge_time(m):
        """Time of the edge where the count reaches m (each m <= c[-1]), s."""
        j = np.clip(np.searchsorted(c, m, side="left") - 1, 0, n - 1)  # the row whose span holds m
        lo, hi = np.zeros(len(m)), np.ones(len(m))
        for _ in range(40):  # bisection on the monotone cubic
            mid = 0.5 * (lo + hi)
            below = _hermite_angle(c[j], c[j + 1], w_m[j] * scale, w_m[j + 1] * scale, Ts, mid) < m
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return (j + 0.5 * (lo + hi)) * Ts

    t_end = (np.arange(n) + 1) * Ts
    m1 = np.floor(c[1:])            # the last edge at or before each row's end
    first = np.floor(c[0]) + 1      # the first edge of the recording
    ok = m1 - 1 >= first
    out = np.full(n, np.nan)
    if ok.any():
        t1 = edge_time(m1[ok])
        t0 = edge_time(m1[ok] - 1)
        t1q, t0q = np.floor(t1 / ENCODER_TICK_S), np.floor(t0 / ENCODER_TICK_S)
        per = (t1q - t0q) * ENCODER_TICK_S
        fresh = (t_end[ok] - t0 <= ENCODER_TIMEOUT_S) & (per > 0)
        out[np.flatnonzero(ok)[fresh]] = per[fresh]
    return out


def adc_channel(x, var, gain, shift, n_conv, bench: Bench, rng):
    """Mean of ``n_conv`` ADC conversions of a signal with sample mean ``x``."""
    lsb = bench.adc_vref_V / (2 ** bench.adc_bits)
    full = 2 ** bench.adc_bits - 1
    code = gain * (np.asarray(x) + shift) / lsb
    if bench.noise:
        sigma = np.sqrt(bench.adc_noise_lsb ** 2 + var * (gain / lsb) ** 2) / math.sqrt(n_conv)
        code = code + rng.standard_normal(code.shape) * sigma
    code = np.clip(np.round(code * n_conv) / n_conv, 0.0, full)
    return code * lsb / gain - shift


def measure(bench: Bench, res, duty, load, rng):
    """Logged columns (dict of arrays) and the list of injected glitches."""
    n = len(duty)
    rate = res.rate_hz
    Ts = 1.0 / rate
    n_conv = max(1, int(bench.adc_conv_per_s / 2.0 / rate))

    # commutation ripple on the current: a I cos(N theta_m), mean over the sample
    a_rip = bench.effect_si("ripple")
    theta_m = res.theta * bench.gear_ratio
    i_true = res.i_mean.copy()
    i_var = res.i_var.copy()
    if a_rip > 0:
        nr = bench.ripples_per_rev
        phase0 = rng.uniform(0, 2 * math.pi)
        x1 = nr * theta_m[:-1] + phase0
        x2 = nr * theta_m[1:] + phase0
        span = x2 - x1
        small = span < 1e-6
        mean_cos = np.where(small, libm.cos(0.5 * (x1 + x2)),
                            (libm.sin(x2) - libm.sin(x1)) / np.where(small, 1.0, span))
        i_true = i_true + a_rip * res.i_mean * mean_cos
        i_var = i_var + 0.5 * (a_rip * res.i_mean) ** 2
    t_mid = (np.arange(n) + 0.5) * Ts  # the sample's middle, after power-up
    v_meas_in = (res.v_mean * (1.0 + bench.effect_si("v_gain") * v_gain_share(bench.form("v_gain"), res.v_mean))
                 + bench.effect_si("v_offset") * offset_share(bench.form("v_offset"), t_mid, res.tc, bench.ambient_C))
    i_meas_in = i_true + bench.effect_si("current_offset") * offset_share(bench.form("current_offset"), t_mid,
                                                                          res.tc, bench.ambient_C)

    v = adc_channel(v_meas_in, res.v_var, bench.v_div_gain, bench.v_shift_V, n_conv, bench, rng)
    i = adc_channel(i_meas_in, i_var, bench.i_gain_V_per_A, 0.0, n_conv, bench, rng)

    counts_per_rev = _hw.HARDWARE.encoder_quadrature * bench.encoder_ppr
    off = rng.uniform(0, 1)
    cnt = np.floor(theta_m / (2 * math.pi) * counts_per_rev + off)
    rpm_ref = np.diff(cnt) / counts_per_rev / bench.gear_ratio / Ts * 60.0

    if rate >= schema.DYNAMICS_MIN_RATE_HZ:  # a fast log: the speed from the encoder's periods too
        period = encoder_period_s(res.theta * bench.gear_ratio, res.w_bound * bench.gear_ratio, Ts,
                                  counts_per_rev, off)
    # DS18B20: readings finished at m * period; row k carries the latest one at t_end
    t_end = (np.arange(n) + 1) * Ts
    t_read = np.floor(t_end / bench.temp_period_s) * bench.temp_period_s
    tc_at_read = np.interp(t_read, np.concatenate([[0.0], t_end]), np.concatenate([[bench.ambient_C], res.tc]))
    if bench.noise:
        tc_at_read = tc_at_read + 0.02 * rng.standard_normal(n)
    temp = np.round(tc_at_read / bench.temp_step_C) * bench.temp_step_C

    cols = {
        "t_s": np.arange(n) * Ts,
        "duty": np.asarray(duty, dtype=float),
        "v_V": v,
        "i_A": i,
        "rpm_ref": rpm_ref,
        "temp_C": temp,
        "load": np.asarray(load, dtype=np.int64),
        "seq": np.arange(n, dtype=np.int64),
    }
    if rate >= schema.DYNAMICS_MIN_RATE_HZ:
        cols[dataset.ENC_PERIOD_COLUMN] = period
    glitches = []
    if bench.glitches > 0 and n > 10:
        rows = np.sort(rng.choice(np.arange(5, n), size=min(bench.glitches, n - 5), replace=False))
        chans = ("v_V", "i_A", "rpm_ref")
        for j, row in enumerate(rows):
            ch = chans[int(rng.integers(0, 3))]
            true_val = float(cols[ch][row])
            if ch == "v_V":  # a spike on the divider: full-scale code for part of the period
                bad = true_val + float(rng.uniform(2.0, 5.0))
            elif ch == "i_A":  # a dropout or a spike on the shunt channel
                bad = true_val * float(rng.choice([0.0, 2.5])) + (0.0 if true_val > 0.05 else 1.0)
            else:  # electrical noise on the encoder lines: extra counts
                extra = int(rng.integers(60, 200))
                bad = true_val + extra / counts_per_rev / bench.gear_ratio / Ts * 60.0
            cols[ch][row] = bad
            glitches.append({"row": int(row), "t_s": float(cols["t_s"][row]), "column": ch,
                             "true": round(true_val, 6), "logged": round(bad, 6)})
    return cols, glitches
