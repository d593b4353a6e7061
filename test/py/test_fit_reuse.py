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


def test_the_temperatures_of_a_prefix_are_the_whole_recordings_on_its_rows():
    """A fit whose rows end before its recording does runs the node over physics.trajectory_prefix rows only
    (effects.temperature's upto): on every row up to the last it needs, the same bits as the whole
    recording's, whether the bound holds the winding within a block after those rows, in the block that
    holds the last of them, or nowhere, and with steps of no period."""
    rng = np.random.default_rng(5)
    n = 4 * ph._BLOCK + 211
    dt = np.where(rng.random(n) < 0.01, 0.0, 0.01)
    read = rng.random(n) < 0.9
    temp = np.where(read, 25.0 + rng.normal(0.0, 2.0, n), np.nan)
    base = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4, ra_tc_per_K=0.00393, t_ref_C=25.0, t_amb_C=25.0,
                            th_r_K_per_W=3.0, th_tau_s=20.0)
    i = np.abs(rng.normal(1.0, 0.3, n))
    for hot_from in (None, ph._BLOCK + 700, 3 * ph._BLOCK + 5):
        cur = i.copy()
        if hot_from is not None:
            cur[hot_from:] = 40.0  # the winding at its class limit from here: its blocks taken step by step
        whole = ph.temperatures(base, cur, dt, temp)
        for upto in (0, 1, 500, ph._BLOCK, ph._BLOCK + 1, ph._BLOCK + 650, 2 * ph._BLOCK + 3, n - 1, n):
            k = ph.trajectory_prefix(upto, n)
            assert upto <= k <= n and (k == n or k % ph._BLOCK == 0)
            part = ph.temperatures(base, cur[:k], dt[:k], temp[:k])
            for a, b in ((part.winding_C, whole.winding_C), (part.magnet_C, whole.magnet_C)):
                assert a[:upto].tobytes() == b[:upto].tobytes()
    # and effects.temperature with upto (a fit's last row): the whole recording's on the rows up to it
    inp = core.load(DEFAULT, core.Options())
    fx._fit_memo.clear()
    fx._temp_cache.clear()
    got = fx.fit(inp.rows, inp.m2, ["thermal_ra"])
    fx._fit_memo.clear()
    whole_temps = {id(r): fx.temperature(r, got) for r in inp.rows}
    assert all(fx.temperature(r, got, int(np.flatnonzero(r.train)[-1]) + 1).winding_C.tobytes()
               == whole_temps[id(r)].winding_C[: ph.trajectory_prefix(int(np.flatnonzero(r.train)[-1]) + 1,
                                                                       len(r.i))].tobytes() for r in inp.rows)


def test_the_periods_of_a_copy_that_came_through_pickle_are_kept():
    """A bootstrap resample reaches its worker pickled, its arrays' dtype an equal object that is not
    numpy's own; np.asarray then gives a new view at every call, and the periods' decays, kept by the
    identity of the array (physics._decay), were sorted again at every evaluation of every fit (4.6 of
    22 CPU-s of the 13.6k-row bench's diagnosis). The node takes such an array as it is, and keeps its
    periods once."""
    import pickle

    n = 3 * ph._BLOCK
    dt = pickle.loads(pickle.dumps(np.full(n, 0.5)))
    i = pickle.loads(pickle.dumps(np.full(n, 1.2)))
    assert np.asarray(dt, np.float64) is not dt  # (what numpy does with it)
    p = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4, ra_tc_per_K=0.00393, t_ref_C=25.0, t_amb_C=25.0,
                         th_r_K_per_W=3.0, th_tau_s=20.0)
    ph._periods_of.clear()
    first = ph.thermal_trajectory(p, i, dt)
    for tau in (21.0, 22.0, 23.0):  # a fit's steps: new decays over the same periods
        ph.thermal_trajectory(dataclasses.replace(p, th_tau_s=tau), i, dt)
    assert len(ph._periods_of) == 1 and next(iter(ph._periods_of.values()))[0] is dt
    fresh = ph.thermal_trajectory(p, np.full(n, 1.2), np.full(n, 0.5))
    assert first.tobytes() == fresh.tobytes()
