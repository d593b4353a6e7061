"""Shared by the tests. pyproject.toml ([tool.pytest.ini_options] pythonpath) puts tools/
on the import path: the tests import the package from the tree under test, and the
wrapper scripts (tools/gen_weights.py ...) as modules."""
import pathlib

# First, before any test module imports numpy: hpddo sets one BLAS thread per process
# (hpddo/__init__.py), as it does for every command.
import hpddo  # noqa: F401

ROOT = pathlib.Path(__file__).resolve().parents[2]


def pytest_configure(config):
    """One folder for hpddo's cache (the built native replays, evaluation/replay.py) for the whole run, the
    workers' too (they inherit the environment), removed at its end: the tests leave the user's cache alone,
    and a model the tests build twice is compiled once."""
    import os
    import tempfile
    from hpddo.evaluation import replay
    if not hasattr(config, "workerinput") and replay.CACHE_ENV not in os.environ:
        os.environ[replay.CACHE_ENV] = tempfile.mkdtemp(prefix="hpddo-test-cache-")
        config._hpddo_cache = os.environ[replay.CACHE_ENV]


def pytest_unconfigure(config):
    import shutil
    folder = getattr(config, "_hpddo_cache", None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)
