#!/usr/bin/env python3
"""Diagnoses the physics model against labelled bench logs and names the missing effects.

    tools/diagnose.py LOG... --out DIR [--effects NAMES] [options]

Fits the physics model (plain M2, or M2 with --effects) on the training rows (first 80 %
of each recording), analyses its residual on the held-out rows (where the squared error
sits, whiteness, cross-correlation with V, I, duty, temperature), ranks the effects of the
library (tools/hpddo/effects.py) by the share of the held-out residual each explains,
says which are missing (or that nothing is), adds them, and reports the error before and
after for the physics model and for the hybrid retrained on top. Writes DIR/index.html
and DIR/diagnosis.json together, or nothing (a malformed log is refused with its file,
line and fault). See docs/diagnosis.md.
"""
import os

# The fits are many small least-squares problems; the bootstrap runs them on every core.
# One BLAS thread per process keeps the cores from fighting (43 s instead of 68 s here).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from hpddo import outdir  # noqa: E402
from hpddo.errors import USER_ERRORS  # noqa: E402
from hpddo import effects as fx  # noqa: E402
from hpddo.diagnosis import core, report  # noqa: E402


def parser():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("logs", nargs="+", type=pathlib.Path, help="labelled bench logs (CSV)")
    ap.add_argument("--out", required=True, type=pathlib.Path, help="output folder (index.html, diagnosis.json)")
    ap.add_argument("--effects", type=fx.parse_names, default=(),
                    help=f"effects already in the model under test: {', '.join(fx.NAMES)}")
    ap.add_argument("--ra-ohm", type=float, help="armature resistance, ohm (default: the logs' ra_ohm metadata)")
    ap.add_argument("--bootstrap", type=int, default=core.ranking.BOOTSTRAP,
                    help=f"block-bootstrap resamples for the inclusion frequency ({core.ranking.BOOTSTRAP}; 0: none)")
    ap.add_argument("--no-hybrid", action="store_true", help="skip retraining the hybrid before/after")
    ap.add_argument("--hybrid-iter", type=int, default=core.HYBRID_ITER,
                    help=f"training iterations of the hybrid ({core.HYBRID_ITER})")
    ap.add_argument("--seed", type=int, default=1, help="seed of the bootstrap and the network (1)")
    ap.add_argument("--no-glitch-filter", action="store_true", help="keep every row (no glitch filter)")
    return ap


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    t0 = time.perf_counter()
    opt = core.Options(effects=args.effects, ra_ohm=args.ra_ohm, bootstrap=args.bootstrap,
                       hybrid=not args.no_hybrid, hybrid_iter=args.hybrid_iter, seed=args.seed,
                       glitch_filter=not args.no_glitch_filter)
    out = args.out
    try:
        outdir.check(out, "diagnose")  # before the work: a refused folder costs nothing
        res, plot = core.diagnose(args.logs, opt)
        with outdir.staged(out, "diagnose") as stage:
            report.write(stage, res, plot)
    except USER_ERRORS as exc:
        print(f"diagnose: {exc}", file=sys.stderr)
        return 1
    for w in res.get("warnings", []):
        print(f"diagnose: WARNING: {w}", file=sys.stderr)
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


if __name__ == "__main__":
    sys.exit(main())
