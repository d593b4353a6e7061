"""The main job on the bundled recordings (data/default), no hardware needed:

  1. identify M1 and M2, train M3, export the model header, replay the recordings natively
     through the board observer, print the RMSE table, write an HTML report;
  2. diagnose which physical effects the physics model misses (hpddo diagnose);
  3. add the named effects (hpddo train --effects), retrain M3 on top, replay natively, and
     show the error fall, for the physics model and for the hybrid; and the same hybrid
     without its novelty gate;
  4. validate both models on recordings no training protocol covers (hpddo evaluate on
     data/validation: duty/load pairs absent from training, a hot motor), beside the lookup
     baseline (mean training speed of the nearest training operating point), so that
     memory and estimation show side by side; and the RMSE table of README.md
     (hpddo.studies.validation.rmse_table), written into OUT/summary.json.

    hpddo demo [--out out] [--data data/default] [--validation data/validation]
                                                      (tools/demo.py is the same command)
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from .. import resource_root
from ..logs import benchlog
from . import options


def parser(prog: str = "hpddo demo") -> argparse.ArgumentParser:
    p = options.new_parser(prog, __doc__)
    options.out(p, "output folder: new, empty, or a previous output of hpddo demo (default: out, in the "
                   "current folder)", required=False, default=pathlib.Path("out"))
    p.add_argument("--data", type=pathlib.Path, default=resource_root() / "data" / "default", metavar="DIR",
                   help="folder of labelled bench logs, *.csv (default: the bundled data/default)")
    p.add_argument("--validation", type=pathlib.Path, default=resource_root() / "data" / "validation",
                   metavar="DIR", help="folder of labelled bench logs the models are not trained on, scored whole "
                                       f"(default: the bundled {resource_root() / 'data' / 'validation'}; an empty or "
                                       "missing folder: none, and the demo says so)")
    options.ra_ohm(p)
    options.glitch_filter(p)
    options.seed(p, "the networks and the bootstrap")
    options.quiet(p)
    return p


def pipeline(logs, out: pathlib.Path, shown: pathlib.Path, effects, args, title: str, physics=None,
             gate: bool = True):
    """Runs the train pipeline into out/model and writes the report into out/report;
    `shown` is where out will be once the demo's output is in place; physics: M2 with the
    effects as the diagnosis fitted it (not identified again); gate: False for an open
    novelty gate (the same network, its whole correction everywhere inside the envelope)."""
    from ..reports import training as report
    from ..pipeline import PipelineConfig, run as run_pipeline
    from ..model.train import TrainConfig

    res = run_pipeline(logs, out / "model", PipelineConfig(effects=tuple(effects), physics=physics, ra_ohm=args.ra_ohm,
                                                           glitch_filter=not args.no_glitch_filter,
                                                           train=TrainConfig(seed=args.seed, gate=gate,
                                                                             progress=not args.quiet)))
    report.write(res.metrics, out / "model" / "work" / "estimates", out / "report", title,
                 [f"Model header: {shown / 'model' / 'model_default.h'}. Effects in the physics model: "
                  f"{', '.join(effects) or 'none'}. RMSE measured by the native replay of the cleaned "
                  "recordings through the board observer (hpddo_core)."])
    for w in res.metrics["warnings"]:
        print(f"   WARNING: {w}", file=sys.stderr)
    return res, shown / "report" / "index.html"


def bench_logs(folder: pathlib.Path) -> list:
    """The bench logs of a folder (*.csv without the twin's *.truth.csv sidecars), sorted."""
    return sorted(p for p in folder.glob("*.csv") if not p.name.endswith(".truth.csv"))


def run(args) -> int:
    from ..logs import outdir
    from ..logs.errors import InputError

    logs = bench_logs(args.data)
    if not logs:
        raise InputError(f"no bench logs (*.csv) in {args.data}")
    validation = bench_logs(args.validation) if args.validation.is_dir() else []
    t0 = time.perf_counter()
    outdir.check(args.out, "demo")
    with outdir.staged(args.out, "demo") as stage:
        demo(logs, validation, stage, args)
    print(f"done in {time.perf_counter() - t0:.1f} s; everything is in {args.out}")
    return 0


def score_validation(res, validation, out: pathlib.Path, shown: pathlib.Path, label: str, args):
    """Scores the model of a pipeline result on the validation recordings (hpddo evaluate)
    into out/validation (metrics.json, report/, work/); the metrics, or None without
    validation recordings. metrics.json names the model by the folder it will be in once the
    demo's output is in place (shown / "model"), not by the staging folder it was scored in."""
    from ..evaluation.evaluate import evaluate
    from ..reports.training import write_evaluation as write

    if not validation:
        return None
    ev = evaluate(res.out, validation, out / "validation" / "work", glitch_filter=not args.no_glitch_filter)
    ev.metrics["model"]["folder"] = str(shown / "model")
    write(ev, out / "validation", f"hpddo: {label} on recordings it never saw",
          ["Every row of recordings no training protocol covers, replayed natively through the board "
           "observer; lookup: the mean training speed of the nearest training operating point."])
    print("   " + ev.table.replace("\n", "\n   ").rstrip())
    print(f"   report: {shown / 'validation' / 'report' / 'index.html'}")
    return ev.metrics


def side_by_side(chrono: dict, valid: dict | None) -> dict:
    """{figure: {model: RMSE}}: the chronological average and each validation recording."""
    table = {"chronological (average)": {m: v["average"] for m, v in chrono["rmse_rpm"].items() if m != "M1"}}
    if valid:
        for c in valid["recordings"]:
            table[f"{c} (never seen)"] = {m: v[c] for m, v in valid["rmse_rpm"].items() if m != "M1"}
    return table


def print_side_by_side(title: str, table: dict) -> None:
    models = ["M2", "M3", "lookup"]
    print(f"   {title}")
    print("   " + f"{'':28s}" + "".join(f"{m:>10s}" for m in models))
    for fig, row in table.items():
        print("   " + f"{fig:28s}" + "".join(f"{row[m]:10.2f}" if row.get(m) is not None else f"{'-':>10s}"
                                           for m in models))


#: summary.json's keys of each variant of the RMSE table (hpddo.studies.validation's names):
#: {variant: (held-out 20 %, every row of the validation recordings)}.
SUMMARY_KEYS = {"plain_gate": ("before", "validation_before"), "effects_gate": ("after", "validation_after"),
                "effects_nogate": ("after_nogate", "validation_after_nogate")}


def rmse_table(summary: dict, hidden) -> str:
    """README.md's RMSE table of a summary.json (hpddo.studies.validation.rmse_table)."""
    from ..studies.validation import rmse_table as table
    variants = {v: {"chrono": summary[c], "validation": summary[n]} for v, (c, n) in SUMMARY_KEYS.items()
                if c in summary}
    return table(variants, hidden, summary["missing_effects"])


def write_summary(stage: pathlib.Path, summary: dict, hidden, shown: pathlib.Path) -> None:
    """Prints README.md's RMSE table of the summary and writes summary.json."""
    print("   the RMSE table of README.md (RPM; average: of the chronological held-out 20 %):")
    print("   " + rmse_table(summary, hidden).replace("\n", "\n   ").rstrip())
    (stage / "summary.json").write_text(benchlog.json_text(summary, indent=2))
    print(f"   summary in {shown}")


def demo(logs, validation, stage: pathlib.Path, args) -> None:
    """The steps, written into stage (which becomes args.out when all succeed)."""
    from ..diagnosis import core
    from . import diagnose

    print(f"== 1. M1, M2, M3 (16, 8): identify, train, export, replay natively: {', '.join(p.name for p in logs)}")
    base, page = pipeline(logs, stage / "plain", args.out / "plain", [], args,
                          "hpddo: M1, M2 and M3 on the bundled recordings")
    ident = base.metrics["identification"]
    for r in base.recordings:
        print(f"   {r.source.name}: {r.n} rows, {len(r.removed)} of {r.rows_in_file} removed as glitches")
    if ident.get("nameplate", {}).get("note"):
        print(f"   note: {ident['nameplate']['note']}")
    print(f"   Ra = {ident['ra_ohm']:.3f} ohm, Ke M1 = {ident['ke_m1_vs_per_rad']:.4f} (nameplate), "
          f"Ke M2 = {ident['ke_m2_vs_per_rad']:.4f} V s/rad, clamp +-{ident['clamp_rpm']:.1f} RPM")
    print(base.table, end="")
    print(f"   report: {page}")
    if validation:
        print(f"   validation on recordings it never saw: {', '.join(p.name for p in validation)}")
    base_valid = score_validation(base, validation, stage / "plain", args.out / "plain", "M1, M2, M3", args)

    print("== 2. diagnosis: where does the physics model fail, which effect is missing?")
    t1 = time.perf_counter()
    d = diagnose.diagnose_into(logs, core.Options(ra_ohm=args.ra_ohm, seed=args.seed,
                                                  glitch_filter=not args.no_glitch_filter), stage / "diagnosis")
    print(diagnose.summary(d))
    note = diagnose.hybrid_note(d)
    if note:
        print(note)
    print(f"   diagnosis took {time.perf_counter() - t1:.1f} s; report: {args.out / 'diagnosis' / 'index.html'}")
    missing = list(d.missing_effects)
    hidden = base.metrics["identification"]["hidden"]
    summary = {"missing_effects": missing, "before": base.metrics["rmse_rpm"],
               "validation_before": base_valid["rmse_rpm"] if base_valid else None}
    if not missing:
        print("== 3. nothing missing: the physics model stays as it is")
        print_side_by_side("memory against estimation (RMSE, RPM):", side_by_side(base.metrics, base_valid))
        write_summary(stage, summary, hidden, args.out / "summary.json")
        return

    print(f"== 3. add {', '.join(missing)} to the physics model, retrain M3 on top, replay natively")
    after, page = pipeline(logs, stage / "with_effects", args.out / "with_effects", missing, args,
                           f"hpddo: M1, M2 + {', '.join(missing)} and M3 on the bundled recordings",
                           physics=d.after_model)
    for e, val in after.metrics["identification"]["effects"].items():
        print(f"   {e}: {val:.5g}")
    print(after.table, end="")
    b, a = base.metrics["rmse_rpm"], after.metrics["rmse_rpm"]
    conds = [c for c in b["M2"] if c != "average"] + ["average"]
    print("   error before -> after adding the effects (RPM, native replay, held-out 20 %):")
    print("   " + f"{'':22s}" + "".join(f"{c:>16s}" for c in conds))
    for label, m in (("physics (M2)", "M2"), ("hybrid (M3)", "M3")):
        print("   " + f"{label:22s}" + "".join(f"{b[m][c]:7.2f} -> {a[m][c]:5.2f}" for c in conds))
    print(f"   report: {page}")
    after_valid = score_validation(after, validation, stage / "with_effects", args.out / "with_effects",
                           f"M2 + {', '.join(missing)} and M3", args)
    print("   the same M3 without its novelty gate (trained again with an open gate), replayed natively")
    nogate, page = pipeline(logs, stage / "with_effects_nogate", args.out / "with_effects_nogate", missing, args,
                            f"hpddo: M2 + {', '.join(missing)} and M3 without its novelty gate on the bundled "
                            "recordings", physics=d.after_model, gate=False)
    print(nogate.table, end="")
    print(f"   report: {page}")
    nogate_valid = score_validation(nogate, validation, stage / "with_effects_nogate",
                                    args.out / "with_effects_nogate",
                                    f"M2 + {', '.join(missing)} and M3 without its novelty gate", args)
    summary.update(after=a, validation_after=after_valid["rmse_rpm"] if after_valid else None,
                   after_nogate=nogate.metrics["rmse_rpm"],
                   validation_after_nogate=nogate_valid["rmse_rpm"] if nogate_valid else None,
                   effects=after.metrics["identification"]["effects"])
    print("== 4. memory against estimation: the chronological split (rows from the training runs) and "
          "recordings no training covers (RMSE, RPM)")
    if not validation:
        print(f"   no recordings the models never saw: {args.validation} holds no bench log, so only the "
              "chronological split is scored, and memory cannot be told from estimation; give --validation DIR "
              "(recordings at other duty/load pairs or temperatures)")
    print_side_by_side("physics as identified, M3 on top:", side_by_side(base.metrics, base_valid))
    print_side_by_side(f"with {', '.join(missing)}, M3 on top:", side_by_side(after.metrics, after_valid))
    write_summary(stage, summary, hidden, args.out / "summary.json")


def main(argv=None) -> int:
    """`hpddo demo ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("demo", argv)
