"""Runs one of test/embedded's Unity suites on the ESP8266's core (Xtensa lx106) in QEMU,
with the real Unity (ctest embedded.lx106.<suite>): Debian's xtensa-lx106-elf-gcc with
picolibc, the soft-float and division helpers the chip has in ROM assembled from GCC's
sources, the benchmark's start stub and memory map (test/bench/lx106.ld), Unity's output
through the simulator (unity_lx106.cpp). The same toolchain settings as the lx106
benchmark (hpddo.studies.perf). Exit status: the suite's (Unity's failure count), 77 (skipped,
with the reason) where QEMU or GCC's sources are not installed (`scripts/bootstrap.sh --tests`
installs them, as `hpddo bench --observer` does), or 1 with the reason under CI=true.

    run_unity.py SUITE --root ROOT --unity UNITY_SRC --build DIR
"""
import argparse
import glob
import os
import pathlib
import shutil
import subprocess
import sys

SKIP = 77


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("suite")
    ap.add_argument("--root", type=pathlib.Path, required=True)
    ap.add_argument("--unity", type=pathlib.Path, required=True)
    ap.add_argument("--build", type=pathlib.Path, required=True)
    a = ap.parse_args()
    sys.path.insert(0, str(a.root / "tools"))
    from hpddo.studies import perf

    if not (shutil.which("qemu-system-xtensa") and glob.glob(perf.GCC_SOURCE_GLOB) and shutil.which(perf.LX_CXX)):
        reason = ("qemu-system-misc, gcc-12-source or the lx106 GCC not installed (scripts/bootstrap.sh --tests "
                  "installs them)")
        if os.environ.get("CI") == "true":
            print(f"CI=true and {reason}: fails in CI")
            return 1
        print(f"skipped: {reason}")
        return SKIP
    b = a.build
    b.mkdir(parents=True, exist_ok=True)
    libsoft = perf._lx106_libgcc(b)
    emb = a.root / "test" / "embedded"
    unity_flags = ["-DUNITY_OUTPUT_CHAR=hpddo_unity_putchar",
                   "-DUNITY_OUTPUT_CHAR_HEADER_DECLARATION=hpddo_unity_putchar(int)",
                   "-DUNITY_OUTPUT_COMPLETE=hpddo_unity_done", "-include", emb / "unity_output.h"]
    inc = [f"-I{d}" for d in (a.unity, a.root / "lib" / "hpddo_core" / "src", a.root / "uno_acq",
                              a.root / "esp_infer", a.root / "models" / "default", a.root / "test" / "bench")]
    perf._run([perf.LX_CC, perf.LX_SPECS, "-O2", "-mlongcalls", "-mtext-section-literals", "-ffunction-sections",
               *unity_flags, f"-I{a.unity}", "-c", a.unity / "unity.c", "-o", b / "unity.o"])
    bench = a.root / "test" / "bench"
    perf._run([perf.LX_CXX, *perf.LX_FLAGS, "-fno-threadsafe-statics", *inc, "-c",
               emb / "lx106" / "unity_lx106.cpp", "-o", b / "unity_lx106.o"])
    perf._run([perf.LX_CXX, *perf.LX_FLAGS, "-c", bench / "lx106_di.cpp", "-o", b / "lx106_di.o"])
    perf._run([perf.LX_CXX, *perf.LX_FLAGS, "-fno-threadsafe-statics", "-Dmain=hpddo_suite_main", *unity_flags,
               *inc, "-c", emb / a.suite / f"{a.suite}.cpp", "-o", b / f"{a.suite}.o"])
    elf = b / f"{a.suite}.elf"
    perf._run([perf.LX_CC, perf.LX_SPECS, "-nostartfiles", "-T", bench / "lx106.ld", bench / "lx106_start.S",
               b / f"{a.suite}.o", b / "unity_lx106.o", b / "unity.o", b / "lx106_di.o", "-Wl,--gc-sections",
               "-Wl,--start-group", libsoft, "-lc", "-lm", "-Wl,--end-group", "-o", elf])
    res = subprocess.run([*perf.LX_QEMU, "-kernel", str(elf)], capture_output=True, text=True, timeout=600)
    print(res.stdout, end="")
    print(res.stderr, end="", file=sys.stderr)
    ok = res.returncode == 0 and "\nOK" in res.stdout
    print(f"[run_unity] {a.suite} on the lx106 in QEMU: exit {res.returncode}, {'passed' if ok else 'FAILED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
