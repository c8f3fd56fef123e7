"""Flight phase of each window: "hover", "climb", "descent", "manoeuvre" (or "unknown").

Inputs: a :class:`~flightlog_fd.flight.Flight` and window bounds ``t_start``, ``t_end`` in seconds
on the log's clock. Output: one phase string per window, so a pilot can see whether a damaged
verdict rests on steady hover (most trustworthy) or on manoeuvres.

Rules, first match wins:

1. **manoeuvre** when the body roll/pitch rate RMS over the window exceeds
   ``MANOEUVRE_RATE_RMS_RAD_S`` (0.6 rad/s ~ 34 deg/s: far above hover gyro noise of a few
   deg/s, typical of a deliberate turn or attitude change).
2. With NED velocity (``Flight.velocity``; z down): mean vertical speed below
   ``-CLIMB_SPEED_M_S`` is **climb**, above ``+CLIMB_SPEED_M_S`` is **descent**; a horizontal
   speed above ``HOVER_MAX_HSPEED_M_S`` is **manoeuvre** (moving flight, not a hover); else **hover**.
3. Without velocity: the collective (mean of the motor commands) in the window compared with the
   flight's typical hover collective (its median over all windows): more than
   ``COLLECTIVE_CLIMB_DELTA`` above it (relative) is **climb**, that much below is **descent**,
   else **hover**. A quad needs extra thrust only while accelerating upwards, so this is coarse:
   it marks the start of a climb and the braking at the end of a descent best.
4. **hover** when only the rates are there and they are calm; **unknown** when the window holds
   no samples of any of these streams.

Limits: yaw rate is ignored (a slow yaw turn in place is still a hover); motor commands of kind
``"signal"`` are compared as they are (the thrust curve is monotonic, so above/below still holds).
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .flight import Series


#: Roll/pitch rate RMS (rad/s) above which a window is a manoeuvre whatever else it is.
MANOEUVRE_RATE_RMS_RAD_S = 0.6
#: Mean vertical speed (m/s) beyond which a window is a climb or a descent (PX4's hover
#: position controller holds altitude within a few dm/s).
CLIMB_SPEED_M_S = 0.5
#: Horizontal speed (m/s) above which the vehicle is travelling, not hovering.
HOVER_MAX_HSPEED_M_S = 1.0
#: Relative collective change versus the flight's median that marks a climb or descent when no
#: velocity is logged (8 % of hover thrust is a vertical acceleration of about 0.8 m/s^2).
COLLECTIVE_CLIMB_DELTA = 0.08


def _window_sums(values: np.ndarray, t: np.ndarray, ts: np.ndarray, te: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per window [ts, te] the sum of ``values`` rows whose time lies inside, and their count.

    One ``np.add.reduceat`` over all windows (rows added in order, as ``np.mean`` over axis 0
    does) instead of one slice per window: 742 windows cost ~40 ms of Python before."""
    i0 = np.searchsorted(t, ts, side="left")
    i1 = np.searchsorted(t, te, side="right")
    ext = np.concatenate([values, np.zeros((1,) + values.shape[1:], dtype=values.dtype)])  # index len(t) is valid
    idx = np.empty(2 * ts.size, dtype=np.intp)
    idx[0::2], idx[1::2] = i0, i1
    sums = np.add.reduceat(ext, idx, axis=0)[0::2] if ts.size else np.zeros((0,) + values.shape[1:])
    return sums, i1 - i0


def _window_means(series: Optional[Series], ts: np.ndarray, te: np.ndarray, cols=None) -> Optional[tuple]:
    """(means (W, C), has (W,)): each window's column means over [a, b] (``has`` False where the
    window holds no sample); None without the series."""
    if series is None or len(series) == 0:
        return None
    v = series.values if cols is None else series.values[:, cols]
    sums, n = _window_sums(np.asarray(v, dtype=np.float64), series.t, ts, te)
    has = n > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        means = sums / np.where(has, n, 1)[:, None]
    return means, has


def _window_rms(series: Optional[Series], ts: np.ndarray, te: np.ndarray, cols) -> Optional[tuple]:
    """(rms (W,), has (W,)) of the 2-norm of the columns ``cols`` per window; None without the series."""
    if series is None or len(series) == 0:
        return None
    v = series.values[:, cols]
    sums, n = _window_sums(np.sum(v * v, axis=1), series.t, ts, te)
    has = n > 0
    return np.sqrt(sums / np.where(has, n, 1)), has


def window_phases(flight, t_start: Sequence[float], t_end: Sequence[float]) -> list[str]:
    """One phase per window (see the module docstring for the rules and thresholds).
    ``flight``: a Flight or a :class:`~flightlog_fd.prepared.PreparedFlight`."""
    flight = getattr(flight, "flight", flight)  # a PreparedFlight's own Flight
    ts = np.asarray(t_start, dtype=np.float64).reshape(-1)
    te = np.asarray(t_end, dtype=np.float64).reshape(-1)
    rates = flight.rates
    velocity = flight.velocity if flight.velocity is not None and flight.velocity.values.shape[1] >= 3 else None
    motors = flight.motors
    n_motors = motors.values.shape[1] if motors is not None else 0

    collective = np.full(ts.shape, np.nan)
    if n_motors:  # also where velocity exists: it may have gaps the motors do not
        got = _window_means(motors, ts, te)
        if got is not None:
            m, has = got
            collective[has] = m[has].mean(axis=1)
    hover_collective = float(np.nanmedian(collective)) if np.any(np.isfinite(collective)) else np.nan

    rms = _window_rms(rates, ts, te, [0, 1]) if rates is not None and rates.values.shape[1] >= 2 else None
    vel = _window_means(velocity, ts, te, [0, 1, 2]) if velocity is not None else None
    # The rules below, in their order, for all windows at once (the first rule that applies wins).
    w = ts.size
    has_rms = rms[1].astype(bool) if rms is not None else np.zeros(w, dtype=bool)
    rp = np.where(has_rms, rms[0], np.nan) if rms is not None else np.full(w, np.nan)
    has_vel = vel[1].astype(bool) if vel is not None else np.zeros(w, dtype=bool)
    v = vel[0] if vel is not None else np.zeros((w, 3))
    hover_known = bool(np.isfinite(hover_collective) and hover_collective > 0)
    by_collective = np.isfinite(collective) if hover_known else np.zeros(w, dtype=bool)
    with np.errstate(invalid="ignore"):
        rel = (collective - hover_collective) / hover_collective if hover_known else np.zeros(w)
        rules = [
            (has_rms & (rp > MANOEUVRE_RATE_RMS_RAD_S), "manoeuvre"),
            (has_vel & (v[:, 2] < -CLIMB_SPEED_M_S), "climb"),
            (has_vel & (v[:, 2] > CLIMB_SPEED_M_S), "descent"),
            (has_vel & (np.hypot(v[:, 0], v[:, 1]) > HOVER_MAX_HSPEED_M_S), "manoeuvre"),
            (has_vel, "hover"),
            (by_collective & (rel > COLLECTIVE_CLIMB_DELTA), "climb"),
            (by_collective & (rel < -COLLECTIVE_CLIMB_DELTA), "descent"),
            (by_collective, "hover"),
            (has_rms, "hover"),
        ]
    names = [name for _, name in rules] + ["unknown"]
    first = np.full(w, len(rules))
    for i in range(len(rules) - 1, -1, -1):
        first[rules[i][0]] = i
    return [names[i] for i in first.tolist()]
