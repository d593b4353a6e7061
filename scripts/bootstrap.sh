#!/usr/bin/env bash
# Installs everything hpddo needs on a Debian/Ubuntu machine, idempotently:
# system packages through apt-get (when root; otherwise prints the command),
# Python packages into the project venv at .venv.
# Usage: scripts/bootstrap.sh            what the main job needs (scripts/demo.sh): a C++
#                                        compiler, CMake and Eigen for the native replay
#        scripts/bootstrap.sh --tests    and what every test needs (scripts/test.sh): googletest,
#                                        the AVR and ESP8266 toolchains, simavr, clang's
#                                        sanitizers and fuzzer, Chromium for the reports, the
#                                        C++ headers of the ESP8266 sketch's compile-only check
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

apt_pkgs=(cmake g++ make python3 python3-venv python3-pip libeigen3-dev)
case "${1:-}" in
  --tests) apt_pkgs+=(git googletest libgtest-dev
                      gcc-avr avr-libc arduino-core-avr simavr libsimavr-dev
                      gcc-xtensa-lx106 binutils-xtensa-lx106 picolibc-xtensa-lx106-elf
                      clang libclang-rt-14-dev chromium
                      libstdc++-arm-none-eabi-dev  # its C++ headers: the ESP8266 sketch's compile check
                      qemu-system-misc gcc-12-source) ;;  # the lx106 in QEMU, its ROM's helpers from GCC's sources
  "") ;;
  *) echo "usage: scripts/bootstrap.sh [--tests]" >&2; exit 2 ;;
esac

missing=()
for p in "${apt_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  if [[ $(id -u) -eq 0 ]]; then
    echo "bootstrap: installing system packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "bootstrap: missing system packages; run as root:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
fi

# Project venv: the pinned dependencies (requirements.txt: runtime; requirements-test.txt:
# pytest, the build backend and the documentation site's MkDocs) and hpddo itself, editable (pip install -e: the venv's
# hpddo command and package are this tree's tools/hpddo, so the tests run against the
# tree). Refreshed only when pyproject.toml or a pin changes.
stamp=.venv/.requirements.sha256
want=$(cat pyproject.toml requirements.txt requirements-test.txt | sha256sum | cut -d' ' -f1)
if [[ ! -x .venv/bin/python || ! -f $stamp || $(cat "$stamp") != "$want" ]]; then
  echo "bootstrap: installing Python packages and hpddo (editable) into .venv"
  python3 -m venv .venv
  pip=(.venv/bin/pip install -q --disable-pip-version-check)
  "${pip[@]}" -r requirements.txt -r requirements-test.txt
  # The pins as constraints: hpddo's dependencies resolve to them (or pip says which
  # pin falls outside pyproject.toml's ranges); built with the pinned setuptools, offline.
  "${pip[@]}" --no-build-isolation -c requirements.txt -c requirements-test.txt -e '.[test]'
  echo "$want" > "$stamp"
fi
