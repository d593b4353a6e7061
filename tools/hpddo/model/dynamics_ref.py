"""The dynamic family on the boards, the Python reference of lib/hpddo_core/src/hpddo/dynamics.h
(hpddo::DynamicsObserver), step for step in float32 (test/core/test_dynamics.cpp and
test/py/test_dynamics.py hold the two to the same bits on the golden vector
test/fixtures/dynamics_golden.h).

A two-state observer at the output shaft: the speed w (rad/s) and the load torque T_L (N m) that
the modelled friction does not explain. The process is the mechanical balance (schema.py, the
dynamic family)

    J dw/dt = Kt i - B w - Tc sgn(w) - T_L,     dT_L/dt = 0,     Kt = Ke (SI),

advanced one sample with the explicit step w+ = w + dt/J (Kt i - B w - Tc s(w) - T_L), the sign
s(w) = clamp(w / W_SMOOTH, -1, 1) (a friction that does not chatter around standstill). The
measurement is the back-EMF speed of the physics model (M2 with its named effects, La di/dt among
them when the inductance is named). The gains put both poles of the error's dynamics at
p = exp(-dt / tau_obs): with a = 1 - dt B / J and g = dt / J,

    l_w = 1 - p^2 / a,     l_T = -(1 - p)^2 / g,

so the estimate follows the back-EMF speed within a few tau_obs and the model smooths the rest
(the channels' noise). The family is named when j_kgm2 > 0; otherwise step() returns the
measured speed itself, the same float (the family off changes nothing).
"""
from __future__ import annotations

import math

import numpy as np

from .. import schema
from .physics import RPM_PER_RAD_S

F32 = np.float32
W_SMOOTH_RAD_S = 0.5   # the speed over which Coulomb friction reaches its full torque (hpddo::kFrictionSmooth_rad_s)


def dynamics_params(**values):
    """A DynamicsParams as a dict of float32, every field of schema.DYNAMICS (0: the family off)."""
    unknown = set(values) - set(schema.DYN_BY_FIELD)
    if unknown:
        raise KeyError(f"no dynamic-family field {sorted(unknown)}")
    return {d.field: F32(values.get(d.field, 0.0)) for d in schema.DYNAMICS}


def named(d) -> bool:
    return bool(d["j_kgm2"] > F32(0))


class DynamicsObserver:
    """hpddo::DynamicsObserver in float32."""

    def __init__(self):
        self.reset()

    def reset(self):
        self.w = F32(0)
        self.load_nm = F32(0)
        self.started = False

    def step(self, ke_vs_per_rad, d, i_A, n_meas_rpm, dt_s):
        """The speed estimate (RPM) after one sample of current i_A (A) and back-EMF speed n_meas_rpm."""
        n_meas = F32(n_meas_rpm)
        if not named(d):
            return n_meas
        dt, i, ke = F32(dt_s), F32(i_A), F32(ke_vs_per_rad)
        if not (dt > F32(0)) or not np.isfinite(n_meas) or not np.isfinite(i):
            return n_meas
        y = F32(n_meas / F32(RPM_PER_RAD_S))
        J, B, Tc = d["j_kgm2"], d["b_nms_per_rad"], d["tc_nm"]
        if not self.started:  # start settled: the load torque that holds the measured speed
            self.w = y
            self.load_nm = F32(F32(ke * i) - F32(B * y) - F32(Tc * _sign(y)))
            self.started = True
            return n_meas
        g = F32(dt / J)
        a = F32(F32(1) - F32(g * B))
        p = exp_neg(F32(-dt / d["tau_obs_s"])) if d["tau_obs_s"] > F32(0) else F32(0)
        lw = F32(F32(1) - F32(F32(p * p) / a))
        lt = F32(-F32(F32(F32(1) - p) * F32(F32(1) - p)) / g)
        torque = F32(F32(F32(ke * i) - F32(Tc * _sign(self.w))) - self.load_nm)
        w_pred = F32(F32(a * self.w) + F32(g * torque))
        e = F32(y - w_pred)
        self.w = F32(w_pred + F32(lw * e))
        self.load_nm = F32(self.load_nm + F32(lt * e))
        return F32(self.w * F32(RPM_PER_RAD_S))


# hpddo::exp_neg's constants (dynamics.h), float32: ln 2 split for Cody-Waite, the Taylor
# coefficients of e^r to r^7 (highest first).
_LOG2E = F32(1.44269504)
_LN2_HI, _LN2_LO = F32(0.693359375), F32(-2.12194440e-4)
_EXP_COEF = [F32(c) for c in (1.98412698e-4, 1.38888889e-3, 8.33333377e-3, 4.16666679e-2, 1.66666672e-1, 0.5, 1.0, 1.0)]


def exp_neg(x):
    """hpddo::exp_neg, step for step in float32: e^x for x <= 0 with the same bits on every board
    (no libm: the C libraries' expf differ in the last bits), 0 below -40."""
    x = F32(x)
    if not (x > F32(-40)):
        return F32(0)
    if x >= F32(0):
        return F32(1)
    n = int(F32(F32(x * _LOG2E) - F32(0.5)))  # C's cast: toward zero
    fn = F32(n)
    r = F32(F32(x - F32(fn * _LN2_HI)) - F32(fn * _LN2_LO))
    e = _EXP_COEF[0]
    for c in _EXP_COEF[1:]:
        e = F32(F32(e * r) + c)
    return F32(e * F32(2.0 ** n))


def _sign(w):
    s = F32(w / F32(W_SMOOTH_RAD_S))
    return F32(1) if s > F32(1) else F32(-1) if s < F32(-1) else s


def run(ke_vs_per_rad, d, i_A, n_meas_rpm, dt_s) -> tuple[np.ndarray, np.ndarray]:
    """(speed RPM, load torque N m) per sample of the observer over arrays."""
    obs = DynamicsObserver()
    i_A, n_meas_rpm = np.asarray(i_A, float), np.asarray(n_meas_rpm, float)
    dt = np.broadcast_to(np.asarray(dt_s, float), i_A.shape)
    n_out, load = np.empty(len(i_A), F32), np.empty(len(i_A), F32)
    for k in range(len(i_A)):
        n_out[k] = obs.step(ke_vs_per_rad, d, i_A[k], n_meas_rpm[k], dt[k])
        load[k] = obs.load_nm
    return n_out, load


# ---------------------------------------------------------------------------------------
# The golden vector: test/fixtures/dynamics_golden.h, generated here and compared byte for byte
# (test/py/test_dynamics.py), read by test/core/test_dynamics.cpp.

GOLDEN = "test/fixtures/dynamics_golden.h"
GOLDEN_COMMAND = "cd tools && python -m hpddo.model.dynamics_ref --write"
GOLDEN_KE = 0.355
GOLDEN_DT_S = 0.01
# The twin's shaft (twin/params.py): J, motor plus generator friction, an observer of 20 ms.
GOLDEN_ON = dict(j_kgm2=3.0e-4, b_nms_per_rad=4.0e-3, tc_nm=0.095, tau_obs_s=0.02)


def golden_inputs(n: int = 200):
    """Duty steps seen as a current and a noisy back-EMF speed: (i_A, n_meas_rpm) float32, from a
    fixed integer sequence (no random generator, no libm: the same numbers everywhere)."""
    i = np.empty(n, F32)
    m = np.empty(n, F32)
    state = 12345
    for k in range(n):
        level = (k // 40) % 4                        # four levels, 40 samples each
        state = (1103515245 * state + 12345) % (1 << 31)
        noise = (state / float(1 << 31)) - 0.5       # -0.5..0.5
        i[k] = F32(0.2 + 0.1 * level + 0.05 * noise + (0.6 if k % 40 == 0 and k else 0.0))
        m[k] = F32(30.0 + 40.0 * level + 12.0 * noise)
    return i, m


def golden_exp_args() -> np.ndarray:
    """The arguments of exp_neg's golden rows: -k^2/64 for k = 0..50 (to -39.1, each exact in
    float32) and -dt/tau for the bench's periods over the observer's taus (the poles the boards
    compute), float32."""
    wide = [F32(-(k * k) / 64.0) for k in range(51)]
    poles = [F32(-F32(dt) / F32(tau)) for dt in (0.5, 0.1, 0.01, 0.008, 0.001)
             for tau in (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)]
    return np.array(wide + poles, F32)


def golden_h() -> str:
    """The text of the golden vector's header."""
    i, m = golden_inputs()
    xs = golden_exp_args()
    d = dynamics_params(**GOLDEN_ON)
    out, load = run(GOLDEN_KE, d, i, m, GOLDEN_DT_S)
    def h(x) -> str:  # 9 significant digits: the float32 exactly, always a float literal
        t = f"{float(x):.9g}"
        return t if any(c in t for c in ".en") else t + ".0"
    rows = "\n".join(f"  {{{h(a)}f, {h(b)}f, {h(c)}f, {h(e)}f}}," for a, b, c, e in zip(i, m, out, load))
    exp_rows = "\n".join(f"  {{{h(x)}f, {h(exp_neg(x))}f}}," for x in xs)
    return f"""// GENERATED golden vector of the dynamic family's observer: DO NOT EDIT.
// command: {GOLDEN_COMMAND}
// source: tools/hpddo/model/dynamics_ref.py (the Python reference of hpddo/dynamics.h)
#ifndef HPDDO_DYNAMICS_GOLDEN_H
#define HPDDO_DYNAMICS_GOLDEN_H

#include "hpddo/platform.h"

namespace dynamics_golden {{

static const float kKe = {h(F32(GOLDEN_KE))}f;
static const float kDt = {h(F32(GOLDEN_DT_S))}f;
static const float kJ = {h(d['j_kgm2'])}f;
static const float kB = {h(d['b_nms_per_rad'])}f;
static const float kTc = {h(d['tc_nm'])}f;
static const float kTau = {h(d['tau_obs_s'])}f;

/// i_A, back-EMF speed (RPM), the observer's speed (RPM), its load torque (N m), per sample; in
/// flash on the boards (3.2 KB: more than the UNO's RAM), read with at().
HPDDO_FLASH static const float kRows[][4] = {{
{rows}
}};
static const int kN = {len(i)};

/// Row k, column c of kRows.
inline float at(int k, int c) {{ return hpddo::flash_float(&kRows[k][c]); }}

/// x and hpddo::exp_neg(x) (the observer's pole e^(-dt/tau)), per row.
HPDDO_FLASH static const float kExp[][2] = {{
{exp_rows}
}};
static const int kExpN = {len(xs)};

/// Row k, column c of kExp.
inline float exp_at(int k, int c) {{ return hpddo::flash_float(&kExp[k][c]); }}

}}  // namespace dynamics_golden

#endif  // HPDDO_DYNAMICS_GOLDEN_H
"""


def main(argv=None) -> int:
    import argparse
    import pathlib
    ap = argparse.ArgumentParser(prog="python -m hpddo.model.dynamics_ref", description="write or check " + GOLDEN)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true")
    g.add_argument("--check", action="store_true")
    args = ap.parse_args(argv)
    path = pathlib.Path(schema.ROOT) / GOLDEN
    text = golden_h()
    if args.check:
        same = path.exists() and path.read_text() == text
        print(f"{GOLDEN}: {'up to date' if same else 'out of date: ' + GOLDEN_COMMAND}")
        return 0 if same else 1
    path.write_text(text)
    print(f"wrote {GOLDEN}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
