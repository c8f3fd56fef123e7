"""Logger emulation: logging profiles and the assembly of simulated streams into `Flight` objects.

Each stream is recorded every ``k`` simulation steps (``k = sim_rate_hz / stream rate``, an
integer), so a logged value is the vehicle's state at a simulation step, as a logger writes the
latest message of a topic. On the log's clock:

- the autopilot clock starts at boot; logging starts at arming ``boot_offset_s`` later (PX4
  18-30 s, as the PX4 SIH dev logs start ~23.9 s after boot; ArduPilot 30-300 s, ``TimeUS``);
- timestamps are whole microseconds; every stream of the non-training profiles gets a timing
  jitter N(0, ``jitter_frac`` · its interval), clipped at ±0.3 interval, and loses samples with
  probability ``drop_prob`` (PX4 high-rate logs measure ~249.5 Hz for 250 Hz);
- the ``"training"`` profile has neither (the fast path for datasets).

Profiles (:data:`PROFILES`; rates in Hz):

==================  =========  ====  ========  ======  ==========  ========  ==========
profile             autopilot  sim   rates     att.    motors      alt       velocity
==================  =========  ====  ========  ======  ==========  ========  ==========
``px4_high``        px4        250   250       250     250         10        10
``px4_default``     px4        250   50        50      10          10        10
``ardupilot``       ardupilot  400   50 (IMU)  50      50 (RATE)   10 RCOU   10
``ardupilot_slow``  ardupilot  400   20 (IMU)  20      20 (RATE)   10 RCOU   10
``ardupilot_fast``  ardupilot  400   400       400     400 (RATE)  10 RCOU   10
``ardupilot_rcou``  ardupilot  400   50 (IMU)  50      10 (RCOU)   -         10
``training``        px4        200   100       100     100         10        10
==================  =========  ====  ========  ======  ==========  ========  ==========

``ardupilot_rcou`` is an old ArduCopter log (3.1-3.3, the ``real_healthy`` Erle set: RCOU 3-11 Hz,
IMU 15-56 Hz, measured 50-56 Hz on real_healthy, no ``RATE`` message): logs/dataflash.py then takes the motors from RCOU, so the
Flight's motors are the PWM signal (``motor_kind = "signal"``, through ``MOT_THST_EXPO``) at
10 Hz and there is no alternative motor stream.

Motors: PX4 profiles log ``actuator_motors`` thrust setpoints (``motor_kind = "thrust"``) and
``alt_motors["actuator_outputs"]``, the PWM signal normalised to 0..1 after PX4's thrust model
``thrust = f·s² + (1−f)·s`` with ``f = THR_MDL_FAC`` (0 unless the airframe sets it). ArduPilot
profiles give the per-motor thrust commands at the RATE rate (``"RATE mixer"``) and
``alt_motors["RCOU"]``, the signal through ``MOT_THST_EXPO`` (default 0.65) at 10 Hz.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.sim.airframe import Airframe
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.dynamics import quat_to_euler
from flightlog_fd.sim.engine import BatchResult

FIRMWARE = "flightlog-fd sim"
ARDUPILOT_THST_EXPO = 0.65
ARDUPILOT_PWM_MIN, ARDUPILOT_PWM_MAX = 1000.0, 2000.0
PX4_SYS_AUTOSTART = {"quad_x": 4001, "quad_plus": 5001,
                     # PX4 generic n-rotor airframes (ROMFS airframes 6001 hexa X, 7001 hexa +,
                     # 8001 octo X, 9001 octo +, 12001 octo coaxial)
                     "hexa_x": 6001, "hexa_plus": 7001, "octo_x": 8001, "octo_plus": 9001, "octaquad_x": 12001}
PX4_SIH_AUTOSTART = 10040  # PX4's SIH quadrotor airframe (sihsim_quadx)
ARDUPILOT_FRAME_TYPE = {"quad_x": 1, "quad_plus": 0}
#: MAV_TYPE per rotor count (2 quadrotor, 13 hexarotor, 14 octorotor) and Flight.vehicle_type.
PX4_MAV_TYPE = {4: 2.0, 6: 13.0, 8: 14.0}
VEHICLE_TYPE = {4: "quadrotor", 6: "hexarotor", 8: "octorotor"}
LOG_TAIL_RANGE_S = (0.5, 1.0)  # logging continues this long after disarm (PX4 SIH logs: ~1 s)
#: PX4's land detector reports "not landed" shortly after the take-off command / thrust ramp start.
LAND_DETECTOR_TAKEOFF_DELAY_S = (0.1, 0.3)
JITTER_CLIP = 0.3


@dataclass(frozen=True)
class LogProfile:
    """Stream rates (Hz) and timing behaviour of one logging configuration (see module docstring)."""

    name: str
    autopilot: str  # "px4" | "ardupilot"
    sim_rate_hz: float
    rates_hz: float
    attitude_hz: float
    motors_hz: float
    alt_motors_hz: float
    velocity_hz: float
    jitter_frac: float
    drop_prob: float
    boot_offset_s: tuple[float, float]
    motors_from: str = "rate"  # "rate": thrust setpoints (RATE mixer / actuator_motors); "rcou": PWM signal only

    def decimation(self) -> dict[str, int]:
        """Record every k simulation steps, per stream (engine stream names)."""
        out = {}
        for name, hz in (("rates", self.rates_hz), ("attitude", self.attitude_hz), ("motors", self.motors_hz),
                         ("velocity", self.velocity_hz)):
            k = self.sim_rate_hz / hz
            if abs(k - round(k)) > 1e-9:
                raise ValueError(f"profile {self.name}: {name} at {hz} Hz does not divide {self.sim_rate_hz} Hz")
            out[name] = int(round(k))
        out["accel"] = out["rates"]  # the IMU logs gyro and accelerometer together (sensor_combined / IMU)
        return out

    @property
    def alt_every(self) -> int:
        """Keep every n-th motor sample for the alternative (signal) motor stream."""
        return max(1, int(round(self.motors_hz / self.alt_motors_hz)))


PROFILES: dict[str, LogProfile] = {
    "px4_high": LogProfile("px4_high", "px4", 250.0, 250.0, 250.0, 250.0, 10.0, 10.0, 0.04, 0.002, (18.0, 30.0)),
    "px4_default": LogProfile("px4_default", "px4", 250.0, 50.0, 50.0, 10.0, 10.0, 10.0, 0.04, 0.0005,
                              (18.0, 30.0)),
    "ardupilot": LogProfile("ardupilot", "ardupilot", 400.0, 50.0, 50.0, 50.0, 10.0, 10.0, 0.02, 0.0,
                            (30.0, 300.0)),
    # ArduCopter 3.x with the default LOG_BITMASK: RATE/ATT/IMU at 20-25 Hz (the Erle logs: ~24 Hz).
    "ardupilot_slow": LogProfile("ardupilot_slow", "ardupilot", 400.0, 20.0, 20.0, 20.0, 10.0, 10.0, 0.02, 0.0,
                                 (30.0, 300.0)),
    "ardupilot_fast": LogProfile("ardupilot_fast", "ardupilot", 400.0, 400.0, 400.0, 400.0, 10.0, 10.0, 0.02,
                                 0.001, (30.0, 300.0)),
    # Old ArduCopter (3.1-3.3) default logging, no RATE message: motors only from RCOU at ~10 Hz.
    "ardupilot_rcou": LogProfile("ardupilot_rcou", "ardupilot", 400.0, 50.0, 50.0, 10.0, 10.0, 10.0, 0.02, 0.0,
                                 (30.0, 300.0), motors_from="rcou"),
    "training": LogProfile("training", "px4", 200.0, 100.0, 100.0, 100.0, 10.0, 10.0, 0.0, 0.0, (18.0, 30.0)),
}


def get_profile(name: str) -> LogProfile:
    try:
        return PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown logging profile {name!r}; known: {sorted(PROFILES)}") from None


def thrust_to_signal(thrust: np.ndarray, curve: float) -> np.ndarray:
    """Motor signal s (0..1) whose thrust ``(1−c)·s + c·s²`` equals ``thrust`` (PX4 THR_MDL_FAC / AP MOT_THST_EXPO)."""
    t = np.clip(thrust, 0.0, 1.0)
    if curve <= 1e-6:
        return t
    b = 1.0 - curve
    return (-b + np.sqrt(b * b + 4.0 * curve * t)) / (2.0 * curve)


def _stamp(t_sim: np.ndarray, offset: float, interval: float, profile: LogProfile,
           rng: Optional[np.random.Generator]) -> tuple[np.ndarray, np.ndarray]:
    """Log-clock seconds (µs resolution) and the kept-sample mask for one stream of one vehicle."""
    us = (t_sim + offset) * 1e6
    keep = np.ones(t_sim.shape[0], dtype=bool)
    if rng is not None and profile.jitter_frac > 0:
        jit = np.clip(rng.normal(0.0, profile.jitter_frac, t_sim.shape[0]), -JITTER_CLIP, JITTER_CLIP)
        us = us + jit * interval * 1e6
        if profile.drop_prob > 0:
            keep = rng.uniform(size=t_sim.shape[0]) >= profile.drop_prob
    # Strictly increasing whole microseconds even after jitter (us[i] >= us[i-1] + 1).
    idx = np.arange(us.shape[0], dtype=np.float64)
    us = np.maximum.accumulate(np.round(us) - idx) + idx
    return us / 1e6, keep


def _us(t: float) -> float:
    """Seconds rounded to the log clock's microsecond."""
    return float(np.round(t * 1e6) / 1e6)


def px4_params(af: Airframe) -> dict[str, float]:
    frame = af.geometry()
    p: dict[str, float] = {
        "SYS_AUTOSTART": float(PX4_SIH_AUTOSTART if af.name == "sih" else PX4_SYS_AUTOSTART[af.frame]),
        "MAV_TYPE": PX4_MAV_TYPE[af.rotor_count],
        "CA_ROTOR_COUNT": float(af.rotor_count),
        "THR_MDL_FAC": float(af.thr_mdl_fac),
        "MPC_THR_HOVER": float(round(af.hover_command, 3)),
        "IMU_GYRO_CUTOFF": float(af.gyro_cutoff_hz),
    }
    for i, r in enumerate(frame.rotors):
        p[f"CA_ROTOR{i}_PX"] = float(r.x)
        p[f"CA_ROTOR{i}_PY"] = float(r.y)
        p[f"CA_ROTOR{i}_KM"] = float(r.spin * af.torque_ratio)
    return p


def _ardupilot_frame(af: Airframe) -> tuple[int, int]:
    """(FRAME_CLASS, FRAME_TYPE) of a simulated airframe."""
    from flightlog_fd.sim.airframe import N_ROTOR_FRAMES

    return N_ROTOR_FRAMES[af.frame] if af.frame in N_ROTOR_FRAMES else (1, ARDUPILOT_FRAME_TYPE[af.frame])


def ardupilot_params(af: Airframe) -> dict[str, float]:
    fclass, ftype = _ardupilot_frame(af)
    return {
        "FRAME_CLASS": float(fclass),
        "FRAME_TYPE": float(ftype),
        "MOT_PWM_MIN": ARDUPILOT_PWM_MIN,
        "MOT_PWM_MAX": ARDUPILOT_PWM_MAX,
        "MOT_THST_EXPO": ARDUPILOT_THST_EXPO,
        "MOT_THST_HOVER": float(round(af.hover_command, 3)),
        "INS_GYRO_FILTER": float(af.gyro_cutoff_hz),
    }


def build_flights(res: BatchResult, profile: LogProfile, airframes: Sequence[Airframe], damages: Sequence[Damage],
                  rho: np.ndarray, rho_mode: str, mission: Union[str, Sequence[str]], seed: int,
                  rng: np.random.Generator,
                  extra_truth: Optional[Sequence[dict]] = None) -> list[Flight]:
    """One `Flight` per vehicle from a batch's recorded streams (see module docstring)."""
    px4 = profile.autopilot == "px4"
    jitter_rng = rng if profile.jitter_frac > 0 else None
    flights = []
    # Vehicle-major float64 copies: one pass per stream instead of a strided gather per vehicle.
    per_vehicle = {k: np.ascontiguousarray(res.data[k].transpose(1, 0, 2), dtype=np.float64)
                   for k in ("rates", "attitude", "motors", "velocity", "accel") if k in res.data}
    for i, af in enumerate(airframes):
        offset = float(rng.uniform(*profile.boot_offset_s))
        t_disarm = res.t_disarm[i]
        t_last = (t_disarm + rng.uniform(*LOG_TAIL_RANGE_S)) if np.isfinite(t_disarm) else res.t_end

        def stream(name: str, hz: float, also: Optional[str] = None) -> tuple[np.ndarray, ...]:
            """Stamped samples of ``name`` (and of ``also``, recorded with it, on the same stamps)."""
            t_sim = res.times[name]
            m = int(np.searchsorted(t_sim, t_last + 1e-9, side="right"))
            t, keep = _stamp(t_sim[:m], offset, 1.0 / hz, profile, jitter_rng)
            extra = (per_vehicle[also][i, :m][keep],) if also is not None else ()
            return (t[keep], per_vehicle[name][i, :m][keep]) + extra

        if "accel" in per_vehicle:
            t_r, rates, acc = stream("rates", profile.rates_hz, also="accel")
        else:
            (t_r, rates), acc = stream("rates", profile.rates_hz), None
        t_a, q = stream("attitude", profile.attitude_hz)
        t_m, motors = stream("motors", profile.motors_hz)
        t_v, vel = stream("velocity", profile.velocity_hz)
        att = quat_to_euler(q / np.linalg.norm(q, axis=1, keepdims=True))
        alt_idx = np.arange(0, t_m.shape[0], profile.alt_every)

        frame = af.geometry()
        nr = af.rotor_count
        if px4:
            curve = float(af.thr_mdl_fac)
            params = px4_params(af)
            frame = Frame(frame.name, frame.rotors, f"CA_ROTOR_COUNT={nr}, CA_ROTORn_PX/PY/KM", layout=frame.layout)
            src = dict(rates="vehicle_angular_velocity.xyz", attitude="vehicle_attitude.q",
                       motors=f"actuator_motors.control[0..{nr - 1}]", alt=f"actuator_outputs.output[0..{nr - 1}]",
                       velocity="vehicle_local_position.vx/vy/vz", accel="sensor_combined.accelerometer_m_s2")
            alt_name, airborne_src = "actuator_outputs", "vehicle_land_detected"
        else:
            curve = ARDUPILOT_THST_EXPO
            params = ardupilot_params(af)
            fclass, ftype = _ardupilot_frame(af)
            frame = Frame(frame.name, frame.rotors, f"FRAME_CLASS={fclass}, FRAME_TYPE={ftype}", layout=frame.layout)
            src = dict(rates="IMU.GyrX/Y/Z", attitude="ATT.Roll/Pitch/Yaw",
                       motors="RATE mixer (AOut + ROut/POut/YOut x AP_MotorsMatrix factors)",
                       alt="RCOU." + ",".join(f"C{k}" for k in range(1, nr + 1)), velocity="XKF1.VN/VE/VD",
                       accel="IMU.AccX/Y/Z")
            alt_name, airborne_src = "RCOU", "EV (NOT_LANDED 28 .. LAND_COMPLETE 18 / DISARMED 11)"
        alt = Series(t_m[alt_idx], thrust_to_signal(motors[alt_idx], curve), src["alt"])
        motor_series, motor_kind, alt_motors = Series(t_m, motors, src["motors"]), "thrust", {alt_name: alt}
        if profile.motors_from == "rcou":
            # No RATE message: the parser's motors are RCOU itself (PWM signal), nothing else.
            motor_series = Series(t_m, thrust_to_signal(motors, curve), src["alt"])
            motor_kind, alt_motors = "signal", {}

        t_start = float(min(t_r[0], t_m[0], t_a[0]))  # arming: the first logged instant
        t_end = float(max(t_r[-1], t_m[-1], t_a[-1]))
        armed_end = _us(min(t_disarm + offset, t_end)) if np.isfinite(t_disarm) else t_end
        # Airborne as the autopilot's land detector reports it: from the take-off command (thrust
        # ramp) to "landed" after touchdown; the true lift-off / touchdown go to the truth.
        airborne = []
        if np.isfinite(res.t_takeoff[i]):
            start = res.t_takeoff_cmd[i] + rng.uniform(*LAND_DETECTOR_TAKEOFF_DELAY_S)
            end = res.t_landed[i] + offset if np.isfinite(res.t_landed[i]) else t_end
            airborne.append((_us(start + offset), _us(min(end, t_end))))
        d = damages[i]
        # Log-clock onset of a mid-flight damage; None when healthy or damaged from take-off.
        onset = float(d.onset_s + offset) if (d.motor and d.onset_s is not None) else None
        truth = {
            "label": int(d.motor), "motor": int(d.motor), "eta": float(d.eta),
            "cause": d.cause if d.motor else None,
            "onset_s": onset, "airframe": af.to_dict(), "rho": rho[i].tolist(), "rho_mode": rho_mode,
            "mission": mission if isinstance(mission, str) else mission[i], "seed": int(seed), "index": i, "profile": profile.name,
            "takeoff_s": _us(res.t_takeoff[i] + offset) if np.isfinite(res.t_takeoff[i]) else None,
            "touchdown_s": _us(res.t_touchdown[i] + offset) if np.isfinite(res.t_touchdown[i]) else None,
            "log_start_boot_s": offset,
            # every damaged propeller (a two-propeller flight lists both; the fields above are the first's)
            "motors": [int(x.motor) for x in d.parts], "etas": [float(x.eta) for x in d.parts],
            "onsets_s": [None if x.onset_s is None else float(x.onset_s + offset) for x in d.parts],
        }
        if nr != 4:
            truth["rotor_count"] = nr  # labels 0..n (features.labels_for_spans); quads keep their truth
        if extra_truth is not None:
            truth.update(extra_truth[i])
        flights.append(Flight(
            path=None, autopilot=profile.autopilot, firmware=FIRMWARE, vehicle_type=VEHICLE_TYPE.get(nr, "multirotor"),
            vehicle_id=f"sim-{seed}-{i}", frame=frame,
            rates=Series(t_r, rates, src["rates"]),
            attitude=Series(t_a, att, src["attitude"]),
            motors=motor_series, motor_kind=motor_kind, thrust_curve=curve,
            velocity=Series(t_v, vel, src["velocity"]),
            accel=Series(t_r, acc, src["accel"]) if acc is not None else None,
            alt_motors=alt_motors,
            armed=[(t_start, float(armed_end))], airborne=airborne, airborne_source=airborne_src,
            t_start=t_start, t_end=t_end, params=params, truth=truth,
        ))
    return flights
