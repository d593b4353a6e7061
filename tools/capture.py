#!/usr/bin/env python3
"""Records the acquisition board's USB stream to a bench log.

    tools/capture.py ...   is   hpddo capture ...   (`hpddo capture --help` lists the options)

A thin wrapper, kept for the documents and tests that name it. Python puts this script's
folder first on the import path, so the package beside it (tools/hpddo) is the one that
runs, installed or not; the dependencies come from .venv (scripts/bootstrap.sh).
"""
import sys

if __name__ == "__main__":  # the stop handler first, before the tool loads (hpddo.interrupt)
    from hpddo import interrupt

    interrupt.arm("hpddo capture")

from hpddo.cli.capture import main, parser  # noqa: E402,F401 (parser: for the tests)

if __name__ == "__main__":
    sys.exit(main())
