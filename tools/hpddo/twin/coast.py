"""The coast probe in the twin (issue 33, item 7; docs/ripple-coast.md): a warm-up run whose drive
is switched off for probe_s every period_s (params.COAST_PROBE), so the open terminals show the
back-EMF itself, and what the estimator (hpddo.ripple.coast) needs of it.

The run: rows of probe_s (the log's row period, so a probe is one row), a schedule of
(duration_s, duty, load) segments, every period_s a row at duty 0. The plant (twin/plant.py)
integrates it as any run: the winding and the case (and the magnets' node) warm at their own time
constants, the copper's Ra and the magnets' Ke follow them. The log's rows come from
twin/sensors.py (the averaging ADC, the DS18B20, the encoder).

Inside a probe row the plant's averaged model is replaced, for the bursts, by the switched
circuit, exactly:

* the current at the cut is the PWM's periodic steady state at the cut's phase
  (plant.pwm_waveform); from there the freewheel diode carries it towards
  -(Vf + E + vb) / R_off with La / R_off until it reaches zero (t_c); the terminals read
  -(Vf + (Rsh + rd) i) while it flows, the back-EMF Ke w after;
* the shaft: J dw/dt = Ke i - (B w + Tc), B the motor's, the generator's friction and the
  load's braking (plant.load_damping_nms), Tc the Coulomb torques: the motor slows at its
  mechanical time constant (J / B, 16 ms under the heaviest load, so 4 ms cost up to a quarter
  of the speed there), the back-EMF falls with it;
* one converter samples the two channels in turn, the current at even ticks of 1 / sample_hz
  and the terminal voltage at odd ones, each through its channel (gain error, offset, divider
  and level shift, the ADC's noise and steps).

Limits: the armature reaction (saturation) is left out inside the probe; the rows after a probe
restart from the plant's averaged model, whose current decays with La / R_loop (0.5 ms) where the
switched one reaches zero in about 0.2 ms, so the twin's speed steps by a few % at the probe's
end, inside the recovery that the estimator leaves out (options.CoastOptions.recovery_s).

The current bursts beside the probes (burst_s each side) are twin/ripple.py's, synchronous or
free-running (twin/ripple_free.py) as the ripple parameters ask. The random draws come from
streams of their own (SEED_TAG), so nothing else of the twin changes.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from ..logs import ripple as rf
from ..logs import coast as coast_file
from ..logs.coast import ProbeBursts
from . import plant, ripple_free, sensors
from . import ripple as ripple_mode
from .params import Bench, brush_share, coast_probe, offset_share, ripple_burst, v_gain_share

SEED_TAG = 33  # the probes' stream: SeedSequence([seed, 33]); the bursts' [seed, 33, ripple.SEED_TAG]


@dataclasses.dataclass
class CoastRecord:
    """A warm-up with coast probes: the log (sensors.measure's columns, one row per probe_s), the
    current bursts beside the probes (logs.ripple.Bursts, one per row kept), the probes, and the
    truth per row (t_s, ra_ohm, winding_C, case_C, ke_vs_per_rad, rpm_true, cond_frac: the share of the
    time the current flows)."""

    log: pd.DataFrame
    bursts: rf.Bursts
    probes: ProbeBursts
    truth: pd.DataFrame
    bench: Bench
    probe: dict
    ripple: dict
    facts: pd.DataFrame | None = None  # per probe the true cut: t_s, w_cut, ke, t_decay_s, i_cut_A, w_end


def schedule(segments, probe: dict | None, rate_hz: float):
    """Per row duty and load of the segments (duration_s, duty, load) at rate_hz, with the drive off
    every probe['period_s'] (None: no probe): (duty, load, the probe rows)."""
    from . import protocols
    duty, load = protocols.per_sample(segments, rate_hz)
    duty = duty.copy()
    if probe is None:
        return duty, load, np.zeros(0, np.int64)
    every = probe["period_s"] * rate_hz
    rows = np.round(np.arange(1, int(len(duty) / every) + 1) * every).astype(np.int64)
    rows = rows[(rows > 0) & (rows < len(duty) - 1)]
    rows = rows[duty[rows - 1] > 0]  # a probe cuts a running drive
    duty[rows] = 0.0
    return duty, load, rows


def _sliced(res, a: int, b: int):
    """The plant's result over rows a..b-1 (its boundaries a..b), for twin/ripple.py."""
    kw = {k: v[a:b] for k, v in res.__dict__.items() if isinstance(v, np.ndarray) and len(v) == len(res.i_mean)}
    return plant.Result(theta=res.theta[a:b + 1], w_bound=res.w_bound[a:b + 1], rate_hz=res.rate_hz, **kw)


def _probe(bench: Bench, res, k: int, d_prev: float, load: int, rp: dict, rng):
    """One probe row k: (current codes, voltage codes, the true cut facts)."""
    T = 1.0 / res.rate_hz
    fs = rp["sample_hz"]
    n2 = max(1, int(math.floor(T * fs + 1e-9)) // 2)
    t_i = 2 * np.arange(n2) / fs
    t_v = t_i + 1.0 / fs
    la = bench.effect_si("inductance")
    ke, ra, w0 = float(res.ke[k]), float(res.ra[k]), float(res.w_bound[k])
    i_prev = max(float(res.i_mean[k - 1]), 0.0)
    vb = bench.effect_si("brush_drop") * brush_share(bench.form("brush_drop"), i_prev)
    pwm_hz = float(rp.get("pwm_hz") or fs)
    pb = dataclasses.replace(bench, pwm_hz=pwm_hz)
    E0 = ke * w0
    i0 = float(plant.pwm_waveform(np.array([(k * T * pwm_hz) % 1.0]), d_prev, E0, vb, ra, la, pb)[0])
    r_off = ra + bench.r_shunt_ohm + bench.diode_r_ohm
    i2 = -(bench.diode_vf_V + E0 + vb) / r_off  # the freewheel's asymptote (< 0)
    tau = la / r_off if la > 0 else 0.0
    t_c = tau * math.log((i0 - i2) / -i2) if (i0 > 0 and tau > 0) else 0.0

    def current(t):
        t = np.asarray(t, float)
        if t_c <= 0:
            return np.zeros_like(t)
        return np.where(t < t_c, np.maximum(i2 + (i0 - i2) * np.exp(-t / tau), 0.0), 0.0)

    # the shaft: J dw/dt = Ke i - B w - Tc, exactly for the linear part (an integrating factor on a fine grid)
    J = bench.j_kgm2
    B = bench.b_motor_nms + bench.b_gen_nms + plant.load_damping_nms(bench, load)
    Tc = bench.tc_motor_nm + bench.tc_gen_nm
    from scipy.integrate import cumulative_trapezoid
    tg = np.linspace(0.0, T, 4001)
    beta = B / J
    f = (ke * current(tg) - Tc) / J
    w = np.exp(-beta * tg) * (w0 + cumulative_trapezoid(np.exp(beta * tg) * f, tg, initial=0.0))
    w = np.maximum(w, 0.0)  # static friction holds a shaft that has stopped
    i_at = current(t_i)
    v_true = np.where(t_v < t_c, -(bench.diode_vf_V + (bench.r_shunt_ohm + bench.diode_r_ohm) * current(t_v)),
                      ke * np.interp(t_v, tg, w))
    t_abs_v, t_abs_i = k * T + t_v, k * T + t_i
    v_in = (v_true * (1.0 + bench.effect_si("v_gain") * v_gain_share(bench.form("v_gain"), v_true))
            + bench.effect_si("v_offset") * offset_share(bench.form("v_offset"), t_abs_v, res.tc[k], bench.ambient_C))
    i_in = i_at + bench.effect_si("current_offset") * offset_share(bench.form("current_offset"), t_abs_i, res.tc[k],
                                                                   bench.ambient_C)
    lsb = bench.adc_vref_V / (2 ** bench.adc_bits)
    full = 2 ** bench.adc_bits - 1
    cv = bench.v_div_gain * (v_in + bench.v_shift_V) / lsb
    ci = i_in * bench.i_gain_V_per_A / lsb
    if bench.noise:
        cv = cv + bench.adc_noise_lsb * rng.standard_normal(n2)
        ci = ci + bench.adc_noise_lsb * rng.standard_normal(n2)
    codes_v = np.clip(np.round(cv), 0, full).astype(np.int64)
    codes_i = np.clip(np.round(ci), 0, full).astype(np.int64)
    facts = {"t_s": k * T, "w_cut": w0, "ke": ke, "t_decay_s": t_c, "i_cut_A": i0,
             "w_end": float(w[-1])}
    return codes_i, codes_v, facts


def warmup(bench: Bench, segments, seed: int = 1, probe: dict | None = None, ripple: dict | None = None):
    """A warm-up run of `segments` (duration_s, duty, load) with coast probes (probe: params.coast_probe();
    None: none) and the current bursts beside them (ripple: params.ripple_burst() and, for free-running
    sampling, twin.ripple_free.ripple_free()'s keys; None: the synchronous defaults). A CoastRecord."""
    rp = ripple if ripple is not None else ripple_burst()
    pr = probe if probe is not None else coast_probe()
    rate_hz = 1.0 / pr["probe_s"]
    bench = dataclasses.replace(bench, pwm_hz=float(rp.get("pwm_hz") or rp["sample_hz"]))
    duty, load, rows = schedule(segments, probe, rate_hz)
    res = plant.simulate(bench, duty, load, rate_hz)
    cols, _ = sensors.measure(bench, res, duty, load, np.random.default_rng(np.random.SeedSequence([int(seed)])))
    log = pd.DataFrame(cols)
    truth = pd.DataFrame({"t_s": log["t_s"], "ra_ohm": res.ra, "winding_C": res.tw, "case_C": res.tc,
                          "ke_vs_per_rad": res.ke, "rpm_true": res.w_mean * 60.0 / (2 * math.pi),
                          "cond_frac": res.cond})
    prng = np.random.default_rng(np.random.SeedSequence([int(seed), SEED_TAG]))
    brng = np.random.default_rng(np.random.SeedSequence([int(seed), SEED_TAG, ripple_mode.SEED_TAG]))
    T = 1.0 / rate_hz
    side = max(1, int(round(pr["burst_s"] * rate_hz)))
    # the rows whose bursts are kept: burst_s on each side of every probe (the first burst_s without one)
    keep = np.zeros(len(duty), bool)
    for k in rows if len(rows) else [side]:
        keep[max(0, k - side):k] = True
        keep[k + 1:k + 1 + side] = True
    keep[rows] = False
    t0s, codes, seqs, bmeta = [], [], [], None
    edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        t0, c, bmeta = ripple_mode.synthesise(bench, _sliced(res, a, b), duty[a:b], rp, brng)
        t0s.extend(np.asarray(t0) + a * T)
        codes.extend(c)
        seqs.extend(range(a, b))
    bmeta = {"condition": "coast", **(bmeta or {"sample_hz": f"{rp['sample_hz']:g}"})}
    bursts = rf.of_meta({"format": rf.FORMAT, **{k: str(v) for k, v in bmeta.items()}}, np.array(seqs, np.int64),
                        np.array(t0s, float), codes)
    pi, pv, facts = [], [], []
    for k in rows:
        ci, cv, fx = _probe(bench, res, int(k), float(duty[k - 1]), int(load[k]), rp, prng)
        pi.append(ci)
        pv.append(cv)
        facts.append(fx)
    lsb = bench.adc_vref_V / (2 ** bench.adc_bits)
    probes = ProbeBursts(sample_hz=float(rp["sample_hz"]), a_per_code=lsb / bench.i_gain_V_per_A,
                         v_per_code=lsb / bench.v_div_gain, v_shift_V=bench.v_shift_V,
                         seq=np.asarray(rows, np.int64), t_s=np.asarray(rows, float) * T, i_codes=pi, v_codes=pv)
    return CoastRecord(log=log, bursts=bursts, probes=probes, truth=truth, bench=bench, probe=pr, ripple=rp,
                       facts=pd.DataFrame(facts))


def write(rec: CoastRecord, out_dir, condition: str = "coast", note: str = "") -> dict:
    """The record as files in out_dir, as a bench would write them: the bench log `<condition>.csv`
    (its Ra at the reference temperature in the metadata), the current bursts `<condition>.ripple.csv`,
    the probes `<condition>.coast.csv` and the twin's truth per row `<condition>.truth.csv`. Returns
    {kind: path}."""
    import pathlib

    from ..logs import benchlog
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    b = rec.bench
    meta = {"condition": condition, "sample_rate_hz": f"{1.0 / rec.probe['probe_s']:g}",
            "motor": "25GA371 1:4.4 (bench twin)", "ra_ohm": f"{b.ra_ohm:.2f}",
            "note": note or f"coast probe warm-up of the bench twin; truth in {condition}.truth.csv"}
    paths = {"log": benchlog.write_log(out / f"{condition}.csv", rec.log, meta)}
    bz = rec.bursts
    paths["ripple"] = rf.write(out / f"{condition}{rf.SUFFIX}", {**{k: v for k, v in bz.meta.items() if k != "format"},
                                                                "condition": condition}, bz.seq, bz.t_s, bz.codes)
    paths["coast"] = coast_file.write(out / f"{condition}{coast_file.SUFFIX}", rec.probes, {"condition": condition})
    paths["truth"] = benchlog.write_text_atomic(out / f"{condition}.truth.csv",
                                                rec.truth.to_csv(index=False, float_format="%.6f", lineterminator="\n"))
    return paths
