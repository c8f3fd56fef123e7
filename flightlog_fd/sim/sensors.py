"""Sensor, estimator and environment realism for N vehicles (numpy, vectorised, arrays (k, N)).

- Gyro: ``raw = ω + bias + white noise`` (noise density 0.04-0.25 °/s/√Hz, i.e. per-sample
  σ = density·√(sim rate), so the filtered noise does not depend on the step size; bias
  N(0, 0.3 °/s) per axis), then the autopilot's gyro low-pass (first order at the airframe's
  ``gyro_cutoff_hz``, PX4 IMU_GYRO_CUTOFF-like), plus propeller vibration at each rotor's rotation
  frequency, attenuated by a 2nd-order low-pass gain ``1/√(1 + (f/fc)⁴)`` evaluated at that
  frequency (see damage.py for the amplitude). This filtered signal is what the rate controller
  uses and what PX4 logs as ``vehicle_angular_velocity`` (ArduPilot ``IMU``/``RATE``). The white
  noise is read at random offsets from a pool of ``NOISE_POOL_SIZE`` pre-drawn normals (cost);
  vibration phasors are rotated by ``w·dt`` each step, amplitudes refreshed at the outer-loop rate.
- Accelerometer: the body specific force (``QuadDynamics.specific_force``) + a constant bias
  N(0, ``ACCEL_BIAS_STD``) + white noise σ per logged sample drawn log-uniformly from
  ``ACCEL_NOISE_STD`` (m/s²). Measured per 250 Hz sample after a 0.4 s high-pass, airborne:
  real PX4 ``sample_px4_events`` 0.03 / 0.03 / 0.10 (x / y / z, the z including the thrust
  changes), PX4 SIH dev flights 0.35 / 1.2 / 1.0 (white: 69 % of the z power above 20 Hz); old
  ArduCopter IMU logs at 24-50 Hz, aliased vibration, 0.2-2 on z. Vibration lines at the rotor
  frequency are not modelled on the accelerometer. Drawn from a generator derived from the gyro
  parameters, so adding the accelerometer left every other simulated stream unchanged.
- Attitude estimate: the true attitude delayed by ``ATTITUDE_DELAY_S`` (estimator latency).
- Position/velocity estimates: true + Ornstein-Uhlenbeck errors (velocity σ 0.02-0.1 m/s with
  0.5 s correlation; position σ 0.05-0.3 m with 3 s correlation), as a GNSS/EKF solution wanders.
- Wind: mean 0-5 m/s horizontal, gusts OU per axis σ 0.2-1.5 m/s (vertical half) with 2 s
  correlation; acts through the linear drag. Both are capped for light vehicles so that the mean
  wind's drag is at most ``MAX_WIND_DRAG_FRACTION`` of the weight (a nano quad does not fly in 5 m/s).
- Turbulence / prop-wash torque: OU angular-acceleration disturbance with 0.1 s correlation
  (advanced at the outer-loop rate), sized so that it alone shakes the hovering vehicle by about
  1-6 °/s RMS: σ_α = level · rate-loop kp. With the gyro noise, hover rates come out at 2-10 °/s
  RMS (PX4 SIH dev flights: 6-8 °/s roll, 3-5 pitch, 1.5-2 yaw; a Crazyflie about 2 °/s) and
  angular accelerations from 250 Hz differences at 200-800 °/s² RMS (SIH: 800/400/170).
  ``noise="real_logs"`` raises the upper ends to 9 °/s wobble and 0.35 °/s/√Hz (the shipped
  model's training data, build_default) so that flight noise spans real healthy logs (``python benchmarks/real_imbalance.py --sim 24``, 0.5 s detrended std
  over airborne time): real Erle ArduCopter / CrazyPAD roll-pitch gyro 2-43 °/s (median ≈ 8),
  yaw 0.6-11, motor commands 0.008-0.09 (median ≈ 0.02); simulated random airframes roll-pitch
  p10/50/90 ≈ 4.5 / 7 / 13 °/s, yaw 1.4 / 2.5 / 4.5, motor commands 0.012 / 0.018 / 0.033
  (the wobbliest real logs, > 20 °/s, are beyond it). Full table: imbalance.py. It is not the
  default because the calmest hovers then get rarer (fdlog calibrate needs hover < 14 °/s).

``realism=False`` switches all of this off (exact measurements, no wind, no delay): used for
physics unit tests.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe
from flightlog_fd.sim.dynamics import VehicleParams

ATTITUDE_DELAY_S = 0.008
GYRO_NOISE_DENSITY_DPS = (0.04, 0.25)  # °/s/√Hz
GYRO_BIAS_STD_DPS = 0.3
VEL_NOISE_STD = (0.02, 0.10)
VEL_NOISE_TAU_S = 0.5
POS_NOISE_STD = (0.05, 0.30)
POS_NOISE_TAU_S = 3.0
WIND_MEAN_MS = (0.0, 5.0)
GUST_STD_MS = (0.2, 1.5)
GUST_TAU_S = 2.0
MAX_WIND_DRAG_FRACTION = 0.25
TURBULENCE_WOBBLE_DPS = (1.0, 6.0)
#: Wider ranges spanning real healthy logs (see below), opt-in: ``SensorParams.draw(noise="real_logs")``.
REAL_LOG_TURBULENCE_WOBBLE_DPS = (1.0, 9.0)
REAL_LOG_GYRO_NOISE_DENSITY_DPS = (0.04, 0.25)
NOISE_LEVELS = ("default", "real_logs")
TURBULENCE_TAU_S = 0.1
ACCEL_NOISE_STD = (0.05, 1.2)  # m/s² per logged sample (see the module docstring)
ACCEL_BIAS_STD = 0.2  # m/s²
#: Share of the roll/pitch vibration that appears on the yaw gyro (frame flex is mostly in-plane).
VIBRATION_YAW_SHARE = 0.3
#: White gyro noise is read from a pool of pre-drawn normals at random offsets (drawing 3·N normals
#: every step would cost as much as the whole dynamics step); 2**20 samples repeat no visible pattern.
NOISE_POOL_SIZE = 1 << 20


@dataclass
class SensorParams:
    """Per-vehicle realism parameters (arrays, leading axis = vehicle)."""

    gyro_noise_density: np.ndarray  # (N,) rad/s/√Hz
    gyro_bias: np.ndarray  # (N, 3) rad/s
    gyro_cutoff_hz: np.ndarray  # (N,)
    vel_noise_std: np.ndarray  # (N,) m/s
    pos_noise_std: np.ndarray  # (N,) m
    wind_mean: np.ndarray  # (N, 3) m/s
    gust_std: np.ndarray  # (N,) m/s
    turbulence_std: np.ndarray  # (N, 3) rad/s²
    attitude_delay_s: float
    vibration_gain: float  # rad/s per unit imbalance at full speed (0 disables)
    realism: bool

    @classmethod
    def draw(cls, airframes: Sequence[Airframe], rng: np.random.Generator, *, realism: bool = True,
             vibration_gain: float = 1.2, noise: str = "default") -> "SensorParams":
        if noise not in NOISE_LEVELS:
            raise ValueError(f"noise must be one of {NOISE_LEVELS}, got {noise!r}")
        wobble_range = TURBULENCE_WOBBLE_DPS if noise == "default" else REAL_LOG_TURBULENCE_WOBBLE_DPS
        density_range = GYRO_NOISE_DENSITY_DPS if noise == "default" else REAL_LOG_GYRO_NOISE_DENSITY_DPS
        n = len(airframes)
        cutoff = np.array([a.gyro_cutoff_hz for a in airframes], dtype=np.float64)
        if not realism:
            z = np.zeros(n)
            return cls(gyro_noise_density=z, gyro_bias=np.zeros((n, 3)), gyro_cutoff_hz=cutoff, vel_noise_std=z,
                       pos_noise_std=z, wind_mean=np.zeros((n, 3)), gust_std=z, turbulence_std=np.zeros((n, 3)),
                       attitude_delay_s=0.0, vibration_gain=0.0, realism=False)
        kp = np.array([a.gains.rate_kp for a in airframes], dtype=np.float64)
        wind_dir = rng.uniform(-np.pi, np.pi, size=n)
        # A light vehicle cannot fly in a wind whose drag needs a steep tilt: cap the mean wind
        # (and the gusts) so that their drag stays within MAX_WIND_DRAG_FRACTION of the weight.
        weight = np.array([a.mass for a in airframes]) * GRAVITY
        drag = np.array([a.drag_lin for a in airframes])
        wind_cap = np.minimum(WIND_MEAN_MS[1], MAX_WIND_DRAG_FRACTION * weight / drag)
        wind_speed = rng.uniform(0.0, 1.0, size=n) * wind_cap
        wobble = np.radians(rng.uniform(*wobble_range, size=n))
        return cls(
            gyro_noise_density=np.radians(rng.uniform(*density_range, size=n)),
            gyro_bias=np.radians(rng.normal(0.0, GYRO_BIAS_STD_DPS, size=(n, 3))),
            gyro_cutoff_hz=cutoff,
            vel_noise_std=rng.uniform(*VEL_NOISE_STD, size=n),
            pos_noise_std=rng.uniform(*POS_NOISE_STD, size=n),
            wind_mean=np.stack([wind_speed * np.cos(wind_dir), wind_speed * np.sin(wind_dir), np.zeros(n)], axis=1),
            gust_std=rng.uniform(*GUST_STD_MS, size=n) * np.minimum(1.0, wind_cap / WIND_MEAN_MS[1]),
            # Yaw is shaken less than roll/pitch (no lever arm for most disturbances).
            turbulence_std=wobble[:, None] * kp * np.array([1.0, 1.0, 0.4]),
            attitude_delay_s=ATTITUDE_DELAY_S, vibration_gain=vibration_gain, realism=True,
        )

    def to_dict(self, i: int) -> dict:
        """Vehicle ``i``'s realism parameters in plain units (for Flight.truth)."""
        return {
            "gyro_noise_density_dps_rthz": float(np.degrees(self.gyro_noise_density[i])),
            "gyro_bias_dps": np.degrees(self.gyro_bias[i]).round(4).tolist(),
            "wind_mean_ms": self.wind_mean[i].round(3).tolist(),
            "gust_std_ms": float(self.gust_std[i]),
            "turbulence_std_rads2": self.turbulence_std[i].round(4).tolist(),
            "vibration_gain": self.vibration_gain,
        }


def _ou_coeffs(dt: float, tau: float) -> tuple[float, float]:
    """Exact discretisation of an OU process with unit stationary σ: x ← a·x + b·N(0, 1)."""
    a = float(np.exp(-dt / tau))
    return a, float(np.sqrt(1.0 - a * a))


class Sensors:
    """Measurement and disturbance generator for one batch (component-major arrays, (k, N))."""

    def __init__(self, sp: SensorParams, vp: VehicleParams, dt: float, dt_outer: float, rng: np.random.Generator):
        self.sp, self.vp, self.rng, self.dt = sp, vp, rng, dt
        n = vp.n
        self.n = n
        self.gyro_sigma = sp.gyro_noise_density * np.sqrt(1.0 / dt)
        self.gyro_alpha = 1.0 - np.exp(-2 * np.pi * sp.gyro_cutoff_hz * dt)
        self.gyro_bias = sp.gyro_bias.T.copy()
        self.turb_std = sp.turbulence_std.T.copy()
        self.gyro_filt = np.zeros((3, n))
        # Vibration phasors (sin, cos of each rotor's phase), rotated each step by w·dt.
        r = vp.rotor_x.shape[0]
        phase = rng.uniform(0.0, 2 * np.pi, size=(r, n))
        self.vib_s, self.vib_c = np.sin(phase), np.cos(phase)
        self.rot_s, self.rot_c = np.zeros((r, n)), np.ones((r, n))
        self.vib_amp = np.zeros((r, n))
        arm = np.hypot(vp.rotor_x, vp.rotor_y)
        self.vib_yaw_x = VIBRATION_YAW_SHARE * vp.rotor_x / arm
        self.vib_yaw_y = VIBRATION_YAW_SHARE * vp.rotor_y / arm
        self._vib = np.empty((3, n))
        self.pool = rng.standard_normal(NOISE_POOL_SIZE) if sp.realism else np.zeros(3 * n)
        self.offsets: list[int] = []
        self.delay_steps = int(round(sp.attitude_delay_s / dt))
        self.q_buf = None  # ring buffer of past attitudes, created on first use
        self.buf_i = 0
        self.turb = np.zeros((3, n))
        self.outer_every = max(1, int(round(dt_outer / dt)))
        self.turb_a_outer, self.turb_b_outer = _ou_coeffs(dt_outer, TURBULENCE_TAU_S)
        self.gust_a, self.gust_b = _ou_coeffs(dt_outer, GUST_TAU_S)
        self.vel_a, self.vel_b = _ou_coeffs(dt_outer, VEL_NOISE_TAU_S)
        self.pos_a, self.pos_b = _ou_coeffs(dt_outer, POS_NOISE_TAU_S)
        self.gust_std = sp.gust_std * np.array([1.0, 1.0, 0.5])[:, None]
        self.wind_mean = sp.wind_mean.T.copy()
        if sp.realism:
            # Start the slow processes in their stationary distribution.
            r = rng.standard_normal((9, n))
            self.gust = r[0:3] * self.gust_std
            self.vel_err = r[3:6] * sp.vel_noise_std
            self.pos_err = r[6:9] * sp.pos_noise_std
        else:
            self.gust, self.vel_err, self.pos_err = np.zeros((3, n)), np.zeros((3, n)), np.zeros((3, n))
        self.wind = self.wind_mean + self.gust
        self.vib_gain = sp.vibration_gain
        if sp.realism:
            # The accelerometer's own generator, seeded from the gyro parameters: it draws nothing
            # from ``rng``, so the other streams of a seeded batch do not depend on it.
            self.acc_rng = np.random.default_rng(np.frombuffer(np.ascontiguousarray(sp.gyro_bias).tobytes(),
                                                               dtype=np.uint32))
            lo, hi = ACCEL_NOISE_STD
            self.acc_sigma = np.exp(self.acc_rng.uniform(np.log(lo), np.log(hi), size=n))
            self.acc_bias = self.acc_rng.normal(0.0, ACCEL_BIAS_STD, size=(3, n))
        else:
            self.acc_rng, self.acc_sigma, self.acc_bias = None, np.zeros(n), np.zeros((3, n))

    def accelerometer(self, specific_force: np.ndarray) -> np.ndarray:
        """(3, N) accelerometer reading (m/s², FRD) for the body specific force: bias + white noise."""
        if self.acc_rng is None:
            return specific_force.copy()
        return specific_force + self.acc_bias + self.acc_sigma * self.acc_rng.standard_normal((3, self.n))

    def nav(self, pos: np.ndarray, vel: np.ndarray, w: np.ndarray, imbalance: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Outer-loop tick: (pos_est, vel_est, wind), each (3, N), with estimator errors and gusts advanced.

        Also refreshes the vibration amplitudes from the rotor speeds ``w`` (4, N) and the
        propeller ``imbalance`` (4, N) (they change slowly compared with the outer-loop period).
        """
        if not self.sp.realism:
            return pos, vel, self.wind
        sp = self.sp
        r = self.rng.standard_normal((12, self.n))
        self.gust = self.gust_a * self.gust + self.gust_b * r[0:3] * self.gust_std
        self.wind = self.wind_mean + self.gust
        self.vel_err = self.vel_a * self.vel_err + self.vel_b * r[3:6] * sp.vel_noise_std
        self.pos_err = self.pos_a * self.pos_err + self.pos_b * r[6:9] * sp.pos_noise_std
        self.turb = self.turb_a_outer * self.turb + self.turb_b_outer * r[9:12] * self.turb_std
        if self.vib_gain > 0.0:
            ratio = w * (1.0 / (2 * np.pi)) / sp.gyro_cutoff_hz
            w_rel = w / self.vp.omega_max
            ratio *= ratio
            self.vib_amp = self.vib_gain * imbalance * w_rel * w_rel / np.sqrt(1.0 + ratio * ratio)
            # Per-step phasor rotation for the coming steps (rotor speeds change slowly) and
            # renormalisation of the phasors against rounding drift.
            self.rot_s, self.rot_c = np.sin(w * self.dt), np.cos(w * self.dt)
            norm = np.sqrt(self.vib_s * self.vib_s + self.vib_c * self.vib_c)
            self.vib_s /= norm
            self.vib_c /= norm
        self.offsets = list(self.rng.integers(0, NOISE_POOL_SIZE - 3 * self.n, size=self.outer_every))
        return pos + self.pos_err, vel + self.vel_err, self.wind

    def gyro_and_disturbance(self, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(filtered gyro (3, N) rad/s as the controller and logger see it, disturbance (3, N) rad/s²).

        The turbulence is advanced at the outer-loop rate (its 0.1 s correlation is much longer).
        """
        if not self.sp.realism:
            return omega.copy(), self.turb
        off = self.offsets.pop() if self.offsets else int(self.rng.integers(0, NOISE_POOL_SIZE - 3 * self.n))
        white = self.pool[off:off + 3 * self.n].reshape(3, self.n)
        raw = omega + self.gyro_bias + self.gyro_sigma * white
        self.gyro_filt += self.gyro_alpha * (raw - self.gyro_filt)
        if self.vib_gain <= 0.0:
            return self.gyro_filt, self.turb
        s, c = self.vib_s, self.vib_c
        s_new = s * self.rot_c + c * self.rot_s
        c *= self.rot_c
        c -= s * self.rot_s
        s[:] = s_new
        sa, ca = s * self.vib_amp, c * self.vib_amp
        vib = self._vib
        vib[0] = sa.sum(axis=0)
        vib[1] = ca.sum(axis=0)
        vib[1] *= -1.0
        vib[2] = (self.vib_yaw_x * sa - self.vib_yaw_y * ca).sum(axis=0)
        return self.gyro_filt + vib, self.turb

    def attitude(self, q: np.ndarray) -> np.ndarray:
        """Estimated attitude quaternion (4, N): the true one ``attitude_delay_s`` ago."""
        d = self.delay_steps
        if d == 0:
            return q
        if self.q_buf is None:
            self.q_buf = np.repeat(q[None], d + 1, axis=0)
        self.q_buf[self.buf_i] = q
        self.buf_i = (self.buf_i + 1) % (d + 1)
        return self.q_buf[self.buf_i]
