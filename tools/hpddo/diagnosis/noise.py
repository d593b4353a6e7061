"""The noise floor of the speed error, and what the sensors themselves limit.

The floor the diagnosis compares the residual with is the larger of
  * the floor measured on the residual: from first differences of the held-out residual
    of a time series (analysis.robust_noise_var); on a steady-state table, whose rows have no
    clock, from the operating points it repeats, or, where it repeats none, the model's own
    out-of-fold residual (then "consistent with measurement noise" cannot be said: the floor
    is what the model leaves), and
  * the floor of the sensors, from the log's metadata (docs/bench-log.md): the encoder's
    quantisation (counts per output-shaft revolution over the counting window) and the
    resolution of the voltage and current channels, each through the model's sensitivity.
Each part is reported.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from ..logs import dataset
from ..model.identify import MIN_RPM, RAD_S_PER_RPM
from . import analysis

# Repeated operating points of a table: rows of one recording at the same duty and load whose
# currents differ by at most REPEAT_I_REL (relative) or REPEAT_I_A; at least REPEAT_MIN pairs.
REPEAT_I_REL = 0.02
REPEAT_I_A = 0.002
REPEAT_MIN = 5
# A coarse encoder: where one count per window is a step of more than MIN_RPM and more than
# TRUNCATED_MAX of the driven rows (duty > 0) read at most MIN_RPM, those rows fall out of
# every fit (rpm_ref > MIN_RPM) while the motor turns: a truncated sample, which biases Ke
# and Ra however narrow their intervals.
TRUNCATED_MAX = 0.02


# Why a floor is what the model leaves out of fold (NoiseFloor.unmeasured), and the measurement that would give one
NO_REPEATS = ("this table repeats no operating point", "repeat a few operating points to measure the noise")
FEW_DIFFERENCES = (f"fewer than {analysis.MIN_DIFFERENCES} consecutive rows with rpm_ref read differ in the held-out "
                   "residual", "log rpm_ref on consecutive rows to measure the noise")


@dataclasses.dataclass
class NoiseFloor:
    """The noise floor (variance, RPM^2) and its parts."""

    var_rpm2: float        # the floor used: the largest of measured and the sensors' sum
    measured_rpm2: float   # the floor measured on the residual
    source: str            # how it was measured, in words
    sensors: dict          # {part: variance RPM^2} from the log's metadata (may be empty)
    from_model: bool = False  # the measured floor is the model's own out-of-fold residual ...
    unmeasured: tuple = NO_REPEATS  # ... because (why, what would measure it): NO_REPEATS or FEW_DIFFERENCES
    encoder_step_rpm: float = 0.0  # one encoder count per window, RPM (the coarsest recording's)
    truncated_share: float = 0.0   # driven rows reading at most MIN_RPM, of all driven rows
    # where the floor is the bound of the model with every library effect (FROM_ALL_EFFECTS): whether that model
    # explains the held-out rows better than the final one (core.refloor), so that a residual above it is evidence
    # of something missing
    bound_evidence: bool = True

    @property
    def truncated(self) -> str:
        """Why Ke and Ra are not determined by a coarse encoder's rows ("" when they are)."""
        if self.encoder_step_rpm <= MIN_RPM or self.truncated_share <= TRUNCATED_MAX:
            return ""
        return (f"one encoder count per window is {self.encoder_step_rpm:.3g} RPM, so "
                f"{100 * self.truncated_share:.0f} % of the rows with the motor driven read {MIN_RPM:g} RPM or "
                "less and fall out of every fit: a truncated sample, which biases it")

    @property
    def sensors_rpm2(self) -> float:
        return float(sum(self.sensors.values()))

    @property
    def limited_by_sensors(self) -> bool:
        return self.sensors_rpm2 > self.measured_rpm2

    def to_json(self) -> dict:
        return {"rpm": math.sqrt(self.var_rpm2), "var_rpm2": self.var_rpm2, "measured_rpm2": self.measured_rpm2,
                "source": self.source, "from_model": self.from_model,
                "sensors_rpm2": dict(self.sensors), "sensors_rpm": {k: math.sqrt(v) for k, v in self.sensors.items()},
                "limited_by_sensors": self.limited_by_sensors, "encoder_step_rpm": self.encoder_step_rpm,
                "truncated_share": self.truncated_share, "truncated": self.truncated, "text": self.text()}

    def text(self) -> str:
        parts = [f"measured {math.sqrt(self.measured_rpm2):.3g} RPM ({self.source})"]
        parts += [f"{k} {math.sqrt(v):.3g} RPM" for k, v in self.sensors.items()]
        head = f"noise floor {math.sqrt(self.var_rpm2):.3g} RPM"
        if self.limited_by_sensors:
            head += " (set by the sensors)"
        return head + ": " + "; ".join(parts)


def copies(r) -> np.ndarray:
    """Per row of a table: True where it is a copy of an earlier row, every channel the same (duty, load,
    voltage, current, speed and temperature). A copy is the same reading written twice, not a second
    measurement of its point: paired with its original it differs by exactly zero, and enough of them
    shrink the repeats' spread below the sensors' noise (a table whose logger wrote each point two or
    three times read a floor of 0.16 RPM at a noise of 0.3)."""
    df = r.rec.df
    cols = np.column_stack([r.duty, df["load"].to_numpy(float) if "load" in df else np.zeros(len(r.i)),
                            r.v, r.i, r.ref, r.temp])
    return pd.DataFrame(cols).duplicated(keep="first").to_numpy()  # NaN equal to NaN


def repeats(rows, res) -> tuple[np.ndarray, list, int]:
    """(differences, where, copies) of the residual res between rows of a steady-state table that repeat
    one operating point (the same duty and load, currents within REPEAT_I_REL / REPEAT_I_A),
    taking consecutive repeats pairwise, labelled rows only, each copy of an earlier row (copies) left
    out and counted; where: "recording rows a and b" of each pair (1-based data rows). Without a load
    column the current is the only mark of the load: rows within the tolerance of each other repeat a point
    only where they stand apart from the table's other rows at that duty (_told_apart)."""
    out, where, n_copies = [], [], 0
    for r, e in zip(rows, res):
        if not r.steady:
            continue
        df = r.rec.df
        has_load = "load" in df
        load = df["load"].to_numpy() if has_load else np.zeros(len(r.i))
        ok = (r.train | r.test) & np.isfinite(e)
        dup = copies(r) & ok
        n_copies += int(dup.sum())
        key = sorted(np.flatnonzero(ok & ~dup), key=lambda k: (r.duty[k], load[k], r.i[k]))
        for group in _points(key, r, load, has_load):
            for a, b in zip(group[:-1], group[1:]):
                out.append(e[a] - e[b])
                where.append(f"{r.rec.name} rows {min(a, b) + 1} and {max(a, b) + 1}")
    return np.asarray(out, float), where, n_copies


def _tol(i: float) -> float:
    return max(REPEAT_I_A, REPEAT_I_REL * abs(i))


def _points(key: list, r, load, has_load: bool) -> list:
    """The groups of rows (indices, sorted as key: by duty, load and current) that repeat one operating point:
    runs of rows of one duty and load, each within the current's tolerance of the one before; without a load
    column, only the runs whose currents lie within one tolerance of their first and whose nearest other row of
    that duty lies REPEAT_APART tolerances or more beyond (_told_apart: a sweep of loads as close as the current's
    noise puts neighbouring loads within the tolerance by chance; an independent simulator's dyno tables, 16
    loads a log, read a floor twice the noise from such pairs)."""
    runs, run = [], []
    for k in key:
        if run and (r.duty[k] == r.duty[run[-1]] and load[k] == load[run[-1]]
                    and abs(r.i[k] - r.i[run[-1]]) <= _tol(r.i[run[-1]])):
            run.append(k)
            continue
        if len(run) > 1:
            runs.append(run)
        run = [k]
    if len(run) > 1:
        runs.append(run)
    if has_load:
        return runs
    return [g for g in runs if _told_apart(g, key, r)]


def _told_apart(group: list, key: list, r) -> bool:
    """Whether a run of rows (of one duty, within the current's tolerance of each other) is one operating point
    told from the table's other rows of that duty by the current alone: its currents within one tolerance of its
    first, and every other row of the duty REPEAT_APART tolerances or more from its nearest."""
    i = np.array([r.i[k] for k in group])
    tol = _tol(float(np.median(i)))
    if np.ptp(i) > tol:
        return False
    others = np.array([r.i[k] for k in key if r.duty[k] == r.duty[group[0]] and k not in group])
    return not len(others) or float(np.min(np.minimum(np.abs(others - i.min()), np.abs(others - i.max())))) \
        >= REPEAT_APART * tol


# (_told_apart) without a load column, a repeated point's rows stand this many current tolerances clear of the
# table's other rows at its duty
REPEAT_APART = 4.0


# A repeated pair further apart than REPEAT_OUTLIER robust standard deviations of the pairs'
# differences is an outlier: named, and left out of the floor (the floor is the pairs' robust
# spread, so one or two wild pairs cannot make "consistent with measurement noise" true).
REPEAT_OUTLIER = 5.0


def measured(data, res, mse_out_of_fold: float) -> tuple[float, str, tuple]:
    """(variance RPM^2, how, why not measured: () where it is) of the noise measured on the held-out residual res:
    first differences where the rows are a time series; on steady-state tables the repeated
    operating points (their robust spread, the outlying pairs named); else (a table that repeats none, a time
    series with too few consecutive labelled rows that differ) the model's out-of-fold mean squared error
    mse_out_of_fold."""
    rows = data.rows
    if not any(r.steady for r in rows):
        var = analysis.robust_noise_var(analysis.parts(rows, res))
        if math.isfinite(var):
            return var, "the white part of the held-out residual, from row-to-row differences", ()
        # too few consecutive labelled rows that differ (an encoder read on every other row, or slower than the
        # logger): nothing measures the white part, and the floor is what the model leaves, as on a table
        return (float(mse_out_of_fold), f"the model's own out-of-fold residual: {FEW_DIFFERENCES[0]} "
                f"({FEW_DIFFERENCES[1]})", FEW_DIFFERENCES)
    d, where, n_copies = repeats(rows, res)
    copied = (f"; {n_copies} row(s) that copy an earlier row in every channel taken once: a copy is no second "
              "reading") if n_copies else ""
    if len(d) >= REPEAT_MIN:
        sd = analysis.MAD_NORMAL * float(np.median(np.abs(d)))  # a pair's difference is centred on zero
        far = np.flatnonzero(np.abs(d) > REPEAT_OUTLIER * sd) if sd > 0 else np.zeros(0, int)
        how = f"the robust spread of {len(d)} repeated operating points of the table" + copied
        if len(far):
            how += (f"; {len(far)} outlying pair(s) left out ({REPEAT_OUTLIER:g} robust sd or more apart: "
                    + ", ".join(f"{where[k]}, {abs(d[k]):.3g} RPM" for k in far[:5])
                    + (", ..." if len(far) > 5 else "") + ")")
        if sd > 0:
            return sd * sd / 2.0, how, ()
        return float(np.mean(d * d) / 2.0), f"{len(d)} repeated operating points of the table" + copied, ()
    return (float(mse_out_of_fold),
            "the model's own out-of-fold residual: the table repeats no operating point (repeat a few to "
            "measure the noise)" + copied, NO_REPEATS)


def step_rpm(rec, r) -> float | None:
    """One encoder count over the counting window, RPM (None: the log declares no encoder):
    the window is encoder_window_s, else the sample period (1 / sample_rate_hz, else the
    median spacing of the rows; not the time since the previous row, which a removed glitch
    row doubles)."""
    meta = dataset.sensor_meta(rec.meta, rec.source)
    period = None
    if "encoder_counts_per_rev" in meta and "encoder_window_s" not in meta:  # the window is the sample period
        try:
            period = 1.0 / float(rec.meta["sample_rate_hz"])
        except (KeyError, ValueError, ZeroDivisionError):
            period = float(np.median(r.dt))
    return dataset.encoder_count_rpm(meta, period)


def encoder_step_rpm(recs, rows) -> float:
    """The largest step_rpm over the recordings (0 where none declares its encoder)."""
    return max((q for rec, r in zip(recs, rows) for q in [step_rpm(rec, r)] if q is not None), default=0.0)


def truncated_share(rows) -> float:
    """Share of the rows with the motor driven (duty > 0, speed read) that read MIN_RPM or less."""
    driven = sum(int(np.sum((r.duty > 0) & np.isfinite(r.ref))) for r in rows)
    low = sum(int(np.sum((r.duty > 0) & np.isfinite(r.ref) & (r.ref <= MIN_RPM))) for r in rows)
    return low / driven if driven else 0.0


def rpm_per_reading(p) -> dict:
    """The plain model's sensitivity of the speed to each channel's reading, in magnitude: {Rows
    attribute: RPM per volt ("v", 1 / Ke) or per ampere ("i", Ra / Ke)}."""
    per_v = 1.0 / (p.ke_vs_per_rad * RAD_S_PER_RPM)
    return {"v": per_v, "i": p.ra_ohm * per_v}


#: the part of an undeclared speed grid: its step q as the rows show it, read as a rounding (q^2 / 12); the figure
#: shown is its RMS, not the step (a fuzzing round's "(its step as the rows show it) 4.47 RPM" on rows 15.5 RPM apart)
SPEED_GRID_PART = "speed rounding (the rows' grid step / sqrt 12)"


def sensors(recs, rows, p) -> dict:
    """{part: variance RPM^2} of the speed error that the sensors' resolution alone gives, from
    each recording's metadata (dataset.sensor_meta), pooled over the labelled rows: the
    encoder's quantisation (a count over a window of T s at c counts per output-shaft
    revolution steps by q = 60 / (c T) RPM, and the two ends of the window each fall anywhere
    within a count: variance q^2 / 6) and the channels' resolution (a step s: s^2 / 12),
    each through the model's sensitivity to it (dn/dV = 1 / Ke, dn/dI = -Ra / Ke, in RPM)."""
    sums, n = {}, 0
    for rec, r in zip(recs, rows):
        m = r.train | r.test
        k = int(m.sum())
        if not k:
            continue
        n += k
        meta = dataset.sensor_meta(rec.meta, rec.source)
        parts = {}
        q = step_rpm(rec, r)
        if q is not None:
            parts["encoder quantisation"] = q * q / 6.0
        else:  # no encoder declared: the speed's step as its rows show it, rounded (an independent probe's
            # undeclared 62.5 RPM a count read as a residual 263x the floor that no effect explains)
            q = dataset.grid_step(r.ref[m])
            if q > 0:
                parts[SPEED_GRID_PART] = q * q / 12.0
        per = rpm_per_reading(p)
        if meta.get("v_lsb_V"):
            parts["voltage resolution"] = (meta["v_lsb_V"] * per["v"]) ** 2 / 12.0
        if meta.get("i_lsb_A"):
            parts["current resolution"] = (meta["i_lsb_A"] * per["i"]) ** 2 / 12.0
        for key, v in parts.items():
            sums[key] = sums.get(key, 0.0) + v * k
    return {key: v / n for key, v in sums.items()} if n else {}


#: how a table's floor is measured where the model with every library effect leaves less out of fold than the
#: model the diagnosis starts from (core.fit_model)
FROM_ALL_EFFECTS = ("the out-of-fold residual of the model with every library effect, less than the model under "
                    "test's")


def floor(data, recs, res, mse_out_of_fold: float, p, cap_rpm2: float = math.nan) -> NoiseFloor:
    """The NoiseFloor of the held-out residual res of model p (mse_out_of_fold: its held-out
    mean squared error, the floor of a table that repeats no point). cap_rpm2: the out-of-fold
    residual variance of the model with every library effect; where the floor is a model's own
    out-of-fold residual and the cap is less, the cap (FROM_ALL_EFFECTS): a model that lacks an
    effect the table shows leaves that effect in its residual, and a floor made of it calls the
    effect noise."""
    var, how, why = measured(data, res, mse_out_of_fold)
    from_model = bool(why)
    if from_model and math.isfinite(cap_rpm2) and cap_rpm2 < var:
        var, how = cap_rpm2, f"{FROM_ALL_EFFECTS}: {why[0]} ({why[1]})"
    parts = sensors(recs, data.rows, p)
    total = max(var if np.isfinite(var) else 0.0, float(sum(parts.values())))
    return NoiseFloor(var_rpm2=total if total > 0 else var, measured_rpm2=var, source=how, sensors=parts,
                      from_model=from_model and not total > var, unmeasured=why or NO_REPEATS,
                      encoder_step_rpm=encoder_step_rpm(recs, data.rows), truncated_share=truncated_share(data.rows))
