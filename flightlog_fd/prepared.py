"""One prepared flight per diagnosis: what the windows, the phases, the hover finder and the
effectiveness fit share, derived once.

What: :class:`PreparedFlight` wraps a :class:`~flightlog_fd.flight.Flight` and memoises the
work its consumers share: the cleaned streams (rates, motors, attitude
unwrapped, velocity), the thrust-proxy stream (:func:`flightlog_fd.streams.flight_thrust_proxy`),
the airborne :class:`~flightlog_fd.streams.Segment` s on a model grid (one list per resampling
setting), the gyro low-pass cutoff and the effectiveness fit's fine-grid commands (keyed by the
segments they were made for).

Inputs: a Flight that is not changed afterwards (the memo does not watch it). Every function
that takes a Flight for these steps (:func:`resample`, ``windows.make_windows``,
``analyzers.effectiveness_fit.estimate_effectiveness``, ``hover.hover_segments``) also takes a PreparedFlight;
given a plain Flight it prepares one for that call only, with the same numbers.

Why: the steps re-derived what another had just made (the effectiveness fit cleaned the motor
stream and rebuilt the thrust proxy again, the hover finder resampled the flight again), and
each entry point took a Flight, so nothing could be shared; ``diagnose`` took 4-6x the time to
load a 600 s log (``benchmarks/bench_diagnose.py``).

Layer: above :mod:`flightlog_fd.streams` (whose steps it memoises), below the windows, the
hover finder and the estimators.

Limits: memory grows with the settings asked for (one segment list per setting: a 600 s flight
at 50 Hz is ~2 MB each).
"""
from __future__ import annotations

from typing import Any, Callable, Hashable, Optional, Union

import numpy as np

from .flight import Flight
from .streams import (DEFAULT_MAX_GAP_S, DEFAULT_RATE_HZ, DEFAULT_SAVGOL_WINDOW_S, DEFAULT_TRIM_S, GridRuns, Segment,
                      Stream, clean_stream, grid_runs, gyro_cutoff_hz, resample_streams, speed_stream)


class PreparedFlight:
    """A flight and its derived streams, each computed on first use (see the module docstring)."""

    def __init__(self, flight: Flight) -> None:
        if isinstance(flight, PreparedFlight):
            raise TypeError("already prepared")
        self.flight = flight
        self._memo: dict = {}

    @classmethod
    def of(cls, flight: Union[Flight, "PreparedFlight"]) -> "PreparedFlight":
        """``flight`` itself when it is prepared already, else a new PreparedFlight for it."""
        return flight if isinstance(flight, PreparedFlight) else cls(flight)

    def memo(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """The value stored under ``key``, made by ``make()`` the first time."""
        try:
            return self._memo[key]
        except KeyError:
            value = self._memo[key] = make()
            return value

    # ------------------------------------------------------------------ streams
    def clean(self, name: str, max_gap_s: float, columns: int):
        """``streams.clean_stream(flight.<name>, max_gap_s, columns)``, memoised (do not modify it)."""
        return self.memo(("clean", name, max_gap_s, columns),
                         lambda: clean_stream(getattr(self.flight, name), max_gap_s, columns))

    def attitude(self, max_gap_s: float):
        """The cleaned roll/pitch stream unwrapped (see streams.resample_streams), or None without one."""
        def make():
            att = self.flight.attitude
            if att is None or len(att) < 2 or att.values.shape[1] < 2:
                return None
            s = self.clean("attitude", max_gap_s, 2)
            # np.unwrap changes nothing when no step exceeds pi (it then costs ~7 ms on 600 s at 250 Hz).
            # The steps are taken on the contiguous copy: on the strided roll/pitch columns of the
            # (n, 3) attitude they cost 4-5 ms of a 600 s 400 Hz log, on the copy under 1 ms.
            v = np.array(s.v, dtype=np.float64)
            steps = np.abs(np.diff(v, axis=0))
            if steps.size and steps.max() > np.pi:
                v = np.unwrap(v, axis=0)
            return Stream(s.t, v, s.gap_s, s.median_dt)
        return self.memo(("attitude", max_gap_s), make)

    def speed_stream(self, speed_source: str, rate_hz: float, max_gap_s: float, n_motors: int = 4):
        """``streams.speed_stream`` (the thrust-proxy stream and its source), memoised."""
        return self.memo(("speed", speed_source, rate_hz, max_gap_s, n_motors),
                         lambda: speed_stream(self.flight, speed_source, rate_hz, max_gap_s, n_motors))

    # ------------------------------------------------------------------ grids
    def grid_runs(self, rate_hz: float, max_gap_s: float, trim_s: float, savgol_window_s: float,
                  need_attitude: bool = False, speed_source: str = "command", n_motors: int = 4) -> GridRuns:
        """:func:`streams.grid_runs` with these settings (where the segments lie), computed once."""
        key = ("grid_runs", float(rate_hz), float(max_gap_s), float(trim_s), float(savgol_window_s),
               bool(need_attitude), speed_source, int(n_motors))
        return self.memo(key, lambda: grid_runs(self, float(rate_hz), max_gap_s, trim_s, savgol_window_s,
                                                need_attitude, speed_source, n_motors))

    def segments(self, rate_hz: float, max_gap_s: float, trim_s: float, savgol_window_s: float,
                 need_attitude: bool = False, speed_source: str = "command", n_motors: int = 4) -> list:
        """:func:`resample` with these settings, computed once (shared list: do not modify)."""
        key = ("segments", float(rate_hz), float(max_gap_s), float(trim_s), float(savgol_window_s),
               bool(need_attitude), speed_source, int(n_motors))
        return self.memo(key, lambda: resample_streams(self, float(rate_hz), max_gap_s, trim_s, savgol_window_s,
                                                need_attitude, speed_source, n_motors))

    @property
    def gyro_cutoff_hz(self) -> Optional[float]:
        """The autopilot's gyro low-pass cutoff (Hz) from the log's parameters, or None."""
        return self.memo("gyro_cutoff_hz", lambda: gyro_cutoff_hz(self.flight))



def segment_times(flight: Union[Flight, PreparedFlight], rate_hz: float = DEFAULT_RATE_HZ,
                  max_gap_s: float = DEFAULT_MAX_GAP_S, trim_s: float = DEFAULT_TRIM_S,
                  savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S, need_attitude: bool = False,
                  speed_source: str = "command", n_motors: int = 4) -> list[np.ndarray]:
    """The times of the segments :func:`resample` makes with these settings, without resampling
    or filtering anything (the same runs, shared through a PreparedFlight); raises as it does."""
    return PreparedFlight.of(flight).grid_runs(rate_hz, max_gap_s, trim_s, savgol_window_s, need_attitude,
                                               speed_source, n_motors).times()


def resample(flight: Union[Flight, PreparedFlight], rate_hz: float = DEFAULT_RATE_HZ,
             max_gap_s: float = DEFAULT_MAX_GAP_S, trim_s: float = DEFAULT_TRIM_S,
             savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S, need_attitude: bool = False,
             speed_source: str = "command", n_motors: int = 4) -> list[Segment]:
    """Gap-free airborne :class:`~flightlog_fd.streams.Segment` s on a uniform grid at ``rate_hz``
    (:mod:`flightlog_fd.streams`).

    ``flight``: a Flight or a PreparedFlight (which computes each setting once and shares the
    list: callers must not modify it). Needed streams: rates, motors (or ESC rpm) and, if
    ``need_attitude``, attitude; a gap in any of them splits the segment. Raises MissingDataError /
    UnsupportedVehicleError when a needed stream is absent or the vehicle does not have
    ``n_motors`` rotors (4: a quadrotor); returns [] when nothing is airborne.
    """
    return PreparedFlight.of(flight).segments(rate_hz, max_gap_s, trim_s, savgol_window_s, need_attitude,
                                              speed_source, n_motors)
