"""The physics models M1 and M2 in numpy, term for term as lib/hpddo_core/src/hpddo/physics.h.

    v_true = ra(T) i_true + brush(i_true) + la di/dt + ke(T, i_true) w

Vectorised over samples; `dtype` selects float32 (to mirror the boards exactly) or
float64 (for identification). Field names and units match the C++ PhysicsParams.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

RPM_PER_RAD_S = 60.0 / (2.0 * np.pi)
BRUSH_KNEE_A = 0.02

# Effect names, as in the bench twin and the diagnosis, with their C++ bit and
# the PhysicsParams field that carries their coefficient.
EFFECT_BITS = {
    "thermal_ra": (1 << 0, "ra_tc_per_K"),
    "magnet_thermal": (1 << 1, "ke_tc_per_K"),
    "brush_drop": (1 << 2, "brush_V"),
    "saturation": (1 << 3, "ke_sat_per_A"),
    "current_offset": (1 << 4, "i_offset_A"),
    "v_gain": (1 << 5, "v_gain"),
    "inductance": (1 << 6, "la_H"),
}


@dataclasses.dataclass
class PhysicsParams:
    """Lumped parameters of one assembly (SI units, speed at the output shaft)."""

    ra_ohm: float
    ke_vs_per_rad: float
    t_ref_C: float = 25.0
    ra_tc_per_K: float = 0.0
    ke_tc_per_K: float = 0.0
    brush_V: float = 0.0
    ke_sat_per_A: float = 0.0
    i_offset_A: float = 0.0
    v_gain: float = 0.0
    la_H: float = 0.0
    th_r_K_per_W: float = 0.0
    th_tau_s: float = 0.0
    t_amb_C: float = 25.0
    effects: int = 0

    FIELDS = (
        "ra_ohm", "ke_vs_per_rad", "t_ref_C", "ra_tc_per_K", "ke_tc_per_K", "brush_V",
        "ke_sat_per_A", "i_offset_A", "v_gain", "la_H", "th_r_K_per_W", "th_tau_s", "t_amb_C",
    )

    def effect_names(self) -> list[str]:
        return [name for name, (bit, _) in EFFECT_BITS.items() if self.effects & bit]

    def thermal_enabled(self) -> bool:
        return self.th_r_K_per_W > 0.0 and self.th_tau_s > 0.0


def nameplate_ke_vs_per_rad(rated_V: float, rated_rpm: float) -> float:
    """M1's Ke: rated voltage over rated (no-load) speed, armature drop neglected."""
    return rated_V / (rated_rpm / RPM_PER_RAD_S)


def nameplate_params(ra_ohm: float, rated_V: float = 12.0, rated_rpm: float = 1000.0) -> PhysicsParams:
    return PhysicsParams(ra_ohm=ra_ohm, ke_vs_per_rad=nameplate_ke_vs_per_rad(rated_V, rated_rpm))


def _f(p: PhysicsParams, name: str, dtype):
    return dtype(getattr(p, name))


def true_current_A(p, i_A, dtype=np.float64):
    return np.asarray(i_A, dtype) - _f(p, "i_offset_A", dtype)


def true_voltage_V(p, v_V, dtype=np.float64):
    return np.asarray(v_V, dtype) / (dtype(1.0) + _f(p, "v_gain", dtype))


def ra_at_ohm(p, temp_C, dtype=np.float64):
    t = np.asarray(temp_C, dtype)
    return _f(p, "ra_ohm", dtype) * (dtype(1.0) + _f(p, "ra_tc_per_K", dtype) * (t - _f(p, "t_ref_C", dtype)))


def brush_drop_V(p, i_true_A, dtype=np.float64):
    i = np.asarray(i_true_A, dtype)
    return _f(p, "brush_V", dtype) * i / (np.abs(i) + dtype(BRUSH_KNEE_A))


def ke_at_vs_per_rad(p, temp_C, i_true_A, dtype=np.float64):
    t = np.asarray(temp_C, dtype)
    i = np.asarray(i_true_A, dtype)
    return (_f(p, "ke_vs_per_rad", dtype) * (dtype(1.0) + _f(p, "ke_tc_per_K", dtype) * (t - _f(p, "t_ref_C", dtype)))
            * (dtype(1.0) - _f(p, "ke_sat_per_A", dtype) * np.abs(i)))


def back_emf_V(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype=np.float64):
    i = true_current_A(p, i_A, dtype)
    return (true_voltage_V(p, v_V, dtype) - ra_at_ohm(p, temp_C, dtype) * i - brush_drop_V(p, i, dtype)
            - _f(p, "la_H", dtype) * np.asarray(di_dt_A_per_s, dtype))


def physics_rpm(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype=np.float64):
    """Output-shaft RPM; NaN where the effective Ke is not positive."""
    ke = ke_at_vs_per_rad(p, temp_C, true_current_A(p, i_A, dtype), dtype)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = back_emf_V(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype) / ke * dtype(RPM_PER_RAD_S)
    return np.where(ke > 0, n, np.nan).astype(dtype)


def thermal_trajectory(p, i_true_A, dt_s, dtype=np.float64, start_C=None):
    """Winding temperature estimate per sample, as ThermalEstimator::step before each sample."""
    i = np.asarray(i_true_A, dtype)
    dt = np.asarray(dt_s, dtype)
    out = np.empty(len(i), dtype)
    t = dtype(p.t_amb_C if start_C is None else start_C)
    if not p.thermal_enabled():
        out[:] = t
        return out
    if np.dtype(dtype) == np.float64:  # same steps on Python floats: ~20x faster for fits
        ra, a, tref = float(p.ra_ohm), float(p.ra_tc_per_K), float(p.t_ref_C)
        r, tau, amb, tf = float(p.th_r_K_per_W), float(p.th_tau_s), float(p.t_amb_C), float(t)
        for k, (ik, dk) in enumerate(zip(i.tolist(), dt.tolist())):
            if dk > 0:
                target = amb + r * (ik * ik * (ra * (1.0 + a * (tf - tref))))
                tf = target + (tf - target) * math.exp(-dk / tau)
            out[k] = tf
        return out
    r = dtype(p.th_r_K_per_W)
    tau = dtype(p.th_tau_s)
    amb = dtype(p.t_amb_C)
    for k in range(len(i)):
        if dt[k] > 0:
            loss = i[k] * i[k] * ra_at_ohm(p, t, dtype)
            target = amb + r * loss
            t = dtype(target + (t - target) * np.exp(-dt[k] / tau).astype(dtype))
        out[k] = t
    return out
