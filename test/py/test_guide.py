"""docs/your-motor.md, walked as typed: every `sh` block of the guide runs in a new folder
with the hpddo command on the PATH (the `board` blocks need hardware and are skipped), on
the bench twin; then the figures the guide quotes are checked against what the walk wrote,
and the diagnosis' printed next command against the one the guide gives."""
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys

import pytest

from conftest import ROOT

GUIDE = ROOT / "docs" / "your-motor.md"
pytestmark = pytest.mark.slow


def blocks(kind: str) -> list:
    """The command lines of the guide's ```kind blocks, in order."""
    text = GUIDE.read_text(encoding="utf-8")
    return [ln for b in re.findall(rf"^```{kind}\n(.*?)^```", text, re.M | re.S) for ln in b.splitlines()
            if ln.strip()]


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    bin_dir = pathlib.Path(sys.executable).parent
    if not (bin_dir / "hpddo").exists():
        pytest.skip(f"no hpddo command beside {sys.executable} (scripts/bootstrap.sh installs it)")
    cwd = tmp_path_factory.mktemp("guide")
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}")
    outputs = []
    for line in blocks("sh"):
        res = subprocess.run(["bash", "-c", line], cwd=cwd, env=env, capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, f"the guide's command failed: {line}\n{res.stdout}\n{res.stderr}"
        assert "Traceback" not in res.stderr, res.stderr
        outputs.append((line, res.stdout, res.stderr))
    return cwd, outputs


def test_the_guide_has_commands_for_each_step():
    sh, board = blocks("sh"), blocks("board")
    assert [shlex.split(c)[1] for c in sh] == ["twin", "train", "diagnose", "train", "twin", "evaluate", "evaluate"]
    assert any("capture" in c for c in board) and any("esp8266" in c for c in board)


def test_the_diagnosis_prints_the_command_the_guide_gives(walked):
    cwd, outputs = walked
    out = next(o for line, o, _ in outputs if shlex.split(line)[1] == "diagnose")
    printed = shlex.split(out.splitlines()[next(i for i, ln in enumerate(out.splitlines()) if ln.startswith("next ("))
                                        + 1])
    given = shlex.split(blocks("sh")[3])
    opt = lambda words, flag: words[words.index(flag) + 1] if flag in words else None
    for flag in ("--effects", "--ra-ohm"):
        assert opt(printed, flag) == opt(given, flag), (flag, printed, given)
    named = json.loads((cwd / "my_diagnosis" / "diagnosis.json").read_text())["missing_effects"]
    assert opt(given, "--effects").split(",") == named


def _avg(path: pathlib.Path, model: str) -> float:
    return json.loads(path.read_text())["rmse_rpm"][model]["average"]


def test_the_figures_the_guide_quotes_are_what_the_walk_measures(walked):
    cwd, _ = walked
    text = " ".join(GUIDE.read_text(encoding="utf-8").split())
    train = cwd / "my_model" / "metrics.json"
    assert f"M2 {_avg(train, 'M2'):.2f} RPM, M3 {_avg(train, 'M3'):.2f}, lookup {_avg(train, 'lookup'):.2f}" in text
    for folder, label in (("my_eval", "`my_model` (plain physics)"),
                          ("my_eval_fx", "`my_model_fx` (with the three named effects)")):
        m = cwd / folder / "metrics.json"
        row = f"| {label} | {_avg(m, 'M2'):.2f} | {_avg(m, 'M3'):.2f} | {_avg(m, 'lookup'):.2f} |"
        assert row in text, row
    d = json.loads((cwd / "my_diagnosis" / "diagnosis.json").read_text())["rmse_rpm"]
    assert f"held-out rows from {d['before']['average']:.2f} to {d['after']['average']:.2f} RPM" in text
    # the error falls where the models never were: the mission's loop, on data never seen
    assert _avg(cwd / "my_eval_fx" / "metrics.json", "M2") < 0.6 * _avg(cwd / "my_eval" / "metrics.json", "M2")
    for page in ("my_model/report/index.html", "my_diagnosis/index.html", "my_eval_fx/report/index.html"):
        assert (cwd / page).is_file(), page
