"""Scores a trained model on recordings it never saw: every row counts.

    hpddo evaluate --model DIR LOG... --out OUT [options]

DIR is an output of hpddo train (model_<name>.h, lookup.json). Each LOG is cleaned as for
training (glitch filter), replayed whole through the board observer compiled against the
model's header (the native replay), and scored against its encoder readings: RMSE of M1,
M2 and M3, and of the lookup baseline (the mean training speed of the nearest training
operating point: what memory alone scores). Writes OUT/metrics.json, OUT/report/index.html
and OUT/work/ (cleaned logs, the replay, every row's estimates) together, or nothing.
This is the figure to trust for a new run; the chronological split of hpddo train scores
rows from the same runs the model was trained on.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from . import options

TOOL = "evaluate"


def parser(prog: str = "hpddo evaluate") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    p.add_argument("--model", type=pathlib.Path, required=True, metavar="DIR",
                   help="a model folder written by hpddo train")
    p.add_argument("--name", default=None, help="model name, when DIR holds more than one model_<name>.h")
    options.logs(p)
    options.out(p, "output folder: new, empty, or a previous output of hpddo evaluate")
    options.glitch_filter(p)
    options.reference(p)
    options.quiet(p)
    return p


def run(args) -> int:
    from ..logs import outdir
    from ..evaluation.evaluate import evaluate, model_header
    from ..ripple import reference
    from ..reports.training import write_evaluation as write
    from .. import progress

    t0 = time.perf_counter()
    ref = options.reference_of(args)
    model_header(args.model, args.name)  # a missing model is refused before any work
    outdir.check(args.out, TOOL)
    with outdir.staged(args.out, TOOL) as stage:
        ev = evaluate(args.model, args.logs, stage / "work", args.name, not args.no_glitch_filter, ref)
        progress.stage("writing the report")
        write(ev, stage, f"hpddo evaluate: {args.model}",
              [f"Model {args.model} (effects in its physics model: {', '.join(ev.metrics['model']['effects']) or 'none'}), "
               "replayed natively through the board observer on every row of recordings it was not trained on "
               "(no split: every row is scored); lookup: the mean training speed of the nearest training "
               "operating point."])
    for w in ev.metrics["warnings"]:
        print(f"hpddo evaluate: WARNING: {w}", file=sys.stderr)
    for r in ev.recordings:
        if r.reference is not None:
            print(reference.line(r.name, r.reference))
    for r in ev.recordings:
        if "rpm_ref" not in r.df or not r.df["rpm_ref"].notna().any():
            what = ("no row kept by the ripple reference (the line above)" if r.reference is not None
                    else "no encoder readings (rpm_ref)")
            print(f"hpddo evaluate: {r.source}: {what}: its estimates are written "
                  f"({args.out / 'work' / 'estimates'}), there is nothing to score them against")
    print(ev.table, end="")
    if not args.quiet:
        print(f"wrote {args.out}/ in {time.perf_counter() - t0:.1f} s; report: {args.out / 'report' / 'index.html'}")
    return 0


def main(argv=None) -> int:
    """`hpddo evaluate ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand(TOOL, argv)
