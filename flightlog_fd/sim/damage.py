"""Propeller damage: which motor, how much, from when; and its vibration signature.

A damaged propeller k (PX4/ArduPilot numbering 1..4) has an efficiency ``eta`` (0 < η ≤ 1) that
scales BOTH its thrust and its reaction (drag) torque: ``f_k = η·k_f·w_k²``, ``τ_k = η·k_tau·w_k²``.
In steady hover the controller then commands that motor ``1/η`` times the others' thrust
setpoint (u_k / u_others ≈ 1/η), which is the signature the diagnosis looks for.

Onset: ``onset_s`` is seconds after arming (= after the log's first sample) or ``None`` for a
propeller damaged from take-off; :class:`Damage` with ``motor = 0`` is a healthy vehicle.
``Flight.truth["onset_s"]`` reports the onset on the log's own clock.

Vibration: an unbalanced propeller shakes the frame at its rotation frequency ``w_k / 2π``
(100-400 Hz). The gyro sees an oscillation of amplitude
``VIBRATION_GAIN_RADS · imbalance_k · (w_k/omega_max)²`` rad/s before the autopilot's gyro
low-pass filter, with ``imbalance_k = BASE_IMBALANCE (healthy props are never perfect) +
(1 − η_k)``; the filtered amplitude is what the controller and the logs see (sensors.py).

Random damages (:func:`random_damages`): healthy with probability ``healthy_fraction``, else a
uniformly chosen motor with η uniform in ``eta_range`` but never below
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
MAX_DAMAGED_COMMAND = 0.72
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
    """One vehicle's propeller condition. ``motor`` 0 = healthy, 1..4 = damaged motor."""

    motor: int = 0
    eta: float = 1.0
    onset_s: Optional[float] = None  # s after arming; None = damaged from take-off

    def __post_init__(self) -> None:
        if not 0 <= self.motor <= 4:
            raise ValueError(f"motor must be 0 (healthy) or 1..4, got {self.motor}")
        if not 0.0 < self.eta <= 1.0:
            raise ValueError(f"eta must be in (0, 1], got {self.eta}")
        if self.motor == 0 and self.eta != 1.0:
            raise ValueError("a healthy vehicle (motor 0) has eta 1.0")

    @property
    def label(self) -> int:
        """Class label: 0 healthy, k = propeller k damaged."""
        return self.motor


HEALTHY = Damage()


def min_feasible_eta(af: Airframe) -> float:
    """Smallest η this airframe flies with (see module docstring): hover command of the damaged
    motor ≤ ``MAX_DAMAGED_COMMAND`` and the damage torque tilting it ≤ ``MAX_STATIC_TILT_DEG`` at
    lift-off, before the rate integrator takes the torque over."""
    lever = af.arm if af.frame == "quad_plus" else af.arm / np.sqrt(2.0)
    # Angular acceleration per unit of lost efficiency at hover, on the weaker roll/pitch axis.
    alpha_per_loss = af.mass * GRAVITY / 4.0 * lever / min(af.inertia[0], af.inertia[1])
    g = af.gains
    loss_max = np.radians(MAX_STATIC_TILT_DEG) * g.rate_kp[0] * g.att_p[0] / alpha_per_loss
    return float(max(af.hover_command / MAX_DAMAGED_COMMAND, 1.0 - loss_max))


def random_damages(airframes: Sequence[Airframe], planned_s: np.ndarray, rng: np.random.Generator, *,
                   healthy_fraction: float = HEALTHY_FRACTION, eta_range: tuple[float, float] = ETA_RANGE,
                   midflight_fraction: float = MIDFLIGHT_FRACTION) -> list[Damage]:
    """One random :class:`Damage` per airframe (see module docstring); ``planned_s`` (N,) flight lengths."""
    out = []
    for af, planned in zip(airframes, planned_s):
        if rng.uniform() < healthy_fraction:
            out.append(HEALTHY)
            continue
        motor = int(rng.integers(1, 5))
        # An airframe too weak for any η in the range gets the mildest one (never η = 1 with a label).
        lo = min(max(eta_range[0], min_feasible_eta(af)), eta_range[1])
        eta = float(rng.uniform(lo, eta_range[1]))
        onset = None
        if rng.uniform() < midflight_fraction:
            onset = float(rng.uniform(*MIDFLIGHT_WINDOW) * planned)
        out.append(Damage(motor, eta, onset))
    return out


@dataclass
class DamageArrays:
    """Damage of N vehicles as arrays for the time loop."""

    eta: np.ndarray  # (N, 4) efficiency of each rotor once damaged (1 for healthy rotors)
    onset: np.ndarray  # (N,) s after arming (0 = from the start)
    imbalance_base: np.ndarray  # (N, 4) residual imbalance of each propeller

    @classmethod
    def build(cls, damages: Sequence[Damage], rng: np.random.Generator) -> "DamageArrays":
        n = len(damages)
        eta = np.ones((n, 4))
        onset = np.zeros(n)
        for i, d in enumerate(damages):
            if d.motor:
                eta[i, d.motor - 1] = d.eta
                onset[i] = d.onset_s if d.onset_s is not None else 0.0
        return cls(eta=eta, onset=onset, imbalance_base=rng.uniform(*BASE_IMBALANCE_RANGE, size=(n, 4)))

    def eta_at(self, t: float) -> np.ndarray:
        """(N, 4) rotor efficiencies at time ``t`` (s after arming)."""
        return np.where((t >= self.onset)[:, None], self.eta, 1.0)
