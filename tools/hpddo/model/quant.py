"""Fixed-point form of the residual network (lib/hpddo_core/src/hpddo/mlp_q.h is the board's half).

The float network z = (x - mean) / scale, h1 = relu(W0 z + b0), h2 = relu(W1 h1 + b1),
y = W2 h2 + b2 becomes integer arithmetic with one float multiply at the end:

    xq_j  = sat16(round(x_j 2^e_j))                 e_j: the largest with max|envelope_j| 2^e_j <= 32767
    acc_o = B_o + sum_j W_oj h_j                    int32, exactly (no overflow: see below)
    h_o   = min((max(acc_o, 0) + 2^(R-1)) >> R, 32767)   hidden layers, shift R per layer
    y     = float32(acc_out) * out_scale            RPM

round() is half away from zero; sat16 clips to [-32767, 32767]; a NaN input counts as 0.
The scaler is folded into the first layer (W0 / scale, b0 - W0 mean / scale), together
with the input exponents 2^-e_j. Each row o of a layer carries its own scale s_o (the
largest |weight| of the row maps to the type's largest value); the next layer absorbs
it (its column o is multiplied by s_o 2^R), so no rescaling multiply runs on the board.
Layer 0 and the output layer keep int16 weights (5 and H2 weights a row: the mean the
scaler removes is large against the spread, and int8 there costs accuracy); the hidden
layer's weights are int8 or int16 (`hidden_type`).

No overflow, for any input: every accumulator's bound |B_o| + sum_j |W_oj| max|h_j| is
computed exactly in Python integers from the largest input each column can carry
(32767 for the inputs, the previous layer's bound after its shift), and a row whose bound
would pass 2^31 - 1 - 2^(R-1) has its scale raised until it does not. The shifts are the
smallest that keep every hidden value within int16.

Everything here is integer arithmetic or float64 arithmetic on float32 weights in a
fixed order (math.fsum), without BLAS: the same bytes on every CPU. The forward pass is
written from the equations above, not from mlp_q.h, so its golden vectors check the C++.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

INT16_MAX = 32767
INT8_MAX = 127
INT32_MAX = 2 ** 31 - 1
TYPES = {"int8": INT8_MAX, "int16": INT16_MAX}
C_TYPES = {"int8": "int8_t", "int16": "int16_t"}
# The hidden layer's weights: int16. int8 there costs 0.108 RPM RMS against the float
# model on the test rows of data/default (int16: 0.021), over the 0.05 RPM budget
# (docs/performance.md, `hpddo bench --accuracy`).
DEFAULT_HIDDEN_TYPE = "int16"
# The int8 model (model_<name>_q8.h, issue 24): layer 0 and the hidden layer int8, the output
# layer int16 (8 weights, about 150 AVR cycles in int16; int8 there gains little), the shifts
# from the envelope and the weights rounded for the training rows (quantise's calibration).
INT8_TYPES = ("int8", "int8")  # (layer 0, hidden layers)


def round_half_away(y: float) -> int:
    """Nearest integer of a float64, halves away from zero (exact for |y| < 2^52)."""
    a = math.floor(abs(y) + 0.5)
    return int(-a if y < 0 else a)


@dataclasses.dataclass
class QuantNet:
    """Integer network: per-feature input exponents, integer layers, shifts, output scale."""

    in_exp: list          # e_j, int
    weights: list         # per layer: list of rows (lists of int), W[out][in]
    biases: list          # per layer: list of int
    types: list           # per layer: "int16" / "int8"
    shifts: list          # per hidden layer: R
    out_scale: np.float32 # RPM per unit of the output accumulator
    bounds: list          # per layer: largest |acc| over the rows (exact), for the docs and tests
    gate: "GateQ | None" = None  # the novelty gate in integers (gate_q.h), over the same inputs

    @property
    def hidden(self) -> tuple:
        return tuple(len(w) for w in self.weights[:-1])

    @property
    def hidden_type(self) -> str:
        return self.types[1] if len(self.types) > 2 else "int16"

    @property
    def first_type(self) -> str:
        return self.types[0]


def input_exponent(lo: float, hi: float) -> int:
    """Largest e with max(|lo|, |hi|) 2^e <= 32767 (within [-60, 60])."""
    m = max(abs(float(lo)), abs(float(hi)))
    e = 60
    while e > -60 and m * 2.0 ** e > INT16_MAX:
        e -= 1
    return e


@dataclasses.dataclass
class Moments:
    """Exact integer moments of a layer's integer inputs over calibration rows: n rows,
    sums S_j and products P_jk (Python integers: the same on every machine)."""

    n: int
    sums: list
    prods: list

    @classmethod
    def of(cls, rows: np.ndarray) -> "Moments":
        r = [[int(v) for v in col] for col in np.asarray(rows, np.int64).T]
        return cls(n=len(rows), sums=[sum(c) for c in r],
                   prods=[[sum(a * b for a, b in zip(ci, cj)) for cj in r] for ci in r])

    def cov(self) -> list:
        """n^2 times the covariance, as floats from exact integers: n P_jk - S_j S_k."""
        return [[float(self.n * p - sj * sk) for p, sk in zip(row, self.sums)] for row, sj in zip(self.prods, self.sums)]


def _data_rounding(u: list, wq: list, wmax: int, cov: list) -> list:
    """Integer weights near u (real weights in units of the row's step) that make the row's
    output error over the calibration inputs small: the rounding of each weight up or down
    chosen so that the errors d = u - wq cancel over correlated inputs (minimising d' C d,
    C their covariance; greedy, one weight at a time, while the error falls), instead of each
    weight to its nearest. The mean error goes into the bias (_quantise_layer)."""
    wq = list(wq)
    d = [a - w for a, w in zip(u, wq)]
    n = len(u)
    for _ in range(8 * n):
        best, best_j, best_step = 0.0, -1, 0
        for j in range(n):
            step = 1 if d[j] > 0 else -1  # the other rounding of weight j
            if abs(wq[j] + step) > wmax or abs(d[j]) >= 1.0:
                continue
            cd = math.fsum(cov[j][k] * d[k] for k in range(n))
            gain = -(2.0 * (-step) * cd + cov[j][j])  # change of d' C d when d_j -> d_j - step, negated
            if gain > best * (1.0 + 1e-12) + 1e-300:
                best, best_j, best_step = gain, j, step
        if best_j < 0:
            break
        wq[best_j] += best_step
        d[best_j] -= best_step
    return wq


SCALE_TRIES = 12  # the data-aware rounding tries the row scales s (1 + k / 64), k < SCALE_TRIES


def _best_scale(a, s0, wq0, wmax, cov):
    """The row's scale among s0 (1 + k / 64), and its data-aware rounding, with the smallest
    output error s^2 d' C d over the calibration rows (a larger step can put the weights
    nearer their grid); the first of equals."""
    best = None
    for k in range(SCALE_TRIES):
        s = s0 * (1.0 + k / 64.0)
        u = [v / s for v in a]
        wq = _data_rounding(u, [round_half_away(v) for v in u], wmax, cov)
        d = [x - w for x, w in zip(u, wq)]
        err = s * s * math.fsum(d[j] * math.fsum(cov[j][k2] * d[k2] for k2 in range(len(d))) for j in range(len(d)))
        if best is None or err < best[0]:
            best = (err, s, wq)
    return best[1], best[2]


def _quantise_layer(a_rows, bias, wmax: int, in_max: list, limit: int, moments: "Moments | None" = None):
    """Rows of real weights a (per unit of the integer inputs) and real biases -> integer
    rows, biases and scales, each row's bound within limit. moments: the integer inputs'
    moments over calibration rows, for the data-aware rounding (_data_rounding) and the
    bias correction (the mean of the rounding errors over the rows added to the bias)."""
    w_out, b_out, s_out, bound_out = [], [], [], []
    cov = moments.cov() if moments is not None else None
    for a, b in zip(a_rows, bias):
        amax = max(abs(v) for v in a)
        # A row of zero weights is its bias alone: stored as 2^24, far from any bound.
        s = amax / wmax if amax > 0 else (abs(b) / 2.0 ** 24 if b != 0 else 1.0)
        while True:
            wq = [round_half_away(v / s) for v in a]
            bq = round_half_away(b / s)
            if cov is not None and amax > 0:
                s, wq = _best_scale(a, s, wq, wmax, cov)
                u = [v / s for v in a]
                mean_err = math.fsum((x - w) * sj for x, w, sj in zip(u, wq, moments.sums)) / moments.n
                bq = round_half_away(b / s + mean_err)
            bound = abs(bq) + sum(abs(w) * m for w, m in zip(wq, in_max))
            if bound <= limit and max(abs(w) for w in wq) <= wmax:
                break
            s *= max(bound / limit, 1.0) * (1.0 + 2.0 ** -20)
        w_out.append(wq)
        b_out.append(bq)
        s_out.append(s)
        bound_out.append(bound)
    return w_out, b_out, s_out, bound_out


def _shift(bounds) -> int:
    """Smallest R with (bound + 2^(R-1)) >> R <= 32767 for every bound."""
    r = 0
    while any(((b + ((1 << r) >> 1)) >> r) > INT16_MAX for b in bounds):
        r += 1
    return r


def _box_max(wq, bq, lo, hi) -> list:
    """Per row, the largest accumulator bq + sum_j w_j x_j over the box lo_j <= x_j <= hi_j
    (exact, Python integers), at least 0 (the ReLU's)."""
    return [max(0, b + sum(max(w * a, w * c) for w, a, c in zip(row, lo, hi))) for row, b in zip(wq, bq)]


def quantise(model, hidden_type: str = DEFAULT_HIDDEN_TYPE, first_type: str = "int16",
             envelope_shifts: bool = False, calibration=None) -> QuantNet:
    """The fixed-point network of a ModelData (observer_ref.py), from its float32 weights;
    hidden_type and first_type: the weights of the hidden layers and of layer 0.

    envelope_shifts: each hidden layer's shift R is the smallest that keeps its values
    within int16 for inputs inside the training envelope (the only ones the observer runs
    the network on), instead of for any int16 input: the hidden values then use the whole
    int16 range where it matters (with int8 weights, the any-input shifts left them below
    3,000 and cost 0.08 RPM RMS; issue 24). Outside the envelope a hidden value saturates
    at 32767 (mlp_q.h's clamp, as before), and the sums' int32 bounds still hold for any
    input (each layer's inputs taken at 32767).

    calibration: feature rows x (the training rows) for the data-aware rounding of the
    int8 layers (_data_rounding, with the bias correction); None: every weight to its
    nearest integer."""
    for t in (hidden_type, first_type):
        if t not in TYPES:
            raise ValueError(f"weight types are one of {sorted(TYPES)}, got {t!r}")
    layers = [(np.asarray(w, np.float32), np.asarray(b, np.float32)) for w, b in model.layers]
    mean = [float(v) for v in np.asarray(model.scaler_mean, np.float32)]
    scale = [float(v) for v in np.asarray(model.scaler_scale, np.float32)]
    e = [input_exponent(lo, hi) for lo, hi in zip(model.env_lo, model.env_hi)]
    w0, b0 = layers[0]
    # Layer 0 per unit of xq_j: W0_oj / scale_j 2^-e_j; bias b0_o - sum_j W0_oj mean_j / scale_j.
    a0 = [[float(w0[o, j]) / scale[j] * 2.0 ** -e[j] for j in range(w0.shape[1])] for o in range(w0.shape[0])]
    c0 = [float(b0[o]) - math.fsum(float(w0[o, j]) * mean[j] / scale[j] for j in range(w0.shape[1]))
          for o in range(w0.shape[0])]
    in_max = [INT16_MAX] * w0.shape[1]
    # The envelope box in units of xq (the inputs the observer runs the network on).
    box = ([quantise_inputs_e(e, model.env_lo)], [quantise_inputs_e(e, model.env_hi)])
    box = ([min(a, c) for a, c in zip(box[0][0], box[1][0])], [max(a, c) for a, c in zip(box[0][0], box[1][0])])
    weights, biases, types, shifts, bounds = [], [], [], [], []
    a_rows, bias, n = a0, c0, len(layers)
    if calibration is not None:
        cal_in = np.asarray([quantise_inputs_e(e, r) for r in np.asarray(calibration, np.float32)], np.int64)
    for k in range(n):
        last = k == n - 1
        t = first_type if k == 0 and not last else "int16" if last else hidden_type
        limit = INT32_MAX if last else INT32_MAX - (1 << 15)  # room for the rounding of a shift <= 16
        mom = None
        if calibration is not None and t == "int8":
            mom = Moments.of(cal_in)
        wq, bq, s, bd = _quantise_layer(a_rows, bias, TYPES[t], in_max, limit, mom)
        weights.append(wq)
        biases.append(bq)
        types.append(t)
        bounds.append(max(bd))
        if last:
            out_scale = np.float32(s[0])
            break
        top = _box_max(wq, bq, *box) if envelope_shifts else bd
        r = _shift(top)
        if r > 16:
            raise ValueError(f"layer {k} needs a shift of {r} > 16")
        shifts.append(r)
        box_top = [min(INT16_MAX, (b + ((1 << r) >> 1)) >> r) for b in top]
        box = ([0] * len(box_top), box_top)
        if calibration is not None:  # the next layer's integer inputs over the calibration rows
            acc = np.asarray(bq, np.int64)[None, :] + sum(np.asarray([row[j] for row in wq], np.int64)[None, :]
                                                          * cal_in[:, j: j + 1] for j in range(cal_in.shape[1]))
            cal_in = np.minimum((np.maximum(acc, 0) + ((1 << r) >> 1)) >> r, INT16_MAX)
        in_max = [INT16_MAX] * len(bd) if envelope_shifts else box_top
        # The next layer's columns absorb each row's scale s_o 2^R.
        w_next, b_next = layers[k + 1]
        a_rows = [[float(w_next[p, o]) * s[o] * 2.0 ** r for o in range(w_next.shape[1])]
                  for p in range(w_next.shape[0])]
        bias = [float(v) for v in b_next]
    return QuantNet(in_exp=e, weights=weights, biases=biases, types=types, shifts=shifts,
                    out_scale=out_scale, bounds=bounds, gate=quantise_gate(model.gate, e))


def quantise_inputs(q: QuantNet, x) -> list:
    """xq_j = sat16(round(x_j 2^e_j)), a NaN as 0; x in float32."""
    return quantise_inputs_e(q.in_exp, x)


def quantise_inputs_e(in_exp, x) -> list:
    """quantise_inputs with the input exponents e_j."""
    out = []
    for xj, e in zip(np.asarray(x, np.float32), in_exp):
        y = float(xj)
        if math.isnan(y):
            out.append(0)
            continue
        if math.isinf(y):
            out.append(INT16_MAX if y > 0 else -INT16_MAX)
            continue
        out.append(max(-INT16_MAX, min(INT16_MAX, round_half_away(y * 2.0 ** e))))
    return out


def forward_int(q: QuantNet, x) -> tuple[list, int, np.float32]:
    """(xq, output accumulator, residual RPM float32) for the features x: the integer
    equations of the module docstring, in Python integers, each accumulator checked
    against int32."""
    h = quantise_inputs(q, x)
    xq = list(h)
    n = len(q.weights)
    for k in range(n):
        acc = [b + sum(w * v for w, v in zip(row, h)) for row, b in zip(q.weights[k], q.biases[k])]
        assert all(-2 ** 31 <= a <= INT32_MAX for a in acc), "int32 overflow: the bound is wrong"
        if k == n - 1:
            out = acc[0]
            return xq, out, np.float32(np.float32(out) * q.out_scale)
        r = q.shifts[k]
        h = [min(INT16_MAX, (max(a, 0) + ((1 << r) >> 1)) >> r) for a in acc]
    raise AssertionError("unreachable")


# ---------------------------------------------------------------- the gate in integers
#
# gate.h's weight with integers (gate_q.h is the board's half): the same prototypes,
# thresholds and rule, in units of 2^-GATE_FRAC of the gate's scaled space.
#
#   gq_j  = sat16(round(g_j 2^e_j))                  the network's input quantisation
#   zq_j  = clip(((gq_j - cq_j) m_j + 2^(S_j-1)) >> S_j, -GATE_ZMAX, GATE_ZMAX)
#           cq_j = round(centre_j 2^e_j), m_j / 2^S_j ~ 2^GATE_FRAC / (scale_j 2^e_j), m_j <= 16383
#   acc_k = sum_j (zq_j - pq_kj)^2                   int32 (|zq - pq| <= 2 GATE_ZMAX: no overflow)
#   best  = min(r_out_q, acc_k ...) (a prototype's sum stops once acc >= best; the prototypes
#           sorted by their coordinate sort_dim, for the board's search)
#   w     = 0 unless best < r_out_q; 1 if best <= r_in_q; else float32(r_out_q - best) * fade
#           pq = clip(round(p 2^GATE_FRAC)), r_q = round(r_sq 2^(2 GATE_FRAC)), fade = float32(1 / (r_out_q - r_in_q))
# A NaN or infinite g_j gives w = 0, as gate.h.
GATE_FRAC = 10
GATE_ZMAX = 8191
GATE_MULT_MAX = 16383


@dataclasses.dataclass
class GateQ:
    in_exp: list
    centre: list      # cq_j, int16
    shift: list       # S_j
    mult: list        # m_j, int16
    prototypes: list  # rows of int16
    r_in_q: int
    r_out_q: int
    fade: np.float32
    sort_dim: int = 0  # the prototypes are in ascending order of this coordinate (quantise_gate)


def quantise_gate(gd, in_exp) -> GateQ:
    """The integer gate of a gate.GateData over inputs quantised with in_exp."""
    centre, shift, mult = [], [], []
    for c, sc, e in zip(gd.centre, gd.scale, in_exp):
        centre.append(max(-INT16_MAX, min(INT16_MAX, round_half_away(float(np.float32(c)) * 2.0 ** e))))
        unit = 2.0 ** GATE_FRAC / (float(np.float32(sc)) * 2.0 ** e)  # zq per unit of (gq - cq)
        s = 30
        while s > 0 and round_half_away(unit * 2.0 ** s) > GATE_MULT_MAX:
            s -= 1
        shift.append(s)
        # Clipped where even S = 0 is too coarse: an envelope so wide that 2^e_j is below
        # 2^GATE_FRAC / (16383 scale_j) (no trained model; an open gate of a physics-only model).
        mult.append(min(GATE_MULT_MAX, round_half_away(unit * 2.0 ** s)))
    protos = [[max(-GATE_ZMAX, min(GATE_ZMAX, round_half_away(float(np.float32(v)) * 2.0 ** GATE_FRAC))) for v in row]
              for row in np.asarray(gd.prototypes, np.float32)]
    # Stored in ascending order of one coordinate, the one along which the prototypes spread
    # most (sort_dim, the largest variance; then the others): the board's search (gate_q.h) starts at the previous
    # nearest and walks up and down that order, stopping each way where that coordinate's
    # difference alone reaches the best distance (exact: the prototypes beyond differ more
    # still). The minimum, and so the weight, does not depend on the order.
    n = len(protos)  # n^2 times each coordinate's variance, exact
    spread = [n * sum(r[j] * r[j] for r in protos) - sum(r[j] for r in protos) ** 2 for j in range(len(in_exp))]
    sort_dim = spread.index(max(spread))
    protos = sorted(protos, key=lambda r: (r[sort_dim], r))
    def q_sq(r):  # a squared radius in units of 2^-2GATE_FRAC, within [0, 2^31 - 1]
        r = float(np.float32(r)) * 2.0 ** (2 * GATE_FRAC)
        return INT32_MAX if not math.isfinite(r) or r >= INT32_MAX else max(0, round_half_away(r))
    # An open gate (thresholds at the float maximum) keeps w = 1 for every sum (<= 5 (2 GATE_ZMAX)^2).
    r_in = min(q_sq(gd.r_in_sq), INT32_MAX - 1)
    r_out = max(r_in + 1, q_sq(gd.r_out_sq))
    return GateQ(in_exp=list(in_exp), centre=centre, shift=shift, mult=mult, prototypes=protos, r_in_q=r_in,
                 r_out_q=r_out, fade=np.float32(1.0 / (r_out - r_in)), sort_dim=sort_dim)


def gate_weight_int(gq: GateQ, g) -> np.float32:
    """The integer gate's weight for the features g (float32)."""
    g = np.asarray(g, np.float32)
    if not np.all(np.isfinite(g)):
        return np.float32(0)
    xq = quantise_inputs(QuantNet(in_exp=gq.in_exp, weights=[], biases=[], types=[], shifts=[],
                                  out_scale=np.float32(1), bounds=[]), g)
    zq = []
    for v, c, m, s in zip(xq, gq.centre, gq.mult, gq.shift):
        t = (v - c) * m
        assert -2 ** 31 <= t + ((1 << s) >> 1) <= INT32_MAX
        zq.append(max(-GATE_ZMAX, min(GATE_ZMAX, (t + ((1 << s) >> 1)) >> s)))
    best = gq.r_out_q
    for row in gq.prototypes:
        acc = 0
        for z, p in zip(zq, row):
            if acc >= best:
                break
            acc += (z - p) * (z - p)
        else:
            if acc < best:
                best = acc
    if not best < gq.r_out_q:
        return np.float32(0)
    if best <= gq.r_in_q:
        return np.float32(1)
    return np.float32(np.float32(gq.r_out_q - best) * gq.fade)


def gate_fn(q: QuantNet):
    """The observer's gate weight for features x (observer_ref.ReferenceObserver's gate)."""
    return lambda x: gate_weight_int(q.gate, x)


def fixed_observer(model, q: QuantNet):
    """The reference observer of the fixed-point model: integer network and gate."""
    from .observer_ref import ReferenceObserver
    return ReferenceObserver(model, residual_fn(q), gate_fn(q))


def gate_bytes(gq: GateQ) -> bytes:
    """Little-endian bytes of the stored gate in gate_q.h's checksum order: centre (int16),
    shifts (int8), multipliers (int16), prototypes (int16), r_in_q, r_out_q (int32), fade
    (float32), sort_dim (uint8)."""
    return b"".join([np.asarray(gq.centre, "<i2").tobytes(), np.asarray(gq.shift, "<i1").tobytes(),
                     np.asarray(gq.mult, "<i2").tobytes(),
                     np.asarray([v for r in gq.prototypes for v in r], "<i2").tobytes(),
                     np.asarray([gq.r_in_q, gq.r_out_q], "<i4").tobytes(), np.asarray([gq.fade], "<f4").tobytes(),
                     bytes([gq.sort_dim])])


def residual_fn(q: QuantNet):
    """The observer's residual for features x (observer_ref.ReferenceObserver's network)."""
    return lambda x: forward_int(q, x)[2]


def c_int_array(name: str, ctype: str, values, per_line: int = 12) -> str:
    vals = [str(int(v)) for v in values]
    lines = [", ".join(vals[k:k + per_line]) for k in range(0, len(vals), per_line)]
    body = ",\n    ".join(lines)
    return f"HPDDO_FLASH static const {ctype} {name}[{len(vals)}] = {{\n    {body}}};\n"


def weight_bytes(q: QuantNet) -> bytes:
    """Little-endian bytes of the stored network in mlp_q.h's checksum order: input
    exponents (int8), then per layer weights (int16 or int8) and biases (int32), then
    the output scale (float32)."""
    parts = [np.asarray(q.in_exp, "<i1").tobytes()]
    for w, b, t in zip(q.weights, q.biases, q.types):
        parts.append(np.asarray([v for row in w for v in row], "<i2" if t == "int16" else "<i1").tobytes())
        parts.append(np.asarray(b, "<i4").tobytes())
    parts.append(np.asarray([q.out_scale], "<f4").tobytes())
    return b"".join(parts)


def _stream(rec, rows):
    """(v, i, temp or None, dt, seq) of the given rows of a recording, as the replay feeds them."""
    from ..logs import dataset
    df = rec.df
    dt = dataset.dt_s(rec)
    temp = dataset.temp_read_C(rec)
    seq = df["seq"].to_numpy(np.int64) % 65536 if "seq" in df else None
    v, i = df["v_V"].to_numpy(float), df["i_A"].to_numpy(float)
    return [(v[k], i[k], None if np.isnan(temp[k]) else temp[k], dt[k], None if seq is None else int(seq[k]))
            for k in rows]


def accuracy(model, q: QuantNet, recs, part: str = "test") -> dict:
    """Float against fixed-point observer, both the float32 reference (observer_ref), over
    the rows of each recording (part "test": the test rows, lags restarted at the first;
    "all": every row). Per recording and overall: RMS of the difference of the estimates,
    largest |difference|, and both RMSEs against rpm_ref where the log has it (RPM)."""
    from .observer_ref import ReferenceObserver
    out, d_all, ef_all, eq_all = {}, [], [], []
    for rec in recs:
        rows = range(rec.n_train, rec.n) if part == "test" else range(rec.n)
        f_obs, q_obs = ReferenceObserver(model), fixed_observer(model, q)
        est_f, est_q = [], []
        for s in _stream(rec, rows):
            est_f.append(float(f_obs.step(*s)["rpm"]))
            est_q.append(float(q_obs.step(*s)["rpm"]))
        ef, eq = np.asarray(est_f), np.asarray(est_q)
        d = eq - ef
        r = {"rows": len(d), "rms_diff_rpm": float(np.sqrt(np.mean(d * d))), "max_abs_diff_rpm": float(np.max(np.abs(d)))}
        if "rpm_ref" in rec.df:
            ref = rec.df["rpm_ref"].to_numpy(float)[list(rows)]
            r["rmse_float_rpm"] = float(np.sqrt(np.mean((ef - ref) ** 2)))
            r["rmse_fixed_rpm"] = float(np.sqrt(np.mean((eq - ref) ** 2)))
            ef_all.append(ef - ref)
            eq_all.append(eq - ref)
        out[rec.name] = r
        d_all.append(d)
    d = np.concatenate(d_all)
    tot = {"rows": len(d), "rms_diff_rpm": float(np.sqrt(np.mean(d * d))), "max_abs_diff_rpm": float(np.max(np.abs(d)))}
    if ef_all:
        a, b = np.concatenate(ef_all), np.concatenate(eq_all)
        tot["rmse_float_rpm"] = float(np.sqrt(np.mean(a * a)))
        tot["rmse_fixed_rpm"] = float(np.sqrt(np.mean(b * b)))
    out["all"] = tot
    return out
