"""Builds and runs the native replay (host/replay.cpp) against a generated model header.

The replay is built by CMake only: host/CMakeLists.txt, standalone, for one model folder
(-DHPDDO_MODEL_DIR, -DHPDDO_MODEL_NAME, Eigen through find_package(Eigen3)), the same
recipe and flags (-O2, -ffp-contract=off) the root project uses for its own replay. Each
build has a temporary folder of its own (so that several models build at once, as hpddo
compare does); the executable is copied to where the caller asked and the folder removed.
"""
from __future__ import annotations

import json
import pathlib
import shutil
import subprocess
import tempfile

from .. import resource_root
from ..logs.errors import InputError

ROOT = resource_root()
SOURCE = ROOT / "host"


class ToolchainError(InputError):
    """CMake, a C++ compiler or Eigen is missing: the message says what to install."""


#: How to get the native replay's toolchain, for pip users and clones alike.
INSTALL = ("on Debian/Ubuntu: sudo apt-get install cmake g++ libeigen3-dev (in a clone of hpddo, "
           "scripts/bootstrap.sh runs it)")


def _cmake(args, what: str) -> None:
    res = subprocess.run(["cmake", *args], capture_output=True, text=True)
    if res.returncode == 0:
        return
    text = res.stdout + res.stderr
    if "CMAKE_CXX_COMPILER" in text and "could not be found" in text.replace("\n", " "):
        raise ToolchainError(f"no C++ compiler for the native replay: {INSTALL}")
    if "Eigen3" in text and "find_package" in text.replace("\n", " "):
        raise ToolchainError(f"Eigen 3 not found by CMake (find_package(Eigen3)) for the native replay: {INSTALL}")
    raise RuntimeError(f"{what} failed: cmake {' '.join(args)}\n{text}")


def build(model_dir: pathlib.Path, name: str, out: pathlib.Path) -> pathlib.Path:
    """Builds replay for model_<name>.h in model_dir with CMake; writes the executable
    to out and returns it."""
    if shutil.which("cmake") is None:
        raise ToolchainError(f"cmake not found, needed to build the native replay: {INSTALL}")
    if not (SOURCE / "replay.cpp").is_file():
        raise ToolchainError(f"the replay's sources are not at {SOURCE}: reinstall hpddo")
    with tempfile.TemporaryDirectory(prefix="hpddo-replay-") as bdir:
        _cmake(["-S", str(SOURCE), "-B", bdir, f"-DHPDDO_MODEL_DIR={pathlib.Path(model_dir).resolve()}",
                f"-DHPDDO_MODEL_NAME={name}"], "configuring the native replay")
        _cmake(["--build", bdir], "building the native replay")
        out = pathlib.Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(pathlib.Path(bdir) / "replay", out)
    return out


def run(exe: pathlib.Path, logs, out_dir: pathlib.Path, split: float | None = None) -> list:
    """Replays each log through the board observer; writes out_dir/<stem>.estimates.csv
    (every row: M1, M2, M3, residual, temperature used, status, part) and returns them
    as DataFrames, in the order of logs. split: the training fraction of each log that
    carries no split_row metadata (0: every row is a test row; None: the replay's 0.8)."""
    from .metrics import read_estimates
    cmd = [str(exe), "--out-dir", str(out_dir)]
    if split is not None:
        cmd += ["--split", repr(float(split))]
    cmd += [str(p) for p in logs]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"replay failed ({res.returncode}): {res.stderr.strip()}")
    return [read_estimates(pathlib.Path(out_dir) / f"{pathlib.Path(p).stem}.estimates.csv") for p in logs]


def bench(exe: pathlib.Path, logs, repeat: int) -> dict:
    """Replay throughput in memory on one thread, best of `repeat` passes over the logs:
    {"samples", "repeat", "per_sample_per_s", "batched_per_s"} (the replay's --bench)."""
    res = subprocess.run([str(exe), "--bench", str(int(repeat)), *map(str, logs)], capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"replay --bench failed ({res.returncode}): {res.stderr.strip()}")
    for line in reversed(res.stdout.splitlines()):
        if line.startswith('{"bench"'):
            return json.loads(line)["bench"]
    raise RuntimeError(f"replay --bench printed no result: {res.stdout[-500:]!r}")
