#!/usr/bin/env bash
# Runs every test of hpddo: the host build with googletest, the three-compiler
# header checks, firmware simulation and fuzzing (all through ctest), the same
# host tests under AddressSanitizer and UndefinedBehaviorSanitizer, the benchmarks,
# and pytest for the tools on every core. Installs what it needs first
# (scripts/bootstrap.sh --tests).
#
# Usage: scripts/test.sh            the full run (the README's test command, CI)
#        scripts/test.sh --quick    for work in progress: the host build and its ctest
#                                   (no fuzzing), the documentation site, and pytest without
#                                   the tests marked slow (pyproject.toml, markers); no
#                                   sanitizers, no benchmarks
# Both build the documentation site (mkdocs.yml) with mkdocs build --strict into build-docs/:
# a broken link, a page missing from the nav or a stale anchor fails the run.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
quick=0
case "${1:-}" in
  --quick) quick=1 ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--quick]" >&2; exit 2 ;;
esac
bash scripts/bootstrap.sh --tests

jobs=$(nproc)

docs_site() {
  echo "== documentation site (mkdocs build --strict)"
  # (not --quiet: with it mkdocs 1.6 drops the warnings --strict counts, and passes)
  NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict
}
gen=(); command -v ninja >/dev/null && gen=(-G Ninja)

# ctest in build folder $1 (further options after it), then the tests it skipped with their reasons
# (test/ctest_skips.py, from ctest's JUnit file: ctest's own summary counts a skip as passed and gives no
# reason); a skip without a reason, or any skip under CI=true, fails the run.
run_ctest() {
  local dir=$1 rc=0
  shift
  ctest --test-dir "$dir" -j "$jobs" --output-on-failure --output-junit ctest-junit.xml "$@" || rc=$?
  python3 test/ctest_skips.py "$dir/ctest-junit.xml" || rc=$((rc ? rc : 1))
  return "$rc"
}

echo "== host build and ctest"
cmake -S . -B build "${gen[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$jobs"
if ((quick)); then
  run_ctest build -E '^firmware\.fuzz\.'
  docs_site
  echo "== pytest (quick: not the slow tests)"
  exec .venv/bin/python -m pytest -q -rs -n "$jobs" -m "not slow and not realtime" test/py
fi
run_ctest build
docs_site

echo "== sanitizer build (ASan + UBSan) and ctest"
cmake -S . -B build-asan "${gen[@]}" -DCMAKE_BUILD_TYPE=Debug -DHPDDO_SANITIZE=ON -DHPDDO_CROSS_CHECKS=OFF >/dev/null
cmake --build build-asan -j "$jobs"
run_ctest build-asan

echo "== benchmark (prints its figures; the targets are judged against peers measured in the same run)"
.venv/bin/hpddo bench
# AVR cycles in simavr, host samples/s: float against fixed point (the ESP8266's lx106 counts are left
# out for time; QEMU is installed by bootstrap.sh --tests and ctest's embedded.lx106.* ran on it above)
.venv/bin/hpddo bench --observer --no-lx106
# the diagnosis with its defaults on the bundled recordings beside one full-library fit (its peer)
.venv/bin/hpddo bench --diagnose

echo "== pytest"
rc=0
.venv/bin/python -m pytest -q -rs -n "$jobs" -m "not realtime" test/py || rc=$?
# the tests timed against the wall clock, one at a time with the cores to themselves
echo "== pytest (realtime, alone)"
.venv/bin/python -m pytest -q -rs -p no:xdist -m realtime test/py || rc=$((rc ? rc : $?))
exit "$rc"
