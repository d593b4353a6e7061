#!/usr/bin/env python3
"""avr-libc's float on the ATmega328P against IEEE single rounded to nearest (numpy float32) and
its expf against the correctly rounded e^x (float32 of math.exp), and hpddo::exp_neg's Python twin
against the same: the measurement behind hpddo/dynamics.h's exp_neg (docs/firmware-internals.md, "The
dynamic family on the UNO"). Builds float_check.c with avr-gcc, runs it in simavr with the Unity
harness (test/embedded/avr/unity_sim.c, built by ctest as build/test/embedded/unity_sim) and prints
how many results differ and by how many ulp. A measurement, not a test.

    test/embedded/avr/float_check.py --unity-sim build/test/embedded/unity_sim --build /tmp/fc
"""
import argparse
import math
import pathlib
import subprocess
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2] / "tools"))
from hpddo.model.dynamics_ref import exp_neg  # noqa: E402

MCU = ["-mmcu=atmega328p", "-DF_CPU=16000000L", "-Os"]


def f32(h: str) -> np.float32:
    return np.array([int(h, 16)], np.uint32).view(np.float32)[0]


def ulps(a, b) -> int:
    return int(np.array([a], np.float32).view(np.int32)[0]) - int(np.array([b], np.float32).view(np.int32)[0])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--unity-sim", required=True, help="the simavr harness (build/test/embedded/unity_sim)")
    ap.add_argument("--build", type=pathlib.Path, required=True, help="a folder for the ELF")
    a = ap.parse_args()
    a.build.mkdir(parents=True, exist_ok=True)
    elf = a.build / "float_check.elf"
    subprocess.run(["avr-gcc", *MCU, "-std=gnu99", str(HERE / "float_check.c"), str(HERE / "unity_avr.c"), "-lm",
                    "-o", str(elf)], check=True)
    # the harness passes only on Unity's "OK", which this program does not print: its exit status is not ours
    res = subprocess.run([a.unity_sim, str(elf), "600"], capture_output=True, text=True)
    out = res.stdout + res.stderr
    if "end marker seen" not in out:
        print("the program did not finish in simavr:", out[-500:])
        return 1
    rows = [l.split() for l in out.splitlines() if len(l.split()) == 7 and all(len(x) == 8 for x in l.split())]
    if not rows:
        print("no rows from the board:", out[-500:])
        return 1
    ops = {"a + b": 0, "a * b": 0, "a / b": 0}
    exp_by_range = {(-1, 0): [], (-3, -1): [], (-10, -3): []}
    for sa, sb, ssum, sprod, squot, sx, se in rows:
        x, y = f32(sa), f32(sb)
        with np.errstate(all="ignore"):
            for key, want, got in (("a + b", x + y, ssum), ("a * b", x * y, sprod), ("a / b", x / y, squot)):
                ops[key] += np.float32(want) != f32(got)
        arg = f32(sx)
        ref = np.float32(math.exp(float(arg)))
        for (lo, hi), acc in exp_by_range.items():
            if lo <= arg < hi or (hi == 0 and arg == 0):
                acc.append((ulps(f32(se), ref), ulps(exp_neg(arg), ref)))
    print(f"avr-libc on the ATmega328P (simavr), {len(rows)} operand sets:")
    for key, n in ops.items():
        print(f"  {key}: {n} of {len(rows)} differ from IEEE single rounded to nearest")
    for (lo, hi), acc in exp_by_range.items():
        libm = [abs(u) for u, _ in acc]
        own = [abs(u) for _, u in acc]
        print(f"  expf(x), x in [{lo}, {hi}): {sum(1 for u in libm if u)} of {len(acc)} differ from the correctly "
              f"rounded e^x, by at most {max(libm)} ulp; hpddo::exp_neg: {sum(1 for u in own if u)} differ, "
              f"at most {max(own)} ulp")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
