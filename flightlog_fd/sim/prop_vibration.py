"""Propeller imbalance in the simulator: the once-per-revolution force and moment of an
out-of-balance propeller, the IMU that sees it, and the vibration metrics the autopilots log.

Physics, per rotor k, with its phase φ_k integrated from its simulated speed w_k (motor dynamics,
recorded at every simulation step) and its spin direction:

- **mass imbalance** m·r (kg·m): a force m·r·w² in the rotor plane, rotating with the rotor;
- **aerodynamic imbalance** ε: the blades' thrusts differ by ε of the rotor's thrust T = k_f·w²
  (a cut, chipped or mis-pitched blade): a hub moment ε·T·r_a about an in-plane axis rotating
  with the rotor (r_a = ``AERO_CENTRE`` of the propeller radius ``PROP_RADIUS_PER_ARM``·arm), and
  the blades' drag differs alike: an in-plane force ε·Q/r_a (Q = k_tau·w²) rotating with it;
- the hub sits ``HUB_HEIGHT_PER_ARM``·arm above the centre of mass at the rotor's (x, y): the
  in-plane force also has the moment r × F.

Rigid body: the accelerometer (at the centre of mass) reads F/m; the gyro reads ∫ I⁻¹·M dt, for
a line at w the phasor I⁻¹·M / (j·w). Every signal is Σ_k Re[P_k(t)·H(f_k)·e^{jφ_k(t)}] with P_k
the rotor's phasor and H the sensor path's filter at the rotor's frequency; it is evaluated at
the sensor's sample times (``SENSOR_RATE_HZ``), from the phase integrated at the simulation
step (250-400 Hz is too coarse for rotor lines of 80-280 Hz; a phasor at the exact sample time
is not). The line is left out of the simulated dynamics: the controller's bandwidth (< 10 Hz)
is far below rotor rates and the force moves the airframe by micrometres, so a flight's controls
are those of the balanced vehicle.

What is logged, as the autopilots do it (the raw sensor: rigid-body specific force / rates
interpolated at the sample times + the line + the airframe's broadband vibration floor + gyro
noise and bias):

- ArduPilot: ``VIBE`` at ``METRIC_LOG_HZ`` = sqrt of the 2 Hz low-pass of the squared deviation of
  the raw accelerometer from its 5 Hz low-pass, on every raw sample (AP_InertialSensor
  ``calc_vibration_and_clipping``: ``AP_INERTIAL_SENSOR_ACCEL_VIBE_FLOOR_FILT_HZ`` 5,
  ``..._VIBE_FILT_HZ`` 2; first-order filters), with the clipping count (any axis beyond
  ``CLIP_LIMIT``); the IMU message (the flight's ``rates`` and ``accel``) after the 2-pole
  ``INS_GYRO_FILTER`` (the airframe's gyro cutoff) / ``INS_ACCEL_FILTER`` (20 Hz) filters,
  sampled at the log rate (aliasing what the filter leaves);
- PX4: ``vehicle_imu_status`` at ``METRIC_LOG_HZ``: ``accel_vibration_metric`` = 0.99·m + 0.01·|a_k −
  a_k−1| on every raw sample (VehicleIMU::UpdateAccelVibrationMetrics), the gyro metric and the
  coning metric |g_k × g_k−1| alike; ``vehicle_angular_velocity`` (``rates``) after the 2-pole
  ``IMU_GYRO_CUTOFF``; ``sensor_combined`` accelerometer (``accel``) as the mean over the
  integration interval (``PX4_INTEGRATION_HZ``), sampled at the log rate;
- optionally raw samples at ``imu_rate_hz`` (``SENSOR_RATE_HZ``/k: every k-th raw sample, no
  anti-alias filter): ArduPilot ``ACC``/``GYR`` (raw IMU logging), PX4 ``sensor_accel`` /
  ``sensor_gyro``.

Healthy airframes: every propeller keeps a residual mass imbalance, balance grade G =
e·w_max drawn log-uniformly from ``RESIDUAL_GRADE_MM_S`` (ISO 21940-11, e = m·r / propeller
mass) with the propeller mass ``PROP_MASS_FRACTION`` of the vehicle's, and a residual blade thrust
difference from ``RESIDUAL_AERO_RANGE``; and the airframe has a broadband vibration floor
(motors, airflow, frame) whose horizontal VIBE level is drawn log-uniformly from
``FLOOR_LEVEL_RANGE``, the span of the real healthy airframes (results/vibration.md), varied per
flight by ``FLOOR_FLIGHT_SPREAD_LOG``. Residuals and floor are drawn from a generator seeded by
the airframe's parameters, so two flights of one airframe share them (a calibration flight and a
later one).

Limits: rigid airframe (a real frame's arm and plate modes amplify or damp the line: octo_air's
15-35 mm cuts raised VIBE 5-7x, more than a rigid body of that mass would); IMU at the centre of
mass; one line per rotor (no harmonics, no blade-pass line); the floor is white.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.flight import Flight, ImuStream, Series, Vibration
from flightlog_fd.sim.airframe import Airframe

#: The raw IMU sample rate both autopilots compute their metrics on: ArduPilot's backends run the
#: gyro at 1 kHz by default (INS_GYRO_RATE 0); PX4's IMU drivers publish about 1 kHz (FIFO means).
SENSOR_RATE_HZ = 1000.0
#: ArduPilot AP_INERTIAL_SENSOR_ACCEL_VIBE_FLOOR_FILT_HZ and _VIBE_FILT_HZ (AP_InertialSensor.h).
VIBE_FLOOR_HZ = 5.0
VIBE_FILT_HZ = 2.0
#: Clipping threshold: (16 - 0.5) g, the default of ArduPilot's backends.
CLIP_LIMIT = 15.5 * 9.80665
#: PX4 VehicleIMU vibration metrics: m = (1 - PX4_METRIC_ALPHA) m + PX4_METRIC_ALPHA |difference|.
PX4_METRIC_ALPHA = 0.01
#: VIBE (ArduCopter's 10 Hz logging loop) and vehicle_imu_status (published at 10 Hz) rates.
METRIC_LOG_HZ = 10.0
#: ArduPilot INS_ACCEL_FILTER default (Hz, 2-pole).
AP_ACCEL_FILTER_HZ = 20.0
#: PX4 IMU_INTEG_RATE default: sensor_combined holds the mean of the raw samples over 1/this s.
PX4_INTEGRATION_HZ = 200.0
#: Rotor plane above the centre of mass (fraction of the arm): an F450 with the battery under the
#: centre plate has its motor hubs ~45 mm above the centre of mass on 225 mm arms.
HUB_HEIGHT_PER_ARM = 0.2
#: Propeller radius per arm: F450 10-inch (127 mm on 225 mm arms: 0.56), X500 13-inch (0.66),
#: Crazyflie 2.1 46 mm (0.50); median.
PROP_RADIUS_PER_ARM = 0.56
#: A blade's thrust acts at 0.75 of the radius (blade-element rule of thumb).
AERO_CENTRE = 0.75
#: Mass of one propeller per vehicle mass: 10-inch 12 g on a 1.5 kg F450 (0.008), 13-inch 15 g on
#: a 2 kg X500 (0.0075), 0.2 g on a 30 g Crazyflie (0.007).
PROP_MASS_FRACTION = 0.0075
#: Residual balance grade of intact propellers (mm/s, G = e·w at full speed, ISO 21940-11):
#: G 6.3 (balanced on a propeller balancer) to G 40 (an off-the-shelf moulded propeller).
RESIDUAL_GRADE_MM_S = (6.3, 40.0)
#: Residual blade-to-blade thrust difference of an intact propeller (fraction): a ±0.25° pitch
#: tolerance on a 10-15° blade changes a blade's lift by up to 2 %.
RESIDUAL_AERO_RANGE = (0.0, 0.02)
#: Healthy airframes' broadband vibration, horizontal VIBE sqrt(X² + Y²) in m/s/s, log-uniform:
#: the real healthy airframes in ../shared span 0.7 (Erle copter34_7) to 8.0 (Erle copter34_22).
FLOOR_LEVEL_RANGE = (0.7, 8.0)
#: Flight-to-flight spread (std of ln) of one airframe's floor: measured 0.03-0.20 (results/vibration.md).
FLOOR_FLIGHT_SPREAD_LOG = 0.10
#: The floor grows with the rotors' speed as (w / w_hover)^this, w the rotors' mean speed and
#: w_hover the airframe's balanced hover speed: the forces that shake a frame (imbalance, blade
#: passage, motor magnetics) go as w². So motors at rest add no floor, and a payload that turns the
#: rotors faster shakes more without any damage (the same exponent as the vibration analyzer's
#: SPEED_EXPONENT prior: a simulated payload checks the comparison at matching speed, not the
#: exponent itself, which no real log in ../shared spans enough rotor speed to measure).
FLOOR_SPEED_EXPONENT = 2.0
#: Raw IMU logging rates the simulator writes (divisors of SENSOR_RATE_HZ).
IMU_RATES_HZ = (100.0, 125.0, 200.0, 250.0, 500.0, 1000.0)


@dataclass(frozen=True)
class PropImbalance:
    """Imbalance added to one vehicle's propellers: ``mass`` m·r per rotor (kg·m), ``aero`` blade
    thrust difference per rotor (fraction of the rotor's thrust); shorter tuples are padded with 0.
    ``residual`` False removes the healthy residuals and floor (physics checks)."""

    mass: tuple = ()
    aero: tuple = ()
    residual: bool = True

    @classmethod
    def on(cls, motor: int, mass: float = 0.0, aero: float = 0.0, rotors: int = 4,
           residual: bool = True) -> "PropImbalance":
        """Imbalance on one motor (1..rotors)."""
        if not 1 <= motor <= rotors:
            raise ValueError(f"imbalance motor must be 1..{rotors}, got {motor}")
        m, a = [0.0] * rotors, [0.0] * rotors
        m[motor - 1], a[motor - 1] = float(mass), float(aero)
        return cls(tuple(m), tuple(a), residual)

    def arrays(self, rotors: int) -> tuple[np.ndarray, np.ndarray]:
        m = np.zeros(rotors)
        a = np.zeros(rotors)
        if len(self.mass) > rotors or len(self.aero) > rotors:
            raise ValueError(f"imbalance given for {max(len(self.mass), len(self.aero))} rotors on a "
                             f"{rotors}-rotor vehicle")
        m[:len(self.mass)] = self.mass
        a[:len(self.aero)] = self.aero
        if np.any(m < 0) or np.any(a < 0) or np.any(a >= 1):
            raise ValueError("mass imbalance must be >= 0 kg·m and aerodynamic imbalance in [0, 1)")
        return m, a


PropSpec = Union[None, str, PropImbalance, Sequence[Optional[PropImbalance]]]


@dataclass
class PropVibration:
    """One vehicle's resolved propeller vibration (see module docstring)."""

    mass: np.ndarray  # (R,) total m·r, kg·m (residual + added)
    aero: np.ndarray  # (R,) total blade thrust difference
    added_mass: np.ndarray  # (R,)
    added_aero: np.ndarray  # (R,)
    floor: float  # horizontal broadband level of this flight, m/s/s (0: none)
    phase0: np.ndarray  # (R,) rad

    def to_dict(self) -> dict:
        return {"mass_kgm": self.mass.tolist(), "aero": self.aero.tolist(),
                "added_mass_kgm": self.added_mass.tolist(), "added_aero": self.added_aero.tolist(),
                "floor_ms2": self.floor, "sensor_hz": SENSOR_RATE_HZ}


def _airframe_rng(af: Airframe) -> np.random.Generator:
    """A generator seeded by the airframe's parameters: the same airframe draws the same residuals."""
    key = np.array([af.mass, af.arm, af.k_f, af.k_tau, af.omega_max, af.motor_tau, *af.inertia], dtype=np.float64)
    return np.random.default_rng(np.frombuffer(key.tobytes(), dtype=np.uint32))


def airframe_residuals(af: Airframe) -> tuple[np.ndarray, np.ndarray, float]:
    """(m·r (R,) kg·m, ε (R,), floor level m/s/s) of this airframe's intact propellers and frame."""
    rng = _airframe_rng(af)
    r = af.rotor_count
    grade = np.exp(rng.uniform(*np.log(RESIDUAL_GRADE_MM_S), size=r)) * 1e-3  # m/s
    mass = PROP_MASS_FRACTION * af.mass * grade / af.omega_max
    aero = rng.uniform(*RESIDUAL_AERO_RANGE, size=r)
    floor = float(np.exp(rng.uniform(*np.log(FLOOR_LEVEL_RANGE))))
    return mass, aero, floor


def resolve(spec: PropSpec, airframes: Sequence[Airframe], seed: int, realism: bool = True
            ) -> Optional[list[PropVibration]]:
    """Per-vehicle PropVibration (None: the model is off). ``spec``: None, "residual" (healthy
    residuals only), one PropImbalance for all, or a list of n (None entries: residual only)."""
    if spec is None:
        return None
    n = len(airframes)
    if isinstance(spec, str):
        if spec != "residual":
            raise ValueError(f"prop_imbalance must be None, 'residual', a PropImbalance or a list; got {spec!r}")
        specs = [PropImbalance()] * n
    elif isinstance(spec, PropImbalance):
        specs = [spec] * n
    else:
        specs = [PropImbalance() if s is None else s for s in spec]
        if len(specs) != n:
            raise ValueError(f"got {len(specs)} propeller imbalances for {n} vehicles")
    out = []
    for i, (af, s) in enumerate(zip(airframes, specs)):
        rng = np.random.default_rng([seed, 9, i])
        add_m, add_a = s.arrays(af.rotor_count)
        res_m, res_a, floor = airframe_residuals(af)
        if not s.residual:
            res_m, res_a, floor = np.zeros_like(res_m), np.zeros_like(res_a), 0.0
        floor *= float(np.exp(rng.normal(0.0, FLOOR_FLIGHT_SPREAD_LOG)))
        out.append(PropVibration(res_m + add_m, np.clip(res_a + add_a, 0.0, 0.99), add_m, add_a,
                                 floor if realism else 0.0, rng.uniform(0.0, 2 * np.pi, size=af.rotor_count)))
    return out


def butterworth2(f: np.ndarray, fc: float) -> np.ndarray:
    """Complex response of a 2-pole Butterworth low-pass at ``fc`` (the autopilots' LowPassFilter2p)."""
    s = 1j * np.asarray(f, dtype=np.float64) / fc
    return 1.0 / (s * s + np.sqrt(2.0) * s + 1.0)


def boxcar(f: np.ndarray, seconds: float) -> np.ndarray:
    """Complex response of the mean over the last ``seconds`` (integrated IMU samples)."""
    x = np.asarray(f, dtype=np.float64) * seconds
    return np.sinc(x) * np.exp(-1j * np.pi * x)


class RotorLines:
    """Phasors of one vehicle's rotor lines (accelerometer m/s², gyro rad/s), evaluated at any time."""

    def __init__(self, af: Airframe, pv: PropVibration, t_step: np.ndarray, w_step: np.ndarray):
        frame = af.geometry()
        self.t = t_step
        self.w = w_step.astype(np.float64)  # (steps, R) rad/s
        dt = np.diff(t_step)
        steps = 0.5 * (self.w[1:] + self.w[:-1]) * dt[:, None]
        self.phi = np.vstack([np.zeros((1, self.w.shape[1])), np.cumsum(steps, axis=0)]) + pv.phase0
        self.af, self.pv = af, pv
        self.spin = np.array([r.spin for r in frame.rotors], dtype=np.float64)
        self.x = np.array([r.x for r in frame.rotors]) * af.arm
        self.y = np.array([r.y for r in frame.rotors]) * af.arm
        self.h = HUB_HEIGHT_PER_ARM * af.arm
        self.r_a = AERO_CENTRE * PROP_RADIUS_PER_ARM * af.arm
        self.inertia = np.asarray(af.inertia, dtype=np.float64)

    def speed(self, t: np.ndarray, k: int) -> np.ndarray:
        return np.interp(t, self.t, self.w[:, k])

    def phasors(self, t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(accel phasor (n, 3), gyro phasor (n, 3), e^{jφ} (n,)) of rotor k at times ``t`` (sim clock)."""
        af, pv = self.af, self.pv
        w = self.speed(t, k)
        phi = np.interp(t, self.t, self.phi[:, k])
        s = self.spin[k]
        u = np.array([1.0, 1j * s, 0.0])  # in-plane unit vector rotating with the rotor (FRD)
        z_u = np.array([-1j * s, 1.0, 0.0])  # z × u (the aerodynamic moment's axis)
        x, y, h = self.x[k], self.y[k], self.h
        r_u = np.array([h * u[1], -h * u[0], x * u[1] - y * u[0]])  # (x, y, -h) × u
        w2 = w * w
        c_f = pv.mass[k] * w2 - 1j * pv.aero[k] * af.k_tau * w2 / self.r_a  # force on u: mass + drag difference
        c_m = pv.aero[k] * af.k_f * w2 * self.r_a  # aerodynamic moment on z × u
        acc = c_f[:, None] * u[None, :] / af.mass
        mom = c_f[:, None] * r_u[None, :] + c_m[:, None] * z_u[None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            gyro = np.where(w[:, None] > 1.0, mom / self.inertia[None, :] / (1j * np.maximum(w, 1.0))[:, None], 0.0)
        return acc, gyro, np.exp(1j * phi)

    def signal(self, t: np.ndarray, filt=None) -> tuple[np.ndarray, np.ndarray]:
        """(accel (n, 3), gyro (n, 3)) of all rotors at times ``t``; ``filt(f_hz) -> complex`` (or a
        pair for accel, gyro) is the sensor path's filter at each rotor's frequency."""
        fa, fg = (filt, filt) if not isinstance(filt, tuple) else filt
        acc = np.zeros((t.size, 3))
        gyro = np.zeros((t.size, 3))
        for k in range(self.w.shape[1]):
            a, g, e = self.phasors(t, k)
            f = self.speed(t, k) / (2 * np.pi)
            ha = 1.0 if fa is None else fa(f)[:, None]
            hg = 1.0 if fg is None else fg(f)[:, None]
            acc += np.real(a * ha * e[:, None])
            gyro += np.real(g * hg * e[:, None])
        return acc, gyro


def _first_order(x: np.ndarray, alpha: float) -> np.ndarray:
    """y_k = y_k-1 + alpha (x_k - y_k-1), started at x_0 (ArduPilot's LowPassFilter), along axis 0."""
    from scipy.signal import lfilter

    zi = (1.0 - alpha) * x[:1]
    y, _ = lfilter([alpha], [1.0, -(1.0 - alpha)], x, axis=0, zi=zi)
    return y


def _alpha(fc: float, dt: float) -> float:
    return dt / (dt + 1.0 / (2 * np.pi * fc))


def ardupilot_vibe(acc: np.ndarray, fs: float) -> np.ndarray:
    """(n, 3) VIBE X/Y/Z of raw accelerometer samples ``acc`` (n, 3) at ``fs`` Hz."""
    dt = 1.0 / fs
    d = acc - _first_order(acc, _alpha(VIBE_FLOOR_HZ, dt))
    return np.sqrt(np.maximum(_first_order(d * d, _alpha(VIBE_FILT_HZ, dt)), 0.0))


def px4_metrics(acc: np.ndarray, gyro: np.ndarray) -> np.ndarray:
    """(n, 3) vehicle_imu_status accel_vibration_metric, gyro_vibration_metric, gyro_coning_vibration."""
    from scipy.signal import lfilter

    def smooth(x):
        return lfilter([PX4_METRIC_ALPHA], [1.0, -(1.0 - PX4_METRIC_ALPHA)], x)

    da = np.linalg.norm(np.diff(acc, axis=0, prepend=acc[:1]), axis=1)
    dg = np.linalg.norm(np.diff(gyro, axis=0, prepend=gyro[:1]), axis=1)
    cone = np.linalg.norm(np.cross(gyro, np.vstack([gyro[:1], gyro[:-1]])), axis=1)
    return np.column_stack([smooth(da), smooth(dg), smooth(cone)])


def add_vibration(flight: Flight, af: Airframe, pv: PropVibration, res, i: int, *, autopilot: str,
                  rates_hz: float, gyro_density: float, gyro_bias: np.ndarray, gyro_cutoff_hz: float,
                  imu_rate_hz: Optional[float], rng: np.random.Generator) -> None:
    """Add the rotor lines and the floor to vehicle ``i``'s logged IMU (``flight.rates`` /
    ``flight.accel``), and set ``flight.vibration`` (metrics, raw streams); ``res`` the batch's
    recording with ``w_fine``, ``omega_fine`` and ``sforce`` at every step."""
    offset = float(flight.truth["log_start_boot_s"])
    lines = RotorLines(af, pv, res.times["w_fine"], res.data["w_fine"][:, i, :])
    fs = SENSOR_RATE_HZ
    t_last = flight.t_end - offset
    ts = np.arange(0.0, t_last, 1.0 / fs)
    w_hover = af.omega_max * np.sqrt(af.hover_command)
    w_mean = np.interp(ts, lines.t, lines.w.mean(axis=1))
    # per axis: VIBE of white noise above 5 Hz is its RMS; growing with the rotors' speed
    sigma_t = pv.floor / np.sqrt(2.0) * (np.maximum(w_mean, 0.0) / w_hover) ** FLOOR_SPEED_EXPONENT
    sigma = pv.floor / np.sqrt(2.0)  # at hover: what the logged (decimated) streams carry
    line_a, line_g = lines.signal(ts)
    t_fine = res.times["sforce"]
    sf = np.column_stack([np.interp(ts, t_fine, res.data["sforce"][:, i, c]) for c in range(3)])
    om = np.column_stack([np.interp(ts, t_fine, res.data["omega_fine"][:, i, c]) for c in range(3)])
    acc_raw = sf + line_a + sigma_t[:, None] * rng.standard_normal((ts.size, 3))
    gyro_raw = om + gyro_bias + line_g + gyro_density * np.sqrt(fs) * rng.standard_normal((ts.size, 3))
    every = int(round(fs / METRIC_LOG_HZ))
    idx = np.arange(every - 1, ts.size, every)
    tm = ts[idx] + offset
    clip = np.cumsum(np.any(np.abs(acc_raw) > CLIP_LIMIT, axis=1))[idx].astype(np.float64)[:, None]

    px4 = autopilot == "px4"
    if px4:
        h_acc = (lambda f: boxcar(f, 1.0 / max(PX4_INTEGRATION_HZ, rates_hz)))
        floor_logged = sigma / np.sqrt(fs / max(PX4_INTEGRATION_HZ, rates_hz))
    else:
        h_acc = (lambda f: butterworth2(f, AP_ACCEL_FILTER_HZ))
        bw = AP_ACCEL_FILTER_HZ * (np.pi / 4) / np.sin(np.pi / 4)  # noise bandwidth of a 2-pole Butterworth
        floor_logged = sigma * np.sqrt(min(bw / (fs / 2), 1.0))
    h_gyro = (lambda f: butterworth2(f, gyro_cutoff_hz))
    combined_gyro = None
    if flight.rates is not None:
        t = flight.rates.t - offset
        _, g = lines.signal(t, (None, h_gyro))
        if px4:  # sensor_combined.gyro_rad: the raw gyro integrated over PX4's interval (VehicleIMU),
            # not the rate controller's IMU_GYRO_CUTOFF low-pass (vehicle_angular_velocity)
            _, gi = lines.signal(t, (None, h_acc))
            combined_gyro = Series(flight.rates.t, flight.rates.values + gi, "sensor_combined.gyro_rad")
        flight.rates = Series(flight.rates.t, flight.rates.values + g, flight.rates.source)
    if flight.accel is not None:
        t = flight.accel.t - offset
        a, _ = lines.signal(t, (h_acc, None))
        grow = (np.maximum(np.interp(t, lines.t, lines.w.mean(axis=1)), 0.0) / w_hover) ** FLOOR_SPEED_EXPONENT
        a = a + floor_logged * grow[:, None] * rng.standard_normal(a.shape)
        flight.accel = Series(flight.accel.t, flight.accel.values + a, flight.accel.source)

    raw = None
    if imu_rate_hz:
        k = int(round(fs / imu_rate_hz))
        if k < 1 or abs(fs / k - imu_rate_hz) > 1e-6:
            raise ValueError(f"imu_rate_hz must divide {fs:g} Hz: one of {IMU_RATES_HZ}")
        tr = ts[::k] + offset
        if px4:
            raw = ImuStream(0, "sensor_accel/gyro[0]", Series(tr, acc_raw[::k], "sensor_accel[0].x/y/z"),
                            Series(tr, gyro_raw[::k], "sensor_gyro[0].x/y/z"))
        else:
            raw = ImuStream(0, "ACC/GYR[0]", Series(tr, acc_raw[::k], "ACC[0].AccX/Y/Z"),
                            Series(tr, gyro_raw[::k], "GYR[0].GyrX/Y/Z"))
    if px4:
        m = px4_metrics(acc_raw, gyro_raw)[idx]
        vib = Vibration("px4_imu_status",
                        {0: Series(tm, m, "vehicle_imu_status[0].accel/gyro_vibration_metric, coning")},
                        {0: Series(tm, clip, "vehicle_imu_status[0].accel_clipping")})
        logged = ImuStream(0, "sensor_combined",
                           Series(flight.accel.t, flight.accel.values, "sensor_combined.accelerometer_m_s2")
                           if flight.accel is not None else None,
                           combined_gyro if combined_gyro is not None else
                           Series(flight.rates.t, flight.rates.values, "sensor_combined.gyro_rad"))
    else:
        vib = Vibration("ardupilot_vibe", {0: Series(tm, ardupilot_vibe(acc_raw, fs)[idx], "VIBE[0].VibeX/Y/Z")},
                        {0: Series(tm, clip, "VIBE[0].Clip")})
        logged = ImuStream(0, "IMU[0]",
                           Series(flight.accel.t, flight.accel.values, "IMU[0].AccX/Y/Z")
                           if flight.accel is not None else None,
                           Series(flight.rates.t, flight.rates.values, "IMU[0].GyrX/Y/Z"))
    vib.imus = sorted([s for s in (raw, logged) if s is not None], key=lambda s: -s.rate_hz)
    flight.vibration = vib
    w_hover = np.array([np.median(lines.w[lines.w[:, k] > 0.3 * af.omega_max, k]) if np.any(
        lines.w[:, k] > 0.3 * af.omega_max) else 0.0 for k in range(af.rotor_count)])
    flight.truth["prop_imbalance"] = {
        **pv.to_dict(), "imu_rate_hz": imu_rate_hz,
        "rotor_hz": (w_hover / (2 * np.pi)).round(2).tolist(),
        # amplitude of each rotor's mass-imbalance acceleration at its median airborne speed (m/s/s)
        "line_ms2": (pv.mass * w_hover ** 2 / af.mass).round(4).tolist()}
