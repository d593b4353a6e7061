"""The paper's comparison as one command: M1, M2, M3 (with and without the novelty
gate), an EKF, a sliding-mode observer, a pure network and the lookup baseline, every
one tuned on the training rows only; Tables 7-10 and the out-of-distribution stress test
of section 4.10 (docs/compare.md).

    hpddo compare LOG... --out DIR [--validation LOG...] [--effects NAME,...] [--quick]
                  [--ripples-per-rev N --gear-ratio G [--ke-vs-per-rad KE | --prior-model DIR]]

Writes DIR/table7.json, table8.json, table9.json, table10.json, ood.json, summary.txt,
report/index.html and work/ (tuning logs, model headers, replays, estimates) together,
or nothing. The full run trains 25 networks (those of one architecture in lockstep) on
--workers processes, the (128, 64) network of Table 9 among them; --quick trains each
for 60 epochs, only (8) and the chosen architecture in Table 9, and tunes the observers
on a coarser grid (for tests).
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from . import options

TOOL = "compare"


def parser(prog: str = "hpddo compare") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    options.logs(p)
    options.out(p, "output folder: new, empty, or a previous output of hpddo compare")
    options.logs(p, "--validation", "labelled recordings no training sees, scored whole (e.g. data/validation/*.csv)",
                 default=[])
    options.effects(p, "also score M2 with these effect terms")
    p.add_argument("--hidden", type=options.hidden_sizes, default=(16, 8), metavar="N[,M]",
                   help="hidden layers of M3 and of the pure network (default 16,8)")
    p.add_argument("--quick", action="store_true",
                   help="a quick look, not the comparison: 60 epochs per network (unless --epochs), two "
                        "architectures, coarse observer tuning; the report says so")
    p.add_argument("--epochs", type=options.positive_int, default=None, metavar="N",
                   help="training epochs of every network, no early stop (default 2000; 60 with --quick)")
    p.add_argument("--workers", type=options.positive_int, default=2,
                   help="processes training networks at once (default 2)")
    options.ripple(p, False, " (both given: ripple counting as a peer, alone and fused with M2, from the current "
                             "bursts beside every log, <condition>.ripple.csv)",
                   prior_flags=options.PRIOR_MODEL_FLAGS)
    options.ra_ohm(p)
    options.seed(p, "the networks and the cross-validation folds")
    options.glitch_filter(p)
    options.quiet(p)
    return p


def run(args) -> int:
    from ..studies.compare import CompareConfig, command_line, run as run_compare, text_summary

    t0 = time.perf_counter()
    prior_model = options.prior_model_of(args)  # a bad folder refused before any log is read
    argv = [*map(str, args.logs), "--out", str(args.out)]
    if args.validation:
        argv += ["--validation", *map(str, args.validation)]
    if args.effects:
        argv += ["--effects", ",".join(args.effects)]
    if tuple(args.hidden) != (16, 8):
        argv += ["--hidden", ",".join(map(str, args.hidden))]
    if args.quick:
        argv.append("--quick")
    if args.epochs is not None:
        argv += ["--epochs", str(args.epochs)]
    if args.seed != 1:
        argv += ["--seed", str(args.seed)]
    if args.ra_ohm is not None:
        argv += ["--ra-ohm", repr(args.ra_ohm)]
    if args.no_glitch_filter:
        argv.append("--no-glitch-filter")
    argv += options.ripple_words(args)
    cfg = CompareConfig(hidden=tuple(args.hidden), effects=tuple(args.effects), ra_ohm=args.ra_ohm, seed=args.seed,
                        quick=args.quick, workers=args.workers, glitch_filter=not args.no_glitch_filter,
                        progress=not args.quiet, command=command_line(argv),
                        epochs_given=args.epochs, ripples_per_rev=args.ripples_per_rev, gear_ratio=args.gear_ratio,
                        ripple_ke_vs_per_rad=args.ke_vs_per_rad, ripple_floor_A=args.floor_a,
                        ripple_prior_model=prior_model)
    res = run_compare(args.logs, args.out, cfg, args.validation)
    print(text_summary(res.tables), end="")
    if not args.quiet:
        print(f"wrote {args.out}/ in {time.perf_counter() - t0:.1f} s")
    sys.stdout.flush()
    return 0


def main(argv=None) -> int:
    from . import run as run_subcommand
    return run_subcommand(TOOL, argv)
