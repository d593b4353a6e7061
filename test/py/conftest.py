"""Puts tools/ on the import path so tests import the hpddo package as users' scripts do."""
import os
import pathlib
import sys

# As the CLIs do: one BLAS thread per process (the diagnosis runs its bootstrap on every core).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
