"""Savitzky-Golay and first-order lag filters in numpy, evaluated only where they are needed.

What: :func:`savgol_at` gives ``scipy.signal.savgol_filter(x, n, p, deriv, delta, axis=0,
mode="interp")[idx]`` bit for bit (the same coefficients from ``scipy.linalg.lstsq``, the same
symmetric summation order as ``scipy.ndimage.correlate1d``, the same polynomial edge fits) while
computing only the rows ``idx``; :func:`lag` and :func:`lag_at_grid` give the first-order lag of
:func:`flightlog_fd.analyzers.effectiveness_fit` (``lfilter([1-a], [1, -a], u, zi=a*u[0])``) within float noise.

Why: ``scipy.signal`` costs 0.6-1.6 s to import on this project's machines (it imports
``scipy.stats``), more than a whole diagnosis, and the features only keep every k-th sample of a
filter run at k x the model rate (k up to 8), so filtering every fine sample wastes 7/8 of the work.
``scipy.linalg`` and ``scipy.ndimage`` cost 0.3 s CPU more: the coefficients come from NumPy's
``lstsq`` (the same LAPACK routine, the same bits) and :func:`correlate1d_zero_ends` sums as
``scipy.ndimage.correlate1d`` does.

Limits: ``mode="interp"`` only, odd windows, ``x`` 1-D or 2-D along axis 0.
"""
from __future__ import annotations

from functools import lru_cache
from math import factorial

import numpy as np

#: Symmetry tolerance of scipy.ndimage's correlate1d (DBL_EPSILON): within it a filter is summed
#: as symmetric (x[-j] + x[j]) * w[j] or antisymmetric (x[-j] - x[j]) * w[j].
_SYMMETRY_EPS = np.finfo(np.float64).eps
#: A lag term smaller than this fraction of the signal is below float64 resolution and dropped.
LAG_TRUNCATION = 1e-18
#: Rows per block of :func:`correlate1d_zero_ends` (x 4 columns x 8 bytes: 128 kB, within L2).
CORRELATE_BLOCK = 4096


def _lstsq(a: np.ndarray, b: np.ndarray, cond: float) -> tuple[np.ndarray, int]:
    """``scipy.linalg.lstsq(a, b, cond=cond)`` (LAPACK gelsd): NumPy's gives the same bits on every
    shape these filters solve (tests/test_prepared.py), without importing scipy."""
    c, _, rank, _ = np.linalg.lstsq(a, b, rcond=cond)
    return c, int(rank)


def _symmetry(fw: np.ndarray) -> int:
    """scipy.ndimage's test of a filter's taps: 1 symmetric, -1 antisymmetric, 0 neither."""
    n = fw.size
    if not n & 1:
        return 0
    size1 = n // 2
    if all(abs(fw[i + size1] - fw[size1 - i]) <= _SYMMETRY_EPS for i in range(1, size1 + 1)):
        return 1
    if all(abs(fw[size1 + i] + fw[size1 - i]) <= _SYMMETRY_EPS for i in range(1, size1 + 1)):
        return -1
    return 0


def _correlate(at, fw: np.ndarray, sym: int) -> np.ndarray:
    """sum_j fw[size1 + j] x[i + j], as scipy.ndimage's correlate1d sums it (``at(j)``: the rows
    x[i + j] for every output row i)."""
    n = fw.size
    size1 = n // 2
    size2 = n - size1 - 1
    if sym != 0:
        acc = at(0) * fw[size1]
        for jj in range(-size1, 0):
            a, b = at(jj), at(-jj)
            acc += ((a + b) if sym > 0 else (a - b)) * fw[size1 + jj]
    else:
        acc = at(size2) * fw[size1 + size2]
        for jj in range(-size1, size2):
            acc += at(jj) * fw[size1 + jj]
    return acc


def correlate1d_zero_ends(x: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.correlate1d(x, weights, axis=0, mode="constant")`` (zeros beyond the ends) of
    a float64 (m,) or (m, C) array, the same bits, without importing scipy (0.2-0.5 s CPU). The rows
    go in blocks of :data:`CORRELATE_BLOCK` that stay in the cache: 1.5x scipy's time for a 41-tap
    filter over 240 000 x 4 samples, 0.45x the time of one pass per tap over the whole array."""
    x = np.asarray(x, dtype=np.float64)
    fw = np.asarray(weights, dtype=np.float64)
    one_d = x.ndim == 1
    x2 = x[:, None] if one_d else x
    m, n = x2.shape[0], fw.size
    size1 = n // 2
    cols = np.zeros((x2.shape[1], m + n - 1))  # columns as rows: one long loop per column (same operations)
    cols[:, size1:size1 + m] = x2.T
    sym = _symmetry(fw)
    out = np.empty((x2.shape[1], m))
    for lo in range(0, m, CORRELATE_BLOCK):
        hi = min(m, lo + CORRELATE_BLOCK)
        out[:, lo:hi] = _correlate(lambda shift: cols[:, size1 + shift + lo:size1 + shift + hi], fw, sym)
    return out[0] if one_d else out.T


@lru_cache(maxsize=64)
def savgol_coeffs(window_length: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """``scipy.signal.savgol_coeffs(window_length, polyorder, deriv, delta)`` (use="conv"), same bits."""
    if polyorder >= window_length:
        raise ValueError("polyorder must be less than window_length.")
    if deriv > polyorder:
        return np.zeros(window_length)
    halflen, rem = divmod(window_length, 2)
    pos = halflen if rem else halflen - 0.5
    x = np.flip(np.arange(-pos, window_length - pos, dtype=np.float64))
    A = x ** np.arange(polyorder + 1, dtype=np.float64).reshape(-1, 1)
    y = np.zeros(polyorder + 1)
    y[deriv] = float(factorial(deriv)) / (delta ** deriv)
    coeffs, _ = _lstsq(A, y, np.finfo(np.float64).eps * max(A.shape))
    coeffs.setflags(write=False)
    return coeffs


def _polyfit_edge(xe: np.ndarray, polyorder: int, deriv: int, delta: float, positions: np.ndarray) -> np.ndarray:
    """scipy.signal's ``_fit_edge``: fit a polynomial to the rows of ``xe`` (n, C) at 0..n-1 and
    evaluate its ``deriv``-th derivative at ``positions`` (same operations, same bits)."""
    n = xe.shape[0]
    xs = np.arange(0, n, dtype=xe.dtype)
    order = polyorder + 1
    lhs = xs[:, None] ** np.flip(np.arange(order, dtype=xs.dtype))[None, :]
    scale = np.sqrt(np.sum(lhs * lhs, axis=0))
    lhs /= scale
    c, _ = _lstsq(lhs, xe, n * np.finfo(xs.dtype).eps)
    c = (c.T / scale).T
    if deriv > 0:
        m = c.shape[0]
        if m <= deriv:
            c = np.zeros_like(c[:1])
        else:
            dp = np.array(c[:-deriv], copy=True)
            for k in range(deriv):
                dp *= np.arange(m - k - 1, deriv - k - 1, -1, dtype=c.dtype).reshape((m - deriv,) + (1,) * (c.ndim - 1))
            c = dp
    pos = np.asarray(positions, dtype=c.dtype).reshape(-1, 1)
    y = np.zeros_like(pos)
    for j in range(c.shape[0]):
        y = y * pos + c[j]
    return y / (delta ** deriv)


def savgol_at(x: np.ndarray, window_length: int, polyorder: int, idx: np.ndarray, deriv: int = 0,
              delta: float = 1.0) -> np.ndarray:
    """``savgol_filter(x, window_length, polyorder, deriv, delta, axis=0, mode="interp")[idx]``.

    ``x`` (m,) or (m, C) float64, ``idx`` integer rows in 0..m-1 (any order). Cost: O(len(idx) x
    window) instead of O(m x window)."""
    return savgol_at_derivs(x, window_length, polyorder, idx, (deriv,), delta)[0]


def savgol_at_derivs(x: np.ndarray, window_length: int, polyorder: int, idx: np.ndarray, derivs=(0,),
                     delta: float = 1.0) -> list[np.ndarray]:
    """:func:`savgol_at` of the same ``x`` for each derivative order in ``derivs`` (a list, same
    order): the rows the filters read are gathered once for all of them."""
    x = np.asarray(x, dtype=np.float64)
    one_d = x.ndim == 1
    if one_d:
        x = x[:, None]
    m = x.shape[0]
    n = int(window_length)
    if n > m:
        raise ValueError("If mode is 'interp', window_length must be less than or equal to the size of x.")
    idx = np.asarray(idx, dtype=np.int64)
    half = n // 2
    inner = (idx >= half) & (idx <= m - 1 - half)
    p = idx[inner]
    head = idx < half
    tail = idx > m - 1 - half
    at = blocks = None
    if p.size:
        step = int(p[1] - p[0]) if p.size > 1 else 1
        if step > 0 and p[-1] == p[0] + step * (p.size - 1) and np.all(np.diff(p) == step):
            at, blocks = _phase_rows(x, int(p[0]) - half, step, p.size, n), True
        else:
            def at(shift: int) -> np.ndarray:
                return x[p + shift]
            blocks = False
    outs = []
    for deriv in derivs:
        out = np.empty((idx.size, x.shape[1]))
        fw = savgol_coeffs(n, polyorder, deriv, delta)[::-1]  # convolve1d correlates with the reversed taps
        sym = _symmetry(fw)
        if blocks:  # (C, count) rows in cache-sized blocks, each sample's sum as in one pass
            acc = np.empty((x.shape[1], p.size))
            for lo in range(0, p.size, CORRELATE_BLOCK):
                hi = min(p.size, lo + CORRELATE_BLOCK)
                acc[:, lo:hi] = _correlate(lambda shift: at(shift)[:, lo:hi], fw, sym)
            out[inner] = acc.T
        elif blocks is not None:
            out[inner] = _correlate(at, fw, sym)
        if np.any(head):
            vals = _polyfit_edge(x[:n], polyorder, deriv, delta, np.arange(0, half))
            out[head] = vals[idx[head]]
        if np.any(tail):
            vals = _polyfit_edge(x[m - n:], polyorder, deriv, delta, np.arange(n - half, n))
            out[tail] = vals[idx[tail] - (m - half)]
        outs.append(out[:, 0] if one_d else out)
    return outs


def _phase_rows(x: np.ndarray, base: int, step: int, count: int, n: int):
    """``at(shift)`` = the rows x[base + half + i * step + shift], i < ``count``, |shift| <= half
    (``n`` = 2 half + 1 taps), transposed to (C, count) and contiguous.

    Why: one tap of a filter read at every ``step``-th sample is a strided view that pulls a
    whole cache line per value (a 41-tap filter at every 8th sample of 240 000 x 3 read the array
    41 times: 10-17 ms). Split once into ``step`` phases, each tap is a contiguous row slice of
    one phase: the same values, so the same operations give the same bits."""
    half = n // 2
    rows = count + (n - 1) // step + 1  # phase rows any tap reaches
    m = x.shape[0]
    need = rows * step
    if base + need <= m:
        src = x[base:base + need]
    else:  # rows past the end are never read by a tap (inner samples only): zeros keep the shape
        src = np.zeros((need, x.shape[1]))
        src[:m - base] = x[base:]
    phases = np.ascontiguousarray(src.reshape(rows, step, -1).transpose(2, 1, 0))  # (C, step, rows)

    def at(shift: int) -> np.ndarray:
        q, r = divmod(shift + half, step)
        return phases[:, r, q:q + count]
    return at


def savgol_edge_matrix(n: int, polyorder: int, positions: np.ndarray) -> np.ndarray:
    """(len(positions), n) matrix E with ``E @ y[:n]`` = the polynomial edge fit of ``y`` at
    ``positions`` (deriv 0), i.e. savgol_filter's "interp" edge values as a linear map."""
    return _polyfit_edge(np.eye(n), polyorder, 0, 1.0, np.asarray(positions))


def lag_coefficient(tau_s: float, rate_hz: float) -> float:
    """a = exp(-1 / (tau x rate)) of the discrete first-order lag; 0 for tau <= 0 (no lag)."""
    return float(np.exp(-1.0 / (tau_s * rate_hz))) if tau_s > 0 else 0.0


def scan(x: np.ndarray, A: np.ndarray) -> np.ndarray:
    """y[i] = A * y[i-1] + x[i] along axis 0 (y[-1] = 0) for per-column factors ``A`` (last axis,
    0 <= A < 1), by doubling; terms below ``LAG_TRUNCATION`` of the signal are dropped."""
    y = np.array(x, dtype=np.float64, copy=True)
    A = np.asarray(A, dtype=np.float64)
    n = y.shape[0]
    d = 1
    Ad = A.copy()
    while d < n:
        live = Ad > LAG_TRUNCATION
        if not np.any(live):
            break
        if np.all(live):
            y[d:] += Ad * y[:-d]
        else:
            cols = np.flatnonzero(live)
            if cols[-1] - cols[0] + 1 == cols.size:  # a run of columns (ascending time constants)
                sl = slice(int(cols[0]), int(cols[-1]) + 1)
                y[d:, ..., sl] += Ad[sl] * y[:-d, ..., sl]
            else:
                y[d:, ..., cols] += Ad[cols] * y[:-d, ..., cols]
        Ad = Ad * Ad
        d *= 2
    return y


def scan_inplace(y: np.ndarray, A: float) -> np.ndarray:
    """:func:`scan` with one factor ``A`` for all columns, overwriting ``y`` (and returning it)."""
    n = y.shape[0]
    d = 1
    Ad = float(A)
    while d < n and Ad > LAG_TRUNCATION:
        y[d:] += Ad * y[:-d]
        Ad *= Ad
        d *= 2
    return y


def lag(u: np.ndarray, tau_s: float, rate_hz: float) -> np.ndarray:
    """First-order lag of each column of ``u`` (m, C) started at its first value: the values of
    ``scipy.signal.lfilter([1-a], [1, -a], u, axis=0, zi=a*u[0])`` within float noise."""
    u = np.asarray(u, dtype=np.float64)
    if tau_s <= 0:
        return u
    a = lag_coefficient(tau_s, rate_hz)
    y = scan_inplace((1.0 - a) * u, a)
    # the initial state a*u[0] decays as a^(i+1) (below LAG_TRUNCATION after `live` samples)
    live = min(u.shape[0], int(np.ceil(np.log(LAG_TRUNCATION) / np.log(a))) + 1)
    decay = a ** np.arange(1, live + 1, dtype=np.float64)
    y[:live] += decay.reshape((-1,) + (1,) * (u.ndim - 1)) * u[0]
    return y


def moving_mean_nearest(x: np.ndarray, size: int) -> np.ndarray:
    """``scipy.ndimage.uniform_filter1d(x, size, axis=0, mode="nearest")`` of a float64 (m,) or
    (m, C) array, the same bits (its running sum: the first window summed in order, then one
    sample in and one out per step, divided by ``size``), without importing scipy."""
    x = np.asarray(x, dtype=np.float64)
    one_d = x.ndim == 1
    x2 = x[:, None] if one_d else x
    m = x2.shape[0]
    before = size // 2
    line = np.concatenate([np.repeat(x2[:1], before, axis=0), x2, np.repeat(x2[-1:], size - before - 1, axis=0)])
    first = np.cumsum(line[:size], axis=0)[-1:]  # cumsum adds in order, as the C loop does
    out = np.cumsum(np.concatenate([first, line[size:size + m - 1] - line[:m - 1]]), axis=0) / size
    return out[:, 0] if one_d else out
