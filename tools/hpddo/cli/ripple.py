"""Speed from the commutation ripple: per window of each bench log, the output-shaft speed
counted from the current bursts beside it (<condition>.ripple.csv, docs/bench-log.md), with a
confidence and the reason where there is none (docs/ripple.md).

    hpddo ripple LOG... --ripples-per-rev N --gear-ratio G --out OUT [--ke-vs-per-rad KE]

The back-EMF prior that picks the main line among its sub-harmonics is M2, (V - I Ra) / Ke:
with --ke-vs-per-rad, that Ke; without, a Ke calibrated from the ripple itself (the windows
the comb alone resolves). Where a log has encoder speeds (rpm_ref), the ripple speed is
scored against them (rows the pipeline's glitch filter marks left out) and the gear ratio checked: the statement says when the data's ratio is
not the one given. Writes OUT/<condition>.ripple_speed.csv and OUT/summary.json.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from . import options

TOOL = "ripple"


def parser(prog: str = "hpddo ripple") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    options.logs(p, help="bench logs (CSV, docs/bench-log.md), each with its <condition>.ripple.csv beside it")
    p.add_argument("--ripples-per-rev", type=options.positive_int, required=True, metavar="N",
                   help="commutation ripples per motor revolution (2 x segments for two brushes)")
    p.add_argument("--gear-ratio", type=options.positive_float, required=True, metavar="G",
                   help="motor revolutions per output revolution (the nameplate's; checked where there is an encoder)")
    p.add_argument("--ke-vs-per-rad", type=options.positive_float, default=None, metavar="KE",
                   help="Ke of the back-EMF prior, V s/rad at the output shaft (default: calibrated from the ripple)")
    p.add_argument("--floor-a", type=options.positive_float, default=None, metavar="A",
                   help="no speed under this mean current (default 0.10 A)")
    options.ra_ohm(p)
    options.out(p, "output folder: new, empty, or a previous output of hpddo ripple")
    options.quiet(p)
    return p


def run(args) -> int:
    import dataclasses

    import numpy as np

    from ..logs import benchlog, dataset, outdir
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from ..model import ripple as rp

    opts = rp.Options(args.ripples_per_rev, args.gear_ratio)
    if args.floor_a is not None:
        opts = dataclasses.replace(opts, floor_A=args.floor_a)
    summary = {}
    with outdir.staged(args.out, TOOL) as stage:
        for path in args.logs:
            log = benchlog.read_log(path)
            df = log.df
            bpath = rf.path_for(path)
            if not bpath.exists():
                raise InputError(f"{path}: no current bursts beside it ({bpath.name}); record them in the ripple "
                                 "mode (hpddo twin --ripple-hz, docs/ripple.md)")
            b = rf.read(bpath)
            seq = df["seq"].to_numpy() if "seq" in df else np.arange(len(df))
            pos = {int(s): k for k, s in enumerate(seq)}
            rows = [pos.get(int(s)) for s in b.seq]
            if any(r is None for r in rows):
                raise InputError(f"{bpath}: a burst's seq is not in {path.name}")
            ra = args.ra_ohm if args.ra_ohm is not None else float(log.meta.get("ra_ohm", "nan"))
            if not math.isfinite(ra):
                raise InputError(f"{path}: no ra_ohm metadata; give --ra-ohm")
            duty, v, i = (df[c].to_numpy()[rows] for c in ("duty", "v_V", "i_A"))
            if args.ke_vs_per_rad:
                ke, n_ke = args.ke_vs_per_rad, 0
            else:
                ke, n_ke = rp.calibrate_ke(b, duty, v, i, ra, opts)
            prior = rp.m2_prior_rpm(v, i, ra, ke) if math.isfinite(ke) else None
            est = rp.estimate(b, duty, prior, opts)
            est.insert(1, "t_s", df["t_s"].to_numpy()[rows])
            est["rpm_prior"] = np.nan if prior is None else prior
            name = log.condition
            cols = ["seq", "t_s", "rpm", "confidence", "confident", "reason", "f_Hz", "cycles", "i_mean_A",
                    "rpm_prior", "rpm_fft"]
            est[cols].rename(columns={"rpm": "rpm_ripple"}).to_csv(stage / f"{name}.ripple_speed.csv", index=False,
                                                                    float_format="%.6g")
            conf = est["confident"].to_numpy()
            above = est["i_mean_A"].to_numpy() >= opts.floor_A
            s = {"windows": len(est), "confident": int(conf.sum()), "above_floor": int(above.sum()),
                 "ke_prior_vs_per_rad": ke, "ke_from": "user" if args.ke_vs_per_rad else f"ripple ({n_ke} windows)",
                 "reasons": {k or "confident": int(n) for k, n in est["key"].value_counts().sort_index().items()}}
            if "rpm_ref" in df and np.isfinite(df["rpm_ref"].to_numpy()[rows]).any():
                glitch, _ = dataset.glitch_mask(df)  # the glitch filter of the pipeline (docs/pipeline.md)
                ref = np.where(glitch, np.nan, df["rpm_ref"].to_numpy())[rows]
                s["glitch_rows_left_out"] = int(glitch.sum())
                ok = conf & np.isfinite(ref) & (ref > 0)
                if ok.any():
                    e = est["rpm"].to_numpy()[ok] / ref[ok] - 1
                    s["rms_vs_encoder_pct"] = float(100 * np.sqrt(np.mean(e ** 2)))
                    s["max_vs_encoder_pct"] = float(100 * np.max(np.abs(e)))
                window_s = float(np.median(np.diff(df["t_s"].to_numpy()))) if len(df) > 1 else math.nan
                s["ratio_check"] = rp.check_ratio(est, ref, window_s, opts)
            summary[name] = s
            share = f"{(conf & above).sum() / above.sum():.1%}" if above.sum() else "-"
            line = (f"{name}: {len(est)} windows, confident {conf.sum()} ({share} of the {above.sum()} above "
                    f"{opts.floor_A:g} A); prior Ke {ke:.4f} V s/rad from {s['ke_from']}")
            if "rms_vs_encoder_pct" in s:
                line += f"; against the encoder RMS {s['rms_vs_encoder_pct']:.3f} %, max {s['max_vs_encoder_pct']:.2f} %"
            print(line)
            if "ratio_check" in s:
                print(f"{name}: {s['ratio_check']['statement']}")
            if not args.quiet:
                print("  no estimate: " + ", ".join(f"{k} {n}" for k, n in s["reasons"].items() if k != "confident"),
                      file=sys.stderr)
        benchlog.write_text_atomic(stage / "summary.json", json.dumps(summary, indent=1, sort_keys=True,
                                                                      default=float) + "\n")
    return 0


def main(argv=None) -> int:
    from . import run as run_subcommand
    return run_subcommand(TOOL, argv)
