"""Generate one recording: plant + sensors -> bench log + ground-truth sidecars.

Files written into the output directory for condition ``c``:

* ``c.csv`` -- the bench log (what the bench would record; no ground truth in it)
* ``c.truth.csv`` -- per sample: true output-shaft speed, true V/I means, winding and
  case temperature, the true Ra and Ke in force, conduction fraction, glitch flag
* ``c.truth.json`` -- generator version, preset, seed, rate, the effects with their
  magnitudes and units, every bench parameter, the injected glitches, a summary and
  the energy ledger of the run

Everything is a function of (preset, effects, protocol, rate, time scale, seed):
the same inputs give the same bytes. A protocol that declares an ambient temperature
(``bench.Protocol.ambient_C``, e.g. ``hot``) runs the bench at it; the truth JSON's
``bench.ambient_C`` and ``truth.case_C_start`` carry it.
"""
from __future__ import annotations

import json
import math
import pathlib

import numpy as np
import pandas as pd

from .. import bench as bench_hw
from .. import schema
from ..logs import benchlog
from ..logs import ripple as ripple_file
from . import plant, protocols, sensors
from . import ripple as ripple_mode
from .params import EFFECT_NAMES, EFFECTS, GENERATOR_VERSION, Bench

TRUTH_CSV = ".truth.csv"  # the per-sample ground truth beside each log: <condition>.truth.csv

PROTOCOL_SEED_OFFSET = {"sweep": 0, "load": 1, "long": 2, "unseen": 3, "hot": 4}

TRUTH_FORMATS = {
    "t_s": "%.4f",
    "rpm_true": "%.4f",
    "v_true_V": "%.6f",
    "i_true_A": "%.6f",
    "winding_C": "%.4f",
    "case_C": "%.4f",
    "ra_ohm": "%.6f",
    "ke_vs_per_rad": "%.6f",
    "cond_frac": "%.4f",
    "glitch": "%d",
}


def _r(x, nd=6):
    return float(round(float(x), nd))


def generate(bench: Bench, protocol: str, rate_hz: float = 2.0, seed: int = 1, out_dir=None,
             preset_name: str = "custom", time_scale: float = 1.0, progress=None, condition=None,
             ripple=None):
    """Simulate ``protocol`` and (if ``out_dir``) write the three files.

    ``ripple``: None (the default: no ripple mode, nothing changes), or the ripple mode's
    parameters (``params.ripple_burst()``): the PWM then runs at its sample rate, and a
    fourth file ``<condition>.ripple.csv`` holds one current burst per window
    (twin/ripple.py, docs/bench-log.md).

    Returns a dict with ``log`` (DataFrame as written), ``meta``, ``truth`` (DataFrame),
    ``info`` (the JSON content) and ``paths``.
    """
    if protocol not in protocols.KNOWN:
        raise ValueError(f"unknown protocol {protocol!r}")
    if not rate_hz > 0:
        raise ValueError("rate_hz must be > 0")
    condition = condition or protocol
    bench = protocols.bench_for(protocol, bench)  # the protocol's ambient, if it declares one
    if ripple is not None:  # the ripple mode: one current sample per PWM period
        import dataclasses
        bench = dataclasses.replace(bench, pwm_hz=float(ripple.get("pwm_hz") or ripple["sample_hz"]))  # free: its own
    segs = protocols.schedule(protocol, time_scale)
    duty, load = protocols.per_sample(segs, rate_hz)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), PROTOCOL_SEED_OFFSET[protocol]]))
    res = plant.simulate(bench, duty, load, rate_hz, progress=progress)
    cols, glitches = sensors.measure(bench, res, duty, load, rng)
    bursts = None
    if ripple is not None:  # its own random stream: the log's draws are those of a run without it
        rrng = np.random.default_rng(np.random.SeedSequence(
            [int(seed), PROTOCOL_SEED_OFFSET[protocol], ripple_mode.SEED_TAG]))
        bursts = ripple_mode.synthesise(bench, res, duty, ripple, rrng)
    log = pd.DataFrame(cols)

    rate_txt = f"{rate_hz:g}"
    meta = {
        "condition": condition,
        "sample_rate_hz": rate_txt,
        "motor": "25GA371 1:4.4 (bench twin)",
        "ra_ohm": f"{bench.ra_ohm:.2f}",
        "note": f"simulated by {GENERATOR_VERSION}, protocol={protocol}, seed={seed}; "
                f"ground truth in {condition}.truth.json / {condition}.truth.csv",
    }
    if rate_hz >= schema.DYNAMICS_MIN_RATE_HZ:  # a fast log carries its encoder's periods: their scale
        meta["encoder_counts_per_rev"] = f"{bench_hw.HARDWARE.encoder_quadrature * bench.encoder_ppr * bench.gear_ratio:g}"
    glitch_flag = np.zeros(len(duty), dtype=np.int64)
    for gl in glitches:
        glitch_flag[gl["row"]] = 1
    truth = pd.DataFrame({
        "t_s": log["t_s"],
        "rpm_true": res.w_mean * 60.0 / (2 * math.pi),
        "v_true_V": res.v_mean,
        "i_true_A": res.i_mean,
        "winding_C": res.tw,
        "case_C": res.tc,
        "ra_ohm": res.ra,
        "ke_vs_per_rad": res.ke,
        "cond_frac": res.cond,
        "glitch": glitch_flag,
    })

    rpm = truth["rpm_true"].to_numpy()
    info = {
        "generator_version": GENERATOR_VERSION,
        "condition": condition,
        "protocol": protocol,
        "preset": preset_name,
        "seed": int(seed),
        "sample_rate_hz": float(rate_hz),
        "time_scale": float(time_scale),
        "duration_s": _r(len(duty) / rate_hz, 4),
        "rows": int(len(duty)),
        "segments": [{"duration_s": _r(dd, 4), "duty": _r(du, 4), "load": int(ld)} for dd, du, ld in segs],
        "effects": {
            name: {
                "enabled": bench.effect(name) != 0.0,
                "magnitude": _r(bench.effect(name)),
                "unit": EFFECTS[name].unit,
                "physics": EFFECTS[name].physics,
            }
            for name in EFFECT_NAMES
        },
        "bench": {k: (_r(v, 9) if isinstance(v, float) else v)
                  for k, v in bench.to_dict().items() if k != "effects"},
        "truth": {
            "ke_true_ref_vs_per_rad": _r(bench.ke_vs_per_rad),
            "ra_true_at_ref_ohm": _r(bench.ra_ohm),
            "ra_ref_C": _r(bench.ra_ref_C),
            "rpm_true_max": _r(rpm.max(), 4),
            "case_C_start": _r(bench.ambient_C, 4),
            "case_C_end": _r(res.tc[-1], 4),
            "winding_C_end": _r(res.tw[-1], 4),
            "winding_C_max": _r(res.tw.max(), 4),
        },
        "glitches": glitches,
        "energy_J": {k: _r(v, 4) for k, v in res.energy.items()},
    }
    if ripple is not None:
        info["ripple"] = {k: _r(v, 9) for k, v in ripple.items()}
        info["ripple"]["ripples_per_rev"] = int(bench.ripples_per_rev)
        info["ripple"]["gear_ratio"] = _r(bench.gear_ratio, 9)
    paths = {}
    if out_dir is not None:
        out = pathlib.Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths["log"] = benchlog.write_log(out / f"{condition}.csv", log, meta)
        lines = [",".join(truth.columns)]
        fmts = [TRUTH_FORMATS[c] for c in truth.columns]
        arrs = [truth[c].tolist() for c in truth.columns]
        row_fmt = ",".join(fmts)
        lines += [row_fmt % tuple(r) for r in zip(*arrs)]
        paths["truth_csv"] = out / f"{condition}{TRUTH_CSV}"
        benchlog.write_text_atomic(paths["truth_csv"], "\n".join(lines) + "\n")
        paths["truth_json"] = out / f"{condition}.truth.json"
        benchlog.write_text_atomic(paths["truth_json"], json.dumps(info, indent=1, sort_keys=True) + "\n")
        if bursts is not None:
            t0, codes, rmeta = bursts
            paths["ripple"] = ripple_file.write(out / f"{condition}{ripple_file.SUFFIX}",
                                                {"condition": condition, **rmeta}, log["seq"], t0, codes)
    return {"log": log, "meta": meta, "truth": truth, "info": info, "paths": paths, "result": res,
            "bursts": bursts}
