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





# ----------------------------------------------------------------------------- airborne from the IMU

#: Window (s) of the IMU's airborne test.
IMU_WINDOW_S = 2.0
#: Low-pass (Hz) separating the vehicle's motion (below: attitude and body-rate changes, gravity)
#: from the motors' vibration (above: ArduPilot's VIBE floor filter, 5 Hz).
IMU_FLOOR_HZ = 5.0
#: Motors running: the accelerometer's vibration above IMU_FLOOR_HZ (RMS, all axes) reaches this
#: many times the log's resting level (its quietest IMU_REST_QUANTILE of windows, at most
#: IMU_REST_MAX: a resting MEMS accelerometer reads 0.01-0.05 m/s/s). A log that never rests (it
#: starts in flight) counts every window as running.
IMU_RUNNING_FACTOR = 2.0
IMU_REST_QUANTILE = 0.1
IMU_REST_MAX = 0.1
#: Flying: the body rates (the gyro below IMU_FLOOR_HZ) move by this much (std within a window,
#: deg/s): a vehicle on the ground, motors running or not, is held still by it. Measured on the 45
#: real logs whose land detector is known (results/vibration.md, "airborne from the IMU"): 5 % of
#: airborne windows below 3.1 deg/s, half the running-on-the-ground windows below 0.65.
IMU_MIN_MOTION_DPS = 2.0
#: Flying windows closer than this (s) join; a stretch shorter than this is not a flight.
IMU_MERGE_S = 4.0
IMU_MIN_FLIGHT_S = 5.0
#: Stream rate (Hz) the test needs: above twice IMU_FLOOR_HZ, with margin.
IMU_MIN_RATE_HZ = 20.0


def _window_stats(s: Series, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(window start times, RMS above IMU_FLOOR_HZ per window (all axes), std of the part below it
    per window (all axes))."""
    fs = s.rate_hz
    k = max(int(round(fs / IMU_FLOOR_HZ)), 1)
    x = s.values[:, :3]
    c = np.cumsum(np.vstack([np.zeros((1, 3)), x]), axis=0)
    lp = (c[k:] - c[:-k]) / k
    hp = x[k // 2:k // 2 + lp.shape[0]] - lp
    n = hp.shape[0] // w
    if n == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    hf = np.sqrt((hp[:n * w] ** 2).reshape(n, w, 3).mean(axis=1).sum(axis=1))
    low = lp[:n * w].reshape(n, w, 3)
    motion = np.sqrt(low.var(axis=1).sum(axis=1))
    return s.t[k // 2:k // 2 + n * w:w], hf, motion


def imu_airborne(flight: Flight) -> list[tuple[float, float]]:
    """Airborne intervals from the fastest continuous IMU alone (a log with no land detector,
    arming or motor outputs): windows where the motors run (the accelerometer's vibration,
    IMU_RUNNING_FACTOR over the log's rest) and the vehicle moves (its body rates, gravity's
    direction, IMU_MIN_MOTION_DPS), joined across IMU_MERGE_S, at least IMU_MIN_FLIGHT_S long.
    [] when the log has no gyro fit for it."""
    v = flight.vibration
    if v is None:
        return []
    imu = v.fastest("gyro", batch=False)
    if imu is None or imu.gyro.rate_hz < IMU_MIN_RATE_HZ or len(imu.gyro) < 4 * IMU_WINDOW_S * imu.gyro.rate_hz:
        return []
    g = imu.gyro
    w = max(int(round(IMU_WINDOW_S * g.rate_hz)), 4)
    t0, _, motion = _window_stats(g, w)
    flying = np.degrees(motion) >= IMU_MIN_MOTION_DPS
    a = imu.accel if imu.accel is not None else None
    if a is not None and a.rate_hz >= IMU_MIN_RATE_HZ and len(a) >= 4 * w:
        ta, hf, _ = _window_stats(a, max(int(round(IMU_WINDOW_S * a.rate_hz)), 4))
        if hf.size >= 4:
            rest = float(np.quantile(hf, IMU_REST_QUANTILE))
            running = hf >= IMU_RUNNING_FACTOR * rest if rest <= IMU_REST_MAX else np.ones(hf.size, bool)
            flying &= np.interp(t0, ta, running.astype(float), left=0.0, right=0.0) > 0.5
    dt = w / g.rate_hz
    spans: list[list[float]] = []
    for s0 in t0[flying]:
        if spans and s0 - spans[-1][1] <= IMU_MERGE_S:
            spans[-1][1] = s0 + dt
        else:
            spans.append([s0, s0 + dt])
    return [(float(x), float(y)) for x, y in spans if y - x >= IMU_MIN_FLIGHT_S]


def with_imu_airborne(flight: Flight) -> Flight:
    """The flight with its airborne time from the IMU (:func:`imu_airborne`) when the log gave
    none and has nothing better to find it from (no motor outputs); the source says so."""
    if flight.airborne or flight.motors is not None:
        return flight
    air = imu_airborne(flight)
    if air:
        flight.warnings = [w for w in flight.warnings if "airborne time estimated from throttle" not in w]
        flight.airborne = air
        flight.airborne_source = "IMU: the motors running (vibration) and the vehicle moving (gyro)"
        flight.warnings.append(f"no land detector, arming state or motor outputs: airborne time ({sum(b - a for a, b in air):.0f} s) "
                               "estimated from the IMU (the motors' vibration, gravity and motion)")
    return flight

__all__ = ["split_flights", "flight_bounds", "part_of", "imu_airborne", "with_imu_airborne", "SPLIT_GROUND_S",
           "PART_MARGIN_S"]
