"""Reference of the board observer (lib/hpddo_core/src/hpddo/observer.h) in numpy float32.

Written from the equations, not from the C++ source, so that golden vectors computed here
check the boards' code independently. Every intermediate stage is returned.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from . import dynamics_ref
from . import gate as gate_mod
from . import physics as ph

F32 = np.float32
STATUS = {"ok": 0, "clamped": 1, "fallback": 2, "invalid": 3, "gated": 4}


from ..schema import Limits  # noqa: E402,F401 (declared once, in schema.py; re-exported)


@dataclasses.dataclass
class ModelData:
    """Everything a generated model header holds, in float32 where the boards store it."""

    physics: ph.PhysicsParams
    scaler_mean: np.ndarray
    scaler_scale: np.ndarray
    layers: list  # [(W[out,in], b[out]), ...], hidden layers ReLU, last linear
    env_lo: np.ndarray
    env_hi: np.ndarray
    clamp_rpm: float
    gate: gate_mod.GateData  # the novelty gate over the features (gate.h)
    limits: Limits = dataclasses.field(default_factory=Limits)
    nameplate: ph.PhysicsParams | None = None  # M1, for comparison only; not in the checksum
    # the dynamic family (dynamics_ref.dynamics_params, the header's kDynamics) where named, else None
    dynamics: dict | None = None

    @property
    def dynamics_named(self) -> bool:
        return self.dynamics is not None and dynamics_ref.named(self.dynamics)

    @property
    def hidden(self) -> tuple:
        return tuple(w.shape[0] for w, _ in self.layers[:-1])


def dense_f32(w, b, h):
    """out[o] = b[o] + w[o, 0] h[0] + w[o, 1] h[1] + ..., each product and each sum rounded
    to float32 in that order: the order the boards use (mlp.h), and one that no BLAS kernel,
    CPU or thread count can change (elementwise float32 operations are exact IEEE)."""
    w = np.asarray(w, F32)
    acc = np.array(b, F32, copy=True)
    for k in range(w.shape[1]):
        acc = (acc + (w[:, k] * F32(h[k])).astype(F32)).astype(F32)
    return acc


def mlp_forward(layers, z):
    """Dense ReLU network, float32, linear scalar output (summed in the boards' order)."""
    h = np.asarray(z, F32)
    for k, (w, b) in enumerate(layers):
        h = dense_f32(w, b, h)
        if k < len(layers) - 1:
            h = np.maximum(h, F32(0.0))
    return F32(h[0])


class ReferenceObserver:
    """Step-by-step float32 observer with the lag, seq and thermal rules of the boards, and
    their bounds (docs/core.md): a period outside [PERIOD_MIN_S, PERIOD_MAX_S] starts a new
    segment, an n_M2 beyond speed_limit_rpm is invalid, the winding stays below WINDING_MAX_C."""

    def __init__(self, model: ModelData, network=None, gate=None):
        """network(x) -> residual RPM (float32) replaces the float scaler and network, and
        gate(x) -> weight (float32) the float gate (quant.residual_fn and quant.gate_fn:
        the fixed-point model); None: the float32 ones."""
        self.m = model
        self.network = network
        self.gate = gate
        self.speed_limit = ph.speed_limit_rpm(model.physics, model.limits.v_max_V, model.limits.i_max_A, F32)
        self.reset()

    def restart_lags(self):
        """A new segment (seq gap, split): lags restart, the thermal state stays."""
        self.has_lag = False

    def reset(self):
        self.has_lag = False
        self.has_seq = False
        self.last_seq = 0
        self.i_lag = F32(0)
        self.m2_lag = F32(0)
        self.rise_K = F32(0)
        self.dyn = dynamics_ref.DynamicsObserver()
        self.last = dict(rpm=F32(0), rpm_m2=F32(0), residual_rpm=F32(0), temp_C=F32(0), confidence=F32(0))

    def _invalid(self, out):
        self.has_lag = False
        out.update(self.last)
        out.update(residual_rpm=F32(0), confidence=F32(0), status=STATUS["invalid"])
        return out

    def step(self, v_V, i_A, temp_C, dt_s, seq=None):
        m, p = self.m, self.m.physics
        out = dict(x=np.full(5, np.nan, F32), z=np.full(5, np.nan, F32), mlp_rpm=F32(np.nan))
        if seq is not None:
            if self.has_seq and seq != (self.last_seq + 1) % 65536:
                self.has_lag = False
            self.has_seq = True
            self.last_seq = seq
        v, i, dt = F32(v_V), F32(i_A), F32(dt_s)
        lim = m.limits
        if not (np.isfinite(v) and np.isfinite(i) and np.isfinite(dt) and abs(v) <= F32(lim.v_max_V)
                and abs(i) <= F32(lim.i_max_A) and dt > 0):
            return self._invalid(out)
        if not (F32(ph.PERIOD_MIN_S) <= dt <= F32(ph.PERIOD_MAX_S)):
            self.has_lag = False  # no sample-to-sample step: a new segment, the sample still used
        i_true = ph.true_current_A(p, i, F32)
        t_read = temp_C is not None and np.isfinite(temp_C) and lim.temp_min_C <= temp_C <= lim.temp_max_C
        ref = F32(temp_C) if t_read else F32(p.t_amb_C)
        if p.thermal_enabled():
            t_w, self.rise_K = ph.thermal_trajectory(p, [i_true], [dt], F32, ref_C=[ref], start_rise_K=self.rise_K,
                                                     final_rise=True)
            temp_used = F32(t_w[0])
            magnet = ref if t_read else temp_used
        else:
            temp_used = ref if t_read else F32(p.t_ref_C)
            magnet = temp_used
        di_dt = (i - self.i_lag) / dt if self.has_lag else F32(0)
        m2 = ph.physics_rpm(p, v, i, di_dt, ph.Temps(temp_used, magnet), F32)
        m2 = F32(m2)
        if not (np.isfinite(m2) and abs(m2) <= self.speed_limit):  # beyond the model's speed range: no speed
            return self._invalid(out)
        if m.dynamics_named:  # the dynamic family: n_M2 is its measurement, restarted with the lags
            if not self.has_lag:
                self.dyn.reset()
            m2 = F32(self.dyn.step(p.ke_vs_per_rad, m.dynamics, i_true, m2, dt))
        x = np.array([v, i, m2, self.i_lag if self.has_lag else i, self.m2_lag if self.has_lag else m2], F32)
        self.i_lag, self.m2_lag, self.has_lag = i, m2, True
        out.update(x=x, rpm_m2=m2, temp_C=temp_used, residual_rpm=F32(0), confidence=F32(0),
                   status=STATUS["fallback"])
        # Inside the per-feature box, the gate's weight w (nearness to the training rows)
        # scales the clamped residual; where w = 0 the network is not evaluated.
        w = F32(0)
        if np.all((x >= m.env_lo) & (x <= m.env_hi)):
            w = F32(gate_mod.weight(m.gate, x[None, :])[0] if self.gate is None else self.gate(x))
            if not w > 0:
                out.update(status=STATUS["gated"])  # inside the box, far from every training row
        if w > 0:
            if self.network is None:
                z = ((x - m.scaler_mean.astype(F32)) / m.scaler_scale.astype(F32)).astype(F32)
                r = mlp_forward(m.layers, z)
                out.update(z=z, mlp_rpm=r)
            else:
                r = F32(self.network(x))
                out.update(mlp_rpm=r)
            if np.isfinite(r):
                c = F32(m.clamp_rpm)
                rc = F32(min(max(r, -c), c))
                status = STATUS["gated"] if w < 1 else STATUS["clamped"] if rc != r else STATUS["ok"]
                out.update(residual_rpm=F32(w * rc), confidence=w, status=status)
        out["rpm"] = F32(m2 + out["residual_rpm"])
        self.last = {k: out[k] for k in ("rpm", "rpm_m2", "residual_rpm", "temp_C", "confidence")}
        return out
