"""The ripple count on an independent commutator simulation (hpddo.studies.commutator,
hpddo.studies.ripple_independent; docs/ripple-independent.md):
the simulation's ripples per revolution are the commutator's (S for even S, 2 S for odd S) in its
network and in its current's spectrum; over a few randomised benches written as files and counted by
the product's path, no confident window is more than 5 % off the true speed, and with half or
double the ripples per revolution given no window is confident; the docs quote the committed study."""
import functools
import json
import math

import numpy as np
import pytest

from conftest import ROOT
from hpddo.studies import commutator as cm
from hpddo.studies import ripple_independent as study


@pytest.mark.parametrize("segments", study.SEGMENTS)
def test_the_networks_strongest_angle_harmonic_is_the_commutators_ripple_count(segments):
    ke, r = cm.angle_harmonics(cm.Motor(segments, 2.0, 0.02, 1e-3), harmonics=4 * segments)
    n = cm.ripples_per_rev(segments)
    assert n == (2 * segments if segments % 2 else segments)
    assert int(np.argmax(ke)) + 1 == n
    # a symmetric commutator: nothing under the ripple's harmonic, every line a multiple of it (to the
    # angle grid's own aliasing, under 1e-4 of the ripple)
    assert ke[: n - 1].max() < 1e-3 * ke.max() and r[: n - 1].max() < 1e-3 * r.max()
    lines = np.flatnonzero(np.maximum(ke, r) > 1e-3 * ke.max()) + 1
    assert np.all(lines % n == 0)


@pytest.mark.parametrize("segments", (3, 8))
def test_the_simulated_currents_strongest_line_is_the_ripple(segments):
    motor = cm.Motor(segments, 3.0, 0.03, 1e-3)
    sim = cm.simulate(motor, cm.Drive(white_A=0.0, pink_A=0.0, a_per_code=1e-4, bits=16), cm.Protocol((0.7,) * 4), 1)
    x = np.asarray(sim["bursts"][1][3], float)
    fs = float(sim["bursts"][2]["sample_hz"])
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x))))
    f = np.fft.rfftfreq(len(x), 1 / fs)
    f_line = cm.ripples_per_rev(segments) * sim["rpm_true"][3] / 60
    assert f[np.argmax(spec)] == pytest.approx(f_line, abs=2 * fs / len(x))


def test_the_simulation_keeps_its_physics():
    """The mean current and speed of a steady window obey the armature's balance v = Ke w + Ra i (the
    PWM's mean voltage in continuous conduction) and the torque balance Ke i = Tc + b w."""
    m = cm.Motor(5, 2.0, 0.02, 2e-3, tc_nm=0.004, b_nms=1e-6)
    sim = cm.simulate(m, cm.Drive(vs_V=12.0, pwm_hz=16000.0, sample_hz=16000.0), cm.Protocol((0.8,) * 8), 2)
    w = sim["rpm_true"][-1] * 2 * math.pi / 60
    i = sim["i_true_A"][-1]
    v = sim["log"]["v_V"].to_numpy()[-1]
    assert m.ke_vs_per_rad * i == pytest.approx(m.tc_nm + m.b_nms * w, rel=0.01)
    assert v == pytest.approx(m.ke_vs_per_rad * w + m.ra_ohm * i, rel=0.01)


BENCHES = (study.Bench(3, "synchronous", "undeclared", "speed_steps", 3),
           study.Bench(7, "free", "declared", "load_steps", 3),
           study.Bench(12, "synchronous", "none", "duty_steps", 3),
           study.Bench(6, "free", "undeclared", "creep_stall", 3),
           # the study's two benches with confident windows off: a 5-bar motor's once-per-revolution line counted
           # under a Ke calibrated on it (-90 %, its one comb window at the figure `far` from that prior), and a
           # free-running burst whose two comb windows show half the rotation frequency's comb (-50 %, double given)
           study.Bench(5, "synchronous", "none", "duty_ramp", 1),
           study.Bench(3, "free", "none", "creep_stall", 2))


@functools.lru_cache(maxsize=None)
def _case(bench):
    return study.run_bench(bench)


def _id(bench):
    return f"S{bench.segments}-{bench.sampling}-{bench.mains}-{bench.protocol}"


@pytest.mark.parametrize("bench", BENCHES, ids=_id)
def test_no_confident_window_is_more_than_five_percent_off(bench):
    case = _case(bench)
    assert case["right"]["over_target"] == 0, case["right"]["wrong"]
    assert case["right"]["false_stalls"] == 0


# every bench, the figure given half and double: none confident. Where the rotor's once-per-revolution lines are too
# weak to show, the comb's spacing is twice the rotation frequency and shows half the figure; the recordings' combs
# confirm a figure only by the rule --calibrate names one by (line.figure_confirmed), which the few such windows of
# S 3's speed steps do not meet (docs/ripple-independent.md says where the limit remains)
@pytest.mark.parametrize("bench,given", [pytest.param(b, g, id=f"{_id(b)}-{g}")
                                         for b in BENCHES for g in ("half", "double")])
def test_a_wrong_figure_is_never_confident(bench, given):
    case = _case(bench)
    assert case[given]["confident"] == 0, (given, case[given])


def test_the_docs_quote_the_committed_study():
    doc = (ROOT / study.DOC).read_text(encoding="utf-8")
    figures = json.loads((ROOT / study.FIGURES).read_text(encoding="utf-8"))
    assert study.docs_text(doc, figures) == doc
    assert figures["command"].startswith("python -m hpddo.studies.ripple_independent")
    assert study.summarise(figures["cases"]) == figures["summary"]


@pytest.mark.slow
def test_one_bench_of_the_study_regenerates_its_figures():
    figures = json.loads((ROOT / study.FIGURES).read_text(encoding="utf-8"))
    old = next(c for c in figures["cases"] if c["segments"] == 5 and c["seed"] == 1 and c["sampling"] == "synchronous"
               and c["mains"] == "none")
    new = study.run_bench(study.Bench(old["segments"], old["sampling"], old["mains"], old["protocol"], old["seed"]))
    assert json.loads(json.dumps(new)) == old
