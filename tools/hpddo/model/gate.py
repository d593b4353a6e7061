"""Novelty gate of M3: the residual correction fades to zero where the input lies far
from every training row (lib/hpddo_core/src/hpddo/gate.h is the board's half).

    n_M3 = n_M2 + w(g) * clamp(MLP(scale(x)))

The gate input g is the network's features x = [v_V, i_A, n_M2, i_A(t-1), n_M2(t-1)],
optionally followed by the temperature the observer feeds the physics (the winding
estimate, Estimate::temp_C): the network never sees temperature, so without it a hot
motor looks in-distribution. The gate carries its own scaling, z_j = (g_j - centre_j) /
scale_j (training mean and standard deviation, a constant dimension keeps scale 1), and
K prototypes in that scaled space, chosen from the training rows. d2 is the squared
Euclidean distance of z to the nearest prototype, and

    w = 1                                    d2 <= r_in_sq
    w = (r_out_sq - d2) / (r_out_sq - r_in_sq)   r_in_sq < d2 < r_out_sq   (linear in d2)
    w = 0                                    d2 >= r_out_sq, or any g_j NaN or infinite

The rule of the thresholds (no tuning to a bench; `fit` applies it to any training set):
r_in_sq is the IN_QUANTILE quantile of the training rows' own d2 (the distance at which
the training rows themselves sit from the prototypes), floored at MIN_RADIUS**2; r_out_sq
is OUT_FACTOR**2 r_in_sq (the weight reaches 0 at OUT_FACTOR times that distance).

The prototypes are the first K of a deterministic farthest-point sampling of the training
rows (started at the row nearest the centre; ties go to the lowest row index), optionally
moved by KMEANS_ITERATIONS Lloyd steps ("kmeans"). The sampling runs over the core of the
training rows: those whose distance to their nearest other training row lies within the
core_quantile quantile (IN_QUANTILE by default, the same 99 % the radius describes). The 1 %
most isolated rows (a duty step's first window, whose lagged features still hold the old
operating point) receive no prototype: farthest-point sampling would put one on each, every
one of them taken from the K that cover the rest, so the radius of the gate (and so its
weight everywhere) depended on how many such rows a bench holds. Measured on the default twin
(docs/gate.md, "Design", the core): 8 more duty-step rows out of 6759
(the encoder labels them, the ripple leaves them out as `changing`) took 6 more prototypes
and doubled r_in_sq, 0.108 -> 0.201; with the core, 0.058 and 0.060. core_quantile = 1.0 is
the gate before (every row a candidate). No BLAS, no random numbers: every
distance is the float32 arithmetic of gate.h in its order, so the prototypes, the
thresholds and the weights are the same bytes on every CPU.

Arithmetic order (the contract with gate.h; all float32):
    z_j  = (g_j - centre_j) / scale_j                           j = 0 .. D-1
    acc  = 0; for j = 0 .. D-1: diff = z_j - p_kj; acc = acc + diff * diff
    best = r_out_sq; for k = 0 .. K-1: best = acc_k if acc_k < best
    w    = 0 if not best < r_out_sq; 1 if best <= r_in_sq;
           else (r_out_sq - best) / (r_out_sq - r_in_sq)
(the board may stop summing a prototype once acc >= best: acc only grows, so the result
is the same.)

The measurement behind the chosen gate (the twins, the variants, the cost on the boards)
is hpddo.studies.gate_study (docs/gate.md).
"""
from __future__ import annotations

import dataclasses

import numpy as np

F32 = np.float32

# The rule of the thresholds (see the module text). Stated once, never tuned to a bench.
IN_QUANTILE = 0.99     # r_in: the distance within which 99 % of the training rows lie
OUT_FACTOR = 2.0       # the weight reaches 0 at twice that distance
MIN_RADIUS = 0.1       # r_in is at least a tenth of a training standard deviation: below
#                        that, distances are the sensors' noise, not novelty
DEFAULT_PROTOTYPES = 32
KMEANS_ITERATIONS = 20  # fixed Lloyd steps for the "kmeans" placement (deterministic)
METHODS = ("fps", "kmeans")


@dataclasses.dataclass
class GateData:
    """What a model header carries for the gate (float32 throughout)."""

    centre: np.ndarray      # (D,) in the units of g
    scale: np.ndarray       # (D,) in the units of g, never 0
    prototypes: np.ndarray  # (K, D) in the scaled space, row-major as in flash
    r_in_sq: F32            # squared scaled distance up to which w = 1
    r_out_sq: F32           # squared scaled distance from which w = 0
    rule: str = ""          # how the thresholds were set (for the header's banner)

    @property
    def dims(self) -> int:
        return int(self.centre.shape[0])

    @property
    def count(self) -> int:
        return int(self.prototypes.shape[0])

    def flash_bytes(self) -> int:
        """Bytes of the flash arrays (centre, scale, prototypes)."""
        return 4 * (2 * self.dims + self.count * self.dims)


def scaled(gd: GateData, g) -> np.ndarray:
    """z = (g - centre) / scale in float32, as gate.h."""
    g = np.asarray(g, F32)
    with np.errstate(over="ignore", invalid="ignore"):
        return ((g - gd.centre.astype(F32)) / gd.scale.astype(F32)).astype(F32)


def _sq_dist(z: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Squared distance of every row of z to one prototype p, summed over the dimensions
    in their order, each step rounded to float32 (gate.h's order)."""
    acc = np.zeros(len(z), F32)
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(z.shape[1]):
            diff = (z[:, j] - F32(p[j])).astype(F32)
            acc = (acc + (diff * diff).astype(F32)).astype(F32)
    return acc


def nearest_sq(gd: GateData, z: np.ndarray, start=None) -> np.ndarray:
    """min over the prototypes of the squared distance, starting from `start`
    (r_out_sq by default, as gate.h): best = acc where acc < best, prototype by prototype."""
    best = np.full(len(z), F32(gd.r_out_sq) if start is None else F32(start), F32)
    for k in range(gd.count):
        acc = _sq_dist(z, gd.prototypes[k])
        best = np.where(acc < best, acc, best)
    return best


def weight(gd: GateData, g) -> np.ndarray:
    """The gate's weight in [0, 1] for each row of g (N, D), float32, as gate.h computes it."""
    g = np.atleast_2d(np.asarray(g, F32))
    finite = np.isfinite(g).all(axis=1)
    z = scaled(gd, np.where(finite[:, None], g, F32(0)))
    best = nearest_sq(gd, z)
    r_in, r_out = F32(gd.r_in_sq), F32(gd.r_out_sq)
    den = F32(r_out - r_in)
    with np.errstate(divide="ignore", invalid="ignore"):
        fade = ((r_out - best).astype(F32) / den).astype(F32)
    w = np.where(best <= r_in, F32(1), fade)
    return np.where(finite & (best < r_out), w, F32(0)).astype(F32)


def _farthest_points(z: np.ndarray, k: int) -> np.ndarray:
    """Indices of k rows by farthest-point sampling in float32 (first: the row nearest the
    centre; then each time the row farthest from those chosen; ties: lowest index)."""
    origin = np.zeros(z.shape[1], F32)
    first = int(np.argmin(_sq_dist(z, origin)))
    chosen = [first]
    d = _sq_dist(z, z[first])
    for _ in range(1, min(k, len(z))):
        nxt = int(np.argmax(d))
        if not d[nxt] > 0:  # every row coincides with a prototype already
            break
        chosen.append(nxt)
        d = np.minimum(d, _sq_dist(z, z[nxt]))
    return np.asarray(chosen, np.int64)


def _kmeans(z: np.ndarray, protos: np.ndarray, iterations: int) -> np.ndarray:
    """Lloyd steps from the given prototypes: each row to its nearest prototype (float32
    distances, lowest index on ties), each prototype to the mean of its rows (float64
    sum over rows in row order, then float32); a prototype with no rows stays."""
    protos = protos.astype(F32).copy()
    for _ in range(iterations):
        dist = np.stack([_sq_dist(z, p) for p in protos], axis=1)
        label = np.argmin(dist, axis=1)
        new = protos.copy()
        for c in range(len(protos)):
            rows = z[label == c].astype(np.float64)
            if len(rows):
                new[c] = (np.add.reduce(rows, axis=0) / len(rows)).astype(F32)
        if np.array_equal(new, protos):
            break
        protos = new
    return protos


def open_gate(dims: int, k: int = DEFAULT_PROTOTYPES) -> GateData:
    """A gate that keeps the whole correction at any finite input (w = 1): the observer
    without novelty gate, as before it (hpddo train --no-gate; test fixtures)."""
    big = np.finfo(F32).max  # both thresholds: w = 1 at any finite distance, a step to 0 beyond
    return GateData(centre=np.zeros(dims, F32), scale=np.ones(dims, F32), prototypes=np.zeros((k, dims), F32),
                    r_in_sq=F32(big), r_out_sq=F32(big), rule="open: no novelty gate (w = 1)")


NEAREST_BLOCK = 128  # rows whose distances to the others nearest_other_sq takes at once


def nearest_other_sq(z: np.ndarray) -> np.ndarray:
    """Each row's squared distance to its nearest other row (float32, gate.h's order of the
    sum; inf for a single row). N^2 D operations. For float32 rows, the distances of
    NEAREST_BLOCK rows at once, each pair once: z_i - z_j is exactly -(z_j - z_i) in IEEE
    arithmetic, so the two distances are the same bits, and each value is _sq_dist's (0.15 s for
    6759 rows, against 0.63 s row by row, measured on one core of a busy 2-core machine); other rows (their p_j rounded to float32 first, not
    symmetric) row by row."""
    z = np.asarray(z)
    n = len(z)
    out = np.full(n, np.inf, F32)
    if n < 2:
        return out
    if z.dtype != F32:
        for i in range(n):
            d = _sq_dist(z, z[i])
            d[i] = np.inf
            out[i] = d.min()
        return out
    with np.errstate(over="ignore", invalid="ignore"):
        for s in range(0, n, NEAREST_BLOCK):
            e = min(s + NEAREST_BLOCK, n)
            acc = np.zeros((e - s, n - s), F32)  # rows s..e against rows s..n, gate.h's order over j
            for j in range(z.shape[1]):
                diff = z[None, s:, j] - z[s:e, j, None]
                np.multiply(diff, diff, out=diff)
                acc += diff
            k = np.arange(e - s)
            acc[k, k] = np.inf  # (not itself)
            np.minimum(out[s:e], acc.min(axis=1), out=out[s:e])
            if e < n:  # the same pairs seen from the later rows
                np.minimum(out[e:], acc[:, e - s:].min(axis=0), out=out[e:])
    return out


def core_rows(z: np.ndarray, core_quantile: float) -> np.ndarray:
    """Indices (ascending) of the rows whose nearest-other-row distance lies within the
    core_quantile quantile: the candidates for a prototype (every row at 1.0)."""
    if core_quantile >= 1.0 or len(z) < 2:
        return np.arange(len(z))
    nn = nearest_other_sq(z).astype(np.float64)
    return np.flatnonzero(nn <= np.quantile(nn, core_quantile))


def fit(g_train, k: int = DEFAULT_PROTOTYPES, method: str = "fps", in_quantile: float = IN_QUANTILE,
        out_factor: float = OUT_FACTOR, core_quantile: float | None = None) -> GateData:
    """The gate of the training rows g_train (N, D): scaling, k prototypes placed on the core
    of the rows (core_quantile, in_quantile by default; 1.0: every row), thresholds by the
    rule of the module text over every row. Rows with a NaN or infinity are left out."""
    if method not in METHODS:
        raise ValueError(f"unknown placement {method!r} (known: {', '.join(METHODS)})")
    core_quantile = in_quantile if core_quantile is None else core_quantile
    if not (0.0 < in_quantile <= 1.0 and 0.0 < core_quantile <= 1.0 and out_factor > 1.0 and k >= 1):
        raise ValueError("need 0 < in_quantile <= 1, 0 < core_quantile <= 1, out_factor > 1, k >= 1")
    g = np.asarray(g_train, np.float64)
    g = g[np.isfinite(g).all(axis=1)]
    if len(g) == 0:
        raise ValueError("no finite training rows for the gate")
    mean = np.add.reduce(g, axis=0) / len(g)
    std = np.sqrt(np.add.reduce((g - mean) ** 2, axis=0) / len(g))
    scale = np.where(std > 0, std, 1.0)
    gd = GateData(centre=mean.astype(F32), scale=scale.astype(F32), prototypes=np.zeros((0, g.shape[1]), F32),
                  r_in_sq=F32(0), r_out_sq=F32(np.inf))
    z = scaled(gd, g)
    core = z[core_rows(z, core_quantile)]
    protos = core[_farthest_points(core, k)]
    if method == "kmeans":
        protos = _kmeans(core, protos, KMEANS_ITERATIONS)
    # Fewer distinct rows than k: the prototypes repeat (a repeat changes no distance), so
    # that a model always carries the k its header declares.
    protos = protos[np.arange(k) % len(protos)]
    gd.prototypes = np.ascontiguousarray(protos, F32)
    d_train = nearest_sq(gd, z, start=np.inf)
    r_in_sq = max(float(np.quantile(d_train.astype(np.float64), in_quantile)), MIN_RADIUS ** 2)
    gd.r_in_sq = F32(r_in_sq)
    gd.r_out_sq = F32(out_factor * out_factor * float(gd.r_in_sq))
    gd.rule = (f"{gd.count} prototypes by {method} over {len(core)} of {len(g)} training rows (nearest-row "
               f"distance within the {core_quantile:g} quantile); r_in = "
               f"{in_quantile:g} quantile of their distances (at least {MIN_RADIUS:g}), r_out = {out_factor:g} r_in")
    return gd


# --------------------------------------------------------------------------------------
# C++ text and golden vectors
# --------------------------------------------------------------------------------------

def _lit(v: float) -> str:
    """A float32 as a C++ literal, exact (%.9g), e.g. 70.0f, 1e-05f, __builtin_nanf("")."""
    v = float(v)
    if v != v:
        return '__builtin_nanf("")'
    if v in (float("inf"), float("-inf")):
        return ("-" if v < 0 else "") + '__builtin_inff()'
    t = "%.9g" % v
    return t + ("f" if any(c in t for c in ".e") else ".0f")


def _floats(a) -> str:
    return ", ".join(_lit(v) for v in np.asarray(a, F32).ravel())


def cpp_data(gd: GateData, prefix: str = "kGate") -> str:
    """The flash arrays and the hpddo::Gate of a model header (namespace-less text)."""
    d, k = gd.dims, gd.count
    return (f"HPDDO_FLASH static const float {prefix}Centre[{d}] = {{{_floats(gd.centre)}}};\n"
            f"HPDDO_FLASH static const float {prefix}Scale[{d}] = {{{_floats(gd.scale)}}};\n"
            f"HPDDO_FLASH static const float {prefix}Prototypes[{k * d}] = {{{_floats(gd.prototypes)}}};\n"
            f"static const hpddo::Gate<{d}, {k}> {prefix} = {{{prefix}Centre, {prefix}Scale, {prefix}Prototypes, "
            f"{_lit(gd.r_in_sq)}, {_lit(gd.r_out_sq)}}};\n")
