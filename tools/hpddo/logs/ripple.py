"""Ripple bursts: the high-rate armature current beside a bench log (docs/bench-log.md,
"Ripple bursts"). One file per recording, `<condition>.ripple.csv`: metadata lines as in a
bench log, the header `seq,t_s,n,codes`, one row per window of the bench log (the same
`seq`), `codes` the window's ADC codes of the current, space separated, one per PWM period.
"""
from __future__ import annotations

import dataclasses
import pathlib
import re

import numpy as np

from .benchlog import write_text_atomic
from .errors import InputError

SUFFIX = ".ripple.csv"
FORMAT = "hpddo-ripple 1"
HEADER = "seq,t_s,n,codes"
REQUIRED_META = ("format", "sample_hz", "a_per_code")
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
    codes: list  # one int array per window

    def current_A(self, k: int) -> np.ndarray:
        return self.codes[k].astype(float) * self.a_per_code

    def one(self, k: int, codes, t_offset_s: float = 0.0) -> "Bursts":
        """The bursts of window k alone, holding codes (a part of its burst, or several bursts
        joined), starting t_offset_s after the window's burst."""
        return dataclasses.replace(self, seq=self.seq[k:k + 1], t_s=self.t_s[k:k + 1] + t_offset_s, codes=[codes])

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
        if c.size and (c.min() < 0 or not np.issubdtype(c.dtype, np.integer)):
            raise ValueError("codes are non-negative integers")
        lines.append(f"{int(s)},{float(t)!r},{c.size}," + " ".join(map(str, c.tolist())))
    return write_text_atomic(path, "\n".join(lines) + "\n")


def read(path) -> Bursts:
    """Reads a burst file; a RippleFileError names the line and the fault."""
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RippleFileError(f"{path}: cannot read: {exc}") from None
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    meta, i = {}, 0
    while i < len(lines) and lines[i].startswith("#"):
        m = _META.match(lines[i])
        if not m:
            raise RippleFileError(f"{path}:{i + 1}: malformed metadata")
        meta[m.group(1)] = m.group(2).strip()
        i += 1
    for k in REQUIRED_META:
        if k not in meta:
            raise RippleFileError(f"{path}: missing metadata {k}")
    if meta["format"] != FORMAT:
        raise RippleFileError(f"{path}: format {meta['format']!r}, expected {FORMAT!r}")
    if i >= len(lines) or lines[i].strip() != HEADER:
        raise RippleFileError(f"{path}:{i + 1}: header {HEADER!r} expected")
    seq, t, codes = [], [], []
    for j in range(i + 1, len(lines)):
        parts = lines[j].split(",")
        try:
            if len(parts) != 4:
                raise ValueError("field count")
            c = np.array(parts[3].split(), dtype=np.int64) if parts[3].strip() else np.zeros(0, np.int64)
            if c.size != int(parts[2]) or (c.size and c.min() < 0):
                raise ValueError("n does not match the codes, or a negative code")
            s, tt = int(parts[0]), float(parts[1])
        except ValueError as exc:
            raise RippleFileError(f"{path}:{j + 1}: {exc}") from None
        if t and tt <= t[-1]:
            raise RippleFileError(f"{path}:{j + 1}: t_s not increasing")
        seq.append(s)
        t.append(tt)
        codes.append(c)
    try:
        fs, lsb = float(meta["sample_hz"]), float(meta["a_per_code"])
    except ValueError:
        raise RippleFileError(f"{path}: sample_hz and a_per_code are numbers") from None
    if not (fs > 0 and lsb > 0):
        raise RippleFileError(f"{path}: sample_hz and a_per_code must be > 0")
    return Bursts(meta, fs, lsb, np.array(seq, np.int64), np.array(t), codes)
