"""hpddo tools: bench log I/O, the bench twin, identification, training, export, diagnosis.

The command line is `hpddo SUBCOMMAND ...` (hpddo/cli/, also `python -m hpddo`)."""
import os as _os
import sys as _sys

# One BLAS thread per process, set here once, before anything of the package imports
# numpy: the diagnosis runs its block bootstrap on every core (43 s instead of 68 s on
# two cores), and the scikit-learn peer of the benchmark is measured on one core. An
# environment that sets these itself keeps its values.
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
_os.environ.setdefault("OMP_NUM_THREADS", "1")

__version__ = "0.2.0"


def resource_root() -> "pathlib.Path":
    """The folder holding host/, lib/hpddo_core/ and data/default/: the source tree when
    this package is used from a clone (an editable install), else the copy a wheel
    installs under <prefix>/share/hpddo (pyproject.toml, data-files)."""
    import pathlib  # here: a tool's entry imports this package before its stop handler is in place

    tree = pathlib.Path(__file__).resolve().parents[2]
    if (tree / "host" / "replay.cpp").is_file():
        return tree
    import site
    for prefix in (_sys.prefix, _sys.base_prefix, site.getuserbase()):
        share = pathlib.Path(prefix) / "share" / "hpddo"
        if (share / "host" / "replay.cpp").is_file():
            return share
    return tree  # what is missing is then named by whoever needs it
