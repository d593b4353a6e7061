"""Stopping a tool: Ctrl-C (SIGINT) or SIGTERM, at any moment, ends every hpddo tool with
one line and exit status 130 (SIGINT) or 143 (SIGTERM), no process of its own left running
and nothing half-written.

How. `handling()` installs one handler for both signals in the tool's main process. On the
first signal it ends every process the tool started (pool workers, compilers, the native
replay, the observers' tuners: all descendants, SIGTERM then SIGKILL) and raises
`Interrupted` in the main thread. The exception unwinds through the tools' `outdir.staged`
blocks, which remove their staging folders, so an output folder is either untouched or
complete; `outdir.commit` runs under `held()`, so a signal never falls between two of its
renames. Threads waiting on a killed process see it end and return.
In a forked worker the handler ignores SIGINT (a terminal sends it to the whole process
group; the main process stops the workers) and dies on SIGTERM as a process does by default.
"""
from __future__ import annotations

import contextlib
import os
import signal
import time

#: exit status of a tool stopped by each signal (128 + the signal's number, as a shell reports it)
STATUS = {signal.SIGINT: 128 + signal.SIGINT, signal.SIGTERM: 128 + signal.SIGTERM}
SIGNALS = tuple(STATUS)
KILL_GRACE_S = 2.0  # how long a descendant has to end after SIGTERM before SIGKILL


class Interrupted(KeyboardInterrupt):
    """The tool was stopped by a signal; `status` is its exit status."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum
        self.status = STATUS[signum]


def stop_descendants(grace_s: float = KILL_GRACE_S) -> int:
    """Ends every process this one started, and theirs (SIGTERM, then SIGKILL after
    grace_s); returns how many there were. It waits for them without reaping them: the
    zombie of a child is left for its owner (multiprocessing, subprocess) to collect, which
    would otherwise take a reaped worker for alive and wait for it forever."""
    import psutil

    try:
        kids = psutil.Process().children(recursive=True)
    except psutil.Error:
        return 0

    def gone(p) -> bool:
        try:
            return not p.is_running() or p.status() == psutil.STATUS_ZOMBIE
        except psutil.Error:
            return True

    for sig in ("terminate", "kill"):
        for p in kids:
            if not gone(p):
                with contextlib.suppress(psutil.Error):
                    getattr(p, sig)()
        deadline = time.monotonic() + grace_s
        while not all(gone(p) for p in kids) and time.monotonic() < deadline:
            time.sleep(0.02)
        if all(gone(p) for p in kids):
            break
    return len(kids)


_held = {"depth": 0, "pending": None}  # held(): how deeply, and the signal that came meanwhile


def _handler(main_pid: int):
    def handle(signum, frame):
        if os.getpid() != main_pid:  # a forked worker: the main process stops it
            if signum == signal.SIGTERM:
                signal.signal(signum, signal.SIG_DFL)
                os.kill(os.getpid(), signum)
            return
        if _held["depth"]:
            _held["pending"] = _held["pending"] or signum
            return
        for s in SIGNALS:  # a second signal while the first unwinds changes nothing
            signal.signal(s, signal.SIG_IGN)
        stop_descendants()
        raise Interrupted(signum)
    return handle


def worker_init() -> None:
    """A pool worker's initializer: SIGINT ignored (the main process stops its workers),
    SIGTERM ends it, whatever the start method."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextlib.contextmanager
def handling():
    """Within: SIGINT and SIGTERM raise Interrupted in the main thread after the tool's
    processes are ended. The previous handlers come back on exit."""
    handle = _handler(os.getpid())
    old = {s: signal.signal(s, handle) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def held():
    """Within: a SIGINT or SIGTERM waits, and takes effect on exit: for the few steps that
    must not be cut in two (moving a finished output into place). (Python runs signal
    handlers in the main thread, so a flag suffices where a signal mask would miss a signal
    delivered to another thread.)"""
    _held["depth"] += 1
    try:
        yield
    finally:
        _held["depth"] -= 1
        pending = _held["pending"]
        if pending and not _held["depth"]:
            _held["pending"] = None
            handler = signal.getsignal(pending)
            if callable(handler):
                handler(pending, None)
