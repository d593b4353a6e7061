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
from hpddo import report  # noqa: E402
from hpddo.pipeline import PipelineConfig, run  # noqa: E402
from hpddo.train import TrainConfig  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def pipeline(logs, out: pathlib.Path, effects, seed: int, title: str):
    res = run(logs, out / "model", PipelineConfig(effects=tuple(effects), train=TrainConfig(seed=seed)))
    page = report.write(res.metrics, out / "model" / "work" / "estimates", out / "report", title,
                        [f"Model header: {out / 'model' / 'model_default.h'}. Effects in the physics model: "
                         f"{', '.join(effects) or 'none'}. RMSE measured by the native replay of the cleaned "
                         "recordings through the board observer (hpddo_core)."])
    return res, page


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "out")
    ap.add_argument("--data", type=pathlib.Path, default=ROOT / "data" / "default")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    logs = sorted(p for p in args.data.glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        print(f"demo: no bench logs in {args.data}", file=sys.stderr)
        return 1
    t0 = time.perf_counter()

    print(f"== 1. M1, M2, M3 (16, 8): identify, train, export, replay natively: {', '.join(p.name for p in logs)}")
    base, page = pipeline(logs, args.out / "plain", [], args.seed, "hpddo: M1, M2 and M3 on the bundled recordings")
    ident = base.metrics["identification"]
    for r in base.recordings:
        print(f"   {r.source.name}: {r.n} rows, {len(r.removed)} glitch rows removed")
    print(f"   Ra = {ident['ra_ohm']:.3f} ohm, Ke M1 = {ident['ke_m1_vs_per_rad']:.4f} (nameplate), "
          f"Ke M2 = {ident['ke_m2_vs_per_rad']:.4f} V s/rad, clamp +-{ident['clamp_rpm']:.1f} RPM")
    print(base.table, end="")
    print(f"   report: {page}")

    print("== 2. diagnosis: where does the physics model fail, which effect is missing?")
    diag_dir = args.out / "diagnosis"
    rc = diagnose.main([*map(str, logs), "--out", str(diag_dir), "--seed", str(args.seed)])
    if rc != 0:
        return rc
    diag = json.loads((diag_dir / "diagnosis.json").read_text())
    missing = diag["missing_effects"]
    print(f"   report: {diag_dir / 'index.html'}")
    if not missing:
        print("== 3. nothing missing: the physics model stays as it is")
        print(f"done in {time.perf_counter() - t0:.1f} s")
        return 0

    print(f"== 3. add {', '.join(missing)} to the physics model, retrain M3 on top, replay natively")
    after, page = pipeline(logs, args.out / "with_effects", missing, args.seed,
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
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"   report: {page}")
    print(f"done in {time.perf_counter() - t0:.1f} s; summary in {args.out / 'summary.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
