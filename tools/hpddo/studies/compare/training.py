"""The networks of the comparison, trained as M3 is (network.train_lockstep, several at once) in worker processes."""
from __future__ import annotations

import concurrent.futures as cf
import sys
import threading
import time
import numpy as np

from ...model import network
from ... import interrupt
from .config import LOCKSTEP_PAD_MAX, param_count


def fit_networks(xs: list, ys: list, hiddens: list, epochs: int, seed: int, standardise: list) -> list:
    """Networks trained as M3's (network.AdamConfig: Adam 1e-3, batch 200, L2 1e-4, Glorot,
    no early stop) on rows xs[k], targets ys[k], in lockstep (network.train_lockstep). Where
    standardise[k], the target is standardised for training and the output layer
    rescaled after, so the network maps to y's units directly. Returns [(Scaler, Network)]."""
    scalers = [network.Scaler.fit(x) for x in xs]
    shift = []
    for y, std in zip(ys, standardise):
        y = np.asarray(y, float)
        shift.append((float(y.mean()), float(y.std()) or 1.0) if std else (0.0, 1.0))
    cfg = network.AdamConfig(hidden=tuple(hiddens[0]), max_iter=epochs, seed=seed)
    nets = network.train_lockstep([s.transform(x) for s, x in zip(scalers, xs)],
                          [(np.asarray(y, float) - mu) / sd for y, (mu, sd) in zip(ys, shift)], cfg, hiddens)
    for net, (mu, sd) in zip(nets, shift):
        net.coefs_[-1] = net.coefs_[-1] * sd
        net.intercepts_[-1] = net.intercepts_[-1] * sd + mu
    return list(zip(scalers, nets))


def fit_network(x, y, hidden: tuple, epochs: int, seed: int, standardise_target: bool = False):
    """One network (fit_networks); returns (Scaler, Network)."""
    return fit_networks([x], [y], [hidden], epochs, seed, [standardise_target])[0]


def _job(keys, xs, ys, hiddens, epochs, seed, standardise):
    t0 = time.perf_counter()
    out = fit_networks(xs, ys, hiddens, epochs, seed, standardise)
    return keys, out, time.perf_counter() - t0


class Trainer:
    """Runs the trainings on `workers` processes (they share the cores): the networks of
    one architecture and input width train in lockstep as one job, the jobs largest
    first. Results by key; a line on stderr as each job finishes."""

    def __init__(self, workers: int, progress: bool):
        self.pool = cf.ProcessPoolExecutor(max_workers=max(1, workers), initializer=interrupt.worker_init) \
            if workers > 1 else None
        self.futures = {}
        self.done = {}
        self.jobs = 0
        self.finished = 0
        self.progress = progress
        self.t0 = time.perf_counter()
        self.lock = threading.Lock()

    def submit_all(self, jobs, epochs: int, seed: int, first=()):
        """jobs: (key, x, y, hidden, standardise) each. The networks of one architecture
        train in lockstep as one job whatever their inputs; the architectures with a
        single network each, the same number of layers and no layer wider than
        LOCKSTEP_PAD_MAX also share one job (padded to the widest). Jobs holding a key
        of `first` start first (their results are needed early), then the largest."""
        by_arch = {}
        for key, x, y, hidden, std in jobs:
            by_arch.setdefault(tuple(hidden), []).append((key, x, y, tuple(hidden), std))
        groups = {}
        for hidden, members in by_arch.items():
            pad = len(members) == 1 and max(hidden) <= LOCKSTEP_PAD_MAX
            groups.setdefault(("padded", len(hidden)) if pad else hidden, []).extend(members)
        work = lambda g: (max(param_count(j[3], np.shape(j[1])[1]) for j in g) * max(len(j[1]) for j in g)
                          * np.sqrt(len(g)))
        order = sorted(groups.values(), key=lambda g: (not any(j[0] in first for j in g), -work(g)))
        self.jobs = len(order)
        for members in order:
            keys = [j[0] for j in members]
            args = (keys, [np.asarray(j[1], float) for j in members], [np.asarray(j[2], float) for j in members],
                    [j[3] for j in members], epochs, seed, [j[4] for j in members])
            if self.pool is None:
                res = _job(*args)
                self._say(res)
                self.done.update(zip(res[0], res[1]))
                continue
            fut = self.pool.submit(_job, *args)
            for k in keys:
                self.futures[k] = fut
            fut.add_done_callback(lambda f: f.exception() is None and self._say(f.result()))

    def _say(self, result):
        keys, _, dt = result
        with self.lock:
            self.finished += 1
            if self.progress:
                what = ", ".join(f"{k[0]} {k[1]} {k[2]}" for k in keys)
                print(f"[{time.perf_counter() - self.t0:6.1f} s] trained {len(keys)} networks ({what}) in "
                      f"{dt:.1f} s, job {self.finished}/{self.jobs}", file=sys.stderr, flush=True)

    def get(self, key):
        if key not in self.done:
            keys, out, _ = self.futures[key].result()
            self.done.update(zip(keys, out))
        return self.done[key]

    def close(self):
        if self.pool:
            self.pool.shutdown(cancel_futures=True)
