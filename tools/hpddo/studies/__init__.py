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
