#!/usr/bin/env python3
"""Writes the core's unit-test fixtures: small model headers and their golden vectors.

    tools/gen_fixtures.py [--out test/fixtures]

The expected outputs are computed in numpy float32 (hpddo/observer_ref.py), never by the C++
code under test. A pytest regenerates them and compares byte for byte.
"""
import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from hpddo import benchlog, export, fixtures  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(pathlib.Path(__file__).resolve().parents[1] / "test" / "fixtures"))
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, (hidden, seed, gain) in fixtures.FIXTURES.items():
        model = fixtures.tiny_model(hidden, seed, gain)
        prov = {"command": "tools/gen_fixtures.py", "seed": seed, "data": "hand-made fixture, no training data"}
        (out / f"model_{name}.h").write_text(export.model_header(model, name, prov))
        rows = export.golden_rows(model, fixtures.tiny_stream(seed))
        (out / f"golden_{name}.h").write_text(export.golden_header(rows, name, prov))
        (out / f"golden_{name}.csv").write_text(export.golden_csv(rows))
        print(f"wrote {out}/model_{name}.h, golden_{name}.h/.csv ({len(rows)} rows)")
    df, meta = fixtures.short_log()
    benchlog.write_log(out / "log_short.csv", df, meta)
    (out / "log_bad_duty.csv").write_text(fixtures.BAD_DUTY_LOG)
    print(f"wrote {out}/log_short.csv ({len(df)} rows), log_bad_duty.csv")


if __name__ == "__main__":
    main()
