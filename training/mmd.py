"""Maximum mean discrepancy (MMD^2) with a multi-bandwidth Gaussian kernel.

Inputs: two sets of feature vectors ``x`` (m, d) and ``y`` (n, d), float tensors (in training:
the DCNN's first-dense-layer activations of healthy simulated and healthy real windows).
Output: a scalar tensor, differentiable with respect to both sets.

Estimator: the BIASED (V-statistic) estimate by default,

    MMD_b^2 = mean k(x_i, x_j) + mean k(y_i, y_j) - 2 mean k(x_i, y_j)   (diagonals included),

because it is never negative and exactly 0 for identical sets, which makes it a clear measure of
how far apart two feature sets are. Its positive bias is O(1/m + 1/n) and its
gradient differs from the unbiased one only by a (m-1)/m factor on the within-set terms.
``unbiased=True`` gives the U-statistic (diagonals excluded; zero mean for equal distributions,
can be negative; needs m, n >= 2). Training (training/train.py) uses the unbiased one: under
lam = 1e4 the biased floor's gradient, which rewards pulling each set's points together,
collapses the features; the biased one stays the default for measuring (0 for identical sets).

Kernel: k(a, b) = mean over s in BANDWIDTH_MULTIPLIERS of exp(-||a - b||^2 / (s * h)), where h is
the median of the pairwise squared distances of the pooled set x U y, DETACHED from the graph.
Why: (1) the median heuristic makes the MMD invariant to the scale of the features, so the
network cannot shrink the lambda * MMD term by simply shrinking (or blowing up) its ReLU
activations - the term can only fall by actually aligning the two distributions, and training
stays stable with lambda = 1e4; (2) five bandwidths from h/4 to 4h catch both fine and coarse
differences without tuning; (3) averaging (not summing) keeps k in (0, 1], so MMD_b^2 is in
[0, 2]. A fixed ``bandwidth`` (squared-distance scale h) can be passed instead, e.g. to compare
values across batches on the same scale.

Limits: O((m + n)^2 d) memory and time - meant for mini-batches (hundreds of rows), not whole
data sets. h is clamped to >= MIN_BANDWIDTH so identical points do not divide by zero.
"""
from __future__ import annotations

import torch

BANDWIDTH_MULTIPLIERS = (0.25, 0.5, 1.0, 2.0, 4.0)  # times the median squared distance
MIN_BANDWIDTH = 1e-6  # floor on h when (almost) all points coincide


def pairwise_sq_dists(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Squared Euclidean distances (len(a), len(b)), clamped at 0 against round-off."""
    a_sq = (a * a).sum(1, keepdim=True)  # (m, 1)
    b_sq = (b * b).sum(1, keepdim=True).T  # (1, n)
    return (a_sq + b_sq - 2.0 * a @ b.T).clamp_min(0.0)  # (m, n)


def median_bandwidth(z: torch.Tensor) -> torch.Tensor:
    """Median of the off-diagonal pairwise squared distances of ``z`` (detached scalar)."""
    with torch.no_grad():
        d = pairwise_sq_dists(z, z)  # (k, k)
        k = z.shape[0]
        off_diag = d[~torch.eye(k, dtype=torch.bool, device=z.device)]  # (k * (k - 1),)
        if off_diag.numel() == 0:
            return torch.tensor(1.0, dtype=z.dtype, device=z.device)
        return off_diag.median().clamp_min(MIN_BANDWIDTH)


def gaussian_kernel(d2: torch.Tensor, bandwidth: torch.Tensor | float) -> torch.Tensor:
    """Multi-bandwidth Gaussian kernel values from squared distances ``d2``."""
    total = torch.zeros_like(d2)
    for s in BANDWIDTH_MULTIPLIERS:
        total = total + torch.exp(-d2 / (s * bandwidth))
    return total / len(BANDWIDTH_MULTIPLIERS)


def mmd2(
    x: torch.Tensor,
    y: torch.Tensor,
    *,
    unbiased: bool = False,
    bandwidth: float | None = None,
) -> torch.Tensor:
    """MMD^2 between the rows of ``x`` (m, d) and ``y`` (n, d); see the module docstring."""
    if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1]:
        raise ValueError(f"mmd2 needs (m, d) and (n, d) tensors, got {tuple(x.shape)}, {tuple(y.shape)}")
    m, n = x.shape[0], y.shape[0]
    if m == 0 or n == 0:
        raise ValueError("mmd2 needs at least one row in each set")
    if unbiased and (m < 2 or n < 2):
        raise ValueError("the unbiased MMD^2 needs at least two rows in each set")
    z = torch.cat([x, y], 0)  # (m + n, d)
    h = median_bandwidth(z) if bandwidth is None else bandwidth
    k = gaussian_kernel(pairwise_sq_dists(z, z), h)  # (m + n, m + n)
    k_xx, k_yy, k_xy = k[:m, :m], k[m:, m:], k[:m, m:]  # (m, m), (n, n), (m, n)
    if unbiased:
        # Drop the diagonals (k(a, a) = 1): U-statistic, unbiased, may be negative.
        xx = (k_xx.sum() - k_xx.diagonal().sum()) / (m * (m - 1))
        yy = (k_yy.sum() - k_yy.diagonal().sum()) / (n * (n - 1))
    else:
        xx, yy = k_xx.mean(), k_yy.mean()
    return xx + yy - 2.0 * k_xy.mean()
