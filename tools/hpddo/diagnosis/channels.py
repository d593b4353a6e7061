"""Channel health: a voltage or current channel that is saturated, stuck, too coarse for its
range, or (the current) explains nothing of the load, named with its figure and with what
cannot be concluded because of it. Checked on the rows with the motor driven (duty > 0) of
each recording.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
from scipy import stats
from statsmodels.regression.linear_model import OLS  # (not statsmodels.api: 0.13 s more of every command's start)
from statsmodels.tools.sm_exceptions import SingularMatrixWarning
from statsmodels.tools.tools import add_constant

from .. import schema
from ..logs import dataset

SATURATED_SHARE = 0.02   # driven rows at the channel's extreme value, exactly: saturated
SATURATED_MIN_ROWS = 5
# ... and over at least this many different commands (duty for the voltage; duty and load for the
# current): one value at one command is what the protocol holds (a fixed supply, the top duty of a
# sweep), not a channel at the end of its range
SATURATED_COMMANDS = 2
STUCK_LEVELS = 2         # at most this many distinct values while the duty takes STUCK_DUTIES or more
STUCK_DUTIES = 3
COARSE_LEVELS = 20       # fewer steps than this over the range of the driven rows: too coarse
# The current explains nothing of the load when, with the speed varying beyond the voltage by
# more than LOAD_MIN_NOISE noise variances, it takes less than LOAD_SHARE of that variation
# (in a recording whose load column, if it has one, holds more than one state).
LOAD_SHARE = 0.10
LOAD_MIN_NOISE = 4.0
# ... unless the current moves with the voltage over those rows (its share of variance explained by a straight
# line in the voltage at least LOAD_COLLINEAR_R2): at one supply the terminal voltage sags with the load through the
# driver's and the leads' resistance, so the voltage carries the load as the current does, and nothing is left for
# the current to explain beyond it; the rows cannot judge the channel (an independent simulator's dyno table, one
# supply, the current 0.07..2.13 A and the speed 6086..2180 RPM with it, corr(V, I) = -0.9997: "the current channel
# ... explains nothing of the load", and Ra and every effect through the current set aside).
LOAD_COLLINEAR_R2 = 0.99

CHANNELS = (("current", "i_A", "i_lsb_A"), ("voltage", "v_V", "v_lsb_V"))
# what cannot be concluded from a faulty channel: the effects whose term reads it (schema.Effect.reads)
def _reading(channel: str) -> str:
    return ", ".join(e.name for e in schema.EFFECTS if e.reads == channel)


CANNOT = {
    "current": f"Ra and every effect that acts through the current ({_reading('current')}) cannot be concluded from it",
    "voltage": (f"Ke and every effect that acts through the voltage ({_reading('voltage')}) cannot be concluded from "
                "it, nor anything that rests on the back-EMF"),
}


# The faults after which a channel carries nothing of what it measures: a stuck channel reads the
# same value whatever the motor does. (A coarse channel still carries its steps, and a fit through it
# carries their error in its interval; a saturated channel's clipped rows are left out, clipped.)
# A channel reading two values over many duties may be stuck with its last bit toggling, or be
# following a quantity that moves less than one step there: the rows cannot tell, and either way
# nothing is concluded through it ("flat within one step").
FLAT = "flat within one step"
BLIND = ("stuck", FLAT)
#: what a selected effect's note says when its channel is blind in every recording (core, verdict)
BLIND_NOTE = "channel, stuck or flat within one step in every recording"


def everywhere(faults: list, n_recordings: int) -> set:
    """The channels that are blind (BLIND) in every one of n_recordings recordings: nothing is
    concluded through them."""
    return {ch for ch, _, _ in CHANNELS
            if len({f.recording for f in faults if f.channel == ch and f.fault in BLIND}) >= n_recordings > 0}


@dataclasses.dataclass
class ChannelFault:
    recording: str
    channel: str     # "current" or "voltage"
    fault: str       # "saturated", "stuck", "too coarse", "explains nothing of the load"
    figure: str      # the measurement, in words

    def to_json(self) -> dict:
        return {"recording": self.recording, "channel": self.channel, "fault": self.fault, "figure": self.figure,
                "cannot": CANNOT[self.channel], "text": self.text()}

    def text(self) -> str:
        verb = "" if self.fault.startswith("explains") else "is "
        return (f"the {self.channel} channel of {self.recording} {verb}{self.fault} ({self.figure}): "
                f"{CANNOT[self.channel]}")


# The evidence that a channel clips at an end it reads over several commands (a held end alone is
# no evidence: the top load of a recording draws the same current at every duty, and a channel
# whose noise stays within a step reads it as one code):
#  * a channel that dithers reads a pile of rows at one exact value: the holds that reach the end
#    read DITHER_CODES or more distinct values short of it (their noise spreads them over steps), and
#    the end holds more of their rows than the band of one noise width below it would leave it if
#    nothing clipped (a density that falls towards the sample's largest value puts no more rows in
#    its last code than in any code below it; a clip puts there every reading beyond it): more than
#    one code's share of that band at p < PILE_P (binomial). The largest values of a hold's noise
#    alone, read exactly by a few rows, are the tail of its sample, not a pile;
#  * or the motor's own balance says the rows at the end measured more than it: the value the
#    other channel and the speed imply (the recording's V = a w + b I + c, least squares over the
#    rows off the ends) exceeds the reading at the end by CLIP_STEPS steps (or CLIP_SE standard
#    errors) more than at the rows just short of it (CLIP_NEAR_STEPS), whose bias it shares. The
#    standard error holds the balance's own, extrapolated to the end (Balance.se_between): a
#    coarse channel's rounding is one error per operating point, shared by its rows, so the
#    balance's covariance is clustered by operating point (BALANCE_GROUPS).
DITHER_CODES = 3
PILE_P = 1e-3
CLIP_STEPS = 1.0
CLIP_SE = 4.0
CLIP_NEAR_STEPS = 3.0
CLIP_MIN_NEAR = 5


# The balance bends where the motor's own physics does (the copper heating with the current, the
# armature reaction, a brush drop levelling off): fitted on the rows off the ends, a straight balance
# V = a w + b I + c leaves that bend at the highest current, where a channel would clip, and reads it as
# a clip. Where the rows off the ends show the bend (the terms I^2, I w, w^2, I^3 together at p <
# CURVE_P: the settled copper adds a r Ra^2 I^3 to the drop, the armature reaction I w), the balance
# carries them and is extrapolated to the ends with them.
CURVE_P = 1e-3


@dataclasses.dataclass
class Balance:
    """A channel's value per row that the motor's balance implies (implied()), and what it takes to
    say how well: the balance's design per row, its coefficients' covariance and its slope in the
    channel (1 for the voltage; dV/dI for the current)."""

    values: np.ndarray          # NaN where the balance cannot say
    design: np.ndarray | None = None
    covs: tuple = ()            # the coefficients' covariances, plain and clustered (_clustered)
    slope: np.ndarray | None = None

    @staticmethod
    def none(n: int) -> "Balance":
        return Balance(np.full(n, np.nan))

    def take(self, rows) -> "Balance":
        if self.design is None:
            return Balance(self.values[rows])
        return Balance(self.values[rows], self.design[rows], self.covs, self.slope[rows])

    def se_between(self, a: np.ndarray, b: np.ndarray) -> float:
        """The standard error of the balance's mean value over rows a less that over rows b: the
        coefficients' error extrapolated to where the two sets of rows lie, the largest over its
        covariances (0 where unknown)."""
        if self.design is None or not a.any() or not b.any():
            return 0.0
        dx = self.design[a].mean(axis=0) - self.design[b].mean(axis=0)
        slope = float(np.nanmean(np.r_[self.slope[a], self.slope[b]]))
        var = max(float(dx @ c @ dx) for c in self.covs)
        return float(np.sqrt(var)) / abs(slope) if var > 0 and np.isfinite(slope) and slope != 0 else 0.0


# The balance's errors are not independent row by row: a channel's rounding is one error per operating
# point, which every row of it shares. Its covariance is clustered by operating point: the rows of one
# command that read one code of the current, or of the voltage (the larger of the two), or row by row
# where fewer than BALANCE_GROUPS clusters per coefficient are left.
BALANCE_GROUPS = 2


def _clustered(y: np.ndarray, x: np.ndarray, groups: list):
    """The OLS fit of y on x and its coefficients' covariance: the largest over the clusterings in
    groups (each one label per row) that hold BALANCE_GROUPS clusters per coefficient, or the plain
    one (row by row) where none does."""
    fit = OLS(y, x).fit()
    covs = [np.asarray(fit.cov_params(), float)]
    for g in groups:
        labels = np.unique(g, axis=0, return_inverse=True)[1].ravel()
        if labels.max() + 1 >= BALANCE_GROUPS * x.shape[1]:
            robust = fit.get_robustcov_results(cov_type="cluster", groups=labels)
            covs.append(np.asarray(robust.cov_params(), float))
    return fit, covs


def _bend_p(x_bent: np.ndarray, fit, covs: list) -> float:
    """The p value of the bent terms (the design's columns past the straight three) being zero: the
    largest over the covariances (Wald, chi-square)."""
    q = np.asarray(fit.params, float)[3:]
    p = 0.0
    for cov in covs:
        c = cov[3:, 3:]
        try:
            stat = float(q @ np.linalg.solve(c, q))
        except np.linalg.LinAlgError:
            return 1.0
        p = max(p, float(stats.chi2.sf(stat, len(q))) if np.isfinite(stat) and stat >= 0 else 1.0)
    return p


def implied(r, name: str, command=None) -> Balance:
    """The channel `name`'s value per row that the motor's balance implies (V = a w + b I + c, and
    its bend where the rows show one: CURVE_P), from the other channel and the speed, least squares
    over the driven rows with a speed at which the channel reads neither end it may clip at; NaN where
    it cannot say: no speed, too few rows, or an I term it does not determine). The current's value:
    the reading moved by the voltage's excess over the balance at it, over the balance's slope in I
    there (with the straight balance, (V - a w - c) / b). command: each row's command (a vector or a
    matrix, one row per row of r), which with a channel's code names an operating point
    (BALANCE_GROUPS); default the duty."""
    n = len(r.v)
    ok = (r.duty > 0) & np.isfinite(r.v) & np.isfinite(r.i) & np.isfinite(r.ref)
    if ok.sum() < 10:
        return Balance.none(n)
    x_ch = r.v if name == "voltage" else r.i
    # the balance from the rows off the ends it may clip at (the bottom only at zero or below: _saturated)
    lo = np.min(x_ch[ok])
    inner = ok & (x_ch < np.max(x_ch[ok])) & ((x_ch > lo) | (lo > 0))
    if inner.sum() < 10 or np.ptp(r.i[inner]) <= 0 or np.ptp(r.ref[inner]) <= 0:
        return Balance.none(n)
    w = r.ref * (2.0 * np.pi / 60.0)
    cmd = np.asarray(r.duty if command is None else command, float).reshape(n, -1)
    groups = [np.column_stack([cmd[inner], r.i[inner]]), np.column_stack([cmd[inner], r.v[inner]])]

    def design(rows, bent):
        cols = [w[rows], r.i[rows], np.ones(int(rows.sum()))]
        if bent:
            cols += [r.i[rows] ** 2, r.i[rows] * w[rows], w[rows] ** 2, r.i[rows] ** 3]
        return np.column_stack(cols)

    x_bent = design(inner, True)
    if not (inner.sum() >= 20 and np.linalg.matrix_rank(x_bent) == x_bent.shape[1]):
        # the rows off the ends cannot show whether the balance bends (fewer than four levels of the current, say):
        # a straight line through them, extrapolated to an end, would read the motor's own bend there (saturation's
        # I w) as a clip, so the balance says nothing (a bench's load at three voltages, its top load one code at all
        # three, 0.08 A under a straight balance through the two loads between)
        return Balance.none(n)
    try:
        fit, covs = _clustered(r.v[inner], design(inner, False), groups)
        bent = False
        curved, curved_covs = _clustered(r.v[inner], x_bent, groups)
        if (np.all(np.isfinite(curved.params)) and np.all([np.isfinite(c).all() for c in curved_covs])
                and curved.compare_f_test(fit)[1] < CURVE_P and _bend_p(x_bent, curved, curved_covs) < CURVE_P):
            fit, covs, bent = curved, curved_covs, True
    except (np.linalg.LinAlgError, ValueError):
        return Balance.none(n)
    if not np.all(np.isfinite(fit.params)) or not np.all(np.isfinite(fit.bse)):
        return Balance.none(n)
    q = np.asarray(fit.params, float)
    x_all = np.full((n, len(q)), np.nan)
    x_all[ok] = design(ok, bent)
    v_hat = x_all[ok] @ q
    out = np.full(n, np.nan)
    if name == "voltage":
        out[ok] = v_hat
        return Balance(out, x_all, tuple(covs), np.ones(n))
    b = float(q[1])
    if not (b > 0 and abs(b) > 4.0 * float(np.sqrt(max(c[1, 1] for c in covs)))):
        return Balance.none(n)
    slope = np.full(n, np.nan)
    slope[ok] = b + (2.0 * q[3] * r.i[ok] + q[4] * w[ok] + 3.0 * q[6] * r.i[ok] ** 2 if bent else 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[ok] = np.where(slope[ok] > 0, r.i[ok] + (r.v[ok] - v_hat) / slope[ok], np.nan)
    return Balance(out, x_all, tuple(covs), slope)


def noise_of(x: np.ndarray, step: float) -> float:
    """A channel's noise (its driven readings x in steps of `step`): the robust spread of its row-to-row
    changes away from its ends (steps of load or duty are outliers to it; rows held at an end change by
    nothing), at least one step."""
    levels = np.unique(x)
    if len(levels) < 2:
        return step
    inner = (x[1:] != levels[0]) & (x[1:] != levels[-1]) & (x[:-1] != levels[0]) & (x[:-1] != levels[-1])
    dx = np.diff(x)[inner]
    return max(1.4826 * float(np.median(np.abs(dx - np.median(dx)))) / np.sqrt(2.0), step) if len(dx) > 2 else step


def _pile(x: np.ndarray, edge: float, sign: float, short: np.ndarray, step: float, noise: float) -> bool:
    """Whether the end `edge` holds a pile (the first evidence above): the rows at it against the
    rows `short` of it within one noise width (at least a step), of which a falling density leaves it
    at most one code's share."""
    width = max(noise, step)
    band = short & (sign * (edge - x) <= width + 0.5 * step)
    n_at, n_band = int(np.sum(x == edge)), int(band.sum())
    share = 1.0 / (1.0 + max(width / step, 1.0)) if step > 0 else 0.0
    return bool(share > 0 and stats.binomtest(n_at, n_at + n_band, share, alternative="greater").pvalue < PILE_P)


def _clips(x: np.ndarray, edge: float, which: str, hold: np.ndarray, step: float, balance,
           noise: float = 0.0) -> bool:
    """Whether the readings x (driven rows) at their end `edge` show the channel clipping there (the
    evidence above); hold: the hold of each row (runs of one command); balance: the balance's value
    per row (a Balance, implied(), its values NaN where unknown), or None; noise: the channel's noise
    (noise_of). A hold's rows short of the end count as its dither only within TRUNCATED_SD of that
    noise: a command that does not name the load (no load column) holds several loads, whose levels
    are other operating points."""
    at = x == edge
    sign = 1.0 if which == "top" else -1.0
    short = ~at & np.isin(hold, hold[at]) & (sign * (edge - x) <= TRUNCATED_SD * max(noise, step))
    if len(np.unique(x[short])) >= DITHER_CODES and _pile(x, edge, sign, short, step, noise):
        return True
    if balance is None:
        return False
    excess = sign * (balance.values - x)
    top = at & np.isfinite(excess)
    off = np.flatnonzero(~at & np.isfinite(excess))
    if top.sum() < SATURATED_MIN_ROWS or len(off) < CLIP_MIN_NEAR:
        return False
    # the rows just short of the end: within CLIP_NEAR_STEPS steps, at least as many as read the end
    # (the nearest; a fine channel's step is no distance)
    dist = sign * (edge - x[off])
    order = np.argsort(dist, kind="stable")
    k = max(int(np.sum(dist <= CLIP_NEAR_STEPS * step)), CLIP_MIN_NEAR, int(top.sum()))
    near = np.zeros(len(x), bool)
    near[off[order[:k]]] = True
    d = float(np.median(excess[top]) - np.median(excess[near]))
    spread = 1.4826 * float(np.median(np.abs(excess[near] - np.median(excess[near]))))
    se = float(np.hypot(1.2533 * spread * np.sqrt(1.0 / top.sum() + 1.0 / near.sum()),
                        balance.se_between(top, near)))
    return d > max(CLIP_STEPS * step, CLIP_SE * se)


def _saturated(x: np.ndarray, command: np.ndarray, step: float = 0.0, balance=None) -> list:
    """[(edge value, "top"/"bottom", rows at it, commands at it)] of the ends of x (a channel's driven
    readings, in steps of `step`; balance: the balance's value of each, a Balance, implied()) that it
    reads exactly in at least SATURATED_SHARE of the rows (SATURATED_MIN_ROWS) under at least
    SATURATED_COMMANDS different commands, with the evidence that it clips there (_clips): the ends
    of its range, not what it measured (the bottom only at zero or below)."""
    out = []
    if len(x) == 0:
        return out
    hold = _holds(command)
    noise = noise_of(x, step)
    for edge, which in ((x.max(), "top"), (x.min(), "bottom")):
        if which == "bottom" and edge > 0:
            # a positive floor held at several commands is a motor's own (the no-load current of a sweep,
            # its friction, at every duty), not a channel's end: a channel clips at zero or below
            continue
        at = x == edge
        n = int(np.sum(at))
        held = len(np.unique(command[at], axis=0))
        if (n >= max(SATURATED_MIN_ROWS, SATURATED_SHARE * len(x)) and held >= SATURATED_COMMANDS
                and _clips(x, float(edge), which, hold, step, balance, noise)):
            out.append((float(edge), which, n, held))
    return out


TRUNCATED_SD = 4.0  # rows this many noise standard deviations from a clipping edge are its truncated sample


def _step(meta: dict, lsb_key: str, levels: np.ndarray, readings: int = 0) -> float:
    """A channel's step: the declared resolution, else the grid its values lie on (levels: its distinct
    values, two or more, of `readings` readings): the smallest step between them where they lie on its
    grid above the lowest (dataset.on_grid: a converter's codes, whatever its offset; refitted,
    dataset.refined_step, where they are written with fewer decimals than the step has), else the
    resolution the values are written with (written_step). A table's settled means lie on no grid, and
    their smallest step is between two loads: an independent bench's loads 0.27 A apart, logged to 1 uA,
    were taken for the current's step, its zero's doubt 0.545 A, and a 0.8 V brush drop went unnamed."""
    if meta.get(lsb_key):
        return meta[lsb_key]
    step = float(np.min(np.diff(levels)))
    if len(levels) <= 2 or not step > 0:
        return step
    if dataset.on_grid(levels, step, levels[0]):
        return step
    # a converter's codes written with fewer decimals: refitted where enough levels make a grid no chance gives
    # (a few settled means fit some grid once its step is fitted to them) and the readings come back to them (a
    # converter reads each code again and again; a table's settled means, of loads evenly spaced, are each read
    # once, and their spacing is no step)
    refit = len(levels) >= GRID_REFIT_LEVELS and readings >= GRID_REFIT_REPEATS * len(levels)
    fitted = dataset.refined_step(levels, step, levels[0]) if refit else 0.0
    return fitted if fitted > 0 and dataset.on_grid(levels, fitted, levels[0]) else written_step(levels)


GRID_REFIT_LEVELS = 8   # (_step)
GRID_REFIT_REPEATS = 2  # (_step: readings per level)


WRITTEN_DECIMALS = 12  # at most this many decimals are looked for (written_step)


def written_step(values: np.ndarray) -> float:
    """The resolution the values are written with: 10^-d for the fewest decimals d (at most WRITTEN_DECIMALS)
    that write every one of them; 0 where they need more (computed values written in full)."""
    x = np.asarray(values, float)
    x = x[np.isfinite(x)]
    for d in range(WRITTEN_DECIMALS + 1):
        scaled = x * 10.0 ** d
        if x.size == 0 or np.max(np.abs(scaled)) > 1e13:  # beyond what a double's 16 digits tell
            break
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-14 * np.abs(scaled) + 1e-6):
            return 10.0 ** -d
    return 0.0


# the Rows attribute that carries each channel's reading (effects.Rows)
ROW_ATTR = {"current": "i", "voltage": "v"}


def steps(rec, r) -> dict:
    """{Rows attribute ("i", "v"): the channel's step} of a recording (rows r): the declared
    resolution, else the smallest step between the values it logs on the driven rows (0 where it
    logs fewer than two)."""
    driven = (r.duty > 0) & np.isfinite(r.v) & np.isfinite(r.i)
    meta = dataset.sensor_meta(rec.meta, rec.source)
    out = {}
    for name, col, lsb_key in CHANNELS:
        x = rec.df[col].to_numpy(float)[driven]
        x = x[np.isfinite(x)]
        levels = np.unique(x)
        out[ROW_ATTR[name]] = float(_step(meta, lsb_key, levels, len(x))) if meta.get(lsb_key) or len(levels) > 1 else 0.0
    return out


def _command_rows(r, load: np.ndarray, name: str) -> np.ndarray:
    """The commands that move the channel `name`, per row of r: the duty moves the voltage; the duty
    and the load (a column of zeros where the log has none) the current."""
    return r.duty if name == "voltage" else np.column_stack([r.duty, load])


def _holds(command: np.ndarray) -> np.ndarray:
    """The hold of each row: runs of consecutive rows at one command (in a time series, one operating
    point), numbered from 1."""
    keys = _keys(command)
    return np.cumsum(np.r_[True, keys[1:] != keys[:-1]])


def _keys(command: np.ndarray) -> np.ndarray:
    """One value per row of command (a vector, or a matrix of one command per row) naming the command."""
    c = np.asarray(command, float)
    return c if c.ndim == 1 else np.array([hash(tuple(row)) for row in c])


def clipped(rec, r) -> tuple[np.ndarray, list]:
    """The rows of a recording (rows r) at which a saturated channel (_saturated) reads an end of its
    range, and a sentence for each such channel: a clipped reading is no measurement of the motor, and
    no fit may use it (a coarse or stuck channel is named by check(), its rows kept)."""
    driven = (r.duty > 0) & np.isfinite(r.v) & np.isfinite(r.i)
    mask = np.zeros(len(r.duty), bool)
    said = []
    if driven.sum() < SATURATED_MIN_ROWS:
        return mask, said
    load = rec.df["load"].to_numpy() if "load" in rec.df else np.zeros(rec.n)
    meta = dataset.sensor_meta(rec.meta, rec.source)
    for name, col, lsb_key in CHANNELS:
        x_all = rec.df[col].to_numpy(float)
        x = x_all[driven]
        levels = np.unique(x)
        if len(levels) < 2:
            continue
        command_all = _command_rows(r, load, name)
        command = command_all[driven]
        step = _step(meta, lsb_key, levels, len(x))
        fine = np.ptp(x) / step >= COARSE_LEVELS
        balance = implied(r, name, command_all).take(driven)
        hold = _holds(command)
        noise = noise_of(x, step)
        for edge, which, n, _held in _saturated(x, command, step, balance):
            at = x == edge
            # the rows of a hold in which a fine channel clips that read within TRUNCATED_SD of its
            # noise below the edge: they read below it because their noise did, a truncated sample
            # whose mean is biased away from the edge (a table's row is its own operating point, and
            # a coarse channel's last step is one of its few levels: their rows at the edge only)
            near = np.abs(x - edge) <= TRUNCATED_SD * noise
            hit = (np.isin(hold, hold[at]) & near) | at if fine and not r.steady else at
            rows = np.flatnonzero(driven)[hit]
            mask[rows] = True
            said.append(f"{rec.source}: {n} driven rows read the {name} channel's {which} ({edge:.4g}, saturated); "
                        f"they and the other {int(hit.sum()) - n} rows of the holds in which it clips are left "
                        "out of every fit")
    return mask, said


def _faults(rec, r, sigma2: float, moved: dict) -> list:
    """The faults of one recording's channels; moved: {channel: the most levels any recording of the run moves it
    over, this one's among them} (check)."""
    driven = (r.duty > 0) & np.isfinite(r.v) & np.isfinite(r.i)
    if driven.sum() < SATURATED_MIN_ROWS:
        return []
    out = []
    meta = dataset.sensor_meta(rec.meta, rec.source)
    duties = len(np.unique(r.duty[driven]))
    load = rec.df["load"].to_numpy() if "load" in rec.df else np.zeros(rec.n)
    for name, col, lsb_key in CHANNELS:
        x = rec.df[col].to_numpy(float)[driven]
        levels = np.unique(x)
        if len(levels) <= STUCK_LEVELS and duties >= STUCK_DUTIES:
            figure = f"{len(levels)} distinct values over {len(x)} driven rows at {duties} duties"
            if len(levels) == 1:
                out.append(ChannelFault(rec.name, name, "stuck", figure))
            else:
                out.append(ChannelFault(rec.name, name, FLAT, f"{figure}, {np.ptp(levels):.3g} apart: stuck, or the "
                                        f"{name} moves less than a step here; the rows cannot tell"))
            continue
        if len(levels) < 2:
            continue  # one value and one command: the protocol holds it (a supply per log), no fault to name
        command_all = _command_rows(r, load, name)
        command = command_all[driven]
        commands = len(np.unique(command, axis=0))
        step = _step(meta, lsb_key, levels, len(x))
        span = float(np.ptp(x))
        # too coarse for the range its commands move it over (one command: its range is its noise)
        if commands >= SATURATED_COMMANDS and step > 0 and span > 0 and moved[name] < COARSE_LEVELS:
            out.append(ChannelFault(rec.name, name, "too coarse", f"steps of {step:.3g} over a range of {span:.3g}: "
                                    f"{span / step:.0f} levels"))
            continue  # a coarse channel repeats its extremes as it repeats every level
        for edge, which, n, held in _saturated(x, command, step, implied(r, name, command_all).take(driven)):
            out.append(ChannelFault(rec.name, name, "saturated", f"{n} of {len(x)} driven rows read exactly "
                                    f"{edge:.4g} ({which} of its range) over {held} different commands"))
            break
    # the current and the load: what the current explains of the speed beyond the voltage
    # (a recording whose load column holds one state has no load to explain: its speed varies
    # beyond the voltage with the temperature, not the load)
    lab = driven & (r.train | r.test) & np.isfinite(r.ref)
    loads = rec.df["load"].to_numpy()[lab] if "load" in rec.df else None
    varied = loads is None or len(np.unique(loads)) > 1
    if varied and lab.sum() > 10 and not any(f.channel == "current" and f.fault in BLIND for f in out):
        y = r.ref[lab]
        xv = add_constant(r.v[lab])
        with warnings.catch_warnings():  # a channel flat over these rows makes the design rank-deficient: the
            # least-squares residual (pinv) is still the one asked for, and the user sees no library warning
            warnings.simplefilter("ignore", SingularMatrixWarning)
            sse_v = float(np.sum(OLS(y, xv).fit().resid ** 2))
            sse_vi = float(np.sum(OLS(y, np.column_stack([xv, r.i[lab]])).fit().resid ** 2))
            i_lab = r.i[lab]
            ss_i = float(np.sum((i_lab - np.mean(i_lab)) ** 2))
            r2_iv = 1.0 - float(np.sum(OLS(i_lab, xv).fit().resid ** 2)) / ss_i if ss_i > 0 else 0.0
        # ... beyond the noise of the speed's own channel too: a coarse encoder's rounding (q^2 / 12 a row, its step
        # q as the rows show it) is no load the current should explain (an independent probe's 62.5 RPM a count,
        # undeclared: "the current ... explains nothing of the load" of 23.2 RPM RMS, its rounding 18 RPM)
        q = dataset.grid_step(r.ref[lab])
        if sse_v > LOAD_MIN_NOISE * max(sigma2, q * q / 12.0, 1e-12) * lab.sum() and r2_iv < LOAD_COLLINEAR_R2:
            share = 1.0 - sse_vi / sse_v
            if share < LOAD_SHARE:
                out.append(ChannelFault(rec.name, "current", "explains nothing of the load",
                                        f"the speed varies by {np.sqrt(sse_v / lab.sum()):.3g} RPM RMS beyond what the "
                                        f"voltage explains; the current takes {100 * share:.0f} % of it"))
    return out


def check(recs, rows, sigma2: float) -> list:
    """[ChannelFault] over the recordings (rows: effects.Rows of each; sigma2: the noise floor). A channel is the
    board's, not a recording's: it is too coarse only where no recording of the run moves it over COARSE_LEVELS of
    its steps (levels_moved); one that does shows the channel resolves the motor, and a recording that holds it within
    a few steps (a sweep at no load, its current the friction's alone) holds the motor still on it, no fault of the
    channel (a fuzzing round's 4.9 mA current channel, 16 levels over a no-load sweep and hundreds over the load
    steps beside it, was called too coarse, and the Ra the data support was set aside for it)."""
    moved = {name: max((levels_moved(rec, r, name) for rec, r in zip(recs, rows)), default=0.0)
             for name, _, _ in CHANNELS}
    return [f for rec, r in zip(recs, rows) for f in _faults(rec, r, sigma2, moved)]


def levels_moved(rec, r, name: str) -> float:
    """How many of its steps channel `name` moves over on a recording's driven rows (its range over its step); 0
    where it holds one value or its step is not known."""
    driven = (r.duty > 0) & np.isfinite(r.v) & np.isfinite(r.i)
    col, lsb_key = next((c, k) for n, c, k in CHANNELS if n == name)
    x = rec.df[col].to_numpy(float)[driven]
    x = x[np.isfinite(x)]
    levels = np.unique(x)
    if len(levels) < 2:
        return 0.0
    step = _step(dataset.sensor_meta(rec.meta, rec.source), lsb_key, levels, len(x))
    return float(np.ptp(x) / step) if step > 0 else 0.0
