"""Identifies the physics models, trains the residual network and exports the model header.

    hpddo train LOG... --out DIR [options]        (tools/gen_weights.py is the same command)

From labelled bench logs (t_s, duty, v_V, i_A, rpm_ref, ...): removes sensor glitches
(reports them per file), splits each recording chronologically (first 80 % train, last
20 % test), identifies M1 (nameplate Ke) and M2 (measured Ra, Ke by the paper's eq. 20 or
least squares, plus any --effects), trains M3 on the residual e = rpm_ref - n_M2 with
features [V, I, n_M2, I(t-1), n_M2(t-1)] (with --dynamics, n_M2 through the dynamic
family identified from recordings at 50 Hz and up: docs/dynamics.md), and
writes into DIR:

  model_<name>.h      the model header for lib/hpddo_core (provenance, checksum)
  golden_<name>.h/.csv  golden vectors: inputs and every stage's float32 output
  model_<name>_q.h    the same model with the fixed-point network (hpddo::MlpQ, quant.py)
  golden_<name>_q.h/.csv  its golden vectors, from the integer reference (quant.py)
  model_<name>_q8.h   the same with int8 weights (hpddo::MlpQ, quant.py), rounded for the
                      training rows; golden_<name>_q8.h/.csv its golden vectors
  metrics.json        RMSE of M1, M2, M3 per condition on the test parts, measured by
                      the native replay of the cleaned logs through the board observer
  work/               the cleaned logs, the replay built for this model (by CMake, from
                      host/) and its per-sample estimates (work/estimates/*.estimates.csv)

A malformed log is refused with its file, line and fault, and nothing is written.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from . import options


#: The command recorded in the provenance of every generated header. It names the
#: documented entry point whichever way the run was started (`hpddo train` is the same
#: command), so that both regenerate models/default to the same bytes.
PROVENANCE_COMMAND = "tools/gen_weights.py"


def split_fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a fraction expected, got {text!r}") from None
    if not 0.1 <= value <= 0.95:
        raise argparse.ArgumentTypeError(f"must be within 0.1..0.95, got {text}")
    return value


def parser(prog: str = "hpddo train") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    options.logs(p)
    options.out(p, "output folder: new, empty, or a previous output of hpddo train")
    p.add_argument("--name", default="default", help="model name: model_<name>.h, namespace hpddo_model_<name> "
                   "(default: default)")
    options.ra_ohm(p)
    options.nameplate(p)  # None: not given, the default nameplate (pipeline.DEFAULT_RATED_V/RPM), which the run says
    options.ke_fit(p)
    options.effects(p, "effect terms to add to the physics model M2")
    options.hold(p)
    options.dynamics(p, "add to the model")
    p.add_argument("--hidden", type=options.hidden_sizes, default=(16, 8), metavar="N[,N]",
                   help="hidden layer sizes of M3 (default 16,8; the paper's is 128,64)")
    options.epochs(p, 2000, "M3")
    options.seed(p, "the network")
    p.add_argument("--no-gate", action="store_true",
                   help="no novelty gate: the whole learned correction wherever the features lie inside the "
                        "training envelope (the paper's M3; docs/gate.md)")
    p.add_argument("--split", type=split_fraction, default=0.8, metavar="FRACTION",
                   help="training fraction of each recording, 0.1..0.95 (default 0.8)")
    options.glitch_filter(p)
    options.leave_one_out(p)
    options.reference(p)
    options.quiet(p)
    return p


def _shown_path(path) -> str:
    """A log's path as the provenance shows it: relative to the repository root when the
    log lies in it (so the committed headers read the same on every machine), else as given."""
    from .. import resource_root
    try:
        return str(pathlib.Path(path).resolve().relative_to(resource_root().resolve()))
    except ValueError:
        return str(path)


def hold_word(hold: dict) -> str:
    """--hold's value for {effect: coefficient}: a material's name where the coefficient is its material's,
    else the number in the effect's unit (what parse_holds reads back)."""
    from ..model import effects as fx
    words = []
    for name, x in hold.items():
        eff = fx.LIBRARY[name]
        words.append(f"{name}={eff.material_name if eff.material is not None and x == eff.material else repr(x * eff.show_scale)}")
    return ",".join(words)


def provenance(args) -> str:
    """The command that regenerates the header, from the repository root, with every
    option that changes the result (--out is the folder the header sits in)."""
    defaults = parser().parse_args(["x", "--out", "x"])
    words = [PROVENANCE_COMMAND] + [_shown_path(p) for p in args.logs] + ["--name", args.name]
    for flag, key, show in (("--ra-ohm", "ra_ohm", str), ("--rated-v", "rated_v", str),
                            ("--rated-rpm", "rated_rpm", str), ("--ke-fit", "ke_fit", str),
                            ("--effects", "effects", ",".join),
                            ("--hold", "hold", hold_word),
                            ("--hidden", "hidden", lambda h: ",".join(map(str, h))),
                            ("--epochs", "epochs", str), ("--split", "split", str)):
        if getattr(args, key) != getattr(defaults, key):
            words += [flag, show(getattr(args, key))]
    words += options.reference_words(args)
    words += ["--seed", str(args.seed)]
    if args.no_glitch_filter:
        words.append("--no-glitch-filter")
    if args.dynamics:
        words.append("--dynamics")
    if args.no_gate:
        words.append("--no-gate")
    if args.leave_one_out:
        words.append("--leave-one-out")
    return " ".join(words) + " --out <the folder of this file>"


def run(args) -> int:
    from ..model import physics
    from ..pipeline import DEFAULT_RATED_RPM, DEFAULT_RATED_V, PipelineConfig, run as run_pipeline
    from ..model.train import TrainConfig

    from ..ripple import reference

    ref = options.reference_of(args)
    given = (args.rated_v is not None) + (args.rated_rpm is not None)
    cfg = PipelineConfig(name=args.name, ra_ohm=args.ra_ohm,
                         rated_V=DEFAULT_RATED_V if args.rated_v is None else args.rated_v,
                         rated_rpm=DEFAULT_RATED_RPM if args.rated_rpm is None else args.rated_rpm,
                         nameplate_source=("default", "partly given", "given")[given],
                         ke_fit=args.ke_fit, effects=args.effects, hold=args.hold, dynamics=args.dynamics, train_fraction=args.split,
                         glitch_filter=not args.no_glitch_filter, leave_one_out=args.leave_one_out,
                         train=TrainConfig(hidden=args.hidden, max_iter=args.epochs, seed=args.seed,
                                           gate=not args.no_gate, progress=not args.quiet),
                         command=provenance(args), report=True, reference=ref)
    t0 = time.perf_counter()
    res = run_pipeline(args.logs, args.out, cfg)
    for r in res.recordings:
        print(f"{r.source}: {r.n} rows ({r.n_train} train, {r.n - r.n_train} test), "
              f"{len(r.removed)} of {r.rows_in_file} rows removed as glitches")
        if r.reference is not None:
            print(reference.line(r.name, r.reference))
    if ref is not None:
        print(f"note: {reference.WEIGHTS_NOTE}")
    for w in res.metrics["warnings"]:
        print(f"hpddo train: WARNING: {w}", file=sys.stderr)
    ident = res.metrics["identification"]
    print(f"Ra = {ident['ra_ohm']:.4g} ohm ({ident['ra_source']}); M1 Ke = {ident['ke_m1_vs_per_rad']:.5g} V s/rad "
          f"(nameplate); M2 Ke = {ident['ke_m2_vs_per_rad']:.5g} V s/rad ({args.ke_fit})")
    for e, val in ident["effects"].items():
        print(f"  effect {e}: {physics.EFFECT_BITS[e][1]} = {val:.5g}")
    if "dynamics" in ident:
        d = ident["dynamics"]
        print("  dynamics: " + "; ".join(q["text"] for q in d["quantities"] if q["field"] != "la_H")
              + f"; observer tau {1e3 * d['tau_obs_s']:.0f} ms")
    if "residual" in ident:  # too few rows for the network: physics only
        print(f"note: M3 {args.hidden} {ident['residual']}")
    else:
        print(f"M3 {args.hidden}: clamp +-{ident['clamp_rpm']:.2f} RPM, {ident['train_rows']} training rows")
    if "note" in ident["nameplate"]:
        print(f"note: {ident['nameplate']['note']}")
        fastest = max((float(r.df["rpm_ref"].max()) for r in res.recordings if "rpm_ref" in r.df), default=None)
        if fastest and fastest > 0 and not 0.5 <= cfg.rated_rpm / fastest <= 2.0:
            print(f"hpddo train: WARNING: M1's nameplate says {cfg.rated_rpm:g} RPM at {cfg.rated_V:g} V, and the "
                  f"fastest speed in these recordings is {fastest:.0f} RPM: M1's figures compare with a motor that is "
                  "not yours; read the rated voltage and the output shaft's no-load speed on its label or datasheet "
                  "and pass --rated-v and --rated-rpm", file=sys.stderr)
    print(res.table, end="")
    if "leave_one_out" in res.metrics:
        from ..pipeline import leave_one_out_table
        print(leave_one_out_table(res.metrics["leave_one_out"]), end="")
    if not args.quiet:
        print(f"wrote {args.out}/ in {time.perf_counter() - t0:.1f} s; report: {args.out / 'report' / 'index.html'}")
    return 0


def main(argv=None) -> int:
    """`hpddo train ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("train", argv)
