"""Recordings prepared for identification, training and replay.

Loads bench logs, removes sensor glitches (and says which rows, by file line), splits
each recording chronologically (first 80 % train, last 20 % test) and marks where the
one-step lags restart: the first row, the first test row (lags never cross the split)
and every seq gap. These rules are the board observer's (observer.h): the replay of the
cleaned logs restarts the observer at the same rows.
"""
from __future__ import annotations

import dataclasses
import pathlib
import re

import numpy as np
import pandas as pd

from . import benchlog
from .. import schema

TRAIN_FRACTION = 0.8
MIN_ROWS = 10  # fewer rows than this cannot be split into training and test parts

# A sample is a glitch when it departs from the median of its 5-sample neighbourhood by
# more than GLITCH_SIGMAS robust standard deviations of such departures, by more than an
# absolute floor in the channel's unit, and by more than GLITCH_QUANTA steps of the
# channel's resolution (its quantum, estimated from the data: an encoder at 1 kHz moves
# in steps of 310 RPM, and a sample one step from its neighbours is no glitch), and by
# more than GLITCH_TAIL times the 99th percentile of all departures (at 100 Hz and more
# the V and I channels alias the PWM into heavy-tailed noise that a robust sigma misses;
# a glitch must stand out of that tail, not only out of the typical spread). Real
# steps (load, duty) move the median with them and survive; isolated spikes of one or two
# samples do not. Glitches are rare by nature: a recording that loses more than
# GLITCH_WARN_SHARE of its rows to the filter is reported loudly.
GLITCH_SIGMAS = 12.0
GLITCH_FLOOR = {"v_V": 0.5, "i_A": 0.15, "rpm_ref": 25.0}
GLITCH_QUANTA = 3.0
GLITCH_TAIL = 2.0
GLITCH_WARN_SHARE = 0.01
# ... but a step of the command (duty or load) drives the current within a row or two faster than the
# neighbourhood's median follows: at 50 Hz a 24 V motor's inrush after a duty step read 5.8 and 4.8 A where
# the rows around read 0.9 and 3.6, and the filter took the two rows after every step for glitches, and with
# them the impulse that the shaft's inertia is measured by (J 2.4x low and "determined", an independent
# simulator's bench). In the GLITCH_STEP_ROWS rows from a change of command on, a current that departs the
# way the step drives it (up after a step up of duty or load, down after a step down) is the step's
# transient, not judged against its neighbours (in a time series: a table's rows, each its own point, are
# judged against the table's curve instead, table_misreads). A departure the other way, or in the voltage or
# the speed, is judged as anywhere: the twin's doubled speed reading in the row after a duty step is a glitch.
GLITCH_STEP_ROWS = 2
LIMITS = schema.Limits()  # the readings the observer accepts
TEMP_RANGE_C = (LIMITS.temp_min_C, LIMITS.temp_max_C)  # a reading outside it is taken as not read,
# as the observer does (the row's V, I and speed stay: a faulty temperature sensor must
# not cost the recording)


@dataclasses.dataclass
class Recording:
    """One cleaned recording."""

    name: str             # condition (metadata) or file stem; unique among the recordings of a run
    source: pathlib.Path  # the log it came from
    meta: dict
    df: pd.DataFrame      # cleaned rows, with a seq column (the source's, or its row index)
    removed: list         # [(file line, reason), ...] of rows the glitch filter removed
    n_train: int          # rows [0, n_train) train, [n_train, n) test
    rows_in_file: int = 0  # data rows of the log before the glitch filter
    warnings: list = dataclasses.field(default_factory=list)  # what a user must be told loudly
    # where rpm_ref came from when it is not the log's own column (hpddo.ripple.reference): the
    # record of the swap (rows kept, left out by reason), and each row's weight (its confidence)
    reference: dict | None = None
    weight: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.df)

    def part(self, which: str) -> pd.DataFrame:
        return self.df.iloc[: self.n_train] if which == "train" else self.df.iloc[self.n_train:]

    def has_temp(self) -> bool:
        return "temp_C" in self.df and self.df["temp_C"].notna().any()

    @property
    def file_stem(self) -> str:
        """The name as a safe file name (work files of the run are named by it)."""
        return safe_name(self.name)


def safe_name(name: str) -> str:
    """A recording name reduced to letters, digits, '_', '-' and '.' for file names."""
    out = re.sub(r"[^A-Za-z0-9_.-]", "_", name).strip(".")
    return out or "recording"


def quantum(x: np.ndarray) -> float:
    """The channel's resolution as the data shows it: the 10th percentile of the non-zero
    steps between consecutive samples (a quantised channel never steps by less than one
    quantum; for a continuous noisy channel this is far below its noise)."""
    x = x[np.isfinite(x)]
    d = np.abs(np.diff(x))
    d = d[d > 0]
    return float(np.percentile(d, 10)) if d.size >= 20 else 0.0


GRID_TOL = 0.02    # a value within this share of a step from a whole number of steps lies on the step's grid
GRID_SHARE = 0.9   # ... and this share of the values doing so makes a grid


def grid_step(x: np.ndarray) -> float:
    """The step of a channel whose readings lie on a grid (an encoder's counts over a window, a rounded
    display): quantum(x) where GRID_SHARE of the finite values are whole numbers of it within GRID_TOL; 0
    elsewhere (a continuous channel, or a table's settled points, whose smallest steps are between points)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    q = quantum(x)
    if not q > 0:
        return 0.0
    return q if on_grid(x, q) else 0.0


def refined_step(x: np.ndarray, step: float, origin: float = 0.0) -> float:
    """The step of the grid that the values x lie on near `step` (whole numbers of it from origin), fitted
    by least squares on their codes, nearest codes first: values written with fewer decimals than their
    converter's step (0.009765625 A written 0.00977 or 0.00976) are a whole number of codes apart, but
    their smallest difference misses the step by up to a written digit, which over a hundred codes is
    more than half a step (an independent bench's current at 5 decimals: its step taken for 1e-5, and
    its top load, the same current at two duties, called a clip)."""
    d = np.asarray(x, float) - origin
    d = d[np.isfinite(d)]
    s, reach = float(step), 8.0
    if not s > 0 or d.size == 0:
        return s
    while True:
        k = np.round(d / s)
        use = (k != 0) & (np.abs(k) <= reach)
        if use.any():
            s = float(np.sum(k[use] * d[use]) / np.sum(k[use] * k[use]))
        if reach >= np.max(np.abs(k)):
            return s
        reach *= 4.0


def on_grid(x: np.ndarray, step: float, origin: float = 0.0) -> bool:
    """Whether GRID_SHARE of the values x lie whole numbers of step from origin, within GRID_TOL of a step."""
    k = (np.asarray(x, float) - origin) / step
    return float(np.mean(np.abs(k - np.round(k)) <= GRID_TOL)) >= GRID_SHARE


def glitch_mask(df: pd.DataFrame, steps: bool = True) -> tuple[np.ndarray, list]:
    """Boolean mask of glitch rows and the reason for each; steps: a current departing the way a
    command step drives it in the rows after the step (step_rows) is no glitch (a time series;
    False for a table, whose every row is a point)."""
    n = len(df)
    bad = np.zeros(n, bool)
    reasons = [""] * n
    drive = step_rows(df) if steps else np.zeros(n, int)
    for col, floor in GLITCH_FLOOR.items():
        if col not in df or n < 5:
            continue
        x = df[col].to_numpy(float)
        med = pd.Series(x).rolling(5, center=True, min_periods=3).median().to_numpy()
        dev = np.abs(x - med)
        finite = np.isfinite(dev)
        if not finite.any():
            continue
        sigma = 1.4826 * np.median(dev[finite])
        thresh = max(GLITCH_SIGMAS * sigma, floor, GLITCH_QUANTA * quantum(x),
                     GLITCH_TAIL * float(np.percentile(dev[finite], 99)))
        hit = finite & (dev > thresh)
        if col == "i_A":  # the step's transient: the current departing the way the step drives it
            hit &= ~((drive != 0) & (np.sign(x - med) == drive))
        for k in np.flatnonzero(hit & ~bad):
            reasons[k] = f"{col}={x[k]:.6g} departs {dev[k]:.3g} from its neighbours' median (threshold {thresh:.3g})"
        bad |= hit
    return bad, reasons


def step_rows(df: pd.DataFrame) -> np.ndarray:
    """Per row: the way a change of command drives the current (+1: duty or load up, -1: down; the duty's
    where both change) where one happened at the row or at one of the GLITCH_STEP_ROWS - 1 rows before it,
    else 0."""
    n = len(df)
    way = np.zeros(n, int)
    if n > 1:
        for col in ("load", "duty"):  # (the duty's last: it decides where both change)
            if col in df:
                d = np.sign(np.diff(df[col].to_numpy(float))).astype(int)
                way[1:] = np.where(d != 0, d, way[1:])
    out = way.copy()
    for k in range(1, GLITCH_STEP_ROWS):
        out[k:] = np.where(out[k:] != 0, out[k:], way[:-k])
    return out


# A steady-state table's rows are settled points whose order says nothing (docs/bench-log.md), so a misread speed
# is judged against the table's own curve, not against its neighbours in the file: within one duty (one supply
# voltage of a dyno table), n = (V - I Ra) / Ke bends only gently with the effects (a brush drop shifts it, heating
# and saturation bend it), so a quadratic in the current, linear in the voltage, follows it. Each row is judged by
# the curve through the other rows (its deleted residual: a misread row at the end of the current's range pulls a
# curve fitted through it onto itself), the worst row judged first and, where misread, left out of the curve for the
# next; a row departing from it by more than GLITCH_SIGMAS robust standard deviations of the rows kept, by more than the speed's
# GLITCH_FLOOR and by more than GLITCH_QUANTA of its steps is a misread reading (a digit lost or doubled, a
# tachometer read on the wrong range). Judged only where a duty has at least TABLE_CURVE_MIN_ROWS rows with speed,
# voltage and current read, and only where at most TABLE_MISREAD_MAX of them are misread (else the curve is not
# this shape, and nothing is judged).
TABLE_CURVE_MIN_ROWS = 8
TABLE_MISREAD_MAX = 0.2


def _deleted_residuals(x: np.ndarray, y: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """y less the least-squares fit through the rows keep of (x, y) with the row itself left out: for a kept row
    e / (1 - h) (its hat value h), for another the fit's residual there. NaN where the rows kept do not determine
    the fit (h at 1)."""
    xk = x[keep]
    beta, *_ = np.linalg.lstsq(xk, y[keep], rcond=None)
    e = y - x @ beta
    g = np.linalg.pinv(xk.T @ xk)
    h = np.einsum("ij,jk,ik->i", x, g, x)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(keep, np.where(h < 1 - 1e-9, e / (1 - h), np.nan), e)


def _curve_columns(*cols) -> np.ndarray:
    """The design of a curve: a constant and each of cols centred and scaled, those that do not vary (a fixed
    supply's voltage) left to the constant."""
    out = [np.ones(len(cols[0]))]
    for c in cols:
        c = c - c.mean()
        if np.ptp(c) > 0:
            out.append(c / np.max(np.abs(c)))
    return np.column_stack(out)


def _misread(x: np.ndarray, y: np.ndarray, q: float) -> dict:
    """{row: (departure, threshold)} of the rows of (x, y) misread against the curve through the others
    (TABLE_MISREAD_MAX; table_misreads), the worst judged first and, where misread, left out for the next;
    {} where more are, or the rows do not determine the curve."""
    if len(y) < max(TABLE_CURVE_MIN_ROWS, 3 * x.shape[1]) or np.linalg.matrix_rank(x) < x.shape[1]:
        return {}
    bad = {}
    while len(bad) <= TABLE_MISREAD_MAX * len(y):
        out = np.zeros(len(y), bool)
        out[list(bad)] = True
        dr = _deleted_residuals(x, y, ~out)
        cand = int(np.nanargmax(np.where(out, np.nan, np.abs(dr))))
        out[cand] = True
        dr = _deleted_residuals(x, y, ~out)
        rest = np.abs(dr[~out])
        scale = 1.4826 * float(np.median(rest[np.isfinite(rest)])) if np.isfinite(rest).any() else np.inf
        thresh = max(GLITCH_SIGMAS * scale, GLITCH_FLOOR["rpm_ref"], GLITCH_QUANTA * q)
        if not abs(dr[cand]) > thresh:
            return bad
        bad[cand] = (abs(float(dr[cand])), thresh)
    return {}


def table_misreads(df: pd.DataFrame) -> dict:
    """{row index: reason} of a steady-state table's rows whose speed departs from its duty's speed-current
    curve (TABLE_CURVE_MIN_ROWS, TABLE_MISREAD_MAX; _misread): the rows the neighbours' rule of glitch_mask
    cannot judge where the table is in no order, or too short to estimate the tail it allows for. A table with
    no duty of that many rows (a duty per row) is judged whole, by a curve in the voltage and the current
    (n = (V - I Ra) / Ke: linear in both, bent by a saturation's V I and a heating's I^2)."""
    n = df["rpm_ref"].to_numpy(float)
    i = df["i_A"].to_numpy(float)
    v = df["v_V"].to_numpy(float)
    duty = df["duty"].to_numpy(float)
    q = grid_step(n)  # (not quantum: a table's smallest steps are between its points)
    ok = np.isfinite(n) & np.isfinite(i) & np.isfinite(v) & np.isfinite(duty)
    groups = [(f"at duty {d:g}", np.flatnonzero(ok & (duty == d))) for d in np.unique(duty[ok])]
    groups = [(what, idx) for what, idx in groups if len(idx) >= TABLE_CURVE_MIN_ROWS]
    whole = not groups
    if whole and ok.sum() >= TABLE_CURVE_MIN_ROWS:
        groups = [("over its duties", np.flatnonzero(ok))]
    out = {}
    for what, idx in groups:
        ii, vv = i[idx], v[idx]
        with np.errstate(all="ignore"):  # (readings near the format's largest: their products overflow)
            x = _curve_columns(vv, ii, vv * ii, ii * ii) if whole else _curve_columns(ii, ii * ii, vv)
        if not (np.isfinite(x).all() and np.isfinite(n[idx]).all() and np.ptp(n[idx]) < 1e150):
            continue  # no curve through readings that overflow it
        for k, (dev, thresh) in _misread(x, n[idx], q).items():
            out[int(idx[k])] = (f"rpm_ref={n[idx[k]]:.6g} departs {dev:.3g} from the table's speed-current curve "
                                f"{what} (through its other {len(idx) - 1} rows; threshold {thresh:.3g}): a misread "
                                "speed")
    return dict(sorted(out.items()))


def full_scale(meta: dict, source) -> dict:
    """{column: the largest |value| its channel reads}: the log's declared full scale (v_full_scale_V,
    i_full_scale_A: a bench's own divider or shunt), else the board's (schema.Limits)."""
    sensors = sensor_meta(meta, source)
    return {col: sensors.get(key, default) for col, key, default in FULL_SCALE}


def outside_limits(df: pd.DataFrame, meta: dict | None = None, source=None) -> dict:
    """{row index: reason} of the rows whose v_V or i_A lies beyond its channel's full scale (full_scale: the
    log's declared, else the board's, which the observer refuses beyond)."""
    out = {}
    scale = full_scale(meta or {}, source)
    for col, key, default in FULL_SCALE:
        lim = scale[col]
        x = df[col].to_numpy(float)
        for k in np.flatnonzero(np.abs(x) > lim):
            out[int(k)] = (f"{col}={x[k]:.6g} is beyond the channel's full scale (|{col}| <= {lim:g}, "
                           + (f"the log's {key}" if lim != default or key in (meta or {}) else
                              f"the board's, schema.Limits; a bench whose channel reads further declares "
                              f"# {key}=...") + ")")
    return dict(sorted(out.items()))


def removed_text(removed: list, beyond_lines: set) -> str:
    """What the glitch filter removed, by cause, each with its first row's line and reason (removed:
    [(line, reason)]; beyond_lines: the lines of the rows beyond a channel's full scale): a current
    channel beyond its full scale on every row is a motor larger than the board reads, or a wrong
    scale, not a log of glitches."""
    if not removed:
        return ""
    beyond = [(ln, why) for ln, why in removed if ln in beyond_lines]
    glitches = [(ln, why) for ln, why in removed if ln not in beyond_lines]
    parts = [f"{len(rows)} {what} (the first at line {rows[0][0]}: {rows[0][1]})"
             for rows, what in ((beyond, "beyond a channel's full scale"), (glitches, "departing from their neighbours"))
             if rows]
    return f" after the glitch filter removed {len(removed)} rows: " + "; ".join(parts)


def load_recording(path, train_fraction: float = TRAIN_FRACTION, glitch_filter: bool = True,
                   reference=None, log=None) -> Recording:
    """Reads, cleans and splits one bench log (raises benchlog.BenchLogError on format faults).
    reference: None (rpm_ref is the log's column), or a callable (path, df, meta) -> (df with
    rpm_ref replaced, meta, per-row weight, record) applied before the glitch filter
    (hpddo.ripple.reference.Ripple). log: the log at path as benchlog.read_log gave it, where the
    caller has read it already (load_recordings); its frame is then this recording's."""
    log = benchlog.read_log(path) if log is None else log
    df, meta = log.df, dict(log.meta)  # (the log's own frame: read_log made it, nobody else holds it)
    rows_in_file = len(df)
    weight, ref_record = None, None
    if reference is not None:
        df, meta, weight, ref_record = reference(path, df, meta)
    lines = np.asarray(log.lines, np.int64)
    if "seq" not in df:
        df["seq"] = np.arange(len(df), dtype=np.int64)
    removed, warnings = [], []
    outside = outside_limits(df, meta, path)
    if outside and not glitch_filter:
        k, why = next(iter(outside.items()))
        raise benchlog.BenchLogError(path, int(lines[k]), f"{why}; the board marks such a sample invalid and no "
                                     f"model is fitted to it ({len(outside)} such row(s)): correct the row(s), or "
                                     "let the glitch filter remove them (drop --no-glitch-filter)")
    # a table of settled points, declared or as its rows read (kind)
    table = kind(Recording(name=log.condition, source=pathlib.Path(path), meta=meta, df=df, removed=[],
                           n_train=0))[0] == "steady_state"
    if glitch_filter:
        bad, reasons = glitch_mask(df, steps=not table)
        misread = {}
        if table:
            misread = {k: why for k, why in table_misreads(df).items() if not bad[k]}
            for k, why in misread.items():
                bad[k], reasons[k] = True, why
        for k, why in outside.items():
            bad[k], reasons[k] = True, why
        removed = [(int(lines[k]), reasons[k]) for k in np.flatnonzero(bad)]
        if bad.any():
            df = df.loc[~bad].reset_index(drop=True)
        if weight is not None:
            weight = weight[~bad]
        share = len(removed) / max(rows_in_file, 1)
        if misread:  # a table's row is an operating point of its own: each one left out is named
            warnings.append(f"{path}: " + "; ".join(f"line {int(lines[k])}: {why}" for k, why in misread.items())
                            + " - left out (keep every row with --no-glitch-filter)")
        if share > GLITCH_WARN_SHARE and len(removed) > len(misread):
            warnings.append(f"{path}: the glitch filter removed {len(removed)} of {rows_in_file} rows "
                            f"({100 * share:.1f} %), more than glitches should be; look at the rows it names, "
                            "or keep every row with --no-glitch-filter")
    if "temp_C" in df:
        t = df["temp_C"].to_numpy(float)
        temp_outside = int((np.isfinite(t) & ((t < TEMP_RANGE_C[0]) | (t > TEMP_RANGE_C[1]))).sum())
        if temp_outside:
            warnings.append(f"{path}: {temp_outside} temp_C readings lie outside the sensor range {TEMP_RANGE_C} C "
                            "and are taken as not read")
    if len(df) < (MIN_ROWS if train_fraction > 0 else 1):  # (a recording scored whole, hpddo evaluate's: one row)
        raise benchlog.BenchLogError(path, None, f"only {len(df)} usable rows"
                                     + removed_text(removed, {int(lines[k]) for k in outside})
                                     + f": at least {MIN_ROWS} are needed to split train/test"
                                     + ("; a table of settled points split one log per supply voltage or load: put its "
                                        "rows into one log, the voltage and the load as columns (a table is scored "
                                        "across all its rows; docs/diagnose-table.md)"
                                        if table or meta.get("kind") == "steady_state" or "sample_rate_hz" not in meta
                                        else ""))
    n_train = int(np.floor(train_fraction * len(df)))
    return Recording(name=log.condition, source=pathlib.Path(path), meta=meta, df=df,
                     removed=removed, n_train=n_train, rows_in_file=rows_in_file, warnings=warnings,
                     reference=ref_record, weight=weight)


def load_recordings(paths, train_fraction: float = TRAIN_FRACTION, glitch_filter: bool = True,
                    reference=None) -> list[Recording]:
    """load_recording for each path; refuses two recordings with the same name (condition
    metadata, else file name), which would be counted as one. A reference with an `over` (the ripple's)
    is counted over all the paths first, as recordings of one motor."""
    from .. import progress
    paths = list(paths)
    progress.stage(f"reading {len(paths)} log(s) ({progress.size(paths)})")
    logs = [benchlog.read_log(p) for p in progress.bar(paths, "reading", unit="log")]  # each file parsed once
    if reference is not None and hasattr(reference, "over"):  # the ripple counted over the run's logs of one motor
        progress.stage(f"counting the ripple of {len(paths)} log(s)")
        reference = reference.over(paths, logs)
    recs = [load_recording(p, train_fraction, glitch_filter, reference, log) for p, log in zip(paths, logs)]
    seen = {}
    for r in recs:
        key = r.file_stem.lower()
        if key in seen:
            other = seen[key]
            raise benchlog.BenchLogError(
                r.source, None, f"recording name {r.name!r} is also the name of {other.source} "
                f"({other.name!r}); each recording needs its own name: set '# condition=NAME' in one "
                "of them, or rename the file")
        seen[key] = r
    return recs


def segment_starts(rec: Recording) -> np.ndarray:
    """True where the one-step lags restart: first row, first test row, after a seq gap."""
    seq = rec.df["seq"].to_numpy(np.int64)
    start = np.zeros(rec.n, bool)
    start[0] = True
    start[1:] = (seq[1:] - seq[:-1]) % 65536 != 1
    start[rec.n_train] = True
    return start


def dt_s(rec: Recording) -> np.ndarray:
    """Sample period of each row: the time since the previous row; the first row takes the
    nominal period (metadata sample_rate_hz, else the median spacing)."""
    t = rec.df["t_s"].to_numpy(float)
    dt = np.empty_like(t)
    dt[1:] = np.diff(t)
    rate = rec.meta.get("sample_rate_hz")
    try:
        dt[0] = 1.0 / float(rate)
    except (TypeError, ValueError, ZeroDivisionError):
        dt[0] = float(np.median(dt[1:])) if len(t) > 1 else 1.0
    return dt


def lagged(x: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """x(t-1), with x(t) itself at segment starts (as the observer does after a reset)."""
    out = np.empty_like(x)
    out[1:] = x[:-1]
    out[starts] = x[starts]
    return out


def di_dt_A_per_s(rec: Recording) -> np.ndarray:
    """The current's rate of change per row as the observer takes it (observer.h): the
    step from the previous row over the period, 0 where the lags restart."""
    return rate_per_s(rec, "i_A")


def rate_per_s(rec: Recording, col: str) -> np.ndarray:
    """A column's rate of change per row: the step from the previous row over the period,
    0 where the lags restart (di_dt_A_per_s for the current, dV/dt for the diagnosis)."""
    starts = segment_starts(rec)
    x = rec.df[col].to_numpy(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(starts, 0.0, (x - lagged(x, starts)) / dt_s(rec))


# A case temperature reading stands for the case until it is TEMP_MAX_AGE_S old (hpddo/limits.h,
# kTempMaxAge_ms): the acquisition board repeats its last DS18B20 reading (one a second) at every sample
# until then, so the observer never sees the gaps between conversions. A log written elsewhere with a
# reading once a second and none between (an independent simulator's at 10 Hz) is read as the board would
# have passed it on: without the hold, nine rows in ten read no temperature, the winding node ran along the
# ambient path, and its reference jumped from the ambient to the case and back at every reading.
TEMP_MAX_AGE_S = 2.5


def temp_read_C(rec: Recording) -> np.ndarray:
    """The case temperature per row as the observer takes it: the reading where the log has
    one within the sensor's range (TEMP_RANGE_C), else the last such reading up to
    TEMP_MAX_AGE_S before it by the log's clock (held_readings; not in a steady-state table,
    whose rows are points apart), NaN elsewhere."""
    if "temp_C" not in rec.df:
        return np.full(rec.n, np.nan)
    t = rec.df["temp_C"].to_numpy(float)
    t = np.where(np.isfinite(t) & (t >= TEMP_RANGE_C[0]) & (t <= TEMP_RANGE_C[1]), t, np.nan)
    read = np.isfinite(t)
    if read.all() or not read.any() or kind(rec)[0] == "steady_state":
        return t
    return held_readings(t, rec.df["t_s"].to_numpy(float), TEMP_MAX_AGE_S)


def held_readings(x: np.ndarray, t_s: np.ndarray, max_age_s: float) -> np.ndarray:
    """x (NaN where nothing was read) with each row that read nothing given the last reading before it, where
    that is at most max_age_s older by the clock t_s (and not later: a clock that steps back holds nothing)."""
    last = np.maximum.accumulate(np.where(np.isfinite(x), np.arange(len(x)), -1))
    src = np.maximum(last, 0)
    age = t_s - t_s[src]
    return np.where((last >= 0) & (age >= 0.0) & (age <= max_age_s), x[src], np.nan)


# What a log may declare about itself in its metadata (docs/bench-log.md, Known keys), read
# by the diagnosis: the log's kind, and the resolution of its sensors (the noise floor they set).
KINDS = ("time_series", "steady_state")  # metadata `kind`
SENSOR_KEYS = {
    "encoder_counts_per_rev": "encoder counts per output-shaft revolution (quadrature and gear included)",
    "encoder_window_s": "the time the encoder's counts are taken over, s (default: the sample period)",
    "v_lsb_V": "the step of the logged voltage (its resolution), V",
    "i_lsb_A": "the step of the logged current (its resolution), A",
    "v_cal_rel": "the voltage channel's calibration tolerance, relative (0.01: its gain within 1 %)",
    "i_cal_rel": "the current channel's calibration tolerance, relative (0.02: its gain within 2 %)",
    "v_zero_V": "the voltage channel's zero tolerance, V: it reads within this of 0 V at 0 V (default: as the "
                "rows at rest read it, else two of its steps, an ADC's offset error)",
    "i_zero_A": "the current channel's zero tolerance, A: it reads within this of 0 A at 0 A (default: as the "
                "rows at rest read it, else two of its steps, an ADC's offset error)",
    "v_full_scale_V": "the largest |v_V| the logged voltage channel reads, V (default: the board's, "
                      f"schema.Limits, {LIMITS.v_max_V:g} V)",
    "i_full_scale_A": "the largest |i_A| the logged current channel reads, A (default: the board's, "
                      f"schema.Limits, {LIMITS.i_max_A:g} A)",
}
#: the channels' full scale: (column, its SENSOR_KEYS key, the board's default)
FULL_SCALE = (("i_A", "i_full_scale_A", LIMITS.i_max_A), ("v_V", "v_full_scale_V", LIMITS.v_max_V))


# A column a log may carry beside the format's (an extra column to the readers, docs/bench-log.md,
# What the log says about itself), read by the identification of fast logs (model/dynamics.py):
# the encoder's period, the speed from the time between counts rather than from the counts.
ENC_PERIOD_COLUMN = "enc_period_s"
SENSOR_COLUMNS = {
    ENC_PERIOD_COLUMN: "the time between the last two encoder counts at or before the row's end, s (one count is "
                       "1 / encoder_counts_per_rev of a revolution of the output shaft); empty where the shaft "
                       "made fewer than two counts in the encoder's timeout (standing still)",
}


def enc_period_s(rec: Recording) -> np.ndarray | None:
    """The encoder period column (s, NaN where empty) of a recording, None where the log has none;
    a cell that is not a positive number is refused with the file and line."""
    if ENC_PERIOD_COLUMN not in rec.df:
        return None
    col = rec.df[ENC_PERIOD_COLUMN]
    x = pd.to_numeric(col, errors="coerce").to_numpy(float)
    bad = np.flatnonzero((col.notna().to_numpy() & ~np.isfinite(x)) | (np.isfinite(x) & ~(x > 0)))
    if len(bad):
        k = int(bad[0])
        log = benchlog.read_log(rec.source)  # t_s is strictly increasing: it names the row's line
        at = np.flatnonzero(log.df["t_s"].to_numpy(float) == float(rec.df["t_s"].iloc[k]))
        line = int(np.asarray(log.lines)[at[0]]) if len(at) else None
        raise benchlog.BenchLogError(rec.source, line, f"{ENC_PERIOD_COLUMN} {col.iloc[k]!r} is not a positive "
                                                       "number of seconds (or empty: not measured)")
    return x


def _meta_error(meta: dict, source, key: str, fault: str) -> benchlog.BenchLogError:
    """A fault of metadata `key` (meta: a log's metadata, source: its path), naming its file and
    line."""
    line = None
    try:
        for k, text in enumerate(pathlib.Path(source).read_text(encoding="utf-8-sig").splitlines(), 1):
            if not text.startswith("#"):
                break
            if re.match(rf"#[ \t]*{re.escape(key)}[ \t]*=", text):
                line = k
                break
    except OSError:
        pass
    return benchlog.BenchLogError(source, line, f"metadata {key}={meta.get(key)!r} {fault}")


def kind(rec: Recording) -> tuple[str, str]:
    """(kind, how it is known) of a recording: "steady_state" (a table: one settled row per
    operating point, no clock: the rows' order and t_s say nothing of time) or "time_series"
    (rows one sample period apart). Declared by the metadata `kind`, else detected from the
    rows (detect_kind)."""
    declared = rec.meta.get("kind")
    if declared is not None:
        if declared not in KINDS:
            raise _meta_error(rec.meta, rec.source, "kind", f"is not one of {', '.join(KINDS)}")
        return declared, "declared"
    return detect_kind(rec)


# A recording sampled in time holds each operating point for several rows: most consecutive rows
# share their command (duty, load) and read the same voltage, current and speed within HOLD_REL of
# each channel's size (its 95th percentile of |x|): 72-82 % of the pairs in the twin's 2 Hz recordings
# (data/default, data/validation), none in a dyno table of one supply voltage per log. A table of settled points moves to a new point at (nearly) every row. Rows
# HOLD_MIN_DT_S or more apart that hold their point in under HOLD_MAX_SHARE of the pairs are read as
# a table: a clock that slow carries no dynamics of the motor (its time constants are tens of ms to
# seconds), and a run sampled that slowly would repeat its points.
HOLD_REL = 0.02
HOLD_MAX_SHARE = 0.2
HOLD_MIN_DT_S = 0.5


#: the columns a row is read in: a row equal to the one before in each of them is the same reading written again
CHANNELS = ("duty", "load", "v_V", "i_A", "rpm_ref", "temp_C")


def repeated_rows(rec: Recording) -> np.ndarray:
    """Per pair of consecutive rows: True where the second equals the first in every channel (CHANNELS that the
    log has; a missing reading equal to a missing one): a logger that wrote the row again, not a second sample."""
    cols = [c for c in CHANNELS if c in rec.df]
    if rec.n < 2 or not cols:
        return np.zeros(max(rec.n - 1, 0), bool)
    x = rec.df[cols].to_numpy(float)
    return np.all((x[1:] == x[:-1]) | (np.isnan(x[1:]) & np.isnan(x[:-1])), axis=1)


def hold_share(rec: Recording) -> float:
    """Share of consecutive row pairs that hold their operating point (HOLD_REL), the rows written again
    (repeated_rows) left out: a dyno table whose logger wrote a fifth of its points twice held them in 21 % of
    its pairs, and was read as a time series. NaN with fewer than three rows or pairs left."""
    df = rec.df
    if rec.n < 3:
        return float("nan")
    again = repeated_rows(rec)
    if int((~again).sum()) < 2:
        return float("nan")
    same = np.ones(rec.n - 1, bool)
    if "load" in df:  # a command: held exactly
        same &= np.diff(df["load"].to_numpy(float)) == 0
    for col in ("duty", "v_V", "i_A", "rpm_ref"):  # the duty too: a ramp of it moves a little at every sample
        if col not in df:
            continue
        x = df[col].to_numpy(float)
        ok = np.isfinite(x)
        if ok.sum() < 3:
            continue
        size = float(np.percentile(np.abs(x[ok]), 95))
        same &= ~(np.abs(np.diff(x)) > HOLD_REL * size)  # a missing reading neither holds nor moves
    return float(np.mean(same[~again]))


def detect_kind(rec: Recording) -> tuple[str, str]:
    """(kind, the evidence) of a recording that does not declare its kind: a table when it has
    no sample_rate_hz and its duty never falls from row to row (sorted by operating point), or
    when its rows, HOLD_MIN_DT_S or more apart, hold their operating point in under
    HOLD_MAX_SHARE of the consecutive pairs (hold_share); a time series otherwise. Each says how
    to declare the other."""
    other = {"steady_state": "time_series", "time_series": "steady_state"}
    hint = lambda k: f"; if it is a {other[k].replace('_', '-')} log, declare # kind={other[k]}"  # noqa: E731
    duty = rec.df["duty"].to_numpy(float)
    if rec.n > STEADY_MAX_ROWS:
        return "time_series", f"assumed: more than {STEADY_MAX_ROWS} rows" + hint("time_series")
    if "sample_rate_hz" not in rec.meta and len(np.unique(duty)) > 1 and bool(np.all(np.diff(duty) >= 0)):
        return "steady_state", "detected: no sample_rate_hz, the rows sorted by duty" + hint("steady_state")
    held = hold_share(rec)
    t = rec.df["t_s"].to_numpy(float)
    dt = float(np.median(np.diff(t))) if rec.n > 1 else float("nan")
    if np.isfinite(held) and held < HOLD_MAX_SHARE and dt >= HOLD_MIN_DT_S:
        return "steady_state", (f"detected: only {100 * held:.0f} % of consecutive rows hold their operating point, "
                                f"{dt:g} s apart: settled points, not samples of one run" + hint("steady_state"))
    why = (f"{100 * held:.0f} % of consecutive rows hold their operating point" if np.isfinite(held)
           else "too few rows to tell")
    return "time_series", f"assumed: {why}, {dt:g} s apart" + hint("time_series")


STEADY_MAX_ROWS = 1000


def sensor_meta(meta: dict, source) -> dict:
    """{key: value} of the SENSOR_KEYS a log's metadata declares, each a positive number (meta:
    the metadata, source: the log's path, named in an error)."""
    out = {}
    for key in SENSOR_KEYS:
        if key not in meta:
            continue
        try:
            v = float(meta[key])
        except ValueError:
            raise _meta_error(meta, source, key, "is not a number") from None
        if not (np.isfinite(v) and v > 0):
            raise _meta_error(meta, source, key, "is not a positive number")
        out[key] = v
    return out


def encoder_count_rpm(sensors: dict, window_s: float | None) -> float | None:
    """One encoder count per counting window, RPM, from sensor_meta's {key: value}: the window is
    encoder_window_s where declared, else window_s (the caller's sample period, needed only
    then); None where the log declares no encoder."""
    if "encoder_counts_per_rev" not in sensors:
        return None
    return 60.0 / (sensors["encoder_counts_per_rev"] * sensors.get("encoder_window_s", window_s))


def write_clean(rec: Recording, path) -> pathlib.Path:
    """Writes the cleaned rows as a bench log (the file the native replay reads), each number as it was read."""
    meta = dict(rec.meta)
    meta["condition"] = rec.name
    split = (f"train rows 0..{rec.n_train - 1}, test rows {rec.n_train}..{rec.n - 1}" if rec.n_train
             else f"no training rows, test rows 0..{rec.n - 1}")
    meta["note"] = f"cleaned from {rec.source.name}: {len(rec.removed)} glitch rows removed; {split}"
    meta["split_row"] = str(rec.n_train)
    return benchlog.write_log(path, rec.df, meta, exact=True)  # the numbers it was read with
