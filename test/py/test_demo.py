"""hpddo demo's outputs name where they will be, never the staging folder they were written in
(issue 32 item 3), and its RMSE table is README.md's (issue 32 item 1)."""
import argparse
import json
import pathlib
import shutil
import types

import pytest

from conftest import ROOT
from hpddo.cli import demo
from hpddo.studies import validation

VALIDATION = demo.bench_logs(ROOT / "data" / "validation")


def _text_files(folder: pathlib.Path):
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix in (".json", ".html", ".csv", ".txt", ".h", ".md"):
            yield p


def test_validation_metrics_name_the_final_model_folder_not_the_stage(tmp_path):
    """score_validation runs inside the demo's staging folder (outdir.staged: a temporary
    .OUT.demo.* beside OUT, removed at the end): metrics.json must name OUT/plain/model."""
    out = tmp_path / "out"
    stage = tmp_path / ".out.demo.staging"
    model = stage / "plain" / "model"
    shutil.copytree(ROOT / "models" / "default", model)
    args = argparse.Namespace(no_glitch_filter=False)
    metrics = demo.score_validation(types.SimpleNamespace(out=model), VALIDATION, stage / "plain", out / "plain",
                                    "M1, M2, M3", args)
    written = json.loads((stage / "plain" / "validation" / "metrics.json").read_text())
    assert written["model"]["folder"] == str(out / "plain" / "model") == metrics["model"]["folder"]
    for p in _text_files(stage / "plain" / "validation"):
        assert stage.name not in p.read_text(errors="replace"), p


def test_the_demo_prints_and_writes_readme_table_with_the_ungated_row():
    """summary.json -> README.md's table (hpddo.studies.validation.rmse_table), every row,
    the ungated M3 among them; the validation figures' shape, so the two compare."""
    table = json.loads((ROOT / "docs" / "figures" / "validation_table.json").read_text())
    summary = {"missing_effects": list(validation.NAMED_EFFECTS),
               "before": table["plain_gate"]["chrono"], "validation_before": table["plain_gate"]["validation"],
               "after": table["effects_gate"]["chrono"], "validation_after": table["effects_gate"]["validation"],
               "after_nogate": table["effects_nogate"]["chrono"],
               "validation_after_nogate": table["effects_nogate"]["validation"]}
    text = demo.rmse_table(summary, [16, 8])
    assert text == validation.rmse_table(table, [16, 8])
    assert "| the same M3 without the novelty gate | 1.70 | 0.96 | 0.32 | 0.99 | 7.90 | 1.74 |" in text


@pytest.mark.slow
def test_the_whole_demo_writes_the_committed_figures_and_no_staging_path(tmp_path, capsys):
    """The demo on the bundled recordings (about 3 minutes on 2 cores): its summary.json gives
    README.md's table as docs/figures/validation_table.json does (python -m
    hpddo.studies.validation trains the same models), it prints that table, and no file it
    wrote names its staging folder."""
    out = tmp_path / "out"
    assert demo.main(["--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    committed = validation.rmse_table(json.loads((ROOT / "docs" / "figures" / "validation_table.json").read_text()),
                                      [16, 8])
    assert demo.rmse_table(summary, [16, 8]) == committed
    assert "   " + committed.replace("\n", "\n   ").rstrip() in printed
    for p in _text_files(out):
        assert f".{out.name}.demo." not in p.read_text(errors="replace"), p
