"""The diagnosis names the effect, not the form: effects hidden in the bench twin in forms
other than the library's base form (twin/params.py FORMS) are named, with the form's
shape fitted (schema.Shape), and a voltage offset is named from the rows at rest. Every
effect that 2 Hz recordings show is hidden in a form other than the twin's default (the
magnets at the winding's temperature or lagging the case, sensor offsets that drift while
the electronics warm, a bowed voltage gain) besides its default form (test_diagnosis.py);
inductance is not seen at 2 Hz in any form (test_diagnosis.py). Two seeds: a family of cases takes them in turn (twin_benches.alternating)."""
import dataclasses

import pytest

import law_benches
import true_forms
import twin_benches
from hpddo import schema
from hpddo.diagnosis import core, ranking
from hpddo.model import effects as fx
from hpddo.model import physics as ph
from hpddo.twin import params as tp

SEEDS = (3, 4)
# With Ke fitted, a voltage gain g is an Ra of Ra / (1 + g): only the reading's tolerance tells a
# gain of a few percent from a reading a few percent off, and a wrong reading may be up to
# ranking.RA_ALTERNATIVE_SIGMAS tolerances off, so the diagnosis may say so instead of naming it.
RA_TWINS = {"v_gain"}
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


@pytest.mark.parametrize("key,seed", twin_benches.alternating(sorted(CASES), SEEDS))
def test_an_effect_in_another_form_is_named_alone(root, key, seed):
    """Named alone; or, for an effect that with Ke fitted is a wrong Ra (RA_TWINS), either named
    or said not told apart from a wrong reading of Ra, or selected with an interval that holds
    zero (the current channel's gain error, 2 % by default, is an Ra error where Ra is held, and
    the sensors' part of the budget carries it), with nothing else named."""
    res = run(bench_dir(root, key, seed))
    want = CASES[key][3]
    if want in RA_TWINS and not res["missing_effects"]:
        if f"{want} was selected" in res["verdict"] and "holds zero" in res["verdict"]:
            return
        assert want in res["ra_fit"]["confounded_with"], res["verdict"]
        assert "so neither is named" in res["verdict"] or "none of them" in res["verdict"], res["verdict"]
        return
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
    recordings the knee and Ke share the work, docs/diagnosis-forms.md)."""
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
# Forms outside the library (issue 21, item 7; docs/diagnosis-forms.md, Forms outside the library):
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
@pytest.mark.parametrize("key,seed", twin_benches.alternating(sorted(LAWS), SEEDS))
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
@pytest.mark.parametrize("key,seed", twin_benches.alternating(["brush_tanh_200mA", "brush_exp_500mA"], SEEDS))
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


DRIFT = "current_offset_drift"
THERMAL = ("thermal_ra", "magnet_thermal")


def _drift_pairs_said(res) -> list:
    """The thermal effects the verdict says the drift cannot be told from: each confounded
    group holding the drift and a thermal effect must be said with its separating recording
    (schema: separated_from), never left silent."""
    said = []
    for group in res["confounded"]:  # the named effect first, then what it is not told from
        named, others = group[0], group[1:]
        pairs = ([(named, DRIFT)] if named in THERMAL and DRIFT in others else
                 [(DRIFT, t) for t in others if t in THERMAL] if named == DRIFT else [])
        for a, b in pairs:
            sentence = (f"{a} and {b} cannot be told apart on these recordings; a recording that would "
                        f"separate them: {ranking.separator(a, b)}")
            assert sentence in res["verdict"], (sentence, res["verdict"])
            said.append(a if a != DRIFT else b)
    return said


@pytest.mark.slow
@pytest.mark.parametrize("key,seed", twin_benches.alternating(sorted(DRIFTS), SEEDS))
def test_a_drifting_offset_leaves_the_physics_within_1_2_of_the_true_model(root, key, seed):
    """An offset drifting with the case during the hour's warm-up at one operating point is
    the same speed error as a temperature effect: the thermal effect is named (the motor's
    physics first, ranking.motor_physics_first) and the verdict says that it cannot be told
    from current_offset_drift, with the recording that would (load steps while warm for
    Ra(T), a duty sweep while warm for the magnets). A drift with time (the ramp) is named as
    the drift with the case it looks like. The physics comes within RATIO_MAX."""
    law = DRIFTS[key]
    paths = law_benches.write(root / f"law_{key}_{seed}", law, seed)
    res = run(paths)
    truth, _ = law_benches.true_rmse(paths, law)
    ratio, text = _ratio(res, truth)
    assert res["missing_effects"] and set(res["missing_effects"]) <= {DRIFT, *THERMAL}, res["verdict"]
    if law.form == "case":
        thermal = [n for n in res["missing_effects"] if n in THERMAL]
        assert thermal and DRIFT not in res["missing_effects"], res["verdict"]
        assert set(_drift_pairs_said(res)) & set(thermal), res["verdict"]
    assert ratio <= RATIO_MAX, text
    _no_silent_edge(res)


def _drift_size(law) -> float:
    """The drift's true size in current_offset_drift's field, A/K: a voltage channel's
    drift through Ra (its -dv / Ra)."""
    per_k = 1.0 / law_benches.RISE_K
    return law.size["A"] * per_k if law.effect == "current_offset" else -law.size["V"] / law_benches.RA_OHM * per_k


@pytest.mark.slow
@pytest.mark.parametrize("key,seed", twin_benches.alternating(["current_offset_follows_the_case",
                                                               "v_offset_follows_the_case"], SEEDS))
def test_a_drifting_offset_with_load_steps_while_warm_is_named_and_told_from_the_thermal_effects(root, key, seed):
    """The same benches with load steps while warm (law_benches.write(warm_steps=True): 0.1..1.2 A
    at 8 and 12 V after 40 and 48 min): an offset's drift shifts V - I Ra alike at every current,
    Ra(T) in proportion to it, so the recordings tell them apart: current_offset_drift is named
    alone at its size (a voltage channel's drift as -dv / Ra), no thermal effect is said to be
    confounded with it, and the physics comes within RATIO_MAX."""
    law = DRIFTS[key]
    paths = law_benches.write(root / f"law_{key}_warm_{seed}", law, seed, warm_steps=True)
    res = run(paths)
    truth, _ = law_benches.true_rmse(paths, law)
    ratio, text = _ratio(res, truth)
    assert res["missing_effects"] == [DRIFT], res["verdict"]
    named = {e["effect"]: e for e in res["ranking"] if e["named"]}
    got, want = named[DRIFT]["params"]["i_offset_tc_A_per_K"], _drift_size(law)
    assert abs(got - want) <= 0.25 * abs(want), (got, want)
    assert _drift_pairs_said(res) == [], res["verdict"]
    assert ratio <= RATIO_MAX, text


TWIN_DRIFTS = {"current": ({"current_offset": 20.0}, {"current_offset": "case"}),
               "voltage": ({"v_offset": 100.0}, {"v_offset": "case"})}


@pytest.mark.slow
@pytest.mark.parametrize("key,seed", twin_benches.alternating(sorted(TWIN_DRIFTS), SEEDS))
def test_an_offset_drifting_with_the_case_on_the_twin_is_named(root, key, seed):
    """The twin's current or voltage offset in its "case" form (twin/params.py: none at
    ambient, all of it 30 K above): current_offset_drift is named at the drift's size (20 mA
    or -100 mV / 4.5 ohm over 30 K), every thermal effect it is confounded with said with the
    recording that would separate them, and the physics within RATIO_MAX of the twin's own
    law fitted on the same rows."""
    effects, forms = TWIN_DRIFTS[key]
    b = twin_benches.bench(effects, forms)
    paths = twin_benches.recordings(root / f"twin_drift_{key}_{seed}", b, seed)
    res = run(paths)
    name = next(iter(effects))
    truth, _ = true_forms.true_rmse(paths, b, name)
    ratio, text = _ratio(res, truth)
    assert res["missing_effects"] == [DRIFT], res["verdict"]
    si = b.effect_si(name) / tp.DRIFT_RISE_K
    want = si if name == "current_offset" else -si / b.ra_ohm
    got = {e["effect"]: e for e in res["ranking"] if e["named"]}[DRIFT]["params"]["i_offset_tc_A_per_K"]
    assert abs(got - want) <= 0.25 * abs(want), (got, want)
    _drift_pairs_said(res)
    assert ratio <= RATIO_MAX, text


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
    """The twin's armature reaction from 600 mA (load and long run above it, the sweep at
    0.33..0.56 A below) is explained as well by a wrong Ra (4.21 ohm against the true 4.5);
    neither is named, so the physics stays at the plain model's (3.69 RPM against the true
    model's 1.67, seed 3). The statement is that a wrong Ra cannot be told from saturation,
    never a confident value. That is what the data hold, not the selection's strictness:
    even the twin's own law, with Ra at the true value, gains nothing over the wrong Ra on
    the held-out rows (apart_z below Z_MIN: 0.048 RPM^2 of 3.82, z 0.26), and on the
    training rows the wrong Ra fits better (docs/diagnosis-forms.md, Forms outside the library).
    Either explanation forced alone comes within RATIO_MAX of the true model."""
    b = twin_benches.bench({"saturation": 8.0}, {"saturation": "onset_600mA"})
    paths = twin_benches.recordings(root / "twin_saturation_onset_600mA", b, SEEDS[0])
    res = run(paths)
    assert res["missing_effects"] == [] and not res["ra_fit"]["mismatch"], res["verdict"]
    assert "saturation" in res["ra_fit"]["confounded_with"], res["verdict"]
    assert "explains as well as saturation" in res["verdict"], res["verdict"]
    inp = core.load(paths, core.Options(bootstrap=0, hybrid=False))
    d, sigma2 = inp.data, core.fit_model(inp).sigma2
    truth, fitted = true_forms.true_rmse(paths, b, "saturation")
    res_true = [r.ref - true_forms.law_rpm(b, "saturation", r, fitted) for r in d.rows]
    p_ra, res_ra = ranking.scored_names(d, inp.m2, [ranking.RA_MISMATCH], sigma2)
    g, z = ranking.gain_z(d, res_ra, res_true, sigma2)
    print(f"the twin's law over a wrong Ra ({p_ra.ra_ohm:.3f} ohm) on the held-out rows: {g:.4f} RPM^2 "
          f"of {ranking.held_out_mse(d, res_ra):.3f}, z {z:.2f}")
    assert ranking.apart_z(d, res_ra, res_true, sigma2) < ranking.Z_MIN
    for forced in (fx.fit(d.rows, inp.m2, ["saturation"]), p_ra):
        after = core._rmse_by_condition(inp.rows, [r.ref - fx.predict(r, forced) for r in inp.rows])["average"]
        print(f"forced (Ra {forced.ra_ohm:.3f} ohm, saturation {forced.ke_sat_per_A:.4f}/A q {forced.ke_sat_quad:.2f}): "
              f"{after:.3f} RPM, true model {truth:.3f}: ratio {after / truth:.3f}")
        assert after <= RATIO_MAX * truth
