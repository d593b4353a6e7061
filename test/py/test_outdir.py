"""No tool deletes or overwrites what it did not write (hpddo/logs/outdir.py and every CLI)."""
import json
import pathlib

import pytest

from conftest import ROOT

import demo
import diagnose
import gen_weights
import twin
from hpddo.logs import outdir

DATA = sorted(p for p in (ROOT / "data" / "default").glob("*.csv") if not p.name.endswith(".truth.csv"))


def _user_folder(tmp_path) -> pathlib.Path:
    d = tmp_path / "mine"
    d.mkdir()
    (d / "notes.txt").write_text("my notes\n")
    (d / "sweep.csv").write_bytes(DATA[-1].read_bytes())
    return d


def _snapshot(d: pathlib.Path) -> dict:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


TOOLS = {
    "diagnose": lambda logs, out: diagnose.main([*map(str, logs), "--out", str(out), "--bootstrap", "0",
                                                 "--no-hybrid"]),
    "gen_weights": lambda logs, out: gen_weights.main([*map(str, logs), "--out", str(out), "--quiet",
                                                       "--epochs", "1"]),
    "demo": lambda logs, out: demo.main(["--data", str(logs[0].parent), "--out", str(out)]),
    "twin": lambda logs, out: twin.main(["--protocol", "sweep", "--time-scale", "0.05", "--out", str(out),
                                         "--quiet"]),
}


@pytest.mark.parametrize("tool", sorted(TOOLS))
def test_a_folder_of_someone_elses_files_is_refused_and_left_as_it_was(tmp_path, capsys, tool):
    d = _user_folder(tmp_path)
    before = _snapshot(d)
    rc = TOOLS[tool](DATA, d)
    err = capsys.readouterr().err
    assert rc == 1
    assert str(d) in err and "not empty" in err and "nothing was written" in err
    assert _snapshot(d) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"], "no staging folder may be left behind"


@pytest.mark.parametrize("tool", sorted(TOOLS))
def test_an_existing_file_at_the_output_path_is_refused_and_kept(tmp_path, capsys, tool):
    f = tmp_path / "result"
    f.write_text("keep me\n")
    assert TOOLS[tool](DATA, f) == 1
    assert "is not a folder" in capsys.readouterr().err
    assert f.read_text() == "keep me\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result"]


@pytest.mark.slow
def test_rerun_replaces_only_what_the_tool_wrote(tmp_path):
    out = tmp_path / "diag"
    assert TOOLS["diagnose"](DATA, out) == 0
    manifest = json.loads((out / outdir.MANIFEST).read_text())
    assert manifest["tool"] == "diagnose" and "index.html" in manifest["entries"]
    (out / "my_comment.txt").write_text("added by the user\n")
    assert TOOLS["diagnose"](DATA, out) == 0
    assert (out / "my_comment.txt").read_text() == "added by the user\n"
    assert (out / "diagnosis.json").is_file()


@pytest.mark.slow
def test_a_user_file_where_the_tool_would_write_is_refused(tmp_path, capsys):
    out = tmp_path / "diag"
    assert TOOLS["diagnose"](DATA, out) == 0
    (out / "index.html").unlink()
    (out / "index.html").write_text("my own page\n")
    manifest = json.loads((out / outdir.MANIFEST).read_text())
    manifest["entries"].remove("index.html")
    (out / outdir.MANIFEST).write_text(json.dumps(manifest))
    assert TOOLS["diagnose"](DATA, out) == 1
    assert "would replace index.html" in capsys.readouterr().err
    assert (out / "index.html").read_text() == "my own page\n"


def test_another_tools_output_is_refused(tmp_path, capsys):
    out = tmp_path / "t"
    assert TOOLS["twin"](DATA, out) == 0
    before = _snapshot(out)
    assert TOOLS["diagnose"](DATA, out) == 1
    assert "'hpddo twin'" in capsys.readouterr().err
    assert _snapshot(out) == before


@pytest.mark.slow
def test_a_refusal_names_the_tools_as_the_user_types_them(tmp_path, capsys):
    out = tmp_path / "m"
    assert TOOLS["gen_weights"](DATA[:1], out) == 0
    capsys.readouterr()
    assert TOOLS["twin"](DATA, out) == 1
    err = capsys.readouterr().err
    assert "written by 'hpddo train', not 'hpddo twin'" in err and "gen_weights" not in err, err


def test_a_failure_inside_the_stage_leaves_nothing(tmp_path):
    out = tmp_path / "o"
    with pytest.raises(RuntimeError):
        with outdir.staged(out, "x") as stage:
            (stage / "half.txt").write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_twin_collects_protocols_in_one_folder(tmp_path):
    out = tmp_path / "t"
    assert twin.main(["--protocol", "sweep", "--time-scale", "0.05", "--out", str(out), "--quiet"]) == 0
    assert twin.main(["--protocol", "load", "--time-scale", "0.05", "--out", str(out), "--quiet"]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert "sweep.csv" in names and "load.csv" in names
    assert sorted(json.loads((out / outdir.MANIFEST).read_text())["entries"]) == sorted(
        n for n in names if n != outdir.MANIFEST)


def test_committed_outputs_carry_their_manifest():
    """models/default and data/default are regenerated in place by their tools."""
    assert json.loads((ROOT / "models/default" / outdir.MANIFEST).read_text())["tool"] == "gen_weights"
    assert json.loads((ROOT / "data/default" / outdir.MANIFEST).read_text())["tool"] == "twin"
