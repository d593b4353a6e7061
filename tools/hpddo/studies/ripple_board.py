"""What the board's ripple counter gives through a warm-up (issue 23 item 5, docs/ripple-board-count.md,
"Figures through a warm-up"): a twin run in the ripple mode replayed through the host's
reference of the counting build (hpddo.ripple.board.track, which the simavr test
firmware.uno.sim_ripple_count holds the AVR build equal to), with the board's observer (the
fixed-point default model) as the prior, scored against the twin's truth: the ripple speed,
Ra and the winding temperature, with no temperature sensor.

    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_board            # ~1 min
    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_board --json F
    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_board --model DIR   # another model's prior and M2

The second table is the warm-up's error budget: the Ke the first KE_CAL_S of confident windows
calibrate, over five seeds of the same run (its spread and what it is worth in kelvin at the
warm-up's operating point: ke w / (I Ra0 alpha + ke w b), b the model's magnet coefficient),
the windows the Ra gate leaves out, and T's errors with the seeds' mean Ke in place of each
seed's own. The third: the 100 Hz load steps over seeds 1-7, the count's speed against the truth.

Each board window's burst is its last ripple_n periods (acq_ripple.h: 3968 of 5000 at 2 Hz,
768 of 1000 at 10 Hz), the counter runs on those codes; V and I are the twin log's window
means (the board's come from the window's first 20 %).
"""
from __future__ import annotations

import json
import math
import pathlib
import sys

import numpy as np

from .. import bench, resource_root
from ..model import export, quant
from ..ripple import board as rc
from ..twin import generate, params
from . import parser

RIPPLES_PER_REV = bench.HARDWARE.ripples_per_rev  # the build's ACQ_RIPPLES_PER_REV (bench_gen.h's by default)


def burst_n(window_periods: int) -> int:
    """acq_ripple.h ripple_burst_samples at 10 kHz and 500000 baud (whole chunks of 32 in the
    window less its 20 % V/I share and 3 stop periods, within the line's budget)."""
    room = window_periods - window_periods * 0.2 - 3
    n = int(room) // 32 * 32
    chars = 50000 * 0.8 * window_periods / 10000 - 96
    while n and (n // 32) * 82 > chars:
        n -= 32
    return n


def run(protocol: str = "long", time_scale: float = 0.1, rate_hz: float = 2.0, bench_twin=None, seed: int = 1,
        model_dir=None, ke_cal=None):
    """Replays one twin run through the board's counter; returns the per-window table and figures.
    ke_cal: the calibrated Ke (V s/rad) put in place of the tracker's own once it has one."""
    tw = bench_twin or params.preset("default")
    out = generate.generate(tw, protocol, rate_hz, seed, time_scale=time_scale,
                            ripple=params.ripple_burst(sample_hz=10000))
    log, truth = out["log"], out["truth"]
    _, burst_codes, _ = out["bursts"]
    model_dir = pathlib.Path(model_dir or resource_root() / "models" / "default")
    model = export.read_model_header((model_dir / "model_default.h").read_text())
    obs = quant.fixed_observer(model, quant.quantise(model))
    dt = 1.0 / rate_hz
    prior = np.array([float(obs.step(v, i, None, dt, k & 0xFFFF)["rpm"])
                      for k, (v, i) in enumerate(zip(log["v_V"], log["i_A"]))])
    n = burst_n(round(10000 / rate_hz))
    codes = [np.asarray(c)[len(c) - n:] for c in burst_codes]
    per_rev = RIPPLES_PER_REV * bench.HARDWARE.gear_ratio
    tracker = rc.RaTracker(model.physics, ke_fixed=ke_cal)  # kept for the budget: its Ke, its gate's count
    rows = rc.track(codes, log["v_V"].to_numpy(), log["i_A"].to_numpy(), prior, dt, model.physics, 10000.0, per_rev,
                    round(10000 / rate_hz) - n, ra=tracker)
    rpm = np.array([r["rpm"] if r["confident"] else np.nan for r in rows])
    have = np.array([r["have_ra"] for r in rows])
    ra = np.array([r["ra_ohm"] for r in rows])
    tw_c = np.array([r["tw_C"] for r in rows])
    rpm_true, ra_true, t_true = (truth[c].to_numpy() for c in ("rpm_true", "ra_ohm", "winding_C"))
    ok = np.isfinite(rpm)
    e_rpm = (rpm[ok] - rpm_true[ok]) / rpm_true[ok]
    e_ra = (ra[have] - ra_true[have]) / ra_true[have]
    e_t = tw_c[have] - t_true[have]
    figures = dict(protocol=protocol, time_scale=time_scale, rate_hz=rate_hz, windows=len(rows), burst_n=n,
                   confident=int(ok.sum()), rpm_rms_pct=float(100 * np.sqrt(np.mean(e_rpm ** 2))),
                   rpm_max_pct=float(100 * np.max(np.abs(e_rpm))), windows_with_ra=int(have.sum()),
                   ra_rms_pct=float(100 * np.sqrt(np.mean(e_ra ** 2))), ra_max_pct=float(100 * np.max(np.abs(e_ra))),
                   t_rms_K=float(np.sqrt(np.mean(e_t ** 2))), t_max_K=float(np.max(np.abs(e_t))),
                   t_true_start_C=float(t_true[0]), t_true_end_C=float(t_true[-1]),
                   t_est_end_C=float(tw_c[-1]), ra_true_end=float(ra_true[-1]), ra_est_end=float(ra[-1]),
                   ke_cal=float(tracker.ke_cal), ra_glitches=int(tracker.n_glitch),
                   ke_sens_K_per_pct=_ke_sensitivity(model.physics, log, truth, have))
    return figures


def _ke_sensitivity(p, log, truth, have) -> float:
    """Kelvin of winding temperature per 1 % of calibrated Ke at the run's median operating
    point: 0.01 ke w / (I Ra0 alpha + ke w b) (b the model's magnet coefficient, 0 without)."""
    if not have.any():
        return float("nan")
    i = float(np.median(log["i_A"].to_numpy()[have]))
    emf = float(np.median(truth["ke_vs_per_rad"].to_numpy()[have] * truth["rpm_true"].to_numpy()[have])) / rc.RPM_PER_RAD_S
    return 0.01 * emf / (i * p.ra_ohm * rc.ALPHA_CU + emf * p.ke_tc_per_K)


#: the budget's warm-ups per window rate (run's keywords beside protocol="long" and the seed)
BUDGET_RATES = (("2 Hz", dict(rate_hz=2.0)), ("10 Hz", dict(rate_hz=10.0)),
                ("100 Hz (time scale 0.02)", dict(rate_hz=100.0, time_scale=0.02)))


def budget(model_dir=None, seeds=(1, 2, 3, 4, 5), done=None):
    """The warm-up's error budget per window rate: each seed's calibrated Ke, its spread, the
    gate's left-out windows, and T's errors with the seeds' mean Ke in place of each seed's.
    done: {rate's name: run's figures} of warm-ups already run with the first seed (main's
    first table), not run again."""
    out = {}
    done = done or {}
    for name, kw in BUDGET_RATES:
        own = [done[name] if k == 0 and name in done else run(protocol="long", seed=s, model_dir=model_dir, **kw)
               for k, s in enumerate(seeds)]
        kes = np.array([f["ke_cal"] for f in own])
        mean_ke = float(kes.mean())
        fixed = [run(protocol="long", seed=s, model_dir=model_dir, ke_cal=mean_ke, **kw) for s in seeds]
        out[name] = dict(seeds=list(seeds), ke_cal=kes.tolist(), ke_sd_pct=float(100 * kes.std(ddof=1) / mean_ke),
                         k_per_pct=own[0]["ke_sens_K_per_pct"],
                         glitches=[f["ra_glitches"] for f in own], windows=[f["confident"] for f in own],
                         t_max_own=[f["t_max_K"] for f in own], t_max_mean_ke=[f["t_max_K"] for f in fixed],
                         t_end_err_own=[f["t_est_end_C"] - f["t_true_end_C"] for f in own],
                         t_end_err_mean_ke=[f["t_est_end_C"] - f["t_true_end_C"] for f in fixed])
    return out


def step_seeds(model_dir=None, seeds=range(1, 8)):
    """The load steps at 100 Hz windows, time scale 0.05 (a step every 1.25 s), over seeds:
    where "no confident estimate more than 5 % off" is tried hardest (the count lags a step the
    window's current does not show)."""
    return {s: run(protocol="load", rate_hz=100.0, time_scale=0.05, seed=s, model_dir=model_dir) for s in seeds}


def main(argv=None) -> int:
    ap = parser("ripple_board", __doc__)
    ap.add_argument("--model", type=pathlib.Path, metavar="DIR",
                    help="a trained model's folder (model_default.h) in place of models/default")
    a = ap.parse_args(argv)
    if a.model is not None and not (a.model / "model_default.h").is_file():
        ap.error(f"--model {a.model}: no model_default.h there (a folder hpddo train wrote)")
    warm = {"2 Hz": "long warm-up, 2 Hz, default twin", "10 Hz": "long warm-up, 10 Hz, default twin",
            "100 Hz (time scale 0.02)": "long warm-up, 100 Hz, default twin"}  # budget's rates: the same runs
    rates = dict(BUDGET_RATES)
    scenarios = [
        (warm["2 Hz"], dict(protocol="long", **rates["2 Hz"])),
        (warm["10 Hz"], dict(protocol="long", **rates["10 Hz"])),
        ("long warm-up, 2 Hz, magnets without temperature drift",
         dict(protocol="long", rate_hz=2.0, bench_twin=params.with_effects(params.preset("default"),
                                                                           magnet_thermal=0.0))),
        ("load steps, 2 Hz, default twin", dict(protocol="load", rate_hz=2.0)),
        (warm["100 Hz (time scale 0.02)"], dict(protocol="long", **rates["100 Hz (time scale 0.02)"])),
        ("load steps, 10 Hz, default twin", dict(protocol="load", rate_hz=10.0)),
        ("load steps, 100 Hz (time scale 0.02), default twin", dict(protocol="load", rate_hz=100.0, time_scale=0.02)),
    ]
    out = {}
    print("| scenario | windows | confident | speed RMS / max % | windows with Ra | Ra RMS / max % | "
          "winding T RMS / max K | T truth start -> end | T board end |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, kw in scenarios:
        f = run(model_dir=a.model, **kw)
        out[name] = f
        print(f"| {name} | {f['windows']} | {f['confident']} | {f['rpm_rms_pct']:.3f} / {f['rpm_max_pct']:.2f} | "
              f"{f['windows_with_ra']} | {f['ra_rms_pct']:.2f} / {f['ra_max_pct']:.2f} | {f['t_rms_K']:.2f} / "
              f"{f['t_max_K']:.2f} | {f['t_true_start_C']:.1f} -> {f['t_true_end_C']:.1f} | {f['t_est_end_C']:.1f} |")
        sys.stdout.flush()
    print()
    print("| warm-up, window rate | Ke calibrated, spread over seeds | K per 1 % of Ke | windows the Ra gate "
          "left out | T max error, each seed's Ke | T max error, the seeds' mean Ke | T end error, each seed's Ke |")
    print("|---|---|---|---|---|---|---|")
    b = budget(a.model, done={rate: out[name] for rate, name in warm.items()})
    for name, r in b.items():
        print(f"| {name} | {np.mean(r['ke_cal']):.4f} V s/rad, {r['ke_sd_pct']:.2f} % | {r['k_per_pct']:.2f} | "
              f"{', '.join(f'{g} of {w}' for g, w in zip(r['glitches'], r['windows']))} | "
              f"{', '.join(f'{x:.1f}' for x in r['t_max_own'])} | {', '.join(f'{x:.1f}' for x in r['t_max_mean_ke'])} | "
              f"{', '.join(f'{x:+.1f}' for x in r['t_end_err_own'])} |")
        sys.stdout.flush()
    out["budget"] = b
    print()
    print("| load steps, 100 Hz windows, time scale 0.05, seed | windows | confident | speed RMS % | speed max % |")
    print("|---|---|---|---|---|")
    st = step_seeds(a.model)
    for seed, f in st.items():
        print(f"| {seed} | {f['windows']} | {f['confident']} | {f['rpm_rms_pct']:.3f} | {f['rpm_max_pct']:.2f} |")
    out["load_steps_100hz_seeds"] = st
    if a.json:
        a.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
