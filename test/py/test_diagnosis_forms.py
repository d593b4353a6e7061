"""The diagnosis names the effect, not the form: effects hidden in the bench twin in forms
other than the library's base form (twin/params.py FORMS) are named, with the form's
shape fitted (schema.Shape), and a voltage offset is named from the rows at rest. Every
effect that 2 Hz recordings show is hidden in a form other than the twin's default (the
magnets at the winding's temperature or lagging the case, sensor offsets that drift while
the electronics warm, a bowed voltage gain) besides its default form (test_diagnosis.py);
inductance is not seen at 2 Hz in any form (test_diagnosis.py). Two seeds each."""
import dataclasses

import pytest

import law_benches
import true_forms
import twin_benches
from hpddo import schema
from hpddo.diagnosis import core
from hpddo.model import effects as fx
from hpddo.model import physics as ph

SEEDS = (3, 4)
# name -> (effects (twin units), forms, bench overrides, effect that must be named)
CASES = {
    "saturation_quadratic": ({"saturation": 8.0}, {"saturation": "quadratic"}, {}, "saturation"),
    "saturation_onset": ({"saturation": 8.0}, {"saturation": "onset"}, {}, "saturation"),
    # every real armature has inductance (see test_diagnosis.SINGLE)
    "brush_exp_50mA": ({"brush_drop": 0.5, "inductance": 2.5}, {"brush_drop": "exp_50mA"}, {}, "brush_drop"),
    "copper_at_case": ({"thermal_ra": 0.393}, {"thermal_ra": "case"}, {}, "thermal_ra"),
    # a winding with ten times the heat capacity: a 90 s winding-to-case time constant
    "copper_slow_winding": ({"thermal_ra": 0.393}, {}, {"c_winding_J_per_K": 60.0}, "thermal_ra"),
    "magnet_at_winding": ({"magnet_thermal": -0.2}, {"magnet_thermal": "winding"}, {}, "magnet_thermal"),
    "magnet_lagging_case": ({"magnet_thermal": -0.2}, {"magnet_thermal": "lag_600s"}, {}, "magnet_thermal"),
    "current_offset_warmup": ({"current_offset": 20.0}, {"current_offset": "warmup"}, {}, "current_offset"),
    "v_offset_warmup": ({"v_offset": 100.0}, {"v_offset": "warmup"}, {}, "v_offset"),
    "v_gain_bowed": ({"v_gain": 2.0}, {"v_gain": "bowed"}, {}, "v_gain"),
    "v_offset_positive": ({"v_offset": 100.0}, {}, {}, "v_offset"),
    "v_offset_negative": ({"v_offset": -60.0}, {}, {}, "v_offset"),
}


def bench_dir(root, key, seed):
    effects, forms, over, _ = CASES[key]
    return twin_benches.recordings(root / f"{key}_{seed}", twin_benches.bench(effects, forms, **over), seed)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("forms")


run = twin_benches.diagnosed


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("key", sorted(CASES))
def test_an_effect_in_another_form_is_named_alone(root, key, seed):
    res = run(bench_dir(root, key, seed))
    want = CASES[key][3]
    assert res["missing_effects"] == [want], res["verdict"]
    assert not res["ra_fit"]["mismatch"], res["verdict"]
    # what it removes: the physics error falls to within 1.3x the noise floor of the bench
    after = res["rmse_rpm"]["after"]["average"]
    assert after < 1.3 * res["noise_rpm"] + 0.5, (after, res["noise_rpm"])


@pytest.mark.parametrize("seed", SEEDS)
def test_the_fitted_shape_follows_the_form(root, seed):
    """saturation: q (the i^2 share) near 1 for the quadratic form, and between the linear
    and the quadratic form for an onset at 0.3 A. The brush knee of 1 - exp(-i / 50 mA) (half
    the drop at 35 mA): found, or said not to be fixed by these recordings (on 2 Hz
    recordings the knee and Ke share the work, docs/diagnosis.md, Forms)."""
    quad = {e["effect"]: e for e in run(bench_dir(root, "saturation_quadratic", seed))["ranking"]}
    assert quad["saturation"]["params"]["ke_sat_quad"] > 0.7
    onset = {e["effect"]: e for e in run(bench_dir(root, "saturation_onset", seed))["ranking"]}
    assert onset["saturation"]["params"]["ke_sat_quad"] > 0.2
    brush = {e["effect"]: e for e in run(bench_dir(root, "brush_exp_50mA", seed))["ranking"]}["brush_drop"]
    assert 0.01 < brush["params"]["brush_knee_A"] < 0.1 or "do not fix it" in brush["plausibility"]


def test_an_offset_read_at_rest_is_held_there_and_told_apart(root):
    res = run(bench_dir(root, "v_offset_positive", SEEDS[0]))
    rest = res["rest_offsets"]
    assert rest["v_offset"]["value"] == pytest.approx(0.1, abs=0.005)
    assert abs(rest["current_offset"]["value"]) < 0.002
    named = {e["effect"]: e for e in res["ranking"] if e["named"]}
    assert named["v_offset"]["params"]["v_offset_V"] == rest["v_offset"]["value"]
    assert res["confounded"] == []


@pytest.mark.parametrize("seed", SEEDS)
def test_a_knee_shaped_brush_drop_is_not_named_as_something_else(root, seed):
    """A brush drop that builds up over 100 mA removes as much of the held-out error as a
    wrong Ra and as a voltage gain error (docs/diagnosis.md): the verdict must not name
    another effect for it (v_gain +7.45 % was named before ranking.apart_z). Either the
    brush drop is named, or the wrong Ra reported is said to be confounded with it."""
    key = f"brush_knee_100mA_{seed}"
    b = twin_benches.bench({"brush_drop": 0.5, "inductance": 2.5}, {"brush_drop": "knee_100mA"})
    res = run(twin_benches.recordings(root / key, b, seed))
    missing = res["missing_effects"]
    assert set(missing) <= {"brush_drop"}, res["verdict"]
    if "brush_drop" not in missing:
        # a wrong Ra said not to be told from the brush drop; since issue 21 the reading (right
        # on this bench) is no longer called wrong: with the brush drop fitted alongside, the data
        # alone put Ra at 4.94 (4.61..5.28, seed 3), which holds the reading
        assert "brush_drop" in res["ra_fit"]["confounded_with"], res["verdict"]
        assert ("cannot tell a wrong Ra from" in res["verdict"] if res["ra_fit"]["mismatch"] else
                "a wrong Ra (with Ke, the named effects and brush_drop fitted alongside" in res["verdict"]), \
            res["verdict"]


# ---------------------------------------------------------------------------------------
# Forms outside the library (issue 21, item 7; docs/diagnosis.md, Forms outside the library):
# benches simulated from a law of the motor the library has no form for (law_benches.py: no
# PWM, the law exact for the means), and two of the twin's own. After naming, the physics on
# the diagnosis' held-out rows comes within RATIO_MAX of the true model's (the law in its own
# form, Ke and its sizes fitted on the same training rows, Ra at the true value); a shape at
# the edge of its range is said not to be fixed, and the size of an effect whose widened
# family stops at an edge is not determined.

RATIO_MAX = 1.2
Law = law_benches.Law
# name -> (the law, the effect that must be named, its true size in the library's field or None)
LAWS = {
    "brush_tanh_200mA": (Law("brush_drop", "tanh", {"V": 0.8, "i0": 0.2}), "brush_drop", 0.8),
    "brush_tanh_500mA": (Law("brush_drop", "tanh", {"V": 0.8, "i0": 0.5}), "brush_drop", 0.8),
    "brush_exp_500mA": (Law("brush_drop", "exp", {"V": 0.8, "i0": 0.5}), "brush_drop", 0.8),
    "saturation_lorentz_3A": (Law("saturation", "lorentz", {"i0": 3.0}), "saturation", None),
    "saturation_onset_600mA": (Law("saturation", "onset", {"s": 0.1, "i0": 0.6}), "saturation", None),
}
# offsets that drift: with the case temperature (zero cold, all of it 30 K warmer) or over an hour
DRIFTS = {
    "current_offset_follows_the_case": Law("current_offset", "case", {"A": 0.03}),
    "v_offset_follows_the_case": Law("v_offset", "case", {"V": 0.15}),
    "v_offset_ramp": Law("v_offset", "ramp", {"V": 0.15}),
}


def _ratio(res, truth) -> tuple[float, str]:
    after = res["rmse_rpm"]["after"]["average"]
    text = (f"physics after naming {after:.3f} RPM, true model {truth:.3f} RPM: ratio {after / truth:.3f}; "
            f"named {res['missing_effects']}")
    print(text)  # the figures of docs/diagnosis.md (pytest -s)
    return after / truth, text


def _no_silent_edge(res) -> None:
    """Every named effect's shape at an edge of the forms allowed (but the base form) is said
    not to be fixed; in the widened family, its size is then not determined either."""
    for e in res["ranking"]:
        if not e["named"]:
            continue
        eff = schema.BY_NAME[e["effect"]]
        shapes = {sh.field: e["params"][sh.field] for sh in eff.shapes}
        p = dataclasses.replace(ph.PhysicsParams(ra_ohm=1.0, ke_vs_per_rad=1.0), **shapes)
        widened = bool(fx.widened_in(p, [eff.name]))
        for sh in eff.shapes:
            v, (lo, hi) = shapes[sh.field], fx.shape_bounds(sh, widened)
            at_edge = min(abs(v - lo), abs(v - hi)) <= 1e-6 * (hi - lo) and v != sh.default
            if at_edge:
                assert "do not fix it" in e["plausibility"], (eff.name, sh.field, v, e["plausibility"])
                if widened:
                    size = next(iv for iv in e["intervals"] if iv["field"] == eff.field)
                    assert not size["determined"], (eff.name, size)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("key", sorted(LAWS))
def test_an_effect_outside_the_library_is_named_and_its_physics_comes_within_1_2_of_the_true_model(root, key, seed):
    law, want, size = LAWS[key]
    paths = law_benches.write(root / f"law_{key}_{seed}", law, seed)
    res = run(paths)
    truth, _ = law_benches.true_rmse(paths, law)
    ratio, text = _ratio(res, truth)
    assert res["missing_effects"] == [want], res["verdict"]
    assert ratio <= RATIO_MAX, text
    if size is not None:  # the right magnitude
        named = {e["effect"]: e for e in res["ranking"] if e["named"]}
        got = named[want]["params"][schema.BY_NAME[want].field]
        assert abs(got - size) <= 0.25 * size, (got, size)
    _no_silent_edge(res)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("key", ["brush_tanh_200mA", "brush_exp_500mA"])
def test_a_smooth_brush_drop_with_ra_given_10_percent_high_gets_no_spurious_saturation(root, key, seed):
    """Before the widened family: brush_drop, saturation (its shape at an edge) and a current
    offset were named for a tanh drop with Ra given 10 % high."""
    law, want, _ = LAWS[key]
    paths = law_benches.write(root / f"law_{key}_ra_high_{seed}", law, seed, ra_given=1.1 * law_benches.RA_OHM)
    res = run(paths)
    truth, _ = law_benches.true_rmse(paths, law)
    ratio, text = _ratio(res, truth)
    assert want in res["missing_effects"], res["verdict"]
    named = {e["effect"]: e for e in res["ranking"] if e["named"]}
    if "saturation" in named:  # only where its size is said not to be determined
        size = next(iv for iv in named["saturation"]["intervals"] if iv["field"] == "ke_sat_per_A")
        assert not size["determined"], res["verdict"]
    assert ratio <= RATIO_MAX, text
    _no_silent_edge(res)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("key", sorted(DRIFTS))
def test_a_drifting_offset_leaves_the_physics_within_1_2_of_the_true_model(root, key, seed):
    """The library has no offset that drifts: on these recordings the drift acts during the
    hour's warm-up at one operating point, where it looks like a temperature effect, and a
    thermal effect stands in for it (docs/diagnosis.md: the right name is left undone). The
    physics still comes within RATIO_MAX, and nothing else is named."""
    law = DRIFTS[key]
    paths = law_benches.write(root / f"law_{key}_{seed}", law, seed)
    res = run(paths)
    truth, _ = law_benches.true_rmse(paths, law)
    ratio, text = _ratio(res, truth)
    assert set(res["missing_effects"]) <= {law.effect, "thermal_ra", "magnet_thermal"}, res["verdict"]
    assert ratio <= RATIO_MAX, text
    _no_silent_edge(res)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
def test_a_tanh_brush_drop_on_the_twin_is_named_with_its_unfixed_form_said(root, seed):
    """The twin's brush drop tanh(i / 300 mA) through its PWM stage (the drop acts only while
    current flows, a share of the period at light load): named, within RATIO_MAX of the
    twin's own law fitted on the same rows, its form at the edges of the widened family and
    said so, its size not determined."""
    b = twin_benches.bench({"brush_drop": 0.5, "inductance": 2.5}, {"brush_drop": "tanh_300mA"})
    paths = twin_benches.recordings(root / f"twin_brush_tanh_300mA_{seed}", b, seed)
    res = run(paths)
    truth, _ = true_forms.true_rmse(paths, b, "brush_drop")
    ratio, text = _ratio(res, truth)
    assert res["missing_effects"] == ["brush_drop"], res["verdict"]
    assert ratio <= RATIO_MAX, text
    _no_silent_edge(res)


@pytest.mark.slow
def test_saturation_from_600mA_on_the_twin_is_said_not_told_from_a_wrong_ra(root):
    """Left undone: the twin's armature reaction from 600 mA (load and long run above it, the
    sweep below) is explained as well by a wrong Ra; neither is named, so the physics stays
    at the plain model's (3.69 RPM against the true model's 1.67, seed 3). The statement is
    that a wrong Ra cannot be told from saturation, never a confident value."""
    b = twin_benches.bench({"saturation": 8.0}, {"saturation": "onset_600mA"})
    res = run(twin_benches.recordings(root / "twin_saturation_onset_600mA", b, SEEDS[0]))
    assert res["missing_effects"] == [] and not res["ra_fit"]["mismatch"], res["verdict"]
    assert "saturation" in res["ra_fit"]["confounded_with"], res["verdict"]
    assert "explains as well as saturation" in res["verdict"], res["verdict"]
