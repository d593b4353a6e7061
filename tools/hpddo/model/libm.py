"""Elementwise exp, sin and cos through the C library, for arrays.

numpy's own vectorised versions differ in the last bits between the SIMD paths it
picks for the CPU (AVX2, AVX-512, none), and generated files (golden vectors, model
headers, the bundled recordings) must be the same bytes on every machine. The C
library's functions take one path on a given platform. Slower than numpy's; used where
the results are written out.
"""
from __future__ import annotations

import math

import numpy as np


def _each(fn, x) -> np.ndarray:
    a = np.asarray(x, float)
    return np.fromiter(map(fn, a.ravel().tolist()), float, a.size).reshape(a.shape)


def exp(x) -> np.ndarray:
    """e**x, float64, element by element: once per distinct value (a thermal node's steps share a
    few sample periods), which gives the same bits (exp(-0.0) = exp(0.0) = 1)."""
    a = np.asarray(x, float)
    if a.size < 64:
        return _each(math.exp, a)
    u, inv = np.unique(a, return_inverse=True)
    if len(u) > a.size // 2:
        return _each(math.exp, a)
    return _each(math.exp, u)[inv].reshape(a.shape)


def sin(x) -> np.ndarray:
    """sin(x), float64, element by element."""
    return _each(math.sin, x)


def cos(x) -> np.ndarray:
    """cos(x), float64, element by element."""
    return _each(math.cos, x)
