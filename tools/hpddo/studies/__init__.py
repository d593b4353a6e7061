"""Measurements built on the pipeline: the paper's comparison with its peers (compare), the
figures on never-seen recordings (validation), the novelty gate's study (gate_study), the
ripple speed's figures on the twin (ripple; at low speed: ripple_low), why the residual follows dV/dt on a fast twin recording
and the dynamic family identified there (dynamics), and the benchmarks of the observer step on every
target (perf); README.md's tables of figures (readme) and the documentation's pictures (figures),
from the committed JSON.

May import: everything below the command line (the foundations, logs, model, ripple, evaluation,
twin, diagnosis, reports, hpddo.pipeline); not hpddo.cli.
"""

import argparse as _argparse
import pathlib as _pathlib


def parser(module: str, doc: str) -> _argparse.ArgumentParser:
    """A study's command line: `python -m hpddo.studies.<module>`, its docstring as the help, and
    --json FILE (the figures also written as JSON)."""
    ap = _argparse.ArgumentParser(prog=f"python -m hpddo.studies.{module}", description=doc,
                                  formatter_class=_argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", type=_pathlib.Path, metavar="FILE", help="also write the figures as JSON")
    return ap


def write_json(path, figures) -> None:
    """A study's figures as --json writes them: sorted keys, one space of indent, numpy numbers as floats."""
    import json
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(figures, fh, indent=1, sort_keys=True, default=float)
        fh.write("\n")


def report(module: str, doc: str, run, block, argv=None) -> int:
    """The main of a study without options of its own: run(quiet=False)'s figures printed as
    block(figures) renders them, and written by --json."""
    a = parser(module, doc).parse_args(argv)
    res = run(quiet=False)
    print(block(res))
    if a.json:
        write_json(a.json, res)
    return 0


def doc_markers(module: str, what: str, figures: str) -> tuple:
    """The lines around a document's block of a study's figures (regenerate.DOC_BEGIN, DOC_END),
    written from the committed figures (JSON) by `python -m hpddo.studies.<module> --write-docs`."""
    from .. import regenerate
    return (regenerate.DOC_BEGIN.format(what=what, source=figures,
                                        command=f"python -m hpddo.studies.{module} --write-docs"),
            regenerate.DOC_END.format(what=what))


def with_block(doc: str, markers: tuple, block: str, name: str, what: str) -> str:
    """doc (the text of the document name) with the block between markers replaced by block;
    ValueError naming the document where the markers are missing."""
    begin, end = markers
    i, j = doc.find(begin), doc.find(end)
    if i < 0 or j < i:
        raise ValueError(f"{name}: the markers of {what} are missing")
    return doc[: i + len(begin)] + "\n" + block + doc[j:]


def write_docs(doc: str, figures: str, docs_text) -> int:
    """--write-docs: the document doc (a path in the source tree) with its block rewritten by
    docs_text(its text, the figures) from the committed figures (JSON) at the path figures."""
    import json
    from .. import resource_root
    root = resource_root()
    path = root / doc
    path.write_text(docs_text(path.read_text(encoding="utf-8"),
                              json.loads((root / figures).read_text(encoding="utf-8"))), encoding="utf-8")
    return 0
