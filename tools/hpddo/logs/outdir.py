"""Output folders that never lose a user's files.

Every tool writes its results into a staging folder beside the output folder and moves
them into place only when all of them are complete, so a failed run leaves nothing
behind. A manifest, ``.hpddo-output.json`` (the tool's name and the entries it wrote),
marks a folder as a tool's output. The rules:

* a folder that does not exist, or an empty one, is written;
* a folder with entries is written only when its manifest names the same tool, and then
  only the entries that tool wrote before are replaced or removed: anything else in it is
  left as it is, and a new entry that would replace a file the tool did not write is
  refused;
* a path that exists and is not a folder is refused.

A refusal raises `OutputDirError` before anything is written.
"""
from __future__ import annotations

import contextlib
import json
import os
import pathlib
import shutil
import tempfile

from .errors import InputError

MANIFEST = ".hpddo-output.json"
# The tool's name in a manifest, where it is not the subcommand's (kept: folders written
# before the subcommand was named read as the same tool's).
SUBCOMMAND = {"gen_weights": "train"}


def shown(tool: str) -> str:
    """A manifest's tool as the user types it: 'hpddo train'."""
    return f"'hpddo {SUBCOMMAND.get(tool, tool)}'"


class OutputDirError(InputError):
    """The output folder cannot be written without losing something the tool did not write."""


def _manifest(out: pathlib.Path):
    try:
        data = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
        return str(data["tool"]), set(map(str, data["entries"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None, set()


def check(out, tool: str, entries=None) -> None:
    """Raises OutputDirError if writing `entries` (names inside out; None: any) into out
    by `tool` could replace or delete something that tool did not write."""
    out = pathlib.Path(out)
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise OutputDirError(f"{out}: exists and is not a folder; give --out a new or empty folder "
                             "(nothing was written)")
    if not out.exists():
        return
    present = {p.name for p in out.iterdir()} - {MANIFEST}
    if not present:
        return
    owner, ours = _manifest(out)
    if owner != tool:
        whose = "no hpddo tool" if owner is None else shown(owner)
        raise OutputDirError(f"{out}: folder is not empty and was written by {whose}, not {shown(tool)}; give --out "
                             "a new or empty folder, or a previous output of this tool (nothing was written)")
    clash = sorted(n for n in (entries or ()) if n in present and n not in ours)
    if clash:
        raise OutputDirError(f"{out}: would replace {', '.join(clash)}, which {shown(tool)} did not write; move "
                             "them or give --out another folder (nothing was written)")


def _move_aside(path: pathlib.Path, trash: pathlib.Path) -> None:
    if path.exists() or path.is_symlink():
        os.rename(path, trash / path.name)


def commit(stage: pathlib.Path, out: pathlib.Path, tool: str, prune: bool = True) -> pathlib.Path:
    """Moves every entry of stage into out, replacing only what `tool` wrote there before,
    and writes the manifest. With prune, what the tool wrote there before and did not write
    now is removed (the folder is one result, as a report); without, it stays (the folder
    collects results, as recordings). Removes stage."""
    from ..interrupt import held

    with held():  # a signal waits until every entry is in place
        return _commit(stage, out, tool, prune)


def _commit(stage: pathlib.Path, out: pathlib.Path, tool: str, prune: bool) -> pathlib.Path:
    from .benchlog import write_text_atomic  # on use: the bench-log reader loads pandas

    entries = sorted(p.name for p in stage.iterdir() if p.name != MANIFEST)
    check(out, tool, entries)
    _, old = _manifest(out) if out.is_dir() else (None, set())
    listed = entries if prune else sorted(set(entries) | {n for n in old if (out / n).exists()})
    manifest = json.dumps({"tool": tool, "entries": listed}, indent=1) + "\n"
    if not out.exists():
        write_text_atomic(stage / MANIFEST, manifest)
        os.chmod(stage, 0o755)
        os.rename(stage, out)
        return out
    trash = pathlib.Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
    try:
        for name in sorted(old - set(entries)) if prune else ():  # written last time, not now
            _move_aside(out / name, trash)
        for name in entries:
            _move_aside(out / name, trash)
            os.rename(stage / name, out / name)
        write_text_atomic(out / MANIFEST, manifest)
    finally:
        shutil.rmtree(trash, ignore_errors=True)
        shutil.rmtree(stage, ignore_errors=True)
    return out


@contextlib.contextmanager
def staged(out, tool: str, prune: bool = True):
    """Yields an empty staging folder beside out; on success its entries are committed
    into out (see commit), on any exception nothing reaches out and the stage is removed."""
    out = pathlib.Path(out)
    check(out, tool)
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = pathlib.Path(tempfile.mkdtemp(prefix=f".{out.name}.{tool}.", dir=out.parent))
    try:
        yield stage
        commit(stage, out, tool, prune)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
