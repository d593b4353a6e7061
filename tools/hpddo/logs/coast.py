"""Coast probes: the drive held off for a few milliseconds, both channels sampled in turn
(docs/bench-log.md, "Coast probes"; docs/ripple-coast.md). One file per recording,
`<condition>.coast.csv` beside the bench log and its `<condition>.ripple.csv`: metadata lines as
in a bench log, the header `seq,t_s,n_i,i_codes,n_v,v_codes`, one row per probe: the bench log's
row that holds it (`seq`), the time of the cut on the log's clock (`t_s`, s), and the two
channels' ADC codes, space separated. One converter takes the channels in turn: the current
sample j at t_s + 2 j / sample_hz, the voltage sample j at t_s + (2 j + 1) / sample_hz. The
current is (code - offset_code) x a_per_code A, the terminal voltage code x v_per_code - v_shift_V V.
"""
from __future__ import annotations

import dataclasses
import pathlib
import re

import numpy as np

from . import ripple as rf
from .benchlog import write_text_atomic
from .errors import InputError

SUFFIX = ".coast.csv"
FORMAT = "hpddo-coast 1"
HEADER = "seq,t_s,n_i,i_codes,n_v,v_codes"
REQUIRED_META = ("format", "sample_hz", "a_per_code", "v_per_code")
V_SHIFT = "v_shift_V"          # the voltage channel's level shift, V (default 0)
OFFSET_CODE = "offset_code"    # the current channel's code of zero current (default 0)


class CoastFileError(InputError):
    """A coast probe file that does not follow docs/bench-log.md (file, line, what)."""


@dataclasses.dataclass
class ProbeBursts:
    """The probes of a run: per probe its log row (seq), the cut's time (s), and both channels'
    codes, the current at t_s + 2 j / sample_hz, the voltage at t_s + (2 j + 1) / sample_hz."""

    sample_hz: float      # the converter's rate; each channel gets half of it
    a_per_code: float     # current channel, A per code
    v_per_code: float     # voltage channel, V per code (before the level shift)
    v_shift_V: float      # the level shift: v = code x v_per_code - v_shift_V
    seq: np.ndarray
    t_s: np.ndarray
    i_codes: list
    v_codes: list
    offset_code: float = 0.0  # the current channel's code of zero current

    def __len__(self) -> int:
        return len(self.seq)

    def current(self, k: int):
        """(times after the cut, s; current, A) of probe k."""
        c = np.asarray(self.i_codes[k], float)
        return 2 * np.arange(len(c)) / self.sample_hz, (c - self.offset_code) * self.a_per_code

    def voltage(self, k: int):
        """(times after the cut, s; terminal voltage, V) of probe k."""
        c = np.asarray(self.v_codes[k], float)
        return (2 * np.arange(len(c)) + 1) / self.sample_hz, c * self.v_per_code - self.v_shift_V


def path_for(log_path) -> pathlib.Path:
    """The coast probe file beside a bench log `<condition>.csv`."""
    p = pathlib.Path(log_path)
    return p.with_name(p.name[:-4] + SUFFIX if p.name.endswith(".csv") else p.name + SUFFIX)


def write(path, probes: ProbeBursts, meta: dict | None = None) -> pathlib.Path:
    """Writes the probes atomically; meta: more keys (condition, notes) after the required ones."""
    head = {"format": FORMAT, "sample_hz": repr(float(probes.sample_hz)), "a_per_code": repr(float(probes.a_per_code)),
            "v_per_code": repr(float(probes.v_per_code)), V_SHIFT: repr(float(probes.v_shift_V))}
    if probes.offset_code:
        head[OFFSET_CODE] = repr(float(probes.offset_code))
    lines = []
    for k, v in {**head, **(meta or {})}.items():
        v = str(v)
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", k) or "\n" in v or "\r" in v:
            raise ValueError(f"bad metadata {k}={v!r}")
        lines.append(f"# {k}={v}")
    lines.append(HEADER)
    for s, t, ci, cv in zip(probes.seq, probes.t_s, probes.i_codes, probes.v_codes):
        ci, cv = np.asarray(ci), np.asarray(cv)
        if any(c.size and not np.issubdtype(c.dtype, np.integer) for c in (ci, cv)):
            raise ValueError("codes are integers")
        lines.append(f"{int(s)},{float(t)!r},{ci.size}," + " ".join(map(str, ci.tolist()))
                     + f",{cv.size}," + " ".join(map(str, cv.tolist())))
    return write_text_atomic(path, "\n".join(lines) + "\n")


def read(path) -> ProbeBursts:
    """Reads a coast probe file; a CoastFileError names the line and the fault."""
    path = pathlib.Path(path)
    lines, meta, where, i = rf.head(path, CoastFileError, REQUIRED_META, FORMAT, HEADER)

    def number(key):
        return rf.number(path, meta, where, key, CoastFileError)

    fs, a_lsb, v_lsb = (number(k) for k in REQUIRED_META[1:])
    for k, v in (("sample_hz", fs), ("a_per_code", a_lsb), ("v_per_code", v_lsb)):
        if not v > 0:
            raise CoastFileError(f"{path}:{where[k]}: metadata {k}={meta[k]} must be > 0")
    shift = number(V_SHIFT) if V_SHIFT in meta else 0.0
    offset = number(OFFSET_CODE) if OFFSET_CODE in meta else 0.0
    seq, t, ic, vc = [], [], [], []
    for j in range(i + 1, len(lines)):
        parts = lines[j].split(",")
        try:
            if len(parts) != 6:
                raise ValueError(f"{len(parts)} fields, 6 expected ({HEADER})")
            s, tt = int(parts[0]), rf.time_of(parts[1])
            ci, cv = rf.codes_of(parts[2], parts[3], "n_i"), rf.codes_of(parts[4], parts[5], "n_v")
        except (ValueError, OverflowError) as exc:
            raise CoastFileError(f"{path}:{j + 1}: {exc}") from None
        if t and tt <= t[-1]:
            raise CoastFileError(f"{path}:{j + 1}: t_s not increasing")
        seq.append(s)
        t.append(tt)
        ic.append(ci)
        vc.append(cv)
    return ProbeBursts(sample_hz=fs, a_per_code=a_lsb, v_per_code=v_lsb, v_shift_V=shift,
                       seq=np.array(seq, np.int64), t_s=np.array(t, float), i_codes=ic, v_codes=vc, offset_code=offset)
