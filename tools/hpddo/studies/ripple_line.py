"""The ripple line's identity from the data (docs/ripple-line.md, "How the line is found"): twin
benches where the user gives the wrong ripples per revolution (half, double), a damaged
commutator (one segment's contact resistance raised), and the same windows under two back-EMF
priors 12 % apart. Each case is counted as hpddo ripple counts it (ripple.speed_of_log) and
scored against the twin's truth; the ripples per revolution are found from the data alone and
from the encoder (calibrate.calibrate), and the commutator's health lines are read per window.

    cd tools && ../.venv/bin/python -m hpddo.studies.ripple_line --json ../docs/figures/ripple_line.json

The figures of docs/ripple-line.md, "Measured: the line's identity" are this JSON's (test_ripple_line.py
holds the page to it).
"""
from __future__ import annotations

import dataclasses
import math
import sys

import numpy as np

from ..logs import ripple as rf
from ..ripple.log import speed_of_log
from ..ripple.options import Options
from ..ripple import calibrate as rcal
from ..ripple import comb as rc
from ..twin import generate, params
from . import report

WINDOW_S = 0.5
PROTOCOLS = ("sweep", "load")
TIME_SCALE = 0.25
SEED = 1
PRIOR_APART = 1.12   # the second prior's Ke over the first's
WRONG = 0.05         # a confident window further than this from the truth is wrong
MIN_CYCLES = 3.0     # the driven windows whose share confident is scored hold at least this many cycles
BAR_FAULT_PCT = 30.0  # the damaged commutator's segment: contact resistance + 30 % of the loop's
BAR_FAULT_SMALL_PCT = 10.0  # a smaller fault, to see the health threshold's margin


@dataclasses.dataclass(frozen=True)
class Case:
    name: str
    what: str
    given: int = None          # ripples per revolution the user gives; None: the bench's
    ripple: dict = dataclasses.field(default_factory=dict)
    ke_scale: float = None     # the prior's Ke: the calibrated one times this (None: calibrated as hpddo ripple)


CASES = (
    Case("right", "the bench's 6 ripples per revolution given"),
    Case("half", "3 given for a 6-ripple motor", given=3),
    Case("double", "12 given for a 6-ripple motor", given=12),
    Case("damaged", f"a damaged commutator: one segment's contact resistance raised by {BAR_FAULT_PCT:g} % of the "
         "loop's", ripple={"bar_fault_pct": BAR_FAULT_PCT}),
    Case("worn", f"a worn commutator: one segment's contact resistance raised by {BAR_FAULT_SMALL_PCT:g} % of the "
         "loop's", ripple={"bar_fault_pct": BAR_FAULT_SMALL_PCT}),
)


def _record(prot: str, ripple: dict):
    bench = params.preset("default")
    g = generate.generate(bench, prot, 1.0 / WINDOW_S, SEED, time_scale=TIME_SCALE, ripple=params.ripple_burst(**ripple))
    t0, codes, bmeta = g["bursts"]
    b = rf.of_meta(bmeta, g["log"]["seq"].to_numpy(), t0, codes)
    return bench, g, b


def _score(est, log, truth, bench, opts) -> dict:
    conf = est["confident"].to_numpy(bool)
    true = truth["rpm_true"].to_numpy(float)
    rpm = est["rpm"].to_numpy(float)
    ok = conf & (true > 0)
    err = np.abs(rpm[ok] / true[ok] - 1.0)
    cycles_true = true * bench.ripples_per_rev * bench.gear_ratio / 60.0 * WINDOW_S
    driven = (log["duty"].to_numpy(float) > 0) & (est["i_mean_A"].to_numpy(float) >= opts.floor_A)
    base = driven & (cycles_true >= MIN_CYCLES)
    keys = est["key"].to_numpy()
    return {"windows": int(len(est)), "confident": int(conf.sum()),
            "wrong": int((err > WRONG).sum()), "max_error_pct": float(100 * err.max()) if len(err) else math.nan,
            "driven_3_cycles": int(base.sum()),
            "confident_share_driven_3_cycles": float((conf & base).sum() / base.sum()) if base.sum() else math.nan,
            "multiple_said": int((keys == "multiple").sum()), "damaged_said": int((keys == "damaged").sum()),
            "rot1_rel": est["rot1_rel"].to_numpy(float), "rot2_rel": est["rot2_rel"].to_numpy(float),
            "fault_rel": est["fault_rel"].to_numpy(float)}


def run_case(case: Case, quiet: bool = True) -> dict:
    parts, cal = [], {}
    for prot in PROTOCOLS:
        bench, g, b = _record(prot, case.ripple)
        log, truth = g["log"], g["truth"]
        opts = Options(case.given or bench.ripples_per_rev, bench.gear_ratio)
        est, ke, _ = speed_of_log(f"{prot}.csv", log, g["meta"], opts, None, None, bursts=b)
        parts.append(_score(est, log, truth, bench, opts))
        c = rcal.calibrate(b, log["duty"].to_numpy(), opts, log["rpm_ref"].to_numpy())
        cal[prot] = {"comb": c["comb"]["ripples_per_rev"], "encoder": c["encoder"]["ripples_per_rev"],
                     "named": c["ripples_per_rev"], "statement": c["statement"]}
        if not quiet:
            print(f"  {case.name}/{prot}: {c['statement']}", file=sys.stderr)
    return _merge(case, parts, cal)


def _merge(case: Case, parts: list, cal: dict) -> dict:
    conf = sum(p["confident"] for p in parts)
    base = sum(p["driven_3_cycles"] for p in parts)
    share = [p["confident_share_driven_3_cycles"] * p["driven_3_cycles"] for p in parts if p["driven_3_cycles"]]
    rot2 = np.concatenate([p["rot2_rel"] for p in parts])
    rot1 = np.concatenate([p["rot1_rel"] for p in parts])
    fault = np.concatenate([p["fault_rel"] for p in parts])
    flagged = np.array([rc.damaged(a, b, c) for a, b, c in zip(rot1, rot2, fault)], bool)
    read = np.isfinite(rot2)
    return {"case": case.name, "what": case.what, "windows": sum(p["windows"] for p in parts), "confident": conf,
            "wrong": sum(p["wrong"] for p in parts),
            "max_error_pct": float(np.nanmax([p["max_error_pct"] for p in parts] + [-np.inf])) if conf else math.nan,
            "driven_3_cycles": base,
            "confident_share_driven_3_cycles": float(sum(share) / base) if base else math.nan,
            "multiple_said": sum(p["multiple_said"] for p in parts),
            "damaged_said": sum(p["damaged_said"] for p in parts),
            "health_read": int(read.sum()), "health_flagged": int((flagged & read).sum()),
            "rot2_rel_median": float(np.nanmedian(rot2)) if read.any() else math.nan,
            "rot2_rel_p99": float(np.nanpercentile(rot2, 99)) if read.any() else math.nan,
            "rot2_rel_p01": float(np.nanpercentile(rot2, 1)) if read.any() else math.nan,
            "fault_rel_p01": float(np.nanpercentile(fault, 1)) if read.any() else math.nan,
            "fault_rel_median": float(np.nanmedian(fault)) if read.any() else math.nan,
            "fault_rel_p99": float(np.nanpercentile(fault, 99)) if read.any() else math.nan,
            "calibrate": cal}


def run_priors(quiet: bool = True) -> dict:
    """The same windows under two priors whose Ke are PRIOR_APART apart: each window confident under both
    must give the same speed (within WRONG), or one of them is not confident."""
    pairs = both = disagree = 0
    only_one = 0
    for prot in PROTOCOLS:
        bench, g, b = _record(prot, {})
        log = g["log"]
        opts = Options(bench.ripples_per_rev, bench.gear_ratio)
        _, ke, _ = speed_of_log(f"{prot}.csv", log, g["meta"], opts, None, None, bursts=b)
        a, _, _ = speed_of_log(f"{prot}.csv", log, g["meta"], opts, None, ke, bursts=b)
        c, _, _ = speed_of_log(f"{prot}.csv", log, g["meta"], opts, None, ke * PRIOR_APART, bursts=b)
        ca, cc = a["confident"].to_numpy(bool), c["confident"].to_numpy(bool)
        pairs += len(a)
        both += int((ca & cc).sum())
        only_one += int((ca ^ cc).sum())
        ra, rc_ = a["rpm"].to_numpy(float), c["rpm"].to_numpy(float)
        disagree += int((ca & cc & (np.abs(rc_ / ra - 1.0) > WRONG)).sum())
        if not quiet:
            print(f"  priors/{prot}: Ke {ke:.4f} and {ke * PRIOR_APART:.4f} V s/rad", file=sys.stderr)
    return {"windows": pairs, "confident_under_both": both, "confident_under_one": only_one,
            "disagree_over_5pct": disagree, "prior_ke_ratio": PRIOR_APART}


# Synthetic currents: a window's lines written down one by one, for what the twin does not make (a free-running
# PWM's sideband stronger than the commutation line it surrounds)
SYNTH_FS = 20000.0       # samples per second
SYNTH_A_PER_CODE = 1e-5  # the converter's step, A


def synthetic_bursts(currents, fs=SYNTH_FS, meta=None) -> rf.Bursts:
    """Bursts (one a window, seq 0, 1, ...) of currents (A), quantised by SYNTH_A_PER_CODE."""
    codes = [np.round(np.asarray(x) / SYNTH_A_PER_CODE).astype(np.int64) for x in currents]
    n = len(codes[0])
    return rf.Bursts(dict(meta or {}), fs, SYNTH_A_PER_CODE, np.arange(len(codes)), np.arange(len(codes)) * n / fs,
                     codes)


def synthetic_current(rot_hz, lines, seconds=0.5, i_mean=1.0, noise=0.002, seed=0, fs=SYNTH_FS, extra=()):
    """A current (A) with lines at multiples of rot_hz: lines {multiple: amplitude A}; extra: (Hz, A) fixed lines;
    each line at a random phase, white noise of sd `noise` A."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    x = i_mean + noise * rng.standard_normal(len(t))
    for m, a in lines.items():
        x = x + a * np.cos(2 * math.pi * m * rot_hz * t + rng.uniform(0, 2 * math.pi))
    for hz, a in extra:
        x = x + a * np.cos(2 * math.pi * hz * t + rng.uniform(0, 2 * math.pi))
    return x


def commutation_current(rot_hz, n, depth=None, smooth=None, dip_width=0.12, line_a=0.02, seconds=0.5, noise=0.01,
                        seed=0, fs=SYNTH_FS):
    """A current (A) whose commutation events are narrow dips, n a revolution, each a Gaussian of dip_width of a
    ripple's period on a pedestal that gives it zero mean (a change of one event's depth adds no mean to its
    segment, so a bar fault puts little power at once and twice the rotation frequency), the j-th event of a
    revolution depth[j] deep (1: healthy), scaled so the commutation line's amplitude is line_a A; plus a smooth
    modulation {multiple: amplitude as a share of line_a} (an eccentric or asymmetric rotor), white noise of sd noise A."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    th = 2 * math.pi * rot_hz * t + rng.uniform(0, 2 * math.pi)
    ph = th * n / (2 * math.pi)
    idx = np.floor(ph).astype(int) % n
    loc = ph - np.floor(ph)
    shape = np.exp(-((loc - 0.5) / dip_width) ** 2) - dip_width * math.sqrt(math.pi)
    fundamental = 2 * dip_width * math.sqrt(math.pi) * math.exp(-(math.pi * dip_width) ** 2)  # of a unit dip
    d = np.ones(n) if depth is None else np.asarray(depth, float)
    x = 1.0 - line_a / fundamental * d[idx] * shape + noise * rng.standard_normal(len(t))
    for m, a in (smooth or {}).items():
        x = x + a * line_a * np.cos(m * th + rng.uniform(0, 2 * math.pi))
    return x


HEALTH_DRAWS = 60  # windows per kind (healthy with a smooth modulation; a bar fault) of run_health


def health_draw(kind: str, seed: int) -> tuple:
    """One window of run_health: (current A, ripples per revolution, true rotation Hz). A healthy motor: bars within
    1 % of each other, a smooth modulation once (10-50 % of the commutation line's amplitude) and twice (5-25 %) a
    revolution; a bar fault: one bar (or two half a turn apart) 1.3-2.5 times as deep or 0.1-0.7 times, the
    rotation lines at 1-5 % of the line. Dips 0.04-0.15 of a ripple's period wide, 6, 10 or 14 ripples a
    revolution, 25-60 Hz of rotation."""
    rng = np.random.default_rng([seed, 7])
    n = int(rng.choice([6, 10, 14]))
    rot = float(rng.uniform(25.0, 60.0))
    depth = 1 + 0.01 * rng.standard_normal(n)
    if kind == "healthy":
        smooth = {1: rng.uniform(0.10, 0.50), 2: rng.uniform(0.05, 0.25)}
    else:
        smooth = {1: rng.uniform(0.01, 0.05), 2: rng.uniform(0.01, 0.05)}
        f = rng.uniform(1.3, 2.5) if rng.uniform() < 0.5 else rng.uniform(0.1, 0.7)
        depth[0] *= f
        if rng.uniform() < 0.5:
            depth[n // 2] *= 1 + 0.8 * (f - 1)
    x = commutation_current(rot, n, depth, smooth, dip_width=float(rng.uniform(0.04, 0.15)), seed=seed)
    return x, n, rot


def run_health(draws: int = HEALTH_DRAWS) -> dict:
    """Windows of synthetic commutators (health_draw), each counted with the right figure and the true speed as the
    prior: per kind, the windows, those named damaged (of them by the fault's lines, comb.fault_rel), those confident
    and more than 5 % off."""
    from ..ripple.count import estimate_window

    out = {}
    for kind in ("healthy", "fault"):
        named = by_fault = confident = wrong = 0
        for seed in range(draws):
            x, n, rot = health_draw(kind, seed)
            r = estimate_window(synthetic_bursts([x]), 0, 0.5, rot * 60.0, Options(n, 1.0))
            named += r["key"] == "damaged"
            by_fault += r["key"] == "damaged" and r["fault_rel"] > rc.HEALTH_FAULT_MAX
            confident += r["key"] == ""
            wrong += r["key"] == "" and abs(r["rpm"] / (rot * 60.0) - 1) > WRONG
        out[kind] = {"windows": draws, "damaged_said": int(named), "fault_named": int(by_fault),
                     "confident": int(confident), "wrong": int(wrong)}
    return out


# A free-running 490 Hz PWM sampled at 9.6 kS/s around a 6-ripple motor without rotation lines (no comb places
# its line): the commutation line (0.08 A, its second harmonic 0.024 A) and the PWM's sidebands f_pwm -+ f_c
# (2 f_pwm - f_c at a fifth of them) at SIDEBAND_DEPTHS times its amplitude, the rotation SIDEBAND_WINDOWS steps
# of a ramp across f_pwm - f_c = f_c (41 Hz), the prior the true speed (Ke given)
SIDEBAND_PWM_HZ = 490.196
SIDEBAND_FS = 9600.0
SIDEBAND_ROT_HZ = (25.0, 50.0)
SIDEBAND_WINDOWS = 48
SIDEBAND_DEPTHS = (0.0, 0.25, 0.4, 0.7, 1.0, 2.0, 3.0, 5.0, 10.0)


def run_sidebands() -> dict:
    """Per sideband depth: the windows counted confident, and those more than WRONG off; and under "line
    hidden", the sidebands at 0.08 A around a commutation line of none (a light load's, under the noise)."""
    from ..ripple.count import estimate_window
    pwm, out = SIDEBAND_PWM_HZ, []
    for depth in SIDEBAND_DEPTHS + (None,):
        conf = off = 0
        line_a, side_a = (0.08, depth * 0.08) if depth is not None else (0.0, 0.08)
        for k, rot in enumerate(np.linspace(*SIDEBAND_ROT_HZ, SIDEBAND_WINDOWS)):
            c = 6 * rot
            extra = ([(abs(pwm - c), side_a), (pwm + c, side_a), (abs(2 * pwm - c), 0.2 * side_a)] if side_a else [])
            x = synthetic_current(rot, {6: line_a, 12: 0.3 * line_a}, fs=SIDEBAND_FS, extra=extra, seed=k)
            b = dataclasses.replace(synthetic_bursts([x], fs=SIDEBAND_FS), pwm_hz=pwm, sampling=rf.FREE)
            r = estimate_window(b, 0, 0.5, rot * 60.0, Options(6, 1.0))
            if r["key"] == "":
                conf += 1
                off += int(abs(r["rpm"] / (rot * 60.0) - 1.0) > WRONG)
        out.append({"sidebands": "line hidden" if depth is None else f"{depth:g}x", "confident": conf, "wrong": off})
    return {"windows": SIDEBAND_WINDOWS, "depths": out}


# An undeclared fixed line (a PWM of another pin, a supply's line) beside the ripple, in windows of random synthetic
# motors: TONE_SEEDS x TONE_WINDOWS windows (those whose line lies under TONE_MAX_HZ), each a motor of TONE_RIPPLES
# ripples per revolution turning at TONE_ROT_HZ, its line at 0.08 A (its second harmonic at 0.02 A), half of them with
# rotation lines (1, 2, 3, N - 1 and N + 1 x f_rot at 2-8 mA: a comb), the tone at TONE_AT times the ripple's
# frequency with TONE_AMPLITUDE times its amplitude (log-uniform) and its second harmonic at a third of that; the prior
# the truth within 5 % (sd), its spread 10 %. Each window also counted without the tone (the coverage the rules cost)
TONE_SEEDS = (1, 2, 3)
TONE_WINDOWS = 300
TONE_RIPPLES = (6, 10, 14)
TONE_ROT_HZ = (20.0, 120.0)
TONE_MAX_HZ = 1900.0
TONE_AT = (0.8, 1.25)
TONE_AMPLITUDE = (10 ** -1.3, 10.0)


def run_tones() -> dict:
    """Per group (comb or none, the tone stronger than the ripple or weaker): the windows, those confident, those more
    than WRONG off, those that name another ripples per revolution (`multiple`: each a false statement, the motor's
    figure is the one given), and the windows confident without the tone."""
    from ..ripple.count import estimate_window
    groups = {}
    for seed in TONE_SEEDS:
        rng = np.random.default_rng(seed)
        for k in range(TONE_WINDOWS):
            n_rip = int(rng.choice(TONE_RIPPLES))
            rot = rng.uniform(*TONE_ROT_HZ)
            fc = n_rip * rot
            if fc > TONE_MAX_HZ:
                continue
            comb = bool(rng.random() < 0.5)
            lines = {n_rip: 0.08, 2 * n_rip: 0.02}
            if comb:
                lines.update({m: 0.004 * rng.uniform(0.5, 2.0) for m in (1, 2, 3, n_rip - 1, n_rip + 1)})
            tone_hz = fc * rng.uniform(*TONE_AT)
            amp = 0.08 * math.exp(rng.uniform(*np.log(TONE_AMPLITUDE)))
            prior = rot * 60.0 * (1.0 + 0.05 * rng.standard_normal())
            g = groups.setdefault((comb, amp > 0.08), {"comb": comb, "tone_stronger": amp > 0.08, "windows": 0,
                                                       "confident": 0, "wrong": 0, "multiple_said": 0,
                                                       "confident_without_tone": 0})
            g["windows"] += 1
            for tone in (True, False):
                extra = [(tone_hz, amp), (2 * tone_hz, amp / 3.0)] if tone else []
                x = synthetic_current(rot, lines, extra=extra, seed=k)
                r = estimate_window(synthetic_bursts([x]), 0, 0.5, prior, Options(n_rip, 1.0), None,
                                    (0.1 * prior, 0.1 * prior))
                if not tone:
                    g["confident_without_tone"] += int(r["key"] == "")
                    continue
                g["confident"] += int(r["key"] == "")
                g["wrong"] += int(r["key"] == "" and abs(r["rpm"] / (rot * 60.0) - 1.0) > WRONG)
                g["multiple_said"] += int(r["key"] == "multiple")
    return {"seeds": list(TONE_SEEDS), "windows_a_seed": TONE_WINDOWS,
            "groups": [groups[k] for k in sorted(groups)]}


def run(quiet: bool = True) -> dict:
    cases = [run_case(c, quiet) for c in CASES]
    return {"command": "cd tools && ../.venv/bin/python -m hpddo.studies.ripple_line --json "
                       "../docs/figures/ripple_line.json",
            "protocols": list(PROTOCOLS), "time_scale": TIME_SCALE, "seed": SEED, "window_s": WINDOW_S,
            "health_rot1_max": rc.HEALTH_ROT1_MAX, "health_rot2_max": rc.HEALTH_ROT2_MAX,
            "health_fault_max": rc.HEALTH_FAULT_MAX,
            "cases": cases, "priors": run_priors(quiet), "sidebands": run_sidebands(), "tones": run_tones(),
            "health": run_health()}


def block(res: dict) -> str:
    """docs/ripple-line.md's table of this study (under "Measured: the line's identity"), from the JSON."""
    rows = ["| case | confident | more than 5 % off | worst % | confident of driven windows with >= 3 cycles | "
            "'another multiple' said | 'damaged' said | ripples per rev named (comb / encoder), sweep; load | "
            "windows over a health threshold, of those read | rot2_rel 1st / 50th / 99th percentile | "
            "fault_rel 1st / 50th / 99th percentile |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in res["cases"]:
        named = "; ".join(f"{v['comb'] or '-'} / {v['encoder'] or '-'}" for v in c["calibrate"].values())
        rows.append(f"| {c['case']}: {c['what']} | {c['confident']} of {c['windows']} | {c['wrong']} | "
                    f"{c['max_error_pct']:.2f} | {100 * c['confident_share_driven_3_cycles']:.1f} % of "
                    f"{c['driven_3_cycles']} | {c['multiple_said']} | {c['damaged_said']} | {named} | {c['health_flagged']} of "
                    f"{c['health_read']} | {c['rot2_rel_p01']:.3g} / {c['rot2_rel_median']:.3g} / {c['rot2_rel_p99']:.3g} | "
                    f"{c['fault_rel_p01']:.3g} / {c['fault_rel_median']:.3g} / {c['fault_rel_p99']:.3g} |")
    p = res["priors"]
    rows.append("")
    rows.append(f"Two priors, Ke {p['prior_ke_ratio']:g}x apart, on the same {p['windows']} windows: confident under "
                f"both {p['confident_under_both']}, of which {p['disagree_over_5pct']} disagree by more than 5 %; "
                f"confident under one only {p['confident_under_one']}.")
    sb = res["sidebands"]
    rows += ["", f"A free-running PWM's sidebands around a line no comb places ({sb['windows']} windows a depth):", "",
             "| sideband amplitude / line | " + " | ".join(v["sidebands"] for v in sb["depths"]) + " |",
             "|---|" + "---|" * len(sb["depths"]),
             "| confident (more than 5 % off) | " + " | ".join(f"{v['confident']} ({v['wrong']})"
                                                          for v in sb["depths"]) + " |"]
    tn = res["tones"]
    rows += ["", f"An undeclared fixed line beside the ripple ({len(tn['seeds'])} x {tn['windows_a_seed']} random "
                 "windows; 'multiple' said is a false statement):", "",
             "| rotation comb | tone | windows | confident | more than 5 % off | 'another multiple' said | "
             "confident without the tone |", "|---|---|---|---|---|---|---|"]
    for v in tn["groups"]:
        rows.append(f"| {'yes' if v['comb'] else 'no'} | {'stronger' if v['tone_stronger'] else 'weaker'} | "
                    f"{v['windows']} | {v['confident']} | {v['wrong']} | {v['multiple_said']} | "
                    f"{v['confident_without_tone']} |")
    h = res["health"]
    rows += ["", f"Synthetic commutators, narrow dips, the right figure and the true speed given ({h['healthy']['windows']} "
                 "windows a kind, `run_health`):", "",
             "| motor | windows | 'damaged' said (of them by the fault's lines) | confident | more than 5 % off |",
             "|---|---|---|---|---|"]
    for kind, what in (("healthy", "healthy, smooth modulations once and twice a revolution"),
                       ("fault", "a bar fault: one bar, or two opposite, deeper or shallower")):
        v = h[kind]
        rows.append(f"| {what} | {v['windows']} | {v['damaged_said']} ({v['fault_named']}) | {v['confident']} | "
                    f"{v['wrong']} |")
    return "\n".join(rows) + "\n"


def main(argv=None) -> int:
    return report("ripple_line", __doc__, run, block, argv)


if __name__ == "__main__":
    sys.exit(main())
