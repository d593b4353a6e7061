"""Stopping a tool: Ctrl-C (SIGINT) or SIGTERM, at any moment, ends every hpddo tool with
one line and exit status 130 (SIGINT) or 143 (SIGTERM), no process of its own left running
and nothing half-written.

How. A tool's entry (hpddo.__main__ for the `hpddo` command and `python -m hpddo`, each
tools/*.py wrapper) calls `arm()` as its first statement, before anything heavy is imported:
one handler for both signals in the tool's main process. While the tool loads and parses
its command line no output folder is open and no process started, so a signal ends the
process at once with the line: nothing is raised into a half-done import, whatever module
it is. Once its subcommand returned, both signals are ignored: the process is exiting with
its status (Python's finalisation would put back the default, death by the signal with no
line, in place of a handler). Within `handling()`, where
the subcommand runs (hpddo.cli.run), the first signal ends every process the tool started
(pool workers, compilers, the native replay, the observers' tuners: all descendants, SIGTERM
then SIGKILL) and raises
`Interrupted` in the main thread. The exception unwinds through the tools' `outdir.staged`
blocks, which remove their staging folders, so an output folder is either untouched or
complete; `outdir.commit` runs under `held()`, so a signal never falls between two of its
renames. Threads waiting on a killed process see it end and return.
In a forked worker the handler ignores SIGINT (a terminal sends it to the whole process
group; the main process stops the workers) and dies on SIGTERM as a process does by default.
"""
from __future__ import annotations

import _signal  # the builtin under `signal` (which imports enum): this module loads nothing heavy, since a
import _thread  # tool's entry imports it first and arms it before anything else (arm)
import os
import sys
import time

SIGINT, SIGTERM = _signal.SIGINT, _signal.SIGTERM
SIGNALS = (SIGINT, SIGTERM)
NAMES = {_signal.SIGINT: "SIGINT", _signal.SIGTERM: "SIGTERM"}
#: exit status of a tool stopped by each signal (128 + the signal's number, as a shell reports it)
STATUS = {s: 128 + s for s in SIGNALS}
KILL_GRACE_S = 2.0  # how long a descendant has to end after SIGTERM before SIGKILL


class Interrupted(KeyboardInterrupt):
    """The tool was stopped by a signal; `status` is its exit status."""

    def __init__(self, signum: int):
        super().__init__(NAMES[signum])
        self.signum = signum
        self.status = STATUS[signum]


def stopped_line(label: str, signame: str) -> str:
    """The one line a stopped tool prints (label: `hpddo NAME`)."""
    return (f"{label}: stopped by {signame}: its processes ended, nothing half-written (an output folder is as "
            "it was, or complete)")


#: psutil once imported whole (handling() imports it before a tool starts any process): the handler never
#: imports it, so a signal landing while the main thread is importing psutil never meets it half-initialised
_psutil = None


STOP_SCANS = 20  # stop_descendants: scans of the process tree at the most while holding it still


def stop_descendants(grace_s: float = KILL_GRACE_S) -> int:
    """Ends every process this one started, and theirs (SIGTERM, then SIGKILL after
    grace_s); returns how many there were. It waits for them without reaping them: the
    zombie of a child is left for its owner (multiprocessing, subprocess) to collect, which
    would otherwise take a reaped worker for alive and wait for it forever. Before psutil is
    loaded (handling() loads it before the tool starts anything) there is nothing to end."""
    psutil = _psutil
    if psutil is None:
        return 0

    def gone(p) -> bool:
        try:
            return not p.is_running() or p.status() == psutil.STATUS_ZOMBIE
        except psutil.Error:
            return True

    # the tree held still first (SIGSTOP, scanned again until no new process shows): a process that a
    # child starts between one scan and the signals would lose its parent and run on (a compiler that the
    # native build's make started as the tool was stopped: a test's evaluate left a cc1plus running)
    kids, seen = [], set()
    for _ in range(STOP_SCANS):
        try:
            new = [p for p in psutil.Process().children(recursive=True) if p.pid not in seen]
        except psutil.Error:
            break
        if not new:
            break
        for p in new:
            seen.add(p.pid)
            try:
                p.suspend()
            except psutil.Error:
                pass
        kids += new
    for sig in ("terminate", "kill"):
        for p in kids:
            if not gone(p):
                try:
                    getattr(p, sig)()
                    if sig == "terminate":  # then let run (it is held still) to end
                        p.resume()
                except psutil.Error:
                    pass
        deadline = time.monotonic() + grace_s
        while not all(gone(p) for p in kids) and time.monotonic() < deadline:
            time.sleep(0.02)
        if all(gone(p) for p in kids):
            break
    return len(kids)


_held = {"depth": 0, "pending": None}  # held(): how deeply, and the signal that came meanwhile
#: the process's stop handler: armed (by a tool's entry, arm()), its phase ("start": loading and parsing,
#: nothing started yet; "run": the subcommand runs), the main process, the label of its line, handling()'s depth
_state = {"armed": False, "phase": None, "pid": None, "label": "hpddo", "depth": 0}


def _exit_now(signum: int) -> None:
    """Before a subcommand's run (loading, parsing): no output folder is open, so the
    process ends here: its processes ended, one line, the signal's status."""
    for s in SIGNALS:  # a second signal meanwhile changes nothing (and prints no second line)
        _signal.signal(s, _signal.SIG_IGN)
    stop_descendants()
    try:
        sys.stdout.flush()
    except Exception:  # noqa: BLE001 (a stream cut mid-write by the signal: what it held is lost either way)
        pass
    os.write(2, (stopped_line(_state["label"], NAMES[signum]) + "\n").encode())
    os._exit(STATUS[signum])


REDELIVER_S = 0.05  # a signal that came during an import is sent again this much later


def _importing(frame) -> bool:
    """Whether the main thread is executing a module's import: an exception raised there can come
    out of it as another error (numpy's C extension turns it into an ImportError), so the handler
    ends the processes at once and raises once the import is done (_again)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib._bootstrap"):
            return True
        frame = frame.f_back
    return False


def _again(signum: int) -> None:
    time.sleep(REDELIVER_S)
    os.kill(os.getpid(), signum)


def _handle(signum, frame):
    if os.getpid() != _state["pid"]:  # a forked worker: the main process stops it
        if signum == _signal.SIGTERM:
            _signal.signal(signum, _signal.SIG_DFL)
            os.kill(os.getpid(), signum)
        return
    if _state["phase"] != "run":
        _exit_now(signum)
    if _held["depth"]:
        _held["pending"] = _held["pending"] or signum
        return
    if _importing(frame):
        stop_descendants()
        _thread.start_new_thread(_again, (signum,))
        return
    for s in SIGNALS:  # a second signal while the first unwinds changes nothing
        _signal.signal(s, _signal.SIG_IGN)
    stop_descendants()
    raise Interrupted(signum)


def arm(label: str | None = None) -> None:
    """A tool's entry calls this first (hpddo.__main__, tools/*.py): from here on, SIGINT or
    SIGTERM at any moment ends the process with one line and 130 or 143, with no traceback,
    whatever is loading; inside handling() by unwinding (Interrupted), elsewhere at once. A
    Ctrl-C that the interpreter's start printed and dropped ends it here (swallowed_at_start).
    label: `hpddo NAME` for the line (default: `hpddo` and the command line's first word)."""
    if label is None:
        word = sys.argv[1] if len(sys.argv) > 1 else ""
        label = f"hpddo {word}" if word.isidentifier() else "hpddo"
    _state.update(armed=True, phase="start", pid=os.getpid(), label=label)
    _signal.signal(_signal.SIGINT, _handle)
    _signal.signal(_signal.SIGTERM, _handle)  # last: a caught SIGTERM means both are in place
    if swallowed_at_start():
        _exit_now(_signal.SIGINT)


def swallowed_at_start() -> bool:
    """Whether a Ctrl-C came during the interpreter's own start and was printed and dropped
    there: CPython, checking whether a script's path is an import path entry (zipimport) before
    it runs the script, prints any exception raised meanwhile ("Failed checking if argv[0] is an
    import path entry") and goes on, the KeyboardInterrupt with it; the tool would then run its
    whole course after the user asked it to stop. What PyErr_Print printed stays in
    sys.last_value (sys.last_exc from 3.12): a KeyboardInterrupt there is that lost request."""
    lost = getattr(sys, "last_exc", None) or getattr(sys, "last_value", None)
    return isinstance(lost, KeyboardInterrupt)


def worker_init() -> None:
    """A pool worker's initializer: SIGINT ignored (the main process stops its workers),
    SIGTERM ends it, whatever the start method; one BLAS thread (one_blas_thread)."""
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)
    _signal.signal(_signal.SIGTERM, _signal.SIG_DFL)
    one_blas_thread()


def one_blas_thread():
    """The BLAS and OpenMP libraries of this process held to one thread each, until the returned
    handle's restore_original_limits() (threadpoolctl). hpddo/__init__.py asks for one thread
    already, but only where the environment does not set OPENBLAS_NUM_THREADS itself; with it
    set to 2, 69 numbers of the 13.6k-row bench's diagnosis.json differed in their last digits
    from those under 1 (Ke's checks, interval budgets; no sentence, no effect). Held here, the
    diagnosis gives the same bytes whatever the environment says, and processes working side by
    side on the cores do not spread their products over each other's core. The trainings call
    no BLAS at all (network)."""
    import threadpoolctl

    return threadpoolctl.threadpool_limits(limits=1)


def map_on_cores(fn, jobs: list, shown=None) -> list:
    """[fn(job) for job in jobs], on every core: forked workers (worker_init: SIGINT is the main
    process's to handle), the results in the order of jobs. In this process where there is one core
    or one job, or where this is a daemonic pool's worker (which may not start processes). shown:
    (iterable of results, number of jobs) -> the same iterable (a progress bar), or None."""
    import multiprocessing

    show = shown if shown is not None else (lambda it, n: it)
    workers = min(len(jobs), os.cpu_count() or 1)
    if workers > 1 and not multiprocessing.current_process().daemon:  # (each worker: one_blas_thread)
        import concurrent.futures
        with concurrent.futures.ProcessPoolExecutor(max_workers=workers, initializer=worker_init,
                                                    mp_context=multiprocessing.get_context("fork")) as pool:
            return list(show(pool.map(fn, jobs), len(jobs)))
    return [fn(j) for j in show(jobs, len(jobs))]


WAIT_POLL_S = 0.1  # a wait on a background job wakes this often (a signal's handler runs in between)


class Task:
    """A job given to Background: result() gives what it returned (raises what it raised)."""

    def __init__(self, owner: "Background", fn, job):
        import threading

        self.owner, self.fn, self.job = owner, fn, job
        self.state = "queued"  # then "running" (in a worker or in this process) and "done"; or "cancelled"
        self._done = threading.Event()
        self._value = None
        self._exc = None

    def _finish(self, value=None, exc=None) -> None:
        self._value, self._exc = value, exc
        self.state = "done"
        self._done.set()

    def _run_here(self) -> None:
        try:
            value = self.fn(self.job)
        except Exception as exc:  # noqa: BLE001 (given back by result(), as a worker's would be)
            self._finish(exc=exc)
        else:
            self._finish(value)

    def result(self):
        """Its result, once done. Meanwhile this process does queued jobs itself, the first in the
        queue each time (the lowest priority number: the one the caller waits for last but longest
        to run starts first, and the cores finish together), and waits only where every job left
        is already running. A cancelled job whose result is asked for after all runs here."""
        with self.owner._lock:
            here = self.state == "cancelled"
            if here:
                self.state = "running"
        if here:
            self._run_here()
        while not self._done.is_set():
            job = self.owner._take()
            if job is not None:
                job._run_here()
            else:
                self._done.wait(WAIT_POLL_S)
        if self._exc is not None:
            raise self._exc
        return self._value

    def cancel(self) -> None:
        """Not run where it has not started (unless its result() is asked for after all)."""
        with self.owner._lock:
            if self.state == "queued":
                self.state = "cancelled"


class Background:
    """Jobs run on forked workers (worker_init: SIGINT is the main process's to handle) while this
    process goes on with its own work, each collected where it is needed (Task.result(), which
    has this process do queued jobs itself while it waits):
    `with Background() as bg: t = bg.submit(fn, job); ...; t.result()`.
    One worker fewer than the cores (this process works on the last one), and at most one job
    handed to each at a time, the lowest `priority` first (then in the order given), so that a job
    submitted late and needed first does not wait behind a queue. Where there is one core, or this
    is a daemonic pool's worker, every job runs in this process when its result is asked for. A
    job's result depends on the job alone, not on where or when it runs. On leaving the block the
    jobs not started are dropped; after an exception the workers are ended too (a signal's
    handler has ended them already)."""

    def __init__(self, workers: int | None = None):
        import heapq
        import multiprocessing
        import threading

        n = (os.cpu_count() or 1) - 1 if workers is None else int(workers)
        self.workers = max(n, 0) if not multiprocessing.current_process().daemon else 0
        self._heapq = heapq
        self._lock = threading.RLock()  # (a pool's callback may run inside _dispatch, in this thread)
        self._queue = []   # heap of (priority, order, Task)
        self._order = 0
        self._running = 0  # jobs in the workers
        self._pool = None
        self._closed = False

    def __enter__(self):
        # this process works beside the workers: one BLAS thread here too, as long as they run (and
        # with no worker too, so that the results are the same bits on every machine and setting)
        self._limits = one_blas_thread()
        return self

    def submit(self, fn, job, priority: int = 0) -> Task:
        task = Task(self, fn, job)
        with self._lock:
            self._heapq.heappush(self._queue, (priority, self._order, task))
            self._order += 1
            self._dispatch()
        return task

    def _executor(self):
        if self._pool is None:
            import concurrent.futures
            import multiprocessing
            self._pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=self.workers, initializer=worker_init, mp_context=multiprocessing.get_context("fork"))
        return self._pool

    def _pop(self):
        """The first queued job (the lock held), None where there is none; it is then running."""
        while self._queue:
            _, _, task = self._heapq.heappop(self._queue)
            if task.state == "queued":
                task.state = "running"
                return task
        return None

    def _take(self):
        """The first queued job, for this process to do while it waits; None where none is queued."""
        with self._lock:
            return self._pop()

    def _dispatch(self) -> None:
        """Hands queued jobs to the pool while a worker is free (the lock held)."""
        while self._running < self.workers and not self._closed:
            task = self._pop()
            if task is None:
                return
            try:
                fut = self._executor().submit(task.fn, task.job)
            except Exception as exc:  # noqa: BLE001 (a broken pool: the job fails with its error)
                task._finish(exc=exc)
                continue
            self._running += 1
            fut.add_done_callback(lambda f, t=task: self._done(f, t))

    def _done(self, fut, task: Task) -> None:
        # (in the pool's own thread)
        try:
            value = fut.result()
        except BaseException as exc:  # noqa: BLE001 (the job's error, or the pool's: given back by result())
            task._finish(exc=exc)
        else:
            task._finish(value)
        with self._lock:
            self._running -= 1
            self._dispatch()

    def __exit__(self, exc_type, exc, tb):
        with self._lock:
            self._closed = True
            for _, _, task in self._queue:
                if task.state == "queued":
                    task.state = "cancelled"
            self._queue.clear()
        if self._pool is not None:
            if exc_type is not None:  # nothing more is needed of the workers: ended, not waited for
                for p in list((getattr(self._pool, "_processes", None) or {}).values()):
                    try:
                        p.terminate()
                    except Exception:  # noqa: BLE001 (already gone)
                        pass
            self._pool.shutdown(wait=True, cancel_futures=True)
        self._limits.restore_original_limits()
        return False


class handling:
    """Within: SIGINT and SIGTERM raise Interrupted in the main thread after the tool's
    processes are ended (`with handling(label):`). In an armed process the handler stays
    after the block (a signal then ends the process at once); otherwise (a tool called from
    Python) the previous handlers come back on exit."""

    def __init__(self, label: str = "hpddo"):
        self.label = label
        self.old = None

    def __enter__(self):
        global _psutil
        import psutil  # whole, before the block starts any process (under arm(), a signal meanwhile exits)

        _psutil = psutil
        _state["label"] = self.label
        if not _state["armed"] and not _state["depth"]:
            _state["pid"] = os.getpid()
            self.old = {s: _signal.signal(s, _handle) for s in SIGNALS}
        _state["depth"] += 1
        _state["phase"] = "run"
        return self

    def __exit__(self, *exc):
        _state["depth"] -= 1
        if _state["depth"]:  # an outer block still runs
            return False
        _state["phase"] = None
        if _state["armed"]:  # the tool is done: what is left is its return and the interpreter's exit, which a
            for s in SIGNALS:  # signal would only cut short (Python's finalisation puts back the default,
                _signal.signal(s, _signal.SIG_IGN)  # death by the signal, for a handler; an ignored one stays)
        if self.old is not None:
            for s, h in self.old.items():
                _signal.signal(s, h)
        return False


class held:
    """Within: a SIGINT or SIGTERM waits, and takes effect on exit: for the few steps that
    must not be cut in two (moving a finished output into place). (Python runs signal
    handlers in the main thread, so a flag suffices where a signal mask would miss a signal
    delivered to another thread.)"""

    def __enter__(self):
        _held["depth"] += 1
        return self

    def __exit__(self, *exc):
        _held["depth"] -= 1
        pending = _held["pending"]
        if pending and not _held["depth"]:
            _held["pending"] = None
            handler = _signal.getsignal(pending)
            if callable(handler):
                handler(pending, None)
        return False
