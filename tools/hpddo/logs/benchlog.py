"""Reader and writer for the bench log format, specified in docs/bench-log.md.

A bench log is UTF-8 CSV text::

    # condition=sweep
    # sample_rate_hz=2
    t_s,duty,v_V,i_A,rpm_ref,temp_C,load
    0.0,0.000,0.012,0.003,0.0,31.7,0

`read_log` accepts every file that follows docs/bench-log.md and refuses any other with
a `BenchLogError` whose message names the file, the 1-based line number in the file
and the fault (``.line``, ``.kind`` the fault keyword of the specification). It never
drops a row. The C++ reader host/bench_log.h follows the same page; the conformance
corpus test/fixtures/logs/ and a differential fuzz test keep the two in agreement.

Conventions of the returned `BenchLog`:

* ``df``: all columns of the file, in file order; extra columns are kept too
  (float where every non-empty cell is a number, text otherwise);
* an optional column that is absent from the file is absent from ``df``
  (it is *not* added as an all-NaN column);
* required columns ``t_s, duty, v_V, i_A`` are float64 and always finite;
* ``rpm_ref`` and ``temp_C`` are float64, an empty cell is NaN;
* ``load`` and ``seq`` are int64 (the format has no empty cell there);
* ``lines``: int64 array, the 1-based file line of each row of ``df``.

`write_log` writes only files the format accepts, atomically (temporary file in the
same directory, then ``os.replace``), so a reader never sees a partial file.
"""
from __future__ import annotations

import dataclasses
import json
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
    "INT_MAX",
    "FAULTS",
    "NUMBER_RE",
    "INTEGER_RE",
    "read_log",
    "write_log",
    "write_text_atomic",
]

REQUIRED_COLUMNS = ("t_s", "duty", "v_V", "i_A")
OPTIONAL_FLOAT_COLUMNS = ("rpm_ref", "temp_C")
OPTIONAL_INT_COLUMNS = ("load", "seq")
KNOWN_COLUMNS = REQUIRED_COLUMNS + OPTIONAL_FLOAT_COLUMNS + OPTIONAL_INT_COLUMNS

#: Largest value of each integer column (docs/bench-log.md, Integers).
INT_MAX = {"load": 255, "seq": 2**53 - 1}

#: Fault keywords of docs/bench-log.md, in the order a line is checked.
FAULTS = (
    "not UTF-8", "empty file", "carriage return", "blank line", "malformed metadata",
    "duplicate metadata key", "no header", "empty column name", "duplicate column",
    "missing required column", "no rows", "metadata after header", "field count",
    "empty value", "non-finite", "non-numeric", "non-integer", "out of range",
    "t_s not increasing", "duty outside 0..1",
)

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

_PAD = " \t"  # the only padding the format knows
_META_KEY_RE = re.compile(r"[A-Za-z0-9_.\-]+")
_META_RE = re.compile(r"#[ \t]*([^=]*?)[ \t]*=(.*)", re.S)
#: The number grammar of docs/bench-log.md (to be used with fullmatch, on a cell without padding).
NUMBER_RE = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
#: The integer grammar of docs/bench-log.md (load, seq): digits only.
INTEGER_RE = r"[0-9]+"
_NUMBER_RE = NUMBER_RE
_NONFINITE_RE = r"[+-]?(?:[iI][nN][fF](?:[iI][nN][iI][tT][yY])?|[nN][aA][nN])"
_NUMBER_CHARS = frozenset("0123456789+-.eE")
_DIGITS = frozenset("0123456789")
_DBL_MIN = 2.2250738585072014e-308


class BenchLogError(ValueError):
    """A bench log that does not follow the format. The message names file, line, fault."""

    def __init__(self, path, line, fault, kind=None):
        self.path = str(path)
        self.line = line
        self.fault = fault
        self.kind = kind  # the fault keyword of docs/bench-log.md, None for other errors
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {fault}")


class _Fault(Exception):
    """A format fault found while parsing: its line, keyword and message."""

    def __init__(self, line, kind, message):
        super().__init__(message)
        self.line, self.kind, self.message = line, kind, message


@dataclasses.dataclass
class BenchLog:
    """One recording: its path, its ``# key=value`` metadata, its rows and their file lines."""

    path: pathlib.Path
    meta: dict
    df: pd.DataFrame
    lines: np.ndarray = None  # 1-based file line of each row of df

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


#: The reader takes a file this many bytes at a time (cut at a line end): its memory is the
#: rows' values (8 bytes a cell) and one chunk's text and cells, not the whole file's, and
#: a fault is refused when its chunk is read, not after the whole file.
CHUNK_BYTES = 1 << 20
_BOM = b"\xef\xbb\xbf"


def read_log(path) -> BenchLog:
    """Read and validate a bench log; raise `BenchLogError` on any format fault."""
    path = pathlib.Path(path)
    try:
        with open(path, "rb") as fh:
            meta, df, lines = _parse_stream(_blocks(fh))
    except OSError as exc:
        raise BenchLogError(path, None, f"cannot read file: {exc.strerror or exc}") from None
    except _Fault as f:
        raise BenchLogError(path, f.line, f.message, f.kind) from None
    return BenchLog(path=path, meta=meta, df=df, lines=lines)


def _blocks(fh, size: int | None = None):
    """The bytes of a binary file in blocks of about size bytes (default CHUNK_BYTES), each cut
    after a LF (so no line, no CR LF and no UTF-8 sequence is split; the last block: the rest of
    the file)."""
    size = size or CHUNK_BYTES
    rest = b""
    while True:
        b = fh.read(size)
        if not b:
            if rest:
                yield rest
            return
        k = b.rfind(b"\n")
        if k < 0:
            rest += b
            continue
        yield rest + b[:k + 1]
        rest = b[k + 1:]


def _parse_bytes(raw: bytes):
    """Parses the bytes of a bench log into (meta, df, lines); raises _Fault on a format fault."""
    import io
    return _parse_stream(_blocks(io.BytesIO(raw)))


class _Text:
    """The lines of a stream of blocks (_blocks), decoded block by block: the BOM dropped, CR LF
    read as LF, the first stray CR of the block noted (cr_line), file lines counted from 1."""

    def __init__(self, blocks):
        self.blocks = iter(blocks)
        self.line = 1  # file line of the next block's first line
        self.bom = False
        self.crlf = False
        self.started = False

    def next(self):
        """(lines, file line of lines[0], cr_line or None) of the next block, None at the end."""
        block = next(self.blocks, None)
        if block is None:
            return None
        if not self.started:
            self.started = True
            self.bom = block[:3] == _BOM
            if self.bom:
                block = block[3:]
        text = self._decode(block)
        cr_line = None
        if "\r" in text:
            self.crlf = self.crlf or "\r\n" in text
            text = text.replace("\r\n", "\n")
            k = text.find("\r")
            if k >= 0:
                cr_line = self.line + text.count("\n", 0, k)
        lines = text.split("\n")
        if lines[-1] == "":
            lines.pop()  # the line end of the block's last line
        first = self.line
        self.line += len(lines)
        return lines, first, cr_line

    def _decode(self, block: bytes) -> str:
        try:
            return block.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = self.line + block.count(b"\n", 0, exc.start)
            raise _Fault(line, "not UTF-8", f"not UTF-8 text (byte 0x{block[exc.start]:02x})") from None

    def check_rest(self) -> None:
        """The encoding is checked over the whole file first (docs/bench-log.md, Faults): before a
        format fault is raised, the blocks not yet read are decoded (and dropped)."""
        for block in self.blocks:
            self._decode(block)
            self.line += block.count(b"\n")


def _parse_stream(blocks):
    """(meta, df, lines) of a bench log given as blocks of bytes (_blocks); raises _Fault on the
    file's first format fault as soon as the block that holds it is read."""
    text = _Text(blocks)
    try:
        return _parse_text(text)
    except _Fault as f:
        if f.kind != "not UTF-8":
            text.check_rest()
        raise


def _fault(cr_line, line, kind, message):
    """Raises the fault on line, or the stray CR's where it comes first (on or before line)."""
    if cr_line is not None and cr_line <= line:
        raise _Fault(cr_line, "carriage return", "carriage return inside a line (only CR LF ends a line)")
    raise _Fault(line, kind, message)


def _parse_text(text: _Text):
    got = text.next()
    if got is None or not got[0]:  # (a block before the last has a line: it ends with LF)
        raise _Fault(1, "empty file", "empty file")
    lines, _, cr_line = got
    meta: dict = {}
    i = 0
    while True:  # the metadata, then the header (a block at a time: the metadata may be long)
        while i >= len(lines):
            more = text.next()
            if more is None:
                _fault(cr_line, max(len(lines), 1), "no header", "no header row after the metadata")
            lines += more[0]
            cr_line = cr_line if cr_line is not None else more[2]
        ln = lines[i]
        if not ln.strip(_PAD):
            _fault(cr_line, i + 1, "blank line", "blank line")
        if not ln.startswith("#"):
            break
        kv = parse_meta_line(ln)
        if kv is None:
            _fault(cr_line, i + 1, "malformed metadata",
                   f"malformed metadata line {ln!r} (expected '# key=value', key of A-Z a-z 0-9 _ . -)")
        key = kv[0]
        if key in meta:
            _fault(cr_line, i + 1, "duplicate metadata key", f"duplicate metadata key {key!r}")
        meta[key] = kv[1]
        i += 1

    hline = i + 1
    data = lines[i + 1:]
    first = hline + 1  # file line of data[0]
    if not data:  # the rows may begin in the next block
        more = text.next()
        if more is not None:
            data = more[0]
            cr_line = cr_line if cr_line is not None else more[2]
    problem = header_fault(lines[i], data[0] if data else None, text.bom, text.crlf)
    if problem is not None:
        _fault(cr_line, hline, *problem)
    columns = [c.strip(_PAD) for c in lines[i].split(",")]
    if not data:
        _fault(cr_line, hline, "no rows", "header with no rows")
    del lines

    parts = {c: [] for c in columns}
    prev = None  # (value, text) of the last t_s read
    nrows = 0
    while True:
        out, prev = _parse_rows(columns, data, first, cr_line, prev)
        for c, x in out.items():
            parts[c].append(x)
        nrows += len(data)
        more = text.next()
        if more is None:
            break
        data, first, cr_line = more
    out = {}
    for c in columns:
        x = parts.pop(c)
        x = x[0] if len(x) == 1 else np.concatenate(x)
        out[c] = _extra(x) if c not in KNOWN_COLUMNS else x
        del x
    df = pd.DataFrame(out, columns=columns, copy=False)
    return meta, df, np.arange(hline + 1, hline + 1 + nrows, dtype=np.int64)


def _parse_rows(columns, data, first, cr_line, prev):
    """The values of the row lines data (data[0] on file line first) under columns: ({column:
    values}, (value, text) of the last t_s); extra columns as their text. Raises _Fault on the
    first fault among them (a stray CR on cr_line counted); prev: the last t_s before them."""
    # Structure of the row lines: the first line that is blank, metadata or of the wrong
    # field count ends what the cells are read from (a cell fault before it comes first).
    ncomma = len(columns) - 1
    counts = np.fromiter((ln.count(",") for ln in data), dtype=np.int64, count=len(data))
    bad_row = _first(counts != ncomma)
    hash_row = _first_hash_row(data)
    if hash_row is not None and (bad_row is None or hash_row < bad_row):
        bad_row = hash_row
    struct = None
    if bad_row is not None:
        ln = data[bad_row]
        if not ln.strip(_PAD):
            struct = ("blank line", "blank line")
        elif ln.startswith("#"):
            struct = ("metadata after header", f"metadata after header: {ln!r}")
        else:
            n = ln.count(",") + 1
            hint = ("; decimal commas? (numbers are written with '.', docs/bench-log.md)"
                    if n > len(columns) and '"' in ln and re.search(r"\d,\d", ln) else "")
            struct = ("field count", f"field count: row has {n} fields, header has {len(columns)}{hint}")
        data = data[:bad_row]
    if cr_line is not None and cr_line - first < len(data):
        data = data[:max(cr_line - first, 0)]

    nrows = len(data)
    joined = ",".join(data)
    if nrows:  # every row has len(columns) fields: one split, one reshape
        cells = np.array(joined.split(","), dtype=object).reshape(nrows, len(columns))
    else:
        cells = np.empty((0, len(columns)), dtype=object)
    padded = " " in joined or "\t" in joined
    del joined

    out = {}
    best = None  # (row, column index, kind, message) of the first cell fault
    for j, col in enumerate(columns):
        vals = cells[:, j]
        if padded:
            vals = pd.Series(vals, dtype=object).str.strip(_PAD).to_numpy(dtype=object)
        if col in REQUIRED_COLUMNS or col in OPTIONAL_FLOAT_COLUMNS:
            x, bad = _parse_numbers(vals, col, required=col in REQUIRED_COLUMNS)
            if col == "t_s" and nrows:
                inc = np.zeros(nrows, bool)
                inc[1:] = ~(x[1:] > x[:-1])
                if prev is not None:
                    inc[0] = not x[0] > prev[0]
                bad = _merge(bad, inc, "t_s not increasing",
                             lambda r: f"t_s not increasing: {vals[r]} after {vals[r - 1] if r else prev[1]}")
                t_last = (x[-1], vals[-1])
            elif col == "duty":
                bad = _merge(bad, (x < 0) | (x > 1), "duty outside 0..1",
                             lambda r: f"duty outside 0..1: {vals[r]}")
            out[col] = x
        elif col in OPTIONAL_INT_COLUMNS:
            x, bad = _parse_ints(vals, col)
            out[col] = x
        else:
            out[col] = vals  # text; read_log makes it numbers where the whole column is
            bad = None
        if bad is not None and (best is None or bad[0] < best[0]):
            best = (bad[0], j, bad[1], bad[2])
    if best is not None:
        _fault(cr_line, first + best[0], best[2], best[3])
    if struct is not None:
        _fault(cr_line, first + bad_row, *struct)
    if cr_line is not None:
        _fault(cr_line, cr_line, "", "")
    return out, (t_last if nrows else prev)


def parse_meta_line(line: str):
    """(key, value) of a '# key=value' metadata line, None when it is not one."""
    m = _META_RE.fullmatch(line)
    if m is None or not _META_KEY_RE.fullmatch(m.group(1)):
        return None
    return m.group(1), m.group(2).strip(_PAD)


def header_fault(line: str, row: str | None = None, bom: bool = False, crlf: bool = False):
    """(fault keyword, message) of a header line that the format refuses, else None. row: the
    line after it, if any, bom and crlf: whether the file started with a BOM and has CR LF line
    ends (they name a spreadsheet's export in the message where the header is refused)."""
    seen = set()
    for c in (c.strip(_PAD) for c in line.split(",")):
        if c == "":
            return "empty column name", "empty column name in header"
        if c in seen:
            return "duplicate column", f"duplicate column {c!r} in header"
        seen.add(c)
    missing = [c for c in REQUIRED_COLUMNS if c not in seen]
    if missing:
        return "missing required column", (f"missing required column(s) {', '.join(missing)} in header"
                                           + _export_hint(line, row, bom, crlf))
    return None


#: Separators a spreadsheet writes instead of the format's ',' (name of each, for the message).
_OTHER_SEPARATORS = ((";", "semicolons"), ("\t", "tabs"), ("|", "bars"))


def _export_hint(header: str, row: str | None = None, bom: bool = False, crlf: bool = False) -> str:
    """What a spreadsheet's export did to a header whose required columns are all there in
    another dress, each named with its fix: another separator (and with it, often, decimal
    commas in the row after it), quotes around the names, names in another case. "" where the
    required columns are not there in any dress (a header that really lacks them)."""
    sep, sep_name = ",", None
    for s, name in _OTHER_SEPARATORS:
        if s in header and len(header.split(s)) > len(header.split(",")):
            sep, sep_name = s, name
            break
    cells = [c.strip(_PAD) for c in header.split(sep)]
    quoted = any(c[:1] in "\"'" for c in cells)
    bare = [c.strip("\"'").strip(_PAD) for c in cells]
    by_lower = {}
    for c in bare:
        by_lower.setdefault(c.lower(), c)
    if not all(c.lower() in by_lower for c in REQUIRED_COLUMNS):
        return ""
    want = [c for c in REQUIRED_COLUMNS if c not in bare]
    other_case = [by_lower[c.lower()] for c in want]
    faults, fixes = [], []
    if sep_name:
        faults.append(f"the columns are separated by {sep_name}")
        comma = None if row is None else next((c.strip(_PAD + "\"'") for c in row.split(sep)
                                               if re.search(r"\d,\d", c)), None)
        if comma is not None:
            faults.append(f"the numbers have decimal commas ({comma!r} on the next line)")
        fixes.append("export the file as CSV with ',' between columns and '.' in numbers (a spreadsheet set to a "
                     "locale with decimal commas writes ';' and '0,5')")
    if quoted:
        faults.append("the column names are in quotes")
        fixes.append("write the names bare")
    if other_case:
        faults.append(f"column(s) {', '.join(want)} are there in another case, as {', '.join(other_case)} "
                      "(names are case-sensitive)")
        fixes.append(f"rename {', '.join(other_case)} to {', '.join(want)}")
    if not faults:
        return ""
    export = [w for w, on in (("a UTF-8 byte order mark", bom), ("CR LF line ends", crlf)) if on]
    if export:
        faults.append(f"(its {' and '.join(export)} the format accepts)")
    return f": {'; '.join(faults)}; fix: {'; '.join(fixes)} (docs/bench-log.md)"


def parse_row(header: str, row: str) -> dict:
    """The values of one data row under its header, read with the reader's own rules (for
    tools that check rows one by one as they arrive); raises BenchLogError whose fault
    names what is wrong (its line: 2, the row's line in that two-line log)."""
    try:
        _, df, _ = _parse_bytes(f"{header}\n{row}\n".encode("utf-8"))
    except _Fault as f:
        raise BenchLogError("<row>", f.line, f.message, f.kind) from None
    return {c: df[c].iloc[0] for c in df.columns}


def _first(mask):
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def _first_hash_row(data):
    """Index of the first row line that starts with '#', or None."""
    body = "\n" + "\n".join(data)
    k = body.find("\n#")
    return None if k < 0 else body.count("\n", 0, k + 1) - 1


def _merge(bad, mask, kind, message):
    """The earlier of a cell fault so far (row, kind, message) and the first row of mask."""
    r = _first(mask)
    if r is None or (bad is not None and bad[0] <= r):
        return bad
    return (r, kind, message(r))


def _cells_off(vals, chars):
    """True when some cell has a character outside chars (or is empty)."""
    return not set("".join(vals)) <= chars


def _parse_numbers(vals, col, required):
    """Float values of a number column and its first cell fault (row, kind, message) or None."""
    nrows = len(vals)
    empty = vals == ""
    has_empty = bool(empty.any())
    x = np.full(nrows, np.nan)
    bad = None
    fast = not _cells_off(vals, _NUMBER_CHARS)
    if fast:
        try:
            if has_empty:
                x[~empty] = vals[~empty].astype(np.float64)
            else:
                x = vals.astype(np.float64)
        except ValueError:
            fast = False
    if not fast:  # some cell is off the grammar: find it, cell by cell but in C loops
        s = pd.Series(vals, dtype=object)
        ok = s.str.fullmatch(_NUMBER_RE).to_numpy(dtype=bool)
        nonfin = s.str.fullmatch(_NONFINITE_RE).to_numpy(dtype=bool)
        x = np.full(nrows, np.nan)
        x[ok] = vals[ok].astype(np.float64)
        bad = _merge(bad, nonfin, "non-finite",
                     lambda r: f"non-finite value {vals[r]!r} in column {col}")
        bad = _merge(bad, ~ok & ~empty & ~nonfin, "non-numeric",
                     lambda r: f"non-numeric value {vals[r]!r} in column {col}")
    if required and has_empty:
        bad = _merge(bad, empty, "empty value", lambda r: f"empty value in required column {col}")
    ax = np.abs(x)
    oor = np.isinf(x) | ((ax < _DBL_MIN) & (ax > 0))
    zero = np.flatnonzero(x == 0)
    if zero.size:
        nonzero_text = pd.Series(vals[zero], dtype=object).str.contains(r"^[^eE]*[1-9]").to_numpy(dtype=bool)
        oor[zero[nonzero_text]] = True
    bad = _merge(bad, oor, "out of range", lambda r: f"out of range value {vals[r]!r} in column {col}")
    return x, bad


def _parse_ints(vals, col):
    """int64 values of an integer column and its first cell fault (row, kind, message) or None."""
    nrows = len(vals)
    bad = None
    if _cells_off(vals, _DIGITS) or (vals == "").any():
        s = pd.Series(vals, dtype=object)
        ok = s.str.fullmatch(INTEGER_RE).to_numpy(dtype=bool)
        empty = vals == ""
        bad = _merge(bad, empty, "empty value", lambda r: f"empty value in column {col}")
        bad = _merge(bad, ~ok & ~empty, "non-integer",
                     lambda r: f"non-integer value {vals[r]!r} in column {col} (digits only)")
        vals = np.where(ok, vals, "0")
    # digits only: a double is exact up to 2^53, and any larger decimal rounds to >= 2^53
    x = vals.astype(np.float64) if nrows else np.zeros(0)
    big = x > INT_MAX[col]
    bad = _merge(bad, big, "out of range",
                 lambda r: f"out of range value {vals[r]!r} in column {col} (0..{INT_MAX[col]})")
    x[big] = 0
    return x.astype(np.int64), bad


def _extra(vals):
    """An extra column: float where every non-empty cell is a number, text otherwise."""
    s = pd.Series(vals, dtype=object)
    nonempty = vals != ""
    if s[nonempty].str.fullmatch(_NUMBER_RE).all():
        x = np.full(len(vals), np.nan)
        x[nonempty] = vals[nonempty].astype(np.float64)
        return x
    return vals


# ----------------------------------------------------------------------------- writing


#: write_log's format of a float column written exactly (exact=True): the shortest text that reads back as the same
#: double (Python's repr), so a copy of a log holds the numbers it was read with
EXACT = "repr"


def _format_column(name: str, values, fmt: str | None = None) -> list:
    fmt = fmt or COLUMN_FORMATS.get(name)
    s = pd.Series(values)
    if fmt == "%d":
        return ["" if pd.isna(v) else "%d" % int(v) for v in s.tolist()]
    if fmt is not None or pd.api.types.is_float_dtype(s):
        if fmt == EXACT:
            return ["" if math.isnan(v) else repr(v) for v in s.astype(float).tolist()]
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


def _time_format(t) -> str:
    """The format of t_s: COLUMN_FORMATS' decimals, or as many more as keep a strictly increasing t_s strictly
    increasing once written (a log faster than 10 kHz); ValueError where none up to 17 does."""
    t = np.asarray(t, float)
    for dec in range(4, 18):
        fmt = f"%.{dec}f"
        if len(t) < 2 or (np.diff(np.array([float(fmt % v) for v in t.tolist()])) > 0).all():
            return fmt
    raise ValueError("t_s not strictly increasing once written with 17 decimals")


def write_log(path, df: pd.DataFrame, meta: dict | None = None, exact: bool = False) -> pathlib.Path:
    """Write ``df`` (and ``meta`` as ``# key=value`` lines) as a bench log, atomically.

    Known columns are written in the order of docs/bench-log.md (t_s, duty, v_V, i_A,
    rpm_ref, temp_C, load, seq), extra columns after them in ``df`` order, each float column
    with its COLUMN_FORMATS (t_s with more decimals where a fast log needs them: _time_format),
    or, with ``exact``, as the shortest text of the same double (a copy of a log read in, which
    must hold the numbers it was read with: 1e-6 A is no 0.000001 rounded). NaN in
    rpm_ref, temp_C or an extra column is written as an empty cell. Raises ValueError
    for data the format cannot hold (missing or non-finite required values, t_s not
    increasing once written, duty outside 0..1, infinite rpm_ref/temp_C, missing,
    fractional or out-of-range load/seq, metadata with line ends, bad column names);
    the text is read back before it is written, so only files the format accepts are
    written.
    """
    path = pathlib.Path(path)
    meta = {str(k): str(v) for k, v in (meta or {}).items()}
    if len(meta) != len(meta or {}):
        raise ValueError("two metadata keys are the same text")
    for k, v in meta.items():
        if not _META_KEY_RE.fullmatch(k):
            raise ValueError(f"metadata key {k!r} is not of A-Z a-z 0-9 _ . -")
        if "\n" in v or "\r" in v:
            raise ValueError(f"metadata value for {k!r} contains a line end")
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
    for c in OPTIONAL_FLOAT_COLUMNS:
        if c in df.columns and np.isinf(df[c].to_numpy(dtype=float)).any():
            raise ValueError(f"infinite value in column {c} (NaN, written empty, means not measured)")
    for c in OPTIONAL_INT_COLUMNS:
        if c in df.columns:
            if df[c].isna().any():
                raise ValueError(f"missing value in column {c} (the format has no empty {c} cell)")
            a = df[c].to_numpy(dtype=float)
            if not ((a == np.round(a)) & (a >= 0) & (a <= INT_MAX[c])).all():
                raise ValueError(f"column {c} holds a value that is not an integer in 0..{INT_MAX[c]}")

    cols = [c for c in KNOWN_COLUMNS if c in df.columns]
    cols += [c for c in df.columns if c not in KNOWN_COLUMNS]
    names = [str(c) for c in cols]
    for c in names:
        if (not c.strip(_PAD) or c != c.strip(_PAD) or any(ch in c for ch in ",\n\r")):
            raise ValueError(f"bad column name {c!r}")
    if len(set(names)) != len(names):
        raise ValueError("two columns have the same name")
    head = "".join(f"# {k}={v}\n" for k, v in meta.items()) + ",".join(names) + "\n"
    fmts = {c: (EXACT if exact and COLUMN_FORMATS.get(c) != "%d" and (c in COLUMN_FORMATS or
                                                                       pd.api.types.is_float_dtype(df[c]))
                else None) for c in cols}
    if not exact:
        fmts["t_s"] = _time_format(df["t_s"].to_numpy(float))
    chunks = [(a, min(a + WRITE_CHUNK_ROWS, len(df))) for a in range(0, len(df), WRITE_CHUNK_ROWS)]
    # the first chunk is formatted and read back before the file is opened (a refusal of small
    # data costs no file); each chunk is read back, after the last row of the one before it (t_s
    # increasing across the cut), before it is written: what is written reads back
    first_text = _checked_chunk(df, cols, head, *chunks[0], head.count("\n"), None, fmts)

    def write(fh):
        fh.write(head.encode("utf-8"))
        fh.write(first_text[0].encode("utf-8"))
        last = first_text[1]
        for a, b in chunks[1:]:
            text, last = _checked_chunk(df, cols, head, a, b, head.count("\n") + a, last, fmts)
            fh.write(text.encode("utf-8"))

    return write_bytes_atomic(path, write)


#: write_log formats and checks this many rows at a time (its memory: a chunk's text).
WRITE_CHUNK_ROWS = 100_000


def _checked_chunk(df, cols, head: str, a: int, b: int, line0: int, last: str | None, fmts=None):
    """The text of rows a..b of df (their file lines from line0 + 1) and its last line, read
    back as a bench log (after the last line of the chunk before, if any); a ValueError naming
    the file line where the text would not be a valid bench log."""
    formatted = [_format_column(c, df[c].iloc[a:b], (fmts or {}).get(c)) for c in cols]
    rows = [",".join(row) for row in zip(*formatted)]
    del formatted
    text = "\n".join(rows) + "\n"
    if last is None:
        check, shift = head + text, 0
    else:
        check = head.splitlines()[-1] + "\n" + last + "\n" + text
        shift = line0 - 1 - 1  # line 2 of check is file line line0 (the last row of the chunk before)
    try:
        _parse_bytes(check.encode("utf-8"))
    except _Fault as f:
        raise ValueError(f"the text would not be a valid bench log (line {f.line + shift}: {f.message})") from None
    return text, rows[-1]


def finite_json(obj):
    """obj with every float that is not finite (NaN, +-inf: a standard error of an effect the rows
    do not excite, an RMSE without encoder rows) as None, and numpy's scalars and arrays as
    Python's: what json_text writes."""
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite_json(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_text(obj, **kw) -> str:
    """obj as the text of a JSON file the tools write (RFC 8259: no NaN or Infinity, which a
    browser's JSON.parse and most readers refuse): every number that is not finite written as
    null (finite_json), and a newline at the end. kw: json.dumps' (indent, sort_keys, default)."""
    return json.dumps(finite_json(obj), allow_nan=False, **kw) + "\n"


def write_text_atomic(path, text: str) -> pathlib.Path:
    """Writes text (UTF-8, LF) to a temporary file beside path, then renames it over path,
    so a reader sees the old file or the whole new one, never a part."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path, data, opener=None) -> pathlib.Path:
    """Writes data to a temporary file beside path (flushed and fsynced, mode 0644), then
    renames it over path, so a reader sees the old file or the whole new one, never a part;
    on any failure the temporary file is removed and path is untouched. data: bytes, or a
    function that writes into the open binary file it is given (to stream a large source).
    opener(temporary path) opens the temporary file for writing (default: the file
    tempfile made)."""
    path = pathlib.Path(path)
    directory = path.parent if str(path.parent) else pathlib.Path(".")
    directory.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        if opener is None:
            fh = os.fdopen(fd, "wb")
        else:
            os.close(fd)
            fh = opener(tmp)
        with fh:
            if callable(data):
                data(fh)
            else:
                fh.write(data)
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
