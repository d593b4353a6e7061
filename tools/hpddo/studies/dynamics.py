"""Why the residual of M2 follows dV/dt on a fast recording: the parts, measured on the twin.

    cd tools && python -m hpddo.studies.dynamics      # the figures of docs/dynamics.md

On the twin's sweep (duty steps of 20 %, no load) at 100 Hz, ideal bench with the inductance on,
the residual of M2 (n = (V - Ra I) / Ke, the true Ra and Ke) is split by switching the parts off:

* inductance: the residual against the TRUE speed with the sensors' noise off, with La and
  without it (what La di/dt leaves in V = Ra I + La di/dt + Ke w), and how much of it the
  term La (I_k - I_(k-1)) / T of the logged means takes out;
* mechanics (inertia J, friction B and Tc): M2 is algebraic in V and I, so the speed's lag behind
  the voltage is carried by the current; what is left against the true speed without La is M2's
  error from the mechanics;
* the encoder: counts over the row's window are the window mean of the speed, the same window as
  V and I (no half-window lag); what remains is the quantisation, rpm_ref minus the true mean;
* the voltage and current channels: the ADC's noise and the PWM waveform's aliasing, the residual
  against the true speed with the noise on;
* the correlation of the residual with dV/dt (the backward difference, as the diagnosis computes
  it) with the noise on and off: with it off there is none, so the diagnosis' "follows dV/dt" at a
  lag of -1 row is the voltage channel's own noise, shared by the residual (-V_k / Ke) and by
  dV/dt one row later ((V_(k+1) - V_k) / T).

The speed's own lag behind a duty step (the mechanical time constant, what a "lag" means
physically) is measured on the true speed: the time to 63 % of each step.
"""
from __future__ import annotations

import math

import numpy as np

from ..twin import generate, params

RATE_HZ = 100.0
TIME_SCALE = 0.1   # the sweep's 30 s steps cut to 3 s: 3300 rows at 100 Hz
SEED = 3
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def _run(noise: bool, la: bool, rate_hz: float = RATE_HZ):
    b = params.with_effects(params.preset("ideal"), inductance=2.5 if la else 0.0)
    b.noise = noise
    return generate.generate(b, "sweep", rate_hz=rate_hz, seed=SEED, time_scale=TIME_SCALE)


def _ccf(e: np.ndarray, u: np.ndarray, lag: int) -> float:
    """Correlation of e(t) with u(t - lag)."""
    if lag < 0:
        return float(np.corrcoef(e[:lag], u[-lag:])[0, 1])
    if lag > 0:
        return float(np.corrcoef(e[lag:], u[:-lag])[0, 1])
    return float(np.corrcoef(e, u)[0, 1])


def parts(rate_hz: float = RATE_HZ) -> dict:
    """The residual's parts (RPM rms) and correlations, measured as the module's docstring says."""
    out = {"rate_hz": rate_hz}
    runs = {(n, la): _run(n, la, rate_hz) for n in (False, True) for la in (False, True)}
    T = 1.0 / rate_hz
    for (noise, la), g in runs.items():
        log, truth, b = g["log"], g["truth"], None
        info = g["info"]
        ra, ke = info["bench"]["ra_ohm"], info["bench"]["ke_vs_per_rad"]
        la_H = 2.5e-3 if la else 0.0
        v, i = log["v_V"].to_numpy(), log["i_A"].to_numpy()
        m2 = (v - ra * i) / ke * RPM_PER_RAD_S
        true = truth["rpm_true"].to_numpy()
        enc = log["rpm_ref"].to_numpy()
        di = np.r_[0.0, np.diff(i)] / T
        dv = np.r_[0.0, np.diff(v)] / T
        e_true = true - m2
        e_enc = enc - m2
        key = f"{'noise' if noise else 'clean'}_{'La' if la else 'noLa'}"
        out[key] = {
            "rms_vs_true_rpm": float(np.sqrt(np.mean(e_true ** 2))),
            "rms_vs_encoder_rpm": float(np.sqrt(np.mean(e_enc ** 2))),
            "encoder_quantisation_rpm": float(np.sqrt(np.mean((enc - true) ** 2))),
            "rms_vs_true_after_la_rpm": float(np.sqrt(np.mean((e_true + la_H * di / ke * RPM_PER_RAD_S) ** 2))),
            "r_dvdt_by_lag": {k: _ccf(e_enc, dv, k) for k in (-2, -1, 0, 1, 2)},
        }
    # the speed's lag behind each duty step: time to 63 % of the step, on the true speed
    g = runs[(False, True)]
    duty = g["log"]["duty"].to_numpy()
    w = g["truth"]["rpm_true"].to_numpy()
    steps = np.flatnonzero(np.diff(duty) != 0) + 1
    taus = []
    for s in steps:
        end = min(len(w), s + int(round(1.0 * rate_hz)))
        w0, w1 = w[s - 1], np.mean(w[end - int(0.2 * rate_hz):end])
        if abs(w1 - w0) < 5.0 or w0 < 1.0:
            continue
        frac = (w[s:end] - w0) / (w1 - w0)
        k = int(np.argmax(frac >= 1.0 - math.exp(-1.0)))
        # the row means: the row k is the first whose mean passes 63 %; interpolate within it
        f0 = frac[k - 1] if k > 0 else 0.0
        taus.append(T * (k - 1 + (1 - math.exp(-1.0) - f0) / max(frac[k] - f0, 1e-9)) + 0.5 * T)
    out["speed_lag_63_s"] = taus
    return out


def identified(seeds=range(1, 13), rate_hz: float = RATE_HZ) -> list:
    """The dynamic family as the diagnosis identifies it (model/dynamics.py, all rows, the true Ra and
    Ke) on the twin's sweep at rate_hz for each seed: [(seed, J, its interval, B, Tc)]."""
    import tempfile
    import pathlib
    from ..model import dynamics
    from ..logs import dataset
    b = params.with_effects(params.preset("ideal"), inductance=2.5)
    out = []
    for seed in seeds:
        with tempfile.TemporaryDirectory() as tmp:
            generate.generate(b, "sweep", rate_hz=rate_hz, seed=seed, time_scale=TIME_SCALE, out_dir=tmp)
            rec = dataset.load_recording(pathlib.Path(tmp) / "sweep.csv")
        d = dynamics.identify([rec], b.ra_ohm, b.ke_vs_per_rad)
        j, bb, tc = (d.by_field(f) for f in ("j_kgm2", "b_nms_per_rad", "tc_nm"))
        out.append((seed, j.value, (j.lo, j.hi), bb.value, tc.value))
    return out


def main() -> int:
    p = parts()
    print(f"twin sweep at {p['rate_hz']:g} Hz, ideal bench, seed {SEED}, time scale {TIME_SCALE}")
    for key in ("clean_noLa", "clean_La", "noise_noLa", "noise_La"):
        q = p[key]
        print(f"  {key:11s} M2 vs true {q['rms_vs_true_rpm']:6.2f} RPM, after La dI/dt "
              f"{q['rms_vs_true_after_la_rpm']:6.2f}; vs encoder {q['rms_vs_encoder_rpm']:6.2f}; encoder "
              f"quantisation {q['encoder_quantisation_rpm']:6.2f}; r(residual, dV/dt) at lags -2..2: "
              + " ".join(f"{r:+.2f}" for r in q["r_dvdt_by_lag"].values()))
    taus = np.array(p["speed_lag_63_s"]) * 1e3
    print(f"  the speed's lag behind a duty step (63 %, true speed): median {np.median(taus):.1f} ms, "
          f"{taus.min():.1f}..{taus.max():.1f} ms over {len(taus)} steps")
    b = params.preset("ideal")
    j_true, b_true, tc_true = b.j_kgm2, b.b_motor_nms + b.b_gen_nms, b.tc_motor_nm + b.tc_gen_nm
    rows = identified()
    err = np.array([j / j_true - 1 for _, j, _, _, _ in rows])
    held = sum(lo <= j_true <= hi for _, _, (lo, hi), _, _ in rows)
    print(f"  identified J on seeds 1..{len(rows)} (truth {j_true * 1e7:.0f} g cm^2): "
          + " ".join(f"{j * 1e7:.0f}" for _, j, _, _, _ in rows))
    print(f"    error mean {100 * err.mean():+.0f} %, sd {100 * err.std():.0f} %, within 20 % in "
          f"{int((abs(err) <= 0.2).sum())} of {len(rows)}; the 95 % interval holds the truth in {held} of {len(rows)}")
    eb = np.array([bb / b_true - 1 for _, _, _, bb, _ in rows])
    et = np.array([tc / tc_true - 1 for _, _, _, _, tc in rows])
    print(f"    B error {100 * np.abs(eb).max():.1f} % at most, Tc {100 * np.abs(et).max():.1f} % at most")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
