"""ArduPilot DataFlash (``.bin``) reader: the messages the diagnosis needs, as numpy columns.

Input: a binary DataFlash log (ArduCopter 3.3 ... 4.6 tested). Output: a
:class:`~flightlog_fd.flight.Flight`. Times are seconds on the log's own clock
(``TimeUS`` / 1e6, or ``TimeMS`` / 1e3 in logs before ArduCopter 3.4).

**Speed.** pymavlink's ``recv_match`` builds one Python object per message (about 13 s for a
40 MB log; 25 s for the 26 MB, 1.1 M-message synthetic log of ``benchmarks/bench_load.py``,
which this reader loads in about 0.4 s: 40-60x faster on every file measured). We reuse only pymavlink's *index* of the file (``DFReader_binary``: its format
table ``formats`` and the byte ``offsets`` of every message of every type, built by its Cython
scan) and then decode all messages of one type at once with ``np.frombuffer``-style structured
dtypes built from the ``FMT`` format string. Scaling is applied exactly as pymavlink applies
it: only the format characters with a built-in multiplier (``c``/``C`` x0.01, ``e``/``E``
x0.01, ``L`` x1e-7, computed as ``value / (1 / mult)`` like pymavlink) are scaled; FMTU/MULT
multipliers are metadata that pymavlink does not apply either. pymavlink's clock search
(``init_clock``) is skipped: on a log without GPS time it decodes the whole file.

**Streams** (first available wins):

- ``rates`` p, q, r rad/s: the highest-rate of ``GYR`` (raw gyro, instance 0),
  ``IMU`` ``GyrX/Y/Z`` (rad/s, instance 0) and ``RATE`` ``R/P/Y`` (the *achieved* rates, deg/s,
  converted to rad/s; centidegrees/s before ArduCopter 3.4). Ties go to the sensor message.
- ``attitude`` roll, pitch, yaw rad from ``ATT`` (degrees in every version after pymavlink's
  ``c`` scaling).
- ``motors``: ``RCOU`` PWM per motor, normalised with ``MOT_PWM_MIN/MAX`` (or, when those are 0,
  the throttle channel's ``RC3_MIN/MAX``, else 1000/2000) and clipped to 0..1, motor k taken
  from the output whose ``SERVOn_FUNCTION`` is 33+k-1 (82.. for motors 9..12) as logged at the
  start (an output re-assigned in flight is warned about, not followed: its ESC stays wired to
  that motor); n = the frame's rotor count (6 on a hexa, RCOU C1..C14); before 3.5 (no
  ``SERVOn_FUNCTION``) outputs 1..n are motors 1..n; a plane's RCOU is used only through
  those lift-motor functions. ``motor_kind = "signal"``; spin min/max are not removed.
  When ``RATE`` carries the mixer inputs at a higher rate than ``RCOU`` (ArduCopter logs RCOU
  at 10 Hz), the motors are instead **rebuilt through the mixer** and RCOU moves to
  ``alt_motors["RCOU"]`` (see below); ``motor_kind = "thrust"``.
- ``esc_rpm`` from ``ESC`` (``Instance`` = output channel - 1) or ``ESC1..ESC8``, resampled onto
  the first motor's ESC timestamps (kept for the features' speed source); ``esc``: the same
  messages per motor on their own times, never resampled (:func:`esc_telemetry`, every ESC
  message generation); ``velocity`` NED m/s from ``XKF1`` (core 0), ``NKF1`` or
  ``EKF1`` ``VN/VE/VD``; ``accel`` (m/s², FRD) from the primary ``IMU``'s ``AccX/Y/Z``.
- ``armed`` from ``EV`` 10 (armed) / 11 (disarmed), else ``ARM.ArmState``; a log that starts
  armed starts its interval at the first sample, and an arm event while already armed (a
  missing disarm, seen in 3.3 logs whose logging stops at disarm) closes the previous interval
  at the last sample before the logging gap. ``airborne`` from ``EV`` 28 (NOT_LANDED) to 18
  (LAND_COMPLETE) or disarm, *confirmed by the throttle*: ``CTUN`` throttle out above
  ``AIRBORNE_HOVER_FRACTION`` x hover throttle (``MOT_THST_HOVER``, ``THR_MID``/1000, default
  0.5), else mean motor command above ``AIRBORNE_MOTOR_SIGNAL``, for at least
  ``AIRBORNE_MIN_S`` s (dips shorter than ``AIRBORNE_MERGE_GAP_S`` merged), all within armed
  time. The land detector alone is not trusted: the 3.4-rc Erle logs report NOT_LANDED for 20 s
  with the throttle at 1 %, and 3.3 never logs LAND_COMPLETE (there, and without NOT_LANDED
  events, the throttle alone decides: "throttle fallback"). ``airborne_source`` says which.
- ``vehicle_id``: the board's UID line in ``MSG`` (``"CubeOrange 003A002E 31385106 39353735"``),
  else ``BRD_SERIAL_NUM``, else ``SYSID_THISMAV`` (operator-set, 1 by default: weak);
  ``vehicle_id_source`` says which. ``utc_start``: from the first ``GPS`` message with a 3D fix
  (``GWk``/``GMS``, GPS time minus the leap seconds of ``GPS_LEAP_SECONDS``), else None.

**RATE mixer reconstruction.** ``RATE.ROut/POut/YOut`` are the attitude controller's
normalised roll/pitch/yaw demands handed to ``AP_Motors`` (``motors.get_roll()`` etc., plus the
feed-forward terms from 4.x), and ``AOut`` is ``motors.get_throttle()``, the 0..1 collective
thrust demand; all are *before* the mixer. ``AP_MotorsMatrix::output_armed_stabilizing`` then
forms ``thrust_i = throttle + roll*roll_factor_i + pitch*pitch_factor_i + yaw*yaw_factor_i``
with ``roll_factor = cos(angle + 90 deg)``, ``pitch_factor = cos(angle)`` and yaw factor +1
(CCW) / -1 (CW) for each motor's arm angle, normalised so each axis' largest magnitude is 0.5
(``normalise_rpy_factors``, called by ``AP_MotorsQuad::setup_motors`` since the 3.4 mixer
rewrite). Checked on the ArduCopter 3.4 Erle logs: regressing the thrust recovered from RCOU
(through MOT_SPIN_MIN/MAX and MOT_THST_EXPO) on the RATE inputs gives a yaw gain of 0.54 and
collective 1.08-1.12 against the normalised factors (raw factors would need 1.0 for yaw).
Before 3.4 the mixer worked in PWM units, so no reconstruction is attempted there. We apply
that linear mix and clip to 0..1. The approximation: the voltage/air-density
``compensation_gain`` (1 without battery scaling) is taken as 1, and the saturation handling (yaw headroom limiting, ``rpy_scale`` and the
``throttle_thrust_best_rpy`` shift) that only acts when a motor would leave 0..1 is not
reproduced; the result is the thrust setpoint *before* ``MOT_THST_EXPO``, spin min/max and PWM
scaling, i.e. linear in thrust like PX4's ``actuator_motors``.

``thrust_curve`` is ``MOT_THST_EXPO``; when the parameter is missing it is 0.65 (the default
since ArduCopter 3.4 introduced it) for firmware >= 3.4, else ``None`` (3.3 used the
piecewise ``MOT_TCRV_*`` curve), with a warning.

Frame: ``FRAME_CLASS`` (1 quad, 2 hexa, 3 octa, 4 octaquad, 5 Y6, 6 heli, 7 tri, ...) and
``FRAME_TYPE`` (0 plus, 1 X, 2 V, 3 H, ..., 14 CW_X), or the pre-3.5 ``FRAME`` parameter (0 plus, 1 X,
2 V, 3 H) with the class from the ``Frame: QUAD`` startup message. Rotors use ArduPilot's
numbering and arm angles (quad-X 1 front-right CCW, 2 rear-left CCW, 3 front-left CW, 4
rear-right CW; plus 1 right, 2 left, 3 front, 4 back); every other class/type comes from the
firmware's motor tables in :mod:`flightlog_fd.frames` (``Frame.unplaced`` says why when none
applies), and ``Frame.outputs`` holds each motor's output channel.

Timestamps (checks and thresholds in :mod:`flightlog_fd.flight`): each decoded message type is
checked in FILE order (``TimeUS``/``TimeMS``, and ``SampleUS`` where present) before anything is
derived from it; messages with an implausible time (a spike out and back, a step backwards of
more than the spike threshold) are dropped with a warning naming the type. One flipped bit in
a ``TimeUS`` once stretched a flight to the year 36 000 and made the resampler ask for 3.28 PiB.
Allocations are bounded by the file: every table holds at most file size / message length rows.

Limits: one flight per file; a type whose ``FMT`` is redefined mid-file is decoded with its
last definition (warned); a truncated file keeps every complete message before the damage
(warned); unreadable bytes in the middle are skipped by pymavlink's indexer (warned with their
count). Errors are :mod:`flightlog_fd.errors` classes, never a library traceback.
"""
from __future__ import annotations

#: What `fdlog info` names as the reader of a DataFlash log.
READER = "numpy DataFlash reader (pymavlink's index)"

import contextlib
import io
import math
import os
import re
import sys
from dataclasses import dataclass, field
from typing import Iterable, Optional

import numpy as np

from .sniff import read_head
from ..util import intersect_intervals
from ..errors import CorruptLogError, NotALogError
from ..flight import Flight, Frame, ImuStream, Rotor, Series, Vibration, describe_dropped, implausible_times
from ..frames import ardupilot_frame, ardupilot_mixer_factors, ardupilot_motor_channels

# --- file layout ---------------------------------------------------------------------------
HEAD1, HEAD2 = 0xA3, 0x95
FMT_TYPE_ID = 0x80
HEADER_BYTES = 3

#: DataFlash format character -> (numpy dtype, pymavlink multiplier or None).
#: Mirrors pymavlink.DFReader.FORMAT_TO_STRUCT (little-endian, packed).
FORMAT_CHARS: dict[str, tuple[str, Optional[float]]] = {
    "a": ("(32,)<i2", None),
    "b": ("<i1", None),
    "B": ("<u1", None),
    "g": ("<f2", None),
    "h": ("<i2", None),
    "H": ("<u2", None),
    "i": ("<i4", None),
    "I": ("<u4", None),
    "f": ("<f4", None),
    "n": ("S4", None),
    "N": ("S16", None),
    "Z": ("S64", None),
    "c": ("<i2", 0.01),
    "C": ("<u2", 0.01),
    "e": ("<i4", 0.01),
    "E": ("<u4", 0.01),
    "L": ("<i4", 1.0e-7),
    "d": ("<f8", None),
    "M": ("<i1", None),
    "q": ("<i8", None),
    "Q": ("<u8", None),
}
STRING_CHARS = "nNZ"

# --- events (AP_Logger LogEvent) -----------------------------------------------------------
EV_ARMED = 10
EV_DISARMED = 11
EV_LAND_COMPLETE = 18
EV_NOT_LANDED = 28

# --- outputs / parameters ------------------------------------------------------------------
#: SERVOn_FUNCTION values for motors 1..8 (33..40) and 9..12 (82..85).
MOTOR_FUNCTIONS: dict[int, int] = {**{33 + k: k + 1 for k in range(8)}, **{82 + k: k + 9 for k in range(4)}}
DEFAULT_PWM_MIN = 1000.0
DEFAULT_PWM_MAX = 2000.0
#: MOT_THST_EXPO default since ArduCopter 3.4 introduced it.
DEFAULT_THST_EXPO = 0.65
#: Hover throttle assumed when neither MOT_THST_HOVER nor THR_MID is logged.
DEFAULT_HOVER_THROTTLE = 0.5

# --- airborne fallback ---------------------------------------------------------------------
AIRBORNE_HOVER_FRACTION = 0.6  # CTUN throttle out above 60 % of hover throttle = flying
AIRBORNE_MOTOR_SIGNAL = 0.3  # mean normalised motor command above this = flying
AIRBORNE_MIN_S = 1.0  # the condition must hold this long
AIRBORNE_MERGE_GAP_S = 2.0  # shorter throttle dips (fast descents) do not split a flight
#: Motor signal above which a log without arm events is taken as armed.
ARMED_MOTOR_SIGNAL = 0.02
#: A gap in the sample clock longer than this marks logging stopped (disarmed, LOG_DISARMED=0).
LOGGING_GAP_S = 1.0
#: Two streams' rates within this ratio count as equal when choosing the rate source.
RATE_TIE_RATIO = 1.05

# --- firmware-dependent conventions --------------------------------------------------------
#: RATE R/P/Y were logged in centidegrees/s before this version, deg/s from it on.
RATE_DEGREES_SINCE = (3, 4)
#: From this version the mixer is the normalised thrust mix that RATE's outputs feed.
MIXER_SINCE = (3, 4)
#: Firmware assumed when the log names none (modern logging conventions).
MODERN_FIRMWARE = (4, 0, 0)

# ArduPilot frame classes / types (AP_Motors_Class.h).
FRAME_CLASS_VEHICLE = {
    1: "quadrotor", 2: "hexarotor", 3: "octorotor", 4: "octorotor", 5: "hexarotor", 6: "helicopter",
    7: "tricopter", 8: "singlecopter", 9: "coaxial", 10: "bicopter", 11: "helicopter",
    12: "dodecarotor", 13: "helicopter", 14: "decarotor",
}
FRAME_TYPE_PLUS, FRAME_TYPE_X, FRAME_TYPE_V, FRAME_TYPE_H = 0, 1, 2, 3
CCW, CW = 1.0, -1.0
#: (class, type) -> per motor (arm angle deg clockwise from forward, yaw factor), AP_MotorsMatrix.
MOTOR_LAYOUTS: dict[tuple[int, int], tuple[tuple[float, float], ...]] = {
    (1, FRAME_TYPE_PLUS): ((90, CCW), (-90, CCW), (0, CW), (180, CW)),
    (1, FRAME_TYPE_X): ((45, CCW), (-135, CCW), (-45, CW), (135, CW)),
    (1, FRAME_TYPE_V): ((45, 0.7981), (-135, 1.0), (-45, -0.7981), (135, -1.0)),
    (1, FRAME_TYPE_H): ((45, CW), (-135, CW), (-45, CCW), (135, CCW)),
    (2, FRAME_TYPE_PLUS): ((0, CW), (180, CCW), (-120, CW), (60, CCW), (-60, CCW), (120, CW)),
    (2, FRAME_TYPE_X): ((90, CW), (-90, CCW), (-30, CW), (150, CCW), (30, CCW), (-150, CW)),
    (3, FRAME_TYPE_PLUS): ((0, CW), (180, CW), (45, CCW), (135, CCW), (-45, CCW), (-135, CCW), (-90, CW), (90, CW)),
    (3, FRAME_TYPE_X): ((22.5, CW), (-157.5, CW), (67.5, CCW), (157.5, CCW), (-22.5, CCW), (-112.5, CCW),
                        (-67.5, CW), (112.5, CW)),
}
QUAD_FRAME_NAMES = {FRAME_TYPE_PLUS: "quad_plus", FRAME_TYPE_X: "quad_x"}
#: Frame class from the "Frame: QUAD" startup text of firmware built per frame (before 3.5).
FRAME_TEXT_CLASS = {"QUAD": 1, "HEXA": 2, "OCTA": 3, "OCTA_QUAD": 4, "OCTAQUAD": 4, "Y6": 5, "HELI": 6, "TRI": 7}

FIRMWARE_RE = re.compile(
    r"(ArduCopter|APM:Copter|ArduPlane|APM:Plane|ArduRover|APM:Rover|ArduSub|Blimp|AntennaTracker)"
    r"\s+V(\d+)\.(\d+)(?:\.(\d+))?")
#: Startup line "BoardName 0047002B 34385105 36363539": board name and 96-bit unique id.
BOARD_UID_RE = re.compile(r"^(\S+)\s+([0-9A-Fa-f]{8}\s[0-9A-Fa-f]{8}\s[0-9A-Fa-f]{8})\s*$")
FRAME_TEXT_RE = re.compile(r"^Frame:\s*([A-Z0-9_]+)")

#: Messages decoded for a Flight (only these are touched).
NEEDED_TYPES = ("PARM", "MSG", "EV", "ARM", "RATE", "IMU", "GYR", "ATT", "RCOU", "ESC",
                *(f"ESC{k}" for k in range(1, 9)), "CTUN", "XKF1", "NKF1", "EKF1", "GPS",
                "FMTU", "MULT", "ESCX", "EDT2", "VIBE", "IMU2", "IMU3", "ACC", "ISBH", "ISBD")

#: GPS time -> UTC: the GPS epoch (1980-01-06) in POSIX seconds, and the GPS-UTC leap-second
#: offset in force from each POSIX time on (18 s since 2017-01-01).
GPS_EPOCH_POSIX = 315964800
GPS_LEAP_SECONDS = ((1483228800, 18), (1435708800, 17), (1341100800, 16), (1230768000, 15),
                    (1136073600, 14), (0, 13))
#: GPS.Status from which the week/ms fields hold a real time (3 = 3D fix).
GPS_TIME_MIN_STATUS = 3


@dataclass
class MessageTable:
    """All messages of one DataFlash type, decoded.

    ``t``: (n,) seconds on the log clock (from ``TimeUS``/``TimeMS``; for types without a time
    field, the time of the nearest earlier timed message, or ``None`` when none was decoded).
    ``columns``: column name -> (n,) float64 (scaled like pymavlink), (n, 32) int16 for ``a``
    arrays, or an object array of ``str`` for string columns. ``offsets``: byte offset of each
    message in the file.
    """

    name: str
    format: str
    t: Optional[np.ndarray]
    columns: dict[str, np.ndarray]
    offsets: np.ndarray

    def __len__(self) -> int:
        return int(self.offsets.shape[0])

    def has(self, *names: str) -> bool:
        return all(n in self.columns for n in names)

    def rows(self, mask: np.ndarray) -> "MessageTable":
        """The messages where ``mask`` is true."""
        return MessageTable(self.name, self.format, None if self.t is None else self.t[mask],
                            {k: v[mask] for k, v in self.columns.items()}, self.offsets[mask])


@dataclass
class _Index:
    """pymavlink's index of a file plus the raw bytes we decode from."""

    path: str
    data: np.ndarray  # uint8, the whole file
    formats: dict  # type id -> pymavlink DFFormat
    name_to_id: dict[str, int]
    offsets: list[np.ndarray]  # per type id 0..255: byte offsets of its messages (int64)
    redefined: set[str] = field(default_factory=set)


@contextlib.contextmanager
def _silenced_output():
    """Mute pymavlink's indexer: it prints one "bad header" line per damaged byte, from C
    (libc stdout, buffered) and from Python. Redirects file descriptors 1 and 2 meanwhile."""
    libc = _libc()
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            yield
    finally:
        if libc is not None:
            libc.fflush(None)  # drop C-buffered lines into /dev/null, not the restored stdout
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def _libc():
    try:
        import ctypes
        import ctypes.util

        name = ctypes.util.find_library("c")
        return ctypes.CDLL(name) if name else None
    except (OSError, ImportError):
        return None


def _index_file(path: str) -> _Index:
    """Index the file with pymavlink (FMT table + per-type offsets), without its clock search."""
    from pymavlink import DFReader

    class _IndexOnlyReader(DFReader.DFReader_binary):
        def init_clock(self):  # pymavlink would scan (worst case: decode) the whole log here
            self.init_clock_usec()

    reader = None
    try:
        with _silenced_output():
            reader = _IndexOnlyReader(path)
        formats = dict(reader.formats)
        name_to_id = dict(reader.name_to_id)
        offsets = [np.asarray(o, dtype=np.int64) for o in reader.offsets]
    except (MemoryError, KeyboardInterrupt):
        raise
    except Exception as e:  # any failure inside pymavlink = undecodable file
        raise CorruptLogError(path, f"cannot index DataFlash messages ({type(e).__name__}: {e})") from None
    finally:
        if reader is not None:
            with contextlib.suppress(Exception):
                reader.data_map.close()
            with contextlib.suppress(Exception):
                reader.filehandle.close()
    data = np.fromfile(path, dtype=np.uint8)
    idx = _Index(path, data, formats, name_to_id, offsets)
    idx.redefined = _redefined_formats(idx)
    return idx


def _redefined_formats(idx: _Index) -> set[str]:
    """Names of types whose FMT appears more than once with a different format."""
    fmt_offsets = np.asarray(idx.offsets[FMT_TYPE_ID], dtype=np.int64)
    if fmt_offsets.size == 0:
        return set()
    body = _gather(idx.data, fmt_offsets[fmt_offsets + 89 <= idx.data.size] + HEADER_BYTES, 86)
    seen: dict[int, bytes] = {}
    out = set()
    for row in body:
        key, spec = int(row[0]), bytes(row[1:22])  # type id; length + name + format
        if key in seen and seen[key] != spec:
            fmt = idx.formats.get(key)
            out.add(fmt.name if fmt is not None else str(key))
        seen[key] = spec
    return out


def _gather(data: np.ndarray, starts: np.ndarray, width: int) -> np.ndarray:
    """(n, width) uint8 copy of ``data[s:s+width]`` for each start (one strided fancy index)."""
    if starts.size == 0 or width <= 0 or data.size < width:
        return np.zeros((0, max(width, 0)), dtype=np.uint8)
    windows = np.lib.stride_tricks.as_strided(data, shape=(data.size - width + 1, width), strides=(1, 1),
                                              writeable=False)
    return windows[starts]


def _dtype_for(fmt) -> np.dtype:
    """Packed structured dtype for one FMT format string (fields f0, f1...)."""
    fields = []
    for i, ch in enumerate(fmt.format):
        if ch not in FORMAT_CHARS:
            raise ValueError(f"unsupported format character {ch!r}")
        fields.append((f"f{i}", FORMAT_CHARS[ch][0]))
    return np.dtype(fields)


def _decode(idx: _Index, name: str) -> Optional[MessageTable]:
    """Decode every complete message of type ``name`` (None when the log has none)."""
    type_id = idx.name_to_id.get(name)
    if type_id is None:
        return None
    fmt = idx.formats[type_id]
    offs = np.asarray(idx.offsets[type_id], dtype=np.int64)
    offs = offs[offs + fmt.len <= idx.data.size]  # a message cut by truncation is dropped
    if offs.size == 0:
        return None
    if fmt.len <= HEADER_BYTES or offs.size * fmt.len > idx.data.size:
        # the index never overlaps messages, so this only trips on a damaged FMT length: the
        # decoded table must never be larger than the file that holds it
        raise ValueError(f"{name}: {offs.size} messages of {fmt.len} bytes cannot fit in {idx.data.size} bytes")
    dtype = _dtype_for(fmt)
    if dtype.itemsize != fmt.len - HEADER_BYTES:
        raise ValueError(f"{name}: FMT length {fmt.len} does not match format {fmt.format!r}")
    rec = _gather(idx.data, offs + HEADER_BYTES, fmt.len - HEADER_BYTES).view(dtype).reshape(-1)
    columns: dict[str, np.ndarray] = {}
    for i, (col, ch) in enumerate(zip(fmt.columns, fmt.format)):
        raw = rec[f"f{i}"]
        mult = FORMAT_CHARS[ch][1]
        if ch in STRING_CHARS:
            columns[col] = np.array([_cstr(b) for b in raw], dtype=object)
        elif ch == "a":
            columns[col] = np.array(raw, dtype=np.int16)
        elif mult is not None:
            # pymavlink divides by 1/mult ("more accurate than multiplying"): same bits here
            columns[col] = raw.astype(np.float64) / (1.0 / mult)
        else:
            columns[col] = raw.astype(np.float64)
    t = None
    numeric = {col for col, ch in zip(fmt.columns, fmt.format) if ch not in STRING_CHARS and ch != "a"}
    if "TimeUS" in numeric:
        t = columns["TimeUS"] / 1e6
    elif "TimeMS" in numeric:
        t = columns["TimeMS"] / 1e3
    return MessageTable(name, fmt.format, t, columns, offs)


def _cstr(b: bytes) -> str:
    b = b.split(b"\0", 1)[0]
    try:
        return b.decode("utf-8")
    except UnicodeDecodeError:
        return b.decode("ISO-8859-1")


def _check_header(path: str) -> None:
    head = read_head(path, 3)
    if len(head) < 3 or head[0] != HEAD1 or head[1] != HEAD2 or head[2] != FMT_TYPE_ID:
        raise NotALogError(path, "not an ArduPilot DataFlash log (no FMT message header)")


def read_tables(path, names: Iterable[str]) -> dict[str, MessageTable]:
    """Decode the named message types of a DataFlash log (those present), keyed by name.

    Types without a time field get the time of the nearest earlier timed message among the
    requested types.
    """
    path = str(path)
    _check_header(path)
    idx = _index_file(path)
    tables = _decode_all(idx, names, [])
    return tables


def _decode_all(idx: _Index, names: Iterable[str], warnings: list[str]) -> dict[str, MessageTable]:
    tables: dict[str, MessageTable] = {}
    for name in names:
        try:
            tab = _decode(idx, name)
        except ValueError as e:
            warnings.append(f"{name} messages skipped: {e}")
            continue
        if tab is not None:
            tab = _drop_implausible_times(tab, warnings)
        if tab is not None:
            tables[name] = tab
    _assign_missing_times(tables)
    return tables


def _drop_implausible_times(tab: MessageTable, warnings: list[str]) -> Optional[MessageTable]:
    """The table without the messages whose time (file order) is implausible; None when none is left."""
    if tab.t is None:
        return tab
    bad = implausible_times(tab.t)
    if bad.any():
        warnings.append(describe_dropped(f"{tab.name} messages", tab.t, bad))
    if "SampleUS" in tab.columns and tab.columns["SampleUS"].dtype.kind == "f":
        sample_t = tab.columns["SampleUS"] / 1e6
        bad_sample = implausible_times(sample_t) & ~bad
        if bad_sample.any():
            warnings.append(describe_dropped(f"{tab.name}.SampleUS", sample_t, bad_sample))
        bad |= bad_sample
    if not bad.any():
        return tab
    return tab.rows(~bad) if (~bad).any() else None


def _assign_missing_times(tables: dict[str, MessageTable]) -> None:
    """Give timeless messages (old EV/MSG/PARM) the time of the last timed message before them,
    or of the first one after them when a logging gap follows: logging that stopped at disarm
    restarts with the arm event written before the first sample."""
    timed = [t for t in tables.values() if t.t is not None and len(t)]
    if not timed or all(t.t is not None for t in tables.values()):
        return
    offs = np.concatenate([t.offsets for t in timed])
    times = np.concatenate([t.t for t in timed])
    order = np.argsort(offs, kind="stable")
    offs, times = offs[order], times[order]
    for tab in tables.values():
        if tab.t is None:
            nxt = np.searchsorted(offs, tab.offsets, side="right")
            prev_t = times[np.clip(nxt - 1, 0, offs.size - 1)]
            next_t = times[np.clip(nxt, 0, offs.size - 1)]
            use_next = (nxt == 0) | ((nxt < offs.size) & (next_t - prev_t > LOGGING_GAP_S))
            tab.t = np.where(use_next, next_t, prev_t)


# --- helpers shared with the writer --------------------------------------------------------

def parse_firmware(text: str) -> Optional[tuple[int, int, int]]:
    """(major, minor, patch) from "ArduCopter V4.6.2 (...)" / "APM:Copter V3.4-rc2", else None."""
    m = FIRMWARE_RE.search(text or "")
    if not m:
        return None
    return int(m.group(2)), int(m.group(3)), int(m.group(4) or 0)


def mixer_factors(frame_class: int, frame_type: int) -> Optional[np.ndarray]:
    """(n_motors, 3) roll, pitch, yaw factors of AP_MotorsMatrix (ArduCopter >= 3.4), or None
    for frames without a motor table (quad X/+/V/H and hexa/octa X/+ from ``MOTOR_LAYOUTS``,
    every other table from :mod:`flightlog_fd.frames`).

    ``roll = cos(angle + 90 deg)``, ``pitch = cos(angle)``, ``yaw`` = the layout's yaw factor,
    each axis normalised to a largest magnitude of 0.5 (``normalise_rpy_factors``).
    """
    layout = MOTOR_LAYOUTS.get((int(frame_class), int(frame_type)))
    if layout is None:
        return ardupilot_mixer_factors(frame_class, frame_type)  # every other AP_MotorsMatrix table
    ang = np.radians([a for a, _ in layout])
    fac = np.column_stack([np.cos(ang + np.pi / 2), np.cos(ang), [y for _, y in layout]]).astype(np.float64)
    # cos(90 deg) in float is 6e-17, not 0: snap so "no roll authority" stays exactly 0
    fac[np.abs(fac) < 1e-9] = 0.0
    peak = np.abs(fac).max(axis=0)
    return np.where(peak > 0, 0.5 * fac / np.where(peak > 0, peak, 1.0), fac)


def mix(throttle: np.ndarray, roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """Per-motor thrust ``throttle + roll*rf + pitch*pf + yaw*yf`` clipped to 0..1, (n, motors)."""
    # explicit broadcasting: a 3-term sum is cheaper than a BLAS call for n x 3 @ 3 x 4
    out = np.asarray(throttle, dtype=np.float64)[:, None] + np.asarray(roll, dtype=np.float64)[:, None] * factors[:, 0]
    out += np.asarray(pitch, dtype=np.float64)[:, None] * factors[:, 1]
    out += np.asarray(yaw, dtype=np.float64)[:, None] * factors[:, 2]
    return np.clip(out, 0.0, 1.0, out=out)


def pwm_range(params: dict[str, float]) -> tuple[float, float, str]:
    """(pwm_min, pwm_max, source) used to normalise RCOU: MOT_PWM_*, else RC3_*, else 1000/2000."""
    lo, hi = params.get("MOT_PWM_MIN", 0.0), params.get("MOT_PWM_MAX", 0.0)
    if lo > 0 and hi > lo:
        return float(lo), float(hi), "MOT_PWM_MIN/MAX"
    lo, hi = params.get("RC3_MIN", 0.0), params.get("RC3_MAX", 0.0)
    if lo > 0 and hi > lo:
        return float(lo), float(hi), "RC3_MIN/MAX"
    return DEFAULT_PWM_MIN, DEFAULT_PWM_MAX, "default 1000..2000"


def motor_output_channels(params: dict[str, float], n_motors: int) -> tuple[list[int], str]:
    """1-based output channel of motors 1..n: from SERVOn_FUNCTION (33.. = motor 1..), else 1..n
    (:func:`flightlog_fd.frames.ardupilot_motor_channels`)."""
    return ardupilot_motor_channels(params, n_motors)


def thrust_to_signal(thrust: np.ndarray, expo: float) -> np.ndarray:
    """ArduPilot's thrust curve (AP_MotorsMulticopter::apply_thrust_curve_and_volt_scaling
    without voltage scaling): actuator signal 0..1 for a thrust demand 0..1."""
    thrust = np.clip(np.asarray(thrust, dtype=np.float64), 0.0, 1.0)
    if abs(expo) < 1e-6:
        return thrust
    return ((expo - 1.0) + np.sqrt((1.0 - expo) ** 2 + 4.0 * expo * thrust)) / (2.0 * expo)


def signal_to_thrust(signal: np.ndarray, expo: float) -> np.ndarray:
    """Inverse of :func:`thrust_to_signal`: ``thrust = (1 - expo) * s + expo * s**2``."""
    s = np.clip(np.asarray(signal, dtype=np.float64), 0.0, 1.0)
    return (1.0 - expo) * s + expo * s * s


# --- Flight assembly -----------------------------------------------------------------------

def _firmware_text(tables: dict[str, MessageTable]) -> tuple[str, Optional[str], list[str]]:
    """(firmware line, vehicle id, all MSG lines)."""
    lines = list(tables["MSG"].columns.get("Message", [])) if "MSG" in tables else []
    firmware = next((s for s in lines if FIRMWARE_RE.search(s)), "")
    vehicle_id = None
    for s in lines:
        m = BOARD_UID_RE.match(s)
        if m and not FIRMWARE_RE.search(s):
            vehicle_id = f"{m.group(1)} {m.group(2)}"
            break
    return firmware, vehicle_id, lines


def _vehicle_id(board_uid: Optional[str], params: dict[str, float]) -> tuple[Optional[str], str]:
    """(vehicle id, source): the board's UID line in MSG, else BRD_SERIAL_NUM, else SYSID_THISMAV
    (the MAVLink system id: an operator-set number, 1 by default, so the weakest of the three)."""
    if board_uid is not None:
        return board_uid, "board_uid"
    if params.get("BRD_SERIAL_NUM", 0) != 0:
        return f"BRD_SERIAL_NUM {int(params['BRD_SERIAL_NUM'])}", "BRD_SERIAL_NUM"
    if "SYSID_THISMAV" in params:
        return f"SYSID_THISMAV {int(params['SYSID_THISMAV'])}", "SYSID_THISMAV"
    return None, ""


def _utc_start(tables: dict[str, MessageTable], t_start: float) -> Optional[float]:
    """UTC (POSIX s) at ``t_start`` from the first GPS message with a 3D fix and a GPS week."""
    gps = tables.get("GPS")
    if gps is None or not len(gps) or not gps.has("GWk", "GMS"):
        return None
    ok = np.asarray(gps.columns["GWk"], dtype=np.float64) > 0
    if "Status" in gps.columns:
        ok &= np.asarray(gps.columns["Status"], dtype=np.float64) >= GPS_TIME_MIN_STATUS
    idx = np.flatnonzero(ok)
    if not idx.size:
        return None
    k = idx[0]
    gps_posix = GPS_EPOCH_POSIX + float(gps.columns["GWk"][k]) * 604800.0 + float(gps.columns["GMS"][k]) / 1e3
    leap = next(sec for since, sec in GPS_LEAP_SECONDS if gps_posix >= since)
    return gps_posix - leap - (float(gps.t[k]) - t_start)


def _params(tables: dict[str, MessageTable]) -> dict[str, float]:
    if "PARM" not in tables or not tables["PARM"].has("Name", "Value"):  # a damaged FMT renames columns
        return {}
    tab = tables["PARM"]
    # later values win: a parameter changed in flight is logged again
    return {str(n): float(v) for n, v in zip(tab.columns["Name"], tab.columns["Value"])}


def _motor_function_params(tables: dict[str, MessageTable], params: dict[str, float],
                           warnings: list[str]) -> dict[str, float]:
    """``params`` with every SERVOn_FUNCTION at its FIRST logged value: the outputs are wired to
    the motors as configured when the flight started, and a re-assignment during the log (the
    SITL hexa set switches a motor's output to RC pass-through to stop it) is warned about, not
    followed. Other parameters keep their last value."""
    if "PARM" not in tables or not tables["PARM"].has("Name", "Value"):
        return params
    tab = tables["PARM"]
    first: dict[str, tuple[float, float]] = {}
    out = dict(params)
    order = np.argsort(tab.t, kind="stable") if tab.t is not None else np.arange(len(tab))
    for i in order:
        name, value = str(tab.columns["Name"][i]), float(tab.columns["Value"][i])
        if not name.startswith("SERVO") or not name.endswith("_FUNCTION"):
            continue
        t = float(tab.t[i]) if tab.t is not None else float("nan")
        if name not in first:
            first[name] = (value, t)
            out[name] = value
        elif int(value) != int(first[name][0]) and int(first[name][0]) in MOTOR_FUNCTIONS:
            motor = MOTOR_FUNCTIONS[int(first[name][0])]
            warnings.append(f"{name} changed from {int(first[name][0])} (motor {motor}) to {int(value)} at "
                            f"t={t:.2f} s: that output stops following the mixer for motor {motor} from then on "
                            f"(the start-of-flight wiring is used)")
            first[name] = (value, t)
    return out


def _frame(params: dict[str, float], msg_lines: list[str], firmware_line: str) -> tuple[Frame, str, int, int]:
    """(Frame, vehicle_type, frame_class, frame_type); class/type -1 when unknown."""
    fw = firmware_line
    if re.search(r"Plane", fw):
        vtol = params.get("Q_ENABLE", 0) >= 1
        name = "vtol" if vtol else "fixed_wing"
        return Frame(name, (), f"firmware '{fw}'" + (", Q_ENABLE=1" if vtol else "")), name, -1, -1
    if re.search(r"Rover", fw):
        return Frame("rover", (), f"firmware '{fw}'"), "ground_rover", -1, -1
    if re.search(r"Sub", fw):
        return Frame("submarine", (), f"firmware '{fw}'"), "submarine", -1, -1
    if re.search(r"Blimp|AntennaTracker", fw):
        return Frame("other", (), f"firmware '{fw}'"), "unknown", -1, -1
    if "FRAME_CLASS" in params:
        fclass = int(params["FRAME_CLASS"])
        ftype = int(params.get("FRAME_TYPE", FRAME_TYPE_X))
        source = f"FRAME_CLASS={fclass}, FRAME_TYPE={ftype}"
    else:
        fclass = -1
        for s in msg_lines:
            m = FRAME_TEXT_RE.match(s)
            if m:
                fclass = FRAME_TEXT_CLASS.get(m.group(1).split("/")[0], -1)
                break
        ftype = int(params.get("FRAME", FRAME_TYPE_X))
        if fclass == -1 and "FRAME" in params and firmware_line and "Copter" in firmware_line:
            fclass = 1  # per-frame builds before 3.5 without a "Frame:" line: quad is the default build
        source = f"'Frame:' message (class {fclass}), FRAME={ftype}"
    if fclass == 0:
        return (Frame("undefined", (), source + " (FRAME_CLASS 0: not configured)",
                      unplaced="FRAME_CLASS 0: the frame was never configured"), "unknown", fclass, ftype)
    vehicle = FRAME_CLASS_VEHICLE.get(fclass, "unknown")
    layout = MOTOR_LAYOUTS.get((fclass, ftype))
    rotors: tuple[Rotor, ...] = ()
    if layout is not None:
        rotors = tuple(
            Rotor(_snap(math.cos(math.radians(a))), _snap(math.sin(math.radians(a))), 1 if y > 0 else -1)
            for a, y in layout)
    table = ardupilot_frame(fclass, ftype, source)
    if fclass == 1:
        if layout is not None and ftype in QUAD_FRAME_NAMES:
            ref = Frame.quad_x() if ftype == FRAME_TYPE_X else Frame.quad_plus()
            return Frame(ref.name, ref.rotors, source, layout=table.layout), vehicle, fclass, ftype
        if layout is None:  # BF_X, DJI_X, CW_X, V-tail...: the firmware's table (flightlog_fd.frames)
            rotors, unplaced = table.rotors, table.unplaced
        else:
            unplaced = ""
        return (Frame("quad_other", rotors, source + " (not X or +)", layout=table.layout, unplaced=unplaced),
                vehicle, fclass, ftype)
    return table, vehicle, fclass, ftype  # hexa, octo, octaquad, Y6... (flightlog_fd.frames)


def _snap(x: float) -> float:
    return 0.0 if abs(x) < 1e-9 else x


def _instance(tab: MessageTable, field_names=("I", "Instance", "C", "Core")) -> MessageTable:
    """Rows of the lowest instance (primary IMU / EKF core) of a multi-instance message."""
    for f in field_names:
        if f in tab.columns:
            inst = tab.columns[f]
            return tab.rows(inst == inst.min())
    return tab


def _sorted_series(t: np.ndarray, values: np.ndarray, source: str) -> Series:
    order = np.argsort(t, kind="stable")
    return Series(t[order], np.asarray(values, dtype=np.float64)[order], source)


def rate_sources(tables: dict[str, MessageTable], firmware: Optional[tuple[int, int, int]]) -> list[Series]:
    """Every angular-rate stream of the log in rad/s (GYR, IMU, RATE), in preference order."""
    out = []
    if "GYR" in tables and tables["GYR"].has("GyrX", "GyrY", "GyrZ"):
        g = _instance(tables["GYR"])
        t = g.columns["SampleUS"] / 1e6 if "SampleUS" in g.columns else g.t
        out.append(_sorted_series(t, np.column_stack([g.columns[c] for c in ("GyrX", "GyrY", "GyrZ")]),
                                  "GYR.GyrX/Y/Z"))
    if "IMU" in tables and tables["IMU"].has("GyrX", "GyrY", "GyrZ"):
        g = _instance(tables["IMU"])
        out.append(_sorted_series(g.t, np.column_stack([g.columns[c] for c in ("GyrX", "GyrY", "GyrZ")]),
                                  "IMU.GyrX/Y/Z"))
    if "RATE" in tables and tables["RATE"].has("R", "P", "Y"):
        r = tables["RATE"]
        centi = (firmware or MODERN_FIRMWARE) < RATE_DEGREES_SINCE
        scale = math.radians(0.01 if centi else 1.0)
        unit = "cdeg/s" if centi else "deg/s"
        out.append(_sorted_series(r.t, np.column_stack([r.columns[c] for c in ("R", "P", "Y")]) * scale,
                                  f"RATE.R/P/Y ({unit} -> rad/s)"))
    # a writer without gyro data fills RATE.R/P/Y with NaN: not a rate source
    return [s for s in out if len(s) > 0 and np.isfinite(s.values).any()]


def _choose_rates(cands: list[Series]) -> Optional[Series]:
    """Highest sample rate wins; within RATE_TIE_RATIO the earlier (sensor) candidate stays."""
    best = None
    for s in cands:
        if best is None or s.rate_hz > best.rate_hz * RATE_TIE_RATIO:
            best = s
    return best


def _rcou(tables, params, n_motors, warnings, multirotor: bool) -> Optional[Series]:
    if "RCOU" not in tables:
        return None
    tab = tables["RCOU"]
    channels, chan_source = motor_output_channels(params, n_motors)
    if not multirotor and chan_source != "SERVOn_FUNCTION":
        # a plane's outputs 1..4 are control surfaces and throttle, not lift motors
        warnings.append("no SERVOn_FUNCTION lift motors on this vehicle: RCOU not used as motor outputs")
        return None
    cols = []
    for ch in channels:
        name = f"C{ch}" if f"C{ch}" in tab.columns else f"Ch{ch}"
        if name not in tab.columns:
            warnings.append(f"RCOU has no column for output {ch}: motors from RCOU unavailable")
            return None
        cols.append(tab.columns[name])
    lo, hi, pwm_source = pwm_range(params)
    sig = np.clip((np.column_stack(cols) - lo) / (hi - lo), 0.0, 1.0)
    prefix = "C" if "C1" in tab.columns else "Ch"
    src = (f"RCOU.{','.join(prefix + str(c) for c in channels)} PWM {lo:.0f}..{hi:.0f} ({pwm_source}; "
           f"motor order {chan_source})")
    return _sorted_series(tab.t, sig, src)


def _rate_mixer(tables, fclass, ftype, firmware, n_motors) -> Optional[Series]:
    if "RATE" not in tables or not tables["RATE"].has("ROut", "POut", "YOut", "AOut"):
        return None
    if (firmware or MODERN_FIRMWARE) < MIXER_SINCE:
        return None
    fac = mixer_factors(fclass, ftype)
    if fac is None or fac.shape[0] != n_motors:
        return None
    r = tables["RATE"]
    thrust = mix(r.columns["AOut"], r.columns["ROut"], r.columns["POut"], r.columns["YOut"], fac)
    return _sorted_series(r.t, thrust, "RATE mixer (AOut + ROut/POut/YOut x AP_MotorsMatrix factors)")


def _esc_rpm(tables, params, n_motors) -> Optional[Series]:
    channels, _ = motor_output_channels(params, n_motors)
    per_motor: list[Optional[tuple[np.ndarray, np.ndarray]]] = []
    if "ESC" in tables and tables["ESC"].has("RPM"):
        tab = tables["ESC"]
        inst_col = "Instance" if "Instance" in tab.columns else ("I" if "I" in tab.columns else None)
        if inst_col is None:
            return None
        for ch in channels:
            m = tab.columns[inst_col] == ch - 1
            per_motor.append((tab.t[m], tab.columns["RPM"][m]) if m.any() else None)
        source = "ESC.RPM by Instance"
    else:
        for ch in channels:
            tab = tables.get(f"ESC{ch}")
            per_motor.append((tab.t, tab.columns["RPM"]) if tab is not None and tab.has("RPM") else None)
        source = "ESC1..n.RPM"
    if any(p is None or p[0].size == 0 for p in per_motor):
        return None
    t0 = np.sort(per_motor[0][0])
    cols = []
    for t, v in per_motor:
        order = np.argsort(t, kind="stable")
        cols.append(np.interp(t0, t[order], v[order]))
    return Series(t0, np.column_stack(cols), source + " (resampled on motor 1's ESC times)")


# --- ESC telemetry (Flight.esc) --------------------------------------------------------------
#: ArduPilot's FMTU multiplier ids (AP_Logger/LogStructure.h log_Multipliers), used when a log's
#: own MULT messages are missing.
DEFAULT_MULTIPLIERS = {"-": 0.0, "?": 1.0, "2": 1e2, "1": 1e1, "0": 1.0, "A": 1e-1, "B": 1e-2, "C": 1e-3,
                       "D": 1e-4, "E": 1e-5, "F": 1e-6, "G": 1e-7, "I": 1e-9, "!": 3.6, "/": 3600.0}
#: FMTU unit ids each ESC quantity must carry when a log has FMTU (q rpm, A ampere, v volt, O degC).
ESC_UNIT_IDS = {"rpm": "q", "current": "A", "voltage": "v", "temperature": "O"}
#: ESC column names per quantity, in order of preference (ArduPilot 3.3 .. 4.6).
ESC_COLUMNS = {"rpm": ("RPM",), "current": ("Curr",), "voltage": ("Volt",), "temperature": ("Temp",)}
#: ``ESC1..ESC8`` (ArduCopter 3.3-3.6, "Qcccc") log ``rpm / 10`` in an int16 whose format char
#: ``c`` reads x0.01, so the decoded RPM is rpm / 1000 (Log_Write_ESC: ``esc_rpm/10``).
ESCN_RPM_FACTOR = 1000.0


def _fmtu(tables, name_to_id: dict[str, int]) -> dict[str, tuple[str, str]]:
    """Message name -> (unit ids, multiplier ids) from the log's FMTU messages (empty without)."""
    tab = tables.get("FMTU")
    if tab is None or not tab.has("FmtType", "UnitIds", "MultIds"):
        return {}
    by_id = {int(k): (str(u), str(m)) for k, u, m in
             zip(tab.columns["FmtType"], tab.columns["UnitIds"], tab.columns["MultIds"])}
    return {name: by_id[i] for name, i in name_to_id.items() if i in by_id}


def _multipliers(tables) -> dict[str, float]:
    mult = dict(DEFAULT_MULTIPLIERS)
    tab = tables.get("MULT")
    if tab is not None and tab.has("Id", "Mult"):
        for i, m in zip(tab.columns["Id"], tab.columns["Mult"]):
            mult[chr(int(i) & 0xFF)] = float(m)
    return mult


def _esc_column(tab: "MessageTable", quantity: str, units: Optional[tuple[str, str]], mults: dict[str, float],
                notes: dict[str, str]) -> Optional[np.ndarray]:
    """One ESC quantity in its canonical unit, following the log's FMT (and FMTU/MULT when present):
    pymavlink's format-char scaling first; a FMTU multiplier that differs from that built-in scale
    is applied to the raw integer; a FMTU unit other than the expected one drops the column."""
    col = next((c for c in ESC_COLUMNS[quantity] if c in tab.columns), None)
    if col is None:
        return None
    values = tab.columns[col].astype(np.float64)
    i = list(tab.columns).index(col)
    ch = tab.format[i] if i < len(tab.format) else "f"
    builtin = FORMAT_CHARS.get(ch, ("", None))[1]
    note = f"{tab.name}.{col} ({ch}" + (f" x{builtin:g}" if builtin else "") + ")"
    if units is not None and i < len(units[0]):
        unit_id, mult_id = units[0][i], units[1][i]
        if unit_id not in (ESC_UNIT_IDS[quantity], "-", "?"):
            notes[quantity] = f"{note}: FMTU unit {unit_id!r} is not {ESC_UNIT_IDS[quantity]!r}, ignored"
            return None
        mult = mults.get(mult_id)
        if mult and mult_id not in ("-", "?") and builtin is None and mult != 1.0:
            values = values * mult  # a raw integer with a FMTU multiplier pymavlink does not apply
            note += f", FMTU mult {mult:g}"
        else:
            note += ", FMTU unit checked"
    if tab.name != "ESC" and quantity == "rpm":
        values = values * ESCN_RPM_FACTOR
        note += f" x{ESCN_RPM_FACTOR:g} (ESCn logs rpm/10 in a centi field)"
    notes[quantity] = note
    return values


def esc_telemetry(tables, params: dict[str, float], n_motors: int, warnings: list[str],
                  name_to_id: Optional[dict[str, int]] = None):
    """Per-motor ESC telemetry (:class:`~flightlog_fd.flight.EscTelemetry`) or None.

    Sources: ``ESC`` with ``Instance`` (4.0: ``QBeCCcHc``; 4.1-4.2: ``QBeffcfcff``; 4.3+ with
    ``RawRPM``: ``QBffffcfcf``), else ``ESC1..ESC8`` (3.3-3.6, ``Qcccc``). ``Instance`` / ``ESCn - 1``
    is the ESC's output channel - 1, mapped to motors through ``SERVOn_FUNCTION``
    (:func:`motor_output_channels`). Units follow the FMT format characters and, where the log
    has them, its FMTU/MULT messages. Every logged message is a fresh report (ArduPilot logs an
    ESC only when its telemetry updated), so ``online`` is all True and a silent ESC shows as gaps.
    ``ESCX`` / ``EDT2`` carry no speed or current: their presence is named in ``source``."""
    from ..flight import EscChannel, EscTelemetry

    channels, chan_source = motor_output_channels(params, n_motors)
    fmtu = _fmtu(tables, name_to_id or {})
    mults = _multipliers(tables)
    per_index: list[tuple[int, "MessageTable"]] = []
    if "ESC" in tables and tables["ESC"].has("RPM") and tables["ESC"].t is not None:
        tab = tables["ESC"]
        inst_col = "Instance" if "Instance" in tab.columns else ("I" if "I" in tab.columns else None)
        if inst_col is None:
            warnings.append("ESC messages without an Instance field: ESC telemetry not read")
            return None
        inst = tab.columns[inst_col].astype(int)
        per_index = [(int(k), tab.rows(inst == k)) for k in np.unique(inst)]
        generation = "ESC (Instance, RawRPM)" if "RawRPM" in tab.columns else "ESC (Instance)"
    else:
        for k in range(1, 9):
            tab = tables.get(f"ESC{k}")
            if tab is not None and tab.has("RPM") and tab.t is not None and len(tab):
                per_index.append((k - 1, tab))
        generation = "ESC1..ESC8"
    if not per_index:
        return None
    out, notes = [], {}
    by_channel = {ch: k for k, ch in enumerate(channels)}
    unmapped = []
    for index, tab in per_index:
        motor0 = by_channel.get(index + 1)
        if motor0 is None:
            unmapped.append(index)
            continue
        units = fmtu.get(tab.name)
        order = np.argsort(tab.t, kind="stable")
        vals = {q: _esc_column(tab, q, units, mults, notes) for q in ESC_COLUMNS}
        vals = {q: (None if v is None else v[order]) for q, v in vals.items()}
        out.append(EscChannel(motor0 + 1, tab.t[order], vals["rpm"], vals["current"], vals["voltage"],
                              vals["temperature"], esc_index=index,
                              source=f"{tab.name}" + (f"[Instance {index}]" if tab.name == "ESC" else "")))
    if unmapped:
        warnings.append(f"ESC telemetry of output(s) {', '.join(str(i + 1) for i in unmapped)} is not a motor "
                        f"({chan_source}): ignored")
    if not out:
        return None
    extra = [name for name in ("ESCX", "EDT2") if name in tables and len(tables[name])]
    source = generation + f"; motors by {chan_source}" + (f"; also {'/'.join(extra)} (status only)" if extra else "")
    return EscTelemetry(out, source, notes)


def _accel(tables) -> Optional[Series]:
    """Primary IMU's accelerometer (m/s², FRD body specific force) from ``IMU.AccX/Y/Z``."""
    if "IMU" not in tables or not tables["IMU"].has("AccX", "AccY", "AccZ"):
        return None
    imu = _instance(tables["IMU"])
    if imu.t is None or not len(imu):
        return None
    a = np.column_stack([imu.columns[c] for c in ("AccX", "AccY", "AccZ")])
    ok = np.isfinite(a).all(axis=1)
    if not ok.any():
        return None
    return _sorted_series(imu.t[ok], a[ok], "IMU.AccX/Y/Z")


def _instances(tab: MessageTable, field_names=("I", "IMU", "Instance")) -> dict[int, MessageTable]:
    """{instance: rows} of a multi-instance message (one instance 0 when it has no such field)."""
    for f in field_names:
        if f in tab.columns:
            inst = tab.columns[f]
            ok = np.isfinite(inst)
            return {int(i): tab.rows(ok & (inst == i)) for i in np.unique(inst[ok])}
    return {0: tab}


def _xyz(tab: MessageTable, cols: tuple[str, str, str], source: str, t: Optional[np.ndarray] = None) -> Optional[Series]:
    if not tab.has(*cols) or tab.t is None or not len(tab):
        return None
    v = np.column_stack([tab.columns[c] for c in cols])
    t = tab.t if t is None else t
    ok = np.isfinite(v).all(axis=1) & np.isfinite(t)
    return _sorted_series(t[ok], v[ok], source) if ok.sum() >= 2 else None


#: ISBH.type of the batch sampler's sensors (AP_InertialSensor::BatchSampler::IMU_SENSOR_TYPE).
ISB_SENSOR_TYPES = {0: "accel", 1: "gyro"}


def _batch_sampler(tables) -> list[ImuStream]:
    """ArduPilot's batch sampler (ISBH header + ISBD 32-sample chunks): per sensor type and
    instance, the raw samples at the sensor's rate, int16 / ``mul`` (m/s/s, rad/s); sample times
    from ``SampleUS`` + k / ``smp_rate``. Chunks whose header is missing are skipped."""
    if "ISBH" not in tables or "ISBD" not in tables:
        return []
    h, d = tables["ISBH"], tables["ISBD"]
    if not h.has("N", "type", "instance", "mul", "SampleUS", "smp_rate") or not d.has("N", "seqno", "x", "y", "z"):
        return []
    heads = {}
    for i in range(len(h)):
        heads[int(h.columns["N"][i])] = (int(h.columns["type"][i]), int(h.columns["instance"][i]),
                                         float(h.columns["mul"][i]), float(h.columns["SampleUS"][i]) / 1e6,
                                         float(h.columns["smp_rate"][i]))
    parts: dict[tuple[int, int], list] = {}
    xs, ys, zs = (np.asarray(d.columns[c], dtype=np.float64) for c in ("x", "y", "z"))
    for j in range(len(d)):
        head = heads.get(int(d.columns["N"][j]))
        if head is None or head[2] == 0 or head[4] <= 0:
            continue
        typ, inst, mul, t0, rate = head
        n = xs.shape[1]
        k = int(d.columns["seqno"][j]) * n + np.arange(n)
        parts.setdefault((typ, inst), []).append((t0 + k / rate, np.column_stack([xs[j], ys[j], zs[j]]) / mul))
    streams: dict[int, ImuStream] = {}
    for (typ, inst), chunks in sorted(parts.items()):
        kind = ISB_SENSOR_TYPES.get(typ)
        if kind is None:
            continue
        t = np.concatenate([c[0] for c in chunks])
        v = np.concatenate([c[1] for c in chunks])
        s = streams.setdefault(inst, ImuStream(inst, f"ISBH/ISBD[{inst}]", batch=True))
        setattr(s, kind, _sorted_series(t, v, f"ISBD {kind}[{inst}] (int16 / ISBH.mul)"))
    return list(streams.values())


def _vibration(tables) -> Optional[Vibration]:
    """Every vibration source of a DataFlash log: VIBE per IMU (4.x: ``IMU`` field and one
    ``Clip``; 3.3-3.6: one message with ``Clip0..2``), raw IMU streams (IMU / IMU2 / IMU3 per
    instance, ACC + GYR per instance, sample times from ``SampleUS`` where logged) and the batch
    sampler (ISBH/ISBD)."""
    v = Vibration(metric_kind="ardupilot_vibe")
    if "VIBE" in tables and tables["VIBE"].has("VibeX", "VibeY", "VibeZ"):
        for inst, tab in _instances(tables["VIBE"], ("IMU",)).items():
            s = _xyz(tab, ("VibeX", "VibeY", "VibeZ"), f"VIBE[{inst}].VibeX/Y/Z")
            if s is not None:
                v.metrics[inst] = s
            if "Clip" in tab.columns:
                v.clips[inst] = _sorted_series(tab.t, tab.columns["Clip"], f"VIBE[{inst}].Clip")
            for k in range(3):
                if f"Clip{k}" in tab.columns:
                    v.clips[k] = _sorted_series(tab.t, tab.columns[f"Clip{k}"], f"VIBE.Clip{k}")
    imus: dict[tuple[str, int], ImuStream] = {}
    for name, base in (("IMU", 0), ("IMU2", 1), ("IMU3", 2)):
        if name not in tables:
            continue
        for inst, tab in _instances(tables[name], ("I",)).items():
            inst = inst if name == "IMU" else base
            s = ImuStream(inst, f"{name}[{inst}]" if name == "IMU" else name,
                          _xyz(tab, ("AccX", "AccY", "AccZ"), f"{name}[{inst}].AccX/Y/Z"),
                          _xyz(tab, ("GyrX", "GyrY", "GyrZ"), f"{name}[{inst}].GyrX/Y/Z"))
            if s.accel is not None or s.gyro is not None:
                imus[("IMU", inst)] = s
    for name, kind, cols in (("ACC", "accel", ("AccX", "AccY", "AccZ")), ("GYR", "gyro", ("GyrX", "GyrY", "GyrZ"))):
        if name not in tables:
            continue
        for inst, tab in _instances(tables[name], ("I",)).items():
            t = tab.columns["SampleUS"] / 1e6 if "SampleUS" in tab.columns else None
            s = _xyz(tab, cols, f"{name}[{inst}].{cols[0][:3]}X/Y/Z", t)
            if s is not None:
                setattr(imus.setdefault(("ACC/GYR", inst), ImuStream(inst, f"ACC/GYR[{inst}]")), kind, s)
    v.imus = sorted(imus.values(), key=lambda s: -s.rate_hz) + _batch_sampler(tables)
    return v if v else None


def _velocity(tables) -> Optional[Series]:
    for name in ("XKF1", "NKF1", "EKF1"):
        if name in tables and tables[name].has("VN", "VE", "VD"):
            tab = _instance(tables[name], ("C", "Core"))
            return _sorted_series(tab.t, np.column_stack([tab.columns[c] for c in ("VN", "VE", "VD")]),
                                  f"{name}.VN/VE/VD")
    return None


def _events(tables) -> tuple[np.ndarray, np.ndarray]:
    """(times, ids) of EV messages, time-ordered."""
    if "EV" not in tables or "Id" not in tables["EV"].columns or tables["EV"].t is None:
        return np.zeros(0), np.zeros(0, dtype=int)
    ev = tables["EV"]
    order = np.argsort(ev.t, kind="stable")
    return ev.t[order], ev.columns["Id"][order].astype(int)


def _intervals(starts_ends: list[tuple[float, int]], t0: float, t1: float, clock: np.ndarray) -> list[tuple[float, float]]:
    """Pair +1 (start) / -1 (end) marks into intervals; a repeated start closes the previous
    interval at the last clock sample before the start (logging stopped in between)."""
    out = []
    open_at: Optional[float] = None
    first = True
    for t, kind in starts_ends:
        if kind > 0:
            if open_at is not None:
                before = clock[clock < t]
                out.append((open_at, float(before[-1]) if before.size else open_at))
            open_at = t
        else:
            if open_at is not None:
                out.append((open_at, t))
            elif first:
                out.append((t0, t))  # the log started while already in the state
            open_at = None
        first = False
    if open_at is not None:
        out.append((open_at, t1))
    return [(a, b) for a, b in out if b > a]


def _above_for(t: np.ndarray, flag: np.ndarray, min_s: float) -> list[tuple[float, float]]:
    """Intervals where ``flag`` holds continuously for at least ``min_s`` seconds."""
    out = []
    if t.size == 0:
        return out
    edges = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    for s, e in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1):
        if t[e] - t[s] >= min_s:
            out.append((float(t[s]), float(t[e])))
    return out


def _hover_throttle(params: dict[str, float]) -> float:
    """Hover throttle 0..1: MOT_THST_HOVER (3.4+), THR_MID / 1000 (older), else the default."""
    if params.get("MOT_THST_HOVER", 0) > 0:
        return float(params["MOT_THST_HOVER"])
    if params.get("THR_MID", 0) > 0:
        return float(params["THR_MID"]) / 1000.0
    return DEFAULT_HOVER_THROTTLE


def _armed_airborne(tables, params, firmware, motors_signal: Optional[Series], clock: np.ndarray,
                    t0: float, t1: float, warnings: list[str]):
    ev_t, ev_id = _events(tables)
    marks = [(float(t), +1 if i == EV_ARMED else -1) for t, i in zip(ev_t, ev_id) if i in (EV_ARMED, EV_DISARMED)]
    armed: list[tuple[float, float]] = []
    if marks:
        armed = _intervals(marks, t0, t1, clock)
    elif "ARM" in tables and "ArmState" in tables["ARM"].columns:
        arm = tables["ARM"]
        order = np.argsort(arm.t, kind="stable")
        marks = [(float(t), +1 if s >= 1 else -1) for t, s in zip(arm.t[order], arm.columns["ArmState"][order])]
        armed = _intervals(marks, t0, t1, clock)
    elif motors_signal is not None:
        armed = _above_for(motors_signal.t, motors_signal.values.max(axis=1) > ARMED_MOTOR_SIGNAL, 0.0)
        warnings.append("no arm/disarm events: armed time taken from motor outputs above idle")

    throttle = _throttle_flying(tables, params, firmware, motors_signal)
    fly_marks = []
    for t, i in zip(ev_t, ev_id):
        if i == EV_NOT_LANDED:
            fly_marks.append((float(t), +1))
        elif i in (EV_LAND_COMPLETE, EV_DISARMED):
            fly_marks.append((float(t), -1))
    # The land detector's events are unreliable alone: 3.3 logs NOT_LANDED on a throttle blip at
    # idle and never LAND_COMPLETE, and the 3.4-rc Erle logs flag NOT_LANDED with the throttle
    # at 1 % for 20 s. So the events bound the airborne time and the throttle confirms it.
    ev_usable = bool(np.any(ev_id == EV_NOT_LANDED)) and (
        bool(np.any(ev_id == EV_LAND_COMPLETE)) or (firmware or MODERN_FIRMWARE) >= MIXER_SINCE)
    ev_airborne = _intervals(fly_marks, t0, t1, clock) if ev_usable else None
    if throttle is not None:
        intervals, thr_source = throttle
        if ev_airborne is not None:
            intervals = intersect_intervals(intervals, ev_airborne)
            source = f"EV (NOT_LANDED 28 .. LAND_COMPLETE 18 / DISARMED 11) confirmed by {thr_source}"
        else:
            source = f"throttle fallback: {thr_source}"
    elif ev_airborne is not None:
        intervals, source = ev_airborne, "EV (NOT_LANDED 28 .. LAND_COMPLETE 18 / DISARMED 11)"
    else:
        return armed, [], "none (no land-detector events, CTUN or motor outputs)"
    if armed:
        intervals = intersect_intervals(intervals, armed)
    return armed, intervals, source


def _merge_short_gaps(intervals: list[tuple[float, float]], gap_s: float) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in intervals:
        if out and a - out[-1][1] < gap_s:
            out[-1] = (out[-1][0], b)
        else:
            out.append((a, b))
    return out


def _throttle_flying(tables, params, firmware, motors_signal: Optional[Series]):
    """(intervals, description) where the throttle says the vehicle flies, or None."""
    if "CTUN" in tables:
        tab = tables["CTUN"]
        col = "ThO" if "ThO" in tab.columns else ("ThrOut" if "ThrOut" in tab.columns else None)
        if col is not None and len(tab):
            thr = tab.columns[col]
            if (firmware or MODERN_FIRMWARE) < (3, 4) or np.nanmax(thr) > 1.5:
                thr = thr / 1000.0  # 3.3 logs throttle in 0..1000
            hover = _hover_throttle(params)
            order = np.argsort(tab.t, kind="stable")
            flying = _above_for(tab.t[order], thr[order] > AIRBORNE_HOVER_FRACTION * hover, AIRBORNE_MIN_S)
            return (_merge_short_gaps(flying, AIRBORNE_MERGE_GAP_S),
                    f"CTUN.{col} > {AIRBORNE_HOVER_FRACTION:.0%} of hover throttle {hover:.2f} for >= "
                    f"{AIRBORNE_MIN_S:g} s")
    if motors_signal is not None and len(motors_signal):
        flying = _above_for(motors_signal.t, motors_signal.values.mean(axis=1) > AIRBORNE_MOTOR_SIGNAL,
                            AIRBORNE_MIN_S)
        return (_merge_short_gaps(flying, AIRBORNE_MERGE_GAP_S),
                f"mean motor command > {AIRBORNE_MOTOR_SIGNAL} for >= {AIRBORNE_MIN_S:g} s")
    return None


def _damage_warnings(idx: _Index, warnings: list[str]) -> None:
    """Truncation (a message running past the end) and skipped unreadable bytes."""
    size = idx.data.size
    last_end, last_name, covered = 0, "", 0
    for type_id, offs in enumerate(idx.offsets):
        if not offs.size or type_id not in idx.formats:
            continue
        fmt = idx.formats[type_id]
        complete = offs + fmt.len <= size
        covered += int(complete.sum()) * fmt.len
        if (~complete).any():
            last_name = fmt.name
            last_end = max(last_end, int(offs[~complete].max()))
    # pymavlink's indexer does not list a message cut inside its 3 header bytes: look at the tail
    ends = [int(offs[-1]) + idx.formats[i].len for i, offs in enumerate(idx.offsets)
            if offs.size and i in idx.formats]
    end_complete = max((e for e in ends if e <= size), default=0)
    tail = idx.data[end_complete:end_complete + 2].tobytes()
    if not last_name and 0 < size - end_complete and tail in (bytes([HEAD1, HEAD2]), bytes([HEAD1])):
        last_name, last_end = "(unknown)", end_complete
    if last_name:
        warnings.append(f"truncated file: the last {last_name} message at byte {last_end} of {size} is cut off; "
                        f"kept every complete message before it")
    skipped = size - covered - (size - last_end if last_name else 0)
    # fewer than one page of trailing garbage is normal for block-based logs (pymavlink: 528)
    if skipped > 528:
        warnings.append(f"{skipped} bytes of unreadable data skipped (damaged or foreign blocks)")
    if idx.redefined:
        warnings.append(f"FMT redefined mid-file for {', '.join(sorted(idx.redefined))}: decoded with the last definition")


def read_dataflash(path) -> Flight:
    """Read an ArduPilot DataFlash binary log into a :class:`Flight` (see module docstring)."""
    path = str(path)
    _check_header(path)
    idx = _index_file(path)
    if not any(idx.offsets[i].size for i in range(256) if i != FMT_TYPE_ID):
        raise CorruptLogError(path, "no data messages after the format table (empty or damaged log)")
    warnings: list[str] = []
    _damage_warnings(idx, warnings)
    tables = _decode_all(idx, NEEDED_TYPES, warnings)

    firmware_line, vehicle_id, msg_lines = _firmware_text(tables)
    firmware = parse_firmware(firmware_line)
    params = _params(tables)
    vehicle_id, vehicle_id_source = _vehicle_id(vehicle_id, params)
    frame, vehicle_type, fclass, ftype = _frame(params, msg_lines, firmware_line)
    n_motors = frame.rotor_count or 4

    rates = _choose_rates(rate_sources(tables, firmware))
    attitude = None
    if "ATT" in tables and tables["ATT"].has("Roll", "Pitch"):
        att = tables["ATT"]
        cols = ["Roll", "Pitch"] + (["Yaw"] if "Yaw" in att.columns else [])
        attitude = _sorted_series(att.t, np.radians(np.column_stack([att.columns[c] for c in cols])),
                                  f"ATT.{'/'.join(cols)} (deg -> rad)")

    multirotor = frame.rotor_count > 0 or "Copter" in firmware_line
    wiring = _motor_function_params(tables, params, warnings)
    rcou = _rcou(tables, wiring, n_motors, warnings, multirotor)
    mixed = _rate_mixer(tables, fclass, ftype, firmware, n_motors)
    alt_motors: dict[str, Series] = {}
    if mixed is not None and (rcou is None or mixed.rate_hz > rcou.rate_hz * RATE_TIE_RATIO):
        motors, motor_kind = mixed, "thrust"
        if rcou is not None:
            alt_motors["RCOU"] = rcou
    else:
        motors, motor_kind = rcou, "signal"
    if motors is None:
        warnings.append("no motor outputs (RCOU) in this log")
    if frame.rotor_count and rcou is not None:
        frame.outputs = tuple(motor_output_channels(wiring, n_motors)[0])

    if "MOT_THST_EXPO" in params:
        thrust_curve: Optional[float] = params["MOT_THST_EXPO"]
    elif firmware is not None and firmware < (3, 4):
        thrust_curve = None
        warnings.append("no MOT_THST_EXPO (firmware before 3.4 uses the MOT_TCRV_* curve): thrust curve unknown")
    else:
        thrust_curve = DEFAULT_THST_EXPO
        warnings.append(f"MOT_THST_EXPO not logged: assuming the default {DEFAULT_THST_EXPO}")

    # the log's span: only messages with their own time field (timeless ones borrow times)
    all_t = [tab.t for tab in tables.values()
             if len(tab) and ("TimeUS" in tab.columns or "TimeMS" in tab.columns)]
    if not all_t:
        raise CorruptLogError(path, "no timestamped messages among the ones needed (RATE, IMU, ATT, RCOU...)")
    t_start = float(min(t.min() for t in all_t))
    t_end = float(max(t.max() for t in all_t))
    clock = np.sort(np.concatenate(all_t))

    sig_for_state = rcou if rcou is not None else (motors if motor_kind == "signal" else None)
    armed, airborne, airborne_source = _armed_airborne(tables, params, firmware, sig_for_state, clock,
                                                       t_start, t_end, warnings)
    return Flight(
        path=path,
        reader=READER,
        autopilot="ardupilot",
        firmware=firmware_line,
        vehicle_type=vehicle_type,
        vehicle_id=vehicle_id,
        vehicle_id_source=vehicle_id_source,
        utc_start=_utc_start(tables, t_start),
        frame=frame,
        rates=rates,
        attitude=attitude,
        motors=motors,
        motor_kind=motor_kind,
        thrust_curve=thrust_curve,
        esc_rpm=_esc_rpm(tables, wiring, n_motors) if frame.rotor_count else None,
        esc=esc_telemetry(tables, wiring, n_motors, warnings, idx.name_to_id) if frame.rotor_count else None,
        velocity=_velocity(tables),
        accel=_accel(tables),
        vibration=_vibration(tables),
        alt_motors=alt_motors,
        armed=armed,
        airborne=airborne,
        airborne_source=airborne_source,
        t_start=t_start,
        t_end=t_end,
        params=params,
        warnings=warnings,
    )
