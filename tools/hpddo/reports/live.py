"""The live view's page: a Bokeh server application (hpddo live, docs/live.md).

`Feed` holds what the page shows, filled from two threads: the UNO's bench log rows
(`add_row`, the recording's reader: t_s, the encoder's rpm_ref, the UNO's own estimate
rpm_est and est_status) and, optionally, the ESP8266's telemetry lines (`add_esp`), joined
to the rows on the low 16 bits of seq (the link frame's seq). `Server` runs the page (`serve`:
the Bokeh server and the Feed) in a process of its own, fed through a pipe by the recording's
process, which never waits for it; each browser session polls the feed and streams the new points
into its plots. Nothing here writes a file: the recording is hpddo.cli.capture's.
"""
from __future__ import annotations

import collections
import html
import json
import math
import pathlib
import socket
import threading
import time

#: points kept per series (and shown): 60 s at 100 samples/s
KEEP = 6000
#: how often a page takes the new points (ms)
POLL_MS = 200
#: the observer's status numbers (hpddo/observer.h Status) and the telemetry's names of them
STATUS_NAMES = {0: "ok", 1: "clamped", 2: "fallback", 3: "invalid", 4: "gated"}
STATUS_NUMBERS = {v: k for k, v in STATUS_NAMES.items()}
#: ESP8266 lines waiting for their UNO row, and UNO rows' seq remembered for late ESP lines
JOIN_WINDOW = 4096

UNO_COLUMNS = ("n", "t_s", "rpm_ref", "rpm_est", "error", "est_status")
ESP_COLUMNS = ("n", "t_s", "rpm", "rpm_m2", "residual", "confidence", "status")


def _number(text: str | None) -> float:
    """A CSV cell as a float; an empty or absent cell is NaN (a gap in the plot)."""
    if text is None or text.strip() == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        return math.nan


class Feed:
    """The points to show, appended by the readers and taken by the pages; thread-safe."""

    def __init__(self, keep: int = KEEP):
        self._lock = threading.Lock()
        self._uno = collections.deque(maxlen=keep)
        self._esp = collections.deque(maxlen=keep)
        self.n_uno = 0  # points ever appended (a page's cursor counts in these)
        self.n_esp = 0
        self._t_of_seq16 = collections.OrderedDict()  # seq & 0xFFFF -> t_s of a recent UNO row
        self._esp_waiting = collections.OrderedDict()  # seq16 -> telemetry that came before its row
        self.esp_lines = 0  # telemetry lines read
        self.esp_joined = 0
        self.esp_bad = 0  # lines that are not telemetry JSON (events excluded)
        self.esp_fs = None  # the board's file system as its ready line says: "mounted", "unmounted"
        self.esp_tx_dropped = 0  # lines the board dropped for a full USB ring (its tx_dropped events)
        self.rows = 0
        self.lost = 0
        self.garbled = 0
        self.columns: list[str] = []

    # ------------------------------------------------------------------ the readers
    def add_row(self, line: str, cap) -> None:
        """One data row of the recording as capture wrote it (capture's on_row hook)."""
        cells = dict(zip(cap.columns, line.split(",")))
        t = _number(cells.get("t_s"))
        ref, est = _number(cells.get("rpm_ref")), _number(cells.get("rpm_est"))
        point = (t, ref, est, est - ref, _number(cells.get("est_status")))
        seq = cells.get("seq")
        with self._lock:
            self.rows, self.lost, self.garbled, self.columns = cap.rows, cap.lost, len(cap.garbled), cap.columns
            self._uno.append((self.n_uno, *point))
            self.n_uno += 1
            if seq is not None and seq.strip().isdigit():
                s16 = int(seq) & 0xFFFF
                self._t_of_seq16[s16] = t
                self._t_of_seq16.move_to_end(s16)
                if len(self._t_of_seq16) > JOIN_WINDOW:
                    self._t_of_seq16.popitem(last=False)
                early = self._esp_waiting.pop(s16, None)
                if early is not None:
                    self._join(t, early)

    def add_esp(self, line: str) -> bool:
        """One line from the ESP8266; True when it was a telemetry line (an event or a reply is skipped)."""
        try:
            obj = json.loads(line)
        except ValueError:
            with self._lock:
                self.esp_bad += 1
            return False
        if isinstance(obj, dict) and obj.get("event") in ("ready", "tx_dropped"):
            with self._lock:
                if obj["event"] == "ready" and isinstance(obj.get("fs"), str):
                    self.esp_fs = obj["fs"]
                elif isinstance(obj.get("lines"), int):
                    self.esp_tx_dropped = obj["lines"]
            return False
        if not isinstance(obj, dict) or "event" in obj:
            return False
        try:
            s16 = int(obj["seq"]) & 0xFFFF
            values = tuple(math.nan if obj[k] is None else float(obj[k])  # null: a non-finite number
                           for k in ("rpm", "rpm_m2", "residual", "confidence"))
            values += (float(STATUS_NUMBERS.get(obj["status"], math.nan)),)
        except (KeyError, TypeError, ValueError):
            with self._lock:
                self.esp_bad += 1
            return False
        with self._lock:
            self.esp_lines += 1
            t = self._t_of_seq16.get(s16)
            if t is None:  # its row has not arrived yet
                self._esp_waiting[s16] = values
                if len(self._esp_waiting) > JOIN_WINDOW:
                    self._esp_waiting.popitem(last=False)
            else:
                self._join(t, values)
        return True

    def _join(self, t: float, values: tuple) -> None:
        self._esp.append((self.n_esp, t, *values))
        self.n_esp += 1
        self.esp_joined += 1

    # ------------------------------------------------------------------ the pages
    def take(self, uno_from: int, esp_from: int):
        """The points appended since the cursors (older ones that rolled out are skipped), as
        column dicts, with the counters for the page's status line."""
        with self._lock:
            uno = [p for p in self._uno if p[0] >= uno_from]
            esp = [p for p in self._esp if p[0] >= esp_from]
            counts = dict(rows=self.rows, lost=self.lost, garbled=self.garbled, esp_lines=self.esp_lines,
                          esp_joined=self.esp_joined, esp_bad=self.esp_bad, n_uno=self.n_uno, n_esp=self.n_esp,
                          esp_fs=self.esp_fs, esp_tx_dropped=self.esp_tx_dropped)
        return (dict(zip(UNO_COLUMNS, map(list, zip(*uno)))) if uno else None,
                dict(zip(ESP_COLUMNS, map(list, zip(*esp)))) if esp else None, counts)


def make_document(feed: Feed, title: str, with_esp: bool):
    """Returns the function that builds one browser session's document."""
    def build(doc):
        import os

        import numpy as np

        busy_until = time.monotonic() + float(os.environ.get(BUSY_ENV) or 0)
        while time.monotonic() < busy_until:  # the test hook (BUSY_ENV): spins, holding the lock
            pass
        from bokeh.layouts import column
        from bokeh.models import ColumnDataSource, Div, FixedTicker, Legend
        from bokeh.plotting import figure

        uno = ColumnDataSource({c: [] for c in UNO_COLUMNS}, name="uno")
        esp = ColumnDataSource({c: [] for c in ESP_COLUMNS}, name="esp")
        shown = html.escape(title)  # a Div's text is HTML: the ports' and the file's names escaped
        head = Div(text=f"<b>{shown}</b>: waiting for the first row", name="counts")

        def fig(name, y_label, height=260, **kw):
            f = figure(name=name, height=height, sizing_mode="stretch_width", x_axis_label="t_s (s)",
                       y_axis_label=y_label, tools="pan,xwheel_zoom,box_zoom,reset,save", **kw)
            f.add_layout(Legend(), "right")
            return f

        speed = fig("speed", "speed (RPM)")
        speed.line("t_s", "rpm_ref", source=uno, color="#000000", line_width=2, legend_label="encoder (rpm_ref)")
        speed.line("t_s", "rpm_est", source=uno, color="#1f77b4", line_width=2, legend_label="UNO estimate (rpm_est)")
        error = fig("error", "RPM", x_range=speed.x_range)
        error.line("t_s", "error", source=uno, color="#1f77b4", legend_label="UNO estimate - encoder")
        status = fig("status", "status", height=180, x_range=speed.x_range, y_range=(-0.5, 4.5))
        status.scatter("t_s", "est_status", source=uno, color="#1f77b4", size=4, legend_label="UNO est_status")
        status.yaxis.ticker = FixedTicker(ticks=list(STATUS_NAMES))
        status.yaxis.major_label_overrides = {k: v for k, v in STATUS_NAMES.items()}
        if with_esp:
            confidence = fig("confidence", "confidence", height=180, x_range=speed.x_range, y_range=(-0.05, 1.05))
            speed.line("t_s", "rpm", source=esp, color="#ff7f0e", line_width=2, legend_label="ESP8266 estimate (rpm)")
            speed.line("t_s", "rpm_m2", source=esp, color="#2ca02c", legend_label="ESP8266 physics (rpm_m2)")
            error.line("t_s", "residual", source=esp, color="#ff7f0e", legend_label="ESP8266 residual (network)")
            status.scatter("t_s", "status", source=esp, color="#ff7f0e", size=4, marker="x",
                           legend_label="ESP8266 status")
            confidence.line("t_s", "confidence", source=esp, color="#ff7f0e", legend_label="ESP8266 confidence")
        else:
            confidence = Div(text="The ESP8266's estimate, residual, status and confidence: hpddo live --esp-port PORT")
        cursor = {"uno": 0, "esp": 0}

        def poll():
            new_uno, new_esp, c = feed.take(cursor["uno"], cursor["esp"])
            if new_uno:
                cursor["uno"] = new_uno["n"][-1] + 1
                uno.stream({k: np.asarray(v, dtype=float) for k, v in new_uno.items()}, rollover=KEEP)
            if new_esp:
                cursor["esp"] = new_esp["n"][-1] + 1
                esp.stream({k: np.asarray(v, dtype=float) for k, v in new_esp.items()}, rollover=KEEP)
            esp_text = (f"; ESP8266: {c['esp_lines']} lines, {c['esp_joined']} joined on seq, "
                        f"{c['esp_bad']} not telemetry"
                        + (f", {c['esp_tx_dropped']} dropped by the board (its USB line full)"
                           if c["esp_tx_dropped"] else "")
                        + (", its file system did not mount (compiled model)" if c["esp_fs"] == "unmounted"
                           else "")) if with_esp else ""
            head.text = (f"<b>{shown}</b>: {c['rows']} rows recorded, {c['lost']} samples lost, "
                         f"{c['garbled']} garbled{esp_text}")

        doc.title = title
        doc.add_root(column(head, speed, error, status, confidence, sizing_mode="stretch_width"))
        doc.add_periodic_callback(poll, POLL_MS)
    return build


#: what the recording side keeps for a page that does not take it (about 4 minutes at 100 rows/s):
#: older points are dropped for the page, never for the recording
FORWARD_KEEP = 24000
#: how often the recording side hands the page its new points (s)
FORWARD_S = 0.05
#: a test hook: each browser session's document spins this long first (s), holding its
#: process's interpreter lock, as a page being built on a busy machine does
BUSY_ENV = "HPDDO_LIVE_PAGE_BUSY_S"


class Server:
    """The page in a process of its own (`python -m hpddo.reports.live`), so that nothing the
    page does (Bokeh building a session, serialising a document, a slow browser) ever holds the
    recording's interpreter: the serial reader stays in the calling process and hands each row
    and ESP8266 line to add_row/add_esp, which only append to a bounded queue; a thread of ours
    writes the queue to the page's stdin. A page that falls behind loses old points (counted in
    `dropped`), never the recording. stop() ends the page; so does the end of the caller."""

    def __init__(self, address: str, port: int, title: str, with_esp: bool):
        self._args = {"address": address, "port": port, "title": title, "with_esp": with_esp}
        self._queue = collections.deque()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._proc = None
        self._thread = threading.Thread(target=self._forward, name="hpddo-live-forward", daemon=True)
        self.port = None
        self.dropped = 0  # messages the page never got: it fell FORWARD_KEEP behind

    def start(self, timeout: float = 60.0) -> int:
        """Starts the page's process; returns its port, or raises OSError when it cannot listen."""
        import os
        import select
        import subprocess
        import sys

        env = dict(os.environ)
        tools = str(pathlib.Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = tools + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        # its own session: a Ctrl-C at the terminal reaches the recording, which then ends the page
        self._proc = subprocess.Popen([sys.executable, "-m", "hpddo.reports.live", json.dumps(self._args)],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env,
                                      start_new_session=True)
        ready = select.select([self._proc.stdout], [], [], timeout)[0]
        line = self._proc.stdout.readline().decode(errors="replace").strip() if ready else ""
        if not line.startswith("listening "):
            self.stop()
            raise OSError(line[len("error "):] if line.startswith("error ") else "the page's server did not start")
        self.port = int(line.split()[1])
        self._thread.start()
        return self.port

    # ------------------------------------------------------------------ the recording's side
    def _put(self, message: list) -> None:
        if len(self._queue) >= FORWARD_KEEP:
            self._queue.popleft()
            self.dropped += 1
        self._queue.append(message)

    def add_row(self, line: str, cap) -> None:
        """capture's on_row hook: never waits (the page's process takes it when it can)."""
        self._put(["row", line, cap.columns, cap.rows, cap.lost, len(cap.garbled)])

    def add_esp(self, line: str) -> None:
        self._put(["esp", line])

    def _forward(self):
        while not self._stop.is_set():
            self._wake.wait(FORWARD_S)
            batch = []
            while self._queue:
                batch.append(json.dumps(self._queue.popleft(), separators=(",", ":")))
            if not batch:
                continue
            try:
                self._proc.stdin.write(("\n".join(batch) + "\n").encode())
                self._proc.stdin.flush()
            except (OSError, ValueError):  # the page's process has gone: the recording goes on
                return

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(5.0)
        if self._proc is not None:
            try:
                self._proc.stdin.close()  # the page ends at the end of its input
            except OSError:
                pass
            try:
                self._proc.wait(10.0)
            except Exception:  # noqa: BLE001 (subprocess.TimeoutExpired): it did not end by itself
                self._proc.kill()
                self._proc.wait()
            self._proc.stdout.close()


class _Counts:
    """A capture's counters as the recording's side sent them (Feed.add_row reads these)."""

    def __init__(self, columns, rows, lost, garbled):
        self.columns, self.rows, self.lost, self.garbled = columns, rows, lost, range(garbled)


def serve(address: str, port: int, title: str, with_esp: bool) -> int:
    """The page's process: a Bokeh server on (address, port) over a Feed filled from stdin (the
    recording's messages, one JSON array a line) until stdin ends; prints "listening PORT" or
    "error WHY" first. Exit status 0, or 1 when it could not listen."""
    import asyncio
    import logging
    import os
    import signal
    import sys

    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server as BokehServer
    from tornado.ioloop import IOLoop

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the recording decides when the page ends
    for name in ("bokeh", "tornado"):  # a browser closing its page is no news: the tool's own lines only
        logging.getLogger(name).setLevel(logging.ERROR)
    asyncio.set_event_loop(asyncio.new_event_loop())
    feed = Feed()
    try:
        if port == 0:  # a free port, known before the server starts (its websocket origins name it)
            with socket.socket() as s:
                s.bind((address, 0))
                port = s.getsockname()[1]
        app = Application(FunctionHandler(make_document(feed, title, with_esp)))
        # a page open to the network is reached by any host name; on 127.0.0.1 only by the local ones
        origins = ["*"] if address != "127.0.0.1" else [f"127.0.0.1:{port}", f"localhost:{port}"]
        server = BokehServer({"/": app}, io_loop=IOLoop.current(), address=address, port=port,
                             allow_websocket_origin=origins)
        server.start()
    except BaseException as exc:  # the port is taken, an address that is not ours
        print(f"error {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", flush=True)
        return 1
    loop = server.io_loop

    def read_input():
        for raw in sys.stdin.buffer:
            try:
                msg = json.loads(raw)
                if msg[0] == "row":
                    feed.add_row(msg[1], _Counts(*msg[2:]))
                elif msg[0] == "esp":
                    feed.add_esp(msg[1])
            except (ValueError, IndexError, TypeError):
                continue
        loop.add_callback(loop.stop)  # the recording has ended

    print(f"listening {server.port}", flush=True)
    threading.Thread(target=read_input, name="hpddo-live-input", daemon=True).start()
    loop.start()
    server.stop()
    os._exit(0)  # Bokeh's and tornado's threads need no goodbye


if __name__ == "__main__":
    import sys as _sys

    _a = json.loads(_sys.argv[1])
    _sys.exit(serve(_a["address"], _a["port"], _a["title"], _a["with_esp"]))
