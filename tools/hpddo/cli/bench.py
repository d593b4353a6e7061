"""Benchmark of the offline pipeline and the native replay; prints its figures.

    hpddo bench [--repeat 30]          (tools/bench_pipeline.py is the same command)

1. The whole default pipeline, (16, 8), on the bundled recordings: wall time (target: 60 s
   on a 2-core machine).
2. The native replay throughput, in memory, one thread: per-sample (the board observer,
   physics + features + network, one Observer::step per sample) and batched (network as
   Eigen matrix products), against scikit-learn's MLPRegressor.predict on the same rows
   (network only, features precomputed, one BLAS thread), measured in the same run.
   Target: at least 1e6 samples/s per core for the per-sample path.

    hpddo bench --observer [--write-docs] [--no-lx106] [--build DIR] [--peer-python PY]

instead measures the observer on the boards and the host, float against fixed point
(tools/hpddo/studies/perf.py: AVR cycle-exact in simavr with emlearn as the peer, host samples/s
against scikit-learn) and prints the table; with --write-docs it also writes the table
into docs/performance.md and the figures into docs/figures/bench_observer.json.

    hpddo bench --diagnose [--data DIR]

instead times hpddo diagnose with its defaults on the bundled recordings (--data) beside one fit of
M2 with every library effect on the same rows, its peer, and on a twin bench of 13.6k rows written
into a temporary folder (tools/hpddo/studies/diagnose_speed.py; target: 10 s each on an idle 2-core
machine), with the CPU-seconds of the main process and its workers.

    hpddo bench --large-log [--rows 2000000]

instead writes a large synthetic bench log in a temporary folder and prints what reading it
costs, each in a fresh process (tools/hpddo/studies/large_log.py): read_log's peak RSS against
the file's size, the time and peak RSS to refuse a fault at line 7207 against the whole read,
and hpddo evaluate of the whole file with models/default (target: peak RSS at most 3 x the
file + 300 MB).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import tempfile
import time

from .. import resource_root
from . import options


def parser(prog: str = "hpddo bench") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    p.add_argument("--repeat", type=options.positive_int, default=30, metavar="N",
                   help="passes over the rows; the best one counts (default 30)")
    p.add_argument("--data", type=pathlib.Path, default=resource_root() / "data" / "default", metavar="DIR",
                   help="folder of labelled bench logs, *.csv (default: the bundled data/default)")
    p.add_argument("--observer", action="store_true",
                   help="measure the observer step on the AVR (simavr) and the host, float against fixed point "
                        "(tools/hpddo/studies/perf.py) instead of the pipeline")
    p.add_argument("--write-docs", action="store_true",
                   help="--observer: write the table into docs/performance.md and the figures into "
                        "docs/figures/bench_observer.json")
    p.add_argument("--build", type=pathlib.Path, default=resource_root() / "build-bench", metavar="DIR",
                   help="--observer: build folder (default build-bench in the source tree)")
    p.add_argument("--no-lx106", action="store_true",
                   help="--observer: leave out the ESP8266 instruction counts (QEMU's lx106; without this, "
                        "qemu-system-misc and gcc-12-source are installed on demand when root, as scripts/bootstrap.sh "
                        "--tests does)")
    p.add_argument("--peer-python", type=pathlib.Path, default=None, metavar="PY",
                   help="--observer: a Python with emlearn 0.23.2 and scikit-learn, for the peer "
                        "(default .venv-bench/bin/python of the source tree)")
    p.add_argument("--large-log", action="store_true",
                   help="measure reading a large bench log and hpddo evaluate on it (peak RSS against the file's "
                        "size, time to refuse an early fault against the whole read) instead of the pipeline")
    p.add_argument("--diagnose", action="store_true",
                   help="time hpddo diagnose with its defaults on --data beside one full-library fit of the same "
                        "rows, its peer, and on a 13.6k-row twin bench (tools/hpddo/studies/diagnose_speed.py), "
                        "instead of the pipeline")
    p.add_argument("--rows", type=options.positive_int, default=2_000_000, metavar="N",
                   help="--large-log: rows of the synthetic log (default 2000000, about 98 MB)")
    return p


def sklearn_peer(net):
    """scikit-learn's MLPRegressor holding the trained weights: the peer for predict speed."""
    import numpy as np
    from sklearn.neural_network import MLPRegressor
    peer = MLPRegressor(hidden_layer_sizes=net.hidden, max_iter=1)
    peer.partial_fit(np.zeros((2, net.coefs_[0].shape[0])), np.zeros(2))  # sets up the layers
    peer.coefs_ = [w.copy() for w in net.coefs_]
    peer.intercepts_ = [b.copy() for b in net.intercepts_]
    return peer


def run(args) -> int:
    # every figure as a first run costs: no native replay from the cache (evaluation/replay.py), its build timed
    from ..evaluation import replay as _replay
    os.environ[_replay.CACHE_ENV] = ""
    if args.large_log:
        from ..studies import large_log
        with tempfile.TemporaryDirectory(prefix="hpddo-bench-large-") as tmp:
            large_log.measure(tmp, args.rows, resource_root() / "models" / "default")
        return 0
    if args.diagnose:
        from ..studies import diagnose_speed
        with tempfile.TemporaryDirectory(prefix="hpddo-bench-diagnose-") as tmp:
            m = diagnose_speed.measure(args.data, pathlib.Path(tmp) / "report")
            large = diagnose_speed.measure_large(pathlib.Path(tmp) / "large")
        print(diagnose_speed.report(m, large))
        return 0
    if args.observer:
        from ..studies import perf
        # absolute: emlearn's converter runs inside the build folder (a relative --build failed there)
        perf.run(args.build.resolve(), min(args.repeat, 20), args.peer_python, write=args.write_docs, lx=not args.no_lx106)
        return 0
    import numpy as np

    from ..evaluation import replay
    from ..model import train
    from ..logs.errors import InputError
    from ..pipeline import PipelineConfig, run as run_pipeline
    from ..model.train import TrainConfig

    logs = sorted(p for p in args.data.glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        raise InputError(f"no bench logs (*.csv) in {args.data}")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_pipeline(logs, pathlib.Path(tmp), PipelineConfig(train=TrainConfig(progress=False)))
        pipeline_s = time.perf_counter() - t0
        work = pathlib.Path(tmp) / "work"
        clean = sorted((work / "logs").glob("*.csv"))
        speed = replay.bench(work / "replay", clean, args.repeat)
        rows, per_sample, batched = speed["samples"], speed["per_sample_per_s"], speed["batched_per_s"]
        x = np.concatenate([train.features(r, res.m2)[0] for r in res.recordings])
        z = res.residual.scaler.transform(x)
        peer = sklearn_peer(res.residual.mlp)
        best = 1e30
        for _ in range(args.repeat):
            t1 = time.perf_counter()
            peer.predict(res.residual.scaler.transform(x))
            best = min(best, time.perf_counter() - t1)
        sk = len(z) / best
    print(f"pipeline (16, 8), identify + train 2000 it + export + replay: {pipeline_s:.1f} s "
          f"(target 60 s: {'met' if pipeline_s <= 60 else 'NOT met'})")
    print(f"replay per-sample: {per_sample:.3g} samples/s on one core "
          f"(target 1e6: {'met' if per_sample >= 1e6 else 'NOT met'}), {rows} rows, best of {args.repeat}")
    print(f"replay batched:    {batched:.3g} samples/s")
    print(f"scikit-learn predict (scaler + network only): {sk:.3g} samples/s")
    print(f"ratio per-sample replay / scikit-learn: {per_sample / sk:.2f}; batched / scikit-learn: {batched / sk:.2f}")
    return 0


def main(argv=None) -> int:
    """`hpddo bench ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("bench", argv)
