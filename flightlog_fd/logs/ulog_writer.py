"""PX4 ULog writer: :class:`~flightlog_fd.flight.Flight` -> a ``.ulg`` file PX4 tools and pyulog read.

pyulog 1.3.0 can only re-write a ULog it has parsed (``ULog.write_ulog``, one Python
``struct.pack`` per field per message), so this module writes the binary format itself (PX4 docs,
"ULog File Format"): 16-byte header (magic ``ULog\\x01\\x12\\x35``, version 1, start time µs),
flag bits, ``F`` formats, ``I`` info, ``P`` initial parameters, ``A`` subscriptions, then ``D``
data messages merged in time order. Each topic is one numpy structured array whose rows are
complete messages (3-byte header + msg_id + payload); rows of all topics are gathered into one
byte buffer with a single vectorised index, so a 100 s, 250 Hz flight writes in well under a second.

Input: a Flight whose Series are already sampled at each stream's own rate (the simulator adds
the jitter); times are seconds on the flight's clock and must be > 0 (written as µs, rounded; a 0 timestamp means
"not set" to PX4 tools and to the reader).
Topics written (PX4 field names; float32 as PX4 logs them):

- ``vehicle_angular_velocity`` (``xyz`` rad/s, ``timestamp_sample`` = ``timestamp``) from ``rates``;
- ``actuator_motors`` (``control[12]``, NaN beyond the rotor count) from ``motors`` - thrust
  setpoints; a ``"signal"`` flight is mapped through the thrust model first;
- ``actuator_outputs`` (``output[16]`` µs, ``noutputs`` = rotor count) from
  ``alt_motors["actuator_outputs"]`` when present, else from ``motors`` through the inverse
  ``THR_MDL_FAC`` model; output = MIN + signal * (MAX - MIN) with ``PWM_MAIN_MIN/MAX`` (default
  1000/2000 µs) and ``PWM_MAIN_DISARM`` (900 µs) outside the armed intervals, as PX4 does;
- ``vehicle_attitude`` (``q`` w,x,y,z from roll, pitch and yaw - yaw 0 when absent);
- ``vehicle_status`` (``arming_state`` 2 armed / 1 disarmed, ``vehicle_type``, ``is_vtol``,
  ``system_type``) at ``STATUS_RATE_HZ`` plus one message at every arming change;
- ``vehicle_land_detected`` (``landed`` = not airborne) at ``LAND_DETECTED_RATE_HZ`` plus one at
  every change;
- ``sensor_combined`` (``accelerometer_m_s2`` and ``gyro_rad`` interpolated to its times: the
  vibration's ``sensor_combined`` gyro where it has one, the integrated raw gyro, else ``rates``) if ``accel``;
- from ``vibration``: ``vehicle_imu_status`` per IMU (multi_id = instance; accel / gyro vibration
  metrics, coning, the clipping count in ``accel_clipping[0]``) when its metrics are PX4's (VIBE
  has another definition and is not written), ``sensor_accel`` / ``sensor_gyro`` (x, y, z,
  ``timestamp_sample``) for every continuous raw stream other than sensor_combined;
- ``vehicle_local_position`` (``vx, vy, vz`` and ``x, y, z`` integrated from them) if ``velocity``;
- ``esc_status`` from ``esc`` (per slot ``esc_index``: ``esc_rpm``, ``esc_current``,
  ``esc_voltage``, ``esc_temperature``, ``timestamp`` of the slot's last report,
  ``actuator_function`` 100 + motor, bit i of ``esc_online_flags``), one message at every time
  any ESC reported (one per round when the ESCs report in rounds), each slot holding its last report; with
  ``esc_layout="legacy"`` the esc_report of PX4 < 1.13 (no ``actuator_function``: slot i is
  motor i+1). Else from ``esc_rpm`` (``esc[i].esc_rpm``, ``actuator_function`` 101+i).

Info fields: ``sys_name`` "PX4", ``ver_hw``, ``ver_sw`` (the flight's firmware text),
``ver_sw_release`` when the firmware text holds a ``vX.Y.Z`` version, ``sys_uuid`` = vehicle_id,
and the simulator's truth as JSON under ``fdlog_truth`` (the reader never uses it). Parameters:
``flight.params`` overridden by what the Flight's own fields say: ``CA_ROTOR_COUNT``,
``CA_ROTOR{i}_PX/PY/PZ/KM/CT/AX/AY/AZ`` from the frame, ``SYS_AUTOSTART`` (4001 quad-X, 5001
quad-+), ``MAV_TYPE``, ``THR_MDL_FAC``, ``PWM_MAIN_MIN/MAX`` and ``PWM_MAIN_FUNCn`` = 101.. (motor
k on output channel k). Parameters PX4 declares as integers (``INT_PARAM_PATTERN``) are written as
int32, the rest as float.
"""
from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from ..flight import Flight, Frame, Series
from .ulog import TRUTH_INFO_KEY, ULOG_MAGIC

FILE_VERSION = 1
US_PER_S = 1e6
MSG_FORMAT, MSG_INFO, MSG_PARAM, MSG_ADD_LOGGED, MSG_DATA, MSG_FLAG_BITS = (ord(c) for c in "FIPADB")
#: PX4's actuator_motors / actuator_outputs / esc_status array sizes.
ACTUATOR_MOTORS_CONTROLS = 12
ACTUATOR_OUTPUTS_CHANNELS = 16
ESC_SLOTS = 8
#: Output range written when the flight's params have none (PX4 defaults, µs).
PWM_MIN_DEFAULT = 1000
PWM_MAX_DEFAULT = 2000
PWM_DISARMED_DEFAULT = 900
#: PX4 publishes vehicle_status at about 2 Hz and vehicle_land_detected at about 1 Hz (plus on change).
STATUS_RATE_HZ = 2.0
LAND_DETECTED_RATE_HZ = 1.0
ARMING_STATE_ARMED = 2
ARMING_STATE_DISARMED = 1  # "STANDBY" in PX4 < 1.14, "DISARMED" after: both 1
#: vehicle_status.vehicle_type: 1 rotary wing, 2 fixed wing.
STATUS_ROTARY_WING, STATUS_FIXED_WING = 1, 2
OUTPUT_FUNCTION_MOTOR1 = 101
#: PX4 default per-rotor coefficients for CA_ROTORn_KM (magnitude) and CA_ROTORn_CT.
CA_KM_MAGNITUDE = 0.05
CA_CT_DEFAULT = 6.5
#: Airframes (SYS_AUTOSTART) and MAV_TYPE written for each frame / vehicle type.
AUTOSTART_FOR_FRAME = {"quad_x": 4001, "quad_plus": 5001}
MAV_TYPE_FOR_VEHICLE = {"quadrotor": 2, "multirotor": 2, "hexarotor": 13, "octorotor": 14, "tricopter": 15,
                        "fixed_wing": 1, "vtol": 22, "helicopter": 4, "coaxial": 3}
MAV_TYPE_FOR_ROTORS = {3: 15, 4: 2, 6: 13, 8: 14}
#: Parameters PX4 declares as int32 (all others are written as float).
INT_PARAM_PATTERN = re.compile(
    r"^(SYS_AUTOSTART|SYS_CTRL_ALLOC|MAV_TYPE|MAV_SYS_ID|MAV_COMP_ID|CA_ROTOR_COUNT|CA_AIRFRAME|CA_METHOD"
    r"|SDLOG_\w+|COM_\w+_EN|\w+_FUNC\d+|PWM_(MAIN|AUX)_(MIN|MAX|DISARM|DIS|FAIL|REV|RATE|OUT|TIM)\w*"
    r"|PWM_(MIN|MAX|DISARMED|RATE)|\w+_EC_(MIN|MAX)\d*)$")
#: Info key for the hardware name PX4 tools display; simulated flights get this one.
DEFAULT_HARDWARE = "FDLOG_SIM"

_NP_TYPES = {
    "uint64_t": "<u8", "int64_t": "<i8", "uint32_t": "<u4", "int32_t": "<i4", "uint16_t": "<u2",
    "int16_t": "<i2", "uint8_t": "u1", "int8_t": "i1", "bool": "u1", "float": "<f4", "double": "<f8",
}

#: Message formats: name -> [(type, field, array length or 0)]. Nested type esc_report as in PX4.
FORMATS: dict[str, list[tuple[str, str, int]]] = {
    "vehicle_angular_velocity": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0),
                                 ("float", "xyz", 3)],
    "actuator_motors": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0),
                        ("uint16_t", "reversible_flags", 0), ("float", "control", ACTUATOR_MOTORS_CONTROLS)],
    "actuator_outputs": [("uint64_t", "timestamp", 0), ("uint32_t", "noutputs", 0),
                         ("float", "output", ACTUATOR_OUTPUTS_CHANNELS)],
    "sensor_combined": [("uint64_t", "timestamp", 0), ("float", "gyro_rad", 3), ("float", "accelerometer_m_s2", 3)],
    "vehicle_attitude": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0), ("float", "q", 4),
                         ("float", "delta_q_reset", 4), ("uint8_t", "quat_reset_counter", 0)],
    "vehicle_status": [("uint64_t", "timestamp", 0), ("uint64_t", "armed_time", 0), ("uint64_t", "takeoff_time", 0),
                       ("uint8_t", "arming_state", 0), ("uint8_t", "nav_state", 0), ("uint8_t", "vehicle_type", 0),
                       ("bool", "is_vtol", 0), ("uint8_t", "system_type", 0)],
    "vehicle_land_detected": [("uint64_t", "timestamp", 0), ("bool", "freefall", 0), ("bool", "ground_contact", 0),
                              ("bool", "maybe_landed", 0), ("bool", "landed", 0)],
    "vehicle_local_position": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0),
                               ("bool", "xy_valid", 0), ("bool", "z_valid", 0), ("bool", "v_xy_valid", 0),
                               ("bool", "v_z_valid", 0), ("float", "x", 0), ("float", "y", 0), ("float", "z", 0),
                               ("float", "vx", 0), ("float", "vy", 0), ("float", "vz", 0)],
    "vehicle_imu_status": [("uint64_t", "timestamp", 0), ("uint32_t", "accel_device_id", 0),
                           ("uint32_t", "gyro_device_id", 0), ("uint32_t", "accel_clipping", 3),
                           ("float", "accel_vibration_metric", 0), ("float", "gyro_vibration_metric", 0),
                           ("float", "gyro_coning_vibration", 0)],
    "sensor_accel": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0), ("uint32_t", "device_id", 0),
                     ("float", "x", 0), ("float", "y", 0), ("float", "z", 0)],
    "sensor_gyro": [("uint64_t", "timestamp", 0), ("uint64_t", "timestamp_sample", 0), ("uint32_t", "device_id", 0),
                    ("float", "x", 0), ("float", "y", 0), ("float", "z", 0)],
    "esc_report": [("uint64_t", "timestamp", 0), ("uint32_t", "esc_errorcount", 0), ("int32_t", "esc_rpm", 0),
                   ("float", "esc_voltage", 0), ("float", "esc_current", 0), ("float", "esc_temperature", 0),
                   ("uint8_t", "esc_address", 0), ("uint8_t", "esc_state", 0), ("uint8_t", "actuator_function", 0)],
    "esc_status": [("uint64_t", "timestamp", 0), ("uint16_t", "counter", 0), ("uint8_t", "esc_count", 0),
                   ("uint8_t", "esc_connectiontype", 0), ("uint8_t", "esc_online_flags", 0),
                   ("uint8_t", "esc_armed_flags", 0), ("esc_report", "esc", ESC_SLOTS)],
}
#: esc_report of PX4 before 1.13 (no actuator_function), written with ``esc_layout="legacy"``.
ESC_REPORT_LEGACY = [f for f in FORMATS["esc_report"] if f[1] != "actuator_function"]
ESC_LAYOUTS = ("current", "legacy")
#: Order of the data topics (also their msg_id order).
DATA_TOPICS = ("vehicle_status", "vehicle_land_detected", "vehicle_angular_velocity", "vehicle_attitude",
               "actuator_motors", "actuator_outputs", "vehicle_local_position", "esc_status", "sensor_combined",
               "vehicle_imu_status", "sensor_accel", "sensor_gyro")


# ---------------------------------------------------------------- thrust model (PX4 FunctionMotors)


def thrust_from_signal(signal: np.ndarray, thr_mdl_fac: float) -> np.ndarray:
    """PX4 thrust model: ``thrust = f*x^2 + (1-f)*x`` for a motor signal x in 0..1."""
    x = np.clip(np.asarray(signal, dtype=np.float64), 0.0, 1.0)
    f = float(thr_mdl_fac or 0.0)
    return f * x * x + (1.0 - f) * x


def signal_from_thrust(thrust: np.ndarray, thr_mdl_fac: float) -> np.ndarray:
    """Inverse of :func:`thrust_from_signal` (what PX4's mixer module does to ``actuator_motors``)."""
    t = np.clip(np.asarray(thrust, dtype=np.float64), 0.0, 1.0)
    f = float(thr_mdl_fac or 0.0)
    if f <= 1e-6:
        return t
    b = 1.0 - f
    return (-b + np.sqrt(b * b + 4.0 * f * t)) / (2.0 * f)


# ---------------------------------------------------------------- binary building blocks


def _message(msg_type: int, payload: bytes) -> bytes:
    if len(payload) > 0xFFFF:
        raise ValueError(f"ULog message too long ({len(payload)} bytes)")
    return struct.pack("<HB", len(payload), msg_type) + payload


def _format_message(name: str, formats: Optional[dict] = None) -> bytes:
    formats = FORMATS if formats is None else formats
    text = name + ":" + "".join(f"{t}[{n}] {f};" if n else f"{t} {f};" for t, f, n in formats[name])
    return _message(MSG_FORMAT, text.encode("ascii"))


def _key_value(type_name: str, key: str, value) -> bytes:
    """Payload of an info / parameter message: key length, "type key", value."""
    if type_name.startswith("char["):
        raw = str(value).encode("utf-8")
        type_name = f"char[{len(raw)}]"
    else:
        raw = struct.pack("<" + {"int32_t": "i", "uint32_t": "I", "float": "f"}[type_name], value)
    k = f"{type_name} {key}".encode("ascii")
    return struct.pack("<B", len(k)) + k + raw


def _info(key: str, value) -> bytes:
    if isinstance(value, str):
        return _message(MSG_INFO, _key_value("char[]", key, value))
    return _message(MSG_INFO, _key_value("uint32_t", key, int(value)))


def _param(name: str, value: float) -> bytes:
    if INT_PARAM_PATTERN.match(name) and float(value).is_integer():
        return _message(MSG_PARAM, _key_value("int32_t", name, int(value)))
    return _message(MSG_PARAM, _key_value("float", name, float(value)))


def _flat_fields(name: str, prefix: str = "", formats: Optional[dict] = None) -> list[tuple[str, str]]:
    """Flattened (field name, numpy type) of a format, nested types expanded like pyulog does."""
    formats = FORMATS if formats is None else formats
    out = []
    for t, f, n in formats[name]:
        names = [f"{prefix}{f}[{i}]" for i in range(n)] if n else [f"{prefix}{f}"]
        for fn in names:
            if t in _NP_TYPES:
                out.append((fn, _NP_TYPES[t]))
            else:
                out.extend(_flat_fields(t, fn + ".", formats))
    return out


@dataclass
class _TopicData:
    """Rows of one topic: timestamps (µs) and the field values by flattened name."""

    name: str
    timestamp_us: np.ndarray
    values: dict[str, np.ndarray] = field(default_factory=dict)
    instance: int = 0  # the subscription's multi_id

    def records(self, msg_id: int, formats: Optional[dict] = None) -> np.ndarray:
        """(n, message size) uint8: each row one complete 'D' message."""
        fields = _flat_fields(self.name, formats=formats)
        dtype = np.dtype([("msg_size", "<u2"), ("msg_type", "u1"), ("msg_id", "<u2")] + fields)
        n = len(self.timestamp_us)
        rec = np.zeros(n, dtype=dtype)
        rec["msg_size"] = dtype.itemsize - 3
        rec["msg_type"] = MSG_DATA
        rec["msg_id"] = msg_id
        rec["timestamp"] = self.timestamp_us
        for k, v in self.values.items():
            rec[k] = v
        return rec.view(np.uint8).reshape(n, dtype.itemsize)


def _us(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    if t.size and (not np.all(np.isfinite(t)) or t.min() <= 0):
        raise ValueError("write_ulog: times must be finite and > 0 s (ULog timestamps are unsigned µs "
                         "since boot and 0 means 'not set': PX4 logs start seconds after boot)")
    return np.round(t * US_PER_S).astype(np.uint64)


def _in_intervals(t: np.ndarray, intervals: list[tuple[float, float]]) -> np.ndarray:
    m = np.zeros(len(t), dtype=bool)
    for a, b in intervals:
        m |= (t >= a) & (t < b)
    return m


def _state_times(t0: float, t1: float, rate_hz: float, intervals: list[tuple[float, float]]) -> np.ndarray:
    """Periodic publication times plus every interval edge up to t1."""
    edges = [x for a, b in intervals for x in (a, b) if x <= t1]
    t0 = min([t0] + edges)  # an interval may start before the header's start time (PX4 arms first)
    n = max(int(np.floor((t1 - t0) * rate_hz)), 0)
    periodic = t0 + np.arange(n + 1) / rate_hz
    # µs-rounded and de-duplicated so an edge and a periodic sample never share a timestamp
    return np.unique(np.round(np.concatenate([periodic, [t1], edges]) * US_PER_S)) / US_PER_S


def euler_to_quaternion(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (rad) -> (n, 4) quaternions w, x, y, z (body to NED, PX4 convention)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.column_stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


# ---------------------------------------------------------------- Flight -> topics / params / info


def _output_range(flight: Flight) -> tuple[float, float, float]:
    p = flight.params
    lo = p.get("PWM_MAIN_MIN", p.get("PWM_MIN", PWM_MIN_DEFAULT))
    hi = p.get("PWM_MAIN_MAX", p.get("PWM_MAX", PWM_MAX_DEFAULT))
    disarmed = p.get("PWM_MAIN_DISARM", p.get("PWM_DISARMED", PWM_DISARMED_DEFAULT))
    return float(lo), float(hi), float(disarmed)


def _thr_mdl_fac(flight: Flight) -> float:
    if flight.thrust_curve is not None:
        return float(flight.thrust_curve)
    return float(flight.params.get("THR_MDL_FAC", 0.0))


def _vehicle_type(flight: Flight) -> str:
    vt = (flight.vehicle_type or "unknown").lower()
    if vt == "unknown" and flight.frame is not None and flight.frame.is_quad:
        return "quadrotor"
    return vt


def _esc_status(flight: Flight, esc_layout: str) -> _TopicData:
    """esc_status from ``flight.esc``: a message at every report time of any ESC, each slot
    holding its last report (values, own timestamp, online bit), as PX4 publishes it."""
    chans = flight.esc.channels
    if max(c.esc_index if c.esc_index >= 0 else c.motor - 1 for c in chans) >= ESC_SLOTS:
        raise ValueError(f"write_ulog: esc_status has {ESC_SLOTS} slots")
    lengths = {len(c) for c in chans}
    rounds = np.max([c.t for c in chans], axis=0) if len(lengths) == 1 else None
    if rounds is not None and rounds.size > 1 and np.all(np.min([c.t for c in chans], axis=0)[1:] > rounds[:-1]):
        times = rounds  # one message per telemetry round, as PX4's DShot driver publishes
    else:
        times = np.unique(np.concatenate([c.t for c in chans]))
    us = _us(times)
    online = np.zeros(times.size, dtype=np.int64)
    vals: dict[str, np.ndarray] = {"counter": np.arange(times.size) % 65536,
                                   "esc_count": max(c.esc_index if c.esc_index >= 0 else c.motor - 1
                                                    for c in chans) + 1}
    for c in chans:
        slot = c.esc_index if c.esc_index >= 0 else c.motor - 1
        if esc_layout == "legacy" and slot != c.motor - 1:
            raise ValueError("write_ulog: the legacy esc_report has no actuator_function, so ESC slot i must be "
                             f"motor i+1 (motor {c.motor} is in slot {slot})")
        last = np.searchsorted(c.t, times, side="right") - 1  # the slot's last report at each message
        has = last >= 0
        li = np.clip(last, 0, None)
        vals[f"esc[{slot}].timestamp"] = np.where(has, _us(np.maximum(c.t, 1e-6))[li], 0)
        for q, fld in (("rpm", "esc_rpm"), ("current", "esc_current"), ("voltage", "esc_voltage"),
                       ("temperature", "esc_temperature")):
            v = c.quantity(q)
            if v is None:
                continue
            col = np.where(has, np.nan_to_num(v[li], nan=0.0), 0.0)
            vals[f"esc[{slot}].{fld}"] = np.round(col).astype(np.int64) if q == "rpm" else col
        if esc_layout != "legacy":
            vals[f"esc[{slot}].actuator_function"] = OUTPUT_FUNCTION_MOTOR1 + c.motor - 1
        online |= np.where(has & c.online[li], 1 << slot, 0)
    vals["esc_online_flags"] = online
    return _TopicData("esc_status", us, vals)


def _topics(flight: Flight, esc_layout: str = "current") -> list[_TopicData]:
    out: list[_TopicData] = []
    fac = _thr_mdl_fac(flight)
    t0, t1 = float(flight.t_start), float(flight.t_end)
    vtype = _vehicle_type(flight)

    # vehicle_status and vehicle_land_detected: periodic plus every state change
    ts = _state_times(t0, t1, STATUS_RATE_HZ, flight.armed)
    armed = _in_intervals(ts, flight.armed)
    # armed_time / takeoff_time: µs of the first arming / take-off, 0 before it (PX4: "not set")
    first_arm = flight.armed[0][0] if flight.armed else np.inf
    first_air = flight.airborne[0][0] if flight.airborne else np.inf
    out.append(_TopicData("vehicle_status", _us(ts), {
        "armed_time": np.where(armed, round(first_arm * US_PER_S) if flight.armed else 0, 0),
        "takeoff_time": np.where(ts >= first_air, round(first_air * US_PER_S) if flight.airborne else 0, 0),
        "arming_state": np.where(armed, ARMING_STATE_ARMED, ARMING_STATE_DISARMED),
        "vehicle_type": STATUS_FIXED_WING if vtype == "fixed_wing" else STATUS_ROTARY_WING,
        "is_vtol": 1 if vtype == "vtol" else 0,
        "system_type": _mav_type(flight) or 0,
    }))
    tl = _state_times(t0, t1, LAND_DETECTED_RATE_HZ, flight.airborne)
    landed = ~_in_intervals(tl, flight.airborne)
    out.append(_TopicData("vehicle_land_detected", _us(tl), {
        "ground_contact": landed, "maybe_landed": landed, "landed": landed}))

    if flight.rates is not None and len(flight.rates):
        us = _us(flight.rates.t)
        xyz = flight.rates.values[:, :3]
        out.append(_TopicData("vehicle_angular_velocity", us, {
            "timestamp_sample": us, **{f"xyz[{i}]": xyz[:, i] for i in range(3)}}))

    if flight.accel is not None and len(flight.accel):
        acc = flight.accel
        us = _us(acc.t)
        # PX4's sensor_combined gyro is the integrated raw gyro, not vehicle_angular_velocity's
        # low-passed one: the vibration's sensor_combined stream holds it where the Flight has one
        own = next((s.gyro for s in (flight.vibration.imus if flight.vibration is not None else [])
                    if s.source == "sensor_combined" and s.gyro is not None and len(s.gyro)), None)
        src = own if own is not None else flight.rates
        gyro = (np.column_stack([np.interp(acc.t, src.t, src.values[:, i]) for i in range(3)])
                if src is not None and len(src) else np.zeros((len(acc), 3)))
        out.append(_TopicData("sensor_combined", us, {
            **{f"gyro_rad[{i}]": gyro[:, i] for i in range(3)},
            **{f"accelerometer_m_s2[{i}]": acc.values[:, i] for i in range(3)}}))

    if flight.attitude is not None and len(flight.attitude):
        a = flight.attitude.values
        yaw = a[:, 2] if a.shape[1] > 2 else np.zeros(len(a))
        q = euler_to_quaternion(a[:, 0], a[:, 1], yaw)
        us = _us(flight.attitude.t)
        out.append(_TopicData("vehicle_attitude", us, {
            "timestamp_sample": us, **{f"q[{i}]": q[:, i] for i in range(4)}}))

    if flight.motors is not None and len(flight.motors):
        m = flight.motors
        n = min(m.values.shape[1], ACTUATOR_MOTORS_CONTROLS)
        thrust = m.values[:, :n] if flight.motor_kind == "thrust" else thrust_from_signal(m.values[:, :n], fac)
        control = np.full((len(m), ACTUATOR_MOTORS_CONTROLS), np.nan)
        control[:, :n] = thrust
        us = _us(m.t)
        out.append(_TopicData("actuator_motors", us, {
            "timestamp_sample": us, **{f"control[{i}]": control[:, i] for i in range(ACTUATOR_MOTORS_CONTROLS)}}))

    signal: Optional[Series] = flight.alt_motors.get("actuator_outputs")
    if signal is None and flight.motors is not None and len(flight.motors):
        m = flight.motors
        values = signal_from_thrust(m.values, fac) if flight.motor_kind == "thrust" else m.values
        signal = Series(m.t, values, "motors")
    if signal is not None and len(signal):
        lo, hi, disarmed = _output_range(flight)
        n = min(signal.values.shape[1], ACTUATOR_OUTPUTS_CHANNELS)
        pwm = lo + np.clip(signal.values[:, :n], 0.0, 1.0) * (hi - lo)
        if flight.armed:
            pwm[~_in_intervals(signal.t, flight.armed)] = disarmed
        output = np.zeros((len(signal), ACTUATOR_OUTPUTS_CHANNELS))
        output[:, :n] = pwm
        out.append(_TopicData("actuator_outputs", _us(signal.t), {
            "noutputs": n, **{f"output[{i}]": output[:, i] for i in range(ACTUATOR_OUTPUTS_CHANNELS)}}))

    if flight.velocity is not None and len(flight.velocity):
        v = flight.velocity.values[:, :3]
        t = flight.velocity.t
        # position integrated from velocity (trapezoid): the reader's ground-run check looks at z
        dt = np.diff(t, prepend=t[:1])
        mid = np.vstack([v[:1], 0.5 * (v[1:] + v[:-1])])
        pos = np.cumsum(mid * dt[:, None], axis=0)
        us = _us(t)
        out.append(_TopicData("vehicle_local_position", us, {
            "timestamp_sample": us, "xy_valid": 1, "z_valid": 1, "v_xy_valid": 1, "v_z_valid": 1,
            "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2], "vx": v[:, 0], "vy": v[:, 1], "vz": v[:, 2]}))

    if flight.esc is not None and flight.esc.channels:
        out.append(_esc_status(flight, esc_layout))
    elif flight.esc_rpm is not None and len(flight.esc_rpm):
        e = flight.esc_rpm
        n = min(e.values.shape[1], ESC_SLOTS)
        us = _us(e.t)
        vals: dict[str, np.ndarray] = {"counter": np.arange(len(e)) % 65536, "esc_count": n,
                                       "esc_online_flags": (1 << n) - 1}
        for i in range(n):
            vals[f"esc[{i}].timestamp"] = us
            vals[f"esc[{i}].esc_rpm"] = np.round(e.values[:, i]).astype(np.int64)
            vals[f"esc[{i}].actuator_function"] = OUTPUT_FUNCTION_MOTOR1 + i
        out.append(_TopicData("esc_status", us, vals))
    out.extend(_vibration_topics(flight))
    return out


def _vibration_topics(flight: Flight) -> list[_TopicData]:
    """vehicle_imu_status (PX4 metrics only) and sensor_accel / sensor_gyro from ``flight.vibration``:
    every continuous raw stream except sensor_combined (written from ``accel`` and ``rates``)."""
    v = flight.vibration
    if v is None:
        return []
    out = []
    if v.metric_kind == "px4_imu_status":
        for inst, m in sorted(v.metrics.items()):
            clip = v.clips.get(inst)
            c = (np.interp(m.t, clip.t, clip.values[:, 0]) if clip is not None and len(clip)
                 else np.zeros(len(m)))
            vals = np.nan_to_num(m.values[:, :3], nan=0.0) if m.values.shape[1] >= 3 else np.column_stack(
                [m.values[:, 0], np.zeros((len(m), 2))])
            out.append(_TopicData("vehicle_imu_status", _us(m.t), {
                "accel_device_id": 1 + inst, "gyro_device_id": 1 + inst,
                "accel_clipping[0]": np.round(c).astype(np.int64),
                "accel_vibration_metric": vals[:, 0], "gyro_vibration_metric": vals[:, 1],
                "gyro_coning_vibration": vals[:, 2]}, instance=inst))
    for s in v.imus:
        if s.batch or s.gyro is flight.rates or s.accel is flight.accel or s.source.startswith(("IMU", "sensor_combined")):
            continue
        for topic, series in (("sensor_accel", s.accel), ("sensor_gyro", s.gyro)):
            if series is None or not len(series):
                continue
            us = _us(series.t)
            out.append(_TopicData(topic, us, {"timestamp_sample": us, "device_id": 1 + s.instance,
                                              **{c: series.values[:, j] for j, c in enumerate("xyz")}},
                                  instance=s.instance))
    return out


def _mav_type(flight: Flight) -> Optional[int]:
    vt = _vehicle_type(flight)
    if vt in MAV_TYPE_FOR_VEHICLE:
        return MAV_TYPE_FOR_VEHICLE[vt]
    if flight.frame is not None and flight.frame.rotor_count in MAV_TYPE_FOR_ROTORS:
        return MAV_TYPE_FOR_ROTORS[flight.frame.rotor_count]
    if "MAV_TYPE" in flight.params:
        return int(flight.params["MAV_TYPE"])
    return None


def _frame_params(frame: Frame) -> dict[str, float]:
    p: dict[str, float] = {"CA_ROTOR_COUNT": float(frame.rotor_count), "CA_AIRFRAME": 0.0}
    for i, r in enumerate(frame.rotors):
        p.update({f"CA_ROTOR{i}_PX": r.x, f"CA_ROTOR{i}_PY": r.y, f"CA_ROTOR{i}_PZ": 0.0,
                  f"CA_ROTOR{i}_KM": CA_KM_MAGNITUDE * (1 if r.spin >= 0 else -1), f"CA_ROTOR{i}_CT": CA_CT_DEFAULT,
                  f"CA_ROTOR{i}_AX": 0.0, f"CA_ROTOR{i}_AY": 0.0, f"CA_ROTOR{i}_AZ": -1.0})
        p[f"PWM_MAIN_FUNC{i + 1}"] = float(OUTPUT_FUNCTION_MOTOR1 + i)
    if frame.name in AUTOSTART_FOR_FRAME:
        p["SYS_AUTOSTART"] = float(AUTOSTART_FOR_FRAME[frame.name])
    return p


def _params(flight: Flight) -> dict[str, float]:
    p = {str(k): float(v) for k, v in flight.params.items()}
    if flight.frame is not None and flight.frame.rotors:
        # the frame's geometry replaces any stale one (and the legacy-mixer switch that would hide it)
        for k in [k for k in p if k.startswith("CA_ROTOR") or k == "SYS_CTRL_ALLOC"]:
            del p[k]
        p.update(_frame_params(flight.frame))
    mav = _mav_type(flight)
    if mav is not None:
        p["MAV_TYPE"] = float(mav)
    p["THR_MDL_FAC"] = _thr_mdl_fac(flight)
    lo, hi, disarmed = _output_range(flight)
    p.update({"PWM_MAIN_MIN": lo, "PWM_MAIN_MAX": hi, "PWM_MAIN_DISARM": disarmed})
    return dict(sorted(p.items()))


def _json_safe(obj):
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _info_fields(flight: Flight, hardware: str) -> dict:
    firmware = flight.firmware or "flightlog-fd simulator"
    info: dict = {"sys_name": "PX4", "ver_hw": hardware, "ver_sw": firmware, "sys_os_name": "fdlog"}
    m = re.search(r"v(\d+)\.(\d+)\.(\d+)", firmware)
    if m:
        major, minor, patch = (int(g) for g in m.groups())
        info["ver_sw_release"] = (major << 24) | (minor << 16) | (patch << 8) | 0xFF
    if flight.vehicle_id:
        info["sys_uuid"] = str(flight.vehicle_id)
    if flight.truth is not None:
        info[TRUTH_INFO_KEY] = json.dumps(_json_safe(flight.truth), sort_keys=True, default=str)
    return info


# ---------------------------------------------------------------- entry point


def write_ulog(flight: Flight, path, *, hardware: str = DEFAULT_HARDWARE, esc_layout: str = "current") -> Path:
    """Write ``flight`` as a PX4 ULog at ``path`` (see the module docstring); returns the path.
    ``esc_layout``: ``"current"`` (esc_report with actuator_function) or ``"legacy"`` (PX4 < 1.13)."""
    if esc_layout not in ESC_LAYOUTS:
        raise ValueError(f"esc_layout must be one of {ESC_LAYOUTS}, not {esc_layout!r}")
    formats = FORMATS if esc_layout == "current" else {**FORMATS, "esc_report": ESC_REPORT_LEGACY}
    topics = [tp for tp in _topics(flight, esc_layout) if len(tp.timestamp_us)]
    head = bytearray(ULOG_MAGIC)
    head += struct.pack("<BQ", FILE_VERSION, int(_us(np.array([flight.t_start]))[0]))
    head += _message(MSG_FLAG_BITS, bytes(16) + struct.pack("<3Q", 0, 0, 0))
    needed = {tp.name for tp in topics}
    if "esc_status" in needed:
        needed.add("esc_report")
    for name in FORMATS:
        if name in needed:
            head += _format_message(name, formats)
    for key, value in _info_fields(flight, hardware).items():
        head += _info(key, value)
    for name, value in _params(flight).items():
        head += _param(name, value)
    order = sorted(topics, key=lambda tp: (DATA_TOPICS.index(tp.name), tp.instance))
    for msg_id, tp in enumerate(order):
        head += _message(MSG_ADD_LOGGED, struct.pack("<BH", tp.instance, msg_id) + tp.name.encode("ascii"))

    # every topic's rows as bytes, then one gather in (timestamp, topic) order
    blocks = [tp.records(msg_id, formats) for msg_id, tp in enumerate(order)]
    flat = np.concatenate([b.reshape(-1) for b in blocks]) if blocks else np.zeros(0, np.uint8)
    lengths = np.concatenate([np.full(len(b), b.shape[1], dtype=np.int64) for b in blocks]) if blocks \
        else np.zeros(0, np.int64)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    stamps = np.concatenate([tp.timestamp_us for tp in order]) if order else np.zeros(0, np.uint64)
    topic_rank = np.concatenate([np.full(len(tp.timestamp_us), i) for i, tp in enumerate(order)]) if order \
        else np.zeros(0, np.int64)
    sequence = np.lexsort((topic_rank, stamps))
    sorted_len = lengths[sequence]
    out_starts = np.concatenate([[0], np.cumsum(sorted_len)[:-1]]).astype(np.int64)
    gather = np.repeat(starts[sequence] - out_starts, sorted_len) + np.arange(int(sorted_len.sum()))
    data = flat[gather]

    p = Path(path)
    with open(p, "wb") as f:
        f.write(bytes(head))
        f.write(data.tobytes())
    return p


__all__ = ["write_ulog", "thrust_from_signal", "signal_from_thrust", "euler_to_quaternion", "FORMATS"]
