#!/usr/bin/env python3
"""Records the acquisition board's USB stream to a bench log.

    python tools/capture.py --port /dev/ttyACM0 --run sweep -o data/my/sweep.csv
    python tools/capture.py --port /dev/ttyACM0 --rec warmup --rows 600 -o warmup.csv

The board writes metadata, the header and one row per sample; lines that start
with "!" are its replies and are shown, not logged. The capture is written to
a temporary file next to the output and renamed only when it is complete (the
protocol's "! end" line, --rows or --seconds reached), so an interrupted
capture never leaves a file that looks whole: it stays as <output>.partial.
Lost samples are reported from gaps in the seq column.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

try:
    from tqdm import tqdm
except ImportError:  # pragma: no cover
    tqdm = None


class CaptureError(RuntimeError):
    pass


class Capture:
    """State of one recording: the lines kept and the seq bookkeeping."""

    def __init__(self):
        self.meta: list[str] = []
        self.header: str | None = None
        self.rows = 0
        self.last_seq: int | None = None
        self.gaps: list[tuple[int, int]] = []  # (after seq, lost samples)
        self.ended = False
        self.replies: list[str] = []
        self.seq_col: int | None = None

    def feed(self, line: str) -> str | None:
        """Takes one line; returns the text to write to the log, or None."""
        line = line.rstrip("\r\n")
        if not line:
            return None
        if line.startswith("!"):
            self.replies.append(line)
            if line.startswith("! end"):
                self.ended = True
            return None
        if line.startswith("#"):
            if self.header is not None:  # a new recording started: keep the first one only
                raise CaptureError("a second recording started before the first one ended")
            self.meta.append(line)
            return line
        if self.header is None:
            if not self.meta:
                return None  # rows of a recording whose start we missed
            self.header = line
            cols = line.split(",")
            self.seq_col = cols.index("seq") if "seq" in cols else None
            return line
        if self.seq_col is not None:
            try:
                seq = int(line.split(",")[self.seq_col])
            except (IndexError, ValueError):
                raise CaptureError(f"malformed row: {line!r}") from None
            if self.last_seq is not None and seq != self.last_seq + 1:
                self.gaps.append((self.last_seq, seq - self.last_seq - 1))
            self.last_seq = seq
        self.rows += 1
        return line

    @property
    def lost(self) -> int:
        return sum(n for _, n in self.gaps if n > 0)


def capture(port, out: pathlib.Path, command: str | None = None, rows: int | None = None,
            seconds: float | None = None, progress: bool = True, log=print) -> Capture:
    """Reads lines from an open serial port (anything with write() and readline())
    into out. Raises KeyboardInterrupt/CaptureError unchanged after keeping the
    partial file; returns the Capture on success."""
    out = pathlib.Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.name + ".partial")
    cap = Capture()
    if command:
        port.write((command + "\n").encode())
    start = time.monotonic()
    bar = tqdm(total=rows, unit="row", disable=not progress) if tqdm else None
    try:
        with open(partial, "w", encoding="utf-8", newline="\n") as f:
            while True:
                raw = port.readline()
                if not raw:
                    if seconds is not None and time.monotonic() - start >= seconds:
                        break
                    continue
                text = raw.decode("utf-8", errors="replace")
                kept = cap.feed(text)
                if kept is not None:
                    f.write(kept + "\n")
                    if cap.header is not None and not kept.startswith("#") and kept != cap.header:
                        if bar is not None:
                            bar.update(1)
                            if cap.gaps:
                                bar.set_postfix(lost=cap.lost)
                elif text.startswith("!"):
                    log(text.rstrip())
                if cap.ended or (rows is not None and cap.rows >= rows):
                    break
                if seconds is not None and time.monotonic() - start >= seconds:
                    break
            f.flush()
            os.fsync(f.fileno())
    finally:
        if bar is not None:
            bar.close()
    if cap.header is None or cap.rows == 0:
        raise CaptureError(f"no rows recorded; partial capture kept in {partial}")
    os.replace(partial, out)
    return cap


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--port", required=True, help="serial port of the UNO, e.g. /dev/ttyACM0 or COM3")
    ap.add_argument("--baud", type=int, default=115200)
    ap.add_argument("-o", "--output", required=True, type=pathlib.Path, help="bench log to write")
    what = ap.add_mutually_exclusive_group()
    what.add_argument("--run", choices=["sweep", "load", "long"], help="start this protocol and record it")
    what.add_argument("--rec", metavar="CONDITION", help="start a recording by hand with this condition")
    ap.add_argument("--rate", type=float, help="set the sample rate first (Hz)")
    ap.add_argument("--hold", type=float, help="set the protocol step length first (s)")
    ap.add_argument("--rows", type=int, help="stop after this many rows")
    ap.add_argument("--seconds", type=float, help="stop after this many seconds")
    ap.add_argument("--no-progress", action="store_true")
    a = ap.parse_args(argv)
    import serial  # pyserial

    with serial.Serial(a.port, a.baud, timeout=1.0) as port:
        time.sleep(2.0)  # the UNO resets when the port opens
        port.reset_input_buffer()
        for cmd, val in (("rate", a.rate), ("hold", a.hold)):
            if val is not None:
                port.write(f"{cmd} {val:g}\n".encode())
                print(port.readline().decode(errors="replace").rstrip())
        command = f"run {a.run}" if a.run else f"rec {a.rec}" if a.rec else None
        try:
            cap = capture(port, a.output, command, a.rows, a.seconds, progress=not a.no_progress)
        except KeyboardInterrupt:
            port.write(b"stop\n")
            print(f"interrupted: nothing written to {a.output}; partial rows in {a.output}.partial",
                  file=sys.stderr)
            return 130
        except CaptureError as e:
            print(f"capture failed: {e}", file=sys.stderr)
            return 1
        if not cap.ended:
            port.write(b"stop\n")
    print(f"{a.output}: {cap.rows} rows, {len(cap.gaps)} seq gaps, {cap.lost} samples lost")
    for after, n in cap.gaps:
        print(f"  gap after seq {after}: {n} lost")
    return 0


if __name__ == "__main__":
    sys.exit(main())
