"""hpddo demo's outputs name where they will be, never the staging folder they were written in
(issue 32 item 3)."""
import argparse
import json
import pathlib
import shutil
import types

from conftest import ROOT
from hpddo.cli import demo

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
