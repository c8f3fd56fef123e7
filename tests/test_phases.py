"""Flight phases per window from velocity, or from rates and collective when velocity is absent."""
from __future__ import annotations

import numpy as np

from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.phases import window_phases

RATE_HZ = 50.0


def profile_flight(with_velocity: bool) -> Flight:
    """0-10 s climb at 1.5 m/s, 10-20 s hover, 20-30 s roll manoeuvre, 30-40 s forward cruise
    at 3 m/s, 40-50 s descent at 1 m/s."""
    t = np.arange(0.0, 50.0, 1.0 / RATE_HZ)
    vel = np.zeros((t.size, 3))
    vel[t < 10, 2] = -1.5
    vel[(t >= 30) & (t < 40), 0] = 3.0
    vel[t >= 40, 2] = 1.0
    rates = np.zeros((t.size, 3))
    man = (t >= 20) & (t < 30)
    rates[man, 0] = 1.2 * np.sin(2 * np.pi * 0.5 * t[man])
    hover = 0.5
    coll = np.full(t.size, hover)
    coll[t < 10] = hover * 1.2  # climbing
    coll[t >= 40] = hover * 0.85  # descending
    return Flight(path="synthetic", autopilot="sim", frame=Frame.quad_x(),
                  rates=Series(t, rates, "rates"), motors=Series(t, np.tile(coll[:, None], (1, 4)), "motors"),
                  velocity=Series(t, vel, "vel") if with_velocity else None, t_start=0.0, t_end=50.0)


WINDOWS_T = np.array([2.0, 12.0, 22.0, 32.0, 42.0])


def test_phases_from_velocity():
    f = profile_flight(with_velocity=True)
    assert window_phases(f, WINDOWS_T, WINDOWS_T + 2.0) == ["climb", "hover", "manoeuvre", "manoeuvre", "descent"]


def test_phases_from_collective_without_velocity():
    f = profile_flight(with_velocity=False)
    # Without velocity a steady cruise looks like a hover: only the collective and rates are known.
    assert window_phases(f, WINDOWS_T, WINDOWS_T + 2.0) == ["climb", "hover", "manoeuvre", "hover", "descent"]


def test_window_without_samples_is_unknown():
    f = profile_flight(with_velocity=True)
    assert window_phases(f, [100.0], [102.0]) == ["unknown"]
    assert window_phases(f, [], []) == []
