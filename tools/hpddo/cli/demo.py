"""The main job on the bundled recordings (data/default), no hardware needed:

  1. identify M1 and M2, train M3, export the model header, replay the recordings natively
     through the board observer, print the RMSE table, write an HTML report;
  2. diagnose which physical effects the physics model misses (hpddo diagnose);
  3. add the named effects (hpddo train --effects), retrain M3 on top, replay natively, and
     show the error fall, for the physics model and for the hybrid.

    hpddo demo [--out out] [--data data/default]      (tools/demo.py is the same command)
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

from .. import resource_root
from . import options


def parser(prog: str = "hpddo demo") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    options.out(p, "output folder: new, empty, or a previous output of hpddo demo (default: out, in the "
                   "current folder)", required=False, default=pathlib.Path("out"))
    p.add_argument("--data", type=pathlib.Path, default=resource_root() / "data" / "default", metavar="DIR",
                   help="folder of labelled bench logs, *.csv (default: the bundled data/default)")
    options.ra_ohm(p)
    options.glitch_filter(p)
    options.seed(p, "the networks and the bootstrap")
    options.quiet(p, "no progress bars")
    return p


def pipeline(logs, out: pathlib.Path, shown: pathlib.Path, effects, args, title: str):
    """Runs the train pipeline into out/model and writes the report into out/report;
    `shown` is where out will be once the demo's output is in place."""
    from ..reports import training as report
    from ..pipeline import PipelineConfig, run as run_pipeline
    from ..train import TrainConfig

    res = run_pipeline(logs, out / "model", PipelineConfig(effects=tuple(effects), ra_ohm=args.ra_ohm,
                                                           glitch_filter=not args.no_glitch_filter,
                                                           train=TrainConfig(seed=args.seed,
                                                                             progress=not args.quiet)))
    report.write(res.metrics, out / "model" / "work" / "estimates", out / "report", title,
                 [f"Model header: {shown / 'model' / 'model_default.h'}. Effects in the physics model: "
                  f"{', '.join(effects) or 'none'}. RMSE measured by the native replay of the cleaned "
                  "recordings through the board observer (hpddo_core)."])
    for w in res.metrics["warnings"]:
        print(f"   WARNING: {w}", file=sys.stderr)
    return res, shown / "report" / "index.html"


def run(args) -> int:
    from .. import outdir
    from ..errors import InputError

    logs = sorted(p for p in args.data.glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        raise InputError(f"no bench logs (*.csv) in {args.data}")
    t0 = time.perf_counter()
    outdir.check(args.out, "demo")
    with outdir.staged(args.out, "demo") as stage:
        demo(logs, stage, args)
    print(f"done in {time.perf_counter() - t0:.1f} s; everything is in {args.out}")
    return 0


def demo(logs, stage: pathlib.Path, args) -> None:
    """The three steps, written into stage (which becomes args.out when all succeed)."""
    from ..diagnosis import core
    from . import diagnose

    print(f"== 1. M1, M2, M3 (16, 8): identify, train, export, replay natively: {', '.join(p.name for p in logs)}")
    base, page = pipeline(logs, stage / "plain", args.out / "plain", [], args,
                          "hpddo: M1, M2 and M3 on the bundled recordings")
    ident = base.metrics["identification"]
    for r in base.recordings:
        print(f"   {r.source.name}: {r.n} rows, {len(r.removed)} of {r.rows_in_file} removed as glitches")
    print(f"   Ra = {ident['ra_ohm']:.3f} ohm, Ke M1 = {ident['ke_m1_vs_per_rad']:.4f} (nameplate), "
          f"Ke M2 = {ident['ke_m2_vs_per_rad']:.4f} V s/rad, clamp +-{ident['clamp_rpm']:.1f} RPM")
    print(base.table, end="")
    print(f"   report: {page}")

    print("== 2. diagnosis: where does the physics model fail, which effect is missing?")
    t1 = time.perf_counter()
    d = diagnose.diagnose_into(logs, core.Options(ra_ohm=args.ra_ohm, seed=args.seed,
                                                  glitch_filter=not args.no_glitch_filter), stage / "diagnosis")
    print(diagnose.summary(d))
    print(f"   diagnosis took {time.perf_counter() - t1:.1f} s; report: {args.out / 'diagnosis' / 'index.html'}")
    missing = list(d.missing_effects)
    if not missing:
        print("== 3. nothing missing: the physics model stays as it is")
        return

    print(f"== 3. add {', '.join(missing)} to the physics model, retrain M3 on top, replay natively")
    after, page = pipeline(logs, stage / "with_effects", args.out / "with_effects", missing, args,
                           f"hpddo: M1, M2 + {', '.join(missing)} and M3 on the bundled recordings")
    for e, val in after.metrics["identification"]["effects"].items():
        print(f"   {e}: {val:.5g}")
    print(after.table, end="")
    b, a = base.metrics["rmse_rpm"], after.metrics["rmse_rpm"]
    conds = [c for c in b["M2"] if c != "average"] + ["average"]
    print("   error before -> after adding the effects (RPM, native replay, held-out 20 %):")
    print("   " + f"{'':22s}" + "".join(f"{c:>16s}" for c in conds))
    for label, m in (("physics (M2)", "M2"), ("hybrid (M3)", "M3")):
        print("   " + f"{label:22s}" + "".join(f"{b[m][c]:7.2f} -> {a[m][c]:5.2f}" for c in conds))
    summary = {"missing_effects": missing, "before": b, "after": a,
               "effects": after.metrics["identification"]["effects"]}
    (stage / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"   report: {page}; summary in {args.out / 'summary.json'}")


def main(argv=None) -> int:
    """`hpddo demo ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("demo", argv)
