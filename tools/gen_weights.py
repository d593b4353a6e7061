#!/usr/bin/env python3
"""Identifies the physics models, trains the residual network and exports the model header.

    tools/gen_weights.py LOG... --out DIR [options]

From labelled bench logs (t_s, duty, v_V, i_A, rpm_ref, ...): removes sensor glitches
(reports them per file), splits each recording chronologically (first 80 % train, last
20 % test), identifies M1 (nameplate Ke) and M2 (measured Ra, Ke by the paper's eq. 20 or
least squares, plus any --effects), trains M3 on the residual e = rpm_ref - n_M2 with
features [V, I, n_M2, I(t-1), n_M2(t-1)], and writes into DIR:

  model_<name>.h      the model header for lib/hpddo_core (provenance, checksum)
  golden_<name>.h/.csv  golden vectors: inputs and every stage's float32 output
  metrics.json        RMSE of M1, M2, M3 per condition on the test parts, measured by
                      the native replay of the cleaned logs through the board observer
  work/               the cleaned logs, the replay built for this model and its
                      per-sample estimates (work/estimates/*.estimates.csv)

A malformed log is refused with its file, line and fault, and nothing is written.
"""
import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from hpddo import physics  # noqa: E402
from hpddo.errors import USER_ERRORS  # noqa: E402
from hpddo import effects as fx  # noqa: E402
from hpddo.pipeline import PipelineConfig, run  # noqa: E402
from hpddo.train import TrainConfig  # noqa: E402


def hidden_sizes(text: str) -> tuple:
    try:
        sizes = tuple(int(s) for s in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"hidden sizes like 16,8 expected, got {text!r}") from None
    if not 1 <= len(sizes) <= 2 or min(sizes) < 1 or max(sizes) > 255:
        raise argparse.ArgumentTypeError("one or two hidden layers of 1..255 neurons (the core's Mlp)")
    return sizes


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("logs", nargs="+", type=pathlib.Path, help="labelled bench logs (CSV)")
    ap.add_argument("--out", required=True, type=pathlib.Path, help="output folder")
    ap.add_argument("--name", default="default", help="model name: model_<name>.h, namespace hpddo_model_<name>")
    ap.add_argument("--ra-ohm", type=float, help="armature resistance, ohm (default: the logs' ra_ohm metadata)")
    ap.add_argument("--rated-v", type=float, default=12.0, help="nameplate voltage for M1, V (12)")
    ap.add_argument("--rated-rpm", type=float, default=1000.0, help="nameplate no-load speed for M1, RPM (1000)")
    ap.add_argument("--ke-fit", choices=["eq20", "lsq"], default="eq20",
                    help="M2 Ke: mean of per-row ratios (paper eq. 20) or least squares")
    ap.add_argument("--effects", type=fx.parse_names, default=(),
                    help=f"effects to add to the physics model, comma separated: {', '.join(physics.EFFECT_BITS)}")
    ap.add_argument("--hidden", type=hidden_sizes, default=(16, 8), help="hidden layer sizes (16,8)")
    ap.add_argument("--max-iter", type=int, default=2000, help="training iterations (epochs), no early stop (2000)")
    ap.add_argument("--seed", type=int, default=1, help="random seed of the network (1)")
    ap.add_argument("--split", type=float, default=0.8, help="training fraction of each recording (0.8)")
    ap.add_argument("--no-glitch-filter", action="store_true", help="keep every row")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    if not 0.1 <= args.split <= 0.95:
        print("gen_weights: --split must be within 0.1..0.95", file=sys.stderr)
        return 2
    cfg = PipelineConfig(name=args.name, ra_ohm=args.ra_ohm, rated_V=args.rated_v, rated_rpm=args.rated_rpm,
                         ke_fit=args.ke_fit, effects=args.effects, train_fraction=args.split,
                         glitch_filter=not args.no_glitch_filter,
                         train=TrainConfig(hidden=args.hidden, max_iter=args.max_iter, seed=args.seed,
                                           progress=not args.quiet),
                         command="tools/gen_weights.py " + " ".join(
                             [str(p.name) for p in args.logs] + ["--name", args.name, "--seed", str(args.seed)]
                             + (["--effects", ",".join(args.effects)] if args.effects else [])
                             + (["--hidden", ",".join(map(str, args.hidden))] if args.hidden != (16, 8) else [])))
    t0 = time.perf_counter()
    try:
        res = run(args.logs, args.out, cfg)
    except USER_ERRORS as exc:
        print(f"gen_weights: {exc}", file=sys.stderr)
        return 1
    for r in res.recordings:
        print(f"{r.source}: {r.n} rows ({r.n_train} train, {r.n - r.n_train} test), "
              f"{len(r.removed)} of {r.rows_in_file} rows removed as glitches")
    for w in res.metrics["warnings"]:
        print(f"gen_weights: WARNING: {w}", file=sys.stderr)
    ident = res.metrics["identification"]
    print(f"Ra = {ident['ra_ohm']:.4g} ohm ({ident['ra_source']}); M1 Ke = {ident['ke_m1_vs_per_rad']:.4f} V s/rad "
          f"(nameplate); M2 Ke = {ident['ke_m2_vs_per_rad']:.4f} V s/rad ({args.ke_fit})")
    for e, val in ident["effects"].items():
        print(f"  effect {e}: {physics.EFFECT_BITS[e][1]} = {val:.5g}")
    print(f"M3 {args.hidden}: clamp +-{ident['clamp_rpm']:.2f} RPM, {ident['train_rows']} training rows")
    print(res.table, end="")
    print(f"wrote {args.out}/ in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
