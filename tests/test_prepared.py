"""The prepared flight and the fast filters give the numbers of the code they replace."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flightlog_fd import filters as F


@pytest.fixture(scope="module")
def flight():
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    return simulate_flights(1, damages=[Damage(2, 0.75)], duration_s=40, profile="px4_high", seed=3)[0]


@pytest.mark.parametrize("n", [5, 11, 25, 41])
@pytest.mark.parametrize("deriv, delta", [(0, 1.0), (1, 1 / 400), (1, 0.02)])
def test_savgol_at_is_scipy_bit_for_bit(n, deriv, delta):
    from scipy.signal import savgol_filter

    rng = np.random.default_rng(n)
    for m in (n, n + 2, 997):
        x = np.cumsum(rng.normal(size=(m, 3)), axis=0) * 0.01 + 0.5
        ref = savgol_filter(x, n, 2, deriv=deriv, delta=delta, axis=0)
        assert np.array_equal(F.savgol_at(x, n, 2, np.arange(m), deriv, delta), ref)
        for idx in (np.arange(0, m, 7), np.array([m - 1, 0, m // 2])):  # strided and gathered rows
            assert np.array_equal(F.savgol_at(x, n, 2, idx, deriv, delta), ref[idx])


@pytest.mark.parametrize("step", [1, 5, 8])
def test_savgol_at_derivs_long_strided_is_scipy_bit_for_bit(step):
    """Every step-th sample of a long stream (more rows than one cache block, a last phase row
    past the end), both derivatives from one gather: scipy's bits (the resampler's case)."""
    from scipy.signal import savgol_filter

    rng = np.random.default_rng(step)
    m, n, delta = 40_003, 41, 1 / 400
    x = np.cumsum(rng.normal(size=(m, 3)), axis=0) * 0.01 + 0.5
    idx = np.arange(3, m, step)
    smooth, slope = F.savgol_at_derivs(x, n, 2, idx, (0, 1), delta)
    assert np.array_equal(smooth, savgol_filter(x, n, 2, axis=0)[idx])
    assert np.array_equal(slope, savgol_filter(x, n, 2, deriv=1, delta=delta, axis=0)[idx])
    assert np.array_equal(F.savgol_at(x[:, 1], n, 2, idx, 1, delta),
                          savgol_filter(x[:, 1], n, 2, deriv=1, delta=delta)[idx])


def test_numpy_lstsq_is_scipys_on_every_savgol_shape():
    """The filters solve their small least squares with NumPy: the same bits as scipy.linalg's."""
    from math import factorial

    from scipy.linalg import lstsq

    rng = np.random.default_rng(0)
    for n in range(3, 82, 2):
        for deriv, delta in ((0, 1.0), (1, 1 / 250), (1, 1 / 400), (1, 1 / 3200), (1, 0.02)):
            x = np.flip(np.arange(-(n // 2), n - n // 2, dtype=np.float64))
            A = x ** np.arange(3, dtype=np.float64).reshape(-1, 1)
            y = np.zeros(3)
            y[deriv] = float(factorial(deriv)) / delta ** deriv
            cond = np.finfo(np.float64).eps * max(A.shape)
            assert np.array_equal(F._lstsq(A, y, cond)[0], lstsq(A, y, cond=cond)[0])
        xs = np.arange(n, dtype=np.float64)
        lhs = xs[:, None] ** np.flip(np.arange(3, dtype=np.float64))[None, :]
        lhs /= np.sqrt(np.sum(lhs * lhs, axis=0))
        xe = rng.normal(size=(n, 4))
        assert np.array_equal(F._lstsq(lhs, xe, n * np.finfo(float).eps)[0], lstsq(lhs, xe, n * np.finfo(float).eps)[0])


def test_correlate_and_moving_mean_are_scipy_ndimage_bit_for_bit():
    from scipy.ndimage import correlate1d, uniform_filter1d

    rng = np.random.default_rng(1)
    for n in (3, 5, 9, 21, 41):
        for w in (F.savgol_coeffs(n, 2)[::-1], F.savgol_coeffs(n, 2, 1, 0.004)[::-1], rng.normal(size=n),
                  rng.normal(size=n + 1)):
            for shape in ((50,), (997, 4), (n + 1, 2)):
                x = rng.normal(size=shape) * 10.0 ** rng.integers(-3, 4)
                assert np.array_equal(F.correlate1d_zero_ends(x, w), correlate1d(x, w, axis=0, mode="constant"))
    for _ in range(200):
        size, m = int(rng.integers(1, 300)), int(rng.integers(1, 2000))
        x = rng.normal(size=(m, int(rng.integers(1, 4)))) * 10.0 ** rng.integers(-6, 6) + rng.normal() * 1e3
        if rng.random() < 0.5:
            x = x[:, 0]
        assert np.array_equal(F.moving_mean_nearest(x, size), uniform_filter1d(x, size=size, axis=0, mode="nearest"))


@pytest.mark.parametrize("tau, rate", [(0.002, 400), (0.158, 400), (0.05, 50), (0.0053, 250)])
def test_lag_matches_lfilter(tau, rate):
    from scipy.signal import lfilter

    u = np.random.default_rng(1).normal(size=(5000, 4)) * 0.01 + 0.5
    a = np.exp(-1.0 / (tau * rate))
    ref, _ = lfilter([1 - a], [1, -a], u, axis=0, zi=(a * u[0])[None, :])
    assert np.max(np.abs(F.lag(u, tau, rate) - ref)) < 1e-13


@pytest.mark.parametrize("m, k, n", [(4001, 8, 41), (1001, 5, 25), (300, 1, 5), (41, 8, 41), (57, 8, 41)])
def test_many_lags_at_once_equal_one_at_a_time(m, k, n):
    """_SegmentLags (commuted filters, decimated scan, exact ends) against lag-then-smooth per lag."""
    from flightlog_fd.analyzers.effectiveness_fit import _SegmentLags

    rng = np.random.default_rng(m)
    m = (m - 1) // k * k + 1  # kept samples 0, k, ..., m-1
    u = 0.5 + np.cumsum(rng.normal(size=(m, 4)), axis=0) * 0.003
    taus = np.array([0.0, 0.002, 0.03, 0.158, 0.011])
    got = _SegmentLags(u, 50.0 * k, n, k).smoothed(taus)
    for i, tau in enumerate(taus):
        ref = F.savgol_at(F.lag(u, tau, 50.0 * k), n, 2, np.arange(0, m, k))
        assert np.max(np.abs(got[i] - ref)) < 1e-12, tau


def test_batched_lag_search_equals_one_lag_at_a_time(flight):
    """The lag search's batched commands (_SegmentLags) are the definition's, one lag at a time."""
    from flightlog_fd.analyzers import effectiveness_fit as E
    from flightlog_fd.prepared import PreparedFlight, resample
    from flightlog_fd.streams import odd_window

    prep = PreparedFlight(flight)
    segs = E._usable(E._away_from_ground(resample(prep), flight.airborne), odd_window(0.1, 50.0), 21)
    fit = E._LagFit(prep, segs, 50.0, odd_window(0.1, 50.0), 21, 0.1)
    taus = [0.0, 0.03, 0.074, 0.15]
    batched = fit.commands(taus)
    for i, tau in enumerate(taus):
        one = E._detrended_commands(segs, tau, 50.0, odd_window(0.1, 50.0), 21, fit.fine, 0.1)
        assert np.max(np.abs(batched[i] - one)) < 1e-8 * np.max(np.abs(one)), tau
    assert fit.best_lag() is not None


def test_prepared_flight_is_shared_and_changes_no_number(flight):
    from flightlog_fd.analyzers.effectiveness_fit import estimate_effectiveness
    from flightlog_fd.prepared import resample
    from flightlog_fd.windows import FeatureSpec, make_windows
    from flightlog_fd.hover import hover_segments
    from flightlog_fd.prepared import PreparedFlight

    prep = PreparedFlight(flight)
    assert PreparedFlight.of(prep) is prep
    for spec in (FeatureSpec("nif"), FeatureSpec("cf")):
        a, b = make_windows(flight, spec), make_windows(prep, spec)
        assert a.X.tobytes() == b.X.tobytes() and np.array_equal(a.t_start, b.t_start)
    # one resampling per setting: the windows, the hover finder and the effectiveness share it
    assert make_windows(prep, FeatureSpec("nif")).segments is resample(prep)
    assert [(h.t0, h.t1) for h in hover_segments(prep)] == [(h.t0, h.t1) for h in hover_segments(flight)]
    e1, e2 = estimate_effectiveness(flight), estimate_effectiveness(prep)
    assert np.array_equal(e1.values, e2.values) and e1.motor_lag_s == e2.motor_lag_s


def test_window_phases_match_the_per_window_rule(flight):
    from flightlog_fd.windows import FeatureSpec, make_windows
    from flightlog_fd.phases import window_phases

    w = make_windows(flight, FeatureSpec("nif"))
    fast = window_phases(flight, w.t_start, w.t_end)
    no_vel = dataclasses.replace(flight, velocity=None)
    assert len(fast) == len(w.t_start)
    # the reference: each window's samples by slicing, as phases.py did before the reduceat
    rates, motors = flight.rates, flight.motors
    coll = []
    for a, b in zip(w.t_start, w.t_end):
        i0, i1 = np.searchsorted(motors.t, a, "left"), np.searchsorted(motors.t, b, "right")
        coll.append(np.mean(np.mean(motors.values[i0:i1], axis=0)))
    hover = np.median(coll)
    ref = []
    for (a, b), c in zip(zip(w.t_start, w.t_end), coll):
        i0, i1 = np.searchsorted(rates.t, a, "left"), np.searchsorted(rates.t, b, "right")
        v = rates.values[i0:i1, :2]
        rms = np.sqrt(np.mean(np.sum(v * v, axis=1)))
        rel = (c - hover) / hover
        ref.append("manoeuvre" if rms > 0.6 else "climb" if rel > 0.08 else "descent" if rel < -0.08 else "hover")
    assert window_phases(no_vel, w.t_start, w.t_end) == ref
