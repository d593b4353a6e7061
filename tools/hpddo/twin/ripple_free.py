"""The ripple mode's free-running sampling (issue 33, docs/ripple-captures.md): the current
sampled at a fixed rate that is not synchronised with the PWM, as an ADC left free-running
beside the UNO's default analogWrite (490 Hz) does, with optional mains interference.

What it adds to the synchronous burst of twin/ripple.py, per sample at time t:

* the samples 1 / sample_hz apart from the window's start, at every phase of the PWM period;
* the current's PWM ripple as the plant has it (plant.pwm_waveform: the winding's L / R
  charging towards (Vs - E - vb) / R_on while on, freewheeling towards -(Vf + E + vb) / R_off
  while off, down to zero in discontinuous conduction), its period mean taken out, so the
  window keeps the plant's mean current; the sum floored at zero (the freewheel diode blocks
  a negative current, and with no current there is no commutation ripple either);
* where mains_hz > 0, a rectified-mains comb: lines at 2 k mains_hz of amplitude
  mains_mA x 3 / (4 k^2 - 1) (the Fourier series of |sin|: the first line mains_mA), up to
  the Nyquist frequency, each with its own phase.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..logs import ripple as rf
from . import plant
from .params import BurstParam, brush_share, declared_values, params_md

RIPPLE_FREE = {
    p.name: p
    for p in [
        BurstParam("pwm_hz", "Hz", 0.0, (490.196, 20000.0),
                   "0: the synchronous mode (one sample per PWM period, the PWM at sample_hz); > 0: the PWM "
                   "at this frequency and the samples free-running at sample_hz (the UNO's default "
                   "analogWrite: 490.196 Hz)"),
        BurstParam("mains_hz", "Hz", 0.0, (50.0, 60.0),
                   "0: no mains; > 0: a rectified-mains comb at 2 k x mains_hz in the current (a supply "
                   "rectified from the mains, a mains-powered neighbour), declared in the burst file"),
        BurstParam("mains_mA", "mA", 20.0, (5.0, 100.0), "the comb's first line (2 x mains_hz), mA"),
    ]
}


def ripple_free(**values) -> dict:
    """The free-running parameters (RIPPLE_FREE defaults, names checked) as {name: value}: merged
    into params.ripple_burst()'s dict for generate(..., ripple=...)."""
    out = declared_values(RIPPLE_FREE, values, "free-running")
    if not (out["pwm_hz"] >= 0 and out["mains_hz"] >= 0 and out["mains_mA"] >= 0):
        raise ValueError("pwm_hz, mains_hz and mains_mA must be >= 0")
    return out


def ripple_free_md() -> str:
    """The free-running parameters' table of docs/ripple-captures.md, from RIPPLE_FREE."""
    return params_md(RIPPLE_FREE.values())


def is_free(params: dict) -> bool:
    """Whether the ripple mode's parameters ask for free-running sampling."""
    return float(params.get("pwm_hz", 0.0)) > 0


def sample_times(nb: int, fs: float, duty: float, params: dict) -> np.ndarray:
    """The samples' times from the window's start (s): free-running from it, else the middle of
    the on-time of each PWM period (the synchronous mode)."""
    return np.arange(nb) / fs if is_free(params) else (np.arange(nb) + 0.5 * duty) / fs


def added_current(bench, res, k: int, duty: float, w, t_abs, sig, params: dict, phases) -> np.ndarray:
    """The free-running burst's current: sig (the synchronous model's current at t_abs) plus the
    PWM ripple about its period mean, floored at zero, plus the mains comb (A). w: the shaft speed
    at each sample (rad/s, output), for the back-EMF; phases: one random phase per comb line."""
    if not is_free(params):
        return sig
    pwm_hz = float(params["pwm_hz"])
    b = bench if bench.pwm_hz == pwm_hz else dataclasses.replace(bench, pwm_hz=pwm_hz)
    la = b.effect_si("inductance")
    i_mean = float(res.i_mean[k])
    vb = b.effect_si("brush_drop") * brush_share(b.form("brush_drop"), max(i_mean, 0.0))
    E = float(res.ke[k] * np.mean(w))
    grid = (np.arange(1024) + 0.5) / 1024
    mean = float(plant.pwm_waveform(grid, duty, E, vb, float(res.ra[k]), la, b).mean())
    dev = plant.pwm_waveform(t_abs * pwm_hz, duty, E, vb, float(res.ra[k]), la, b) - mean
    out = np.maximum(sig + dev, 0.0)
    return out + mains_comb(t_abs, params, bench_nyquist_hz=0.5 * float(params["sample_hz"]), phases=phases)


def mains_comb(t_abs, params: dict, bench_nyquist_hz: float, phases) -> np.ndarray:
    """The rectified-mains comb at the times t_abs (A): lines at 2 k mains_hz, 3 mains_mA / (4 k^2 - 1)."""
    f0 = float(params.get("mains_hz", 0.0))
    a0 = float(params.get("mains_mA", 0.0)) / 1000.0
    out = np.zeros_like(np.asarray(t_abs, float))
    if not (f0 > 0 and a0 > 0):
        return out
    n_lines = int(bench_nyquist_hz // (2 * f0))
    for j in range(1, n_lines + 1):
        out = out + a0 * 3.0 / (4 * j * j - 1) * np.cos(2 * math.pi * 2 * j * f0 * t_abs + phases[j % len(phases)])
    return out


def meta(params: dict) -> dict:
    """The burst file's metadata of the free-running mode (logs.ripple's keys); {} when synchronous."""
    if not is_free(params):
        return {}
    m = {rf.SAMPLING: rf.FREE, rf.PWM_HZ: f"{float(params['pwm_hz']):g}", "sample_phase": "free-running"}
    if float(params.get("mains_hz", 0.0)) > 0:
        m[rf.MAINS_HZ] = f"{float(params['mains_hz']):g}"
    return m
