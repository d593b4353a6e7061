"""Bench twin: simulates the paper's PMDC test bench (12 V, low-side PWM, 25GA371 1:4.4,
generator load) and writes <condition>.csv bench logs plus <condition>.truth.json /
<condition>.truth.csv ground truth.          (tools/twin.py is the same command)

examples:
  hpddo twin --protocol all --preset default --seed 1 --out data/default
  hpddo twin --protocol validation --preset default --seed 1 --out data/validation
  hpddo twin --protocol sweep --preset ideal --effects thermal_ra,brush_drop=0.8 --out out/twin
  hpddo twin --protocol load --rate-hz 1000 --time-scale 0.05 --out out/fast
  hpddo twin --protocol load --ripple-hz 10000 --out out/ripple   # with the current bursts (docs/ripple.md)
  hpddo twin --protocol load --ripple-hz 9600 --free-running --mains-hz 50 --out out/free
      # the bursts free-running under the 490 Hz PWM, with mains (docs/ripple-captures.md)
  hpddo twin --list-effects
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from . import options



def _effect_help() -> str:
    from ..twin.params import EFFECTS
    lines = []
    for e in EFFECTS.values():
        lo, hi = e.typical
        lines.append(f"  {e.name:15s} [{e.unit}] default {e.default:g}, typical {lo:g}..{hi:g}: {e.physics}")
    return "\n".join(lines)


def effect_magnitudes(text: str) -> dict:
    """An argparse type: NAME[=MAG],NAME... as {name: magnitude}; a bare NAME takes the
    effect's default magnitude, MAG is in the effect's shown unit, 0 switches it off."""
    from ..twin.params import EFFECT_NAMES, EFFECTS
    mags = {}
    for spec in (s.strip() for s in text.split(",")):
        if not spec:
            continue
        name, sep, val = spec.partition("=")
        name = name.strip()
        if name not in EFFECTS:
            raise argparse.ArgumentTypeError(f"unknown effect {name!r}; known: {', '.join(EFFECT_NAMES)}")
        try:
            mags[name] = float(val) if sep else EFFECTS[name].default
        except ValueError:
            raise argparse.ArgumentTypeError(f"bad magnitude in {spec!r}: NAME=NUMBER expected") from None
        if mags[name] != mags[name] or abs(mags[name]) == float("inf"):
            raise argparse.ArgumentTypeError(f"bad magnitude in {spec!r}: not finite")
    return mags


def effect_names_or_all(text: str) -> tuple:
    """An argparse type: NAME,NAME... or 'all'."""
    from ..twin.params import EFFECT_NAMES, EFFECTS
    names = tuple(s.strip() for s in text.split(",") if s.strip())
    if names == ("all",):
        return tuple(EFFECT_NAMES)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown effect {unknown[0]!r}; known: {', '.join(EFFECT_NAMES)}, or all")
    return names


def parser(prog: str = "hpddo twin") -> argparse.ArgumentParser:
    from ..twin import protocols
    from ..twin.params import PRESETS

    p = options.new_parser(prog, __doc__, epilog="effects (magnitude in the physical unit shown; 0 turns an "
                           "effect off):\n" + _effect_help())
    p.add_argument("--protocol", default="all",
                   choices=list(protocols.KNOWN) + ["all", "validation"],
                   help="training (the paper's): sweep: duty 0-100-0 %% in 20 %% steps; load: 80 %% "
                   "duty, relay switching open/0.5/0.01 ohm; long: 80 %% duty, 0.01 ohm, 60 min; "
                   "all: the three (default). Validation (hpddo's, not in training): unseen: duty/load "
                   "pairs no training protocol holds, 20 s each; hot: training pairs at 55 C ambient "
                   "after a 20 min warm-up; validation: the two")
    options.rate_hz(p, "sample rate (default 2, the paper's)", default=2.0)
    p.add_argument("--preset", default="default", choices=PRESETS,
                   help="default: every effect at its default magnitude + 3 glitches per "
                   "recording; ideal: every effect off, no glitches")
    p.add_argument("--effects", type=effect_magnitudes, default={}, metavar="NAME[=MAG][,NAME...]",
                   help="switch effects on, each at MAG (its physical unit, see below) or at its "
                   "default magnitude; NAME=0 switches one off")
    p.add_argument("--no-effects", type=effect_names_or_all, default=(), metavar="NAME[,NAME...]|all",
                   help="switch effects off ('all' for every effect; --effects then switches some back on)")
    p.add_argument("--glitches", type=options.non_negative_int, default=None, metavar="N",
                   help="sensor glitches per recording (default: 3 with preset default, 0 with ideal)")
    p.add_argument("--no-noise", action="store_true", help="no ADC noise, PWM aliasing or sensor noise")
    p.add_argument("--pwm-hz", type=options.positive_float, default=None, metavar="HZ",
                   help="PWM frequency (default 490.196)")
    p.add_argument("--ripple-hz", type=options.positive_float, default=None, metavar="HZ",
                   help="the ripple mode (docs/ripple.md): the PWM runs at HZ and the current is sampled once "
                   "per PWM period (8000-20000 typical), one burst per window into <condition>.ripple.csv "
                   "(docs/bench-log.md, Ripple bursts); off by default")
    p.add_argument("--free-running", action="store_true",
                   help="with --ripple-hz: the current sampled free-running at that rate, not synchronised with "
                        "the PWM, which runs at --pwm-hz (default 490.196, the UNO's analogWrite); the PWM's own "
                        "current ripple is then in the bursts (docs/ripple-captures.md)")
    p.add_argument("--mains-hz", type=options.positive_float, default=None, metavar="HZ",
                   help="with --free-running: a rectified-mains comb (lines at 2 k HZ) in the current, declared in "
                        "the burst file")
    p.add_argument("--mains-ma", type=options.positive_float, default=None, metavar="MA",
                   help="with --mains-hz: the comb's first line, mA (default 20)")
    p.add_argument("--time-scale", type=options.positive_float, default=1.0, metavar="FACTOR",
                   help="scale every protocol segment duration (e.g. 0.05 for a short test run; default 1)")
    options.seed(p, "the simulation")
    options.out(p, "output folder: new, empty, or a previous output of hpddo twin (protocols add up)",
                required=False)
    options.quiet(p)
    p.add_argument("--list-effects", action="store_true", help="print the effects and exit")
    return p


def validate(args, p: argparse.ArgumentParser) -> None:
    if args.out is None and not args.list_effects:
        p.error("the following arguments are required: --out")
    if args.free_running and args.ripple_hz is None:
        p.error("--free-running applies to the ripple mode: give --ripple-hz HZ")
    if args.mains_hz is not None and not args.free_running:
        p.error("--mains-hz applies with --free-running")
    if args.mains_ma is not None and args.mains_hz is None:
        p.error("--mains-ma applies with --mains-hz")


def build_bench(args):
    import dataclasses

    from ..twin.params import EFFECTS, preset, with_effects

    bench = preset(args.preset)
    mags = {n: 0.0 for n in args.no_effects}
    mags.update(args.effects)
    for name, mag in args.effects.items():
        lo, hi = EFFECTS[name].typical
        if mag != 0.0 and not (min(lo, hi) <= mag <= max(lo, hi)) and not args.quiet:
            print(f"hpddo twin: note: {name}={mag:g} {EFFECTS[name].unit} is outside the typical "
                  f"range {lo:g}..{hi:g}", file=sys.stderr)
    bench = with_effects(bench, **mags)
    changes = {}
    if args.glitches is not None:
        changes["glitches"] = args.glitches
    if args.no_noise:
        changes["noise"] = False
    if args.pwm_hz is not None:
        if args.ripple_hz is not None and not args.free_running and args.pwm_hz != args.ripple_hz:
            from ..logs.errors import InputError
            raise InputError("--pwm-hz and --ripple-hz differ: in the ripple mode the PWM runs at the sample rate")
        changes["pwm_hz"] = args.pwm_hz
    return dataclasses.replace(bench, **changes) if changes else bench


def simulate(bench, prot: str, args, stage: pathlib.Path) -> None:
    """One protocol into stage (which becomes args.out), with a progress bar on long runs."""
    from ..twin import generate, protocols

    total = sum(s[0] for s in protocols.schedule(prot, args.time_scale))
    bar = None
    cb = None
    if not args.quiet and total * args.rate_hz >= 2000:
        from tqdm import tqdm

        bar = tqdm(total=round(total, 3), unit="s", desc=f"{prot} (simulated s)",
                   file=sys.stderr, mininterval=0.5, leave=False, disable=None,  # None: no bar off a terminal
                   bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s [{elapsed}<{remaining}]")
        cb = bar.update
    from ..twin.params import ripple_burst
    ripple = None if args.ripple_hz is None else ripple_burst(sample_hz=args.ripple_hz)
    if args.free_running:  # twin/ripple_free.py: the PWM at the bench's frequency, the samples free-running
        from ..twin.ripple_free import ripple_free
        free = {"pwm_hz": bench.pwm_hz}
        if args.mains_hz is not None:
            free["mains_hz"] = args.mains_hz
        if args.mains_ma is not None:
            free["mains_mA"] = args.mains_ma
        ripple = {**ripple, **ripple_free(**free)}
    g = generate.generate(bench, prot, args.rate_hz, args.seed, out_dir=stage,
                          preset_name=args.preset, time_scale=args.time_scale, progress=cb, ripple=ripple)
    if bar is not None:
        bar.close()
    if not args.quiet:
        tr = g["info"]["truth"]
        print(f"{pathlib.Path(args.out) / g['paths']['log'].name}: {g['info']['rows']} rows, true speed max "
              f"{tr['rpm_true_max']:.1f} RPM, case {tr['case_C_start']:.1f} -> "
              f"{tr['case_C_end']:.1f} C, {len(g['info']['glitches'])} glitches")


def run(args) -> int:
    from ..logs import outdir
    from ..twin import protocols

    if args.list_effects:
        print(_effect_help())
        return 0
    bench = build_bench(args)
    groups = {"all": protocols.PROTOCOLS, "validation": protocols.VALIDATION_PROTOCOLS}
    prots = list(groups.get(args.protocol, (args.protocol,)))
    t0 = time.perf_counter()
    with outdir.staged(args.out, "twin", prune=False) as stage:
        for prot in prots:
            simulate(bench, prot, args, stage)
    if not args.quiet:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


def main(argv=None) -> int:
    """`hpddo twin ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("twin", argv)
