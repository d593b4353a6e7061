"""Benches the project's twin is not: recordings simulated from a quasi-static law of the
motor with an effect in a form outside the library (issue 21, item 7), written in the
bench log format, and the same law as the true model.

The law, per row: V = Ra I + drop(I) + Ke(I) w, the readings v = V + v_off(t, T) + noise,
i = I + i_off(t, T) + noise, rpm = w + noise, temp = the case temperature. Three
recordings at 2 Hz: a duty sweep at light load (the currents where a brush drop's shape
shows), load steps at five voltages (currents to 1.2 A), an hour at 12 V and 0.8 A while
the case warms 30 K; each holds its operating points 10 s in a shuffled order, so the
diagnosis' held-out tail (the last 20 % of each) spans their range. No PWM and no
discontinuous conduction: the law holds for the means exactly, unlike the twin's."""
import dataclasses
import math

import numpy as np
from scipy.optimize import least_squares

from hpddo.model import physics as ph

RA_OHM = 4.5
KE_VS_PER_RAD = 0.4
AMBIENT_C = 30.0
RISE_K = 30.0          # the case's rise over the hour at 0.8 A
TAU_S = 900.0          # its time constant
HOLD_ROWS = 20         # rows per operating point (10 s at 2 Hz)
RATE_HZ = 2.0
NOISE = {"v_V": 0.01, "i_A": 0.002, "rpm": 1.2}


def _brush(form, size, i):
    a = np.abs(i)
    if form == "tanh":              # tanh(|i| / i0)
        return size["V"] * np.sign(i) * np.tanh(a / size["i0"])
    if form == "exp":               # 1 - exp(-|i| / i0)
        return size["V"] * np.sign(i) * -np.expm1(-a / size["i0"])
    return np.zeros_like(i)


def _ke_share(form, size, i):
    """Ke(I) / Ke."""
    a = np.abs(i)
    if form == "lorentz":           # 1 / (1 + (i / i0)^2)
        return 1.0 / (1.0 + (a / size["i0"]) ** 2)
    if form == "onset":             # 1 - s max(0, |i| - i0)
        return 1.0 - size["s"] * np.maximum(0.0, a - size["i0"])
    return np.ones_like(i)


def _offset_share(form, t_s, rise_K):
    if form == "case":              # follows the case's rise, all of it at RISE_K
        return rise_K / RISE_K
    if form == "ramp":              # grows linearly over an hour of running
        return np.minimum(t_s / 3600.0, 1.0)
    return np.ones_like(t_s)


@dataclasses.dataclass(frozen=True)
class Law:
    """The effect: which (brush_drop, saturation, current_offset, v_offset), its form and
    its sizes {"V", "i0", "s", "A"}."""

    effect: str
    form: str
    size: dict

    def speed_rpm(self, v_true, i_true, ke, size=None):
        size = self.size if size is None else size
        drop = _brush(self.form, size, i_true) if self.effect == "brush_drop" else 0.0
        share = _ke_share(self.form, size, i_true) if self.effect == "saturation" else 1.0
        return (v_true - RA_OHM * i_true - drop) / (ke * share) * ph.RPM_PER_RAD_S

    def offsets(self, t_s, rise_K, size=None):
        """(v offset, i offset) of the readings per row."""
        size = self.size if size is None else size
        share = _offset_share(self.form, t_s, rise_K)
        zero = np.zeros_like(t_s)
        return (size["V"] * share if self.effect == "v_offset" else zero,
                size["A"] * share if self.effect == "current_offset" else zero)


WARM_STEPS = [(v, i) for v in (8.0, 12.0) for i in (0.1, 0.4, 0.8, 1.2)]  # 80 s of load steps


def _points(name, warm_steps=False):
    if name == "sweep":   # light load: a little friction current growing with speed
        return [(v, 0.02 + 0.012 * v) for v in np.arange(1.0, 12.01, 0.5)]
    if name == "load":
        return [(v, i) for v in (4.0, 6.0, 8.0, 10.0, 12.0) for i in np.arange(0.1, 1.21, 0.1)]
    # long: an hour at one point; with warm_steps, 40 min of it, load steps at two voltages while
    # warm, 8 min more at the point and the load steps again (in the held-out tail)
    if warm_steps:
        return [(12.0, 0.8)] * 120 + WARM_STEPS + [(12.0, 0.8)] * 24 + WARM_STEPS
    return [(12.0, 0.8)] * 180


def _case_rise(i_true, t):
    """The case's rise over a recording whose current changes: the first-order node (RISE_K
    at 0.8 A, TAU_S) stepped row by row; heat per row (i / 0.8 A)^2."""
    rise = np.zeros(len(t))
    step = -np.expm1(-(1.0 / RATE_HZ) / TAU_S)
    for k in range(1, len(t)):
        rise[k] = rise[k - 1] + (RISE_K * (i_true[k - 1] / 0.8) ** 2 - rise[k - 1]) * step
    return rise


def write(folder, law: Law, seed: int, ra_given: float = RA_OHM, warm_steps: bool = False) -> list:
    """The three recordings of the law bench (seed) in folder; their paths. warm_steps: the
    long run holds load steps (0.1..1.2 A at 8 and 12 V, 80 s) twice while the case is warm,
    after 40 and 48 min, the second in the held-out tail: what tells an offset's drift from
    the thermal effects (docs/diagnosis-forms.md, Offsets that drift)."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    paths = []
    for name in ("sweep", "load", "long"):
        pts = _points(name, warm_steps)
        order = rng.permutation(len(pts)) if name != "long" else np.arange(len(pts))
        vi = np.repeat(np.array([pts[k] for k in order]), HOLD_ROWS, axis=0)
        n = len(vi)
        t = np.arange(n) / RATE_HZ
        v_true, i_true = vi[:, 0], vi[:, 1]
        heat = (i_true / 0.8) ** 2 if name == "long" else np.zeros(n)
        rise = _case_rise(i_true, t) if (warm_steps and name == "long") else RISE_K * heat * -np.expm1(-t / TAU_S)
        temp = AMBIENT_C + rise
        rpm = law.speed_rpm(v_true, i_true, KE_VS_PER_RAD)
        vo, io = law.offsets(t, rise)
        v = v_true + vo + rng.normal(0, NOISE["v_V"], n)
        i = i_true + io + rng.normal(0, NOISE["i_A"], n)
        rpm = rpm + rng.normal(0, NOISE["rpm"], n)
        duty = v_true / 12.0
        lines = [f"# condition={name}", f"# sample_rate_hz={RATE_HZ:g}", "# kind=time_series", f"# ra_ohm={ra_given:g}",
                 f"# note=law bench {law.effect} {law.form} seed {seed} (test/py/law_benches.py)",
                 "t_s,duty,v_V,i_A,rpm_ref,temp_C"]
        lines += [f"{a:.1f},{b:.4f},{c:.4f},{d:.5f},{e:.2f},{f:.4f}" for a, b, c, d, e, f in
                  zip(t, duty, v, i, rpm, np.round(temp / 0.0625) * 0.0625)]
        path = folder / f"{name}.csv"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    return paths


def true_rmse(paths, law: Law) -> tuple[float, dict]:
    """The true model: the law with Ra at its true value, Ke and the effect's sizes fitted on
    the diagnosis' training rows, scored on its held-out rows as core.diagnose scores the
    physics after naming (Diagnosis rmse_rpm["after"]["average"]). (RMSE, fitted sizes)."""
    from hpddo.diagnosis import core
    inp = core.load(paths, core.Options(bootstrap=0, hybrid=False))
    keys = sorted(law.size)
    rows = inp.rows

    def predict(r, x):
        size = dict(zip(keys, x[1:]))
        t = r.rec.df["t_s"].to_numpy(float)
        vo, io = law.offsets(t, r.temp - AMBIENT_C, size)
        return law.speed_rpm(r.v - vo, r.i - io, x[0], size)

    def resid(x):
        return np.concatenate([np.nan_to_num((r.ref - predict(r, x))[r.train], nan=1e4) for r in rows])

    x0 = [KE_VS_PER_RAD] + [law.size[k] for k in keys]
    fit = least_squares(resid, x0, x_scale=[0.3] + [abs(v) or 1.0 for v in x0[1:]])
    res = [r.ref - predict(r, fit.x) for r in rows]
    return core._rmse_by_condition(rows, res)["average"], dict(zip(["ke"] + keys, (float(v) for v in fit.x)))
