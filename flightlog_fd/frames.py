"""Multirotor frame geometry from the log: the autopilots' own motor tables, the output channel
of each motor, and plain-words rotor positions.

What: :func:`ardupilot_frame` turns ``FRAME_CLASS`` / ``FRAME_TYPE`` into a
:class:`~flightlog_fd.flight.Frame` with every rotor's position, spin and thrust axis in the
firmware's motor numbering; :func:`ardupilot_motor_channels` maps motors to outputs through
``SERVOn_FUNCTION``; :func:`px4_ca_frame` reads PX4's control-allocation geometry
(``CA_ROTOR_COUNT``, ``CA_ROTORn_PX/PY/PZ``, ``CA_ROTORn_KM``, ``CA_ROTORn_AX/AY/AZ``) and
:func:`px4_autostart_frame` the older ``SYS_AUTOSTART`` airframes (mixer-file geometries).
A frame that cannot be placed comes back with no rotors and ``Frame.unplaced`` saying why.

Sources (copied by hand, one entry per ``case``; ``tests/test_frames.py`` checks each):

- ArduPilot ``libraries/AP_Motors/AP_MotorsMatrix.cpp`` (ArduPilot/ardupilot, the table form
  used since ArduCopter 4.1: ``setup_quad_matrix``, ``setup_hexa_matrix``, ``setup_octa_matrix``,
  ``setup_octaquad_matrix``, ``setup_dodecahexa_matrix``, ``setup_y6_matrix``,
  ``setup_deca_matrix``) and the enums of ``AP_Motors_Class.h``. ``MotorDef {angle, yaw, order}``
  entries are ``add_motor(i, angle, yaw)``: roll factor ``cos(angle + 90 deg)``, pitch factor
  ``cos(angle)``, so the rotor sits at angle degrees clockwise from the nose: x = cos, y = sin.
  ``MotorDefRaw {roll, pitch, yaw, order}`` entries give the factors directly; a rotor's position
  is then ``x = pitch``, ``y = -roll`` (the same relation). The V-tail / A-tail quads give
  separate roll and pitch angles; their position is taken from the pitch angle (the rear motors
  have no roll factor; -160 deg is rear-left, 160 deg rear-right). Yaw factor > 0 is CCW
  (``AP_MOTORS_MATRIX_YAW_FACTOR_CCW = 1``). ArduPilot does not log arm lengths: positions are
  on a unit circle (or the raw factors' scale) and say where each rotor is, not how far.
- ``SERVOn_FUNCTION`` 33..40 = motors 1..8, 82..85 = motors 9..12 (``SRV_Channel.h``).
- PX4 ``src/lib/mixer/MultirotorMixer/geometries/{quad_x,quad_plus,hex_x,hex_plus,hex_cox,
  octa_x,octa_plus,octa_cox}.toml`` for the pre-control-allocation airframes (PX4-Autopilot),
  with the ``SYS_AUTOSTART`` ranges of ``ROMFS/px4fmu_common/init.d/airframes``.

Limits: tilted rotors are only known where PX4 logs ``CA_ROTORn_AX/AY/AZ``; ArduPilot's tables
are vertical thrust. Scripting matrices (FRAME_CLASS 15-17) are defined in a Lua script that the
log does not hold, so they are unplaced, as are helicopters, tri-, single-, coax- and bicopters
(not motor matrices).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional

from .flight import Frame, Rotor

CCW, CW = 1.0, -1.0
#: A coordinate below this is 0 (cos(90 deg) in float is 6e-17).
SNAP = 1e-9
#: A rotor is on the x (y) axis when its other coordinate is below this fraction of its arm.
AXIS_FRACTION = 0.2
#: Thrust axis of a vertical rotor in the body frame (FRD: up is -z).
VERTICAL = (0.0, 0.0, -1.0)

# ----------------------------------------------------------------------------- ArduPilot enums

#: AP_Motors_Class.h motor_frame_class.
ARDUPILOT_FRAME_CLASSES = {
    0: "undefined", 1: "quad", 2: "hexa", 3: "octa", 4: "octaquad", 5: "y6", 6: "heli", 7: "tri",
    8: "singlecopter", 9: "coax", 10: "bicopter", 11: "heli_dual", 12: "dodecahexa", 13: "heli_quad",
    14: "deca", 15: "scripting_matrix", 16: "6dof_scripting", 17: "dynamic_scripting_matrix",
}
#: AP_Motors_Class.h motor_frame_type.
ARDUPILOT_FRAME_TYPES = {
    0: "PLUS", 1: "X", 2: "V", 3: "H", 4: "VTAIL", 5: "ATAIL", 6: "PLUSREV", 10: "Y6B", 11: "Y6F",
    12: "BF_X", 13: "DJI_X", 14: "CW_X", 15: "I", 16: "NYT_PLUS", 17: "NYT_X", 18: "BF_X_REV", 19: "Y4",
}
#: Frame.name per ArduPilot frame class (quads are named by layout, see ardupilot_frame).
ARDUPILOT_CLASS_FRAME_NAMES = {2: "hexa", 3: "octo", 4: "octaquad", 5: "y6", 12: "dodecahexa", 14: "deca"}
#: Classes that are not a motor matrix, with the words used when refusing them.
ARDUPILOT_NOT_MATRIX = {
    6: "a traditional helicopter", 7: "a tricopter (tilting tail rotor)", 8: "a single-copter",
    9: "a coaxial copter", 10: "a bicopter", 11: "a dual helicopter", 13: "a quad helicopter",
    15: "a scripting matrix (motor layout defined by a Lua script, not in the log)",
    16: "a 6-DoF scripting frame (motor layout defined by a Lua script, not in the log)",
    17: "a dynamic scripting matrix (motor layout defined by a Lua script, not in the log)",
}
#: SERVOn_FUNCTION value -> motor number (SRV_Channel.h k_motor1..8 = 33..40, k_motor9..12 = 82..85).
ARDUPILOT_MOTOR_FUNCTIONS: dict[int, int] = {**{33 + k: k + 1 for k in range(8)}, **{82 + k: k + 9 for k in range(4)}}


@dataclass(frozen=True)
class MotorDef:
    """One AP_MotorsMatrix entry: raw roll/pitch/yaw factors (before normalisation), the test
    order, and the rotor's position (x forward, y right) implied by them."""

    roll: float
    pitch: float
    yaw: float
    order: int
    x: float
    y: float


def _snap(v: float) -> float:
    return 0.0 if abs(v) < SNAP else v


def _A(angle: float, yaw: float, order: int) -> MotorDef:
    """``MotorDef {angle, yaw, order}`` / ``add_motor(i, angle, yaw, order)``."""
    r = math.radians(angle)
    return MotorDef(_snap(math.cos(r + math.pi / 2)), _snap(math.cos(r)), yaw, order,
                    _snap(math.cos(r)), _snap(math.sin(r)))


def _RP(roll_deg: float, pitch_deg: float, yaw: float, order: int) -> MotorDef:
    """``add_motor(i, roll_angle, pitch_angle, yaw, order)`` (V-tail / A-tail quads)."""
    p = math.radians(pitch_deg)
    return MotorDef(_snap(math.cos(math.radians(roll_deg) + math.pi / 2)), _snap(math.cos(p)), yaw, order,
                    _snap(math.cos(p)), _snap(math.sin(p)))


def _R(roll: float, pitch: float, yaw: float, order: int) -> MotorDef:
    """``MotorDefRaw {roll, pitch, yaw, order}``: position x = pitch, y = -roll."""
    return MotorDef(roll, pitch, yaw, order, _snap(pitch), _snap(-roll))


_QUAD = {
    0: (_A(90, CCW, 2), _A(-90, CCW, 4), _A(0, CW, 1), _A(180, CW, 3)),
    1: (_A(45, CCW, 1), _A(-135, CCW, 3), _A(-45, CW, 4), _A(135, CW, 2)),
    2: (_A(45, 0.7981, 1), _A(-135, 1.0, 3), _A(-45, -0.7981, 4), _A(135, -1.0, 2)),
    3: (_A(45, CW, 1), _A(-135, CW, 3), _A(-45, CCW, 4), _A(135, CCW, 2)),
    4: (_RP(60, 60, 0, 1), _RP(0, -160, CW, 3), _RP(-60, -60, 0, 4), _RP(0, 160, CCW, 2)),
    5: (_RP(60, 60, 0, 1), _RP(0, -160, CCW, 3), _RP(-60, -60, 0, 4), _RP(0, 160, CW, 2)),
    6: (_A(90, CW, 2), _A(-90, CW, 4), _A(0, CCW, 1), _A(180, CCW, 3)),
    12: (_A(135, CW, 2), _A(45, CCW, 1), _A(-135, CCW, 3), _A(-45, CW, 4)),
    13: (_A(45, CCW, 1), _A(-45, CW, 4), _A(-135, CCW, 3), _A(135, CW, 2)),
    14: (_A(45, CCW, 1), _A(135, CW, 2), _A(-135, CCW, 3), _A(-45, CW, 4)),
    18: (_A(135, CCW, 2), _A(45, CW, 1), _A(-135, CW, 3), _A(-45, CCW, 4)),
    19: (_R(-1.0, 1.0, CCW, 1), _R(0.0, -1.0, CW, 2), _R(0.0, -1.0, CCW, 3), _R(1.0, 1.0, CW, 4)),
}
_HEXA = {
    0: (_A(0, CW, 1), _A(180, CCW, 4), _A(-120, CW, 5), _A(60, CCW, 2), _A(-60, CCW, 6), _A(120, CW, 3)),
    1: (_A(90, CW, 2), _A(-90, CCW, 5), _A(-30, CW, 6), _A(150, CCW, 3), _A(30, CCW, 1), _A(-150, CW, 4)),
    3: (_R(-1.0, 0.0, CW, 2), _R(1.0, 0.0, CCW, 5), _R(1.0, 1.0, CW, 6), _R(-1.0, -1.0, CCW, 3),
        _R(-1.0, 1.0, CCW, 1), _R(1.0, -1.0, CW, 4)),
    13: (_A(30, CCW, 1), _A(-30, CW, 6), _A(-90, CCW, 5), _A(-150, CW, 4), _A(150, CCW, 3), _A(90, CW, 2)),
    14: (_A(30, CCW, 1), _A(90, CW, 2), _A(150, CCW, 3), _A(-150, CW, 4), _A(-90, CCW, 5), _A(-30, CW, 6)),
}
_OCTA = {
    0: (_A(0, CW, 1), _A(180, CW, 5), _A(45, CCW, 2), _A(135, CCW, 4), _A(-45, CCW, 8), _A(-135, CCW, 6),
        _A(-90, CW, 7), _A(90, CW, 3)),
    1: (_A(22.5, CW, 1), _A(-157.5, CW, 5), _A(67.5, CCW, 2), _A(157.5, CCW, 4), _A(-22.5, CCW, 8),
        _A(-112.5, CCW, 6), _A(-67.5, CW, 7), _A(112.5, CW, 3)),
    2: (_R(0.83, 0.34, CW, 7), _R(-0.67, -0.32, CW, 3), _R(0.67, -0.32, CCW, 6), _R(-0.50, -1.00, CCW, 4),
        _R(1.00, 1.00, CCW, 8), _R(-0.83, 0.34, CCW, 2), _R(-1.00, 1.00, CW, 1), _R(0.50, -1.00, CW, 5)),
    3: (_R(-1.0, 1.0, CW, 1), _R(1.0, -1.0, CW, 5), _R(-1.0, 0.333, CCW, 2), _R(-1.0, -1.0, CCW, 4),
        _R(1.0, 1.0, CCW, 8), _R(1.0, -0.333, CCW, 6), _R(1.0, 0.333, CW, 7), _R(-1.0, -0.333, CW, 3)),
    15: (_R(0.333, -1.0, CW, 5), _R(-0.333, 1.0, CW, 1), _R(1.0, -1.0, CCW, 6), _R(0.333, 1.0, CCW, 8),
         _R(-0.333, -1.0, CCW, 4), _R(-1.0, 1.0, CCW, 2), _R(-1.0, -1.0, CW, 3), _R(1.0, 1.0, CW, 7)),
    13: (_A(22.5, CCW, 1), _A(-22.5, CW, 8), _A(-67.5, CCW, 7), _A(-112.5, CW, 6), _A(-157.5, CCW, 5),
         _A(157.5, CW, 4), _A(112.5, CCW, 3), _A(67.5, CW, 2)),
    14: (_A(22.5, CCW, 1), _A(67.5, CW, 2), _A(112.5, CCW, 3), _A(157.5, CW, 4), _A(-157.5, CCW, 5),
         _A(-112.5, CW, 6), _A(-67.5, CCW, 7), _A(-22.5, CW, 8)),
}
_OCTAQUAD = {
    0: (_A(0, CCW, 1), _A(-90, CW, 7), _A(180, CCW, 5), _A(90, CW, 3), _A(-90, CCW, 8), _A(0, CW, 2),
        _A(90, CCW, 4), _A(180, CW, 6)),
    1: (_A(45, CCW, 1), _A(-45, CW, 7), _A(-135, CCW, 5), _A(135, CW, 3), _A(-45, CCW, 8), _A(45, CW, 2),
        _A(135, CCW, 4), _A(-135, CW, 6)),
    2: (_A(45, 0.7981, 1), _A(-45, -0.7981, 7), _A(-135, 1.0, 5), _A(135, -1.0, 3), _A(-45, 0.7981, 8),
        _A(45, -0.7981, 2), _A(135, 1.0, 4), _A(-135, -1.0, 6)),
    3: (_A(45, CW, 1), _A(-45, CCW, 7), _A(-135, CW, 5), _A(135, CCW, 3), _A(-45, CW, 8), _A(45, CCW, 2),
        _A(135, CW, 4), _A(-135, CCW, 6)),
    14: (_A(45, CCW, 1), _A(45, CW, 2), _A(135, CW, 3), _A(135, CCW, 4), _A(-135, CCW, 5), _A(-135, CW, 6),
         _A(-45, CW, 7), _A(-45, CCW, 8)),
    12: (_A(135, CW, 3), _A(45, CCW, 1), _A(-135, CCW, 5), _A(-45, CW, 7), _A(135, CCW, 4), _A(45, CW, 2),
         _A(-135, CW, 6), _A(-45, CCW, 8)),
    18: (_A(135, CCW, 3), _A(45, CW, 1), _A(-135, CW, 5), _A(-45, CCW, 7), _A(135, CW, 4), _A(45, CCW, 2),
         _A(-135, CCW, 6), _A(-45, CW, 8)),
}
_DODECAHEXA = {
    0: tuple(_A(a, y, i + 1) for i, (a, y) in enumerate(
        [(0, CCW), (0, CW), (60, CW), (60, CCW), (120, CCW), (120, CW), (180, CW), (180, CCW),
         (-120, CCW), (-120, CW), (-60, CW), (-60, CCW)])),
    1: tuple(_A(a, y, i + 1) for i, (a, y) in enumerate(
        [(30, CCW), (30, CW), (90, CW), (90, CCW), (150, CCW), (150, CW), (-150, CW), (-150, CCW),
         (-90, CCW), (-90, CW), (-30, CW), (-30, CCW)])),
}
#: Y6: Y6B (10), Y6F (11); every other FRAME_TYPE gets the "default" table (the firmware's ``default:``).
_Y6 = {
    10: (_R(-1.0, 0.5, CW, 1), _R(-1.0, 0.5, CCW, 2), _R(0.0, -1.0, CW, 3), _R(0.0, -1.0, CCW, 4),
         _R(1.0, 0.5, CW, 5), _R(1.0, 0.5, CCW, 6)),
    11: (_R(0.0, -1.0, CCW, 3), _R(-1.0, 0.5, CCW, 1), _R(1.0, 0.5, CCW, 5), _R(0.0, -1.0, CW, 4),
         _R(-1.0, 0.5, CW, 2), _R(1.0, 0.5, CW, 6)),
    -1: (_R(-1.0, 0.666, CCW, 2), _R(1.0, 0.666, CW, 5), _R(1.0, 0.666, CCW, 6), _R(0.0, -1.333, CW, 4),
         _R(-1.0, 0.666, CW, 1), _R(0.0, -1.333, CCW, 3)),
}
_DECA_X = tuple(_A(a, y, i + 1) for i, (a, y) in enumerate(
    [(18, CCW), (54, CW), (90, CCW), (126, CW), (162, CCW), (-162, CW), (-126, CCW), (-90, CW), (-54, CCW),
     (-18, CW)]))
_DECA = {
    0: tuple(_A(a, y, i + 1) for i, (a, y) in enumerate(
        [(0, CCW), (36, CW), (72, CCW), (108, CW), (144, CCW), (180, CW), (-144, CCW), (-108, CW), (-72, CCW),
         (-36, CW)])),
    1: _DECA_X, 14: _DECA_X,
}
#: (FRAME_CLASS, FRAME_TYPE) -> motor table, motor 1 first (AP_MotorsMatrix.cpp). Y6 is looked up
#: by :func:`ardupilot_layout` (any type falls back to its default table).
ARDUPILOT_LAYOUTS: dict[tuple[int, int], tuple[MotorDef, ...]] = {
    **{(1, t): v for t, v in _QUAD.items()}, **{(2, t): v for t, v in _HEXA.items()},
    **{(3, t): v for t, v in _OCTA.items()}, **{(4, t): v for t, v in _OCTAQUAD.items()},
    **{(5, t): v for t, v in _Y6.items() if t >= 0}, **{(12, t): v for t, v in _DODECAHEXA.items()},
    **{(14, t): v for t, v in _DECA.items()},
}
#: Coaxial octaquad X is PX4's octa_cox layout motor for motor: motors 1-4 on top, 5-8 below.
_COAX_TOP_BOTTOM = {(4, 1): ("top",) * 4 + ("bottom",) * 4}


def ardupilot_layout(frame_class: int, frame_type: int) -> Optional[tuple[MotorDef, ...]]:
    """The firmware's motor table for this class/type, or None when it defines none."""
    if int(frame_class) == 5:
        return _Y6.get(int(frame_type), _Y6[-1])
    return ARDUPILOT_LAYOUTS.get((int(frame_class), int(frame_type)))


def ardupilot_mixer_factors(frame_class: int, frame_type: int):
    """(n, 3) roll, pitch, yaw factors after ``normalise_rpy_factors`` (each axis' largest
    magnitude 0.5), or None without a table."""
    import numpy as np

    layout = ardupilot_layout(frame_class, frame_type)
    if layout is None:
        return None
    fac = np.array([[m.roll, m.pitch, m.yaw] for m in layout], dtype=np.float64)
    peak = np.abs(fac).max(axis=0)
    return np.where(peak > 0, 0.5 * fac / np.where(peak > 0, peak, 1.0), fac)


def _type_name(frame_type: int) -> str:
    return ARDUPILOT_FRAME_TYPES.get(int(frame_type), f"type {int(frame_type)}")


def ardupilot_frame(frame_class: int, frame_type: int, source: str = "") -> Frame:
    """Frame for ArduPilot ``FRAME_CLASS``/``FRAME_TYPE``: rotors in motor order with positions
    and names, or no rotors and ``unplaced`` saying why. Quad X and + keep the names
    ``quad_x``/``quad_plus`` (numbering identical to PX4's); other quad layouts are ``quad_other``."""
    fclass, ftype = int(frame_class), int(frame_type)
    source = source or f"FRAME_CLASS={fclass}, FRAME_TYPE={ftype}"
    cname = ARDUPILOT_FRAME_CLASSES.get(fclass, f"frame class {fclass}")
    if fclass < 0:
        return Frame(f"frame class {fclass}", (), source,
                     unplaced="the log names no frame class (no FRAME_CLASS parameter or 'Frame:' startup message)")
    if fclass == 0:
        return Frame("undefined", (), source, unplaced="FRAME_CLASS 0: the frame was never configured")
    if fclass in ARDUPILOT_NOT_MATRIX:
        return Frame(cname, (), source, unplaced=f"FRAME_CLASS {fclass} is {ARDUPILOT_NOT_MATRIX[fclass]}, "
                                                 f"not a multirotor motor matrix")
    layout = ardupilot_layout(fclass, ftype)
    if fclass == 1:
        name = {0: "quad_plus", 1: "quad_x"}.get(ftype, "quad_other")
    else:
        name = ARDUPILOT_CLASS_FRAME_NAMES.get(fclass, cname)
    if layout is None:
        why = (f"ArduPilot defines no {cname} {_type_name(ftype)} layout (FRAME_TYPE {ftype}); the firmware "
               f"refuses to arm with it" if fclass in (1, 2, 3, 4, 12, 14)
               else f"unknown FRAME_CLASS {fclass}")
        return Frame(name, (), source, unplaced=why)
    if fclass == 1 and ftype in (0, 1):
        ref = Frame.quad_x() if ftype == 1 else Frame.quad_plus()
        return Frame(ref.name, ref.rotors, source, layout=f"ArduPilot {cname.upper()}/{_type_name(ftype)}")
    levels = _COAX_TOP_BOTTOM.get((fclass, ftype))
    rotors = tuple(Rotor(m.x, m.y, 1 if m.yaw > 0 else (-1 if m.yaw < 0 else 0)) for m in layout)
    rotors = name_rotors(rotors, levels)
    return Frame(name, rotors, source, layout=f"ArduPilot {cname.upper()}/{_type_name(ftype)}")


def ardupilot_motor_channels(params: dict[str, float], n_motors: int) -> tuple[list[int], str]:
    """1-based output channel of motors 1..n from ``SERVOn_FUNCTION`` (the first parameter listed
    wins when two outputs drive one motor), else outputs 1..n. ``params`` should be the values the flight started
    with: a script may re-assign an output in flight (see the SITL hexa set)."""
    by_motor: dict[int, int] = {}
    for key, value in params.items():
        # the prefix test first: a DataFlash log holds ~800 parameters, of which ~16 are outputs
        n = _servo_number(key) if key.startswith("SERVO") else 0
        if n and int(value) in ARDUPILOT_MOTOR_FUNCTIONS:
            by_motor.setdefault(ARDUPILOT_MOTOR_FUNCTIONS[int(value)], n)
    if n_motors > 0 and all(k in by_motor for k in range(1, n_motors + 1)):
        return [by_motor[k] for k in range(1, n_motors + 1)], "SERVOn_FUNCTION"
    return list(range(1, n_motors + 1)), "outputs 1..n (no SERVOn_FUNCTION motor mapping)"


_SERVO_RE = re.compile(r"SERVO(\d+)_FUNCTION")


def _servo_number(name: str) -> int:
    m = _SERVO_RE.fullmatch(name)
    return int(m.group(1)) if m else 0


# ----------------------------------------------------------------------------- PX4

def _px4_toml(rows) -> tuple[Rotor, ...]:
    """Rotors from (x, y, z, "CW"/"CCW") rows of a PX4 geometry file (z < 0 = top of a coaxial pair)."""
    rotors = tuple(Rotor(float(x), float(y), 1 if d == "CCW" else -1) for x, y, _, d in rows)
    levels = tuple("top" if z < 0 else "bottom" if z > 0 else "" for _, _, z, _ in rows)
    return name_rotors(rotors, levels if any(levels) else None)


#: PX4 mixer geometries (src/lib/mixer/MultirotorMixer/geometries/*.toml), motor 1 first.
PX4_GEOMETRIES = {
    "hex_x": [(0.0, 1.0, 0, "CW"), (0.0, -1.0, 0, "CCW"), (0.866025, -0.5, 0, "CW"), (-0.866025, 0.5, 0, "CCW"),
              (0.866025, 0.5, 0, "CCW"), (-0.866025, -0.5, 0, "CW")],
    "hex_plus": [(1.0, 0.0, 0, "CW"), (-1.0, 0.0, 0, "CCW"), (-0.5, -0.866025, 0, "CW"), (0.5, 0.866025, 0, "CCW"),
                 (0.5, -0.866025, 0, "CCW"), (-0.5, 0.866025, 0, "CW")],
    "hex_cox": [(0.5, 0.866, -0.1, "CW"), (0.5, 0.866, 0.1, "CCW"), (-1.0, 0.0, -0.1, "CW"), (-1.0, 0.0, 0.1, "CCW"),
                (0.5, -0.866, -0.1, "CW"), (0.5, -0.866, 0.1, "CCW")],
    "octa_x": [(0.9238795, 0.3826834, 0, "CW"), (-0.9238795, -0.3826834, 0, "CW"), (0.3826834, 0.9238795, 0, "CCW"),
               (-0.9238795, 0.3826834, 0, "CCW"), (0.9238795, -0.3826834, 0, "CCW"),
               (-0.3826834, -0.9238795, 0, "CCW"), (0.3826834, -0.9238795, 0, "CW"),
               (-0.3826834, 0.9238795, 0, "CW")],
    "octa_plus": [(1.0, 0.0, 0, "CW"), (-1.0, 0.0, 0, "CW"), (0.707107, 0.707107, 0, "CCW"),
                  (-0.707107, 0.707107, 0, "CCW"), (0.707107, -0.707107, 0, "CCW"),
                  (-0.707107, -0.707107, 0, "CCW"), (0.0, -1.0, 0, "CW"), (0.0, 1.0, 0, "CW")],
    "octa_cox": [(0.707107, 0.707107, -0.1, "CCW"), (0.707107, -0.707107, -0.1, "CW"),
                 (-0.707107, -0.707107, -0.1, "CCW"), (-0.707107, 0.707107, -0.1, "CW"),
                 (0.707107, -0.707107, 0.1, "CCW"), (0.707107, 0.707107, 0.1, "CW"),
                 (-0.707107, 0.707107, 0.1, "CCW"), (-0.707107, -0.707107, 0.1, "CW")],
}
#: SYS_AUTOSTART // 1000 -> (Frame.name, geometry) for the n-rotor PX4 airframe ranges
#: (6xxx hexa X, 7xxx hexa +, 8xxx octo X, 9xxx octo +, 11xxx hexa coaxial, 12xxx octo coaxial).
PX4_AUTOSTART_GEOMETRY = {6: ("hexa", "hex_x"), 7: ("hexa", "hex_plus"), 8: ("octo", "octa_x"),
                          9: ("octo", "octa_plus"), 11: ("y6", "hex_cox"), 12: ("octaquad", "octa_cox")}


def px4_autostart_frame(autostart: int) -> Optional[Frame]:
    """Frame of a pre-control-allocation PX4 n-rotor airframe (SYS_AUTOSTART range), else None."""
    hit = PX4_AUTOSTART_GEOMETRY.get(int(autostart) // 1000)
    if hit is None:
        return None
    name, geom = hit
    return Frame(name, _px4_toml(PX4_GEOMETRIES[geom]), f"SYS_AUTOSTART {int(autostart)} airframe range",
                 layout=f"PX4 mixer geometry {geom}")


def px4_ca_rotors(params: dict[str, float]) -> tuple[Optional[tuple[Rotor, ...]], str]:
    """Rotors from ``CA_ROTOR_COUNT`` and ``CA_ROTORn_PX/PY/PZ/KM/AX/AY/AZ`` (n 0-based = motor
    n+1; KM > 0 = CCW; axis default (0, 0, -1)), or (None, why)."""
    if "CA_ROTOR_COUNT" not in params:
        return None, "no CA_ROTOR_COUNT"
    n = int(params["CA_ROTOR_COUNT"])
    if n <= 0:
        return None, f"CA_ROTOR_COUNT={n}"
    rotors = []
    for i in range(n):
        px, py = params.get(f"CA_ROTOR{i}_PX"), params.get(f"CA_ROTOR{i}_PY")
        if px is None or py is None:
            return None, f"CA_ROTOR_COUNT={n} but CA_ROTOR{i}_PX/PY missing"
        km = float(params.get(f"CA_ROTOR{i}_KM", 0.0))
        axis = tuple(float(params.get(f"CA_ROTOR{i}_A{c}", d)) for c, d in zip("XYZ", VERTICAL))
        norm = math.sqrt(sum(a * a for a in axis))
        axis = tuple(a / norm for a in axis) if norm > 0 else VERTICAL
        rotors.append(Rotor(float(px), float(py), 1 if km >= 0 else -1, axis=axis))
    levels = tuple("top" if params.get(f"CA_ROTOR{i}_PZ", 0.0) < 0 else
                   "bottom" if params.get(f"CA_ROTOR{i}_PZ", 0.0) > 0 else "" for i in range(n))
    return name_rotors(tuple(rotors), levels if any(levels) else None), ""


# ----------------------------------------------------------------------------- names

_SIDE = {(1, 0): "front", (-1, 0): "rear", (0, 1): "right", (0, -1): "left", (0, 0): "centre"}


def position_word(x: float, y: float) -> str:
    """"front", "front-right", "right"... for a rotor at (x forward, y right): on an axis when
    the other coordinate is under AXIS_FRACTION of the arm."""
    arm = math.hypot(x, y)
    if arm == 0:
        return "centre"
    sx = 0 if abs(x) < AXIS_FRACTION * arm else (1 if x > 0 else -1)
    sy = 0 if abs(y) < AXIS_FRACTION * arm else (1 if y > 0 else -1)
    if sx and sy:
        return f"{'front' if sx > 0 else 'rear'}-{'right' if sy > 0 else 'left'}"
    return _SIDE[(sx, sy)]


def _angle(r: Rotor) -> float:
    return math.degrees(math.atan2(r.y, r.x))


def name_rotors(rotors: tuple[Rotor, ...], levels: Optional[tuple[str, ...]] = None) -> tuple[Rotor, ...]:
    """The rotors with plain-words names: the position word; of rotors at different places that
    share a word, one nearer the lateral axis than the longitudinal one is "mid-..." (PX4's
    octa-X names), and any left alike get their arm angle ("rear-left (-162 deg)"); rotors at one
    place (coaxial) get "top"/"bottom" when known, else their spin ("(CCW)"/"(CW)")."""
    def same_place(a: Rotor, b: Rotor) -> bool:
        return math.hypot(a.x - b.x, a.y - b.y) <= 1e-3 * max(math.hypot(a.x, a.y), 1e-9)

    words = [position_word(r.x, r.y) for r in rotors]
    for i, r in enumerate(rotors):
        apart = [j for j in range(len(rotors)) if j != i and position_word(rotors[j].x, rotors[j].y) == words[i]
                 and not same_place(r, rotors[j])]
        if apart and "-" in words[i] and abs(r.y) > abs(r.x) + 1e-6:
            words[i] = "mid-" + words[i]
    for i, r in enumerate(rotors):
        if any(words[j] == words[i] and not same_place(r, rotors[j]) for j in range(len(rotors)) if j != i):
            words[i] = f"{words[i]} ({_angle(r):.0f} deg)"
    out = []
    for i, r in enumerate(rotors):
        word = words[i]
        if any(same_place(r, rotors[j]) for j in range(len(rotors)) if j != i):
            word = f"{word} {levels[i]}" if levels and levels[i] else f"{word} ({'CCW' if r.spin > 0 else 'CW'})"
        out.append(Rotor(r.x, r.y, r.spin, axis=r.axis, name=word))
    return tuple(out)


__all__ = ["MotorDef", "ARDUPILOT_FRAME_CLASSES", "ARDUPILOT_FRAME_TYPES", "ARDUPILOT_LAYOUTS",
           "ARDUPILOT_MOTOR_FUNCTIONS", "PX4_GEOMETRIES", "PX4_AUTOSTART_GEOMETRY", "ardupilot_layout",
           "ardupilot_mixer_factors", "ardupilot_frame", "ardupilot_motor_channels", "px4_autostart_frame",
           "px4_ca_rotors", "position_word", "name_rotors"]
