"""Shows the bench live in a browser page while recording it (docs/live.md).

    hpddo live --port /dev/ttyACM0 --run sweep --out data/my/sweep.csv
    hpddo live --port /dev/ttyACM0 --esp-port /dev/ttyUSB0 --rec warmup --out warmup.csv

The recording is hpddo capture's, with the same format, checks and guarantees (the same
code: OUT.partial while it runs, OUT written atomically at the end, nothing under OUT when
it fails or is stopped; the same exit status). The page, at the URL printed first, shows
from the UNO's rows the estimate (rpm_est, the observer the UNO runs) against the encoder
(rpm_ref), their difference and est_status; with --esp-port, also the ESP8266's telemetry
(rpm, rpm_m2, the network's residual, confidence, status), joined to the rows on the low
16 bits of seq. The ESP8266's lines are shown, not recorded: they have no t_s or duty.

The page runs in a process of its own, fed through a pipe: the serial readers here never wait
for it (hpddo.reports.live.Server). The page listens on 127.0.0.1 only; --open-to-network listens on every address (a warning
says so: anyone who reaches this machine sees the page). Both serial ports are opened
exclusively and closed on every way out; the page ends with the recording.
"""
from __future__ import annotations

import argparse
import sys
import threading

from ..reports import live as page
from . import capture, options

#: The ESP8266's telemetry baud rate (esp_infer, docs/esp8266.md).
ESP_BAUD = 460800
LOCAL = "127.0.0.1"
EVERY_ADDRESS = "0.0.0.0"


def parser(prog: str = "hpddo live") -> argparse.ArgumentParser:
    """The command line options: capture's, and the page's."""
    p = options.new_parser(prog, __doc__)
    capture.recording_options(p)
    p.add_argument("--esp-port", metavar="PORT",
                   help="serial port of the ESP8266 (opened exclusively, DTR/RTS held off): its telemetry "
                        "joins the page on seq")
    p.add_argument("--esp-baud", type=options.positive_int, default=ESP_BAUD, metavar="BAUD",
                   help=f"baud rate of the ESP8266's port (default {ESP_BAUD})")
    p.add_argument("--http-port", type=options.non_negative_int, default=5006, metavar="N",
                   help="TCP port of the page (default 5006; 0: any free port, the URL printed says which)")
    p.add_argument("--open-to-network", action="store_true",
                   help="listen on every address, not only 127.0.0.1: anyone who reaches this machine sees "
                        "the page (no password); a warning says so")
    return p


class EspReader:
    """Reads the ESP8266's telemetry into the feed in a thread until stop()."""

    def __init__(self, port, name: str, feed: page.Server):
        self.port, self.name, self.feed = port, name, feed
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="hpddo-live-esp", daemon=True)

    def _run(self):
        pending = b""
        first = True  # opening the port discards what it held: the first line may be a line's tail
        while not self._stop.is_set():
            try:
                raw = self.port.readline()
            except capture.PORT_ERRORS as exc:
                if not self._stop.is_set():
                    print(f"hpddo live: WARNING: lost the ESP8266's port {self.name}: {exc}; the recording "
                          f"goes on without its telemetry", file=sys.stderr)
                return
            if raw and not raw.endswith(b"\n"):
                pending += raw  # a read timeout cut the line
                continue
            line, pending = (pending + raw).decode("utf-8", errors="replace").strip(), b""
            if first and line:
                first = False
                if not line.startswith("{"):
                    continue  # the tail of a line cut by the opening: not the board's garbage
            if line:
                self.feed.add_esp(line)

    def start(self):
        self._thread.start()

    def stop(self):
        self._stop.set()
        self._thread.join(2.0)


def run(a: argparse.Namespace) -> int:
    """Starts the page, reads the ESP8266 if asked, records the UNO; the exit status is capture's."""
    address = EVERY_ADDRESS if a.open_to_network else LOCAL
    esp_port = esp = server = None
    try:
        if a.esp_port:
            esp_port = capture.open_port(a.esp_port, a.esp_baud, timeout=0.2, hold_reset=True)
        title = f"hpddo live: {a.port}" + (f" + {a.esp_port}" if a.esp_port else "") + f" -> {a.out}"
        server = page.Server(address, a.http_port, title, with_esp=bool(a.esp_port))
        try:
            http_port = server.start()
        except OSError as exc:
            raise capture.CaptureError(f"cannot serve the page on {address}:{a.http_port}: {exc}; nothing "
                                       f"recorded") from None
        also = f", and from the network at http://<this machine's address>:{http_port}/" if a.open_to_network else ""
        print(f"hpddo live: the page is at http://{LOCAL}:{http_port}/{also} (recording to {a.out})", flush=True)
        if a.open_to_network:
            print(f"hpddo live: WARNING: the page listens on every address ({EVERY_ADDRESS}:{http_port}), open "
                  f"to the network: anyone who reaches this machine sees the bench's data (no password)",
                  file=sys.stderr, flush=True)
        if esp_port is not None:
            esp = EspReader(esp_port, a.esp_port, server)
            esp.start()
        return capture.record(a, on_row=server.add_row, prog="hpddo live")
    except KeyboardInterrupt as exc:  # before the recording started (record reports its own)
        print(f"hpddo live: {'stopped by ' + exc.args[0] if getattr(exc, 'status', None) else 'interrupted'} "
              f"before recording started on {a.port}: nothing written to {a.out}", file=sys.stderr)
        return getattr(exc, "status", capture.EXIT_INTERRUPTED)
    finally:
        if esp is not None:
            esp.stop()
        if esp_port is not None:
            try:
                esp_port.close()
            except capture.PORT_ERRORS:
                pass
        if server is not None:
            server.stop()


def main(argv=None) -> int:
    """`hpddo live ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("live", argv)
