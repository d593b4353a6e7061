"""How long the diagnosis takes with its defaults (hpddo bench --diagnose).

Two benches, each diagnosed as `hpddo diagnose` does with its defaults (the bootstrap's
resamples and the hybrid retrained before and after): the bundled recordings (data/default:
three recordings, 8,451 rows) and a three-recording twin bench of 13,612 rows (LARGE: the
training protocols at 1.61 times their length, `hpddo twin --protocol all --preset default
--time-scale 1.61 --seed 2`, written into a temporary folder). On the bundled recordings the
physics verdict alone is timed too, and its peer in the same run: one fit of M2 with every
effect of the library on the same rows (core.fit_model), the unit every step of the diagnosis
is made of; the ratios to it do not depend on the machine, the seconds do.

The bootstrap's resamples and the hybrid's trainings run on the other core beside the stages
(core.diagnose, interrupt.Background), so the seconds are printed with the CPU-seconds of the
main process and of its workers: on a shared machine the wall time is the load's, and the
CPU-seconds say what the work costs. Their sum over two is the least wall time two idle cores
allow. Each figure is printed beside the one measured the same way before the diagnosis ran its
stages side by side (BEFORE).

The target (calibration issue, item 8): at most 10 s for each, on an idle 2-core machine. The
figure the issue measured before any work on speed: 31 s for a three-recording bench of 13.6k
rows on an idle 2-core machine (116 s with the other core busy).
"""
from __future__ import annotations

import pathlib
import resource
import time

TARGET_S = 10.0

# The large bench: the twin's training protocols (hpddo twin --protocol all) at LARGE_TIME_SCALE times
# their length, preset default, seed LARGE_SEED, 2 Hz: 13,612 rows in three recordings (glitches removed)
LARGE_PROTOCOLS = ("sweep", "load", "long")
LARGE_TIME_SCALE = 1.61
LARGE_SEED = 2
LARGE_PRESET = "default"
LARGE_RATE_HZ = 2.0

# The same measures before the diagnosis ran its stages side by side (commit 915662b), taken alternately
# with the code after it on the same 2-core machine in the same minutes (shared with other work, load
# 4-5, about one core left to this): wall s, CPU-s of the main process, CPU-s of its workers; the median of
# three runs on the bundled recordings, the lesser of two on the large bench. See docs/performance-diagnosis.md.
BEFORE = {
    "bundled": {"default_s": 20.6, "main_cpu_s": 7.4, "workers_cpu_s": 13.0},
    "large": {"default_s": 38.3, "main_cpu_s": 11.7, "workers_cpu_s": 26.5},
}


def _logs(data: pathlib.Path) -> list:
    from ..logs.errors import InputError

    logs = sorted(p for p in pathlib.Path(data).glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        raise InputError(f"no bench logs (*.csv) in {data}")
    return logs


def timed(logs, opt) -> dict:
    """diagnose(logs, opt) timed: wall s, CPU-s of this process and of the workers it started (their
    time is counted once they are reaped, which diagnose does before it returns)."""
    from ..diagnosis import core

    def workers() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    w0, c0, k0 = time.perf_counter(), time.process_time(), workers()
    core.diagnose(logs, opt)
    return {"s": time.perf_counter() - w0, "main_cpu_s": time.process_time() - c0, "workers_cpu_s": workers() - k0}


def command_s(logs, out: pathlib.Path) -> float:
    """The wall seconds of `hpddo diagnose LOGS --out OUT --quiet` with the defaults, as a user runs it: a
    fresh interpreter and its imports, the diagnosis, the report (its figures, index.html,
    diagnosis.json) and the process's exit."""
    import subprocess
    import sys

    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hpddo", "diagnose", *map(str, logs), "--out", str(out), "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def measure(data: pathlib.Path, out: pathlib.Path | None = None) -> dict:
    """The default diagnosis of the logs in data, its physics verdict alone (no bootstrap, no
    hybrid), and one full-library fit (the peer), measured in this process; and the command's
    wall time (command_s) where out, a folder for its report, is given."""
    from ..diagnosis import core

    logs = _logs(data)
    t0 = time.perf_counter()
    inp = core.load(logs, core.Options())
    core.fit_model(inp)
    peer_s = time.perf_counter() - t0
    physics = timed(logs, core.Options(bootstrap=0, hybrid=False))
    default = timed(logs, core.Options())
    rows = sum(r.rec.n for r in inp.rows)
    return {"recordings": len(logs), "rows": rows, "default_s": default["s"], "main_cpu_s": default["main_cpu_s"],
            "workers_cpu_s": default["workers_cpu_s"], "command_s": command_s(logs, out) if out is not None else None,
            "physics_s": physics["s"],
            "physics_cpu_s": physics["main_cpu_s"], "peer_fit_s": peer_s,
            "default_over_peer": default["s"] / peer_s, "physics_over_peer": physics["s"] / peer_s}


def large_bench(out_dir: pathlib.Path) -> list:
    """The large bench's recordings written into out_dir (as hpddo twin writes them): their paths."""
    from ..twin import generate, params

    bench = params.preset(LARGE_PRESET)
    for prot in LARGE_PROTOCOLS:
        generate.generate(bench, prot, LARGE_RATE_HZ, LARGE_SEED, out_dir=out_dir, preset_name=LARGE_PRESET,
                          time_scale=LARGE_TIME_SCALE)
    return _logs(out_dir)


def measure_large(out_dir: pathlib.Path) -> dict:
    """The default diagnosis of the large bench, written into out_dir/bench first, and the command's
    wall time on it (its report in out_dir/report)."""
    from ..diagnosis import core

    logs = large_bench(out_dir / "bench")
    default = timed(logs, core.Options())
    rows = sum(r.rec.n for r in core.load(logs, core.Options()).rows)
    return {"recordings": len(logs), "rows": rows, "default_s": default["s"], "main_cpu_s": default["main_cpu_s"],
            "workers_cpu_s": default["workers_cpu_s"], "command_s": command_s(logs, out_dir / "report")}


def _line(m: dict, before: dict) -> str:
    total = m["main_cpu_s"] + m["workers_cpu_s"]
    met = "met" if m["default_s"] <= TARGET_S else "NOT met"
    out = (f"{m['default_s']:.1f} s (target {TARGET_S:g} s on an idle 2-core machine: {met} on this machine as "
           f"loaded now); CPU-s {m['main_cpu_s']:.1f} main + {m['workers_cpu_s']:.1f} workers = {total:.1f}, "
           f"over two cores {total / 2:.1f} s")
    if before.get("default_s") is not None:
        b_total = before["main_cpu_s"] + before["workers_cpu_s"]
        out += (f"\n    before the stages side by side (BEFORE): {before['default_s']:.1f} s; CPU-s "
                f"{before['main_cpu_s']:.1f} + {before['workers_cpu_s']:.1f} = {b_total:.1f}")
    if m.get("command_s") is not None:
        met = "met" if m["command_s"] <= TARGET_S else "NOT met"
        out += (f"\n    the command as a user runs it (hpddo diagnose --out DIR, a fresh interpreter, the report "
                f"and the exit included): {m['command_s']:.1f} s (target {TARGET_S:g} s: {met} on this machine as "
                "loaded now)")
    return out


def report(m: dict, large: dict | None = None) -> str:
    from ..diagnosis.ranking import BOOTSTRAP
    lines = [
        f"diagnosis of {m['recordings']} recordings, {m['rows']} rows (data/default):",
        f"  with the defaults (bootstrap {BOOTSTRAP}, hybrid before and after): " + _line(m, BEFORE["bundled"]),
        f"  the physics verdict alone (--bootstrap 0 --no-hybrid): {m['physics_s']:.1f} s "
        f"({m['physics_cpu_s']:.1f} CPU-s)",
        f"  peer: one fit of M2 with every library effect on the same rows: {m['peer_fit_s']:.2f} s",
        f"  ratios (machine-independent): defaults / peer {m['default_over_peer']:.0f}, "
        f"physics verdict / peer {m['physics_over_peer']:.0f}",
    ]
    if large is not None:
        lines += [
            f"diagnosis of {large['recordings']} recordings, {large['rows']} rows (the twin's training protocols "
            f"x{LARGE_TIME_SCALE:g}, preset {LARGE_PRESET}, seed {LARGE_SEED}):",
            "  with the defaults: " + _line(large, BEFORE["large"]),
            "  the issue's figure before any work on speed: 31 s for 13.6k rows on an idle 2-core machine",
        ]
    return "\n".join(lines)
