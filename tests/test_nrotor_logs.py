"""Simulated hexa- and octocopters written as DataFlash and ULog read back with their frame, n motors
and the commands they flew; the diagnosability check and model choice follow the frame's rotor count."""
import numpy as np
import pytest

from flightlog_fd import load_flight
from flightlog_fd.checks import TRAINED_LAYOUTS, diagnosability, trained_layout
from flightlog_fd.frames import ardupilot_frame
from flightlog_fd.logs.dataflash import read_tables
from flightlog_fd.logs.dataflash_writer import frame_class_type, write_dataflash
from flightlog_fd.logs.ulog_writer import write_ulog
from flightlog_fd.sim.airframe import N_ROTOR_FRAMES, preset
from flightlog_fd.sim.api import simulate_flights
from flightlog_fd.sim.damage import Damage

#: RATE carries 4 mixer inputs; a least-squares allocation's n commands are in their span except
#: where a motor is clipped at 0 on the ground (max 0.006 there); airborne the error measured 0
#: (float32) on every frame, damaged or not.
RATE_ROUND_TRIP_ATOL = 1e-4
#: RCOU is whole microseconds of a 1000 µs range.
RCOU_ATOL = 0.0006


def _fly(frame: str, profile: str, motor: int = 0, duration_s: float = 12.0):
    n = preset("x500", frame).rotor_count
    dmg = [Damage(motor, 0.7, rotors=n)] if motor else [Damage()]
    return simulate_flights(1, airframes=preset("x500", frame), damages=dmg, profile=profile, duration_s=duration_s,
                            seed=4)[0]


def _max_error(a, b, airborne=None) -> float:
    """Largest difference of ``b`` (read back) from ``a`` (flown), inside ``airborne`` intervals if given."""
    back = np.column_stack([np.interp(a.t, b.t, b.values[:, k]) for k in range(b.values.shape[1])])
    keep = np.ones(len(a.t), bool)
    if airborne is not None:
        keep = np.any([(a.t > t0 + 1.0) & (a.t < t1 - 1.0) for t0, t1 in airborne], axis=0)
    return float(np.abs(back - a.values)[keep].max())


@pytest.mark.parametrize("frame", sorted(N_ROTOR_FRAMES))
def test_n_rotor_dataflash_round_trip(frame, tmp_path):
    f = _fly(frame, "ardupilot", motor=2)
    cls, typ = N_ROTOR_FRAMES[frame]
    assert frame_class_type(f) == (cls, typ)
    path = write_dataflash(f, tmp_path / f"{frame}.bin")
    g = load_flight(path)
    n = f.frame.rotor_count
    assert g.frame.rotor_count == n and g.frame.layout == ardupilot_frame(cls, typ).layout
    assert g.params["FRAME_CLASS"] == cls and g.params["FRAME_TYPE"] == typ
    assert [int(g.params[f"SERVO{k}_FUNCTION"]) for k in range(1, n + 1)] == list(range(33, 33 + n))
    assert g.motors.values.shape[1] == n and g.motor_kind == "thrust"
    assert _max_error(f.motors, g.motors, f.airborne) < RATE_ROUND_TRIP_ATOL
    rcou = read_tables(path, ["RCOU"])["RCOU"]
    assert all(rcou.has(f"C{k}") for k in range(1, n + 1))
    msgs = [m for m in read_tables(path, ["MSG"])["MSG"].columns["Message"]]
    assert any(str(m).startswith("Frame: ") and "/" in str(m) for m in msgs)


@pytest.mark.parametrize("frame", ["hexa_x", "octaquad_x"])
def test_n_rotor_rcou_only_round_trip(frame, tmp_path):
    f = _fly(frame, "ardupilot_rcou")
    g = load_flight(write_dataflash(f, tmp_path / "r.bin"))
    assert g.motor_kind == "signal" and g.motors.values.shape[1] == f.frame.rotor_count
    assert _max_error(f.motors, g.motors) < RCOU_ATOL


@pytest.mark.parametrize("frame", ["hexa_plus", "octo_x", "octaquad_x"])
def test_n_rotor_ulog_round_trip(frame, tmp_path):
    f = _fly(frame, "px4_high", motor=1)
    g = load_flight(write_ulog(f, tmp_path / f"{frame}.ulg"))
    n = f.frame.rotor_count
    assert g.frame.rotor_count == n and int(g.params["CA_ROTOR_COUNT"]) == n
    assert g.motors.values.shape[1] == n
    np.testing.assert_allclose(g.motors.values, f.motors.values, atol=1e-6)
    # bearing and spin of every motor as the trained table (coaxial pairs are named by spin from PX4's
    # geometry, top/bottom from ArduPilot's table, so names are not compared)
    assert trained_layout(g.frame) == ardupilot_frame(*N_ROTOR_FRAMES[frame]).layout


def test_trained_layouts_are_the_simulator_frames():
    from flightlog_fd.training.build_default import FRAMES_BY_ROTORS

    for n, tables in TRAINED_LAYOUTS.items():
        assert sorted(tables) == sorted(N_ROTOR_FRAMES[f] for f in FRAMES_BY_ROTORS[n])


def test_other_hexa_numbering_is_not_a_trained_layout():
    assert trained_layout(ardupilot_frame(2, 1)) == "ArduPilot HEXA/X"
    for typ in (3, 13, 14):  # H, DJI_X, CW_X: other motor numbering
        assert trained_layout(ardupilot_frame(2, typ)) == ""
    assert trained_layout(ardupilot_frame(5, 10)) == ""  # Y6 is no trained frame


def test_diagnosability_follows_the_models_rotor_count(tmp_path):
    from flightlog_fd.model import shipped_model_path

    f = load_flight(write_ulog(_fly("hexa_x", "px4_default", duration_s=20.0), tmp_path / "h.ulg"))
    hexa_spec = {"rate_hz": 50.0, "window": 80, "n_motors": 6}
    assert diagnosability(f, hexa_spec).ok
    quad = diagnosability(f, {"rate_hz": 50.0, "window": 80})
    assert not quad.ok
    if shipped_model_path(6) is not None:
        assert "the model diagnoses 4 rotors" in quad.reason
        assert diagnosability(f).ok
    else:
        assert "only stopped-motor detection" in quad.reason
    f.frame = ardupilot_frame(2, 14)  # the same six motors numbered as HEXA/CW_X
    assert "motor numbering" in diagnosability(f, hexa_spec).reason
