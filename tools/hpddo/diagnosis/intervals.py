"""How well the recordings determine each identified quantity: a 95 % interval from the
data for Ke, Ra and every fitted effect coefficient, shape and winding-node parameter, and
whether the recordings determine it at all.

The interval is the linearised least-squares one with a covariance robust to the errors of
one operating point being alike (statsmodels' cluster-robust sandwich, clusters = the
bootstrap's operating-point blocks, ranking.op_blocks): the asymptotic form of a bootstrap
over whole operating points, from one Jacobian at the fitted values, with Student's t on
(clusters - 1) degrees of freedom. With fewer clusters than parameters + 2 the rows are
taken as independent (heteroskedasticity-robust HC1) and the interval says so.

A quantity is *not determined by these recordings* when
  * the fit stopped at the edge of the range it was allowed (the data pull it further),
  * its interval reaches outside the range that is physical for it (Ra or Ke through zero,
    a shape beyond its forms), or
  * the objective is flat along it (its column of the Jacobian is zero, or a combination
    of the others': no standard error).
Such a quantity is reported with the measurement that would determine it, never as a value
the data support.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import stats
from statsmodels.regression.linear_model import OLS  # (not statsmodels.api: 0.13 s more of every command's start)

from ..model import effects as fx
from ..model import physics as ph
from .. import schema
from ..model.interval import LEVEL, Interval  # noqa: F401 (the diagnosis' intervals are these)

# relative step of the central differences of the Jacobian (of the field, or of its typical scale)
STEP_REL = 1e-4
EDGE_REL = 1e-6  # a value this close to a bound of its fit (relative to the range) sits on it

# The measurement that determines each quantity that is no effect coefficient (an effect's
# is its declaration's excited_by, schema.py).
KE_NEEDS = ("coasting: the supply switched off with the motor turning, the back-EMF read at the open "
            "terminals while it runs down (or runs at several speeds with little load)")
RA_NEEDS = ("stall dwells (the motor held at standstill with current flowing, a few current levels), or "
            "heavy load next to light load at one voltage")
THERMAL_NEEDS = "a cold-then-warm run: the motor started cold and run at load until its temperature settles"

# field -> (quantity shown, unit shown, scale to the unit shown, physical range, what determines it)
_OTHER = {
    "ke_vs_per_rad": ("Ke", "V s/rad", 1.0, (0.0, math.inf), KE_NEEDS),
    "ra_ohm": ("Ra", "ohm", 1.0, (0.0, math.inf), RA_NEEDS),
}


def _describe(field: str, path: str | None = None) -> tuple:
    """(quantity, unit shown, show scale, physical range, needs, SI unit) of a fitted field; a field of the
    winding's thermal node along the heat path `path` (effects.node_path: "case" where the rows read the case
    temperature, "ambient" where some do not), whose ranges differ by path (schema.NODE)."""
    if field in _OTHER:
        q, u, s, phys, needs = _OTHER[field]
        return q, u, s, phys, needs, u
    for e in schema.EFFECTS:
        needs = THERMAL_NEEDS if e.thermal else e.excited_by
        if e.field == field:  # an interval through zero leaves even the effect's sign open
            phys = (min(e.physical[0], 0.0), max(e.physical[1], 0.0))
            return e.name, e.show_unit, e.show_scale, phys, needs, e.unit
        for sh in e.shapes:
            if sh.field == field:
                return f"{e.name} shape {field}", sh.unit, 1.0, sh.widened or sh.bounds, needs, sh.unit
    for n in schema.NODE:
        if n.field == field and (path is None or n.path == path):
            return f"winding node {field}", n.show_unit, 1.0, n.physical, THERMAL_NEEDS, n.show_unit
    return field, "", 1.0, (-math.inf, math.inf), "", ""


def predict_all(rows, masks, p: ph.PhysicsParams) -> np.ndarray:
    """n_M2 of p at the masked rows of every recording (temperatures recomputed at p)."""
    return np.concatenate([fx.predict(r, p)[m] for r, m in zip(rows, masks)])


def jacobian(rows, masks, p: ph.PhysicsParams, fields) -> np.ndarray:
    """d n_M2 / d field at p for every masked row (columns in the order of fields), by
    central differences through the physics and the winding node (fx.predict)."""
    cols = []
    for f in fields:
        c = float(getattr(p, f))
        h = STEP_REL * max(abs(c), _scale(f))
        up = predict_all(rows, masks, dataclasses.replace(p, **{f: c + h}))
        dn = predict_all(rows, masks, dataclasses.replace(p, **{f: c - h}))
        cols.append((up - dn) / (2 * h))
    return np.column_stack(cols) if cols else np.zeros((0, 0))


def _scale(field: str) -> float:
    for e in schema.EFFECTS:
        if e.field == field:
            return abs(e.scale)
        for sh in e.shapes:
            if sh.field == field:
                return sh.scale
    return 1e-3


def covariance(jac: np.ndarray, e: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, int, str]:
    """(covariance of the fitted fields, degrees of freedom of the t quantile, method) from
    the Jacobian jac of the prediction and the residual e at the fit: the cluster-robust
    sandwich over the operating-point groups (statsmodels), HC1 with too few groups. NaN
    where the objective is flat along a field."""
    k = jac.shape[1]
    ok = np.isfinite(e) & np.all(np.isfinite(jac), axis=1)  # a prediction that overflows says nothing
    jac, e, groups = jac[ok], e[ok], groups[ok]
    norms = np.sqrt(np.sum(jac * jac, axis=0))
    flat = ~(norms > 0) | ~np.isfinite(norms)
    cov = np.full((k, k), np.nan)
    if flat.all() or len(e) <= k:
        return cov, 1, "flat"
    x = jac[:, ~flat] / norms[~flat]
    n_groups = len(np.unique(groups))
    iid = OLS(e, x).fit()  # rows independent, one variance
    c = np.asarray(iid.cov_params())
    df, method = max(len(e) - x.shape[1], 1), f"rows taken as independent (only {n_groups} operating points)"
    if n_groups >= x.shape[1] + 2:
        # Over few operating points the cluster-robust variance is itself poorly estimated (a
        # 60-row table of 6 voltages: a quarter of the independent rows' by chance); the larger
        # of the two is kept, so that neither an autocorrelated residual nor a lucky draw of
        # clusters narrows the interval.
        clu = np.asarray(OLS(e, x).fit(cov_type="cluster", cov_kwds={"groups": groups}).cov_params())
        scale = np.sqrt(np.maximum(np.diag(clu), np.diag(c)) / np.maximum(np.diag(c), 1e-300))
        c = c * np.outer(scale, scale)
        df, method = n_groups - 1, f"cluster-robust over {n_groups} operating points, at least the rows' own"
    c = c / np.outer(norms[~flat], norms[~flat])
    # a combination of the other columns: the information along it is (numerically) nil
    sv = np.linalg.svd(x, compute_uv=False)
    if sv[-1] <= 1e-9 * sv[0]:
        return cov, df, "flat"
    idx = np.flatnonzero(~flat)
    cov[np.ix_(idx, idx)] = c
    return cov, df, method


def fitted_rows(rows, groups_per_rec, p: ph.PhysicsParams, fields, bounds: dict) -> tuple:
    """(per recording, the mask of the training rows p was fitted on that it predicts; the fields not
    held on an edge of their bounds): a field on an edge is held there (an active constraint), out
    of the covariance and of every sensitivity."""
    masks = [r.train & np.isfinite(r.ref) & np.isfinite(fx.predict(r, p)) & (g >= 0)
             for r, g in zip(rows, groups_per_rec)]
    free = [f for f in fields if not (f in bounds and on_edge(float(getattr(p, f)), bounds[f]))]
    return masks, free


def free_covariance(rows, groups_per_rec, p: ph.PhysicsParams, fields, bounds: dict) -> tuple:
    """(the fields not held on an edge of their bounds, their covariance, its degrees of freedom,
    its method, the number of blocks) of p fitted on the training rows of `rows` (groups_per_rec: the operating-point
    block id per row of each recording, -1 outside the training rows), cluster-robust over the
    blocks (covariance)."""
    masks, free = fitted_rows(rows, groups_per_rec, p, fields, bounds)
    groups = []
    offset = 0
    for g, m in zip(groups_per_rec, masks):
        groups.append(g[m] + offset)
        offset += int(g.max()) + 1 if len(g) else 0
    ref = np.concatenate([r.ref[m] for r, m in zip(rows, masks)])
    e = ref - predict_all(rows, masks, p)
    groups = np.concatenate(groups)
    cov, df, method = covariance(jacobian(rows, masks, p, free), e, groups)
    if method.startswith("rows taken as independent") and rows and all(r.steady for r in rows):
        # a table's rows are settled points, each its own operating point: its blocks (ranking.op_blocks: runs of one
        # duty and load, split by the made-up clock) are not (a fuzzing round's one-voltage table of 32 settled
        # points read "only 4 operating points")
        method = f"rows taken as independent ({int(np.isfinite(e).sum())} settled points of a table)"
    return free, cov, df, method, len(np.unique(groups))


def intervals(rows, groups_per_rec, p: ph.PhysicsParams, fields, bounds: dict | None = None) -> list[Interval]:
    """The Interval of every field of p fitted on the training rows of `rows` (groups_per_rec:
    the operating-point block id per row of each recording, -1 outside the training rows;
    bounds: {field: (lo, hi)} the fit was held within)."""
    bounds = dict(bounds or {})
    free, cov, df, method, clusters = free_covariance(rows, groups_per_rec, p, fields, bounds)
    t = float(stats.t.ppf(0.5 + LEVEL / 2, df))
    var = dict(zip(free, np.diag(cov)))
    out = []
    path = fx.node_path(any(r.needs_state for r in rows))  # the node's path, as fx.spec_for takes it
    for f in fields:
        q, unit, scale, phys, needs, si = _describe(f, path)
        v = float(getattr(p, f))
        c = var.get(f, math.nan)
        se = float(np.sqrt(c)) if np.isfinite(c) and c >= 0 else math.inf
        lo, hi = v - t * se, v + t * se
        why = ""
        b = bounds.get(f)
        if b is not None and on_edge(v, b):
            why = f"{EDGE_WHY} of the range allowed, {_rng(b, scale, unit)}: the data pull it further"
        elif f == "th_tau_s" and all(r.steady for r in rows):
            why = "steady-state tables have no clock: the winding's time constant is not in their rows"
        elif not math.isfinite(se):
            why = "the objective is flat along it: these rows do not move the speed estimate with it"
        elif lo <= phys[0] or hi >= phys[1]:
            why = (f"{OUTSIDE_WHY} {_rng((lo, hi), scale, unit)} reaches outside the physical "
                   f"{_rng(phys, scale, unit)}")
        out.append(Interval(q, f, si, v, lo if math.isfinite(se) else None, hi if math.isfinite(se) else None,
                            determined=not why, why=why, needs=needs, clusters=clusters,
                            method=method, show_scale=scale, show_unit=unit, physical=phys,
                            budget={"statistical": se} if math.isfinite(se) else {}))
    return _thermal_needs_its_node(_sizes_of_unfixed_forms(_node_within_insulation(out, rows, p), p, bounds))


EDGE_WHY = "the fit stopped at the edge"


def _node_within_insulation(ivs: list, rows, p: ph.PhysicsParams) -> list:
    """ivs with the winding node's thermal resistance not determined (an edge, EDGE_WHY, so that
    _thermal_needs_its_node takes the thermal coefficients and Ra with it) where p's node holds the winding at
    the hottest insulation class's limit (physics.WINDING_MAX_C, where the node's rise is held) on some row: the
    fit then uses the limit as a plateau of the resistance, a heating no winding survives, and the node's value
    inside its range is not what the data say (an independent probe's large motor with a brush drop: the data-
    alone fit held the winding at the limit on most rows with 80 K/W and put Ra at 0.239 ohm, 0.158..0.287,
    against the motor's 0.35; its node's own interval, reaching past the range, had said only that)."""
    if not p.thermal_enabled() or not any(iv.field == "th_r_K_per_W" for iv in ivs):
        return ivs
    hot = total = 0
    for r in rows:
        w = np.asarray(fx.temperature(r, p).winding_C, float)
        hot += int(np.count_nonzero(w >= ph.WINDING_MAX_C - 1e-6))
        total += w.size
    if not hot:
        return ivs
    why = (f"{EDGE_WHY} of what a winding survives: the node holds the winding at {ph.WINDING_MAX_C:g} C, the "
           f"hottest insulation class's limit, on {hot} of {total} rows, a heating traded for the other terms")
    return [dataclasses.replace(iv, determined=False, why=why) if iv.field == "th_r_K_per_W" else iv for iv in ivs]
OUTSIDE_WHY = "its interval"  # (the head of the reason of an interval that reaches outside the physical range)


def _thermal_needs_its_node(ivs: list) -> list:
    """ivs with a thermal effect's coefficient, and Ra where the fit moved it, not determined where the winding
    node's thermal resistance they are fitted through stopped at the edge of its range: the winding's rise over
    the case is then not what the data say but the range's end, and the coefficient (the copper's change per
    kelvin of that rise) would be a value that was not fitted, and so would Ra at the reference temperature (an
    independent probe's large motor, 0.34 K/W from winding to ambient, below the range's 1.5 K/W: Ra from the
    data alone 0.702 ohm, 0.659..0.746, against the motor's 1.29)."""
    node = [iv for iv in ivs if iv.field == "th_r_K_per_W" and not iv.determined and iv.why.startswith(EDGE_WHY)]
    if not node:
        return ivs
    head = f"the winding node it is fitted through is not determined ({node[0].field}: {node[0].why}), and "
    why = {e.field: head + "the coefficient depends on the winding temperature the node gives"
           for e in schema.EFFECTS if e.thermal}
    why["ra_ohm"] = head + "Ra at the reference temperature rests on the winding temperature the node gives"
    return [dataclasses.replace(iv, determined=False, why=why[iv.field], needs=THERMAL_NEEDS)
            if iv.field in why and iv.determined else iv for iv in ivs]


FORM_WHY = "it trades against"  # (the head of the reason of an Ra that rests on a form stopped at its edge)


def value_stands(iv: "Interval") -> bool:
    """Whether iv's value is what a model that explains the rows gives: determined, or not determined only
    because it rests on a form stopped at its edge (FORM_WHY), a model the data did not exclude all the same."""
    return iv.determined or iv.why.startswith(FORM_WHY)


def _sizes_of_unfixed_forms(ivs: list, p: ph.PhysicsParams, bounds: dict) -> list:
    """ivs with the coefficient of an effect fitted in its widened family (schema.Shape.widened)
    not determined where one of its shapes stops at an edge of the widest range (but the base
    form's): the data pull the form beyond every form allowed, and the size depends on the
    form, so a narrow interval of the size at the edge's form would be a silent edge.
    Where that effect's term is a function of the current (schema.Effect.reads) and the shape stopped at
    the edge toward which the term becomes a straight line in the current (schema.Shape.straight_at: a
    brush drop's knee beyond the currents run, a resistance), Ra fitted beside it is not determined
    either: the data want more of the drop straight in the current than any form allowed, and how much
    of it is the form's and how much I Ra's they do not say (an independent bench's tanh brush drop,
    knee 1.14 A: the knee stopped at 1 A, and Ra from the data alone was 0.546 ohm, 0.534..0.558 before
    its budget, against the motor's 0.591). Stopped at the other edge (a drop that levels off sharper
    than any form allowed) the drop is level over most currents and Ra is the slope beside it."""
    by_field = {iv.field: k for k, iv in enumerate(ivs)}
    for e in schema.EFFECTS:
        if e.field not in by_field or e.name not in fx.widened_in(p, [e.name]):
            continue
        for sh in e.shapes:
            v = float(getattr(p, sh.field))
            if sh.field not in bounds or v == sh.default or not on_edge(v, bounds[sh.field]):
                continue
            k = by_field[e.field]
            edge = (f"{sh.field} = {schema.quantity(v, sh.unit)}, range {_rng(bounds[sh.field], 1.0, sh.unit)}")
            if ivs[k].determined:
                ivs[k] = dataclasses.replace(
                    ivs[k], determined=False,
                    why=f"its form stopped at the edge of the forms allowed ({edge}) and its size depends on the form")
            ra = by_field.get("ra_ohm")
            lo, hi = bounds[sh.field]
            straight = (sh.straight_at == "hi" and abs(v - hi) <= abs(v - lo)) or (
                sh.straight_at == "lo" and abs(v - lo) <= abs(v - hi))  # (on the edge of the straight line)
            if straight and e.reads == "current" and ra is not None and ivs[ra].determined:
                ivs[ra] = dataclasses.replace(
                    ivs[ra], determined=False,
                    why=(f"{FORM_WHY} the form of {e.name}, which stopped at the edge where it turns into a "
                         f"straight line in the current as I Ra is ({edge}): the data want more of the drop "
                         f"straight in the current than any form allowed, and do not say how much of it is Ra's"))
            break
    return ivs


def on_edge(v: float, b: tuple) -> bool:
    lo, hi = b
    span = (hi - lo) if math.isfinite(hi - lo) else max(abs(v), 1.0)
    return abs(v - lo) <= EDGE_REL * span or abs(v - hi) <= EDGE_REL * span


def _rng(b: tuple, scale: float, unit: str) -> str:
    lo, hi = b
    u = "" if unit == "1" else f" {unit}"  # (a pure number's unit, 1, is not written)
    return f"{lo * scale:.3g}..{hi * scale:.3g}{u}" if math.isfinite(hi) else f"above {lo * scale:.3g}{u}"


def fitted_fields(rows, names, hold=None, ra_bounds=None, widen=()) -> tuple[list, dict]:
    """(fields, {field: bounds}) that fx.fit moves for the effects in names (hold as fx.fit's;
    ra_bounds: Ra moved too, within them; widen: the effects fitted in their widened family):
    Ke, the coefficients not held, their shapes, the winding node of a thermal effect."""
    spec = fx.spec_for(rows, names, hold, widen)
    fields, bounds = list(spec.free), dict(spec.bounds)
    if spec.thermal_state:
        for n in fx.node_params(spec.blind):
            if n.field not in spec.node_free:  # held (a profile's fit)
                continue
            fields.append(n.field)
            bounds[n.field] = n.physical
    if ra_bounds is not None:
        fields.append("ra_ohm")
        bounds["ra_ohm"] = tuple(ra_bounds)
    return fields, bounds


def of_fit(data, p: ph.PhysicsParams, names, hold=None, ra_bounds=None) -> list[Interval]:
    """The Interval of every quantity that fx.fit(data.rows, ..., names, hold, ra_bounds)
    moved to reach p (its training rows, the bootstrap's operating-point blocks)."""
    widen = fx.widened_in(p, [n for n in names if n in fx.LIBRARY])
    fields, bounds = fitted_fields(data.rows, names, hold, ra_bounds, widen)
    return intervals(data.rows, data.blocks_train, p, fields, bounds)


def ke_two_ways(recs, ra_ohm: float) -> dict:
    """Ke by the paper's eq. 20 (the mean of (V - I Ra) / w) and by least squares (V - I Ra on w,
    no intercept) on the rows hpddo train identifies M2's Ke on (identify.ke_rows: the training
    rows, in windows), so that eq. 20's value here is train's, each with its 95 % interval
    (cluster-robust over the runs of one duty, at least the rows' own), Ra at ra_ohm:
    {"eq20": (value, lo, hi), "lsq": (value, lo, hi), "apart": bool (the two intervals do not
    overlap), "clusters": int}."""
    from ..model import identify
    try:
        v, i, n, _, groups = identify.ke_rows(recs)
    except identify.IdentificationError:
        v = i = n = groups = np.zeros(0)
    emf, w = v - i * ra_ohm, n * 2.0 * math.pi / 60.0
    ok = np.isfinite(emf) & np.isfinite(w) & (w > 0)
    v, i, n, emf, w, groups = v[ok], i[ok], n[ok], emf[ok], w[ok], groups[ok]
    # the values are train's own functions' (the same sums, to the bit); the fits give their intervals
    value = {"eq20": identify.ke_eq20, "lsq": identify.ke_lsq}
    out = {"clusters": int(len(np.unique(groups)))}
    if len(w) < 3:  # too few rows to say either
        nan = (math.nan, math.nan, math.nan)
        return {**out, "eq20": nan, "lsq": nan, "apart": False}
    for key, (y, x) in (("eq20", (emf / w, np.ones_like(w))), ("lsq", (emf, w))):
        fit = OLS(y, x[:, None]).fit()
        var = float(fit.cov_params()[0, 0])
        df = max(len(y) - 1, 1)
        if out["clusters"] >= 3:
            clu = OLS(y, x[:, None]).fit(cov_type="cluster", cov_kwds={"groups": groups})
            var, df = max(var, float(clu.cov_params()[0, 0])), out["clusters"] - 1
        t = float(stats.t.ppf(0.5 + LEVEL / 2, df))
        k, se = value[key](v, i, n, ra_ohm), math.sqrt(var)
        out[key] = (k, k - t * se, k + t * se)
    out["apart"] = bool(out["eq20"][1] > out["lsq"][2] or out["lsq"][1] > out["eq20"][2])
    return out


# ---------------------------------------------------------------------------------------
# The uncertainty budget (GUM): what the data's scatter gives (the statistical part above) is
# conditional on the model being right and on perfect sensors. Each interval the diagnosis
# reports adds, in quadrature, as standard uncertainties:
#   * the sensors' part: the channels' calibration, a rectangular tolerance of half-width
#     v_cal_rel / i_cal_rel (log header, docs/bench-log.md; else the defaults below), and their ADC
#     steps, each carried through the fit (sensors_u); where no fit is at hand, the calibration
#     alone through the quantity's own scaling with each channel's gain (SENSOR_GAIN);
#   * the model's part: the held-out residual beyond the noise floor (the Birge ratio
#     R = sqrt(held-out MSE / floor)): where the model leaves structure, its statistical part is
#     scaled by R (u_model = u_stat sqrt(R^2 - 1));
#   * for a quantity fitted with Ra held at the reading (Ke, the effects): the reading's own
#     doubt, its tolerance as a rectangular half-width, through the quantity's sensitivity to Ra.
# The expanded interval is value -+ sqrt((t u_stat)^2 + (k (u_sensor^2 + u_model^2 + u_ra^2))),
# k = 1.96 for the parts that are not the data's (a normal approximation).
K_OTHER = 1.959963984540054
# Calibration tolerances assumed where the log declares none: a voltage divider of 1 % resistors
# read by a 10-bit ADC against its supply; a shunt and amplifier of 2 %.
DEFAULT_CAL_REL = {"v_cal_rel": 0.01, "i_cal_rel": 0.02}
# each tolerance key's channel, as the report names it
CAL_CHANNEL = {"v_cal_rel": "voltage", "i_cal_rel": "current"}
# A channel's zero: declared (v_zero_V, i_zero_A), else as the rows at rest read it (effects.rest_offsets: its
# offset's size and twice its standard error), else within ZERO_STEPS of its steps (an AVR's ADC reads 0 V as a
# code within about 2 of 0: its offset error; none where no step is known), rectangular; none for a channel
# whose offset effect the model carries (fitted, or held at its reading at rest). One error for every recording
# (one board), carried through the fit as the gains are.
ZERO_KEY = {"v": "v_zero_V", "i": "i_zero_A"}
ZERO_STEPS = 2.0
ZERO_FROM = {"declared": "declared", "rest": "as the rows at rest read it", "steps": f"{ZERO_STEPS:g} of its steps",
             "model": "its offset in the model"}


def zero_tolerance(attr: str, cal: dict, steps: list) -> float:
    """The half-width of the zero error of channel attr ("v", "i"): cal[ZERO_KEY] where given (declared,
    or core.zeros'), else ZERO_STEPS of its largest step over the recordings (steps: per recording {attr:
    step})."""
    z = cal.get(ZERO_KEY[attr])
    return float(z) if z is not None else ZERO_STEPS * max((st.get(attr, 0.0) for st in steps), default=0.0)


def sensors_text(cal: dict, declared, zeros: dict, steps_declared: bool) -> str:
    """The sentence that says what every interval's sensors' part takes of the channels (cal: their
    gains' tolerances; declared: the keys a log declares, the others are the defaults; zeros: {Rows
    attribute: (its zero's half-width, where it comes from: a ZERO_FROM key)}; steps_declared: whether
    the logs declare the channels' steps, else they are read off the rows)."""
    gains = (f"the voltage channel's gain as right within {100 * cal['v_cal_rel']:.3g} % and the current's within "
             f"{100 * cal['i_cal_rel']:.3g} %")
    units = {"v": "V", "i": "A"}
    parts = []
    for a, (z, src) in zeros.items():
        what = f"the {CAL_CHANNEL[CAL_KEY[a]]}'s zero"
        if src == "model":
            parts.append(f"{what} from the offset the model fits")
            continue
        if src == "steps" and not z > 0:  # (zero_tolerance: no step known, so no zero error counted)
            parts.append(f"{what} as exact (no recording shows two levels of it, as a supply held fixed in each does, "
                         "and no log declares its step: no error of its zero is counted)")
            continue
        how = ZERO_FROM[src] + (("; the steps " + ("as the logs declare them" if steps_declared else "as the rows show "
                                                   "them: their grid, else the decimals written")) if src == "steps" else "")
        parts.append(f"{what} within {z:.3g} {units[a]} ({how})")
    assumed = [k for k in DEFAULT_CAL_REL if k not in declared] + [
        ZERO_KEY[a] for a, (_, src) in zeros.items() if src == "steps"]
    said = ("" if not assumed else
            f"; assumed where no log declares {', '.join(assumed)}: a channel worse than that leaves the intervals too "
            f"narrow; declare its tolerances in the logs, # {assumed[0]}= (docs/bench-log.md)")
    return f"every interval takes {gains}, and {' and '.join(parts)}{said}"


# field -> {tolerance key: exponent}: the quantity scales as gain_v^a gain_i^b under the channels'
# gains (Ke w = V - I Ra: Ke with the voltage's gain; Ra = V / I with the voltage's over the
# current's; a brush drop is a voltage; an offset of the current and the saturation per ampere
# with the current's)
SENSOR_GAIN = {
    "ke_vs_per_rad": {"v_cal_rel": 1.0},
    "ra_ohm": {"v_cal_rel": 1.0, "i_cal_rel": -1.0},
    "brush_V": {"v_cal_rel": 1.0},
    "v_offset_V": {"v_cal_rel": 1.0},
    "i_offset_A": {"i_cal_rel": 1.0},
    "ke_sat_per_A": {"i_cal_rel": -1.0},
    "la_H": {"v_cal_rel": 1.0, "i_cal_rel": -1.0},
}


def sensor_u(field: str, value: float, cal: dict) -> float:
    """Standard uncertainty of a quantity from the channels' calibration tolerances cal
    ({key: relative half-width}), rectangular: |value| sqrt(sum (a tol / sqrt 3)^2)."""
    rel2 = sum((a * cal.get(k, 0.0)) ** 2 / 3.0 for k, a in SENSOR_GAIN.get(field, {}).items())
    return abs(value) * math.sqrt(rel2)


RESOLUTION_PART = "of which ADC steps"  # the sensors' part's share from the channels' rounding (sensors_u)
RESOLUTION_SHOWN = 0.01  # ... shown where it is at least this share of the sensors' part
# the Rows attribute of each channel's reading -> its calibration tolerance key
CAL_KEY = {"v": "v_cal_rel", "i": "i_cal_rel"}


NOISE_TRIM = 4.0  # row-to-row changes beyond this many steps (or robust spreads) are a load's steps


def _row_noise(x: np.ndarray, step: float) -> float:
    """A channel's noise within a block of consecutive rows at one command, read in steps of `step`:
    the spread of its row-to-row changes over sqrt 2, the changes beyond NOISE_TRIM steps or robust
    spreads left out (the steps of a load the log does not name; a quantised channel's median change
    is often none, so the step bounds the cut from below); 0 with fewer than three rows."""
    if len(x) < 3:
        return 0.0
    dx = np.diff(x)
    mad = 1.4826 * float(np.median(np.abs(dx - np.median(dx))))
    kept = dx[np.abs(dx) <= NOISE_TRIM * max(step, mad)]
    return float(np.sqrt(np.mean(kept ** 2)) / math.sqrt(2.0)) if len(kept) else 0.0


def point_rounding_u(x: np.ndarray, step: float, steady: bool) -> float:
    """The standard rounding error that the mean of one operating point's readings x (a channel read
    in steps of `step`) carries: anywhere within -+ step/2 (standard step / sqrt 12) where its noise
    does not dither it over several steps, falling as exp(-2 pi^2 sigma^2 / step^2) (the first
    harmonic) where Gaussian noise sigma before the ADC does; sigma from the point's row-to-row
    changes (_row_noise) with Sheppard's correction (sigma^2 - step^2 / 12). A steady-state table's
    row is a settled point of its own, whose noise its neighbours do not show (taken as none)."""
    sigma = 0.0 if steady else _row_noise(x, step)
    sigma2 = max(sigma * sigma - step ** 2 / 12.0, 0.0)
    return math.exp(-2.0 * math.pi ** 2 * sigma2 / step ** 2) * step / math.sqrt(12.0)


def shared_rounding(r, blocks: np.ndarray, steps: dict, p: ph.PhysicsParams) -> list:
    """The rounding errors that the rows of one recording (rows r) share, for the held-out test
    (ranking.gain_z): per channel with a known step (steps: {Rows attribute: step}), (a label per row
    naming the operating point (blocks, -1 outside) and the code it reads, -1 where none; the
    standard speed error, RPM, of that shared rounding: point_rounding_u through the plain model's
    sensitivity to the channel, noise.rpm_per_reading)."""
    from .noise import rpm_per_reading

    sens = rpm_per_reading(p)
    out = []
    for attr, step in steps.items():
        if not step or step <= 0 or attr not in sens:
            continue
        x = getattr(r, attr)
        labels = np.full(len(x), -1, np.int64)
        u = np.zeros(len(x))
        inside = (blocks >= 0) & np.isfinite(x)
        if not inside.any():
            continue
        codes = np.round(x[inside] / step)
        labels[inside] = np.unique(np.column_stack([blocks[inside], codes]), axis=0, return_inverse=True)[1].ravel()
        for b in np.unique(blocks[inside]):
            sel = inside & (blocks == b)
            u[sel] = point_rounding_u(x[sel], step, r.steady) * sens[attr]
        out.append((labels, u))
    return out


def sensors_u(rows, groups_per_rec, p: ph.PhysicsParams, fields, bounds: dict, steps: list, cal: dict) -> dict:
    """{field: (calibration's, rounding's standard uncertainty)} of the fields of p fitted on the
    training rows of `rows` (groups_per_rec: their operating-point blocks, as for intervals()),
    each sensor error carried through the fit (GUM: its sensitivity coefficient, by the fit's
    linearised least-squares projection of the speed change the error makes on the rows onto the
    fitted fields; the model's sensitivity to each channel by central differences):
      * calibration: each channel's gain error, rectangular within cal[CAL_KEY] (relative). Not
        only the quantity's own scale: with Ra held, a current gain error is an Ra error; a voltage
        gain error moves what is fitted through the back-EMF (Ke, and a term that can take its shape);
      * rounding: steps, per recording {Rows attribute "v"/"i": the channel's step s, 0 where
        unknown}. Where a channel's noise within an operating point dithers it over several steps,
        the rounding averages out of the point's mean; where it does not (a held load reading one
        code, or two neighbours), every row of the point carries the same rounding error, anywhere
        within -+ s/2 (standard s / sqrt 12), and so do the other rows that read the same code (the
        same load at another duty draws the same current): the rows' scatter does not show it. For
        Gaussian noise sigma before the ADC the bias on a point's mean falls as
        exp(-2 pi^2 sigma^2 / s^2) (its first harmonic), sigma from the block's row-to-row changes
        (_row_noise) with Sheppard's correction (sigma^2 - s^2 / 12); a steady-state table's row is
        a settled point of its own, whose noise its neighbours do not show (taken as none). The
        codes add in quadrature."""
    masks, free = fitted_rows(rows, groups_per_rec, p, fields, bounds)
    if not free or not any(m.any() for m in masks):
        return {}
    jac = jacobian(rows, masks, p, free)
    ok = np.all(np.isfinite(jac), axis=1)
    norms = np.sqrt(np.sum(jac[ok] ** 2, axis=0))
    live = (norms > 0) & np.isfinite(norms)
    if not live.any() or ok.sum() <= live.sum():
        return {}
    proj = np.zeros((len(free), len(ok)))
    proj[np.ix_(live, ok)] = np.linalg.pinv(jac[np.ix_(ok, live)] / norms[live], rcond=1e-9) / norms[live][:, None]
    var_cal, var_res = np.zeros(len(free)), np.zeros(len(free))
    for attr, key in CAL_KEY.items():
        x = np.concatenate([getattr(r, attr)[m] for r, m in zip(rows, masks)])
        h = 1e-4 * max(float(np.max(np.abs(x))), 1e-9)
        up = predict_all([dataclasses.replace(r, **{attr: getattr(r, attr) + h}) for r in rows], masks, p)
        dn = predict_all([dataclasses.replace(r, **{attr: getattr(r, attr) - h}) for r in rows], masks, p)
        sens = np.where(np.isfinite(up - dn), (up - dn) / (2 * h), 0.0)  # d speed / d reading, per row
        var_cal += (proj @ (sens * x) * cal.get(key, 0.0)) ** 2 / 3.0
        var_cal += (proj @ sens * zero_tolerance(attr, cal, steps)) ** 2 / 3.0
        weight = np.zeros(len(sens))  # per row: the standard rounding error its point's mean carries
        step_of = np.zeros(len(sens))  # per row: its channel's step (0: unknown) and the code it reads
        code_of = np.zeros(len(sens))
        at = 0
        for r, g, m, st in zip(rows, groups_per_rec, masks, steps):
            s_step = st.get(attr, 0.0)
            n = int(m.sum())
            if s_step > 0:
                xr, blk = getattr(r, attr)[m], g[m]
                for b in np.unique(blk):
                    sel = np.flatnonzero(blk == b)
                    weight[at + sel] = point_rounding_u(xr[sel], s_step, r.steady)
                step_of[at:at + n], code_of[at:at + n] = s_step, np.round(xr / s_step)
            at += n
        use = step_of > 0
        if use.any():
            # the rows that read one code (of one step) share its rounding error; the codes numbered in
            # the order they first appear
            _, first, inv = np.unique(np.column_stack([step_of[use], code_of[use]]), axis=0,
                                      return_index=True, return_inverse=True)
            rank = np.empty(len(first), np.int64)
            rank[np.argsort(first, kind="stable")] = np.arange(len(first))
            moves = np.zeros((len(first), len(free)))
            np.add.at(moves, rank[np.ravel(inv)], (proj[:, use] * (sens * weight)[use]).T)
            var_res += np.sum(moves ** 2, axis=0)
    return {f: (float(math.sqrt(c)), float(math.sqrt(r))) for f, c, r in zip(free, var_cal, var_res)}


def sensors_of_fit(data, p: ph.PhysicsParams, names, steps: list, cal: dict, hold=None, ra_bounds=None) -> dict:
    """sensors_u of the quantities that fx.fit(data.rows, ..., names, hold, ra_bounds) moved to
    reach p (as of_fit)."""
    widen = fx.widened_in(p, [n for n in names if n in fx.LIBRARY])
    fields, bounds = fitted_fields(data.rows, names, hold, ra_bounds, widen)
    return sensors_u(data.rows, data.blocks_train, p, fields, bounds, steps, cal)


def spread_u(value: float, alternatives) -> float:
    """The standard uncertainty of a quantity from the models that explain the data about as
    well as the one it was fitted with (their values of it, alternatives): the largest distance
    from value, read as the half-width of a rectangular distribution (GUM type B), 0 without any."""
    d = [abs(a - value) for a in alternatives if math.isfinite(a)]
    return max(d, default=0.0) / math.sqrt(3.0)


def reaching_over(iv: "Interval", values) -> "Interval":
    """iv (with_budget's) reaching over further models' values of its quantity too, each with iv's own
    expanded half-width (half_without_models), as with_budget's models do: lo and hi widened to hold them, the
    model part of the budget with their spread added (in quadrature: spread_u of the values about iv.value).
    iv as it is where it has no budget or no value is finite."""
    vals = [float(v) for v in values if math.isfinite(v)]
    if iv is None or not vals or iv.half_without_models is None or iv.lo is None or iv.hi is None:
        return iv
    half = iv.half_without_models
    lo, hi = min(iv.lo, min(vals) - half), max(iv.hi, max(vals) + half)
    if lo == iv.lo and hi == iv.hi:
        return iv
    budget = dict(iv.budget)
    budget["model"] = math.hypot(budget.get("model", 0.0), spread_u(iv.value, vals))
    return _inside_physical(iv, dataclasses.replace(iv, lo=lo, hi=hi, budget=budget))


def _inside_physical(iv: "Interval", out: "Interval") -> "Interval":
    """out (iv with its whole budget) not determined where its interval reaches outside the quantity's physical
    range, though iv was."""
    _, unit, scale, phys, _, _ = _describe(iv.field)
    phys = iv.physical if iv.physical is not None else phys
    # (an interval already outside on its statistical part alone says so again with the interval it now has: the
    # report printed -0.778..-0.305 %/K in the reason beside -1.16..+0.617 %/K as the interval, a fuzzing round's)
    again = not iv.determined and iv.why.startswith(OUTSIDE_WHY)
    if (iv.determined or again) and (out.lo <= phys[0] or out.hi >= phys[1]):
        return dataclasses.replace(out, determined=False, why=(
            f"with its whole uncertainty budget its interval {out.lo * scale:.3g}..{out.hi * scale:.3g} {unit} "
            f"reaches outside the physical {_rng(phys, scale, unit)}"))
    return out


def with_budget(iv: "Interval", cal: dict, birge: float, ra_u: float = 0.0, ra_sens: float = 0.0,
                given: str = "", models=(), sensors: tuple | None = None) -> "Interval":
    """iv with its uncertainty budget and the expanded interval (above); ra_u: the standard
    uncertainty of the Ra the fit held, ra_sens: d value / d Ra; given: what it is conditional on;
    models: the quantity's values in the candidate models the data did not exclude: the interval
    reaches from the lowest of them and iv.value, less the expanded half-width of one model, to the
    highest, plus it (every model with its own doubt), and their spread (spread_u) joins the model
    part of the budget shown; sensors: (calibration's, rounding's) standard uncertainty carried
    through the fit (sensors_u), else the calibration's through the quantity's own scale (sensor_u)
    and no rounding part; the rounding's share of the sensors' part is shown as its own."""
    if iv.lo is None or iv.hi is None or not (math.isfinite(iv.lo) and math.isfinite(iv.hi)):
        return iv
    if "statistical" not in iv.budget:
        return iv
    t_stat = (iv.hi - iv.lo) / 2.0  # t u_stat
    u_stat = iv.budget["statistical"]
    u_cal, u_res = sensors if sensors is not None else (sensor_u(iv.field, iv.value, cal), 0.0)
    u_sens = math.hypot(u_cal, u_res)
    u_birge = u_stat * math.sqrt(max(birge * birge - 1.0, 0.0))
    models = [m for m in models if math.isfinite(m)]
    u_model = math.hypot(u_birge, spread_u(iv.value, models))
    u_ra = abs(ra_sens) * ra_u
    half = math.sqrt(t_stat ** 2 + K_OTHER ** 2 * (u_sens ** 2 + u_birge ** 2 + u_ra ** 2))
    budget = {"statistical": u_stat, "sensors": u_sens}
    if u_res >= RESOLUTION_SHOWN * u_sens > 0:
        budget[RESOLUTION_PART] = u_res
    budget["model"] = u_model
    if ra_u > 0 and ra_sens:
        budget["Ra given"] = u_ra
    lo, hi = min([iv.value] + models) - half, max([iv.value] + models) + half
    out = dataclasses.replace(iv, lo=lo, hi=hi, budget=budget, given=given,
                              half_without_ra=math.sqrt(t_stat ** 2 + K_OTHER ** 2 * (u_sens ** 2 + u_birge ** 2)),
                              half_without_models=half)
    return _inside_physical(iv, out)  # the whole budget may leave what is physical
