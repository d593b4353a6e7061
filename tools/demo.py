#!/usr/bin/env python3
"""The main job on the bundled recordings (data/default): identify, train, export, replay
natively, print the RMSE table and write an HTML report. No hardware needed.

    tools/demo.py [--out out] [--data data/default]
"""
import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from hpddo import report  # noqa: E402
from hpddo.pipeline import PipelineConfig, run  # noqa: E402
from hpddo.train import TrainConfig  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "out")
    ap.add_argument("--data", type=pathlib.Path, default=ROOT / "data" / "default")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    logs = sorted(args.data.glob("*.csv"))
    logs = [p for p in logs if not p.name.endswith(".truth.csv")]
    if not logs:
        print(f"demo: no bench logs in {args.data}", file=sys.stderr)
        return 1

    t0 = time.perf_counter()
    print(f"== 1. identify M1/M2, train M3 (16, 8), export, replay natively: {', '.join(p.name for p in logs)}")
    res = run(logs, args.out / "model", PipelineConfig(train=TrainConfig(seed=args.seed)))
    ident = res.metrics["identification"]
    for r in res.recordings:
        print(f"   {r.source.name}: {r.n} rows, {len(r.removed)} glitch rows removed")
    print(f"   Ra = {ident['ra_ohm']:.3f} ohm, Ke M1 = {ident['ke_m1_vs_per_rad']:.4f} (nameplate), "
          f"Ke M2 = {ident['ke_m2_vs_per_rad']:.4f} V s/rad, clamp +-{ident['clamp_rpm']:.1f} RPM")
    print(res.table, end="")
    page = report.write(res.metrics, args.out / "model" / "work" / "estimates", args.out / "report",
                        "hpddo: M1, M2 and M3 on the bundled recordings",
                        [f"Model header: {args.out / 'model' / 'model_default.h'}. RMSE measured by the native "
                         "replay of the cleaned recordings through the board observer (hpddo_core)."])
    print(f"   report: {page}")
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
