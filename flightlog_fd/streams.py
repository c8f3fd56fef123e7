"""A flight's streams made ready for estimation: cleaned, turned into a thrust proxy and put on
one uniform airborne grid (:class:`Segment`).

Layer: above :mod:`flightlog_fd.flight`, below :mod:`flightlog_fd.prepared` (which memoises each
step here per flight and gives the public :func:`~flightlog_fd.prepared.resample`).

Pipeline (every step documented where it is implemented):

1. :func:`resample_streams` puts the needed streams on ONE uniform time grid at the model rate
   (``FeatureSpec.rate_hz``, default 50 Hz), only inside the airborne intervals, trimmed by
   ``trim_s`` (default 1 s) after take-off and before landing (ground effect, spin-up and
   touchdown transients are not what the model was trained on). Grid points are integer
   multiples of ``1 / rate_hz`` on the log's clock, so the same log always gives the same grid.
   - **Gaps**: a stream has a gap between two consecutive samples when they are further apart
     than ``min(max_gap_s, GAP_FACTOR x the longer of its median sample interval and the grid's
     interval)`` (:func:`grid_gap_s`: a stream logged faster than the grid that misses a few
     samples between two grid points still gives the grid all it keeps). No value is ever
     interpolated across a gap in ANY needed stream: the airborne interval is split there into
     separate :class:`Segment` s, and no window crosses a segment boundary. NaN samples count as
     missing (they create gaps), and so do samples beyond ``MAX_ABS_SAMPLE`` (a flipped exponent
     bit: no rate, angle, command or speed ratio comes near it).
   - **Bounded grids**: grid points are made only inside the stretches every needed stream
     covers (consecutive samples closer than its gap threshold), intersected with the airborne
     intervals - never over a span read from timestamps. So the grid has at most
     ``fine rate x gap threshold`` points per sample of the rate stream, whatever a corrupted
     timestamp says (one flipped bit once asked for a 3.28 PiB grid, another for 66 s of work);
     more than ``MAX_GRID_S`` seconds of grid (a day) is refused as not diagnosable.
   - **Slow streams** (PX4's default ``actuator_motors`` at 10 Hz, ArduPilot ``RCOU`` at 10 Hz)
     are interpolated linearly onto the faster grid. Consequence: the motor channels are a
     piecewise-linear curve through the logged points; nothing above the stream's Nyquist
     frequency (5 Hz at 10 Hz) survives, a motor step appears as a ramp lasting one logging
     interval, and an 80-sample window holds only 16 independent motor samples. A model meant
     for such logs must be trained on simulated flights logged at the same rate (the logger
     emulation does this); the damage signature (a persistent offset of one motor's share) is
     slow and survives.
2. **Angular acceleration** (p_dot, q_dot, r_dot, rad/s^2): a Savitzky-Golay derivative
   (``scipy.signal.savgol_filter``'s numbers, ``polyorder`` 2, ``deriv=1``, from
   :func:`flightlog_fd.filters.savgol_at`, which computes only the samples kept) over ``savgol_window_s``
   (default 0.1 s). Why: a plain finite difference multiplies gyro noise by ~sqrt(2)/dt
   (at 250 Hz, 6 deg/s of noise becomes ~37 rad/s^2); a local least-squares slope over 0.1 s
   cuts the noise gain by ~sqrt(6 / N^3) while keeping amplitude and phase of the slow dynamics
   (amplitude gain 0.99 at 1 Hz, 0.96 at 2 Hz, 0.78 at 5 Hz, ~0.5 at 8 Hz; zero phase: the
   filter is symmetric). Because the window is fixed in SECONDS, 50, 100 and 250 Hz logs see the
   same response within 1-3 % (computed from ``savgol_coeffs`` for 5, 11 and 25 points). Where the gyro is logged faster than the grid, the derivative is taken
   on a fine uniform grid at ``k x rate_hz`` (k = round(gyro rate / grid rate), <= 8) before
   decimation, so the extra samples reduce noise instead of aliasing into the windows; the
   rates themselves are smoothed by the same filter with ``deriv=0`` (an anti-alias filter
   with the same window). When the gyro is not faster, k = 1 and the same code runs on the
   grid itself.
3. **Thrust proxy** (:func:`thrust_proxy`): the paper's w^2 "stands for thrust"; the commanded
   speed replaces the measured speed. ``motor_kind == "thrust"``: the setpoint is linear in
   thrust and used as it is. ``"signal"`` (PWM after the autopilot's thrust curve) is mapped
   back through the curve (sources in :func:`thrust_proxy`). ``FeatureSpec.speed_source``
   chooses ``"command"`` (default: every log has it, and the simulator makes the same thing, so
   training and diagnosis agree), ``"esc_rpm"`` or ``"auto"`` (ESC rpm^2 / max rpm^2 where the log
   has rpm at >= rate_hz / 2 for every motor). :attr:`flightlog_fd.windows.Windows.speed_source` says which was used.

Also here: the autopilot's gyro low-pass cutoff from the log's parameters (:func:`gyro_cutoff_hz`),
which the effectiveness fit applies to the commands.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .errors import MissingDataError, NotDiagnosableError, UnsupportedVehicleError
from .filters import savgol_at_derivs
from .flight import Flight, Series

#: Model grid rate (Hz): the paper's 50 Hz.
DEFAULT_RATE_HZ = 50.0

#: Seconds cut after take-off and before landing: ground effect and spin-up / touchdown transients.
DEFAULT_TRIM_S = 1.0
#: A gap is a sample interval longer than GAP_FACTOR x the stream's median interval (i.e. at
#: least ~2-3 samples lost) or longer than max_gap_s, whichever is shorter.
GAP_FACTOR = 3.5
DEFAULT_MAX_GAP_S = 0.5

#: A sample value beyond this magnitude is corrupt (rad/s, rad, 0..1 commands, m/s): missing.
MAX_ABS_SAMPLE = 1e6
#: Most grid time (s) one flight may need: a day (no log spans more; see flight.MAX_LOG_SPAN_S).
MAX_GRID_S = 86400.0

#: Savitzky-Golay window (seconds) and polynomial order for the derivative and rate smoothing.
DEFAULT_SAVGOL_WINDOW_S = 0.1
SAVGOL_POLYORDER = 2
#: Fewest points a Savitzky-Golay window may have (polyorder 2 needs 3; 5 gives some smoothing).
SAVGOL_MIN_POINTS = 5
#: The fine derivative grid is at most this many times the model rate (1 kHz gyro -> 400 Hz).
MAX_FINE_FACTOR = 8

#: ArduPilot defaults used when a log lacks the parameter (AP_Motors_Thrust_Linearization.cpp).
ARDUPILOT_DEFAULT_SPIN_MIN = 0.15
ARDUPILOT_DEFAULT_SPIN_MAX = 0.95
ARDUPILOT_DEFAULT_THST_EXPO = 0.65
#: ESC rpm is used ("auto") only when at least this fraction of airborne samples is non-zero.
ESC_RPM_MIN_VALID_FRACTION = 0.9
#: Parameters naming the autopilot's gyro low-pass cutoff (Hz): the logged rates passed through it,
#: the commands did not, so the effectiveness fit gives the commands the same first-order low-pass
#: (a 2nd-order filter's low-frequency delay is close enough; its lag search absorbs the rest).
GYRO_CUTOFF_PARAMS = ("IMU_GYRO_CUTOFF", "INS_GYRO_FILTER")


def gyro_cutoff_hz(flight: Flight) -> Optional[float]:
    """The autopilot's gyro low-pass cutoff from the log's parameters, or None."""
    for name in GYRO_CUTOFF_PARAMS:
        v = flight.params.get(name)
        if v is not None and np.isfinite(v) and v > 0:
            return float(v)
    return None


@dataclass
class Segment:
    """A gap-free stretch of airborne flight on the model grid (n samples)."""

    t: np.ndarray  # (n,) s, log clock
    rates: np.ndarray  # (n, 3) p, q, r rad/s (Savitzky-Golay smoothed)
    attitude: np.ndarray  # (n, 2) roll, pitch rad (NaN when the log has no attitude)
    motors: np.ndarray  # (n, n_motors) commands 0..1 as logged
    w_sq: np.ndarray  # (n, n_motors) thrust proxy (see thrust_proxy)
    ang_acc: np.ndarray  # (n, 3) rad/s^2
    speed_source: str = "command"

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self) else 0.0





# ----------------------------------------------------------------------------- thrust proxy

def thrust_proxy(motors: np.ndarray, motor_kind: str, thrust_curve: Optional[float] = None,
                 autopilot: str = "px4", spin_min: Optional[float] = None,
                 spin_max: Optional[float] = None) -> np.ndarray:
    """Relative thrust (0..1, linear in thrust, i.e. ~ w^2) from normalised motor commands.

    - ``motor_kind == "thrust"``: a thrust setpoint (PX4 ``actuator_motors``, ArduPilot mixer
      reconstruction, simulator) is already linear in thrust: returned as it is (clipped >= 0).
    - ``motor_kind == "signal"``, PX4 (``actuator_outputs`` normalised between PWM min and max):
      PX4 ``FunctionMotors`` / ``THR_MDL_FAC`` (src/lib/mixer_module/motor_params.c) models
      ``rel_thrust = f * u^2 + (1 - f) * u`` with u the relative signal; applied as is.
    - ``motor_kind == "signal"``, ArduPilot (``RCOU`` normalised between MOT_PWM_MIN and MAX):
      ``Thrust_Linearization::thrust_to_actuator`` (AP_Motors_Thrust_Linearization.cpp) outputs
      ``u = spin_min + (spin_max - spin_min) * x`` where x solves ``e x^2 + (1-e) x = thrust``
      (e = MOT_THST_EXPO), so ``x = (u - spin_min) / (spin_max - spin_min)`` clipped to 0..1 and
      ``thrust = e x^2 + (1 - e) x``. ArduPilot's battery-voltage scaling (lift_max) is not undone:
      it scales all motors alike, which the scale-free transform cancels.
    ``thrust_curve`` None means 0 for PX4 (its default) and 0.65 for ArduPilot (its default);
    ArduCopter <= 3.3 logs (older ``MOT_TCRV_*`` curve, no MOT_THST_EXPO) get these defaults too,
    an approximation of their curve that is the same for all motors.
    """
    u = np.asarray(motors, dtype=np.float64)
    if motor_kind == "thrust":
        return np.clip(u, 0.0, None)
    if motor_kind != "signal":
        raise ValueError(f"motor_kind must be 'thrust' or 'signal', not {motor_kind!r}")
    if autopilot == "ardupilot":
        e = ARDUPILOT_DEFAULT_THST_EXPO if thrust_curve is None else float(thrust_curve)
        lo = ARDUPILOT_DEFAULT_SPIN_MIN if spin_min is None else float(spin_min)
        hi = ARDUPILOT_DEFAULT_SPIN_MAX if spin_max is None else float(spin_max)
        x = np.clip((u - lo) / max(hi - lo, 1e-6), 0.0, 1.0)
    else:
        e = 0.0 if thrust_curve is None else float(thrust_curve)
        x = np.clip(u, 0.0, 1.0)
    e = float(np.clip(e, -1.0, 1.0))
    return e * x * x + (1.0 - e) * x


def flight_thrust_proxy(flight: Flight, values: Optional[np.ndarray] = None) -> np.ndarray:
    """:func:`thrust_proxy` of ``values`` (default ``flight.motors.values``) with the flight's
    motor kind, thrust curve and (ArduPilot) MOT_SPIN_MIN / MOT_SPIN_MAX parameters."""
    if values is None:
        if flight.motors is None:
            raise MissingDataError(flight.path, "no motor outputs in this log")
        values = flight.motors.values
    return thrust_proxy(values, flight.motor_kind, flight.thrust_curve, flight.autopilot,
                        flight.params.get("MOT_SPIN_MIN"), flight.params.get("MOT_SPIN_MAX"))


# ----------------------------------------------------------------------------- cleaning and resampling

@dataclass
class Stream:
    """A cleaned stream: sorted, unique, NaN-free times with its gap threshold."""

    t: np.ndarray
    v: np.ndarray
    gap_s: float
    #: median sample interval (s) when clean_stream already computed it
    median_dt: Optional[float] = None

    @property
    def rate_hz(self) -> float:
        if len(self.t) < 2:
            return 0.0
        return float(1.0 / (self.median_dt if self.median_dt is not None else np.median(np.diff(self.t))))

    def valid_at(self, tg: np.ndarray) -> np.ndarray:
        """True where ``tg`` lies between two samples that are not separated by a gap."""
        if len(self.t) < 2:
            return np.zeros(tg.shape, dtype=bool)
        i = np.searchsorted(self.t, tg, side="right") - 1
        inside = (i >= 0) & (tg <= self.t[-1])
        i = np.clip(i, 0, len(self.t) - 2)
        ok = np.diff(self.t)[i] <= self.gap_s
        return inside & ok

    def covered(self) -> list[tuple[float, float]]:
        """Closed intervals [t_i, t_j] over which consecutive samples are no further apart than
        the gap threshold (where :meth:`valid_at` can be true), in time order."""
        if len(self.t) < 2:
            return []
        pairs_ok = np.diff(self.t) <= self.gap_s
        return [(float(self.t[a]), float(self.t[b])) for a, b in _runs(pairs_ok)]

    def interp(self, tg: np.ndarray) -> np.ndarray:
        out = np.empty((tg.shape[0], self.v.shape[1]))
        for k in range(self.v.shape[1]):
            out[:, k] = np.interp(tg, self.t, self.v[:, k])
        return out


def clean_stream(series: Series, max_gap_s: float, columns: int) -> Stream:
    t = series.t
    v = series.values[:, :columns]
    # NaN and inf fail the test; one whole-array test first, the per-row mask only when it fails
    if not (np.isfinite(t).all() and (np.abs(v) <= MAX_ABS_SAMPLE).all()):
        keep = np.isfinite(t) & np.all(np.abs(v) <= MAX_ABS_SAMPLE, axis=1)
        t, v = t[keep], v[keep]  # (a clean stream otherwise keeps the series' own arrays: never modified)
    dt = np.diff(t)
    if t.size > 1 and np.any(dt <= 0):
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        t, first = np.unique(t, return_index=True)
        v = v[first]
        dt = np.diff(t)
    if t.size > 1:
        # the series' own remembered median when its times were kept as they are (all increasing)
        med = series.median_dt if t is series.t else float(np.median(dt))
        return Stream(t, v, min(max_gap_s, GAP_FACTOR * float(med)), med)
    return Stream(t, v, 0.0)


def grid_gap_s(stream: Stream, rate_hz: float, max_gap_s: float) -> float:
    """The gap threshold of ``stream`` put on a grid at ``rate_hz``: ``GAP_FACTOR`` times the
    longer of its own median sample interval and the grid's interval, at most ``max_gap_s``.

    Why the grid's interval: a hole no longer than a few grid steps loses nothing the grid keeps
    that a stream logged at the grid's rate would have given (a 10 Hz motor stream is bridged over
    350 ms). A logger that drops messages under load (ArduPilot fast logging, ``DSF.Dp``) leaves
    holes of 2-16 samples in its 400 Hz streams; judged by its own interval (8.75 ms), ArduCopter
    4.7 SITL ``healthy_fastlog.BIN`` (126,941 dropped messages, 1,569 IMU intervals over 8.75 ms,
    the longest 40 ms) was cut into stretches of at most 1.3 s and refused."""
    own = GAP_FACTOR * float(stream.median_dt if stream.median_dt is not None else
                             (np.median(np.diff(stream.t)) if len(stream.t) > 1 else 0.0))
    return min(max_gap_s, max(own, GAP_FACTOR / rate_hz))


def at_grid_rate(stream: Stream, rate_hz: float, max_gap_s: float) -> Stream:
    """``stream`` (same arrays) with the gap threshold :func:`grid_gap_s` for a grid at ``rate_hz``."""
    if len(stream.t) < 2:
        return stream
    return Stream(stream.t, stream.v, grid_gap_s(stream, rate_hz, max_gap_s), stream.median_dt)


def _intersect_sorted(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Overlaps of two time-ordered lists of disjoint closed intervals (one linear merge)."""
    out, i, j = [], 0, 0
    while i < len(a) and j < len(b):
        lo, hi = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if hi >= lo:
            out.append((lo, hi))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def _grid_indices(pieces: list[tuple[float, float]], fine_hz: float) -> np.ndarray:
    """Fine-grid indices j (t = j / fine_hz) inside the given intervals, ascending, unique."""
    parts = [np.arange(math.ceil(lo * fine_hz - 1e-6), math.floor(hi * fine_hz + 1e-6) + 1) for lo, hi in pieces]
    parts = [p for p in parts if p.size]
    if not parts:
        return np.zeros(0, dtype=np.int64)
    j = np.concatenate(parts)
    # the pieces are time-ordered and disjoint, so j is already ascending and unique unless two
    # pieces meet within the rounding tolerance (np.unique hashes: 0.1-0.3 s on a 600 s 400 Hz log)
    return j if j.size < 2 or bool(np.all(np.diff(j) > 0)) else np.unique(j)


def _valid_everywhere(needed: list[Stream], tf: np.ndarray, pieces: list[tuple[float, float]]) -> np.ndarray:
    """``AND(s.valid_at(tf) for s in needed)`` for grid times ``tf`` made inside ``pieces`` (the
    intersection of every needed stream's covered intervals, see _grid_indices).

    A time strictly inside a piece lies strictly inside a covered interval of every stream, where
    valid_at is true; so only the grid points at or next to a piece's ends are tested (the same
    test), instead of a binary search of every fine grid point in every stream."""
    ok = np.ones(tf.shape, dtype=bool)
    if tf.size == 0:
        return ok
    ends = np.array([x for piece in pieces for x in piece], dtype=np.float64)
    left = np.searchsorted(tf, ends, side="left")
    right = np.searchsorted(tf, ends, side="right")
    cand = np.unique(np.clip(np.concatenate([left - 1, left, right]), 0, tf.size - 1))
    sub = tf[cand]
    good = np.ones(cand.shape, dtype=bool)
    for s in needed:
        good &= s.valid_at(sub)
    ok[cand] = good
    return ok


def _split_at_jumps(runs: list[tuple[int, int]], j: np.ndarray) -> list[tuple[int, int]]:
    """Split [start, stop) runs of grid positions wherever the grid index ``j`` skips (a run must
    never bridge uncovered time, where no grid point was made)."""
    jumps = np.flatnonzero(np.diff(j) != 1) + 1  # first position after each skip
    out = []
    for lo, hi in runs:
        cuts = jumps[(jumps > lo) & (jumps < hi)].tolist()
        edges = [lo, *cuts, hi]
        out.extend(zip(edges[:-1], edges[1:]))
    return out


def odd_window(seconds: float, rate_hz: float) -> int:
    """The odd number of samples (at least ``SAVGOL_MIN_POINTS``) a Savitzky-Golay window of
    ``seconds`` spans at ``rate_hz``."""
    n = int(round(seconds * rate_hz))
    if n % 2 == 0:
        n += 1
    return max(n, SAVGOL_MIN_POINTS)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index pairs of the True runs of a boolean array."""
    if mask.size == 0:
        return []
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    return list(zip(starts.tolist(), stops.tolist()))


def speed_stream(flight: Flight, speed_source: str, rate_hz: float, max_gap_s: float,
                  n_motors: int = 4) -> tuple[Stream, str]:
    """The thrust-proxy stream (n, n_motors) and which source it came from."""
    n = n_motors
    use_rpm = False
    if speed_source in ("esc_rpm", "auto") and flight.esc_rpm is not None and flight.esc_rpm.values.shape[1] >= n:
        rpm = flight.esc_rpm
        airborne = np.zeros(len(rpm), dtype=bool)
        for a, b in flight.airborne:
            airborne |= (rpm.t >= a) & (rpm.t <= b)
        vals = rpm.values[airborne, :n]
        valid_fraction = float(np.mean(np.all(vals > 0, axis=1))) if vals.size else 0.0
        use_rpm = rpm.rate_hz >= rate_hz / 2.0 and valid_fraction >= ESC_RPM_MIN_VALID_FRACTION
    if speed_source == "esc_rpm" and not use_rpm:
        raise MissingDataError(flight.path, "speed_source 'esc_rpm' asked for, but the log has no usable ESC rpm "
                                            f"(needs {n} motors at >= {rate_hz / 2:g} Hz, non-zero in flight)")
    if use_rpm:
        rpm = flight.esc_rpm.values[:, :n].astype(np.float64)
        rpm = np.where(rpm > 0, rpm, np.nan)  # telemetry dropouts read as 0: treat as missing
        top = np.nanmax(rpm) if np.any(np.isfinite(rpm)) else 1.0
        s = clean_stream(flight.esc_rpm.with_values((rpm / top) ** 2), max_gap_s, n)
        return s, "esc_rpm"
    m = flight.motors
    s = clean_stream(m.with_values(flight_thrust_proxy(flight, m.values[:, :n])), max_gap_s, n)
    return s, "command"


def _check_streams(flight: Flight, need_attitude: bool, n_motors: int = 4) -> None:
    # "unknown": the parser could not tell; the motor column count decides below.
    quad_names = ("quad_x", "quad_plus", "quad_other", "unknown")
    frame = flight.frame
    if n_motors != 4:
        _check_n_rotor_frame(flight, n_motors)
    elif frame is not None and (frame.name not in quad_names or frame.rotor_count not in (0, 4)):
        rotors = f" with {frame.rotor_count} rotors" if frame.rotor_count else ""
        raise UnsupportedVehicleError(flight.path, f"this tool diagnoses quadrotors; this log is a {frame.name}{rotors}")
    if flight.rates is None or len(flight.rates) < 2:
        raise MissingDataError(flight.path, "no angular-rate stream in this log")
    if flight.rates.values.shape[1] < 3:
        raise MissingDataError(flight.path, f"the angular-rate stream has {flight.rates.values.shape[1]} axes, not 3")
    if flight.motors is None or len(flight.motors) < 2:
        raise MissingDataError(flight.path, "no motor output stream in this log")
    if flight.motors.values.shape[1] != n_motors:
        if n_motors == 4:
            raise UnsupportedVehicleError(flight.path, f"this tool diagnoses quadrotors; the log has "
                                                       f"{flight.motors.values.shape[1]} motor outputs")
        raise UnsupportedVehicleError(flight.path, f"these features are for {n_motors} motors; the log has "
                                                   f"{flight.motors.values.shape[1]} motor outputs")
    if need_attitude and (flight.attitude is None or len(flight.attitude) < 2 or flight.attitude.values.shape[1] < 2):
        raise MissingDataError(flight.path, "no attitude stream in this log (the CF features need roll and pitch)")


def _check_n_rotor_frame(flight: Flight, n_motors: int) -> None:
    """An n-rotor spec (n != 4) needs a placed frame with n rotors (or none the reader could tell)."""
    frame = flight.frame
    if frame is None or frame.rotor_count == 0:
        if frame is not None and frame.unplaced:
            raise UnsupportedVehicleError(flight.path, f"cannot place the rotors of this {frame.name}: {frame.unplaced}")
        return
    if frame.rotor_count != n_motors:
        raise UnsupportedVehicleError(flight.path, f"these features are for {n_motors} rotors; this log is a "
                                                   f"{frame.name} with {frame.rotor_count} rotors")


@dataclass
class GridRuns:
    """Where the airborne grid has gap-free data (module docstring), before any value is
    interpolated or filtered: the streams on the grid, the fine-grid factor ``k`` (fine rate
    ``fine_hz``), the Savitzky-Golay length ``n_sg`` and, per future segment, its fine-grid times
    and indices (``runs``)."""

    rates: Stream
    speed: Stream
    source: str
    motors: Stream
    attitude: Optional[Stream]
    k: int
    fine_hz: float
    n_sg: int
    runs: list[tuple[np.ndarray, np.ndarray]]

    def times(self) -> list[np.ndarray]:
        """Each segment's model-grid times (what :func:`resample_streams` gives as ``Segment.t``)."""
        return [j[(j % self.k) == 0] / self.fine_hz for _, j in self.runs]


def grid_runs(prep, rate_hz: float, max_gap_s: float, trim_s: float, savgol_window_s: float,
              need_attitude: bool, speed_source: str, n_motors: int) -> GridRuns:
    """The gap-free airborne runs of the grid (:class:`GridRuns`) from ``prep``'s cleaned streams
    (a :class:`~flightlog_fd.prepared.PreparedFlight`: ``flight``, ``clean``, ``speed_stream``,
    ``attitude``): what decides the segments, without the filters (`fdlog info` needs no more)."""
    flight = prep.flight
    _check_streams(flight, need_attitude, n_motors)
    rates = at_grid_rate(prep.clean("rates", max_gap_s, 3), rate_hz, max_gap_s)
    speed, source = prep.speed_stream(speed_source, rate_hz, max_gap_s, n_motors)
    speed = at_grid_rate(speed, rate_hz, max_gap_s)
    motors = at_grid_rate(prep.clean("motors", max_gap_s, n_motors), rate_hz, max_gap_s)
    # Unwrapped (after NaNs are gone) so interpolation between +179 and -179 deg avoids 0.
    attitude = prep.attitude(max_gap_s)
    attitude = at_grid_rate(attitude, rate_hz, max_gap_s) if attitude is not None else None
    needed = [rates, speed, motors] + ([attitude] if need_attitude else [])

    # Fine grid for the derivative: an integer multiple of the model rate, so that every model
    # grid point is a fine grid point (index divisible by k).
    k = int(min(MAX_FINE_FACTOR, max(1, round(rates.rate_hz / rate_hz)))) if rates.rate_hz > 0 else 1
    fine_hz = rate_hz * k
    n_sg = odd_window(savgol_window_s, fine_hz)

    # Where every needed stream has data: the only place grid points are made (bounded grids).
    coverage = needed[0].covered()
    for s in needed[1:]:
        coverage = _intersect_sorted(coverage, s.covered())
    covered_s = sum(hi - lo for lo, hi in coverage)
    if covered_s > MAX_GRID_S:
        raise NotDiagnosableError(flight.path, f"the streams cover {covered_s / 3600:.0f} h: no flight log spans "
                                               f"more than {MAX_GRID_S / 3600:.0f} h (damaged timestamps?)")

    runs = []
    for a, b in sorted(flight.airborne):
        t0, t1 = a + trim_s, b - trim_s
        if t1 <= t0:
            continue
        pieces = _intersect_sorted(coverage, [(t0, t1)])
        j = _grid_indices(pieces, fine_hz)
        if j.size == 0:
            continue
        tf = j / fine_hz
        ok = _valid_everywhere(needed, tf, pieces)
        for lo, hi in _split_at_jumps(_runs(ok), j):
            if hi - lo < n_sg:
                continue
            if np.count_nonzero((j[lo:hi] % k) == 0) < 2:
                continue
            runs.append((tf[lo:hi], j[lo:hi]))
    return GridRuns(rates, speed, source, motors, attitude, k, fine_hz, n_sg, runs)


def resample_streams(prep, rate_hz: float, max_gap_s: float, trim_s: float, savgol_window_s: float,
                     need_attitude: bool, speed_source: str, n_motors: int) -> list[Segment]:
    """Gap-free airborne segments on the grid (module docstring) from ``prep``'s
    :func:`grid_runs`; :func:`flightlog_fd.prepared.resample` calls it once per setting."""
    g = prep.grid_runs(rate_hz, max_gap_s, trim_s, savgol_window_s, need_attitude, speed_source, n_motors)
    rates, speed, source, motors, attitude = g.rates, g.speed, g.source, g.motors, g.attitude
    k, fine_hz, n_sg = g.k, g.fine_hz, g.n_sg
    segments: list[Segment] = []
    for tf_run, j_run in g.runs:
        on_grid = (j_run % k) == 0
        w_fine = rates.interp(tf_run)
        dt = 1.0 / fine_hz
        # the filters' values at the grid samples only (the fine samples between are dropped)
        keep = np.flatnonzero(on_grid)
        smooth, dwdt = savgol_at_derivs(w_fine, n_sg, SAVGOL_POLYORDER, keep, (0, 1), delta=dt)
        tg = j_run[on_grid] / fine_hz
        att = (attitude.interp(tg) if attitude is not None else np.full((tg.size, 2), np.nan))
        att = (att + np.pi) % (2 * np.pi) - np.pi
        segments.append(Segment(t=tg, rates=smooth, attitude=att, motors=motors.interp(tg),
                                w_sq=speed.interp(tg), ang_acc=dwdt, speed_source=source))
    return segments


