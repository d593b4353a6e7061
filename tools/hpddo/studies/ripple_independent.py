"""The ripple count's confidence on an independent commutator simulation (docs/ripple-independent.md):
randomised benches of studies/commutator.py (S bars in
{3, 5, 6, 7, 8, 12}, the network solved per angle; torque balance with load steps or imposed speed
profiles; synchronous sampling at 8-20 kHz or free-running at 9.6 kHz under 490.196 Hz PWM; no
mains, mains declared, mains not declared), written as a bench log and its bursts file, read back
and counted by the product's own path (benchlog.read_log, ripple.log.speed_of_log, as `hpddo
ripple` does, Ke calibrated from the ripple and Ra the log's ra_ohm) with the ripples per revolution
given right, half and double. Scored against the simulation's true mean shaft speed per window:
the confident windows, those more than 5 % off (the target: none; with a wrong figure, the target is
no confident window at all), the RMS error of the confident, the coverage (confident share of the
driven windows), the reasons of the others, the stalls and the false ones.

    cd tools && PYTHONPATH=$PWD python -m hpddo.studies.ripple_independent --json ../docs/figures/ripple_independent.json
    cd tools && PYTHONPATH=$PWD python -m hpddo.studies.ripple_independent --write-docs
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import sys
import tempfile

import numpy as np

from ..logs import benchlog
from ..logs import ripple as rf
from ..ripple.line import comb_windows
from ..ripple.log import speed_of_log
from ..ripple.options import Options
from . import commutator as cm

FIGURES = "docs/figures/ripple_independent.json"
DOC = "docs/ripple-independent.md"
WHAT = "the independent commutator study's figures"
TARGET = 0.05                 # no confident window further off the truth than this
SEGMENTS = (3, 5, 6, 7, 8, 12)
SAMPLINGS = ("synchronous", "free")
MAINS = ("none", "declared", "undeclared")
GIVEN = ("right", "half", "double")
PROTOCOLS = ("duty_steps", "load_steps", "duty_ramp", "speed_steps", "speed_ramp", "creep_stall")
SEEDS = (1, 2)
WINDOWS = 20


@dataclasses.dataclass(frozen=True)
class Bench:
    """One randomised recording's settings (its draws from seed)."""

    segments: int
    sampling: str
    mains: str
    protocol: str
    seed: int


def given_of(n_true: int, given: str) -> int:
    return {"right": n_true, "half": n_true // 2, "double": 2 * n_true}[given]


def draw(bench: Bench) -> tuple:
    """(Motor, Drive, Protocol, what the user declares in the bursts file) of a bench, from its seed."""
    rng = np.random.default_rng([bench.seed, bench.segments, SAMPLINGS.index(bench.sampling), MAINS.index(bench.mains),
                                 PROTOCOLS.index(bench.protocol), 33])
    s = bench.segments
    vs = float(rng.choice([6.0, 12.0, 24.0]))
    ra = float(np.exp(rng.uniform(math.log(1.0), math.log(8.0))))
    n_free_rpm = rng.uniform(1500.0, 6000.0)
    ke = vs / (n_free_rpm * 2 * math.pi / 60)
    tau_m = rng.uniform(0.02, 0.1)                 # mechanical time constant J Ra / Ke^2
    stall_nm = ke * vs / ra
    gap = rng.uniform(0.04, 0.1)
    motor = cm.Motor(
        segments=s, ra_ohm=ra, ke_vs_per_rad=ke, la_H=float(np.exp(rng.uniform(math.log(3e-4), math.log(3e-3)))),
        contact_share=rng.uniform(0.05, 0.15), brush_pitches=rng.uniform(gap + 0.1, 0.45), gap_pitches=gap,
        coil_r=tuple(rng.normal(0, rng.uniform(0.01, 0.04), s)), coil_emf=tuple(rng.normal(0, rng.uniform(0.01, 0.04), s)),
        ecc=rng.uniform(0.0, 0.03), ecc_phase_rad=rng.uniform(0, 2 * math.pi),
        brush_offset_rad=rng.uniform(-0.03, 0.03) * 2 * math.pi / s, neutral_rad=rng.uniform(-0.03, 0.03),
        j_kgm2=tau_m * ke ** 2 / ra, b_nms=0.02 * stall_nm / (n_free_rpm * 2 * math.pi / 60),
        tc_nm=rng.uniform(0.05, 0.15) * stall_nm, diode_V=0.7)
    i_stall = vs / ra
    bits = int(rng.choice([10, 12]))
    bipolar = bits == 12
    full = 1.3 * i_stall * (2 if bipolar else 1)
    mains_hz = float(rng.choice([50.0, 60.0])) if bench.mains != "none" else 0.0
    if bench.sampling == "synchronous":
        pwm = float(2 * rng.integers(4000, 10001))
        sample = pwm
    else:
        pwm, sample = cm.FREE_PWM_HZ, cm.FREE_SAMPLE_HZ
    drive = cm.Drive(
        vs_V=vs, sampling=bench.sampling, pwm_hz=pwm, sample_hz=sample, mains_hz=mains_hz,
        mains_supply_rel=rng.uniform(0.005, 0.05) if mains_hz else 0.0,
        mains_pickup_A=rng.uniform(0.002, 0.01) * i_stall if mains_hz else 0.0,
        bounce_per_s=rng.uniform(5, 50), bounce_ohm=rng.uniform(0.3, 1.0) * ra, bounce_s=rng.uniform(5e-5, 3e-4),
        white_A=rng.uniform(0.002, 0.01) * i_stall, pink_A=rng.uniform(0.001, 0.005) * i_stall,
        a_per_code=full / 2 ** bits, offset_code=2 ** (bits - 1) if bipolar else 0, bits=bits,
        v_noise_V=0.002 * vs, i_noise_A=0.002 * i_stall)
    protocol = _protocol(bench.protocol, motor, vs, stall_nm, rng)
    declared = {}
    if bench.mains == "declared":
        declared[rf.MAINS_HZ] = f"{mains_hz:g}"
    return motor, drive, protocol, declared


def _protocol(kind: str, m: cm.Motor, vs: float, stall_nm: float, rng) -> cm.Protocol:
    n = WINDOWS
    if kind == "duty_steps":
        duty, k = [], 0
        while len(duty) < n:
            d = 0.0 if k == 2 else float(np.round(rng.uniform(0.25, 1.0), 3))
            duty += [d] * (2 if d == 0 else int(rng.integers(3, 7)))
            k += 1
        return cm.Protocol(tuple(duty[:n]))
    if kind == "load_steps":
        d = float(np.round(rng.uniform(0.6, 1.0), 3))
        load, level = [], 0.0
        while len(load) < n:
            level = float(rng.uniform(0.0, 0.4)) * stall_nm if load else 0.0
            load += [level] * int(rng.integers(3, 7))
        return cm.Protocol((d,) * n, tuple(load[:n]))
    if kind == "duty_ramp":
        return cm.Protocol(tuple(np.round(np.linspace(0.2, 1.0, n), 3)))
    w_max = vs / m.ke_vs_per_rad
    i_load = rng.uniform(0.1, 0.4) * vs / m.ra_ohm
    if kind == "speed_steps":
        pts, t = [(0.0, 0.0)], 0.0
        w = 0.0
        while t < n * cm.WINDOW_S:
            t_step = t + rng.uniform(1.0, 3.0)
            pts.append((t_step, w))
            w = rng.uniform(0.15, 0.8) * w_max
            pts.append((t_step + rng.uniform(0.005, 0.05), w))
            t = t_step
        imposed = tuple(pts)
    elif kind == "speed_ramp":
        imposed = ((0.0, 0.1 * w_max), (n * cm.WINDOW_S, 0.8 * w_max))
    else:  # creep_stall: standing, creeping (0.5..3 RPM), then turning
        creep = rng.uniform(0.5, 3.0) * 2 * math.pi / 60
        turn = rng.uniform(0.2, 0.6) * w_max
        t1, t2 = 6 * cm.WINDOW_S, 12 * cm.WINDOW_S
        imposed = ((0.0, 0.0), (t1, 0.0), (t1 + 0.01, creep), (t2, creep), (t2 + 0.2, turn), (n * cm.WINDOW_S, turn))
    bt, bw = np.asarray(imposed).T
    centres = (np.arange(n) + 0.5) * cm.WINDOW_S
    w_c = np.interp(centres, bt, bw)
    # the duty that drives the load's current at the window's speed (the PWM's mean voltage)
    duty = np.clip((m.ke_vs_per_rad * w_c + m.ra_ohm * i_load) / vs, 0.05, 1.0)
    return cm.Protocol(tuple(np.round(duty, 3)), imposed=imposed)


def simulate(bench: Bench) -> tuple:
    """(the simulation's result, the Motor, the user's declarations) of a bench."""
    motor, drive, protocol, declared = draw(bench)
    return cm.simulate(motor, drive, protocol, bench.seed), motor, declared


def write_files(folder, name: str, sim: dict, motor: cm.Motor, declared: dict, seed: int) -> pathlib.Path:
    """The bench log `<name>.csv` and its bursts `<name>.ripple.csv` in folder, as a user's recording:
    ra_ohm a multimeter's reading, a few % off the mean brush-to-brush resistance."""
    rng = np.random.default_rng([seed, 77])
    folder = pathlib.Path(folder)
    path = folder / f"{name}.csv"
    meta = {"condition": name, "sample_rate_hz": f"{1 / cm.WINDOW_S:g}",
            "ra_ohm": f"{motor.ra_ohm * (1 + rng.uniform(-0.05, 0.05)):.4f}",
            "note": "independent commutator simulation (hpddo.studies.commutator)"}
    benchlog.write_log(path, sim["log"], meta)
    t0, codes, bmeta = sim["bursts"]
    rf.write(rf.path_for(path), {**bmeta, **declared}, sim["log"]["seq"].to_numpy(), t0, codes)
    return path


def score(est, sim: dict, given: int, n_true: int) -> dict:
    """One count of one bench against its truth."""
    true = sim["rpm_true"]
    rows = est["row"].to_numpy()
    true = true[rows]
    duty = sim["log"]["duty"].to_numpy()[rows]
    conf = est["confident"].to_numpy(bool)
    rpm = est["rpm"].to_numpy(float)
    driven = duty > 0
    moving = true > 0
    err = np.full(len(est), np.inf)
    err[moving] = rpm[moving] / true[moving] - 1
    off = conf & ~(np.abs(err) <= TARGET)
    ec = err[conf & moving]
    stall = est["stall"].to_numpy(bool)
    bound = est["rpm_bound"].to_numpy(float)
    false_stall = stall & ~(np.abs(true) <= bound)
    reasons = {}
    for k, v in est.loc[driven & ~conf, "key"].value_counts().sort_index().items():
        reasons[str(k)] = int(v)
    wrong = [{"window": int(r), "rpm_true": round(float(t), 3), "rpm": round(float(x), 3),
              "err_pct": round(100 * float(e), 2) if math.isfinite(e) else None,
              "f_Hz": round(float(f), 2), "rpm_prior": round(float(p), 1)}
             for r, t, x, e, f, p in zip(rows[off], true[off], rpm[off], err[off], est["f_Hz"].to_numpy()[off],
                                          est["rpm_prior"].to_numpy()[off])]
    m = est["multiple"].to_numpy(int)
    comb = comb_windows(est)
    return {"given": int(given), "windows": int(len(est)), "driven": int(driven.sum()), "confident": int(conf.sum()),
            "comb_windows": int(comb.sum()), "comb_at_given": int((comb & (m == given)).sum()),
            "over_target": int(off.sum()),
            "rms_pct": float(100 * np.sqrt(np.mean(ec ** 2))) if len(ec) else None,
            "worst_pct": float(100 * np.max(np.abs(ec))) if len(ec) else None,
            "stalls": int(stall.sum()), "false_stalls": int(false_stall.sum()),
            "reasons": reasons, "wrong": wrong}


def run_bench(bench: Bench, folder=None) -> dict:
    """One bench simulated, written, read back and counted three times (the ripples per revolution
    given right, half, double)."""
    sim, motor, declared = simulate(bench)
    n_true = cm.ripples_per_rev(bench.segments)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_files(folder or tmp, "bench", sim, motor, declared, bench.seed)
        log = benchlog.read_log(path)
        out = {**dataclasses.asdict(bench), "ripples_per_rev": n_true,
               "rpm_range": [round(float(np.min(sim["rpm_true"])), 1), round(float(np.max(sim["rpm_true"])), 1)]}
        for g in GIVEN:
            n = given_of(n_true, g)
            est, ke, _ = speed_of_log(path, log.df, log.meta, Options(n, 1.0))
            out[g] = {**score(est, sim, n, n_true), "ke_vs_per_rad": round(float(ke), 6) if math.isfinite(ke) else None}
    out["ke_true_vs_per_rad"] = round(motor.ke_vs_per_rad, 6)
    return out


def benches(seeds=SEEDS, segments=SEGMENTS) -> list:
    """Every segment count x sampling x mains, per seed; the protocols in turn over the sampling x mains
    settings, their order shifted by one from one segment count to the next, so that each setting meets every
    protocol over the segment counts."""
    out = []
    for seed in seeds:
        for i, s in enumerate(segments):
            for j, (sampling, mains) in enumerate((a, b) for a in SAMPLINGS for b in MAINS):
                out.append(Bench(s, sampling, mains, PROTOCOLS[(i + j + seed) % len(PROTOCOLS)], seed))
    return out


def summarise(cases: list) -> list:
    """Per sampling, mains and figure given: the benches, windows, driven, confident, over the target,
    the RMS and worst error of the confident, the reasons of the driven windows not confident."""
    rows = []
    for sampling in SAMPLINGS:
        for mains in MAINS:
            for g in GIVEN:
                rs = [c[g] for c in cases if c["sampling"] == sampling and c["mains"] == mains]
                if not rs:
                    continue
                conf = sum(r["confident"] for r in rs)
                sq = sum(r["rms_pct"] ** 2 * r["confident"] for r in rs if r["rms_pct"] is not None)
                worst = [r["worst_pct"] for r in rs if r["worst_pct"] is not None]
                reasons = {}
                for r in rs:
                    for k, v in r["reasons"].items():
                        reasons[k] = reasons.get(k, 0) + v
                rows.append({"sampling": sampling, "mains": mains, "given": g, "benches": len(rs),
                             "windows": sum(r["windows"] for r in rs), "driven": sum(r["driven"] for r in rs),
                             "confident": conf, "over_target": sum(r["over_target"] for r in rs),
                             "rms_pct": math.sqrt(sq / conf) if conf else None,
                             "worst_pct": max(worst) if worst else None,
                             "stalls": sum(r["stalls"] for r in rs), "false_stalls": sum(r["false_stalls"] for r in rs),
                             "reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1]))})
    return rows


def table(rows: list) -> str:
    """One row per sampling and mains: the figure given right (confident of the driven windows, more than 5 %
    off, the RMS and worst of the confident), half and double (confident, more than 5 % off), the reasons."""
    lines = ["| sampling | mains | benches | driven windows | right: confident (coverage) / more than 5 % off | "
             "RMS / worst of the confident | half: confident / off | double: confident / off | stalls (false) | "
             "right, driven, not confident: why |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    by = {(r["sampling"], r["mains"], r["given"]): r for r in rows}
    for (sampling, mains) in dict.fromkeys((r["sampling"], r["mains"]) for r in rows):
        r, h, d = (by[(sampling, mains, g)] for g in GIVEN)
        err = "–" if r["rms_pct"] is None else f"{r['rms_pct']:.3g} % / {r['worst_pct']:.3g} %"
        why = ", ".join(f"{k} {v}" for k, v in sorted(r["reasons"].items(), key=lambda kv: (-kv[1], kv[0]))[:5])
        lines.append(f"| {sampling} | {mains} | {r['benches']} | {r['driven']} | {r['confident']} "
                     f"({r['confident'] / r['driven']:.1%}) / {r['over_target']} | {err} | {h['confident']} / "
                     f"{h['over_target']} | {d['confident']} / {d['over_target']} | {r['stalls']} ({r['false_stalls']}) | "
                     f"{why} |")
    return "\n".join(lines)


def doc_markers() -> tuple:
    from . import doc_markers as markers
    return markers("ripple_independent", WHAT, FIGURES)


def docs_text(doc: str, figures: dict) -> str:
    from . import with_block
    block = (f"Measured by `{figures['command']}` ({len(figures['cases'])} benches of {WINDOWS} windows: "
             f"S in {{{', '.join(map(str, figures['segments']))}}}, seeds {', '.join(map(str, figures['seeds']))}; "
             "errors against the simulation's true window-mean speed):\n\n" + table(figures["summary"]) + "\n")
    return with_block(doc, doc_markers(), block, DOC, WHAT)


def main(argv=None) -> int:
    import json
    from . import parser, write_docs
    ap = parser("ripple_independent", __doc__)
    ap.add_argument("--write-docs", action="store_true",
                    help=f"only write {DOC}'s block of figures from the committed {FIGURES}")
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)), metavar="S,S,..")
    ap.add_argument("--segments", default=",".join(map(str, SEGMENTS)), metavar="S,S,..")
    a = ap.parse_args(argv)
    if a.write_docs:
        return write_docs(DOC, FIGURES, docs_text)
    seeds = [int(s) for s in a.seeds.split(",")]
    segments = [int(s) for s in a.segments.split(",")]
    cases = []
    for b in benches(seeds, segments):
        c = run_bench(b)
        cases.append(c)
        print(f"S={b.segments} {b.sampling} mains {b.mains} {b.protocol} seed {b.seed}: "
              + "; ".join(f"{g} {c[g]['confident']}/{c[g]['driven']} conf, {c[g]['over_target']} off" for g in GIVEN),
              file=sys.stderr, flush=True)
    command = "python -m hpddo.studies.ripple_independent " + " ".join(argv if argv is not None else sys.argv[1:])
    figures = {"command": command.strip(), "seeds": seeds, "segments": segments, "windows": WINDOWS,
               "summary": summarise(cases), "cases": cases}
    print(table(figures["summary"]))
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(figures, indent=1, sort_keys=True, allow_nan=False) + "\n",
                                        encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
