"""Every file generated from the declarations, written by one command: the C++ parameter
struct (lib/hpddo_core/src/hpddo/params_gen.h, from hpddo/schema.py), the board's ripple
counter constants (uno_acq/ripple_count_gen.h, from hpddo/ripple/board.py) and the generated
tables of the documents (the effects table of docs/core.md, from the schema; the twin's
effects table of docs/twin.md, from hpddo/twin/params.py; the model header's fields of
docs/model-header.md, from hpddo/model/export.py and the schema). A pytest compares each with
what this writes, byte for byte:

    cd tools && ../.venv/bin/python -m hpddo.regenerate --write      # or --check

It sits above the declarations it reads (the schema and the twin), so neither imports
the other.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import zlib

from . import schema
from .schema import GENERATOR, ROOT, layout_crc
from .model import export
from .ripple import board as ripple_board
from .twin import params as twin_params
from .twin import ripple_free

COMMAND = "cd tools && ../.venv/bin/python -m hpddo.regenerate --write"


def _banner(kind: str, body: str, source: str, layout: bool = True) -> str:
    lines = [f"// GENERATED {kind}: DO NOT EDIT. Regenerate with the command below.",
             f"// command: {COMMAND}",
             f"// source: {source}",
             f"// generator: {GENERATOR}"]
    if layout:
        lines.append(f"// layout: crc32 0x{layout_crc():08x} (kParamsSchema)")
    lines.append(f"// checksum: crc32 0x{zlib.crc32(body.encode()) & 0xFFFFFFFF:08x} of the text below this banner")
    return "\n".join(lines) + "\n"


DOC_BEGIN = "<!-- BEGIN GENERATED: {what}, from {source} ({command}); do not edit -->"
DOC_END = "<!-- END GENERATED: {what} -->"
EFFECTS_DOC = "docs/core.md"
TWIN_DOC = "docs/twin.md"
RIPPLE_DOC = "docs/ripple-counting.md"
CAPTURES_DOC = "docs/ripple-captures.md"
HEADER_DOC = "docs/model-header.md"


def with_generated_block(text: str, block: str, path: str, what: str, source: str) -> str:
    """text with the part between the BEGIN and END markers of `what` replaced by block."""
    begin, end = DOC_BEGIN.format(what=what, source=source, command=COMMAND), DOC_END.format(what=what)
    i, j = text.find(begin), text.find(end)
    if i < 0 or j < i:
        raise ValueError(f"{path}: the markers of the generated {what} are missing")
    return text[: i + len(begin)] + "\n" + block + text[j:]


def doc_blocks() -> list:
    """(document, what, source, block text) of every generated block in the documents."""
    return [(EFFECTS_DOC, "the effects table", "tools/hpddo/schema.py", schema._effects_md()),
            (TWIN_DOC, "the twin's effects table", "tools/hpddo/twin/params.py", twin_params.effects_md()),
            (RIPPLE_DOC, "the ripple mode's parameters", "tools/hpddo/twin/params.py", twin_params.ripple_burst_md()),
            (CAPTURES_DOC, "the free-running mode's parameters", "tools/hpddo/twin/ripple_free.py",
             ripple_free.ripple_free_md()),
            (HEADER_DOC, "the model header's fields", "tools/hpddo/model/export.py", export.header_md())]


def generated(root: pathlib.Path = ROOT) -> dict:
    """{path relative to the repository: text} of every file generated from the schema
    (whole files, and the documents with a generated block, as they should read)."""
    body = schema._params_h_body()
    out = {"lib/hpddo_core/src/hpddo/params_gen.h": _banner("parameter schema", body, "tools/hpddo/schema.py") + body}
    body = ripple_board.header_body()
    out["uno_acq/ripple_count_gen.h"] = _banner("ripple counter constants", body, "tools/hpddo/ripple/board.py",
                                                layout=False) + body
    for doc, what, source, block in doc_blocks():
        text = out.get(doc) or (pathlib.Path(root) / doc).read_text(encoding="utf-8")
        out[doc] = with_generated_block(text, block, doc, what, source)
    return out


def write_or_check(prog: str, doc: str, what: str) -> argparse.ArgumentParser:
    """The parser of a generator's command: --write (write `what`) or --check (exit 1 when one is
    out of date), one of them required."""
    ap = argparse.ArgumentParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help=f"write {what}")
    g.add_argument("--check", action="store_true", help=f"exit 1 when one of {what} is out of date")
    return ap


def main(argv=None) -> int:
    ap = write_or_check("python -m hpddo.regenerate", __doc__, "the generated files")
    ap.add_argument("--root", default=str(ROOT), help="repository root (default: this checkout)")
    args = ap.parse_args(argv)
    root = pathlib.Path(args.root)
    stale = []
    for rel, text in generated(root).items():
        path = root / rel
        old = path.read_bytes() if path.exists() else None
        if old == text.encode():
            continue
        stale.append(rel)
        if args.write:
            path.write_bytes(text.encode())
            print(f"wrote {rel}")
    if args.check and stale:
        print("out of date (run: " + COMMAND + "): " + ", ".join(stale), file=sys.stderr)
        return 1
    if not stale:
        print("generated files up to date")
    for rel, command in stale_models(root):
        print(f"note: {rel} was written for another parameter layout; regenerate it: {command}")
    return 0


def stale_models(root: pathlib.Path = ROOT) -> list[tuple[str, str]]:
    """(path, the command in its banner) of every committed model header (models/*/,
    test/fixtures/) that asserts another parameter layout than this schema's."""
    want = f"hpddo::kParamsSchema == 0x{layout_crc():08x}u"
    out = []
    for path in sorted([*root.glob("models/*/model_*.h"), *root.glob("test/fixtures/model_*.h")]):
        text = path.read_text()
        if want not in text:
            cmd = next((ln.split(":", 1)[1].strip() for ln in text.splitlines() if ln.startswith("// command:")), "?")
            out.append((str(path.relative_to(root)), cmd))
    return out


if __name__ == "__main__":
    sys.exit(main())
