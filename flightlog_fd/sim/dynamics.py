"""Vectorised 6-DoF quadrotor dynamics: N vehicles stepped together as arrays (numpy only).

Frames: world NED (z down, ground at z = 0), body FRD; attitude quaternion ``q = (w, x, y, z)``
rotating body vectors into NED. Units SI: m, m/s, rad/s, N, N·m.

Array layout: component-major, ``(k, N)`` (a 3-vector of N vehicles is ``(3, N)``, rotors
``(4, N)``): sums over components are then contiguous row additions, which keeps a step of a few
hundred vehicles at a few dozen cheap numpy calls.

Model per vehicle (parameters from :class:`~flightlog_fd.sim.airframe.Airframe`):

- motor first-order lag ``w_dot = (w_com - w) / motor_tau`` (discretised exactly), speed clipped to
  ``0..omega_max``;
- rotor i thrust ``f_i = s_i · k_f,i · w_i²`` along −z_body and drag torque
  ``spin_i · s_i · d_i · k_tau,i · w_i²`` about z_body, where ``s_i`` is the per-rotor thrust
  effectiveness (propeller damage η_thrust and the unbalance of the adjusted model, see
  damage.py / rho.py) and ``d_i = η_torque/η_thrust`` the damaged propeller's extra drag
  change; ``k_f,i``, ``k_tau,i`` and the motor lag are the nominal ones × the airframe's per-rotor
  spread (imbalance.py), rotor positions are taken about the (possibly offset) CoG, and a tilted
  rotor adds a yaw torque ``|r_i| sin δ_i · f_i``; ``spin_i`` = +1 for a counter-clockwise rotor seen from above (positive yaw
  torque in FRD, as PX4's positive ``CA_ROTORn_KM``); geometry from
  ``flightlog_fd.flight.Frame.quad_x/quad_plus``;
- roll torque ``−Σ y_i f_i``, pitch torque ``Σ x_i f_i`` (r × F with F = (0, 0, −f));
- linear drag ``drag_lin · (wind − v)``, angular damping ``−drag_ang · ω``, gyroscopic term
  ``−ω × Iω``, and an angular-acceleration disturbance (turbulence / prop wash) from the caller;
- accelerometer: ``QuadDynamics.specific_force`` (3, N) body-frame specific force of the last step,
  ``(−Σ f_i·z_body + drag)/m`` seen in FRD, and ``−g`` along body z while resting on the ground;
- loads (loads.py, :meth:`QuadDynamics.set_loads` with :meth:`VehicleParams.with_loads`): the rigid
  body's mass, rotors about the loaded CoM, the full inertia tensor ``I ω̇ = τ − ω × Iω − cω``,
  the IMU's lever arm to the CoM in the accelerometer, and a payload on a line: its tension
  (reduced-mass solution of the taut line) pulls the body at the attachment point and the
  payload's direction ``n`` swings as a damped spherical pendulum driven by the attachment
  point's acceleration;
- ground contact: the vehicle starts landed at z = 0; while thrust cannot lift it (z ≥ 0 after a
  step) it stays level (yaw kept) with zero velocity and angular velocity; touching down clamps
  z to 0 and levels it the same way.

Integration: semi-implicit Euler (velocities first, then positions/attitude), quaternion
renormalised each step. Steps up to 5 ms are stable for every random airframe (fastest motor lag
15 ms, discretised exactly).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe
from flightlog_fd.sim.esc import loaded_speed
from flightlog_fd.sim.loads import LINE_DAMPING_RATIO, LINE_LIFT_RAMP_M


@dataclass
class VehicleParams:
    """Airframe parameters of N vehicles, component-major: (N,) or (k, N)."""

    mass: np.ndarray  # (N,) kg
    inertia: np.ndarray  # (3, N) kg·m²
    rotor_x: np.ndarray  # (R, N) m, forward (R rotors: 4 on a quad, 6 on a hexa...)
    rotor_y: np.ndarray  # (R, N) m, right
    spin: np.ndarray  # (R, N) +1 CCW / −1 CW
    k_f: np.ndarray  # (N,)
    k_tau: np.ndarray  # (N,)
    motor_tau: np.ndarray  # (N,) s
    omega_max: np.ndarray  # (N,) rad/s
    drag_lin: np.ndarray  # (N,) N/(m/s)
    drag_ang: np.ndarray  # (N,) N·m/(rad/s)
    # Per-rotor imbalance of the real airframe (imbalance.py); None = nominal. The controller's
    # mixer always sees the nominal parameters, only the dynamics the imbalanced ones.
    thrust_scale: Optional[np.ndarray] = None  # (4, N) × k_f
    torque_scale: Optional[np.ndarray] = None  # (4, N) × k_tau
    motor_tau_scale: Optional[np.ndarray] = None  # (4, N) × motor_tau
    tilt_yaw_lever: Optional[np.ndarray] = None  # (4, N) m, yaw torque per newton of rotor thrust
    # Full inertia tensor (3, 3, N) about the CoM of vehicles carrying loads (loads.py: products
    # of inertia of an off-centre mass); None = the diagonal ``inertia``.
    inertia_full: Optional[np.ndarray] = None

    @property
    def n(self) -> int:
        return int(self.mass.shape[0])

    @property
    def n_rotors(self) -> int:
        return int(self.rotor_x.shape[0])

    @property
    def thrust_max(self) -> np.ndarray:
        """(N,) maximum thrust of one healthy rotor, N."""
        return self.k_f * self.omega_max ** 2

    @classmethod
    def from_airframes(cls, airframes: Sequence[Airframe]) -> "VehicleParams":
        rx, ry, sp = [], [], []
        counts = {af.rotor_count for af in airframes}
        if len(counts) > 1:
            raise ValueError(f"one batch flies one rotor count; got {sorted(counts)}")
        for af in airframes:
            frame = af.geometry()
            rx.append([r.x for r in frame.rotors])
            ry.append([r.y for r in frame.rotors])
            sp.append([r.spin for r in frame.rotors])

        def f(name: str) -> np.ndarray:
            return np.array([getattr(a, name) for a in airframes], dtype=np.float64)

        return cls(mass=f("mass"), inertia=np.array([a.inertia for a in airframes], dtype=np.float64).T.copy(),
                   rotor_x=np.array(rx, dtype=np.float64).T.copy(), rotor_y=np.array(ry, dtype=np.float64).T.copy(),
                   spin=np.array(sp, dtype=np.float64).T.copy(), k_f=f("k_f"), k_tau=f("k_tau"),
                   motor_tau=f("motor_tau"), omega_max=f("omega_max"), drag_lin=f("drag_lin"),
                   drag_ang=f("drag_ang"))

    def with_imbalance(self, imb) -> "VehicleParams":
        """These vehicles as built (:class:`~flightlog_fd.sim.imbalance.ImbalanceArrays`): rotors
        placed relative to the shifted CoG, per-rotor coefficient / lag scales, tilt yaw levers."""
        from dataclasses import replace

        arm = np.hypot(self.rotor_x, self.rotor_y)
        return replace(self, rotor_x=self.rotor_x - imb.cog[0] * arm.max(axis=0),
                       rotor_y=self.rotor_y - imb.cog[1] * arm.max(axis=0),
                       thrust_scale=imb.thrust_scale, torque_scale=imb.torque_scale,
                       motor_tau_scale=imb.motor_tau_scale, tilt_yaw_lever=arm * np.sin(imb.tilt))

    def with_loads(self, la) -> "VehicleParams":
        """These vehicles carrying loads (:class:`~flightlog_fd.sim.loads.LoadArrays`): the rigid
        body's mass, rotors placed relative to the loaded CoM, the full inertia about it."""
        from dataclasses import replace

        return replace(self, mass=la.mass.copy(), rotor_x=self.rotor_x - la.shift[0], rotor_y=self.rotor_y - la.shift[1],
                       inertia=np.einsum("iin->in", la.inertia).copy(), inertia_full=la.inertia.copy())

    def rotor_k_f(self) -> np.ndarray:
        """(4, N) thrust coefficient of each rotor."""
        return self.k_f * (np.ones((self.n_rotors, self.n)) if self.thrust_scale is None else self.thrust_scale)

    def rotor_k_tau(self) -> np.ndarray:
        """(4, N) drag-torque coefficient of each rotor."""
        return self.k_tau * (np.ones((self.n_rotors, self.n)) if self.torque_scale is None else self.torque_scale)

    def rotor_motor_tau(self) -> np.ndarray:
        """(4, N) motor time constant of each rotor, s."""
        return self.motor_tau * (np.ones((self.n_rotors, self.n)) if self.motor_tau_scale is None
                                 else self.motor_tau_scale)

    def torque_matrix(self) -> np.ndarray:
        """(3, 4, N): body torque = Σ_i G[:, i] · (s_i w_i²) (roll, pitch from thrust; yaw from drag
        and from the tilted rotors' horizontal thrust)."""
        k_f = self.rotor_k_f()
        yaw = self.spin * self.rotor_k_tau()
        if self.tilt_yaw_lever is not None:
            yaw = yaw + self.tilt_yaw_lever * k_f
        return np.stack([-self.rotor_y * k_f, self.rotor_x * k_f, yaw])

    def drag_torque_row(self) -> np.ndarray:
        """(4, N): the rotor drag-torque part of the yaw row of :meth:`torque_matrix`."""
        return self.spin * self.rotor_k_tau()


@dataclass
class RigidBodyState:
    """State of N vehicles (component-major). ``landed``: resting on the ground."""

    pos: np.ndarray  # (3, N) NED m
    vel: np.ndarray  # (3, N) NED m/s
    quat: np.ndarray  # (4, N) w, x, y, z body→NED
    omega: np.ndarray  # (3, N) body FRD rad/s
    w: np.ndarray  # (R, N) rotor speeds rad/s
    landed: np.ndarray  # (N,) bool

    @classmethod
    def on_ground(cls, n: int, yaw: Optional[np.ndarray] = None, n_rotors: int = 4) -> "RigidBodyState":
        yaw = np.zeros(n) if yaw is None else np.asarray(yaw, dtype=np.float64)
        quat = np.zeros((4, n))
        quat[0] = np.cos(yaw / 2.0)
        quat[3] = np.sin(yaw / 2.0)
        return cls(pos=np.zeros((3, n)), vel=np.zeros((3, n)), quat=quat, omega=np.zeros((3, n)),
                   w=np.zeros((n_rotors, n)), landed=np.ones(n, dtype=bool))


def quat_to_euler(q: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions (w, x, y, z) → (..., 3) roll, pitch, yaw rad (ZYX, as PX4 and ArduPilot)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=-1)


def quat_yaw(q: np.ndarray) -> np.ndarray:
    """(4, N) quaternions → (N,) yaw rad."""
    w, x, y, z = q
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def cross(a: np.ndarray, b: np.ndarray, out: Optional[np.ndarray] = None) -> np.ndarray:
    """Cross product of (3, N) arrays (``np.cross`` costs several times more on this layout)."""
    out = np.empty_like(a) if out is None else out
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


class QuadDynamics:
    """Steps N vehicles with a fixed ``dt`` (see module docstring for the model)."""

    def __init__(self, params: VehicleParams, dt: float):
        self.p = params
        self.dt = float(dt)
        self.motor_alpha = 1.0 - np.exp(-self.dt / params.rotor_motor_tau())
        self.inv_mass = 1.0 / params.mass
        self.inv_inertia = 1.0 / params.inertia
        self.g_torque = params.torque_matrix()
        self.g_drag = params.drag_torque_row()
        self.k_f = params.rotor_k_f()
        self.omega_max = params.omega_max
        self.drag_ang = params.drag_ang
        self.drag_lin = params.drag_lin
        self._acc = np.empty((3, params.n))
        #: Body-frame specific force (3, N) m/s² of the last step: what an accelerometer reads.
        self.specific_force = np.zeros((3, params.n))
        self.specific_force[2] = -GRAVITY
        #: Whether step() updates ``specific_force``; nothing else reads it, so a run that records
        #: no accelerometer turns it off (a tenth of a training batch's time).
        self.track_specific_force = True
        self._dq = np.empty((4, params.n))
        self._cross = np.empty((3, params.n))
        self.k_tau_rotor = params.rotor_k_tau()
        #: Load-dependent motor speed (sim/esc.py): None = the rotor reaches its commanded speed.
        self.motor_a0: Optional[np.ndarray] = None
        self.motor_kv: Optional[np.ndarray] = None
        self.motor_exp: Optional[np.ndarray] = None
        self.torque_rel = np.ones_like(self.k_tau_rotor) if params.torque_scale is None else params.torque_scale
        #: Loads (loads.py, :meth:`set_loads`): full inertia, the IMU's offset from the loaded CoM
        #: (3, N) body m, and a payload on a line (None: none).
        self.inertia_full = params.inertia_full
        self.inv_inertia_full = (None if params.inertia_full is None
                                 else np.linalg.inv(params.inertia_full.transpose(2, 0, 1)).transpose(1, 2, 0).copy())
        self.imu_offset: Optional[np.ndarray] = None
        self.line_mass: Optional[np.ndarray] = None

    def set_motor_model(self, a0: np.ndarray, kv_scale: np.ndarray, speed_exponent: Optional[np.ndarray] = None) -> None:
        """Use the load-dependent motor model of sim/esc.py (``a0`` (N,) s/rad, ``kv_scale`` (R, N);
        ``speed_exponent`` (N,) the drive's speed law, None: all 1, :func:`~flightlog_fd.sim.esc.loaded_speed`)."""
        self.motor_a0 = np.asarray(a0, dtype=np.float64)
        self.motor_kv = np.asarray(kv_scale, dtype=np.float64)
        self.motor_exp = None if speed_exponent is None or np.all(np.asarray(speed_exponent) == 1.0) else \
            np.asarray(speed_exponent, dtype=np.float64)

    def rotor_drag_torque(self, w: np.ndarray, effectiveness: np.ndarray,
                          drag_ratio: Optional[np.ndarray] = None) -> np.ndarray:
        """(4, N) magnitude of each propeller's aerodynamic drag torque N·m (what its motor delivers)."""
        q = self.k_tau_rotor * effectiveness
        if drag_ratio is not None:
            q = q * drag_ratio
        return q * w * w

    def step(self, s: RigidBodyState, w_com: np.ndarray, effectiveness: np.ndarray, wind: np.ndarray,
             ang_acc_dist: np.ndarray, speed_gain: Optional[np.ndarray] = None,
             drag_ratio: Optional[np.ndarray] = None, drive: Optional[np.ndarray] = None) -> np.ndarray:
        """Advance ``s`` in place by one step; returns the (4, N) rotor thrusts of this step.

        ``w_com`` (4, N) commanded rotor speeds rad/s; ``effectiveness`` (4, N) thrust/torque scale;
        ``wind`` (3, N) NED m/s; ``ang_acc_dist`` (3, N) rad/s²; ``speed_gain`` (4, N) optional
        multiplier on the rotor speed seen by the air (the paper's adjusted model); ``drag_ratio``
        (4, N) optional drag-torque efficiency / thrust efficiency of each rotor (a damaged
        propeller loses torque and thrust in different proportions, damage.py); ``drive`` (4, N)
        optional fraction of the commanded speed each motor delivers (a weak motor or ESC, damage.py).
        """
        dt = self.dt
        w = s.w
        if self.motor_a0 is not None:
            load = self.torque_rel * effectiveness * (1.0 if drag_ratio is None else drag_ratio)
            w_com = loaded_speed(w_com, load, self.motor_a0, self.motor_kv, drive, self.motor_exp, self.omega_max)
        elif drive is not None:
            w_com = w_com * drive
        w += self.motor_alpha * (w_com - w)
        np.minimum(w, self.omega_max, out=w)
        np.maximum(w, 0.0, out=w)
        w_air = w if speed_gain is None else w * speed_gain
        w2 = effectiveness * w_air * w_air
        f = self.k_f * w2
        thrust = f.sum(axis=0)
        torque = (self.g_torque * w2).sum(axis=1)
        if drag_ratio is not None:
            torque[2] += (self.g_drag * (drag_ratio - 1.0) * w2).sum(axis=0)

        # Translational: thrust along −z_body, linear drag relative to the air (gravity below).
        om = s.omega
        q = s.quat
        qw, qx, qy, qz = q
        acc = self._acc
        acc[0] = 2 * (qx * qz + qw * qy)
        acc[1] = 2 * (qy * qz - qw * qx)
        acc[2] = 1 - 2 * (qx * qx + qy * qy)
        acc *= -thrust
        acc += self.drag_lin * (wind - s.vel)
        acc *= self.inv_mass
        if self.line_mass is not None:  # a payload on a line: its tension on the body (loads.py)
            torque = torque + self._line_tension(s, acc)

        # Rotational dynamics: I ω_dot = τ − ω × Iω − c ω, plus the disturbance.
        if self.inertia_full is None:
            om_dot = torque - cross(om, self.p.inertia * om, self._cross) - self.drag_ang * om
            om_dot *= self.inv_inertia
        else:  # a vehicle carrying loads: the full tensor about the loaded CoM
            i_om = np.einsum("ijn,jn->in", self.inertia_full, om)
            om_dot = np.einsum("ijn,jn->in", self.inv_inertia_full,
                               torque - cross(om, i_om, self._cross) - self.drag_ang * om)
        om_dot += ang_acc_dist
        if self.track_specific_force:
            self._body_frame(q, acc, self.specific_force)  # the accelerometer: thrust + drag, no gravity
            if self.imu_offset is not None:  # the IMU at the frame centre, off the loaded CoM
                r = self.imu_offset
                self.specific_force += cross(om_dot, r) + cross(om, cross(om, r))
        if self.line_mass is not None:
            self._om_dot = om_dot.copy()
        acc[2] += GRAVITY
        s.vel += acc * dt
        s.pos += s.vel * dt
        om += om_dot * dt

        # Quaternion kinematics q_dot = ½ q ⊗ (0, ω), first order, renormalised.
        h = om * (0.5 * dt)
        dq = self._dq
        dq[0] = -(q[1:] * h).sum(axis=0)
        dq[1:] = qw * h + cross(q[1:], h, self._cross)
        q += dq
        q /= np.sqrt((q * q).sum(axis=0))

        # Ground contact: resting or touching down → clamp, zero velocities, level (keep yaw).
        ground = s.pos[2] >= 0.0
        s.landed = ground
        if ground.any():
            air = ~ground
            if self.track_specific_force:
                # Resting on the ground the accelerometer reads the normal force: −g along body z.
                self.specific_force *= air
                self.specific_force[2] -= GRAVITY * ground
            s.pos[2] *= air
            s.vel *= air
            om *= air
            yaw = quat_yaw(q)
            q[1] *= air
            q[2] *= air
            q[0] = np.where(ground, np.cos(yaw / 2.0), q[0])
            q[3] = np.where(ground, np.sin(yaw / 2.0), q[3])
        if self.line_mass is not None:
            self._swing_step()
        return f

    def set_loads(self, la) -> None:
        """Fly the loads of :class:`~flightlog_fd.sim.loads.LoadArrays` ``la`` (the params must come
        from :meth:`VehicleParams.with_loads`): the IMU's lever arm to the loaded CoM and, where a
        vehicle carries one, the payload on a line (hanging straight down at the start)."""
        n = self.p.n
        self.imu_offset = -la.shift.copy() if np.any(la.shift) else None
        if not np.any(la.line_mass):
            return
        self.line_mass = la.line_mass.copy()
        self.line_attach = la.line_attach.copy()
        self.line_length = la.line_length.copy()
        m = self.p.mass
        self._line_mu = self.line_mass * m / (m + self.line_mass)  # reduced mass: tension per m/s²
        self._line_w0 = np.sqrt(GRAVITY / self.line_length)
        self.line_n = np.zeros((3, n))
        self.line_n[2] = 1.0
        self.line_ndot = np.zeros((3, n))
        self._om_dot = np.zeros((3, n))
        self.line_tension = np.zeros(n)

    @staticmethod
    def _rotation(q: np.ndarray) -> np.ndarray:
        """(3, 3, N) body→NED rotation matrices of (4, N) quaternions."""
        w, x, y, z = q
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

    def _line_tension(self, s: RigidBodyState, acc: np.ndarray) -> np.ndarray:
        """Add the line's pull to ``acc`` (NED specific force of the body, m/s²) in place and
        return its (3, N) body torque about the CoM.

        The tension follows from the line staying taut (|n| = 1): with the attachment point's
        acceleration ``a_a = g + acc + T·n/M + rot`` (``rot``: ω̇ × r + ω × (ω × r), ω̇ of the
        previous step) and the payload's ``m·(a_a + L·n̈) = m·g − T·n``,
        ``T = μ·(L·|ṅ|² − (acc + rot)·n)`` with the reduced mass ``μ = m·M/(m + M)``; never
        negative (a slack line pulls nothing), scaled by how far the payload is lifted."""
        r_mat = self._rotation(s.quat)
        ra = self.line_attach
        rot_b = cross(self._om_dot, ra) + cross(s.omega, cross(s.omega, ra))
        rot_w = np.einsum("ijn,jn->in", r_mat, rot_b)
        ra_w = np.einsum("ijn,jn->in", r_mat, ra)
        n, nd = self.line_n, self.line_ndot
        base = acc + rot_w
        # The payload rests on the ground until the attachment point is a line length up.
        self._lifted = np.clip(-(s.pos[2] + ra_w[2] + self.line_length) / LINE_LIFT_RAMP_M, 0.0, 1.0)
        self._swing_drive = base
        tension = self._line_mu * np.maximum(self.line_length * (nd * nd).sum(axis=0) - (base * n).sum(axis=0), 0.0)
        tension *= self._lifted
        self.line_tension = tension
        pull = n * tension
        acc += pull * self.inv_mass
        pull_b = np.einsum("jin,jn->in", r_mat, pull)  # Rᵀ: NED → body
        return cross(ra, pull_b)

    def _swing_step(self) -> None:
        """Advance the payload's direction ``n`` (NED unit vector from the attachment point) by one
        step: ``n̈ = −(acc + rot)⊥ / L − |ṅ|²·n − 2ζω₀·ṅ`` (the attachment point's acceleration
        across the line, the constraint, light damping); straight down and still while on the ground."""
        dt = self.dt
        n, nd = self.line_n, self.line_ndot
        drive = -self._swing_drive
        drive -= (drive * n).sum(axis=0) * n
        ndd = drive / self.line_length - (nd * nd).sum(axis=0) * n - (2.0 * LINE_DAMPING_RATIO * self._line_w0) * nd
        nd += ndd * dt
        n += nd * dt
        n /= np.sqrt((n * n).sum(axis=0))
        nd -= (nd * n).sum(axis=0) * n
        rest = self._lifted < 1.0
        if rest.any():
            n[:, rest] = np.array([[0.0], [0.0], [1.0]])
            nd[:, rest] = 0.0

    @staticmethod
    def _body_frame(q: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
        """(3, N) NED vectors ``v`` → body frame (FRD) in ``out``, for (4, N) body-to-NED ``q``."""
        w, x, y, z = q
        out[0] = (1 - 2 * (y * y + z * z)) * v[0] + 2 * (x * y + w * z) * v[1] + 2 * (x * z - w * y) * v[2]
        out[1] = 2 * (x * y - w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] + 2 * (y * z + w * x) * v[2]
        out[2] = 2 * (x * z + w * y) * v[0] + 2 * (y * z - w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2]
