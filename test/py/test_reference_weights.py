"""The ripple reference's confidence weights its rows (issue 23 item 4, docs/ripple-training.md): in
M2's Ke (eq. 20 as a weighted mean, least squares weighted) and in the effect fits, times any
weights the caller gives (the diagnosis' bootstrap); a recording without a confidence (the
encoder) is fitted as before, to the bit."""
import dataclasses
import pathlib

import numpy as np
import pytest

from hpddo.logs import dataset
from hpddo.model import effects, identify

ROOT = pathlib.Path(__file__).resolve().parents[2]
SWEEP = ROOT / "data" / "default" / "sweep.csv"
RA_OHM = 4.5


@pytest.fixture(scope="module")
def sweep():
    return dataset.load_recordings([SWEEP])[0]


def confidence(rec, seed=5):
    """A confidence per row as the ripple gives one: 0.6..1."""
    return np.random.default_rng(seed).uniform(0.6, 1.0, rec.n)


def test_ke_is_the_confidence_weighted_eq20_and_least_squares(sweep):
    w = confidence(sweep)
    rec = dataclasses.replace(sweep, weight=w)
    v, i, n, got_w = identify.steady_rows([rec])
    assert got_w is not None and len(got_w) == len(v)
    ratio = (v - i * RA_OHM) / (n * identify.RAD_S_PER_RPM)
    assert identify.m2_params([rec], RA_OHM).ke_vs_per_rad == pytest.approx(np.average(ratio, weights=got_w), rel=1e-12)
    assert identify.m2_params([rec], RA_OHM).ke_vs_per_rad != pytest.approx(float(np.mean(ratio)), rel=1e-9)
    om = n * identify.RAD_S_PER_RPM
    want = np.sum(got_w * (v - i * RA_OHM) * om) / np.sum(got_w * om * om)
    assert identify.m2_params([rec], RA_OHM, "lsq").ke_vs_per_rad == pytest.approx(want, rel=1e-12)
    # a constant confidence changes nothing; no confidence is the unweighted fit to the bit
    flat = dataclasses.replace(sweep, weight=np.full(sweep.n, 0.8))
    assert identify.m2_params([flat], RA_OHM).ke_vs_per_rad == pytest.approx(
        identify.m2_params([sweep], RA_OHM).ke_vs_per_rad, rel=1e-12)
    v0, i0, n0, w0 = identify.steady_rows([sweep])
    assert w0 is None
    assert identify.m2_params([sweep], RA_OHM).ke_vs_per_rad == identify.ke_eq20(v0, i0, n0, RA_OHM)


def test_effect_fits_multiply_the_confidence_with_the_callers_weights(sweep):
    m2 = identify.m2_params([sweep], RA_OHM)
    conf = confidence(sweep)
    boot = np.random.default_rng(9).integers(0, 3, sweep.n).astype(float)  # a bootstrap's multiplicities
    with_conf = effects.fit([effects.rows_of(dataclasses.replace(sweep, weight=conf))], m2, ["brush_drop"],
                            weights=[boot])
    product = effects.fit([effects.rows_of(sweep)], m2, ["brush_drop"], weights=[boot * conf])
    unweighted = effects.fit([effects.rows_of(sweep)], m2, ["brush_drop"], weights=[boot])
    assert with_conf.ke_vs_per_rad == pytest.approx(product.ke_vs_per_rad, rel=1e-9)
    assert with_conf.brush_V == pytest.approx(product.brush_V, rel=1e-7)
    assert with_conf.brush_V != pytest.approx(unweighted.brush_V, rel=1e-6)


def test_m3_training_weights_rows_and_ones_change_nothing():
    from hpddo.model import network

    rng = np.random.default_rng(3)
    z = rng.normal(size=(400, 3))
    y = np.where(np.arange(400) % 2 == 0, 0.0, 10.0)  # two targets at the same inputs
    cfg = network.AdamConfig(hidden=(4,), max_iter=40, seed=1, batch_size=50, learning_rate=1e-2)
    plain, loss_plain = network.train(z, y, cfg)
    ones, loss_ones = network.train(z, y, cfg, weight=np.full(400, 0.7))
    assert all(np.array_equal(a, b) for a, b in zip(plain.coefs_ + plain.intercepts_, ones.coefs_ + ones.intercepts_))
    assert loss_plain == loss_ones
    w = np.where(y == 0.0, 1.0, 0.25)  # the y = 0 rows 4x as confident: the fit leans to 0 (weighted mean 2)
    leaned, _ = network.train(z, y, cfg, weight=w)
    assert abs(leaned.predict(z).mean() - 2.0) < 1.0 and abs(plain.predict(z).mean() - 5.0) < 1.0
    lock = network.train_lockstep([z, z], [y, y], cfg, weights=[None, w])
    assert abs(lock[0].predict(z).mean() - 5.0) < 1.0 and abs(lock[1].predict(z).mean() - 2.0) < 1.0
    with pytest.raises(ValueError):
        network.train(z, y, cfg, weight=np.zeros(400))
