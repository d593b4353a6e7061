"""Ripple bursts: the high-rate armature current beside a bench log (docs/bench-log.md,
"Ripple bursts"). One file per recording, `<condition>.ripple.csv`: metadata lines as in a
bench log, the header `seq,t_s,n,codes`, one row per window of the bench log (the same
`seq`), `codes` the window's ADC codes of the current, space separated (integers, signed
where the converter is), 1 / sample_hz apart: one per PWM period where `sampling` is
`synchronous` (the default), free-running under a PWM at `pwm_hz` where it is `free`; the
current is (code - offset_code) x a_per_code A (docs/bench-log.md, docs/ripple-captures.md).
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import re

import numpy as np

from .benchlog import write_text_atomic
from .errors import InputError

SUFFIX = ".ripple.csv"
FORMAT = "hpddo-ripple 1"
HEADER = "seq,t_s,n,codes"
REQUIRED_META = ("format", "sample_hz", "a_per_code")
#: a burst's current (code - offset_code) x a_per_code beyond this is no motor's: a scale or an offset gone wrong
#: (1e300 A made the spectrum overflow, and every window a made-up reason)
MAX_CURRENT_A = 1e6
# the optional keys the reader interprets (any other key is kept as it is)
SAMPLING = "sampling"            # how the samples sit against the PWM
SYNCHRONOUS, FREE = "synchronous", "free"  # one sample per PWM period at a fixed phase / free-running
SAMPLINGS = (SYNCHRONOUS, FREE)
PWM_HZ = "pwm_hz"                # the PWM frequency (Hz), 0 for none (a DC supply): needed where sampling is free
MAINS_HZ = "mains_hz"            # the mains frequency (Hz) whose harmonics may be in the current: 50 or 60; 0: none
OFFSET_CODE = "offset_code"      # the code of zero current (an AC-coupled or offset channel); default 0
COUPLING = "coupling"            # dc (the default: the mean current is in the codes) or ac (it is not)
DC, AC = "dc", "ac"
COUPLINGS = (DC, AC)
_META = re.compile(r"^#[ \t]*([A-Za-z0-9_.-]+)[ \t]*=(.*)$")


class RippleFileError(InputError):
    """A ripple burst file that does not follow docs/bench-log.md (file, line, what)."""


@dataclasses.dataclass
class Bursts:
    """The bursts of one recording: per window its seq, start time and current (A)."""

    meta: dict
    sample_hz: float
    a_per_code: float
    seq: np.ndarray
    t_s: np.ndarray
    codes: list  # one int array per window (float where the PWM-synchronous average is removed)
    offset_code: float = 0.0  # the code of zero current
    sampling: str = SYNCHRONOUS
    pwm_hz: float = float("nan")  # NaN: not declared
    mains_hz: float = float("nan")  # NaN: not declared; 0: declared absent
    coupling: str = DC
    refused: tuple = ()  # per window, why no count of it can be confident ("": none); set by the
    #                      estimator's preparation (ripple/sync.py), empty as read

    def refusal(self, k: int) -> str:
        return self.refused[k] if k < len(self.refused) else ""

    def current_A(self, k: int) -> np.ndarray:
        return (np.asarray(self.codes[k], float) - self.offset_code) * self.a_per_code

    def one(self, k: int, codes, t_offset_s: float = 0.0) -> "Bursts":
        """The bursts of window k alone, holding codes (a part of its burst, or several bursts
        joined), starting t_offset_s after the window's burst."""
        return dataclasses.replace(self, seq=self.seq[k:k + 1], t_s=self.t_s[k:k + 1] + t_offset_s, codes=[codes],
                                   refused=(self.refusal(k),))

    def __len__(self) -> int:
        return len(self.codes)


def path_for(log_path) -> pathlib.Path:
    """The burst file beside a bench log `<condition>.csv`."""
    p = pathlib.Path(log_path)
    return p.with_name(p.name[:-4] + SUFFIX if p.name.endswith(".csv") else p.name + SUFFIX)


def write(path, meta: dict, seq, t_s, codes) -> pathlib.Path:
    """Writes the bursts (codes: one integer array per window) atomically."""
    meta = {"format": FORMAT, **meta}
    for k in REQUIRED_META:
        if k not in meta:
            raise ValueError(f"ripple bursts need the metadata {k}")
    lines = []
    for k, v in meta.items():
        v = str(v)
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", k) or "\n" in v or "\r" in v:
            raise ValueError(f"bad metadata {k}={v!r}")
        lines.append(f"# {k}={v}")
    lines.append(HEADER)
    for s, t, c in zip(seq, t_s, codes):
        c = np.asarray(c)
        if c.size and not np.issubdtype(c.dtype, np.integer):
            raise ValueError("codes are integers")
        lines.append(f"{int(s)},{float(t)!r},{c.size}," + " ".join(map(str, c.tolist())))
    return write_text_atomic(path, "\n".join(lines) + "\n")


def head(path, error, required, fmt: str, header: str) -> tuple:
    """The metadata and header of a file beside a bench log (bursts, coast probes): (its lines,
    {key: value}, {key: line number}, the header's index); error(text) names the file, the line and
    the fault: unreadable, malformed or missing metadata, another format, no header."""
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark, as a bench log may begin with one
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read: {exc}") from None
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    meta, where, i = {}, {}, 0
    while i < len(lines) and lines[i].startswith("#"):
        m = _META.match(lines[i])
        if not m:
            raise error(f"{path}:{i + 1}: malformed metadata")
        if m.group(1) in meta:  # one value a key, as in a bench log
            raise error(f"{path}:{i + 1}: metadata {m.group(1)} given again (first on line {where[m.group(1)]})")
        meta[m.group(1)] = m.group(2).strip()
        where[m.group(1)] = i + 1
        i += 1
    for k in required:
        if k not in meta:
            raise error(f"{path}: missing metadata {k}")
    if meta["format"] != fmt:
        raise error(f"{path}:{where['format']}: format {meta['format']!r}, expected {fmt!r}")
    if i >= len(lines) or lines[i].strip() != header:
        raise error(f"{path}:{i + 1}: header {header!r} expected")
    return lines, meta, where, i


def codes_of(count: str, text: str, name: str) -> np.ndarray:
    """A row's codes (integers, space separated) and their count in the column `name`; ValueError
    where they are not integers or their number is not the count."""
    c = np.array(text.split(), dtype=np.int64) if text.strip() else np.zeros(0, np.int64)
    if c.size != int(count):
        raise ValueError(f"{name} {count.strip()} does not match the {c.size} codes")
    return c


def time_of(text: str) -> float:
    """A row's t_s; ValueError where it is not a finite number."""
    t = float(text)
    if not math.isfinite(t):
        raise ValueError(f"t_s {text.strip()!r} is not a finite number")
    return t


def read(path) -> Bursts:
    """Reads a burst file; a RippleFileError names the line and the fault."""
    path = pathlib.Path(path)
    lines, meta, where, i = head(path, RippleFileError, REQUIRED_META, FORMAT, HEADER)
    seq, t, codes, line_of = [], [], [], {}
    for j in range(i + 1, len(lines)):
        parts = lines[j].split(",")
        try:
            if len(parts) != 4:
                raise ValueError("field count")
            c = codes_of(parts[2], parts[3], "n")
            s, tt = int(parts[0]), time_of(parts[1])
        except (ValueError, OverflowError) as exc:
            raise RippleFileError(f"{path}:{j + 1}: {exc}") from None
        if t and tt <= t[-1]:
            raise RippleFileError(f"{path}:{j + 1}: t_s not increasing")
        if s in line_of:  # a burst is its log row's (seq): two bursts of one row are no file of this format
            raise RippleFileError(f"{path}:{j + 1}: seq {s} given again (first on line {line_of[s]}): each burst "
                                  "is the one of its log row's seq")
        line_of[s] = j + 1
        seq.append(s)
        t.append(tt)
        codes.append(c)
    return of_meta(meta, np.array(seq, np.int64), np.array(t), codes, path, where)


def of_meta(meta: dict, seq, t_s, codes, path="bursts", where: dict | None = None) -> Bursts:
    """Bursts from their metadata (the file's keys, values as strings) and rows, the declared keys
    checked and read as read() does (RippleFileError naming path and the key's line)."""
    where = where if where is not None else {k: j + 1 for j, k in enumerate(meta)}
    for k in REQUIRED_META[1:]:
        if k not in meta:
            raise RippleFileError(f"{path}: missing metadata {k}")
    fs, lsb = number(path, meta, where, "sample_hz"), number(path, meta, where, "a_per_code")
    if not (fs > 0 and lsb > 0):
        raise RippleFileError(f"{path}: sample_hz and a_per_code must be > 0")
    declared = {}
    # pwm_hz=0: no PWM (a DC supply); mains_hz=0: no mains near the motor (a battery, nothing mains-powered beside it)
    for key in (PWM_HZ, MAINS_HZ):
        if key in meta:
            declared[key] = number(path, meta, where, key)
            if not declared[key] >= 0:
                raise RippleFileError(f"{path}:{where[key]}: metadata {key}={meta[key]} must be > 0"
                                      + (" (0: no PWM)" if key == PWM_HZ else " (0: no mains)")
                                      + "; leave the key out where unknown")
    offset = number(path, meta, where, OFFSET_CODE) if OFFSET_CODE in meta else 0.0
    for key, allowed in ((SAMPLING, SAMPLINGS), (COUPLING, COUPLINGS)):
        if key in meta and meta[key] not in allowed:
            raise RippleFileError(f"{path}: metadata {key}={meta[key]!r}, expected one of {', '.join(allowed)}")
    extreme = largest_current_A(codes, offset, lsb)
    if not extreme <= MAX_CURRENT_A:
        raise RippleFileError(f"{path}:{where['a_per_code']}: a_per_code={meta['a_per_code']} and "
                              f"{OFFSET_CODE}={offset:g} make currents of {extreme:.3g} A, over any motor's "
                              f"{MAX_CURRENT_A:g} A (the spectrum would overflow): check the scale and the offset")
    return Bursts(dict(meta), fs, lsb, np.asarray(seq, np.int64), np.asarray(t_s, float), list(codes), offset_code=offset,
                  sampling=meta.get(SAMPLING, SYNCHRONOUS), pwm_hz=declared.get(PWM_HZ, math.nan),
                  mains_hz=declared.get(MAINS_HZ, math.nan), coupling=meta.get(COUPLING, DC))


def largest_current_A(codes, offset_code: float, a_per_code: float) -> float:
    """The largest |current| the bursts' codes hold, (code - offset_code) x a_per_code, A (0 without a code)."""
    return max((float(np.max(np.abs(np.asarray(c, float) - offset_code))) for c in codes if len(c)),
               default=0.0) * a_per_code


def number(path, meta: dict, where: dict, key: str, error=RippleFileError) -> float:
    """A metadata value that must be a finite number; error (RippleFileError) naming the key otherwise."""
    try:
        v = float(meta[key])
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise error(f"{path}:{where[key]}: metadata {key}={meta[key]!r} is not a finite number")
    return v


