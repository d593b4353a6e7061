"""Stopping a tool (hpddo.interrupt): SIGINT or SIGTERM at a random moment of every tool's
run gives one line, exit status 130 or 143, no process of the tool left running and no
half-written output.

Each case starts the tool in a session of its own, sends the signal to its main process
alone (as `timeout -s INT`, a supervisor or an IDE's stop button do) or to its whole
process group (as Ctrl-C in a terminal does), and then checks what is left."""
from __future__ import annotations

import os
import random
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
