"""Builds and runs the native replay (host/replay.cpp) against a generated model header.

The replay is built by CMake only: host/CMakeLists.txt, standalone, for one model folder
(-DHPDDO_MODEL_DIR, -DHPDDO_MODEL_NAME, Eigen through find_package(Eigen3)), the same
recipe and flags (-O2, -ffp-contract=off) the root project uses for its own replay. Each
build has a temporary folder of its own (so that several models build at once, as hpddo
compare does); the executable is copied to where the caller asked and the folder removed.

A built replay is kept in the user's cache (cache_dir) under a key of everything it is built
from (build_key: the replay's and the core's sources, the model header's code, the toolchain),
and given again where the key is the same: a training run again on the same logs, or a model
evaluated again, builds nothing (a build is 10-16 s of compiling Eigen on a 2-core machine).
"""
from __future__ import annotations

import hashlib
import json
import os
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


# The environment variable naming the folder of hpddo's cache (the built replays under replay/); empty: no
# cache. Unset: $XDG_CACHE_HOME/hpddo, else ~/.cache/hpddo.
CACHE_ENV = "HPDDO_CACHE_DIR"


def cache_dir() -> pathlib.Path | None:
    """The folder of the built replays (CACHE_ENV), None where the cache is turned off."""
    given = os.environ.get(CACHE_ENV)
    if given is not None:
        return pathlib.Path(given) / "replay" if given else None
    base = os.environ.get("XDG_CACHE_HOME") or str(pathlib.Path.home() / ".cache")
    return pathlib.Path(base) / "hpddo" / "replay"


def _tool_id(name: str) -> str:
    """A program on the PATH (or a path) as what would change its output: its real path, size and time."""
    found = shutil.which(name)
    if found is None:
        return f"{name}: none"
    real = os.path.realpath(found)
    st = os.stat(real)
    return f"{name}: {real} {st.st_size} {st.st_mtime_ns}"


# what else a build reads from the environment (CMake's compiler and flags, where Eigen is looked for)
BUILD_ENV = ("CXX", "CXXFLAGS", "CPPFLAGS", "LDFLAGS", "CMAKE_PREFIX_PATH", "CMAKE_GENERATOR", "Eigen3_DIR")


def build_key(model_dir: pathlib.Path, name: str) -> str:
    """sha256 of everything the replay of model_<name>.h is built from: the files of the replay's
    sources (host/) and of the core's headers, the model header's code (its comment lines, the
    provenance that names folders and commands, left out: they compile to nothing), the model's
    name, the toolchain (cmake, the C++ compiler: path, size and time; the environment it reads)."""
    h = hashlib.sha256()
    for base in (SOURCE, ROOT / "lib" / "hpddo_core" / "src"):
        for f in sorted(p for p in base.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
            h.update(f"{base.name}/{f.relative_to(base).as_posix()}\0".encode())
            h.update(f.read_bytes())
    header = (pathlib.Path(model_dir) / f"model_{name}.h").read_text(encoding="utf-8")
    h.update("\n".join(ln for ln in header.splitlines() if not ln.lstrip().startswith("//")).encode())
    cxx = os.environ.get("CXX") or "c++"
    h.update("\0".join([name, _tool_id("cmake"), _tool_id(cxx)]
                       + [f"{k}={os.environ.get(k, '')}" for k in BUILD_ENV]).encode())
    return h.hexdigest()


def _from_cache(key: str, out: pathlib.Path) -> bool:
    """Copies the replay kept under key to out; False where none is kept."""
    folder = cache_dir()
    if folder is None or not (folder / key / "replay").is_file():
        return False
    shutil.copy2(folder / key / "replay", out)
    return True


def _to_cache(key: str, exe: pathlib.Path) -> None:
    """Keeps exe under key (written aside, then renamed into place: a reader sees a whole file or
    none); a cache that cannot be written is left as it is."""
    folder = cache_dir()
    if folder is None:
        return
    try:
        (folder / key).mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".replay-", dir=folder / key)
        os.close(fd)
        shutil.copy2(exe, tmp)
        os.replace(tmp, folder / key / "replay")
    except OSError:
        pass


def build(model_dir: pathlib.Path, name: str, out: pathlib.Path) -> pathlib.Path:
    """Builds replay for model_<name>.h in model_dir with CMake; writes the executable
    to out and returns it (the one kept in the cache where build_key is the same)."""
    if shutil.which("cmake") is None:
        raise ToolchainError(f"cmake not found, needed to build the native replay: {INSTALL}")
    if not (SOURCE / "replay.cpp").is_file():
        raise ToolchainError(f"the replay's sources are not at {SOURCE}: reinstall hpddo")
    out = pathlib.Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    # (without its header there is no key: CMake's configure names the missing file)
    key = build_key(model_dir, name) if (pathlib.Path(model_dir) / f"model_{name}.h").is_file() else None
    if key is not None and _from_cache(key, out):
        return out
    with tempfile.TemporaryDirectory(prefix="hpddo-replay-") as bdir:
        _cmake(["-S", str(SOURCE), "-B", bdir, f"-DHPDDO_MODEL_DIR={pathlib.Path(model_dir).resolve()}",
                f"-DHPDDO_MODEL_NAME={name}"], "configuring the native replay")
        _cmake(["--build", bdir], "building the native replay")
        shutil.copy2(pathlib.Path(bdir) / "replay", out)
    if key is not None:
        _to_cache(key, out)
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
