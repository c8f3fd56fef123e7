"""Propeller damage: which motor, how much, from when; and its vibration signature.

A damaged propeller k (PX4/ArduPilot numbering 1..4) has a thrust efficiency ``eta`` (0 < η ≤ 1)
and a drag-torque efficiency ``eta_torque`` (default: = ``eta``): ``f_k = η·k_f·w_k²``,
``τ_k = η_torque·k_tau·w_k²``. In steady hover the controller then commands that motor ``1/η``
times the others' thrust setpoint (u_k / u_others ≈ 1/η), and its effectiveness (angular
acceleration per unit command) drops by the factor η: the latter is what an airframe's own
imbalance (CoG offset, motor tilt, imbalance.py) never does.

Why two efficiencies: a chipped or cut blade tip loses more torque than thrust (blade-element
theory: thrust ∝ R⁴, power/torque ∝ R⁵ for the same speed, so a cut to radius R' gives
η_thrust ≈ (R'/R)⁴ and η_torque ≈ (R'/R)⁵ = η_thrust^1.25); a tape or a crack that bends the tip
changes pitch and drag more than lift. :func:`random_damages` therefore draws
``η_torque = η^k`` with ``k ~ U(TORQUE_EXPONENT_RANGE)`` = U(1.0, 1.6) (the CrazyPAD cuts of
0.5-3 mm on a 46 mm prop are the R⁴/R⁵ case; k up to 1.6 covers the draggier tapes and chips).

Cause: ``cause="propeller"`` (the default, everything above) or ``"motor"``: the propeller is
sound and the motor or its ESC is weak (a failing ESC or a resistive joint delivers less voltage;
ArduPilot SITL's ``SIM_ENGINE_MUL`` scales the motor's command the same way): the rotor turns at
``sqrt(η)`` of the speed its command asks for, so it gives η of its thrust per unit of command
and the controller commands it ``1/η`` times as a damaged propeller's (the commands alone cannot
tell the two apart), but it turns *slower* per command where a lighter propeller turns faster,
and its current per rpm² stays that of its propeller (the same drag torque). It adds no
vibration (the propeller's balance is unchanged).

Onset: ``onset_s`` is seconds after arming (= after the log's first sample) or ``None`` for a
propeller damaged from take-off; :class:`Damage` with ``motor = 0`` is a healthy vehicle.
``Flight.truth["onset_s"]`` reports the onset on the log's own clock.

Vibration: an unbalanced propeller shakes the frame at its rotation frequency ``w_k / 2π``
(100-400 Hz). The gyro sees an oscillation of amplitude
``VIBRATION_GAIN_RADS · imbalance_k · (w_k/omega_max)²`` rad/s before the autopilot's gyro
low-pass filter, with ``imbalance_k = BASE_IMBALANCE (healthy props are never perfect) +
(1 − η_k)``: it grows linearly with the thrust loss (η 0.95 adds 0.05, more than a healthy
prop's 0.01-0.04; η 0.6 adds 0.4, ten times it); the filtered amplitude is what the controller
and the logs see (sensors.py).

Random damages (:func:`random_damages`): healthy with probability ``healthy_fraction``, else a
uniformly chosen motor; a fraction ``mild_fraction`` of the damaged ones get mild damage, η
uniform in ``mild_eta_range`` (0.9-0.97: a nick that a pilot does not notice), the others η
uniform in ``eta_range``; η is never below
:func:`min_feasible_eta`: a weaker propeller would need more than ``MAX_DAMAGED_COMMAND`` of
full thrust in hover (no control margin left: the vehicle spins or sinks), or its torque would
tip the vehicle by more than ``MAX_STATIC_TILT_DEG`` at lift-off before the rate integrator
holds it (slow, low-inertia airframes flip) - not the "flies on, slightly off" case the tool
diagnoses; an airframe too weak for any η of the range gets its upper end. A fraction
``midflight_fraction`` of the damaged ones start mid-flight, 30-70 % into the planned flight.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe

ETA_RANGE = (0.6, 0.97)
MILD_ETA_RANGE = (0.9, 0.97)
#: Share of the damaged vehicles drawn with mild damage by default (0: full-size damage only).
MILD_FRACTION = 0.0
#: η_torque = η_thrust ** k, k uniform in this range (see module docstring).
TORQUE_EXPONENT_RANGE = (1.0, 1.6)
MAX_DAMAGED_COMMAND = 0.72
#: What lost the thrust (see module docstring).
CAUSES = ("propeller", "motor")
#: Largest attitude error the damage torque may cause before the rate integrator catches up
#: (P-only equilibrium α_damage / (kp · att_p)); beyond it lift-off with the damage tips over.
MAX_STATIC_TILT_DEG = 15.0
HEALTHY_FRACTION = 0.2
MIDFLIGHT_FRACTION = 0.25
MIDFLIGHT_WINDOW = (0.3, 0.7)
#: Gyro vibration amplitude (rad/s, before the gyro filter) per unit imbalance at full rotor speed.
VIBRATION_GAIN_RADS = 1.2
#: Residual imbalance of an undamaged propeller (fraction of the damaged-propeller scale).
BASE_IMBALANCE_RANGE = (0.01, 0.04)


@dataclass(frozen=True)
class Damage:
    """One vehicle's propeller condition. ``motor`` 0 = healthy, 1..``rotors`` = damaged motor
    (``rotors`` 4 on a quad, 6 on a hexa...)."""

    motor: int = 0
    eta: float = 1.0
    onset_s: Optional[float] = None  # s after arming; None = damaged from take-off
    eta_torque: Optional[float] = None  # drag-torque efficiency; None = same as eta
    rotors: int = 4
    cause: str = "propeller"  # "propeller" or "motor" (the motor / ESC, module docstring)

    def __post_init__(self) -> None:
        if self.cause not in CAUSES:
            raise ValueError(f"cause must be one of {', '.join(CAUSES)}, got {self.cause!r}")
        if self.cause == "motor" and self.eta_torque is not None:
            raise ValueError("a weak motor keeps its propeller's torque: eta_torque is for a damaged propeller")
        if self.eta_torque is not None and not 0.0 < self.eta_torque <= 1.0:
            raise ValueError(f"eta_torque must be in (0, 1], got {self.eta_torque}")
        if self.motor == 0 and self.eta_torque not in (None, 1.0):
            raise ValueError("a healthy vehicle (motor 0) has eta_torque 1.0")
        if not 0 <= self.motor <= self.rotors:
            raise ValueError(f"motor must be 0 (healthy) or 1..{self.rotors}, got {self.motor}")
        if not 0.0 < self.eta <= 1.0:
            raise ValueError(f"eta must be in (0, 1], got {self.eta}")
        if self.motor == 0 and self.eta != 1.0:
            raise ValueError("a healthy vehicle (motor 0) has eta 1.0")

    @property
    def torque_eta(self) -> float:
        """Drag-torque efficiency of the damaged propeller (``eta`` when not given; 1 for a weak motor)."""
        if self.cause == "motor":
            return 1.0
        return self.eta if self.eta_torque is None else float(self.eta_torque)

    @property
    def propeller_eta(self) -> float:
        """Thrust efficiency of the propeller itself (1 when the motor is the cause)."""
        return 1.0 if self.cause == "motor" else self.eta

    @property
    def drive(self) -> float:
        """Fraction of the commanded speed the motor and ESC deliver (sqrt(eta) for a weak motor, else 1)."""
        return float(np.sqrt(self.eta)) if self.cause == "motor" else 1.0

    @property
    def label(self) -> int:
        """Class label: 0 healthy, k = propeller k damaged."""
        return self.motor


HEALTHY = Damage()


def min_feasible_eta(af: Airframe) -> float:
    """Smallest η this airframe flies with (see module docstring): hover command of the damaged
    motor ≤ ``MAX_DAMAGED_COMMAND`` and the damage torque tilting it ≤ ``MAX_STATIC_TILT_DEG`` at
    lift-off, before the rate integrator takes the torque over."""
    if af.frame in ("quad_x", "quad_plus"):
        lever = af.arm if af.frame == "quad_plus" else af.arm / np.sqrt(2.0)
    else:  # n rotors: a rotor on an axis has the whole arm as its lever (the worst case)
        lever = af.arm
    # Angular acceleration per unit of lost efficiency at hover, on the weaker roll/pitch axis.
    alpha_per_loss = af.mass * GRAVITY / float(af.rotor_count) * lever / min(af.inertia[0], af.inertia[1])
    g = af.gains
    loss_max = np.radians(MAX_STATIC_TILT_DEG) * g.rate_kp[0] * g.att_p[0] / alpha_per_loss
    return float(max(af.hover_command / MAX_DAMAGED_COMMAND, 1.0 - loss_max))


def random_damages(airframes: Sequence[Airframe], planned_s: np.ndarray, rng: np.random.Generator, *,
                   healthy_fraction: float = HEALTHY_FRACTION, eta_range: tuple[float, float] = ETA_RANGE,
                   midflight_fraction: float = MIDFLIGHT_FRACTION, mild_fraction: float = MILD_FRACTION,
                   mild_eta_range: tuple[float, float] = MILD_ETA_RANGE,
                   torque_exponent_range: Optional[tuple[float, float]] = None) -> list[Damage]:
    """One random :class:`Damage` per airframe (see module docstring); ``planned_s`` (N,) flight lengths.

    ``torque_exponent_range`` None keeps η_torque = η (the paper's model); give
    ``TORQUE_EXPONENT_RANGE`` for the separate drag-torque loss."""
    out = []
    for af, planned in zip(airframes, planned_s):
        if rng.uniform() < healthy_fraction:
            out.append(HEALTHY)
            continue
        motor = int(rng.integers(1, af.rotor_count + 1))
        # An airframe too weak for any η in the range gets the mildest one (never η = 1 with a label).
        rng_eta = mild_eta_range if (mild_fraction > 0 and rng.uniform() < mild_fraction) else eta_range
        lo = min(max(rng_eta[0], min_feasible_eta(af)), rng_eta[1])
        eta = float(rng.uniform(lo, rng_eta[1]))
        eta_torque = None
        if torque_exponent_range is not None:
            eta_torque = float(eta ** rng.uniform(*torque_exponent_range))
        onset = None
        if rng.uniform() < midflight_fraction:
            onset = float(rng.uniform(*MIDFLIGHT_WINDOW) * planned)
        out.append(Damage(motor, eta, onset, eta_torque, rotors=af.rotor_count))
    return out


@dataclass
class DamageArrays:
    """Damage of N vehicles as arrays for the time loop."""

    eta: np.ndarray  # (N, R) thrust efficiency of each rotor once damaged (1 for healthy rotors)
    onset: np.ndarray  # (N,) s after arming (0 = from the start)
    imbalance_base: np.ndarray  # (N, R) residual imbalance of each propeller
    eta_torque: Optional[np.ndarray] = None  # (N, R) drag-torque efficiency once damaged (None: = eta)
    #: (N, R) fraction of the commanded speed each motor delivers once damaged (None: all 1;
    #: a weak motor or ESC, :attr:`Damage.drive`)
    drive: Optional[np.ndarray] = None

    @classmethod
    def build(cls, damages: Sequence[Damage], rng: np.random.Generator, n_rotors: int = 4) -> "DamageArrays":
        n = len(damages)
        bad = [d.motor for d in damages if d.motor > n_rotors]
        if bad:
            raise ValueError(f"damaged motor {bad[0]} on a {n_rotors}-rotor vehicle")
        eta = np.ones((n, n_rotors))
        eta_torque = np.ones((n, n_rotors))
        drive = np.ones((n, n_rotors))
        onset = np.zeros(n)
        for i, d in enumerate(damages):
            if d.motor:
                eta[i, d.motor - 1] = d.propeller_eta
                eta_torque[i, d.motor - 1] = d.torque_eta
                drive[i, d.motor - 1] = d.drive
                onset[i] = d.onset_s if d.onset_s is not None else 0.0
        return cls(eta=eta, onset=onset, imbalance_base=rng.uniform(*BASE_IMBALANCE_RANGE, size=(n, n_rotors)),
                   eta_torque=None if np.array_equal(eta_torque, eta) else eta_torque,
                   drive=None if np.all(drive == 1.0) else drive)

    def eta_at(self, t: float) -> np.ndarray:
        """(N, 4) rotor efficiencies at time ``t`` (s after arming)."""
        return np.where((t >= self.onset)[:, None], self.eta, 1.0)
