"""The inputs and variants of the compared methods: M2, M3 and its gate, the pure network's features."""
from __future__ import annotations

import dataclasses
import numpy as np

from ...logs import dataset
from ...model import identify, network
from ...model import gate as gate_mod
from ...model import train as train_mod


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
