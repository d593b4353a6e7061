"""The built native replay kept in the cache (evaluation/replay.py, build_key): the same model code
builds once, whatever the provenance comments say; another model's code, or a cache turned off,
builds again."""
import shutil
import subprocess

import pytest

from conftest import ROOT
from hpddo.evaluation import replay

pytestmark = pytest.mark.slow


def _model(folder, extra_comment="", weight_edit=None):
    folder.mkdir(parents=True, exist_ok=True)
    text = (ROOT / "models" / "default" / "model_default.h").read_text(encoding="utf-8")
    if weight_edit:
        text = text.replace(*weight_edit, 1)
    (folder / "model_default.h").write_text(extra_comment + text, encoding="utf-8")
    return folder


def test_the_same_code_builds_once_and_other_code_again(tmp_path, monkeypatch):
    monkeypatch.setenv(replay.CACHE_ENV, str(tmp_path / "cache"))
    calls = []
    real = replay._cmake
    monkeypatch.setattr(replay, "_cmake", lambda args, what: (calls.append(what), real(args, what)))
    a = replay.build(_model(tmp_path / "a"), "default", tmp_path / "a" / "replay")
    assert len(calls) == 2  # configured and built
    b = replay.build(_model(tmp_path / "b", "// trained elsewhere, another command line\n"), "default",
                     tmp_path / "b" / "replay")
    assert len(calls) == 2 and b.read_bytes() == a.read_bytes()  # comments compile to nothing: kept
    log = ROOT / "data" / "default" / "sweep.csv"
    for exe in (a, b):  # a whole executable that runs
        (exe.parent / "est").mkdir()
        res = subprocess.run([str(exe), "--out-dir", str(exe.parent / "est"), str(log)], capture_output=True)
        assert res.returncode == 0 and (exe.parent / "est" / "sweep.estimates.csv").is_file()
    header = (ROOT / "models" / "default" / "model_default.h").read_text(encoding="utf-8")
    code = next(ln for ln in header.splitlines() if ln.rstrip().endswith("f,") and not ln.lstrip().startswith("//"))
    other = _model(tmp_path / "c", weight_edit=(code, code.replace("f,", "1f,", 1)))
    assert replay.build_key(other, "default") != replay.build_key(tmp_path / "a", "default")
    replay.build(other, "default", tmp_path / "c" / "replay")
    assert len(calls) == 4  # another model's code: built


def test_an_empty_cache_variable_turns_the_cache_off(tmp_path, monkeypatch):
    monkeypatch.setenv(replay.CACHE_ENV, "")
    assert replay.cache_dir() is None
    monkeypatch.delenv(replay.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert replay.cache_dir() == tmp_path / "hpddo" / "replay"


def test_a_cache_that_cannot_be_written_is_left_alone(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("not a folder\n")
    monkeypatch.setenv(replay.CACHE_ENV, str(tmp_path / "file"))
    exe = tmp_path / "exe"
    exe.write_bytes(b"\x7fELF")
    replay._to_cache("k", exe)  # no error: nothing kept
    assert (tmp_path / "file").read_text() == "not a folder\n"
    assert not replay._from_cache("k", tmp_path / "out")
