"""The paper's comparison as one command (hpddo compare, docs/compare.md).

    hpddo compare LOG... --out DIR [--validation LOG...] [--effects NAME,...] [--quick]

On any set of labelled recordings, every method sees V and I (and temp_C where it uses
it) at run time and is identified, trained and tuned on the training rows only:

* M1 (nameplate), M2 (identified Ke; and with named effects, --effects), M3 (the
  residual network, clamp and envelope) and M3 with the novelty gate: the board observer,
  replayed natively (host/replay.cpp) on the chronological split and the never-seen
  recordings; elsewhere its rules in float64 (train.correction), which agree with the
  replay to the figure the tables show (the agreement is measured and written);
* the EKF and the sliding-mode observer (host/compare/observers.h), friction identified
  by steady-state torque balance and their parameters grid-tuned on the training rows,
  which are the only rows the tuner is given (a log of them alone);
* the pure network: M3's architecture and training, mapping (V, I, I(t-1), V(t-1)) to
  speed, replayed in float32 by the same native tool;
* the lookup baseline (mean training speed of the nearest training operating point).

Tables (each a JSON file and a table of OUT/report/index.html, with the paper's figures
beside ours): 7, RMSE per condition for every method, chronological and never seen
(--validation recordings, and leave one recording out); 8, shuffled 5-fold
cross-validation against the chronological split; 9, the architecture ablation; 10,
the feature ablation; ood, the out-of-distribution stress test of section 4.10 with the
eq. 26 bound checked on every sample.

The networks are trained as network.train trains M3 (the same initialisation, epochs,
batches, gradients and Adam steps), several of one architecture in lockstep with BLAS
matrix products (train_lockstep): network.py fixes its order of summation so that a
committed model header is the same bytes everywhere, and pays Python's cost once per
step and network; a comparison of 25 networks needs the speed more than the bytes. The
figures therefore move in their last digits with the CPU and the BLAS kernel
(docs/compare.md gives the tolerance).
"""
from __future__ import annotations

import atexit
import concurrent.futures as cf
import dataclasses
import json
import os
import pathlib
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

from ..evaluation import baseline, replay
from ..logs import dataset, outdir
from ..model import export, identify, network
from .. import interrupt, resource_root
from ..model import gate as gate_mod
from ..evaluation import metrics as metrics_mod
from ..model import physics as ph
from ..model import train as train_mod
from ..logs.errors import InputError

TOOL = "compare"
SOURCE = resource_root() / "host" / "compare"

#: The architectures of Table 9, as in the paper.
ARCHITECTURES = ((8,), (16,), (32,), (64,), (16, 8), (32, 16), (64, 32), (128, 64))
QUICK_ARCHITECTURES = ((8,), (16, 8))
QUICK_EPOCHS = 60   # --quick: epochs of every network (the full comparison: 2000, Table 2)
CV_FOLDS = 5
LOCKSTEP_PAD_MAX = 64  # single networks with no layer wider train padded together (Trainer)
#: Feature sets of Table 10: columns of train.FEATURES [V, I, n_M2, I(t-1), n_M2(t-1)].
FEATURE_SETS = {"full": (0, 1, 2, 3, 4), "without lags": (0, 1, 2), "without physics feature n_M2": (0, 1, 3, 4)}
NN_FEATURES = ["v_V", "i_A", "i_A_lag1", "v_V_lag1"]
EQ26_TOLERANCE_RPM = 1e-3  # float32 rounding of the board's sums (a few ulp of a speed of hundreds of RPM)

#: The paper's figures (RPM), quoted beside ours; not measured here.
PAPER = {
    "table7": {"M1": {"sweep": 114.46, "load": 473.80, "long": 449.74, "average": 346.00},
               "M2": {"sweep": 4.57, "load": 9.57, "long": 7.62, "average": 7.25},
               "EKF": {"sweep": 13.30, "load": 8.88, "long": 6.29, "average": 9.49},
               "SMO": {"sweep": 13.55, "load": 10.24, "long": 8.88, "average": 10.89},
               "pure NN": {"sweep": 12.88, "load": 3.82, "long": 4.73, "average": 7.14},
               "M3": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11}},
    "table8": {"shuffled 5-fold CV": {"sweep": 6.10, "load": 5.84, "long": 4.85, "average": 5.60},
               "chronological 80/20": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11}},
    "table9": {"(8)": [57, 0.2, 5.82, 4.23, 4.62, 4.89], "(16)": [113, 0.4, 4.36, 4.01, 4.62, 4.33],
               "(32)": [225, 0.9, 4.69, 3.94, 4.62, 4.42], "(64)": [449, 1.8, 4.19, 3.83, 4.62, 4.21],
               "(16, 8)": [241, 0.9, 3.88, 3.84, 4.62, 4.11], "(32, 16)": [737, 2.9, 4.90, 3.92, 4.62, 4.48],
               "(64, 32)": [2497, 9.8, 4.24, 3.87, 4.62, 4.24], "(128, 64)": [9089, 35.5, 4.19, 3.51, 4.63, 4.11]},
    "table9_columns": ["params", "memory_kB", "sweep", "load", "long", "average"],
    "table10": {"full": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11},
                "without lags": {"sweep": 4.30, "load": 4.29, "long": 4.61, "average": 4.40},
                "without physics feature n_M2": {"sweep": 7.53, "load": 3.94, "long": 4.64, "average": 5.37}},
    "ood": {"M2 (physics only)": {"sweep": 9.81},
            "unconstrained": {"sweep": 13.95, "load": 5.76, "long": 5.02, "average": 8.24},
            "clamped": {"sweep": 10.32, "average": 7.08}, "clamp_rpm": 20.9, "clamped_share_average": 0.045},
}


@dataclasses.dataclass
class CompareConfig:
    hidden: tuple = (16, 8)
    effects: tuple = ()
    ra_ohm: float | None = None
    seed: int = 1
    quick: bool = False
    workers: int = 2
    glitch_filter: bool = True
    progress: bool = True
    command: str = "hpddo compare"
    epochs_given: int | None = None  # --epochs; None: QUICK_EPOCHS with --quick, else network's default

    @property
    def epochs(self) -> int:
        if self.epochs_given is not None:
            return self.epochs_given
        return QUICK_EPOCHS if self.quick else network.AdamConfig.max_iter

    @property
    def architectures(self) -> tuple:
        archs = QUICK_ARCHITECTURES if self.quick else ARCHITECTURES
        return archs if tuple(self.hidden) in archs else archs + (tuple(self.hidden),)


# ---------------------------------------------------------------------------------------
# Training, in worker processes (BLAS products, one thread each)

def train_lockstep(zs: list, ys: list, cfg: network.AdamConfig, hiddens: list | None = None) -> list:
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
    zero), so the padding changes nothing but the cost. Returns one Network per (z, y)."""
    K = len(zs)
    zs = [np.asarray(z, float) for z in zs]
    ys = [np.asarray(y, float).reshape(-1) for y in ys]
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
        vec, flat = network.init_network(sz[0], tuple(sz[1:-1]), rng)
        ws, bs = flat.views(vec)
        for l in range(L):
            W[l][k, : sz[l], : sz[l + 1]] = ws[l]
            b[l][k, : sz[l + 1]] = bs[l]
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
                shuffled[k] = (zs[k][order], ys[k][order])
            lo = j * B
            zb, yb = shuffled[k][0][lo: lo + B], shuffled[k][1][lo: lo + B]
            c = len(zb)
            X[k, :c, : sizes[k][0]] = zb
            Y[k, :c, 0] = yb
            mask[k, :c] = 1.0
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
        b1_t *= network.ADAM_BETA1
        b2_t *= network.ADAM_BETA2
        lr_t = cfg.learning_rate * np.sqrt(1.0 - b2_t) / (1.0 - b1_t)
        for a, g, mm, vv in zip(params, grads_w + grads_b, m, v):
            mm *= network.ADAM_BETA1
            mm += (1.0 - network.ADAM_BETA1) * g
            vv *= network.ADAM_BETA2
            vv += (1.0 - network.ADAM_BETA2) * (g * g)
            a -= lr_t * mm / (np.sqrt(vv) + network.ADAM_EPS)
        for k in np.flatnonzero(total == t + 1):
            sz = sizes[k]
            result[k] = network.Network(coefs_=[W[l][k, : sz[l], : sz[l + 1]].copy() for l in range(L)],
                                        intercepts_=[b[l][k, : sz[l + 1]].copy() for l in range(L)])
    return result


def fit_networks(xs: list, ys: list, hiddens: list, epochs: int, seed: int, standardise: list) -> list:
    """Networks trained as M3's (network.AdamConfig: Adam 1e-3, batch 200, L2 1e-4, Glorot,
    no early stop) on rows xs[k], targets ys[k], in lockstep (train_lockstep). Where
    standardise[k], the target is standardised for training and the output layer
    rescaled after, so the network maps to y's units directly. Returns [(Scaler, Network)]."""
    scalers = [network.Scaler.fit(x) for x in xs]
    shift = []
    for y, std in zip(ys, standardise):
        y = np.asarray(y, float)
        shift.append((float(y.mean()), float(y.std()) or 1.0) if std else (0.0, 1.0))
    cfg = network.AdamConfig(hidden=tuple(hiddens[0]), max_iter=epochs, seed=seed)
    nets = train_lockstep([s.transform(x) for s, x in zip(scalers, xs)],
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


# ---------------------------------------------------------------------------------------
# The native competitors (host/compare)

_build_lock = threading.Lock()
_exe: pathlib.Path | None = None


def observers_exe() -> pathlib.Path:
    """compare_observers, built once per process with CMake (removed at exit)."""
    global _exe
    with _build_lock:
        if _exe is None:
            if shutil.which("cmake") is None:
                raise replay.ToolchainError("cmake not found, needed to build the observers of hpddo compare: "
                                            f"{replay.INSTALL}")
            d = pathlib.Path(tempfile.mkdtemp(prefix="hpddo-compare-"))
            pid = os.getpid()
            atexit.register(lambda: os.getpid() == pid and shutil.rmtree(d, ignore_errors=True))
            replay._cmake(["-S", str(SOURCE), "-B", str(d)], "configuring the observers of hpddo compare")
            replay._cmake(["--build", str(d)], "building the observers of hpddo compare")
            _exe = d / "compare_observers"
    return _exe


def training_log(rec: dataset.Recording, path: pathlib.Path) -> pathlib.Path:
    """The training rows of rec alone as a bench log: all the tuner is given."""
    part = dataclasses.replace(rec, df=rec.df.iloc[: rec.n_train].reset_index(drop=True))
    part = dataclasses.replace(part, n_train=part.n)
    meta = dict(rec.meta)
    meta["condition"] = rec.name
    meta["note"] = f"training rows 0..{rec.n_train - 1} of {rec.source.name} (cleaned), for tuning"
    meta["split_row"] = str(part.n)
    from ..logs import benchlog
    return benchlog.write_log(path, part.df, meta)


def tune_observers(jobs: dict, work: pathlib.Path, coarse: bool = False) -> dict:
    """Friction and the EKF's and SMO's parameters for each job {name: (train_recs, m2)},
    tuned on the training rows of train_recs only: each recording's training part is
    written to work/<name>/ as a log of its own, and that is all the tuner reads. The
    tuners run as parallel processes. Returns {name: the tuner's JSON}."""
    procs = {}
    for name, (train_recs, m2) in jobs.items():
        d = work / dataset.safe_name(name)
        d.mkdir(parents=True, exist_ok=True)
        logs = [training_log(r, d / f"{r.file_stem}.train.csv") for r in train_recs if r.n_train > 1]
        procs[name] = subprocess.Popen([str(observers_exe()), "tune", "--ke", repr(m2.ke_vs_per_rad), "--ra",
                                        repr(m2.ra_ohm), *(["--coarse"] if coarse else []), *map(str, logs)], stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, text=True)
    out = {}
    for name, pr in procs.items():
        stdout, stderr = pr.communicate()
        if pr.returncode != 0:
            raise InputError(f"tuning the observers ({name}) failed: {stderr.strip()}")
        out[name] = json.loads(stdout)
    return out


def write_mlp(scaler: network.Scaler, net: network.Network, path: pathlib.Path) -> pathlib.Path:
    """The pure network for compare_observers (its read_mlp), floats to 9 digits."""
    sizes = [len(scaler.mean_)] + [w.shape[1] for w in net.coefs_]
    f = lambda a: " ".join(f"{v:.9g}" for v in np.asarray(a, float).ravel())
    lines = [f"hpddo-mlp 1 {len(sizes)}", " ".join(map(str, sizes)), f(scaler.mean_), f(scaler.scale_)]
    for w, b in zip(net.coefs_, net.intercepts_):
        lines += [f(np.asarray(w).T), f(b)]
    path.write_text("\n".join(lines) + "\n")
    return path


def run_observers(tuned: dict, recs, work: pathlib.Path, mlp: pathlib.Path | None) -> list:
    """EKF, SMO and pure network estimates (rpm) of every row of recs: [{method: array}]."""
    import pandas as pd
    (work / "logs").mkdir(parents=True, exist_ok=True)
    (work / "estimates").mkdir(parents=True, exist_ok=True)
    logs = [dataset.write_clean(r, work / "logs" / f"{r.file_stem}.csv") for r in recs]
    m, e, s = tuned["motor"], tuned["ekf"], tuned["smo"]
    j = lambda *v: ",".join(repr(float(x)) for x in v)
    cmd = [str(observers_exe()), "run", "--motor", j(m["ke_vs_per_rad"], m["ra_ohm"], m["b_nms_per_rad"], m["tc_nm"]),
           "--ekf", j(e["j_kgm2"], e["q_w"], e["q_t"], e["r_A2"]), "--smo", j(s["k_V"], s["phi_A"], s["tau_s"]),
           "--out-dir", str(work / "estimates")]
    if mlp is not None:
        cmd += ["--mlp", str(mlp)]
    res = subprocess.run(cmd + [str(p) for p in logs], capture_output=True, text=True)
    if res.returncode != 0:
        raise InputError(f"replaying the observers failed: {res.stderr.strip()}")
    out = []
    for r, p in zip(recs, logs):
        df = pd.read_csv(work / "estimates" / f"{p.stem}.observers.csv")
        if len(df) != r.n:
            raise RuntimeError(f"compare_observers wrote {len(df)} rows for {r.n} of {r.name}")
        out.append({"EKF": df["rpm_ekf"].to_numpy(float), "SMO": df["rpm_smo"].to_numpy(float),
                    "pure NN": df["rpm_nn"].to_numpy(float)})
    return out


# ---------------------------------------------------------------------------------------
# M1, M2, M3 and their features

def nn_features(rec: dataset.Recording) -> np.ndarray:
    """(V, I, I(t-1), V(t-1)) of every row, lags restarting as the observer's."""
    starts = dataset.segment_starts(rec)
    v, i = rec.df["v_V"].to_numpy(float), rec.df["i_A"].to_numpy(float)
    return np.column_stack([v, i, dataset.lagged(i, starts), dataset.lagged(v, starts)])


def reference(rec: dataset.Recording) -> np.ndarray:
    return rec.df["rpm_ref"].to_numpy(float) if "rpm_ref" in rec.df else np.full(rec.n, np.nan)


def stack_rows(recs, fn, rows="train"):
    """fn(rec) -> (x, y) for every row; the labelled finite rows of the chosen part, stacked."""
    xs, ys = [], []
    for r in recs:
        x, y = fn(r)
        sel = slice(0, r.n_train) if rows == "train" else slice(None)
        x, y = x[sel], y[sel]
        keep = np.isfinite(y) & np.isfinite(x).all(axis=1)
        xs.append(x[keep])
        ys.append(y[keep])
    return np.concatenate(xs), np.concatenate(ys)


@dataclasses.dataclass
class Fitted:
    """A trained residual network on feature columns `cols` with its safeguards."""

    cols: tuple
    scaler: network.Scaler
    mlp: network.Network
    clamp_rpm: float
    env_lo: np.ndarray
    env_hi: np.ndarray
    gate: gate_mod.GateData | None = None
    n_train: int = 0

    def residual(self, cols5: np.ndarray) -> tuple:
        """(raw network output, inside the envelope) per row of the 5-feature matrix."""
        x = np.asarray(cols5, float)[:, list(self.cols)]
        finite = np.isfinite(x).all(axis=1)
        r = np.zeros(len(x))
        if finite.any():
            r[finite] = self.mlp.predict(self.scaler.transform(x[finite]))
        inside = finite & np.all((x >= self.env_lo) & (x <= self.env_hi), axis=1)
        return r, inside

    def as_residual(self, gated: bool) -> train_mod.Residual:
        """The train.Residual of this network (5 features), gated or with an open gate."""
        return train_mod.Residual(scaler=self.scaler, mlp=self.mlp, clamp_rpm=self.clamp_rpm, env_lo=self.env_lo,
                                  env_hi=self.env_hi, gate=self.gate if gated else gate_mod.open_gate(5),
                                  n_train=self.n_train, loss_curve=[])


def finish_fit(cols, fitted, x_train: np.ndarray, e_train: np.ndarray, gate: bool = False) -> Fitted:
    """The safeguards of train.train_residual around a trained network: clamp at the 99th
    percentile of |e|, the envelope widened by 10 %, the novelty gate where asked."""
    scaler, mlp = fitted
    x = x_train[:, list(cols)]
    lo, hi = x.min(axis=0), x.max(axis=0)
    span = np.maximum(hi - lo, 1e-6)
    return Fitted(cols=tuple(cols), scaler=scaler, mlp=mlp,
                  clamp_rpm=float(np.percentile(np.abs(e_train), train_mod.CLAMP_PERCENTILE)),
                  env_lo=lo - train_mod.ENVELOPE_MARGIN * span, env_hi=hi + train_mod.ENVELOPE_MARGIN * span,
                  gate=gate_mod.fit(x_train) if gate else None, n_train=len(x))


def m3_variants(fit: Fitted, x5: np.ndarray, n2: np.ndarray) -> dict:
    """The M3 estimates of section 4.10 for every row (float64, the observer's rules):
    unconstrained n2 + r; clamped; clamped with the envelope fallback; and with the gate
    too (when fitted). Plus the raw residual, the inside-envelope mask and gate weight."""
    r, inside = fit.residual(x5)
    c = np.clip(r, -fit.clamp_rpm, fit.clamp_rpm)
    out = {"unconstrained": n2 + r, "clamped": n2 + c, "clamped + fallback": n2 + np.where(inside, c, 0.0),
           "r": r, "inside": inside}
    if fit.gate is not None:
        w = np.zeros(len(x5))
        if inside.any():
            w[inside] = gate_mod.weight(fit.gate, x5[inside])
        out["clamped + fallback + gate"] = n2 + np.where(inside, w * c, 0.0)
        out["w"] = w
    return out


def rmse_table(recs, estimates: list, masks=None) -> dict:
    """{method: {condition: rmse, "average": mean over conditions}} pooled per condition,
    over the rows of each mask (default every row) with an encoder reading."""
    per = {}
    for k, (r, est) in enumerate(zip(recs, estimates)):
        ref = reference(r)
        mask = np.ones(r.n, bool) if masks is None else masks[k]
        for m, v in est.items():
            per.setdefault(m, {}).setdefault(r.name, []).append((np.asarray(v, float) - ref)[mask])
    out = {}
    for m, conds in per.items():
        vals = {c: metrics_mod.rmse(np.concatenate(e)) for c, e in conds.items()}
        out[m] = {**{c: metrics_mod.figure(v) for c, v in vals.items()},
                  "average": metrics_mod.figure(float(np.mean(list(vals.values()))))}
    return out


EQ26_FLOAT64_TOLERANCE_RPM = 1e-9  # float64 rounding where the clamp is reached exactly (~1e-14 RPM)


def eq26(n3: np.ndarray, n2: np.ndarray, ref: np.ndarray, clamp: float, tol: float = EQ26_FLOAT64_TOLERANCE_RPM) -> dict:
    """Eq. 26, |n_M3 - n| <= |n_M2 - n| + clamp, on every labelled sample: the samples
    checked, the violations and the largest excess (RPM)."""
    ok = np.isfinite(ref) & np.isfinite(n3) & np.isfinite(n2)
    excess = np.abs(n3[ok] - ref[ok]) - (np.abs(n2[ok] - ref[ok]) + clamp)
    return {"samples": int(ok.sum()), "violations": int(np.sum(excess > tol)),
            "largest_excess_rpm": metrics_mod.figure(float(excess.max())) if ok.any() else None,
            "clamp_rpm": metrics_mod.figure(clamp), "tolerance_rpm": tol}


def param_count(hidden, n_in: int = 5) -> int:
    sizes = (n_in, *hidden, 1)
    return int(sum(a * b + b for a, b in zip(sizes[:-1], sizes[1:])))


def label(hidden) -> str:
    return "(" + ", ".join(map(str, hidden)) + ")"


# ---------------------------------------------------------------------------------------
# The comparison

@dataclasses.dataclass
class Comparison:
    tables: dict
    out: pathlib.Path
    seconds: float


def _m2(recs, ra):
    return identify.m2_params(recs, ra)


def _x_e(recs, p, rows="train"):
    """5 features and residual e = rpm_ref - n_M2 of the training (or all) rows."""
    def fn(r):
        x, n2 = train_mod.features(r, p)
        return x, reference(r) - n2
    return stack_rows(recs, fn, rows)


def _physics(rec, p):
    return train_mod.physics_rpm(rec, p)


def run(log_paths, out_dir, cfg: CompareConfig, validation_paths=()) -> Comparison:
    """The whole comparison into out_dir (outdir policy: new, empty or a previous output of
    hpddo compare); raises the usual user errors before writing anything."""
    t0 = time.perf_counter()
    outdir.check(out_dir, TOOL)
    if len(log_paths) < 2:
        raise InputError("hpddo compare needs at least two labelled recordings (leave one recording out, "
                         "and the out-of-distribution test, train on some and test on the others)")
    recs = dataset.load_recordings(log_paths, dataset.TRAIN_FRACTION, cfg.glitch_filter)
    for r in recs:
        if not np.isfinite(reference(r)).any():
            raise InputError(f"{r.source}: no encoder readings (rpm_ref): hpddo compare needs labelled recordings")
    whole = dataset.load_recordings(log_paths, 0.0, cfg.glitch_filter)   # every row a test row
    vrecs = dataset.load_recordings(validation_paths, 0.0, cfg.glitch_filter) if validation_paths else []
    ra, _ = identify.ra_from_logs(recs, cfg.ra_ohm)
    m1 = ph.nameplate_params(ra)
    m2 = _m2(recs, ra)
    m2e = None
    if cfg.effects:
        from ..model import effects
        m2e = effects.identify(recs, m2, cfg.effects)
    say = (lambda s: print(f"[{time.perf_counter() - t0:6.1f} s] {s}", file=sys.stderr, flush=True)) \
        if cfg.progress else (lambda s: None)
    h, ep, seed = tuple(cfg.hidden), cfg.epochs, cfg.seed
    trainer = Trainer(cfg.workers, cfg.progress)
    try:
        with outdir.staged(pathlib.Path(out_dir), TOOL) as stage:
            work = stage / "work"
            # ---- every training, submitted at once (the longest first)
            x_tr, e_tr = _x_e(recs, m2)
            xn_tr, y_tr = stack_rows(recs, lambda r: (nn_features(r), reference(r)))
            jobs = []
            for hh in sorted(cfg.architectures, key=param_count, reverse=True):
                jobs.append((("M3", label(hh), "chronological"), x_tr, e_tr, hh, False))
            jobs.append((("pure NN", label(h), "chronological"), xn_tr, y_tr, h, True))
            for name, cols in FEATURE_SETS.items():
                if name != "full":
                    jobs.append((("M3", label(h), name), x_tr[:, list(cols)], e_tr, h, False))
            loro = {}
            for k, held in enumerate(recs):
                others = recs[:k] + recs[k + 1:]
                p = _m2(others, ra)
                xo, eo = _x_e(others, p)
                xno, yo = stack_rows(others, lambda r: (nn_features(r), reference(r)))
                loro[held.name] = (others, p, xo, eo)
                jobs.append((("M3", label(h), f"leave out {held.name}"), xo, eo, h, False))
                jobs.append((("pure NN", label(h), f"leave out {held.name}"), xno, yo, h, True))
            cv = cv_folds(recs, ra, seed)
            for k, fold in enumerate(cv["folds"]):
                jobs.append((("M3", label(h), f"CV fold {k + 1}"), fold["x"], fold["e"], h, False))
            ood = {}
            for r in recs:
                p = _m2([r], ra)
                xo, eo = _x_e([r], p)
                ood[r.name] = (p, xo, eo)
                jobs.append((("M3", label(h), f"trained on {r.name} only"), xo, eo, h, False))
            trainer.submit_all(jobs, ep, seed, first=[("M3", label(h), "chronological"),
                                                      ("pure NN", label(h), "chronological")])
            say(f"{len(jobs)} networks in {trainer.jobs} jobs on {cfg.workers} worker(s), {ep} epochs each; "
                "building and tuning the observers")

            # ---- three threads: the observers build and tune; the board observer is built
            # against the chronological M3 with and without the gate and replayed (the
            # networks train meanwhile in their processes)
            def observers():
                jobs_ = {"chronological": (recs, m2)}
                jobs_.update({f"leave out {name}": (v[0], v[1]) for name, v in loro.items()})
                observers_exe()
                t = tune_observers(jobs_, work / "tuning", coarse=cfg.quick)
                say(f"observers tuned: EKF train RMSE {t['chronological']['train_rmse_rpm']['ekf']:.2f}, SMO "
                    f"{t['chronological']['train_rmse_rpm']['smo']:.2f} RPM (M2 "
                    f"{t['chronological']['train_rmse_rpm']['m2']:.2f})")
                return t

            chrono_fit = {}
            fit_lock = threading.Lock()

            def chrono():
                with fit_lock:
                    if not chrono_fit:
                        chrono_fit["fit"] = finish_fit(range(5), trainer.get(("M3", label(h), "chronological")),
                                                       x_tr, e_tr, gate=True)
                return chrono_fit["fit"]

            with cf.ThreadPoolExecutor(max_workers=3) as threads:
                fut_obs = threads.submit(observers)
                native = (True,) if cfg.quick else (True, False)
                fut_nat = {g: threads.submit(lambda g=g: replay_m3(recs, vrecs, m1, m2, chrono(), g, work, cfg))
                           for g in native}
                tuned_all = fut_obs.result()
                replays = {k: v for g in native for k, v in fut_nat[g].result().items()}
            fit = chrono()
            tuned = tuned_all.pop("chronological")
            tuned_loro = {k[len("leave out "):]: v for k, v in tuned_all.items()}
            say("native replays of M3 done")

            # ---- Table 7: chronological and never seen
            nn = trainer.get(("pure NN", label(h), "chronological"))
            mlp_file = write_mlp(nn[0], nn[1], (work / "pure_nn_chronological.mlp"))
            table7, native = table7_chrono_and_validation(recs, vrecs, m2, m2e, fit, replays, tuned, mlp_file, work)
            table7["leave_one_out"] = table7_loro(whole, loro, tuned_loro, trainer, m1, m2e, cfg, work, ra)
            table7["tuned"] = {"chronological": tuned, "leave_one_out": tuned_loro}
            table7["checks"] = native

            # ---- Table 8, 9, 10, ood
            table8 = make_table8(recs, cv, trainer, fit, m2, cfg)
            table9 = make_table9(recs, trainer, m2, x_tr, e_tr, cfg)
            table10 = make_table10(recs, trainer, m2, x_tr, e_tr, cfg)
            tood = make_ood(recs, whole, ood, trainer, cfg)
            tables = {"table7": table7, "table8": table8, "table9": table9, "table10": table10, "ood": tood}
            for t in tables.values():
                t["command"] = cfg.command
                t["settings"] = settings(cfg, recs, vrecs)
            for name, t in tables.items():
                (stage / f"{name}.json").write_text(json.dumps(t, indent=1) + "\n")
            seconds = time.perf_counter() - t0
            from ..reports import compare as report
            report.write(tables, stage / "report", cfg.command, seconds)
            (stage / "summary.txt").write_text(text_summary(tables) + f"\nfinished in {seconds:.1f} s\n")
    finally:
        trainer.close()
    return Comparison(tables, pathlib.Path(out_dir), time.perf_counter() - t0)


def settings(cfg: CompareConfig, recs, vrecs) -> dict:
    return {"hidden": list(cfg.hidden), "epochs": cfg.epochs, "seed": cfg.seed, "quick": cfg.quick,
            "effects": list(cfg.effects), "recordings": [r.source.name for r in recs],
            "validation": [r.source.name for r in vrecs], "train_fraction": dataset.TRAIN_FRACTION,
            "training": "network.train's algorithm (Adam 1e-3, batch 200, L2 1e-4, Glorot, no early stop), "
                        "in lockstep with BLAS products (compare.train_lockstep)"}


def replay_m3(recs, vrecs, m1, m2, fit: Fitted, gated: bool, work, cfg) -> dict:
    """The board observer, compiled against the chronological M3 with (or without) the
    gate, replayed on the chronological split and the never-seen recordings:
    {(model, part): [estimates DataFrame per recording]}."""
    from ..pipeline import model_data
    name = "M3 gated" if gated else "M3"
    model = model_data(m1, m2, fit.as_residual(gated))
    mname = "compare_gated" if gated else "compare_nogate"
    mdir = work / "models" / mname
    mdir.mkdir(parents=True, exist_ok=True)
    (mdir / f"model_{mname}.h").write_text(export.model_header(model, mname, {
        "command": cfg.command, "seed": cfg.seed, "note": "hpddo compare, chronological training part"}))
    rdir = work / "replay" / mname
    exe = replay.build(mdir, mname, rdir / "replay")
    out = {}
    for part, rs, split in (("chronological", recs, None), ("validation", vrecs, 0.0)):
        d = rdir / part
        (d / "logs").mkdir(parents=True, exist_ok=True)
        (d / "estimates").mkdir(parents=True, exist_ok=True)
        clean = [dataset.write_clean(r, d / "logs" / f"{r.file_stem}.csv") for r in rs]
        out[(name, part)] = replay.run(exe, clean, d / "estimates", split) if rs else []
    return out


def table7_chrono_and_validation(recs, vrecs, m2, m2e, fit: Fitted, replays: dict, tuned, mlp_file, work):
    """Chronological test parts and never-seen recordings: M1, M2, M3 (with and without
    the gate) by the native replay of the board observer, the rest as documented."""
    est = {"chronological": [dict() for _ in recs], "validation": [dict() for _ in vrecs]}
    native_check = {}
    float64_only = []
    for name in ("M3 gated", "M3"):
        gated = name == "M3 gated"
        for part, rs in (("chronological", recs), ("validation", vrecs)):
            if (name, part) not in replays:  # --quick: one native model, the other by the float64 rules
                float64_only.append(name)
                for k, r in enumerate(rs):
                    x, n2 = train_mod.features(r, m2)
                    est[part][k][name] = n2 + train_mod.correction(fit.as_residual(gated), x)[0]
                continue
            for k, (r, f) in enumerate(zip(rs, replays[(name, part)])):
                e = est[part][k]
                e[name] = f["rpm_m3"].to_numpy(float)
                e["M1"], e["M2"] = f["rpm_m1"].to_numpy(float), f["rpm_m2"].to_numpy(float)
                # the float64 rules used elsewhere, against the board's float32
                x, n2 = train_mod.features(r, m2)
                py = n2 + train_mod.correction(fit.as_residual(gated), x)[0]
                d = np.abs(py - e[name])
                native_check.setdefault(f"{name}: largest |float64 rules - native replay| (RPM)", []).append(
                    float(np.nanmax(d)) if np.isfinite(d).any() else 0.0)
                ref = reference(r)
                mask = np.arange(r.n) >= r.n_train
                chk = eq26(e[name][mask], e["M2"][mask], ref[mask], fit.clamp_rpm, EQ26_TOLERANCE_RPM)
                native_check.setdefault(f"eq. 26 on the native {name}", []).append(chk)
    for key in list(native_check):
        v = native_check[key]
        if isinstance(v[0], float):
            native_check[key] = metrics_mod.figure(max(v))
        else:
            native_check[key] = {"samples": sum(c["samples"] for c in v), "violations": sum(c["violations"] for c in v),
                                 "clamp_rpm": v[0]["clamp_rpm"], "tolerance_rpm": EQ26_TOLERANCE_RPM}
    lookup = baseline.Lookup.fit(recs)
    for part, rs in (("chronological", recs), ("validation", vrecs)):
        obs = run_observers(tuned, rs, work / "observers" / part, mlp_file) if rs else []
        for k, r in enumerate(rs):
            e = est[part][k]
            if m2e is not None:
                e["M2 + effects"] = _physics(r, m2e)
            e.update(obs[k])
            e["lookup"] = lookup.predict_rows(r)
    out = {"title": "Table 7: RMSE (RPM) of every method",
           "methods": method_order(m2e is not None),
           "chronological": {"what": "the held-out chronological 20 % of each recording (the paper's Table 7)",
                             "rmse_rpm": order(rmse_table(recs, est["chronological"],
                                                          [np.arange(r.n) >= r.n_train for r in recs]),
                                               m2e is not None)},
           "paper": PAPER["table7"],
           "sources": {"M1, M2, " + ("M3 gated" if float64_only else "M3, M3 gated"):
                       "native replay of the board observer (host/replay.cpp), float32",
                       **({"M3": "--quick: the observer's rules in float64 (train.correction)"} if float64_only else {}),
                       "EKF, SMO, pure NN": "native replay of host/compare (compare_observers): EKF and SMO in "
                                            "double, the network in float32",
                       "M2 + effects": "physics.physics_rpm in float64 with the observer's lag and thermal rules",
                       "lookup": "hpddo.evaluation.baseline.Lookup of the training rows"}}
    if vrecs:
        out["validation"] = {"what": "every row of recordings no training saw (--validation); models of the "
                                     "chronological training part",
                             "rmse_rpm": order(rmse_table(vrecs, est["validation"]), m2e is not None)}
    return out, native_check


def method_order(effects: bool) -> list:
    return ["M1", "M2"] + (["M2 + effects"] if effects else []) + ["EKF", "SMO", "pure NN", "M3", "M3 gated",
                                                                  "lookup"]


def order(t: dict, effects: bool) -> dict:
    return {m: t[m] for m in method_order(effects) if m in t}


def table7_loro(whole, loro, tuned_loro, trainer, m1, m2e, cfg, work, ra) -> dict:
    """Leave one recording out: for each recording, every method identified, trained and
    tuned on the training parts of the others, scored on every row of it (M3 by the
    float64 rules)."""
    h = label(cfg.hidden)
    rmse = {}
    for k, rec in enumerate(whole):
        others, p, xo, eo = loro[rec.name]
        fit = finish_fit(range(5), trainer.get(("M3", h, f"leave out {rec.name}")), xo, eo, gate=True)
        nn = trainer.get(("pure NN", h, f"leave out {rec.name}"))
        sub = work / "leave_one_out" / dataset.safe_name(rec.name)
        sub.mkdir(parents=True, exist_ok=True)
        obs = run_observers(tuned_loro[rec.name], [rec], sub, write_mlp(nn[0], nn[1], sub / "pure_nn.mlp"))[0]
        x, n2 = train_mod.features(rec, p)
        v = m3_variants(fit, x, n2)
        est = {"M1": _physics(rec, m1), "M2": n2}
        if m2e is not None:
            from ..model import effects
            est["M2 + effects"] = _physics(rec, effects.identify(others, p, cfg.effects))
        est.update(obs)
        est["M3"] = v["clamped + fallback"]
        est["M3 gated"] = v["clamped + fallback + gate"]
        est["lookup"] = baseline.Lookup.fit(others).predict_rows(rec)
        for m, val in rmse_table([rec], [est]).items():
            rmse.setdefault(m, {})[rec.name] = val[rec.name]
    for m in rmse:
        rmse[m]["average"] = metrics_mod.figure(float(np.mean([v for v in rmse[m].values()])))
    return {"what": "every row of each recording, everything identified, trained and tuned on the training parts "
                    "of the others (M1, M2, M3 by the float64 rules of the observer)",
            "rmse_rpm": order(rmse, m2e is not None)}


def cv_folds(recs, ra, seed: int) -> dict:
    """Shuffled 5-fold cross-validation over every labelled row of every recording (the
    features computed on the whole recordings, lags included, as a shuffled split of a
    feature table does): per fold, Ke (eq. 20) and the network on the other folds."""
    rows = []
    for k, r in enumerate(recs):
        ref = reference(r)
        idx = np.flatnonzero(np.isfinite(ref))
        rows.append(np.column_stack([np.full(len(idx), k), idx]))
    rows = np.concatenate(rows)
    perm = np.random.default_rng(seed).permutation(len(rows))
    fold_of = np.empty(len(rows), int)
    fold_of[perm] = np.arange(len(rows)) % CV_FOLDS
    v = np.concatenate([r.df["v_V"].to_numpy(float) for r in recs])
    folds = []
    offsets = np.cumsum([0] + [r.n for r in recs])
    flat_v = v
    flat_i = np.concatenate([r.df["i_A"].to_numpy(float) for r in recs])
    flat_ref = np.concatenate([reference(r) for r in recs])
    glob = offsets[rows[:, 0]] + rows[:, 1]
    for f in range(CV_FOLDS):
        tr = glob[fold_of != f]
        keep = tr[flat_ref[tr] > identify.MIN_RPM]
        ke = identify.ke_eq20(flat_v[keep], flat_i[keep], flat_ref[keep], ra)
        identify.check_ke(ke, flat_v[keep], flat_i[keep], ra)
        p = ph.PhysicsParams(ra_ohm=ra, ke_vs_per_rad=ke, t_ref_C=identify.reference_temp_C(recs),
                             t_amb_C=identify.reference_temp_C(recs))
        xs, n2s = zip(*[train_mod.features(r, p) for r in recs])
        x, n2 = np.concatenate(xs), np.concatenate(n2s)
        e = flat_ref - n2
        ok = tr[np.isfinite(x[tr]).all(axis=1)]
        folds.append({"p": p, "x": x[ok], "e": e[ok], "test": glob[fold_of == f], "x_all": x, "n2_all": n2})
    return {"folds": folds, "offsets": offsets, "rows": len(rows)}


def make_table8(recs, cv, trainer, fit_chrono: Fitted, m2, cfg) -> dict:
    h = label(cfg.hidden)
    flat_ref = np.concatenate([reference(r) for r in recs])
    est = np.full(len(flat_ref), np.nan)
    for k, fold in enumerate(cv["folds"]):
        fit = finish_fit(range(5), trainer.get(("M3", h, f"CV fold {k + 1}")), fold["x"], fold["e"])
        t = fold["test"]
        est[t] = m3_variants(fit, fold["x_all"][t], fold["n2_all"][t])["clamped + fallback"]
    off = cv["offsets"]
    cv_est = [{"shuffled 5-fold CV": est[off[k]:off[k + 1]]} for k in range(len(recs))]
    cv_rm = rmse_table(recs, cv_est)
    chrono = []
    for r in recs:
        x, n2 = train_mod.features(r, m2)
        chrono.append({"chronological 80/20": m3_variants(fit_chrono, x, n2)["clamped + fallback"]})
    ch_rm = rmse_table(recs, chrono, [np.arange(r.n) >= r.n_train for r in recs])
    return {"title": f"Table 8: M3 {h} RMSE (RPM) under both evaluation protocols",
            "rmse_rpm": {**cv_rm, **ch_rm}, "paper": PAPER["table8"],
            "what": "M3 (clamp and envelope, no gate), float64 rules. CV: every labelled row in 5 shuffled folds, "
                    "Ke and the network fitted on 4, scored on the 5th, pooled per condition; chronological: "
                    "the last 20 % of each recording, trained on the first 80 %"}


def make_table9(recs, trainer, m2, x_tr, e_tr, cfg) -> dict:
    rows = {}
    masks = [np.arange(r.n) >= r.n_train for r in recs]
    feats = [train_mod.features(r, m2) for r in recs]
    for hh in cfg.architectures:
        fit = finish_fit(range(5), trainer.get(("M3", label(hh), "chronological")), x_tr, e_tr)
        est = [{"M3": m3_variants(fit, x, n2)["clamped + fallback"]} for x, n2 in feats]
        rm = rmse_table(recs, est, masks)["M3"]
        n = param_count(hh)
        rows[label(hh)] = {"params": n, "bytes": 4 * n, "memory_kB": round(4 * n / 1024, 1), "rmse_rpm": rm}
    return {"title": "Table 9: architecture ablation, M3 RMSE (RPM) on the chronological test parts",
            "rows": rows, "paper": PAPER["table9"], "paper_columns": PAPER["table9_columns"],
            "what": "M3 (clamp and envelope, no gate), float64 rules; params: weights and biases of the network; "
                    "bytes: 4 per float32 parameter (the network alone, without scaler, envelope or gate)"}


def make_table10(recs, trainer, m2, x_tr, e_tr, cfg) -> dict:
    h = label(cfg.hidden)
    masks = [np.arange(r.n) >= r.n_train for r in recs]
    feats = [train_mod.features(r, m2) for r in recs]
    rows = {}
    for name, cols in FEATURE_SETS.items():
        key = ("M3", h, "chronological") if name == "full" else ("M3", h, name)
        fit = finish_fit(cols, trainer.get(key), x_tr, e_tr)
        est = [{"M3": m3_variants(fit, x, n2)["clamped + fallback"]} for x, n2 in feats]
        rows[name] = {"features": [train_mod.FEATURES[c] for c in cols],
                      "rmse_rpm": rmse_table(recs, est, masks)["M3"]}
    return {"title": f"Table 10: feature ablation with the {h} network, M3 RMSE (RPM)", "rows": rows,
            "paper": PAPER["table10"],
            "what": "M3 (clamp and envelope, no gate), float64 rules, on the chronological test parts; the "
                    "correction is still added to n_M2 in every row"}


def make_ood(recs, whole, ood, trainer, cfg) -> dict:
    """Section 4.10: trained on one recording's training part, tested on every row of each
    other recording; the four safeguard levels, their shares and eq. 26 on every sample."""
    h = label(cfg.hidden)
    runs = {}
    for r in recs:
        p, xo, eo = ood[r.name]
        fit = finish_fit(range(5), trainer.get(("M3", h, f"trained on {r.name} only")), xo, eo, gate=True)
        tests = [w for w in whole if w.name != r.name]
        est, shares, checks = [], {}, {}
        for w in tests:
            x, n2 = train_mod.features(w, p)
            v = m3_variants(fit, x, n2)
            ref = reference(w)
            lab = np.isfinite(ref)
            e = {"M2 (physics only)": n2}
            e.update({k: v[k] for k in ("unconstrained", "clamped", "clamped + fallback", "clamped + fallback + gate")})
            est.append(e)
            shares[w.name] = {"clamped": metrics_mod.figure(float(np.mean(np.abs(v["r"][lab]) > fit.clamp_rpm))),
                              "fallback": metrics_mod.figure(float(np.mean(~v["inside"][lab]))),
                              "gated": metrics_mod.figure(float(np.mean(v["inside"][lab] & (v["w"][lab] < 1))))}
            for k in ("unconstrained", "clamped", "clamped + fallback", "clamped + fallback + gate"):
                checks.setdefault(k, []).append(eq26(v[k], n2, ref, fit.clamp_rpm))
        rm = rmse_table(tests, est)
        eq = {k: {"samples": sum(c["samples"] for c in v), "violations": sum(c["violations"] for c in v),
                  "largest_excess_rpm": max((c["largest_excess_rpm"] for c in v if c["largest_excess_rpm"] is not None),
                                            default=None)}
              for k, v in checks.items()}
        runs[r.name] = {"trained_on": r.name, "train_rows": fit.n_train, "clamp_rpm": metrics_mod.figure(fit.clamp_rpm),
                        "rmse_rpm": rm, "shares": shares, "eq26": eq}
    return {"title": "Section 4.10: out-of-distribution stress test, RMSE (RPM)", "runs": runs,
            "paper": PAPER["ood"],
            "what": "M2 and M3 identified and trained on the training part of one recording, scored on every row "
                    "of each other recording; shares: of the labelled rows, the raw residual beyond the clamp, "
                    "outside the envelope (fallback to M2), inside but faded by the gate; eq26: "
                    "|n_M3 - n| <= |n_M2 - n| + clamp on every labelled sample (float64 rules; the unconstrained "
                    "network has no bound, its count shows what the clamp prevents)"}


# ---------------------------------------------------------------------------------------
# Text

def _cell(x) -> str:
    return metrics_mod.table_cell(x)


def rmse_text(title: str, rm: dict, paper: dict | None = None) -> str:
    conds = [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    lines = [title, f"{'method':<32s}" + "".join(f"{c:>10s}" for c in conds)]
    for m, v in rm.items():
        lines.append(f"{m:<32s}" + "".join(_cell(v.get(c)) for c in conds))
        if paper and m in paper:
            lines.append(f"{'  paper':<32s}" + "".join(_cell(paper[m].get(c)) for c in conds))
    return "\n".join(lines) + "\n"


def text_summary(t: dict) -> str:
    t7 = t["table7"]
    st = t7.get("settings", {})
    head = []
    if st.get("quick"):
        head.append(f"A quick look (--quick: {st.get('epochs')} epochs per network, two architectures, coarse "
                    "tuning): not the comparison; run without --quick for it.\n")
    if st.get("effects"):
        head.append(f"M2 + effects: M2 with {', '.join(st['effects'])}.\n")
    head.append("Rows 'paper': the paper's figures on its own recordings, quoted; all others measured on yours.\n")
    parts = head + [rmse_text("Table 7, chronological test parts (RPM)", t7["chronological"]["rmse_rpm"], t7["paper"])]
    if "validation" in t7:
        parts.append(rmse_text("Table 7, never-seen recordings (--validation), every row", t7["validation"]["rmse_rpm"]))
    parts.append(rmse_text("Table 7, leave one recording out, every row", t7["leave_one_out"]["rmse_rpm"]))
    parts.append(rmse_text("Table 8, M3", t["table8"]["rmse_rpm"], t["table8"]["paper"]))
    parts.append(rmse_text("Table 9, M3 per architecture", {f"{k} {v['params']} p": v["rmse_rpm"]
                                                            for k, v in t["table9"]["rows"].items()}))
    parts.append(rmse_text("Table 10, M3 per feature set", {k: v["rmse_rpm"] for k, v in t["table10"]["rows"].items()},
                           t["table10"]["paper"]))
    for name, run_ in t["ood"]["runs"].items():
        parts.append(rmse_text(f"Section 4.10, trained on {name} only (clamp {run_['clamp_rpm']} RPM)",
                               run_["rmse_rpm"]))
        parts.append("  eq. 26 violations: " + ", ".join(f"{k} {v['violations']}/{v['samples']}"
                                                        for k, v in run_["eq26"].items()) + "\n")
    return "\n".join(parts)


def command_line(argv) -> str:
    return "hpddo compare " + " ".join(shlex.quote(str(a)) for a in argv)


# ---------------------------------------------------------------------------------------
# Markdown (docs/compare.md), from the JSON files of a run

def _md_rmse(rm: dict, paper: dict | None = None, conds=None) -> list:
    conds = conds or [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    f = lambda v: "–" if v is None else f"{v:.2f}"
    lines = ["| method | " + " | ".join(conds) + " |", "|---" * (len(conds) + 1) + "|"]
    for m, v in rm.items():
        lines.append(f"| {m} | " + " | ".join(f(v.get(c)) for c in conds) + " |")
        if paper and m in paper:
            lines.append(f"| *{m}, paper* | " + " | ".join(f"*{f(paper[m].get(c))}*" if paper[m].get(c) is not None
                                                              else "–" for c in conds) + " |")
    return lines


def markdown(folder: pathlib.Path) -> str:
    """The tables of docs/compare.md from table7.json ... ood.json in folder (a run's
    output, or docs/figures/compare_*.json with prefix)."""
    def load(name):
        for cand in (folder / f"{name}.json", folder / f"compare_{name}.json"):
            if cand.is_file():
                return json.loads(cand.read_text())
        raise InputError(f"{folder}: no {name}.json (an output of hpddo compare)")
    t7, t8, t9, t10, ood = (load(n) for n in ("table7", "table8", "table9", "table10", "ood"))
    out = [f"Command: `{t7['command']}`", "", "**Table 7, chronological test parts** (RMSE, RPM; paper in italics)", ""]
    out += _md_rmse(t7["chronological"]["rmse_rpm"], t7["paper"])
    if "validation" in t7:
        out += ["", "**Table 7, never-seen recordings** (every row of `--validation`)", ""]
        out += _md_rmse(t7["validation"]["rmse_rpm"])
    out += ["", "**Table 7, leave one recording out** (every row of the recording left out)", ""]
    out += _md_rmse(t7["leave_one_out"]["rmse_rpm"])
    out += ["", "**Table 8**, M3 under both protocols", ""] + _md_rmse(t8["rmse_rpm"], t8["paper"])
    out += ["", "**Table 9**, architecture ablation (M3, chronological test parts; paper in italics)", "",
            "| hidden | params | bytes | sweep | load | long | average | paper: params, kB, sweep, load, long, avg |",
            "|---|---|---|---|---|---|---|---|"]
    for k, v in t9["rows"].items():
        r = v["rmse_rpm"]
        p = t9["paper"].get(k)
        out.append(f"| {k} | {v['params']} | {v['bytes']} | " + " | ".join(f"{r[c]:.2f}" for c in CONDITIONS_DOC)
                   + " | " + (", ".join(f"{x:g}" for x in p) if p else "–") + " |")
    out += ["", "**Table 10**, feature ablation", ""]
    out += _md_rmse({k: v["rmse_rpm"] for k, v in t10["rows"].items()}, t10["paper"])
    for name, run_ in ood["runs"].items():
        out += ["", f"**Section 4.10, trained on {name} only** ({run_['train_rows']} training rows, clamp "
                    f"{run_['clamp_rpm']:.2f} RPM)", ""]
        out += _md_rmse(run_["rmse_rpm"])
        out += ["", "| tested on | clamped | fallback | gated |", "|---|---|---|---|"]
        out += [f"| {c} | {100 * s['clamped']:.1f} % | {100 * s['fallback']:.1f} % | {100 * s['gated']:.1f} % |"
                for c, s in run_["shares"].items()]
        out += ["", "eq. 26 on every labelled sample: " + "; ".join(
            f"{k}: {v['violations']} violations in {v['samples']}" for k, v in run_["eq26"].items())]
    return "\n".join(out) + "\n"


CONDITIONS_DOC = ("sweep", "load", "long", "average")


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m hpddo.studies.compare",
                                 description="print the markdown tables of docs/compare.md from a run's JSON files")
    ap.add_argument("folder", type=pathlib.Path, help="an output of hpddo compare, or docs/figures")
    args = ap.parse_args(argv)
    print(markdown(args.folder), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
