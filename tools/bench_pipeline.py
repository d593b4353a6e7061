#!/usr/bin/env python3
"""Benchmark of the offline pipeline and the native replay; prints its figures.

    tools/bench_pipeline.py ...   is   hpddo bench ...   (`hpddo bench --help` lists the options)

A thin wrapper, kept for the documents and tests that name it. Python puts this script's
folder first on the import path, so the package beside it (tools/hpddo) is the one that
runs, installed or not; the dependencies come from .venv (scripts/bootstrap.sh).
"""
import sys

if __name__ == "__main__":  # the stop handler first, before the tool loads (hpddo.interrupt)
    from hpddo import interrupt

    interrupt.arm("hpddo bench")

from hpddo.cli.bench import main, parser  # noqa: E402,F401 (parser: for the tests)

if __name__ == "__main__":
    sys.exit(main())
