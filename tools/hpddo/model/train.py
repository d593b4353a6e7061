"""M3: the residual network, its scaler, the residual clamp and the training envelope."""
from __future__ import annotations

import dataclasses
import functools

import numpy as np
from tqdm import tqdm

from . import dynamics_ref
from . import gate as gate_mod
from . import network
from . import physics as ph
from ..logs.dataset import Recording, di_dt_A_per_s, dt_s, kind, lagged, segment_starts, temp_read_C
from ..logs.errors import InputError

FEATURES = ["v_V", "i_A", "n_M2", "i_A_lag1", "n_M2_lag1"]
CLAMP_PERCENTILE = 99.0   # paper 4.10: the 99th percentile of absolute training residuals
ENVELOPE_MARGIN = 0.10    # the envelope is the training range widened by 10 % of it each side
PHYSICS_ONLY_ENVELOPE = 1e30  # physics_only's envelope, -1e30..1e30: every finite feature inside


class TrainingError(InputError):
    """The training rows cannot train the residual network."""


@dataclasses.dataclass
class TrainConfig(network.AdamConfig):
    """The network's training (network.AdamConfig), whether the novelty gate is fitted
    (else an open gate: the whole correction everywhere inside the envelope) and whether
    a progress bar shows."""

    gate: bool = True
    progress: bool = True


def temperature_used(rec: Recording, p: ph.PhysicsParams) -> ph.Temps:
    """The winding and magnet temperatures the observer feeds the thermal effects
    (physics.temperatures): the case reading where it lies in the sensor's range; on a
    steady-state table's settled rows, the node settled at each (effects.temperature)."""
    return ph.temperatures(p, rec.df["i_A"].to_numpy(float), dt_s(rec), temp_read_C(rec),
                           settled=kind(rec)[0] == "steady_state")


def physics_rpm(rec: Recording, p: ph.PhysicsParams) -> np.ndarray:
    """n_M2 for every row of a recording, with the observer's lag and thermal rules."""
    return ph.physics_rpm(p, rec.df["v_V"].to_numpy(float), rec.df["i_A"].to_numpy(float), di_dt_A_per_s(rec),
                          temperature_used(rec, p))


def dynamic_rpm(rec: Recording, p: ph.PhysicsParams, n2: np.ndarray, dyn: dict | None) -> np.ndarray:
    """n_M2 through the dynamic family's observer (dynamics_ref, hpddo/dynamics.h) where dyn names
    it, restarted where the lags restart (observer.h); n2 itself otherwise."""
    if dyn is None or not dynamics_ref.named(dyn):
        return n2
    starts = np.flatnonzero(segment_starts(rec))
    ends = np.r_[starts[1:], rec.n]
    i_true = ph.true_current_A(p, rec.df["i_A"].to_numpy(float))
    dt = dt_s(rec)
    out = np.empty(rec.n)
    for s, e in zip(starts, ends):
        out[s:e] = dynamics_ref.run(p.ke_vs_per_rad, dyn, i_true[s:e], n2[s:e], dt[s:e])[0]
    return out


def features(rec: Recording, p: ph.PhysicsParams, dyn: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Feature matrix [V, I, n_M2, I(t-1), n_M2(t-1)] and n_M2 of every row (through the dynamic
    family where dyn names it)."""
    starts = segment_starts(rec)
    n2 = dynamic_rpm(rec, p, physics_rpm(rec, p), dyn)
    i = rec.df["i_A"].to_numpy(float)
    x = np.column_stack([rec.df["v_V"].to_numpy(float), i, n2, lagged(i, starts), lagged(n2, starts)])
    return x, n2


@dataclasses.dataclass
class Residual:
    scaler: network.Scaler
    mlp: network.Network
    clamp_rpm: float
    env_lo: np.ndarray
    env_hi: np.ndarray
    gate: gate_mod.GateData
    n_train: int
    loss_curve: list
    note: str = ""  # why there is no learned correction (physics_only), else empty

    @property
    def trained(self) -> bool:
        return not self.note


def labelled_rows(recs: list[Recording], p: ph.PhysicsParams, dyn: dict | None = None):
    """The features x, residuals e = rpm_ref - n_M2 and weights of the labelled training rows: the
    weight is the reference's confidence (Recording.weight, the ripple's) where a recording has
    one, 1 elsewhere; None where no recording has one (the encoder: every row once)."""
    xs, es, ws = [], [], []
    for r in recs:
        x, n2 = features(r, p, dyn)
        x, n2 = x[: r.n_train], n2[: r.n_train]
        ref = r.part("train")["rpm_ref"].to_numpy(float) if "rpm_ref" in r.df else np.full(r.n_train, np.nan)
        keep = np.isfinite(ref) & np.isfinite(x).all(axis=1)
        xs.append(x[keep])
        es.append((ref - n2)[keep])
        ws.append((np.ones(r.n_train) if r.weight is None else np.asarray(r.weight, float)[: r.n_train])[keep])
    weighted = any(r.weight is not None for r in recs)
    return np.concatenate(xs), np.concatenate(es), (np.concatenate(ws) if weighted else None)


def training_rows(recs: list[Recording], p: ph.PhysicsParams, dyn: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The features x and residuals e = rpm_ref - n_M2 of the labelled training rows."""
    x, e, _ = labelled_rows(recs, p, dyn)
    return x, e


def train_residual(recs: list[Recording], p: ph.PhysicsParams, cfg: TrainConfig, dyn: dict | None = None) -> Residual:
    """Fits the residual e = rpm_ref - n_M2 on the training rows of every recording (n_M2 through
    the dynamic family where dyn names it), each row weighted by its reference's confidence where
    it has one (labelled_rows: the ripple's); TrainingError with fewer labelled rows than one batch."""
    x, e, weight = labelled_rows(recs, p, dyn)
    if len(x) < cfg.batch_size:
        raise TrainingError(f"only {len(x)} labelled training rows: too few to train the residual network "
                            f"(at least one batch, {cfg.batch_size}); record longer, or give more recordings")
    scaler = network.Scaler.fit(x)
    z = scaler.transform(x)
    bar = functools.partial(tqdm, desc=f"train M3 {cfg.hidden}", unit="epoch", disable=None if cfg.progress else True,  # None: no bar off a terminal
                            mininterval=0.5, leave=False)
    mlp, losses = network.train(z, e, cfg, progress=bar, weight=weight)
    lo, hi = x.min(axis=0), x.max(axis=0)
    span = np.maximum(hi - lo, 1e-6)
    return Residual(scaler=scaler, mlp=mlp, clamp_rpm=float(np.percentile(np.abs(e), CLAMP_PERCENTILE)),
                    env_lo=lo - ENVELOPE_MARGIN * span, env_hi=hi + ENVELOPE_MARGIN * span,
                    gate=gate_mod.fit(x) if cfg.gate else gate_mod.open_gate(x.shape[1]), n_train=len(x),
                    loss_curve=losses)


def physics_only_note(n_rows: int, cfg: TrainConfig) -> str:
    """Why a model carries no learned correction (metrics.json identification.residual)."""
    return (f"not trained: {n_rows} labelled training rows, at least {cfg.batch_size} (one batch) are needed; "
            "the model is physics only (M3 = M2)")


def physics_only(n_rows: int, cfg: TrainConfig) -> Residual:
    """M3 = M2: a residual that never corrects, for tables too small to train the network
    (a steady-state dyno table of tens of rows). Every number is finite, so the header,
    its checksum and the golden vectors are written as for a trained model: the network
    of cfg.hidden with every weight and bias 0, scaler 0/1, clamp 0, an envelope that
    holds every finite feature (1e30 either way: no row falls back for the box), and a
    closed novelty gate, r_in_sq = r_out_sq = 0, so that no distance is < r_out_sq and the
    weight is 0 at every input (gate.h): the observer reports "gated", confidence 0, and
    rpm = rpm_m2, without evaluating the network."""
    dims = len(FEATURES)
    sizes = (dims, *tuple(cfg.hidden), 1)
    mlp = network.Network(coefs_=[np.zeros((a, b)) for a, b in zip(sizes[:-1], sizes[1:])],
                          intercepts_=[np.zeros(b) for b in sizes[1:]])
    closed = gate_mod.GateData(centre=np.zeros(dims, gate_mod.F32), scale=np.ones(dims, gate_mod.F32),
                               prototypes=np.zeros((gate_mod.DEFAULT_PROTOTYPES, dims), gate_mod.F32),
                               r_in_sq=gate_mod.F32(0), r_out_sq=gate_mod.F32(0),
                               rule="closed: no residual network trained (w = 0 at every input, physics only)")
    return Residual(scaler=network.Scaler(mean_=np.zeros(dims), scale_=np.ones(dims)), mlp=mlp, clamp_rpm=0.0,
                    env_lo=np.full(dims, -PHYSICS_ONLY_ENVELOPE), env_hi=np.full(dims, PHYSICS_ONLY_ENVELOPE),
                    gate=closed, n_train=n_rows, loss_curve=[], note=physics_only_note(n_rows, cfg))


def residual_or_physics_only(recs: list[Recording], p: ph.PhysicsParams, cfg: TrainConfig,
                             dyn: dict | None = None) -> Residual:
    """train_residual where the labelled training rows fill one batch, else physics_only
    (its note says why)."""
    x, _ = training_rows(recs, p, dyn)
    if len(x) < cfg.batch_size:
        return physics_only(len(x), cfg)
    return train_residual(recs, p, cfg, dyn)


def correction(res: Residual, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The learned correction the observer adds to n_M2, for every row of features x at
    once (observer.h's rules, the network in float64): inside the envelope, the novelty
    gate's weight w times the clamped residual; 0 outside the envelope, where w = 0, or
    where a feature is not finite. Returns (correction in RPM, w) per row."""
    x = np.asarray(x, float)
    inside = np.isfinite(x).all(axis=1) & np.all((x >= res.env_lo) & (x <= res.env_hi), axis=1)
    w = np.zeros(len(x))
    if inside.any():
        w[inside] = gate_mod.weight(res.gate, x[inside])
    on = w > 0
    corr = np.zeros(len(x))
    if on.any():
        r = np.clip(res.mlp.predict(res.scaler.transform(x[on])), -res.clamp_rpm, res.clamp_rpm)
        corr[on] = w[on] * r
    return corr, w


def hybrid_rpm(res: Residual, rec: Recording, p: ph.PhysicsParams, dyn: dict | None = None) -> np.ndarray:
    """n_M3 for every row of a recording: n_M2 plus the correction (train.correction)."""
    x, n2 = features(rec, p, dyn)
    return n2 + correction(res, x)[0]
