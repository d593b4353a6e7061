"""Writes the core's unit-test fixtures: small model headers and their golden vectors.

    hpddo fixtures [--out test/fixtures]     (tools/gen_fixtures.py is the same command)

The expected outputs are computed in numpy float32 (hpddo/model/observer_ref.py), never by the C++
code under test. A pytest regenerates them and compares byte for byte.
"""
from __future__ import annotations

import argparse

from .. import resource_root
from . import options


def parser(prog: str = "hpddo fixtures") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    tree = resource_root() / "test" / "fixtures"
    options.out(p, "output folder (default: test/fixtures of the source tree; required when hpddo is "
                   "installed from a wheel, which has no tests)", required=False,
                default=tree if tree.is_dir() else None)
    options.quiet(p)
    return p


def validate(args, p: argparse.ArgumentParser) -> None:
    if args.out is None:
        p.error("the following arguments are required: --out (no source tree with test/fixtures here)")


def run(args) -> int:
    import numpy as np

    from ..logs import benchlog
    from ..model import export, fixtures

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    for name, (hidden, seed, gain) in fixtures.FIXTURES.items():
        model = fixtures.tiny_model(hidden, seed, gain)
        prov = {"command": "tools/gen_fixtures.py", "seed": seed, "data": "hand-made fixture, no training data"}
        (out / f"model_{name}.h").write_text(export.model_header(model, name, prov))
        rows = export.golden_rows(model, fixtures.tiny_stream(seed))
        (out / f"golden_{name}.h").write_text(export.golden_header(rows, name, prov))
        (out / f"golden_{name}.csv").write_text(export.golden_csv(rows))
        export.write_fixed_point(out, model, name, prov, fixtures.tiny_stream(seed))
        export.write_int8(out, model, name, prov, fixtures.tiny_stream(seed))  # int8 weights, quantised as they are
        if not args.quiet:
            print(f"wrote {out}/model_{name}.h, golden_{name}.h/.csv, model_{name}_q.h, golden_{name}_q.h/.csv, "
                  f"model_{name}_q8.h, golden_{name}_q8.h/.csv ({len(rows)} rows)")
    # The deployed model with the dynamic family, on the inputs of its golden vectors: the UNO's
    # build and simavr run with it (test/firmware), the Unity suite test_dynamics_golden.
    default = resource_root() / "models" / "default"
    dyn_out = out / fixtures.DYNAMICS_DIR
    dyn_out.mkdir(exist_ok=True)
    deployed = export.read_model_header((default / "model_default.h").read_text())
    model = fixtures.with_dynamics(deployed)
    samples = fixtures.golden_samples(np.genfromtxt(default / "golden_default.csv", delimiter=",", names=True))
    shaft = ", ".join(f"{k}={v:g}" for k, v in fixtures.DYNAMICS_SHAFT.items())
    prov = {"command": "tools/gen_fixtures.py", "data": f"models/default/model_default.h "
            f"(crc32 0x{export.model_checksum(deployed):08x}) with the dynamic family {shaft} "
            f"(hpddo.model.fixtures.DYNAMICS_SHAFT)"}
    (dyn_out / "model_default.h").write_text(export.model_header(model, "default", prov))
    rows = export.golden_rows(model, samples)
    (dyn_out / "golden_default.h").write_text(export.golden_header(rows, "default", prov))
    (dyn_out / "golden_default.csv").write_text(export.golden_csv(rows))
    export.write_fixed_point(dyn_out, model, "default", prov, samples)
    if not args.quiet:
        print(f"wrote {dyn_out}/model_default.h, golden_default.h/.csv, model_default_q.h, golden_default_q.h/.csv "
              f"({len(rows)} rows, the dynamic family {shaft})")
    df, meta = fixtures.short_log()
    benchlog.write_log(out / "log_short.csv", df, meta)
    (out / "log_bad_duty.csv").write_text(fixtures.BAD_DUTY_LOG)
    if not args.quiet:
        print(f"wrote {out}/log_short.csv ({len(df)} rows), log_bad_duty.csv")
    return 0


def main(argv=None) -> int:
    """`hpddo fixtures ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("fixtures", argv)
