"""Healthy airframes unbalanced the way real ones are: :class:`AirframeImbalance` per vehicle.

A real healthy quad never hovers with four equal motor commands. In a steady hover the four
commands have 4 degrees of freedom (collective, roll, pitch and yaw moment), and each cause of
imbalance fills its own:

- **centre-of-mass offset** ``cog_offset`` (x forward, y right, as a fraction of the arm length):
  the rotors sit at ``r_i − c`` from the CoG, so the thrusts balance about the shifted CoG. A CoG
  toward the front makes the front pair run high, symmetric left/right (roll/pitch pattern);
  offset in u ≈ hover command · (c / lever) per motor. Enters the dynamics only (the rotor
  positions in the torque matrix), never the controller's mixer (the autopilot assumes the
  nominal geometry; its rate integrators absorb the moment, as on a real quad).
- **motor tilt** ``motor_tilt_rad`` (per rotor, tangential, positive = horizontal thrust component
  that yaws the vehicle positively in FRD): each rotor adds a yaw torque ``|r_i| · sin δ_i · f_i``
  (the vertical loss 1 − cos δ ≤ 0.1 % is ignored). Because a rotor's drag torque is only 5-13 %
  of ``|r|·f``, 1° of tilt is worth about 15-35 % of a rotor's drag torque: the yaw controller
  answers with the diagonal pattern (the CW pair against the CCW pair), i.e. the "yaw trim" of
  real logs.
- **per-motor thrust and drag-torque coefficients** ``thrust_scale``, ``torque_scale`` (motor /
  propeller spread; independent draws): a thrust-weak rotor runs its own command high.
- **per-motor motor time constants** ``motor_tau_scale`` (ESC / motor spread).

Randomisation (:func:`random_imbalances`, per vehicle, a severity ``s ~ U(0.25, 1)`` scales all
of it so that near-balanced airframes appear too):

- CoG offset: random direction, magnitude ``s · U(0, COG_MAX_ARM_FRACTION)`` of the arm;
- motor tilt: common ``s · N(0, TILT_COMMON_STD_DEG)`` plus per-motor ``s · N(0, TILT_MOTOR_STD_DEG)``
  degrees, clipped to ``± TILT_CLIP_DEG``;
- thrust / torque scale: ``1 + s · N(0, COEF_STD)`` each, independent, clipped to ``± COEF_CLIP``;
- motor time-constant scale: ``1 + N(0, MOTOR_TAU_STD)`` clipped to ``± MOTOR_TAU_CLIP``.

Real healthy logs, measured with ``python benchmarks/real_imbalance.py --sim 24`` (offsets =
steady per-motor command minus the mean of the four, full scale 1; hover segments where found,
else all airborne time; ArduPilot "signal" = RCOU PWM, "thrust" = RATE mixer / actuator_motors):

===========================================  =========================  ==============  ==========
log                                          offsets m1..m4             gyro std °/s    motor std
                                                                        roll/pitch/yaw
===========================================  =========================  ==============  ==========
real_logs erle_copter33_73 (RCOU 10 Hz)      −0.048 +0.009 +0.019 +0.019  8.6 / 8.2 / 2.9  0.026-0.032
real_logs erle_copter34_22 (RATE 24 Hz)      −0.016 −0.036 +0.042 +0.010  4.0 / 6.0 / 1.5  0.011-0.019
real_logs erle_copter34_7 (RATE 24 Hz)       +0.003 −0.008 +0.015 −0.010  12.3 / 13.2 / 1.7 0.019-0.022
real_healthy 09-10-2014_25                   +0.030 +0.007 −0.011 −0.026  18.8 / 14.8 / 11.2 0.022-0.024
real_healthy 09-10-2014_31                   +0.029 +0.043 −0.027 −0.045  6.7 / 5.5 / 1.7  0.013-0.019
real_healthy 10-11-2014_104                  +0.027 +0.026 −0.009 −0.043  13.3 / 11.9 / 2.6 0.016-0.019
real_healthy 11-2-2015_112                   −0.038 +0.010 +0.008 +0.020  2.1 / 1.9 / 1.2  0.016-0.019
real_healthy 15-10-2014_42                   −0.013 +0.013 +0.059 −0.059  11.4 / 8.1 / 2.1  0.014-0.025
real_healthy 19-10-2014_ALT_HOLD_test1       +0.036 −0.009 −0.066 +0.039  6.2 / 3.9 / 1.2  0.010-0.012
real_healthy 22-12-2014_37                   +0.035 +0.043 −0.025 −0.052  4.4 / 3.3 / 1.5  0.031-0.034
real_healthy 25-9-2014_3                     −0.092 −0.041 +0.044 +0.089  17.4 / 21.2 / 9.2 0.029-0.040
real_healthy 27-9-2014_72                    −0.039 +0.029 +0.001 +0.009  8.7 / 5.2 / 0.6  0.022-0.028
real_healthy 29-09-2014_2                    +0.004 +0.075 −0.023 −0.056  43.1 / 34.2 / 3.1 0.076-0.087
real_healthy 5-12-2014_218                   +0.012 +0.017 +0.008 −0.037  3.8 / 4.2 / 1.7  0.008-0.009
real_healthy 6-3-2014_6                      +0.002 −0.068 −0.018 +0.084  9.7 / 7.7 / 4.2  0.088-0.093
real_healthy 7-9-2014_21                     −0.004 +0.044 −0.027 −0.014  19.3 / 14.9 / 1.4 0.050-0.053
real_healthy 7-9-2014_25                     +0.011 +0.030 −0.010 −0.031  22.8 / 20.1 / 2.1 0.056-0.063
CrazyPAD E9 normal_flight log00..02          +0.01 +0.072..0.081 −0.063..−0.071 −0.013..−0.022
                                                                        3.9-4.7 / 3.1-4.4 / 0.6-0.9
                                                                                        0.018-0.026
===========================================  =========================  ==============  ==========

(real_healthy "Erle-Brain2 first flight" is excluded: its motors sit at full scale, 9 s only.)
Summary: the largest |offset| of a real healthy airframe is 0.015-0.092, median 0.045, 90th
percentile ≈ 0.08; gyro noise (0.5 s detrended, 50-100 Hz logs) roll/pitch 2-43 °/s, median ≈ 8,
yaw 0.6-11 °/s; motor command noise 0.008-0.09, median ≈ 0.02. The real_healthy logs are
ArduCopter 3.1-3.2 without RATE: IMU at 50-56 Hz, RCOU at 10-11 Hz (the ``ardupilot_rcou``
logging profile of logger.py).

Simulated healthy airframes with these ranges (same script, ``--sim 24``: 72 flights, random
airframes, ardupilot_rcou manual + waypoints and px4_default hover): largest |offset| per flight
p10/50/90/max 0.021 / 0.045 / 0.077 / 0.126; gyro std roll/pitch p10/50/90 4.5 / 7.1 / 12.6 (yaw 1.4 / 2.5 / 4.5) °/s; motor std p10/50/90
0.012 / 0.018 / 0.033. The static hover balance :func:`hover_commands` (used to keep every draw flyable)
gives the same offsets to within 0.003 (tests/test_sim_imbalance.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.sim.airframe import Airframe

COG_MAX_ARM_FRACTION = 0.10
TILT_COMMON_STD_DEG = 0.45
TILT_MOTOR_STD_DEG = 0.2
TILT_CLIP_DEG = 1.2
COEF_STD = 0.03
COEF_CLIP = 0.08
MOTOR_TAU_STD = 0.08
MOTOR_TAU_CLIP = 0.2
SEVERITY_RANGE = (0.25, 1.0)
#: A healthy motor may need at most this hover command after all imbalances (else the draw is
#: scaled down: a real airframe that far off would be re-trimmed before it flies).
MAX_HEALTHY_HOVER_COMMAND = 0.75

_ONES = (1.0, 1.0, 1.0, 1.0)
_ZEROS = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class AirframeImbalance:
    """One airframe's imbalance (see module docstring). Defaults: perfectly balanced."""

    cog_offset: tuple[float, float] = (0.0, 0.0)  # (x forward, y right) / arm length
    motor_tilt_rad: tuple[float, float, float, float] = _ZEROS
    thrust_scale: tuple[float, float, float, float] = _ONES
    torque_scale: tuple[float, float, float, float] = _ONES
    motor_tau_scale: tuple[float, float, float, float] = _ONES

    def __post_init__(self) -> None:
        r = len(self.motor_tilt_rad)  # 4 on a quad; an n-rotor airframe gives n everywhere
        for name in ("motor_tilt_rad", "thrust_scale", "torque_scale", "motor_tau_scale"):
            v = getattr(self, name)
            if len(v) != r or r < 3:
                raise ValueError(f"{name} needs {max(r, 4)} values, got {len(v)}")
            object.__setattr__(self, name, tuple(float(x) for x in v))
        if len(self.cog_offset) != 2:
            raise ValueError("cog_offset needs (x, y)")
        object.__setattr__(self, "cog_offset", tuple(float(x) for x in self.cog_offset))
        if min(self.thrust_scale + self.torque_scale + self.motor_tau_scale) <= 0:
            raise ValueError("scales must be positive")

    def to_dict(self) -> dict:
        return {"cog_offset": list(self.cog_offset), "motor_tilt_deg": np.degrees(self.motor_tilt_rad).round(4).tolist(),
                "thrust_scale": list(self.thrust_scale), "torque_scale": list(self.torque_scale),
                "motor_tau_scale": list(self.motor_tau_scale)}


BALANCED = AirframeImbalance()


def balanced(n_rotors: int = 4) -> AirframeImbalance:
    """A perfectly balanced airframe with ``n_rotors`` rotors (BALANCED for a quad)."""
    if n_rotors == 4:
        return BALANCED
    return AirframeImbalance((0.0, 0.0), (0.0,) * n_rotors, (1.0,) * n_rotors, (1.0,) * n_rotors, (1.0,) * n_rotors)

ImbalanceSpec = Union[None, str, AirframeImbalance, Sequence[Optional[AirframeImbalance]]]


def _scaled(imb: AirframeImbalance, k: float) -> AirframeImbalance:
    return AirframeImbalance(
        cog_offset=tuple(k * c for c in imb.cog_offset),
        motor_tilt_rad=tuple(k * t for t in imb.motor_tilt_rad),
        thrust_scale=tuple(1.0 + k * (s - 1.0) for s in imb.thrust_scale),
        torque_scale=tuple(1.0 + k * (s - 1.0) for s in imb.torque_scale),
        motor_tau_scale=imb.motor_tau_scale)


def hover_commands(af: Airframe, imb: AirframeImbalance) -> np.ndarray:
    """(R,) steady hover thrust setpoints of ``af`` with ``imb`` (static force/moment balance; for
    R != 4 rotors the least-squares one, as the simulator's allocation)."""
    frame = af.geometry()
    x = np.array([r.x for r in frame.rotors]) - imb.cog_offset[0] * af.arm
    y = np.array([r.y for r in frame.rotors]) - imb.cog_offset[1] * af.arm
    spin = np.array([r.spin for r in frame.rotors], dtype=float)
    ts = np.array(imb.thrust_scale)
    qs = np.array(imb.torque_scale)
    tilt = np.array(imb.motor_tilt_rad)
    r = np.hypot(np.array([r.x for r in frame.rotors]), np.array([r.y for r in frame.rotors]))
    # Rows: total thrust, roll, pitch, yaw per unit command (u · thrust_max = healthy thrust).
    a = np.stack([ts, -y * ts, x * ts, spin * af.torque_ratio * qs + r * np.sin(tilt) * ts])
    rhs = np.array([af.mass * 9.80665 / af.thrust_max, 0.0, 0.0, 0.0])
    if a.shape[1] == 4:
        return np.linalg.solve(a, rhs)
    return np.linalg.pinv(a) @ rhs


def random_imbalances(airframes: Sequence[Airframe], rng: np.random.Generator) -> list[AirframeImbalance]:
    """One realistic random :class:`AirframeImbalance` per airframe (see module docstring)."""
    out = []
    for af in airframes:
        s = rng.uniform(*SEVERITY_RANGE)
        ang = rng.uniform(-np.pi, np.pi)
        c = s * rng.uniform(0.0, COG_MAX_ARM_FRACTION)
        r = af.rotor_count
        tilt = np.radians(np.clip(s * (rng.normal(0.0, TILT_COMMON_STD_DEG) + rng.normal(0.0, TILT_MOTOR_STD_DEG, r)),
                                  -TILT_CLIP_DEG, TILT_CLIP_DEG))
        ts = 1.0 + np.clip(s * rng.normal(0.0, COEF_STD, r), -COEF_CLIP, COEF_CLIP)
        qs = 1.0 + np.clip(s * rng.normal(0.0, COEF_STD, r), -COEF_CLIP, COEF_CLIP)
        tau = 1.0 + np.clip(rng.normal(0.0, MOTOR_TAU_STD, r), -MOTOR_TAU_CLIP, MOTOR_TAU_CLIP)
        imb = AirframeImbalance((c * np.cos(ang), c * np.sin(ang)), tuple(tilt), tuple(ts), tuple(qs), tuple(tau))
        # Keep the hover flyable with margin: shrink the draw until the highest motor fits.
        for _ in range(6):
            if hover_commands(af, imb).max() <= max(MAX_HEALTHY_HOVER_COMMAND, af.hover_command * 1.05):
                break
            imb = _scaled(imb, 0.6)
        out.append(imb)
    return out


def resolve_imbalances(spec: ImbalanceSpec, airframes: Sequence[Airframe],
                       rng: np.random.Generator) -> list[AirframeImbalance]:
    """None (balanced) / "random" / one AirframeImbalance for all / a list of n (None = balanced)."""
    n = len(airframes)
    if spec is None:
        return [balanced(af.rotor_count) for af in airframes]
    if isinstance(spec, str):
        if spec != "random":
            raise ValueError(f"imbalance must be None, 'random', an AirframeImbalance or a list, got {spec!r}")
        return random_imbalances(airframes, rng)
    if isinstance(spec, AirframeImbalance):
        return [spec] * n
    out = [BALANCED if s is None else s for s in spec]
    if len(out) != n:
        raise ValueError(f"got {len(out)} imbalances for {n} vehicles")
    return out


@dataclass
class ImbalanceArrays:
    """Imbalances of N vehicles, component-major (4, N) / (2, N), for the dynamics."""

    cog: np.ndarray  # (2, N) fraction of arm
    tilt: np.ndarray  # (4, N) rad
    thrust_scale: np.ndarray  # (4, N)
    torque_scale: np.ndarray  # (4, N)
    motor_tau_scale: np.ndarray  # (4, N)
    items: list = field(default_factory=list)

    @classmethod
    def build(cls, imbalances: Sequence[AirframeImbalance]) -> "ImbalanceArrays":
        def arr(name: str) -> np.ndarray:
            return np.array([getattr(i, name) for i in imbalances], dtype=np.float64).T.copy()

        return cls(cog=arr("cog_offset"), tilt=arr("motor_tilt_rad"), thrust_scale=arr("thrust_scale"),
                   torque_scale=arr("torque_scale"), motor_tau_scale=arr("motor_tau_scale"), items=list(imbalances))
