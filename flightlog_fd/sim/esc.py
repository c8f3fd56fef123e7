"""ESC telemetry in the simulator: the motor's electrical side and what its ESC reports.

Motor model (enabled per batch by ``simulate_flights(esc=...)``; without it the rotor reaches
its commanded speed whatever the load). A brushless motor on an open-loop ESC is a DC
motor: ``w = Kv·(d·V − R·I)`` with ``I = I0 + τ·Kv`` (SI, Kt = 1/Kv) and the propeller's drag
torque ``τ = q·w²``. The autopilot's command ``u`` gives the duty whose *nominal* motor and
propeller turn at ``w_com = omega_max·sqrt(u)``; the no-load speed of that duty is then
``w_nl = w_com + a0·w_com²`` with ``a0 = δ / ((1 − δ)·omega_max)``, δ the speed the nominal
propeller's load costs at full command (``DROOP_FULL_RANGE``: hobby multirotor motors lose
10-20 % of their no-load speed at full throttle with the propeller they were sized for). A rotor
with torque coefficient ``L·q0`` (L: damage η_torque, the airframe's torque spread, the
unbalance) and a motor of ``kv`` times the nominal Kv turns at the root of
``a0·L·kv²·w² + w = kv·w_nl``: a lighter (cut, chipped) propeller spins faster at the same
command, a trim change (CoG offset, motor tilt) only moves the motor along its own curve. A weak
motor or ESC (sim/damage.py, cause "motor") delivers a fraction of the no-load speed: it turns
slower at the same command, with its propeller's current per rpm².

Speed law (``EscParams.speed_exponent`` b, default 1): the nominal rotor turns at
``omega_max·u^(b/2)`` for the autopilot's thrust command ``u``. b = 1 when the autopilot's thrust
model matches the rotor (thrust linear in ``u``); a real airframe's seldom does: ArduCopter 4.7
SITL (``MOT_THST_EXPO`` 0.65 over a motor whose speed is linear in its signal) measures b 1.31-1.34
(``motor1_weak_esc.BIN``, results/cause.md), and PX4's ``THR_MDL_FAC`` 0 over such a motor gives
about 2. The controller sees the same law (its integrators absorb it), as on a real airframe.
Battery sag is left to the autopilot's voltage compensation (ArduPilot ``MOT_BAT_VOLT_*``, PX4
``THR_MDL_FAC`` with battery scaling): the pack voltage is reported, not fed back.

What the ESC reports, per motor, at its own rate (``rate_hz`` 10-100 Hz, each ESC with its own
latency of up to one interval, whole µs):

- RPM: the mechanical speed ``w·60/2π`` with relative noise ``RPM_NOISE_FRAC`` (commutation timing),
  quantised in eRPM steps of ``ERPM_STEP`` (DShot / BLHeli telemetry: 100 eRPM) over the motor's
  pole pairs;
- current: ``gain_k · (I0 + τ·Kv_k) + offset_k`` plus noise, in 0.01 A steps; τ is the
  propeller's aerodynamic drag torque (the rotor's acceleration torque is left out);
  ``gain_k``/``offset_k``: the ESC's current-sense spread (``CURRENT_GAIN_STD``; offset
  ``CURRENT_OFFSET_FRAC`` of the hover current);
- voltage: the pack (``cells`` × ``CELL_V_START`` falling at ``CELL_DISCHARGE_V_PER_S``) minus
  ``PACK_R_PER_CELL``·cells·(total current), 0.01 V steps;
- temperature: 25 °C rising with the motor's current (first order, ``TEMP_TAU_S``), whole °C.

Per-vehicle draws (:func:`random_esc_params`): KV spread ``1 + N(0, KV_STD)`` clipped to
``± KV_CLIP`` (a few percent, same-batch motors); pole pairs from ``POLE_PAIRS``; cell count
from the mass (1S at 30 g ... 6S at 5 kg); Kv from omega_max and the pack voltage; I0 a fraction
``NO_LOAD_CURRENT_FRACTION`` of the hover current.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.flight import EscChannel, EscTelemetry
from flightlog_fd.sim.airframe import Airframe

#: ESC telemetry rates drawn when none is given (Hz): DShot/BLHeli telemetry on ArduPilot and
#: PX4 reach 10-100 Hz per ESC.
RATE_RANGE_HZ = (10.0, 100.0)
#: Speed lost to the nominal propeller's load at full command (fraction of the no-load speed).
DROOP_FULL_RANGE = (0.10, 0.20)
KV_STD = 0.015
KV_CLIP = 0.04
POLE_PAIRS = (6, 7, 7, 7, 12)
ERPM_STEP = 100.0
RPM_NOISE_FRAC = 0.002
CURRENT_GAIN_STD = 0.01
CURRENT_OFFSET_FRAC = 0.02
CURRENT_NOISE_FRAC = 0.01
CURRENT_STEP_A = 0.01
NO_LOAD_CURRENT_FRACTION = 0.04
CELL_V_START = 4.1
CELL_DISCHARGE_V_PER_S = 0.0008
PACK_R_PER_CELL = 0.004
VOLTAGE_STEP_V = 0.01
TEMP_AMBIENT_C = 25.0
TEMP_RISE_C_PER_HOVER_CURRENT = 15.0
TEMP_TAU_S = 60.0
#: Speed-law exponents the simulator accepts (module docstring): 1 a thrust model that fits the
#: rotor; ~2 PX4's THR_MDL_FAC 0 over a motor whose speed is linear in its signal; beyond, none
#: seen.
SPEED_EXPONENT_RANGE = (0.8, 2.2)
#: Largest recording rate of the ESC streams (the simulation records at sim_rate / k, k integer).
MAX_RECORD_HZ = 100.0


@dataclass(frozen=True)
class EscParams:
    """One vehicle's motors and ESCs (see module docstring)."""

    rate_hz: float
    droop_full: float
    kv_scale: tuple[float, ...]  # one per rotor
    pole_pairs: int
    cells: int
    kv_si: float  # nominal Kv, rad/s per volt
    no_load_current_a: float
    current_gain: tuple[float, ...]
    current_offset_a: tuple[float, ...]
    latency_frac: tuple[float, ...]  # each ESC's report latency, fraction of an interval
    speed_exponent: float = 1.0  # the drive's speed law b: omega_max·u^(b/2) (module docstring)

    def to_dict(self) -> dict:
        return asdict(self)


EscSpec = Union[None, str, float, tuple[float, float], EscParams, Sequence[Optional[EscParams]]]


def cells_for(af: Airframe) -> int:
    """Battery cells of an airframe: 1S at 30 g, 4S at 1-2 kg, 5-6S at 5 kg."""
    return int(np.clip(round(3.9 + 1.7 * np.log10(af.mass)), 1, 6))


def random_esc_params(af: Airframe, rng: np.random.Generator, rate_hz: Optional[float] = None,
                      speed_exponent: float = 1.0) -> EscParams:
    """Random motors/ESCs for ``af`` (see module docstring); ``rate_hz`` None draws one in RATE_RANGE_HZ;
    ``speed_exponent`` the speed law (given, never drawn: the draws stay those of older versions)."""
    rate = float(rng.uniform(*RATE_RANGE_HZ)) if rate_hz is None else float(rate_hz)
    droop = float(rng.uniform(*DROOP_FULL_RANGE))
    r = int(getattr(af, "rotor_count", 4))
    kv = 1.0 + np.clip(rng.normal(0.0, KV_STD, r), -KV_CLIP, KV_CLIP)
    cells = cells_for(af)
    w_nl_max = af.omega_max / (1.0 - droop)
    kv_si = w_nl_max / (cells * CELL_V_START)
    hover_torque = af.k_tau * af.omega_max ** 2 * af.hover_command
    hover_current = hover_torque * kv_si
    return EscParams(rate_hz=rate, droop_full=droop, kv_scale=tuple(float(x) for x in kv),
                     pole_pairs=int(rng.choice(POLE_PAIRS)), cells=cells, kv_si=float(kv_si),
                     no_load_current_a=float(NO_LOAD_CURRENT_FRACTION * hover_current),
                     current_gain=tuple(float(x) for x in 1.0 + rng.normal(0.0, CURRENT_GAIN_STD, r)),
                     current_offset_a=tuple(float(x) for x in rng.normal(0.0, CURRENT_OFFSET_FRAC, r)
                                            * max(hover_current, 0.05)),
                     latency_frac=tuple(float(x) for x in rng.uniform(0.0, 1.0, r)),
                     speed_exponent=float(speed_exponent))


def resolve_esc(spec: EscSpec, airframes: Sequence[Airframe], rng: np.random.Generator) -> Optional[list[EscParams]]:
    """None (no ESC telemetry, ideal speed-controlled motors) / "random" / a rate in Hz / (rate in
    Hz, speed exponent): random motors at that rate whose rotors turn as omega_max·u^(b/2) (the same
    draws as the rate alone) / one EscParams for all / a list of n."""
    if spec is None:
        return None
    if isinstance(spec, tuple) and len(spec) == 2 and all(isinstance(x, (int, float)) for x in spec):
        rate, b = float(spec[0]), float(spec[1])
        if not RATE_RANGE_HZ[0] <= rate <= MAX_RECORD_HZ:
            raise ValueError(f"ESC rate must be {RATE_RANGE_HZ[0]:g}..{MAX_RECORD_HZ:g} Hz, got {rate}")
        if not SPEED_EXPONENT_RANGE[0] <= b <= SPEED_EXPONENT_RANGE[1]:
            raise ValueError(f"the rotors' rpm curve exponent must be {SPEED_EXPONENT_RANGE[0]:g}.."
                             f"{SPEED_EXPONENT_RANGE[1]:g}, got {b:g}")
        return [random_esc_params(af, rng, rate, b) for af in airframes]
    if isinstance(spec, str):
        if spec != "random":
            raise ValueError(f"esc must be None, 'random', a rate in Hz, EscParams or a list, got {spec!r}")
        return [random_esc_params(af, rng) for af in airframes]
    if isinstance(spec, (int, float)):
        if not RATE_RANGE_HZ[0] <= float(spec) <= MAX_RECORD_HZ:
            raise ValueError(f"ESC rate must be {RATE_RANGE_HZ[0]:g}..{MAX_RECORD_HZ:g} Hz, got {spec}")
        return [random_esc_params(af, rng, float(spec)) for af in airframes]
    if isinstance(spec, EscParams):
        return [spec] * len(airframes)
    out = list(spec)
    if len(out) != len(airframes):
        raise ValueError(f"got {len(out)} ESC parameter sets for {len(airframes)} vehicles")
    return [p if p is not None else random_esc_params(af, rng) for p, af in zip(out, airframes)]


@dataclass
class MotorArrays:
    """What the dynamics needs of the ESC model, component-major: droop coefficient a0 (N,) s/rad,
    KV scale (R, N) and the speed law's exponent (N,)."""

    a0: np.ndarray
    kv_scale: np.ndarray
    speed_exponent: Optional[np.ndarray] = None

    @classmethod
    def build(cls, params: Sequence[EscParams], airframes: Sequence[Airframe]) -> "MotorArrays":
        a0 = np.array([p.droop_full / ((1.0 - p.droop_full) * af.omega_max) for p, af in zip(params, airframes)])
        return cls(a0=a0, kv_scale=np.array([p.kv_scale for p in params], dtype=np.float64).T.copy(),
                   speed_exponent=np.array([p.speed_exponent for p in params], dtype=np.float64))


def loaded_speed(w_com: np.ndarray, load: np.ndarray, a0: np.ndarray, kv: np.ndarray,
                 drive: Optional[np.ndarray] = None, exponent: Optional[np.ndarray] = None,
                 omega_max: Optional[np.ndarray] = None) -> np.ndarray:
    """Steady rotor speed (R, N) for commanded speeds ``w_com`` of the nominal motor, relative
    torque coefficients ``load`` and KV scales ``kv`` (see module docstring); ``drive`` (R, N) the
    fraction of its no-load speed a weak motor or ESC delivers (sim/damage.py cause "motor": less
    voltage reaches the windings), None for all 1; ``exponent`` (N,) the speed law b with
    ``omega_max`` (N,): the nominal rotor turns at omega_max·(w_com/omega_max)^b (None: b = 1)."""
    if exponent is not None:
        w_com = omega_max * np.power(np.clip(w_com / omega_max, 0.0, None), exponent)
    w_nl = kv * (w_com + a0 * w_com * w_com)
    if drive is not None:
        w_nl = w_nl * drive
    a = a0 * np.maximum(load, 1e-6) * kv * kv
    return 2.0 * w_nl / (1.0 + np.sqrt(1.0 + 4.0 * a * w_nl))  # the root, written stably for small a


def esc_telemetry(t_rec: np.ndarray, w: np.ndarray, torque: np.ndarray, p: EscParams, offset: float,
                  t_last: float, rng: np.random.Generator, jitter_frac: float = 0.02) -> EscTelemetry:
    """One vehicle's :class:`~flightlog_fd.flight.EscTelemetry` from its recorded rotor speeds
    ``w`` (M, R) rad/s and drag torques ``torque`` (M, R) N·m at sim times ``t_rec`` (M,) s since
    arming, decimated to the ESC rate, on the log clock (``offset`` s after boot)."""
    base_dt = float(np.median(np.diff(t_rec))) if t_rec.size > 1 else 0.01
    step = max(1, int(round(1.0 / (p.rate_hz * base_dt))))
    idx = np.arange(0, int(np.searchsorted(t_rec, t_last + 1e-9, side="right")), step)
    t_sim, ws, tq = t_rec[idx], w[idx], torque[idx]
    interval = step * base_dt
    kv = np.asarray(p.kv_scale)
    current = p.no_load_current_a * (ws > 1.0) + tq * p.kv_si * kv
    total = current.sum(axis=1)
    volt = p.cells * (CELL_V_START - CELL_DISCHARGE_V_PER_S * t_sim) - PACK_R_PER_CELL * p.cells * total
    hover_i = max(float(np.median(current[current > 0])) if np.any(current > 0) else 1.0, 1e-3)
    alpha = 1.0 - np.exp(-interval / TEMP_TAU_S)
    chans = []
    for k in range(ws.shape[1]):
        rpm = ws[:, k] * 60.0 / (2.0 * np.pi) * (1.0 + RPM_NOISE_FRAC * rng.standard_normal(idx.size))
        rpm_step = ERPM_STEP / p.pole_pairs
        rpm = np.round(np.maximum(rpm, 0.0) / rpm_step) * rpm_step
        cur = p.current_gain[k] * current[:, k] * (1.0 + CURRENT_NOISE_FRAC * rng.standard_normal(idx.size))
        cur = np.round(np.maximum(cur + p.current_offset_a[k], 0.0) / CURRENT_STEP_A) * CURRENT_STEP_A
        heat = np.empty(idx.size)
        level = 0.0
        target = TEMP_RISE_C_PER_HOVER_CURRENT * current[:, k] / hover_i
        for i in range(idx.size):  # first-order lag; ESC rates keep this loop short (<= 100 Hz)
            level += alpha * (target[i] - level)
            heat[i] = level
        temp = np.round(TEMP_AMBIENT_C + heat)
        jit = np.clip(rng.normal(0.0, jitter_frac, idx.size), -0.3, 0.3)
        us = np.round((t_sim + offset + (p.latency_frac[k] + jit) * interval) * 1e6)
        us = np.maximum.accumulate(us - np.arange(us.size)) + np.arange(us.size)  # strictly increasing
        chans.append(EscChannel(k + 1, us / 1e6, rpm, cur, np.round(volt / VOLTAGE_STEP_V) * VOLTAGE_STEP_V, temp,
                                esc_index=k, source=f"sim ESC {k + 1}"))
    return EscTelemetry(chans, "simulated ESC telemetry",
                        {"rpm": f"rpm ({ERPM_STEP:g} eRPM / {p.pole_pairs} pole pairs steps)", "current": "A",
                         "voltage": "V", "temperature": "degC"})
