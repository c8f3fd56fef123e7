"""Multi-bandwidth Gaussian MMD^2: zero for identical sets, grows with the shift, scale-free."""
from __future__ import annotations

import pytest
import torch

from flightlog_fd.training.mmd import median_bandwidth, mmd2


def _sets(shift: float, n: int = 200, d: int = 16, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    x = torch.randn(n, d, generator=g)
    y = torch.randn(n, d, generator=g) + shift
    return x, y


def test_identical_sets_give_zero():
    x, _ = _sets(0.0)
    assert float(mmd2(x, x.clone())) == pytest.approx(0.0, abs=1e-6)


def test_shifted_larger_than_same_distribution():
    x, y_same = _sets(0.0)
    _, y_small = _sets(0.3)
    _, y_big = _sets(1.0)
    same, small, big = float(mmd2(x, y_same)), float(mmd2(x, y_small)), float(mmd2(x, y_big))
    assert 0.0 <= same < small < big
    assert big > 10 * same
    assert big <= 2.0  # averaged kernel in (0, 1] bounds the biased estimate


def test_unbiased_estimator_centred_for_equal_distributions():
    x, y_same = _sets(0.0, seed=3)
    _, y_big = _sets(1.0, seed=3)
    same = float(mmd2(x, y_same, unbiased=True))
    big = float(mmd2(x, y_big, unbiased=True))
    assert abs(same) < 0.01
    assert big > 0.1
    # biased = unbiased + a positive O(1/n) floor
    assert float(mmd2(x, y_same)) > same


def test_median_bandwidth_makes_it_scale_invariant():
    x, y = _sets(0.5)
    base = float(mmd2(x, y))
    assert float(mmd2(100 * x, 100 * y)) == pytest.approx(base, rel=1e-3)
    # the same value with the median fixed by hand...
    h = float(median_bandwidth(torch.cat([x, y])))
    assert float(mmd2(x, y, bandwidth=h)) == pytest.approx(base, rel=1e-5)
    # ...but a fixed bandwidth is not scale-free: scaled up, every point looks unrelated to every
    # other and only the 1/m + 1/n diagonal floor is left
    assert float(mmd2(100 * x, 100 * y, bandwidth=h)) == pytest.approx(2 / len(x), rel=1e-3)


def test_gradient_flows_and_pulls_sets_together():
    x, y = _sets(1.0)
    y = y.clone().requires_grad_(True)
    loss = mmd2(x, y, unbiased=True)
    loss.backward()
    assert torch.isfinite(y.grad).all()
    with torch.no_grad():
        stepped = y - 50.0 * y.grad  # a gradient step lowers the discrepancy
    assert float(mmd2(x, stepped, unbiased=True)) < float(loss.detach())


def test_bad_inputs():
    with pytest.raises(ValueError):
        mmd2(torch.zeros(4, 3), torch.zeros(4, 2))
    with pytest.raises(ValueError):
        mmd2(torch.zeros(0, 3), torch.zeros(4, 3))
    with pytest.raises(ValueError):
        mmd2(torch.zeros(1, 3), torch.zeros(4, 3), unbiased=True)
