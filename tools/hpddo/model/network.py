"""The residual network of M3 and its training, in a defined order of arithmetic.

The trained weights are written into a committed model header, so they must be the
same bytes on every machine. A BLAS matrix product sums in an order that depends on
the CPU, the kernel OpenBLAS picks (OPENBLAS_CORETYPE) and the thread count, and over
tens of thousands of Adam steps those last-bit differences reach the weights. Here
every product is an elementwise float64 multiply followed by an add or a numpy
reduction over a fixed axis: IEEE-exact operations whose order depends only on the
array shapes, never on the CPU. Nothing in this module calls BLAS or LAPACK.

The network and its training follow the usual dense ReLU regressor: Glorot-uniform
initialisation (bound sqrt(6 / (fan_in + fan_out))), squared loss halved, L2 penalty
alpha, Adam (beta1 0.9, beta2 0.999, eps 1e-8), minibatches over a fresh permutation
each epoch.
"""
from __future__ import annotations

import dataclasses

import numpy as np

ADAM_BETA1 = 0.9
ADAM_BETA2 = 0.999
ADAM_EPS = 1e-8
L2_ALPHA = 1e-4


TERM_BY_TERM_MAX = 32  # matmul sums an inner axis up to this long term by term, a longer one by numpy


def matmul(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """a @ w as elementwise products summed over the inner axis in an order fixed by the
    shapes: term by term for a short inner axis, else one numpy reduction."""
    k, m = w.shape
    if k == 1:
        return a[:, 0:1] * w[0]
    if k <= TERM_BY_TERM_MAX and m > 1:
        acc = a[:, 0:1] * w[0]
        for j in range(1, k):
            acc += a[:, j: j + 1] * w[j]
        return acc
    return (a[:, :, None] * w[None, :, :]).sum(axis=1)


def matmul_cols(w: np.ndarray, a_t: np.ndarray) -> np.ndarray:
    """matmul(a, w).T from a_t = a.T (features by rows), the same bits: for w of more than one
    column and an inner axis summed term by term, the inner index's terms added in order (a
    reduction over the first axis of a C-ordered array adds its slabs one after the other) in
    two numpy calls instead of two per inner index; otherwise matmul itself."""
    k, m = w.shape
    if k > TERM_BY_TERM_MAX or m == 1:
        return matmul(np.ascontiguousarray(a_t.T), w).T
    if k == 1:
        return w[0][:, None] * a_t[0:1]
    # the products in C order whatever the operands' strides (a transposed w would otherwise lay
    # them out with the inner index fastest, and numpy would sum them pairwise)
    terms = np.multiply(w[:, :, None], a_t[:, None, :], out=np.empty((k, m, a_t.shape[1])))
    return np.add.reduce(terms, axis=0)


def matmul_t(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """a.T @ d (the weight gradient), summed over the rows in a fixed order."""
    return (a[:, :, None] * d[:, None, :]).sum(axis=0)


@dataclasses.dataclass
class Scaler:
    """Standardisation z = (x - mean) / scale per feature; a constant feature keeps scale 1."""

    mean_: np.ndarray
    scale_: np.ndarray

    @classmethod
    def fit(cls, x: np.ndarray) -> "Scaler":
        x = np.asarray(x, float)
        mean = x.mean(axis=0)
        std = np.sqrt(((x - mean) ** 2).mean(axis=0))
        return cls(mean_=mean, scale_=np.where(std > 0, std, 1.0))

    def transform(self, x: np.ndarray) -> np.ndarray:
        return (np.asarray(x, float) - self.mean_) / self.scale_


@dataclasses.dataclass
class Network:
    """Dense ReLU layers with a linear scalar output; coefs_[k] is W[in, out]."""

    coefs_: list
    intercepts_: list

    @property
    def hidden(self) -> tuple:
        return tuple(w.shape[1] for w in self.coefs_[:-1])

    def activations(self, z: np.ndarray) -> list:
        """Inputs, every hidden activation and the output, for a batch of rows."""
        acts = [np.asarray(z, float)]
        for k, (w, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            h = matmul(acts[-1], w) + b
            if k < len(self.coefs_) - 1:
                np.maximum(h, 0.0, out=h)
            acts.append(h)
        return acts

    def predict(self, z: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """Network output for standardised rows z, in chunks to bound memory."""
        z = np.asarray(z, float)
        out = [self.activations(z[s: s + chunk])[-1][:, 0] for s in range(0, len(z), chunk)]
        return np.concatenate(out) if out else np.zeros(0)


@dataclasses.dataclass
class AdamConfig:
    """The network and its training: hidden sizes, Adam's step, rows per batch, epochs
    (max_iter: full passes over the rows, no early stop), seed, L2 penalty, and the Adam steps at
    the most (max_steps: the epochs cut to the fewest whose batches reach it; None: max_iter
    epochs whatever the rows)."""

    hidden: tuple = (16, 8)
    learning_rate: float = 1e-3
    batch_size: int = 200
    max_iter: int = 2000
    seed: int = 1
    alpha: float = L2_ALPHA
    max_steps: int | None = None


def epochs(cfg: AdamConfig, n: int) -> int:
    """The epochs a training of n rows runs: cfg.max_iter, cut where cfg.max_steps is given to the
    fewest whose batches (ceil(n / batch_size) an epoch) reach it."""
    if cfg.max_steps is None:
        return cfg.max_iter
    per_epoch = max(1, -(-n // cfg.batch_size))
    return max(1, min(cfg.max_iter, -(-cfg.max_steps // per_epoch)))


class _Flat:
    """All weights and biases in one vector, with per-layer views (one Adam update a step)."""

    def __init__(self, sizes):
        self.shapes = []
        for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
            self.shapes += [(fan_in, fan_out), (fan_out,)]
        self.total = sum(int(np.prod(s)) for s in self.shapes)

    def views(self, vec):
        out, k = [], 0
        for s in self.shapes:
            n = int(np.prod(s))
            out.append(vec[k: k + n].reshape(s))
            k += n
        return out[0::2], out[1::2]


def init_network(n_in: int, hidden: tuple, rng: np.random.Generator) -> tuple[np.ndarray, _Flat]:
    """Glorot-uniform weights and biases for ReLU layers, as one flat vector."""
    sizes = (n_in, *hidden, 1)
    flat = _Flat(sizes)
    vec = np.empty(flat.total)
    ws, bs = flat.views(vec)
    for w, b, fan_in, fan_out in zip(ws, bs, sizes[:-1], sizes[1:]):
        bound = np.sqrt(6.0 / (fan_in + fan_out))
        w[...] = rng.uniform(-bound, bound, w.shape)
        b[...] = rng.uniform(-bound, bound, b.shape)
    return vec, flat


def adam_rate(cfg: AdamConfig, b1_t: float, b2_t: float) -> float:
    """Adam's step size with both moments' bias corrected (b1_t, b2_t: the betas to the power
    of the step's number)."""
    return cfg.learning_rate * np.sqrt(1.0 - b2_t) / (1.0 - b1_t)


def adam_step(theta: np.ndarray, grad: np.ndarray, m: np.ndarray, v: np.ndarray, lr_t: float) -> None:
    """One Adam step of the parameters theta in place, with their moments m and v."""
    m *= ADAM_BETA1
    m += (1.0 - ADAM_BETA1) * grad
    v *= ADAM_BETA2
    v += (1.0 - ADAM_BETA2) * (grad * grad)
    theta -= lr_t * m / (np.sqrt(v) + ADAM_EPS)


def sample_weights(weight, n: int) -> np.ndarray | None:
    """Per-row weights of the squared loss scaled to mean 1 (so the L2 term and Adam's step keep
    their balance against it); None stays None (every row once)."""
    if weight is None:
        return None
    w = np.asarray(weight, float).reshape(-1)
    if w.shape != (n,) or not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise ValueError("sample weights: one finite, non-negative weight per row, not all zero")
    return (w / w.mean()).reshape(-1, 1)


def train(z: np.ndarray, y: np.ndarray, cfg: AdamConfig, progress=None, weight=None) -> tuple[Network, list]:
    """Fits the network to targets y on standardised rows z; returns it and the loss per
    epoch (mean of the halved squared error plus the L2 term, over the epoch's batches).
    `progress`, if given, wraps the epoch range (a tqdm bar). weight: one per row (the
    reference's confidence), scaled to mean 1 (sample_weights): each row's squared error
    counts that many times; None: every row once, the arithmetic unchanged."""
    z = np.asarray(z, float)
    y = np.asarray(y, float).reshape(-1, 1)
    n = len(z)
    wt = sample_weights(weight, n)
    rng = np.random.default_rng(cfg.seed)
    theta, flat = init_network(z.shape[1], tuple(cfg.hidden), rng)
    ws, bs = flat.views(theta)
    grad = np.zeros_like(theta)
    gws, gbs = flat.views(grad)
    m = np.zeros_like(theta)
    v = np.zeros_like(theta)
    b1_t = b2_t = 1.0
    nlayers = len(ws)
    losses = []
    # Each layer's activations are kept both ways: rows by units (acts, C order) for the sums over
    # a batch's rows (the weight and bias gradients), units by rows (acts_t) for the sums over a
    # layer's inputs (matmul_cols). Every number is the same bits as the row-major arithmetic of
    # network.activations and matmul (test_network: trained to the byte).
    z_t = np.ascontiguousarray(z.T)
    n_epochs = epochs(cfg, n)
    for _ in range(n_epochs) if progress is None else progress(range(n_epochs)):
        order = rng.permutation(n)
        zs, zs_t, ys = z[order], z_t[:, order], y[order]
        wts = None if wt is None else wt[order]
        acc_loss = 0.0
        for start in range(0, n, cfg.batch_size):
            stop = start + cfg.batch_size
            acts, acts_t, yb = [zs[start: stop]], [zs_t[:, start: stop]], ys[start: stop]
            nb = len(yb)
            for k, (w, b) in enumerate(zip(ws, bs)):
                h_t = matmul_cols(w, acts_t[-1])
                h_t += b[:, None]
                if k < nlayers - 1:
                    np.maximum(h_t, 0.0, out=h_t)
                acts_t.append(h_t)
                acts.append(np.ascontiguousarray(h_t.T))
            delta = acts[-1] - yb
            if wts is None:
                sq = float((delta * delta).sum()) / nb / 2.0
            else:  # the weighted loss: sum w d^2 / 2 nb, its gradient w d
                wb = wts[start: stop]
                sq = float((wb * delta * delta).sum()) / nb / 2.0
                delta = delta * wb
            l2 = sum(float((w * w).sum()) for w in ws)
            acc_loss += (sq + 0.5 * cfg.alpha * l2 / nb) * nb
            for k in range(nlayers - 1, -1, -1):
                gws[k][...] = (matmul_t(acts[k], delta) + cfg.alpha * ws[k]) / nb
                gbs[k][...] = delta.sum(axis=0) / nb
                if k:
                    d_t = matmul_cols(ws[k].T, np.ascontiguousarray(delta.T))
                    d_t *= acts_t[k] > 0
                    delta = np.ascontiguousarray(d_t.T)
            b1_t *= ADAM_BETA1
            b2_t *= ADAM_BETA2
            adam_step(theta, grad, m, v, adam_rate(cfg, b1_t, b2_t))
        losses.append(acc_loss / n)
    return Network(coefs_=[w.copy() for w in ws], intercepts_=[b.copy() for b in bs]), losses


def train_lockstep(zs: list, ys: list, cfg: AdamConfig, hiddens: list | None = None, weights: list | None = None) -> list:
    """network.train for several networks at once, each on its own rows: the same
    initialisation (its own generator seeded cfg.seed), the same fresh permutation each
    epoch, the same batches, loss gradients, L2 term and Adam steps, so each network is
    the one network.train gives on its rows (to the rounding of the BLAS products). The
    networks step together, their batches stacked into one array: Python's cost per
    step, which dominates for small networks, is paid once for all. A network whose rows
    are fewer takes fewer steps and is frozen when its last epoch ends.

    The networks may differ in their inputs and layer widths (hiddens[k], default
    cfg.hidden for all; the same number of layers): each is embedded in the widest shape
    with zeros, and the zeros stay zeros (a zero input or unit has no gradient, the L2
    term of a zero weight is zero, Adam does not move a weight whose gradients were all
    zero), so the padding changes nothing but the cost. weights: per network, one weight per
    row or None, as network.train's weight. Returns one Network per (z, y)."""
    K = len(zs)
    zs = [np.asarray(z, float) for z in zs]
    ys = [np.asarray(y, float).reshape(-1) for y in ys]
    wts = [None] * K if weights is None else [sample_weights(w, len(z)) for w, z in zip(weights, zs)]
    wts = [np.ones(len(z)) if w is None else w.reshape(-1) for w, z in zip(wts, zs)]
    hiddens = [tuple(cfg.hidden)] * K if hiddens is None else [tuple(h) for h in hiddens]
    sizes = [(z.shape[1], *h, 1) for z, h in zip(zs, hiddens)]
    if len({len(sz) for sz in sizes}) != 1:
        raise ValueError("lockstep networks need the same number of layers")
    widest = [max(sz[j] for sz in sizes) for j in range(len(sizes[0]))]
    L = len(widest) - 1
    W = [np.zeros((K, widest[l], widest[l + 1])) for l in range(L)]   # (K, in, out)
    b = [np.zeros((K, widest[l + 1])) for l in range(L)]              # (K, out)
    rngs = [np.random.default_rng(cfg.seed) for _ in range(K)]
    for k, (rng, sz) in enumerate(zip(rngs, sizes)):
        vec, flat = init_network(sz[0], tuple(sz[1:-1]), rng)
        ws, bs = flat.views(vec)
        for l in range(L):
            W[l][k, : sz[l], : sz[l + 1]] = ws[l]
            b[l][k, : sz[l + 1]] = bs[l]
    if cfg.max_steps is not None:
        raise ValueError("train_lockstep runs max_iter epochs; a step budget (max_steps) is train's")
    n_in = widest[0]
    B = cfg.batch_size
    params = W + b
    m = [np.zeros_like(a) for a in params]
    v = [np.zeros_like(a) for a in params]
    n = np.array([len(z) for z in zs])
    per_epoch = -(-n // B)
    total = per_epoch * cfg.max_iter
    result = [None] * K
    X = np.zeros((K, B, n_in))
    Y = np.zeros((K, B, 1))
    mask = np.zeros((K, B, 1))
    nb = np.ones(K)
    shuffled = [None] * K
    b1_t = b2_t = 1.0
    for t in range(int(total.max())):
        mask[:] = 0.0
        for k in range(K):
            if t >= total[k]:
                continue
            j = t % per_epoch[k]
            if j == 0:
                order = rngs[k].permutation(n[k])
                shuffled[k] = (zs[k][order], ys[k][order], wts[k][order])
            lo = j * B
            zb, yb = shuffled[k][0][lo: lo + B], shuffled[k][1][lo: lo + B]
            c = len(zb)
            X[k, :c, : sizes[k][0]] = zb
            Y[k, :c, 0] = yb
            mask[k, :c, 0] = shuffled[k][2][lo: lo + B]  # 1 for a row (times its weight), 0 for padding
            nb[k] = c
        acts = [X]
        for l in range(L):
            h = acts[-1] @ W[l] + b[l][:, None, :]
            if l < L - 1:
                np.maximum(h, 0.0, out=h)
            acts.append(h)
        delta = (acts[-1] - Y) * mask
        grads_w, grads_b = [None] * L, [None] * L
        for l in range(L - 1, -1, -1):
            grads_w[l] = (np.swapaxes(acts[l], 1, 2) @ delta + cfg.alpha * W[l]) / nb[:, None, None]
            grads_b[l] = delta.sum(axis=1) / nb[:, None]
            if l:
                delta = (delta @ np.swapaxes(W[l], 1, 2)) * (acts[l] > 0)
        b1_t *= ADAM_BETA1
        b2_t *= ADAM_BETA2
        lr_t = adam_rate(cfg, b1_t, b2_t)
        for a, g, mm, vv in zip(params, grads_w + grads_b, m, v):
            adam_step(a, g, mm, vv, lr_t)
        for k in np.flatnonzero(total == t + 1):
            sz = sizes[k]
            result[k] = Network(coefs_=[W[l][k, : sz[l], : sz[l + 1]].copy() for l in range(L)],
                                        intercepts_=[b[l][k, : sz[l + 1]].copy() for l in range(L)])
    return result
