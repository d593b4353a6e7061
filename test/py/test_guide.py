"""docs/your-motor.md, walked as typed: every `sh` block of the guide runs in a new folder
laid out as a clone after the README's setup (its `.venv`), in a shell without the venv on
the PATH, so the guide's own `. .venv/bin/activate` is what makes `hpddo` a command (the
`board` blocks need hardware and are skipped), on the bench twin; then the figures the
guide quotes are checked against what the walk wrote, and the diagnosis' printed next
steps against the guide's printout of them."""
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


SETUP = re.compile(r"^(\.|source)\s")  # a line that changes the shell the later lines run in


def _clone_like(cwd: pathlib.Path) -> dict:
    """cwd with this venv as its .venv, and an environment whose PATH holds no venv (a new shell)."""
    if sys.prefix == sys.base_prefix or not (pathlib.Path(sys.prefix) / "bin" / "activate").is_file():
        pytest.skip(f"the tests do not run in a venv ({sys.prefix}; scripts/bootstrap.sh makes .venv)")
    (cwd / ".venv").symlink_to(sys.prefix, target_is_directory=True)
    bin_dir = str(pathlib.Path(sys.prefix) / "bin")
    path = [d for d in os.environ.get("PATH", "").split(os.pathsep) if d and os.path.realpath(d) != os.path.realpath(bin_dir)]
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = os.pathsep.join(path)
    return env


def _run(line: str, setup: list, cwd, env):
    script = "\n".join(["set -e", *setup, line])
    return subprocess.run(["bash", "-c", script], cwd=cwd, env=env, capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("guide")
    env = _clone_like(cwd)
    outputs, setup = [], []
    for line in blocks("sh"):
        res = _run(line, setup, cwd, env)
        assert res.returncode == 0, f"the guide's command failed: {line}\n{res.stdout}\n{res.stderr}"
        assert "Traceback" not in res.stderr, res.stderr
        if SETUP.match(line):
            setup.append(line)
        else:
            outputs.append((line, res.stdout, res.stderr))
    return cwd, outputs


def test_the_guide_activates_the_venv_before_its_first_command(tmp_path):
    """Issue 32: after the README's setup the guide's first `hpddo twin` gave `hpddo: command not found`."""
    sh = blocks("sh")
    assert sh[0] == ". .venv/bin/activate", sh[0]
    env = _clone_like(tmp_path)
    assert _run("command -v hpddo", [], tmp_path, env).returncode != 0  # a new shell: not a command yet
    res = _run("command -v hpddo", [sh[0]], tmp_path, env)
    assert res.returncode == 0 and res.stdout.strip().endswith("/bin/hpddo"), res.stdout + res.stderr
    for line in sh[1:] + blocks("board"):  # one way of writing the command throughout
        assert not line.startswith(".venv/bin/"), line


def test_the_guide_has_commands_for_each_step():
    sh, board = [c for c in blocks("sh") if not SETUP.match(c)], blocks("board")
    assert [shlex.split(c)[1] for c in sh] == ["twin", "train", "diagnose", "train", "twin", "evaluate", "evaluate"]
    assert any("capture" in c for c in board) and any("esp8266" in c for c in board)


def test_the_diagnosis_prints_what_the_guide_shows(walked):
    """The guide's printout of the diagnosis' next steps is what it printed, line for line, and the guide's
    next command is that one with the folder named (issue 32: the printed one had no nameplate)."""
    cwd, outputs = walked
    out = next(o for line, o, _ in outputs if shlex.split(line)[1] == "diagnose").splitlines()
    k = next(i for i, ln in enumerate(out) if ln.startswith("next ("))
    shown = blocks("text")
    start = next(i for i, ln in enumerate(shown) if ln.startswith("next ("))
    assert shown[start:start + 4] == out[k:k + 4]
    given = [c for c in blocks("sh") if not SETUP.match(c)][3]
    assert shlex.split(given) == [w.replace("MODEL", "my_model_fx") for w in shlex.split(out[k + 1])]
    named = json.loads((cwd / "my_diagnosis" / "diagnosis.json").read_text())["missing_effects"]
    words = shlex.split(given)
    assert words[words.index("--effects") + 1].split(",") == named


def _avg(path: pathlib.Path, model: str) -> float:
    return json.loads(path.read_text())["rmse_rpm"][model]["average"]


def test_the_figures_the_guide_quotes_are_what_the_walk_measures(walked):
    cwd, _ = walked
    text = " ".join(GUIDE.read_text(encoding="utf-8").split())
    train = cwd / "my_model" / "metrics.json"
    assert f"M2 {_avg(train, 'M2'):.2f} RPM, M3 {_avg(train, 'M3'):.2f}, lookup {_avg(train, 'lookup'):.2f}" in text
    for folder, label in (("my_eval", "`my_model` (plain physics)"),
                          ("my_eval_fx", "`my_model_fx` (with the two named effects)")):
        m = cwd / folder / "metrics.json"
        row = f"| {label} | {_avg(m, 'M2'):.2f} | {_avg(m, 'M3'):.2f} | {_avg(m, 'lookup'):.2f} |"
        assert row in text, row
    d = json.loads((cwd / "my_diagnosis" / "diagnosis.json").read_text())["rmse_rpm"]
    assert f"held-out rows from {d['before']['average']:.2f} to {d['after']['average']:.2f} RPM" in text
    # the error falls where the models never were: the mission's loop, on data never seen
    assert _avg(cwd / "my_eval_fx" / "metrics.json", "M2") < 0.6 * _avg(cwd / "my_eval" / "metrics.json", "M2")
    for page in ("my_model/report/index.html", "my_diagnosis/index.html", "my_eval_fx/report/index.html"):
        assert (cwd / page).is_file(), page
