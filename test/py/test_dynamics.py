"""The dynamic family (issue 21, item 8): the observer's Python reference against its golden
vector (the C++ side: ctest core.dynamics), the family off changes nothing, the schema's
declaration, the twin's encoder periods."""
from __future__ import annotations

import math

import numpy as np

from hpddo import schema
from hpddo.model import dynamics_ref as dr
from hpddo.twin import generate, params


def test_golden_vector_is_what_the_reference_writes():
    path = schema.ROOT / dr.GOLDEN
    assert path.read_text() == dr.golden_h(), f"regenerate: {dr.GOLDEN_COMMAND}"


def test_exp_neg_is_within_one_ulp_of_the_correctly_rounded_exp():
    """The observer's pole without libm (hpddo::exp_neg): within 1 ulp of float32(math.exp) over
    [-40, 0], 0 below, exactly 1 at 0."""
    import math as m
    xs = np.float32(-np.linspace(0.0, 40.0, 20001)[:-1]).astype(np.float32)
    got = np.array([dr.exp_neg(x) for x in xs], np.float32)
    want = np.array([m.exp(float(x)) for x in xs], np.float32)
    ulp = np.abs(got.view(np.int32).astype(np.int64) - want.view(np.int32).astype(np.int64))
    assert ulp.max() <= 1 and got[0] == np.float32(1)
    assert dr.exp_neg(np.float32(-40.0)) == 0 and dr.exp_neg(np.float32(-50.0)) == 0


def test_not_named_returns_the_measured_speed_bit_for_bit():
    i, m = dr.golden_inputs()
    off = dr.dynamics_params(**{**dr.GOLDEN_ON, "j_kgm2": 0.0})
    out, load = dr.run(dr.GOLDEN_KE, off, i, m, dr.GOLDEN_DT_S)
    assert out.tobytes() == m.astype(np.float32).tobytes()
    assert not load.any()


def test_named_with_the_twins_shaft_brings_m2_closer_to_the_true_speed():
    # the twin's 100 Hz sweep: M2 (true Ra, Ke) carries the channels' noise (14.5 RPM rms against
    # the true speed); the observer with the twin's own J, B, Tc smooths it through the mechanics
    b = params.with_effects(params.preset("ideal"), inductance=2.5)
    g = generate.generate(b, "sweep", rate_hz=100.0, seed=3, time_scale=0.1)
    log, true = g["log"], g["truth"]["rpm_true"].to_numpy()
    ke = b.ke_vs_per_rad
    m2 = (log["v_V"].to_numpy() - b.ra_ohm * log["i_A"].to_numpy()) / ke * 60 / (2 * math.pi)
    d = dr.dynamics_params(j_kgm2=b.j_kgm2, b_nms_per_rad=b.b_motor_nms + b.b_gen_nms,
                           tc_nm=b.tc_motor_nm + b.tc_gen_nm, tau_obs_s=0.02)
    out, _ = dr.run(ke, d, log["i_A"].to_numpy(), m2, 0.01)
    before, after = np.sqrt(np.mean((m2 - true) ** 2)), np.sqrt(np.mean((out - true) ** 2))
    assert after < 0.8 * before, (before, after)


def test_schema_declares_the_family_once_beside_physics_params():
    fields = [d.field for d in schema.DYNAMICS]
    assert fields == ["j_kgm2", "b_nms_per_rad", "tc_nm", "tau_obs_s"]
    assert not set(fields) & set(schema.FIELDS)       # PhysicsParams and its layout do not change
    assert schema.DYNAMICS_INDUCTANCE in schema.BY_NAME
    header = (schema.ROOT / "lib/hpddo_core/src/hpddo/params_gen.h").read_text()
    assert "struct DynamicsParams {" in header and f"kDynamicsParamCount = {len(fields)}" in header


def test_twin_writes_encoder_periods_at_fast_rates_only():
    b = params.with_effects(params.preset("ideal"), inductance=2.5)
    fast = generate.generate(b, "sweep", rate_hz=100.0, seed=3, time_scale=0.05)
    slow = generate.generate(b, "sweep", rate_hz=2.0, seed=3, time_scale=0.05)
    assert "enc_period_s" not in slow["log"]
    per = fast["log"]["enc_period_s"].to_numpy()
    cpr = float(fast["meta"]["encoder_counts_per_rev"])
    rpm = 60.0 / (cpr * per)
    true = fast["truth"]["rpm_true"].to_numpy()
    moving = np.isfinite(rpm) & (true > 30)
    # the period's speed is the instantaneous one at the row's end: within a few RPM of the true
    # mean where the counts' speed is off by its 31 RPM step (measured: 1.8 against 10.6 RPM rms)
    err_period = np.sqrt(np.mean((rpm - true)[moving] ** 2))
    err_counts = np.sqrt(np.mean((fast["log"]["rpm_ref"].to_numpy() - true)[moving] ** 2))
    assert err_period < 0.4 * err_counts
    assert math.isclose(cpr, 193.6)


def test_the_boards_fixture_names_the_family_and_it_moves_the_estimate():
    """test/fixtures/dynamics (tools/gen_fixtures.py): models/default with DYNAMICS_SHAFT named; the
    UNO is built with it (ctest firmware.uno.*dynamics*) and its golden rows, which the Unity suite
    test_dynamics_golden holds the boards to bit for bit, show the family at work."""
    from hpddo.model import export, fixtures
    folder = schema.ROOT / "test" / "fixtures" / fixtures.DYNAMICS_DIR
    model = export.read_model_header((folder / "model_default.h").read_text())  # its checksum checked
    assert model.dynamics == dr.dynamics_params(**fixtures.DYNAMICS_SHAFT) and model.dynamics_named
    assert "static constexpr const hpddo::DynamicsParams& kDynamics = hpddo_model_default::kDynamics;" in (
        folder / "model_default_q.h").read_text()  # a constant expression: uno_acq.cpp decides from it
    plain = schema.ROOT / "models" / "default"
    assert "kDynamics" not in (plain / "model_default.h").read_text() + (plain / "model_default_q.h").read_text()
    col = lambda f: np.genfromtxt(f, delimiter=",", names=True)["rpm_m2"]
    on, off = col(folder / "golden_default_q.csv"), col(plain / "golden_default_q.csv")
    assert on[0] == off[0]  # starts settled on the back-EMF speed
    assert np.nanmax(np.abs(on - off)) > 1.0  # and filters it where it changes (RPM)
