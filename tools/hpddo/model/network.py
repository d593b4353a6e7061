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


def matmul(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """a @ w as elementwise products summed over the inner axis in an order fixed by the
    shapes: term by term for a short inner axis, else one numpy reduction."""
    k, m = w.shape
    if k == 1:
        return a[:, 0:1] * w[0]
    if k <= 32 and m > 1:
        acc = a[:, 0:1] * w[0]
        for j in range(1, k):
            acc += a[:, j: j + 1] * w[j]
        return acc
    return (a[:, :, None] * w[None, :, :]).sum(axis=1)


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
    (max_iter: full passes over the rows, no early stop), seed, L2 penalty."""

    hidden: tuple = (16, 8)
    learning_rate: float = 1e-3
    batch_size: int = 200
    max_iter: int = 2000
    seed: int = 1
    alpha: float = L2_ALPHA


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


def train(z: np.ndarray, y: np.ndarray, cfg: AdamConfig, progress=None) -> tuple[Network, list]:
    """Fits the network to targets y on standardised rows z; returns it and the loss per
    epoch (mean of the halved squared error plus the L2 term, over the epoch's batches).
    `progress`, if given, wraps the epoch range (a tqdm bar)."""
    z = np.asarray(z, float)
    y = np.asarray(y, float).reshape(-1, 1)
    n = len(z)
    rng = np.random.default_rng(cfg.seed)
    theta, flat = init_network(z.shape[1], tuple(cfg.hidden), rng)
    ws, bs = flat.views(theta)
    grad = np.zeros_like(theta)
    gws, gbs = flat.views(grad)
    m = np.zeros_like(theta)
    v = np.zeros_like(theta)
    b1_t = b2_t = 1.0
    nlayers = len(ws)
    net = Network(coefs_=ws, intercepts_=bs)
    losses = []
    epochs = range(cfg.max_iter) if progress is None else progress(range(cfg.max_iter))
    for _ in epochs:
        order = rng.permutation(n)
        zs, ys = z[order], y[order]
        acc_loss = 0.0
        for start in range(0, n, cfg.batch_size):
            zb, yb = zs[start: start + cfg.batch_size], ys[start: start + cfg.batch_size]
            nb = len(zb)
            acts = net.activations(zb)
            delta = acts[-1] - yb
            sq = float((delta * delta).sum()) / nb / 2.0
            l2 = sum(float((w * w).sum()) for w in ws)
            acc_loss += (sq + 0.5 * cfg.alpha * l2 / nb) * nb
            for k in range(nlayers - 1, -1, -1):
                gws[k][...] = (matmul_t(acts[k], delta) + cfg.alpha * ws[k]) / nb
                gbs[k][...] = delta.sum(axis=0) / nb
                if k:
                    delta = matmul(delta, ws[k].T)
                    delta *= acts[k] > 0
            b1_t *= ADAM_BETA1
            b2_t *= ADAM_BETA2
            m *= ADAM_BETA1
            m += (1.0 - ADAM_BETA1) * grad
            v *= ADAM_BETA2
            v += (1.0 - ADAM_BETA2) * (grad * grad)
            lr_t = cfg.learning_rate * np.sqrt(1.0 - b2_t) / (1.0 - b1_t)
            theta -= lr_t * m / (np.sqrt(v) + ADAM_EPS)
        losses.append(acc_loss / n)
    return Network(coefs_=[w.copy() for w in ws], intercepts_=[b.copy() for b in bs]), losses
