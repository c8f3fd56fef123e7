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

from .flight import Flight, Series

PHASES = ("hover", "climb", "descent", "manoeuvre", "unknown")

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


def _window_mean(series: Optional[Series], a: float, b: float, cols=None) -> Optional[np.ndarray]:
    """Mean of the series' columns over [a, b]; None if the window holds no sample."""
    if series is None or len(series) == 0:
        return None
    i0, i1 = np.searchsorted(series.t, a, side="left"), np.searchsorted(series.t, b, side="right")
    if i1 <= i0:
        return None
    v = series.values[i0:i1] if cols is None else series.values[i0:i1, cols]
    return np.mean(v, axis=0)


def _window_rms(series: Optional[Series], a: float, b: float, cols) -> Optional[float]:
    if series is None or len(series) == 0:
        return None
    i0, i1 = np.searchsorted(series.t, a, side="left"), np.searchsorted(series.t, b, side="right")
    if i1 <= i0:
        return None
    v = series.values[i0:i1, cols]
    return float(np.sqrt(np.mean(np.sum(v * v, axis=1))))


def window_phases(flight: Flight, t_start: Sequence[float], t_end: Sequence[float]) -> list[str]:
    """One phase per window (see the module docstring for the rules and thresholds)."""
    ts = np.asarray(t_start, dtype=np.float64).reshape(-1)
    te = np.asarray(t_end, dtype=np.float64).reshape(-1)
    rates = flight.rates
    velocity = flight.velocity if flight.velocity is not None and flight.velocity.values.shape[1] >= 3 else None
    motors = flight.motors
    n_motors = motors.values.shape[1] if motors is not None else 0

    collective = np.full(ts.shape, np.nan)
    if n_motors:  # also where velocity exists: it may have gaps the motors do not
        for i, (a, b) in enumerate(zip(ts, te)):
            m = _window_mean(motors, a, b)
            if m is not None:
                collective[i] = float(np.mean(m))
    hover_collective = float(np.nanmedian(collective)) if np.any(np.isfinite(collective)) else np.nan

    phases: list[str] = []
    for i, (a, b) in enumerate(zip(ts, te)):
        rp_rms = _window_rms(rates, a, b, [0, 1]) if rates is not None and rates.values.shape[1] >= 2 else None
        if rp_rms is not None and rp_rms > MANOEUVRE_RATE_RMS_RAD_S:
            phases.append("manoeuvre")
            continue
        if velocity is not None:
            v = _window_mean(velocity, a, b, [0, 1, 2])
            if v is not None:
                if v[2] < -CLIMB_SPEED_M_S:
                    phases.append("climb")
                elif v[2] > CLIMB_SPEED_M_S:
                    phases.append("descent")
                elif float(np.hypot(v[0], v[1])) > HOVER_MAX_HSPEED_M_S:
                    phases.append("manoeuvre")
                else:
                    phases.append("hover")
                continue
        if np.isfinite(collective[i]) and np.isfinite(hover_collective) and hover_collective > 0:
            rel = (collective[i] - hover_collective) / hover_collective
            phases.append("climb" if rel > COLLECTIVE_CLIMB_DELTA
                          else "descent" if rel < -COLLECTIVE_CLIMB_DELTA else "hover")
            continue
        phases.append("hover" if rp_rms is not None else "unknown")
    return phases
