"""Is the diagnosis' confidence a measured property? Randomised benches whose truth is known,
diagnosed with the defaults (no bootstrap, no hybrid: the physics verdict), and scored:

  * the empirical coverage of each kind of 95 % interval: Ke, Ra from the data alone, each
    named effect's coefficient (target 90-98 %);
  * the rate of each kind of false statement: an effect named that the bench does not have (nor any
    effect the verdict says it cannot be told from);
    "consistent with measurement noise" where an effect moves the speed by more than the floor;
    an Ra stated (--ra-ohm X) more than 10 % off; an actionable instruction that is wrong (an
    --ra-ohm further from the truth than the reading given, an effect to add that is absent, a
    recording of the motor called inconsistent); and how often a recording of another motor is
    named.

    python -m hpddo.studies.calibration [--benches N] [--seed S] [--json FILE] [--jobs J]

The benches: a quasi-static law, V = Ra(T) I + drop(I) + Ke(T, I) w, evaluated by the
library's own physics (model.physics) with random Ra (1-12 ohm), Ke (0.05-0.6 V s/rad at
the output shaft) and effects (brush_drop, thermal_ra, saturation, v_offset, each in about
a third of the benches, random sizes); the readings through channels with calibration errors
drawn within their tolerances (1 % voltage, 2 % current, declared in the header in half the
benches), ADC steps of 5-50 mV and 1-20 mA, noise; Ra given up to 15 % off; time series at
2-100 Hz (each operating point held 2 s) or steady-state tables of 20-200 rows (kind declared
in half); in some a fourth recording of another motor (Ke 13 % lower). No PWM, no dynamics:
the twin's plant (hpddo twin) adds those and is not used here, so that the truth is the
library's parametrisation exactly.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pathlib
import re
import sys
import tempfile

import numpy as np

EFFECTS = {  # effect -> (field, draw of its size)
    "brush_drop": ("brush_V", lambda rng: rng.uniform(0.2, 1.5)),
    "thermal_ra": ("ra_tc_per_K", lambda rng: 0.00393),
    "saturation": ("ke_sat_per_A", lambda rng: rng.uniform(0.03, 0.15)),
    "v_offset": ("v_offset_V", lambda rng: rng.choice([-1, 1]) * rng.uniform(0.05, 0.3)),
}
EFFECT_SHARE = 0.3
TOL = {"v_cal_rel": 0.01, "i_cal_rel": 0.02}
RATES_HZ = (2.0, 10.0, 50.0, 100.0)
HOLD_S = 2.0
OTHER_MOTOR_KE = 0.87
OTHER_MOTOR_SHARE = 0.15
RA_OFF_MAX = 0.15
T0_C = 25.0
WARM_K = 30.0
NOISE = {"v_V": 0.01, "i_A": 0.002, "rpm": 1.0}


@dataclasses.dataclass
class Bench:
    seed: int
    ra_ohm: float
    ke_vs_per_rad: float
    effects: dict            # effect -> true coefficient
    gains: dict              # channel tolerance key -> the channel's true relative gain error
    declared_cal: bool
    v_lsb_V: float
    i_lsb_A: float
    ra_given_ohm: float
    table: bool
    rate_hz: float
    rows: int                # a table's rows over its recordings
    declared_kind: bool
    other_motor: bool
    i_max_A: float
    # the channels' zero errors (intervals.ZERO_KEY's keys), V and A: within ZERO_STEPS of their steps, the
    # tolerance the diagnosis takes where a log declares none (one board: the same in every recording)
    zeros: dict = dataclasses.field(default_factory=dict)

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def draw(seed: int) -> Bench:
    """One random bench (seeded)."""
    rng = np.random.default_rng(seed)
    ra = float(math.exp(rng.uniform(math.log(1.0), math.log(12.0))))
    effects = {n: float(size(rng)) for n, (_, size) in EFFECTS.items() if rng.random() < EFFECT_SHARE}
    b = Bench(seed=seed, ra_ohm=ra, ke_vs_per_rad=float(rng.uniform(0.05, 0.6)), effects=effects,
          gains={k: float(rng.uniform(-t, t)) for k, t in TOL.items()}, declared_cal=bool(rng.random() < 0.5),
          v_lsb_V=float(rng.choice([0.005, 0.015, 0.05])), i_lsb_A=float(rng.choice([0.001, 0.005, 0.02])),
          ra_given_ohm=ra * float(rng.uniform(1 - RA_OFF_MAX, 1 + RA_OFF_MAX)), table=bool(rng.random() < 0.5),
          rate_hz=float(rng.choice(RATES_HZ)), rows=int(rng.integers(20, 201)),
          declared_kind=bool(rng.random() < 0.5), other_motor=bool(rng.random() < OTHER_MOTOR_SHARE),
          i_max_A=float(min(0.45 * 12.0 / ra, 3.0)))
    from ..diagnosis.intervals import ZERO_KEY, ZERO_STEPS
    steps = {"v": b.v_lsb_V, "i": b.i_lsb_A}
    zero_rng = np.random.default_rng(seed + 2_000_003)  # (drawn apart: every other draw as it was)
    return dataclasses.replace(b, zeros={ZERO_KEY[a]: float(zero_rng.uniform(-ZERO_STEPS, ZERO_STEPS) * steps[a])
                                         for a in ("v", "i")})


# The winding above the case (thermal_ra benches): the library's first-order node, 1.5 K/W and 20 s.
NODE = {"th_r_K_per_W": 1.5, "th_tau_s": 20.0}


def true_params(b: Bench, ke_scale: float = 1.0, with_effects: bool = True):
    from ..model import physics as ph

    kw = {EFFECTS[n][0]: v for n, v in b.effects.items()} if with_effects else {}
    if with_effects and "thermal_ra" in b.effects:
        kw.update(NODE)
    return ph.PhysicsParams(ra_ohm=b.ra_ohm, ke_vs_per_rad=b.ke_vs_per_rad * ke_scale, t_ref_C=T0_C,
                            t_amb_C=T0_C, **kw)


def winding(p, i, dt_s: float, case_C, settled: bool):
    """The winding's and the magnets' temperatures (physics.Temps) at the case readings case_C: the
    library's node over time (a time series, rows dt_s apart), or settled at every row (a table)."""
    from ..model import physics as ph

    if not p.thermal_enabled():
        return ph.Temps(case_C, case_C)
    if not settled:
        return ph.temperatures(p, i, np.full(len(i), dt_s), case_C)
    rise = np.zeros(len(i))
    for _ in range(50):  # the settled rise: r i^2 Ra(T_case + rise), by fixed point
        rise = p.th_r_K_per_W * i * i * ph.ra_at_ohm(p, case_C + rise)
    return ph.Temps(case_C + rise, case_C)


def points(b: Bench, which: str, n: int, rng) -> tuple:
    """(terminal volts, amps, case C) of n operating points of a recording: a duty sweep at light
    load, load steps at three voltages, or a warm-up alternating two loads as the case rises."""
    if which == "sweep":
        v = np.linspace(3.0, 12.0, n)
        i = np.full(n, 0.12 * b.i_max_A) * (1 + 0.1 * rng.random(n))
        t = np.full(n, T0_C)
    elif which == "load":
        v = np.repeat([6.0, 9.0, 12.0], math.ceil(n / 3))[:n]
        i = np.tile(np.linspace(0.15, 1.0, math.ceil(n / 3)), 3)[:n] * b.i_max_A
        t = np.full(n, T0_C + 2.0)
    else:  # warm
        v = np.full(n, 12.0)
        i = np.where(np.arange(n) % 2 == 0, 0.3, 0.9) * b.i_max_A
        t = T0_C + WARM_K * (1 - np.exp(-np.arange(n) / max(n / 3, 1)))
    return v, i, t


def write(b: Bench, folder: pathlib.Path) -> list:
    """The bench's recordings as bench logs in folder; their paths (another motor's last)."""
    from ..model import physics as ph

    rng = np.random.default_rng(b.seed + 1_000_003)
    names = ["sweep", "load", "warm"] + (["other"] if b.other_motor else [])
    paths = []
    for name in names:
        n_pts = max(b.rows // len(names), 7) if b.table else 10
        v, i, t = points(b, "load" if name == "other" else name, n_pts, rng)
        hold = 1 if b.table else int(b.rate_hz * HOLD_S)
        v, i, t = (np.repeat(x, hold) for x in (v, i, t))
        p = true_params(b, OTHER_MOTOR_KE if name == "other" else 1.0)
        n = len(v)
        dt = 1.0 if b.table else 1.0 / b.rate_hz
        # the library's law read backwards: the model's speed of the true readings is the shaft's
        rpm = ph.physics_rpm(dataclasses.replace(p, v_offset_V=0.0), v, i, np.zeros(n), winding(p, i, dt, t, b.table))
        v_read = (v * (1 + b.gains["v_cal_rel"]) + b.effects.get("v_offset", 0.0) + b.zeros.get("v_zero_V", 0.0)
                  + rng.normal(0, NOISE["v_V"], n))
        i_read = i * (1 + b.gains["i_cal_rel"]) + b.zeros.get("i_zero_A", 0.0) + rng.normal(0, NOISE["i_A"], n)
        v_read = np.round(v_read / b.v_lsb_V) * b.v_lsb_V
        i_read = np.round(i_read / b.i_lsb_A) * b.i_lsb_A
        rpm_read = rpm + rng.normal(0, NOISE["rpm"], n)
        meta = [f"# condition={name}", f"# ra_ohm={b.ra_given_ohm:.4g}", f"# v_lsb_V={b.v_lsb_V:g}",
                f"# i_lsb_A={b.i_lsb_A:g}"]
        if b.declared_cal:
            meta += [f"# {k}={TOL[k]:g}" for k in TOL]
        if b.declared_kind:
            meta.append(f"# kind={'steady_state' if b.table else 'time_series'}")
        if not b.table:
            meta.append(f"# sample_rate_hz={b.rate_hz:g}")
        duty = np.round(v / 12.0, 4)
        lines = meta + ["t_s,duty,v_V,i_A,rpm_ref,temp_C"]
        lines += [f"{k * dt:.4f},{duty[k]:.4f},{v_read[k]:.6g},{i_read[k]:.6g},{rpm_read[k]:.4f},{t[k]:.2f}"
                  for k in range(n)]
        path = folder / f"{name}.csv"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    return paths


def effect_rms_rpm(b: Bench) -> float:
    """RMS over the motor's recordings' points of what the bench's effects move the speed model by
    (the plain model at the true Ra and Ke against the one with the effects)."""
    from ..model import physics as ph

    rng = np.random.default_rng(0)
    d = []
    for name in ("sweep", "load", "warm"):
        v, i, t = points(b, name, 10, rng)
        full = ph.physics_rpm(true_params(b), v, i, np.zeros(len(v)), winding(true_params(b), i, 1.0, t, True))
        plain = ph.physics_rpm(true_params(b, with_effects=False), v, i, np.zeros(len(v)), ph.Temps(t, t))
        d.append(full - plain)
    d = np.concatenate(d)
    return float(np.sqrt(np.mean(d * d)))


def _covers(iv, truth) -> bool | None:
    if not iv or not iv.get("determined") or iv.get("lo") is None:
        return None
    return bool(iv["lo"] <= truth <= iv["hi"])


def score(b: Bench, js: dict, paths, effect_rms: float | None = None) -> dict:
    """What the diagnosis js said of bench b, against its truth. b: a Bench or any bench with its
    fields (ke_vs_per_rad, ra_ohm, ra_given_ohm, other_motor and effects, {library name: true
    coefficient}, NaN where the bench's law is not the library's form and no coefficient is
    comparable); effect_rms: the RMS RPM by which its effects move the plain model (default
    effect_rms_rpm(b))."""
    from ..diagnosis.intervals import ZERO_KEY
    from ..diagnosis.verdict import NOTHING
    from ..model import effects as fx

    out = {"covered": {}, "false": {}}
    ivs = {iv["field"]: iv for iv in js.get("intervals", [])}
    out["covered"]["Ke"] = _covers(ivs.get("ke_vs_per_rad"), b.ke_vs_per_rad)
    out["covered"]["Ra (data alone)"] = _covers((js.get("ra_fit") or {}).get("data_alone"), b.ra_ohm)
    # a channel's zero error (within its tolerance) is an offset of that channel: a named offset's truth holds it
    zeros = getattr(b, "zeros", None) or {}
    zero_of = {e: zeros.get(ZERO_KEY[ch], 0.0) for e, ch in fx.REST_READ.items()}
    for e in js.get("missing_effects", []):
        if e in b.effects and math.isfinite(b.effects[e]):
            out["covered"][f"{e} coefficient"] = _covers(ivs.get(fx.LIBRARY[e].field), b.effects[e] + zero_of.get(e, 0.0))
    # every channel has its gain error (within its tolerance): a named v_gain is present where its interval holds the
    # bench's drawn error (or it has none to compare), and absent where it does not (a +4.9 % gain named on a
    # channel within 1 % of true is a false statement, not the channel's error found)
    present = set(b.effects)
    v_true = (getattr(b, "gains", None) or {}).get("v_cal_rel")
    if "v_gain" in js.get("missing_effects", []) and v_true is not None:
        out["covered"]["v_gain coefficient"] = _covers(ivs.get(fx.LIBRARY["v_gain"].field), v_true)
        if out["covered"]["v_gain coefficient"] is not False:
            present.add("v_gain")
    elif v_true is None:
        present.add("v_gain")
    for e, z in zero_of.items():  # ... and a named offset the bench has no effect of is its channel's zero, where it holds it
        if e in js.get("missing_effects", []) and e not in b.effects and z:
            out["covered"][f"{e} coefficient"] = _covers(ivs.get(fx.LIBRARY[e].field), z)
            if out["covered"][f"{e} coefficient"] is not False:
                present.add(e)
    # a named effect that the verdict says cannot be told from others (a confounded group: "X and Y
    # cannot be told apart on these recordings") states one of the group: absent only when all are
    # (a channel's zero error of a code or more is that channel's offset, there on the bench, named or not)
    steps = {e: getattr(b, {"v": "v_lsb_V", "i": "i_lsb_A"}[ch], 0.0) for e, ch in fx.REST_READ.items()}
    there = present | {e for e, z in zero_of.items() if steps[e] and abs(z) >= steps[e]}
    groups = [set(g) for g in js.get("confounded", [])]
    absent_named = [e for e in js.get("missing_effects", []) if e not in present
                    and not any(e in g and g & there for g in groups)]
    verdict = js.get("verdict", "")
    floor = float(js.get("noise_rpm") or 0.0)
    ra_said = [float(x.rstrip(".")) for x in re.findall(r"--ra-ohm ([0-9.eE+-]+)", verdict)]
    units = (js.get("consistency") or {}).get("units", [])
    odd = [u["name"] for u in units if u.get("inconsistent")]
    odd += [o["recording"] for o in (js.get("consistency") or {}).get("other_motors", [])]
    out["false"]["effect named that is absent"] = bool(absent_named)
    out["false"]["'consistent with noise' with an effect above the floor"] = bool(
        NOTHING in verdict and (effect_rms_rpm(b) if effect_rms is None else effect_rms) > 2.0 * max(floor, NOISE["rpm"]))
    out["false"]["an Ra stated more than 10 % off"] = any(abs(x / b.ra_ohm - 1) > 0.10 for x in ra_said)
    out["false"]["a wrong instruction"] = bool(
        any(abs(x / b.ra_ohm - 1) > abs(b.ra_given_ohm / b.ra_ohm - 1) for x in ra_said)
        or absent_named or [u for u in odd if not u.startswith("other")])
    out["false"]["a recording called inconsistent that is not"] = bool([u for u in odd if not u.startswith("other")])
    # no bench of the study clips a channel (its readings have no range to clip at)
    out["false"]["a channel called saturated that does not clip"] = any(
        c.get("fault") == "saturated" for c in js.get("channels", []))
    out["other motor named"] = (any(u.startswith("other") for u in odd)) if b.other_motor else None
    # each effect on the bench (a channel's gain within its tolerance aside): named, or in a group the
    # verdict states with a named effect
    said = set(js.get("missing_effects", []))
    said |= {e for g in groups if g & said for e in g}
    out["found"] = {e: e in said for e in b.effects}
    out["named"], out["ra_said"], out["inconsistent"] = js.get("missing_effects", []), ra_said, odd
    return out


def run_one(seed: int) -> dict:
    """Draws, writes, diagnoses and scores one bench; a user error is recorded, a traceback is not
    caught (it is a bug)."""
    from ..diagnosis import core
    from ..logs.errors import USER_ERRORS

    b = draw(seed)
    with tempfile.TemporaryDirectory(prefix="hpddo-cal-") as tmp:
        paths = write(b, pathlib.Path(tmp))
        try:
            d = core.diagnose(paths, core.Options(ra_ohm=b.ra_given_ohm, bootstrap=0, hybrid=False))
        except USER_ERRORS as exc:
            # (the bench's folder, a temporary one, named BENCH: no random name in the study's JSON)
            return {"bench": b.to_json(), "refused": str(exc).replace(tmp, "BENCH")}
        js = d.to_json()
        # (no runtime: the committed run is the same bytes on any machine; hpddo bench --diagnose times the diagnosis)
        return {"bench": b.to_json(), "score": score(b, js, paths)}


def summarise(results: list) -> dict:
    """Coverage of each kind of interval and the rate of each false statement over the benches."""
    scored = [r["score"] for r in results if "score" in r]
    cov, false, found = {}, {}, {}
    for s in scored:
        for k, v in s.get("found", {}).items():
            found.setdefault(k, []).append(v)
        for k, v in s["covered"].items():
            if v is not None:
                cov.setdefault(k, []).append(v)
        for k, v in s["false"].items():
            false.setdefault(k, []).append(v)
    other = [s["other motor named"] for s in scored if s["other motor named"] is not None]
    return {"benches": len(results), "diagnosed": len(scored), "refused": len(results) - len(scored),
            "coverage": {k: {"n": len(v), "covered": int(sum(v)), "share": sum(v) / len(v)} for k, v in cov.items()},
            "false": {k: {"n": len(v), "count": int(sum(v)), "share": sum(v) / len(v)} for k, v in false.items()},
            "found": {k: {"n": len(v), "count": int(sum(v)), "share": sum(v) / len(v)} for k, v in sorted(found.items())},
            "other motor named": {"n": len(other), "count": int(sum(other))}}


def table(summary: dict) -> str:
    lines = [f"{summary['diagnosed']} of {summary['benches']} benches diagnosed ({summary['refused']} refused "
             "with a user error)", "", "| 95 % interval | benches | covers the truth |", "|---|---|---|"]
    for k, v in summary["coverage"].items():
        lines.append(f"| {k} | {v['n']} | {100 * v['share']:.1f} % |")
    lines += ["", "| false statement | benches | rate |", "|---|---|---|"]
    for k, v in summary["false"].items():
        lines.append(f"| {k} | {v['n']} | {100 * v['share']:.1f} % ({v['count']}) |")
    if summary.get("found"):
        lines += ["", "| effect on the bench | benches | named, or in a stated group with a named effect |",
                  "|---|---|---|"]
        for k, v in summary["found"].items():
            lines.append(f"| {k} | {v['n']} | {100 * v['share']:.1f} % ({v['count']}) |")
    o = summary["other motor named"]
    lines.append(f"\nanother motor's recording named: {o['count']} of {o['n']}")
    return "\n".join(lines)


FIGURES = "docs/figures/calibration.json"   # the committed run (--json), its command inside
DOC = "docs/diagnosis-limits.md"
WHAT = "the calibration study's figures"


def doc_markers() -> tuple:
    from . import doc_markers as markers
    return markers("calibration", WHAT, FIGURES)


def block_in(doc: str, figures: dict, markers: tuple, name: str, what: str) -> str:
    """doc (the text of the document name) with the block between markers rendered from a bench study's
    figures (its committed JSON): the command, then table() of its summary (this study, calibration_mismatch)."""
    from . import with_block
    block = f"Measured by `{figures['command']}`:\n\n{table(figures['summary'])}\n"
    return with_block(doc, markers, block, name, what)


def docs_text(doc: str, figures: dict) -> str:
    """doc (docs/diagnosis-limits.md's text) with its block of the study's figures rendered from figures
    (the committed JSON)."""
    return block_in(doc, figures, doc_markers(), DOC, WHAT)


def run_benches(module: str, description: str, run_one, docs: tuple, benches: int, argv=None) -> int:
    """The command line of a study over randomised benches (this one, calibration_mismatch): run_one(seed)
    on --benches seeds from --seed, on --jobs processes, the summary printed as table() renders it and
    every bench's result with it written to --json after each bench (a long run stopped early keeps what
    it measured); --write-docs: only the document's block from the committed figures. docs: (the
    document, the committed figures, docs_text(document's text, figures))."""
    doc, figures, docs_text_of = docs
    ap = argparse.ArgumentParser(prog=f"python -m hpddo.studies.{module}", description=description)
    ap.add_argument("--write-docs", action="store_true",
                    help=f"only write {doc}'s block of figures from the committed {figures}")
    ap.add_argument("--benches", type=int, default=benches)
    ap.add_argument("--seed", type=int, default=1, help="the first bench's seed (the others follow)")
    ap.add_argument("--jobs", type=int, default=1, help="benches diagnosed at once (processes)")
    ap.add_argument("--json", type=pathlib.Path, help="write every bench's result and the summary here")
    args = ap.parse_args(argv)
    if args.write_docs:
        from . import write_docs
        return write_docs(doc, figures, docs_text_of)
    seeds = list(range(args.seed, args.seed + args.benches))
    command = f"python -m hpddo.studies.{module} " + " ".join(argv if argv is not None else sys.argv[1:])
    from tqdm import tqdm

    def save(results):
        if args.json:
            tmp = args.json.with_name(args.json.name + ".partial")
            tmp.write_text(json.dumps({"command": command, "summary": summarise(results), "results": results},
                                      indent=1, default=float) + "\n")
            tmp.replace(args.json)

    results = []
    if args.jobs > 1:
        import multiprocessing as mp
        with mp.get_context("fork").Pool(args.jobs) as pool:
            for r in tqdm(pool.imap(run_one, seeds), total=len(seeds), file=sys.stderr, disable=None):
                results.append(r)
                save(results)
    else:
        for s in tqdm(seeds, file=sys.stderr, disable=None):
            results.append(run_one(s))
            save(results)
    print(table(summarise(results)))
    return 0


def main(argv=None) -> int:
    return run_benches("calibration", __doc__.split("\n\n")[0], run_one, (DOC, FIGURES, docs_text), 200, argv)


if __name__ == "__main__":
    sys.exit(main())
