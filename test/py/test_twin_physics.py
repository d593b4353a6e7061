"""Bench twin physics: PWM-cycle identities, back-EMF relation, energy, heat, approximation."""
import dataclasses
import math

import numpy as np
import pytest

from hpddo.twin import generate, params, plant, protocols, reference

RPM = 60.0 / (2 * math.pi)


def quiet(bench, **kw):
    return dataclasses.replace(bench, noise=False, glitches=0, **kw)


# ---------------------------------------------------------------- one PWM period


@pytest.mark.parametrize("d", [0.05, 0.2, 0.5, 0.8, 0.95, 1.0])
@pytest.mark.parametrize("E", [0.0, 3.0, 7.5])
@pytest.mark.parametrize("la_mH", [0.0, 0.3, 2.5, 20.0])
def test_pwm_cycle_identities(d, E, la_mH):
    """Exact period means: V = Ra I + E + vb*cond, and supply power = sum of uses."""
    b = params.Bench()
    ra, vb = 4.6, 0.4
    (i, i2, vm, vvar, cond, ion, i2on, ioff, i2off) = plant.pwm_cycle(d, E, vb, ra, la_mH * 1e-3, b)
    assert i >= 0 and i2 >= i * i * (1 - 1e-12) and 0 <= cond <= 1
    assert vm == pytest.approx(ra * i + E * (1.0 if i > 0 else 1.0) + vb * cond, abs=1e-9) or i == 0
    if i > 0:
        p_supply = b.supply_V * ion
        p_uses = (ra * i2 + E * i + vb * i + b.r_shunt_ohm * i2 + b.r_dson_ohm * i2on
                  + b.diode_vf_V * ioff + b.diode_r_ohm * i2off)
        assert p_supply == pytest.approx(p_uses, rel=1e-9)
    if la_mH >= 20.0 and d >= 0.8 and E <= 3.0:
        assert cond == pytest.approx(1.0)  # large La, heavy conduction: continuous


def test_pwm_cycle_dcm_vs_ccm_regimes():
    b = params.Bench()
    # light load, small inductance: discontinuous; 100 % duty: continuous
    assert plant.pwm_cycle(0.3, 5.0, 0.0, 4.5, 2.5e-3, b)[4] < 1.0
    assert plant.pwm_cycle(1.0, 5.0, 0.0, 4.5, 2.5e-3, b)[4] == pytest.approx(1.0)


# ---------------------------------------------------------------- whole runs


@pytest.fixture(scope="module")
def ideal_sweep():
    b = params.preset("ideal")
    return b, generate.generate(b, "sweep", 2.0, seed=3)


def _steady_rows(duty, settle=4):
    steady = np.ones(len(duty), bool)
    change = np.flatnonzero(np.diff(duty) != 0) + 1
    for c in change:
        steady[c:c + settle] = False
    steady[:settle] = False
    return steady


def test_steady_state_back_emf_relation(ideal_sweep):
    """Effects off: V = Ra I + Ke w for the logged means, to within the sensor noise.

    Noise budget per row (from the sensor model): the voltage mean of 2404
    conversions carries ~0.1 V rms of PWM aliasing at mid duty, the encoder 0.62 RPM
    of quantisation (0.02 V of EMF). So each row is within ~0.4 V and the mean of all
    steady moving rows (hundreds) within 0.02 V; noise-free true means are exact.
    """
    b, g = ideal_sweep
    log, truth = g["log"], g["truth"]
    ke = b.ke_vs_per_rad
    st = _steady_rows(log["duty"].to_numpy()) & (truth["rpm_true"].to_numpy() > 10)
    assert st.sum() > 300
    # true means: exact (to float and integration rounding)
    r_true = truth["v_true_V"] - b.ra_ohm * truth["i_true_A"] - ke * truth["rpm_true"] / RPM
    assert np.abs(r_true[st]).max() < 1e-6
    # logged means: within noise
    r = log["v_V"] - b.ra_ohm * log["i_A"] - ke * log["rpm_ref"] / RPM
    assert abs(r[st].mean()) < 0.02
    assert np.abs(r[st]).max() < 0.4
    # and the ideal bench identifies its own Ke (eq. 20) to 0.5 %
    from hpddo.twin import check

    assert check.identify_ke(log["v_V"].to_numpy()[st], log["i_A"].to_numpy()[st],
                             log["rpm_ref"].to_numpy()[st]) == pytest.approx(ke, rel=0.005)


def test_energy_balance_default_long():
    """Supply = losses + conversion; conversion = friction + generator + kinetic; heat."""
    b = params.preset("default")
    g = generate.generate(b, "long", 2.0, seed=1, time_scale=0.1)
    e = g["info"]["energy_J"]
    # electrical: supply energy = copper + brush + stage losses + conversion + magnetic storage
    elec = e["copper"] + e["brush"] + e["drive"] + e["conversion"] + e["magnetic_change"]
    # (stage losses are scaled from the periodic waveform while the current is off its
    # periodic state, i.e. during the start-up: a few tenths of a percent)
    assert e["supply"] == pytest.approx(elec, rel=5e-3)
    # mechanical: conversion = both machines' friction + generator load + kinetic storage
    mech = e["friction_motor"] + e["friction_gen"] + e["generator"] + e["kinetic_change"]
    assert e["conversion"] == pytest.approx(mech, rel=1e-4)
    # thermal: heat into the motor = heat to ambient + stored heat
    heat_in = e["copper"] + e["brush"] + e["friction_motor"]
    assert heat_in == pytest.approx(e["heat_to_ambient"] + e["thermal_change"], rel=1e-6)
    assert e["generator"] > 0 and e["copper"] > 0


def test_energy_balance_with_transients():
    """The sweep (11 duty steps, start and stop) keeps the ledger too."""
    b = params.preset("default")
    res = plant.simulate(b, *protocols.per_sample(protocols.schedule("sweep", 0.2), 100.0), 100.0)
    e = res.energy
    mech = e["friction_motor"] + e["friction_gen"] + e["generator"] + e["kinetic_change"]
    assert e["conversion"] == pytest.approx(mech, rel=2e-3)
    elec = e["copper"] + e["brush"] + e["drive"] + e["conversion"] + e["magnetic_change"]
    assert e["supply"] == pytest.approx(elec, rel=1e-2)


def test_thermal_rise_long_run_in_paper_range():
    """Paper 3.6.1: case 31.7 C -> a steady 71.3 C over the long run."""
    info = generate.generate(params.preset("default"), "long", 2.0, seed=1)["info"]
    tr = info["truth"]
    assert tr["case_C_start"] == pytest.approx(31.7)
    assert 60.0 <= tr["case_C_end"] <= 80.0
    assert tr["winding_C_max"] < 130.0  # class B insulation
    assert tr["winding_C_end"] > tr["case_C_end"]


def test_thermal_steady_by_the_end():
    g = generate.generate(params.preset("default"), "long", 2.0, seed=1)
    tc = g["truth"]["case_C"].to_numpy()
    # "rose to a steady 71.3 C": the last 10 minutes move much less than the first 10
    # (the twin's case node, which includes the motor mount, still creeps ~0.3 K/min)
    assert (tc[-1] - tc[-1200]) < 0.3 * (tc[1200] - tc[0])


def test_averaged_model_against_cycle_by_cycle_reference():
    """PWM-averaged plant vs the switched circuit integrated cycle by cycle (RK4,
    200 points per PWM period): speed, current and voltage in steady state, compared
    over 200 ms windows (98 PWM periods, so the reference's window aliasing averages
    out)."""
    b = quiet(params.with_effects(params.preset("ideal"), inductance=2.5, brush_drop=0.5, saturation=4.0))
    rate = 100.0
    duty = np.r_[np.full(40, 0.8), np.full(40, 0.4), np.full(40, 0.2)]
    load = np.r_[np.zeros(60, int), np.full(60, 2)]
    ref = reference.simulate_cycles(b, duty, load, rate, substeps=200)
    avg = plant.simulate(b, duty, load, rate)
    for lo, hi in [(20, 40), (60, 80), (100, 120)]:  # the steady ends of three operating points
        w_ref, w_avg = ref["w_mean"][lo:hi].mean(), avg.w_mean[lo:hi].mean()
        i_ref, i_avg = ref["i_mean"][lo:hi].mean(), avg.i_mean[lo:hi].mean()
        v_ref, v_avg = ref["v_mean"][lo:hi].mean(), avg.v_mean[lo:hi].mean()
        assert w_avg == pytest.approx(w_ref, rel=0.015), (lo, w_ref, w_avg)
        assert i_avg == pytest.approx(i_ref, rel=0.03), (lo, i_ref, i_avg)
        assert v_avg == pytest.approx(v_ref, rel=0.03), (lo, v_ref, v_avg)
    # transients: within 10 % of the speed from the second 10 ms sample after a step on
    for k in (1, 2, 5, 41, 45, 61, 81):
        assert avg.w_mean[k] == pytest.approx(ref["w_mean"][k], rel=0.10, abs=1.0), k


def test_inductance_visible_at_1khz():
    """At 1 kHz the mean current lags a duty step with tau = La / R."""
    base = quiet(params.preset("ideal"))
    segs = [(0.2, 0.8, 0), (0.1, 1.0, 0)]
    duty, load = protocols.per_sample(segs, 1000.0)
    k0 = int(np.flatnonzero(np.diff(duty))[0]) + 1
    frac = {}
    for la in (0.0, 2.5):
        b = params.with_effects(base, inductance=la)
        r = plant.simulate(b, duty, load, 1000.0)
        i = r.i_mean
        jump = i[k0:k0 + 10].max() - i[k0 - 1]
        frac[la] = (i[k0] - i[k0 - 1]) / jump
    b = params.with_effects(base, inductance=2.5)
    tau = 2.5e-3 / (b.ra_ohm + b.r_shunt_ohm + b.r_dson_ohm)
    h = 1e-3
    expect = 1 - tau / h * (1 - math.exp(-h / tau))  # first-sample mean of 1 - exp(-t/tau)
    assert frac[0.0] > 0.95
    assert frac[2.5] == pytest.approx(expect, abs=0.1)
