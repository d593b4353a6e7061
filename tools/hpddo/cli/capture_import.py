"""Imports a current-only capture into the project's burst format (docs/ripple-captures.md):
a scope's or DAQ's CSV, a sound card's WAV, a MATLAB .mat, at any sample rate, cut into
contiguous windows and written as OUT (a `<name>.ripple.csv`) for `hpddo ripple OUT`.

    hpddo import scope.csv --a-per-unit 10 --pwm-hz 490.196 --out run1.ripple.csv
    hpddo import card.wav --a-per-unit 0.0005 --pwm-hz 0 --mains-hz 50 --out grinder.ripple.csv
    hpddo import lab.mat --variable i_motor --sample-hz 100000 --pwm-hz 20000 --out lab.ripple.csv
    hpddo ripple run1.ripple.csv --ripples-per-rev 36 --gear-ratio 1 --rpm-range 1000 3000 --out speed

The current is (value - offset) x a_per_unit, value in the file's units (a scope's volts, a
WAV's codes). The sample rate comes from --sample-hz or the file (a CSV's time column, the WAV
header, a .mat variable named fs, Fs, sample_hz, ...); where both are there they must agree.
The file's name, SHA-256 and what was read are kept in the burst file's metadata.
"""
from __future__ import annotations

import argparse

from . import options

TOOL = "import"


def parser(prog: str = "hpddo import") -> argparse.ArgumentParser:
    from ..logs import ripple as rf
    from ..logs.capture_import import KINDS

    p = options.new_parser(prog, __doc__)
    p.add_argument("capture", type=str, metavar="CAPTURE", help="the capture: .csv/.txt, .wav or .mat")
    p.add_argument("--format", choices=sorted(set(KINDS.values())), default=None,
                   help="the capture's type (default: from its suffix)")
    p.add_argument("--a-per-unit", type=options.positive_float, required=True, metavar="A",
                   help="amperes per unit of the file's values (a current probe's 10 A/V: 10; a shunt of 0.1 ohm "
                        "read in volts: 10; a WAV's codes: A per code)")
    p.add_argument("--offset", type=float, default=None, metavar="U",
                   help="the file's value at zero current, in its units (default 0; with --coupling ac the "
                        "capture's mean)")
    p.add_argument("--coupling", choices=rf.COUPLINGS, default=None,
                   help="dc: the mean current is in the values; ac: it is not (a sound card, an AC-coupled "
                        "probe), so no floor on the mean current. Default: ac for WAV, dc otherwise")
    p.add_argument("--sample-hz", type=options.positive_float, default=None, metavar="HZ",
                   help="samples per second (default: from the file)")
    p.add_argument("--pwm-hz", type=options.non_negative_float, required=True, metavar="HZ",
                   help="the drive's PWM frequency, 0 for none (a DC supply): its synchronous average is "
                        "removed before counting (the UNO's analogWrite: 490.196)")
    p.add_argument("--mains-hz", type=options.non_negative_float, default=None, metavar="HZ",
                   help="the mains frequency (50 or 60) where its harmonics may be in the current: a line at "
                        "one of its multiples is never a confident count; 0 where no mains is near the motor (a "
                        "battery): lines on multiples of 50 or 60 Hz are then the motor's. Default: not declared, "
                        "hum at 50 or 60 Hz taken as possible")
    p.add_argument("--window-s", type=options.positive_float, default=0.5, metavar="S",
                   help="the windows the capture is cut into, each counted on its own (default 0.5)")
    p.add_argument("--column", default=None, metavar="NAME|INDEX", help="CSV: the current's column")
    p.add_argument("--time-column", default=None, metavar="NAME|INDEX", help="CSV: the time column (s)")
    p.add_argument("--skip-rows", type=options.non_negative_int, default=0, metavar="N",
                   help="CSV: lines before the header or the first row (a scope's preamble)")
    p.add_argument("--channel", default=None, metavar="INDEX", help="WAV: the channel (0-based)")
    p.add_argument("--variable", default=None, metavar="NAME", help=".mat: the current's variable")
    options.out(p, "the burst file to write, <name>.ripple.csv")
    options.quiet(p)
    return p


def run(args) -> int:
    from ..logs import capture_import as ci
    from ..logs import ripple as rf

    kind = ci.kind_of(args.capture, args.format)
    cap = ci.read(args.capture, kind, column=args.column, time_column=args.time_column, channel=args.channel,
                  variable=args.variable, sample_hz=args.sample_hz, skip_rows=args.skip_rows)
    coupling = args.coupling or (rf.AC if kind == "wav" else rf.DC)
    b = ci.write_bursts(cap, args.out, args.a_per_unit, args.offset, args.window_s, pwm_hz=args.pwm_hz,
                        mains_hz=args.mains_hz, coupling=coupling, source_path=args.capture)
    n = sum(len(c) for c in b.codes)
    left = len(cap.values) - n  # the capture's last samples, fewer than a window can count (ci.MIN_SAMPLES)
    print(f"{args.out}: {len(b)} windows of {float(b.meta['burst_s']):g} s, {n} samples at {cap.sample_hz:g} Hz "
          f"(from {cap.rate_from})" + (f" (the last {left}, fewer than {ci.MIN_SAMPLES}, left out)" if left else "")
          + f", {cap.source} of {args.capture}; {rf.COUPLING}={coupling}, "
          f"{rf.PWM_HZ}={args.pwm_hz:g}" + (f", {rf.MAINS_HZ}={args.mains_hz:g}" if args.mains_hz is not None else ""))
    return 0


def main(argv=None) -> int:
    from . import run as run_subcommand
    return run_subcommand(TOOL, argv)
