"""Which library effect is missing: forward selection scored on held-out rows, a block
bootstrap for confidence, identifiability and confounding checks, and the verdict.

Scoring. Every candidate is added to the current model and the model is refitted on the
training rows (Ke and all coefficients, effects.fit); the score is what it removes from the
held-out squared error. Each recording's held-out rows carry equal total weight, as the
per-condition average RMSE does. The gain is tested against its own sampling noise with
contiguous blocks of held-out rows (residuals are autocorrelated; blocks keep that).

An effect is named when, at its step of the forward selection:
  * its held-out gain is at least Z_MIN standard errors (block estimate),
  * it removes at least REL_MIN of the current held-out mean squared error and at least
    EXCESS_MIN of the part of it above the noise floor,
  * it removes at least SCORE_MIN of the held-out mean squared error of the model the
    selection started from (its score): an effect that the data support but that changes
    the speed estimate by less than that is not what a user looks for, and a small gain at
    a late step is where an autocorrelated residual passes the noise test (named effects
    score 0.06 and more on the twin's benches, unnamed candidates 0.008 and less); a wrong
    Ra is exempt: it is the reading's error, bounded by its prior, and worth saying at any
    size beyond the reading's tolerance,
  * its fitted coefficient is physical (sign and order of magnitude; effects.Effect.physical):
    a wrong-signed coefficient is the fit using the term's inputs to chase noise.
A wrong Ra (RA_MISMATCH, Ra moving under a prior around the reading) is a candidate too,
scored the same way. Selection stops when no candidate passes. Confidence: the selection is repeated on
BOOTSTRAP resamples of the training rows' operating points (op_blocks: a block per duty and
load, at most TRAIN_BLOCK_S long); the inclusion frequency is the share of resamples in
which the effect is named. Naming depends on the held-out tests alone: a term whose gain is
within the noise is not named, whatever its inclusion.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..model import effects as fx
from .. import interrupt, progress
from ..model import physics as ph
from .. import schema
from . import analysis

Z_MIN = 2.5
REL_MIN = 0.02
EXCESS_MIN = 0.10
SCORE_MIN = 0.02
#: the residual is above the noise floor where its excess over the noise variance is more than this share of it
#: (the verdict's sentences; the look-ahead tries pairs of effects only above it)
ABOVE_SHARE = 0.5
#: the look-ahead tries pairs of effects only where the model with every library effect removes at least this share
#: of what the model at hand leaves above the noise variance (its held-out MSE against theirs)
PAIR_SHARE = 0.5
BLOCK_S = 15.0          # held-out blocks: at most this long, seconds (op_blocks)
TRAIN_BLOCK_S = 30.0    # bootstrap blocks: one operating point, at most this long, seconds (op_blocks)
BOOTSTRAP = 12
# Small data (steady-state tables, short runs): with at most CV_MAX_ROWS labelled rows, a
# chronological 20 % is too few rows, and the end of a sorted table (its highest voltages),
# not a sample of its operating points. Every row is then held out once instead: CV_FOLDS
# folds of whole operating points (op_blocks, dealt round-robin over the recordings), each
# scored by the model fitted on the others.
CV_MAX_ROWS = 1000
CV_FOLDS = 5
IDENT_SIGMAS = 4.0      # a plausible coefficient must be this many standard errors to be seen
CONFOUND_CORR = 0.95    # partial correlation of two regressors above which they are confounded
CONFOUND_GAIN = 0.6     # an alternative explaining this share of the chosen gain is confounded

# Ra as a nuisance parameter. Ra is the user's multimeter reading (log metadata ra_ohm or
# --ra-ohm); the diagnosis may move it, as the candidate RA_MISMATCH of the forward
# selection, within a Gaussian prior around the reading. RA_TOLERANCE is the reading's
# 1-sigma relative uncertainty: a two-wire reading of a few ohms carries lead and contact
# resistance (0.1-0.2 ohm unless nulled: 2-4 %), the brushes' contact varies with the rotor
# position (a few %), and the copper is read at the bench's temperature, not t_ref
# (0.39 %/K: 5 K is 2 %); added in quadrature, about 5 %. Ra is named mismatched when the
# selection takes RA_MISMATCH (its gain passes the same tests as an effect's) and the value
# the data support lies more than RA_MISMATCH_SIGMAS tolerances from the reading: a shift
# within the reading's own uncertainty is not a mismatch.
RA_MISMATCH = "ra_mismatch"
RA_TOLERANCE = 0.05
RA_MISMATCH_SIGMAS = 1.0
# ... and at most RA_PLAUSIBLE_SIGMAS tolerances (15 %): the prior puts 0.3 % beyond; a fit
# that wants Ra further off is taking up an error that only looks proportional to the
# current on these rows (a winding warm throughout the held-out rows), not the reading's.
RA_PLAUSIBLE_SIGMAS = 3.0
# An effect is named only where the recordings tell it from a wrong reading: the model without it
# and with Ra moving freely (no prior) within RA_ALTERNATIVE_SIGMAS tolerances of the reading (25 %),
# where that Ra lies beyond the reading's own band (RA_MISMATCH_SIGMAS), must miss the held-out rows
# by Z_MIN standard errors more. A reading can be that far off (a
# two-wire reading of a 1-ohm motor through 0.2 ohm of leads is 20 % high), and an effect whose
# evidence is a current-proportional error that such an Ra removes is not told from it; the
# sentence then names both and the measurement that separates them (RA_SEPARATOR).
RA_ALTERNATIVE_SIGMAS = 5.0
RA_SEPARATOR = ("re-measure Ra at the motor's terminals (four-wire, or the leads' resistance subtracted, "
                "at the bench's temperature), or a recording at a known winding temperature over a wide "
                "range of current (stall or heavy load next to light load)")


def ra_prior(m2: ph.PhysicsParams, sigma2: float) -> tuple:
    """The prior of fx.fit(ra_prior=...): the reading, its 1-sigma in ohm, the noise level."""
    return (m2.ra_ohm, RA_TOLERANCE * m2.ra_ohm, float(np.sqrt(max(sigma2, 1e-12))))


def fit_names(rows, m2: ph.PhysicsParams, names, sigma2: float, **kw) -> ph.PhysicsParams:
    """fx.fit of the effects in names; with RA_MISMATCH among them, Ra moves too (prior
    around m2's reading)."""
    names = list(dict.fromkeys(names))  # each effect once, in order
    if RA_MISMATCH in names:
        names.remove(RA_MISMATCH)
        kw["ra_prior"] = ra_prior(m2, sigma2)
        kw["hold"] = material_holds(names, kw.get("hold"))
    return fx.fit(rows, m2, names, **kw)


def material_holds(names, hold=None) -> dict:
    """hold with every material coefficient among names held at the material's value (where
    Ra moves): Ra and a free temperature coefficient trade off (Ra (1 + a (T - t_ref)) with
    the winding node's rise), and only the material constant tells them apart."""
    hold = dict(hold or {})
    for n in names:
        if fx.LIBRARY[n].material is not None and n not in hold:
            hold[n] = fx.LIBRARY[n].material
    return hold


# Ra as the data alone determine it (no prior): moved within a factor RA_DATA_RANGE of the
# reading; a fit that stops at either edge says the data do not determine it.
RA_DATA_RANGE = 100.0


def ra_data_bounds(m2: ph.PhysicsParams) -> tuple:
    return (m2.ra_ohm / RA_DATA_RANGE, m2.ra_ohm * RA_DATA_RANGE)


def fit_ra_free(rows, m2: ph.PhysicsParams, names, **kw) -> ph.PhysicsParams:
    """fx.fit of the effects in names (RA_MISMATCH dropped) with Ra moving and no prior
    (ra_data_bounds): Ra as the data alone determine it."""
    names = [n for n in names if n != RA_MISMATCH]
    kw["hold"] = material_holds(names, kw.get("hold"))
    return fx.fit(rows, m2, names, ra_bounds=ra_data_bounds(m2), **kw)


def ra_alternative_bounds(m2: ph.PhysicsParams) -> tuple:
    """Where a wrong reading can put the true Ra (RA_ALTERNATIVE_SIGMAS tolerances either side)."""
    a = RA_ALTERNATIVE_SIGMAS * RA_TOLERANCE * m2.ra_ohm
    return (max(m2.ra_ohm - a, m2.ra_ohm / RA_DATA_RANGE), m2.ra_ohm + a)


def scored_ra_alternative(d: "Data", m2: ph.PhysicsParams, names, weights=None, start=None) -> tuple:
    """scored() of the effects in names with Ra moving freely within ra_alternative_bounds: the
    explanation by a wrong reading that every named effect must beat."""
    names = [n for n in names if n != RA_MISMATCH]
    hold = material_holds(names)
    return scored(d, lambda rows, st: fx.fit(rows, m2, names, weights=weights, start=st, hold=hold,
                                             ra_bounds=ra_alternative_bounds(m2)), start)


def needed_beside_free_ra(d: "Data", m2: ph.PhysicsParams, given, names, res_named, sigma2: float,
                          swaps=()) -> dict:
    """{effect: z} for each effect in names: how far the recordings tell the named model (its
    held-out residuals res_named: every effect of given + names, Ra as the selection held it) from
    the model without that effect and with Ra moving freely within ra_alternative_bounds
    (apart_z), and from the model with each effect of swaps in its place and Ra as free (the
    effects already found not told from a wrong Ra: one that does the work of such an effect is no
    better attributed than it); the smallest of these. Below Z_MIN the effect is not told from a
    reading of Ra further off than its own tolerance (an Ra within RA_MISMATCH_SIGMAS tolerances of
    the reading is the reading: the effect's interval carries that doubt, intervals.with_budget;
    an effect put in its place fits at any Ra). An offset that the rows at rest measure
    (effects.rest_offsets, Z_MIN standard errors from zero) is read there, not traded with Ra; an
    alternative that cannot be fitted is none: the effect keeps its name (inf)."""
    names = [n for n in names if n != RA_MISMATCH]
    rest = {n: abs(v) / se for n, (v, se, _) in fx.rest_offsets(d.rows).items() if se > 0}
    out = {}
    for n in names:
        if rest.get(n, 0.0) >= Z_MIN:
            out[n] = math.inf
            continue
        others = list(given) + [x for x in names if x != n]
        zs = []
        for alt in [None] + [s for s in swaps if s not in names and s != RA_MISMATCH]:
            try:
                p_n, r_n = scored_ra_alternative(d, m2, others + ([alt] if alt else []))
            except Exception:  # noqa: BLE001 (a degenerate fit is no alternative)
                continue
            if alt is None and abs(ra_sigmas(m2, p_n.ra_ohm)) <= RA_MISMATCH_SIGMAS:
                continue
            zs.append(apart_z(d, r_n, res_named, sigma2))
        out[n] = min(zs, default=math.inf)
    return out


def rivals_beside_free_ra(d: "Data", m2: ph.PhysicsParams, given, names, candidates, res_named,
                          sigma2: float) -> dict:
    """{effect: {rival: z}} for each effect in names: the candidates that, fitted in its place with Ra
    moving freely within ra_alternative_bounds and a physical coefficient, the recordings do not tell
    from the named model (res_named: its held-out residuals) by Z_MIN standard errors (apart_z). A
    wrong reading of Ra with that candidate explains the rows as well: the two are named together
    with what separates them (core.confounding). An offset that the rows at rest measure has none."""
    names = [n for n in names if n != RA_MISMATCH]
    rest = {n: abs(v) / se for n, (v, se, _) in fx.rest_offsets(d.rows).items() if se > 0}
    out = {}
    for n in names:
        if rest.get(n, 0.0) >= Z_MIN:
            continue
        others = list(given) + [x for x in names if x != n]
        for c in candidates:
            if c in names or c == RA_MISMATCH or c in given:
                continue
            try:
                p_c, r_c = scored_ra_alternative(d, m2, others + [c])
            except Exception:  # noqa: BLE001 (a degenerate fit is no rival)
                continue
            if not _physical(c, _value(c, p_c), m2):
                continue
            z = apart_z(d, r_c, res_named, sigma2)
            if z < Z_MIN:
                out.setdefault(n, {})[c] = z
    return out


def ra_sigmas(m2: ph.PhysicsParams, ra: float) -> float:
    """How many tolerances ra lies from the reading."""
    return (ra - m2.ra_ohm) / (RA_TOLERANCE * m2.ra_ohm)


# Recordings that separate two effects which the data at hand cannot tell apart: the
# `separated_from` entries of the effects' declarations (hpddo/schema.py).
SEPARATORS = schema.SEPARATORS


def separator(a: str, b: str) -> str:
    if RA_MISMATCH in (a, b):
        return RA_SEPARATOR
    s = SEPARATORS.get(frozenset({a, b}))
    if s:
        return s
    ea, eb = fx.LIBRARY[a], fx.LIBRARY[b]
    return (f"a recording in which {ea.signature} and {eb.signature} vary independently "
            f"({ea.excited_by}; {eb.excited_by})")


@dataclasses.dataclass
class Data:
    """The rows of every recording with their held-out weights and blocks."""

    rows: list
    w_test: list       # per recording: per-row weight of held-out rows (sums to 1 per recording)
    blocks_test: list  # per recording: block id per row (-1 outside the held-out rows)
    blocks_train: list  # per recording: block id per row (-1 outside the training rows)
    # cross-validation (small data, CV_MAX_ROWS): per fold, the rows of every recording with
    # the fold's rows as test and the others as train; None: the chronological split
    folds: list | None = None
    # per recording: the rounding errors its held-out rows share, [(label per row, standard RPM per row)]
    # per channel (intervals.shared_rounding); () where unknown
    rounding: list = ()

    @property
    def scheme(self) -> str:
        """How the rows are held out, in words."""
        if self.folds is None:
            return "the last 20 % of each recording (chronological)"
        return f"every row once, {len(self.folds)} folds of whole operating points (cross-validation)"


def op_blocks(r, mask: np.ndarray, max_s: float) -> np.ndarray:
    """Block id per row (-1 outside mask): a new block wherever the operating point (duty,
    load) changes, and after max_s seconds within one (a long run at one duty is several
    blocks, each at its own temperature), and wherever the mask is interrupted. The
    bootstrap resamples these: whole operating points, not stretches of time that straddle
    two of them."""
    n = len(r.dt)
    df = r.rec.df
    load = df["load"].to_numpy() if "load" in df else np.zeros(n)
    change = np.ones(n, bool)
    if n > 1:
        change[1:] = (r.duty[1:] != r.duty[:-1]) | (load[1:] != load[:-1])
    t = np.cumsum(r.dt)
    out = np.full(n, -1, int)
    bid, start, prev_in = -1, 0.0, False
    for k in range(n):
        if not mask[k]:
            prev_in = False
            continue
        if not prev_in or change[k] or t[k] - start >= max_s:
            bid += 1
            start = t[k]
        out[k] = bid
        prev_in = True
    return out


def cv_folds(rows, k: int = CV_FOLDS) -> list | None:
    """The folds of cross-validation over whole operating points (op_blocks of the labelled
    rows), dealt round-robin over the blocks of all recordings in order; None with fewer
    than two blocks."""
    blocks = [op_blocks(r, r.train | r.test, BLOCK_S) for r in rows]
    counts = [int(b.max()) + 1 if len(b) else 0 for b in blocks]  # op_blocks numbers from 0; -1 for none
    k = min(k, sum(counts))
    if k < 2:
        return None
    folds = [[] for _ in range(k)]
    for r, b, offset in zip(rows, blocks, np.cumsum([0] + counts[:-1])):
        fold_of = np.where(b >= 0, (b + offset) % k, -1)
        good = r.train | r.test
        for f in range(k):
            folds[f].append(dataclasses.replace(r, train=good & (fold_of != f), test=good & (fold_of == f)))
    return folds


def make_data(rows) -> Data:
    """The rows as the diagnosis scores them: the chronological split, or (at most
    CV_MAX_ROWS labelled rows) every labelled row held out once by cross-validation (the
    rows' train and test masks then both cover every labelled row)."""
    folds = None
    if sum(int((r.train | r.test).sum()) for r in rows) <= CV_MAX_ROWS:
        folds = cv_folds(rows)
        if folds is not None:
            rows = [dataclasses.replace(r, train=r.train | r.test, test=r.train | r.test) for r in rows]
    w, bt, btr = [], [], []
    for r in rows:
        n = int(r.test.sum())
        w.append(np.where(r.test, 1.0 / max(n, 1), 0.0))
        bt.append(op_blocks(r, r.test, BLOCK_S))
        btr.append(op_blocks(r, r.train, TRAIN_BLOCK_S))
    return Data(rows=list(rows), w_test=w, blocks_test=bt, blocks_train=btr, folds=folds)


def residuals(d: Data, p: ph.PhysicsParams) -> list:
    """rpm_ref - n_M2 for every row of every recording (NaN where undefined)."""
    return [r.ref - fx.predict(r, p) for r in d.rows]


def scored(d: Data, fitter, start=None) -> tuple:
    """(params, held-out residuals) of a model refitted by fitter(rows, start) -> params:
    fitted on the training rows of d.rows; the residuals are rpm_ref - n_M2 of those params
    (chronological split) or, under cross-validation, each fold's rows by the model fitted
    on the other folds (NaN outside the labelled rows)."""
    p = fitter(d.rows, start)
    return p, held_out_residuals(d, p, fitter)


def held_out_residuals(d: Data, p: ph.PhysicsParams, fitter) -> list:
    """The held-out residuals of model p, fitted by fitter(rows, start) on d.rows' training
    rows: rpm_ref - n_M2 of p itself (chronological split) or, under cross-validation, of
    each fold's refit (started from p) on the fold's rows (NaN outside the labelled rows)."""
    if d.folds is None:
        return residuals(d, p)
    res = [np.full(len(r.ref), np.nan) for r in d.rows]
    for fold in d.folds:
        pf = fitter(fold, p)
        for e, rf in zip(res, fold):
            if rf.test.any():
                e[rf.test] = (rf.ref - fx.predict(rf, pf))[rf.test]
    return res


def scored_names(d: Data, m2: ph.PhysicsParams, names, sigma2: float, weights=None, start=None) -> tuple:
    """scored() of fit_names: the effects in names (and a moving Ra with RA_MISMATCH)."""
    return scored(d, lambda rows, st: fit_names(rows, m2, names, sigma2, weights=weights, start=st), start)


def held_out_mse(d: Data, res) -> float:
    """Weighted held-out MSE: the mean over recordings of each one's held-out MSE."""
    tot = 0.0
    for r, e, w in zip(d.rows, res, d.w_test):
        tot += float(np.nansum(w * np.where(r.test, e * e, 0.0)))
    return tot / len(d.rows)


def gain_z(d: Data, res_a, res_b, sigma2: float) -> tuple[float, float]:
    """Held-out MSE gain of model b over model a, and how many standard errors of noise it
    is. With delta = e_a - e_b (the change of prediction), e_a^2 - e_b^2 = delta^2 +
    2 delta e_b: the first term is what b explains; the second is what noise of variance
    sigma2 alone would add, with standard error 2 sigma sqrt(sum w^2 delta^2), each row's noise
    its own; and what the rounding that the rows of an operating point share adds (a channel
    whose noise does not dither it reads a held point as one code, every row with one error:
    d.rounding), 2 u sum(w delta) over each point's code, with u its standard speed error."""
    g = 0.0
    v = 0.0
    shared = 0.0
    rounding = d.rounding or [()] * len(d.rows)
    for r, ea, eb, w, rr in zip(d.rows, res_a, res_b, d.w_test, rounding):
        m = r.test & np.isfinite(ea) & np.isfinite(eb)
        if not m.any():
            continue
        ww = w[m] / len(d.rows)
        dl = ea[m] - eb[m]
        g += float(np.sum(ww * (ea[m] ** 2 - eb[m] ** 2)))
        v += float(np.sum((ww * dl) ** 2))
        for labels, u in rr:
            lab = labels[m]
            on = lab >= 0
            if on.any():
                shared += float(np.sum(np.bincount(lab[on], weights=(ww * dl * u[m])[on]) ** 2))
    se = 2.0 * float(np.sqrt(max(sigma2, 1e-12) * v + shared))
    return g, (g / se if se > 0 else (np.inf if g > 0 else 0.0))


def noise_var(d: Data, res) -> float:
    """Variance of the white part of the held-out residual (analysis.robust_noise_var on
    its contiguous runs)."""
    return analysis.robust_noise_var(analysis.parts(d.rows, res))


def _ambient_node(rows, p: ph.PhysicsParams) -> ph.PhysicsParams:
    """p with the winding node assumed where no temperature is read and no node was fitted yet: the
    fit's starting values on the ambient path (effects.node_start over the labelled rows)."""
    r0, tau0 = fx.node_start(rows, [r.train | r.test for r in rows], p, True)
    return dataclasses.replace(p, th_r_K_per_W=r0, th_tau_s=tau0)


def identifiability(d: Data, p: ph.PhysicsParams, name: str, sigma2: float, others) -> dict:
    """Standard error of the coefficient of `name` on the training rows, with Ke and the
    effects in `others` fitted alongside (their regressors projected out); the effect is
    identifiable when the plausible magnitude is IDENT_SIGMAS standard errors or more."""
    eff = fx.LIBRARY[name]
    cols = {k: [] for k in ["ke_vs_per_rad", name] + list(others)}
    # (one assumed node for every recording that reads no temperature: it depends on all their rows, not on one)
    ambient = (_ambient_node(d.rows, p) if eff.thermal and not p.thermal_enabled()
               and any(r.needs_state for r in d.rows) else p)
    for r in d.rows:
        m = r.train
        if not m.any():
            continue
        cols["ke_vs_per_rad"].append(fx.ke_regressor(r, p)[m])
        for k in [name] + list(others):
            pk = ambient if k == name and r.needs_state else p
            cols[k].append(fx.regressor(r, pk, k)[m])
    x = {k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()}
    target = x.pop(name)
    other = np.column_stack(list(x.values())) if x else np.zeros((len(target), 0))
    ok = np.isfinite(target) & np.all(np.isfinite(other), axis=1)
    target, other = target[ok], other[ok]
    whole = float(np.dot(target, target))
    if other.shape[1]:
        coef, *_ = np.linalg.lstsq(other, target, rcond=None)
        target = target - other @ coef
    info = float(np.dot(target, target))
    se = float(np.sqrt(sigma2 / info)) if info > 0 else float("inf")
    mag = max(abs(eff.plausible[0]), abs(eff.plausible[1]))
    # the share of the effect's speed error that Ke (and `others`) would take up in a fit
    absorbed = 1.0 - info / whole if whole > 0 else 1.0
    return {"se": se, "identifiable": bool(mag >= IDENT_SIGMAS * se), "absorbed": absorbed}


def _regressor(r, p, name, t):
    if name == RA_MISMATCH:
        return fx.sensitivity(r, p, "ra_ohm", 1e-3 * p.ra_ohm, t)
    return fx.regressor(r, p, name, t)


def more_data_needed(z: float) -> float | None:
    """How many times the data at hand it would take to tell two explanations apart, for a
    z (the named one's held-out gain over the other, in standard errors) below Z_MIN: z grows
    with the square root of the rows that separate them, so (Z_MIN / z)^2 times; None for
    z <= 0 (the data at hand hold nothing that separates them)."""
    if z is None or not np.isfinite(z) or z <= 0:
        return None
    return float((Z_MIN / z) ** 2)


def partial_corr(d: Data, p: ph.PhysicsParams, a: str, b: str, given) -> float:
    """Correlation of the regressors of a and b on the training and held-out rows after
    Ke and the `given` effects are projected out."""
    xa, xb, xo = [], [], []
    # (one for all, as in identifiability, and only where some recording reads no temperature)
    ambient = p if p.thermal_enabled() or not any(r.needs_state for r in d.rows) else _ambient_node(d.rows, p)
    for r in d.rows:
        m = r.train | r.test
        if not m.any():
            continue
        pp = ambient if r.needs_state else p
        t = fx.temperature(r, pp)
        xa.append(_regressor(r, pp, a, t)[m])
        xb.append(_regressor(r, pp, b, t)[m])
        o = [fx.ke_regressor(r, pp, t)]
        o += [fx.regressor(r, pp, g, t) for g in given if g not in (a, b)]
        xo.append(np.column_stack(o)[m])
    xa, xb, xo = np.concatenate(xa), np.concatenate(xb), np.concatenate(xo)
    ok = np.isfinite(xa) & np.isfinite(xb) & np.all(np.isfinite(xo), axis=1)
    xa, xb, xo = xa[ok], xb[ok], xo[ok]
    for v in (xa, xb):
        coef, *_ = np.linalg.lstsq(xo, v, rcond=None)
        v -= xo @ coef
    den = np.sqrt(np.dot(xa, xa) * np.dot(xb, xb))
    return float(np.dot(xa, xb) / den) if den > 0 else 0.0


@dataclasses.dataclass
class Step:
    name: str
    params: ph.PhysicsParams
    gain: float
    z: float
    mse_before: float
    mse_after: float
    alternatives: list  # [(name, gain, z, physical), ...] of every candidate tried at this step
    # z of the named effect's held-out gain over the model with a wrong Ra instead (RA_MISMATCH
    # passing every test at this step); None when it did not. Below Z_MIN: not told apart.
    ra_z: float | None = None
    # z of the named effect's held-out gain over each alternative that passed every test at
    # this step (the model with the alternative instead): at Z_MIN or more, the recordings at
    # hand tell the two apart, whatever the alternative explains on its own.
    told_apart: dict = dataclasses.field(default_factory=dict)
    # the first of a pair taken together (_look_ahead): the second's name; its own gain may be negative
    pair_with: str | None = None


def _physical(name: str, value: float, m2: ph.PhysicsParams | None = None) -> bool:
    """The fitted coefficient is physical; for RA_MISMATCH (value: the fitted Ra): it lies
    more than RA_MISMATCH_SIGMAS tolerances from the reading m2.ra_ohm."""
    if name == RA_MISMATCH:
        return RA_MISMATCH_SIGMAS < abs(ra_sigmas(m2, value)) <= RA_PLAUSIBLE_SIGMAS
    return fx.LIBRARY[name].is_physical(value)


def _value(name: str, p: ph.PhysicsParams) -> float:
    return p.ra_ohm if name == RA_MISMATCH else getattr(p, fx.LIBRARY[name].field)


def forward_select(d: Data, m2: ph.PhysicsParams, given, candidates, sigma2: float, weights=None,
                   start=None, exclude=(), fits=None, starts=None, bound=None) -> tuple[list, ph.PhysicsParams]:
    """Forward selection from the model with `given` effects; returns (steps, final params).
    exclude: candidates tried at every step (their gains are the alternatives') but never
    named. An offset drifting with the case temperature that the final model could trade for
    a thermal effect of the motor without the recordings telling the two apart is excluded
    so (motor_physics_first).
    fits: a dict filled with every model fitted along the way, {frozenset of its effects:
    params}; starts: such a dict of another selection on the same recordings (the bootstrap's
    of the selection on all rows), each model's fit started there where it holds the model.
    bound: the held-out MSE of the model with every library effect (a number, or a LibraryBound; None where
    it cannot be fitted), which decides where pairs are tried (_look_ahead); None: pairs are tried only
    beside a candidate that helps alone."""
    steps, p = _forward_select(d, m2, given, candidates, sigma2, weights, start, exclude, fits, starts, bound)
    if not exclude and motor_physics_first(d, m2, given, steps, p, candidates, sigma2, weights):
        drifts = tuple(c for c in candidates if _drifts(c))
        return _forward_select(d, m2, given, candidates, sigma2, weights, start, drifts, fits, starts, bound)
    return steps, p


def motor_physics_first(d: Data, m2: ph.PhysicsParams, given, steps, p, candidates, sigma2: float,
                        weights=None) -> bool:
    """Whether the selection named an offset drifting with the case temperature
    (schema.Effect.case_temperature) that a thermal effect of the motor, in its place with
    the other named effects, explains as well: the drift's held-out gain over that model
    below Z_MIN standard errors (apart_z), and the thermal coefficient physical. Both follow
    the temperature, and at one operating point during a warm-up they are the same speed
    error (docs/diagnosis-forms.md, Offsets that drift). Copper and magnets are in every motor,
    with material constants; a drifting offset is one bench's electronics: it is named only
    where the recordings tell it from them, and otherwise reported as not told apart, with
    the recording that would separate them. Judged on the final model, not at the drift's
    step: a thermal effect alone can lose to a drift at the first step while the effect
    named after it (saturation beside the magnets) is still missing. A drift fitted beyond
    its plausible range gives way also where the recordings tell it apart, to a physical
    thermal effect that removes CONFOUND_GAIN of what it removes."""
    names = [s.name for s in steps if s.name]
    drifts = [n for n in names if _drifts(n)]
    if not drifts:
        return False
    res = held_out_residuals(d, p, lambda rows, st: fit_names(rows, m2, list(given) + names, sigma2,
                                                               weights=weights, start=st))
    thermal = [c for c in candidates if c in fx.LIBRARY and fx.LIBRARY[c].thermal and c not in names]
    for drift in drifts:
        # a drift beyond what electronics do (its plausible range) that a thermal effect explains
        # much of is a temperature effect in a form the library does not hold (the magnets at the
        # winding's temperature or lagging the case fit the drift's form at 2.0..2.7 mA/K)
        plausible = fx.LIBRARY[drift].plausibility(_value(drift, p))[0]
        g_drift = None
        for t in thermal:
            alt = [t if n == drift else n for n in names]
            try:
                pt, rt = scored_names(d, m2, list(given) + alt, sigma2, weights=weights, start=p)
            except Exception:  # a degenerate fit is no alternative
                continue
            if not _physical(t, _value(t, pt), m2):
                continue
            if apart_z(d, rt, res, sigma2) < Z_MIN:
                return True
            if not plausible:
                if g_drift is None:  # the drift's and the thermal effect's gains over the model without either
                    _, r0 = scored_names(d, m2, list(given) + [n for n in names if n != drift], sigma2,
                                         weights=weights, start=p)
                    g_drift = gain_z(d, r0, res, sigma2)[0]
                if gain_z(d, r0, rt, sigma2)[0] >= CONFOUND_GAIN * g_drift:
                    return True
    return False


def a_step(gain: float, z: float, mse_now: float, mse_start: float, sigma2: float, z_min: float = Z_MIN,
           ra: bool = False, excess: bool = True) -> bool:
    """Whether a held-out gain (RPM^2, z its standard errors) names an effect added to a model of
    held-out MSE mse_now, in a selection that started from mse_start: the bar of the module's
    docstring (Z_MIN, REL_MIN, EXCESS_MIN, SCORE_MIN; a wrong Ra is exempt from SCORE_MIN). One
    bar for every stage that names an effect (the forward selection, core.material_check).
    excess=False leaves out EXCESS_MIN, for a step that is a test of one named reading against
    another (core.material_check) rather than a search: the excess left then is mostly what no
    static effect removes (a 2 Hz sweep's transients), and a tenth of it is no measure of the
    step (the twin's magnets beside copper held: 2.35 RPM^2 at 6.7 standard errors, 2.4 % of the
    starting error, where a tenth of the excess was 2.67)."""
    return (z >= z_min and gain >= REL_MIN * mse_now
            and (not excess or gain >= EXCESS_MIN * max(mse_now - sigma2, 0.0))
            and (gain >= SCORE_MIN * mse_start or ra))


def _forward_select(d: Data, m2: ph.PhysicsParams, given, candidates, sigma2: float, weights=None,
                    start=None, exclude=(), fits=None, starts=None, bound=None) -> tuple[list, ph.PhysicsParams]:
    starts = starts or {}

    def fit_from(names, p_before):
        """scored_names of the model of names, started from starts' fit of it, else p_before."""
        key = frozenset(names)
        pc, rc = scored_names(d, m2, names, sigma2, weights=weights, start=starts.get(key, p_before))
        if fits is not None:
            fits[key] = pc
        return pc, rc

    chosen = list(given)
    p, res = fit_from(chosen, start)
    mse = held_out_mse(d, res)
    mse_start = mse
    steps = []
    remaining = [c for c in candidates if c not in chosen]

    def passes(t, mse_now, z_min=Z_MIN):
        """Whether a trial (_trials) is a step from a model of held-out MSE mse_now."""
        return (t[0] not in exclude and t[3]
                and a_step(t[1], t[2], mse_now, mse_start, sigma2, z_min=z_min, ra=t[0] == RA_MISMATCH))

    while remaining:
        tried = _trials(d, m2, sigma2, fit_from, chosen, remaining, p, res)
        ok = [t for t in tried if passes(t, mse)]
        if not ok:
            ahead = _look_ahead(d, m2, sigma2, res, mse, tried, remaining, chosen, fit_from, passes, exclude,
                                bound)
            if ahead is None:
                steps.append(Step("", p, 0.0, 0.0, mse, mse, [(t[0], t[1], t[2], t[3]) for t in tried]))
                break
            first, tried_next, second = ahead
            c, g, z, _, pc, rc = first
            new_mse = held_out_mse(d, rc)
            steps.append(Step(c, pc, g, z, mse, new_mse, [(t[0], t[1], t[2], t[3]) for t in tried],
                              pair_with=second[0]))
            chosen.append(c)
            remaining.remove(c)
            p, res, mse, tried = pc, rc, new_mse, tried_next
            ok = [second]
        best = plausible_first(d, sigma2, ok, max(ok, key=lambda t: t[1]))
        c, g, z, _, pc, rc = best
        new_mse = held_out_mse(d, rc)
        ra = [t for t in ok if t[0] == RA_MISMATCH and c != RA_MISMATCH]
        ra_z = apart_z(d, ra[0][5], rc, sigma2) if ra else None
        apart = {t[0]: apart_z(d, t[5], rc, sigma2) for t in ok if t[0] != c}
        steps.append(Step(c, pc, g, z, mse, new_mse, [(t[0], t[1], t[2], t[3]) for t in tried], ra_z, apart))
        chosen.append(c)
        remaining.remove(c)
        p, res, mse = pc, rc, new_mse
    return steps, p


def _plausible(t) -> bool:
    """Whether a trial's (_trials) coefficient lies within the range its effect takes on a motor
    (schema.Effect.plausible); a wrong Ra's trial is (its range is RA_MISMATCH's own test)."""
    return t[0] not in fx.LIBRARY or fx.LIBRARY[t[0]].plausibility(_value(t[0], t[4]))[0]


def plausible_first(d: Data, sigma2: float, ok: list, best):
    """The step's effect among the trials that pass (ok): the one of the largest held-out gain (best),
    unless its coefficient is beyond what the effect takes on a motor while another trial whose
    held-out residuals these rows do not tell from best's (apart_z under Z_MIN) is plausible: then
    that one, the largest gain of them. Between two effects the data cannot tell apart, the one a
    motor can hold is named: a constant 0.6 V brush drop on a dyno table whose currents all lie far
    above the brush's knee is a voltage offset of 0.6 V too, which no bench's electronics hold, and
    the offset won the step by the knee's last digits; it was then left unnamed as beyond plausible,
    with nothing in its place, while the residual stayed 12x the floor."""
    if _plausible(best):
        return best
    alts = [t for t in ok if t is not best and _plausible(t) and apart_z(d, t[5], best[5], sigma2) < Z_MIN]
    return max(alts, key=lambda t: t[1]) if alts else best


def _trials(d: Data, m2: ph.PhysicsParams, sigma2: float, fit_from, chosen: list, candidates, p, res) -> list:
    """Each candidate fitted beside `chosen` (fit_from, started at p): [(candidate, its held-out gain
    over the model of residuals res, its z, whether its coefficient is physical, params, residuals)];
    a degenerate fit is simply not a candidate."""
    tried = []
    for c in candidates:
        try:
            pc, rc = fit_from(chosen + [c], p)
        except Exception:  # noqa: BLE001
            continue
        g, z = gain_z(d, res, rc, sigma2)
        tried.append((c, g, z, _physical(c, _value(c, pc), m2), pc, rc))
    return tried


def _look_ahead(d: Data, m2: ph.PhysicsParams, sigma2: float, res, mse: float, tried: list, remaining: list,
                chosen: list, fit_from, passes, exclude=(), bound=None):
    """Where no candidate passes alone, one step ahead: two effects that act together (a winding's
    heating and a saturation, each alone worse on the held-out rows than neither, the pair far
    better) are missed by a search that adds one at a time. The candidate of the largest held-out
    gain that passes every test but its z (physical, a gain above the noise's share) is tried with
    each other candidate beside it: where one of them passes its own step's tests beside it, and the
    pair's gain over the model without either passes Z_MIN, the two are taken in turn ((the first's
    trial, the second step's trials, the second's trial)); otherwise None. The first is then judged
    as every named effect is (its interval, its rivals): it is a step, not a finding."""
    near = [t for t in tried if t[1] > 0 and passes(t, mse, -math.inf)]
    if near:
        firsts = [max(near, key=lambda t: t[1])]
    elif mse - sigma2 > ABOVE_SHARE * sigma2 and _library_explains(mse, sigma2, bound):
        # the residual well above the noise, no candidate helping alone, and the library as a whole removing most
        # of it: each candidate that may stand in a model (physical alone, or a wrong Ra, whose size the pair
        # sets) is tried first, the largest gain first, until a pair passes (a 0.4 V brush drop beside an Ra given
        # 10 % high: either alone is worse on the held-out rows than neither, 1.8 -> 0.75 RPM together; copper
        # and magnets in a warm-up, after a wrong Ra and an offset's drift were taken). Not where the library
        # removes little of it (a 2 Hz sweep's transients: on the bundled recordings the model with every
        # effect removes a third of what their final model leaves above the floor, and pairs tried at every
        # selection's end and in each bootstrap resample took their command from 17 to 35 s)
        # an offset drifting with the case temperature is in no such pair (_drifts): it trades with the motor's
        # thermal effects, and beside copper it was named on a bench without one (the mismatch study's bench 20:
        # a 0.14 V offset, magnets and copper of forms the library does not hold); it is named where it helps alone
        firsts = sorted((t for t in tried if t[0] not in exclude and (t[3] or t[0] == RA_MISMATCH)
                         and not _drifts(t[0])), key=lambda t: -t[1])
    else:
        return None
    for first in firsts:
        c1, _, _, _, p1, r1 = first
        mse1 = held_out_mse(d, r1)
        tried_next = _trials(d, m2, sigma2, fit_from, chosen + [c1], [c for c in remaining if c != c1], p1, r1)
        ok = []
        for t in tried_next:
            pair = gain_z(d, res, t[5], sigma2)  # the pair's gain over the model without either
            # where neither helps alone, the pair is one step from the model before it: the step's every test
            # (an independent bench's -0.44 V offset with a wrong Ra took 0.2 % of the starting error, standing
            # in for a saturation that levels off: the reading, right, was called 15 % high)
            if (passes(t, mse1) and pair[1] >= Z_MIN and _physical(c1, _value(c1, t[4]), m2)
                    and (near or (not _drifts(t[0]) and passes((c1, *pair, True), mse)))):
                ok.append(t)
        if ok:
            return first, tried_next, max(ok, key=lambda t: t[1])
    return None


def _drifts(name: str) -> bool:
    """Whether the effect is an offset drifting with the case temperature (schema.Effect.case_temperature)."""
    return name in fx.LIBRARY and fx.LIBRARY[name].case_temperature


def _library_explains(mse: float, sigma2: float, bound) -> bool:
    """Whether the model with every library effect (bound: its held-out MSE, or a LibraryBound) removes
    PAIR_SHARE or more of what a model of held-out MSE mse leaves above the noise."""
    if isinstance(bound, LibraryBound):
        return bound.explains(mse, sigma2)
    return bound is not None and math.isfinite(bound) and mse - bound >= PAIR_SHARE * (mse - sigma2)


class LibraryBound:
    """The held-out MSE of the model with every library effect, measured (measure() -> the MSE, or None where
    that model cannot be fitted) the first time a selection asks for it: most selections never ask.
    opened: whether it removed PAIR_SHARE or more of what a step's model left above the noise, so that pairs
    were tried where no candidate helps alone (_look_ahead). for_resamples(): the bound the bootstrap's
    resamples judge by, the measured MSE where the selection on all rows opened that search, else None (they
    try pairs only beside a candidate that helps alone): a resample whose selection stops earlier than the
    one on all rows leaves more above the noise, the library removes more of it, and the pairs its search
    then tried cost the bundled recordings' twelve resamples 10 CPU-s without naming one."""

    def __init__(self, measure):
        self._measure, self.asked, self.measured, self.opened = measure, False, None, False

    def value(self) -> float | None:
        if not self.asked:
            self.asked = True
            self.measured = self._measure()
        return self.measured

    def explains(self, mse: float, sigma2: float) -> bool:
        ok = _library_explains(mse, sigma2, self.value())
        self.opened = self.opened or ok
        return ok

    def for_resamples(self) -> float | None:
        return self.measured if self.opened else None


def apart_z(d: Data, res_alt, res_named, sigma2: float) -> float:
    """How far the recordings tell a named explanation from an alternative: the z of its
    held-out gain over the model with the alternative instead (gain_z), or 0 when that gain
    is below REL_MIN of the alternative model's held-out MSE. Two models whose held-out
    errors differ by less than that explain the same rows: with thousands of rows a 0.01 %
    difference reaches a z of 3 under white noise (a knee-shaped brush drop against a
    wrong Ra and against a voltage gain, each within 0.02 RPM^2 of the other), and more
    rows of the same kind would not make it matter; only a recording that separates them
    does."""
    g, z = gain_z(d, res_alt, res_named, sigma2)
    return float(z) if g >= REL_MIN * held_out_mse(d, res_alt) else 0.0


# A bootstrap resample's fits decide held-out gains only, from the whole data's optimum: solved to
# BOOTSTRAP_TOL (effects.solver_tolerance), a third fewer evaluations of the model on data/default
BOOTSTRAP_TOL = 1e-5


def _select_names(args) -> list:
    d, m2, given, candidates, sigma2, weights, start, starts, bound = args
    with fx.solver_tolerance(BOOTSTRAP_TOL):
        steps, _ = forward_select(d, m2, given, candidates, sigma2, weights=weights, start=start, starts=starts,
                                  bound=bound)
    return [s.name for s in steps if s.name]


FEW_BLOCKS = 10  # below this many operating points to resample, an inclusion frequency means little


def n_train_blocks(d: Data) -> int:
    """How many operating-point blocks the bootstrap resamples (all recordings)."""
    return int(sum(len(np.unique(b[b >= 0])) for b in d.blocks_train))


def bootstrap_jobs(d: Data, m2, given, candidates, sigma2, start, n: int, seed: int = 7, starts=None,
                   bound: float | None = None) -> list:
    """The jobs of _select_names for n block resamples of the training rows, drawn in order
    from one seed (bootstrap). bound: the held-out MSE of the model with every library effect on
    all rows (forward_select's), where the selection on all rows measured it (the resamples hold
    out the same rows); None: the resamples try pairs only beside a candidate that helps alone."""
    rng = np.random.default_rng(seed)
    jobs = []
    starts = dict(starts) if starts is not None else None  # (as they are now: a job may run later)
    for _ in range(n):
        weights = []
        for r, blk in zip(d.rows, d.blocks_train):
            ids = np.unique(blk[blk >= 0])
            w = np.zeros(len(blk))
            if len(ids):
                pick = rng.choice(ids, size=len(ids), replace=True)
                mult = np.bincount(np.searchsorted(ids, pick), minlength=len(ids)).astype(float)
                w[blk >= 0] = mult[np.searchsorted(ids, blk[blk >= 0])]
            weights.append(w)
        jobs.append((d, m2, list(given), list(candidates), sigma2, weights, start, starts, bound))
    return jobs


def inclusion(candidates, chosen: list) -> dict:
    """{candidate: the share of the resamples' selections (chosen: the names of each) that name it}."""
    return {c: sum(c in names for names in chosen) / len(chosen) for c in candidates}


def _shown(it, k: int):
    return progress.bar(it, "bootstrap", total=k, unit="resample")


def bootstrap(d: Data, m2, given, candidates, sigma2, start, n: int, seed: int = 7, starts=None,
              bound: float | None = None) -> dict:
    """Inclusion frequency of each candidate over n block resamples of the training rows.
    The resamples are drawn in order from one seed, then selected on all cores. starts: the
    fits of the selection on all rows (forward_select's fits), each resample's fit of a
    model started from that model's fit there: a resample's optimum lies near the whole
    data's, and the solver reaches it in fewer steps than from the model one effect smaller."""
    if n <= 0:
        return {c: None for c in candidates}
    jobs = bootstrap_jobs(d, m2, given, candidates, sigma2, start, n, seed, starts, bound)
    return inclusion(candidates, interrupt.map_on_cores(_select_names, jobs, _shown))


@dataclasses.dataclass(frozen=True)
class Pending:
    """An inclusion frequency not known yet: the bootstrap's resamples run on the other cores
    while the diagnosis goes on (PendingBootstrap); core.with_inclusion puts the frequency in
    its place. Nothing reads an inclusion before that (no test, no sentence of the verdict)."""

    effect: str


# Where the bootstrap's resamples queue among a Background's jobs (interrupt.Background: the lowest
# first): behind the hybrid's trainings, which the diagnosis waits for one by one
BOOTSTRAP_PRIORITY = 2


class PendingBootstrap:
    """bootstrap() with its resamples given to a Background (interrupt.Background) at once, to
    run beside the stages that follow the selection; get(c) is a Pending until frequencies()
    collects them (the same frequencies: each resample's selection depends on its job alone)."""

    def __init__(self, background, d: Data, m2, given, candidates, sigma2, start, n: int, seed: int = 7,
                 starts=None, bound: float | None = None):
        self.candidates = list(candidates)
        self.tasks = [background.submit(_select_names, job, BOOTSTRAP_PRIORITY)
                      for job in bootstrap_jobs(d, m2, given, candidates, sigma2, start, n, seed, starts, bound)]

    def get(self, c):
        return Pending(c) if c in self.candidates else None

    def cancel(self) -> None:
        for t in self.tasks:
            t.cancel()

    def frequencies(self) -> dict:
        return inclusion(self.candidates, [t.result() for t in _shown(self.tasks, len(self.tasks))])
