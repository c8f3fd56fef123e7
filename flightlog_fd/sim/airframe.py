"""Multirotor airframes for the simulator: physical parameters, controller gains, presets, randomisation.

Frames: quad-X and quad-+ (``FRAMES``) and the n-rotor ``N_ROTOR_FRAMES`` (hexa X/+, octo X/+,
coaxial octaquad X) with the autopilots' motor numbering from :mod:`flightlog_fd.frames`; one
batch flies one rotor count. ``preset(name, "hexa_x")`` keeps the preset's thrust-to-weight
ratio (each of n rotors gets 4/n of a quad rotor's thrust).

Units: SI throughout. Mass kg, inertia kg·m² (body FRD principal axes, diagonal), arm length m
(rotor centre to vehicle centre), rotor thrust ``k_f * w**2`` N with ``w`` in rad/s, rotor drag
torque ``k_tau * w**2`` N·m, motor first-order lag ``motor_tau`` s (``w_dot = (w_com - w) / tau``),
linear drag N/(m/s), angular damping N·m/(rad/s).

Motor commands are thrust setpoints ``u`` in 0..1 with ``w_com = omega_max * sqrt(u)``, so the
steady-state thrust of a healthy motor is ``u * thrust_max`` (linear in ``u``, as PX4's
``actuator_motors`` with ``THR_MDL_FAC = 0`` and as PX4 SIH).

Presets (``PRESETS`` / :func:`preset`):

- ``"sih"``: PX4 SIH default quadrotor, from its parameters SIH_MASS 1.0 kg, SIH_IXX/IYY 0.025,
  SIH_IZZ 0.030 kg·m², SIH_L_ROLL = SIH_L_PITCH 0.2 m (the rotor's lateral offset, so the arm is
  0.2·√2 m), SIH_T_MAX 5 N and SIH_Q_MAX 0.1 N·m per rotor (thrust and torque linear in the
  command: ``T = T_MAX·u``), SIH_T_TAU 0.05 s, SIH_KDV 1.0 N/(m/s), SIH_KDW 0.025 N·m/(rad/s).
  The rotor speed scale ``omega_max`` is nominal (SIH has none): only ``k_f·omega_max²`` matters.
- ``"x500"`` (~2 kg, Holybro X500-like), ``"f450"`` (~1.5 kg), ``"crazyflie"`` (~30 g Crazyflie
  2.1), ``"heavy"`` (~5 kg, 15" props).

Gains are expressed per unit of angular acceleration (rate loop: rad/s² per rad/s), so they are
airframe-independent once multiplied by the inertia; :func:`tune_gains` derives them from the
motor lag so that every airframe is stable (rate-loop crossover ≈ 0.7 / (motor lag + loop
delay), attitude P below a third of it, velocity loop below half the attitude bandwidth).

:func:`random_airframes` draws airframes from a 30 g nano quad to a 5 kg quad with consistent
scaling: arm ∝ m^(1/3), inertia = c·m·l² (c 0.15-0.35), thrust-to-weight 1.6-3.5, rotor speed
∝ m^-0.2, motor lag ∝ m^0.3 clipped to 15-80 ms, k_tau/k_f ∝ arm, quad-X or quad-+.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

GRAVITY = 9.80665  # m/s²

#: Quadrotor frames the simulator flies (see flightlog_fd.flight.Frame for the motor geometry).
FRAMES = ("quad_x", "quad_plus")
#: n-rotor frames: name -> ArduPilot (FRAME_CLASS, FRAME_TYPE) whose motor table (flightlog_fd.frames)
#: gives the geometry and numbering; PX4's hex_x / hex_plus / octa_x / octa_plus / octa_cox
#: geometries number the motors the same way.
N_ROTOR_FRAMES = {"hexa_x": (2, 1), "hexa_plus": (2, 0), "octo_x": (3, 1), "octo_plus": (3, 0),
                  "octaquad_x": (4, 1)}
#: Every frame the simulator flies.
SIM_FRAMES = FRAMES + tuple(N_ROTOR_FRAMES)

# Random-airframe ranges (documented in the module docstring).
RANDOM_MASS_RANGE_KG = (0.03, 5.0)
RANDOM_TWR_RANGE = (1.6, 3.5)
RANDOM_MOTOR_TAU_RANGE_S = (0.015, 0.080)
RANDOM_INERTIA_FACTOR_RANGE = (0.15, 0.35)  # I_xx = c * m * arm²
RANDOM_QUAD_PLUS_FRACTION = 0.3

# Gain design (see tune_gains).
RATE_CROSSOVER_FACTOR = 0.7  # rate-loop kp = factor / (motor_tau + loop delay)
LOOP_DELAY_S = 0.008  # gyro filter + sampling + estimator delay seen by the rate loop
RATE_KP_RANGE = (4.0, 40.0)  # rad/s² per rad/s
ATT_P_RANGE = (3.0, 10.0)  # rad/s per rad


@dataclass(frozen=True)
class Gains:
    """Cascade gains, per unit of acceleration (PX4 structure: position → velocity → attitude → rate).

    ``rate_kp/ki/kd``: (roll, pitch, yaw) rad/s² per rad/s, per rad, per rad/s² (derivative on
    the measurement). ``rate_int_frac``: integrator limit as a fraction of the axis torque
    authority. ``att_p``: (roll/pitch, yaw) rad/s per rad. ``vel_*``: m/s² per m/s (xy, z).
    ``pos_p``: (xy, z) 1/s. Limits: ``max_tilt_deg``, ``max_rate_dps`` (roll/pitch, yaw).
    """

    rate_kp: tuple[float, float, float]
    rate_ki: tuple[float, float, float]
    rate_kd: tuple[float, float, float]
    rate_int_frac: float
    att_p: tuple[float, float]
    vel_p: tuple[float, float]
    vel_i: tuple[float, float]
    vel_d: tuple[float, float]
    pos_p: tuple[float, float]
    max_tilt_deg: float = 35.0
    max_rate_dps: tuple[float, float] = (220.0, 120.0)


@dataclass(frozen=True)
class Airframe:
    """A quadrotor's physical parameters and controller gains (SI units; see module docstring)."""

    name: str
    frame: str  # "quad_x" | "quad_plus" | one of N_ROTOR_FRAMES ("hexa_x", "octaquad_x"...)
    mass: float
    inertia: tuple[float, float, float]
    arm: float
    k_f: float
    k_tau: float
    motor_tau: float
    omega_max: float
    drag_lin: float
    drag_ang: float
    gyro_cutoff_hz: float = 40.0
    thr_mdl_fac: float = 0.0  # PX4 THR_MDL_FAC written to the log parameters (0: PWM linear in thrust)
    gains: Gains = field(default=None)  # type: ignore[assignment]  # filled by __post_init__

    def __post_init__(self) -> None:
        if self.frame not in SIM_FRAMES:
            raise ValueError(f"frame must be one of {SIM_FRAMES}, got {self.frame!r}")
        if self.gains is None:
            object.__setattr__(self, "gains", tune_gains(self))

    @property
    def thrust_max(self) -> float:
        """Maximum thrust of one healthy rotor, N."""
        return self.k_f * self.omega_max ** 2

    @property
    def rotor_count(self) -> int:
        return 4 if self.frame in FRAMES else len(self.geometry().rotors)

    def geometry(self):
        """:class:`~flightlog_fd.flight.Frame` of this airframe, rotors at ``arm`` metres."""
        from flightlog_fd.flight import Frame, Rotor
        from flightlog_fd.frames import ardupilot_frame

        if self.frame == "quad_x":
            return Frame.quad_x(self.arm)
        if self.frame == "quad_plus":
            return Frame.quad_plus(self.arm)
        table = ardupilot_frame(*N_ROTOR_FRAMES[self.frame])
        r0 = max(float(np.hypot(r.x, r.y)) for r in table.rotors)
        rotors = tuple(Rotor(r.x * self.arm / r0, r.y * self.arm / r0, r.spin, name=r.name) for r in table.rotors)
        return Frame(table.name, rotors, "simulated", layout=table.layout)

    @property
    def thrust_to_weight(self) -> float:
        return float(self.rotor_count) * self.thrust_max / (self.mass * GRAVITY)

    @property
    def hover_command(self) -> float:
        """Thrust setpoint u (0..1) of each motor in a balanced hover."""
        return self.mass * GRAVITY / (float(self.rotor_count) * self.thrust_max)

    @property
    def torque_ratio(self) -> float:
        """k_tau / k_f in metres: rotor drag torque per newton of thrust."""
        return self.k_tau / self.k_f

    def to_dict(self) -> dict:
        """Plain JSON-able description (for Flight.truth)."""
        d = asdict(self)
        d["thrust_to_weight"] = self.thrust_to_weight
        d["hover_command"] = self.hover_command
        return d


def tune_gains(af: Airframe) -> Gains:
    """Cascade gains that fly ``af`` stably, derived from its motor lag (see module docstring)."""
    lag = af.motor_tau + LOOP_DELAY_S
    kp = float(np.clip(RATE_CROSSOVER_FACTOR / lag, *RATE_KP_RANGE))
    # D ≈ 0.02 s · P on roll/pitch as PX4's defaults, capped by the motor lag so that fast nano
    # quads do not amplify gyro noise into saturated motors. I = 2.5 P (PX4 uses ~1.3 P): a
    # propeller damaged from take-off needs the integrator to hold its torque within ~0.4 s of
    # lift-off, else the P-only attitude error (α_damage / (kp·att_p)) tips slow airframes over.
    kd = kp * min(0.02, 0.3 * af.motor_tau)
    kp_yaw = 0.6 * kp
    att_p = float(np.clip(kp / 2.5, *ATT_P_RANGE))
    vel_p_xy = min(1.8, 0.45 * att_p)
    vel_p_z = min(4.0, 0.2 / af.motor_tau)
    return Gains(
        rate_kp=(kp, kp, kp_yaw),
        rate_ki=(2.5 * kp, 2.5 * kp, kp_yaw),
        rate_kd=(kd, kd, 0.0),
        rate_int_frac=0.4,
        att_p=(att_p, 0.6 * att_p),
        vel_p=(vel_p_xy, vel_p_z),
        vel_i=(0.4, 0.5 * vel_p_z),
        vel_d=(0.2, 0.0),
        pos_p=(0.95, 1.0),
    )


def _make(name: str, frame: str, mass: float, inertia, arm: float, thrust_max: float, torque_ratio: float,
          motor_tau: float, omega_max: float, drag_lin: float, drag_ang: float, gyro_cutoff_hz: float = 40.0,
          thr_mdl_fac: float = 0.0) -> Airframe:
    k_f = thrust_max / omega_max ** 2
    return Airframe(name=name, frame=frame, mass=mass, inertia=tuple(float(i) for i in inertia), arm=arm,
                    k_f=k_f, k_tau=torque_ratio * k_f, motor_tau=motor_tau, omega_max=omega_max,
                    drag_lin=drag_lin, drag_ang=drag_ang, gyro_cutoff_hz=gyro_cutoff_hz,
                    thr_mdl_fac=thr_mdl_fac)


SIH_L_ROLL_M = 0.2
SIH_T_MAX_N = 5.0
SIH_Q_MAX_NM = 0.1

PRESETS: dict[str, Airframe] = {
    "sih": _make("sih", "quad_x", 1.0, (0.025, 0.025, 0.030), SIH_L_ROLL_M * np.sqrt(2.0), SIH_T_MAX_N,
                 SIH_Q_MAX_NM / SIH_T_MAX_N, 0.05, 1000.0, 1.0, 0.025),
    "x500": _make("x500", "quad_x", 2.0, (0.0217, 0.0217, 0.040), 0.25, 10.3, 0.016, 0.040, 1100.0, 0.35, 0.01),
    "f450": _make("f450", "quad_x", 1.5, (0.015, 0.015, 0.028), 0.225, 8.0, 0.016, 0.045, 1000.0, 0.3, 0.008),
    "crazyflie": _make("crazyflie", "quad_x", 0.030, (1.4e-5, 1.4e-5, 2.2e-5), 0.046, 0.15, 0.006, 0.018,
                       2500.0, 0.012, 2e-6, gyro_cutoff_hz=80.0),
    "heavy": _make("heavy", "quad_x", 5.0, (0.16, 0.16, 0.29), 0.40, 30.0, 0.02, 0.070, 800.0, 0.8, 0.08,
                   gyro_cutoff_hz=30.0),
}


def preset(name: str, frame: str | None = None) -> Airframe:
    """A preset airframe by name, optionally flown as another frame ("quad_x" | "quad_plus" | an
    n-rotor frame: then each rotor gets 4/n of the quad's thrust and drag torque, so the
    thrust-to-weight ratio and hover throttle stay the preset's)."""
    try:
        af = PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown airframe preset {name!r}; known: {sorted(PRESETS)}") from None
    if frame is not None and frame != af.frame:
        af = replace(af, frame=frame, name=f"{name}_{frame}")
        if frame in N_ROTOR_FRAMES:
            scale = 4.0 / af.rotor_count
            af = replace(af, k_f=af.k_f * scale, k_tau=af.k_tau * scale, gains=None)
    return af


def random_airframes(n: int, rng: np.random.Generator, frames: Optional[Sequence[str]] = None) -> list[Airframe]:
    """``n`` physically consistent random quadrotors from 30 g to 5 kg (see module docstring);
    with ``frames`` (names from SIM_FRAMES) each draws its frame uniformly from them instead, the
    per-rotor thrust sized so the thrust-to-weight ratio is drawn from the same range. Without
    ``frames`` the draws are exactly the quadrotor ones."""
    if frames is not None:
        bad = [f for f in frames if f not in SIM_FRAMES]
        if bad or not frames:
            raise ValueError(f"frames must be names from {SIM_FRAMES}, got {list(frames)!r}")
    out = []
    lo, hi = np.log(RANDOM_MASS_RANGE_KG[0]), np.log(RANDOM_MASS_RANGE_KG[1])
    for i in range(n):
        mass = float(np.exp(rng.uniform(lo, hi)))
        arm = 0.17 * mass ** (1.0 / 3.0) * float(np.exp(rng.normal(0.0, 0.12)))
        c = rng.uniform(*RANDOM_INERTIA_FACTOR_RANGE)
        ixx = c * mass * arm ** 2
        iyy = ixx * rng.uniform(0.9, 1.1)
        izz = (ixx + iyy) * rng.uniform(0.8, 1.0)  # planar mass distribution: Izz ≈ Ixx + Iyy
        twr = rng.uniform(*RANDOM_TWR_RANGE)
        thrust_max = twr * mass * GRAVITY / 4.0
        omega_max = 2500.0 * (mass / 0.03) ** -0.2 * rng.uniform(0.85, 1.15)
        torque_ratio = arm * rng.uniform(0.05, 0.13)
        motor_tau = float(np.clip(0.015 * (mass / 0.03) ** 0.3 * rng.uniform(0.8, 1.25), *RANDOM_MOTOR_TAU_RANGE_S))
        drag_lin = 0.3 * mass ** (2.0 / 3.0) * rng.uniform(0.5, 2.0)
        drag_ang = ixx * rng.uniform(0.2, 1.5)
        frame = "quad_plus" if rng.uniform() < RANDOM_QUAD_PLUS_FRACTION else "quad_x"
        if frames is not None:
            frame = str(frames[int(rng.integers(len(frames)))])
            if frame in N_ROTOR_FRAMES:
                probe = _make("probe", frame, mass, (ixx, iyy, izz), arm, thrust_max, torque_ratio, motor_tau,
                              omega_max, drag_lin, drag_ang)
                thrust_max = twr * mass * GRAVITY / probe.rotor_count
        cutoff = float(np.clip(40.0 * (mass / 1.0) ** -0.15, 25.0, 90.0))
        out.append(_make(f"random_{i}", frame, mass, (ixx, iyy, izz), arm, thrust_max, torque_ratio, motor_tau,
                         omega_max, drag_lin, drag_ang, gyro_cutoff_hz=cutoff))
    return out
