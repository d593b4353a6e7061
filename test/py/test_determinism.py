"""Generated files are a deterministic function of their inputs on any machine.

The committed model headers, golden vectors and metrics must come out byte for byte
the same whatever BLAS kernel OpenBLAS picks for the CPU (OPENBLAS_CORETYPE), however
many threads it runs, and whichever SIMD paths numpy dispatches to. The training
(hpddo/model/network.py) and the golden reference (hpddo/model/observer_ref.py) avoid BLAS for
that reason; these tests run them in fresh processes under several such settings and
compare the bytes.
"""
import hashlib
import os
import pathlib
import platform
import subprocess
import sys

import pytest

from conftest import ROOT

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick

PY = sys.executable
DATA = sorted(p for p in (ROOT / "data" / "default").glob("*.csv") if not p.name.endswith(".truth.csv"))


def _cpu_flags() -> set:
    try:
        text = pathlib.Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    for line in text.splitlines():
        if line.startswith(("flags", "Features")):
            return set(line.split(":", 1)[1].split())
    return set()


def variants() -> dict:
    """Environment settings that change BLAS kernels, BLAS threads and numpy's SIMD paths
    on this machine (only those the CPU can run)."""
    out = {"1 thread": {"OPENBLAS_NUM_THREADS": "1"}, "2 threads": {"OPENBLAS_NUM_THREADS": "2"}}
    if platform.machine() in ("x86_64", "AMD64"):
        out["Prescott, 1 thread"] = {"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"}
        if "avx2" in _cpu_flags():
            out["Haswell, 2 threads"] = {"OPENBLAS_CORETYPE": "Haswell", "OPENBLAS_NUM_THREADS": "2"}
            out["numpy without AVX2/FMA paths"] = {"NPY_DISABLE_CPU_FEATURES": "X86_V3",
                                                   "OPENBLAS_NUM_THREADS": "2"}
    elif platform.machine() in ("aarch64", "arm64"):
        out["ARMV8 kernel"] = {"OPENBLAS_CORETYPE": "ARMV8", "OPENBLAS_NUM_THREADS": "2"}
    return out


def run_env(extra: dict) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "NPY_DISABLE_CPU_FEATURES")}
    env.update(extra)
    return env


SNIPPET = r"""
import hashlib, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from hpddo.model import network, fixtures, export
rng = np.random.default_rng(7)
x = rng.normal(size=(1500, 5)) * [3.0, 0.4, 80.0, 0.4, 80.0] + [8.0, 0.5, 180.0, 0.5, 180.0]
y = 0.02 * x[:, 2] - 1.5 * x[:, 1] ** 2 + rng.normal(0, 0.3, 1500)
sc = network.Scaler.fit(x)
net, loss = network.train(sc.transform(x), y, network.AdamConfig(hidden=(16, 8), max_iter=15, seed=3))
h = hashlib.sha256()
for a in [sc.mean_, sc.scale_, *net.coefs_, *net.intercepts_, np.array(loss)]:
    h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
m = fixtures.tiny_model((4, 3), fixtures.SEED, 20.0)
rows = export.golden_rows(m, fixtures.tiny_stream(fixtures.SEED))
h.update(export.golden_csv(rows).encode())
print(h.hexdigest())
"""


def test_training_and_golden_reference_are_bitwise_identical_across_blas_and_simd_settings():
    digests = {}
    for name, extra in variants().items():
        res = subprocess.run([PY, "-c", SNIPPET, str(ROOT / "tools")], env=run_env(extra),
                             capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, f"{name}: {res.stderr}"
        digests[name] = res.stdout.strip()
    assert len(digests) >= 3
    assert len(set(digests.values())) == 1, f"results depend on the machine settings: {digests}"


def test_default_model_regenerates_byte_identical_under_another_blas_and_simd_setting(tmp_path):
    """The in-process regeneration (test_pipeline.py) runs with this machine's defaults and
    one BLAS thread; this one runs under the Prescott kernel, two threads and, where
    possible, without numpy's AVX2/FMA paths. Both must give the committed bytes."""
    extra = {}
    for v in variants().values():  # every setting this machine can take at once
        extra.update(v)
    extra["OPENBLAS_NUM_THREADS"] = "2"
    if "OPENBLAS_CORETYPE" in extra and platform.machine() in ("x86_64", "AMD64"):
        extra["OPENBLAS_CORETYPE"] = "Prescott"
    out = tmp_path / "regen"
    res = subprocess.run([PY, str(ROOT / "tools" / "gen_weights.py"), *map(str, DATA), "--out", str(out), "--quiet"],
                         env=run_env(extra), capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr
    for name in ("model_default.h", "golden_default.h", "golden_default.csv", "metrics.json",
                 "model_default_q.h", "golden_default_q.h", "golden_default_q.csv", "model_default_q8.h",
                 "golden_default_q8.h", "golden_default_q8.csv"):
        got = (out / name).read_bytes()
        want = (ROOT / "models" / "default" / name).read_bytes()
        assert got == want, (f"models/default/{name} differs when regenerated under {extra} "
                             f"(sha256 {hashlib.sha256(got).hexdigest()[:12]} against "
                             f"{hashlib.sha256(want).hexdigest()[:12]})")


def test_validation_recordings_regenerate_byte_identical_across_blas_and_simd_settings(tmp_path):
    """data/validation (hpddo twin --protocol validation --preset default --seed 1; about
    1.3 s a run) comes out with the committed bytes under every setting."""
    committed = ROOT / "data" / "validation"
    names = sorted(p.name for p in committed.iterdir() if p.name != "README.md")
    for k, (name, extra) in enumerate(variants().items()):
        out = tmp_path / f"v{k}"
        res = subprocess.run([PY, str(ROOT / "tools" / "twin.py"), "--protocol", "validation", "--preset",
                              "default", "--seed", "1", "--out", str(out), "--quiet"],
                             env=run_env(extra), capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, f"{name}: {res.stderr}"
        for f in names:
            assert (out / f).read_bytes() == (committed / f).read_bytes(), f"{name}: data/validation/{f} differs"
