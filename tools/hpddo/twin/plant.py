"""Plant of the bench twin: PWM power stage, armature, shaft, generator load, thermal.

Electrical model (per PWM period, exact for a constant back-EMF within the period)
--------------------------------------------------------------------------------
Low-side MOSFET, freewheel diode across the motor, shunt in the armature loop.
With brush drop ``vb`` (only while current flows) and back-EMF ``E``:

* on  (d T):      La di/dt = Vs - E - vb - (Ra + Rsh + Rds) i
* off, conducting: La di/dt = -Vd - E - vb - (Ra + Rsh + rd) i   until i = 0
* off, i = 0 (discontinuous conduction): terminal voltage = E

Each phase is an exponential; `pwm_cycle` returns the periodic steady state (CCM or
DCM) and its exact period means. Over a whole period v_m = Ra i + La di/dt + E + vb
holds at every instant, so the means obey  V = Ra I + E + vb * (conduction fraction).

Slow model (what is integrated)
-------------------------------
The mean current follows its periodic steady state ``I_ss(d, E)`` with the averaged
time constant tau_e = La / (Ra + Rsh + d Rds + (1 - d) rd) (exact state-space average
in CCM, an approximation in DCM where the true settling is faster). The shaft speed
is integrated with a linearised implicit midpoint step (2nd order, A-stable) that
includes dI_ss/dw (the electrical damping), so steps may be longer than tau_e and the
mechanical time constant, and kinetic energy change = (torque - losses) x speed holds
exactly per step; steps are short (h0) right after each duty or load change and grow
geometrically to h_max. Thermal: two nodes (winding, case), explicit Euler
(h_max << tau).

Ripple of the PWM current/voltage inside a period is not integrated; `simulate`
returns its variance per sample so the sensor model can add the aliasing noise of
an asynchronously sampling ADC.
"""
from __future__ import annotations

import math

import numpy as np

from .params import MAGNET_LAG_S, Bench, brush_share, saturation_shape


def _seg(A, B, tau, t):
    """Integrals of i(s) = A + B exp(-s/tau) over [0, t]: (int i, int i^2, i(t))."""
    if t <= 0.0:
        return 0.0, 0.0, A + B
    x = t / tau
    e1 = math.exp(-x)
    one_m_e1 = -math.expm1(-x)
    one_m_e2 = -math.expm1(-2.0 * x)
    si = A * t + B * tau * one_m_e1
    si2 = A * A * t + 2.0 * A * B * tau * one_m_e1 + B * B * tau * 0.5 * one_m_e2
    return si, si2, A + B * e1


def pwm_cycle(d, E, vb, ra, la, b: Bench):
    """Periodic steady state of one PWM period.

    Returns a tuple:
    (i_mean, i2_mean, v_mean, v_var, cond_frac, ion_mean, i2on_mean, ioff_mean, i2off_mean)
    where ``ion_mean`` = (1/T) int_on i dt (the supply current), ``i2on_mean`` =
    (1/T) int_on i^2, ``ioff_mean``/``i2off_mean`` the same over the freewheel phase,
    ``v_var`` the variance of the terminal voltage over the period (two-level
    approximation, used for ADC aliasing noise only).
    """
    T = 1.0 / b.pwm_hz
    Vs = b.supply_V
    r_on_ext = b.r_shunt_ohm + b.r_dson_ohm
    r_off_ext = b.r_shunt_ohm + b.diode_r_ohm
    R_on = ra + r_on_ext
    R_off = ra + r_off_ext
    A_on = Vs - E - vb
    if d <= 0.0 or A_on <= 0.0:
        # no current can flow: terminal voltage Vs while on, E while off
        vm = d * Vs + (1.0 - d) * E
        var = d * (1.0 - d) * (Vs - E) ** 2
        return 0.0, 0.0, vm, var, 0.0, 0.0, 0.0, 0.0, 0.0
    I1 = A_on / R_on
    t_on = d * T
    t_off = T - t_on
    if la <= 0.0:
        # resistive limit: current I1 while on, zero (not freewheeling) while off
        si_on, si2_on = I1 * t_on, I1 * I1 * t_on
        v_on = Vs - r_on_ext * I1
        vm = d * v_on + (1.0 - d) * E
        var = d * (1.0 - d) * (v_on - E) ** 2
        return (si_on / T, si2_on / T, vm, var, d, si_on / T, si2_on / T, 0.0, 0.0)
    I2, tau_on, tau_off, i0 = _periodic_start(I1, t_on, t_off, R_on, R_off, E, vb, la, b)
    if i0 > 0.0:  # continuous conduction
        si_on, si2_on, i1 = _seg(I1, i0 - I1, tau_on, t_on)
        t_c = t_off
        si_off, si2_off, _ = _seg(I2, i1 - I2, tau_off, t_c)
    else:  # discontinuous: starts each period from zero
        i0 = 0.0
        si_on, si2_on, i1 = _seg(I1, -I1, tau_on, t_on)
        t_c = min(t_off, tau_off * math.log((i1 - I2) / (-I2)))
        si_off, si2_off, _ = _seg(I2, i1 - I2, tau_off, t_c)
    v_on_int = Vs * t_on - r_on_ext * si_on
    v_offc_int = -b.diode_vf_V * t_c - r_off_ext * si_off
    v_idle_int = E * (t_off - t_c)
    vm = (v_on_int + v_offc_int + v_idle_int) / T
    v_on = v_on_int / t_on
    v_off = (v_offc_int + v_idle_int) / t_off if t_off > 0 else 0.0
    var = d * (1.0 - d) * (v_on - v_off) ** 2
    return (
        (si_on + si_off) / T,
        (si2_on + si2_off) / T,
        vm,
        var,
        (t_on + t_c) / T,
        si_on / T,
        si2_on / T,
        si_off / T,
        si2_off / T,
    )


def _periodic_start(I1, t_on, t_off, R_on, R_off, E, vb, la, b: Bench):
    """The freewheel asymptote I2 (< 0), the on and off time constants, and the current at the
    start of the on-time in the periodic steady state (<= 0: discontinuous conduction)."""
    A_off = -b.diode_vf_V - E - vb
    I2 = A_off / R_off  # < 0: asymptote the freewheel current heads for
    tau_on = la / R_on
    tau_off = la / R_off
    a_on = math.exp(-t_on / tau_on)
    a_off = math.exp(-t_off / tau_off)
    den = 1.0 - a_on * a_off
    i0 = (I2 * (1.0 - a_off) + a_off * I1 * (1.0 - a_on)) / den if den > 0 else I1
    return I2, tau_on, tau_off, i0


def pwm_waveform(phase, d, E, vb, ra, la, b: Bench):
    """The armature current (A) at the PWM phases `phase` (0..1, from the start of the on-time) in
    the periodic steady state that pwm_cycle integrates: on, the supply drives it towards
    (Vs - E - vb) / R_on with time constant La / R_on; off, the freewheel diode towards
    -(Vf + E + vb) / R_off with La / R_off, until it reaches zero (discontinuous conduction)."""
    phase = np.asarray(phase, float) % 1.0
    T = 1.0 / b.pwm_hz
    R_on = ra + b.r_shunt_ohm + b.r_dson_ohm
    R_off = ra + b.r_shunt_ohm + b.diode_r_ohm
    A_on = b.supply_V - E - vb
    if d <= 0.0 or A_on <= 0.0:
        return np.zeros_like(phase)
    I1 = A_on / R_on
    t_on, t_off = d * T, T - d * T
    s = phase * T
    if la <= 0.0:
        return np.where(s < t_on, I1, 0.0)
    I2, tau_on, tau_off, i0 = _periodic_start(I1, t_on, t_off, R_on, R_off, E, vb, la, b)
    i0 = max(i0, 0.0)
    i1 = I1 + (i0 - I1) * math.exp(-t_on / tau_on)
    on = I1 + (i0 - I1) * np.exp(-s / tau_on)
    off = np.maximum(I2 + (i1 - I2) * np.exp(-(s - t_on) / tau_off), 0.0)
    return np.where(s < t_on, on, off)


def load_damping_nms(b: Bench, load: int) -> float:
    """The generator's braking per rad/s at the shared shaft under load state `load` (N m s):
    Ke_gen^2 / (R_gen + R_relay + R_load), none with the load open."""
    r_l = b.load_ohm[int(load)]
    return 0.0 if math.isinf(r_l) else b.ke_gen_vs_per_rad ** 2 / (b.r_gen_ohm + b.r_relay_ohm + r_l)


class Result:
    """Per-sample true means and states, and the energy ledger of a run."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def simulate(bench: Bench, duty, load, rate_hz, h_max=None, h0=2e-4, growth=1.15, progress=None):
    """Integrate the bench over the per-sample duty/load commands.

    Returns a `Result` with arrays per sample (length n): ``v_mean, i_mean, w_mean``
    (output shaft, rad/s), ``v_var, i_var`` (PWM ripple variance), ``cond`` (conduction
    fraction), ``ra, ke`` (true values, sample means), ``tw, tc`` (winding/case
    temperature at the sample end), ``theta`` (output shaft angle at the n+1 sample
    boundaries, rad), ``w_bound`` (output shaft speed there, rad/s) and ``energy`` (dict of joules over the run).
    """
    duty = np.asarray(duty, dtype=float)
    load = np.asarray(load)
    n = len(duty)
    Ts = 1.0 / rate_hz
    if h_max is None:
        h_max = min(0.05, Ts)
    h_max = min(h_max, Ts)

    b = bench
    a_cu = b.effect_si("thermal_ra")
    b_mag = b.effect_si("magnet_thermal")
    vb = b.effect_si("brush_drop")
    s_sat = b.effect_si("saturation")
    la = b.effect_si("inductance")
    sat_form, brush_form, copper_form = b.form("saturation"), b.form("brush_drop"), b.form("thermal_ra")
    magnet_form = b.form("magnet_thermal")
    ra_ref = b.ra_ohm
    t_ref = b.ra_ref_C
    ke0 = b.ke_vs_per_rad
    J = b.j_kgm2
    bm, bg = b.b_motor_nms, b.b_gen_nms
    tcm, tcg = b.tc_motor_nm, b.tc_gen_nm
    Tct = tcm + tcg
    rsh, rds, rd, vd, Vs = b.r_shunt_ohm, b.r_dson_ohm, b.diode_r_ohm, b.diode_vf_V, b.supply_V
    cg_of = [load_damping_nms(b, L) for L in range(len(b.load_ohm))]
    Cw, Cc = b.c_winding_J_per_K, b.c_case_J_per_K
    Rwc, Rca = b.r_winding_case_K_per_W, b.r_case_amb_K_per_W
    Ta = b.ambient_C

    # state
    w = 0.0
    ib = 0.0
    Tw = Ta
    Tc = Ta
    Tm = Ta  # the magnets' own node ("lag_600s" form)
    theta = 0.0
    out = {k: np.empty(n) for k in ("v_mean", "i_mean", "w_mean", "v_var", "i_var", "cond",
                                     "ra", "ke", "tw", "tc", "i2_mean")}
    thetas = np.empty(n + 1)
    thetas[0] = 0.0
    w_bound = np.empty(n + 1)  # output-shaft speed at the sample boundaries (the ripple bursts' shape)
    w_bound[0] = w
    en = dict(supply=0.0, terminal=0.0, copper=0.0, brush=0.0, drive=0.0, conversion=0.0,
              friction_motor=0.0, friction_gen=0.0, generator=0.0, heat_to_ambient=0.0)
    ke_start = 0.5 * J * w * w
    wmag_start = 0.5 * la * ib * ib
    u_start = Cw * Tw + Cc * Tc

    h = h0
    prev = None
    prog_every = max(1, n // 500)
    prog_done = 0
    dw_fd = 1e-3  # rad/s, finite difference for dI_ss/dw
    for k in range(n):
        d = float(duty[k])
        L = int(load[k])
        if prev != (d, L):
            h = h0
            prev = (d, L)
        cg = cg_of[L]
        Bt = bm + bg + cg
        t_rem = Ts
        s_v = s_i = s_w = s_vv = s_iv = s_c = s_ra = s_ke = s_i2 = 0.0
        while t_rem > 1e-12:
            hh = h if h < t_rem else t_rem
            if t_rem - hh < 0.25 * hh:
                hh = t_rem
            ra = ra_ref * (1.0 + a_cu * ((Tc if copper_form == "case" else Tw) - t_ref))
            t_mag = Tw if magnet_form == "winding" else Tm if magnet_form == "lag_600s" else Tc
            ke_flux = ke0 * (1.0 + b_mag * (t_mag - t_ref))
            ib_pos = ib if ib > 0.0 else 0.0
            sat = saturation_shape(sat_form, ib_pos)
            ke = ke_flux * (1.0 - s_sat * sat)  # mean EMF constant (armature reaction)
            E = ke * w
            vb_k = vb * brush_share(brush_form, ib_pos)  # the drop at the mean current (quasi-static)
            sol = pwm_cycle(d, E, vb_k, ra, la, b)
            sol2 = pwm_cycle(d, E + ke * dw_fd, vb_k, ra, la, b)
            Iss, i2ss, vss = sol[0], sol[1], sol[2]
            ff = i2ss / (Iss * Iss) if Iss > 1e-9 else 1.0
            # mean torque ke_flux * mean(i (1 - s i)) = ke_flux (I - s <i^2>): PWM ripple counts
            kt = ke_flux * (1.0 - s_sat * ff * sat)
            g = (sol2[0] - Iss) / dw_fd
            gv = (sol2[2] - vss) / dw_fd
            if la > 0.0:
                r_loop = ra + rsh + d * rds + (1.0 - d) * rd
                tau_e = la / r_loop
                x = hh / tau_e
                a = math.exp(-x)
                phi = -math.expm1(-x) / x
            else:
                r_loop = ra
                a = 0.0
                phi = 0.0
            dev0 = ib - Iss
            drive0 = kt * (Iss + dev0 * phi)
            if w <= 0.0 and drive0 <= Tct:
                dw = 0.0  # static friction holds the shaft
            else:
                # implicit midpoint: J dw/h = ke I_step - Bt (w + dw/2) - Tc,
                # I_step = Iss + g dw/2 + dev0 phi (mean current over the step)
                denom = J / hh - 0.5 * kt * g + 0.5 * Bt
                dw = (drive0 - Bt * w - Tct) / denom
                if w + dw < 0.0:
                    dw = -w
            w_new = w + dw
            wm = w + 0.5 * dw
            i_step = Iss + 0.5 * g * dw + dev0 * phi
            ib_new = Iss + g * dw + dev0 * a
            v_step = vss + 0.5 * gv * dw - dev0 * phi * (r_loop - ra)
            i2_step = i_step * i_step * ff
            # energy ledger (powers times step)
            p_cu = ra * i2_step
            p_br = vb_k * i_step
            r = i_step / Iss if Iss > 1e-9 else 0.0
            p_drive = rsh * i2ss * r * r + rds * sol[6] * r * r + vd * sol[7] * r + rd * sol[8] * r * r
            p_conv = kt * i_step * wm
            moving = wm > 0.0
            p_fm = (bm * wm + tcm) * wm if moving else 0.0
            p_fg = (bg * wm + tcg) * wm if moving else 0.0
            p_gen = cg * wm * wm
            en["supply"] += Vs * sol[5] * r * hh
            en["terminal"] += (p_cu + p_br + p_conv) * hh
            en["copper"] += p_cu * hh
            en["brush"] += p_br * hh
            en["drive"] += p_drive * hh
            en["conversion"] += p_conv * hh
            en["friction_motor"] += p_fm * hh
            en["friction_gen"] += p_fg * hh
            en["generator"] += p_gen * hh
            # thermal: copper heats the winding; brush and motor/gearbox friction the case
            q_wc = (Tw - Tc) / Rwc
            q_ca = (Tc - Ta) / Rca
            en["heat_to_ambient"] += q_ca * hh
            Tw_new = Tw + hh / Cw * (p_cu - q_wc)
            Tc = Tc + hh / Cc * (q_wc + p_br + p_fm - q_ca)
            Tw = Tw_new
            Tm = Tm + (Tc - Tm) * -math.expm1(-hh / MAGNET_LAG_S)
            # sample accumulators
            s_v += v_step * hh
            s_i += i_step * hh
            s_i2 += i2_step * hh
            s_w += wm * hh
            s_vv += sol[3] * hh
            s_iv += (i2ss - Iss * Iss) * hh
            s_c += sol[4] * hh
            s_ra += ra * hh
            s_ke += ke * hh
            theta += wm * hh
            w = w_new
            ib = ib_new
            t_rem -= hh
            h = h * growth
            if h > h_max:
                h = h_max
        out["v_mean"][k] = s_v / Ts
        out["i_mean"][k] = s_i / Ts
        out["i2_mean"][k] = s_i2 / Ts
        out["w_mean"][k] = s_w / Ts
        out["v_var"][k] = s_vv / Ts
        out["i_var"][k] = s_iv / Ts
        out["cond"][k] = s_c / Ts
        out["ra"][k] = s_ra / Ts
        out["ke"][k] = s_ke / Ts
        out["tw"][k] = Tw
        out["tc"][k] = Tc
        thetas[k + 1] = theta
        w_bound[k + 1] = w
        if progress is not None and (k % prog_every == prog_every - 1 or k == n - 1):
            progress(Ts * (k + 1 - prog_done))
            prog_done = k + 1

    en["kinetic_change"] = 0.5 * J * w * w - ke_start
    en["magnetic_change"] = 0.5 * la * ib * ib - wmag_start
    en["thermal_change"] = Cw * Tw + Cc * Tc - u_start
    return Result(theta=thetas, w_bound=w_bound, energy=en, rate_hz=rate_hz, **out)
