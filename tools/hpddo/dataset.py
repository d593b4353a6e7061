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

import numpy as np
import pandas as pd

from . import benchlog

TRAIN_FRACTION = 0.8

# A sample is a glitch when it departs from the median of its 5-sample neighbourhood by
# more than GLITCH_SIGMAS robust standard deviations of such departures, and by more than
# an absolute floor in the channel's unit. Real steps (load, duty) move the median with
# them and survive; isolated spikes of one or two samples do not.
GLITCH_SIGMAS = 12.0
GLITCH_FLOOR = {"v_V": 0.5, "i_A": 0.15, "rpm_ref": 25.0}
TEMP_RANGE_C = (-55.0, 125.0)  # DS18B20 range: readings outside are glitches


@dataclasses.dataclass
class Recording:
    """One cleaned recording."""

    name: str             # condition (metadata) or file stem
    source: pathlib.Path  # the log it came from
    meta: dict
    df: pd.DataFrame      # cleaned rows, with a seq column (the source's, or its row index)
    removed: list         # [(file line, reason), ...] of rows the glitch filter removed
    n_train: int          # rows [0, n_train) train, [n_train, n) test

    @property
    def n(self) -> int:
        return len(self.df)

    def part(self, which: str) -> pd.DataFrame:
        return self.df.iloc[: self.n_train] if which == "train" else self.df.iloc[self.n_train:]

    def has_temp(self) -> bool:
        return "temp_C" in self.df and self.df["temp_C"].notna().any()


def _first_data_line(path: pathlib.Path) -> int:
    with open(path, encoding="utf-8-sig") as fh:
        for k, line in enumerate(fh, start=1):
            if not line.startswith("#"):
                return k + 1
    return 1


def glitch_mask(df: pd.DataFrame) -> tuple[np.ndarray, list]:
    """Boolean mask of glitch rows and the reason for each."""
    n = len(df)
    bad = np.zeros(n, bool)
    reasons = [""] * n
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
        thresh = max(GLITCH_SIGMAS * sigma, floor)
        hit = finite & (dev > thresh)
        for k in np.flatnonzero(hit & ~bad):
            reasons[k] = f"{col}={x[k]:.6g} departs {dev[k]:.3g} from its neighbours' median (threshold {thresh:.3g})"
        bad |= hit
    if "temp_C" in df:
        t = df["temp_C"].to_numpy(float)
        hit = np.isfinite(t) & ((t < TEMP_RANGE_C[0]) | (t > TEMP_RANGE_C[1]))
        for k in np.flatnonzero(hit & ~bad):
            reasons[k] = f"temp_C={t[k]:.6g} outside the sensor range {TEMP_RANGE_C}"
        bad |= hit
    return bad, reasons


def load_recording(path, train_fraction: float = TRAIN_FRACTION, glitch_filter: bool = True) -> Recording:
    """Reads, cleans and splits one bench log (raises benchlog.BenchLogError on format faults)."""
    log = benchlog.read_log(path)
    df = log.df.copy()
    if "seq" not in df:
        df["seq"] = np.arange(len(df), dtype=np.int64)
    removed = []
    if glitch_filter:
        bad, reasons = glitch_mask(df)
        first = _first_data_line(pathlib.Path(path))
        removed = [(first + int(k), reasons[k]) for k in np.flatnonzero(bad)]
        df = df.loc[~bad].reset_index(drop=True)
    if len(df) < 10:
        raise benchlog.BenchLogError(path, None, f"only {len(df)} usable rows: too few to split 80/20")
    n_train = int(np.floor(train_fraction * len(df)))
    return Recording(name=log.condition, source=pathlib.Path(path), meta=dict(log.meta), df=df,
                     removed=removed, n_train=n_train)


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


def temp_read_C(rec: Recording) -> np.ndarray:
    """The case temperature per row as the observer takes it: the reading where the log has
    one within the sensor's range (TEMP_RANGE_C), NaN elsewhere."""
    if "temp_C" not in rec.df:
        return np.full(rec.n, np.nan)
    t = rec.df["temp_C"].to_numpy(float)
    return np.where(np.isfinite(t) & (t >= TEMP_RANGE_C[0]) & (t <= TEMP_RANGE_C[1]), t, np.nan)


def write_clean(rec: Recording, path) -> pathlib.Path:
    """Writes the cleaned rows as a bench log (the file the native replay reads)."""
    meta = dict(rec.meta)
    meta["condition"] = rec.name
    meta["note"] = (f"cleaned from {rec.source.name}: {len(rec.removed)} glitch rows removed; "
                    f"train rows 0..{rec.n_train - 1}, test rows {rec.n_train}..{rec.n - 1}")
    meta["split_row"] = str(rec.n_train)
    return benchlog.write_log(path, rec.df, meta)
