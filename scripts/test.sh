#!/usr/bin/env bash
# Runs every test of hpddo: the host build with googletest, the three-compiler
# header checks, firmware simulation and fuzzing (all through ctest), the same
# host tests under AddressSanitizer and UndefinedBehaviorSanitizer, and pytest
# for the tools. Installs what it needs first (scripts/bootstrap.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/bootstrap.sh --tests

jobs=$(nproc)
gen=(); command -v ninja >/dev/null && gen=(-G Ninja)

echo "== host build and ctest"
cmake -S . -B build "${gen[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$jobs"
ctest --test-dir build -j "$jobs" --output-on-failure

echo "== sanitizer build (ASan + UBSan) and ctest"
cmake -S . -B build-asan "${gen[@]}" -DCMAKE_BUILD_TYPE=Debug -DHPDDO_SANITIZE=ON -DHPDDO_CROSS_CHECKS=OFF >/dev/null
cmake --build build-asan -j "$jobs"
ctest --test-dir build-asan -j "$jobs" --output-on-failure

echo "== benchmark (prints its figures; the targets are judged against peers measured in the same run)"
.venv/bin/hpddo bench
# AVR cycles in simavr, host samples/s: float against fixed point (the ESP8266's lx106 counts need
# QEMU, about 700 MB: `hpddo bench --observer` alone installs it on demand)
.venv/bin/hpddo bench --observer --no-lx106

echo "== pytest"
.venv/bin/python -m pytest -q test/py
