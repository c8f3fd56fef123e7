"""Steady-hover segments of a flight (for the motor-imbalance ratios rho of the calibration profile).

Input: a :class:`~flightlog_fd.flight.Flight` with angular rates and motor commands (attitude and
NED velocity are used where the log has them). The streams are put on a 50 Hz grid by
:func:`flightlog_fd.prepared.resample` (airborne only, 1 s trimmed after take-off and before
landing, split at data gaps, gyro smoothed by the 0.1 s Savitzky-Golay filter, slow motor streams
interpolated - so 10 Hz motor logs work), then every grid point is judged on a centred
``HOVER_WINDOW_S`` (1 s) moving window. A point is steady when ALL of these hold:

- angular-rate RMS (3 axes, smoothed gyro) <= ``HOVER_MAX_RATE_RMS`` = 0.15 rad/s (8.6 deg/s).
  Why: the smoothed hover noise is ~4.7 deg/s (3-axis) for SIH at 50 Hz (6/2.6/1.3 deg/s raw)
  and ~1.5 deg/s for a Crazyflie (2 deg/s raw), while a yaw turn in place or any manoeuvre is
  >= 20 deg/s. A yaw turn needs yaw torque, i.e. a CW/CCW imbalance rho must not see.
- |mean angular acceleration| (3-axis norm of the 1 s mean) <= ``HOVER_MAX_MEAN_ANG_ACC`` =
  0.3 rad/s^2: the rate is not drifting (the mean, not the RMS, because the derivative of a
  noisy gyro is noise-dominated sample by sample: ~1.7 rad/s^2 for SIH at 50 Hz).
- total thrust steady: std / mean of the summed thrust proxy <= ``HOVER_MAX_THROTTLE_CV`` = 0.05
  (a climb/descent start or a brake changes the collective by 10 % or more).
- level: |roll| and |pitch| (1 s means) <= ``HOVER_MAX_TILT_RAD`` = 0.12 rad (6.9 deg) where the
  log has attitude: cruising at speed needs tilt, a hover needs only the trim tilt (a few deg).
- slow: 3-D speed (1 s mean) <= ``HOVER_MAX_SPEED_M_S`` = 1.5 m/s where the log has velocity
  (grid points outside the velocity stream's coverage or inside its gaps fall back on tilt).
  Why 1.5 and not ~0: what rho must not see is a manoeuvre or rotor-drag moments, and below
  1.5 m/s the advance ratio of a small propeller (tip speed >= 60 m/s) is < 0.025, so the
  flapping/drag moments are a few % of the yaw-trim imbalance we measure; real pilots rarely
  hold a GPS-perfect hover (the Erle-Copter logs drift at ~1 m/s all flight), SIH cruises at
  2-5 m/s and climbs at 2.5 m/s, which stay excluded.

Runs of steady points at least ``min_duration_s`` (default ``HOVER_MIN_DURATION_S`` = 2 s) long
are hover segments. Their mean motor commands are taken from the RAW motor samples inside the
segment (not the interpolated grid) where there are at least ``MIN_RAW_MOTOR_SAMPLES``.

Limits: a slow, level, constant-speed translation with no velocity logged counts as hover (it is
steady flight too, and balanced the same way); strong steady wind makes a hover tilted and may
exclude it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .filters import moving_mean_nearest
from .prepared import resample

from .streams import DEFAULT_MAX_GAP_S, DEFAULT_SAVGOL_WINDOW_S, DEFAULT_TRIM_S, flight_thrust_proxy
from .flight import Flight
from .prepared import PreparedFlight

#: Grid rate (Hz) of the steadiness tests.
HOVER_GRID_HZ = 50.0
#: Centred moving window (s) over which steadiness is judged.
HOVER_WINDOW_S = 1.0
#: Thresholds (see module docstring for why).
HOVER_MAX_RATE_RMS = 0.25  # rad/s
HOVER_MAX_MEAN_ANG_ACC = 0.3  # rad/s^2
HOVER_MAX_THROTTLE_CV = 0.05  # std / mean of the total thrust
HOVER_MAX_TILT_RAD = 0.12  # rad
HOVER_MAX_SPEED_M_S = 1.5  # m/s
HOVER_MIN_DURATION_S = 2.0  # s
#: Fewest raw motor samples for the segment mean to come from the raw stream (else the grid).
MIN_RAW_MOTOR_SAMPLES = 5


@dataclass
class HoverSegment:
    """One steady hover: [t0, t1] on the log clock, mean motor commands (as logged, 0..1), the
    mean thrust proxy and speed proxy (sqrt of thrust) per motor, and ``throttle`` = mean thrust
    proxy over the motors (thrust units, comparable with PX4 MPC_THR_HOVER / ArduPilot
    MOT_THST_HOVER)."""

    t0: float
    t1: float
    mean_motors: np.ndarray  # (n,)
    throttle: float
    mean_thrust: np.ndarray  # (n,)
    mean_speed: np.ndarray  # (n,)

    @property
    def duration_s(self) -> float:
        return float(self.t1 - self.t0)


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    return moving_mean_nearest(x, n)


def _steady_mask(flight, t: np.ndarray, rates: np.ndarray, ang_acc: np.ndarray, w_sq: np.ndarray,
                 attitude: np.ndarray, n: int, max_rate_rms: float, max_tilt: float, max_speed: float) -> np.ndarray:
    rate_rms = np.sqrt(_moving_mean(np.sum(rates * rates, axis=1), n))
    mean_acc = np.linalg.norm(_moving_mean(ang_acc, n), axis=1)
    total = np.sum(w_sq, axis=1)
    m1 = _moving_mean(total, n)
    m2 = _moving_mean(total * total, n)
    cv = np.sqrt(np.maximum(m2 - m1 * m1, 0.0)) / np.maximum(m1, 1e-9)
    ok = (rate_rms <= max_rate_rms) & (mean_acc <= HOVER_MAX_MEAN_ANG_ACC) & (cv <= HOVER_MAX_THROTTLE_CV)

    level = np.ones(t.shape, dtype=bool)
    if np.all(np.isfinite(attitude)):
        tilt = np.abs(_moving_mean(attitude, n))
        level = np.all(tilt <= max_tilt, axis=1)
    prep = flight
    flight = prep.flight
    if flight.velocity is not None and len(flight.velocity) >= 2 and flight.velocity.values.shape[1] >= 3:
        vel = prep.clean("velocity", DEFAULT_MAX_GAP_S, 3)
        has_vel = vel.valid_at(t)
        if np.any(has_vel):
            speed = np.linalg.norm(vel.interp(t), axis=1)
            slow = _moving_mean(speed, n) <= max_speed
            # where velocity is known it decides together with tilt; elsewhere tilt alone
            level = level & np.where(has_vel, slow, True)
    return ok & level


def motor_count(flight: Flight) -> int:
    """Motors the hover and calibration code read: the placed frame's rotor count when it is more
    than 4 (hexa, octo), else 4."""
    f = flight.frame
    return f.rotor_count if f is not None and not f.unplaced and f.rotor_count > 4 else 4


def hover_segments(flight, min_duration_s: float = HOVER_MIN_DURATION_S,
                   max_rate_rms: float = HOVER_MAX_RATE_RMS, max_tilt_rad: float = HOVER_MAX_TILT_RAD,
                   max_speed_m_s: float = HOVER_MAX_SPEED_M_S, trim_s: float = DEFAULT_TRIM_S) -> list[HoverSegment]:
    """Steady hover segments of ``flight`` (a Flight or a :class:`~flightlog_fd.prepared.PreparedFlight`,
    whose 50 Hz segments - the NIF windows' own at the default spec - it reuses; see module
    docstring). [] when there is none.

    Raises MissingDataError / UnsupportedVehicleError (from resample) when the rates or motors are
    absent or the vehicle is not a quadrotor.
    """
    prep = PreparedFlight.of(flight)
    flight = prep.flight
    nm = motor_count(flight)
    segments = resample(prep, HOVER_GRID_HZ, DEFAULT_MAX_GAP_S, trim_s, DEFAULT_SAVGOL_WINDOW_S,
                        need_attitude=False, speed_source="command", n_motors=nm)
    n = max(1, int(round(HOVER_WINDOW_S * HOVER_GRID_HZ)))
    min_points = int(np.ceil(min_duration_s * HOVER_GRID_HZ)) + 1
    raw = flight.motors
    raw_thrust = flight_thrust_proxy(flight, raw.values[:, :nm])
    out: list[HoverSegment] = []
    for seg in segments:
        if len(seg) < min_points:
            continue
        mask = _steady_mask(prep, seg.t, seg.rates, seg.ang_acc, seg.w_sq, seg.attitude, n,
                            max_rate_rms, max_tilt_rad, max_speed_m_s)
        d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
        for lo, hi in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            if hi - lo < min_points:
                continue
            t0, t1 = float(seg.t[lo]), float(seg.t[hi - 1])
            sel = (raw.t >= t0) & (raw.t <= t1) & np.all(np.isfinite(raw.values[:, :nm]), axis=1)
            if np.count_nonzero(sel) >= MIN_RAW_MOTOR_SAMPLES:
                cmd, thrust = raw.values[sel, :nm], raw_thrust[sel]
            else:
                cmd, thrust = seg.motors[lo:hi], seg.w_sq[lo:hi]
            mean_thrust = thrust.mean(axis=0)
            out.append(HoverSegment(t0=t0, t1=t1, mean_motors=cmd.mean(axis=0), throttle=float(mean_thrust.mean()),
                                    mean_thrust=mean_thrust, mean_speed=np.sqrt(np.clip(thrust, 0, None)).mean(axis=0)))
    return out


def hover_seconds(segments: list[HoverSegment]) -> float:
    """Total duration of hover segments (s)."""
    return float(sum(s.duration_s for s in segments))


def hover_summary(flight: Flight, segments: Optional[list[HoverSegment]] = None) -> str:
    """One line for reports and benchmarks: 'N hover segments, X s, throttle T'."""
    segments = hover_segments(flight) if segments is None else segments
    if not segments:
        return "no steady hover"
    thr = np.average([s.throttle for s in segments], weights=[s.duration_s for s in segments])
    return f"{len(segments)} hover segments, {hover_seconds(segments):.1f} s, hover throttle {thr:.3f}"
