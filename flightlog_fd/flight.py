"""`Flight`, `Frame` and `Series`: what every parser returns and the simulator writes.

Contracts (see README "Architecture"):

- **Time**: every timestamp is seconds on the log's own clock (PX4: µs since boot / 1e6;
  ArduPilot: ``TimeUS`` / 1e6), so a window found here can be found in any log viewer.
- **Body frame**: FRD (x forward, y right, z down); angular rates p, q, r in rad/s.
- **Motor numbering**: the autopilot's own, 1-based in user-facing text, 0-based in arrays.
  PX4 and ArduPilot quad-X agree: 1 front-right CCW, 2 rear-left CCW, 3 front-left CW,
  4 rear-right CW. Column ``k`` of ``Flight.motors.values`` is motor ``k + 1``.
- **Motor commands** are normalised to 0..1 (0 = motor stopped / minimum, 1 = full).
  ``Flight.motor_kind`` says what the numbers are:
  ``"thrust"`` – a thrust setpoint, linear in thrust (PX4 ``actuator_motors``; ArduPilot
  commands rebuilt from ``RATE`` mixer inputs), and
  ``"signal"`` – a motor signal after the autopilot's thrust curve (PWM from PX4
  ``actuator_outputs`` or ArduPilot ``RCOU``), which `features` maps back through
  ``Flight.thrust_curve`` (PX4 ``THR_MDL_FAC``, ArduPilot ``MOT_THST_EXPO``).

**Timestamp sanity** (one flipped bit in a timestamp once sent a log's end to year 36 000 and made
the resampler ask for 3.28 PiB). Every reader runs :func:`implausible_times` on each stream in
FILE order before sorting it, and :func:`sanitise_flight` runs the same checks again on the
assembled Flight (``load_flight`` calls it, whatever reader made the Flight):

- **spikes**: a sample further than ``max(TIME_SPIKE_S, TIME_SPIKE_INTERVALS x median interval)``
  from the median time of its ``TIME_SPIKE_NEIGHBOURS`` neighbours is dropped. A monotonic
  stream is its own running median, so legitimate logging pauses (a clean step forward) are
  never touched; a flipped bit (a jump out and back) always is. The ``TIME_SPIKE_NEIGHBOURS // 2``
  samples at each end of a stream have neighbours on one side only, so there the limit is
  ``MAX_SAMPLE_GAP_S``: a lone late sample (a parameter changed in flight, seen in the ArduCopter
  3.4 Erle logs 100 s after the others) is kept, a flipped high bit (>= 2^30 us) is not.
- **monotonic**: after that, a sample more than the same threshold earlier than an earlier
  kept sample of its stream is dropped (a duplicated or replayed block); smaller backward steps
  (ArduPilot instances interleaved in one message type) are left to the sort.
- **span**: no log spans more than ``MAX_LOG_SPAN_S`` (a day); samples further than half of it
  from the median time of all the flight's samples are dropped.
- **jumps**: a forward step of more than ``MAX_SAMPLE_GAP_S`` between consecutive samples of the
  rate or motor stream is reported (a paused or a damaged log); the resampler splits there and,
  like every grid builder here, sizes its grids from the data present, never from a span.
- ``t_start`` / ``t_end`` further than ``MAX_SAMPLE_GAP_S`` from the first / last sample of the
  streams (a damaged ULog header timestamp) are moved there, and armed / airborne intervals are
  clipped to [t_start, t_end].

Every dropped sample is named in ``Flight.warnings`` (stream, count, an example time).
Measured: none of the 90 real logs in ../shared (PX4 1.x ULogs, ArduCopter 3.3-4.6 DataFlash,
CrazyPAD, SITL) loses a sample or gets one of these warnings; a clean stream costs one ``diff``
and one median of its intervals. Before these checks, a single flipped high bit in one
timestamp of a log cut in flight made ``fdlog diagnose`` die with MemoryError (1.64 TiB to
3.28 PiB grids) or run for minutes (ULog header bit 41: 13 s; bit 43: killed after 200 s).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

#: A timestamp this far (s) from the median of its neighbours is corrupted (see module docstring)...
TIME_SPIKE_S = 1.0
#: ...or this many of the stream's median sample intervals, whichever is larger (slow streams).
TIME_SPIKE_INTERVALS = 10.0
#: Size (samples, odd) of the neighbourhood whose median time a sample is compared with.
TIME_SPIKE_NEIGHBOURS = 9
#: No flight log spans more than this (s).
MAX_LOG_SPAN_S = 86400.0
#: A forward jump (s) between consecutive samples of one stream beyond which the log is reported
#: as paused or damaged, and the largest lead of a header start time over the first sample.
MAX_SAMPLE_GAP_S = 600.0

#: Quad-X motor positions in PX4/ArduPilot numbering (index 0 = motor 1).
QUAD_X_POSITIONS = ("front-right", "rear-left", "front-left", "rear-right")
#: Quad-+ motor positions in PX4/ArduPilot numbering (ArduPilot PLUS: 1 right, 2 left, 3 front, 4 back).
QUAD_PLUS_POSITIONS = ("right", "left", "front", "rear")


@dataclass
class Series:
    """A signal sampled on the log's clock.

    ``t``: (n,) float64 seconds, non-decreasing. ``values``: (n, k) float64.
    ``source``: where it came from, e.g. ``"vehicle_angular_velocity.xyz"`` or ``"RCOU.C1..C4"``.
    """

    t: np.ndarray
    values: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64).reshape(-1)
        v = np.asarray(self.values, dtype=np.float64)
        if v.ndim == 1:
            v = v[:, None]
        if v.shape[0] != self.t.shape[0]:
            raise ValueError(f"Series {self.source!r}: {self.t.shape[0]} times but {v.shape[0]} rows")
        self.values = v

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def median_dt(self) -> float:
        """Median of the positive sample intervals in s (0 when there are none). Remembered for
        the same time array: checks, features and effectiveness ask for it several times per
        diagnosis (a median over 150 000 intervals of a 600 s high-rate log is ~2 ms each time)."""
        key = (id(self.t), self.t.shape[0])
        cached = self.__dict__.get("_median_dt_cache")
        if cached is not None and cached[0] == key:
            return cached[1]
        med = 0.0
        if len(self.t) >= 2:
            dt = np.diff(self.t)
            dt = dt[dt > 0]
            med = float(np.median(dt)) if dt.size else 0.0
        self.__dict__["_median_dt_cache"] = (key, med)
        return med

    def with_values(self, values: np.ndarray, source: Optional[str] = None) -> "Series":
        """A Series of other ``values`` on these very times, its :attr:`median_dt` carried over
        (the thrust proxy of the motor outputs: a second median over the same 240 000 intervals
        cost 3-5 ms of a 600 s 400 Hz log's diagnosis)."""
        med = self.median_dt
        out = Series(self.t, values, self.source if source is None else source)
        out.__dict__["_median_dt_cache"] = ((id(out.t), out.t.shape[0]), med)
        return out

    @property
    def rate_hz(self) -> float:
        """Median sample rate in Hz (0 when fewer than two samples), from :attr:`median_dt`."""
        med = self.median_dt
        return float(1.0 / med) if med > 0 else 0.0

    def between(self, t0: float, t1: float) -> "Series":
        """The samples with t0 <= t <= t1."""
        m = (self.t >= t0) & (self.t <= t1)
        return Series(self.t[m], self.values[m], self.source)


@dataclass(frozen=True)
class Rotor:
    """One rotor: position in the body frame (metres or arm-length units; x forward, y right),
    spin direction (+1 counter-clockwise seen from above, as PX4's positive ``CA_ROTORn_KM``),
    thrust ``axis`` (unit vector, body FRD; vertical = (0, 0, -1)) and a plain-words ``name``
    ("mid-front-right", "front-right top"; empty: :meth:`Frame.position` derives one)."""

    x: float
    y: float
    spin: int
    axis: tuple[float, float, float] = (0.0, 0.0, -1.0)
    name: str = ""


@dataclass
class Frame:
    """Rotor layout in the autopilot's motor numbering (``rotors[0]`` is motor 1).

    ``name`` is ``"quad_x"``, ``"quad_plus"``, ``"quad_other"`` for a 4-rotor layout that is
    neither, ``"hexa"``, ``"octo"``, ``"octaquad"``, ``"y6"``... for n-rotor frames (see
    :mod:`flightlog_fd.frames`), or a vehicle without a motor matrix (``"fixed_wing"``,
    ``"vtol"``...). ``source`` says how it was determined, ``layout`` the firmware table used
    ("ArduPilot HEXA/CW_X"), ``outputs`` the 1-based output channel of each motor where the log
    maps them, and ``unplaced`` why the rotors could not be placed (empty when they were).
    """

    name: str
    rotors: tuple[Rotor, ...] = ()
    source: str = ""
    layout: str = ""
    outputs: tuple[int, ...] = ()
    unplaced: str = ""

    @property
    def rotor_count(self) -> int:
        return len(self.rotors)

    @property
    def is_quad(self) -> bool:
        return self.name in ("quad_x", "quad_plus", "quad_other") and self.rotor_count == 4

    def position(self, motor: int) -> str:
        """Plain-words position of 1-based ``motor`` ("front-right"...)."""
        if self.name == "quad_x" and 1 <= motor <= 4:
            return QUAD_X_POSITIONS[motor - 1]
        if self.name == "quad_plus" and 1 <= motor <= 4:
            return QUAD_PLUS_POSITIONS[motor - 1]
        if 1 <= motor <= self.rotor_count:
            r = self.rotors[motor - 1]
            if r.name:
                return r.name
            fb = "front" if r.x > 1e-6 else ("rear" if r.x < -1e-6 else "")
            lr = "right" if r.y > 1e-6 else ("left" if r.y < -1e-6 else "")
            return "-".join(p for p in (fb, lr) if p) or "centre"
        return f"motor {motor}"

    @staticmethod
    def quad_x(arm: float = 1.0) -> "Frame":
        """PX4/ArduPilot quad-X: 1 front-right CCW, 2 rear-left CCW, 3 front-left CW, 4 rear-right CW."""
        a = arm / np.sqrt(2.0)
        return Frame("quad_x", (Rotor(a, a, +1), Rotor(-a, -a, +1), Rotor(a, -a, -1), Rotor(-a, a, -1)),
                     "default quad-X")

    @staticmethod
    def quad_plus(arm: float = 1.0) -> "Frame":
        """ArduPilot/PX4 quad-+: 1 right CCW, 2 left CCW, 3 front CW, 4 rear CW."""
        return Frame("quad_plus", (Rotor(0, arm, +1), Rotor(0, -arm, +1), Rotor(arm, 0, -1), Rotor(-arm, 0, -1)),
                     "default quad-+")


@dataclass
class StreamInfo:
    """What `fdlog info` shows about one stream: its source and measured rate."""

    name: str  # our name: "rates", "attitude", "motors", "esc_rpm", or an alternative source
    source: str
    rate_hz: float
    samples: int


#: ESC telemetry: a pause between two fresh samples of one ESC longer than this many of its
#: median sample intervals is a telemetry gap (3: a 10 Hz stream that misses two reports)...
ESC_GAP_INTERVALS = 3.0
#: ...and never shorter than this (s), so jitter on a 100 Hz stream is not a gap.
ESC_GAP_MIN_S = 0.25
#: The quantities an ESC channel may carry and their units (what every reader converts to).
ESC_QUANTITIES = {"rpm": "rpm", "current": "A", "voltage": "V", "temperature": "degC"}


@dataclass
class EscChannel:
    """Telemetry of the ESC driving one motor, on its own clock samples (never resampled).

    ``motor``: 1-based, the autopilot's motor numbering. ``t`` (n,) s. ``rpm``, ``current``
    (A), ``voltage`` (V), ``temperature`` (°C): (n,) float64, NaN where the log has no value,
    ``None`` when the log has no such field. ``online`` (n,) bool: the ESC reported fresh data at
    that sample (False: offline flag cleared or a stale repeat of the previous report); readers
    keep those samples so that gaps stay visible. ``esc_index``: the ESC's own index in the log
    (ArduPilot ``Instance`` / ``ESCn`` - 1, PX4 ``esc[]`` slot)."""

    motor: int
    t: np.ndarray
    rpm: np.ndarray
    current: Optional[np.ndarray] = None
    voltage: Optional[np.ndarray] = None
    temperature: Optional[np.ndarray] = None
    online: Optional[np.ndarray] = None
    esc_index: int = -1
    source: str = ""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64).reshape(-1)
        n = self.t.shape[0]
        for name in ("rpm", "current", "voltage", "temperature"):
            v = getattr(self, name)
            if v is not None:
                v = np.asarray(v, dtype=np.float64).reshape(-1)
                if v.shape[0] != n:
                    raise ValueError(f"EscChannel motor {self.motor}: {n} times but {v.shape[0]} {name} values")
                setattr(self, name, v)
        self.online = np.ones(n, dtype=bool) if self.online is None else np.asarray(self.online, dtype=bool).reshape(-1)
        if self.online.shape[0] != n:
            raise ValueError(f"EscChannel motor {self.motor}: {n} times but {self.online.shape[0]} online flags")

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def quantity(self, name: str) -> Optional[np.ndarray]:
        """``rpm`` / ``current`` / ``voltage`` / ``temperature`` values (None when absent)."""
        if name not in ESC_QUANTITIES:
            raise KeyError(f"unknown ESC quantity {name!r}; known: {sorted(ESC_QUANTITIES)}")
        return getattr(self, name)

    def fresh(self) -> np.ndarray:
        """Mask of the samples that carry a fresh, finite RPM from an online ESC."""
        return self.online & np.isfinite(self.rpm)

    @property
    def rate_hz(self) -> float:
        """Median rate (Hz) of the fresh samples (0 with fewer than two)."""
        t = self.t[self.fresh()]
        d = np.diff(t)
        d = d[d > 0]
        return float(1.0 / np.median(d)) if d.size else 0.0

    def gap_threshold_s(self) -> float:
        r = self.rate_hz
        return max(ESC_GAP_MIN_S, ESC_GAP_INTERVALS / r) if r > 0 else ESC_GAP_MIN_S

    def gaps(self, t0: Optional[float] = None, t1: Optional[float] = None) -> list[tuple[float, float]]:
        """Intervals without fresh telemetry longer than :meth:`gap_threshold_s`: between fresh
        samples, and (when given) from ``t0`` to the first / from the last to ``t1``."""
        t = self.t[self.fresh()]
        thr = self.gap_threshold_s()
        if t.size == 0:
            return [(float(t0), float(t1))] if t0 is not None and t1 is not None and t1 > t0 else []
        edges = np.concatenate([[t0] if t0 is not None else [], t, [t1] if t1 is not None else []]).astype(float)
        d = np.diff(edges)
        return [(float(edges[i]), float(edges[i + 1])) for i in np.flatnonzero(d > thr)]

    def series(self, name: str = "rpm") -> Series:
        """The fresh samples of one quantity as a Series (n, 1), e.g. for plotting."""
        v = self.quantity(name)
        m = self.fresh() & (np.isfinite(v) if v is not None else False)
        return Series(self.t[m], v[m] if v is not None else np.zeros(0), f"{self.source} ({name})")


@dataclass
class EscTelemetry:
    """Per-motor ESC telemetry of a flight (see :class:`EscChannel`); ``channels`` sorted by motor,
    at most one per motor; motors whose ESC never reported have no channel. ``source`` names the
    log messages and their generation; ``units`` how each quantity was converted to
    :data:`ESC_QUANTITIES` (e.g. ``{"rpm": "RPM x1000 (ESCn logs rpm/10 in a centi field)"}``)."""

    channels: list[EscChannel] = field(default_factory=list)
    source: str = ""
    units: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.channels = sorted(self.channels, key=lambda c: c.motor)
        motors = [c.motor for c in self.channels]
        if len(set(motors)) != len(motors):
            raise ValueError(f"EscTelemetry: more than one channel for a motor ({motors})")

    @property
    def motors(self) -> list[int]:
        return [c.motor for c in self.channels]

    def channel(self, motor: int) -> Optional[EscChannel]:
        """The channel of 1-based ``motor`` or None."""
        for c in self.channels:
            if c.motor == motor:
                return c
        return None

    def quantities(self) -> list[str]:
        """Quantities that at least one channel carries with a finite value."""
        out = []
        for q in ESC_QUANTITIES:
            if any((v := c.quantity(q)) is not None and np.isfinite(v).any() for c in self.channels):
                out.append(q)
        return out

    def describe(self, t0: Optional[float] = None, t1: Optional[float] = None) -> dict:
        """JSON-safe summary for `fdlog info`: per motor its rate, samples, offline share and gaps."""
        out = {"source": self.source, "units": dict(self.units), "quantities": self.quantities(), "motors": []}
        for c in self.channels:
            gaps = c.gaps(t0, t1)
            out["motors"].append({
                "motor": c.motor, "esc_index": c.esc_index, "rate_hz": round(c.rate_hz, 2), "samples": len(c),
                "offline_samples": int(np.count_nonzero(~c.online)),
                "gaps": [[round(a, 3), round(b, 3)] for a, b in gaps],
                "gap_s": round(float(sum(b - a for a, b in gaps)), 3)})
        return out


#: Kinds of logged vibration metric (:class:`Vibration` ``metrics``): ArduPilot ``VIBE`` (per IMU,
#: X/Y/Z: the RMS of the accelerometer above its 5 Hz floor filter, m/s/s, at the sensor's full
#: rate) and PX4 ``vehicle_imu_status`` (per IMU: accel_vibration_metric m/s/s, gyro_vibration_metric
#: rad/s, delta_angle_coning_metric: high-passed differences of successive integrated samples).
VIBRATION_METRIC_KINDS = ("ardupilot_vibe", "px4_imu_status")


@dataclass
class ImuStream:
    """One IMU's raw samples as logged, on their own clock (never resampled).

    ``accel`` (n, 3) m/s/s FRD and/or ``gyro`` (n, 3) rad/s FRD; ``instance`` the IMU's index in
    the log; ``source`` the message ("IMU[1]", "ACC[0]", "sensor_combined", "ISBD accel[0]").
    ``batch``: a batch-sampler stream (ArduPilot ISBH/ISBD): short bursts at the sensor's full
    rate with gaps between them (``rate_hz`` is the rate within a burst)."""

    instance: int
    source: str
    accel: Optional[Series] = None
    gyro: Optional[Series] = None
    batch: bool = False

    @property
    def rate_hz(self) -> float:
        """The faster of the two streams' median rates (Hz)."""
        return max((s.rate_hz for s in (self.accel, self.gyro) if s is not None), default=0.0)


@dataclass
class Vibration:
    """Every vibration source a log holds (see :data:`VIBRATION_METRIC_KINDS`).

    ``metrics``: per IMU instance a Series of the logged vibration metric (``metric_kind`` says
    which: ArduPilot VIBE (n, 3) X/Y/Z m/s/s; PX4 vehicle_imu_status (n, 3) accel m/s/s, gyro
    rad/s, coning); ``clips``: per IMU instance (n, 1) cumulative accelerometer clipping count;
    ``imus``: raw streams (:class:`ImuStream`), fastest first; ``fft_peaks``: PX4
    ``sensor_gyro_fft`` (n, k) peak frequencies (Hz, NaN where none), columns named in its source."""

    metric_kind: str = ""
    metrics: dict[int, Series] = field(default_factory=dict)
    clips: dict[int, Series] = field(default_factory=dict)
    imus: list[ImuStream] = field(default_factory=list)
    fft_peaks: Optional[Series] = None

    def __bool__(self) -> bool:
        return bool(self.metrics or self.imus or self.fft_peaks is not None)

    def fastest(self, kind: str = "accel", batch: Optional[bool] = None) -> Optional[ImuStream]:
        """The IMU stream with the fastest ``kind`` ("accel" / "gyro") samples (None when none);
        ``batch`` True/False restricts to batch-sampler / continuous streams."""
        best = None
        for s in self.imus:
            x = getattr(s, kind)
            if x is None or len(x) < 2 or (batch is not None and s.batch != batch):
                continue
            if best is None or x.rate_hz > getattr(best, kind).rate_hz:
                best = s
        return best

    def describe(self) -> dict:
        """JSON-safe summary for `fdlog info`."""
        return {"metric_kind": self.metric_kind,
                "metrics": {str(k): {"source": s.source, "rate_hz": round(s.rate_hz, 2), "samples": len(s)}
                            for k, s in self.metrics.items()},
                "imus": [{"instance": s.instance, "source": s.source, "batch": s.batch,
                          "accel_hz": round(s.accel.rate_hz, 1) if s.accel is not None else None,
                          "gyro_hz": round(s.gyro.rate_hz, 1) if s.gyro is not None else None}
                         for s in self.imus],
                "fft_peaks": None if self.fft_peaks is None else {"source": self.fft_peaks.source,
                                                                   "rate_hz": round(self.fft_peaks.rate_hz, 2)}}


#: The Flight's own time-series fields (``alt_motors`` holds more), in the order `fdlog info` lists them.
SERIES_FIELDS = ("rates", "attitude", "motors", "esc_rpm", "velocity", "accel")


@dataclass
class Flight:
    """One flight log, as every parser returns it and the simulator writes it.

    Times are seconds on the log's clock. Arrays are float64. Optional streams are ``None``
    when the log does not have them. ``warnings`` holds things the user should know (truncated
    file, fallback sources...). ``truth`` is only set on simulated flights (label, η, onset...).
    """

    path: Optional[str]
    autopilot: str  # "px4" | "ardupilot" | "sim"
    firmware: str = ""
    vehicle_type: str = "unknown"  # "quadrotor", "hexarotor", "octorotor", "fixed_wing", "vtol", "unknown"...
    vehicle_id: Optional[str] = None  # hardware / system id where the log has one
    # Where vehicle_id came from: "sys_uuid" / "ver_hw" (PX4 info; ver_hw is the board type, not
    # one airframe), "board_uid" (ArduPilot MSG line), "BRD_SERIAL_NUM" / "SYSID_THISMAV" (params).
    vehicle_id_source: str = ""
    utc_start: Optional[float] = None  # POSIX seconds (UTC) at t_start, when the log has GPS/UTC time
    frame: Optional[Frame] = None
    rates: Optional[Series] = None  # (n, 3) p, q, r rad/s, FRD
    attitude: Optional[Series] = None  # (n, 2) roll, pitch rad (a third column yaw if present)
    motors: Optional[Series] = None  # (n, rotor_count) commands 0..1, autopilot numbering
    motor_kind: str = "thrust"  # "thrust" | "signal" (see module docstring)
    thrust_curve: Optional[float] = None  # THR_MDL_FAC (PX4) or MOT_THST_EXPO (ArduPilot)
    esc_rpm: Optional[Series] = None  # (n, rotor_count) rpm
    # per-motor ESC telemetry (rpm, A, V, degC) on each ESC's own samples, gaps kept (EscTelemetry)
    esc: Optional[EscTelemetry] = None
    velocity: Optional[Series] = None  # (n, 3) NED m/s where the log has it (hover detection)
    accel: Optional[Series] = None  # (n, 3) accelerometer, body specific force m/s² FRD (effectiveness.py)
    # every vibration source: VIBE / vehicle_imu_status metrics, raw IMU streams, FFT peaks (Vibration)
    vibration: Optional[Vibration] = None
    alt_motors: dict[str, Series] = field(default_factory=dict)  # other motor sources, e.g. {"RCOU": ...}
    armed: list[tuple[float, float]] = field(default_factory=list)
    airborne: list[tuple[float, float]] = field(default_factory=list)
    airborne_source: str = ""  # "vehicle_land_detected", "EV", "throttle fallback"...
    t_start: float = 0.0
    t_end: float = 0.0
    params: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    truth: Optional[dict] = None
    reader: str = ""  # which decoder read the file, e.g. "fast numpy ULog reader" or "pyulog (fallback: ...)"
    part: str = ""  # "flight 2 of 2, 376.8-464.9 s" when cut from a log holding several (flights.py)

    @property
    def duration_s(self) -> float:
        return float(self.t_end - self.t_start)

    @property
    def airborne_s(self) -> float:
        return float(sum(b - a for a, b in self.airborne))

    def streams(self) -> list[StreamInfo]:
        """The streams present, with their measured rates (for `fdlog info`)."""
        out = []
        for name in SERIES_FIELDS:
            s = getattr(self, name)
            if s is not None:
                out.append(StreamInfo(name, s.source, s.rate_hz, len(s)))
        for name, s in self.alt_motors.items():
            out.append(StreamInfo(f"motors ({name})", s.source, s.rate_hz, len(s)))
        return out


# ----------------------------------------------------------------------------- timestamp sanity

def _spike_threshold(t: np.ndarray) -> float:
    d = np.diff(t)
    d = np.abs(d[np.isfinite(d) & (d != 0)])
    typical = float(np.median(d)) if d.size else 0.0
    return max(TIME_SPIKE_S, TIME_SPIKE_INTERVALS * typical)


def _running_median(x: np.ndarray, size: int) -> np.ndarray:
    """``scipy.ndimage.median_filter(x, size, mode="mirror")`` of a 1-D array (odd ``size``), the
    same numbers, in NumPy: importing scipy.ndimage costs 0.2-0.5 s CPU, more than reading a log.
    An array shorter than ``size`` goes to scipy (its mirror of a short line differs)."""
    n = x.size
    if n < size:
        from scipy.ndimage import median_filter

        return median_filter(x, size=size, mode="mirror")
    half, period = size // 2, 2 * (n - 1)
    idx = np.arange(-half, n + half) % period
    idx = np.where(idx >= n, period - idx, idx)  # mirror about the end samples (d c b | a b c d | c b a)
    return np.median(np.lib.stride_tricks.sliding_window_view(x[idx], size), axis=1)


def implausible_times(t: np.ndarray) -> np.ndarray:
    """Boolean mask of the samples whose timestamp cannot be right, for one stream's times (s) in
    FILE order: non-finite, spikes, and backward steps (see the module docstring). O(n); a clean
    stream costs one ``diff``."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    bad = ~np.isfinite(t)
    idx = np.flatnonzero(~bad)
    if idx.size < 2:
        return bad
    tt = t[idx]
    d = np.diff(tt)
    if d.min() >= -TIME_SPIKE_S and d.max() <= TIME_SPIKE_S:
        return bad  # no step beyond the smallest threshold: no jump anywhere, without the median
    thr = _spike_threshold(tt)
    if d.min() >= -thr and d.max() <= thr:
        return bad  # no jump anywhere: nothing can be a spike or a backward step
    edge = TIME_SPIKE_NEIGHBOURS // 2
    end_limit = max(thr, MAX_SAMPLE_GAP_S)
    if tt.size <= 2 * edge and tt.max() - tt.min() <= end_limit:
        # every sample is an end sample and no median of them lies further than the span: no
        # spike, without the median (a short PARM stream with a late sample is common)
        spike = np.zeros(tt.shape, dtype=bool)
    else:
        med = _running_median(tt, TIME_SPIKE_NEIGHBOURS)
        limit = np.full(tt.shape, thr)
        # the ends have neighbours on one side only: a lone late PARM or a last sample after a
        # pause looks like a spike there, so only a jump beyond MAX_SAMPLE_GAP_S counts
        limit[:edge] = limit[-edge:] = end_limit
        spike = np.abs(tt - med) > limit
    keep = ~spike
    kept = tt[keep]
    if kept.size:
        back = kept < np.maximum.accumulate(kept) - thr
        keep_idx = np.flatnonzero(keep)
        keep[keep_idx[back]] = False
    bad[idx[~keep]] = True
    return bad


def describe_dropped(name: str, t: np.ndarray, bad: np.ndarray) -> str:
    """Warning text naming a stream's dropped samples: how many, an example, the span kept."""
    n = int(np.count_nonzero(bad))
    example = t[bad][0]
    kept = t[~bad]
    span = f"; the rest spans {kept.min():.2f}..{kept.max():.2f} s" if kept.size else ""
    ex = f"t={example:.6g} s" if np.isfinite(example) else "a non-finite time"
    return (f"{name}: dropped {n} sample{'s' if n != 1 else ''} with an implausible timestamp "
            f"(e.g. {ex}{span})")


def _series_fields(flight: "Flight") -> list[tuple[str, Series, Optional[str]]]:
    out = [(name, getattr(flight, name), None) for name in SERIES_FIELDS]
    out += [(f"alt_motors[{k}]", s, k) for k, s in flight.alt_motors.items()]
    return [(n, s, k) for n, s, k in out if s is not None and len(s)]


def _set_series(flight: "Flight", name: str, key: Optional[str], series: Series) -> None:
    if key is None:
        setattr(flight, name, series)
    else:
        flight.alt_motors[key] = series


def sanitise_flight(flight: "Flight") -> "Flight":
    """Apply the timestamp checks of the module docstring to an assembled Flight, in place
    (returned for chaining). Readers have already cleaned their streams in file order; this is
    the safety net every Flight passes through (``load_flight``), whatever reader made it."""
    for name, s, key in _series_fields(flight):
        bad = implausible_times(s.t)
        if bad.any():
            flight.warnings.append(describe_dropped(f"{name} ({s.source})", s.t, bad))
            _set_series(flight, name, key, Series(s.t[~bad], s.values[~bad], s.source))

    fields = _series_fields(flight)
    if not fields:
        return flight
    all_t = np.concatenate([s.t for _, s, _ in fields])
    if all_t.max() - all_t.min() > MAX_LOG_SPAN_S:
        centre = float(np.median(all_t))
        for name, s, key in fields:
            bad = np.abs(s.t - centre) > MAX_LOG_SPAN_S / 2
            if bad.any():
                flight.warnings.append(describe_dropped(f"{name} ({s.source}), beyond a "
                                                        f"{MAX_LOG_SPAN_S / 3600:.0f} h log span", s.t, bad))
                _set_series(flight, name, key, Series(s.t[~bad], s.values[~bad], s.source))
        fields = _series_fields(flight)
        if not fields:
            return flight

    for name in ("rates", "motors"):
        s = getattr(flight, name)
        if s is not None and len(s) > 1:
            d = np.diff(s.t)
            i = int(np.argmax(d))
            if d[i] > MAX_SAMPLE_GAP_S:
                flight.warnings.append(f"{name} ({s.source}): no samples for {d[i]:.0f} s after t={s.t[i]:.2f} s "
                                       f"(logging paused or the log is damaged); the flight is split there")

    lo = float(min(s.t.min() for _, s, _ in fields))
    hi = float(max(s.t.max() for _, s, _ in fields))
    if not (np.isfinite(flight.t_start) and abs(flight.t_start - lo) <= MAX_SAMPLE_GAP_S):
        flight.warnings.append(f"log start time {flight.t_start:.6g} s is implausible (first sample at "
                               f"{lo:.2f} s): using the first sample's time")
        flight.t_start = lo
    if not (np.isfinite(flight.t_end) and abs(flight.t_end - hi) <= MAX_SAMPLE_GAP_S):
        flight.warnings.append(f"log end time {flight.t_end:.6g} s is implausible (last sample at "
                               f"{hi:.2f} s): using the last sample's time")
        flight.t_end = hi
    for attr in ("armed", "airborne"):
        clipped = [(max(float(a), flight.t_start), min(float(b), flight.t_end)) for a, b in getattr(flight, attr)]
        setattr(flight, attr, [(a, b) for a, b in clipped if b > a])
    _sanitise_esc(flight)
    _sanitise_vibration(flight)
    return flight


def _sanitise_esc(flight: "Flight") -> None:
    """The timestamp checks on each ESC channel, plus: no ESC sample further than
    ``MAX_SAMPLE_GAP_S`` outside [t_start, t_end] (the other streams fixed that span)."""
    if flight.esc is None:
        return
    kept = []
    for c in flight.esc.channels:
        bad = implausible_times(c.t)
        bad |= (c.t < flight.t_start - MAX_SAMPLE_GAP_S) | (c.t > flight.t_end + MAX_SAMPLE_GAP_S)
        if bad.any():
            flight.warnings.append(describe_dropped(f"esc motor {c.motor} ({c.source})", c.t, bad))
            keep = ~bad
            c = EscChannel(c.motor, c.t[keep], c.rpm[keep],
                           *(None if v is None else v[keep] for v in (c.current, c.voltage, c.temperature)),
                           online=c.online[keep], esc_index=c.esc_index, source=c.source)
        if len(c):
            kept.append(c)
    flight.esc = EscTelemetry(kept, flight.esc.source, flight.esc.units) if kept else None


def _sanitise_vibration(flight: "Flight") -> None:
    """The timestamp checks on every vibration stream, plus: no sample further than
    ``MAX_SAMPLE_GAP_S`` outside [t_start, t_end]."""
    v = flight.vibration
    if v is None:
        return

    def clean(name: str, s: Optional[Series]) -> Optional[Series]:
        if s is None or not len(s):
            return s
        bad = implausible_times(s.t)
        bad |= (s.t < flight.t_start - MAX_SAMPLE_GAP_S) | (s.t > flight.t_end + MAX_SAMPLE_GAP_S)
        if not bad.any():
            return s
        flight.warnings.append(describe_dropped(f"vibration {name} ({s.source})", s.t, bad))
        return Series(s.t[~bad], s.values[~bad], s.source)

    v.metrics = {k: clean(f"metric[{k}]", s) for k, s in v.metrics.items()}
    v.clips = {k: clean(f"clips[{k}]", s) for k, s in v.clips.items()}
    for imu in v.imus:
        if not imu.batch:  # batch bursts jump by design; their times come from the burst headers
            imu.accel = clean(f"{imu.source} accel", imu.accel)
            imu.gyro = clean(f"{imu.source} gyro", imu.gyro)
    v.fft_peaks = clean("fft peaks", v.fft_peaks)
    flight.vibration = v if v else None
