"""Shared by the tests. pyproject.toml ([tool.pytest.ini_options] pythonpath) puts tools/
on the import path: the tests import the package from the tree under test, and the
wrapper scripts (tools/gen_weights.py ...) as modules."""
import pathlib

# First, before any test module imports numpy: hpddo sets one BLAS thread per process
# (hpddo/__init__.py), as it does for every command.
import hpddo  # noqa: F401

ROOT = pathlib.Path(__file__).resolve().parents[2]
