"""Cycle-by-cycle reference integration of the switched circuit (slow; for checking).

Integrates the instantaneous switched equations (every PWM on/off edge, the diode
blocking when the freewheel current reaches zero) together with the shaft, with RK4
on a fixed grid of ``substeps`` points per PWM period. Temperatures are frozen at
ambient (meant for windows of a few seconds). Returns per-sample true means like
`plant.simulate`, so the PWM-averaged model can be compared against it.
"""
from __future__ import annotations

import math

import numpy as np

from .params import Bench


def simulate_cycles(bench: Bench, duty, load, rate_hz, substeps=200):
    b = bench
    if b.forms:
        raise ValueError("the reference integrator carries the effects' default forms only")
    vb = b.effect_si("brush_drop")
    s_sat = b.effect_si("saturation")
    la = b.effect_si("inductance")
    if la <= 0:
        raise ValueError("the reference integrator needs the inductance effect on")
    a_cu = b.effect_si("thermal_ra")
    b_mag = b.effect_si("magnet_thermal")
    T0 = b.ambient_C
    ra = b.ra_ohm * (1 + a_cu * (T0 - b.ra_ref_C))
    ke_t = b.ke_vs_per_rad * (1 + b_mag * (T0 - b.ra_ref_C))
    Tpwm = 1.0 / b.pwm_hz
    dt = Tpwm / substeps
    Ts = 1.0 / rate_hz
    n = len(duty)
    J = b.j_kgm2
    Tct = b.tc_motor_nm + b.tc_gen_nm
    cgs = [0.0 if math.isinf(r) else b.ke_gen_vs_per_rad ** 2 / (b.r_gen_ohm + b.r_relay_ohm + r)
           for r in b.load_ohm]
    Vs, rsh, rds, rd, vd = b.supply_V, b.r_shunt_ohm, b.r_dson_ohm, b.diode_r_ohm, b.diode_vf_V

    def deriv(i, w, on, cg):
        ke = ke_t * (1 - s_sat * max(i, 0.0))
        E = ke * w
        if on:
            di = (Vs - E - (vb if i > 0 else 0.0) - (ra + rsh + rds) * i) / la
        else:
            di = (-vd - E - vb - (ra + rsh + rd) * i) / la
        tq = ke * i - (b.b_motor_nms + b.b_gen_nms + cg) * w - (Tct if w > 0 else 0.0)
        if w <= 0 and tq < 0:
            tq = 0.0
        return di, tq / J, E

    i = 0.0
    w = 0.0
    t = 0.0
    out = {k: np.zeros(n) for k in ("v_mean", "i_mean", "w_mean")}
    n_total = int(round(n * Ts / dt))
    for step in range(n_total):
        k = min(int(t / Ts + 1e-9), n - 1)
        d = float(duty[k])
        cg = cgs[int(load[k])]
        ph = (t / Tpwm) % 1.0
        on = ph + 1e-12 < d
        blocked = (not on) and i <= 0.0
        if blocked:
            i = 0.0
            # no current: shaft only
            _, a1, E = deriv(0.0, w, True, cg) if False else (0.0, 0.0, 0.0)
            ke = ke_t
            tq = -(b.b_motor_nms + b.b_gen_nms + cg) * w - (Tct if w > 0 else 0.0)
            w_new = max(0.0, w + dt * tq / J)
            v_inst = ke * 0.5 * (w + w_new)
            i_avg = 0.0
            w_avg = 0.5 * (w + w_new)
            w = w_new
        else:
            k1 = deriv(i, w, on, cg)
            k2 = deriv(i + 0.5 * dt * k1[0], w + 0.5 * dt * k1[1], on, cg)
            k3 = deriv(i + 0.5 * dt * k2[0], w + 0.5 * dt * k2[1], on, cg)
            k4 = deriv(i + dt * k3[0], w + dt * k3[1], on, cg)
            i_new = i + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            w_new = w + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            if not on and i_new < 0.0:
                i_new = 0.0
            if w_new < 0.0:
                w_new = 0.0
            i_avg = 0.5 * (i + i_new)
            w_avg = 0.5 * (w + w_new)
            if on:
                v_inst = Vs - (rsh + rds) * i_avg
            else:
                v_inst = -vd - (rsh + rd) * i_avg
            i, w = i_new, w_new
        out["v_mean"][k] += v_inst * dt
        out["i_mean"][k] += i_avg * dt
        out["w_mean"][k] += w_avg * dt
        t += dt
    for key in out:
        out[key] /= Ts
    return out
