"""PX4-like cascade flight controller for N vehicles at once (numpy, no per-vehicle loop).

Structure (as PX4 ``mc_pos_control`` → ``mc_att_control`` → ``mc_rate_control`` → control allocation):

1. position P → velocity setpoint (+ feed-forward), limited to the leg's speed;
2. velocity PID (integrator clamped, frozen while landed) → acceleration setpoint; in "manual"
   mode the horizontal acceleration comes straight from the pilot's sticks instead;
3. acceleration → thrust vector ``F = m (a_sp − g)``, tilt limited to ``max_tilt_deg`` keeping
   the vertical component, desired attitude from the thrust direction and the yaw setpoint;
   collective thrust = F projected on the current body z axis;
4. attitude P on the rotation error ``e_R = ½ vee(R_dᵀR − RᵀR_d)`` (yaw gain lower, as PX4's
   yaw weight) → body-rate setpoint, limited;
5. rate PID (angular-acceleration units × inertia = torque), D on the measurement, integrator
   clamped at ``rate_int_frac`` of the axis torque authority, frozen while the mixer saturates,
   reset while landed (PX4 resets it on the ground);
6. mixer: per-rotor thrust from [T, τ] with the nominal effectiveness matrix (the controller
   does not know about damage), normalised by the rotor's nominal maximum thrust into setpoints
   ``u`` 0..1. Saturation handling, airmode-like: roll/pitch are scaled down only if their spread
   exceeds the full range, the collective is shifted to fit them, then yaw is reduced until every
   motor is within 0..1.

Motor command: ``w_com = omega_max · sqrt(u)`` (thrust linear in u). Outer loops (1-3) run at
``OUTER_RATE_HZ``; 4-6 every step.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe
from flightlog_fd.sim.dynamics import VehicleParams

#: PX4 runs the position controller at the estimator output rate, ~50 Hz.
OUTER_RATE_HZ = 50.0
#: Minimum collective thrust as a fraction of hover thrust while flying (PX4 MPC_THR_MIN-like).
MIN_THRUST_FRACTION = 0.15
#: Velocity-integrator limits, m/s² (xy) and fraction of g (z).
VEL_INT_LIM_XY = 3.0
VEL_INT_LIM_Z_G = 0.5
#: First-order filter on the rate derivative (D term), Hz.
D_TERM_CUTOFF_HZ = 30.0
#: Maximum vertical speeds, m/s (PX4 MPC_Z_VEL_MAX_UP / _DN-like).
MAX_VZ_UP = 3.0
MAX_VZ_DOWN = 1.5

# Controller modes (per vehicle).
MODE_OFF = 0  # disarmed or armed on the ground waiting: motors stopped
MODE_POSITION = 1  # position/velocity setpoints (take-off, waypoints, hold, landing)
MODE_MANUAL = 2  # horizontal acceleration from sticks, vertical speed from throttle


@dataclass
class ControllerGains:
    """Gains of N vehicles as arrays (built from each Airframe's Gains)."""

    rate_kp: np.ndarray  # (N, 3)
    rate_ki: np.ndarray
    rate_kd: np.ndarray
    rate_int_lim: np.ndarray  # (N, 3) rad/s² (angular-acceleration units)
    att_p: np.ndarray  # (N, 3) roll, pitch, yaw
    rate_max: np.ndarray  # (N, 3) rad/s
    vel_p: np.ndarray  # (N, 3) x, y, z
    vel_i: np.ndarray
    vel_d: np.ndarray
    pos_p: np.ndarray  # (N, 3)
    tan_tilt_max: np.ndarray  # (N,)

    @classmethod
    def from_airframes(cls, airframes: Sequence[Airframe], params: VehicleParams) -> "ControllerGains":
        g = [a.gains for a in airframes]
        arr = lambda f: np.array([f(x) for x in g], dtype=np.float64)  # noqa: E731
        # Torque authority per axis (all rotors of one sign at full thrust, the others off).
        t_max = params.k_f * params.omega_max ** 2
        roll_auth = t_max * np.abs(params.rotor_y).sum(axis=1) / 2.0
        pitch_auth = t_max * np.abs(params.rotor_x).sum(axis=1) / 2.0
        yaw_auth = 2.0 * params.k_tau * params.omega_max ** 2
        auth = np.stack([roll_auth, pitch_auth, yaw_auth], axis=1) / params.inertia
        frac = arr(lambda x: x.rate_int_frac)
        return cls(
            rate_kp=arr(lambda x: x.rate_kp), rate_ki=arr(lambda x: x.rate_ki), rate_kd=arr(lambda x: x.rate_kd),
            rate_int_lim=frac[:, None] * auth,
            att_p=arr(lambda x: (x.att_p[0], x.att_p[0], x.att_p[1])),
            rate_max=np.radians(arr(lambda x: (x.max_rate_dps[0], x.max_rate_dps[0], x.max_rate_dps[1]))),
            vel_p=arr(lambda x: (x.vel_p[0], x.vel_p[0], x.vel_p[1])),
            vel_i=arr(lambda x: (x.vel_i[0], x.vel_i[0], x.vel_i[1])),
            vel_d=arr(lambda x: (x.vel_d[0], x.vel_d[0], x.vel_d[1])),
            pos_p=arr(lambda x: (x.pos_p[0], x.pos_p[0], x.pos_p[1])),
            tan_tilt_max=np.tan(np.radians(arr(lambda x: x.max_tilt_deg))),
        )


def mixer_matrices(params: VehicleParams) -> tuple[np.ndarray, np.ndarray]:
    """Nominal allocation: per-rotor thrust = T/4·1 + M_rp @ (τx, τy) + m_yaw · τz.

    Returns ``M_rp`` (N, 4, 2) and ``m_yaw`` (N, 4) in newtons per N·m, from the inverse of the
    effectiveness matrix rows [1…1; −y_i; x_i; spin_i·k_tau/k_f].
    """
    n = params.n
    b = np.empty((n, 4, 4))
    b[:, 0, :] = 1.0
    b[:, 1, :] = -params.rotor_y
    b[:, 2, :] = params.rotor_x
    b[:, 3, :] = params.spin * (params.k_tau / params.k_f)[:, None]
    binv = np.linalg.inv(b)
    return binv[:, :, 1:3], binv[:, :, 3]


def mix(thrust: np.ndarray, torque: np.ndarray, m_rp: np.ndarray, m_yaw: np.ndarray, thrust_max: np.ndarray,
        airmode: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-motor thrust setpoints u (N, 4) in 0..1 from collective thrust (N,) N and torque (N, 3) N·m.

    Returns ``(u, rp_saturated, yaw_saturated)``. ``airmode`` (N,) bool: shift the collective up
    to keep roll/pitch authority at low thrust (disabled on the ground, as PX4).
    """
    inv_tmax = 1.0 / thrust_max
    u_coll = (0.25 * thrust * inv_tmax)[:, None]
    u_rp = (m_rp[:, :, 0] * torque[:, 0:1] + m_rp[:, :, 1] * torque[:, 1:2]) * inv_tmax[:, None]
    u_y = m_yaw * (torque[:, 2] * inv_tmax)[:, None]

    # Roll/pitch: scale down only if the spread alone exceeds the full range.
    spread = u_rp.max(axis=1) - u_rp.min(axis=1)
    rp_sat = spread > 1.0
    u_rp = u_rp / np.maximum(spread, 1.0)[:, None]
    a = u_coll + u_rp
    lo, hi = a.min(axis=1), a.max(axis=1)
    # Shift the collective: down when a motor exceeds 1, up (airmode) when one goes below 0.
    shift = -np.maximum(hi - 1.0, 0.0) + np.where(airmode, np.maximum(-lo, 0.0), 0.0)
    rp_sat |= (hi > 1.0) | (lo < 0.0)
    a = a + shift[:, None]

    # Yaw: the largest fraction k of the yaw demand that keeps every motor in 0..1.
    with np.errstate(divide="ignore", invalid="ignore"):
        k_up = np.where(u_y > 1e-12, (1.0 - a) / u_y, np.inf)
        k_dn = np.where(u_y < -1e-12, a / -u_y, np.inf)
    k = np.clip(np.minimum(k_up.min(axis=1), k_dn.min(axis=1)), 0.0, 1.0)
    yaw_sat = k < 1.0
    u = np.clip(a + k[:, None] * u_y, 0.0, 1.0)
    return u, rp_sat, yaw_sat


class CascadeController:
    """The cascade for N vehicles; call :meth:`outer` at OUTER_RATE_HZ and :meth:`inner` every step."""

    def __init__(self, airframes: Sequence[Airframe], params: VehicleParams, dt: float):
        self.p = params
        self.g = ControllerGains.from_airframes(airframes, params)
        self.dt = float(dt)
        self.outer_every = max(1, int(round(1.0 / (OUTER_RATE_HZ * dt))))
        self.dt_outer = self.outer_every * self.dt
        n = params.n
        self.thrust_max = params.k_f * params.omega_max ** 2
        self.m_rp, self.m_yaw = mixer_matrices(params)
        self.vel_int = np.zeros((n, 3))
        self.rate_int = np.zeros((n, 3))
        self.prev_rate = np.zeros((n, 3))
        self.rate_dot = np.zeros((n, 3))
        self.prev_vel = np.zeros((n, 3))
        self.acc_est = np.zeros((n, 3))
        self.d_alpha = 1.0 - np.exp(-2 * np.pi * D_TERM_CUTOFF_HZ * self.dt)
        # Outputs of the outer loop, held between its updates.
        self.thrust_vec = np.zeros((n, 3))  # desired force N (NED)
        self.r_des = np.tile(np.eye(3), (n, 1, 1))
        self.yaw_rate_ff = np.zeros(n)
        self.rp_sat = np.zeros(n, dtype=bool)
        self.yaw_sat = np.zeros(n, dtype=bool)

    # ---------------------------------------------------------------- outer loops
    def outer(self, pos: np.ndarray, vel: np.ndarray, pos_sp: np.ndarray, vel_ff: np.ndarray, speed_lim: np.ndarray,
              yaw_sp: np.ndarray, yaw_rate_ff: np.ndarray, mode: np.ndarray, man_acc_xy: np.ndarray,
              man_vz: np.ndarray, landed: np.ndarray) -> None:
        """Position/velocity loops → desired attitude ``r_des`` and thrust vector (held until next call).

        ``pos``/``vel`` are the estimates (N, 3); ``speed_lim`` (N,) horizontal speed limit m/s;
        ``mode`` (N,) MODE_*; ``man_acc_xy`` (N, 2) NED m/s² and ``man_vz`` (N,) m/s for MODE_MANUAL.
        """
        g, m = self.g, self.p.mass
        vel_sp = g.pos_p * (pos_sp - pos) + vel_ff
        # Limit horizontal speed to the leg's speed (plus margin for catching up) and vertical speed.
        hs = np.hypot(vel_sp[:, 0], vel_sp[:, 1])
        lim = speed_lim * 1.2 + 0.3
        scale = np.minimum(1.0, lim / np.maximum(hs, 1e-9))
        vel_sp[:, :2] *= scale[:, None]
        manual = mode == MODE_MANUAL
        vel_sp[:, 2] = np.where(manual, man_vz, vel_sp[:, 2])
        np.clip(vel_sp[:, 2], -MAX_VZ_UP, MAX_VZ_DOWN, out=vel_sp[:, 2])

        err = vel_sp - vel
        # Acceleration estimate for the D term (derivative of the velocity estimate, filtered).
        self.acc_est += 0.5 * ((vel - self.prev_vel) / self.dt_outer - self.acc_est)
        self.prev_vel[:] = vel
        acc_sp = g.vel_p * err + self.vel_int - g.vel_d * self.acc_est
        acc_sp[:, :2] = np.where(manual[:, None], man_acc_xy, acc_sp[:, :2])

        # Integrator: frozen while landed (reset) and in manual xy; clamped.
        flying = ~landed & (mode != MODE_OFF)
        self.vel_int += np.where(flying[:, None], g.vel_i * err * self.dt_outer, 0.0)
        self.vel_int[manual, :2] = 0.0
        self.vel_int[~flying] = 0.0
        np.clip(self.vel_int[:, :2], -VEL_INT_LIM_XY, VEL_INT_LIM_XY, out=self.vel_int[:, :2])
        np.clip(self.vel_int[:, 2], -VEL_INT_LIM_Z_G * GRAVITY, VEL_INT_LIM_Z_G * GRAVITY, out=self.vel_int[:, 2])

        # Thrust vector (upward force, NED) with the tilt limit keeping the vertical part.
        f = m[:, None] * acc_sp
        f[:, 2] -= m * GRAVITY
        f[:, 2] = np.minimum(f[:, 2], -MIN_THRUST_FRACTION * m * GRAVITY)
        fh = np.hypot(f[:, 0], f[:, 1])
        fh_max = -f[:, 2] * g.tan_tilt_max
        f[:, :2] *= np.minimum(1.0, fh_max / np.maximum(fh, 1e-9))[:, None]
        self.thrust_vec = f

        # Desired attitude: body z along −F, heading from the yaw setpoint.
        b3 = -f / np.linalg.norm(f, axis=1)[:, None]
        c = np.stack([np.cos(yaw_sp), np.sin(yaw_sp), np.zeros_like(yaw_sp)], axis=1)
        b2 = np.cross(b3, c)
        b2 /= np.linalg.norm(b2, axis=1)[:, None]
        b1 = np.cross(b2, b3)
        self.r_des = np.stack([b1, b2, b3], axis=2)
        self.yaw_rate_ff = yaw_rate_ff

    # ---------------------------------------------------------------- inner loops
    def inner(self, r_est: np.ndarray, rate_meas: np.ndarray, landed: np.ndarray, mode: np.ndarray) -> np.ndarray:
        """Attitude + rate loops and the mixer → thrust setpoints u (N, 4) in 0..1.

        ``r_est`` (N, 3, 3) estimated attitude (body→NED), ``rate_meas`` (N, 3) filtered gyro.
        """
        g, dt = self.g, self.dt
        rd = self.r_des
        # e_R = ½ vee(R_dᵀR − RᵀR_d): only the antisymmetric part of RdᵀR is needed.
        m = np.matmul(np.swapaxes(rd, 1, 2), r_est)
        e = 0.5 * np.stack([m[:, 2, 1] - m[:, 1, 2], m[:, 0, 2] - m[:, 2, 0], m[:, 1, 0] - m[:, 0, 1]], axis=1)
        rate_sp = -g.att_p * e
        rate_sp[:, 2] += self.yaw_rate_ff * r_est[:, 2, 2]
        np.clip(rate_sp, -g.rate_max, g.rate_max, out=rate_sp)

        # Rate PID in angular-acceleration units, D on the (filtered) measurement derivative.
        err = rate_sp - rate_meas
        self.rate_dot += self.d_alpha * ((rate_meas - self.prev_rate) / dt - self.rate_dot)
        self.prev_rate[:] = rate_meas
        alpha = g.rate_kp * err + self.rate_int - g.rate_kd * self.rate_dot
        torque = alpha * self.p.inertia

        # Collective: desired force projected on the current body z axis.
        b3 = r_est[:, :, 2]
        thrust = np.maximum(-(self.thrust_vec * b3).sum(axis=1), 0.0)
        off = mode == MODE_OFF
        u, rp_sat, yaw_sat = mix(thrust, torque, self.m_rp, self.m_yaw, self.thrust_max, ~landed)
        u[off] = 0.0

        # Integrator with anti-windup: frozen on saturated axes, reset on the ground / when off.
        inc = g.rate_ki * err * dt
        inc[rp_sat, :2] = 0.0
        inc[yaw_sat, 2] = 0.0
        self.rate_int += inc
        np.clip(self.rate_int, -g.rate_int_lim, g.rate_int_lim, out=self.rate_int)
        self.rate_int[landed | off] = 0.0
        self.rp_sat, self.yaw_sat = rp_sat, yaw_sat
        return u
