"""The options several subcommands share, declared once: the same name, meaning and help
everywhere, and the argparse types that check a value before any work starts."""
from __future__ import annotations

import argparse
import pathlib

from .. import bench as bench_hw


def new_parser(prog: str, doc: str, epilog: str | None = None) -> argparse.ArgumentParser:
    """A subcommand's parser: its module docstring as the description."""
    return argparse.ArgumentParser(prog=prog, description=doc, epilog=epilog,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)


def out(p, help: str, required: bool = True, default=None, alias: str | None = None) -> None:
    """--out DIR (or FILE): where the results go."""
    names = ["--out"] + ([alias] if alias else [])
    p.add_argument(*names, dest="out", required=required, default=default, type=pathlib.Path,
                   metavar="PATH", help=help)


QUIET_HELP = ("no progress output (bars, progress lines, lists of files written); the results, warnings and "
              "errors still print")


def quiet(p) -> None:
    """--quiet: one meaning in every subcommand."""
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)


def epochs(p, default: int, what: str) -> None:
    """--epochs N: training epochs of a network (no early stop)."""
    p.add_argument("--epochs", type=positive_int, default=default, metavar="N",
                   help=f"training epochs of {what}, no early stop (default {default})")


def rate_hz(p, help: str, default=None) -> None:
    """--rate-hz HZ: a sample rate."""
    p.add_argument("--rate-hz", type=positive_float, default=default, metavar="HZ", help=help)


def seed(p, what: str) -> None:
    p.add_argument("--seed", type=int, default=1, help=f"random seed of {what} (default 1); same seed, same bytes")


def ra_ohm(p) -> None:
    p.add_argument("--ra-ohm", type=float, metavar="OHM",
                   help="armature resistance, ohm (default: the logs' ra_ohm metadata)")


def nameplate(p, what: str = "") -> None:
    """--rated-v and --rated-rpm: the motor's nameplate, for M1 (None: not given)."""
    p.add_argument("--rated-v", type=positive_float, default=None, metavar="V",
                   help=f"nameplate voltage for M1, V (default 12){what}")
    p.add_argument("--rated-rpm", type=positive_float, default=None, metavar="RPM",
                   help=f"nameplate no-load speed for M1, RPM (default 1000){what}")


def number_word(v: float) -> str:
    """A number as a command line repeats it: 12 for 12.0, 4.5 for 4.5."""
    return str(int(v)) if float(v).is_integer() else repr(v)


def ke_fit(p) -> None:
    from ..model.identify import KE_FITS
    p.add_argument("--ke-fit", choices=list(KE_FITS), default=KE_FITS[0],
                   help="M2 Ke: mean of per-window ratios (paper eq. 20, the default) or least squares")


def glitch_filter(p) -> None:
    p.add_argument("--no-glitch-filter", action="store_true",
                   help="keep every row (no glitch filter; docs/pipeline.md, step 2)")


def leave_one_out(p) -> None:
    p.add_argument("--leave-one-out", action="store_true",
                   help="also validate across recordings: for each recording, train on the others and score it "
                        "whole (the figure to trust for a new run)")


def effects(p, what: str) -> None:
    """--effects NAME,NAME...: effect terms of the physics model (hpddo/model/effects.py)."""
    from ..model import effects as fx
    p.add_argument("--effects", type=fx.parse_names, default=(), metavar="NAME[,NAME...]",
                   help=f"{what}, comma separated: {', '.join(fx.NAMES)}")


def hold(p) -> None:
    """--hold NAME=VALUE,...: effects of --effects whose coefficient is held, not fitted (a material's, or a
    number in the effect's unit; hpddo/model/effects.py parse_holds)."""
    from ..model import effects as fx
    p.add_argument("--hold", type=fx.parse_holds, default={}, metavar="NAME=VALUE[,...]",
                   help="hold the coefficient of effects in --effects instead of fitting it: the name of its "
                        f"material ({fx.COPPER}=copper, +0.393 %%/K) or a number in the unit it is shown in "
                        "(hpddo diagnose says where the recordings show a heating's effect, not its coefficient)")


def dynamics(p, what: str) -> None:
    """--dynamics: the dynamic family (inertia, viscous and Coulomb friction at the output shaft;
    tools/hpddo/schema.py), from recordings at 50 Hz and up (docs/dynamics.md)."""
    p.add_argument("--dynamics", action="store_true",
                   help=f"{what}: the dynamic family (inertia J, viscous friction B, Coulomb friction Tc at the "
                        "output shaft), identified from recordings at 50 Hz and up with steps of duty; the "
                        "inductance is the effect 'inductance' in --effects")


PRIOR_MODEL_FLAGS = ("--prior-model", "--prior-name")  # where --model and --name mean something else


def ripple(p, required: bool, need: str = " (with --reference ripple)", prior_flags: tuple | None = None,
           n_optional: str | None = None) -> None:
    """--ripples-per-rev N --gear-ratio G [--ke-vs-per-rad KE | --prior-model DIR [--prior-name NAME]]
    [--floor-a A]: the speed from the commutation ripple (docs/ripple.md); required by hpddo ripple,
    by --reference ripple elsewhere (need: when they apply, in the help). The back-EMF prior's Ke is
    the user's, or a trained model's M2 with its named effects is the prior (prior_model_of), else Ke
    is calibrated from the ripple. prior_flags: the model option's and its name's spellings, first
    the command's own (hpddo ripple has no model of its own, so --model and --name there; train and
    evaluate use --name, evaluate --model, for the model they write or score; hpddo compare's ripple
    peers too), then aliases; None: no prior model. n_optional: where --ripples-per-rev may be left
    out (hpddo ripple --calibrate finds it), said in its help; the command checks it."""
    need = "" if required else need
    p.add_argument("--ripples-per-rev", type=positive_int, required=required and not n_optional, default=None,
                   metavar="N",
                   help=f"commutation ripples per motor revolution (2 x segments for two brushes; this bench's "
                        f"motor: {bench_hw.HARDWARE.ripples_per_rev}, tools/hpddo/bench.py){need}"
                        + (f"; {n_optional}" if n_optional else ""))
    p.add_argument("--gear-ratio", type=positive_float, required=required, default=None, metavar="G",
                   help="motor revolutions per output revolution (the nameplate's; checked where there is an "
                        f"encoder){need}")
    prior = p.add_mutually_exclusive_group() if prior_flags else p
    prior.add_argument("--ke-vs-per-rad", type=positive_float, default=None, metavar="KE",
                       help="Ke of the ripple's back-EMF prior, V s/rad at the output shaft (default: calibrated from "
                            "the ripple)")
    if prior_flags:
        _prior_model(p, prior, need, prior_flags)
    p.add_argument("--floor-a", type=positive_float, default=None, metavar="A",
                   help="no ripple speed under this mean current (default 0.10 A)")


def _prior_model(p, group, need: str, prior_flags: tuple) -> None:
    """The prior model's options (ripple()): DIR in group (exclusive with --ke-vs-per-rad), NAME."""
    model_flag, name_flag = prior_flags[0], prior_flags[1]
    aliases = prior_flags[2:]
    group.add_argument(model_flag, *aliases[0::2], dest="prior_model", type=pathlib.Path, default=None,
                       metavar="DIR",
                       help="a model folder written by hpddo train: its identified M2, with the named effects it "
                            "was trained with, Ra and Ke its own, is the ripple's back-EMF prior (not with "
                            f"--ke-vs-per-rad; the prior's Ra is the model's, not --ra-ohm){need}")
    p.add_argument(name_flag, *aliases[1::2], dest="prior_name", default=None, metavar="NAME",
                   help=f"with {model_flag}: the model name, when DIR holds more than one model_<name>.h")
    p.set_defaults(prior_flags=(model_flag, name_flag))


def prior_model_of(args):
    """The prior model a command line gives (ripple's --model / the others' --prior-model, with its
    name): None, else a hpddo.ripple.prior.ModelPrior, read before any log is: an InputError in one
    line naming the folder or header that is not a model of hpddo train, or the name given without
    the folder."""
    from ..evaluation.evaluate import model_physics
    from ..logs.errors import InputError
    from ..ripple.prior import ModelPrior
    model_flag, name_flag = args.prior_flags
    if args.prior_model is None:
        if args.prior_name is not None:
            raise InputError(f"{name_flag} applies to {model_flag} only")
        return None
    return ModelPrior(model_physics(args.prior_model, args.prior_name), str(args.prior_model))


def reference(p) -> None:
    """--reference {encoder,ripple} and the ripple's options: the speed the models are fitted to
    and scored against (hpddo.ripple.reference)."""
    from ..ripple.reference import REFERENCES
    p.add_argument("--reference", choices=list(REFERENCES), default=REFERENCES[0],
                   help="the measured speed: encoder (the logs' rpm_ref, the default) or ripple (counted from the "
                        "current bursts beside each log, <condition>.ripple.csv; rows without a confident ripple "
                        "speed left out and counted; docs/ripple-training.md)")
    ripple(p, required=False, prior_flags=PRIOR_MODEL_FLAGS)


def reference_of(args):
    """The reference a command line gives: None for the encoder, else a
    hpddo.ripple.reference.Ripple; an InputError where the ripple's options do not fit."""
    from ..logs.errors import InputError
    from ..ripple.reference import Ripple
    given = [f for f, v in (("--ripples-per-rev", args.ripples_per_rev), ("--gear-ratio", args.gear_ratio),
                            ("--ke-vs-per-rad", args.ke_vs_per_rad), ("--floor-a", args.floor_a),
                            (args.prior_flags[0], args.prior_model), (args.prior_flags[1], args.prior_name))
             if v is not None]
    if args.reference != "ripple":
        if given:
            raise InputError(f"{', '.join(given)} appl{'ies' if len(given) == 1 else 'y'} to --reference ripple only "
                             "(the reference is the encoder)")
        return None
    if args.ripples_per_rev is None or args.gear_ratio is None:
        raise InputError("--reference ripple needs --ripples-per-rev N and --gear-ratio G (docs/ripple-training.md)")
    model = prior_model_of(args)
    # with a prior model the prior's Ra is the model's; --ra-ohm (train, diagnose) stays the Ra of
    # the model they identify
    return Ripple(args.ripples_per_rev, args.gear_ratio, args.ke_vs_per_rad, args.floor_a,
                  None if model is not None else getattr(args, "ra_ohm", None), model)


def reference_words(args) -> list:
    """The reference's options as a command line repeats them (a next step, a provenance):
    [] for the encoder."""
    if args.reference != "ripple":
        return []
    return ["--reference", "ripple", *ripple_words(args)]


def ripple_words(args) -> list:
    """The ripple's options (ripple()) as a command line repeats them, each one given."""
    words = []
    for flag, v in (("--ripples-per-rev", args.ripples_per_rev), ("--gear-ratio", args.gear_ratio),
                    ("--ke-vs-per-rad", args.ke_vs_per_rad), ("--floor-a", args.floor_a)):
        if v is not None:
            words += [flag, repr(v)]
    for flag, v in zip(args.prior_flags, (args.prior_model, args.prior_name)):
        if v is not None:
            words += [flag, str(v)]
    return words


class _Logs(argparse.Action):
    """Bench logs, less the sidecars given beside their own logs (as `hpddo train out/*.csv`
    gives them after `hpddo twin --out out`): the twin's ground truth and the ripple bursts
    (docs/bench-log.md, Ripple bursts), each left out with a note on stderr."""

    def __call__(self, parser, namespace, values, option_string=None):
        import sys
        from ..logs.ripple import SUFFIX as RIPPLE_CSV
        from ..twin.generate import TRUTH_CSV

        names = {str(v) for v in values}
        what = {TRUTH_CSV: "the twin's ground truth", RIPPLE_CSV: "the current bursts"}
        sidecar = []
        for v in values:
            for suffix, text in what.items():
                if v.name.endswith(suffix) and str(v.with_name(v.name[:-len(suffix)] + ".csv")) in names:
                    sidecar.append(v)
                    print(f"{parser.prog}: note: left out {v}: {text} beside its log, not a bench log",
                          file=sys.stderr)
        setattr(namespace, self.dest, [v for v in values if v not in sidecar])


def logs(p, name: str = "logs", help: str = "labelled bench logs (CSV, docs/bench-log.md)", **kw) -> None:
    """LOG... (or --NAME LOG...): bench logs; the twin's truth sidecars beside them left out."""
    p.add_argument(name, nargs="+", type=pathlib.Path, metavar="LOG", action=_Logs, help=help, **kw)


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number expected, got {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """An argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number expected, got {text!r}") from None
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be >= 0 and finite, got {text}")
    return value


def _int_at_least(text: str, low: int, fault: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"an integer expected, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"{text} {fault}")
    return value


def hidden_sizes(text: str) -> tuple:
    """--hidden N[,N]: one or two hidden layers of 1..255 neurons (the core's Mlp)."""
    try:
        sizes = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"hidden sizes like 16,8 expected, got {text!r}") from None
    if not 1 <= len(sizes) <= 2 or min(sizes) < 1 or max(sizes) > 255:
        raise argparse.ArgumentTypeError("one or two hidden layers of 1..255 neurons (the core's Mlp)")
    return sizes


def positive_int(text: str) -> int:
    """An argparse type: an integer of at least 1."""
    return _int_at_least(text, 1, "is not a positive integer")


def non_negative_int(text: str) -> int:
    """An argparse type: an integer of at least 0."""
    return _int_at_least(text, 0, "is negative")
