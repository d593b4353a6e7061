"""The novelty gate (tools/hpddo/model/gate.py) and its board half (lib/hpddo_core/src/hpddo/gate.h):
weight 1 on the training rows, 0 far away, monotone away from the data, 0 for NaN and
infinities, a deterministic BLAS-free fit, and the C++ weight equal bit for bit to the
Python one (a small probe compiled plain and over the host flash fake)."""
import hashlib
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT
from hpddo.model import gate

F32 = np.float32


def training_rows(seed: int = 3, n_per: int = 150) -> np.ndarray:
    """Rows like the gate's input [v_V, i_A, n_M2, i_A(t-1), n_M2(t-1), temp_C]: a few
    operating points (duty, load) with noise, the lags equal to the values but for noise,
    and a warming stretch at one point."""
    rng = np.random.default_rng(seed)
    rows = []
    for v, i, temp in [(2.4, 0.12, 32.0), (4.8, 0.15, 33.0), (7.2, 0.18, 34.0), (9.6, 0.2, 35.0),
                       (9.6, 0.6, 36.0), (9.6, 1.1, 40.0)]:
        vv = v + 0.05 * rng.standard_normal(n_per)
        ii = i + 0.01 * rng.standard_normal(n_per)
        n = 28.0 * vv - 60.0 * ii
        tt = temp + (np.linspace(0.0, 30.0, n_per) if i > 1.0 else 0.2 * rng.standard_normal(n_per))
        rows.append(np.column_stack([vv, ii, n, ii + 0.005 * rng.standard_normal(n_per),
                                     n + 0.5 * rng.standard_normal(n_per), tt]))
    return np.concatenate(rows)


@pytest.fixture(scope="module")
def fitted():
    g = training_rows()
    return g, gate.fit(g, k=16)


def test_fit_shapes_and_rule(fitted):
    g, gd = fitted
    assert gd.prototypes.shape == (16, 6) and gd.prototypes.dtype == F32
    assert gd.centre.dtype == F32 and gd.scale.dtype == F32 and np.all(gd.scale > 0)
    assert gd.r_out_sq == F32(gate.OUT_FACTOR ** 2 * float(gd.r_in_sq))
    assert gd.r_in_sq >= F32(gate.MIN_RADIUS ** 2)
    assert gd.flash_bytes() == 4 * (2 * 6 + 16 * 6)
    # the prototypes are training rows (farthest-point sampling), scaled
    z = gate.scaled(gd, g)
    for p in gd.prototypes:
        assert np.any(np.all(z == p, axis=1))


def test_weight_one_on_training_rows(fitted):
    g, gd = fitted
    w = gate.weight(gd, g)
    assert np.mean(w == 1.0) >= gate.IN_QUANTILE - 1e-9  # the rule: 99 % of the rows within r_in
    assert np.all(w > 0.0)
    # with the 1.0 quantile every training row has weight 1
    assert np.all(gate.weight(gate.fit(g, k=16, in_quantile=1.0), g) == 1.0)
    # and each prototype itself
    protos = gd.prototypes.astype(np.float64) * gd.scale + gd.centre
    assert np.all(gate.weight(gd, protos) == 1.0)


def test_weight_zero_far_away_and_between_operating_points(fitted):
    g, gd = fitted
    far = np.array([[20.0, 3.0, 900.0, 3.0, 900.0, 150.0], [-5.0, 0.0, 0.0, 0.0, 0.0, 31.0]])
    assert np.all(gate.weight(gd, far) == 0.0)
    # inside every feature's training range, but at a (duty, load) pair absent from training
    v, i = 4.8, 1.1
    novel = np.array([[v, i, 28 * v - 60 * i, i, 28 * v - 60 * i, 34.0]])
    lo, hi = g.min(axis=0), g.max(axis=0)
    assert np.all((novel >= lo) & (novel <= hi))
    assert gate.weight(gd, novel)[0] == 0.0
    # a hot motor at a trained point: beyond the training temperatures
    hot = g[-1:].copy()
    hot[0, 5] += 40.0
    assert gate.weight(gd, hot)[0] == 0.0


def test_weight_monotone_away_from_the_data(fitted):
    _, gd = fitted
    for j in range(gd.dims):
        for sign in (1.0, -1.0):
            # from the prototype farthest out along +-e_j, outwards: every distance grows
            k = int(np.argmax(sign * gd.prototypes[:, j]))
            t = np.linspace(0.0, 5.0, 400)
            z = np.repeat(gd.prototypes[k:k + 1].astype(np.float64), len(t), axis=0)
            z[:, j] += sign * t
            w = gate.weight(gd, z * gd.scale + gd.centre)
            assert w[0] == 1.0 and w[-1] == 0.0
            assert np.all(np.diff(w) <= 0.0), (j, sign)
            assert np.all((w >= 0.0) & (w <= 1.0))


def test_weight_zero_for_nan_and_infinities(fitted):
    g, gd = fitted
    rows = np.repeat(g[:1], 4, axis=0)
    rows[0, 0] = np.nan
    rows[1, 5] = np.inf
    rows[2, 2] = -np.inf
    w = gate.weight(gd, rows)
    assert list(w[:3]) == [0.0, 0.0, 0.0] and w[3] == 1.0


def test_fit_refuses_bad_rules():
    g = training_rows()
    with pytest.raises(ValueError):
        gate.fit(g, method="sklearn")
    with pytest.raises(ValueError):
        gate.fit(g, out_factor=1.0)
    with pytest.raises(ValueError):
        gate.fit(np.full((5, 3), np.nan))


def test_isolated_rows_take_no_prototype_and_leave_the_radius():
    """A few duty-step rows (the lags still at the previous operating point; 5 of 905 rows, under
    the 1 % the radius leaves out) get no prototype, so the radius stays that of the rest (within
    the shift of centre and scale they bring); with every row a candidate (core_quantile 1.0, the
    gate before) each takes one of the 16 and the radius of every other row triples."""
    g = training_rows()
    points = [g[k * 150] for k in range(6)]
    steps = np.array([np.r_[points[k][:3], points[k - 1][3:5], points[k][5]] for k in range(1, 6)])
    with_steps = np.concatenate([g, steps])
    alone, core, every = gate.fit(g, k=16), gate.fit(with_steps, k=16), gate.fit(with_steps, k=16, core_quantile=1.0)

    def prototypes_on(gd, rows):
        return sum(bool(np.any(np.all(gd.prototypes == z, axis=1))) for z in gate.scaled(gd, rows))

    assert prototypes_on(core, steps) == 0 and prototypes_on(every, steps) == len(steps)
    assert abs(float(core.r_in_sq) / float(alone.r_in_sq) - 1.0) < 0.1
    assert float(every.r_in_sq) > 3.0 * float(alone.r_in_sq)
    assert np.mean(gate.weight(core, g) == 1.0) >= gate.IN_QUANTILE - 1e-9
    assert f"of {len(with_steps)} training rows" in core.rule  # the header's banner says how many were candidates
    with pytest.raises(ValueError):
        gate.fit(g, core_quantile=0.0)


def test_constant_rows_keep_a_minimum_radius():
    gd = gate.fit(np.ones((50, 3)), k=4)
    # one distinct row: one prototype, repeated to the k a model header declares
    assert gd.count == 4 and np.all(gd.prototypes == gd.prototypes[0]) and np.all(gd.scale == 1.0)
    assert gd.r_in_sq == F32(gate.MIN_RADIUS ** 2)
    assert gate.weight(gd, np.ones((1, 3)))[0] == 1.0


def _digest(gd) -> str:
    h = hashlib.sha256()
    for a in (gd.centre, gd.scale, gd.prototypes, np.array([gd.r_in_sq, gd.r_out_sq], F32)):
        h.update(np.ascontiguousarray(a, F32).tobytes())
    return h.hexdigest()


@pytest.mark.parametrize("method", gate.METHODS)
def test_fit_is_deterministic_across_blas_kernels(method):
    g = training_rows()
    here = _digest(gate.fit(g, k=16, method=method))
    assert _digest(gate.fit(g, k=16, method=method)) == here
    code = ("import sys, hashlib, numpy as np; sys.path.insert(0, %r); sys.path.insert(0, %r);"
            "import test_gate as t; from hpddo.model import gate;"
            "print(t._digest(gate.fit(t.training_rows(), k=16, method=%r)))"
            % (str(ROOT / "tools"), str(ROOT / "test/py"), method))
    for core in ("Prescott", "Haswell"):
        env = dict(os.environ, OPENBLAS_CORETYPE=core)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        assert out.stdout.strip() == here, core


PROBE = r"""
#include <stdio.h>
#include "hpddo/gate.h"
#include "gate_data.h"
int main() {
  float g[kGateDims];
  for (;;) {
    for (int j = 0; j < kGateDims; ++j) {
      unsigned int u;
      if (scanf("%x", &u) != 1) return 0;
      __builtin_memcpy(&g[j], &u, 4);
    }
    const float w = kGate.weight(g);
    unsigned int u;
    __builtin_memcpy(&u, &w, 4);
    printf("%08x\n", u);
  }
}
"""


@pytest.fixture(scope="module", params=["plain", "flash_fake"])
def probe(request, tmp_path_factory, fitted):
    cxx = shutil.which("g++") or shutil.which("c++")
    if not cxx:
        pytest.skip("no C++ compiler (g++): run scripts/bootstrap.sh")
    _, gd = fitted
    d = tmp_path_factory.mktemp("gate_probe_" + request.param)
    (d / "gate_data.h").write_text("#include \"hpddo/platform.h\"\n#include \"hpddo/gate.h\"\n"
                                   f"static const int kGateDims = {gd.dims};\n" + gate.cpp_data(gd))
    (d / "probe.cpp").write_text(PROBE)
    extra = ["-DHPDDO_FLASH_FAKE", "-O0"] if request.param == "flash_fake" else ["-O2"]
    exe = d / "probe"
    subprocess.run([cxx, "-std=c++11", "-ffp-contract=off", "-Wall", "-Werror", *extra,
                    f"-I{ROOT / 'lib/hpddo_core/src'}", f"-I{d}", str(d / "probe.cpp"), "-o", str(exe)], check=True)
    return exe, gd


def _vectors(g, gd) -> np.ndarray:
    rng = np.random.default_rng(11)
    lo, hi = g.min(axis=0), g.max(axis=0)
    span = hi - lo
    inside = lo + span * rng.uniform(0.0, 1.0, (3000, g.shape[1]))          # the training box
    near = g[rng.integers(0, len(g), 3000)] + 0.3 * gd.scale * rng.standard_normal((3000, g.shape[1]))
    ring = np.repeat(gd.prototypes[:1].astype(np.float64), 400, axis=0)      # across r_in .. r_out
    ring[:, 0] += np.linspace(0.0, 2.5 * float(np.sqrt(gd.r_out_sq)), 400)
    special = np.repeat(g[:1], 4, axis=0)
    special[0, 0], special[1, 3], special[2, 5], special[3, 1] = np.nan, np.inf, -np.inf, 3.0e38
    return np.concatenate([g, inside, near, ring * gd.scale + gd.centre, special]).astype(F32)


def test_cpp_weight_equals_python_bit_for_bit(probe, fitted):
    exe, gd = probe
    g, _ = fitted
    x = _vectors(g, gd)
    text = "\n".join(" ".join("%08x" % u for u in row) for row in x.view(np.uint32))
    out = subprocess.run([str(exe)], input=text + "\n", capture_output=True, text=True, check=True)
    got = np.array([int(s, 16) for s in out.stdout.split()], np.uint32).view(F32)
    want = gate.weight(gd, x)
    assert len(got) == len(want)
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32)), np.flatnonzero(got != want)[:10]
    # the vectors reach every branch: 1, the fade and 0
    assert np.any(want == 1.0) and np.any((want > 0.0) & (want < 1.0)) and np.any(want == 0.0)


def test_study_lives_apart_and_prints_its_tables(tmp_path, capsys):
    """The measurement is hpddo.studies.gate_study (python -m hpddo.studies.gate_study --table JSON);
    hpddo.model.gate holds only the gate."""
    import json

    from hpddo.studies import gate_study

    assert not any(hasattr(gate, n) for n in ("measure", "table", "verdict", "cost", "main", "VARIANTS"))
    names = [v[0] for v in gate_study.VARIANTS]
    cell = lambda m2, m3, gated: {"rows": 10, "lookup": 9.0, "M2": m2, "M3": m3,  # noqa: E731
                                  **{n: gated for n in names}, **{n + ":w": 0.5 for n in names}}
    res = {"t/none": {"chrono": cell(2.0, 1.0, 1.05), "unseen": cell(3.0, 5.0, 3.1), "hot": cell(3.0, 5.0, 4.0)}}
    path = tmp_path / "gate_measure.json"
    path.write_text(json.dumps(res))
    assert gate_study.main(["--table", str(path)]) == 0
    out = capsys.readouterr().out
    assert "| t/none | unseen | 10 | 9.00 | 3.00 | 5.00 | 3.10 (0.50) |" in out
    # never-seen: 3.1 <= 1.05 * 3.0 passes, 4.0 does not; chronological gain kept (2 - 1.05) / (2 - 1) = 95 %
    assert f"| {names[0]} | 1/2 | 1/1 | 95 % |" in out


def test_the_open_gate_of_no_gate_models_exports_and_keeps_every_finite_correction():
    """hpddo train --no-gate writes an open gate: finite thresholds (a header holds no
    infinity), weight 1 at any finite input, 0 for a NaN."""
    import dataclasses as dc

    from hpddo.model import export, fixtures
    og = gate.open_gate(5)
    model = dc.replace(fixtures.tiny_model(), gate=og)
    text = export.model_header(model, "open", {"command": "test"})
    assert "inf" not in text.split("kGatePrototypes")[-1].split("};")[0]
    g = np.array([[1e18, -1e18, 0.0, 3.0, -7.0], [0.0, 0.0, 0.0, 0.0, 0.0]], F32)
    assert gate.weight(og, g).tolist() == [1.0, 1.0]
    assert gate.weight(og, np.array([[np.nan, 0, 0, 0, 0]], F32))[0] == 0.0
