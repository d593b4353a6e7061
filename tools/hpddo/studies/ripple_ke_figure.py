"""A Ke given against a wrong ripples per revolution on a symmetric rotor (issue 33, docs/ripple-line.md, "A Ke
given checks the figure"): the twin's three training protocols (sweep and load at a quarter of their length, long
at a fiftieth), 10 windows a second, with the rotor's asymmetry lines (f/2, f/3, f/6) at zero, so no window shows a
rotation comb and only the Ke can check the figure. Counted as `hpddo ripple --ke-vs-per-rad` counts a motor's
recordings (speed_of_bench), with 5, 6 (the twin's) and 7 ripples per revolution given, each under a Ke 0.90-1.10
times the motor's. Scored against the twin's true window-mean speed: the confident windows, and those more than
5 % off. Then each recording counted alone (speed_of_log) under the motor's Ke.

    cd tools && ../.venv/bin/python -m hpddo.studies.ripple_ke_figure   # ~3 min: prints the tables
"""
from __future__ import annotations

import argparse

import numpy as np

from ..logs import ripple as rf
from ..ripple.log import speed_of_bench, speed_of_log
from ..ripple.options import FIGURE_CHECK_REL, Options

PROTOCOLS = (("sweep", 0.25), ("load", 0.25), ("long", 0.02))  # (protocol, time scale)
WINDOWS_HZ = 10.0
FIGURES = (5, 6, 7)
KE_FACTORS = (0.90, 0.95, 1.00, 1.05, 1.10)


def bench_logs(seed: int):
    """The symmetric rotor's recordings: ([(name, log, meta, bursts)], {name: true speed per window}, bench)."""
    from ..twin import generate, params

    bench = params.preset("default")
    logs, truth = [], {}
    for prot, ts in PROTOCOLS:
        g = generate.generate(bench, prot, WINDOWS_HZ, seed, time_scale=ts,
                              ripple=params.ripple_burst(sub2_pct=0.0, sub3_pct=0.0, sub6_pct=0.0))
        t0, codes, meta = g["bursts"]
        logs.append((f"{prot}.csv", g["log"], g["meta"], rf.of_meta(meta, g["log"]["seq"].to_numpy(), t0, codes)))
        truth[f"{prot}.csv"] = g["truth"]["rpm_true"].to_numpy()
    return logs, truth, bench


def run(seed: int = 3) -> list:
    """One row per (figure given, Ke factor): dict with the windows, the confident ones, those off by more than
    FIGURE_CHECK_REL, the worst relative error (NaN where none is confident) and the keys' counts."""
    logs, truth, bench = bench_logs(seed)
    rows = []
    for n in FIGURES:
        for f in KE_FACTORS:
            got = speed_of_bench(logs, Options(n, bench.gear_ratio), None, f * bench.ke_vs_per_rad)
            errs, keys, total = [], {}, 0
            for (name, *_), (est, _, _) in zip(logs, got):
                c = est["confident"].to_numpy(bool)
                errs.append(est["rpm"].to_numpy()[c] / truth[name][est["row"].to_numpy()[c]] - 1.0)
                total += len(est)
                for k, v in est["key"].value_counts().items():
                    keys[k] = keys.get(k, 0) + int(v)
            e = np.abs(np.concatenate(errs))
            rows.append({"given": n, "ke_factor": f, "windows": total, "confident": int(len(e)),
                         "off": int((e > FIGURE_CHECK_REL).sum()), "worst": float(e.max()) if len(e) else float("nan"),
                         "keys": keys})
    return rows


def run_alone(seed: int = 3) -> list:
    """Each recording counted alone (speed_of_log) under the motor's Ke, each figure: one row per (recording,
    figure given) as run's, with `recording`."""
    logs, truth, bench = bench_logs(seed)
    rows = []
    for name, log, meta, b in logs:
        for n in FIGURES:
            est, _, _ = speed_of_log(name, log, meta, Options(n, bench.gear_ratio), None, bench.ke_vs_per_rad, bursts=b)
            c = est["confident"].to_numpy(bool)
            e = np.abs(est["rpm"].to_numpy()[c] / truth[name][est["row"].to_numpy()[c]] - 1.0)
            rows.append({"recording": name, "given": n, "windows": len(est), "confident": int(c.sum()),
                         "off": int((e > FIGURE_CHECK_REL).sum()), "worst": float(e.max()) if len(e) else float("nan"),
                         "keys": {k: int(v) for k, v in est["key"].value_counts().items()}})
    return rows


def table_alone(rows) -> str:
    out = ["| recording alone | figure given | confident windows | more than 5 % off | ke_or_figure | unchecked |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['recording']} | {r['given']} | {r['confident']} of {r['windows']} | {r['off']} | "
                   f"{r['keys'].get('ke_or_figure', 0)} | {r['keys'].get('unchecked', 0)} |")
    return "\n".join(out)


def table(rows) -> str:
    out = ["| figure given | Ke given / motor's | confident windows | more than 5 % off | worst | ke_or_figure |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        worst = f"{100 * r['worst']:.1f} %" if r["confident"] else "-"
        out.append(f"| {r['given']} | {r['ke_factor']:.2f} | {r['confident']} of {r['windows']} | {r['off']} | {worst} | "
                   f"{r['keys'].get('ke_or_figure', 0)} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hpddo.studies.ripple_ke_figure", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=3)
    args = ap.parse_args(argv)
    print(table(run(args.seed)))
    print()
    print(table_alone(run_alone(args.seed)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
