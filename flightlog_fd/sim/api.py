"""Public entry point of the simulator: ``simulate_flights(n, ...) -> list[Flight]``.

Flies ``n`` quadrotors together (one vectorised batch) and returns one :class:`~flightlog_fd.flight.Flight`
per vehicle exactly as a log parser would return it, plus ``Flight.truth``:
``{"label": 0..4, "motor": 0..4, "eta": float, "onset_s": log-clock s or None, "motors": [...],
"etas": [...], "onsets_s": [...], "etas_torque": [...], "airframe": {...},
"eta_torque": float, "rho": [4], "rho_mode": str, "imbalance": {...}, "mission": str, "seed": int, "index": i, "profile": str,
"takeoff_s": log-clock s, "log_start_boot_s": s, "sensors": {...}}``.

Arguments (all keyword except ``n``):

- ``airframes``: None (random, :func:`~flightlog_fd.sim.airframe.random_airframes`), a preset name
  or :class:`Airframe` for every vehicle, or a list of ``n`` of those;
- ``damages``: None (random, :func:`~flightlog_fd.sim.damage.random_damages`), one
  :class:`Damage` for every vehicle, or a list of ``n`` (None entries = healthy); a Damage with
  ``also`` (:meth:`Damage.several`) damages several propellers, each with its own eta and onset
  (the truth's ``motors``, ``etas``, ``onsets_s`` list them; ``label``/``motor``/``eta``/``onset_s``
  are the first's);
- ``mission``: "waypoints" | "manual" | "hover", or one of those per vehicle (a batch may mix
  them: the legs are per vehicle); ``duration_s``: planned arming-to-disarm time;
- ``profile``: logging profile (logger.PROFILES); ``rho``: None | "random" | (4,) | (n, 4) unbalance
  ratios, ``rho_mode`` "physical" | "paper" (rho.py);
- ``seed``: everything (airframes, missions, damages, noise, log timing) is drawn from one
  ``numpy.random.default_rng(seed)``, so the same arguments give the same flights;
- ``imbalance``: None (balanced, as designed), ``"random"`` (realistic per-vehicle CoG offset,
  motor tilt, thrust/torque-coefficient and motor-lag spread, imbalance.py), one
  :class:`~flightlog_fd.sim.imbalance.AirframeImbalance` for all, or a list of ``n``;
- ``torque_exponent_range``: random damages draw ``η_torque = η^k`` with k in this range (None:
  η_torque = η); ``mild_fraction``: share of random damages drawn mild (η 0.9-0.97), damage.py;
- ``noise``: "default" | "real_logs" (sensors.py: turbulence and gyro noise ranges widened to
  span real healthy logs);
- ``realism``: False removes noise, wind, delays and vibration (physics checks);
- ``vibration_gain``: rad/s of gyro vibration per unit propeller imbalance at full speed;
- ``esc``: None (no ESC telemetry; rotors reach their commanded speed), ``"random"`` (random
  motors/ESCs, telemetry 10-100 Hz), a telemetry rate in Hz, one
  :class:`~flightlog_fd.sim.esc.EscParams` or a list of n: the rotors then follow the
  load-dependent motor model and each Flight carries ``esc`` (per-motor RPM, current, voltage,
  temperature; sim/esc.py) and ``truth["esc"]``. Drawn from its own generator: the other draws
  of a seed do not change.
- ``prop_imbalance``: None (no propeller vibration model: the flights are as before),
  ``"residual"`` (every propeller keeps its healthy residual imbalance and the airframe its
  broadband vibration floor), one :class:`~flightlog_fd.sim.prop_vibration.PropImbalance` for
  all or a list of n (mass m·r and/or aerodynamic imbalance per rotor on top of the residual):
  once-per-revolution lines at each rotor's speed in the logged IMU, ``Flight.vibration``
  (ArduPilot ``VIBE`` / PX4 ``vehicle_imu_status``) and ``truth["prop_imbalance"]``
  (sim/prop_vibration.py); ``imu_rate_hz`` adds raw IMU samples at that rate (ArduPilot
  ACC/GYR, PX4 sensor_accel/sensor_gyro). Drawn from generators of their own: the other draws
  of a seed do not change, nor do the flown trajectories.

- ``loads``: None (nothing carried: the flights are exactly as before), one
  :class:`~flightlog_fd.sim.loads.Load` or a tuple of Loads carried by every vehicle, or a list
  of n, one per vehicle (each None, a Load or a tuple; ``loads.random_loads`` draws one):
  fixed point masses, a moved battery, a payload swinging on a
  line (loads.py; the controller is not told); ``"random"``: one random load per vehicle
  (point, line, battery 2:1:1, made flyable with its damage and imbalance). ValueError when an
  airframe cannot hover with its loads (and damage). The truth then carries ``loads`` (kind, mass
  kg, mass fraction, position m, line length) and ``load_mass`` (rigid-body and take-off mass,
  CoM, inertia about it). Random loads come from a generator of their own: a seed flies the same
  missions, noise and damage with and without loads.

Cost: one batch of N vehicles costs about as much as a handful of single flights (all array
operations), so call it with a few hundred vehicles at a time for datasets (profile "training").
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.flight import Flight
from flightlog_fd.sim.airframe import Airframe, preset, random_airframes
from flightlog_fd.sim.damage import (ETA_RANGE, HEALTHY, HEALTHY_FRACTION, MIDFLIGHT_FRACTION, VIBRATION_GAIN_RADS,
                                     Damage, DamageArrays, random_damages)
from flightlog_fd.sim.engine import BatchResult, run_batch
from flightlog_fd.sim.esc import MAX_RECORD_HZ, EscParams, EscSpec, MotorArrays, esc_telemetry, resolve_esc
from flightlog_fd.sim.imbalance import AirframeImbalance, ImbalanceArrays, ImbalanceSpec, resolve_imbalances
from flightlog_fd.sim.loads import LoadArrays, check_flyable, random_loads, resolve_loads
from flightlog_fd.sim.logger import LogProfile, build_flights, get_profile
from flightlog_fd.sim.missions import MissionPlan, plan_missions
from flightlog_fd.sim.prop_vibration import PropSpec, add_vibration, resolve as resolve_props
from flightlog_fd.sim.sensors import SensorParams
from flightlog_fd.sim.rho import RhoSpec, check_mode, resolve_rho

#: ``loads="random"``: kinds point, line, battery drawn 2:1:1 (loads.random_loads).
RANDOM_LOAD_WEIGHTS = (2.0, 1.0, 1.0)
#: Extra simulated time allowed beyond the longest planned flight before the batch is stopped.
OVERTIME_FACTOR = 1.5
OVERTIME_S = 20.0

AirframeSpec = Union[None, str, Airframe, Sequence[Union[str, Airframe]]]
DamageSpec = Union[None, Damage, Sequence[Optional[Damage]]]


@dataclass
class SimBatch:
    """Everything a batch was made of and what it recorded (for tests and dataset builders)."""

    airframes: list[Airframe]
    damages: list[Damage]
    rho: np.ndarray  # (n, 4)
    rho_mode: str
    plan: MissionPlan
    sensors: SensorParams
    profile: LogProfile
    result: BatchResult
    seed: int
    imbalances: Optional[list[AirframeImbalance]] = None
    esc: Optional[list[EscParams]] = None
    #: propeller vibration model (sim/prop_vibration.py), None when off; may be replaced before
    #: flights_from_batch to give the same flown batch other propellers
    prop_imbalance: PropSpec = None
    imu_rate_hz: Optional[float] = None
    #: each vehicle's loads (loads.py), None when the batch carries none
    loads: Optional[list] = None
    load_arrays: Optional[LoadArrays] = None


def _resolve_airframes(n: int, airframes: AirframeSpec, rng: np.random.Generator) -> list[Airframe]:
    if airframes is None:
        return random_airframes(n, rng)
    if isinstance(airframes, (str, Airframe)):
        airframes = [airframes] * n
    out = [preset(a) if isinstance(a, str) else a for a in airframes]
    if len(out) == 1 and n > 1:
        out = out * n
    if len(out) != n:
        raise ValueError(f"got {len(out)} airframes for {n} vehicles")
    return out


def _resolve_damages(n: int, damages: DamageSpec, airframes: list[Airframe], plan: MissionPlan,
                     rng: np.random.Generator, healthy_fraction: float, eta_range: tuple[float, float],
                     midflight_fraction: float, **damage_kw) -> list[Damage]:
    if damages is None:
        return random_damages(airframes, plan.estimated_s, rng, healthy_fraction=healthy_fraction,
                              eta_range=eta_range, midflight_fraction=midflight_fraction, **damage_kw)
    if isinstance(damages, Damage):
        return [damages] * n
    out = [HEALTHY if d is None else d for d in damages]
    if len(out) != n:
        raise ValueError(f"got {len(out)} damages for {n} vehicles")
    return out


def simulate_batch(n: int, *, airframes: AirframeSpec = None, damages: DamageSpec = None,
                   mission: Union[str, Sequence[str]] = "waypoints", duration_s: float = 60.0,
                   profile: str = "px4_high",
                   rho: RhoSpec = None, rho_mode: str = "physical", seed: int = 0, realism: bool = True,
                   vibration_gain: float = VIBRATION_GAIN_RADS, healthy_fraction: float = HEALTHY_FRACTION,
                   eta_range: tuple[float, float] = ETA_RANGE, midflight_fraction: float = MIDFLIGHT_FRACTION,
                   extra_streams: Optional[dict[str, int]] = None, imbalance: ImbalanceSpec = None,
                   mild_fraction: float = 0.0,
                   torque_exponent_range: Optional[tuple[float, float]] = None, noise: str = "default",
                   accelerometer: bool = True, esc: EscSpec = None, prop_imbalance: PropSpec = None,
                   imu_rate_hz: Optional[float] = None, loads=None) -> SimBatch:
    """Fly the batch and keep the raw recording (see :func:`simulate_flights` for the arguments).

    ``extra_streams`` maps engine stream names (engine.STREAM_FIELDS, e.g. ``"w_com"``, ``"pos"``)
    to a decimation (record every k simulation steps) for analysis. ``accelerometer=False`` leaves
    the accelerometer out of the recording (datasets, whose windows never read it: 5-15 % faster).
    """
    if n < 1:
        raise ValueError("n must be >= 1")
    check_mode(rho_mode)
    prof = get_profile(profile)
    rng = np.random.default_rng(seed)
    afs = _resolve_airframes(n, airframes, rng)
    plan = plan_missions(n, mission, duration_s, rng)
    dmg = _resolve_damages(n, damages, afs, plan, rng, healthy_fraction, eta_range, midflight_fraction,
                           mild_fraction=mild_fraction, torque_exponent_range=torque_exponent_range)
    n_rot = afs[0].rotor_count
    if any(a.rotor_count != n_rot for a in afs):
        raise ValueError(f"one batch flies one rotor count; got {sorted({a.rotor_count for a in afs})}")
    rho_arr = resolve_rho(rho, n, rng, n_rot)
    # Drawn from a child generator so that adding an imbalance leaves every other draw unchanged.
    imbs = resolve_imbalances(imbalance, afs, np.random.default_rng([seed, 5]))
    sens = SensorParams.draw(afs, rng, realism=realism, vibration_gain=vibration_gain, noise=noise)
    dmg_arr = DamageArrays.build(dmg, rng, n_rot)
    dec = prof.decimation()
    if not accelerometer:
        dec.pop("accel", None)
    if extra_streams:
        dec.update(extra_streams)
    escs = resolve_esc(esc, afs, np.random.default_rng([seed, 7]))
    if escs is not None:
        k = int(np.ceil(prof.sim_rate_hz / MAX_RECORD_HZ))
        dec.setdefault("w", k)
        dec.setdefault("torque", dec["w"])
    if prop_imbalance is not None:  # the rotor phases, rates and specific force at every step
        if not accelerometer:
            raise ValueError("prop_imbalance needs the accelerometer")
        dec.update(w_fine=1, omega_fine=1, sforce=1)
    t_max = float(plan.estimated_s.max()) * OVERTIME_FACTOR + OVERTIME_S
    imb_arr = None if imbalance is None else ImbalanceArrays.build(imbs)
    if isinstance(loads, str):
        if loads != "random":
            raise ValueError(f"loads must be None, 'random', a Load, a tuple or a list, got {loads!r}")
        # Drawn from a child generator after the damages, so each random load flies with its damage.
        loads = random_loads(afs, np.random.default_rng([seed, 11]), weights=RANDOM_LOAD_WEIGHTS, damages=dmg,
                             imbalances=None if imbalance is None else imbs)
    load_sets = resolve_loads(loads, n)
    load_arr = None
    if load_sets is not None:  # nothing drawn: a seed flies the same with and without loads
        cog = None if imb_arr is None else imb_arr.cog * np.array([a.arm for a in afs])
        for af, ld, d, imb in zip(afs, load_sets, dmg, imbs):
            check_flyable(af, ld, d, None if imb_arr is None else imb)
        load_arr = LoadArrays.build(load_sets, afs, cog)
    res = run_batch(afs, plan, dmg_arr, rho_arr, rho_mode, sens, 1.0 / prof.sim_rate_hz, dec, t_max, rng,
                    imbalance=imb_arr, motor_model=None if escs is None else MotorArrays.build(escs, afs),
                    loads=load_arr)
    return SimBatch(airframes=afs, damages=dmg, rho=rho_arr, rho_mode=rho_mode, plan=plan, sensors=sens,
                    profile=prof, result=res, seed=seed, imbalances=imbs, esc=escs, prop_imbalance=prop_imbalance,
                    imu_rate_hz=imu_rate_hz, loads=load_sets, load_arrays=load_arr)


def flights_from_batch(batch: SimBatch) -> list[Flight]:
    """The batch's vehicles as `Flight` objects (deterministic for the batch's seed)."""
    rng = np.random.default_rng([batch.seed, 1])
    imbs = batch.imbalances or [None] * len(batch.airframes)
    extra = [{"sensors": batch.sensors.to_dict(i), "eta_torque": float(batch.damages[i].torque_eta),
              "etas_torque": [float(x.torque_eta) for x in batch.damages[i].parts],
              "imbalance": imbs[i].to_dict() if imbs[i] is not None else None}
             for i in range(len(batch.airframes))]
    if batch.loads is not None:  # the loads' truth (absent from batches without loads)
        for i, (af, ld) in enumerate(zip(batch.airframes, batch.loads)):
            extra[i]["loads"] = [x.to_dict(af) for x in ld]
            extra[i]["load_mass"] = batch.load_arrays.props[i].to_dict()
    flights = build_flights(batch.result, batch.profile, batch.airframes, batch.damages, batch.rho, batch.rho_mode,
                            batch.plan.missions, batch.seed, rng, extra)
    if batch.esc is not None:
        res = batch.result
        esc_rng = np.random.default_rng([batch.seed, 8])
        for i, (fl, p) in enumerate(zip(flights, batch.esc)):
            offset = fl.truth["log_start_boot_s"]
            fl.esc = esc_telemetry(res.times["w"], res.data["w"][:, i].astype(np.float64),
                                   res.data["torque"][:, i].astype(np.float64), p, offset, fl.t_end - offset,
                                   esc_rng, jitter_frac=batch.profile.jitter_frac)
            fl.truth["esc"] = p.to_dict()
    if batch.prop_imbalance is not None:
        if "w_fine" not in batch.result.data:
            raise ValueError("this batch was flown without the propeller vibration model (prop_imbalance=None)")
        props = resolve_props(batch.prop_imbalance, batch.airframes, batch.seed, batch.sensors.realism)
        sp, prof = batch.sensors, batch.profile
        for i, (fl, af, pv) in enumerate(zip(flights, batch.airframes, props)):
            add_vibration(fl, af, pv, batch.result, i, autopilot=prof.autopilot, rates_hz=prof.rates_hz,
                          gyro_density=float(sp.gyro_noise_density[i]), gyro_bias=sp.gyro_bias[i],
                          gyro_cutoff_hz=float(sp.gyro_cutoff_hz[i]), imu_rate_hz=batch.imu_rate_hz,
                          rng=np.random.default_rng([batch.seed, 10, i]))
    return flights


def simulate_flights(n: int, *, airframes: AirframeSpec = None, damages: DamageSpec = None,
                     mission: Union[str, Sequence[str]] = "waypoints", duration_s: float = 60.0,
                   profile: str = "px4_high",
                     rho: RhoSpec = None, rho_mode: str = "physical", seed: int = 0, realism: bool = True,
                     vibration_gain: float = VIBRATION_GAIN_RADS, healthy_fraction: float = HEALTHY_FRACTION,
                     eta_range: tuple[float, float] = ETA_RANGE,
                     midflight_fraction: float = MIDFLIGHT_FRACTION, imbalance: ImbalanceSpec = None,
                     mild_fraction: float = 0.0,
                     torque_exponent_range: Optional[tuple[float, float]] = None,
                     noise: str = "default", accelerometer: bool = True, esc: EscSpec = None,
                     prop_imbalance: PropSpec = None, imu_rate_hz: Optional[float] = None,
                     loads=None) -> list[Flight]:
    """Simulate ``n`` flights and return them as parsed-log `Flight` objects (see module docstring)."""
    batch = simulate_batch(n, airframes=airframes, damages=damages, mission=mission, duration_s=duration_s,
                           profile=profile, rho=rho, rho_mode=rho_mode, seed=seed, realism=realism,
                           vibration_gain=vibration_gain, healthy_fraction=healthy_fraction, eta_range=eta_range,
                           midflight_fraction=midflight_fraction, imbalance=imbalance, mild_fraction=mild_fraction,
                           torque_exponent_range=torque_exponent_range, noise=noise, accelerometer=accelerometer,
                           esc=esc, prop_imbalance=prop_imbalance, imu_rate_hz=imu_rate_hz, loads=loads)
    return flights_from_batch(batch)
