"""The command line: `hpddo SUBCOMMAND [options]` (also `python -m hpddo`).

May import: anything of hpddo (it is the top). One module per subcommand, each with parser(prog), run(args) -> exit status, main(argv)
and, where options depend on each other, validate(args, parser). A subcommand's
module is imported only when it runs, so `hpddo --help` and `hpddo twin` do not load the
training and diagnosis code.

One convention for every subcommand: the same flag names for the same things
(--out, --quiet, --seed, --ra-ohm, --effects NAME[,NAME...], --no-glitch-filter); a user
error (hpddo.logs.errors.USER_ERRORS: a bad log, a refused output folder, an input the
pipeline cannot use, a failed capture) is one line `hpddo SUBCOMMAND: message` on
stderr and exit status 1; progress (hpddo.progress: a stage line on stderr as each long step
starts, a bar on a terminal) unless --quiet; a bad command line is argparse's usage message and status 2;
Ctrl-C (SIGINT) or SIGTERM is one line and status 130 or 143, with no process of the tool
left running and nothing half-written (hpddo.interrupt).
"""
from __future__ import annotations

import argparse
import gc
import importlib
import sys

from .. import __version__

#: name -> (module, one-line help); the order of `hpddo --help`.
SUBCOMMANDS = {
    "train": ("train", "identify M1 and M2, train the M3 network, export the model header, replay natively "
                       "(tools/gen_weights.py)"),
    "evaluate": ("evaluate", "score a trained model on every row of recordings it never saw, beside a "
                             "lookup baseline"),
    "compare": ("compare", "the paper's comparison: EKF, sliding-mode observer, pure network, M1-M3, lookup; "
                           "Tables 7-10 and the out-of-distribution test"),
    "diagnose": ("diagnose", "name the physical effects the physics model misses (tools/diagnose.py)"),
    "ripple": ("ripple", "speed from the commutation ripple of the current bursts beside each log, with a "
                         "confidence and a reason; checks the gear ratio against an encoder (docs/ripple.md)"),
    "import": ("capture_import", "import a current-only capture (scope CSV, sound-card WAV, MATLAB .mat) into the "
                                 "burst format hpddo ripple counts (docs/ripple-captures.md)"),
    "twin": ("twin", "simulate the bench and write bench logs with ground truth (tools/twin.py)"),
    "capture": ("capture", "record the acquisition board's USB stream to a bench log (tools/capture.py)"),
    "live": ("live", "show the estimate against the encoder in a browser page while recording the bench "
                     "(hpddo capture's log)"),
    "upload": ("upload", "send a trained model to the running ESP8266 board, without reflashing"),
    "demo": ("demo", "the whole job on the bundled recordings: train, diagnose, add effects "
                     "(tools/demo.py)"),
    "bench": ("bench", "time the pipeline and the native replay (tools/bench_pipeline.py)"),
    "fixtures": ("fixtures", "write the core's unit-test fixtures (tools/gen_fixtures.py)"),
}


def _module(name: str):
    return importlib.import_module(f"{__name__}.{SUBCOMMANDS[name][0]}")


def parser(name: str) -> argparse.ArgumentParser:
    """The option parser of one subcommand (prog `hpddo NAME`)."""
    return _module(name).parser(f"hpddo {name}")


def report(name: str, message) -> None:
    """A user error as the one line every subcommand prints."""
    text = " ".join(str(message).split("\n"))
    print(f"hpddo {name}: {text}", file=sys.stderr)


def run(name: str, argv=None) -> int:
    """Parses argv for subcommand NAME and runs it; returns its exit status (a user error:
    its one line on stderr and 1; a bad command line: SystemExit(2) from argparse)."""
    from .. import interrupt, progress
    from ..logs.errors import USER_ERRORS  # (here: it loads the log reader, pandas; `hpddo --help` need not)

    # Loading and parsing come before the handler's run phase: a signal meanwhile ends the process at once
    # (under interrupt.arm, as every tool's entry does), never raised into a half-done import.
    mod = _module(name)
    p = mod.parser(f"hpddo {name}")
    args = p.parse_args(argv)
    if hasattr(mod, "validate"):  # checks across options: a usage error, status 2
        mod.validate(args, p)
    if not gc.isenabled():  # (the hpddo command's entry keeps the collector off while it imports: hpddo.__main__)
        gc.freeze()
        gc.enable()
    try:
        with interrupt.handling(f"hpddo {name}"):
            try:
                with progress.reporting(name, not getattr(args, "quiet", False)):
                    return mod.run(args)
            except USER_ERRORS as exc:
                report(name, exc)
                return 1
    except KeyboardInterrupt as exc:  # interrupt.Interrupted, or Ctrl-C where no handler is in place
        signum = exc.signum if isinstance(exc, interrupt.Interrupted) else interrupt.SIGINT
        print(interrupt.stopped_line(f"hpddo {name}", interrupt.NAMES[signum]), file=sys.stderr)
        return interrupt.STATUS[signum]
    except BrokenPipeError:
        # the reader of the standard output went away (`hpddo diagnose ... | head`): nothing more is printed, and no
        # traceback; the command's files are whole (each is written aside and renamed into place) or not there
        _quiet_stdout()
        return BROKEN_PIPE_STATUS


BROKEN_PIPE_STATUS = 141  # 128 + SIGPIPE, as a shell reports a command its pipe's reader left


def _quiet_stdout() -> None:
    """The standard output pointed at the null device: the interpreter's own flush at exit would raise again."""
    import os

    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # (a captured stream: nothing to point elsewhere)
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


def top_parser() -> argparse.ArgumentParser:
    width = max(map(len, SUBCOMMANDS))
    listing = "\n".join(f"  {n:{width}s}  {h}" for n, (_, h) in SUBCOMMANDS.items())
    ap = argparse.ArgumentParser(
        prog="hpddo", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="hpddo: sensorless speed estimation for brushed DC motors (hybrid physics-data-driven "
                    "observer): bench logs in, a model header for the boards out.",
        epilog=f"subcommands:\n{listing}\n\n`hpddo SUBCOMMAND --help` gives each one's options.")
    ap.add_argument("--version", action="version", version=f"hpddo {__version__}")
    ap.add_argument("command", metavar="SUBCOMMAND", choices=list(SUBCOMMANDS),
                    help=f"one of: {', '.join(SUBCOMMANDS)}")
    return ap


def main(argv=None) -> int:
    """`hpddo SUBCOMMAND [options]`."""
    argv = list(sys.argv[1:] if argv is None else argv)
    top = top_parser()
    if not argv or argv[0].startswith("-"):
        top.parse_args(argv[:1])  # --help, --version, or a usage error (exits)
        top.error("the subcommand comes first")
    if argv[0] not in SUBCOMMANDS:
        top.error(f"unknown subcommand {argv[0]!r} (choose from {', '.join(SUBCOMMANDS)})")
    return run(argv[0], argv[1:])
