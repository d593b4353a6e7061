"""Each effect switched on alone changes the M2 error the way its physics says.

M2 here is n = (V - I * 4.50) / Ke * 60/2pi with the bench's true Ke at the reference
temperature and zero current, compared with the true speed, so an effect's bias is
seen whole (the paper's eq. 20 identification would absorb its mean). The sensor
noise is off so the checks can be tight; one test checks the identified-Ke M2 too.
"""
import dataclasses
import math

import numpy as np
import pytest

from hpddo.twin import check, generate, params

RPM = 60.0 / (2 * math.pi)
RA = 4.50


def run(protocol, rate=2.0, time_scale=1.0, noise=False, **effects):
    b = params.with_effects(params.preset("ideal"), **effects)
    b = dataclasses.replace(b, noise=noise, glitches=0)
    g = generate.generate(b, protocol, rate, seed=5, time_scale=time_scale)
    err = (g["log"]["v_V"] - RA * g["log"]["i_A"]) / b.ke_vs_per_rad * RPM - g["truth"]["rpm_true"]
    return b, g, err.to_numpy()


def moving(g, min_rpm=20.0):
    return g["truth"]["rpm_true"].to_numpy() > min_rpm


def test_all_off_has_no_bias():
    _, g, err = run("load")
    m = moving(g)
    assert abs(err[m].mean()) < 0.3 and np.abs(err[m]).max() < 3.0


def test_thermal_ra_overestimates_increasingly():
    b, g, err = run("long", thermal_ra=0.393)
    tr = g["truth"]
    # physics: the extra resistive drop I (Ra(T) - 4.50) is read as back-EMF
    expect = tr["i_true_A"] * (tr["ra_ohm"] - RA) / b.ke_vs_per_rad * RPM
    m = moving(g)
    assert np.allclose(err[m], expect[m], atol=0.5)
    early, late = err[5:60].mean(), err[-720:].mean()
    assert late > early + 5.0 and late > 0
    assert np.corrcoef(err[m], tr["winding_C"][m])[0, 1] > 0.9


def test_magnet_thermal_underestimates_increasingly():
    b, g, err = run("long", magnet_thermal=-0.2)
    tr = g["truth"]
    expect = tr["rpm_true"] * (tr["ke_vs_per_rad"] / b.ke_vs_per_rad - 1.0)
    m = moving(g)
    assert np.allclose(err[m], expect[m], atol=0.5)
    early, late = err[5:60].mean(), err[-720:].mean()
    assert late < early - 3.0 and late < 0
    assert np.corrcoef(err[m], tr["case_C"][m])[0, 1] < -0.9


@pytest.mark.parametrize("vb", [0.3, 0.8])
def test_brush_drop_overestimates_by_drop_over_ke(vb):
    b, g, err = run("load", brush_drop=vb)
    tr = g["truth"]
    m = moving(g)
    # the drop acts while current flows: drop x conduction fraction / Ke
    expect = vb * tr["cond_frac"] / b.ke_vs_per_rad * RPM
    assert err[m].mean() > 0
    assert err[m].mean() == pytest.approx(expect[m].mean(), rel=0.05)
    # at 100 % duty the current never stops: the error is the whole drop / Ke
    _, gs, es = run("sweep", brush_drop=vb)
    full = (gs["log"]["duty"].to_numpy() == 1.0) & moving(gs)
    assert es[full].mean() == pytest.approx(vb / b.ke_vs_per_rad * RPM, rel=0.02)


@pytest.mark.parametrize("off_mA", [-15.0, 8.0])
def test_current_offset_error_is_ra_times_offset(off_mA):
    b, g, err = run("load", current_offset=off_mA)
    m = moving(g)
    expect = -RA * off_mA * 1e-3 / b.ke_vs_per_rad * RPM
    assert err[m].mean() == pytest.approx(expect, rel=0.05)
    assert np.std(err[m]) < 0.3  # constant: does not depend on speed or current


def test_v_gain_error_proportional_to_v():
    gain = 0.8
    b, g, err = run("sweep", v_gain=gain)
    v = g["truth"]["v_true_V"].to_numpy()
    m = moving(g, 5.0)
    slope = np.polyfit(v[m], err[m], 1)[0]
    assert slope == pytest.approx(gain / 100 / b.ke_vs_per_rad * RPM, rel=0.05)
    assert err[m].mean() > 0


def test_saturation_underestimates_more_at_high_current():
    s = 4.0
    b, g, err = run("load", saturation=s)
    tr = g["truth"]
    m = moving(g)
    i = tr["i_true_A"].to_numpy()
    rel_err = err / tr["rpm_true"].to_numpy()
    # Ke(I) = Ke (1 - s I): relative speed error -s I
    assert np.allclose(rel_err[m], -s / 100 * i[m], atol=0.01)
    hi = m & (i > np.median(i[m]))
    lo = m & (i <= np.median(i[m]))
    assert err[hi].mean() < err[lo].mean() < 0


def test_ripple_adds_zero_mean_noise_at_100hz():
    _, g0, e0 = run("load", rate=100.0, time_scale=0.1, noise=False)
    _, g1, e1 = run("load", rate=100.0, time_scale=0.1, noise=False, ripple=15.0)
    m = moving(g0)
    assert np.std(e1[m]) > 1.5 * np.std(e0[m])
    assert abs(e1[m].mean() - e0[m].mean()) < 0.3
    # and at 2 Hz it averages out (a 0.5 s window holds dozens of ripple periods)
    _, g2, e2 = run("load", rate=2.0, ripple=15.0)
    _, g3, e3 = run("load", rate=2.0)
    m2 = moving(g2)
    assert np.std(e2[m2]) < np.std(e3[m2]) + 0.3


def test_inductance_shows_as_la_di_dt_at_1khz():
    """No bias in steady state, spikes of La dI/dt / Ke at the steps."""
    _, g0, e0 = run("sweep", rate=1000.0, time_scale=0.01)
    b, g1, e1 = run("sweep", rate=1000.0, time_scale=0.01, inductance=2.5)
    steps = np.flatnonzero(np.diff(g1["log"]["duty"].to_numpy())) + 1
    steps = steps[(steps > 2) & (g1["truth"]["rpm_true"].to_numpy()[steps - 1] > 20)]
    m = moving(g1)
    quiet = m.copy()
    for s in steps:
        quiet[s - 2:s + 100] = False
    assert abs(e1[quiet].mean() - e0[quiet].mean()) < 0.5
    spike1 = max(np.abs(e1[s:s + 3]).max() for s in steps)
    spike0 = max(np.abs(e0[s:s + 3]).max() for s in steps)
    assert spike1 > spike0 + 3.0


def test_identified_m2_sees_thermal_drift_in_the_test_segment():
    """With the paper's eq. 20 Ke on the first 80 %, thermal_ra still leaves a positive
    bias on the last 20 % of the long run, magnet_thermal a negative one."""
    _, g, _ = run("long", noise=True, thermal_ra=0.393)
    r_ra = check.m_errors(g["log"])
    _, g, _ = run("long", noise=True, magnet_thermal=-0.2)
    r_mag = check.m_errors(g["log"])
    _, g, _ = run("long", noise=True)
    r_off = check.m_errors(g["log"])
    assert r_ra["bias_m2"] > r_off["bias_m2"] + 1.0
    assert r_mag["bias_m2"] < r_off["bias_m2"] - 1.0
