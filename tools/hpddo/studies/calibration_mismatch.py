"""The calibration study on physics the library does not hold: does the diagnosis' confidence
survive a motor whose laws are not the model's forms?

python -m hpddo.studies.calibration draws its benches through the library's own physics, so the
truth is the model's parametrisation exactly. Real motors are not: this study draws benches from a
law of its own, written here and not through model.physics, and scores the diagnosis with the same
rules (calibration.score, summarise, table):

  * the brush drop a hyperbolic tangent, v0 tanh(i / i0), not the library's i / (|i| + knee) family;
  * the armature reaction a Ke that falls as c i^2 / (i_s + |i|) (quadratic at small currents,
    linear at large), not the library's |i| (1 - q + q |i|);
  * the winding two thermal nodes (slot copper and end turns, their own resistances and time
    constants), not one; the magnets between the case and the winding (a third of the winding's
    rise above the case), not at the case reading; ferrite's -0.2 %/K or NdFeB's -0.12 %/K;
  * time series whose operating points change through the mechanics (a first-order speed response,
    the current carrying the acceleration), the speed an encoder's count over the sample period
    (its mean, quantised), the voltage and current instantaneous at the sample;
  * in a third of the benches no case temperature at all (no temp_C column);
  * channel offsets of the current (a shunt amplifier) and the voltage, gain errors within the
    declared tolerances, ADC steps, noise; Ra given up to 15 % off; tables of 20-200 settled rows.

What counts as true: Ra and Ke at 25 C and zero current; an effect is on the bench where its
law is (copper and magnets always: whether the recordings show them is the `found` table's
business); a coefficient's interval is scored only where the law's coefficient is the library's
(the heating's material constant, the magnets', an offset; the brush drop's v0 and the
saturation's c are other forms' numbers and are not scored).

    python -m hpddo.studies.calibration_mismatch [--benches N] [--seed S] [--jobs J] [--json FILE]
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import sys
import tempfile

import numpy as np

from . import calibration as cal

T0_C = 25.0
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
COPPER_TC_PER_K = 0.00393
MAGNETS_TC_PER_K = (-0.002, -0.0012)     # ferrite, NdFeB
MAGNET_SHARE_OF_RISE = 1.0 / 3.0          # the magnets' rise above the case, a share of the winding's
HOLD_S = 2.0
SUBSTEP_S = 0.002                         # the mechanics and the heating integrated at this step
NOISE = {"v_V": 0.01, "i_A": 0.002}


@dataclasses.dataclass
class Bench:
    seed: int
    ra_ohm: float            # armature resistance at 25 C (brushes' linear part included)
    ke_vs_per_rad: float     # at 25 C and zero current
    brush_v0: float          # tanh brush drop: v0 tanh(i / i0) (0: none)
    brush_i0: float
    sat_c: float             # Ke (1 - c i^2 / (i_s + |i|)) (0: none)
    sat_is: float
    magnets_tc: float
    nodes: tuple             # ((R K/W, tau s), (R, tau)): the winding's two nodes above the case
    i_offset_A: float
    v_offset_V: float
    gains: dict
    declared_cal: bool
    v_lsb_V: float
    i_lsb_A: float
    rpm_step: float          # the encoder's count over a sample period, in RPM (0 in a table)
    ra_given_ohm: float
    table: bool
    rate_hz: float
    rows: int
    declared_kind: bool
    case_read: bool
    tau_mech_s: float
    i_max_A: float
    other_motor: bool = False   # calibration.score's field: no other motor here

    @property
    def effects(self) -> dict:
        """The library's names of the effects this bench's law has, with their coefficients where
        the law's is the library's (else NaN)."""
        out = {"thermal_ra": COPPER_TC_PER_K, "magnet_thermal": self.magnets_tc}
        if self.brush_v0 > 0:
            out["brush_drop"] = math.nan
        if self.sat_c > 0:
            out["saturation"] = math.nan
        if self.i_offset_A:
            out["current_offset"] = self.i_offset_A
        if self.v_offset_V:
            out["v_offset"] = self.v_offset_V
        return out

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def draw(seed: int) -> Bench:
    rng = np.random.default_rng(seed + 7_000_001)
    ra = float(math.exp(rng.uniform(math.log(1.0), math.log(12.0))))
    table = bool(rng.random() < 0.5)
    rate = float(rng.choice(cal.RATES_HZ))
    return Bench(
        seed=seed, ra_ohm=ra, ke_vs_per_rad=float(rng.uniform(0.05, 0.6)),
        brush_v0=float(rng.uniform(0.2, 1.5)) if rng.random() < 0.5 else 0.0, brush_i0=float(rng.uniform(0.03, 0.3)),
        sat_c=float(rng.uniform(0.03, 0.15)) if rng.random() < 0.4 else 0.0, sat_is=float(rng.uniform(0.2, 2.0)),
        magnets_tc=float(rng.choice(MAGNETS_TC_PER_K)),
        nodes=((float(rng.uniform(0.5, 2.0)), float(rng.uniform(8.0, 30.0))),
               (float(rng.uniform(0.3, 1.5)), float(rng.uniform(60.0, 200.0)))),
        i_offset_A=float(rng.choice([-1, 1]) * rng.uniform(0.005, 0.03)) if rng.random() < 0.25 else 0.0,
        v_offset_V=float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.3)) if rng.random() < 0.25 else 0.0,
        gains={k: float(rng.uniform(-t, t)) for k, t in cal.TOL.items()}, declared_cal=bool(rng.random() < 0.5),
        v_lsb_V=float(rng.choice([0.005, 0.015, 0.05])), i_lsb_A=float(rng.choice([0.001, 0.005, 0.02])),
        rpm_step=0.0 if table else float(60.0 * rate / rng.choice([600.0, 2000.0, 6000.0])),
        ra_given_ohm=ra * float(rng.uniform(1 - cal.RA_OFF_MAX, 1 + cal.RA_OFF_MAX)), table=table, rate_hz=rate,
        rows=int(rng.integers(20, 201)), declared_kind=bool(rng.random() < 0.5), case_read=bool(rng.random() < 2 / 3),
        tau_mech_s=float(rng.uniform(0.05, 0.4)), i_max_A=float(min(0.45 * 12.0 / ra, 3.0)))


def brush_V(b: Bench, i):
    return b.brush_v0 * np.tanh(np.asarray(i, float) / b.brush_i0) if b.brush_v0 > 0 else np.zeros(np.shape(i))


def ke_at(b: Bench, i, magnet_C):
    i = np.abs(np.asarray(i, float))
    return (b.ke_vs_per_rad * (1.0 + b.magnets_tc * (np.asarray(magnet_C, float) - T0_C))
            * (1.0 - b.sat_c * i * i / (b.sat_is + i)))


def ra_at(b: Bench, winding_C):
    return b.ra_ohm * (1.0 + COPPER_TC_PER_K * (np.asarray(winding_C, float) - T0_C))


def targets(b: Bench, which: str, n: int, rng) -> tuple:
    """(speed rad/s, current A, case C) of n operating points: a sweep at light load, three speeds
    under load steps, a warm-up alternating two loads at full speed as the case rises."""
    w_max = 10.0 / b.ke_vs_per_rad
    if which == "sweep":
        w = np.linspace(0.2, 0.95, n) * w_max
        i = np.full(n, 0.12 * b.i_max_A) * (1 + 0.1 * rng.random(n))
        t = np.full(n, T0_C)
    elif which == "load":
        w = np.repeat([0.3, 0.5, 0.7], math.ceil(n / 3))[:n] * w_max
        i = np.tile(np.linspace(0.15, 1.0, math.ceil(n / 3)), 3)[:n] * b.i_max_A
        t = np.full(n, T0_C + 2.0)
    else:  # warm
        w = np.full(n, 0.7 * w_max)
        i = np.where(np.arange(n) % 2 == 0, 0.3, 0.9) * b.i_max_A
        t = T0_C + cal.WARM_K * (1 - np.exp(-np.arange(n) / max(n / 3, 1)))
    # the electrical law must leave a positive voltage below the supply's 12 V: lower the speed where not
    return w, i, t


def settled_rise(b: Bench, i, case_C) -> np.ndarray:
    """The winding's settled rise above the case at current i (both nodes, the loss at Ra(T))."""
    r = sum(n[0] for n in b.nodes)
    rise = np.zeros(len(i))
    for _ in range(60):
        rise = r * i * i * ra_at(b, case_C + rise)
    return rise


def series(b: Bench, w_t, i_t, case_t, rng) -> tuple:
    """A time series at b.rate_hz through the points (each held HOLD_S): the speed's first-order
    response, the current carrying the acceleration, the winding's two nodes heated by i^2 Ra(T).
    Returns (speed read as the encoder's mean over each period, true instantaneous current,
    winding C, case C, true mean speed) per sample."""
    sub = int(round(1.0 / (b.rate_hz * SUBSTEP_S)))
    dt = 1.0 / (b.rate_hz * sub)
    per_pt = int(round(HOLD_S * b.rate_hz)) * sub
    wt, it, ct = (np.repeat(x, per_pt) for x in (w_t, i_t, case_t))
    n = len(wt)
    w = np.empty(n)
    x = float(wt[0])
    a = math.exp(-dt / b.tau_mech_s)
    for k in range(n):  # first-order speed response to each point's speed
        x = float(wt[k]) + (x - float(wt[k])) * a
        w[k] = x
    accel = np.gradient(w, dt)
    i_acc = 0.6 * b.i_max_A * b.tau_mech_s * accel / max(float(np.max(wt)), 1e-9)  # J / Kt dw/dt
    i = it + i_acc
    rises = [0.0 for _ in b.nodes]
    wind = np.empty(n)
    for k in range(n):
        t_w = ct[k] + sum(rises)
        wind[k] = t_w
        loss = i[k] * i[k] * float(ra_at(b, t_w))
        rises = [rz + (r * loss - rz) * (1 - math.exp(-dt / tau)) for rz, (r, tau) in zip(rises, b.nodes)]
    # samples at the end of each period: V and I instantaneous, the speed the count over the period
    idx = np.arange(sub - 1, n, sub)
    w_mean = w.reshape(-1, sub).mean(axis=1)
    return w_mean, i[idx], wind[idx], ct[idx], w[idx]


def write(b: Bench, folder: pathlib.Path) -> tuple:
    """The bench's three recordings as bench logs; (paths, the RMS RPM by which the law's effects
    move the plain model at the true Ra and Ke over the rows)."""
    rng = np.random.default_rng(b.seed + 1_000_003)
    paths, moved = [], []
    for name in ("sweep", "load", "warm"):
        n_pts = max(b.rows // 3, 7) if b.table else 10
        w_t, i_t, c_t = targets(b, name, n_pts, rng)
        if b.table:
            w_read, i, case = w_t, i_t, c_t
            wind = case + settled_rise(b, i, case)
            w_inst = w_t
            dt = 1.0
        else:
            w_read, i, wind, case, w_inst = series(b, w_t, i_t, c_t, rng)
            dt = 1.0 / b.rate_hz
        magnet = case + MAGNET_SHARE_OF_RISE * (wind - case)
        v = ra_at(b, wind) * i + brush_V(b, i) + ke_at(b, i, magnet) * w_inst
        n = len(v)
        # what the effects move the plain model by, at the true Ra and Ke (the law's true readings)
        moved.append((v - b.ra_ohm * i) / b.ke_vs_per_rad * RPM_PER_RAD_S - w_inst * RPM_PER_RAD_S)
        v_read = v * (1 + b.gains["v_cal_rel"]) + b.v_offset_V + rng.normal(0, NOISE["v_V"], n)
        i_read = i * (1 + b.gains["i_cal_rel"]) + b.i_offset_A + rng.normal(0, NOISE["i_A"], n)
        v_read = np.round(v_read / b.v_lsb_V) * b.v_lsb_V
        i_read = np.round(i_read / b.i_lsb_A) * b.i_lsb_A
        rpm = w_read * RPM_PER_RAD_S
        rpm_read = (np.round(rpm / b.rpm_step) * b.rpm_step if b.rpm_step > 0
                    else rpm + rng.normal(0, cal.NOISE["rpm"], n))
        meta = [f"# condition={name}", f"# ra_ohm={b.ra_given_ohm:.4g}", f"# v_lsb_V={b.v_lsb_V:g}",
                f"# i_lsb_A={b.i_lsb_A:g}"]
        if b.declared_cal:
            meta += [f"# {k}={cal.TOL[k]:g}" for k in cal.TOL]
        if b.declared_kind:
            meta.append(f"# kind={'steady_state' if b.table else 'time_series'}")
        if not b.table:
            meta.append(f"# sample_rate_hz={b.rate_hz:g}")
        duty = np.clip(np.round(v / 12.0, 4), 0.0, 1.0)
        cols = "t_s,duty,v_V,i_A,rpm_ref" + (",temp_C" if b.case_read else "")
        lines = meta + [cols]
        for k in range(n):
            row = f"{k * dt:.4f},{duty[k]:.4f},{v_read[k]:.6g},{i_read[k]:.6g},{rpm_read[k]:.4f}"
            lines.append(row + (f",{case[k]:.2f}" if b.case_read else ""))
        path = folder / f"{name}.csv"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    d = np.concatenate(moved)
    return paths, float(np.sqrt(np.mean(d * d)))


def run_one(seed: int) -> dict:
    """Draws, writes, diagnoses and scores one bench (a user error recorded, a traceback not caught)."""
    from ..diagnosis import core
    from ..logs.errors import USER_ERRORS

    b = draw(seed)
    with tempfile.TemporaryDirectory(prefix="hpddo-calm-") as tmp:
        paths, rms = write(b, pathlib.Path(tmp))
        try:
            d = core.diagnose(paths, core.Options(ra_ohm=b.ra_given_ohm, bootstrap=0, hybrid=False))
        except USER_ERRORS as exc:
            return {"bench": b.to_json(), "refused": str(exc).replace(tmp, "BENCH")}  # (as calibration's)
        js = d.to_json()
        # (no runtime: the file is the same bytes on any machine, as calibration's)
        return {"bench": b.to_json(), "score": cal.score(b, js, paths, effect_rms=rms), "verdict": js.get("verdict", "")}


FIGURES = "docs/figures/calibration_mismatch.json"   # the committed run (--json), its command inside
DOC = "docs/diagnosis-mismatch.md"
WHAT = "the study on physics the library does not hold"


def doc_markers() -> tuple:
    from . import doc_markers as markers
    return markers("calibration_mismatch", WHAT, FIGURES)


def docs_text(doc: str, figures: dict) -> str:
    """doc (docs/diagnosis-mismatch.md's text) with its block of this study's figures rendered from
    figures (the committed JSON)."""
    return cal.block_in(doc, figures, doc_markers(), DOC, WHAT)


def main(argv=None) -> int:
    return cal.run_benches("calibration_mismatch", __doc__.split("\n\n")[0], run_one, (DOC, FIGURES, docs_text), 100,
                           argv)


if __name__ == "__main__":
    sys.exit(main())
