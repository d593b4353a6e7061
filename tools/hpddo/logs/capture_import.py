"""Current-only captures into the burst format (issue 33, docs/ripple-captures.md): a
recording of the armature current at any rate from a scope or DAQ (CSV), a sound card (WAV)
or MATLAB (.mat), cut into contiguous windows and written as a `<name>.ripple.csv`
(hpddo.logs.ripple) that `hpddo ripple` counts without a bench log.

Read with kept readers: pandas (CSV), scipy.io.wavfile (WAV), scipy.io.loadmat (.mat).
The values become integer codes: integer data (a WAV's PCM, a DAQ's raw codes) as they are,
one code per unit; other data at their own step (the smallest difference between two of
their distinct values: an instrument's LSB), or at 2^-24 of their span where that step is
finer (float data), so the quantisation adds nothing a current probe could show. Then

    current (A) = (value - offset) x a_per_unit = (code - offset_code) x a_per_code

with a_per_code = a_per_unit x step and offset_code = offset / step. Every fault is a
CaptureError (an InputError) naming the file, the line or variable, and what is wrong.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import pathlib

import numpy as np

from . import ripple as rf
from .errors import InputError

KINDS = {".csv": "csv", ".txt": "csv", ".wav": "wav", ".mat": "mat"}
#: a .mat variable holding the sample rate (Hz), where the file carries one
MAT_RATE_NAMES = ("sample_hz", "fs", "Fs", "FS", "sample_rate", "SampleRate", "samplerate")
FLOAT_STEPS = 2 ** 24  # float data are quantised at their span / this (far under any probe's resolution)
CODE_RANGE = 2.0 ** 52  # the largest |code|: a double holds every integer up to it, and int64 does
MIN_SAMPLES = 16       # a capture shorter than this holds no window the count could use
UNIFORM_TOL = 0.25     # a time further than this share of a sample from the uniform grid is refused


class CaptureError(InputError):
    """A capture that cannot be imported: file, line or variable, and the fault."""


@dataclasses.dataclass
class Capture:
    """One channel of a capture: its values (file units), sample rate, start time and what it said."""

    values: np.ndarray
    sample_hz: float
    t0_s: float
    integer: bool           # the values are integer codes (one code per unit)
    source: str             # what was read: column, channel or variable
    rate_from: str          # where the sample rate came from


def kind_of(path, given: str | None = None) -> str:
    if given:
        return given
    kind = KINDS.get(pathlib.Path(path).suffix.lower())
    if kind is None:
        raise CaptureError(f"{path}: unknown capture type {pathlib.Path(path).suffix!r}: give --format "
                           f"({', '.join(sorted(set(KINDS.values())))})")
    return kind


def _rate(path, file_hz, given_hz, what: str):
    """The sample rate: the command line's, or the file's; both where they agree (0.1 %)."""
    if given_hz is not None and file_hz is not None and abs(given_hz / file_hz - 1) > 1e-3:
        raise CaptureError(f"{path}: --sample-hz {given_hz:g} but {what} gives {file_hz:g} Hz")
    hz = given_hz if given_hz is not None else file_hz
    if hz is None:
        raise CaptureError(f"{path}: the file does not carry its sample rate: give --sample-hz HZ")
    if not (math.isfinite(hz) and hz > 0):
        raise CaptureError(f"{path}: sample rate {hz:g} Hz from {what}: must be a finite number > 0")
    return float(hz), ("--sample-hz" if given_hz is not None else what)


def _pick(path, names: list, want, what: str) -> int:
    """The index of the column / channel `want` (a name or a 0-based index) among names."""
    if want is None:
        return -1
    if want in names:
        return names.index(want)
    try:
        j = int(want)
    except ValueError:
        raise CaptureError(f"{path}: no {what} {want!r} (there are: {', '.join(map(str, names))})") from None
    if not 0 <= j < len(names):
        raise CaptureError(f"{path}: {what} {j} out of range (0..{len(names) - 1})")
    return j


#: a time column's unit where its name states one (a suffix "_ms", "(ms)", "[ms]", " ms", case aside): seconds per
#: unit; a name that states none is in seconds (a scope's "time_ms" was read as seconds, its 20 kS/s as 20 S/s)
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "\u00b5s": 1e-6, "ns": 1e-9}


def time_unit(name: str) -> tuple[float, str]:
    """(seconds per unit, the unit) of a time column from its name (TIME_UNITS), (1, "s") where it states none."""
    import re

    m = re.search(r"(?:[_\s(\[])(s|ms|us|\u00b5s|ns)[)\]]?\s*$", name.strip().lower())
    return (TIME_UNITS[m.group(1)], m.group(1)) if m else (1.0, "s")


def read_csv(path, column=None, time_column=None, sample_hz=None, skip_rows: int = 0) -> Capture:
    """A scope's or DAQ's CSV: a header row of names (or none), numeric rows; the current in
    `column` (name or 0-based index; default: the only column, or the second of two whose first
    is a time column), the time in `time_column` (uniform; in seconds, or in the unit its name states: time_unit;
    default: the first of two)."""
    import pandas as pd

    try:
        raw = pd.read_csv(path, header=None, dtype=str, keep_default_na=False, skiprows=skip_rows,
                          skip_blank_lines=False, sep=_delimiter(path, skip_rows), engine="c")
    except (OSError, UnicodeDecodeError) as exc:
        raise CaptureError(f"{path}: cannot read: {exc}") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError, IndexError) as exc:
        raise CaptureError(f"{path}: not a CSV table: {' '.join(str(exc).split())}") from None
    if raw.empty:
        raise CaptureError(f"{path}: no rows")
    first = skip_rows + 1  # the file line of raw's first row (blank lines kept, so row k is line first + k)
    cells = raw.fillna("").apply(lambda c: c.str.strip())
    filled = (cells != "").any(axis=1).to_numpy()
    if not filled.any():
        raise CaptureError(f"{path}: no rows")
    cells = cells.iloc[: int(np.flatnonzero(filled)[-1]) + 1]  # blank lines at the end are no rows
    header = not all(_is_number(v) for v in cells.iloc[0])
    names = [str(v) for v in cells.iloc[0]] if header else [str(j) for j in range(cells.shape[1])]
    body = cells.iloc[1:] if header else cells
    line0 = first + (1 if header else 0)
    if body.empty:
        raise CaptureError(f"{path}: a header and no rows")
    j = _pick(path, names, column, "column")
    t = _pick(path, names, time_column, "column")
    if j < 0:
        if len(names) == 1:
            j = 0
        elif len(names) == 2:
            j = 1
            t = 0 if t < 0 else t
        else:
            raise CaptureError(f"{path}: {len(names)} columns ({', '.join(names)}): give --column NAME|INDEX "
                               "(and --time-column for the time)")
    x = _numbers(path, body.iloc[:, j], line0, names[j])
    rate, t0, rate_from = None, 0.0, None
    if t >= 0 and t != j:
        per, unit = time_unit(names[t])
        ts = _numbers(path, body.iloc[:, t], line0, names[t]) * per
        d = np.diff(ts)
        if len(d):
            bad = np.flatnonzero(~(d > 0))
            if bad.size:
                raise CaptureError(f"{path}:{line0 + bad[0] + 1}: time column {names[t]!r} not increasing")
            step = float(ts[-1] - ts[0]) / (len(ts) - 1)
            # each time within UNIFORM_TOL of a step of the uniform grid (a time printed with few digits
            # rounds by less; a gap, a missed sample or a resampled capture does not)
            off = np.flatnonzero(np.abs(ts - ts[0] - step * np.arange(len(ts))) > UNIFORM_TOL * step)
            if off.size:
                k = int(off[0])
                raise CaptureError(f"{path}:{line0 + k}: time column {names[t]!r} not uniform: {ts[k]:.9g} s where "
                                   f"{ts[0] + step * k:.9g} s is expected ({step:.6g} s a sample over the capture): "
                                   "a gap, a missed sample or a resampled capture")
            rate, rate_from = 1.0 / step, f"its time column {names[t]!r}" + (f", in {unit} by its name" if unit != "s"
                                                                                 else "")
        t0 = float(ts[0])
    hz, rate_from = _rate(path, rate, sample_hz, rate_from or "the file")
    return Capture(x, hz, t0, bool(np.all(x == np.round(x))), f"column {names[j]!r}", rate_from)


def _delimiter(path, skip_rows: int) -> str:
    """The CSV's field separator from its first line after skip_rows: a comma, a semicolon or a tab
    where the line holds one (in that order), else runs of blanks (np.savetxt's, a DAQ's text)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        line = ""
        for _ in range(skip_rows + 1):
            line = f.readline()
    for sep in (",", ";", "\t"):
        if sep in line:
            return sep
    return r"\s+"


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _numbers(path, col, line0: int, name: str) -> np.ndarray:
    import pandas as pd

    v = pd.to_numeric(col, errors="coerce").to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        k = int(bad[0])
        raise CaptureError(f"{path}:{line0 + k}: column {name!r}: {col.iloc[k]!r} is not a finite number")
    return v


def read_wav(path, channel=None, sample_hz=None) -> Capture:
    """A sound card's WAV (scipy.io.wavfile): its rate from the file, integer PCM as codes."""
    from scipy.io import wavfile
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", wavfile.WavFileWarning)
            rate, data = wavfile.read(path)
    except (OSError, ValueError, EOFError, TypeError, IndexError) as exc:
        raise CaptureError(f"{path}: not a WAV file scipy can read: {' '.join(str(exc).split())}") from None
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    names = [str(j) for j in range(data.shape[1])]
    j = _pick(path, names, channel, "channel")
    if j < 0:
        if data.shape[1] > 1:
            raise CaptureError(f"{path}: {data.shape[1]} channels: give --channel INDEX")
        j = 0
    x = data[:, j]
    integer = np.issubdtype(x.dtype, np.integer)
    x = x.astype(float)
    if not np.isfinite(x).all():
        raise CaptureError(f"{path}: channel {j}: sample {int(np.flatnonzero(~np.isfinite(x))[0])} is not finite")
    hz, rate_from = _rate(path, float(rate), sample_hz, "the WAV header")
    return Capture(x, hz, 0.0, bool(integer), f"channel {j}", rate_from)


def read_mat(path, variable=None, sample_hz=None) -> Capture:
    """A MATLAB .mat (scipy.io.loadmat, up to v7; v7.3 is HDF5): the current in `variable` (default:
    the only numeric vector), the rate from --sample-hz or a scalar variable of MAT_RATE_NAMES."""
    from scipy.io import loadmat

    try:
        m = loadmat(path, squeeze_me=True)
    except NotImplementedError:
        raise CaptureError(f"{path}: a MATLAB v7.3 (HDF5) file: save it with save(..., '-v7')") from None
    except (OSError, ValueError, TypeError, EOFError, IndexError, KeyError) as exc:
        raise CaptureError(f"{path}: not a .mat file scipy can read: {' '.join(str(exc).split())}") from None
    data = {k: v for k, v in m.items() if not k.startswith("__")}
    vectors = {k: v for k, v in data.items()
               if isinstance(v, np.ndarray) and v.ndim == 1 and v.size > 1 and np.issubdtype(v.dtype, np.number)}
    if variable is None:
        if len(vectors) != 1:
            raise CaptureError(f"{path}: {len(vectors)} numeric vectors ({', '.join(sorted(vectors)) or 'none'}): "
                               "give --variable NAME")
        variable = next(iter(vectors))
    if variable not in data:
        raise CaptureError(f"{path}: no variable {variable!r} (there are: {', '.join(sorted(data)) or 'none'})")
    v = data[variable]
    if variable not in vectors:
        raise CaptureError(f"{path}: variable {variable!r} is not a numeric vector "
                           f"(shape {getattr(v, 'shape', '?')}, {getattr(v, 'dtype', type(v).__name__)})")
    if np.iscomplexobj(v):
        raise CaptureError(f"{path}: variable {variable!r} is complex, not a current")
    x = v.astype(float)
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise CaptureError(f"{path}: variable {variable!r}: element {int(bad[0]) + 1} is not finite")
    file_hz, what = None, "the file"
    for name in MAT_RATE_NAMES:
        r = data.get(name)
        if r is not None and np.ndim(r) == 0 and np.issubdtype(np.asarray(r).dtype, np.number):
            file_hz, what = float(r), f"its variable {name!r}"
            break
    hz, rate_from = _rate(path, file_hz, sample_hz, what)
    return Capture(x, hz, 0.0, bool(np.issubdtype(v.dtype, np.integer)), f"variable {variable!r}", rate_from)


def read(path, kind=None, column=None, time_column=None, channel=None, variable=None, sample_hz=None,
         skip_rows: int = 0) -> Capture:
    """One channel of a capture, by its type (kind_of)."""
    kind = kind_of(path, kind)
    if not pathlib.Path(path).is_file():
        raise CaptureError(f"{path}: no such file")
    if kind == "csv":
        cap = read_csv(path, column, time_column, sample_hz, skip_rows)
    elif kind == "wav":
        cap = read_wav(path, channel, sample_hz)
    else:
        cap = read_mat(path, variable, sample_hz)
    if len(cap.values) < MIN_SAMPLES:
        raise CaptureError(f"{path}: {len(cap.values)} samples: fewer than {MIN_SAMPLES}, nothing to count")
    return cap


def to_codes(values, integer: bool):
    """(integer codes, the value of one code)."""
    x = np.asarray(values, float)
    if integer and np.abs(x).max() < 2 ** 62:
        return x.astype(np.int64), 1.0
    u = np.unique(x)
    with np.errstate(over="ignore"):  # (a span past the float range is inf, taken below)
        span = float(u[-1] - u[0]) if len(u) > 1 else max(abs(float(u[0])), 1.0)
        d = np.diff(u)
    # the fine step, and never finer than the values' own float resolution at their largest magnitude
    # (a small ripple on a large offset: 1e6 +- 1e-9 gave codes past the int64 range)
    fine = max(span / FLOAT_STEPS, float(np.abs(x).max()) / CODE_RANGE)
    step = float(d.min()) if len(d) else span
    # the smallest difference is the data's own step (an instrument's LSB) where every value is a whole
    # number of it and it is coarser than the fine step; else the fine step
    with np.errstate(over="ignore", invalid="ignore"):  # (a step so fine that x / step passes the float range)
        whole = step > fine and np.abs(x / step - np.round(x / step)).max() < 1e-3
    if not whole:
        step = fine
    if not (step > 0 and math.isfinite(step)):  # a span past the float range (values near +-1.8e308)
        step = float(np.abs(x).max()) / CODE_RANGE or 1.0
    return np.round(x / step).astype(np.int64), step


def write_bursts(cap: Capture, out, a_per_unit: float, offset: float | None, window_s: float, *,
                 pwm_hz: float | None = None, mains_hz: float | None = None, coupling: str = rf.DC,
                 source_path=None) -> rf.Bursts:
    """The capture as a burst file at out (`<name>.ripple.csv`): contiguous windows of window_s
    (the last one shorter where the capture ends inside it, left out under MIN_SAMPLES), sampling
    free-running (pwm_hz the PWM's, 0 for none: a DC supply), offset (file units; None: 0 for DC
    coupling, the capture's mean for AC), provenance (file, SHA-256, what was read). Returns the
    bursts as read back."""
    out = pathlib.Path(out)
    if not out.name.endswith(rf.SUFFIX):
        raise CaptureError(f"{out}: the burst file's name ends in {rf.SUFFIX}")
    if not (math.isfinite(a_per_unit) and a_per_unit > 0):
        raise CaptureError(f"--a-per-unit {a_per_unit:g}: must be a finite number > 0")
    if not (math.isfinite(window_s) and window_s > 0):
        raise CaptureError(f"--window-s {window_s:g}: must be a finite number > 0")
    codes, step = to_codes(cap.values, cap.integer)
    if offset is None:
        offset = float(np.mean(cap.values)) if coupling == rf.AC else 0.0
    n_w = max(1, int(round(window_s * cap.sample_hz)))
    if n_w >= len(codes):  # a capture shorter than one window is one window, as long as the capture
        n_w = max(len(codes), 1)
    elif n_w < MIN_SAMPLES:
        raise CaptureError(f"--window-s {window_s:g} at {cap.sample_hz:g} Hz: windows of {n_w} sample"
                           f"{'s' if n_w > 1 else ''}, fewer than {MIN_SAMPLES}, nothing to count: give --window-s "
                           f"{MIN_SAMPLES / cap.sample_hz:.3g} or more")
    cuts = list(range(0, len(codes), n_w))
    parts = [codes[a:a + n_w] for a in cuts]
    if len(parts) > 1 and len(parts[-1]) < MIN_SAMPLES:
        parts, cuts = parts[:-1], cuts[:-1]
    meta = {"condition": out.name[:-len(rf.SUFFIX)], "sample_hz": repr(cap.sample_hz),
            "a_per_code": repr(a_per_unit * step), rf.OFFSET_CODE: repr(offset / step), rf.SAMPLING: rf.FREE,
            rf.COUPLING: coupling, "burst_s": repr(n_w / cap.sample_hz)}
    meta[rf.PWM_HZ] = repr(float(pwm_hz)) if pwm_hz is not None else None
    if meta[rf.PWM_HZ] is None:
        del meta[rf.PWM_HZ]
    if mains_hz is not None:  # (0: no mains, declared)
        meta[rf.MAINS_HZ] = repr(float(mains_hz))
    if source_path is not None:
        p = pathlib.Path(source_path)
        meta.update({"source": p.name, "source_sha256": hashlib.sha256(p.read_bytes()).hexdigest(),
                     "source_channel": "_".join(cap.source.split()).replace("'", ""),
                     "sample_hz_from": "_".join(cap.rate_from.split()).replace("'", ""),
                     "a_per_unit": repr(a_per_unit), "unit_per_code": repr(step)})
    t_s = [cap.t0_s + a / cap.sample_hz for a in cuts]
    extreme = rf.largest_current_A(parts, offset / step, a_per_unit * step)  # the codes and scale written
    if not extreme <= rf.MAX_CURRENT_A:  # (the burst file's reader refuses such currents: nothing is written)
        raise CaptureError(f"{source_path or out}: --a-per-unit {a_per_unit:g} and the offset {offset:g} make currents "
                           f"of {extreme:.3g} A "
                           f"from {cap.source}, over any motor's {rf.MAX_CURRENT_A:g} A: check the scale and the "
                           "offset")
    rf.write(out, meta, range(len(parts)), t_s, parts)
    return rf.read(out)
