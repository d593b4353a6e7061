"""Reader and writer for the bench log format (docs: /spec bench-log.md).

A bench log is UTF-8 CSV text::

    # condition=sweep
    # sample_rate_hz=2
    t_s,duty,v_V,i_A,rpm_ref,temp_C,load
    0.0,0.000,0.012,0.003,0.0,31.7,0

`read_log` accepts every file that follows the format and refuses any other with a
`BenchLogError` whose message names the file, the 1-based line number in the file
and the fault. It never drops a row.

Conventions of the returned DataFrame (``BenchLog.df``):

* all columns of the file are kept, in file order; extra columns are kept too
  (numeric where every non-empty cell is a number, text otherwise);
* an optional column that is absent from the file is absent from ``df``
  (it is *not* added as an all-NaN column);
* required columns ``t_s, duty, v_V, i_A`` are float64 and always finite;
* ``rpm_ref`` and ``temp_C`` are float64, an empty cell is NaN;
* ``load`` and ``seq`` are int64, or pandas' nullable ``Int64`` (empty cell = <NA>)
  when the column has empty cells.

`write_log` writes the exact format atomically (temporary file in the same
directory, then ``os.replace``), so a reader never sees a partial file.
"""
from __future__ import annotations

import dataclasses
import io
import math
import os
import pathlib
import re
import tempfile

import numpy as np
import pandas as pd

__all__ = [
    "BenchLog",
    "BenchLogError",
    "REQUIRED_COLUMNS",
    "OPTIONAL_FLOAT_COLUMNS",
    "OPTIONAL_INT_COLUMNS",
    "KNOWN_COLUMNS",
    "COLUMN_FORMATS",
    "read_log",
    "write_log",
    "write_text_atomic",
]

REQUIRED_COLUMNS = ("t_s", "duty", "v_V", "i_A")
OPTIONAL_FLOAT_COLUMNS = ("rpm_ref", "temp_C")
OPTIONAL_INT_COLUMNS = ("load", "seq")
KNOWN_COLUMNS = REQUIRED_COLUMNS + OPTIONAL_FLOAT_COLUMNS + OPTIONAL_INT_COLUMNS

#: printf formats used by `write_log` for the known columns. The digits keep what
#: the acquisition chain resolves (10-bit ADC, 0.0625 C sensor, encoder counts)
#: with margin, so a written file reads back to the same numbers to that precision.
COLUMN_FORMATS = {
    "t_s": "%.4f",
    "duty": "%.4f",
    "v_V": "%.6f",
    "i_A": "%.6f",
    "rpm_ref": "%.3f",
    "temp_C": "%.4f",
    "load": "%d",
    "seq": "%d",
}

_INT_RE = re.compile(r"^[+-]?[0-9]+$")
_META_KEY_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")


class BenchLogError(ValueError):
    """A bench log that does not follow the format. The message names file, line, fault."""

    def __init__(self, path, line, fault):
        self.path = str(path)
        self.line = line
        self.fault = fault
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {fault}")


@dataclasses.dataclass
class BenchLog:
    """One recording: its path, its ``# key=value`` metadata and its rows."""

    path: pathlib.Path
    meta: dict
    df: pd.DataFrame

    @property
    def condition(self) -> str:
        """The ``condition`` metadata value, else the file name without extension."""
        return self.meta.get("condition") or pathlib.Path(self.path).stem

    @property
    def sample_rate_hz(self):
        """The ``sample_rate_hz`` metadata as float, or None when absent or not a number."""
        try:
            return float(self.meta["sample_rate_hz"])
        except (KeyError, ValueError):
            return None


# ----------------------------------------------------------------------------- reading


def _decode(path, raw: bytes) -> str:
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise BenchLogError(path, line, f"not UTF-8 text (byte 0x{raw[exc.start]:02x})") from None


def _first_bad(mask: np.ndarray):
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def read_log(path) -> BenchLog:
    """Read and validate a bench log; raise `BenchLogError` on any format fault."""
    path = pathlib.Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise BenchLogError(path, None, f"cannot read file: {exc.strerror or exc}") from None
    text = _decode(path, raw)
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()  # the newline that ends the last line
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    # trailing blank lines at the end of the file carry nothing; tolerate them
    while lines and lines[-1].strip() == "":
        lines.pop()
    if not lines:
        raise BenchLogError(path, 1, "empty file (no header, no rows)")

    meta: dict = {}
    i = 0
    n = len(lines)
    while i < n and (lines[i].startswith("#") or lines[i].strip() == ""):
        ln = lines[i]
        if ln.startswith("#"):
            body = ln[1:].strip()
            key, sep, value = body.partition("=")
            key = key.strip()
            if not sep or not key or not _META_KEY_RE.match(key):
                raise BenchLogError(
                    path, i + 1, f"malformed metadata line {ln!r} (expected '# key=value')"
                )
            meta[key] = value.strip()
        i += 1
    if i >= n:
        raise BenchLogError(path, n, "no header row (only metadata)")

    header_lineno = i + 1
    columns = [c.strip() for c in lines[i].split(",")]
    if any(c == "" for c in columns):
        raise BenchLogError(path, header_lineno, "header has an empty column name")
    seen = set()
    for c in columns:
        if c in seen:
            raise BenchLogError(path, header_lineno, f"duplicate column {c!r} in header")
        seen.add(c)
    missing = [c for c in REQUIRED_COLUMNS if c not in seen]
    if missing:
        raise BenchLogError(
            path, header_lineno, f"missing required column(s) {', '.join(missing)} in header"
        )

    data = lines[i + 1 :]
    first_data_lineno = header_lineno + 1
    if not data:
        raise BenchLogError(path, header_lineno, "header with no rows")

    ncomma = len(columns) - 1
    for k, ln in enumerate(data):
        if ln.count(",") != ncomma:
            lineno = first_data_lineno + k
            if ln.strip() == "":
                fault = "blank line among the rows"
            elif ln.startswith("#"):
                fault = "metadata/comment line after the header"
            else:
                fault = (
                    f"row has {ln.count(',') + 1} fields, header has {len(columns)}"
                )
            raise BenchLogError(path, lineno, fault)

    frame = pd.read_csv(
        io.StringIO("\n".join(data)),
        header=None,
        names=columns,
        dtype=str,
        keep_default_na=False,
        na_filter=False,
        skip_blank_lines=False,
        engine="c",
        quoting=3,  # csv.QUOTE_NONE: the format has no quoting
    )
    if len(frame) != len(data):  # cannot happen after the field check; never drop rows
        raise BenchLogError(path, first_data_lineno, "rows could not be parsed one to one")

    out = {}
    for col in columns:
        s = frame[col].str.strip()
        vals = s.to_numpy(dtype=object)
        empty = vals == ""
        if col in REQUIRED_COLUMNS or col in OPTIONAL_FLOAT_COLUMNS:
            num = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
            if col in REQUIRED_COLUMNS:
                bad = _first_bad(empty)
                if bad is not None:
                    raise BenchLogError(
                        path, first_data_lineno + bad, f"empty value in required column {col}"
                    )
            cand = np.isnan(num) & ~empty
            if cand.any():  # a spelled-out NaN is non-finite, anything else non-numeric
                idx = np.flatnonzero(cand)
                cand[idx] = ~_nan_text(vals[idx])
            bad_nonnum = _first_bad(cand)
            bad_nonfin = _first_bad(~np.isfinite(num) & ~empty)
            cands = [b for b in (bad_nonnum, bad_nonfin) if b is not None]
            if cands:
                b = min(cands)
                kind = "non-numeric" if b == bad_nonnum else "non-finite"
                raise BenchLogError(
                    path, first_data_lineno + b, f"{kind} value {vals[b]!r} in column {col}"
                )
            out[col] = num
        elif col in OPTIONAL_INT_COLUMNS:
            ok = s.str.fullmatch(r"[+-]?[0-9]+").to_numpy(dtype=bool)
            bad = _first_bad(~ok & ~empty)
            if bad is not None:
                raise BenchLogError(
                    path, first_data_lineno + bad, f"non-integer value {vals[bad]!r} in column {col}"
                )
            if empty.any():
                out[col] = pd.array(
                    [None if e else int(v) for v, e in zip(vals, empty)], dtype="Int64"
                )
            else:
                out[col] = s.astype(np.int64).to_numpy()
        else:
            num = pd.to_numeric(s, errors="coerce")
            if not (num.isna().to_numpy() & ~empty).any():
                out[col] = num.to_numpy(dtype=float)
            else:
                out[col] = s.to_numpy(dtype=object)

    df = pd.DataFrame(out, columns=columns)

    t = df["t_s"].to_numpy()
    if len(t) > 1:
        bad = _first_bad(np.diff(t) <= 0)
        if bad is not None:
            raise BenchLogError(
                path,
                first_data_lineno + bad + 1,
                f"t_s not strictly increasing ({float(t[bad + 1])!r} after {float(t[bad])!r})",
            )
    d = df["duty"].to_numpy()
    bad = _first_bad((d < 0) | (d > 1))
    if bad is not None:
        raise BenchLogError(path, first_data_lineno + bad, f"duty {float(d[bad])!r} outside 0..1")

    return BenchLog(path=path, meta=meta, df=df)


def _nan_text(vals: np.ndarray) -> np.ndarray:
    """Cells that spell a NaN ('nan', 'NaN'): numeric but non-finite, not 'non-numeric'."""
    return np.fromiter(
        (v.lower() in ("nan", "+nan", "-nan") for v in vals), dtype=bool, count=len(vals)
    )


# ----------------------------------------------------------------------------- writing


def _format_column(name: str, values) -> list:
    fmt = COLUMN_FORMATS.get(name)
    s = pd.Series(values)
    if fmt == "%d":
        return ["" if pd.isna(v) else "%d" % int(v) for v in s.tolist()]
    if fmt is not None or pd.api.types.is_float_dtype(s):
        fmt = fmt or "%.10g"
        return ["" if (v is None or (isinstance(v, float) and math.isnan(v))) else fmt % v
                for v in s.astype(float).tolist()]
    if pd.api.types.is_integer_dtype(s):
        return ["" if pd.isna(v) else "%d" % int(v) for v in s.tolist()]
    out = []
    for v in s.tolist():
        txt = "" if v is None or (isinstance(v, float) and math.isnan(v)) else str(v)
        if "," in txt or "\n" in txt or "\r" in txt:
            raise ValueError(f"column {name}: value {txt!r} contains a separator or newline")
        out.append(txt)
    return out


def write_log(path, df: pd.DataFrame, meta: dict | None = None) -> pathlib.Path:
    """Write ``df`` (and ``meta`` as ``# key=value`` lines) as a bench log, atomically.

    Known columns are written in the order of the format page (t_s, duty, v_V, i_A,
    rpm_ref, temp_C, load, seq), extra columns after them in ``df`` order. NaN in an
    optional column is written as an empty cell. Raises ValueError for data the format
    cannot hold (missing or non-finite required values, t_s not increasing, duty
    outside 0..1, metadata with newlines).
    """
    path = pathlib.Path(path)
    meta = dict(meta or {})
    for k, v in meta.items():
        k = str(k)
        v = str(v)
        if not _META_KEY_RE.match(k):
            raise ValueError(f"metadata key {k!r} is not a plain word")
        if "\n" in v or "\r" in v:
            raise ValueError(f"metadata value for {k!r} contains a newline")
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"missing required column(s): {', '.join(missing)}")
    if len(df) == 0:
        raise ValueError("no rows to write")
    for c in REQUIRED_COLUMNS:
        a = df[c].to_numpy(dtype=float)
        if not np.isfinite(a).all():
            raise ValueError(f"non-finite value in required column {c}")
    if len(df) > 1 and not (np.diff(df["t_s"].to_numpy(dtype=float)) > 0).all():
        raise ValueError("t_s not strictly increasing")
    duty = df["duty"].to_numpy(dtype=float)
    if ((duty < 0) | (duty > 1)).any():
        raise ValueError("duty outside 0..1")

    cols = [c for c in KNOWN_COLUMNS if c in df.columns]
    cols += [c for c in df.columns if c not in KNOWN_COLUMNS]
    for c in cols:
        if "," in str(c) or not str(c).strip():
            raise ValueError(f"bad column name {c!r}")
    formatted = [_format_column(c, df[c]) for c in cols]

    parts = [f"# {k}={v}\n" for k, v in meta.items()]
    parts.append(",".join(str(c) for c in cols) + "\n")
    body = "\n".join(",".join(row) for row in zip(*formatted))
    parts.append(body + "\n")
    text = "".join(parts)

    return write_text_atomic(path, text)


def write_text_atomic(path, text: str) -> pathlib.Path:
    """Writes text (UTF-8, LF) to a temporary file beside path, then renames it over path,
    so a reader sees the old file or the whole new one, never a part."""
    path = pathlib.Path(path)
    directory = path.parent if str(path.parent) else pathlib.Path(".")
    directory.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path
