"""PX4 ULog reader: a ``.ulg`` file -> :class:`~flightlog_fd.flight.Flight`.

Input: a PX4 ULog file (any PX4 version that writes ULog, 2016 onwards; appended data, several
topic instances, tagged logging and default-parameter messages are all handled). Only the topics
listed in ``ULOG_TOPICS`` are decoded.

What is read (times are ``timestamp`` in µs since boot / 1e6 for every stream, the clock every
PX4 log viewer shows; ``timestamp_sample`` is not used so all streams share one time base):

- ``rates`` (rad/s, FRD): ``vehicle_angular_velocity.xyz`` (filtered gyro the rate controller
  uses), else ``sensor_combined.gyro_rad`` (raw gyro), else the old
  ``vehicle_attitude.rollspeed/pitchspeed/yawspeed``. ``Series.source`` names the one used.
- ``attitude`` (rad): roll, pitch, yaw from ``vehicle_attitude.q`` (w, x, y, z; body to NED),
  else the very old ``vehicle_attitude.roll/pitch/yaw``.
- ``motors`` (0..1, column k = motor k+1):

  * ``actuator_motors.control[]`` -> ``motor_kind = "thrust"``. PX4 source
    (``src/lib/mixer_module/functions/FunctionMotors.hpp``, ``updateValues``): the control
    allocator publishes ``actuator_motors`` as normalised *thrust* setpoints and the mixer
    module applies ``THR_MDL_FAC`` afterwards (``rel_thrust = f*x^2 + (1-f)*x`` solved for the
    signal ``x``), then maps 0..1 to -1..1 and on to the output's min..max. So
    ``actuator_motors`` is **before** the thrust model (linear in thrust) and
    ``actuator_outputs`` is **after** it. PX4 publishes NaN for unused motor slots (and, on some
    versions, while disarmed): NaN becomes 0 (motor stopped) and slots beyond the rotor count are
    dropped.
  * else ``actuator_outputs.output[]`` -> ``motor_kind = "signal"``, normalised
    ``(out - min) / (max - min)`` and clipped to 0..1 (the disarmed value, e.g. 900 µs, maps to
    0). Motor k is the output channel whose ``<driver>_FUNCn`` parameter is ``100 + k`` when the
    log has output-function parameters (PX4 >= 1.13), else channel k. min/max per channel from
    ``<driver>_MINn/_MAXn``, else ``PWM_MAIN_MIN/MAX``, else ``PWM_MIN/PWM_MAX``, else
    1000/2000 µs. Of several instances, the one whose motor channels sit in the output range
    and move most is used.
  * when both exist the other one goes to ``Flight.alt_motors["actuator_outputs"]``.
- ``esc_rpm``: ``esc_status.esc[i].esc_rpm`` (mapped to motors by ``actuator_function`` where
  logged), only when the ESCs report something non-zero. ``esc``: the same topic per motor
  (:func:`esc_telemetry`: rpm, current, voltage, temperature; offline and stale reports marked).
- ``velocity`` (NED m/s): ``vehicle_local_position.vx/vy/vz``.
- ``accel`` (m/s², FRD body specific force): ``sensor_combined.accelerometer_m_s2``.
- ``thrust_curve``: ``THR_MDL_FAC``; ``params``: every initial parameter as float.
- ``frame``: ``CA_ROTOR_COUNT`` and ``CA_ROTOR{i}_PX/PY/KM`` (i 0-based = motor i+1) when the
  control allocator is in use (no ``SYS_CTRL_ALLOC = 0``), else the ``SYS_AUTOSTART`` airframe
  range (4xxx/10xxx quad-X, 5xxx quad-+, 6xxx/7xxx/11xxx hexa, 8xxx/9xxx/12xxx octo, 13xxx VTOL,
  2xxx/3xxx fixed wing; the hexa/octo/coaxial ranges get PX4's mixer geometry from
  :mod:`flightlog_fd.frames`), else quad-X assumed for ``MAV_TYPE`` 2, with a warning. n-rotor
  control-allocation frames get rotor names, thrust axes (``CA_ROTORn_AX/AY/AZ``) and, when every
  rotor has a coaxial partner, the name ``y6``/``octaquad``. A 4-rotor
  layout is ``quad_x``/``quad_plus`` only when its positions match PX4's motor numbering,
  otherwise ``quad_other``; spin directions that differ from the convention give a warning.
- ``vehicle_type`` from ``MAV_TYPE`` (else ``vehicle_status.system_type``/``vehicle_type``);
  any ``vehicle_status.is_vtol`` makes it ``"vtol"``. VTOL, fixed-wing and hexa logs load; the
  diagnosability check rejects them.
- ``armed``: ``vehicle_status.arming_state == 2`` (ARMED in every PX4 version), else
  ``actuator_armed.armed``. ``airborne``: ``vehicle_land_detected.landed == False`` intersected
  with armed; a segment in which the estimator's altitude (``vehicle_local_position.z`` with
  ``z_valid``) never rises ``MIN_CLIMB_FOR_AIRBORNE_M`` above its start is dropped with a warning
  (PX4's land detector reports "not landed" as soon as the pilot raises the throttle on the
  ground). Without a land detector: mean motor command above ``THROTTLE_AIRBORNE_LEVEL`` for at
  least ``THROTTLE_AIRBORNE_MIN_S``, said in ``airborne_source`` and a warning.
- ``vehicle_id``: info ``sys_uuid`` (the board's unique id), else ``ver_hw`` (the board type, not
  one airframe); ``vehicle_id_source`` says which. ``utc_start``: info ``boot_time_utc_us`` plus
  ``t_start``, else the first ``vehicle_gps_position``/``sensor_gps`` sample with ``time_utc_usec``.
- ``warnings``: truncation, corrupt messages, logging dropouts, fallback sources, an assumed frame,
  and changes during the log of the parameters that decide how motors are read (initial values
  are used).

Timestamps (see :mod:`flightlog_fd.flight` for the checks and their thresholds): every decoded
topic instance is checked in FILE order before anything is derived from it; samples whose
``timestamp`` is zero or implausible (a spike out and back, a step backwards) are dropped with a
warning naming the topic. ``t_start`` is the header's start time unless it lies more than
``MAX_SAMPLE_GAP_S`` from the first sample (then the first sample's time, warned); ``t_end`` is the
last clean sample's time, so one corrupted timestamp can neither stretch the flight nor the
airborne time to the year 36 000 (which made the resampler run for minutes). A topic instance
whose format lost its ``timestamp`` field (a damaged definition) is skipped with a warning.

Decoding: :mod:`flightlog_fd.logs.ulog_fast` decodes those topics straight into numpy with
pyulog's values (5-8x faster than pyulog's full parse on a 67 MB log); what it refuses
(corrupt streams pyulog re-synchronises, malformed messages; see that module) is read by
``pyulog`` filtered to the same topics. ``Flight.reader`` names the reader used and, for pyulog,
why the fast one refused.

Errors: a file pyulog cannot parse at all (bad header, unknown incompatible flags, no
definitions, definitions on which pyulog's walk would step backwards and spin for ever: see
:func:`pyulog_definitions_stall`) raises :class:`CorruptLogError`; a file that is not a ULog raises
:class:`NotALogError`. A log cut short loads what was read, with a warning; logging dropouts and
skipped corrupt messages are warnings too. A log without motor topics loads with ``motors=None``.
"""
from __future__ import annotations

import contextlib
import io
import struct
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from .sniff import read_head
from ..util import intersect_intervals  # noqa: F401  (part of this module's API)
from ..errors import CorruptLogError, FlightLogError, NotALogError
from ..flight import (MAX_SAMPLE_GAP_S, Flight, Frame, ImuStream, Rotor, Series, Vibration, describe_dropped,
                      implausible_times)
from .ulog_fast import FastULogUnsupported, read_ulog_bytes
from ..frames import name_rotors, px4_autostart_frame, px4_ca_rotors

#: Topics decoded (everything else in the file is skipped by pyulog's filter).
ULOG_TOPICS = [
    "vehicle_angular_velocity", "sensor_combined", "vehicle_attitude", "actuator_motors",
    "actuator_outputs", "esc_status", "vehicle_local_position", "vehicle_status",
    "vehicle_land_detected", "actuator_armed", "vehicle_gps_position", "sensor_gps",
    # vibration sources (Flight.vibration) and control demands for logs without motor outputs
    "vehicle_imu_status", "sensor_accel", "sensor_gyro", "sensor_gyro_fft", "actuator_controls_0",
]
ULOG_MAGIC = b"ULog\x01\x12\x35"
US_PER_S = 1e6

#: vehicle_status.arming_state ARMED (same value in the old INIT/STANDBY/ARMED enum and the new one).
ARMING_STATE_ARMED = 2
#: PX4 output functions Motor1..Motor12 are 101..112 (``<driver>_FUNCn`` parameters).
OUTPUT_FUNCTION_MOTOR1 = 101
MAX_MOTOR_FUNCTIONS = 12
#: Output range when the log has no min/max parameter (PX4 defaults, µs).
PWM_DEFAULT_MIN = 1000.0
PWM_DEFAULT_MAX = 2000.0
#: An actuator_outputs channel is a plausible motor when its values stay within the output range
#: widened by these fractions of it (the disarmed value 900 µs sits 10-20 % below a 1000-1075 min).
OUTPUT_RANGE_SLACK_BELOW = 0.5
OUTPUT_RANGE_SLACK_ABOVE = 0.1
#: Fraction of samples that must be in that widened range.
OUTPUT_IN_RANGE_FRACTION = 0.95
#: Land-detector "airborne" segments in which the altitude never rises this much are ground runs.
MIN_CLIMB_FOR_AIRBORNE_M = 0.3
#: Throttle fallback (no vehicle_land_detected): mean motor command above this level...
THROTTLE_AIRBORNE_LEVEL = 0.25
#: ...for at least this long counts as airborne.
THROTTLE_AIRBORNE_MIN_S = 1.0
#: PX4 MAV_TYPE values -> Flight.vehicle_type.
MAV_TYPE_NAMES = {
    1: "fixed_wing", 2: "quadrotor", 3: "coaxial", 4: "helicopter", 7: "airship",
    10: "ground_rover", 11: "surface_boat", 12: "submarine", 13: "hexarotor", 14: "octorotor",
    15: "tricopter", 19: "vtol", 20: "vtol", 21: "vtol", 22: "vtol", 23: "vtol", 24: "vtol", 25: "vtol",
}
#: vehicle_status.vehicle_type (PX4 enum) -> Flight.vehicle_type, used only without MAV_TYPE.
STATUS_VEHICLE_TYPE_NAMES = {1: "multirotor", 2: "fixed_wing", 3: "ground_rover", 4: "airship"}
#: SYS_AUTOSTART ranges (thousands) -> frame name (PX4 ROMFS airframe numbering).
AUTOSTART_FRAMES = {
    4: "quad_x", 10: "quad_x", 5: "quad_plus", 6: "hexa", 7: "hexa", 11: "hexa", 8: "octo", 9: "octo",
    12: "octo", 13: "vtol", 2: "fixed_wing", 3: "fixed_wing", 14: "tri", 15: "tri", 16: "helicopter",
}
#: SIH/HIL airframes in the 1xxx range that are quad-X (1001 HIL quad-X, 1100 SIH quad-X).
AUTOSTART_QUAD_X_SIM = (1001, 1100)
#: Frame names each vehicle_type is consistent with (to decide whether SYS_AUTOSTART is trusted).
FRAMES_FOR_VEHICLE_TYPE = {
    "quadrotor": ("quad_x", "quad_plus"), "hexarotor": ("hexa",), "octorotor": ("octo",),
    "fixed_wing": ("fixed_wing",), "vtol": ("vtol",), "tricopter": ("tri",), "helicopter": ("helicopter",),
}
ROTOR_COUNT_NAMES = {3: "tri", 6: "hexa", 8: "octo"}
#: Frame names when every rotor has a coaxial partner (same PX/PY): Y6 and octo-quad (X8).
COAXIAL_ROTOR_COUNT_NAMES = {6: "y6", 8: "octaquad"}
ROTOR_COUNT_FOR_VEHICLE_TYPE = {"quadrotor": 4, "hexarotor": 6, "octorotor": 8, "tricopter": 3}
#: A rotor is "on an axis" when its off-axis coordinate is below this fraction of its arm length.
AXIS_TOLERANCE = 0.2
#: Quad-X quadrant signs (sign x, sign y) per motor and quad-+ axis per motor, PX4 numbering.
QUAD_X_QUADRANTS = ((1, 1), (-1, -1), (1, -1), (-1, 1))
QUAD_PLUS_AXES = ((0, 1), (0, -1), (1, 0), (-1, 0))
#: Spin of motors 1..4 in both quad layouts (+1 CCW seen from above).
QUAD_SPINS = (1, 1, -1, -1)
#: Parameters whose change during a log alters how motor outputs or geometry are read.
CHANGED_PARAM_WATCH = re.compile(r"^(THR_MDL_FAC|CA_ROTOR\w*|PWM_(MAIN_)?(MIN|MAX)\d*|\w+_FUNC\d+|MAV_TYPE|SYS_AUTOSTART)$")
#: Info key under which fdlog's own writer stores the simulator's truth (never used for diagnosis).
TRUTH_INFO_KEY = "fdlog_truth"


@dataclass
class _Topic:
    """One decoded topic instance: times (s, sorted) and its fields, rows in time order."""

    name: str
    instance: int
    t: np.ndarray
    fields: dict[str, np.ndarray]

    def has(self, field_name: str) -> bool:
        return field_name in self.fields

    def get(self, field_name: str) -> np.ndarray:
        return self.fields[field_name]

    def array(self, prefix: str, count: int) -> Optional[np.ndarray]:
        """Columns ``prefix[0] .. prefix[count-1]`` as an (n, count) float64 array, or None."""
        names = [f"{prefix}[{i}]" for i in range(count)]
        if not names or not all(n in self.fields for n in names):  # a damaged format may have none
            return None
        return np.column_stack([self.fields[n].astype(np.float64) for n in names])

    def array_length(self, prefix: str) -> int:
        n = 0
        while f"{prefix}[{n}]" in self.fields:
            n += 1
        return n


ULOG_HEADER_BYTES = 16  # magic (7) + version (1) + timestamp (8); messages follow
_MSG_HEADER = struct.Struct("<HB")  # msg_size (payload bytes), msg_type


def _ends_cut(data: bytes) -> bool:
    """True when the message stream's last message is cut off (the file ends inside it).

    pyulog stops silently at a cut message, so on the pyulog fallback path the stream of message
    headers is walked once (a tight loop over (size, type) headers: ~0.1 s for 230k messages);
    the fast reader reports the same thing from its own walk (``FastULog.truncated``).
    """
    pos, n = ULOG_HEADER_BYTES, len(data)
    unpack = _MSG_HEADER.unpack_from
    while pos + 3 <= n:
        size, _ = unpack(data, pos)
        pos += 3 + size
    return pos != n


#: pyulog (``core.py`` ``_check_packet_corruption``, 1.3.0) calls a message of unknown type corrupt
#: when its type is 0, its size 0 or above this many bytes, and then steps one byte past its start.
PYULOG_CORRUPT_MSG_SIZE = 10000
#: Message types pyulog parses in the definitions section (flag bits, format, info, info multiple,
#: parameter, default parameter); subscription, logging and tagged logging end the section.
_PYULOG_DEFINITION_TYPES = frozenset(b"BFIMPQ")
_PYULOG_SECTION_END_TYPES = frozenset(b"ALC")
_FLAG_BITS_BYTES = 40  # compat (8) + incompat (8) + 3 appended-data offsets (8 each)
_NON_ZERO_BYTE = re.compile(rb"[^\x00]")


def pyulog_definitions_stall(data: bytes) -> Optional[tuple[int, int, int]]:
    """Where pyulog's walk of the definitions section would stop advancing: (byte offset, message
    type, declared size) of the first such message, or None when the walk reaches its end.

    pyulog 1.3.0 (``ULog._read_file_definitions``) reads a corrupt message's payload, then seeks
    back ``2 + size`` bytes to step one byte past the message start. When the declared size runs
    past the end of the file the read comes back short and that seek lands *before* the message:
    on the in-memory file it is given the position is clamped to 0 and the walk re-reads the file
    header as a message, for ever (a ULog header followed by random bytes: over 60 s, until
    killed). This walks the same (size, type) headers with the same rules and no decoding: it
    ends where pyulog ends the section (a subscription/logging message, unknown incompatible flag
    bits it raises on, the end of the file) and otherwise advances exactly as pyulog does; the
    data section after it cannot stall (pyulog stops at a short read there).
    """
    pos, n = ULOG_HEADER_BYTES, len(data)
    unpack = _MSG_HEADER.unpack_from
    while pos + 3 <= n:
        size, kind = unpack(data, pos)
        if kind in _PYULOG_SECTION_END_TYPES:
            return None
        if kind == ord("B") and size >= _FLAG_BITS_BYTES and pos + 3 + _FLAG_BITS_BYTES <= n:
            incompat = data[pos + 3 + 8:pos + 3 + 16]
            if incompat[0] & ~1 or any(incompat[1:]):
                return None  # pyulog raises: unknown incompatible flags
        if kind not in _PYULOG_DEFINITION_TYPES and (kind == 0 or size == 0 or size > PYULOG_CORRUPT_MSG_SIZE):
            if pos + 3 + size > n:
                return pos, kind, size
            if kind == 0 and size == 0:  # zero-filled bytes: pyulog steps to 2 bytes before the next non-zero one
                nonzero = _NON_ZERO_BYTE.search(data, pos)
                pos = max(pos + 1, (nonzero.start() if nonzero else n) - 2)
            else:
                pos += 1
            continue
        pos += 3 + size
    return None


#: ``Flight.reader`` of a log decoded by :mod:`flightlog_fd.logs.ulog_fast`.
READER_FAST = "fast numpy ULog reader"
#: Values of ``read_ulog(reader=...)``: "auto" (fast, pyulog when it refuses), "pyulog" (always).
READERS = ("auto", "pyulog")


def _parse(path: Path, reader: str = "auto"):
    """Decode ``path``; returns (log, truncated, printed warnings, reader description).

    The fast reader goes first; whatever it refuses (see :mod:`~flightlog_fd.logs.ulog_fast`)
    is read by pyulog and the reason goes into the reader description."""
    if reader not in READERS:
        raise ValueError(f"reader must be one of {READERS}, not {reader!r}")
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as e:
        raise NotALogError(path, f"cannot read: {e.strerror or e}") from None
    except MemoryError:
        raise CorruptLogError(path, "ULog too large to read into memory") from None
    why = "asked for"
    if reader == "auto":
        try:
            fast = read_ulog_bytes(data, ULOG_TOPICS, path=path)
            return fast, fast.truncated, "\n".join(fast.printed), READER_FAST
        except FastULogUnsupported as e:
            why = str(e)
        except FlightLogError:
            raise
        except MemoryError:
            raise CorruptLogError(path, "ULog too large or corrupt (out of memory while decoding)") from None
        except Exception as e:  # a bug in the fast path must not cost the user the log: pyulog reads it
            why = f"fast reader failed ({type(e).__name__}: {e})"
    ulog, printed = _parse_pyulog(path, data)
    return ulog, _ends_cut(data), printed, f"pyulog (fallback: {why})" if reader == "auto" else "pyulog"


def _refuse_stalling_definitions(path, data: bytes) -> None:
    """CorruptLogError (one line, exit 2) for a file on which pyulog's definitions walk would
    step backwards (:func:`pyulog_definitions_stall`): every pyulog call goes through here."""
    stall = pyulog_definitions_stall(data)
    if stall is not None:
        at, kind, size = stall
        raise CorruptLogError(path, f"not a readable ULog: corrupt definitions at byte {at} (a message of "
                                    f"unknown type {kind} claims {size} bytes, past the end of the file "
                                    f"at byte {len(data)})")


def _parse_pyulog(path: Path, data: bytes):
    """Run pyulog on the file's bytes; returns (ULog, pyulog's printed messages)."""
    from pyulog import ULog
    from pyulog.exceptions import ULogException

    _refuse_stalling_definitions(path, data)
    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed):
            ulog = ULog(io.BytesIO(data), message_name_filter_list=ULOG_TOPICS, disable_str_exceptions=True)
    except ULogException as e:
        raise CorruptLogError(path, f"not a readable ULog: {e}") from None
    except MemoryError:
        raise CorruptLogError(path, "ULog too large or corrupt (out of memory while decoding)") from None
    except Exception as e:  # pyulog has no error type for malformed definitions: never leak a traceback
        raise CorruptLogError(path, f"corrupt ULog ({type(e).__name__}: {e})") from None
    return ulog, printed.getvalue()


def _clean_times(ulog, warnings: list[str]) -> tuple[Optional[float], Optional[float]]:
    """Drop, in place and in file order, every sample of every decoded topic instance whose
    timestamp is zero or implausible (:func:`~flightlog_fd.flight.implausible_times`); drop
    instances without a ``timestamp`` field. Returns the (first, last) clean time in seconds
    over all instances, None when there is none."""
    kept_items, lo, hi = [], None, None
    for d in ulog.data_list:
        label = d.name + (f" (instance {d.multi_id})" if d.multi_id else "")
        if "timestamp" not in d.data:
            warnings.append(f"{label}: no timestamp field in its definition (damaged format?): topic skipped")
            continue
        ts = np.asarray(d.data["timestamp"]).astype(np.uint64)
        t = ts.astype(np.float64) / US_PER_S
        bad = implausible_times(np.where(ts > 0, t, np.nan))
        nonzero_bad = bad & (ts > 0)
        if nonzero_bad.any():
            warnings.append(describe_dropped(label, t, nonzero_bad))
        if bad.any():
            d.data = {k: np.asarray(v)[~bad] for k, v in d.data.items()}
            t = t[~bad]
        if t.size:
            lo = float(t.min()) if lo is None else min(lo, float(t.min()))
            hi = float(t.max()) if hi is None else max(hi, float(t.max()))
        kept_items.append(d)
    ulog.data_list[:] = kept_items
    return lo, hi


def _topics(ulog, name: str) -> list[_Topic]:
    """All instances of a topic, each sorted by time with zero timestamps dropped."""
    out = []
    for d in ulog.data_list:
        if d.name != name or "timestamp" not in d.data:
            continue
        ts = d.data["timestamp"].astype(np.uint64)
        keep = ts > 0
        if keep.all() and bool(np.all(ts[1:] >= ts[:-1])):  # the usual case: no copy of the fields
            fields = {k: np.asarray(v) for k, v in d.data.items()}
            t = ts.astype(np.float64) / US_PER_S
        else:
            rows = np.flatnonzero(keep)[np.argsort(ts[keep], kind="stable")]
            fields = {k: np.asarray(v)[rows] for k, v in d.data.items()}
            t = ts[rows].astype(np.float64) / US_PER_S
        if len(t):
            out.append(_Topic(name, int(d.multi_id), t, fields))
    out.sort(key=lambda tp: tp.instance)
    return out


def _first(ulog, name: str) -> Optional[_Topic]:
    tops = _topics(ulog, name)
    return tops[0] if tops else None


# ---------------------------------------------------------------- metadata


def _release_string(value) -> Optional[str]:
    """ver_sw_release (0xMMmmppTT) -> "v1.14.0" (with the pre-release tag), None if unusable."""
    try:
        v = int(value)
    except (TypeError, ValueError):
        return None
    major, minor, patch, kind = (v >> 24) & 0xFF, (v >> 16) & 0xFF, (v >> 8) & 0xFF, v & 0xFF
    if v == 0 or (major == 0 and minor == 0 and patch == 0):
        return None
    # last byte: 255 release, >=192 rc, >=128 beta, >=64 alpha, below: a development build
    tag = "" if kind == 255 else ("-rc" if kind >= 192 else ("-beta" if kind >= 128 else ("-alpha" if kind >= 64 else "-dev")))
    return f"v{major}.{minor}.{patch}{tag}"


def _firmware(info: dict) -> str:
    """PX4 version from the info fields: release + git hash, or ``ver_sw`` verbatim when it is text."""
    ver_sw = str(info.get("ver_sw", "") or "").strip()
    release = _release_string(info.get("ver_sw_release"))
    if ver_sw and not re.fullmatch(r"[0-9a-fA-F]{7,40}", ver_sw):
        return ver_sw  # a descriptive string (converted or simulated logs): keep it as written
    parts = ["PX4"]
    if release:
        parts.append(release)
    if ver_sw:
        parts.append(f"(git {ver_sw[:10]})")
    branch = str(info.get("ver_sw_branch", "") or "").strip()
    if branch:
        parts.append(f"[{branch}]")
    return " ".join(parts) if len(parts) > 1 else ""


def _vehicle_id(info: dict) -> tuple[Optional[str], str]:
    """(vehicle id, its source): the board's unique id ``sys_uuid``, else the board type ``ver_hw``."""
    uuid = str(info.get("sys_uuid", "") or "").strip()
    if uuid:
        return uuid, "sys_uuid"
    hw = str(info.get("ver_hw", "") or "").strip()
    return (hw, "ver_hw") if hw else (None, "")


def _utc_start(ulog, info: dict, t_start: float) -> Optional[float]:
    """UTC (POSIX s) at ``t_start``: from the info ``boot_time_utc_us`` (newer PX4), else from the
    first GPS sample with a UTC time (``time_utc_usec``), else None. ``time_ref_utc`` is only the
    local time zone offset, not a time."""
    boot = info.get("boot_time_utc_us")
    if isinstance(boot, (int, np.integer)) and boot > 0:
        return float(boot) / US_PER_S + t_start
    for name in ("vehicle_gps_position", "sensor_gps"):
        for top in _topics(ulog, name):
            if not top.has("time_utc_usec"):
                continue
            utc = top.get("time_utc_usec").astype(np.float64)
            ok = np.flatnonzero(utc > 0)
            if ok.size:
                k = ok[0]
                return float(utc[k] / US_PER_S - (top.t[k] - t_start))
    return None


def _vehicle_type(params: dict, status: Optional[_Topic]) -> tuple[str, str]:
    """(vehicle_type, how it was found)."""
    vtype, source = "unknown", ""
    if "MAV_TYPE" in params:
        vtype = MAV_TYPE_NAMES.get(int(params["MAV_TYPE"]), "unknown")
        source = f"MAV_TYPE {int(params['MAV_TYPE'])}"
    elif status is not None and status.has("system_type"):
        mt = int(status.get("system_type")[-1])
        vtype, source = MAV_TYPE_NAMES.get(mt, "unknown"), f"vehicle_status.system_type {mt}"
    elif status is not None and status.has("vehicle_type"):
        vt = int(status.get("vehicle_type")[-1])
        vtype, source = STATUS_VEHICLE_TYPE_NAMES.get(vt, "unknown"), f"vehicle_status.vehicle_type {vt}"
    elif status is not None and status.has("is_rotary_wing") and bool(status.get("is_rotary_wing").any()):
        vtype, source = "multirotor", "vehicle_status.is_rotary_wing"
    if status is not None and status.has("is_vtol") and bool(np.any(status.get("is_vtol") != 0)):
        vtype, source = "vtol", "vehicle_status.is_vtol"
    return vtype, source


def _classify_quad(rotors: tuple[Rotor, ...], source: str, warnings: list[str]) -> Frame:
    """quad_x / quad_plus when the positions match PX4's numbering, else quad_other."""
    xs = np.array([r.x for r in rotors])
    ys = np.array([r.y for r in rotors])
    arm = np.hypot(xs, ys)
    if np.any(arm <= 0):
        warnings.append("frame: a rotor sits at the centre in CA_ROTORn_PX/PY; layout not recognised")
        return Frame("quad_other", rotors, source)
    on_x_axis = np.abs(ys) < AXIS_TOLERANCE * arm
    on_y_axis = np.abs(xs) < AXIS_TOLERANCE * arm
    diagonal = ~on_x_axis & ~on_y_axis
    spins = tuple(r.spin for r in rotors)
    if diagonal.all():
        quadrants = tuple((int(np.sign(x)), int(np.sign(y))) for x, y in zip(xs, ys))
        name = "quad_x" if quadrants == QUAD_X_QUADRANTS else "quad_other"
        if name == "quad_other":
            warnings.append("frame: X layout but motor numbering differs from PX4 quad-X "
                            "(1 front-right, 2 rear-left, 3 front-left, 4 rear-right)")
    elif (on_x_axis | on_y_axis).all():
        axes = tuple((int(np.sign(x)) if a else 0, int(np.sign(y)) if b else 0)
                     for x, y, a, b in zip(xs, ys, on_x_axis, on_y_axis))
        name = "quad_plus" if axes == QUAD_PLUS_AXES else "quad_other"
        if name == "quad_other":
            warnings.append("frame: + layout but motor numbering differs from PX4 quad-+ "
                            "(1 right, 2 left, 3 front, 4 rear)")
    else:
        name = "quad_other"
        warnings.append("frame: 4 rotors neither in an X nor a + layout")
    if name != "quad_other" and spins != QUAD_SPINS:
        warnings.append(f"frame: rotor spin directions {spins} differ from the PX4 quad convention "
                        f"{QUAD_SPINS} (+1 = CCW seen from above, motors 1..4)")
    return Frame(name, rotors, source)


def _frame_from_ca(params: dict, vehicle_type: str, warnings: list[str]) -> Optional[Frame]:
    """Frame from the control-allocation geometry parameters, None when not usable."""
    if "CA_ROTOR_COUNT" not in params:
        return None
    if int(params.get("SYS_CTRL_ALLOC", 1)) == 0:
        return None  # PX4 1.13 with the legacy mixer: CA_* parameters exist but are not in use
    n = int(params["CA_ROTOR_COUNT"])
    rotors = []
    for i in range(n):
        px, py = params.get(f"CA_ROTOR{i}_PX"), params.get(f"CA_ROTOR{i}_PY")
        if px is None or py is None:
            warnings.append(f"frame: CA_ROTOR_COUNT={n} but CA_ROTOR{i}_PX/PY missing")
            return None
        km = float(params.get(f"CA_ROTOR{i}_KM", 0.0))
        rotors.append(Rotor(float(px), float(py), 1 if km >= 0 else -1))
    rotors_t = tuple(rotors)
    source = f"CA_ROTOR_COUNT={n}, CA_ROTORn_PX/PY/KM"
    if vehicle_type == "vtol":
        return Frame("vtol", rotors_t, source)
    if vehicle_type == "fixed_wing":
        return Frame("fixed_wing", rotors_t, source)
    if n == 4:
        return _classify_quad(rotors_t, source, warnings)
    placed, _ = px4_ca_rotors(params)  # same positions and spins, plus names and thrust axes
    placed = placed or name_rotors(rotors_t)
    coaxial = n > 0 and all(any(abs(a.x - b.x) + abs(a.y - b.y) < 1e-3 for b in placed if b is not a) for a in placed)
    name = COAXIAL_ROTOR_COUNT_NAMES.get(n) if coaxial else None
    return Frame(name or ROTOR_COUNT_NAMES.get(n, f"{n}_rotor"), placed, source, layout="PX4 control allocation")


def _autostart_frame_name(autostart: int) -> Optional[str]:
    if autostart in AUTOSTART_QUAD_X_SIM:
        return "quad_x"
    return AUTOSTART_FRAMES.get(autostart // 1000)


def _frame(params: dict, vehicle_type: str, warnings: list[str]) -> Optional[Frame]:
    frame = _frame_from_ca(params, vehicle_type, warnings)
    if frame is not None:
        return frame
    autostart = int(params["SYS_AUTOSTART"]) if "SYS_AUTOSTART" in params else None
    by_autostart = _autostart_frame_name(autostart) if autostart else None
    consistent = FRAMES_FOR_VEHICLE_TYPE.get(vehicle_type)
    if by_autostart and (consistent is None or by_autostart in consistent):
        src = f"SYS_AUTOSTART {autostart} airframe range"
        if by_autostart == "quad_x":
            return Frame("quad_x", Frame.quad_x().rotors, src)
        if by_autostart == "quad_plus":
            return Frame("quad_plus", Frame.quad_plus().rotors, src)
        legacy = px4_autostart_frame(autostart)  # hexa/octo/coaxial mixer geometries
        if legacy is not None:
            return legacy
        return Frame(by_autostart, (), src, unplaced=f"SYS_AUTOSTART {autostart} is a {by_autostart} airframe, "
                                                     f"not a multirotor motor matrix")
    if vehicle_type == "quadrotor":
        why = (f"SYS_AUTOSTART {autostart} is not a quadrotor airframe" if autostart
               else "no SYS_AUTOSTART or CA_ROTOR parameters")
        warnings.append(f"frame: MAV_TYPE says quadrotor but {why}: PX4 quad-X numbering assumed")
        return Frame("quad_x", Frame.quad_x().rotors, "MAV_TYPE 2 (quad-X assumed)")
    if vehicle_type in ("hexarotor", "octorotor", "fixed_wing", "vtol", "tricopter", "helicopter"):
        name = {"hexarotor": "hexa", "octorotor": "octo", "tricopter": "tri"}.get(vehicle_type, vehicle_type)
        why = (f"MAV_TYPE says {vehicle_type} but neither CA_ROTOR* parameters nor a known SYS_AUTOSTART "
               f"airframe give its motor layout" if name in ("hexa", "octo")
               else f"a {vehicle_type.replace('_', '-')} is not a multirotor motor matrix")
        return Frame(name, (), "MAV_TYPE", unplaced=why)
    return None


# ---------------------------------------------------------------- streams


def _rates(ulog) -> Optional[Series]:
    for tp in _topics(ulog, "vehicle_angular_velocity")[:1]:
        xyz = tp.array("xyz", 3)
        if xyz is not None:
            return Series(tp.t, xyz, "vehicle_angular_velocity.xyz")
    for tp in _topics(ulog, "sensor_combined")[:1]:
        g = tp.array("gyro_rad", 3)
        if g is not None:
            return Series(tp.t, g, "sensor_combined.gyro_rad")
    att = _first(ulog, "vehicle_attitude")
    if att is not None and all(att.has(f) for f in ("rollspeed", "pitchspeed", "yawspeed")):
        v = np.column_stack([att.get(f).astype(np.float64) for f in ("rollspeed", "pitchspeed", "yawspeed")])
        return Series(att.t, v, "vehicle_attitude.rollspeed/pitchspeed/yawspeed")
    return None


def quaternion_to_euler(q: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions w, x, y, z (body to NED, PX4) -> (n, 3) roll, pitch, yaw in rad (ZYX)."""
    w, x, y, z = (q[:, i] for i in range(4))
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.column_stack([roll, pitch, yaw])


def _attitude(ulog) -> Optional[Series]:
    att = _first(ulog, "vehicle_attitude")
    if att is None:
        return None
    q = att.array("q", 4)
    if q is not None:
        norm = np.linalg.norm(q, axis=1)
        good = np.isfinite(norm) & (norm > 0.5)  # an all-zero q is "not initialised yet"
        if good.any():
            return Series(att.t[good], quaternion_to_euler(q[good] / norm[good, None]), "vehicle_attitude.q")
    if all(att.has(f) for f in ("roll", "pitch", "yaw")):
        v = np.column_stack([att.get(f).astype(np.float64) for f in ("roll", "pitch", "yaw")])
        return Series(att.t, v, "vehicle_attitude.roll/pitch/yaw")
    return None


def _actuator_motors(ulog, rotor_count: Optional[int]) -> Optional[Series]:
    best, best_score = None, -1.0
    for tp in _topics(ulog, "actuator_motors"):
        width = tp.array_length("control")
        if width == 0:
            continue
        c = tp.array("control", width)
        used = np.isfinite(c).any(axis=0)
        n = rotor_count if rotor_count else int(np.flatnonzero(used).max() + 1) if used.any() else 0
        if n == 0 or n > width:
            continue
        v = np.nan_to_num(c[:, :n], nan=0.0)  # NaN = motor not driven (disarmed / unused): stopped
        score = float(np.nanstd(v, axis=0).sum())
        if score > best_score:
            best, best_score = Series(tp.t, v, f"actuator_motors.control[0..{n - 1}]"
                                      + (f" (instance {tp.instance})" if tp.instance else "")), score
    return best


def _output_function_channels(params: dict, rotor_count: int) -> tuple[list[int], str]:
    """0-based output channels of motors 1..rotor_count and the driver prefix ("PWM_MAIN"...)."""
    groups: dict[str, dict[int, int]] = {}
    for name, value in params.items():
        m = re.fullmatch(r"(\w+?)_FUNC(\d+)", name)
        if not m:
            continue
        func = int(value)
        if OUTPUT_FUNCTION_MOTOR1 <= func < OUTPUT_FUNCTION_MOTOR1 + MAX_MOTOR_FUNCTIONS:
            groups.setdefault(m.group(1), {})[func - OUTPUT_FUNCTION_MOTOR1] = int(m.group(2)) - 1
    complete = {p: g for p, g in groups.items() if all(k in g for k in range(rotor_count))}
    if complete:
        prefix = "PWM_MAIN" if "PWM_MAIN" in complete else sorted(complete)[0]
        return [complete[prefix][k] for k in range(rotor_count)], prefix
    return list(range(rotor_count)), "PWM_MAIN"


def _output_range(params: dict, prefix: str, channel: int) -> tuple[float, float, str]:
    """(min, max, parameter used) of 0-based ``channel``: per-channel, per-driver, legacy, default."""
    def pick(kind: str, default: float) -> tuple[float, str]:
        for key in (f"{prefix}_{kind}{channel + 1}", f"{prefix}_{kind}", f"PWM_{kind}"):
            if key in params and float(params[key]) >= 0:  # -1 = "unset" in PX4 1.11-1.12
                return float(params[key]), key
        return default, f"default {kind.lower()}"

    (lo, lo_key), (hi, hi_key) = pick("MIN", PWM_DEFAULT_MIN), pick("MAX", PWM_DEFAULT_MAX)
    return lo, hi, f"{lo_key}/{hi_key}"


def _actuator_outputs(ulog, params: dict, rotor_count: Optional[int], warnings: list[str]) -> Optional[Series]:
    instances = _topics(ulog, "actuator_outputs")
    if not instances:
        return None
    width = max(tp.array_length("output") for tp in instances)
    n = rotor_count
    if not n:
        # no geometry anywhere: the leading channels that move in a PWM-like range are motors
        n = 0
        for k in range(width):
            col = instances[0].get(f"output[{k}]") if instances[0].has(f"output[{k}]") else None
            if col is None or np.nanstd(col) == 0 or not (500 < np.nanmedian(col) < 2500):
                break
            n += 1
        if n == 0:
            return None
    channels, prefix = _output_function_channels(params, n)
    ranges = [_output_range(params, prefix, ch) for ch in channels]
    best, best_score = None, -1.0
    for tp in instances:
        out = tp.array("output", tp.array_length("output"))
        if out is None or max(channels) >= out.shape[1]:
            continue
        cols = out[:, channels]
        lo = np.array([r[0] for r in ranges])
        hi = np.array([r[1] for r in ranges])
        span = np.where(hi > lo, hi - lo, 1.0)
        norm = (cols - lo) / span
        in_range = (norm >= -OUTPUT_RANGE_SLACK_BELOW) & (norm <= 1.0 + OUTPUT_RANGE_SLACK_ABOVE)
        if np.mean(in_range) < OUTPUT_IN_RANGE_FRACTION:
            continue
        score = float(np.nanstd(np.clip(norm, 0, 1), axis=0).sum())
        if score > best_score:
            chan_txt = ",".join(str(c) for c in channels)
            src = f"actuator_outputs.output[{chan_txt}]" + (f" (instance {tp.instance})" if tp.instance else "")
            src += f" {ranges[0][0]:.0f}..{ranges[0][1]:.0f} ({ranges[0][2]})"
            best, best_score = Series(tp.t, np.clip(np.nan_to_num(norm, nan=0.0), 0.0, 1.0), src), score
    if best is None:
        warnings.append("actuator_outputs present but no instance has motor channels in the output range")
    return best


def _esc_rpm(ulog, rotor_count: Optional[int]) -> Optional[Series]:
    esc = _first(ulog, "esc_status")
    if esc is None or not rotor_count:
        return None
    slots = []
    for k in range(rotor_count):
        slot = k
        for i in range(esc.array_length("esc") or 8):
            key = f"esc[{i}].actuator_function"
            if esc.has(key) and int(np.max(esc.get(key))) == OUTPUT_FUNCTION_MOTOR1 + k:
                slot = i
                break
        if not esc.has(f"esc[{slot}].esc_rpm"):
            return None
        slots.append(esc.get(f"esc[{slot}].esc_rpm").astype(np.float64))
    rpm = np.column_stack(slots)
    if not np.any(rpm != 0):
        return None  # no ESC telemetry (the topic is published with zeros)
    return Series(esc.t, rpm, "esc_status.esc[].esc_rpm")


#: esc_report.actuator_function values of motors 1..12 (PX4 >= 1.13 OutputFunction Motor1..).
ESC_FUNCTION_MOTORS = range(OUTPUT_FUNCTION_MOTOR1, OUTPUT_FUNCTION_MOTOR1 + MAX_MOTOR_FUNCTIONS)
#: PX4 esc_report fields -> Flight ESC quantities (units as PX4 logs them: rpm, A, V, degC).
ESC_REPORT_FIELDS = {"rpm": "esc_rpm", "current": "esc_current", "voltage": "esc_voltage",
                     "temperature": "esc_temperature"}


def esc_telemetry(ulog, rotor_count: Optional[int], warnings: list[str]):
    """Per-motor ESC telemetry from ``esc_status`` (:class:`~flightlog_fd.flight.EscTelemetry`) or None.

    Motor of slot i: ``esc[i].actuator_function`` - 100 where the firmware logs it (PX4 >= 1.13;
    the most common non-zero value of the slot), else slot i = motor i + 1. A sample is
    ``online`` when bit i of ``esc_online_flags`` is set (ignored when the flags are zero for the
    whole log while the ESC reports a speed: not every driver fills them) and the slot's own
    ``esc[i].timestamp`` moved since the previous message (PX4 re-publishes the last report of a
    silent ESC). The sample time is that slot timestamp where set, else the message's.
    None when the topic is absent or every slot reports zeros (the topic is published without
    telemetry)."""
    from ..flight import EscChannel, EscTelemetry

    esc = _first(ulog, "esc_status")
    if esc is None or not rotor_count:
        return None
    n_slots = 0
    while esc.has(f"esc[{n_slots}].esc_rpm"):
        n_slots += 1
    if n_slots == 0:
        return None
    has_function = esc.has("esc[0].actuator_function")
    flags = esc.get("esc_online_flags").astype(np.int64) if esc.has("esc_online_flags") else None
    out = []
    mapped: set[int] = set()
    for i in range(n_slots):
        key = f"esc[{i}].esc_rpm"
        if not esc.has(key):
            continue
        rpm = esc.get(key).astype(np.float64)
        if has_function:
            func = esc.get(f"esc[{i}].actuator_function").astype(np.int64)
            func = func[func != 0]
            if func.size == 0:
                continue
            vals, counts = np.unique(func, return_counts=True)
            f = int(vals[np.argmax(counts)])
            if f not in ESC_FUNCTION_MOTORS:
                continue
            motor = f - OUTPUT_FUNCTION_MOTOR1 + 1
        else:
            motor = i + 1
        if motor > rotor_count or motor in mapped:
            continue
        values = {q: (esc.get(f"esc[{i}].{fld}").astype(np.float64) if esc.has(f"esc[{i}].{fld}") else None)
                  for q, fld in ESC_REPORT_FIELDS.items()}
        if not np.any(rpm != 0) and not any(v is not None and np.any(v != 0) for v in values.values()):
            continue  # an empty slot
        t = esc.t.copy()
        online = np.ones(t.size, dtype=bool)
        if flags is not None and np.any(flags != 0):
            online &= (flags >> i) & 1 == 1
        ts_key = f"esc[{i}].timestamp"
        if esc.has(ts_key):
            ts = esc.get(ts_key).astype(np.float64)
            set_ = ts > 0
            t = np.where(set_, ts / US_PER_S, t)
            stale = np.zeros(t.size, dtype=bool)
            stale[1:] = set_[1:] & (ts[1:] == ts[:-1])
            online &= ~stale
        order = np.argsort(t, kind="stable")
        mapped.add(motor)
        out.append(EscChannel(motor, t[order], rpm[order],
                              *(None if values[q] is None else values[q][order]
                                for q in ("current", "voltage", "temperature")),
                              online=online[order], esc_index=i,
                              source=f"esc_status.esc[{i}]" + (f" (instance {esc.instance})" if esc.instance else "")))
    if not out:
        return None
    mapping = "esc[].actuator_function" if has_function else "slot i = motor i+1 (esc_report of PX4 < 1.13)"
    return EscTelemetry(out, f"esc_status; motors by {mapping}",
                        {q: f"esc_status.esc[].{fld} ({u})" for (q, fld), u in
                         zip(ESC_REPORT_FIELDS.items(), ("rpm", "A", "V", "degC"))})


def _accel(ulog) -> Optional[Series]:
    for tp in _topics(ulog, "sensor_combined")[:1]:
        a = tp.array("accelerometer_m_s2", 3)
        if a is not None and np.isfinite(a).any():
            return Series(tp.t, a, "sensor_combined.accelerometer_m_s2")
    return None


#: vehicle_imu_status fields, in the order of the metric Series' columns (the last has two names
#: across PX4 versions: delta_angle_coning_metric before 1.13, gyro_coning_vibration since).
IMU_STATUS_FIELDS = ("accel_vibration_metric", "gyro_vibration_metric",
                     ("gyro_coning_vibration", "delta_angle_coning_metric"))


def _vibration(ulog) -> Optional[Vibration]:
    """Every vibration source of a PX4 log: ``vehicle_imu_status`` per IMU (accel / gyro vibration
    metrics, accel clipping counts), raw streams (``sensor_combined``; ``sensor_accel`` /
    ``sensor_gyro`` per instance) and ``sensor_gyro_fft`` peak frequencies."""
    v = Vibration(metric_kind="px4_imu_status")
    for tp in _topics(ulog, "vehicle_imu_status"):
        cols = []
        for f in IMU_STATUS_FIELDS:
            names = (f,) if isinstance(f, str) else f
            name = next((n for n in names if tp.has(n)), None)
            cols.append(tp.get(name).astype(np.float64) if name else np.full(len(tp.t), np.nan))
        if np.isfinite(cols[0]).any():
            v.metrics[tp.instance] = Series(tp.t, np.column_stack(cols),
                                            f"vehicle_imu_status[{tp.instance}].accel/gyro_vibration_metric, coning")
        clip = tp.array("accel_clipping", 3)
        if clip is not None:
            v.clips[tp.instance] = Series(tp.t, clip.sum(axis=1), f"vehicle_imu_status[{tp.instance}].accel_clipping")
    for tp in _topics(ulog, "sensor_combined")[:1]:
        a, g = tp.array("accelerometer_m_s2", 3), tp.array("gyro_rad", 3)
        ta = tp.t
        if a is not None and tp.has("accelerometer_timestamp_relative"):
            rel = tp.get("accelerometer_timestamp_relative").astype(np.float64)
            ok = np.abs(rel) < 1e6  # INT32 max = "no accel sample"
            ta = np.where(ok, tp.t + rel / US_PER_S, tp.t)
            order = np.argsort(ta, kind="stable")
            ta, a = ta[order], a[order]
        s = ImuStream(0, "sensor_combined",
                      Series(ta, a, "sensor_combined.accelerometer_m_s2") if a is not None else None,
                      Series(tp.t, g, "sensor_combined.gyro_rad") if g is not None else None)
        if s.accel is not None or s.gyro is not None:
            v.imus.append(s)
    raw: dict[int, ImuStream] = {}
    for topic, kind in (("sensor_accel", "accel"), ("sensor_gyro", "gyro")):
        for tp in _topics(ulog, topic):
            if not all(tp.has(c) for c in "xyz"):
                continue
            t = tp.get("timestamp_sample").astype(np.float64) / US_PER_S if tp.has("timestamp_sample") else tp.t
            x = np.column_stack([tp.get(c).astype(np.float64) for c in "xyz"])
            order = np.argsort(t, kind="stable")
            s = raw.setdefault(tp.instance, ImuStream(tp.instance, f"sensor_accel/gyro[{tp.instance}]"))
            setattr(s, kind, Series(t[order], x[order], f"{topic}[{tp.instance}].x/y/z"))
    v.imus += [raw[k] for k in sorted(raw)]
    v.imus.sort(key=lambda s: -s.rate_hz)
    for tp in _topics(ulog, "sensor_gyro_fft")[:1]:
        names = sorted(k for k in tp.fields if k.startswith("peak_frequencies"))
        if names:
            x = np.column_stack([tp.get(k).astype(np.float64) for k in names])
            x[~(x > 0)] = np.nan  # 0 / NaN: no peak
            v.fft_peaks = Series(tp.t, x, "sensor_gyro_fft." + ",".join(names))
    return v if v else None


def _controls_mixed(ulog, frame: Optional[Frame], warnings: list[str]) -> Optional[Series]:
    """Per-motor thrust commands from ``actuator_controls_0`` (roll, pitch, yaw, thrust demands) through
    the frame's multirotor mixer, for logs that carry no motor outputs (PX4's system-identification
    logging profile): motor k = thrust + g·(roll·(-y_k) + pitch·x_k + yaw·spin_k) with positions scaled
    to unit arm (PX4's quad-X table: ±0.707 roll/pitch, ±1 yaw) and g <= 1 the largest gain that keeps
    every motor in 0..1. Limits: PX4's own desaturation (a thrust boost before the roll/pitch cut,
    yaw cut first) is approximated; they are requests, not outputs, so stopped.py does not judge them."""
    if frame is None or not frame.rotor_count or frame.unplaced:
        return None
    tp = _first(ulog, "actuator_controls_0")
    if tp is None:
        return None
    c = tp.array("control", 4)
    if c is None or not np.isfinite(c).any():
        return None
    pos = np.array([(r.x, r.y) for r in frame.rotors], dtype=np.float64)
    arm = float(np.max(np.hypot(pos[:, 0], pos[:, 1]))) or 1.0
    spin = np.array([float(np.sign(r.spin)) for r in frame.rotors])
    mix = np.column_stack([-pos[:, 1] / arm, pos[:, 0] / arm, spin])  # (n, 3) roll, pitch, yaw
    c = np.nan_to_num(c, nan=0.0)
    thrust = np.clip(c[:, 3:4], 0.0, 1.0)
    rpy = c[:, :3] @ mix.T
    # airmode off: the roll/pitch/yaw part is scaled down until no motor leaves 0..1
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(rpy < 0, thrust / -rpy, np.where(rpy > 0, (1.0 - thrust) / rpy, np.inf))
    gain = np.clip(np.min(room, axis=1, keepdims=True), 0.0, 1.0)
    u = np.clip(thrust + gain * rpy, 0.0, 1.0)
    warnings.append(f"no motor outputs: per-motor commands mixed from actuator_controls_0 with the "
                    f"{frame.name} mixer (roll/pitch/yaw scaled down where a motor saturates)")
    return Series(tp.t, u, f"actuator_controls_0 via {frame.name} mixer")


def _velocity(ulog) -> Optional[Series]:
    lp = _first(ulog, "vehicle_local_position")
    if lp is None or not all(lp.has(f) for f in ("vx", "vy", "vz")):
        return None
    v = np.column_stack([lp.get(f).astype(np.float64) for f in ("vx", "vy", "vz")])
    return Series(lp.t, v, "vehicle_local_position.vx/vy/vz")


# ---------------------------------------------------------------- intervals


def state_intervals(t: np.ndarray, state: np.ndarray, t_end: float) -> list[tuple[float, float]]:
    """Intervals where a sampled boolean state is True: from the first True sample to the next
    False sample (or ``t_end`` when still True at the end)."""
    out = []
    start = None
    for ti, s in zip(t, state):
        if s and start is None:
            start = float(ti)
        elif not s and start is not None:
            out.append((start, float(ti)))
            start = None
    if start is not None:
        out.append((start, max(float(t_end), start)))
    return [(a, b) for a, b in out if b > a]


def _armed(ulog, t_end: float) -> tuple[Optional[list[tuple[float, float]]], str]:
    status = _first(ulog, "vehicle_status")
    if status is not None and status.has("arming_state"):
        return state_intervals(status.t, status.get("arming_state") == ARMING_STATE_ARMED, t_end), \
            "vehicle_status.arming_state"
    armed = _first(ulog, "actuator_armed")
    if armed is not None and armed.has("armed"):
        return state_intervals(armed.t, armed.get("armed") != 0, t_end), "actuator_armed.armed"
    return None, ""


def _climbed(lp: Optional[_Topic], a: float, b: float) -> Optional[float]:
    """Largest rise (m) of the estimated altitude during [a, b] above its value at a, None if unknown."""
    if lp is None or not lp.has("z"):
        return None
    m = (lp.t >= a) & (lp.t <= b)
    if lp.has("z_valid"):
        m &= lp.get("z_valid") != 0
    z = lp.get("z")[m].astype(np.float64)
    z = z[np.isfinite(z)]
    if z.size < 2:
        return None
    return float(z[0] - z.min())  # NED: up is -z


def _throttle_airborne(motors: Optional[Series]) -> list[tuple[float, float]]:
    if motors is None or len(motors) < 2:
        return []
    level = motors.values.mean(axis=1) > THROTTLE_AIRBORNE_LEVEL
    segs = state_intervals(motors.t, level, float(motors.t[-1]))
    return [(a, b) for a, b in segs if b - a >= THROTTLE_AIRBORNE_MIN_S]


def _airborne(ulog, armed, motors, t_end, warnings) -> tuple[list[tuple[float, float]], str]:
    land = _first(ulog, "vehicle_land_detected")
    if land is not None and land.has("landed"):
        segs = state_intervals(land.t, land.get("landed") == 0, t_end)
        if armed is not None:
            segs = intersect_intervals(segs, armed)
        lp = _first(ulog, "vehicle_local_position")
        kept = []
        for a, b in segs:
            climb = _climbed(lp, a, b)
            if climb is not None and climb < MIN_CLIMB_FOR_AIRBORNE_M:
                warnings.append(f"land detector said airborne for {b - a:.1f} s at t={a:.1f} s but the altitude "
                                f"rose only {climb:.2f} m: treated as on the ground")
                continue
            kept.append((a, b))
        return kept, "vehicle_land_detected.landed"
    segs = _throttle_airborne(motors)
    if armed is not None:
        segs = intersect_intervals(segs, armed)
    warnings.append(f"no vehicle_land_detected: airborne time estimated from throttle (mean motor command "
                    f"> {THROTTLE_AIRBORNE_LEVEL} for > {THROTTLE_AIRBORNE_MIN_S:.0f} s)")
    return segs, "throttle fallback"


# ---------------------------------------------------------------- entry points


def _params(ulog) -> dict[str, float]:
    out = {}
    for k, v in ulog.initial_parameters.items():
        try:
            out[str(k)] = float(v)
        except (TypeError, ValueError):
            continue
    return out


def read_ulog(path, reader: str = "auto") -> Flight:
    """Read a PX4 ULog into a :class:`Flight` (see the module docstring for every field).

    ``reader="auto"`` decodes with the fast numpy reader and falls back to pyulog for what it
    refuses; ``"pyulog"`` always uses pyulog. ``Flight.reader`` says which one was used."""
    p = Path(path)
    head = read_head(p, len(ULOG_MAGIC))
    if not head.startswith(b"ULog"):
        raise NotALogError(path, "not a PX4 ULog (missing 'ULog' magic bytes)")
    if head != ULOG_MAGIC:
        raise CorruptLogError(path, "ULog magic bytes damaged or unknown ULog variant")
    ulog, truncated, printed, reader_used = _parse(p, reader)
    if not ulog.message_formats:
        raise CorruptLogError(path, "not a readable ULog: no message format definitions after the header "
                                    "(file cut right after it, or damaged)")
    if truncated and not ulog.data_list:
        raise CorruptLogError(path, "ULog is truncated before any flight data (cut in its definitions "
                                    "or first data messages)")

    warnings: list[str] = []
    info = ulog.msg_info_dict
    params = _params(ulog)
    data_start, data_end = _clean_times(ulog, warnings)
    t_start = ulog.start_timestamp / US_PER_S
    if data_start is not None and abs(t_start - data_start) > MAX_SAMPLE_GAP_S:
        warnings.append(f"header start time {t_start:.6g} s is implausible (first sample at {data_start:.2f} s): "
                        f"using the first sample's time")
        t_start = data_start
    t_end = max(data_end if data_end is not None else t_start, t_start)
    if truncated:
        warnings.append(f"file is truncated (last message cut): data read up to t={t_end:.2f} s")
    if ulog.file_corruption:
        first = printed.strip().splitlines()[0] if printed.strip() else "corrupt messages skipped"
        warnings.append(f"file corruption detected: {first}")
    if ulog.dropouts:
        total_ms = sum(int(d.duration) for d in ulog.dropouts)
        warnings.append(f"{len(ulog.dropouts)} logging dropouts ({total_ms} ms of data lost in total)")
    if not ulog.data_list:
        warnings.append("the log holds none of the topics fdlog reads")
    changed = sorted({str(name) for _, name, _ in ulog.changed_parameters if CHANGED_PARAM_WATCH.match(str(name))})
    if changed:
        warnings.append(f"parameters changed during the log (initial values used): {', '.join(changed[:6])}"
                        + (" ..." if len(changed) > 6 else ""))

    status = _first(ulog, "vehicle_status")
    vehicle_type, _ = _vehicle_type(params, status)
    frame = _frame(params, vehicle_type, warnings)
    rotor_count = frame.rotor_count if frame is not None and frame.rotor_count else \
        ROTOR_COUNT_FOR_VEHICLE_TYPE.get(vehicle_type)

    motors_thrust = _actuator_motors(ulog, rotor_count)
    motors_signal = _actuator_outputs(ulog, params, rotor_count or (motors_thrust.values.shape[1]
                                      if motors_thrust is not None else None), warnings)
    alt_motors: dict[str, Series] = {}
    if motors_thrust is not None:
        motors, motor_kind = motors_thrust, "thrust"
        if motors_signal is not None:
            alt_motors["actuator_outputs"] = motors_signal
    elif motors_signal is not None:
        motors, motor_kind = motors_signal, "signal"
    else:
        motors, motor_kind = _controls_mixed(ulog, frame, warnings), "thrust"
        if motors is None:
            warnings.append("no motor topic (actuator_motors / actuator_outputs) in the log")
    n_motors = motors.values.shape[1] if motors is not None else rotor_count

    rates = _rates(ulog)
    if rates is not None and rates.source != "vehicle_angular_velocity.xyz":
        warnings.append(f"angular rates from {rates.source} (no vehicle_angular_velocity)")
    armed, armed_source = _armed(ulog, t_end)
    if armed is None:
        warnings.append("no arming state (vehicle_status / actuator_armed): armed intervals unknown")
    airborne, airborne_source = _airborne(ulog, armed, motors, t_end, warnings)
    vehicle_id, vehicle_id_source = _vehicle_id(info)

    return Flight(
        path=str(path),
        autopilot="px4",
        firmware=_firmware(info),
        vehicle_type=vehicle_type,
        vehicle_id=vehicle_id,
        vehicle_id_source=vehicle_id_source,
        utc_start=_utc_start(ulog, info, t_start),
        frame=frame,
        rates=rates,
        attitude=_attitude(ulog),
        motors=motors,
        motor_kind=motor_kind,
        thrust_curve=params.get("THR_MDL_FAC"),
        esc_rpm=_esc_rpm(ulog, n_motors),
        esc=esc_telemetry(ulog, n_motors, warnings),
        velocity=_velocity(ulog),
        accel=_accel(ulog),
        vibration=_vibration(ulog),
        alt_motors=alt_motors,
        armed=armed or [],
        airborne=airborne,
        airborne_source=airborne_source,
        t_start=t_start,
        t_end=t_end,
        params=params,
        warnings=warnings,
        reader=reader_used,
    )


def read_ulog_truth(path) -> Optional[dict]:
    """The simulator's truth stored by :func:`~flightlog_fd.logs.ulog_writer.write_ulog` (info key
    ``fdlog_truth``), or None. For evaluation scripts only: :func:`read_ulog` never sets it."""
    from pyulog import ULog
    from pyulog.exceptions import ULogException

    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise NotALogError(path, f"cannot read: {e.strerror or e}") from None
    _refuse_stalling_definitions(path, data)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            ulog = ULog(io.BytesIO(data), message_name_filter_list=[], parse_header_only=True)
    except (ULogException, OSError, ValueError) as e:
        raise CorruptLogError(path, f"not a readable ULog: {e}") from None
    raw = ulog.msg_info_dict.get(TRUTH_INFO_KEY)
    if not raw:
        return None
    try:
        return json.loads(raw)
    except (TypeError, ValueError):
        return None


__all__ = ["read_ulog", "read_ulog_truth", "quaternion_to_euler", "state_intervals", "intersect_intervals",
           "ULOG_TOPICS", "TRUTH_INFO_KEY"]
