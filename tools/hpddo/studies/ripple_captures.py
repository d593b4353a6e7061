"""Free-running sampling under the UNO's 490 Hz PWM, with and without mains (issue 33,
docs/ripple-captures.md): twin benches in the free-running ripple mode (9.6 kHz, not
synchronised with the 490.196 Hz PWM; the PWM's current ripple from the winding's L / R, a
rectified 50 Hz comb where asked), each counted twice by the product's path (speed_of_log: the
prior's Ke calibrated from the ripple, the log's Ra):

* before: the bursts read as a synchronous file that declares nothing (what the estimator did
  before issue 33: the PWM's lines are in the spectrum, nothing marks them);
* after: as declared (sampling=free, pwm_hz, mains_hz): the PWM-synchronous average removed, no
  confident window on a PWM or mains line.

Scored against the twin's true window-mean speed: confident windows, their RMS error, the worst;
a confident window where the shaft stands (true speed 0) counts as more than 5 % off.

    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_captures --json docs/figures/ripple_captures.json  # ~8 min
    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_captures --write-docs   # the docs' block from it
"""
from __future__ import annotations

import json
import math
import pathlib
import sys

import numpy as np

from ..logs import ripple as rf
from ..ripple.log import speed_of_log
from ..ripple.options import Options
from ..twin import generate, params, ripple_free

FIGURES = "docs/figures/ripple_captures.json"
DOC = "docs/ripple-captures.md"
WHAT = "the free-running study's figures"
SAMPLE_HZ = 9600.0
PWM_HZ = 490.196            # the UNO's default analogWrite (16 MHz / 64 / 510)
WINDOW_S = 0.5
TARGET_PCT = 5.0            # no confident window further off than this (issue 33)
MIN_CYCLES = 3.0            # the coverage target's windows: driven, with this many ripple cycles or more (issue 33)
PROTOCOLS = ("sweep", "load", "unseen")
SEEDS = (1, 2)
TIME_SCALE = 0.25
MAINS = (0.0, 50.0)


def run_case(protocol: str, seed: int, mains_hz: float, time_scale: float = TIME_SCALE) -> dict:
    """One bench: the same bursts counted before and after; per variant the windows, the confident
    ones, their RMS and worst error against the truth (%), and the reasons."""
    bench = params.preset("default")
    rpar = {**params.ripple_burst(sample_hz=SAMPLE_HZ),
            **ripple_free.ripple_free(pwm_hz=PWM_HZ, mains_hz=mains_hz)}
    g = generate.generate(bench, protocol, 1.0 / WINDOW_S, seed, time_scale=time_scale, ripple=rpar)
    t0, codes, meta = g["bursts"]
    declared = rf.of_meta(meta, g["log"]["seq"].to_numpy(), t0, codes)
    # the same bursts in a file that declares none of the three: its metadata without them, as read
    undeclared = {k: v for k, v in meta.items() if k not in (rf.SAMPLING, rf.PWM_HZ, rf.MAINS_HZ)}
    before = rf.of_meta(undeclared, g["log"]["seq"].to_numpy(), t0, codes)
    true = g["truth"]["rpm_true"].to_numpy()
    opts = Options(bench.ripples_per_rev, bench.gear_ratio)
    out = {"protocol": protocol, "seed": seed, "mains_hz": mains_hz, "time_scale": time_scale}
    for name, b in (("before", before), ("after", declared)):
        df, ke, _ = speed_of_log(f"{protocol}.csv", g["log"], g["meta"], opts, None, None, bursts=b)
        c = df["confident"].to_numpy()
        above = df["i_mean_A"].to_numpy() >= opts.floor_A
        # the target's windows: driven (duty above 0) and holding MIN_CYCLES ripple cycles or more at the true speed
        cycles = true * bench.ripples_per_rev * bench.gear_ratio / 60.0 * WINDOW_S
        driven = (g["log"]["duty"].to_numpy(float) > 0) & (cycles >= MIN_CYCLES)
        still = c & ~(true > 0)  # a count where the shaft stands: wrong whatever it says
        moving = c & (true > 0)
        e = 100 * (df["rpm"].to_numpy()[moving] / true[moving] - 1)
        out[name] = {"windows": int(len(df)), "above_floor": int(above.sum()), "confident": int(c.sum()),
                     "driven": int(driven.sum()), "driven_confident": int((driven & c).sum()),
                     "confident_at_standstill": int(still.sum()),
                     "rms_pct": float(np.sqrt(np.mean(e ** 2))) if moving.any() else None,
                     "worst_pct": float(np.max(np.abs(e))) if moving.any() else None,
                     "over_target": int(np.sum(np.abs(e) > TARGET_PCT) + still.sum()),
                     "ke_vs_per_rad": float(ke) if math.isfinite(ke) else None,
                     "reasons": {k or "confident": int(n) for k, n in df["key"].value_counts().sort_index().items()}}
    out["ke_true_vs_per_rad"] = float(bench.ke_vs_per_rad)
    return out


def summarise(cases: list) -> dict:
    """Per mains setting and variant: windows, confident, confident windows over the target, the RMS
    over every confident window of the benches and the worst one."""
    out = {}
    for mains in sorted({c["mains_hz"] for c in cases}):
        key = "no mains" if not mains else f"mains {mains:g} Hz"
        out[key] = {}
        for v in ("before", "after"):
            rs = [c[v] for c in cases if c["mains_hz"] == mains]
            conf = sum(r["confident"] for r in rs)
            still = sum(r["confident_at_standstill"] for r in rs)
            sq = sum((r["rms_pct"] ** 2) * (r["confident"] - r["confident_at_standstill"])
                     for r in rs if r["rms_pct"] is not None)
            worst = [r["worst_pct"] for r in rs if r["worst_pct"] is not None]
            out[key][v] = {"benches": len(rs), "windows": sum(r["windows"] for r in rs),
                           "above_floor": sum(r["above_floor"] for r in rs), "confident": conf,
                           "driven": sum(r.get("driven", 0) for r in rs),
                           "driven_confident": sum(r.get("driven_confident", 0) for r in rs),
                           "over_target": sum(r["over_target"] for r in rs), "confident_at_standstill": still,
                           "rms_pct": math.sqrt(sq / (conf - still)) if conf > still else None,
                           "worst_pct": max(worst) if worst else None}
    return out


def table(summary: dict) -> str:
    lines = ["| bench | counted | windows | confident | driven, 3 cycles or more: confident | more than 5 % off (of "
             "them: the shaft standing) | RMS of the confident (shaft turning) | worst confident (shaft turning) |",
             "|---|---|---|---|---|---|---|---|"]
    for key, per in summary.items():
        for v in ("before", "after"):
            s = per[v]
            rms = "–" if s["rms_pct"] is None else f"{s['rms_pct']:.3f} %"
            worst = "–" if s["worst_pct"] is None else f"{s['worst_pct']:.2f} %"
            drv = (f"{s['driven_confident']} of {s['driven']} ({s['driven_confident'] / s['driven']:.1%})"
                   if s.get("driven") else "–")
            lines.append(f"| {key} | {v} | {s['windows']} | {s['confident']} ({s['confident'] / s['windows']:.1%}) | "
                         f"{drv} | {s['over_target']} ({s['confident_at_standstill']}) | {rms} | {worst} |")
    return "\n".join(lines)


def ke_line(cases: list) -> str:
    """The prior's Ke calibrated from the ripple (no encoder), before and after, against the bench's."""
    def span(v):
        ke = [c[v]["ke_vs_per_rad"] for c in cases if c[v]["ke_vs_per_rad"] is not None]
        return f"{min(ke):.4f}..{max(ke):.4f}" if ke else "none"
    true = sorted({c["ke_true_vs_per_rad"] for c in cases})
    return (f"Ke calibrated from the ripple (V s/rad, output shaft; the bench's {', '.join(f'{k:.4f}' for k in true)} "
            f"at its reference temperature): before {span('before')}, after {span('after')}.")


def doc_markers() -> tuple:
    from . import doc_markers as markers
    return markers("ripple_captures", WHAT, FIGURES)


def docs_text(doc: str, figures: dict) -> str:
    """doc (docs/ripple-captures.md) with its block of the study's figures rendered from figures (the
    committed JSON)."""
    from . import with_block
    benches = ", ".join(f"{p} x{figures['time_scale']:g}" for p in figures["protocols"])
    block = (f"Measured by `{figures['command']}` ({benches}, seeds {', '.join(map(str, figures['seeds']))}; "
             f"{figures['sample_hz']:g} S/s free-running under {figures['pwm_hz']:g} Hz PWM; "
             "errors against the twin's true window-mean speed):\n\n" + table(figures["summary"]) + "\n\n"
             + ke_line(figures["cases"]) + "\n")
    return with_block(doc, doc_markers(), block, DOC, WHAT)


def main(argv=None) -> int:
    from . import parser, write_docs
    ap = parser("ripple_captures", __doc__)
    ap.add_argument("--write-docs", action="store_true",
                    help=f"only write {DOC}'s block of figures from the committed {FIGURES}")
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)), metavar="S,S,..")
    ap.add_argument("--protocols", default=",".join(PROTOCOLS), metavar="P,P,..")
    ap.add_argument("--time-scale", type=float, default=TIME_SCALE)
    a = ap.parse_args(argv)
    if a.write_docs:
        return write_docs(DOC, FIGURES, docs_text)
    seeds = [int(s) for s in a.seeds.split(",")]
    protocols = a.protocols.split(",")
    cases = []
    for prot in protocols:
        for seed in seeds:
            for mains in MAINS:
                c = run_case(prot, seed, mains, a.time_scale)
                cases.append(c)
                print(f"{prot} seed {seed} mains {mains:g}: before {c['before']['confident']} confident, worst "
                      f"{c['before']['worst_pct']}; after {c['after']['confident']}, worst {c['after']['worst_pct']}",
                      file=sys.stderr, flush=True)
    command = "python -m hpddo.studies.ripple_captures " + " ".join(argv if argv is not None else sys.argv[1:])
    figures = {"command": command.strip(), "sample_hz": SAMPLE_HZ, "pwm_hz": PWM_HZ, "window_s": WINDOW_S,
               "protocols": protocols, "seeds": seeds, "time_scale": a.time_scale,
               "summary": summarise(cases), "cases": cases}
    print(table(figures["summary"]))
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(figures, indent=1, sort_keys=True, allow_nan=False) + "\n",
                                        encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
