"""Records the acquisition board's USB stream to a bench log.

    hpddo capture --port /dev/ttyACM0 --run sweep --out data/my/sweep.csv
    hpddo capture --port /dev/ttyACM0 --rec warmup --rows 600 --out warmup.csv
    (tools/capture.py is the same command; -o is short for --out)

The port is opened exclusively (no other program can open it meanwhile) and closed on
every way out. The board writes metadata, the header and one row per sample; lines that start
with "!" are its replies and are shown, not logged. Every line is checked as it
arrives (metadata form, field count, numbers, t_s increasing, duty in 0..1); a
garbled line is counted, reported with its stream line number and not written.

The rows go to OUT.partial as they arrive (flushed whenever the port has nothing more
waiting, and at least every 100 ms). At the end the log is written
to OUT atomically with the capture's own metadata first:
"# complete=true" when the board ended the recording ("! end") and no line was
garbled, else "# complete=false" with "# cut=--rows N" or "# cut=--seconds S"
when a limit stopped it; "# garbled_rows=N" always. A capture that fails
(port lost, disk full, Ctrl-C) writes nothing under OUT: the message
names the fault, the port or file, and OUT.partial, which keeps the rows
received so far for inspection.

The UNO's ripple build (uno_acq with -DACQ_RIPPLE_HZ, 500000 baud: --baud 500000) also sends
the current of each window in bursts, "~" lines of framed, CRC-checked chunks
(docs/ripple-board.md, "The UNO's ripple mode"). They are collected and, with the log, written to
OUT's <condition>.ripple.csv beside it (the file the twin writes, which `hpddo ripple` reads);
a burst that did not arrive whole is left out and counted, a damaged chunk line counted. The
build with coast probes (-DACQ_COAST=1, docs/ripple-board.md "Coast probes") sends them as chunks
of their own kind; they go to OUT's <condition>.coast.csv, which `hpddo ripple --coast` reads.

Exit status: 0 log written, 3 log written with garbled rows (complete=false),
1 capture failed (one line "hpddo capture: ...", nothing written to OUT), 130 interrupted.
Lost samples are reported from gaps in the seq column.
"""
from __future__ import annotations

import argparse
import errno
import os
import pathlib
import shutil
import sys
import time

from ..logs import benchlog, coast, ripple, ripple_link
from ..logs.errors import InputError
from . import options

try:
    from tqdm import tqdm
except ImportError:  # pragma: no cover
    tqdm = None

try:
    import serial  # pyserial
except ImportError:  # pragma: no cover
    serial = None

#: What a serial port raises when it fails (unplugged, I/O error); SerialException is an OSError.
PORT_ERRORS = (serial.SerialException, OSError) if serial is not None else (OSError,)

#: Seconds to wait after opening the port: the UNO resets when the port opens.
BOARD_RESET_S = 2.0

#: OUT.partial is at most this far behind the lines read (s): it is flushed when this long has
#: passed since the last flush, and whenever the port has nothing more waiting (the next read may wait).
FLUSH_S = 0.1

#: Garbled lines reported one by one; the rest are only counted.
MAX_GARBLED_SHOWN = 20

EXIT_OK, EXIT_FAILED, EXIT_GARBLED, EXIT_INTERRUPTED = 0, 1, 3, 130


class CaptureError(InputError):
    """A capture that produced no log; the message is one line naming the fault (one of
    hpddo.logs.errors.USER_ERRORS: reported as `hpddo capture: message`, exit status 1)."""


class PortError(CaptureError):
    """The serial port failed (unplugged, I/O error) during the capture."""


class OutputError(CaptureError):
    """A file of the capture could not be written (disk full, permissions)."""


def os_fault(exc: OSError) -> str:
    """The reason of an OSError as text with its errno name, e.g. 'No space left on device (ENOSPC)'."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    name = errno.errorcode.get(exc.errno) if exc.errno else None
    return f"{reason} ({name})" if name else reason


class Capture:
    """State of one recording: the lines kept, the garbled ones and the seq bookkeeping."""

    def __init__(self):
        self.meta: list[str] = []
        self.header: str | None = None
        self.columns: list[str] = []
        self.rows = 0
        self.last_seq: int | None = None
        self.last_t: float | None = None
        self.gaps: list[tuple[int, int]] = []  # (after seq, lost samples)
        self.garbled: list[tuple[int, str, str]] = []  # (stream line, fault, text)
        self.ended = False
        self.cut: str | None = None  # the limit that stopped the capture, e.g. "--rows 600"
        self.replies: list[str] = []
        self.seq_col: int | None = None
        self.line_no = 0  # lines received from the port, 1-based once one arrived
        self.ripple = ripple_link.Assembler()  # the ripple build's bursts ("~" lines)
        self.t_by_seq: dict[int, float] = {}  # t_s of each row by seq, for the bursts' times

    def feed(self, line: str) -> str | None:
        """Takes one line; returns the text to write to the log, or None (reply, garbled, not ours)."""
        self.line_no += 1
        line = line.rstrip("\r\n")
        if not line:
            return None
        if line.startswith(ripple_link.PREFIX):
            if self.header is not None:  # a chunk of the recording (none come before it)
                self.ripple.feed(line, self.line_no)
            return None
        if line.startswith("!"):
            self.replies.append(line)
            if line.startswith("! end"):
                self.ended = True
            return None
        if line.startswith("#"):
            if self.header is not None:  # a new recording started: keep the first one only
                raise CaptureError("a second recording started before the first one ended")
            if benchlog.parse_meta_line(line) is None:
                return self._garbled(line, "not a '# key=value' metadata line")
            self.meta.append(line)
            return line
        if self.header is None:
            if not self.meta:
                return None  # rows of a recording whose start we missed
            self._set_header(line)
            return line
        fault = self._row_fault(line)
        if fault is not None:
            return self._garbled(line, fault)
        self.rows += 1
        return line

    def _set_header(self, line: str) -> None:
        """Checks and keeps the header; a header without the required columns ends the capture."""
        problem = benchlog.header_fault(line)
        if problem is not None:
            raise CaptureError(f"garbled header at stream line {self.line_no}: {line!r} ({problem[1]}; needs "
                               f"{','.join(benchlog.REQUIRED_COLUMNS)}, each column once)")
        cols = [c.strip(" \t") for c in line.split(",")]
        self.header = line
        self.columns = cols
        self.seq_col = cols.index("seq") if "seq" in cols else None

    def _row_fault(self, line: str) -> str | None:
        """What is wrong with a data row against the header and the previous row, or None."""
        try:  # the cells by the bench log reader's own rules (docs/bench-log.md)
            values = benchlog.parse_row(self.header, line)
        except benchlog.BenchLogError as exc:
            return exc.fault
        t_s = float(values["t_s"])
        if self.last_t is not None and t_s <= self.last_t:
            return f"t_s {t_s!r} not after {self.last_t!r}"
        self.last_t = t_s
        seq = int(values["seq"]) if "seq" in values else None
        if seq is not None:
            self.t_by_seq[seq] = t_s
            if self.last_seq is not None and seq != self.last_seq + 1:
                self.gaps.append((self.last_seq, seq - self.last_seq - 1))
            self.last_seq = seq
        return None

    def _garbled(self, line: str, fault: str) -> None:
        """Counts a garbled line; it is not written."""
        self.garbled.append((self.line_no, fault, line))
        return None

    def describe_garbled(self, index: int) -> str:
        """One line saying where garbled line number index was and what was wrong with it."""
        line_no, fault, text = self.garbled[index]
        where = f"after row {self.rows} (t_s={self.last_t:g})" if self.last_t is not None else "before the first row"
        shown = text if len(text) <= 80 else text[:77] + "..."
        return f"garbled line at stream line {line_no}, {where}, not written: {fault}: {shown!r}"

    @property
    def lost(self) -> int:
        """Samples missing from seq gaps (garbled rows count here too: they are not in the log)."""
        return sum(n for _, n in self.gaps if n > 0)

    @property
    def complete(self) -> bool:
        """True when the board ended the recording and every line arrived intact."""
        return self.ended and not self.garbled

    def metadata(self) -> list[str]:
        """The capture's own metadata lines, written before the board's."""
        lines = [f"# complete={'true' if self.complete else 'false'}"]
        if self.cut is not None:
            lines.append(f"# cut={self.cut}")
        lines.append(f"# garbled_rows={len(self.garbled)}")
        return lines


def read_line(port, port_name: str, partial: pathlib.Path) -> bytes:
    """One readline() from the port; a port fault becomes a PortError naming the port and the partial file."""
    try:
        return port.readline()
    except PORT_ERRORS as exc:
        fault = str(exc) if serial is not None and isinstance(exc, serial.SerialException) else os_fault(exc)
        raise PortError(f"lost serial port {port_name} while recording: {fault}; "
                        f"rows so far kept in {partial} (not a complete log)") from None


def waiting(port) -> int:
    """Bytes the port holds unread (0 for a port that cannot say, or fails: its read says why)."""
    try:
        return int(getattr(port, "in_waiting", 0))
    except PORT_ERRORS:
        return 0


def write_final(partial: pathlib.Path, out: pathlib.Path, meta_lines: list[str]) -> None:
    """Writes meta_lines then the partial capture to out atomically (benchlog.write_bytes_atomic:
    temporary file, fsync, rename)."""
    def fill(dst):
        with open(partial, "rb") as src:
            dst.write("".join(line + "\n" for line in meta_lines).encode("utf-8"))
            shutil.copyfileobj(src, dst)

    # the temporary file opened with this module's open (the tests fill the disk through it)
    benchlog.write_bytes_atomic(out, fill, opener=lambda tmp: open(tmp, "wb"))


def capture(port, out: pathlib.Path, command: str | None = None, rows: int | None = None,
            seconds: float | None = None, progress: bool = True, log=print, warn=None,
            port_name: str | None = None, on_row=None) -> Capture:
    """Reads lines from an open serial port (anything with write() and readline()) into out;
    raises CaptureError (PortError, OutputError) or KeyboardInterrupt with nothing under out.
    on_row(line, cap), when given, is called with every data row after it was written to
    OUT.partial (hpddo live shows the rows with it); it must not block."""
    out = pathlib.Path(out)
    partial = out.with_name(out.name + ".partial")
    port_name = port_name or getattr(port, "port", None) or "the serial port"
    if warn is None:
        def warn(text):
            (tqdm.write if tqdm else print)(text, file=sys.stderr)
    cap = Capture()
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        f = open(partial, "w", encoding="utf-8", newline="\n")
    except OSError as exc:
        raise OutputError(f"cannot create {partial}: {os_fault(exc)}; nothing recorded") from None
    if command:
        try:
            port.write((command + "\n").encode())
        except PORT_ERRORS as exc:
            f.close()
            partial.unlink()
            raise PortError(f"cannot send {command!r} to serial port {port_name}: {exc}; "
                            f"nothing recorded") from None
    start = time.monotonic()
    bar = tqdm(total=rows, unit="row", disable=None if progress else True) if tqdm else None  # None: off a terminal
    pending = b""  # the start of a line that a read timeout cut
    flushed_at = time.monotonic()
    try:
        with f:
            while True:
                now = time.monotonic()
                if now - flushed_at >= FLUSH_S or not waiting(port):
                    f.flush()  # what was read is in the file before this read can wait
                    flushed_at = now
                raw = read_line(port, port_name, partial)
                if raw and not raw.endswith(b"\n"):
                    pending += raw
                    raw = b""
                elif raw:
                    raw, pending = pending + raw, b""
                if not raw:
                    if seconds is not None and time.monotonic() - start >= seconds:
                        cap.cut = f"--seconds {seconds:g}"
                        break
                    continue
                text = raw.decode("utf-8", errors="replace")
                n_garbled, n_rows = len(cap.garbled), cap.rows
                try:
                    kept = cap.feed(text)
                except CaptureError as exc:  # garbled header, a second recording
                    raise CaptureError(f"{exc}; nothing written to {out}, what arrived is in {partial}") from None
                if kept is not None:
                    f.write(kept + "\n")
                    if cap.rows > n_rows and on_row is not None:
                        on_row(kept, cap)
                    if cap.rows > n_rows and bar is not None:
                        bar.update(1)
                        if cap.gaps or cap.garbled:
                            bar.set_postfix(lost=cap.lost, garbled=len(cap.garbled))
                elif text.startswith("!"):
                    log(text.rstrip())
                if len(cap.garbled) > n_garbled:
                    if len(cap.garbled) <= MAX_GARBLED_SHOWN:
                        warn(cap.describe_garbled(-1))
                    elif len(cap.garbled) == MAX_GARBLED_SHOWN + 1:
                        warn(f"more garbled lines: counted, not shown (first at stream line {cap.line_no})")
                if cap.ended:
                    break
                if rows is not None and cap.rows >= rows:
                    cap.cut = f"--rows {rows}"
                    break
                if seconds is not None and time.monotonic() - start >= seconds:
                    cap.cut = f"--seconds {seconds:g}"
                    break
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:  # port faults arrive as PortError, so this is the partial file
        raise OutputError(f"cannot write {partial}: {os_fault(exc)}; nothing written to {out}, "
                          f"rows so far kept in {partial} (not a complete log)") from None
    finally:
        if bar is not None:
            bar.close()
    if cap.header is None or cap.rows == 0:
        garbled = f", {len(cap.garbled)} garbled lines" if cap.garbled else ""
        raise CaptureError(f"no rows recorded from {port_name}{garbled}; nothing written to {out}, "
                           f"what arrived is in {partial}")
    try:
        write_final(partial, out, cap.metadata())
    except OSError as exc:
        raise OutputError(f"cannot write {out}: {os_fault(exc)}; nothing written to {out}, "
                          f"the rows are in {partial} (not a complete log)") from None
    try:
        partial.unlink()
    except OSError:
        pass
    if cap.ripple.chunks or cap.ripple.bad:
        write_bursts(cap, out, log)
    return cap


def write_bursts(cap: Capture, out: pathlib.Path, log=print) -> None:
    """Writes the recording's whole bursts to OUT's <condition>.ripple.csv and says what was
    left out; an OutputError when the file cannot be written."""
    meta = dict(kv for kv in (benchlog.parse_meta_line(m) for m in cap.meta) if kv)
    bursts, incomplete = cap.ripple.bursts()
    path = ripple.path_for(out)
    try:
        _, kept = ripple_link.bursts_file(path, bursts, meta, cap.t_by_seq)
    except ValueError as exc:
        raise CaptureError(f"{out} written, but its ripple bursts cannot be: {exc}") from None
    except OSError as exc:
        raise OutputError(f"{out} written, but not {path}: {os_fault(exc)}") from None
    log(f"{path}: {kept} bursts of {len(cap.t_by_seq)} rows; left out: {len(incomplete)} incomplete, "
        f"{len(bursts) - kept} without a row; {cap.ripple.bad} damaged chunk lines, "
        f"{cap.ripple.duplicates} repeated")
    if not cap.ripple.has_probes:
        return
    probes, incomplete = cap.ripple.probes()
    path = coast.path_for(out)
    try:
        _, kept = ripple_link.coast_file(path, probes, meta, cap.t_by_seq)
    except ValueError as exc:
        raise CaptureError(f"{out} written, but its coast probes cannot be: {exc}") from None
    except OSError as exc:
        raise OutputError(f"{out} written, but not {path}: {os_fault(exc)}") from None
    log(f"{path}: {kept} coast probes; left out: {len(incomplete)} incomplete, {len(probes) - kept} without a row")


def send_stop(port) -> None:
    """Asks the board to stop recording; a port that is already gone is not an error here."""
    try:
        port.write(b"stop\n")
    except PORT_ERRORS:
        pass



def recording_options(p: argparse.ArgumentParser) -> None:
    """The options of a recording from the UNO: capture's, and hpddo live's, which records the same way."""
    p.add_argument("--port", required=True, help="serial port of the UNO, e.g. /dev/ttyACM0 or COM3 "
                                                 "(opened exclusively)")
    p.add_argument("--baud", type=options.positive_int, default=115200, help="baud rate of the port (default 115200)")
    options.out(p, "bench log to write (its rows arrive in OUT.partial first)", alias="-o")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--run", choices=["sweep", "load", "long"], help="start this protocol and record it")
    what.add_argument("--rec", metavar="CONDITION", help="start a recording by hand with this condition")
    options.rate_hz(p, "set the board's sample rate first")
    p.add_argument("--hold", type=options.positive_float, metavar="S", help="set the protocol step length first (s)")
    p.add_argument("--rows", type=options.positive_int,
                   help="stop after this many rows (the log says complete=false, cut=--rows N)")
    p.add_argument("--seconds", type=options.positive_float,
                   help="stop after this many seconds (the log says complete=false, cut=--seconds S)")
    options.quiet(p)


def parser(prog: str = "hpddo capture") -> argparse.ArgumentParser:
    """The command line options."""
    p = options.new_parser(prog, __doc__)
    recording_options(p)
    return p


def open_port(name: str, baud: int, timeout: float = 1.0, hold_reset: bool = False):
    """Opens a serial port exclusively (a second program, or a second hpddo, cannot open it
    meanwhile); with hold_reset, DTR and RTS stay off (the NodeMCU then keeps running).
    A port that cannot be opened is a CaptureError naming it."""
    if serial is None:  # pragma: no cover
        raise CaptureError("pyserial is not installed (pip install pyserial)")
    try:
        if not hold_reset:
            return serial.Serial(name, baud, timeout=timeout, exclusive=True)
        port = serial.Serial(None, baud, timeout=timeout, exclusive=True)
        port.port = name
        port.dtr = False
        port.rts = False
        port.open()
        return port
    except PORT_ERRORS as exc:
        raise CaptureError(f"cannot open serial port {name}: {exc}") from None


def record(a: argparse.Namespace, on_row=None, prog: str = "hpddo capture") -> int:
    """Opens the port exclusively, sets the board up, captures, and reports; returns the exit
    status (0, EXIT_GARBLED, or 130/143 when a signal stopped it) or raises CaptureError
    (nothing written to --out). The port is closed on every way out. on_row: see capture()."""
    port = open_port(a.port, a.baud)
    try:
        try:
            time.sleep(BOARD_RESET_S)
            port.reset_input_buffer()
            for cmd, val in (("rate", a.rate_hz), ("hold", a.hold)):
                if val is not None:
                    port.write(f"{cmd} {val:g}\n".encode())
                    print(port.readline().decode(errors="replace").rstrip())
        except PORT_ERRORS as exc:
            raise CaptureError(f"serial port {a.port} failed while setting up the board: {exc}; "
                               f"nothing written to {a.out}") from None
        command = f"run {a.run}" if a.run else f"rec {a.rec}" if a.rec else None
        try:
            cap = capture(port, a.out, command, a.rows, a.seconds, progress=not a.quiet, port_name=a.port,
                          on_row=on_row)
        except KeyboardInterrupt as exc:  # Ctrl-C, or hpddo.interrupt.Interrupted (SIGINT, SIGTERM)
            send_stop(port)
            what = f"stopped by {exc.args[0]}" if getattr(exc, "status", None) else "interrupted"
            print(f"{prog}: {what}: nothing written to {a.out}; rows so far kept in "
                  f"{a.out}.partial (not a complete log)", file=sys.stderr)
            return getattr(exc, "status", EXIT_INTERRUPTED)
        except CaptureError:
            send_stop(port)
            raise
        if not cap.ended:
            send_stop(port)
    finally:
        try:
            port.close()
        except PORT_ERRORS:
            pass
    print(f"{a.out}: {cap.rows} rows, {len(cap.gaps)} seq gaps, {cap.lost} samples lost")
    for after, n in cap.gaps:
        print(f"  gap after seq {after}: {n} lost")
    if cap.complete:
        print(f"{a.out}: complete=true (the board ended the recording)", file=sys.stderr)
        return EXIT_OK
    why = [f"cut by {cap.cut} before the board ended the recording" if cap.cut else None,
           f"{len(cap.garbled)} garbled row{'s' if len(cap.garbled) != 1 else ''} not written "
           f"(stream lines {', '.join(str(n) for n, _, _ in cap.garbled[:10])}"
           f"{', ...' if len(cap.garbled) > 10 else ''})" if cap.garbled else None]
    print(f"{prog + ': WARNING: ' if cap.garbled else ''}{a.out}: complete=false, "
          f"{'; '.join(w for w in why if w)}", file=sys.stderr)
    return EXIT_GARBLED if cap.garbled else EXIT_OK


def run(a: argparse.Namespace) -> int:
    """Runs the capture from the command line; returns the exit status (a CaptureError
    reaches the caller, hpddo.cli.run, which prints its one line)."""
    try:
        return record(a)
    except KeyboardInterrupt as exc:
        print(f"hpddo capture: interrupted before recording started on {a.port}: nothing written to {a.out}",
              file=sys.stderr)
        return getattr(exc, "status", EXIT_INTERRUPTED)


def main(argv=None) -> int:
    """`hpddo capture ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("capture", argv)
