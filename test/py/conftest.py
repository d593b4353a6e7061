"""Puts tools/ on the import path so tests import the hpddo package as users' scripts do."""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
