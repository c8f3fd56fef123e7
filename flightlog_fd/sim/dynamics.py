"""Vectorised 6-DoF quadrotor dynamics: N vehicles stepped together as arrays (numpy only).

Frames: world NED (z down, ground at z = 0), body FRD; attitude quaternion ``q = (w, x, y, z)``
rotating body vectors into NED. Units SI: m, m/s, rad/s, N, N·m.

Model per vehicle (parameters from :class:`~flightlog_fd.sim.airframe.Airframe`):

- motor first-order lag ``w_dot = (w_com - w) / motor_tau`` (discretised exactly), speed clipped to
  ``0..omega_max``;
- rotor i thrust ``f_i = s_i · k_f · w_i²`` along −z_body and drag torque
  ``spin_i · s_i · k_tau · w_i²`` about z_body, where ``s_i`` is the per-rotor effectiveness
  (propeller damage η and the unbalance of the adjusted model, see damage.py) applied to BOTH;
  ``spin_i`` = +1 for a counter-clockwise rotor seen from above (positive yaw torque in FRD, as
  PX4's positive ``CA_ROTORn_KM``); geometry from ``flightlog_fd.flight.Frame.quad_x/quad_plus``;
- roll torque ``−Σ y_i f_i``, pitch torque ``Σ x_i f_i`` (r × F with F = (0, 0, −f));
- linear drag ``drag_lin · (wind − v)``, angular damping ``−drag_ang · ω``, gyroscopic term
  ``−ω × Iω``, an angular-acceleration disturbance (turbulence / prop wash) supplied by the caller;
- ground contact: the vehicle starts landed at z = 0; while thrust cannot lift it (z ≥ 0 after a
  step) it stays level (yaw kept), with zero velocity and angular velocity. Touching down clamps
  z to 0 and levels it the same way.

Integration: semi-implicit Euler (velocities first, then positions/attitude), quaternion
renormalised each step. Step sizes up to 5 ms are stable for every random airframe (fastest motor
lag 15 ms, discretised exactly).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from flightlog_fd.flight import Frame
from flightlog_fd.sim.airframe import GRAVITY, Airframe


@dataclass
class VehicleParams:
    """Airframe parameters stacked for N vehicles (arrays, leading axis = vehicle)."""

    mass: np.ndarray  # (N,) kg
    inertia: np.ndarray  # (N, 3) kg·m²
    rotor_x: np.ndarray  # (N, 4) m, forward
    rotor_y: np.ndarray  # (N, 4) m, right
    spin: np.ndarray  # (N, 4) +1 CCW / −1 CW
    k_f: np.ndarray  # (N,)
    k_tau: np.ndarray  # (N,)
    motor_tau: np.ndarray  # (N,) s
    omega_max: np.ndarray  # (N,) rad/s
    drag_lin: np.ndarray  # (N,) N/(m/s)
    drag_ang: np.ndarray  # (N,) N·m/(rad/s)

    @property
    def n(self) -> int:
        return int(self.mass.shape[0])

    @classmethod
    def from_airframes(cls, airframes: Sequence[Airframe]) -> "VehicleParams":
        rx, ry, sp = [], [], []
        for af in airframes:
            frame = Frame.quad_x(af.arm) if af.frame == "quad_x" else Frame.quad_plus(af.arm)
            rx.append([r.x for r in frame.rotors])
            ry.append([r.y for r in frame.rotors])
            sp.append([r.spin for r in frame.rotors])
        f = lambda name: np.array([getattr(a, name) for a in airframes], dtype=np.float64)  # noqa: E731
        return cls(mass=f("mass"), inertia=np.array([a.inertia for a in airframes], dtype=np.float64),
                   rotor_x=np.array(rx, dtype=np.float64), rotor_y=np.array(ry, dtype=np.float64),
                   spin=np.array(sp, dtype=np.float64), k_f=f("k_f"), k_tau=f("k_tau"),
                   motor_tau=f("motor_tau"), omega_max=f("omega_max"), drag_lin=f("drag_lin"),
                   drag_ang=f("drag_ang"))


@dataclass
class RigidBodyState:
    """State of N vehicles. ``landed`` is the ground-contact flag (True = resting on the ground)."""

    pos: np.ndarray  # (N, 3) NED m
    vel: np.ndarray  # (N, 3) NED m/s
    quat: np.ndarray  # (N, 4) w, x, y, z body→NED
    omega: np.ndarray  # (N, 3) body FRD rad/s
    w: np.ndarray  # (N, 4) rotor speeds rad/s
    landed: np.ndarray  # (N,) bool
    acc_body: np.ndarray  # (N, 3) last linear acceleration minus gravity (specific force) in body, m/s²

    @classmethod
    def on_ground(cls, n: int, yaw: Optional[np.ndarray] = None, xy: Optional[np.ndarray] = None) -> "RigidBodyState":
        yaw = np.zeros(n) if yaw is None else np.asarray(yaw, dtype=np.float64)
        quat = np.zeros((n, 4))
        quat[:, 0] = np.cos(yaw / 2.0)
        quat[:, 3] = np.sin(yaw / 2.0)
        pos = np.zeros((n, 3))
        if xy is not None:
            pos[:, :2] = xy
        return cls(pos=pos, vel=np.zeros((n, 3)), quat=quat, omega=np.zeros((n, 3)), w=np.zeros((n, 4)),
                   landed=np.ones(n, dtype=bool), acc_body=np.zeros((n, 3)))


def quat_to_rotmat(q: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions (w, x, y, z) → (N, 3, 3) rotation matrices body→world."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((q.shape[0], 3, 3))
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    r[:, 0, 0] = 1 - 2 * (yy + zz)
    r[:, 0, 1] = 2 * (xy - wz)
    r[:, 0, 2] = 2 * (xz + wy)
    r[:, 1, 0] = 2 * (xy + wz)
    r[:, 1, 1] = 1 - 2 * (xx + zz)
    r[:, 1, 2] = 2 * (yz - wx)
    r[:, 2, 0] = 2 * (xz - wy)
    r[:, 2, 1] = 2 * (yz + wx)
    r[:, 2, 2] = 1 - 2 * (xx + yy)
    return r


def quat_to_euler(q: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions → (N, 3) roll, pitch, yaw in rad (ZYX, as PX4 and ArduPilot report)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=-1)


def quat_yaw(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def rotor_forces(params: VehicleParams, w: np.ndarray, effectiveness: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-rotor thrust (N, 4) in N and body torque (N, 3) in N·m for rotor speeds ``w``.

    ``effectiveness`` (N, 4) scales both the thrust and the drag torque of each rotor.
    """
    w2 = effectiveness * w * w
    f = params.k_f[:, None] * w2
    torque = np.empty((w.shape[0], 3))
    torque[:, 0] = -(params.rotor_y * f).sum(axis=1)
    torque[:, 1] = (params.rotor_x * f).sum(axis=1)
    torque[:, 2] = params.k_tau * (params.spin * w2).sum(axis=1)
    return f, torque


class QuadDynamics:
    """Steps N vehicles with a fixed ``dt`` (see module docstring for the model)."""

    def __init__(self, params: VehicleParams, dt: float):
        self.p = params
        self.dt = float(dt)
        self.motor_alpha = (1.0 - np.exp(-self.dt / params.motor_tau))[:, None]
        self.inv_mass = 1.0 / params.mass
        self.inv_inertia = 1.0 / params.inertia
        self.weight = params.mass * GRAVITY

    def step(self, s: RigidBodyState, w_com: np.ndarray, effectiveness: np.ndarray, wind: np.ndarray,
             ang_acc_dist: np.ndarray, speed_gain: Optional[np.ndarray] = None) -> None:
        """Advance ``s`` in place by one step.

        ``w_com`` (N, 4) commanded rotor speeds rad/s; ``effectiveness`` (N, 4) thrust/torque scale;
        ``wind`` (N, 3) NED m/s; ``ang_acc_dist`` (N, 3) rad/s² disturbance; ``speed_gain``
        (N, 4) optional multiplier on the rotor speed seen by the air (the paper's adjusted model).
        """
        p, dt = self.p, self.dt
        s.w += self.motor_alpha * (w_com - s.w)
        np.clip(s.w, 0.0, p.omega_max[:, None], out=s.w)
        w_air = s.w if speed_gain is None else s.w * speed_gain
        f, torque = rotor_forces(p, w_air, effectiveness)
        thrust = f.sum(axis=1)

        # Rotational dynamics: I ω_dot = τ − ω × Iω − c ω, plus the disturbance.
        om = s.omega
        iw = p.inertia * om
        gyro = np.cross(om, iw)
        om_dot = (torque - gyro - p.drag_ang[:, None] * om) * self.inv_inertia + ang_acc_dist

        # Translational: thrust along −z_body, gravity, linear drag relative to the air.
        q = s.quat
        qw, qx, qy, qz = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
        b3 = np.empty((q.shape[0], 3))  # body z axis in NED
        b3[:, 0] = 2 * (qx * qz + qw * qy)
        b3[:, 1] = 2 * (qy * qz - qw * qx)
        b3[:, 2] = 1 - 2 * (qx * qx + qy * qy)
        drag = p.drag_lin[:, None] * (wind - s.vel)
        acc = (drag - thrust[:, None] * b3) * self.inv_mass[:, None]
        acc[:, 2] += GRAVITY
        s.vel += acc * dt
        s.pos += s.vel * dt
        s.omega += om_dot * dt

        # Quaternion kinematics q_dot = ½ q ⊗ (0, ω), first order, renormalised.
        ox, oy, oz = s.omega[:, 0] * (0.5 * dt), s.omega[:, 1] * (0.5 * dt), s.omega[:, 2] * (0.5 * dt)
        dq = np.empty_like(q)
        dq[:, 0] = -qx * ox - qy * oy - qz * oz
        dq[:, 1] = qw * ox + qy * oz - qz * oy
        dq[:, 2] = qw * oy - qx * oz + qz * ox
        dq[:, 3] = qw * oz + qx * oy - qy * ox
        q += dq
        q /= np.sqrt((q * q).sum(axis=1))[:, None]

        # Specific force in body (what an accelerometer measures, without gravity).
        s.acc_body[:, :2] = 0.0
        s.acc_body[:, 2] = -thrust * self.inv_mass

        # Ground contact: resting or touching down → clamp, zero velocities, level (keep yaw).
        ground = s.pos[:, 2] >= 0.0
        s.landed = ground
        if ground.any():
            s.pos[ground, 2] = 0.0
            s.vel[ground] = 0.0
            s.omega[ground] = 0.0
            yaw = quat_yaw(q[ground])
            lvl = np.zeros((yaw.shape[0], 4))
            lvl[:, 0] = np.cos(yaw / 2.0)
            lvl[:, 3] = np.sin(yaw / 2.0)
            q[ground] = lvl
