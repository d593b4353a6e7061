"""Parity of every library effect between Python (tools/hpddo/model/physics.py through
effects.py, float32) and hpddo_core (physics.h, thermal.h): a small C++ probe evaluates
the board's terms for the same parameters and inputs, each effect switched on alone at
its typical size and at the edges of its plausible range, each shape across its range, then all
together."""
import dataclasses
import shutil
import subprocess

import numpy as np
import pytest

from conftest import ROOT
from hpddo.model import effects as fx
from hpddo.model import physics as ph
from hpddo import schema

F32 = np.float32
BASE = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.406, t_ref_C=31.7, t_amb_C=31.7)


def grid():
    rng = np.random.default_rng(5)
    v = np.concatenate([[0.0, 0.5, 6.0, 12.0, 9.1, 9.1], rng.uniform(0.0, 12.5, 40)])
    i = np.concatenate([[0.0, 0.001, -0.01, 0.02, 1.0, 2.5], rng.uniform(-0.05, 2.0, 40)])
    di = np.concatenate([[0.0, 0.0, 50.0, -200.0, 1000.0, 0.0], rng.normal(0.0, 100.0, 40)])
    t = np.concatenate([[31.7, 25.0, 60.0, 80.0, -10.0, 110.0], rng.uniform(20.0, 90.0, 40)])
    return [a.astype(F32) for a in (v, i, di, t)]


def cases():
    out = [("plain", BASE)]
    for name, eff in fx.LIBRARY.items():
        for label, val in (("typical", eff.scale), ("lo", eff.plausible[0]), ("hi", eff.plausible[1])):
            out.append((f"{name}:{label}", dataclasses.replace(BASE, **{eff.field: val})))
    for name, eff in fx.LIBRARY.items():  # each shape across its forms, its effect at its typical size
        for sh in eff.shapes:
            lo, hi = sh.bounds
            for label, val in (("lo", lo), ("mid", 0.5 * (lo + hi)), ("hi", hi)):
                out.append((f"{name}:{sh.field}:{label}",
                            dataclasses.replace(BASE, **{eff.field: eff.scale, sh.field: val})))
    # a tanh-like brush drop (docs/diagnosis-forms.md, Forms outside the library)
    out.append(("brush_drop:tanh_like", dataclasses.replace(BASE, brush_V=0.8, brush_knee_A=0.21, brush_order=2.85)))
    out.append(("all", dataclasses.replace(BASE, **{e.field: e.scale for e in fx.LIBRARY.values()},
                                           th_r_K_per_W=12.0, th_tau_s=400.0)))
    return out


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    cxx = shutil.which("g++") or shutil.which("c++")
    if not cxx:
        pytest.skip("no C++ compiler (g++): run scripts/bootstrap.sh")
    exe = tmp_path_factory.mktemp("probe") / "effects_probe"
    subprocess.run([cxx, "-std=c++11", "-O2", "-ffp-contract=off", f"-I{ROOT / 'lib/hpddo_core/src'}",
                    str(ROOT / "test/parity/effects_probe.cpp"), "-o", str(exe)], check=True)
    return exe


def run_probe(exe, lines):
    res = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True)
    return res.stdout.split()


def p_line(p):
    """Every PhysicsParams field in the schema's order (the probe reads them through the
    generated hpddo::for_each_param): the floats, then the effect bits."""
    return "P " + " ".join(["%.9g" % F32(getattr(p, f)) for f in schema.FLOAT_FIELDS] + [str(int(p.effects))])


@pytest.mark.parametrize("label,p", cases(), ids=[c[0] for c in cases()])
def test_physics_term_matches_the_board(probe, label, p):
    v, i, di, t = grid()
    tm = (t[::-1] - F32(5.0)).astype(F32)  # the magnets at another temperature than the winding
    lines = [p_line(p)] + [f"X {a!r} {b!r} {c!r} {d!r} {e!r}".replace("np.float32(", "").replace(")", "")
                           for a, b, c, d, e in zip(v.tolist(), i.tolist(), di.tolist(), t.tolist(), tm.tolist())]
    got = run_probe(probe, lines)
    want = ph.physics_rpm(p, v, i, di, ph.Temps(t, tm), F32)
    assert len(got) == len(want)
    for k, (g, w) in enumerate(zip(got, want)):
        if g == "invalid":
            assert not np.isfinite(w), (label, k)
            continue
        g = F32(float(g))
        assert np.isfinite(w), (label, k, g)
        # same float32 operations in the same order: equal to within one rounding
        assert abs(g - w) <= 2 * np.spacing(max(abs(w), F32(1.0))), (label, k, float(g), float(w))


def test_thermal_state_matches_the_board(probe):
    """The winding node above its reference: the ambient where no temperature is read,
    the case reading where one is (both in one stream, as when a sensor drops out)."""
    p = dataclasses.replace(BASE, ra_tc_per_K=0.00393, th_r_K_per_W=12.0, th_tau_s=400.0)
    rng = np.random.default_rng(2)
    i = rng.uniform(0.0, 1.5, 300).astype(F32)
    dt = np.full(300, 0.5, F32)
    ref = np.where(np.arange(300) < 150, F32(p.t_amb_C), F32(35.0) + np.arange(300, dtype=F32) * F32(0.1))
    lines = [f"T {float(a)!r} {float(b)!r} {float(c)!r}" for a, b, c in zip(i, dt, ref)]
    got = np.array(run_probe(probe, [p_line(p)] + lines), float)
    want = ph.thermal_trajectory(p, i, dt, F32, ref_C=ref)
    # expf and numpy's float32 exp may differ by an ulp; over 300 steps that stays below 1 mK
    assert np.max(np.abs(got - want)) <= 1e-3
    assert np.max(want - ref) > 5.0  # the winding does rise above its reference


def test_every_effect_has_a_field_a_bit_and_a_regressor():
    assert set(fx.LIBRARY) == set(ph.EFFECT_BITS)
    for name, eff in fx.LIBRARY.items():
        assert ph.EFFECT_BITS[name] == (eff.bit, eff.field)
        assert eff.field in ph.PhysicsParams.FIELDS
        lo, hi = eff.plausible
        assert eff.physical[0] <= lo < hi <= eff.physical[1]


def test_the_probe_reads_every_field_in_the_schema_order(probe):
    """A P line sets each field through for_each_param: each field alone at a value that
    changes the speed shows that the probe put it where the schema says."""
    v, i, di, t = F32(9.1), F32(1.0), F32(50.0), F32(60.0)
    x = f"X {float(v)!r} {float(i)!r} {float(di)!r} {float(t)!r} {float(t - F32(5.0))!r}"
    for name, eff in fx.LIBRARY.items():
        p = dataclasses.replace(BASE, **{eff.field: eff.scale}, effects=eff.bit)
        got = F32(float(run_probe(probe, [p_line(p), x])[0]))
        want = ph.physics_rpm(p, [v], [i], [di], ph.Temps(np.array([t]), np.array([t - F32(5.0)])), F32)[0]
        assert abs(got - want) <= 2 * np.spacing(abs(want)), name
        assert abs(want - ph.physics_rpm(BASE, [v], [i], [di], t, F32)[0]) > 0.01, name  # the term matters
