"""PX4-like cascade flight controller for N vehicles at once (numpy, no per-vehicle loop).

Structure (as PX4 ``mc_pos_control`` → ``mc_att_control`` → ``mc_rate_control`` → control allocation):

1. position P → velocity setpoint (+ feed-forward), horizontal speed limited to the leg's speed,
   vertical to ``MAX_VZ_UP``/``MAX_VZ_DOWN``;
2. velocity PID (integrator clamped, reset while landed) → acceleration setpoint; in manual mode
   the horizontal acceleration comes straight from the pilot's sticks instead;
3. acceleration → thrust vector ``F = m (a_sp − g)``, at least ``MIN_THRUST_FRACTION`` of the
   weight, tilt limited to ``max_tilt_deg`` keeping the vertical component; desired attitude from
   the thrust direction and the yaw setpoint (quaternion); collective thrust ``|F|`` (PX4 uses the
   thrust vector's length);
4. attitude P on the quaternion error ``q_e = q⁻¹ ⊗ q_d``, ``e = 2·sign(q_e.w)·q_e.xyz`` (yaw gain
   lower, as PX4's yaw weight) → body-rate setpoint (+ yaw-rate feed-forward), limited;
5. rate PID in angular-acceleration units × inertia = torque; D on the filtered measurement;
   integrator clamped at ``rate_int_frac`` of the axis torque authority, frozen on axes the mixer
   saturates, reset while landed (PX4 resets it on the ground);
6. mixer: per-rotor thrust from [T, τ] with the nominal effectiveness matrix (the controller does
   not know about damage), normalised by the rotor's nominal maximum thrust → setpoints u in 0..1.
   Saturation handling, airmode-like: roll/pitch are scaled down only if their spread exceeds the
   full range, the collective is shifted to fit them (up only when airborne), then yaw is reduced
   until every motor is within 0..1.

Motor command: ``w_com = omega_max · sqrt(u)`` (thrust linear in u). Loops 1-3 run at
``OUTER_RATE_HZ``; 4-6 every step. Arrays are component-major ``(k, N)`` as in dynamics.py.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe
from flightlog_fd.sim.dynamics import VehicleParams

#: PX4 runs the position controller at the estimator output rate, ~50 Hz.
OUTER_RATE_HZ = 50.0
#: Minimum collective thrust as a fraction of the weight while flying (PX4 MPC_THR_MIN-like).
MIN_THRUST_FRACTION = 0.15
#: Velocity-integrator limits, m/s² (xy) and fraction of g (z).
VEL_INT_LIM_XY = 5.0
VEL_INT_LIM_Z_G = 0.5
#: First-order filter on the rate derivative (D term), Hz.
D_TERM_CUTOFF_HZ = 30.0
#: Maximum vertical speeds, m/s (PX4 MPC_Z_VEL_MAX_UP / _DN-like).
MAX_VZ_UP = 3.0
MAX_VZ_DOWN = 1.5

# Controller modes (per vehicle).
MODE_OFF = 0  # disarmed, or armed on the ground before take-off: motors stopped
MODE_POSITION = 1  # position/velocity setpoints (take-off, waypoints, hold, landing)
MODE_MANUAL = 2  # horizontal acceleration from sticks, vertical speed from throttle


@dataclass
class ControllerGains:
    """Gains of N vehicles, component-major (k, N)."""

    rate_kp: np.ndarray  # (3, N) rad/s² per rad/s
    rate_ki: np.ndarray
    rate_kd: np.ndarray
    rate_int_lim: np.ndarray  # (3, N) rad/s²
    att_p: np.ndarray  # (3, N) roll, pitch, yaw
    rate_max: np.ndarray  # (3, N) rad/s
    vel_p: np.ndarray  # (3, N) x, y, z
    vel_i: np.ndarray
    vel_d: np.ndarray
    pos_p: np.ndarray  # (3, N)
    tan_tilt_max: np.ndarray  # (N,)

    @classmethod
    def from_airframes(cls, airframes: Sequence[Airframe], params: VehicleParams) -> "ControllerGains":
        g = [a.gains for a in airframes]

        def arr(f) -> np.ndarray:
            return np.array([f(x) for x in g], dtype=np.float64).T.copy()

        # Torque authority per axis (the rotors on one side at full thrust, the others off).
        t_max = params.thrust_max
        roll_auth = t_max * np.abs(params.rotor_y).sum(axis=0) / 2.0
        pitch_auth = t_max * np.abs(params.rotor_x).sum(axis=0) / 2.0
        yaw_auth = (0.5 * params.n_rotors) * params.k_tau * params.omega_max ** 2
        auth = np.stack([roll_auth, pitch_auth, yaw_auth]) / params.inertia
        return cls(
            rate_kp=arr(lambda x: x.rate_kp), rate_ki=arr(lambda x: x.rate_ki), rate_kd=arr(lambda x: x.rate_kd),
            rate_int_lim=arr(lambda x: x.rate_int_frac) * auth,
            att_p=arr(lambda x: (x.att_p[0], x.att_p[0], x.att_p[1])),
            rate_max=np.radians(arr(lambda x: (x.max_rate_dps[0], x.max_rate_dps[0], x.max_rate_dps[1]))),
            vel_p=arr(lambda x: (x.vel_p[0], x.vel_p[0], x.vel_p[1])),
            vel_i=arr(lambda x: (x.vel_i[0], x.vel_i[0], x.vel_i[1])),
            vel_d=arr(lambda x: (x.vel_d[0], x.vel_d[0], x.vel_d[1])),
            pos_p=arr(lambda x: (x.pos_p[0], x.pos_p[0], x.pos_p[1])),
            tan_tilt_max=np.tan(np.radians(arr(lambda x: x.max_tilt_deg))),
        )


def mixer_matrices(params: VehicleParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nominal allocation: per-rotor thrust = T/R + m_roll·τx + m_pitch·τy + m_yaw·τz (R rotors).

    Returns ``(m_roll, m_pitch, m_yaw)``, each (R, N) in newtons per N·m, from the inverse of the
    effectiveness matrix with rows [1…1; −y_i; x_i; spin_i·k_tau/k_f] (a quad), or its
    pseudo-inverse (the least-squares allocation, as PX4's control allocator) for R != 4.
    """
    n, r = params.n, params.n_rotors
    b = np.empty((n, 4, r))
    b[:, 0, :] = 1.0
    b[:, 1, :] = -params.rotor_y.T
    b[:, 2, :] = params.rotor_x.T
    b[:, 3, :] = params.spin.T * (params.k_tau / params.k_f)[:, None]
    binv = np.linalg.inv(b) if r == 4 else np.linalg.pinv(b)  # (N, R rotors, 4 inputs)
    return binv[:, :, 1].T.copy(), binv[:, :, 2].T.copy(), binv[:, :, 3].T.copy()


def mix(thrust: np.ndarray, torque: np.ndarray, m_roll: np.ndarray, m_pitch: np.ndarray, m_yaw: np.ndarray,
        thrust_max: np.ndarray, airmode: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-motor thrust setpoints u (R, N) in 0..1 from collective thrust (N,) N and torque (3, N) N·m.

    Returns ``(u, rp_saturated, yaw_saturated)``. ``airmode`` (N,) bool: shift the collective up
    to keep roll/pitch authority at low thrust (off on the ground, as PX4).
    """
    inv_tmax = 1.0 / thrust_max
    u_coll = (0.25 if m_roll.shape[0] == 4 else 1.0 / m_roll.shape[0]) * thrust * inv_tmax
    u_rp = (m_roll * (torque[0] * inv_tmax)) + (m_pitch * (torque[1] * inv_tmax))
    u_y = m_yaw * (torque[2] * inv_tmax)

    # Roll/pitch: scaled down only if their spread alone exceeds the full range.
    spread = u_rp.max(axis=0) - u_rp.min(axis=0)
    rp_sat = spread > 1.0
    u_rp /= np.maximum(spread, 1.0)
    a = u_rp + u_coll
    lo, hi = a.min(axis=0), a.max(axis=0)
    # Shift the collective: down when a motor exceeds 1, up (airmode) when one goes below 0.
    over, under = np.maximum(hi - 1.0, 0.0), np.maximum(-lo, 0.0)
    a += under * airmode - over
    rp_sat |= (over > 0.0) | (under > 0.0)

    # Yaw: the largest fraction k of the demand that keeps every motor in 0..1.
    room = np.where(u_y > 0.0, 1.0 - a, a) / np.maximum(np.abs(u_y), 1e-12)
    k = np.minimum(np.maximum(room.min(axis=0), 0.0), 1.0)
    yaw_sat = k < 1.0
    a += k * u_y
    np.maximum(a, 0.0, out=a)
    np.minimum(a, 1.0, out=a)
    return a, rp_sat, yaw_sat


def error_matrix(q_des: np.ndarray) -> np.ndarray:
    """(4, 4, N) matrix A with ``A·q = q⁻¹ ⊗ q_des`` for unit quaternions q (4, N)."""
    w, x, y, z = q_des
    # Right multiplication by q_des, R(p)·a = a ⊗ p, with a = conj(q) = diag(1, −1, −1, −1)·q.
    return np.array([[w, x, y, z],
                     [x, -w, -z, y],
                     [y, z, -w, -x],
                     [z, -y, x, -w]])


class CascadeController:
    """The cascade for N vehicles; call :meth:`outer` every ``outer_every`` steps and :meth:`inner` every step."""

    def __init__(self, airframes: Sequence[Airframe], params: VehicleParams, dt: float):
        self.p = params
        self.g = ControllerGains.from_airframes(airframes, params)
        self.dt = float(dt)
        self.outer_every = max(1, int(round(1.0 / (OUTER_RATE_HZ * dt))))
        self.dt_outer = self.outer_every * self.dt
        n = params.n
        self.n = n
        self.thrust_max = params.thrust_max
        self.m_roll, self.m_pitch, self.m_yaw = mixer_matrices(params)
        self.vel_int = np.zeros((3, n))
        self.rate_int = np.zeros((3, n))
        self.prev_rate = np.zeros((3, n))
        self.rate_dot = np.zeros((3, n))
        self.prev_vel = np.zeros((3, n))
        self.acc_est = np.zeros((3, n))
        self.d_alpha = 1.0 - np.exp(-2 * np.pi * D_TERM_CUTOFF_HZ * self.dt)
        # Outer-loop outputs, held between its updates.
        self.thrust = np.zeros(n)
        self.err_matrix = error_matrix(np.vstack([np.ones(n), np.zeros((3, n))]))
        self.yaw_rate_ff = np.zeros(n)
        self.rp_sat = np.zeros(n, dtype=bool)
        self.yaw_sat = np.zeros(n, dtype=bool)

    # ---------------------------------------------------------------- outer loops
    def outer(self, pos: np.ndarray, vel: np.ndarray, pos_sp: np.ndarray, vel_ff: np.ndarray, speed_lim: np.ndarray,
              yaw_sp: np.ndarray, yaw_rate_ff: np.ndarray, mode: np.ndarray, man_acc_xy: np.ndarray,
              man_vz: np.ndarray, landed: np.ndarray, thrust_ramp: np.ndarray) -> None:
        """Position/velocity loops → desired attitude and collective thrust (held until the next call).

        ``pos``/``vel`` estimates (3, N); ``pos_sp``/``vel_ff`` (3, N); ``speed_lim`` (N,) m/s;
        ``mode`` (N,) MODE_*; ``man_acc_xy`` (2, N) NED m/s² and ``man_vz`` (N,) m/s for MODE_MANUAL;
        ``thrust_ramp`` (N,) 0..1 scales the collective (take-off ramp).
        """
        g, m = self.g, self.p.mass
        vel_sp = g.pos_p * (pos_sp - pos) + vel_ff
        # Horizontal speed limit: the leg's speed plus a margin for catching up with the carrot.
        hs = np.hypot(vel_sp[0], vel_sp[1])
        vel_sp[:2] *= np.minimum(1.0, (speed_lim * 1.2 + 0.3) / np.maximum(hs, 1e-9))
        manual = mode == MODE_MANUAL
        vel_sp[2] = np.clip(np.where(manual, man_vz, vel_sp[2]), -MAX_VZ_UP, MAX_VZ_DOWN)

        err = vel_sp - vel
        # Acceleration estimate for the D term (filtered derivative of the velocity estimate).
        self.acc_est += 0.5 * ((vel - self.prev_vel) / self.dt_outer - self.acc_est)
        self.prev_vel[:] = vel
        acc_sp = g.vel_p * err + self.vel_int - g.vel_d * self.acc_est
        acc_sp[:2] = np.where(manual, man_acc_xy, acc_sp[:2])

        flying = ~landed & (mode != MODE_OFF)
        self.vel_int += g.vel_i * err * (self.dt_outer * flying)
        self.vel_int[:2] *= ~manual
        self.vel_int *= flying
        np.clip(self.vel_int[:2], -VEL_INT_LIM_XY, VEL_INT_LIM_XY, out=self.vel_int[:2])
        np.clip(self.vel_int[2], -VEL_INT_LIM_Z_G * GRAVITY, VEL_INT_LIM_Z_G * GRAVITY, out=self.vel_int[2])

        # Thrust vector (upward force, NED), tilt limited keeping the vertical part.
        f = m * acc_sp
        f[2] = np.minimum(f[2] - m * GRAVITY, -MIN_THRUST_FRACTION * m * GRAVITY)
        fh = np.hypot(f[0], f[1])
        f[:2] *= np.minimum(1.0, -f[2] * g.tan_tilt_max / np.maximum(fh, 1e-9))
        norm = np.sqrt((f * f).sum(axis=0))
        self.thrust = norm * thrust_ramp

        # Desired attitude: the shortest rotation taking the vertical to body z = −F/|F| (tilt),
        # after the heading rotation (yaw): q_d = q_tilt ⊗ q_yaw. Its Euler yaw differs from the
        # setpoint only to second order in the tilt, which the yaw loop absorbs.
        b3x, b3y, b3z = -f[0] / norm, -f[1] / norm, -f[2] / norm
        tw = 1.0 + b3z
        tn = np.sqrt(tw * tw + b3x * b3x + b3y * b3y)
        tw, tx, ty = tw / tn, -b3y / tn, b3x / tn
        cy, sy = np.cos(0.5 * yaw_sp), np.sin(0.5 * yaw_sp)
        self.err_matrix = error_matrix((tw * cy, tx * cy + ty * sy, ty * cy - tx * sy, tw * sy))
        self.yaw_rate_ff = yaw_rate_ff * b3z

    # ---------------------------------------------------------------- inner loops
    def inner(self, q_est: np.ndarray, rate_meas: np.ndarray, landed: np.ndarray, mode: np.ndarray) -> np.ndarray:
        """Attitude + rate loops and the mixer → thrust setpoints u (4, N) in 0..1.

        ``q_est`` (4, N) estimated attitude, ``rate_meas`` (3, N) filtered gyro rad/s.
        """
        g, dt = self.g, self.dt
        qe = (self.err_matrix * q_est).sum(axis=1)
        rate_sp = (2.0 * g.att_p) * qe[1:] * np.where(qe[0] < 0.0, -1.0, 1.0)
        rate_sp[2] += self.yaw_rate_ff
        np.minimum(rate_sp, g.rate_max, out=rate_sp)
        np.maximum(rate_sp, -g.rate_max, out=rate_sp)

        # Rate PID in angular-acceleration units, D on the (filtered) measurement derivative.
        err = rate_sp - rate_meas
        self.rate_dot += self.d_alpha * ((rate_meas - self.prev_rate) * (1.0 / dt) - self.rate_dot)
        self.prev_rate[:] = rate_meas
        torque = (g.rate_kp * err + self.rate_int - g.rate_kd * self.rate_dot) * self.p.inertia

        u, rp_sat, yaw_sat = mix(self.thrust, torque, self.m_roll, self.m_pitch, self.m_yaw, self.thrust_max,
                                 ~landed)
        run = mode != MODE_OFF
        u *= run

        # Integrator with anti-windup: frozen on saturated axes, reset on the ground / when off.
        inc = g.rate_ki * err * dt
        inc[:2] *= ~rp_sat
        inc[2] *= ~yaw_sat
        self.rate_int += inc
        np.minimum(self.rate_int, g.rate_int_lim, out=self.rate_int)
        np.maximum(self.rate_int, -g.rate_int_lim, out=self.rate_int)
        self.rate_int *= run & ~landed
        self.rp_sat, self.yaw_sat = rp_sat, yaw_sat
        return u
