"""The physics models M1 and M2 in numpy, term for term as lib/hpddo_core/src/hpddo/physics.h.

    v_true = ra(T) i_true + brush(i_true) + la di/dt + ke(T, i_true) w

Vectorised over samples; `dtype` selects float32 (to mirror the boards exactly) or
float64 (for identification). PhysicsParams and EFFECT_BITS come from schema.py, the one
declaration of every parameter and effect (the C++ struct is generated from it).
"""
from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from .libm import exp
# The parameters and effects are declared once, in schema.py: PhysicsParams (fields and
# units as the C++ PhysicsParams, generated from the same declaration) and EFFECT_BITS
# (effect name -> (C++ bit, the PhysicsParams field that carries its coefficient)).
from ..schema import EFFECT_BITS, PhysicsParams  # noqa: F401

RPM_PER_RAD_S = 60.0 / (2.0 * np.pi)
BRUSH_KNEE_MIN_A = 0.001   # the smallest brush knee the term takes (hpddo::kBrushKneeMin_A)

# Physical bounds (docs/core.md, "Bounds"), the same numbers as hpddo/limits.h.
WINDING_MAX_C = 250.0      # hottest winding: the 250 C thermal class, the highest of IEC 60085
PERIOD_MIN_S = 1e-5        # shorter periods are no sample-to-sample step (no di/dt; new segment)
PERIOD_MAX_S = 10.0        # longer periods start a new segment too
SPEED_LIMIT_FACTOR = 4.0   # speed range = factor * (v_max + i_max Ra) / Ke

def nameplate_ke_vs_per_rad(rated_V: float, rated_rpm: float) -> float:
    """M1's Ke: rated voltage over rated (no-load) speed, armature drop neglected."""
    return rated_V / (rated_rpm / RPM_PER_RAD_S)


def nameplate_params(ra_ohm: float, rated_V: float = 12.0, rated_rpm: float = 1000.0) -> PhysicsParams:
    return PhysicsParams(ra_ohm=ra_ohm, ke_vs_per_rad=nameplate_ke_vs_per_rad(rated_V, rated_rpm))


def _f(p: PhysicsParams, name: str, dtype):
    return dtype(getattr(p, name))


def _drift(p, field: str, case_C, dtype):
    """An offset's drift with the case temperature (current_offset_drift): coefficient x
    (T_case - t_ref); 0 without a case temperature."""
    if case_C is None:
        return dtype(0.0)
    return _f(p, field, dtype) * (np.asarray(case_C, dtype) - _f(p, "t_ref_C", dtype))


def true_current_A(p, i_A, dtype=np.float64, case_C=None):
    """The current with the channel's offset removed: i_offset_A, and with case_C (the case
    temperature, C) its drift i_offset_tc_A_per_K (T_case - t_ref) as well (physics.h)."""
    i = np.asarray(i_A, dtype) - _f(p, "i_offset_A", dtype)
    return i if case_C is None else i - _drift(p, "i_offset_tc_A_per_K", case_C, dtype)


def _board(dtype) -> bool:
    """float32 is the boards' arithmetic: the divisions by a parameter become multiplies by
    its reciprocal, computed once per model (physics.h, PhysicsConst); float64 is the
    algebra (identification, training) and divides. The two differ by a rounding."""
    return np.dtype(dtype) == np.float32


def true_voltage_V(p, v_V, dtype=np.float64):
    v = np.asarray(v_V, dtype) - _f(p, "v_offset_V", dtype)
    if _board(dtype):  # physics_const(): v_gain_inv = 1 / (1 + v_gain), none without a gain error
        g = _f(p, "v_gain", dtype)
        return v if g == 0 else v * dtype(dtype(1.0) / (dtype(1.0) + g))
    return v / (dtype(1.0) + _f(p, "v_gain", dtype))


def ra_at_ohm(p, temp_C, dtype=np.float64):
    t = np.asarray(temp_C, dtype)
    return _f(p, "ra_ohm", dtype) * (dtype(1.0) + _f(p, "ra_tc_per_K", dtype) * (t - _f(p, "t_ref_C", dtype)))


def brush_drop_V(p, i_true_A, dtype=np.float64):
    """brush_V f_m(i), m = brush_order: f_1 = i / (|i| + knee) the base form (m = 1, an order
    below 1 or NaN, as the boards; computed as before the order existed), f_2 = i / sqrt(i^2 +
    knee^2), and between them the straight blend f_1 + (m - 1) (f_2 - f_1): one square root,
    no pow on the boards (physics.h). With columns of parameters (k x 1), the same choices
    column by column."""
    i = np.asarray(i_true_A, dtype)
    knee = _f(p, "brush_knee_A", dtype)
    if isinstance(knee, np.ndarray):
        knee = np.where(knee > dtype(BRUSH_KNEE_MIN_A), knee, dtype(BRUSH_KNEE_MIN_A))
    else:
        knee = knee if knee > dtype(BRUSH_KNEE_MIN_A) else dtype(BRUSH_KNEE_MIN_A)  # NaN: the minimum, as the boards
    m = _f(p, "brush_order", dtype)

    def base_form():
        return _f(p, "brush_V", dtype) * i / (np.abs(i) + knee)

    blended = m > dtype(1.0)  # (one per column where m is a column)
    columns = isinstance(blended, np.ndarray)
    if not (blended.any() if columns else blended):
        return base_form()
    f1 = i / (np.abs(i) + knee)
    f2 = i / np.sqrt(i * i + knee * knee)
    blend = _f(p, "brush_V", dtype) * (f1 + (m - dtype(1.0)) * (f2 - f1))
    return np.where(blended, blend, base_form()) if columns and not blended.all() else blend


def ke_at_vs_per_rad(p, temp_C, i_true_A, dtype=np.float64):
    t = np.asarray(temp_C, dtype)
    i = np.asarray(i_true_A, dtype)
    return (_f(p, "ke_vs_per_rad", dtype) * (dtype(1.0) + _f(p, "ke_tc_per_K", dtype) * (t - _f(p, "t_ref_C", dtype)))
            * (dtype(1.0) - _f(p, "ke_sat_per_A", dtype) * saturation_shape(p, np.abs(i), dtype)))


def saturation_shape(p, i_mag_A, dtype=np.float64):
    """|i| (1 - q + q |i| / 1 A), q = ke_sat_quad: the armature reaction's growth with the
    current, linear (q = 0) to quadratic (q = 1), in A."""
    q = _f(p, "ke_sat_quad", dtype)
    return i_mag_A * ((dtype(1.0) - q) + q * i_mag_A)


@dataclasses.dataclass
class Temps:
    """The two temperatures of the physics model (C.f. hpddo::PhysicsInput): the copper
    follows the winding, the magnets the case."""

    winding_C: np.ndarray
    magnet_C: np.ndarray

    def __getitem__(self, rows):
        return Temps(np.asarray(self.winding_C)[rows], np.asarray(self.magnet_C)[rows])


def _split(temp_C):
    """(winding, magnet) temperatures from a Temps or one temperature for both."""
    return (temp_C.winding_C, temp_C.magnet_C) if isinstance(temp_C, Temps) else (temp_C, temp_C)


def back_emf_V(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype=np.float64):
    """The back-EMF of the voltage balance, V. The current channel's offset drifts with the
    case temperature: the magnets' temperature (the case reading where read, as the boards'
    PhysicsInput::magnet_C)."""
    winding_C, case_C = _split(temp_C)
    return _emf(p, v_V, true_current_A(p, i_A, dtype, case_C), di_dt_A_per_s, winding_C, dtype)


def _emf(p, v_V, i_true_A, di_dt_A_per_s, winding_C, dtype):
    """back_emf_V of the true current (true_current_A), taken once by physics_rpm for both terms."""
    i = i_true_A
    return (true_voltage_V(p, v_V, dtype) - ra_at_ohm(p, winding_C, dtype) * i - brush_drop_V(p, i, dtype)
            - _f(p, "la_H", dtype) * np.asarray(di_dt_A_per_s, dtype))


def physics_rpm(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype=np.float64):
    """Output-shaft RPM; NaN where the effective Ke is not positive. temp_C: a Temps
    (winding for Ra, magnets for Ke) or one temperature for both."""
    if _board(dtype) and p.ke_tc_per_K == 0 and p.ke_sat_per_A == 0:
        # A constant Ke: the back-EMF times rpm_per_V = RPM_PER_RAD_S / Ke (physics_const()).
        emf = back_emf_V(p, v_V, i_A, di_dt_A_per_s, temp_C, dtype)
        ke0 = _f(p, "ke_vs_per_rad", dtype)
        if not ke0 > 0:
            return np.full(np.shape(emf), np.nan, dtype)
        return (emf * dtype(dtype(RPM_PER_RAD_S) / ke0)).astype(dtype)
    winding_C, case_C = _split(temp_C)
    i = true_current_A(p, i_A, dtype, case_C)  # (the same for both terms: taken once)
    ke = ke_at_vs_per_rad(p, case_C, i, dtype)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = _emf(p, v_V, i, di_dt_A_per_s, winding_C, dtype) / ke * dtype(RPM_PER_RAD_S)
    return np.where(ke > 0, n, np.nan).astype(dtype, copy=False)


_BLOCK = 1024  # samples per block of the vectorised recursion


def trajectory_prefix(n_needed: int, n: int) -> int:
    """How many of a recording's n samples thermal_trajectory (float64) must run over for its first
    n_needed values to be the same bits as over all n: up to the end of the block (_BLOCK) that
    holds the last of them (a block is computed, checked against the bounds and redone step by step
    as a whole, and every block from the one before it alone), at least one block."""
    return min(n, max(1, -(-n_needed // _BLOCK)) * _BLOCK)


def _rise_bounded(rise, ref):
    """A rise held within [0, WINDING_MAX_C - ref]: the node only heats, and no winding
    is hotter than its insulation class allows (NaN gives 0)."""
    rise = min(rise, WINDING_MAX_C - ref)
    return rise if rise >= 0.0 else 0.0


_decays: dict = {}


def _decay(dt, tau):
    """(dt > 0, the node's decay exp(-dt / tau) per step, 1 where no step, 1 - that decay, whether
    every sample is a step) of _rise_float64. A fit moves tau in one Jacobian column of several, so
    the last few are kept per array of periods (by identity, held beside them) and given again, the
    same values. tau a column of time constants (k x 1): the decays one row per tau (k x n), or one
    row for all where they are one value."""
    if isinstance(tau, np.ndarray):
        taus = np.ravel(tau).tolist()
        if len(set(taus)) == 1:
            return _decay(dt, taus[0])
        rows = [_decay(dt, t) for t in taus]
        return rows[0][0], np.stack([d for _, d, _, _ in rows]), np.stack([omd for _, _, omd, _ in rows]), rows[0][3]
    key = (id(dt), float(tau))
    hit = _decays.get(key)
    if hit is not None and hit[0] is dt:
        return hit[1:]
    step, periods, where = _periods(dt)
    # exp of each distinct period's -dt / tau, given to every sample of that period: exp(-dt_k / tau)
    # of each sample, the same bits (libm.exp)
    d = np.where(step, exp(-periods / tau)[where], 1.0)
    if len(_decays) > 32:
        _decays.clear()
    _decays[key] = (dt, step, d, 1.0 - d, bool(step.all()))
    return _decays[key][1:]


_periods_of: dict = {}


def _periods(dt):
    """(dt > 0, the distinct periods of np.where(dt > 0, dt, 0), each sample's index among them),
    once per array of periods (by identity, held beside it): a fit asks for a new tau at every
    step, over the same periods."""
    hit = _periods_of.get(id(dt))
    if hit is not None and hit[0] is dt:
        return hit[1:]
    step = dt > 0
    periods, where = np.unique(np.where(step, dt, 0.0), return_inverse=True)
    if len(_periods_of) > 32:
        _periods_of.clear()
    _periods_of[id(dt)] = (dt, step, periods, where.reshape(np.shape(dt)))
    return step, periods, where.reshape(np.shape(dt))


def _rise_float64(p, i, dt, ref, rise0: float) -> np.ndarray:
    """The rise of thermal_trajectory in float64, vectorised. Each step is linear in the
    previous rise, rise_k = alpha_k rise_(k-1) + beta_k, with (exp step d, loss at Ra(T_w))
        alpha_k = d_k + (1 - d_k) r i_k^2 Ra a,   beta_k = (1 - d_k) r i_k^2 Ra (1 + a (ref_k - T_ref)),
    so blocks of it are cumulative products and sums (equal to the step-by-step loop to
    rounding). A block whose rise leaves [0, WINDING_MAX_C - ref] is redone step by step
    with the bound applied after each step.

    Several parameter sets at once (the columns of a fit's finite-difference Jacobian,
    effects._solve): each of r, tau, Ra, a, T_ref a column of values (k x 1) or one value,
    i and ref one row per set (k x n) or one for all; then the rise is a (k x n) table, each
    row the same bits as the rise of that row's parameters alone (every step elementwise,
    the products and sums along the rows as along one), in one pass of numpy calls instead
    of one per set."""
    r, tau, ra, a, tref = p.th_r_K_per_W, p.th_tau_s, p.ra_ohm, p.ra_tc_per_K, p.t_ref_C
    step, d, omd, every = _decay(dt, tau)
    omdq = omd * (r * i * i * ra)  # (1 - d) q, q = r i^2 Ra
    shape = np.broadcast_shapes(omdq.shape, np.shape(a), ref.shape, np.shape(tref)) if (
        omdq.ndim > 1 or np.ndim(a) or ref.ndim > 1 or np.ndim(tref)) else omdq.shape
    k, n = (1, *shape) if len(shape) == 1 else shape
    # Every block's steps, a row of a (blocks x _BLOCK) table per set of parameters, the last block
    # padded with steps that change nothing (alpha 1, beta 0), and the bound WINDING_MAX_C - ref (none
    # on the padding); computed into the table (no step: alpha 1, beta 0)
    nb = max(1, -(-n // _BLOCK))
    al, be, lim = np.empty((k, nb * _BLOCK)), np.empty((k, nb * _BLOCK)), np.empty((k, nb * _BLOCK))
    al[:, n:], be[:, n:], lim[:, n:] = 1.0, 0.0, np.inf
    alpha, beta = al[:, :n], be[:, :n]
    if every:  # (every sample a step, as on a log whose periods are all positive)
        np.add(d, omdq * a, out=alpha)
        np.multiply(omdq, 1.0 + a * (ref - tref), out=beta)
    else:
        alpha[:] = np.where(step, d + omdq * a, 1.0)
        beta[:] = np.where(step, omdq * (1.0 + a * (ref - tref)), 0.0)
    if len(shape) == 1 and n <= _BLOCK:  # one set in one block: _rise_blocks does it with fewer steps
        return _rise_blocks(alpha[0], beta[0], step, ref, rise0, np.empty(n), 0)
    np.subtract(WINDING_MAX_C, ref, out=lim[:, :n])
    out = _rise_rows(al, be, lim, step, np.broadcast_to(ref, (k, n)), n, rise0)
    return out[0] if len(shape) == 1 else out


def _rise_rows(al, be, lim, step, ref, n: int, rise0: float) -> np.ndarray:
    """_rise_float64's rise (k x n) from its steps alpha, beta and bounds WINDING_MAX_C - ref, each
    row a set of parameters padded to whole blocks (k x blocks _BLOCK)."""
    k, width = al.shape
    nb = width // _BLOCK
    if n == 0:
        return np.empty((k, 0))
    # cumprod and cumsum run along a row of the table as along the block alone, so each value is
    # the same bits as block by block
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        prod = np.cumprod(al.reshape(k, nb, _BLOCK), axis=2)
        table = np.divide(be.reshape(k, nb, _BLOCK), prod)
        np.cumsum(table, axis=2, out=table)
    # (past the last block's last step the padding holds its product and sum: column -1 is every block's end)
    usable = (prod.min(axis=2) > 1e-250) & np.isfinite(prod[:, :, -1])
    # the rise entering each block: the one leaving the block before, as the block computes it
    starts = np.empty((k, nb))
    for c, (pc, sc) in enumerate(zip(prod[:, :, -1].tolist(), table[:, :, -1].tolist())):
        x = rise0
        for b, (pb, sb) in enumerate(zip(pc, sc)):
            starts[c, b] = x
            x = pb * (x + sb)
    with np.errstate(over="ignore", invalid="ignore"):  # the rise: prod (start + sums)
        np.add(starts[:, :, None], table, out=table)
        np.multiply(prod, table, out=table)
    # (the least of a block NaN where any is: then below 0 too, as (table >= 0).all() says)
    inside = (table.min(axis=2) >= 0.0) & np.all(table <= lim.reshape(k, nb, _BLOCK), axis=2) & usable
    out = table.reshape(k, width)
    for c in np.flatnonzero(~inside.all(axis=1)).tolist():
        # from the first block out of range or bounds on, block by block
        first_bad = int(np.argmin(inside[c]))
        x = rise0 if first_bad == 0 else float(out[c, first_bad * _BLOCK - 1])
        _rise_blocks(al[c, :n], be[c, :n], step, ref[c], x, out[c, :n], first_bad * _BLOCK)
    return out[:, :n]


def _rise_blocks(alpha, beta, step, ref, x: float, out, s_from: int):
    """_rise_float64 block by block from sample s_from (a block's start), the rise x entering it."""
    for s0 in range(s_from, len(alpha), _BLOCK):  # from the first block out of range or bounds, block by block
        al, be = alpha[s0:s0 + _BLOCK], beta[s0:s0 + _BLOCK]
        rf = ref[s0:s0 + _BLOCK]
        with np.errstate(over="ignore"):  # an overflow is caught below (isfinite) and redone step by step
            prod = np.cumprod(al)
        blk = None
        if prod.min() > 1e-250 and np.isfinite(prod[-1]):
            with np.errstate(over="ignore", invalid="ignore"):
                blk = prod * (x + np.cumsum(be / prod))
            if not np.all((blk >= 0.0) & (blk <= WINDING_MAX_C - rf)):
                blk = None
        if blk is None:  # out of float64's range or out of bounds: step by step
            blk = np.empty(len(al))
            for k, (ak, bk, sk) in enumerate(zip(al.tolist(), be.tolist(), step[s0:s0 + _BLOCK].tolist())):
                if sk:
                    x = _rise_bounded(ak * x + bk, float(rf[k]))
                blk[k] = x
        out[s0:s0 + _BLOCK] = blk
        x = float(blk[-1])
    return out


_LAG_BLOCK = 64  # samples per block of lagged_case's recursion: exp(-dt / tau) of 64 steps stays a float64 for
# dt / tau below 9 (past it the block goes step by step)


def lagged_case(ref_C, dt, tau) -> np.ndarray:
    """The case reading as a winding that sheds its heat to the case follows it: tau dL/dt = ref - L, L
    starting at the first reading, each step exact for the reading held at its new value over the step
    (L_k = ref_k + d_k (L_(k-1) - ref_k), d_k = exp(-dt_k / tau); held where no step). The node's other form
    (docs/diagnosis.md: the node's form): the winding at L plus the rise, where the boards take
    the case's rise into the winding at once. Host only, a rival model the diagnosis weighs
    (core.node_form_rival), not the boards' model. tau a column (k x 1): one row per tau (k x n).
    Linear in the lag e = L - ref, e_k = d_k (e_(k-1) + ref_(k-1) - ref_k): blocks of cumulative
    products and sums, as _rise_float64's."""
    ref = np.asarray(ref_C, float)
    n = ref.shape[-1]
    if n == 0:
        return ref.copy()
    _, d, _, _ = _decay(dt, tau)
    d = np.atleast_2d(d)
    move = np.zeros(ref.shape)
    move[..., 1:] = ref[..., :-1] - ref[..., 1:]
    beta = np.broadcast_to(d * move, np.broadcast_shapes(d.shape, np.atleast_2d(move).shape))
    k = beta.shape[0]
    nb = -(-n // _LAG_BLOCK)
    al, be = np.ones((k, nb * _LAG_BLOCK)), np.zeros((k, nb * _LAG_BLOCK))
    al[:, :n], be[:, :n] = np.broadcast_to(d, (k, n)), beta
    al3, be3 = al.reshape(k, nb, _LAG_BLOCK), be.reshape(k, nb, _LAG_BLOCK)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        prod = np.cumprod(al3, axis=2)
        sums = np.cumsum(be3 / prod, axis=2)
    usable = prod.min(axis=2) > 1e-250
    # the lag entering each block, block by block from the lag leaving the one before (0 before the first)
    starts = np.zeros((k, nb))
    for c, (pc, sc) in enumerate(zip(prod[:, :, -1].tolist(), sums[:, :, -1].tolist())):
        x = 0.0
        for b, (pb, sb) in enumerate(zip(pc, sc)):
            starts[c, b] = x
            x = pb * (x + sb) if usable[c, b] else math.nan
    with np.errstate(invalid="ignore"):
        e = prod * (starts[:, :, None] + sums)
    for c in np.flatnonzero(~usable.all(axis=1)).tolist():  # decays that underflow over a block: step by step
        x = 0.0
        for b in range(nb):
            if usable[c, b] and math.isfinite(starts[c, b]):  # (up to the first that underflows: as above)
                x = float(e[c, b, -1])
                continue
            if usable[c, b]:
                e[c, b] = prod[c, b] * (x + sums[c, b])
            else:
                for j in range(_LAG_BLOCK):
                    x = al3[c, b, j] * x + be3[c, b, j]
                    e[c, b, j] = x
            x = float(e[c, b, -1])
    lag = e.reshape(k, nb * _LAG_BLOCK)[:, :n]
    return ref + (lag if np.ndim(tau) or ref.ndim > 1 else lag[0])


def _columns(p) -> int:
    """How many sets of parameters p holds: 1 where every field is one value, k where some are
    columns of values (k x 1, the columns of a fit's finite-difference Jacobian: effects._solve)."""
    return max((np.shape(v)[0] for v in vars(p).values() if np.ndim(v)), default=1)


def column(p, c: int):
    """The parameters of column c of p (each field that is a column of values: its c-th value)."""
    q = copy.copy(p)
    q.__dict__.update((f, float(np.reshape(v, -1)[c])) for f, v in vars(p).items() if np.ndim(v))
    return q


def _node_runs(p):
    """Whether the thermal node runs (PhysicsParams.thermal_enabled: r > 0 and tau > 0): for
    columns of parameters, whether it runs in all of them (True) or none (False); None where
    they disagree."""
    if not (isinstance(p.th_r_K_per_W, np.ndarray) or isinstance(p.th_tau_s, np.ndarray)):
        return p.thermal_enabled()
    on = (np.asarray(p.th_r_K_per_W) > 0.0) & (np.asarray(p.th_tau_s) > 0.0)
    return bool(on.all()) if on.all() or not on.any() else None


def thermal_trajectory(p, i_true_A, dt_s, dtype=np.float64, ref_C=None, start_rise_K=0.0, final_rise=False):
    """Winding temperature per sample, as hpddo::ThermalEstimator::step before each sample:
    ref + rise, the rise a first-order node heated by i^2 Ra(T_w) above the reference
    ref_C (per sample: the case reading where read, else t_amb; None: t_amb throughout),
    held within [0, WINDING_MAX_C - ref] after each step.
    With final_rise, also returns the rise after the last sample."""
    i = np.asarray(i_true_A, dtype)
    # the periods themselves where they are of dtype already: their decays are kept per array (_decay, by
    # identity), and np.asarray gives a new view of an array whose dtype is equal but another object (one
    # that came through pickle: a worker's copy of the rows), so a worker's fits found none of them kept
    dt = dt_s if isinstance(dt_s, np.ndarray) and dt_s.dtype == dtype else np.asarray(dt_s, dtype)
    n = i.shape[-1]
    ref = (np.full(np.broadcast_shapes(np.shape(p.t_amb_C), (n,)), p.t_amb_C, dtype) if ref_C is None
           else np.asarray(ref_C, dtype))
    rise = dtype(start_rise_K)
    runs = _node_runs(p)
    if runs is None:
        raise ValueError("thermal_trajectory: the columns of parameters disagree on whether the node runs")
    if not runs:
        out = ref + rise
        return (out, rise) if final_rise else out
    if np.dtype(dtype) == np.float64:
        out = ref + _rise_float64(p, i, dt, ref, float(rise))
        return (out, float(out[-1] - ref[-1]) if n else float(rise)) if final_rise else out
    out = np.empty(n, dtype)
    r = dtype(p.th_r_K_per_W)
    tau = dtype(p.th_tau_s)
    hottest = dtype(WINDING_MAX_C)
    for k in range(n):
        if dt[k] > 0:
            loss = i[k] * i[k] * ra_at_ohm(p, ref[k] + rise, dtype)
            target = dtype(r * loss)
            rise = dtype(target + (rise - target) * dtype(exp(-dt[k] / tau)))
            rise = min(rise, dtype(hottest - ref[k]))
            rise = rise if rise >= 0 else dtype(0)
        out[k] = ref[k] + rise
    return (out, rise) if final_rise else out


def speed_limit_rpm(p, v_max_V, i_max_A, dtype=np.float64):
    """Edge of the model's physical speed range, RPM: SPEED_LIMIT_FACTOR times the speed
    at which the back-EMF balances the largest channel voltage plus the largest resistive
    drop, (v_max + i_max Ra) / Ke; 0 when Ke is not positive. Beyond it n_M2 is no speed."""
    ke = dtype(p.ke_vs_per_rad)
    if not ke > 0:
        return dtype(0)
    emf = dtype(dtype(v_max_V) + dtype(dtype(i_max_A) * dtype(p.ra_ohm)))
    return dtype(dtype(dtype(dtype(SPEED_LIMIT_FACTOR) * emf) / ke) * dtype(RPM_PER_RAD_S))


def settled_rise(p, i_true_A, ref_C) -> np.ndarray:
    """The winding's rise above ref_C (C) once the node has settled at each current: the fixed
    point of thermal_trajectory's step, rise = r i^2 Ra(ref + rise), that is
    rise = r i^2 Ra (1 + a (ref - t_ref)) / (1 - r i^2 Ra a); held within [0, WINDING_MAX_C - ref]
    as the trajectory is (no fixed point, 1 - r i^2 Ra a <= 0: the hottest; NaN gives 0). A row
    of a steady-state table is such a point: the motor ran there until it settled."""
    i = np.asarray(i_true_A, float)
    ref = np.asarray(ref_C, float)
    q = p.th_r_K_per_W * i * i * p.ra_ohm
    gain = 1.0 - q * p.ra_tc_per_K
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rise = np.where(gain > 0.0, q * (1.0 + p.ra_tc_per_K * (ref - p.t_ref_C)) / gain,
                        np.where(gain <= 0.0, np.inf, np.nan))
    rise = np.minimum(rise, WINDING_MAX_C - ref)
    return np.where(rise >= 0.0, rise, 0.0)


def temperatures(p, i_A, dt_s, temp_read_C, settled: bool = False, lag: bool = False) -> Temps:
    """What the observer feeds the thermal effects, per sample (observer.h): temp_read_C
    is the case reading, NaN where none (or out of the sensor's range). With a thermal
    network, the winding is the estimate above the reading (above t_amb where none); the
    magnets follow the reading, else the winding estimate. Without a network, both are
    the reading, else t_ref. settled: the rows are settled operating points (a steady-state
    table, no clock): the winding is at each row's settled rise (settled_rise), where the
    observer would arrive holding that point. lag: the node's other form, the winding's
    reference the reading through the node's lag (lagged_case), a rival the diagnosis weighs;
    the boards' form without it."""
    t = np.asarray(temp_read_C, float)
    read = np.isfinite(t)
    runs = _node_runs(p)
    if runs is None:  # columns of parameters (k x 1) that disagree: each column on its own, the same bits
        cols = [temperatures(column(p, c), i_A, dt_s, temp_read_C, settled, lag) for c in range(_columns(p))]
        return Temps(np.stack([c.winding_C for c in cols]), np.stack([c.magnet_C for c in cols]))
    if runs:
        ref = np.where(read, t, p.t_amb_C)
        if settled:
            winding = ref + settled_rise(p, true_current_A(p, i_A), ref)
        else:
            if lag:
                ref = lagged_case(ref, dt_s, p.th_tau_s)
            winding = thermal_trajectory(p, true_current_A(p, i_A), dt_s, ref_C=ref)
        return Temps(winding, np.where(read, t, winding))
    both = np.where(read, t, p.t_ref_C)
    return Temps(both, both)
