#!/usr/bin/env python3
"""Bench twin: simulate the paper's PMDC bench and write bench logs with ground truth.

Examples:
  tools/twin.py --protocol all --preset default --seed 1 --out data/default
  tools/twin.py --protocol sweep --preset ideal --effect thermal_ra --effect brush_drop=0.8 --out out/twin
  tools/twin.py --protocol load --rate-hz 1000 --time-scale 0.05 --out out/fast
  tools/twin.py --list-effects
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from hpddo import outdir  # noqa: E402
from hpddo.errors import USER_ERRORS  # noqa: E402
from hpddo.twin import generate, protocols  # noqa: E402
from hpddo.twin.params import EFFECT_NAMES, EFFECTS, PRESETS, preset, with_effects  # noqa: E402


def _effect_help():
    lines = []
    for e in EFFECTS.values():
        lo, hi = e.typical
        lines.append(f"  {e.name:15s} [{e.unit}] default {e.default:g}, typical {lo:g}..{hi:g}: {e.physics}")
    return "\n".join(lines)


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        prog="twin.py",
        description="Simulate the paper's PMDC test bench (12 V, low-side PWM, 25GA371 1:4.4, "
        "generator load) and write <condition>.csv bench logs plus <condition>.truth.json / "
        "<condition>.truth.csv ground truth.",
        epilog="Effects (magnitude in the physical unit shown; 0 turns an effect off):\n" + _effect_help(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--protocol", default="all", choices=list(protocols.PROTOCOLS) + ["all"],
                   help="sweep: duty 0-100-0 %% in 20 %% steps; load: 80 %% duty, relay switching "
                   "open/0.5/0.01 ohm; long: 80 %% duty, 0.01 ohm, 60 min; all: the three (default)")
    p.add_argument("--rate-hz", type=float, default=2.0, help="sample rate (default 2, the paper's)")
    p.add_argument("--preset", default="default", choices=PRESETS,
                   help="default: every effect at its default magnitude + 3 glitches per "
                   "recording; ideal: every effect off, no glitches")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[=MAG]",
                   help="switch an effect on, at MAG (physical unit, see below) or at its "
                   "default magnitude; repeatable")
    p.add_argument("--no-effect", action="append", default=[], metavar="NAME",
                   help="switch an effect off ('all' for every effect); repeatable")
    p.add_argument("--glitches", type=int, default=None, help="sensor glitches per recording "
                   "(default: 3 with preset default, 0 with ideal)")
    p.add_argument("--no-noise", action="store_true", help="no ADC noise, PWM aliasing or sensor noise")
    p.add_argument("--pwm-hz", type=float, default=None, help="PWM frequency (default 490.196)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="scale every protocol segment duration (e.g. 0.05 for a short test run)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1); same seed, same bytes")
    p.add_argument("--out", required="--list-effects" not in (argv or sys.argv[1:]),
                   help="output directory")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.add_argument("--list-effects", action="store_true", help="print the effects and exit")
    return p.parse_args(argv)


def build_bench(args):
    import dataclasses

    bench = preset(args.preset)
    mags = {}
    for name in args.no_effect:
        if name == "all":
            mags.update({n: 0.0 for n in EFFECT_NAMES})
        elif name in EFFECTS:
            mags[name] = 0.0
        else:
            raise SystemExit(f"unknown effect {name!r}; known: {', '.join(EFFECT_NAMES)}")
    for spec in args.effect:
        name, sep, val = spec.partition("=")
        name = name.strip()
        if name not in EFFECTS:
            raise SystemExit(f"unknown effect {name!r}; known: {', '.join(EFFECT_NAMES)}")
        try:
            mags[name] = float(val) if sep else EFFECTS[name].default
        except ValueError:
            raise SystemExit(f"bad magnitude in --effect {spec!r}") from None
        lo, hi = EFFECTS[name].typical
        if mags[name] != 0.0 and not (min(lo, hi) <= mags[name] <= max(lo, hi)) and not args.quiet:
            print(f"note: {name}={mags[name]:g} {EFFECTS[name].unit} is outside the typical "
                  f"range {lo:g}..{hi:g}", file=sys.stderr)
    bench = with_effects(bench, **mags)
    changes = {}
    if args.glitches is not None:
        changes["glitches"] = max(0, args.glitches)
    if args.no_noise:
        changes["noise"] = False
    if args.pwm_hz is not None:
        changes["pwm_hz"] = args.pwm_hz
    return dataclasses.replace(bench, **changes) if changes else bench


def simulate(bench, prot: str, args, stage: pathlib.Path) -> None:
    """One protocol into stage (which becomes args.out), with a progress bar on long runs."""
    total = sum(s[0] for s in protocols.schedule(prot, args.time_scale))
    bar = None
    cb = None
    if not args.quiet and total * args.rate_hz >= 2000:
        from tqdm import tqdm

        bar = tqdm(total=round(total, 3), unit="s", desc=f"{prot} (simulated s)",
                   file=sys.stderr, mininterval=0.5, leave=False,
                   bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s [{elapsed}<{remaining}]")
        cb = bar.update
    g = generate.generate(bench, prot, args.rate_hz, args.seed, out_dir=stage,
                          preset_name=args.preset, time_scale=args.time_scale, progress=cb)
    if bar is not None:
        bar.close()
    if not args.quiet:
        tr = g["info"]["truth"]
        print(f"{pathlib.Path(args.out) / g['paths']['log'].name}: {g['info']['rows']} rows, true speed max "
              f"{tr['rpm_true_max']:.1f} RPM, case {tr['case_C_start']:.1f} -> "
              f"{tr['case_C_end']:.1f} C, {len(g['info']['glitches'])} glitches")


def main(argv=None):
    args = parse_args(argv)
    if args.list_effects:
        print(_effect_help())
        return 0
    if not args.rate_hz > 0 or not args.time_scale > 0:
        raise SystemExit("--rate-hz and --time-scale must be > 0")
    bench = build_bench(args)
    prots = list(protocols.PROTOCOLS) if args.protocol == "all" else [args.protocol]
    t0 = time.perf_counter()
    try:
        with outdir.staged(args.out, "twin", prune=False) as stage:
            for prot in prots:
                simulate(bench, prot, args, stage)
    except USER_ERRORS as exc:
        print(f"twin: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
