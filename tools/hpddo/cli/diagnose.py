"""Diagnoses the physics model against labelled bench logs and names the missing effects.

    hpddo diagnose LOG... --out DIR [--effects NAME,...] [options]   (tools/diagnose.py is the same)

Fits the physics model (plain M2, or M2 with --effects) on the training rows (first 80 %
of each recording), analyses its residual on the held-out rows (where the squared error
sits, whiteness, cross-correlation with V, I, duty, temperature), ranks the effects of the
library (tools/hpddo/effects.py) by the share of the held-out residual each explains,
says which are missing (or that nothing is), adds them, and reports the error before and
after for the physics model and for the hybrid retrained on top. Writes DIR/index.html
and DIR/diagnosis.json together, or nothing (a malformed log is refused with its file,
line and fault). See docs/diagnosis.md.
"""
from __future__ import annotations

import argparse
import sys
import time

from . import options



def parser(prog: str = "hpddo diagnose") -> argparse.ArgumentParser:
    from ..diagnosis import core

    p = options.new_parser(prog, __doc__)
    options.logs(p)
    options.out(p, "output folder (index.html, diagnosis.json): new, empty, or a previous output of "
                   "hpddo diagnose")
    options.effects(p, "effects already in the model under test")
    options.ra_ohm(p)
    p.add_argument("--bootstrap", type=options.non_negative_int, default=core.ranking.BOOTSTRAP, metavar="N",
                   help=f"block-bootstrap resamples for the inclusion frequency (default {core.ranking.BOOTSTRAP}; "
                        "0: none)")
    p.add_argument("--no-hybrid", action="store_true", help="skip retraining the hybrid before/after")
    p.add_argument("--hybrid-iter", type=options.positive_int, default=core.HYBRID_ITER, metavar="EPOCHS",
                   help=f"training epochs of the hybrid (default {core.HYBRID_ITER})")
    options.seed(p, "the bootstrap and the network")
    options.glitch_filter(p)
    options.quiet(p, "print only warnings and errors (no summary)")
    return p


def run(args) -> int:
    from .. import outdir
    from ..diagnosis import core, report

    t0 = time.perf_counter()
    opt = core.Options(effects=args.effects, ra_ohm=args.ra_ohm, bootstrap=args.bootstrap,
                       hybrid=not args.no_hybrid, hybrid_iter=args.hybrid_iter, seed=args.seed,
                       glitch_filter=not args.no_glitch_filter)
    out = args.out
    outdir.check(out, "diagnose")  # before the work: a refused folder costs nothing
    res, plot = core.diagnose(args.logs, opt)
    with outdir.staged(out, "diagnose") as stage:
        report.write(stage, res, plot)
    for w in res.get("warnings", []):
        print(f"hpddo diagnose: WARNING: {w}", file=sys.stderr)
    if args.quiet:
        return 0
    print(res["verdict"])
    for e in res["ranking"]:
        if e["named"]:
            incl = "" if e["inclusion"] is None else f", inclusion {100 * e['inclusion']:.0f} %"
            print(f"  {e['effect']:15s} {e['shown']:>14s}  score {e['score']:.3f}{incl}; {e['plausibility']}")
    conds = list(res["rmse_rpm"]["before"])
    print("RMSE on the test parts (RPM)   " + " ".join(f"{c:>9s}" for c in conds))
    rows = [("physics before", res["rmse_rpm"]["before"]), ("physics after", res["rmse_rpm"]["after"])]
    if "rmse_rpm_hybrid" in res:
        rows += [("hybrid before", res["rmse_rpm_hybrid"]["before"]), ("hybrid after", res["rmse_rpm_hybrid"]["after"])]
    for lab, d in rows:
        print(f"  {lab:28s}" + " ".join(f"{d[c]:9.2f}" for c in conds))
    print(f"wrote {out}/index.html and diagnosis.json; diagnosis took {time.perf_counter() - t0:.1f} s")
    return 0


def main(argv=None) -> int:
    """`hpddo diagnose ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("diagnose", argv)
