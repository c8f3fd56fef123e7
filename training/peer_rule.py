"""The peer rule: the rule-based baseline the DCNN is compared against.

A motor is flagged when its mean command in steady flight exceeds the mean of the other motors'
by more than ``THRESHOLD`` (fraction of full scale), after subtracting the offsets a healthy
flight of the same airframe shows (its per-motor mean minus the mean of all four). Steady flight
is the hover segments of :func:`flightlog_fd.hover.hover_segments`; a flight without any falls
back to all airborne time (and says so).

Inputs: `Flight` objects; commands as logged (``Flight.motors``, 0..1). One verdict per flight:
the motor with the largest excess if it exceeds the threshold, else healthy (0).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flightlog_fd.flight import Flight
from flightlog_fd.hover import hover_segments

THRESHOLD = 0.05


@dataclass
class PeerRuleResult:
    motor: int  # 0 healthy, k flagged
    excess: np.ndarray  # (4,) command excess of each motor over the others' mean
    steady_s: float
    source: str  # "hover" or "airborne"


def steady_means(flight: Flight) -> tuple[np.ndarray, float, str]:
    """Mean command per motor over steady flight (the hover segments' means, weighted by their
    durations), else over all airborne time."""
    segs = hover_segments(flight)
    if segs:
        durations = np.array([s.duration_s for s in segs])
        means = np.average(np.stack([s.mean_motors for s in segs]), axis=0, weights=durations)
        return means, float(durations.sum()), "hover"
    m = flight.motors
    mask = np.zeros(len(m.t), bool)
    for a, b in flight.airborne:
        mask |= (m.t >= a) & (m.t <= b)
    vals = m.values[mask][:, :4]
    vals = vals[np.isfinite(vals).all(1)]
    if len(vals) == 0:
        return np.full(4, np.nan), 0.0, "airborne"
    return vals.mean(0), float(sum(b - a for a, b in flight.airborne)), "airborne"


def healthy_offsets(flight: Flight) -> np.ndarray:
    """Per-motor offset of a healthy flight: its steady mean minus the mean of all four motors."""
    means, _, _ = steady_means(flight)
    return means - means.mean()


def peer_rule(flight: Flight, offsets: np.ndarray | None = None, threshold: float = THRESHOLD) -> PeerRuleResult:
    means, steady_s, source = steady_means(flight)
    c = means - (offsets if offsets is not None else 0.0)
    excess = np.array([c[i] - np.delete(c, i).mean() for i in range(4)])
    k = int(np.nanargmax(excess)) if np.isfinite(excess).any() else -1
    motor = k + 1 if k >= 0 and excess[k] > threshold else 0
    return PeerRuleResult(motor, excess, steady_s, source)
