#!/usr/bin/env python3
"""The main job on the bundled recordings (data/default), no hardware needed:

  1. identify M1 and M2, train M3, export the model header, replay the recordings natively
     through the board observer, print the RMSE table, write an HTML report;
  2. diagnose which physical effects the physics model misses (tools/diagnose.py);
  3. add the named effects (gen_weights --effects), retrain M3 on top, replay natively, and
     show the error fall, for the physics model and for the hybrid.

    tools/demo.py [--out out] [--data data/default]
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as tools/diagnose.py
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import diagnose  # noqa: E402
from hpddo import outdir, report  # noqa: E402
from hpddo.errors import USER_ERRORS, InputError  # noqa: E402
from hpddo.pipeline import PipelineConfig, run  # noqa: E402
from hpddo.train import TrainConfig  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def pipeline(logs, out: pathlib.Path, shown: pathlib.Path, effects, args, title: str):
    """Runs gen_weights' pipeline into out/model and writes the report into out/report;
    `shown` is where out will be once the demo's output is in place."""
    res = run(logs, out / "model", PipelineConfig(effects=tuple(effects), ra_ohm=args.ra_ohm,
                                                  glitch_filter=not args.no_glitch_filter,
                                                  train=TrainConfig(seed=args.seed)))
    report.write(res.metrics, out / "model" / "work" / "estimates", out / "report", title,
                 [f"Model header: {shown / 'model' / 'model_default.h'}. Effects in the physics model: "
                  f"{', '.join(effects) or 'none'}. RMSE measured by the native replay of the cleaned "
                  "recordings through the board observer (hpddo_core)."])
    for w in res.metrics["warnings"]:
        print(f"   WARNING: {w}", file=sys.stderr)
    return res, shown / "report" / "index.html"


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "out",
                    help="output folder: new, empty, or a previous output of the demo (out/)")
    ap.add_argument("--data", type=pathlib.Path, default=ROOT / "data" / "default",
                    help="folder of labelled bench logs, *.csv (data/default)")
    ap.add_argument("--ra-ohm", type=float, help="armature resistance, ohm (default: the logs' ra_ohm metadata)")
    ap.add_argument("--no-glitch-filter", action="store_true", help="keep every row (no glitch filter)")
    ap.add_argument("--seed", type=int, default=1, help="random seed of the networks and the bootstrap (1)")
    return ap


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    logs = sorted(p for p in args.data.glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        print(f"demo: no bench logs (*.csv) in {args.data}", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    try:
        outdir.check(args.out, "demo")
        with outdir.staged(args.out, "demo") as stage:
            demo(logs, stage, args)
    except USER_ERRORS as exc:
        print(f"demo: {exc}", file=sys.stderr)
        return 1
    print(f"done in {time.perf_counter() - t0:.1f} s; everything is in {args.out}")
    return 0


def demo(logs, stage: pathlib.Path, args) -> None:
    """The three steps, written into stage (which becomes args.out when all succeed)."""
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
    diag_args = [*map(str, logs), "--out", str(stage / "diagnosis"), "--seed", str(args.seed)]
    diag_args += ["--ra-ohm", str(args.ra_ohm)] if args.ra_ohm is not None else []
    diag_args += ["--no-glitch-filter"] if args.no_glitch_filter else []
    if diagnose.main(diag_args) != 0:
        raise InputError("the diagnosis failed (its message is above); nothing was written")
    diag = json.loads((stage / "diagnosis" / "diagnosis.json").read_text())
    missing = diag["missing_effects"]
    print(f"   report: {args.out / 'diagnosis' / 'index.html'}")
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


if __name__ == "__main__":
    sys.exit(main())
