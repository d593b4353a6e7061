"""The UNO's ripple bursts as they arrive on the USB serial (uno_acq built with
-DACQ_RIPPLE_HZ; docs/ripple-board.md, "The UNO's ripple mode"): lines "~<base64>", each one
chunk of up to 32 current codes, framed and checked like the link's sample frames (sync,
length, CRC-16/CCITT-FALSE; uno_acq/acq_ripple.h gives the layout). `Assembler` collects
the chunks of a recording into whole bursts, one per window, and leaves out (and counts)
the bursts that did not arrive whole; `bursts_file` turns them, with the bench log's rows,
into the `<condition>.ripple.csv` the twin writes (logs/ripple.py), so that `hpddo ripple`
reads the board's bursts as it reads the twin's.

The build with -DACQ_COAST=1 (uno_acq/acq_coast.h; docs/ripple-board.md, "Coast probes") also
sends coast probes: chunks of the same layout whose second sync byte is 0x5C, the current and the
terminal voltage taken in turn (current first) while the drive is held off. The Assembler keeps
them apart from the bursts (`probes`), and `coast_file` writes them, with the log's rows, as the
`<condition>.coast.csv` of logs/coast.py that `hpddo ripple --coast` reads.
"""
from __future__ import annotations

import base64
import binascii
import dataclasses
import struct

import numpy as np

from .. import bench
from . import ripple

PREFIX = "~"
SYNC = b"\xa5\x5b"        # a burst of the current
COAST_SYNC = b"\xa5\x5c"  # a coast probe: current and terminal voltage in turn (uno_acq/acq_coast.h)
HEAD = 16               # bytes before the codes: sync, length, seq, first, total, start period, phase, n
MAX_SAMPLES = 32        # codes a chunk carries at most
SAMPLE_PHASE = "middle of the on-time"


class ChunkError(ValueError):
    """A line that is not a valid chunk; the message says what is wrong."""


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF), as hpddo/crc.h."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclasses.dataclass(frozen=True)
class Chunk:
    seq: int            # the window's seq (the bench log's)
    first: int          # index of the first code in the burst
    total: int          # codes in the burst
    start_period: int   # the PWM period of the window in which code 0 was taken
    phase_cycles: int   # CPU cycles from a period's start to its sample-and-hold
    codes: tuple        # the 10-bit ADC codes
    coast: bool = False  # a coast probe's chunk (sync A5 5C), not a burst's


def decode_line(line: str) -> Chunk:
    """One '~' line to its chunk; ChunkError names the fault."""
    text = line.rstrip("\r\n")
    if not text.startswith(PREFIX):
        raise ChunkError("not a ripple line (no '~')")
    try:
        raw = base64.b64decode(text[1:], validate=True)
    except (binascii.Error, ValueError):
        raise ChunkError("not base64") from None
    if len(raw) < HEAD + 2 or raw[:2] not in (SYNC, COAST_SYNC):
        raise ChunkError("no chunk header")
    if raw[2] != len(raw) - 5:
        raise ChunkError(f"length {raw[2]} does not match {len(raw) - 5} payload bytes")
    if struct.unpack_from("<H", raw, len(raw) - 2)[0] != crc16(raw[2:-2]):
        raise ChunkError("CRC mismatch")
    seq, first, total, start_period, phase, n = struct.unpack_from("<IHHHHB", raw, 3)
    packed = raw[HEAD:-2]
    if not 1 <= n <= MAX_SAMPLES or len(packed) != (10 * n + 7) // 8:
        raise ChunkError(f"{n} codes do not match {len(packed)} packed bytes")
    if first + n > total:
        raise ChunkError(f"codes {first}..{first + n - 1} beyond the burst's {total}")
    bits = int.from_bytes(packed, "little")
    codes = tuple((bits >> (10 * k)) & 0x3FF for k in range(n))
    return Chunk(seq, first, total, start_period, phase, codes, raw[:2] == COAST_SYNC)


@dataclasses.dataclass
class Burst:
    seq: int
    start_period: int
    phase_cycles: int
    codes: np.ndarray


class Assembler:
    """Collects chunks into bursts. A burst is whole when its chunks cover 0..total-1 exactly
    once; the others are counted in `incomplete` and left out. `bad` counts lines that were
    not valid chunks (their faults in `faults`, first ones kept), `duplicates` chunks that
    arrived twice."""

    def __init__(self):
        self._parts: dict[int, dict[int, Chunk]] = {}
        self._probe_parts: dict[int, dict[int, Chunk]] = {}  # the coast probes' chunks, by seq
        self.chunks = 0
        self.bad = 0
        self.duplicates = 0
        self.faults: list[tuple[int, str]] = []

    def feed(self, line: str, line_no: int = 0) -> bool:
        """Takes one '~' line; False (counted) when it is not a valid chunk."""
        try:
            c = decode_line(line)
        except ChunkError as exc:
            self.bad += 1
            if len(self.faults) < 20:
                self.faults.append((line_no, str(exc)))
            return False
        parts = (self._probe_parts if c.coast else self._parts).setdefault(c.seq, {})
        if c.first in parts:
            self.duplicates += 1
            return True
        parts[c.first] = c
        self.chunks += 1
        return True

    def bursts(self) -> tuple[list[Burst], list[int]]:
        """The whole bursts in seq order, and the seqs of the incomplete ones."""
        return self._whole(self._parts)

    def probes(self) -> tuple[list[Burst], list[int]]:
        """The whole coast probes in seq order (codes: current and voltage in turn, current first),
        and the seqs of the incomplete ones."""
        return self._whole(self._probe_parts)

    @property
    def has_probes(self) -> bool:
        return bool(self._probe_parts)

    @staticmethod
    def _whole(by_seq) -> tuple[list[Burst], list[int]]:
        whole, incomplete = [], []
        for seq in sorted(by_seq):
            parts = by_seq[seq]
            chunks = [parts[k] for k in sorted(parts)]
            total = chunks[0].total
            pos, ok = 0, True
            for c in chunks:
                if (c.first != pos or c.total != total or c.phase_cycles != chunks[0].phase_cycles
                        or c.start_period != chunks[0].start_period):
                    ok = False
                    break
                pos += len(c.codes)
            if ok and pos == total:
                codes = np.fromiter((v for c in chunks for v in c.codes), dtype=np.int64, count=total)
                whole.append(Burst(seq, chunks[0].start_period, chunks[0].phase_cycles, codes))
            else:
                incomplete.append(seq)
        return whole, incomplete


def a_per_code(meta: dict) -> float:
    """Amperes per ADC code of the current channel from the log's metadata (adc_ref_V,
    shunt_ohm, shunt_gain): the 10-bit ADC's step over the shunt and its gain."""
    try:
        ref = float(meta["adc_ref_V"])
        shunt = float(meta["shunt_ohm"]) * float(meta.get("shunt_gain", 1.0))
    except (KeyError, ValueError) as exc:
        raise ValueError(f"the log's metadata lack the current channel's calibration ({exc})") from None
    return ref / 2 ** bench.HARDWARE.adc_bits / shunt


def bursts_file(path, bursts: list[Burst], meta: dict, t_start_s: dict, cpu_hz: float | None = None):
    """Writes the bursts as `<condition>.ripple.csv` (logs/ripple.py): meta is the bench log's
    metadata (condition, ripple_hz, adc_ref_V, shunt_ohm, shunt_gain), t_start_s maps each
    seq to the t_s of its log row (the window's start); a burst's t_s adds the periods before
    it and its phase in the period (the PWM period is cpu_hz / ripple_hz cycles). Bursts of
    windows without a log row are left out. Returns the path and the bursts written."""
    cpu_hz = cpu_hz or bench.HARDWARE.cpu_hz
    try:
        hz = float(meta["ripple_hz"])
    except (KeyError, ValueError):
        raise ValueError("the log's metadata lack ripple_hz: not a ripple-mode recording") from None
    kept = [b for b in bursts if b.seq in t_start_s]
    n = max((len(b.codes) for b in kept), default=0)
    out_meta = {"condition": meta.get("condition", ""), "sample_hz": f"{hz:g}", "a_per_code": repr(a_per_code(meta)),
                "pwm_hz": f"{hz:g}", "sample_phase": SAMPLE_PHASE, "burst_s": f"{n / hz:g}", "source": "uno_acq"}
    if not out_meta["condition"]:
        del out_meta["condition"]
    period = round(cpu_hz / hz)
    t = [t_start_s[b.seq] + (b.start_period * period + b.phase_cycles) / cpu_hz for b in kept]
    written = ripple.write(path, out_meta, [b.seq for b in kept], t, [b.codes for b in kept])
    return written, len(kept)


def v_per_code(meta: dict) -> float:
    """Volts per ADC code of the terminal voltage channel from the log's metadata (adc_ref_V,
    divider_ratio): the 10-bit ADC's step times the divider, as the board's own means (acq_window.h)."""
    try:
        return float(meta["adc_ref_V"]) * float(meta["divider_ratio"]) / 2 ** bench.HARDWARE.adc_bits
    except (KeyError, ValueError) as exc:
        raise ValueError(f"the log's metadata lack the voltage channel's calibration ({exc})") from None


def coast_file(path, probes: list[Burst], meta: dict, t_start_s: dict, cpu_hz: float | None = None):
    """Writes the board's coast probes as `<condition>.coast.csv` through logs/coast.py's writer: each
    probe's codes split into the current (even samples) and the terminal voltage (odd ones), its t_s
    the log row's t_s plus the periods before it and its phase (as bursts_file), sample_hz the ripple
    rate (one conversion a PWM period, the channels in turn). Probes of windows without a log row, or
    with an odd number of codes, are left out. Returns the path and the probes written."""
    from . import coast
    cpu_hz = cpu_hz or bench.HARDWARE.cpu_hz
    try:
        hz = float(meta["ripple_hz"])
    except (KeyError, ValueError):
        raise ValueError("the log's metadata lack ripple_hz: not a ripple-mode recording") from None
    kept = [p for p in probes if p.seq in t_start_s and len(p.codes) % 2 == 0]
    period = round(cpu_hz / hz)
    t = np.array([t_start_s[p.seq] + (p.start_period * period + p.phase_cycles) / cpu_hz for p in kept], float)
    pb = coast.ProbeBursts(sample_hz=hz, a_per_code=a_per_code(meta), v_per_code=v_per_code(meta), v_shift_V=0.0,
                           seq=np.array([p.seq for p in kept], np.int64), t_s=t,
                           i_codes=[p.codes[0::2] for p in kept], v_codes=[p.codes[1::2] for p in kept])
    out_meta = {"source": "uno_acq"}
    if meta.get("condition"):
        out_meta = {"condition": meta["condition"], **out_meta}
    return coast.write(path, pb, out_meta), len(kept)
