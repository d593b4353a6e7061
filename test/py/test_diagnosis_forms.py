"""The diagnosis names the effect, not the form: effects hidden in the bench twin in forms
other than the library's base form (twin/params.py FORMS) are named, with the form's
shape fitted (schema.Shape), and a voltage offset is named from the rows at rest. Every
effect that 2 Hz recordings show is hidden in a form other than the twin's default (the
magnets at the winding's temperature or lagging the case, sensor offsets that drift while
the electronics warm, a bowed voltage gain) besides its default form (test_diagnosis.py);
inductance is not seen at 2 Hz in any form (test_diagnosis.py). Two seeds each."""
import pytest

import twin_benches
from hpddo.diagnosis import core

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
