"""Stopping a tool (hpddo.interrupt): SIGINT or SIGTERM at a random moment of every tool's
run gives one line, exit status 130 or 143, no process of the tool left running and no
half-written output.

Each case starts the tool in a session of its own, sends the signal to its main process
alone (as `timeout -s INT`, a supervisor or an IDE's stop button do) or to its whole
process group (as Ctrl-C in a terminal does), and then checks what is left."""
from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time

import psutil
import pytest

from conftest import ROOT as REPO

DATA = REPO / "data" / "default"
LOGS = [str(DATA / f"{c}.csv") for c in ("sweep", "load", "long")]
EXIT_S = 60  # a stopped tool must be gone within this

pytestmark = pytest.mark.slow

# tool -> its arguments (OUT stands for the output folder); every tool that runs for more
# than a moment (capture has its own tests: it stops on Ctrl-C by design, tests/test_capture.py)
TOOLS = {
    "train": ["train", *LOGS, "--out", "OUT", "--epochs", "300"],
    "evaluate": ["evaluate", "--model", str(REPO / "models" / "default"), *LOGS, "--out", "OUT"],
    "diagnose": ["diagnose", *LOGS, "--out", "OUT"],
    "compare": ["compare", *LOGS, "--out", "OUT", "--quick"],
    "twin": ["twin", "--protocol", "long", "--out", "OUT"],
    "demo": ["demo", "--out", "OUT"],
    "fixtures": ["fixtures", "--out", "OUT"],
}


def _session_procs(sid: int) -> list:
    out = []
    for p in psutil.process_iter(["pid", "status"]):
        try:
            if os.getsid(p.pid) == sid and p.info["status"] != psutil.STATUS_ZOMBIE:
                out.append(p)
        except (ProcessLookupError, PermissionError, psutil.Error):
            pass
    return out


def _stop(tool: str, signum: int, group: bool, tmp_path, delay_s: float):
    out = tmp_path / "out"
    args = [str(out) if a == "OUT" else a for a in TOOLS[tool]]
    pr = subprocess.Popen([sys.executable, "-m", "hpddo", *args], cwd=tmp_path, stdin=subprocess.DEVNULL,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(delay_s)
    if pr.poll() is None:
        (os.killpg if group else os.kill)(pr.pid, signum)
    try:
        stdout, stderr = pr.communicate(timeout=EXIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(pr.pid, signal.SIGKILL)
        pr.communicate()
        pytest.fail(f"hpddo {tool} still running {EXIT_S} s after {signal.Signals(signum).name}")
    time.sleep(0.5)
    left = _session_procs(pr.pid)
    for p in left:
        p.kill()
    return pr.returncode, stdout, stderr, out, left


def _check_output(out, tmp_path, finished: bool):
    staging = [p.name for p in tmp_path.iterdir() if p.name.startswith(f".{out.name}.")]
    assert not staging, f"staging folders left: {staging}"
    if out.exists():  # a tool that commits in parts (demo) leaves only complete parts
        assert (out / ".hpddo-output.json").is_file() or finished, sorted(p.name for p in out.iterdir())


CASES = [(t, s, g) for t in TOOLS for s, g in ((signal.SIGINT, False), (signal.SIGTERM, False))]
CASES += [("diagnose", signal.SIGINT, True), ("compare", signal.SIGINT, True)]


@pytest.mark.parametrize("tool,signum,group", CASES,
                         ids=[f"{t}-{signal.Signals(s).name}{'-group' if g else ''}" for t, s, g in CASES])
def test_a_signal_stops_the_tool_cleanly(tool, signum, group, tmp_path):
    # a moment between the end of start-up and a few seconds into the work, drawn per case
    delay_s = random.Random(f"{tool}-{signum}-{group}").uniform(1.5, 6.0)
    status, stdout, stderr, out, left = _stop(tool, signum, group, tmp_path, delay_s)
    assert not left, f"processes left running: {[p.info for p in left]}"
    assert "Traceback" not in stderr, stderr[-3000:]
    if status == 0:  # finished before the signal came: nothing to check but the output
        _check_output(out, tmp_path, finished=True)
        return
    assert status == 128 + signum, (status, stderr[-2000:])
    lines = [ln for ln in stderr.replace("\r", "\n").splitlines() if ln.strip()]
    assert lines[-1].startswith(f"hpddo {tool}: stopped by {signal.Signals(signum).name}"), lines[-3:]
    assert sum("stopped by" in ln for ln in lines) == 1, lines
    _check_output(out, tmp_path, finished=False)


# --- From the first instruction: the signal at fixed delays after the start of each entry ---------------------
# (issue 32: a Ctrl-C while the tool was still importing gave a traceback.) Every entry of the tools, sent SIGINT
# or SIGTERM at DELAYS_S after its start, on a busy machine (a CPU hog beside it). What counts is whether the
# tool's first instruction had run when the signal was sent: an entry's first statement puts the handler for
# both signals in place (hpddo.interrupt.arm, SIGTERM last), and the interpreter itself never catches SIGTERM,
# so a SIGTERM caught in /proc/PID/status (SigCgt), read just before sending, says the tool had started. From
# then on: one line and 128 + the signal, every time. Before it (the interpreter's own start, no code of the tool
# run: median 48 ms for a bare interpreter beside the hog, 80-130 ms to an entry's first statement) the
# interpreter's own behaviour stands; those cases are counted, and they may not reach ARMED_BY_S.
DELAYS_S = [i * 0.015 for i in range(21)] + [0.45, 0.6]  # 0 to 300 ms, and two where every tool has started
ARMED_BY_S = 1.0  # every tool has armed its handler by then (seen: 391 ms at most, load average 11 on 2 cores)
# A SIGINT in the interpreter's start can be printed and dropped by CPython itself: a KeyboardInterrupt in
# importlib's module-lock weakref callback ("Exception ignored in: ... _get_module_lock.<locals>.cb"). Seen in
# 4 of 600 SIGINTs sent 11-16 ms after the start beside a CPU hog; the one other place that drops it (checking
# whether argv[0] is an import path entry) is caught by arm() (interrupt.swallowed_at_start). A tool still
# running this long after a signal sent before it armed was left running by the interpreter: the case is
# counted as before-the-start, and a second signal, as a user's second Ctrl-C, must give the line.
DROPPED_S = 8.0
BIN = os.path.dirname(sys.executable)
LOG_ARGS = [*LOGS, "--out", "OUT"]
ENTRIES = {  # name -> (command line, label of its line)
    "hpddo-diagnose": ([os.path.join(BIN, "hpddo"), "diagnose", *LOG_ARGS], "hpddo diagnose"),
    "python-m-hpddo-train": ([sys.executable, "-m", "hpddo", "train", *LOG_ARGS], "hpddo train"),
    "gen_weights.py": ([sys.executable, str(REPO / "tools" / "gen_weights.py"), *LOG_ARGS], "hpddo train"),
    "diagnose.py": ([sys.executable, str(REPO / "tools" / "diagnose.py"), *LOG_ARGS], "hpddo diagnose"),
    "twin.py": ([sys.executable, str(REPO / "tools" / "twin.py"), "--protocol", "long", "--out", "OUT"],
                "hpddo twin"),
    "demo.py": ([sys.executable, str(REPO / "tools" / "demo.py"), "--out", "OUT"], "hpddo demo"),
    "gen_fixtures.py": ([sys.executable, str(REPO / "tools" / "gen_fixtures.py"), "--out", "OUT"],
                        "hpddo fixtures"),
    "bench_pipeline.py": ([sys.executable, str(REPO / "tools" / "bench_pipeline.py"), "--repeat", "1"],
                          "hpddo bench"),
}


def _term_caught(pid: int) -> bool:
    with open(f"/proc/{pid}/status") as f:
        cgt = next(ln for ln in f if ln.startswith("SigCgt:"))
    return bool(int(cgt.split()[1], 16) >> (signal.SIGTERM - 1) & 1)


@pytest.fixture(scope="module")
def cpu_hog():
    """The other core busy, as in a loaded CI run."""
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    yield
    hog.kill()
    hog.wait()


def _stop_at(cmd, signum, delay_s, tmp_path):
    out = tmp_path / "out"
    shutil.rmtree(out, ignore_errors=True)
    args = [str(out) if a == "OUT" else a for a in cmd]
    pr = subprocess.Popen(args, cwd=tmp_path, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(delay_s)
    try:
        armed = _term_caught(pr.pid)
    except (FileNotFoundError, StopIteration):  # already gone
        armed = None
    if pr.poll() is None:
        os.kill(pr.pid, signum)
    again = False
    try:
        try:
            _, stderr = pr.communicate(timeout=EXIT_S if armed else DROPPED_S)
        except subprocess.TimeoutExpired:
            if armed:
                raise
            # sent in the interpreter's own start, and it went on: CPython dropped it (see DROPPED_S); the
            # user's second Ctrl-C, now with the handler in place, must stop the tool as any signal does
            again = True
            os.kill(pr.pid, signum)
            _, stderr = pr.communicate(timeout=EXIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(pr.pid, signal.SIGKILL)
        pr.communicate()
        pytest.fail(f"{args[:3]} still running {EXIT_S} s after {signal.Signals(signum).name} at {delay_s:.3f} s"
                    + (" (sent twice)" if again else ""))
    time.sleep(0.2)
    left = _session_procs(pr.pid)
    for p in left:
        p.kill()
    assert not left, f"processes left running after a signal at {delay_s:.3f} s: {[p.info for p in left]}"
    if "gen_fixtures.py" not in cmd[1]:  # hpddo fixtures writes into --out in place (test/fixtures holds
        _check_output(out, tmp_path, finished=pr.returncode == 0)  # hand-written files too), not staged
    return armed, pr.returncode, stderr, again


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=lambda s: signal.Signals(s).name)
@pytest.mark.parametrize("entry", list(ENTRIES))
def test_a_signal_from_the_first_instruction_gives_one_line(entry, signum, tmp_path, cpu_hog):
    cmd, label = ENTRIES[entry]
    name = signal.Signals(signum).name
    before = []
    for delay_s in DELAYS_S:
        armed, status, stderr, again = _stop_at(cmd, signum, delay_s, tmp_path)
        if again:  # the interpreter dropped the first: the second gave the line
            lines = [ln for ln in stderr.replace("\r", "\n").splitlines() if ln.strip()]
            assert status == 128 + signum and lines[-1].startswith(f"{label}: stopped by {name}: "), lines[-3:]
            print(f"{entry}: {name} at {delay_s:.3f} s dropped in the interpreter's start; the second stopped it")
        if not armed:
            assert delay_s < ARMED_BY_S, f"{entry} had not armed its handler {delay_s:.3f} s after its start"
            before.append(delay_s)
            continue
        where = f"{entry}, {name} at {delay_s:.3f} s"
        assert "Traceback" not in stderr, f"{where}:\n{stderr[-3000:]}"
        lines = [ln for ln in stderr.replace("\r", "\n").splitlines() if ln.strip()]
        assert status == 128 + signum, f"{where}: status {status}\n{stderr[-2000:]}"
        assert lines and lines[-1].startswith(f"{label}: stopped by {name}: "), f"{where}: {lines[-3:]}"
        assert sum("stopped by" in ln for ln in lines) == 1, f"{where}: {lines}"
    assert len(DELAYS_S) - len(before) >= 4, f"{entry}: the signal came before the tool started at {before}"


def test_a_signal_during_an_import_is_raised_after_it(tmp_path, monkeypatch):
    """In the run phase a signal landing in a module's import ends the processes at once and raises Interrupted
    once the import is done: raised inside it, it can come out as another error (numpy's C extension makes an
    ImportError of it, a traceback instead of the line)."""
    from hpddo import interrupt

    (tmp_path / "hpddo_sig_probe.py").write_text(
        "import os, signal, time\n"
        "os.kill(os.getpid(), signal.SIGTERM)\n"
        "t = time.monotonic()\n"
        "while time.monotonic() - t < 0.3:\n"  # bytecodes run while the signal is pending: the handler runs here
        "    pass\n"
        "DONE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(interrupt.Interrupted) as caught:
        with interrupt.handling("hpddo test"):
            import hpddo_sig_probe  # noqa: F401
            time.sleep(5)  # the signal sent again after the import lands here
    assert caught.value.status == 143
    assert sys.modules["hpddo_sig_probe"].DONE
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handling() gave the previous handler back


def test_a_ctrl_c_the_interpreter_dropped_at_its_start_ends_the_tool_at_arm(tmp_path):
    """Seen in CI (hpddo diagnose, SIGINT 30 ms after its start, still running 60 s later): CPython, checking
    whether the script's path is an import path entry before running it, prints a KeyboardInterrupt raised
    meanwhile ("Failed checking if argv[0] is an import path entry") and goes on. What it printed stays in
    sys.last_value; arm() ends the tool there with the line, as a Ctrl-C after it would."""
    code = ("import sys\n"
            "sys.last_value = KeyboardInterrupt()\n"  # as PyErr_Print leaves it
            "from hpddo import interrupt\n"
            "interrupt.arm('hpddo probe')\n"
            "print('ran on')\n")
    pr = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=EXIT_S, cwd=tmp_path)
    assert pr.returncode == 130, (pr.returncode, pr.stderr)
    assert "ran on" not in pr.stdout
    assert pr.stderr.strip().splitlines()[-1].startswith("hpddo probe: stopped by SIGINT: ")
    # an earlier exception of another kind is no request to stop
    pr = subprocess.run([sys.executable, "-c", code.replace("KeyboardInterrupt()", "ValueError()")],
                        capture_output=True, text=True, timeout=EXIT_S, cwd=tmp_path)
    assert pr.returncode == 0 and "ran on" in pr.stdout, pr.stderr
