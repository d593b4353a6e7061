"""The validation table: memory against estimation, on the bundled recordings.

    python -m hpddo.studies.validation --out DIR        (about 4 minutes on 2 cores)

Trains four models on data/default (sweep, load, long; chronological 80 %): the physics
as identified and with the effects the diagnosis names, each with and without the
novelty gate, replays each natively on its held-out 20 % and on every row of
data/validation (unseen duty/load pairs, a hot motor), and prints the markdown table of
docs/validation.md: lookup, M2, M3 without the gate, M3 with it.
"""
from __future__ import annotations

import argparse
import json
import pathlib

from .. import resource_root

#: The effects the diagnosis names on data/default (docs/diagnosis.md; hpddo demo, step 2).
NAMED_EFFECTS = ("thermal_ra", "magnet_thermal")
TRAINING = ("load", "long", "sweep")
VALIDATION = ("hot", "unseen")


def run(out: pathlib.Path, progress: bool = False) -> dict:
    """Trains and scores the four models into out/<variant>/; returns {variant: {"chrono":
    rmse_rpm of the held-out 20 %, "validation": rmse_rpm of every row of data/validation}}."""
    from ..evaluation.evaluate import evaluate
    from ..pipeline import PipelineConfig, run as run_pipeline
    from ..model.train import TrainConfig

    root = resource_root() / "data"
    logs = [root / "default" / f"{n}.csv" for n in TRAINING]
    valid = [root / "validation" / f"{n}.csv" for n in VALIDATION]
    results = {}
    for effects in ((), NAMED_EFFECTS):
        for gate in (False, True):
            name = ("effects" if effects else "plain") + ("_gate" if gate else "_nogate")
            res = run_pipeline(logs, out / name / "model",
                               PipelineConfig(effects=effects, train=TrainConfig(gate=gate, progress=progress)))
            ev = evaluate(res.out, valid, out / name / "validation")
            results[name] = {"chrono": res.metrics["rmse_rpm"], "validation": ev.metrics["rmse_rpm"]}
            print(f"{name}: chronological M3 {res.metrics['rmse_rpm']['M3']['average']}, validation M3 "
                  f"{ev.metrics['rmse_rpm']['M3']['average']}", flush=True)
    (out / "validation_table.json").write_text(json.dumps(results, indent=2) + "\n")
    return results


def table(results: dict) -> str:
    """The markdown table: one row per physics model and recording."""
    lines = ["| physics model | recording | lookup | M2 | M3, no gate | M3 with the gate |",
             "|---|---|---|---|---|---|"]
    for phys, label in (("plain", "M2 as identified"), ("effects", "M2 + " + ", ".join(NAMED_EFFECTS))):
        ng, g = results[f"{phys}_nogate"], results[f"{phys}_gate"]
        rows = [("chronological 20 % (average)", "chrono", "average")]
        rows += [(f"{c} (never seen, every row)", "validation", c) for c in VALIDATION]
        for text, part, cond in rows:
            f = lambda r, m: f"{r[part][m][cond]:.2f}"
            lines.append(f"| {label} | {text} | {f(g, 'lookup')} | {f(g, 'M2')} | {f(ng, 'M3')} | {f(g, 'M3')} |")
    return "\n".join(lines) + "\n"


#: The RMSE table of README.md and of hpddo demo: (row label, variant, model); the label's
#: {effects} and {hidden} filled in by rmse_table.
RMSE_ROWS = (("lookup (memory alone)", "plain_gate", "lookup"), ("M1 nameplate", "plain_gate", "M1"),
             ("M2 physics", "plain_gate", "M2"), ("M3 hybrid {hidden}, gated", "plain_gate", "M3"),
             ("M2 + {effects} (named by the diagnosis)", "effects_gate", "M2"),
             ("M3 on top of it, gated", "effects_gate", "M3"),
             ("the same M3 without the novelty gate", "effects_nogate", "M3"))
RMSE_COLUMNS = (("sweep", "chrono", "sweep"), ("load", "chrono", "load"), ("long", "chrono", "long"),
                ("average (chronological)", "chrono", "average"),
                ("unseen pairs (never seen)", "validation", "unseen"), ("hot motor (never seen)", "validation", "hot"))


def rmse_table(results: dict, hidden, effects=NAMED_EFFECTS) -> str:
    """The markdown RMSE table of README.md, which hpddo demo prints too: a row per model of
    RMSE_ROWS whose variant results holds ({variant: {"chrono": rmse_rpm, "validation":
    rmse_rpm or None}}, validation_table.json's shape), a column per condition of
    RMSE_COLUMNS ("-" where the results have none); hidden: M3's hidden layers."""
    lines = ["| | " + " | ".join(c for c, _, _ in RMSE_COLUMNS) + " |", "|---" * (len(RMSE_COLUMNS) + 1) + "|"]
    for label, variant, model in RMSE_ROWS:
        if variant not in results:
            continue
        cells = []
        for _, part, cond in RMSE_COLUMNS:
            v = ((results[variant].get(part) or {}).get(model) or {}).get(cond)
            cells.append("-" if v is None else f"{v:.2f}")
        text = label.format(effects=", ".join(effects), hidden=f"({', '.join(map(str, hidden))})")
        lines.append(f"| {text} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hpddo.studies.validation", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, help="a new folder for the models and scores")
    ap.add_argument("--table", type=pathlib.Path, metavar="JSON",
                    help="print the table of a previous run's validation_table.json instead")
    args = ap.parse_args(argv)
    if args.table:
        print(table(json.loads(args.table.read_text())), end="")
        return 0
    if args.out is None:
        ap.error("--out (or --table) is required")
    print(table(run(args.out)), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
