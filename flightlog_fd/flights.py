"""Several flights in one log: each take-off to landing as its own :class:`~flightlog_fd.flight.Flight`.

A log can hold several flights (ArduPilot keeps logging across disarm/arm with LOG_DISARMED or
one file per boot: octo_air ``air_octo_03.BIN`` flies, lands, disarms, then flies again with
another propeller). A flight here is one armed interval that contains airborne time (or, without
arming data, airborne intervals separated by more than ``SPLIT_GROUND_S`` on the ground). Each part
keeps every stream between its bounds (``PART_MARGIN_S`` of ground time each side, never past the
neighbouring flight), on the log's own clock; ``Flight.part`` names it ("flight 2 of 2, 376.8-464.9 s").
"""
from __future__ import annotations

import copy
from typing import Optional

import numpy as np

from .flight import EscChannel, EscTelemetry, Flight, ImuStream, Series

#: Without arming data, airborne intervals further apart than this (s) are separate flights (a
#: touch-and-go or a landing detector blip is shorter).
SPLIT_GROUND_S = 30.0
#: Ground time (s) kept around each flight's airborne time when no armed interval bounds it.
PART_MARGIN_S = 5.0


def flight_bounds(flight: Flight) -> list[tuple[float, float]]:
    """(start, end) of each flight in the log, in time order; one entry for a single flight."""
    air = sorted(flight.airborne)
    if not air:
        return [(flight.t_start, flight.t_end)]
    groups: list[list[tuple[float, float]]] = []
    armed = sorted(flight.armed)
    for a, b in air:
        key = next((i for i, (s, e) in enumerate(armed) if s - 1e-6 <= a and b <= e + 1e-6), None)
        if groups and ((key is not None and key == groups[-1][0][2]) or
                       (key is None and a - groups[-1][-1][1] <= SPLIT_GROUND_S)):
            groups[-1].append((a, b, key))
        else:
            groups.append([(a, b, key)])
    out = []
    for g in groups:
        key = g[0][2]
        if key is not None:
            out.append(armed[key])
        else:
            out.append((max(g[0][0] - PART_MARGIN_S, flight.t_start), min(g[-1][1] + PART_MARGIN_S, flight.t_end)))
    return out


def _cut(s: Optional[Series], a: float, b: float) -> Optional[Series]:
    if s is None:
        return None
    m = (s.t >= a) & (s.t <= b)
    return Series(s.t[m], s.values[m], s.source) if m.any() else None


def _cut_esc(esc: Optional[EscTelemetry], a: float, b: float) -> Optional[EscTelemetry]:
    if esc is None:
        return None
    chans = []
    for c in esc.channels:
        m = (c.t >= a) & (c.t <= b)
        if m.any():
            chans.append(EscChannel(c.motor, c.t[m], c.rpm[m], *(None if v is None else v[m] for v in
                                                               (c.current, c.voltage, c.temperature)),
                                    online=c.online[m], esc_index=c.esc_index, source=c.source))
    return EscTelemetry(chans, esc.source, esc.units) if chans else None


def part_of(flight: Flight, a: float, b: float, label: str = "") -> Flight:
    """The flight between ``a`` and ``b`` (s): every stream cut there, intervals clipped."""
    out = copy.copy(flight)
    for name in ("rates", "attitude", "motors", "esc_rpm", "velocity", "accel"):
        setattr(out, name, _cut(getattr(flight, name), a, b))
    out.alt_motors = {k: s for k, s in ((k, _cut(s, a, b)) for k, s in flight.alt_motors.items()) if s is not None}
    out.esc = _cut_esc(flight.esc, a, b)
    if flight.vibration is not None:
        v = copy.copy(flight.vibration)
        v.metrics = {k: s for k, s in ((k, _cut(s, a, b)) for k, s in v.metrics.items()) if s is not None}
        v.clips = {k: s for k, s in ((k, _cut(s, a, b)) for k, s in v.clips.items()) if s is not None}
        v.imus = [ImuStream(i.instance, i.source, _cut(i.accel, a, b), _cut(i.gyro, a, b), i.batch) for i in v.imus]
        v.imus = [i for i in v.imus if i.accel is not None or i.gyro is not None]
        v.fft_peaks = _cut(v.fft_peaks, a, b)
        out.vibration = v if v else None
    clip = lambda iv: [(max(x, a), min(y, b)) for x, y in iv if min(y, b) > max(x, a)]  # noqa: E731
    out.armed, out.airborne = clip(flight.armed), clip(flight.airborne)
    out.t_start, out.t_end = float(max(a, flight.t_start)), float(min(b, flight.t_end))
    out.warnings = list(flight.warnings)
    out.part = label
    return out


def split_flights(flight: Flight) -> list[Flight]:
    """Each take-off to landing of the log as its own Flight (the flight itself when it holds one)."""
    bounds = flight_bounds(flight)
    if len(bounds) <= 1:
        return [flight]
    n = len(bounds)
    return [part_of(flight, a, b, f"flight {i + 1} of {n}, {a:.1f}-{b:.1f} s") for i, (a, b) in enumerate(bounds)]


__all__ = ["split_flights", "flight_bounds", "part_of", "SPLIT_GROUND_S", "PART_MARGIN_S"]
