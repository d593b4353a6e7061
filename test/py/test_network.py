"""model/network.py: the training's arithmetic is defined by the shapes, not by how the loop is
laid out. network.train keeps its activations both ways (rows by units, units by rows) to do
the sums over a layer's inputs in two numpy calls; each weight must be the same bits as the
plain row-major loop below (network.activations' matmul, term by term), which is what the
committed model headers were trained with."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hpddo.model import network as nw


def _row_major_train(z, y, cfg, weight=None):
    """The training step by step in rows-by-units arrays only (the loop network.train replaced)."""
    z = np.asarray(z, float)
    y = np.asarray(y, float).reshape(-1, 1)
    n = len(z)
    wt = nw.sample_weights(weight, n)
    rng = np.random.default_rng(cfg.seed)
    theta, flat = nw.init_network(z.shape[1], tuple(cfg.hidden), rng)
    ws, bs = flat.views(theta)
    grad = np.zeros_like(theta)
    gws, gbs = flat.views(grad)
    m, v = np.zeros_like(theta), np.zeros_like(theta)
    b1_t = b2_t = 1.0
    net = nw.Network(coefs_=ws, intercepts_=bs)
    losses = []
    for _ in range(cfg.max_iter):
        order = rng.permutation(n)
        zs, ys = z[order], y[order]
        wts = None if wt is None else wt[order]
        acc = 0.0
        for start in range(0, n, cfg.batch_size):
            zb, yb = zs[start: start + cfg.batch_size], ys[start: start + cfg.batch_size]
            nb = len(zb)
            acts = net.activations(zb)
            delta = acts[-1] - yb
            if wts is None:
                sq = float((delta * delta).sum()) / nb / 2.0
            else:
                wb = wts[start: start + cfg.batch_size]
                sq = float((wb * delta * delta).sum()) / nb / 2.0
                delta = delta * wb
            acc += (sq + 0.5 * cfg.alpha * sum(float((w * w).sum()) for w in ws) / nb) * nb
            for k in range(len(ws) - 1, -1, -1):
                gws[k][...] = (nw.matmul_t(acts[k], delta) + cfg.alpha * ws[k]) / nb
                gbs[k][...] = delta.sum(axis=0) / nb
                if k:
                    delta = nw.matmul(delta, ws[k].T)
                    delta *= acts[k] > 0
            b1_t *= nw.ADAM_BETA1
            b2_t *= nw.ADAM_BETA2
            nw.adam_step(theta, grad, m, v, nw.adam_rate(cfg, b1_t, b2_t))
        losses.append(acc / n)
    return [w.copy() for w in ws] + [b.copy() for b in bs], losses


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 450), n_in=st.integers(1, 9),
       hidden=st.sampled_from([(16, 8), (8,), (1,), (3, 1), (1, 5), (33, 2), (16, 8, 4)]),
       batch=st.sampled_from([1, 7, 64, 200]), weighted=st.booleans(), seed=st.integers(0, 2 ** 16))
def test_training_is_the_row_major_arithmetic_to_the_byte(n, n_in, hidden, batch, weighted, seed):
    rng = np.random.default_rng(seed)
    z = rng.normal(size=(n, n_in)) * rng.choice([1e-3, 1.0, 1e3])
    y = rng.normal(size=n) * 50.0 + 3.0 * z[:, 0]
    w = rng.uniform(0.0, 3.0, n) + 1e-3 if weighted else None
    cfg = nw.AdamConfig(hidden=hidden, batch_size=batch, max_iter=3, seed=seed % 7 + 1)
    net, losses = nw.train(z, y, cfg, weight=w)
    want, want_losses = _row_major_train(z, y, cfg, weight=w)
    got = list(net.coefs_) + list(net.intercepts_)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(got, want))
    assert losses == want_losses


@pytest.mark.parametrize("rows", [1, 2, 9, 200])
@pytest.mark.parametrize("k,m", [(1, 16), (5, 16), (16, 8), (8, 16), (40, 3)])
@pytest.mark.parametrize("transposed", [False, True])
def test_matmul_cols_is_matmul_to_the_byte(k, m, rows, transposed):
    """Whatever the strides of its operands (a transposed weight matrix, a slice of rows), as the
    backward pass hands them: a product laid out with the inner index fastest would be summed
    pairwise by numpy, not term by term."""
    rng = np.random.default_rng(k * 100 + m + rows)
    a_t = np.maximum(rng.normal(size=(k, rows + 7)) * 1e3, 0.0)[:, 3: 3 + rows]
    w = rng.normal(size=(m, k)).T if transposed else rng.normal(size=(k, m))
    want = nw.matmul(np.ascontiguousarray(a_t.T), w)
    assert np.ascontiguousarray(nw.matmul_cols(w, a_t).T).tobytes() == np.ascontiguousarray(want).tobytes()


@pytest.mark.parametrize("n,batch,max_iter,max_steps,want", [
    (6759, 200, 150, 5100, 150),    # the bundled recordings: 34 batches an epoch, the budget's own figure
    (10889, 200, 150, 5100, 93),    # 55 batches an epoch: the fewest epochs that reach 5100 steps
    (10889, 200, 150, None, 150),   # no budget: the epochs given whatever the rows
    (10889, 200, 10, 5100, 10),     # the epochs given bound it first
    (150, 200, 7, 1, 1),            # one step: one epoch at least
])
def test_a_step_budget_cuts_the_epochs_to_the_fewest_that_reach_it(n, batch, max_iter, max_steps, want):
    cfg = nw.AdamConfig(batch_size=batch, max_iter=max_iter, max_steps=max_steps)
    assert nw.epochs(cfg, n) == want
    z = np.random.default_rng(1).normal(size=(n, 2))
    if n < 1000:  # the training runs that many epochs, each the one it runs without a budget
        cut, losses = nw.train(z, z[:, 0], cfg)
        whole, whole_losses = nw.train(z, z[:, 0], nw.AdamConfig(batch_size=batch, max_iter=want))
        assert losses == whole_losses and len(losses) == want
        assert all(a.tobytes() == b.tobytes() for a, b in zip(cut.coefs_, whole.coefs_))


def test_the_lockstep_training_refuses_a_step_budget():
    with pytest.raises(ValueError, match="max_steps"):
        nw.train_lockstep([np.zeros((10, 2))], [np.zeros(10)], nw.AdamConfig(max_steps=5))
