"""Progress (hpddo.progress, issue 32 item 1): a command with its output redirected to files
writes one line per stage on stderr (no bar, no carriage return), and with --quiet none; the
results on stdout either way. Run as a user runs them: `python -m hpddo ...` in a subprocess."""
import re
import subprocess
import sys

import pytest

from conftest import ROOT
from hpddo import progress

MODEL = ROOT / "models" / "default"
UNSEEN = ROOT / "data" / "validation" / "unseen.csv"
LINE = re.compile(r"hpddo (\w+): \[ *\d+\.\d s\] (.+)")

EVALUATE_STAGES = ["reading 1 log(s) (47 kB)", "writing the cleaned logs (837 rows)",
                   "building the native replay (CMake, C++)", "replaying 1 recording(s) through the board observer",
                   "scoring the estimates", "writing the report"]
TRAIN_STAGES = ["reading 2 log(s) (70 kB)", "identifying M1 and M2", "training M3 (16, 8), 5 epochs",
                "exporting the model headers and golden vectors (float, fixed point, int8)",
                "writing the cleaned logs (1254 rows)", "building the native replay (CMake, C++)",
                "replaying 2 recording(s) through the board observer", "scoring the estimates", "writing the report"]


def run_redirected(tmp_path, argv):
    """The command with stdout and stderr redirected to files (not a terminal): (status, out, err)."""
    out, err = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    with open(out, "w") as o, open(err, "w") as e:
        status = subprocess.run([sys.executable, "-m", "hpddo", *map(str, argv)], stdout=o, stderr=e,
                                stdin=subprocess.DEVNULL, cwd=tmp_path).returncode
    return status, out.read_text(), err.read_text()


def stages(text: str, tool: str) -> list:
    """The stage texts of a command's stderr; any other line but a warning fails."""
    got = []
    for line in text.splitlines():
        if line.startswith(f"hpddo {tool}: WARNING: "):
            continue
        m = LINE.fullmatch(line)
        assert m and m.group(1) == tool, f"not a stage line of hpddo {tool}: {line!r}"
        got.append(m.group(2))
    return got


def test_evaluate_writes_one_line_per_stage_to_a_redirected_log(tmp_path):
    status, out, err = run_redirected(tmp_path, ["evaluate", "--model", MODEL, UNSEEN, "--out", tmp_path / "ev"])
    assert status == 0, err
    assert "\r" not in err and "\x1b" not in err  # no bar off a terminal
    assert stages(err, "evaluate") == EVALUATE_STAGES
    assert "RMSE on every row" in out and not LINE.search(out) and "wrote " in out


def test_evaluate_quiet_writes_no_progress(tmp_path):
    status, out, err = run_redirected(tmp_path, ["evaluate", "--model", MODEL, UNSEEN, "--out", tmp_path / "ev",
                                                 "--quiet"])
    assert status == 0, err
    assert err == "" and "RMSE on every row" in out and "wrote " not in out and not LINE.search(out)


def test_train_names_the_native_build_after_the_training(tmp_path):
    logs = [ROOT / "data" / "default" / f"{c}.csv" for c in ("sweep", "load")]
    status, out, err = run_redirected(tmp_path, ["train", *logs, "--out", tmp_path / "m", "--epochs", "5"])
    assert status == 0, err
    assert "\r" not in err
    assert stages(err, "train") == TRAIN_STAGES


def test_stages_and_bars_are_silent_outside_a_command_and_with_quiet(capsys):
    progress.stage("nobody listens")
    items = [1, 2, 3]
    assert progress.bar(items, "x") is items
    with progress.reporting("demo", enabled=False):
        progress.stage("quiet")
        assert progress.bar(items, "x") is items
    with progress.reporting("demo"):
        progress.stage("loud")
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and LINE.fullmatch(err[0]).groups() == ("demo", "loud")


@pytest.mark.parametrize("tool", ["train", "diagnose", "evaluate", "ripple", "compare"])
def test_every_long_command_takes_quiet(tool):
    from hpddo import cli
    assert any("--quiet" in a.option_strings for a in cli.parser(tool)._actions)
