"""Frame geometry: every ArduPilot motor table against the published layouts, PX4 geometries,
motor-to-output mapping, the readers on n-rotor logs, and `fdlog info` on them."""
from __future__ import annotations

import json

import numpy as np
import pytest

from flightlog_fd.checks import describe_flight, diagnosability
from flightlog_fd.flight import QUAD_PLUS_POSITIONS, QUAD_X_POSITIONS, Flight, Frame, Rotor, Series
from flightlog_fd.frames import (ARDUPILOT_LAYOUTS, PX4_AUTOSTART_GEOMETRY, ardupilot_frame, ardupilot_layout,
                                 ardupilot_mixer_factors, ardupilot_motor_channels, position_word,
                                 px4_autostart_frame, px4_ca_rotors)

# Written out by hand, motor 1 first: "position spin", from ArduPilot's motor-order diagrams
# (copter docs "Connect ESCs and Motors") and, for the layouts without a diagram, the comments of
# AP_MotorsMatrix.cpp. Positions in the words of flightlog_fd.frames; spin seen from above.
PUBLISHED = {
    (1, 0): "right CCW, left CCW, front CW, rear CW",
    (1, 1): "front-right CCW, rear-left CCW, front-left CW, rear-right CW",
    (1, 2): "front-right CCW, rear-left CCW, front-left CW, rear-right CW",
    (1, 3): "front-right CW, rear-left CW, front-left CCW, rear-right CCW",
    (1, 4): "front-right none, rear-left CW, front-left none, rear-right CCW",
    (1, 5): "front-right none, rear-left CCW, front-left none, rear-right CW",
    (1, 6): "right CW, left CW, front CCW, rear CCW",
    (1, 12): "rear-right CW, front-right CCW, rear-left CCW, front-left CW",
    (1, 13): "front-right CCW, front-left CW, rear-left CCW, rear-right CW",
    (1, 14): "front-right CCW, rear-right CW, rear-left CCW, front-left CW",
    (1, 18): "rear-right CCW, front-right CW, rear-left CW, front-left CCW",
    (1, 19): "front-right CCW, rear (CW) CW, rear (CCW) CCW, front-left CW",
    (2, 0): "front CW, rear CCW, rear-left CW, front-right CCW, front-left CCW, rear-right CW",
    (2, 1): "right CW, left CCW, front-left CW, rear-right CCW, front-right CCW, rear-left CW",
    (2, 3): "right CW, left CCW, front-left CW, rear-right CCW, front-right CCW, rear-left CW",
    (2, 13): "front-right CCW, front-left CW, left CCW, rear-left CW, rear-right CCW, right CW",
    (2, 14): "front-right CCW, right CW, rear-right CCW, rear-left CW, left CCW, front-left CW",
    (3, 0): "front CW, rear CW, front-right CCW, rear-right CCW, front-left CCW, rear-left CCW, left CW, right CW",
    (3, 1): "front-right CW, rear-left CW, mid-front-right CCW, rear-right CCW, front-left CCW, mid-rear-left CCW, "
            "mid-front-left CW, mid-rear-right CW",
    (3, 2): "mid-front-left CW, mid-rear-right CW, mid-rear-left CCW, rear-right CCW, front-left CCW, "
            "mid-front-right CCW, front-right CW, rear-left CW",
    (3, 3): "front-right CW, rear-left CW, mid-front-right CCW, rear-right CCW, front-left CCW, mid-rear-left CCW, "
            "mid-front-left CW, mid-rear-right CW",
    (3, 13): "front-right CCW, front-left CW, mid-front-left CCW, mid-rear-left CW, rear-left CCW, rear-right CW, "
             "mid-rear-right CCW, mid-front-right CW",
    (3, 14): "front-right CCW, mid-front-right CW, mid-rear-right CCW, rear-right CW, rear-left CCW, "
             "mid-rear-left CW, mid-front-left CCW, front-left CW",
    (3, 15): "rear-left (-162 deg) CW, front-right (18 deg) CW, rear-left CCW, front-left (-18 deg) CCW, "
             "rear-right (162 deg) CCW, front-right CCW, rear-right CW, front-left CW",
    (4, 0): "front (CCW) CCW, left (CW) CW, rear (CCW) CCW, right (CW) CW, left (CCW) CCW, front (CW) CW, "
            "right (CCW) CCW, rear (CW) CW",
    (4, 1): "front-right top CCW, front-left top CW, rear-left top CCW, rear-right top CW, front-left bottom CCW, "
            "front-right bottom CW, rear-right bottom CCW, rear-left bottom CW",
    (4, 2): "front-right (CCW) CCW, front-left (CW) CW, rear-left (CCW) CCW, rear-right (CW) CW, "
            "front-left (CCW) CCW, front-right (CW) CW, rear-right (CCW) CCW, rear-left (CW) CW",
    (4, 3): "front-right (CW) CW, front-left (CCW) CCW, rear-left (CW) CW, rear-right (CCW) CCW, "
            "front-left (CW) CW, front-right (CCW) CCW, rear-right (CW) CW, rear-left (CCW) CCW",
    (4, 12): "rear-right (CW) CW, front-right (CCW) CCW, rear-left (CCW) CCW, front-left (CW) CW, "
             "rear-right (CCW) CCW, front-right (CW) CW, rear-left (CW) CW, front-left (CCW) CCW",
    (4, 14): "front-right (CCW) CCW, front-right (CW) CW, rear-right (CW) CW, rear-right (CCW) CCW, "
             "rear-left (CCW) CCW, rear-left (CW) CW, front-left (CW) CW, front-left (CCW) CCW",
    (4, 18): "rear-right (CCW) CCW, front-right (CW) CW, rear-left (CW) CW, front-left (CCW) CCW, "
             "rear-right (CW) CW, front-right (CCW) CCW, rear-left (CCW) CCW, front-left (CW) CW",
    (5, 10): "front-right (CW) CW, front-right (CCW) CCW, rear (CW) CW, rear (CCW) CCW, front-left (CW) CW, "
             "front-left (CCW) CCW",
    (5, 11): "rear (CCW) CCW, front-right (CCW) CCW, front-left (CCW) CCW, rear (CW) CW, front-right (CW) CW, "
             "front-left (CW) CW",
    (5, 0): "front-right (CCW) CCW, front-left (CW) CW, front-left (CCW) CCW, rear (CW) CW, front-right (CW) CW, "
            "rear (CCW) CCW",
    (12, 0): "front (CCW) CCW, front (CW) CW, front-right (CW) CW, front-right (CCW) CCW, rear-right (CCW) CCW, "
             "rear-right (CW) CW, rear (CW) CW, rear (CCW) CCW, rear-left (CCW) CCW, rear-left (CW) CW, "
             "front-left (CW) CW, front-left (CCW) CCW",
    (12, 1): "front-right (CCW) CCW, front-right (CW) CW, right (CW) CW, right (CCW) CCW, rear-right (CCW) CCW, "
             "rear-right (CW) CW, rear-left (CW) CW, rear-left (CCW) CCW, left (CCW) CCW, left (CW) CW, "
             "front-left (CW) CW, front-left (CCW) CCW",
    (14, 0): "front CCW, front-right CW, mid-front-right CCW, mid-rear-right CW, rear-right CCW, rear CW, "
             "rear-left CCW, mid-rear-left CW, mid-front-left CCW, front-left CW",
    (14, 1): "front-right CCW, mid-front-right CW, right CCW, mid-rear-right CW, rear-right CCW, rear-left CW, "
             "mid-rear-left CCW, left CW, mid-front-left CCW, front-left CW",
    (14, 14): "front-right CCW, mid-front-right CW, right CCW, mid-rear-right CW, rear-right CCW, rear-left CW, "
              "mid-rear-left CCW, left CW, mid-front-left CCW, front-left CW",
}
FRAME_NAMES = {1: None, 2: "hexa", 3: "octo", 4: "octaquad", 5: "y6", 12: "dodecahexa", 14: "deca"}


def _layout_words(frame: Frame) -> str:
    spin = {1: "CCW", -1: "CW", 0: "none"}
    return ", ".join(f"{frame.position(i + 1)} {spin[r.spin]}" for i, r in enumerate(frame.rotors))


def test_every_firmware_table_has_a_published_layout():
    assert set(ARDUPILOT_LAYOUTS) | {(5, 0)} == set(PUBLISHED)


@pytest.mark.parametrize("key", sorted(PUBLISHED))
def test_ardupilot_table_matches_published_layout(key):
    fclass, ftype = key
    frame = ardupilot_frame(fclass, ftype)
    expected = PUBLISHED[key]
    assert frame.unplaced == ""
    assert _layout_words(frame) == expected
    assert frame.rotor_count == expected.count(",") + 1
    if FRAME_NAMES[fclass]:
        assert frame.name == FRAME_NAMES[fclass]
    # the mixer factors agree with the positions: a rotor on the right loses thrust to roll right
    # (roll factor < 0), a front rotor gains it for nose-up pitch, yaw follows the spin
    fac = ardupilot_mixer_factors(fclass, ftype)
    layout = ardupilot_layout(fclass, ftype)
    assert fac.shape == (frame.rotor_count, 3)
    assert np.allclose(np.abs(fac).max(axis=0)[:2], 0.5)
    for (roll, pitch, yaw), r, m in zip(fac, frame.rotors, layout):
        if not (fclass == 1 and ftype in (4, 5)):  # V/A-tail rear motors carry no roll by design
            assert np.sign(roll) == -np.sign(round(r.y, 6))
        assert np.sign(pitch) == np.sign(round(r.x, 6))
        assert np.sign(yaw) == r.spin
    assert sorted(m.order for m in layout) == list(range(1, frame.rotor_count + 1))


def test_quad_x_and_plus_keep_their_names_and_positions():
    x, plus = ardupilot_frame(1, 1), ardupilot_frame(1, 0)
    assert x.name == "quad_x" and x.is_quad and [x.position(k) for k in range(1, 5)] == list(QUAD_X_POSITIONS)
    assert plus.name == "quad_plus" and plus.is_quad and [plus.position(k) for k in range(1, 5)] == list(QUAD_PLUS_POSITIONS)
    assert x.rotors == Frame.quad_x().rotors and plus.rotors == Frame.quad_plus().rotors
    assert ardupilot_frame(1, 14).name == "quad_other" and ardupilot_frame(2, 14).is_quad is False


@pytest.mark.parametrize("fclass, ftype, words", [
    (2, 2, "no hexa V layout"), (3, 12, "no octa BF_X layout"), (7, 0, "tricopter"), (6, 0, "helicopter"),
    (15, 0, "Lua script"), (0, 1, "never configured"), (-1, 1, "no FRAME_CLASS"), (99, 0, "unknown FRAME_CLASS 99"),
])
def test_frames_that_cannot_be_placed_say_why(fclass, ftype, words):
    f = ardupilot_frame(fclass, ftype)
    assert f.rotor_count == 0 and words in f.unplaced


def test_y6_any_other_type_uses_the_firmware_default_table():
    assert _layout_words(ardupilot_frame(5, 1)) == PUBLISHED[(5, 0)]


def test_motor_channels_follow_servo_functions_including_remapped_outputs():
    params = {f"SERVO{k}_FUNCTION": 0.0 for k in range(1, 17)}
    params.update({"SERVO9_FUNCTION": 33, "SERVO10_FUNCTION": 34, "SERVO11_FUNCTION": 35, "SERVO12_FUNCTION": 36,
                   "SERVO13_FUNCTION": 37, "SERVO14_FUNCTION": 38})
    assert ardupilot_motor_channels(params, 6) == ([9, 10, 11, 12, 13, 14], "SERVOn_FUNCTION")
    params["SERVO3_FUNCTION"] = 40  # motor 8 on output 3, motors 9..12 on 82..85
    params.update({"SERVO4_FUNCTION": 39, "SERVO5_FUNCTION": 82})
    assert ardupilot_motor_channels(params, 9) == ([9, 10, 11, 12, 13, 14, 4, 3, 5], "SERVOn_FUNCTION")
    assert ardupilot_motor_channels({"SERVO1_FUNCTION": 33}, 6)[0] == [1, 2, 3, 4, 5, 6]  # incomplete: 1..n


# PX4 mixer geometries, motor 1 first, as the airframe reference pages draw them.
PX4_PUBLISHED = {
    "hex_x": "right CW, left CCW, front-left CW, rear-right CCW, front-right CCW, rear-left CW",
    "hex_plus": "front CW, rear CCW, rear-left CW, front-right CCW, front-left CCW, rear-right CW",
    "hex_cox": "front-right top CW, front-right bottom CCW, rear top CW, rear bottom CCW, front-left top CW, "
               "front-left bottom CCW",
    "octa_x": "front-right CW, rear-left CW, mid-front-right CCW, rear-right CCW, front-left CCW, mid-rear-left CCW, "
              "mid-front-left CW, mid-rear-right CW",
    "octa_plus": "front CW, rear CW, front-right CCW, rear-right CCW, front-left CCW, rear-left CCW, left CW, right CW",
    "octa_cox": "front-right top CCW, front-left top CW, rear-left top CCW, rear-right top CW, front-left bottom CCW, "
                "front-right bottom CW, rear-right bottom CCW, rear-left bottom CW",
}


@pytest.mark.parametrize("thousands", sorted(PX4_AUTOSTART_GEOMETRY))
def test_px4_autostart_airframes(thousands):
    f = px4_autostart_frame(thousands * 1000 + 1)
    name, geom = PX4_AUTOSTART_GEOMETRY[thousands]
    assert f.name == name and _layout_words(f) == PX4_PUBLISHED[geom] and geom in f.layout
    assert px4_autostart_frame(4001) is None  # quads stay with the ULog reader's own handling


def test_octaquad_x_is_px4_octa_cox_motor_for_motor():
    ap, px4 = ardupilot_frame(4, 1), px4_autostart_frame(12001)
    assert _layout_words(ap) == _layout_words(px4)


def test_px4_control_allocation_rotors_with_tilt_and_coaxial_levels():
    params = {"CA_ROTOR_COUNT": 6}
    for i, a in enumerate(np.radians([30, 90, 150, -150, -90, -30])):
        params.update({f"CA_ROTOR{i}_PX": 0.3 * np.cos(a), f"CA_ROTOR{i}_PY": 0.3 * np.sin(a),
                       f"CA_ROTOR{i}_KM": 0.05 * (-1) ** i})
    params["CA_ROTOR1_AY"] = -0.2  # motor 2 tilted
    rotors, why = px4_ca_rotors(params)
    assert why == "" and [r.name for r in rotors] == ["front-right", "right", "rear-right", "rear-left", "left",
                                                      "front-left"]
    assert [r.spin for r in rotors] == [1, -1, 1, -1, 1, -1]
    assert np.isclose(np.linalg.norm(rotors[1].axis), 1.0) and rotors[1].axis[1] < 0 and rotors[0].axis == (0, 0, -1)
    params.pop("CA_ROTOR3_PY")
    assert px4_ca_rotors(params) == (None, "CA_ROTOR_COUNT=6 but CA_ROTOR3_PX/PY missing")
    # a coaxial X8: each arm twice, PZ < 0 above the arm, > 0 below
    x8 = {"CA_ROTOR_COUNT": 8}
    for i, (a, z) in enumerate([(45, -1), (-45, -1), (-135, -1), (135, -1), (-45, 1), (45, 1), (135, 1), (-135, 1)]):
        x8.update({f"CA_ROTOR{i}_PX": np.cos(np.radians(a)), f"CA_ROTOR{i}_PY": np.sin(np.radians(a)),
                   f"CA_ROTOR{i}_PZ": 0.05 * z, f"CA_ROTOR{i}_KM": 0.05 * (-1) ** i})
    rotors, _ = px4_ca_rotors(x8)
    assert [r.name for r in rotors][:2] == ["front-right top", "front-left top"] and rotors[5].name == "front-right bottom"


def test_position_words():
    assert position_word(1, 0) == "front" and position_word(0, -1) == "left" and position_word(0, 0) == "centre"
    assert position_word(-0.9, 0.1) == "rear" and position_word(-0.7, 0.7) == "rear-right"


# --------------------------------------------------------------------------- readers, info

def _hexa_logs(shared):
    d = shared("ardupilot_sitl_hexa")
    logs = sorted(d.glob("hexa_cwx_m*.bin"))
    assert len(logs) == 6
    return logs


def test_every_sitl_hexa_log_reads_six_motors(shared):
    from flightlog_fd import load_flight

    for path in _hexa_logs(shared):
        f = load_flight(path)
        k = int(path.stem[-1])
        assert f.frame.name == "hexa" and f.frame.layout == "ArduPilot HEXA/CW_X" and f.frame.rotor_count == 6
        assert f.motors.values.shape[1] == 6 and f.frame.outputs == (1, 2, 3, 4, 5, 6)
        assert f.motors.source.startswith("RCOU.C1,C2,C3,C4,C5,C6")
        # the script re-assigns the stopped motor's output mid-flight: warned, start-of-flight wiring kept
        assert any(w.startswith(f"SERVO{k}_FUNCTION changed from {32 + k} (motor {k})") for w in f.warnings)
        # the hexa's controller answers the lost motor: before the stop every motor flies at a similar
        # output, and the stopped one's RCOU then sits at 1000 us
        air = (f.motors.t > f.airborne[0][0] + 3) & (f.motors.t < f.airborne[0][0] + 6)
        assert f.motors.values[air].min() > 0.3
        assert f.motors.values[-5:, k - 1].max() == 0.0


@pytest.mark.parametrize("k, t_stop", [(1, 79.8), (2, 78.0), (3, 73.8), (4, 77.9), (5, 72.9), (6, 79.0)])
def test_sitl_hexa_mixer_matches_the_cw_x_table(shared, k, t_stop):
    """Firmware data against the table: each motor's RCOU thrust regressed on RATE's throttle,
    roll, pitch and yaw demands before the stop; a motor's coefficient relative to the mean of
    the six has the sign of its factor (the demands vary little, so only signs are compared)."""
    from flightlog_fd import load_flight
    from flightlog_fd.logs.dataflash import read_tables, signal_to_thrust

    path = shared("ardupilot_sitl_hexa", f"hexa_cwx_m{k}.bin")
    f = load_flight(path)
    rate = read_tables(path, ["RATE"])["RATE"]
    m = (f.motors.t > f.airborne[0][0] + 2) & (f.motors.t < t_stop)
    thrust = signal_to_thrust(f.motors.values[m], 0.65)
    X = np.column_stack([np.interp(f.motors.t[m], rate.t, rate.columns[c]) for c in ("ROut", "POut", "YOut", "AOut")])
    coef, *_ = np.linalg.lstsq(np.column_stack([X, np.ones(len(X))]), thrust, rcond=None)
    rel = coef[:3] - coef[:3].mean(axis=1, keepdims=True)
    fac = ardupilot_mixer_factors(2, 14)
    for motor in range(6):
        for axis in range(3):
            if abs(fac[motor, axis]) > 0.1:
                assert np.sign(rel[axis, motor]) == np.sign(fac[motor, axis]), (motor + 1, "roll pitch yaw".split()[axis])


def test_info_prints_the_geometry(shared):
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    path = _hexa_logs(shared)[0]
    res = CliRunner().invoke(app, ["info", "--json", str(path)])
    d = json.loads(res.stdout)
    assert res.exit_code == 2 and d["frame"]["layout"] == "ArduPilot HEXA/CW_X"
    assert [m["position"] for m in d["frame"]["motors"]] == ["front-right", "right", "rear-right", "rear-left",
                                                             "left", "front-left"]
    assert [m["output"] for m in d["frame"]["motors"]] == [1, 2, 3, 4, 5, 6]
    assert [(m["motor"], round(m["t_start"], 2)) for m in d["stopped_motors"]] == [(1, 80.98)]
    assert d["reasons"] == ["6-rotor frame ArduPilot HEXA/CW_X: its motor numbering is not that of the frames the "
                            "6-rotor model was trained on (ArduPilot FRAME_CLASS/TYPE 2/1, 2/0); only stopped-motor "
                            "detection is available for it"]
    res = CliRunner().invoke(app, ["info", str(path)])
    assert "ArduPilot HEXA/CW_X" in res.stdout and "rear-right" in res.stdout and "thrust axis" in res.stdout
    assert "motor 1 at t=80.98 s" in res.stdout


def _flight(frame: Frame, vehicle_type: str) -> Flight:
    t = np.arange(0, 30, 0.02)
    n = max(frame.rotor_count, 4)
    return Flight(path="x.bin", autopilot="ardupilot", vehicle_type=vehicle_type, frame=frame,
                  rates=Series(t, np.zeros((len(t), 3))), motors=Series(t, np.full((len(t), n), 0.5)),
                  airborne=[(1.0, 29.0)], t_start=0.0, t_end=30.0)


def test_unplaced_frame_is_refused_with_the_reason():
    d = diagnosability(_flight(ardupilot_frame(2, 2), "hexarotor"))
    assert not d.ok and d.reasons[0] == ("cannot place the rotors of this hexa frame: ArduPilot defines no hexa V "
                                         "layout (FRAME_TYPE 2); the firmware refuses to arm with it")
    info = describe_flight(_flight(ardupilot_frame(7, 0), "tricopter"))
    assert info["frame"]["unplaced"].startswith("FRAME_CLASS 7 is a tricopter")
    assert diagnosability(_flight(ardupilot_frame(3, 1), "octorotor")).ok  # octo-X: the shipped 8-rotor model
    octo_v = diagnosability(_flight(ardupilot_frame(3, 2), "octorotor"))
    assert "motor numbering is not that of the frames the 8-rotor model" in octo_v.reasons[0]
    twelve = diagnosability(_flight(ardupilot_frame(12, 1), "dodecarotor"))
    assert twelve.reasons[0].startswith("12-rotor frame (dodecahexa): fdlog has no 12-rotor")


def test_dataflash_frame_from_parameters_for_every_table():
    from flightlog_fd.logs.dataflash import _frame

    for (fclass, ftype) in sorted(PUBLISHED):
        frame, vehicle, c, t = _frame({"FRAME_CLASS": fclass, "FRAME_TYPE": ftype}, [], "ArduCopter V4.5.7")
        assert (c, t) == (fclass, ftype) and _layout_words(frame) == PUBLISHED[(fclass, ftype)]
        assert vehicle != "unknown"


def test_ulog_round_trip_hexa_reads_six_motors(tmp_path):
    from flightlog_fd.logs.ulog import read_ulog
    from flightlog_fd.logs.ulog_writer import write_ulog

    hexa = ardupilot_frame(2, 1)
    t = np.arange(1, 20, 0.01)
    rng = np.random.default_rng(2)
    motors = np.clip(0.5 + 0.05 * rng.standard_normal((len(t), 6)), 0, 1)
    fl = Flight(path=None, autopilot="sim", vehicle_type="hexarotor", frame=hexa,
                rates=Series(t, rng.normal(0, 0.1, (len(t), 3))), motors=Series(t, motors), t_start=1.0, t_end=20.0)
    back = read_ulog(write_ulog(fl, tmp_path / "hexa.ulg"))
    assert back.frame.name == "hexa" and back.motors.values.shape[1] == 6
    assert [back.frame.position(k) for k in range(1, 7)] == [hexa.position(k) for k in range(1, 7)]
    np.testing.assert_allclose(back.motors.values, motors, atol=1e-6)


@pytest.mark.parametrize("ftype, diagnosable", [(1, True), (0, True), (2, True), (3, True), (12, False),
                                                (13, False), (14, False), (4, False), (19, False)])
def test_only_the_quad_layouts_diagnosed_before_are_diagnosed(ftype, diagnosable):
    d = diagnosability(_flight(ardupilot_frame(1, ftype), "quadrotor"))
    assert d.ok is diagnosable, d.reasons
    if not diagnosable:
        assert d.reasons[0].startswith(f"unsupported frame ArduPilot QUAD/")
