"""The host's reference of the board's ripple counter (hpddo.model.ripple_count, issue 23 item 5):
it counts a line of known frequency, refuses the octave below, and the Ra tracker recovers the
copper's rise from exact inputs. (The board's build against this reference, code for code: the
simavr test firmware.uno.sim_ripple_count, test/firmware/check_uno_ripple.py --count.)"""
import math

import numpy as np
import pytest

from hpddo import schema
from hpddo.model import physics as ph
from hpddo.model import ripple_count as rc


@pytest.mark.parametrize("f", [30.0, 79.0, 110.0])
def test_counts_a_line_of_known_frequency(f):
    n = np.arange(20000)
    x = np.floor(100 + 6 * np.sin(2 * np.pi * f * n / 1e4) + 1.5 * np.sin(np.pi * f * n / 1e4 + 0.3) + 0.5)
    c = rc.Counter()
    c.begin(rc.lp_shift(f, 5e3), int(1e4 / f + 0.5), 0, True)  # the band at the decimated 5 kHz
    c.run(x.astype(int))
    got = rc.counter_hz(*c.latch(), 1e4)
    assert got == pytest.approx(f, rel=0.002)
    assert rc.confident(got, 1.1 * f) and not rc.confident(got / 2, f)


def test_copper_coefficient_comes_from_the_schema():
    assert rc.ALPHA_CU == next(e.material for e in schema.EFFECTS if e.name == "thermal_ra") == 0.00393


def test_ra_tracker_recovers_the_copper_rise():
    p = ph.PhysicsParams(ra_ohm=4.5, ke_vs_per_rad=0.4, t_ref_C=30.0)
    t = rc.RaTracker(p)
    ke, w, i = 0.4, 12.0, 0.9
    rpm = w * rc.RPM_PER_RAD_S
    for _ in range(2):  # one second of cold windows at 2 Hz calibrates Ke
        t.step(ke * w + i * 4.5, i, rpm, 0.5)
    assert t.have and t.ke_cal == pytest.approx(ke)
    ra_hot = 4.5 * (1 + rc.ALPHA_CU * 10.0)
    for _ in range(400):
        t.step(ke * w + i * ra_hot, i, rpm, 0.5)
    assert t.ra_ohm == pytest.approx(ra_hot, abs=1e-3) and t.tw_C == pytest.approx(40.0, abs=0.05)
    before = t.ra_ohm
    t.step(ke * w + i * ra_hot + 2.0, i, rpm, 0.5)  # a glitch of V: left out
    assert t.ra_ohm == before
    assert not math.isnan(t.tw_C)


@pytest.mark.parametrize("burst_period,lag", [(1032, 1), (232, 1), (36, 2)])  # 2, 10, 100 Hz windows at 10 kHz
def test_band_lag_as_the_board(burst_period, lag):
    """acq_ripple_count.h ripple_band_lag (host test AcqRippleCount.BandLagFollowsTheBurstsLead)."""
    assert rc.band_lag(burst_period, 1e4) == lag
