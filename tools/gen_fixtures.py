#!/usr/bin/env python3
"""Writes the core's unit-test fixtures: small model headers and their golden vectors.

    tools/gen_fixtures.py ...   is   hpddo fixtures ...   (`hpddo fixtures --help` lists the options)

A thin wrapper, kept for the documents and tests that name it. Python puts this script's
folder first on the import path, so the package beside it (tools/hpddo) is the one that
runs, installed or not; the dependencies come from .venv (scripts/bootstrap.sh).
"""
import sys

if __name__ == "__main__":  # the stop handler first, before the tool loads (hpddo.interrupt)
    from hpddo import interrupt

    interrupt.arm("hpddo fixtures")

from hpddo.cli.fixtures import main, parser  # noqa: E402,F401 (parser: for the tests)

if __name__ == "__main__":
    sys.exit(main())
