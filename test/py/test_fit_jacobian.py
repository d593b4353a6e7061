"""The fits' Jacobian (effects.fd_jacobian: its columns evaluated together, those that move no thermal
parameter at the temperatures of the point, the others' thermal trajectories side by side) is scipy's
own 2-point finite differences, bit for bit: the same steps by the same rules (bounds active or not),
the same differences, laid out as scipy lays them, so every fit is the same fit."""
import dataclasses
import itertools

import numpy as np
import pytest
from scipy.optimize import _numdiff

from conftest import ROOT

from hpddo.diagnosis import core
from hpddo.model import effects as fx
from hpddo.model import physics as ph

DEFAULT = [ROOT / "data" / "default" / f"{c}.csv" for c in ("load", "long", "sweep")]


def _scipy(fun, x, f0, lo, hi):
    return _numdiff.approx_derivative(fun, x, method="2-point", f0=f0, bounds=(lo, hi))


def _same(a, b):
    """The same bits, and the same layout (the solver's products take their path by it)."""
    return (a.shape == b.shape and a.tobytes() == b.tobytes() and a.flags.f_contiguous == b.flags.f_contiguous
            and a.flags.c_contiguous == b.flags.c_contiguous)


def test_the_steps_and_differences_are_scipys_whatever_the_bounds():
    rng = np.random.default_rng(7)
    w = rng.normal(size=(5, 40))

    def fun(x):
        return np.sin(w.T @ x) * np.exp(0.1 * x[0]) + x[1] ** 3

    for trial in range(400):
        x = rng.normal(0.0, 10.0 ** rng.integers(-9, 4), 5)
        x[rng.random(5) < 0.2] = 0.0
        lo = np.where(rng.random(5) < 0.5, -np.inf, x - 10.0 ** rng.uniform(-12, 1, 5))
        hi = np.where(rng.random(5) < 0.5, np.inf, x + 10.0 ** rng.uniform(-12, 1, 5))
        edge = rng.random(5) < 0.3  # on a bound: the step turned back, or as far as the room allows
        lo = np.where(edge & (rng.random(5) < 0.5), x, lo)
        hi = np.where(edge & ~(lo == x), x, hi)
        if trial % 7 == 0:
            lo, hi = np.full(5, -np.inf), np.full(5, np.inf)
        f0 = fun(x)
        ours = fx.fd_jacobian(lambda xs: np.stack([fun(r) for r in xs]), x, f0, lo, hi)
        assert _same(ours, _scipy(fun, x, f0, lo, hi))


class _Kept:
    """least_squares as effects._solve calls it, keeping its residual and Jacobian functions and bounds."""

    def __init__(self, real):
        self.real, self.calls = real, []

    def __call__(self, fun, x0, jac=None, bounds=None, **kw):
        self.calls.append((fun, jac, np.asarray(bounds[0], float), np.asarray(bounds[1], float), np.array(x0)))
        return self.real(fun, x0, jac=jac, bounds=bounds, **kw)


# (effects named, what else the fit moves): the plain model, a brush drop with its shape (bounded), thermal
# fits (the node's two parameters, copper's coefficient, Ra with its prior or within bounds), a current offset
FITS = [
    ((), {}),
    (("brush_drop",), {}),
    (("brush_drop",), {"widen": ("brush_drop",)}),
    (("thermal_ra",), {}),
    (("thermal_ra", "magnet_thermal", "saturation"), {}),
    (("thermal_ra", "current_offset"), {"ra_bounds": (3.0, 6.0)}),
    (("brush_drop", "magnet_thermal"), {"ra_prior": (4.5, 0.2, 5.0)}),
]


@pytest.mark.parametrize("names,extra", FITS)
def test_a_fits_jacobian_is_scipys_finite_differences_bit_for_bit(monkeypatch, names, extra):
    inp = core.load(DEFAULT, core.Options())
    kept = _Kept(fx.least_squares)
    monkeypatch.setattr(fx, "least_squares", kept)
    args = (inp.rows, inp.m2, list(names), "train", None, None, None, extra.get("ra_prior"), extra.get("ra_bounds"),
            extra.get("widen", ()))
    fitted = fx._solve(*args)
    fun, jac, lo, hi, x0 = kept.calls[-1]
    assert callable(jac)
    rng = np.random.default_rng(len(names) + 10 * len(extra))
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(1.0, np.abs(x0)))
    for trial in range(6):
        x = x0 + rng.uniform(-0.2, 0.2, x0.size) * span
        if trial % 2:  # parameters at their bounds (within a step of them): the steps turn back
            at_hi, at_lo = np.where(np.isfinite(hi), hi, 0.0), np.where(np.isfinite(lo), lo, 0.0)
            x = np.where(np.isfinite(hi) & (rng.random(x0.size) < 0.5), at_hi - 1e-12 * np.abs(at_hi), x)
            x = np.where(np.isfinite(lo) & (rng.random(x0.size) < 0.5), at_lo + 1e-12 * np.abs(at_lo), x)
        x = np.clip(x, lo, hi)
        f0 = fun(x)
        want = _scipy(fun, x, f0, lo, hi)
        assert _same(jac(x), want)
        fun(x0)  # and where the residual was last evaluated elsewhere
        assert _same(jac(x), want)
    # and the whole fit is the one scipy's own finite differences give
    monkeypatch.setattr(fx, "JACOBIAN", "2-point")
    fx._temp_cache.clear()
    again = fx._solve(*args)
    assert dataclasses.astuple(again[0]) == dataclasses.astuple(fitted[0]) and again[1] == fitted[1]


def test_the_physics_of_columns_of_parameters_is_each_columns_own():
    """physics.temperatures and physics_rpm with columns of parameters (k x 1, one per Jacobian column): each
    row the same bits as the column's parameters alone, over blocks, steps of no period, the winding at its
    class limit (blocks redone step by step), settled rows, columns with the node off, and the brush drop's
    choices (order above 1 or not, the knee's minimum) column by column."""
    rng = np.random.default_rng(11)
    n = 3 * ph._BLOCK + 123
    dt = np.where(rng.random(n) < 0.02, 0.0, 0.5)
    temp = np.where(rng.random(n) < 0.8, 25.0 + rng.normal(0.0, 2.0, n), np.nan)
    i = np.abs(rng.normal(1.0, 0.4, n))
    i[2 * ph._BLOCK + 50:2 * ph._BLOCK + 400] = 30.0  # hot enough for the bound where r is large
    v, di = 12.0 - 0.5 * i + rng.normal(0.0, 0.1, n), rng.normal(0.0, 1.0, n)
    base = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4, ra_tc_per_K=0.00393, t_ref_C=25.0, t_amb_C=25.0,
                            th_r_K_per_W=3.0, th_tau_s=20.0, brush_V=0.3, brush_knee_A=0.05, brush_order=1.5,
                            ke_tc_per_K=-0.002, ke_sat_per_A=0.01, i_offset_A=0.01)
    moves = {"ra_ohm": [4.5, 4.6, 4.4, 4.5], "th_r_K_per_W": [3.0, 3.0, 400.0, 5.0], "th_tau_s": [20.0, 21.0, 20.0, 20.0],
             "ra_tc_per_K": [0.00393, 0.004, 0.00393, 0.0], "i_offset_A": [0.01, 0.02, 0.0, 0.01],
             "brush_order": [1.5, 1.0, 0.5, 2.0], "brush_knee_A": [0.05, 0.0005, np.nan, 0.05]}
    for node_off, m, settled in itertools.product((False, True), (n, ph._BLOCK, 700), (False, True)):
        cols = dataclasses.replace(base)
        for f, vals in moves.items():
            setattr(cols, f, np.array(vals)[:, None])
        cols.th_r_K_per_W[3] = 0.0 if node_off else 5.0
        got = ph.temperatures(cols, i[:m], dt[:m], temp[:m], settled=settled)
        speed = ph.physics_rpm(cols, v[:m], i[:m], di[:m], got)
        for c in range(4):
            one = ph.column(cols, c)
            want = ph.temperatures(one, i[:m], dt[:m], temp[:m], settled=settled)
            assert got.winding_C[c].tobytes() == want.winding_C.tobytes()
            assert got.magnet_C[c].tobytes() == want.magnet_C.tobytes()
            assert speed[c].tobytes() == ph.physics_rpm(one, v[:m], i[:m], di[:m], want).tobytes()
