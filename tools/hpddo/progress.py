"""Progress of a command's steps, declared once: a stage line on stderr as each step that can
take more than a moment starts, and a tqdm bar over a long loop on a terminal.

    hpddo evaluate: [   0.0 s] reading 1 log(s) (125.0 MB)
    hpddo evaluate: [  14.2 s] building the native replay (CMake, C++)

One line per stage, whether stderr is a terminal or a redirected log (a bar draws only on a
terminal: off it, tqdm is disabled, and no carriage return reaches the log). `--quiet`
silences both (hpddo.cli.run starts the reporter with the command's --quiet). The results,
warnings and errors are not progress: they print whatever --quiet says.

The library calls `stage(text)` and `bar(iterable, ...)` where a step begins; outside a
command (a test, a study calling the library) no reporter is active and both are silent
(bar returns the iterable itself).

May import: the standard library and tqdm only (a foundation, below everything else).
"""
from __future__ import annotations

import contextlib
import sys
import time

_active: list = []  # the reporters started by reporting(), innermost last


class Reporter:
    """The stage lines of one command (tool: its name, as `hpddo TOOL`)."""

    def __init__(self, tool: str, enabled: bool = True, stream=None):
        self.tool = tool
        self.enabled = enabled
        self.stream = stream
        self.t0 = time.perf_counter()

    def stage(self, text: str) -> None:
        if self.enabled:  # the line and its end in one write: print writes them apart, and a signal's handler run
            # between the two left the line open, so the tool's "stopped by" line joined it (test_interrupt, demo)
            stream = self.stream or sys.stderr
            stream.write(f"hpddo {self.tool}: [{time.perf_counter() - self.t0:6.1f} s] {text}\n")
            stream.flush()


@contextlib.contextmanager
def reporting(tool: str, enabled: bool = True, stream=None):
    """The reporter of a command, active inside the block."""
    r = Reporter(tool, enabled, stream)
    _active.append(r)
    try:
        yield r
    finally:
        _active.remove(r)


def active() -> bool:
    """Whether progress is shown (a command runs, and not --quiet)."""
    return bool(_active) and _active[-1].enabled


def stage(text: str) -> None:
    """One line: the step that starts now (nothing outside a command, or with --quiet)."""
    if _active:
        _active[-1].stage(text)


def bar(iterable, desc: str, total=None, unit: str = "it"):
    """iterable with a tqdm bar on a terminal (cleared when done: the stage line stays), the
    iterable itself otherwise."""
    if not active():
        return iterable
    from tqdm import tqdm
    return tqdm(iterable, desc=desc, total=total, unit=unit, leave=False, disable=None,
                file=_active[-1].stream or sys.stderr)


def size(paths) -> str:
    """The total size of files, as a stage line shows it."""
    import os
    n = 0
    for p in paths:
        try:
            n += os.path.getsize(p)
        except OSError:
            pass
    return f"{n / 1e6:.1f} MB" if n >= 1e5 else f"{n / 1e3:.0f} kB"
