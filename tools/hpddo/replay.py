"""Builds and runs the native replay (host/replay.cpp) against a generated model header."""
from __future__ import annotations

import json
import pathlib
import shutil
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[2]
EIGEN = pathlib.Path("/usr/include/eigen3")


def build(model_dir: pathlib.Path, name: str, out: pathlib.Path) -> pathlib.Path:
    """Compiles replay for model_<name>.h in model_dir; returns the executable."""
    cxx = shutil.which("g++") or shutil.which("c++")
    if not cxx:
        raise RuntimeError("no C++ compiler (g++): run scripts/bootstrap.sh")
    if not EIGEN.is_dir():
        raise RuntimeError(f"Eigen not found at {EIGEN}: run scripts/bootstrap.sh (libeigen3-dev)")
    cmd = [cxx, "-std=c++17", "-O2", "-ffp-contract=off", "-DNDEBUG", f"-I{ROOT / 'lib/hpddo_core/src'}", f"-I{ROOT / 'host'}",
           f"-isystem{EIGEN}", f"-I{model_dir}", f'-DHPDDO_MODEL_HEADER="model_{name}.h"',
           f"-DHPDDO_MODEL_NS=hpddo_model_{name}", str(ROOT / "host/replay.cpp"), "-o", str(out)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"building the replay failed:\n{' '.join(cmd)}\n{res.stderr}")
    return out


def run(exe: pathlib.Path, logs, metrics: pathlib.Path, out_dir: pathlib.Path | None = None,
        extra=()) -> tuple[dict, str]:
    """Runs the replay; returns (metrics dict, the table it printed)."""
    cmd = [str(exe), "--metrics", str(metrics), *extra]
    if out_dir is not None:
        cmd += ["--out-dir", str(out_dir)]
    cmd += [str(p) for p in logs]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"replay failed ({res.returncode}): {res.stderr.strip()}")
    return json.loads(metrics.read_text()), res.stdout
