"""A steady-state table's rows are settled operating points (docs/diagnosis-limits.md): the winding
stands at each row's settled rise (physics.settled_rise), where the node arrives holding the point, not
on a trajectory through a made-up clock; and there the copper's coefficient and the node's resistance
show only as their product, so copper is held at its material value (effects.spec_for)."""
import dataclasses

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from hpddo.model import effects as fx
from hpddo.model import physics as ph


def _node(r_K_per_W, ra_ohm, tc=fx.COPPER_TC_PER_K):
    return ph.PhysicsParams(ra_ohm=ra_ohm, ke_vs_per_rad=0.3, ra_tc_per_K=tc, th_r_K_per_W=r_K_per_W, th_tau_s=20.0,
                            effects=fx.LIBRARY[fx.COPPER].bit)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(r=st.floats(0.25, 24.0), ra=st.floats(0.3, 20.0), i=st.floats(0.0, 4.0), ref=st.floats(-20.0, 120.0))
@example(r=24.0, ra=20.0, i=4.0, ref=25.0)  # no fixed point below the insulation's class: the hottest
def test_the_settled_rise_is_where_the_node_arrives_holding_the_point(r, ra, i, ref):
    p = _node(r, ra)
    rise = float(ph.settled_rise(p, np.array([i]), np.array([ref]))[0])
    assert 0.0 <= rise <= ph.WINDING_MAX_C - ref
    held = ph.thermal_trajectory(p, np.full(4000, i), np.full(4000, 1.0), ref_C=np.full(4000, ref))
    assert rise == pytest.approx(float(held[-1] - ref), rel=1e-9, abs=1e-9)
    if rise < ph.WINDING_MAX_C - ref:  # the fixed point of one step: r i^2 Ra(ref + rise)
        assert rise == pytest.approx(r * i * i * float(ph.ra_at_ohm(p, ref + rise)), rel=1e-9, abs=1e-12)


def test_a_current_that_is_no_number_heats_nothing_as_in_the_trajectory():
    p = _node(3.0, 1.5)
    rise = ph.settled_rise(p, np.array([np.nan]), np.array([25.0]))
    step = ph.thermal_trajectory(p, np.array([np.nan]), np.array([1.0]), ref_C=np.array([25.0])) - 25.0
    assert rise.tolist() == step.tolist() == [0.0]


def test_a_steady_table_sees_the_settled_winding_and_holds_the_copper(tmp_path):
    """Rows in any order, a made-up 1 s clock: each row's winding is its own settled rise (the order of
    the rows changes nothing), and a fit of the heating moves the node's resistance, not copper's
    coefficient."""
    lines = ["# condition=t", "# kind=steady_state", "t_s,duty,v_V,i_A,rpm_ref,temp_C"]
    rng = np.random.default_rng(1)
    for k, i in enumerate(rng.permutation(np.linspace(0.2, 2.0, 30))):
        lines.append(f"{k},{0.5:.3f},{6.0:.3f},{i:.4f},{300.0:.2f},25.0")
    path = tmp_path / "t.csv"
    path.write_text("\n".join(lines) + "\n")
    from hpddo.logs import dataset
    r = fx.rows_of(dataset.load_recordings([path])[0])
    assert r.steady
    p = _node(3.0, 2.0)
    t = fx.temperature(r, p).winding_C
    assert np.allclose(t, 25.0 + ph.settled_rise(p, r.i, np.full(len(r.i), 25.0)), rtol=0, atol=1e-12)
    spec = fx.spec_for([r], [fx.COPPER])
    assert spec.fixed.get("ra_tc_per_K") == fx.COPPER_TC_PER_K and "ra_tc_per_K" not in spec.free
    # a time series keeps the copper's coefficient free where it reads the case temperature
    ts = dataclasses.replace(r, steady=False)
    assert "ra_tc_per_K" in fx.spec_for([ts], [fx.COPPER]).free


def test_a_tables_intervals_say_its_rows_are_settled_points_not_a_count_of_clock_blocks():
    """A one-voltage steady-state table of 30 settled points (test/fixtures/independent/vgain3, dyno12V alone): its
    rows are blocked by duty, load and 30 s of the table's made-up clock (ranking.op_blocks), too few blocks for the
    cluster-robust variance, and the intervals said "rows taken as independent (only 2 operating points)" (and "only
    1 operating points"); a fuzzing round's 32-point table read "only 4". The method names the table's settled
    points."""
    from conftest import ROOT
    from hpddo.diagnosis import core
    log = ROOT / "test" / "fixtures" / "independent" / "vgain3" / "dyno12V.csv"
    res = core.diagnose([log], core.Options(bootstrap=0, hybrid=False, ra_ohm=2.0)).to_json()
    methods = {iv["method"] for iv in res["intervals"]} | {res["ra_fit"]["data_alone"]["method"]}
    assert methods == {"rows taken as independent (30 settled points of a table)"}, methods
