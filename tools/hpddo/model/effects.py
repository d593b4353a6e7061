"""The effect library: physical effects that the plain model M2 leaves out, each as one
named coefficient of the physics model, its regressor and its identification.

Every effect is declared once, in schema.py (its PhysicsParams field, units, plausible
range, meaning, excitation and bit; the C++ struct and bits are generated from it); the
term itself exists once here (through tools/hpddo/model/physics.py) and once in lib/hpddo_core
(physics.h), and test/py/test_effects_parity.py holds the two together.

The regressor of an effect is the sensitivity of the speed estimate to its coefficient,
d n_M2 / d c (RPM per unit of the coefficient), taken by central difference through
physics.physics_rpm, so a new term needs no hand-written derivative.

`identify` fits Ke and the named coefficients on the training rows (rpm_ref > 10, as
eq. 20) with Ra held at its measured value, by least squares on the speed error.

Temperature (physics.temperatures, as the boards): a thermal effect brings the winding
node (th_r_K_per_W, th_tau_s), fitted with the coefficients. Where the log reads the case
temperature, the copper (thermal_ra) follows the node's rise above the reading and the
magnets (magnet_thermal) the reading. Where it reads none, the node rises above ambient,
the magnets follow it too, and a state and a coefficient only show as their product, so
the coefficient is held at its material value: thermal_ra at copper's +0.00393 /K,
magnet_thermal alone at ferrite's -0.002 /K. With both thermal effects named, copper's
coefficient is always held (only the material constant tells the two apart).
"""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import math

import numpy as np
from scipy.optimize import least_squares

from . import physics as ph
from .. import schema
from ..logs.dataset import Recording, di_dt_A_per_s, dt_s, kind, rate_per_s, temp_read_C
from .identify import MIN_RPM, IdentificationError

# One entry of the library: the declaration in schema.py (name, field, units, plausible
# range, meaning, excitation, separating recordings, material constant, bit).
Effect = schema.Effect

LIBRARY = dict(schema.BY_NAME)

NAMES = tuple(LIBRARY)

COPPER = "thermal_ra"                                 # the copper: Ra at the winding's temperature
COPPER_TC_PER_K = LIBRARY[COPPER].material            # 0.00393, declared in schema.py
FERRITE_TC_PER_K = LIBRARY["magnet_thermal"].material  # -0.002


def check_names(names) -> tuple:
    names = tuple(names)
    unknown = [n for n in names if n not in LIBRARY]
    if unknown:
        raise IdentificationError(f"unknown effect(s) {unknown}; known: {', '.join(NAMES)}")
    return names


def parse_names(text: str) -> tuple:
    """Effect names from a comma-separated option value (an argparse type)."""
    import argparse
    try:
        return check_names(s.strip() for s in text.split(",") if s.strip())
    except IdentificationError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_holds(text: str) -> dict:
    """{effect: coefficient in SI} from an option value NAME=VALUE[,NAME=VALUE...] (an argparse type): VALUE is
    the name of the effect's material (thermal_ra=copper: schema.Effect.material_name) or a number in the unit the
    effect is shown in (thermal_ra=0.393, %/K), within the effect's physical range."""
    import argparse
    out = {}
    for item in (s.strip() for s in text.split(",") if s.strip()):
        name, sep, value = (w.strip() for w in item.partition("="))
        if not sep or not value:
            raise argparse.ArgumentTypeError(f"{item!r}: expected NAME=VALUE (e.g. {COPPER}=copper)")
        try:
            eff = LIBRARY[check_names([name])[0]]
        except IdentificationError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if name in out:
            raise argparse.ArgumentTypeError(f"{name} is held twice")
        if eff.material is not None and value.lower() == eff.material_name.lower():
            out[name] = eff.material
            continue
        try:
            x = float(value) / eff.show_scale
        except ValueError:
            x = float("nan")
        materials = f"its material's name ({eff.material_name}) or " if eff.material is not None else ""
        if not (np.isfinite(x) and eff.is_physical(x)):
            lo, hi = eff.physical
            raise argparse.ArgumentTypeError(
                f"{name}={value}: expected {materials}a number in {eff.show_unit} within its physical range "
                f"{lo * eff.show_scale:.3g}..{hi * eff.show_scale:.3g} {eff.show_unit}")
        out[name] = x
    return out


# ---------------------------------------------------------------------------------------
# Rows: what the physics model sees, per recording


@dataclasses.dataclass
class Rows:
    """Inputs of the physics model for every row of one recording, and its masks."""

    rec: Recording
    v: np.ndarray
    i: np.ndarray
    di_dt: np.ndarray
    dt: np.ndarray
    temp: np.ndarray      # temp_C where read (NaN elsewhere)
    has_temp: np.ndarray  # bool per row
    ref: np.ndarray       # rpm_ref (NaN where absent)
    train: np.ndarray     # bool: training row usable for fitting (rpm_ref > MIN_RPM)
    test: np.ndarray      # bool: held-out row usable for scoring (rpm_ref > MIN_RPM)
    duty: np.ndarray
    steady: bool = False  # a steady-state table (dataset.kind): settled rows, no clock, dI/dt 0
    # the node's other form (physics.lagged_case): the winding follows the case reading through the node's lag; a
    # rival model the diagnosis weighs (core.node_form_rival), never the boards'
    winding_lags_case: bool = False

    @property
    def dv_dt(self) -> np.ndarray:
        """The voltage's rate of change per row, V/s (0 on a steady-state table's settled rows)."""
        return np.zeros(len(self.v)) if self.steady else rate_per_s(self.rec, "v_V")

    @property
    def needs_state(self) -> bool:
        return not bool(self.has_temp.all())


def rows_of(rec: Recording) -> Rows:
    df = rec.df
    i = df["i_A"].to_numpy(float)
    dt = dt_s(rec)
    steady = kind(rec)[0] == "steady_state"
    di_dt = np.zeros(rec.n) if steady else di_dt_A_per_s(rec)  # a settled row: the current does not change
    t = temp_read_C(rec)
    ok = np.isfinite(t)
    ref = df["rpm_ref"].to_numpy(float) if "rpm_ref" in df else np.full(rec.n, np.nan)
    good = np.isfinite(ref) & (ref > MIN_RPM)
    idx = np.arange(rec.n)
    return Rows(rec=rec, v=df["v_V"].to_numpy(float), i=i, di_dt=di_dt, dt=dt, temp=np.where(ok, t, np.nan),
                has_temp=ok, ref=ref, train=good & (idx < rec.n_train), test=good & (idx >= rec.n_train),
                duty=df["duty"].to_numpy(float), steady=steady)


# Fields of PhysicsParams the temperatures depend on; a fit's Jacobian moves the others
# without recomputing the thermal state.
_THERMAL_FIELDS = ("ra_ohm", "ra_tc_per_K", "t_ref_C", "i_offset_A", "th_r_K_per_W", "th_tau_s", "t_amb_C")
_temp_cache: dict = {}


_prefixes: dict = {}


def _prefix(r: Rows, k: int) -> tuple:
    """(i, dt, temp) of r's first k rows, the same arrays for the same recording and k (the node's decay is kept
    per array of periods, physics._decay)."""
    key = (id(r), k)
    hit = _prefixes.get(key)
    if hit is not None and hit[0] is r:
        return hit[1]
    if len(_prefixes) > 64:
        _prefixes.clear()
    _prefixes[key] = (r, (r.i[:k], r.dt[:k], r.temp[:k]))
    return _prefixes[key][1]


def temperature(r: Rows, p: ph.PhysicsParams, upto: int | None = None) -> ph.Temps:
    """The winding and magnet temperatures the thermal effects see, as the boards compute
    them (physics.temperatures, observer.h; on a steady-state table's settled rows, the node
    settled at each); the last few are kept per recording. upto: only the first upto rows'
    are needed (a fit whose rows end there): those of the rows up to physics.trajectory_prefix,
    the same bits on the first upto rows as the whole recording's (the node runs forward)."""
    k, (i, dt, temp) = _node_inputs(r, upto)
    key = (id(r), k, tuple(getattr(p, f) for f in _THERMAL_FIELDS))
    hit = _temp_cache.get(key)
    if hit is not None and hit[0] is r:
        return hit[1]
    t = ph.temperatures(p, i, dt, temp, settled=r.steady, lag=r.winding_lags_case)
    if len(_temp_cache) > 64:
        _temp_cache.clear()
    _temp_cache[key] = (r, t)
    return t


def temperature_cols(r: Rows, p: ph.PhysicsParams, upto: int | None = None) -> ph.Temps:
    """temperature() for parameters with columns of values (k x 1, the columns of a fit's Jacobian): one
    row per column, each the same bits as temperature() of that column alone; not kept."""
    _, (i, dt, temp) = _node_inputs(r, upto)
    return ph.temperatures(p, i, dt, temp, settled=r.steady, lag=r.winding_lags_case)


def _node_inputs(r: Rows, upto: int | None) -> tuple:
    """(k, (i, dt, temp)): the rows the thermal node runs over for the first upto rows' temperatures
    (physics.trajectory_prefix; all where upto is None) and its inputs over them."""
    n = len(r.i)
    k = n if upto is None else ph.trajectory_prefix(upto, n)
    return k, ((r.i, r.dt, r.temp) if k == n else _prefix(r, k))


def predict(r: Rows, p: ph.PhysicsParams, temp=None) -> np.ndarray:
    """n_M2 (RPM) of every row, float64."""
    t = temperature(r, p) if temp is None else temp
    return ph.physics_rpm(p, r.v, r.i, r.di_dt, t)


def sensitivity(r: Rows, p: ph.PhysicsParams, field: str, h: float, temp=None) -> np.ndarray:
    """d n_M2 / d field at p, RPM per unit of the field, by central difference (step h)
    through physics.physics_rpm; temp: the temperatures (default: those at p)."""
    t = temperature(r, p) if temp is None else temp
    c = getattr(p, field)
    up = dataclasses.replace(p, **{field: c + h})
    dn = dataclasses.replace(p, **{field: c - h})
    return (ph.physics_rpm(up, r.v, r.i, r.di_dt, t) - ph.physics_rpm(dn, r.v, r.i, r.di_dt, t)) / (2 * h)


def regressor(r: Rows, p: ph.PhysicsParams, name: str, temp=None) -> np.ndarray:
    """d n_M2 / d coefficient of effect `name` at p, RPM per unit of the field (central
    difference through physics.physics_rpm)."""
    eff = LIBRARY[name]
    return sensitivity(r, p, eff.field, 1e-3 * abs(eff.scale), temp)


def ke_regressor(r: Rows, p: ph.PhysicsParams, temp=None) -> np.ndarray:
    """d n_M2 / d Ke at p, RPM per V s/rad (central difference, step 1e-4 Ke)."""
    return sensitivity(r, p, "ke_vs_per_rad", 1e-4 * p.ke_vs_per_rad, temp)


# ---------------------------------------------------------------------------------------
# Fitting


# The winding node's fields, in the order a fit moves them (after every other parameter). A fit may hold
# one of them at a value (hold={"th_tau_s": 60.0}: the diagnosis' profile over the node's time constant).
NODE_FIELDS = ("th_r_K_per_W", "th_tau_s")


@dataclasses.dataclass
class FitSpec:
    """Which parameters a fit moves, and how they map onto PhysicsParams."""

    names: tuple          # effects switched on
    free: list            # PhysicsParams fields fitted (ke first)
    scales: list
    bounds: dict          # field -> (lo, hi) for the bounded ones (shape parameters)
    fixed: dict           # fields held at a value
    thermal_state: bool   # th_r_K_per_W, th_tau_s fitted too (log-parametrised)
    blind: bool = False   # some rows read no temperature: the node is the rise above ambient
    base_forms: dict = dataclasses.field(default_factory=dict)  # extension shapes held at the base form
    node_free: tuple = NODE_FIELDS  # the node's fields fitted (log-parametrised, after free); the others in fixed


# Channel offsets read where the truth is known: at standstill with the supply off (duty 0,
# the encoder reading 0 RPM) the true voltage and current are zero, so the readings are the
# channels' offsets. Where a recording has REST_MIN_ROWS such rows in its training part, an
# offset effect is held at their mean instead of fitted: the data at hand measure it, and a
# fitted offset would take up whatever else is constant (a brush drop, a wrong voltage).
REST_MIN_ROWS = 5
REST_READ = {"current_offset": "i", "v_offset": "v"}  # effect -> the Rows channel its offset is read on


def rest_mask(r: Rows) -> np.ndarray:
    """Training rows at standstill with the supply off: duty 0 and 0 RPM read."""
    idx = np.arange(len(r.duty))
    return ((r.duty == 0.0) & (r.ref == 0.0) & (idx < r.rec.n_train) & np.isfinite(r.v) & np.isfinite(r.i))


def rest_offsets(rows: list[Rows]) -> dict:
    """{effect: (offset in SI, its standard error, rows)} of the offset effects that the
    rows at rest measure ({} with fewer than REST_MIN_ROWS of them)."""
    m = [rest_mask(r) for r in rows]
    n = int(sum(int(x.sum()) for x in m))
    if n < REST_MIN_ROWS:
        return {}
    out = {}
    for name, ch in REST_READ.items():
        x = np.concatenate([getattr(r, ch)[k] for r, k in zip(rows, m)])
        out[name] = (float(np.mean(x)), float(np.std(x, ddof=1) / math.sqrt(n)), n)
    return out


def shape_bounds(sh: schema.Shape, widened: bool) -> tuple:
    """The range a shape is fitted within: its widened range in a widened family, else its bounds."""
    return sh.widened if widened and sh.widened is not None else sh.bounds


def widened_in(p: ph.PhysicsParams, names) -> tuple:
    """The effects of names whose family p is in the widened one: an extension shape off its
    default, or a shape beyond its base bounds."""
    out = []
    for n in names:
        for sh in LIBRARY[n].shapes if n in LIBRARY else ():
            v = float(getattr(p, sh.field))
            if (sh.extension and v != sh.default) or (sh.widened is not None and not sh.bounds[0] <= v <= sh.bounds[1]):
                out.append(n)
                break
    return tuple(out)


def spec_for(rows: list[Rows], names, hold=None, widen=()) -> FitSpec:
    """hold: {effect: coefficient} held at a value instead of fitted (and {node field: value} for a field of the
    winding node, NODE_FIELDS, where a thermal effect brings it). An offset effect is
    held at its reading at rest where the rows have one (rest_offsets). widen: the effects
    fitted in their widened family (schema.Shape.widened; their extension shapes free, held
    at the base form for the others)."""
    names = check_names(names)
    hold = dict(hold or {})
    if any(n in REST_READ and n not in hold for n in names):
        for n, (value, _, _) in rest_offsets(rows).items():
            if n in names:
                hold.setdefault(n, value)
    thermal = [n for n in names if LIBRARY[n].thermal]
    # A thermal effect always brings the winding node: above the case reading it is the
    # winding-to-case rise (the copper runs hotter than the sensor under load); where no
    # temperature is read it is the whole rise above ambient, and then the temperature
    # scale is unknown, so the coefficient is held at its material value.
    state = bool(thermal)
    blind = state and any(r.needs_state for r in rows)
    # On settled rows (steady-state tables, physics.settled_rise) the winding's rise is
    # r i^2 Ra (...) / (1 - a r i^2 Ra): the copper's coefficient a and the node's r show as
    # their product, so the copper is held at its material value there, as where no temperature
    # is read (the magnets follow the reading: their coefficient stays free).
    settled = state and all(r.steady for r in rows)
    free, scales, fixed = ["ke_vs_per_rad"], [0.3], {}
    # A coefficient that is a material constant (schema: material) is held at it where the
    # temperature scale is unknown (blind), unless a named effect that shares its work with
    # it is held there instead; and with the effect it shares its work with named too (both
    # thermal effects), only the material constant tells the two apart: it is held, the
    # other fitted. Copper (thermal_ra) is held; the magnets at ferrite's only alone.
    for n in names:
        eff = LIBRARY[n]
        partner_named = eff.shares_work_with in names
        held_by_partner = any(LIBRARY[m].shares_work_with == n for m in names)
        if n in hold:
            fixed[eff.field] = hold[n]
        elif eff.material is not None and (partner_named or (blind and not held_by_partner)
                                           or (settled and n == COPPER)):
            fixed[eff.field] = eff.material
        else:
            free.append(eff.field)
            scales.append(abs(eff.scale))
    # The shape of a named effect's term moves within the forms physics allows (schema.Shape):
    # the effect is named, not the form. Held effects keep theirs (the start's, else the base form).
    bounds, base_forms = {}, {}
    for n in names:
        if n in hold:
            continue
        for sh in LIBRARY[n].shapes:
            if sh.extension and n not in widen:
                base_forms[sh.field] = sh.default
                continue
            free.append(sh.field)
            scales.append(sh.scale)
            bounds[sh.field] = shape_bounds(sh, n in widen)
    node_free = NODE_FIELDS
    if state:
        fixed.update({f: float(hold[f]) for f in NODE_FIELDS if f in hold})
        node_free = tuple(f for f in NODE_FIELDS if f not in hold)
    return FitSpec(names=names, free=free, scales=scales, fixed=fixed, thermal_state=state, blind=blind,
                   bounds=bounds, base_forms=base_forms, node_free=node_free)


def node_path(blind: bool) -> str:
    """The heat path of the winding node: "ambient" where some rows read no temperature
    (FitSpec.blind), else "case" (the rise above the case reading)."""
    return "ambient" if blind else "case"


def node_params(blind: bool) -> tuple:
    """(th_r_K_per_W, th_tau_s) declarations (schema.NodeParam) of the node's heat path."""
    path = node_path(blind)
    return schema.node_param(path, "th_r_K_per_W"), schema.node_param(path, "th_tau_s")


# Where a fit has no node to start from, it starts at the declared one (schema.NODE), but not at a
# resistance at which the recordings' currents would heat the winding past NODE_START_ROOM of the
# headroom a winding has (WINDING_MAX_C over ambient), settled at the NODE_START_QUANTILE of their
# current: there the winding sits at that limit on most rows, where the speed error does not move
# with the node, and the solver stays on that plateau trading Ra for it (a 24 V, 0.48 ohm motor's
# warm-up at 17 A started from 10 K/W: the fit stopped at 80 K/W and 30 s with Ra 0.27 ohm; from
# 0.75 K/W it finds 0.26 K/W, 388 s and Ra 0.484, a sum of squares 84x smaller).
NODE_START_ROOM = 0.5
NODE_START_QUANTILE = 0.9


def node_start(rows, masks, p: ph.PhysicsParams, blind: bool) -> tuple[float, float]:
    """(th_r_K_per_W, th_tau_s) a fit of the winding node starts from on the rows in masks (one
    per recording), at p's Ra and ambient: the declared start, its resistance lowered as above."""
    r_decl, tau_decl = node_params(blind)
    parts = [np.abs(np.asarray(r.i, float)[m]) for r, m in zip(rows, masks)]
    i = np.concatenate(parts) if parts else np.zeros(0)
    i = i[np.isfinite(i)]
    r0 = r_decl.start
    if len(i) and p.ra_ohm > 0:
        loss_W = float(np.quantile(i, NODE_START_QUANTILE)) ** 2 * p.ra_ohm
        room_K = NODE_START_ROOM * (ph.WINDING_MAX_C - p.t_amb_C)
        if loss_W * r0 > room_K:
            r0 = max(room_K / loss_W, r_decl.physical[0])
    return r0, tau_decl.start


def node_plausibility(p: ph.PhysicsParams, blind: bool) -> list:
    """Every fitted parameter of p's winding node against its declared ranges (schema.NODE):
    [{"field", "path", "value", "shown", "plausible", "physical", "at_bound", "plausibility"}];
    [] without a node."""
    if not p.thermal_enabled():
        return []
    out = []
    for n in node_params(blind):
        v = float(getattr(p, n.field))
        ok, text = n.plausibility(v)
        out.append({"field": n.field, "path": n.path, "value": v, "shown": n.show(v), "plausible": ok,
                    "physical": bool(n.physical[0] <= v <= n.physical[1]), "at_bound": n.at_bound(v),
                    "plausibility": text, "basis": n.basis})
    return out


def _params(base: ph.PhysicsParams, spec: FitSpec, x: np.ndarray) -> ph.PhysicsParams:
    kw = dict(zip(spec.free, (float(v) for v in x[: len(spec.free)])))
    kw.update(spec.fixed)
    kw.update(spec.base_forms)
    if spec.thermal_state:
        for j, f in enumerate(spec.node_free):
            kw[f] = float(math.exp(x[len(spec.free) + j]))
    # dataclasses.replace(base, **kw) without its checks, once per evaluation of a fit (PhysicsParams has
    # no __post_init__: a copy with the fields set is the same value)
    p = copy.copy(base)
    p.__dict__.update(kw)
    return p


def _column(values: np.ndarray):
    """A field's values over the rows of a batch of parameter sets: the one value where every row holds
    the same bits, else their column (k x 1)."""
    values = np.asarray(values, float)
    if (values.view(np.int64) == values.view(np.int64)[0]).all():
        return float(values[0])
    return values[:, None]


def _params_cols(base: ph.PhysicsParams, spec: FitSpec, xs: np.ndarray) -> ph.PhysicsParams:
    """_params of each row of xs at once: every field that differs between the rows a column of its
    values (k x 1), one value where they agree (physics then computes what depends on it once)."""
    nf = len(spec.free)
    kw = {f: _column(xs[:, j]) for j, f in enumerate(spec.free)}
    kw.update(spec.fixed)
    kw.update(spec.base_forms)
    if spec.thermal_state:  # math.exp of each value, as _params takes it (numpy's exp may differ in the last bit)
        for j, f in enumerate(spec.node_free):
            kw[f] = _column([math.exp(v) for v in xs[:, nf + j].tolist()])
    p = copy.copy(base)
    p.__dict__.update(kw)
    return p


def _plain(p: ph.PhysicsParams) -> ph.PhysicsParams:
    kw = {ph.EFFECT_BITS[n][1]: 0.0 for n in ph.EFFECT_BITS}
    kw.update((sh.field, sh.default) for sh in schema.SHAPES)
    kw.update(effects=0, th_r_K_per_W=0.0, th_tau_s=0.0)
    return dataclasses.replace(p, **kw)


# The widened family of an effect (schema.Shape.widened, extension shapes) is taken where it
# removes at least this share of the training error the base family leaves (the sum of
# squares): as an effect is named only where it removes REL_MIN = 2 % of the held-out error
# (diagnosis/ranking.py), a form is widened only where the data ask for it. A model whose
# effects stay in their base family is the fit it always was (data/default with thermal_ra,
# brush_drop and magnet_thermal: the widened family lowers it by 0.003 %, so the base fit stands).
WIDEN_REL = 0.02


def fit(rows: list[Rows], base: ph.PhysicsParams, names, mask: str = "train", weights=None,
        start: ph.PhysicsParams | None = None, hold=None, ra_prior=None, ra_bounds=None,
        widen=None) -> ph.PhysicsParams:
    """_fit (below) in the base family of every named effect; where a named effect has a
    widened family (schema.Shape.widened: a brush drop that builds up over more than 300 mA
    or levels off more sharply than i / (|i| + knee)), fitted again from there in it, and
    that fit kept where it lowers the sum of squares by WIDEN_REL or more. widen: the
    effects fitted in their widened family from the start (no base fit); None: decided as
    above."""
    hold = dict(hold or {})
    if widen is not None:
        return _fit(rows, base, names, mask, weights, start, hold, ra_prior, ra_bounds, tuple(widen))[0]
    p, cost = _fit(rows, base, names, mask, weights, start, hold, ra_prior, ra_bounds, ())
    wide = tuple(n for n in check_names(names) if n not in hold and any(sh.widened for sh in LIBRARY[n].shapes))
    if not wide:
        return p
    pw, cost_w = _fit(rows, base, names, mask, weights, p, hold, ra_prior, ra_bounds, wide)
    return pw if cost_w <= (1.0 - WIDEN_REL) * cost else p


# The solver's tolerances (scipy's xtol, ftol, gtol). A fit whose only use is a decision on held-out
# gains of REL_MIN (2 %) of an error and more (the bootstrap's resamples, started at the whole data's
# optimum) needs the optimum to far fewer digits than one whose values are reported:
# solver_tolerance() loosens them for its block.
SOLVER_TOL = 1e-8
_solver_tol = [SOLVER_TOL]


@contextlib.contextmanager
def solver_tolerance(tol: float):
    """Every fit inside the block solved to `tol` (xtol, ftol, gtol) instead of SOLVER_TOL."""
    _solver_tol.append(float(tol))
    try:
        yield
    finally:
        _solver_tol.pop()


# The diagnosis asks for the same fit more than once (the ranking, Ra from the data alone and
# its alternatives, the checks after them: 21 of the 119 fits of data/default's physics verdict,
# 3.4 of its 16.9 s). A fit is a function of its inputs, so the last MEMO_FITS are kept and
# given again, the same values: the rows by identity (kept alive beside the result, so an id is
# never reused while it is held), every other input by value.
MEMO_FITS = 128
_fit_memo: dict = {}


def _memo_key(rows, base, names, mask, weights, start, hold, ra_prior, ra_bounds, widen):
    def params(p):
        return None if p is None else dataclasses.astuple(p)

    def arrays(ws):
        if ws is None:
            return None
        return tuple((a.shape, a.dtype.str, a.tobytes()) for a in (np.ascontiguousarray(w, float) for w in ws))

    return (tuple(id(r) for r in rows), params(base), tuple(names), mask, arrays(weights), params(start),
            tuple(sorted((hold or {}).items())), None if ra_prior is None else tuple(map(float, ra_prior)),
            None if ra_bounds is None else tuple(map(float, ra_bounds)), tuple(widen), _solver_tol[-1])


def _fit(rows: list[Rows], base: ph.PhysicsParams, names, mask: str = "train", weights=None,
         start: ph.PhysicsParams | None = None, hold=None, ra_prior=None, ra_bounds=None,
         widen=()) -> tuple:
    """_solve (below), given again from the last MEMO_FITS fits where the inputs are the same."""
    rows = list(rows)
    key = _memo_key(rows, base, names, mask, weights, start, hold, ra_prior, ra_bounds, widen)
    hit = _fit_memo.get(key)
    if hit is not None and all(a is b for a, b in zip(hit[0], rows)):
        _fit_memo[key] = _fit_memo.pop(key)  # the most recent use last
        return dataclasses.replace(hit[1]), hit[2]
    p, cost = _solve(rows, base, names, mask, weights, start, hold, ra_prior, ra_bounds, widen)
    _fit_memo[key] = (rows, p, cost)
    while len(_fit_memo) > MEMO_FITS:
        del _fit_memo[next(iter(_fit_memo))]
    return dataclasses.replace(p), cost


# A fit's Jacobian: "together" (fd_jacobian: scipy's 2-point finite differences bit for bit, the columns
# evaluated in one pass: those that move no thermal parameter at the point's temperatures, the others with
# their thermal trajectories side by side, instead of one evaluation of the model per column), or
# "2-point" (scipy's own, column by column: the reference test_fit_jacobian.py holds the other to).
JACOBIAN = "together"


def _solve(rows: list[Rows], base: ph.PhysicsParams, names, mask: str = "train", weights=None,
           start: ph.PhysicsParams | None = None, hold=None, ra_prior=None, ra_bounds=None,
           widen=()) -> tuple:
    """Least squares of rpm_ref - n_M2 over the `mask` rows of `rows` (weights per row,
    optional, times the reference's confidence where it has one: Recording.weight), moving Ke and the coefficients of `names` (but those in `hold`, {effect:
    coefficient}, which stay at the value given); Ra, t_ref stay at base's.

    ra_prior (the diagnosis only): (ra0, sd_ohm, sigma_rpm) moves Ra too, with a Gaussian
    prior of mean ra0 and standard deviation sd_ohm (the multimeter reading and its
    tolerance): one more residual sigma_rpm (ra - ra0) / sd_ohm, sigma_rpm the noise level
    of the speed error, so that the sum of squares over sigma_rpm^2 is the negative log
    posterior.

    ra_bounds (the diagnosis only): (lo, hi) ohm moves Ra too, within those bounds and with no
    prior: Ra as the data alone determine it (diagnosis.intervals).

    Returns (the fitted parameters, the cost: half the weighted sum of squares)."""
    spec = spec_for(rows, names, hold, widen)
    if ra_prior is not None or ra_bounds is not None:
        spec.free.append("ra_ohm")
        spec.scales.append(float(ra_prior[1]) if ra_prior is not None else 0.05 * base.ra_ohm)
    p0 = _plain(base) if start is None else start
    x0 = [getattr(p0, f) if (start is not None or f in ("ke_vs_per_rad", "ra_ohm") or f in spec.bounds) else 0.0
          for f in spec.free]
    scales = list(spec.scales)
    node = tuple(n for n in node_params(spec.blind) if n.field in spec.node_free) if spec.thermal_state else ()
    sel = [getattr(r, mask) for r in rows]
    if spec.thermal_state:
        # each parameter the start's node holds, the assumed start (node_start) for those it does not: node_start
        # reads every fitted row's current, and most fits start from a model that has a node
        r0, tau0 = p0.th_r_K_per_W, p0.th_tau_s
        if not p0.thermal_enabled():
            r_start, tau_start = node_start(rows, sel, p0, spec.blind)
            r0 = r0 if r0 > 0 else r_start
            tau0 = tau0 if tau0 > 0 else tau_start
        start_at = {"th_r_K_per_W": r0, "th_tau_s": tau0}
        x0 += [math.log(start_at[n.field]) for n in node]
        scales += [1.0] * len(node)
    if sum(int(m.sum()) for m in sel) < len(x0) + 5:
        raise IdentificationError(f"too few labelled rows above {MIN_RPM} RPM to fit {', '.join(spec.free)}")
    if weights is not None:
        # a row of weight 0 (an operating point a bootstrap resample leaves out) adds nothing to the sum of
        # squares: left out of the arrays the model is evaluated on (the thermal trajectory still runs over
        # every row of its recording, temperature() below; the same fit, its sums in another order)
        sel = [m & (np.asarray(wi, float) != 0.0) for m, wi in zip(sel, weights)]
    refs = [r.ref[m] for r, m in zip(rows, sel)]
    w = ([np.ones(int(m.sum())) for m in sel] if weights is None
         else [np.asarray(wi, float)[m] for wi, m in zip(weights, sel)])
    # a reference with a confidence per row (the ripple's: Recording.weight) weights its rows too
    w = [wi if r.rec.weight is None else wi * np.asarray(r.rec.weight, float)[m] for wi, r, m in zip(w, rows, sel)]
    sw = [np.sqrt(wi) for wi in w]
    fixed_temp = [None if (spec.thermal_state or r.needs_state) else r.temp for r in rows]

    # every recording's fitted rows in one set of arrays: one evaluation of the model per step of
    # the solver, not one per recording (the same values, row for row, in the same order)
    v_all = np.concatenate([r.v[m] for r, m in zip(rows, sel)])
    i_all = np.concatenate([r.i[m] for r, m in zip(rows, sel)])
    di_all = np.concatenate([r.di_dt[m] for r, m in zip(rows, sel)])
    ref_all, sw_all = np.concatenate(refs), np.concatenate(sw)
    t_fixed = _cat_temps([t[m] for t, m in zip(fixed_temp, sel)]) if all(t is not None for t in fixed_temp) else None

    last = {"temps": (), "tt": None}  # the temperatures of the last evaluation, and their fitted rows end to end
    # the node runs forward: a recording's temperatures are needed up to its last fitted row only
    upto = [int(np.flatnonzero(m)[-1]) + 1 if m.any() else 0 for m in sel]
    cut = [np.flatnonzero(m) for m in sel]  # (the fitted rows lie within the prefix the temperatures run over)

    def fitted_temps(temps):
        """The fitted rows' temperatures end to end, from each recording's (one set, or one row per
        column of parameters)."""
        return _cat_temps([_rows_at(t, k) for t, k in zip(temps, cut)])

    def residual(p, tt):
        """The weighted speed errors of the fitted rows at p (one row per column of p where it holds
        columns of parameters), and the prior on Ra where there is one."""
        n = ph.physics_rpm(p, v_all, i_all, di_all, tt)
        out = sw_all * np.where(np.isfinite(n), ref_all - n, 1e4)
        if ra_prior is None:
            return out
        prior = np.array([ra_prior[2] * (ra - ra_prior[0]) / ra_prior[1] for ra in np.ravel(p.ra_ohm).tolist()])
        if out.ndim == 1:
            return np.concatenate([out, prior])
        return np.concatenate([out, np.broadcast_to(prior[:, None], (len(out), 1))], axis=1)

    def resid(x):
        p = _params(base, spec, x)
        tt = t_fixed
        if tt is None:
            temps = [temperature(r, p, u) if t is None else t for r, t, u in zip(rows, fixed_temp, upto)]
            if len(temps) == len(last["temps"]) and all(a is b for a, b in zip(temps, last["temps"])):
                tt = last["tt"]  # a step that moves no thermal parameter (most Jacobian columns): the same
            else:
                tt = fitted_temps(temps)
                last.update(temps=temps, tt=tt)
        f = residual(p, tt)
        last.update(x=x.copy(), f=f, tt_x=tt)
        return f

    # which parameters the temperatures depend on (the node's two, log-parametrised, last)
    thermal = np.array([f in _THERMAL_FIELDS for f in spec.free] + [True] * len(node), dtype=bool)

    def columns(xs):
        """resid at each row of xs, one row each (the points of a finite-difference Jacobian: x with one
        parameter moved), evaluated together: those that move no thermal parameter at the temperatures
        at x, the others with their thermal trajectories side by side (physics.temperatures with
        columns of parameters); each row the same bits as resid of it."""
        moved = np.flatnonzero(np.any(xs != last["x"], axis=1))
        out = np.empty((len(xs), len(last["f"])))
        out[:] = last["f"]  # (a step that moves nothing: f(x))
        plain, hot = moved[~thermal[moved]], moved[thermal[moved]]
        if len(plain):
            out[plain] = residual(_params_cols(base, spec, xs[plain]), last["tt_x"])
        if len(hot):
            p = _params_cols(base, spec, xs[hot])
            tt = t_fixed if t_fixed is not None else fitted_temps(
                [temperature_cols(r, p, u) if t is None else t for r, t, u in zip(rows, fixed_temp, upto)])
            out[hot] = residual(p, tt)
        return out

    def jac(x):
        # the residual at x: that of the evaluation just made there (the solver asks for the Jacobian where it
        # has just evaluated the residual, as scipy's finite differences take it), else evaluated again
        if not (last.get("x") is not None and np.array_equal(last["x"], x)):
            resid(x)
        return fd_jacobian(columns, x, last["f"], lo_a, hi_a)

    lo = [-np.inf] * len(x0)
    hi = [np.inf] * len(x0)
    lo[0] = min(1e-6, 0.1 * x0[0]) if x0[0] > 0 else 1e-6  # Ke > 0, whatever its scale
    if ra_prior is not None or ra_bounds is not None:  # Ra within a factor 3 of the reading, or ra_bounds
        k = spec.free.index("ra_ohm")
        lo[k], hi[k] = ra_bounds if ra_bounds is not None else (ra_prior[0] / 3.0, ra_prior[0] * 3.0)
        x0[k] = min(max(x0[k], lo[k] * 1.001), hi[k] * 0.999)
    for k, f in enumerate(spec.free):  # a shape within the forms physics allows
        if f in spec.bounds:
            lo[k], hi[k] = spec.bounds[f]
            x0[k] = min(max(x0[k], lo[k] + 1e-9), hi[k] - 1e-9)
    if spec.thermal_state:  # the node within its physical range (schema.NODE)
        for k, n in zip(range(len(x0) - len(node), len(x0)), node):
            lo[k], hi[k] = math.log(n.physical[0]), math.log(n.physical[1])
            x0[k] = min(max(x0[k], lo[k] + 1e-9), hi[k] - 1e-9)
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    res = least_squares(resid, np.asarray(x0, float), x_scale=np.asarray(scales, float), bounds=(lo, hi),
                        jac=jac if JACOBIAN == "together" else JACOBIAN, method="trf", xtol=_solver_tol[-1],
                        ftol=_solver_tol[-1], gtol=_solver_tol[-1], max_nfev=200)
    p = _params(base, spec, res.x)
    bits = 0
    for n in spec.names:
        bits |= LIBRARY[n].bit
    return dataclasses.replace(p, effects=bits), float(res.cost)


# scipy's relative step of a 2-point finite difference in float64 (scipy.optimize._numdiff._eps_for_method)
FD_REL_STEP = np.finfo(np.float64).eps ** 0.5


def fd_steps(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The step of each parameter in a 2-point finite-difference Jacobian, as scipy's least_squares takes
    it (scipy.optimize._numdiff: _compute_absolute_step with no relative step given, then
    _adjust_scheme_to_bounds for a one-sided scheme): sqrt(eps) max(1, |x|) towards +x (at x = 0 too),
    turned back where it would leave the bounds and the other side has room, else the whole way to the
    farther bound. The same operations in the same order, so the same bits (test_fit_jacobian.py)."""
    sign = (x >= 0).astype(float) * 2 - 1
    h = FD_REL_STEP * sign * np.maximum(1.0, np.abs(x))
    if np.all((lo == -np.inf) & (hi == np.inf)):
        return h
    lower, upper = x - lo, hi - x
    beyond = ((x + h) < lo) | ((x + h) > hi)
    fitting = np.abs(h) <= np.maximum(lower, upper)
    h = np.where(beyond & fitting, -h, h)
    h = np.where(~fitting & (upper >= lower), upper, h)
    return np.where(~fitting & (upper < lower), -lower, h)


def fd_jacobian(columns, x: np.ndarray, f0: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The Jacobian of f at x as scipy's least_squares computes it with jac='2-point', bit for bit:
    column j is (f(x + h_j e_j) - f0) / ((x_j + h_j) - x_j), h from fd_steps, f0 = f(x), laid out as
    scipy lays it (the transpose of a row-major table, so that the solver's products take the same
    path). columns(xs): f at each row of xs, one row each (the caller evaluates them together)."""
    h = fd_steps(x, lo, hi)
    xs = np.repeat(x[None, :], x.size, axis=0)
    idx = np.arange(x.size)
    xs[idx, idx] = x + h
    dx = (x + h) - x
    return ((columns(xs) - f0) / dx[:, None]).T


def _rows_at(t, idx):
    """The temperatures t (a Temps or an array; one row per column of parameters or one for all) at the
    rows idx (indices) of the recording."""
    if isinstance(t, ph.Temps):
        return ph.Temps(np.take(t.winding_C, idx, axis=-1), np.take(t.magnet_C, idx, axis=-1))
    return np.take(t, idx, axis=-1)


def _cat_rows(parts):
    """Arrays of several recordings' rows end to end (along the last axis; one for all columns of
    parameters given to each)."""
    if all(a.ndim == 1 for a in parts):
        return np.concatenate(parts)
    lead = np.broadcast_shapes(*(a.shape[:-1] for a in parts))
    return np.concatenate([np.broadcast_to(a, lead + np.shape(a)[-1:]) for a in parts], axis=-1)


def _cat_temps(parts):
    """The temperatures of several recordings' rows end to end: a Temps where any part is one
    (the winding and the magnets apart), else one array."""
    if not any(isinstance(t, ph.Temps) for t in parts):
        return _cat_rows(parts)
    both = [t if isinstance(t, ph.Temps) else ph.Temps(t, t) for t in parts]
    return ph.Temps(_cat_rows([np.asarray(t.winding_C, float) for t in both]),
                    _cat_rows([np.asarray(t.magnet_C, float) for t in both]))


FIT_DIGITS = 7  # significant digits kept of a fitted coefficient


def settle_digits(p: ph.PhysicsParams) -> ph.PhysicsParams:
    """p with every float parameter rounded to FIT_DIGITS significant digits. The fit's
    linear algebra (LAPACK, BLAS) takes a path that differs between CPUs and kernels: the
    coefficients the data determine well end about 1e-9 apart and round alike; a poorly
    determined one (a fitted winding time constant: 1.5e-6 apart between the default and
    the Prescott kernel on the bundled data) can still differ in its last digit. A fit in a
    defined order of arithmetic throughout (as network.py trains) would remove that."""
    kw = {f.name: float(f"{getattr(p, f.name):.{FIT_DIGITS}g}") for f in dataclasses.fields(p)
          if isinstance(getattr(p, f.name), float)}
    return dataclasses.replace(p, **kw)


def identify(recs: list[Recording], m2_plain: ph.PhysicsParams, names, hold=None) -> ph.PhysicsParams:
    """M2 with effects: Ke and the named coefficients fitted on the training rows
    (rpm_ref > 10), Ra held at its measured value, those in hold ({effect: coefficient},
    each among names) held at theirs; sets the effect bits."""
    names = check_names(names)
    stray = [n for n in (hold or {}) if n not in names]
    if stray:
        raise IdentificationError(f"--hold {', '.join(stray)}: not among the effects of the model "
                                  f"({', '.join(names) or 'none'}); add it to --effects")
    rows = [rows_of(r) for r in recs]
    p = settle_digits(fit(rows, m2_plain, names, hold=hold))
    if not p.ke_vs_per_rad > 0:
        raise IdentificationError(f"identified Ke = {p.ke_vs_per_rad:.4g} V s/rad is not positive")
    return p


def coefficients(p: ph.PhysicsParams) -> dict:
    """{effect: coefficient} of the effects switched on in p."""
    return {n: getattr(p, LIBRARY[n].field) for n in NAMES if p.effects & LIBRARY[n].bit}
