"""hpddo live (docs/live.md) without a board: a pseudo-terminal pair plays
the UNO, writing a bench log's rows (data/default/sweep.csv at 100 samples/s, with the
rpm_est,est_status columns the UNO's own observer appends) once the tool sends its
recording command; a second pair plays the ESP8266's telemetry.

    python test/py/test_live.py --measure 100 200 400   the rows/s figure of docs/live.md
"""
from __future__ import annotations

import argparse
import bisect
import contextlib
import itertools
import json
import os
import pathlib
import re
import select
import signal
import struct
import subprocess
import sys
import threading
import time

import pytest

try:
    from conftest import ROOT
except ImportError:  # run as a script (--measure)
    ROOT = pathlib.Path(__file__).resolve().parents[2]
    sys.path.insert(0, str(ROOT / "tools"))

from hpddo.reports import live as live_page  # noqa: E402

SWEEP = ROOT / "data" / "default" / "sweep.csv"
END = "! end done overruns=0"


def uno_stream(rate_hz: float = 100.0, source: pathlib.Path = SWEEP, repeat: int = 1) -> list[str]:
    """The lines the UNO writes for a recording of source at rate_hz, without its end line:
    its metadata (sample_rate_hz set), the header with rpm_est,est_status, one row per
    sample with t_s at 6 decimals as the board formats it; rpm_est is a stand-in estimate
    (the encoder's speed x 1.02 + 3, 2 decimals) and est_status 0 (ok), 3 (invalid) at rest."""
    text = source.read_text().splitlines()
    meta = [ln if not ln.startswith("# sample_rate_hz=") else f"# sample_rate_hz={rate_hz:g}"
            for ln in text if ln.startswith("#")]
    header = text[len(meta)]
    cols = header.split(",")
    lines = meta + [header + ",rpm_est,est_status"]
    rows = [r.split(",") for r in text[len(meta) + 1:] if r]
    seq = 0
    for _ in range(repeat):
        for r in rows:
            cells = dict(zip(cols, r))
            ref = float(cells["rpm_ref"])
            cells["t_s"] = f"{seq / rate_hz:.6f}"
            cells["seq"] = str(seq)
            lines.append(",".join(cells[c] for c in cols) + f",{ref * 1.02 + 3:.2f},{0 if ref > 0 else 3}")
            seq += 1
    return lines


def esp_line(seq: int, rpm_ref: float) -> str:
    """A telemetry line of the ESP8266 (esp_infer/infer_line.h's members and decimals)."""
    return json.dumps({"seq": seq & 0xFFFF, "rpm": round(rpm_ref * 0.99 + 1, 2), "rpm_m2": round(rpm_ref * 0.97, 2),
                       "residual": round(rpm_ref * 0.02 + 1, 2), "confidence": 1.0, "status": "ok", "us": 812,
                       "rpm_ref": rpm_ref, "v": 9.612, "i": 0.812, "gaps": 0, "lost": 0, "crc_errors": 0},
                      separators=(",", ":"))


class Board:
    """A board on a pseudo-terminal pair: the tool opens `name`; the board waits for a
    recording command (with wait_command), then writes `lines` at rate_hz on a fixed
    schedule, then waits for `release` before writing `end` (if any); on_start() is called
    just before the first line goes out (the UNO starting its recording)."""

    def __init__(self, lines, rate_hz: float, end: str | None = END, wait_command: bool = True, on_start=None):
        self.master, self.slave = os.openpty()
        self.name = os.ttyname(self.slave)
        self.lines = [(ln + "\n").encode() for ln in lines]
        self.rate_hz, self.end, self.wait_command, self.on_start = rate_hz, end, wait_command, on_start
        self.release = threading.Event()
        self.stopped = threading.Event()
        self.sent = 0
        self.sent_at: list[float] = []  # time.monotonic() of each line written
        self.late_s = 0.0  # the most a line was written after its time (a reader that does not keep up)
        self.elapsed_s = None
        self.received = b""
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _read(self, timeout: float) -> None:
        if select.select([self.master], [], [], timeout)[0]:
            try:
                self.received += os.read(self.master, 4096)
            except OSError:
                pass

    def _run(self):
        while self.wait_command and not re.search(rb"^(rec|run)\b", self.received, re.M):
            if self.stopped.is_set():
                return
            self._read(0.1)
        if self.on_start is not None:
            self.on_start()
        t0 = time.monotonic()
        for k, line in enumerate(self.lines):
            if self.stopped.is_set():
                return
            due = t0 + k / self.rate_hz
            now = time.monotonic()
            if due > now:
                time.sleep(due - now)
            else:
                self.late_s = max(self.late_s, now - due)
            os.write(self.master, line)
            self.sent_at.append(time.monotonic())
            self.sent += 1
        self.elapsed_s = time.monotonic() - t0
        while not self.release.wait(0.1):
            if self.stopped.is_set():
                return
        if self.end is not None:
            os.write(self.master, (self.end + "\n").encode())
        while not self.stopped.is_set():  # drain what the tool writes ("stop")
            self._read(0.1)

    def close(self):
        self.stopped.set()
        self.release.set()
        self._thread.join(5)
        os.close(self.master)
        os.close(self.slave)


def start_live(tmp_path, board: Board, *args, out_name="live.csv"):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "tools"))
    cmd = [sys.executable, "-m", "hpddo", "live", "--port", board.name, "--rec", "live", "--out",
           str(tmp_path / out_name), "--http-port", "0", "--quiet", *args]
    return subprocess.Popen(cmd, cwd=tmp_path, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)



@contextlib.contextmanager
def session(proc, board):
    """Around a run of the tool on board: on any exit, the tool killed if it still runs and
    the board closed."""
    try:
        yield
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        board.close()


def finish(proc, board, timeout: float = 60) -> tuple[str, str]:
    """Lets the board end its recording and waits for the tool; its (stdout, stderr)."""
    board.release.set()
    return proc.communicate(timeout=timeout)

def page_url(proc) -> str:
    line = proc.stdout.readline()
    m = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
    assert m, f"no URL in {line!r} (stderr: {proc.stderr.read() if proc.poll() is not None else ''})"
    return m.group(0)


#: true once the page has its document and its first points
PAGE_READY = ("Bokeh.documents.length > 0 && Bokeh.documents[0].get_model_by_name('uno') !== null && "
              "Bokeh.documents[0].get_model_by_name('uno').get_length() > 0")


def what_capture_writes(lines: list[str], path: pathlib.Path) -> bytes:
    """The bench log hpddo capture writes from the same stream (its own code, a stand-in port)."""
    from hpddo.cli import capture

    class Port:
        def __init__(self):
            self.queue = [(ln + "\n").encode() for ln in lines]

        def write(self, b):
            pass

        def readline(self):
            return self.queue.pop(0) if self.queue else b""

    capture.capture(Port(), path, "rec live", progress=False, log=lambda *_: None)
    return path.read_bytes()


# ---------------------------------------------------------------- the page and the recording

@pytest.mark.slow
@pytest.mark.realtime
def test_live_records_what_capture_would_and_the_page_shows_the_points(tmp_path):
    from hpddo.reports import browser

    if browser.chromium() is None:
        pytest.skip("chromium is not installed (scripts/bootstrap.sh --tests installs it)")
    lines = uno_stream(100.0)
    n_rows = len(lines) - sum(ln.startswith("#") for ln in lines) - 1
    uno = Board(lines, 100.0)
    esp = Board([], 100.0, end=None, wait_command=False)
    proc = start_live(tmp_path, uno, "--esp-port", esp.name)
    # the same stream, at the same time, into hpddo capture
    uno2 = Board(lines, 100.0)
    cap = subprocess.Popen([sys.executable, "-m", "hpddo", "capture", "--port", uno2.name, "--rec", "live", "--out",
                            str(tmp_path / "capture.csv"), "--quiet"], cwd=tmp_path, stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           env=dict(os.environ, PYTHONPATH=str(ROOT / "tools")))
    try:
        url = page_url(proc)
        # the ESP8266's lines, a little after the UNO's rows (as the link and its observer delay them)
        feeder = threading.Thread(target=lambda: [
            (os.write(esp.master, (esp_line(k, float(r.split(",")[4])) + "\n").encode()), time.sleep(0.01))
            for k, r in enumerate(lines[len(lines) - n_rows:])], daemon=True)
        while uno.sent < 200 and proc.poll() is None:
            time.sleep(0.05)
        feeder.start()
        shot = tmp_path / "page.png"
        js = "(() => {{ const s = Bokeh.documents[0].get_model_by_name('{}'); return s.get_length(); }})()"
        seen = browser.live(url, shot, 3.0, {"uno": js.format("uno"), "esp": js.format("esp"),
                                             "counts": "Bokeh.documents[0].get_model_by_name('counts').text"},
                            ready=PAGE_READY)
        assert not seen["console_errors"], seen["console_errors"]
        points = seen["values"]
        # the page holds the rows that arrived while it was open, and the ESP8266's joined to them
        assert points["uno"] >= 300 and points["esp"] >= 100, points
        assert re.search(r"\d+ rows recorded, 0 samples lost, 0 garbled; ESP8266: \d+ lines, \d+ joined",
                         points["counts"]), points["counts"]
        # and drew them: the encoder's line (black), the UNO's estimate (blue), the ESP8266's (orange)
        counts = browser.colour_pixels(shot, {"encoder": (0, 0, 0), "uno": (0x1f, 0x77, 0xb4),
                                              "esp": (0xff, 0x7f, 0x0e)})
        assert min(counts.values()) > 1000, counts
        feeder.join(30)
        while uno.elapsed_s is None and proc.poll() is None:
            time.sleep(0.05)
        uno.release.set()
        stdout, stderr = proc.communicate(timeout=60)
        while uno2.elapsed_s is None and cap.poll() is None:
            time.sleep(0.05)
        uno2.release.set()
        cap_out, cap_err = cap.communicate(timeout=60)
    finally:
        for pr in (proc, cap):
            if pr.poll() is None:
                pr.kill()
                pr.communicate()
        for board in (uno, uno2, esp):
            board.close()
    assert proc.returncode == 0, stderr
    assert cap.returncode == 0, cap_err
    assert f"{n_rows} rows, 0 seq gaps, 0 samples lost" in stdout, stdout
    assert uno.late_s < 0.5, f"the tool did not keep up: a row went out {uno.late_s:.3f} s late"
    recorded = (tmp_path / "live.csv").read_bytes()
    assert recorded == (tmp_path / "capture.csv").read_bytes()  # hpddo capture's, over its own pseudo-terminal
    assert recorded == what_capture_writes(lines + [END], tmp_path / "capture_in_process.csv")
    body = [ln for ln in recorded.decode().splitlines() if ln and not ln.startswith("#")]
    assert len(body) == n_rows + 1 and recorded.startswith(b"# complete=true\n# garbled_rows=0\n")
    assert not list(tmp_path.glob("*.partial"))



@pytest.mark.slow
def test_the_esp8266_logic_host_build_joins_the_page_on_seq(tmp_path):
    """The ESP8266's side played by its own logic (host/esp_host: infer::App with the default
    model and ArduinoJson 7) fed the frames of the same rows at 100 Hz, as the link delivers them."""
    from test_upload import esp_host

    from hpddo.reports import browser

    if browser.chromium() is None:
        pytest.skip("chromium is not installed (scripts/bootstrap.sh --tests installs it)")
    exe = esp_host()
    # two sweeps (13.2 s): the frames start with esp_host, before the tool has opened its port
    lines = uno_stream(100.0, repeat=2)
    log = tmp_path / "stream.csv"  # the UNO's rows, from which the link's frames are made
    log.write_text("\n".join(lines) + "\n")
    esp = subprocess.Popen([str(exe), "--store", str(tmp_path / "littlefs"), "--pty", "--frames", str(log),
                            "--rate", "100"], stdout=subprocess.PIPE, text=True)
    uno = Board(lines, 100.0)
    proc = None
    try:
        first = esp.stdout.readline()
        assert first.startswith("pty "), first
        proc = start_live(tmp_path, uno, "--esp-port", first.split()[1])
        url = page_url(proc)
        # the page is looked at once every row is out (the recording not ended yet): the ESP8266's
        # lines run ahead of the UNO's rows by the tool's start-up and are joined as the rows come
        while uno.elapsed_s is None and proc.poll() is None:
            time.sleep(0.05)
        js = "Bokeh.documents[0].get_model_by_name('{}')"
        seen = browser.live(url, tmp_path / "page.png", 1.0, {
            "esp": js.format("esp") + ".get_length()", "counts": js.format("counts") + ".text",
            "esp_status": "(d => Array.from(d instanceof Map ? d.get('status') : d.status))(" + js.format("esp")
                          + ".data)"}, ready=PAGE_READY)
        uno.release.set()
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.communicate()
        uno.close()
        esp.terminate()
        esp.wait(10)
    assert proc.returncode == 0, stderr
    assert not seen["console_errors"], seen["console_errors"]
    values = seen["values"]
    assert values["esp"] >= 300, values
    m = re.search(r"ESP8266: (\d+) lines, (\d+) joined on seq, 0 not telemetry", values["counts"])
    assert m and int(m.group(2)) >= 300, values["counts"]
    assert set(values["esp_status"]) <= {0, 1, 2, 3, 4}, values["esp_status"][:20]

# ---------------------------------------------------------------- the address and the port

def test_the_options_default_to_127_0_0_1_port_5006_and_the_flag_opens_it():
    from hpddo import cli
    from hpddo.cli import live

    p = cli.parser("live")
    a = p.parse_args(["--port", "/dev/ttyX", "--out", "x.csv"])
    assert not a.open_to_network and a.http_port == 5006
    assert p.parse_args(["--port", "/dev/ttyX", "--out", "x.csv", "--open-to-network"]).open_to_network
    assert live.LOCAL == "127.0.0.1"



def test_a_page_port_in_use_or_a_missing_esp_port_is_one_line_and_nothing_recorded(tmp_path, capsys):
    import socket

    from hpddo import cli

    out = tmp_path / "l.csv"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        code = cli.main(["live", "--port", str(tmp_path / "no-uno"), "--out", str(out), "--http-port",
                         str(taken.getsockname()[1])])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith("hpddo live: cannot serve the page on 127.0.0.1:") and err.count("\n") == 1, err
    code = cli.main(["live", "--port", str(tmp_path / "no-uno"), "--esp-port", str(tmp_path / "no-esp"),
                     "--out", str(out), "--http-port", "0"])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith("hpddo live: cannot open serial port ") and "no-esp" in err, err
    assert err.count("\n") == 1 and list(tmp_path.iterdir()) == []

@pytest.mark.slow
@pytest.mark.parametrize("open_to_network", [False, True])
def test_bind_address_and_warning(tmp_path, open_to_network):
    import psutil

    uno = Board(uno_stream(100.0)[:50], 100.0)
    proc = start_live(tmp_path, uno, *(["--open-to-network"] if open_to_network else []))
    with session(proc, uno):
        page_url(proc)
        tool = psutil.Process(proc.pid)  # the page listens in a process of the tool's own
        listening = {c.laddr.ip for p in [tool, *tool.children(recursive=True)] for c in p.net_connections(kind="tcp")
                     if c.status == psutil.CONN_LISTEN}
        stdout, stderr = finish(proc, uno)
    assert proc.returncode == 0, stderr
    if open_to_network:
        assert listening == {"0.0.0.0"}, listening
        warning = [ln for ln in stderr.splitlines() if "WARNING" in ln]
        assert len(warning) == 1 and "open to the network" in warning[0] and "0.0.0.0" in warning[0], stderr
    else:
        assert listening == {"127.0.0.1"}, listening
        assert "WARNING" not in stderr, stderr


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_ends_it_with_one_line_and_releases_the_port(tmp_path, signum):
    import serial

    lines = uno_stream(100.0)
    uno = Board(lines, 100.0)
    proc = start_live(tmp_path, uno)
    try:
        page_url(proc)
        while uno.sent < 100 and proc.poll() is None:
            time.sleep(0.05)
        with pytest.raises(serial.SerialException):  # held exclusively while it records
            serial.Serial(uno.name, 115200, exclusive=True)
        os.kill(proc.pid, signum)
        stdout, stderr = proc.communicate(timeout=60)
        with serial.Serial(uno.name, 115200, exclusive=True, timeout=0.1):  # released
            pass
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        uno.close()
    assert proc.returncode == 128 + signum, (proc.returncode, stderr)
    assert stderr.count("\n") == 1 and stderr.startswith("hpddo live: stopped by "), stderr
    assert not (tmp_path / "live.csv").exists() and (tmp_path / "live.csv.partial").is_file()


@pytest.mark.slow
@pytest.mark.realtime
def test_a_page_that_holds_its_process_does_not_stop_the_recording_and_the_partial_keeps_up(tmp_path):
    """The page's session build made to spin 4 s holding its interpreter (reports/live.py's
    BUSY_ENV hook: a page built on a busy machine; with the reader in the same process its
    byte-at-a-time reads then waited for the lock, and rows stopped for about 4 s). Meanwhile
    the rows keep arriving in OUT.partial, which is at most FLUSH_S (plus a margin) behind the
    lines the tool has read in 95 % of samples and never a second behind (the board's lines less those still
    unread in the pseudo-terminal, FIONREAD)."""
    import fcntl
    import termios
    import urllib.request

    from hpddo.cli import capture

    lines = uno_stream(100.0)  # 660 rows, 6.6 s
    ends = list(itertools.accumulate(len(ln) + 1 for ln in lines))  # byte offset after each line
    uno = Board(lines, 100.0)
    os.environ[live_page.BUSY_ENV] = "4"
    try:
        proc = start_live(tmp_path, uno)
    finally:
        del os.environ[live_page.BUSY_ENV]
    partial = tmp_path / "live.csv.partial"
    samples = []  # (time, whole lines the tool has read, lines in OUT.partial)
    with session(proc, uno):
        url = page_url(proc)
        while uno.sent < 100 and proc.poll() is None:
            time.sleep(0.01)
        opened = {}

        def browse():  # the page's request: its session is built (and spins) before the reply
            t0 = time.monotonic()
            with urllib.request.urlopen(url, timeout=60) as r:
                r.read()
            opened["s"] = (t0, time.monotonic())

        viewer = threading.Thread(target=browse, daemon=True)
        viewer.start()
        while uno.elapsed_s is None and proc.poll() is None:
            sent = uno.sent
            unread = struct.unpack("i", fcntl.ioctl(uno.slave, termios.FIONREAD, b"\0" * 4))[0]
            read = bisect.bisect_right(ends, (ends[sent - 1] if sent else 0) - unread)
            try:
                samples.append((time.monotonic(), read, partial.read_bytes().count(b"\n")))
            except FileNotFoundError:
                pass
            time.sleep(0.01)
        viewer.join(60)
        stdout, stderr = finish(proc, uno)
    assert proc.returncode == 0, stderr
    n_rows = len(lines) - sum(ln.startswith("#") for ln in lines) - 1
    assert f"{n_rows} rows, 0 seq gaps, 0 samples lost" in stdout, stdout
    t0, t1 = opened["s"]
    assert t1 - t0 >= 4.0, (t0, t1)  # the page did spin
    during = [n for t, _, n in samples if t0 + 0.5 <= t <= t0 + 3.5]
    assert during[-1] - during[0] >= 250, (during[0], during[-1])  # 3 s of rows at 100 rows/s, recorded meanwhile
    # at each sample, how long ago the tool had read the oldest line not yet in OUT.partial
    lag, board_lag = [], []
    for t, _, n in samples:
        first = next((s for s, r, _ in samples if r > n), None)
        if first is not None and first <= t:
            lag.append(t - first)
        if n < len(uno.sent_at) and uno.sent_at[n] <= t:
            board_lag.append(t - uno.sent_at[n])
    lag, board_lag = sorted(lag) or [0.0], sorted(board_lag) or [0.0]
    print(f"OUT.partial behind the lines read: at most {lag[-1] * 1000:.0f} ms, 95th percentile "
          f"{lag[int(0.95 * (len(lag) - 1))] * 1000:.0f} ms, median "
          f"{lag[len(lag) // 2] * 1000:.0f} ms over {len(samples)} samples; behind the board's writes at most "
          f"{board_lag[-1] * 1000:.0f} ms (median {board_lag[len(board_lag) // 2] * 1000:.0f}); the page's "
          f"request took {t1 - t0:.1f} s; load average {os.getloadavg()[0]:.1f}")
    # The fault this guards is a stop of seconds (the page's 4 s spin). On a shared machine the
    # tool's process can wait for a core for a few tenths of a second, which is the scheduler's,
    # not the tool's: most samples must be within FLUSH_S plus a margin, none behind by a second.
    p95 = lag[int(0.95 * (len(lag) - 1))]
    assert p95 <= capture.FLUSH_S + 0.1, f"OUT.partial was {p95:.3f} s behind the lines read in 5 % of samples"
    assert lag[-1] < 1.0, f"OUT.partial fell {lag[-1]:.3f} s behind the lines read"


def test_esp_lines_join_rows_on_the_low_16_bits_of_seq_in_either_order():
    from hpddo.reports.live import Feed

    class Cap:
        columns = ["t_s", "duty", "v_V", "i_A", "rpm_ref", "temp_C", "load", "seq", "rpm_est", "est_status"]
        rows = lost = 0
        garbled = []

    feed = Feed()
    feed.add_esp(esp_line(65536 + 7, 100.0))  # before its row: waits
    feed.add_row("0.070000,0.5,9,0.8,100.00,,0,65543,105.00,0", Cap)
    feed.add_row("0.080000,0.5,9,0.8,101.00,,0,65544,106.00,2", Cap)
    feed.add_esp(esp_line(65544, 101.0))  # after its row
    invalid = json.loads(esp_line(65545, 0.0))
    invalid.update(rpm=None, residual=None, status="invalid")  # a non-finite number is written null
    feed.add_esp(json.dumps(invalid))
    assert not feed.add_esp('{"event":"ready","model":"compiled"}')
    assert not feed.add_esp('{"event":"ready","model_crc_ok":true,"model":"compiled","model_crc":1,"fs":"unmounted"}')
    assert not feed.add_esp('{"event":"tx_dropped","lines":3}')
    assert not feed.add_esp("{garbled") and feed.esp_bad == 1
    uno, esp, counts = feed.take(0, 0)
    assert uno["t_s"] == [0.07, 0.08] and uno["est_status"] == [0.0, 2.0] and uno["error"] == [5.0, 5.0]
    assert esp["t_s"] == [0.07, 0.08] and esp["status"] == [0.0, 0.0] and counts["esp_joined"] == 2
    assert counts["esp_lines"] == 3  # the null line is telemetry, waiting for its row
    assert counts["esp_fs"] == "unmounted" and counts["esp_tx_dropped"] == 3 and counts["esp_bad"] == 1
    assert feed.take(2, 2)[:2] == (None, None)


# ---------------------------------------------------------------- the figure of docs/live.md

def measure(rate_hz: float, repeat: int, tmp_path: pathlib.Path, page: bool = True) -> dict:
    """Runs hpddo live on `repeat` sweeps at rate_hz, with the page open in headless Chromium the
    whole time (page); the rows recorded and how late the board's writes fell behind their
    schedule (a pseudo-terminal blocks the writer when the reader lags; a UART would drop)."""
    from hpddo.reports import browser

    lines = uno_stream(rate_hz, repeat=repeat)
    n_rows = len(lines) - sum(ln.startswith("#") for ln in lines) - 1
    uno = Board(lines, rate_hz)
    proc = start_live(tmp_path, uno, out_name=f"live_{rate_hz:g}.csv")
    seen = {}
    with session(proc, uno):
        url = page_url(proc)
        viewer = threading.Thread(target=lambda: seen.update(browser.live(
            url, tmp_path / "page.png", 2.0 + n_rows / rate_hz, {"uno": "Bokeh.documents[0].get_model_by_name("
                                                                 "'uno').get_length()"}, ready=PAGE_READY)),
                                  daemon=True)
        if page:
            viewer.start()
        while uno.elapsed_s is None and proc.poll() is None:
            time.sleep(0.05)
        if page:
            viewer.join(120)
        stdout, stderr = finish(proc, uno, timeout=120)
    m = re.search(r": (\d+) rows, (\d+) seq gaps, (\d+) samples lost", stdout)
    return {"rate_hz": rate_hz, "rows_sent": n_rows, "rows_recorded": int(m.group(1)) if m else None,
            "lost": int(m.group(3)) if m else None, "achieved_rows_per_s": round(n_rows / uno.elapsed_s, 1),
            "max_late_s": round(uno.late_s, 3), "status": proc.returncode,
            "page_points": seen.get("values", {}).get("uno"), "page_errors": seen.get("console_errors")}


if __name__ == "__main__":
    import tempfile

    ap = argparse.ArgumentParser(description="rows/s hpddo live records without loss over a pseudo-terminal")
    ap.add_argument("--measure", type=float, nargs="+", required=True, metavar="HZ")
    ap.add_argument("--repeat", type=int, default=2, help="sweeps of 660 rows each (default 2)")
    ap.add_argument("--no-page", action="store_true", help="no browser on the page meanwhile")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for hz in args.measure:
            print(json.dumps(measure(hz, args.repeat, pathlib.Path(tmp), page=not args.no_page)), flush=True)


def test_the_browsers_profile_is_removed_while_its_helpers_still_write_into_it(tmp_path):
    """browser.live's Chromium profile: its helper processes can write into it after the browser
    has exited (tempfile's one-shot removal then raised "Directory not empty" out of
    browser.live, failing a test whose page was fine; seen once under load): remove_profile
    never raises, and tries again until the folder is gone."""
    from hpddo.reports import browser

    profile = tmp_path / "profile"
    (profile / "Default").mkdir(parents=True)
    stop = threading.Event()

    def helper():  # a late writer: new files in Default for 0.5 s
        k = 0
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            try:
                (profile / "Default").mkdir(parents=True, exist_ok=True)
                (profile / "Default" / f"f{k}").write_bytes(b"x" * 4096)
            except OSError:
                pass
            k += 1
        stop.set()

    writer = threading.Thread(target=helper)
    writer.start()
    browser.remove_profile(profile)
    writer.join()
    browser.remove_profile(profile)  # once the writer has stopped: gone at the first try
    assert stop.is_set() and not profile.exists()
