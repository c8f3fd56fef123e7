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
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

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
    def rate_hz(self) -> float:
        """Median sample rate in Hz (0 when fewer than two samples)."""
        if len(self.t) < 2:
            return 0.0
        dt = np.diff(self.t)
        dt = dt[dt > 0]
        return float(1.0 / np.median(dt)) if dt.size else 0.0

    def between(self, t0: float, t1: float) -> "Series":
        """The samples with t0 <= t <= t1."""
        m = (self.t >= t0) & (self.t <= t1)
        return Series(self.t[m], self.values[m], self.source)


@dataclass(frozen=True)
class Rotor:
    """One rotor: position in the body frame (metres or arm-length units; x forward, y right)
    and spin direction (+1 counter-clockwise seen from above, as PX4's positive ``CA_ROTORn_KM``)."""

    x: float
    y: float
    spin: int


@dataclass
class Frame:
    """Rotor layout in the autopilot's motor numbering (``rotors[0]`` is motor 1).

    ``name`` is ``"quad_x"``, ``"quad_plus"``, ``"quad_other"`` for a 4-rotor layout that is
    neither, or a description of a vehicle we cannot diagnose (``"hexa"``, ``"octo"``,
    ``"fixed_wing"``, ``"vtol"``...). ``source`` says how it was determined.
    """

    name: str
    rotors: tuple[Rotor, ...] = ()
    source: str = ""

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
    velocity: Optional[Series] = None  # (n, 3) NED m/s where the log has it (hover detection)
    alt_motors: dict[str, Series] = field(default_factory=dict)  # other motor sources, e.g. {"RCOU": ...}
    armed: list[tuple[float, float]] = field(default_factory=list)
    airborne: list[tuple[float, float]] = field(default_factory=list)
    airborne_source: str = ""  # "vehicle_land_detected", "EV", "throttle fallback"...
    t_start: float = 0.0
    t_end: float = 0.0
    params: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    truth: Optional[dict] = None

    @property
    def duration_s(self) -> float:
        return float(self.t_end - self.t_start)

    @property
    def airborne_s(self) -> float:
        return float(sum(b - a for a, b in self.airborne))

    def streams(self) -> list[StreamInfo]:
        """The streams present, with their measured rates (for `fdlog info`)."""
        out = []
        for name in ("rates", "attitude", "motors", "esc_rpm", "velocity"):
            s = getattr(self, name)
            if s is not None:
                out.append(StreamInfo(name, s.source, s.rate_hz, len(s)))
        for name, s in self.alt_motors.items():
            out.append(StreamInfo(f"motors ({name})", s.source, s.rate_hz, len(s)))
        return out
