"""What the fits compute once and use again (effects._fit's memo, physics._decay, the thermal
rise's blocks side by side) gives the values computed afresh: the diagnosis is faster, not
different."""
import dataclasses
import math

import numpy as np

from conftest import ROOT

from hpddo.diagnosis import core
from hpddo.model import effects as fx
from hpddo.model import physics as ph

DEFAULT = [ROOT / "data" / "default" / f"{c}.csv" for c in ("load", "long", "sweep")]


def _rise_by_steps(p, i, dt, ref, rise0):
    """The node step by step, as the boards run it (ThermalEstimator::step), in float64."""
    out, x = np.empty(len(i)), rise0
    for k in range(len(i)):
        if dt[k] > 0:
            d = math.exp(-dt[k] / p.th_tau_s)
            loss = i[k] * i[k] * p.ra_ohm * (1.0 + p.ra_tc_per_K * (ref[k] + x - p.t_ref_C))
            x = p.th_r_K_per_W * loss + (x - p.th_r_K_per_W * loss) * d
            x = min(max(x, 0.0), ph.WINDING_MAX_C - ref[k])
        out[k] = x
    return out


def test_the_rise_over_many_blocks_is_the_step_by_step_node():
    rng = np.random.default_rng(3)
    n = 5 * ph._BLOCK + 37
    dt = np.where(rng.random(n) < 0.01, 0.0, 0.01)
    ref = 25.0 + rng.normal(0.0, 2.0, n)
    base = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4, ra_tc_per_K=0.00393, t_ref_C=25.0, t_amb_C=25.0,
                            th_r_K_per_W=3.0, th_tau_s=20.0)
    i = np.abs(rng.normal(1.0, 0.3, n))
    # a current that heats the winding to its class limit in the third block: the blocks from there
    # on are taken step by step with the bound, those before it side by side
    hot = i.copy()
    hot[2 * ph._BLOCK + 100:] = 40.0
    for cur in (i, hot):
        got = ph._rise_float64(base, cur, dt, ref, 0.0)
        want = _rise_by_steps(base, cur, dt, ref, 0.0)
        assert np.max(np.abs(got - want)) < 1e-9
    held = (ph._rise_float64(base, hot, dt, ref, 0.0) + ref)[dt > 0]
    assert np.sum(np.abs(held - ph.WINDING_MAX_C) < 1e-9) > 1000  # the bound did hold it
    # and the periods' decays kept for a given tau are those of that tau
    again = dataclasses.replace(base, th_tau_s=200.0)
    assert np.max(np.abs(ph._rise_float64(again, i, dt, ref, 0.0) - _rise_by_steps(again, i, dt, ref, 0.0))) < 1e-9


def test_a_fit_asked_again_is_the_same_fit_and_a_copy():
    inp = core.load(DEFAULT, core.Options())
    names = ["thermal_ra", "brush_drop"]
    fx._fit_memo.clear()
    first = fx.fit(inp.rows, inp.m2, names)
    kept = len(fx._fit_memo)
    second = fx.fit(inp.rows, inp.m2, names)
    assert len(fx._fit_memo) == kept  # nothing fitted again
    assert dataclasses.astuple(first) == dataclasses.astuple(second) and first is not second
    second.brush_V = 99.0  # a caller changing what it got changes nothing kept
    assert fx.fit(inp.rows, inp.m2, names).brush_V == first.brush_V
    # other inputs are another fit, and the memo's fit is the one computed afresh
    w = [np.where(np.arange(r.rec.n) % 2 == 0, 1.0, 2.0) for r in inp.rows]
    weighted = fx.fit(inp.rows, inp.m2, names, weights=w)
    assert len(fx._fit_memo) > kept
    fx._fit_memo.clear()
    assert dataclasses.astuple(fx.fit(inp.rows, inp.m2, names, weights=w)) == dataclasses.astuple(weighted)
    assert dataclasses.astuple(fx.fit(inp.rows, inp.m2, names)) == dataclasses.astuple(first)
