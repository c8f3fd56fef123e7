"""ArduPilot DataFlash writer: :class:`~flightlog_fd.flight.Flight` -> a binary ``.bin`` log that
pymavlink (``mavlogdump.py``) and :func:`~flightlog_fd.logs.dataflash.read_dataflash` read.

Input: a Flight whose Series are sampled at each stream's own rate; times are seconds on the
flight's clock and must be >= 0 (written as ``TimeUS`` µs, rounded). The file is a DataFlash
log as ArduCopter writes it: every message is ``0xA3 0x95 <type id>`` + a packed little-endian
body described by an ``FMT`` message (the FMT of FMT itself comes first). Formats are
self-describing, so each message carries only columns the Flight has (no invented desired
rates or accelerations); column names and units follow ArduCopter >= 3.4:

- ``PARM`` (TimeUS, Name, Value): ``flight.params`` overridden by what the Flight's own fields
  say: ``FRAME_CLASS`` 1 / ``FRAME_TYPE`` (1 X, 0 +) for a quad, the frame's own ArduPilot class
  and type for an n-rotor frame (:func:`frame_class_type`), ``MOT_THST_EXPO`` (``thrust_curve``, else
  0.65), plus, when the params lack them, ``MOT_PWM_MIN/MAX`` 1000/2000, ``SERVO1..n_FUNCTION``
  (motor k on output k: 33.., 82.. beyond motor 8) and ``MOT_THST_HOVER`` (median collective thrust while airborne). Names longer than
  16 characters (the ``N`` field) are not written.
- ``MSG``: the firmware line (``flight.firmware`` when it names ArduCopter >= 3.4, else
  ``WRITER_FIRMWARE``: the reader's unit and mixer conventions follow the version it reads),
  ``Frame: QUAD/X`` (``HEXA/X``...) and the board's UID line: ``vehicle_id`` itself when it is a
  "board UID UID UID" string, else ``FDLOG_SIM`` and three 8-digit hex words of the sha256 of
  ``vehicle_id`` (:func:`sim_board_uid`), so that simulated fleets have one id per airframe.
- ``EV``: 10 armed / 11 disarmed at the ``armed`` interval ends; 28 NOT_LANDED / 18
  LAND_COMPLETE at the ``airborne`` interval ends.
- ``IMU`` (TimeUS, I=0, GyrX/Y/Z rad/s from ``rates``, AccX/Y/Z m/s² from ``accel`` at those
  times, NaN without one); ``ATT`` (Roll, Pitch, Yaw deg) from
  ``attitude`` (yaw 0 when absent).
- ``RATE`` (R/P/Y deg/s, ROut/POut/YOut/AOut) at the motors' timestamps when ``motor_kind`` is
  ``"thrust"``: the outputs are the exact inverse of the reader's AP_MotorsMatrix mix (4 motors,
  4 unknowns: collective, roll, pitch, yaw; n > 4 motors: the least-squares inputs, exact for
  commands in the mix's span, as a least-squares allocation makes them), and R/P/Y are ``rates``
  interpolated there.
- ``RCOU`` (C1..C14 PWM, integer µs) from ``alt_motors["RCOU"]`` when present, else from
  ``motors`` (a thrust setpoint goes through the ``MOT_THST_EXPO`` curve first), each motor on
  its ``SERVOn_FUNCTION`` output, PWM = min + signal x (max - min). Derived from thrust motors,
  RCOU is written at every ``k``-th motor sample (about ``RCOU_LOG_HZ``, at most half the RATE
  rate) as ArduCopter logs it at 10 Hz; the reader then keeps RATE as the motor source.
- ``CTUN`` (ThO = mean thrust setpoint) at the motors' timestamps, so the reader's throttle
  check of the airborne intervals sees what the Flight flew.
- ESC telemetry from ``esc`` (one message per ESC report, ``Instance`` = the channel's
  ``esc_index``, else its motor's output channel - 1) in the generation ``esc_layout`` names:
  ``"esc_rawrpm"`` (ArduCopter 4.3+, ``QBffffcfcf`` with ``RawRPM``), ``"esc_float"`` (4.1-4.2,
  ``QBeffcfcff``), ``"esc_int"`` (4.0, ``QBeCCcHc``), each with its FMTU (units and multipliers)
  and MULT messages as ArduPilot writes them, or ``"escn"`` (3.3-3.6: ``ESC1..ESC8``, ``Qcccc``,
  rpm/10 in a centi field, no FMTU). Offline samples (``online`` False) are not written (ArduPilot
  logs an ESC only when its telemetry updated). Without ``esc``: ``ESC`` (Instance, RPM) from
  ``esc_rpm``. ``XKF1`` (C=0, VN/VE/VD m/s) from ``velocity``.
- From ``vibration``: ``VIBE`` (IMU, VibeX/Y/Z, Clip; ArduCopter 4.x) per IMU when its metrics are
  ArduPilot's (a PX4 metric has another definition and is not written), ``ACC`` / ``GYR`` (I,
  SampleUS, X/Y/Z) for every continuous raw stream other than the IMU message's; batch-sampler
  streams are not written.

Precision: float32 for rates, attitude, velocity, RATE and parameters; 1 µs for time; 1 µs of
PWM (1/(max-min) of the signal); 0.01 rpm. ``truth`` is not written. Quad X and + and every
frame with an ArduPilot motor table (hexa, octo, octaquad...: from ``Frame.layout``, else the
params' FRAME_CLASS/FRAME_TYPE when they give the frame's rotor count) are written; others raise
``ValueError``. Vectorised: each message type is one numpy structured array
(header + body) and all rows are scattered into the output buffer by one strided assignment
per type, in time order.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from ..flight import Flight, Series
from .dataflash import (
    BOARD_UID_RE,
    DEFAULT_THST_EXPO,
    FMT_TYPE_ID,
    FORMAT_CHARS,
    FRAME_TYPE_PLUS,
    FRAME_TYPE_X,
    HEAD1,
    HEAD2,
    MIXER_SINCE,
    EV_ARMED,
    EV_DISARMED,
    EV_LAND_COMPLETE,
    EV_NOT_LANDED,
    mixer_factors,
    motor_output_channels,
    parse_firmware,
    pwm_range,
    signal_to_thrust,
    thrust_to_signal,
)

US_PER_S = 1e6
WRITER_FIRMWARE = "ArduCopter V4.5.7 (flightlog-fd)"
RCOU_LOG_HZ = 10.0  # ArduCopter's RCOU logging rate
RCOU_CHANNELS = 14
MAX_PARAM_NAME = 16
MAX_MSG_CHARS = 64
QUAD_FRAME_CLASS = 1
DEFAULT_PARAMS = {"MOT_PWM_MIN": 1000.0, "MOT_PWM_MAX": 2000.0,
                  **{f"SERVO{k}_FUNCTION": float(32 + k) for k in range(1, 5)}}
#: Hover thrust written when the flight has no airborne samples to measure it from.
DEFAULT_HOVER_THRUST = 0.35


@dataclass(frozen=True)
class _Format:
    """One message type: id, name, DataFlash format string and column names."""

    type_id: int
    name: str
    format: str
    columns: tuple[str, ...]

    @property
    def dtype(self) -> np.dtype:
        fields = [("head1", "u1"), ("head2", "u1"), ("msgid", "u1")]
        fields += [(c, FORMAT_CHARS[ch][0]) for c, ch in zip(self.columns, self.format)]
        return np.dtype(fields)

    @property
    def length(self) -> int:
        return self.dtype.itemsize


FMT = _Format(FMT_TYPE_ID, "FMT", "BBnNZ", ("Type", "Length", "Name", "Format", "Columns"))
PARM = _Format(129, "PARM", "QNf", ("TimeUS", "Name", "Value"))
MSG = _Format(130, "MSG", "QZ", ("TimeUS", "Message"))
EV = _Format(131, "EV", "QB", ("TimeUS", "Id"))
IMU = _Format(132, "IMU", "QBffffff", ("TimeUS", "I", "GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ"))
ATT = _Format(133, "ATT", "Qfff", ("TimeUS", "Roll", "Pitch", "Yaw"))
RATE = _Format(134, "RATE", "Qfffffff", ("TimeUS", "R", "ROut", "P", "POut", "Y", "YOut", "AOut"))
RCOU = _Format(135, "RCOU", "Q" + "H" * RCOU_CHANNELS, ("TimeUS", *(f"C{k}" for k in range(1, RCOU_CHANNELS + 1))))
CTUN = _Format(136, "CTUN", "Qf", ("TimeUS", "ThO"))
ESC = _Format(137, "ESC", "QBe", ("TimeUS", "Instance", "RPM"))
XKF1 = _Format(138, "XKF1", "QBfff", ("TimeUS", "C", "VN", "VE", "VD"))
FMTU = _Format(139, "FMTU", "QBNN", ("TimeUS", "FmtType", "UnitIds", "MultIds"))
MULT = _Format(140, "MULT", "Qbd", ("TimeUS", "Id", "Mult"))
#: ESC telemetry generations (ArduPilot AP_ESC_Telem / DataFlash LogStructure): format, units, multipliers.
ESC_LAYOUTS = {
    "esc_rawrpm": (_Format(137, "ESC", "QBffffcfcf", ("TimeUS", "Instance", "RPM", "RawRPM", "Volt", "Curr", "Temp",
                                                      "CTot", "MotTemp", "Err")), "s#qqvAOaO%", "F-00--BCB-"),
    "esc_float": (_Format(137, "ESC", "QBeffcfcff", ("TimeUS", "Instance", "RPM", "Volt", "Curr", "Temp", "CTot",
                                                     "MotTemp", "Err", "RXErr")), "s#qvAOaO%%", "F-B--BCB--"),
    "esc_int": (_Format(137, "ESC", "QBeCCcHc", ("TimeUS", "Instance", "RPM", "Volt", "Curr", "Temp", "CTot",
                                                 "MotTemp")), "s#qvAO-O", "F-BBBB-B"),
}
ESCN_FORMATS = tuple(_Format(141 + k, f"ESC{k + 1}", "Qcccc", ("TimeUS", "RPM", "Volt", "Curr", "Temp"))
                     for k in range(8))
#: ``ESC1..8`` store rpm/10 in a ``c`` (x0.01) field: the decoded RPM is rpm/1000.
ESCN_RPM_DIVISOR = 1000.0
#: The multipliers ArduPilot defines for the ids above (AP_Logger log_Multipliers).
MULTIPLIER_VALUES = {"-": 0.0, "?": 1.0, "0": 1.0, "B": 1e-2, "C": 1e-3, "F": 1e-6}
ESC_LAYOUT_NAMES = (*ESC_LAYOUTS, "escn")
#: Vibration (ArduCopter 4.x): VIBE per IMU with its clipping count, raw IMU samples ACC / GYR.
VIBE = _Format(150, "VIBE", "QBfffI", ("TimeUS", "IMU", "VibeX", "VibeY", "VibeZ", "Clip"))
ACC = _Format(151, "ACC", "QBQfff", ("TimeUS", "I", "SampleUS", "AccX", "AccY", "AccZ"))
GYR = _Format(152, "GYR", "QBQfff", ("TimeUS", "I", "SampleUS", "GyrX", "GyrY", "GyrZ"))
ALL_FORMATS = (FMT, PARM, MSG, FMTU, MULT, EV, IMU, ATT, RATE, RCOU, CTUN, ESC, XKF1, VIBE, ACC, GYR)


@dataclass
class _Block:
    """Rows of one message type ready to merge: their sort keys and raw bytes."""

    fmt: _Format
    phase: int  # 0 = header (FMT, PARM, MSG) before all data, 1 = data in time order
    time_us: np.ndarray
    rows: np.ndarray  # (n, length) uint8


def _block(fmt: _Format, time_us: np.ndarray, phase: int = 1, **cols) -> _Block:
    n = int(np.asarray(time_us).shape[0])
    rec = np.zeros(n, dtype=fmt.dtype)
    rec["head1"], rec["head2"], rec["msgid"] = HEAD1, HEAD2, fmt.type_id
    if "TimeUS" in fmt.columns:
        rec["TimeUS"] = time_us
    for name, value in cols.items():
        ch = fmt.format[fmt.columns.index(name)]
        mult = FORMAT_CHARS[ch][1]
        if mult is not None:  # stored as integer value / mult, as ArduPilot logs it
            value = np.round(np.asarray(value, dtype=np.float64) / mult)
        rec[name] = value
    return _Block(fmt, phase, np.asarray(time_us, dtype=np.uint64), rec.view(np.uint8).reshape(n, fmt.length))


def _to_us(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    if t.size and (not np.all(np.isfinite(t)) or t.min() < 0):
        raise ValueError("write_dataflash: times must be finite and >= 0 (TimeUS is unsigned)")
    return np.round(t * US_PER_S).astype(np.uint64)


def frame_class_type(flight: Flight) -> tuple[int, int]:
    """ArduPilot (FRAME_CLASS, FRAME_TYPE) to write for the flight's frame (see module docstring)."""
    from ..frames import ARDUPILOT_FRAME_CLASSES, ARDUPILOT_FRAME_TYPES, ardupilot_frame

    frame = flight.frame
    name = frame.name if frame is not None else "quad_x"
    if name == "quad_x":
        return QUAD_FRAME_CLASS, FRAME_TYPE_X
    if name == "quad_plus":
        return QUAD_FRAME_CLASS, FRAME_TYPE_PLUS
    n = frame.rotor_count if frame is not None else 0
    m = re.fullmatch(r"ArduPilot (\w+)/(\w+)", frame.layout or "") if frame is not None else None
    if m and n:
        classes = {v.upper(): k for k, v in ARDUPILOT_FRAME_CLASSES.items()}
        types = {v: k for k, v in ARDUPILOT_FRAME_TYPES.items()}
        if m.group(1) in classes and m.group(2) in types:
            return classes[m.group(1)], types[m.group(2)]
    if n and "FRAME_CLASS" in flight.params:
        fc, ft = int(flight.params["FRAME_CLASS"]), int(flight.params.get("FRAME_TYPE", 1))
        if ardupilot_frame(fc, ft).rotor_count == n:
            return fc, ft
    raise ValueError(f"write_dataflash: frame {name!r} ({frame.layout if frame is not None else ''}) has no "
                     f"ArduPilot motor table to write")


def _motor_function(k: int) -> float:
    """SERVOn_FUNCTION value of motor k (SRV_Channel.h: motors 1-8 = 33-40, 9-12 = 82-85)."""
    return float(32 + k if k <= 8 else 73 + k)


def _firmware_line(flight: Flight) -> str:
    version = parse_firmware(flight.firmware)
    if version is not None and version >= MIXER_SINCE and "Copter" in flight.firmware:
        return flight.firmware[:MAX_MSG_CHARS]
    return WRITER_FIRMWARE


def _collective_thrust(flight: Flight, expo: float) -> Optional[Series]:
    """Mean thrust setpoint over the motors (what CTUN.ThO logs)."""
    m = flight.motors
    if m is None or len(m) == 0:
        return None
    thrust = m.values if flight.motor_kind == "thrust" else signal_to_thrust(m.values, expo)
    return Series(m.t, thrust.mean(axis=1), "collective")


def _hover_thrust(collective: Optional[Series], airborne: list[tuple[float, float]]) -> float:
    if collective is None:
        return DEFAULT_HOVER_THRUST
    mask = np.zeros(len(collective), dtype=bool)
    for a, b in airborne:
        mask |= (collective.t >= a) & (collective.t <= b)
    vals = collective.values[mask, 0] if mask.any() else collective.values[:, 0]
    vals = vals[np.isfinite(vals)]
    return float(np.median(vals)) if vals.size else DEFAULT_HOVER_THRUST


def _params(flight: Flight, frame_class: int, frame_type: int, n_motors: int, expo: float,
            hover: float) -> dict[str, float]:
    params = {**DEFAULT_PARAMS, **{k: float(v) for k, v in flight.params.items()}}
    if n_motors > 4 and not all(f"SERVO{k}_FUNCTION" in flight.params for k in range(1, n_motors + 1)):
        params.update({f"SERVO{k}_FUNCTION": _motor_function(k) for k in range(1, n_motors + 1)})
    params["FRAME_CLASS"] = float(frame_class)
    params["FRAME_TYPE"] = float(frame_type)
    params.pop("FRAME", None)  # the pre-3.5 parameter would contradict FRAME_TYPE
    params["MOT_THST_EXPO"] = float(expo)
    params.setdefault("MOT_THST_HOVER", float(hover))
    return {k: v for k, v in params.items() if len(k) <= MAX_PARAM_NAME and np.isfinite(v)}


def _event_block(flight: Flight) -> Optional[_Block]:
    events: list[tuple[float, int]] = []
    for a, b in flight.armed:
        events += [(a, EV_ARMED), (b, EV_DISARMED)]
    for a, b in flight.airborne:
        events += [(a, EV_NOT_LANDED), (b, EV_LAND_COMPLETE)]
    if not events:
        return None
    # at equal times ArduCopter logs landing before disarm and arm before take-off
    priority = {EV_ARMED: 0, EV_NOT_LANDED: 1, EV_LAND_COMPLETE: 2, EV_DISARMED: 3}
    events.sort(key=lambda e: (e[0], priority[e[1]]))
    return _block(EV, _to_us([e[0] for e in events]), Id=[e[1] for e in events])


def _rcou_block(flight: Flight, params: dict[str, float], expo: float, n_motors: int) -> Optional[_Block]:
    source = flight.alt_motors.get("RCOU")
    if source is not None:
        t, signal = source.t, source.values
    elif flight.motors is not None and len(flight.motors):
        t, signal = flight.motors.t, flight.motors.values
        if flight.motor_kind == "thrust":
            signal = thrust_to_signal(signal, expo)
            # ArduCopter logs RCOU at 10 Hz; keep it below the RATE rate so RATE stays the source
            step = max(2, int(round(flight.motors.rate_hz / RCOU_LOG_HZ))) if len(t) > 1 else 1
            t, signal = t[::step], signal[::step]
    else:
        return None
    if signal.shape[1] != n_motors:
        raise ValueError(f"write_dataflash: RCOU source has {signal.shape[1]} motors, frame has {n_motors}")
    lo, hi, _ = pwm_range(params)
    channels, _ = motor_output_channels(params, n_motors)
    if max(channels) > RCOU_CHANNELS:
        raise ValueError(f"write_dataflash: motor output channel {max(channels)} beyond C{RCOU_CHANNELS}")
    pwm = np.round(lo + np.clip(signal, 0.0, 1.0) * (hi - lo)).astype(np.uint16)
    return _block(RCOU, _to_us(t), **{f"C{ch}": pwm[:, k] for k, ch in enumerate(channels)})


def _rate_block(flight: Flight, factors: np.ndarray) -> Optional[_Block]:
    m = flight.motors
    if m is None or len(m) == 0 or flight.motor_kind != "thrust":
        return None
    # thrust_i = A + R rf_i + P pf_i + Y yf_i: a 4x4 system per sample for a quad, least squares for n > 4
    mix_matrix = np.column_stack([np.ones(factors.shape[0]), factors])
    if factors.shape[0] == 4:
        inputs = np.linalg.solve(mix_matrix, m.values.T).T  # (n, 4): A, R, P, Y
    else:
        inputs = np.linalg.lstsq(mix_matrix, m.values.T, rcond=None)[0].T
    if flight.rates is not None and len(flight.rates):
        r = flight.rates
        order = np.argsort(r.t, kind="stable")
        deg = np.column_stack([np.interp(m.t, r.t[order], r.values[order, k]) for k in range(3)])
        deg = np.degrees(deg)
    else:
        deg = np.full((len(m), 3), np.nan)
    return _block(RATE, _to_us(m.t), R=deg[:, 0], P=deg[:, 1], Y=deg[:, 2],
                  AOut=inputs[:, 0], ROut=inputs[:, 1], POut=inputs[:, 2], YOut=inputs[:, 3])


def _esc_block(flight: Flight, params: dict[str, float], n_motors: int) -> Optional[_Block]:
    e = flight.esc_rpm
    if e is None or len(e) == 0:
        return None
    channels, _ = motor_output_channels(params, n_motors)
    n, k = e.values.shape
    if k != n_motors:
        raise ValueError(f"write_dataflash: esc_rpm has {k} columns, frame has {n_motors} motors")
    # one message per motor per sample, motors of a sample in a row (time-major)
    t = np.repeat(_to_us(e.t), k)
    inst = np.tile(np.asarray(channels) - 1, n)
    return _block(ESC, t, Instance=inst, RPM=e.values.reshape(-1))


def _esc_telemetry_blocks(flight: Flight, params: dict[str, float], n_motors: int, layout: str) -> list[_Block]:
    """ESC messages of ``flight.esc`` in one generation (see the module docstring), with FMTU/MULT."""
    if layout not in ESC_LAYOUT_NAMES:
        raise ValueError(f"esc_layout must be one of {ESC_LAYOUT_NAMES}, not {layout!r}")
    channels, _ = motor_output_channels(params, n_motors)
    rows = []
    for c in flight.esc.channels:
        index = c.esc_index if c.esc_index >= 0 else channels[c.motor - 1] - 1
        m = c.online
        cols = {q: np.nan_to_num(v[m], nan=0.0) if (v := c.quantity(q)) is not None else np.zeros(int(m.sum()))
                for q in ("rpm", "current", "voltage", "temperature")}
        rows.append((index, c.t[m], cols))
    if layout == "escn":
        out = []
        for index, t, cols in rows:
            if not 0 <= index < len(ESCN_FORMATS):
                raise ValueError(f"write_dataflash: ESC1..ESC8 cannot hold ESC index {index}")
            out.append(_block(ESCN_FORMATS[index], _to_us(t), RPM=cols["rpm"] / ESCN_RPM_DIVISOR,
                              Volt=cols["voltage"], Curr=cols["current"], Temp=cols["temperature"]))
        return out
    fmt, units, mults = ESC_LAYOUTS[layout]
    t = np.concatenate([r[1] for r in rows])
    inst = np.concatenate([np.full(r[1].size, r[0]) for r in rows])
    cat = {q: np.concatenate([r[2][q] for r in rows]) for q in ("rpm", "current", "voltage", "temperature")}
    order = np.argsort(t, kind="stable")
    cols = {"Instance": inst[order], "RPM": cat["rpm"][order], "Volt": cat["voltage"][order],
            "Curr": cat["current"][order], "Temp": cat["temperature"][order]}
    if "RawRPM" in fmt.columns:
        cols["RawRPM"] = cat["rpm"][order]
    esc = _block(fmt, _to_us(t[order]), **cols)
    fmtu = _block(FMTU, np.zeros(1, dtype=np.uint64), phase=0, FmtType=[fmt.type_id], UnitIds=[units.encode()],
                  MultIds=[mults.encode()])
    ids = sorted(set(mults))
    mult = _block(MULT, np.zeros(len(ids), dtype=np.uint64), phase=0, Id=[ord(i) for i in ids],
                  Mult=[MULTIPLIER_VALUES[i] for i in ids])
    return [fmtu, mult, esc]


def _vibration_blocks(flight: Flight) -> list[_Block]:
    """VIBE (ArduPilot metrics only) and ACC / GYR from ``flight.vibration``: every continuous raw
    stream except the one the IMU message already carries (``rates`` / ``accel``)."""
    v = flight.vibration
    if v is None:
        return []
    out = []
    if v.metric_kind == "ardupilot_vibe":
        for inst, m in sorted(v.metrics.items()):
            clip = v.clips.get(inst)
            c = (np.interp(m.t, clip.t, clip.values[:, 0]) if clip is not None and len(clip)
                 else np.zeros(len(m)))
            out.append(_block(VIBE, _to_us(m.t), IMU=np.full(len(m), inst, dtype=np.uint8), VibeX=m.values[:, 0],
                              VibeY=m.values[:, 1], VibeZ=m.values[:, 2], Clip=np.round(c).astype(np.uint32)))
    for s in v.imus:
        if s.batch or s.gyro is flight.rates or s.accel is flight.accel or s.source.startswith(("IMU", "sensor_combined")):
            continue
        for fmt, series, cols in ((ACC, s.accel, ("AccX", "AccY", "AccZ")), (GYR, s.gyro, ("GyrX", "GyrY", "GyrZ"))):
            if series is None or not len(series):
                continue
            us = _to_us(series.t)
            out.append(_block(fmt, us, I=np.full(len(series), s.instance, dtype=np.uint8), SampleUS=us,
                              **{c: series.values[:, j] for j, c in enumerate(cols)}))
    return out


def sim_board_uid(vehicle_id: str) -> str:
    """The MSG board-UID line written for ``vehicle_id`` (itself when it already is one)."""
    if BOARD_UID_RE.match(vehicle_id):
        return vehicle_id
    import hashlib

    h = hashlib.sha256(vehicle_id.encode("utf-8")).hexdigest().upper()
    return f"FDLOG_SIM {h[0:8]} {h[8:16]} {h[16:24]}"


def _header_blocks(flight: Flight, params: dict[str, float], firmware: str, frame_class: int, frame_type: int,
                   formats: list[_Format]) -> list[_Block]:
    from ..frames import ARDUPILOT_FRAME_CLASSES, ARDUPILOT_FRAME_TYPES

    t0 = _to_us([flight.t_start])[0] if flight.t_start > 0 else np.uint64(0)
    fmt_rows = _block(FMT, np.zeros(len(formats), dtype=np.uint64), phase=0,
                      Type=[f.type_id for f in formats], Length=[f.length for f in formats],
                      Name=[f.name.encode() for f in formats], Format=[f.format.encode() for f in formats],
                      Columns=[",".join(f.columns).encode() for f in formats])
    names = sorted(params)
    parm = _block(PARM, np.full(len(names), t0, dtype=np.uint64), phase=0,
                  Name=[n.encode() for n in names], Value=[params[n] for n in names])
    if frame_class == QUAD_FRAME_CLASS:
        frame_line = f"Frame: QUAD/{'X' if frame_type == FRAME_TYPE_X else 'PLUS'}"
    else:
        frame_line = (f"Frame: {ARDUPILOT_FRAME_CLASSES[frame_class].upper()}/"
                      f"{ARDUPILOT_FRAME_TYPES.get(frame_type, frame_type)}")
    lines = [firmware, frame_line]
    if flight.vehicle_id:
        lines.append(sim_board_uid(flight.vehicle_id))
    msg = _block(MSG, np.full(len(lines), t0, dtype=np.uint64), phase=0,
                 Message=[s[:MAX_MSG_CHARS].encode("utf-8", "replace") for s in lines])
    return [fmt_rows, parm, msg]


def _merge(blocks: list[_Block]) -> np.ndarray:
    """All rows in (phase, time, block order) order as one uint8 buffer."""
    lengths = np.concatenate([np.full(len(b.time_us), b.fmt.length, dtype=np.int64) for b in blocks])
    phase = np.concatenate([np.full(len(b.time_us), b.phase, dtype=np.int64) for b in blocks])
    times = np.concatenate([b.time_us for b in blocks])
    seq = np.arange(times.size)
    order = np.lexsort((seq, times, phase))
    start_sorted = np.concatenate([[0], np.cumsum(lengths[order])[:-1]])
    start = np.empty_like(start_sorted)
    start[order] = start_sorted
    total = int(lengths.sum())
    out = np.zeros(total, dtype=np.uint8)
    first = 0
    for b in blocks:
        n = len(b.time_us)
        if n:
            # overlapping strided windows: row i of the view is out[i : i + length]
            windows = np.lib.stride_tricks.as_strided(out, shape=(total - b.fmt.length + 1, b.fmt.length),
                                                      strides=(1, 1))
            windows[start[first:first + n]] = b.rows
        first += n
    return out


def write_dataflash(flight: Flight, path, *, esc_layout: str = "esc_rawrpm") -> Path:
    """Write ``flight`` as an ArduPilot DataFlash binary log at ``path`` (see module docstring).
    ``esc_layout`` picks the ESC telemetry generation written for ``flight.esc``."""
    path = Path(path)
    frame_class, frame_type = frame_class_type(flight)
    factors = mixer_factors(frame_class, frame_type)
    n_motors = factors.shape[0]
    expo = flight.thrust_curve if flight.thrust_curve is not None else \
        float(flight.params.get("MOT_THST_EXPO", DEFAULT_THST_EXPO))
    collective = _collective_thrust(flight, expo)
    params = _params(flight, frame_class, frame_type, n_motors, expo, _hover_thrust(collective, flight.airborne))
    firmware = _firmware_line(flight)
    if flight.motors is not None and flight.motors.values.shape[1] != n_motors:
        raise ValueError(f"write_dataflash: motors has {flight.motors.values.shape[1]} columns, frame has {n_motors}")

    data: list[Optional[_Block]] = []
    if flight.rates is not None and len(flight.rates):
        r = flight.rates
        if flight.accel is not None and len(flight.accel):  # the IMU message carries both sensors
            acc = np.column_stack([np.interp(r.t, flight.accel.t, flight.accel.values[:, i]) for i in range(3)])
        else:
            acc = np.full((len(r), 3), np.nan)  # read back as "no accelerometer"
        data.append(_block(IMU, _to_us(r.t), I=np.zeros(len(r), dtype=np.uint8),
                           GyrX=r.values[:, 0], GyrY=r.values[:, 1], GyrZ=r.values[:, 2],
                           AccX=acc[:, 0], AccY=acc[:, 1], AccZ=acc[:, 2]))
    if flight.attitude is not None and len(flight.attitude):
        a = flight.attitude
        deg = np.degrees(a.values)
        yaw = deg[:, 2] if deg.shape[1] > 2 else np.zeros(len(a))
        data.append(_block(ATT, _to_us(a.t), Roll=deg[:, 0], Pitch=deg[:, 1], Yaw=yaw))
    data.append(_rate_block(flight, factors))
    data.append(_rcou_block(flight, params, expo, n_motors))
    if collective is not None:
        data.append(_block(CTUN, _to_us(collective.t), ThO=collective.values[:, 0]))
    if flight.esc is not None and flight.esc.channels:
        data.extend(_esc_telemetry_blocks(flight, params, n_motors, esc_layout))
    else:
        data.append(_esc_block(flight, params, n_motors))
    if flight.velocity is not None and len(flight.velocity):
        v = flight.velocity
        data.append(_block(XKF1, _to_us(v.t), C=np.zeros(len(v), dtype=np.uint8),
                           VN=v.values[:, 0], VE=v.values[:, 1], VD=v.values[:, 2]))
    data.append(_event_block(flight))
    data.extend(_vibration_blocks(flight))
    blocks = [b for b in data if b is not None]
    extra = [b.fmt for b in blocks if b.fmt not in ALL_FORMATS]
    used = [FMT] + [f for f in ALL_FORMATS[1:] if f in (PARM, MSG) or any(b.fmt is f for b in blocks)] + \
        list(dict.fromkeys(extra))
    buf = _merge(_header_blocks(flight, params, firmware, frame_class, frame_type, used) + blocks)
    path.parent.mkdir(parents=True, exist_ok=True)
    buf.tofile(path)
    return path
