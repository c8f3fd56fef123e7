"""PX4 ULog writer: round trips through our reader and pyulog, the byte format itself, the thrust
model, and a real log re-written. Synthetic flights are built here (small, a few seconds)."""
from __future__ import annotations

import contextlib
import io
import struct

import numpy as np
import pytest

from flightlog_fd.flight import Flight, Frame, Rotor, Series
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.ulog import read_ulog, read_ulog_truth
from flightlog_fd.logs.ulog_writer import (
    euler_to_quaternion, signal_from_thrust, thrust_from_signal, write_ulog,
)

F32 = dict(rtol=2e-7, atol=2e-7)  # float32 storage of O(1) values


def _jittered_times(t0: float, t1: float, rate_hz: float, rng) -> np.ndarray:
    """A logger's sample times: nominal period with up to 10 % jitter, whole µs."""
    n = int((t1 - t0) * rate_hz)
    t = t0 + np.arange(n) / rate_hz + rng.uniform(0, 0.1 / rate_hz, n)
    return np.round(t * 1e6) / 1e6


def synthetic_flight(seed: int = 0, *, thrust_curve: float = 0.3, hot_motor: int = 3) -> Flight:
    """Six seconds of a quad-X: arm at 10.5 s, take off at 11.0 s (1 m/s climb for 1.5 s), land at
    15.0 s, disarm at 15.8 s. Motor ``hot_motor`` runs 0.1 above the others."""
    rng = np.random.default_rng(seed)
    t0, t1 = 10.0, 16.0
    tr = _jittered_times(t0, t1, 250.0, rng)
    rates = Series(tr, rng.normal(0, 0.3, (len(tr), 3)), "sim gyro")
    ta = _jittered_times(t0, t1, 100.0, rng)
    att = np.column_stack([0.2 * np.sin(ta), 0.1 * np.cos(ta), np.pi * np.sin(0.5 * ta)])
    tm = _jittered_times(t0, t1, 200.0, rng)
    armed, airborne = [(10.5, 15.8)], [(11.0, 15.0)]
    on = (tm >= 10.5) & (tm < 15.8)
    motors = np.where(on[:, None], 0.45 + 0.05 * rng.random((len(tm), 4)), 0.0)
    motors[on, hot_motor - 1] += 0.1
    tv = _jittered_times(t0, t1, 50.0, rng)
    vz = np.where((tv > 11.0) & (tv < 12.5), -1.0, 0.0)
    velocity = np.column_stack([0.5 * np.ones(len(tv)), np.zeros(len(tv)), vz])
    te = _jittered_times(t0, t1, 20.0, rng)
    rpm = np.where(((te >= 10.5) & (te < 15.8))[:, None], 9000 + rng.integers(0, 500, (len(te), 4)), 0)
    return Flight(
        path=None, autopilot="sim", firmware="flightlog-fd sim v0.1.0", vehicle_type="quadrotor",
        vehicle_id="SIM-0001", frame=Frame.quad_x(0.25), rates=rates, attitude=Series(ta, att, "sim q"),
        motors=Series(tm, motors, "sim motors"), motor_kind="thrust", thrust_curve=thrust_curve,
        esc_rpm=Series(te, rpm.astype(float), "sim esc"), velocity=Series(tv, velocity, "sim v"),
        armed=armed, airborne=airborne, airborne_source="sim", t_start=t0, t_end=t1,
        params={"MPC_XY_VEL_MAX": 12.0, "SDLOG_PROFILE": 17.0, "CA_ROTOR7_PX": 9.0},
        truth={"label": 3, "eta": np.float64(0.8), "onset_s": 11.5, "rho": np.array([1.0, 0.98, 1.02, 1.0])},
    )


def _walk_messages(data: bytes) -> list[tuple[str, int, bytes]]:
    """(type, offset, payload) of every ULog message after the 16-byte header; fails on a bad size."""
    assert data[:7] == b"ULog\x01\x12\x35"
    out, pos = [], 16
    while pos < len(data):
        size, mtype = struct.unpack_from("<HB", data, pos)
        assert pos + 3 + size <= len(data), "message runs past the end"
        out.append((chr(mtype), pos, data[pos + 3: pos + 3 + size]))
        pos += 3 + size
    return out


# ---------------------------------------------------------------- round trip


def test_round_trip_same_numbers(tmp_path):
    fl = synthetic_flight()
    path = write_ulog(fl, tmp_path / "sim.ulg")
    back = load_flight(path)  # by content, like the CLI
    assert back.autopilot == "px4" and back.warnings == []
    assert back.t_start == fl.t_start and back.t_end == pytest.approx(fl.t_end, abs=1e-6)
    assert back.firmware == fl.firmware and back.vehicle_id == "SIM-0001" and back.vehicle_type == "quadrotor"
    for name in ("rates", "motors", "velocity", "esc_rpm"):
        a, b = getattr(fl, name), getattr(back, name)
        np.testing.assert_allclose(b.t, a.t, rtol=0, atol=1e-6)
        np.testing.assert_allclose(b.values, a.values, **F32)
    np.testing.assert_allclose(back.attitude.values, fl.attitude.values, rtol=0, atol=1e-6)
    assert back.motor_kind == "thrust" and back.thrust_curve == pytest.approx(0.3, rel=1e-7)
    np.testing.assert_allclose(np.array(back.armed), np.array(fl.armed), rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.array(back.airborne), np.array(fl.airborne), rtol=0, atol=1e-6)
    assert back.airborne_source == "vehicle_land_detected.landed"
    # frame: geometry, spin and motor numbering survive; the stale CA_ROTOR7_PX in params is dropped
    assert back.frame.name == "quad_x" and back.frame.source.startswith("CA_ROTOR_COUNT=4")
    for r0, r1 in zip(fl.frame.rotors, back.frame.rotors):
        assert (r1.x, r1.y, r1.spin) == (pytest.approx(r0.x, rel=1e-7), pytest.approx(r0.y, rel=1e-7), r0.spin)
    assert "CA_ROTOR7_PX" not in back.params
    assert back.params["MPC_XY_VEL_MAX"] == 12.0 and back.params["SYS_AUTOSTART"] == 4001.0
    assert back.params["MAV_TYPE"] == 2.0 and back.params["PWM_MAIN_FUNC3"] == 103.0
    assert back.truth is None  # the reader never hands truth to the diagnosis
    truth = read_ulog_truth(path)
    assert truth == {"label": 3, "eta": 0.8, "onset_s": 11.5, "rho": [1.0, 0.98, 1.02, 1.0]}


def test_round_trip_motor_numbering_and_outputs(tmp_path):
    fl = synthetic_flight(seed=1, hot_motor=2, thrust_curve=0.3)
    back = read_ulog(write_ulog(fl, tmp_path / "m2.ulg"))
    a, b = back.airborne[0]
    assert np.argmax(back.motors.between(a, b).values.mean(axis=0)) == 1
    # actuator_outputs carries the PWM signal after the thrust model: inverse model of the thrust
    sig = back.alt_motors["actuator_outputs"]
    armed = (sig.t >= 10.5) & (sig.t < 15.8)
    expected = signal_from_thrust(fl.motors.values, 0.3)
    np.testing.assert_allclose(sig.values[armed], expected[armed], rtol=0, atol=1e-6)
    assert np.all(sig.values[~armed] == 0.0)  # disarmed value 900 µs reads back as 0
    assert np.all(expected[armed] > fl.motors.values[armed])  # f > 0: signal above thrust below full


def test_raw_pyulog_view(tmp_path):
    """What PX4 tools see: pyulog parses it cleanly, with PX4's field names and units."""
    from pyulog import ULog

    fl = synthetic_flight(seed=2, thrust_curve=0.0)
    path = write_ulog(fl, tmp_path / "raw.ulg")
    with contextlib.redirect_stdout(io.StringIO()) as printed:
        u = ULog(str(path))
    assert printed.getvalue() == "" and not u.file_corruption and u.dropouts == []
    d = {x.name: x for x in u.data_list}
    assert set(d) == {"vehicle_status", "vehicle_land_detected", "vehicle_angular_velocity", "vehicle_attitude",
                      "actuator_motors", "actuator_outputs", "vehicle_local_position", "esc_status"}
    assert len(d["vehicle_angular_velocity"].data["timestamp"]) == len(fl.rates)
    motors = d["actuator_motors"].data
    assert np.all(np.isnan(motors["control[4]"])) and np.all(np.isnan(motors["control[11]"]))
    out = d["actuator_outputs"].data
    i = np.flatnonzero((fl.motors.t > 11) & (fl.motors.t < 15))[0]
    assert out["output[0]"][i] == pytest.approx(1000 + 1000 * fl.motors.values[i, 0], abs=1e-3)
    assert out["output[4]"][i] == 0.0 and out["noutputs"][i] == 4
    assert set(np.unique(d["vehicle_status"].data["arming_state"])) == {1, 2}
    assert d["esc_status"].data["esc[2].actuator_function"][0] == 103
    q = np.column_stack([d["vehicle_attitude"].data[f"q[{k}]"] for k in range(4)])
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
    assert u.msg_info_dict["sys_name"] == "PX4" and u.msg_info_dict["ver_hw"] == "FDLOG_SIM"
    assert u.msg_info_dict["ver_sw_release"] == 0x000100FF  # "v0.1.0" as a release
    assert u.initial_parameters["CA_ROTOR_COUNT"] == 4 and isinstance(u.initial_parameters["CA_ROTOR_COUNT"], int)
    assert isinstance(u.initial_parameters["MPC_XY_VEL_MAX"], float)
    assert u.start_timestamp == 10_000_000 and u.last_timestamp == 16_000_000


def test_byte_format_messages_in_time_order(tmp_path):
    data = write_ulog(synthetic_flight(seed=3), tmp_path / "b.ulg").read_bytes()
    msgs = _walk_messages(data)
    kinds = [k for k, _, _ in msgs]
    assert kinds[0] == "B"  # flag bits first, as the spec requires
    first_data = kinds.index("D")
    assert set(kinds[:first_data]) == {"B", "F", "I", "P", "A"} and set(kinds[first_data:]) == {"D"}
    # every data message: msg_id then a uint64 timestamp first; timestamps never go backwards
    stamps = [struct.unpack_from("<Q", payload, 2)[0] for k, _, payload in msgs if k == "D"]
    assert np.all(np.diff(stamps) >= 0) and len(stamps) > 2000


def test_signal_flight_round_trip(tmp_path):
    """A flight whose motors are PWM signals (e.g. read from an old log) keeps its signal as
    actuator_outputs and gains the thrust setpoints through the thrust model."""
    fl = synthetic_flight(seed=4, thrust_curve=0.4)
    fl.motor_kind = "signal"
    fl.params["PWM_MAIN_MIN"], fl.params["PWM_MAIN_MAX"] = 1100.0, 1900.0
    back = read_ulog(write_ulog(fl, tmp_path / "s.ulg"))
    assert back.motor_kind == "thrust"
    np.testing.assert_allclose(back.motors.values, thrust_from_signal(fl.motors.values, 0.4), **F32)
    sig = back.alt_motors["actuator_outputs"]
    armed = (sig.t >= 10.5) & (sig.t < 15.8)
    assert "1100..1900" in sig.source
    np.testing.assert_allclose(sig.values[armed], fl.motors.values[armed], rtol=0, atol=1e-6)


def test_minimal_flight_and_other_frames(tmp_path):
    rng = np.random.default_rng(5)
    t = np.arange(1, 4, 0.004)
    hexa = Frame("hexa", tuple(Rotor(np.cos(a), np.sin(a), 1 if i % 2 else -1)
                               for i, a in enumerate(np.linspace(0, 2 * np.pi, 6, endpoint=False))), "sim")
    fl = Flight(path=None, autopilot="sim", vehicle_type="hexarotor", frame=hexa,
                rates=Series(t, rng.normal(0, 0.1, (len(t), 3))), t_start=1.0, t_end=4.0)
    back = read_ulog(write_ulog(fl, tmp_path / "hexa.ulg"))
    assert back.vehicle_type == "hexarotor" and back.frame.name == "hexa" and back.frame.rotor_count == 6
    assert [r.spin for r in back.frame.rotors] == [r.spin for r in hexa.rotors]
    assert back.motors is None and any("no motor topic" in w for w in back.warnings)
    assert back.armed == [] and back.airborne == []
    np.testing.assert_allclose(back.rates.values, fl.rates.values, **F32)

    fl.vehicle_type, fl.frame = "vtol", None
    back = read_ulog(write_ulog(fl, tmp_path / "vtol.ulg"))
    assert back.vehicle_type == "vtol" and back.frame.name == "vtol"


def test_negative_times_rejected(tmp_path):
    fl = synthetic_flight()
    fl.rates = Series(fl.rates.t - 20.0, fl.rates.values)
    with pytest.raises(ValueError, match="> 0 s"):
        write_ulog(fl, tmp_path / "neg.ulg")


def test_truncated_written_log(tmp_path):
    data = write_ulog(synthetic_flight(seed=6), tmp_path / "full.ulg").read_bytes()
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(data[: int(len(data) * 0.6) + 1])
    f = read_ulog(cut)
    assert any("truncated" in w for w in f.warnings)
    assert 10.5 < f.t_end < 16.0 and f.rates.t[-1] <= f.t_end


def test_real_log_rewritten_reads_the_same(shared, tmp_path):
    src = read_ulog(shared("px4_sih_dev", "logs", "sih_008.ulg"))
    back = read_ulog(write_ulog(src, tmp_path / "again.ulg"))
    for name in ("rates", "attitude", "motors", "velocity"):
        a, b = getattr(src, name), getattr(back, name)
        np.testing.assert_array_equal(b.t, a.t)
        np.testing.assert_allclose(b.values, a.values, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back.alt_motors["actuator_outputs"].values,
                               src.alt_motors["actuator_outputs"].values, rtol=0, atol=1e-6)
    assert back.armed == src.armed and back.airborne == src.airborne
    assert back.frame.name == src.frame.name == "quad_x"


# ---------------------------------------------------------------- models


def test_thrust_model_inverse_and_px4_formula():
    x = np.linspace(0, 1, 101)
    for f in (0.0, 0.25, 0.7, 1.0):
        np.testing.assert_allclose(signal_from_thrust(thrust_from_signal(x, f), f), x, atol=1e-12)
    # PX4 FunctionMotors: rel_thrust = f x^2 + (1-f) x; half thrust with f = 0.5 needs x = 0.618
    assert signal_from_thrust(np.array([0.5]), 0.5)[0] == pytest.approx((np.sqrt(5) - 1) / 2)


def test_euler_quaternion_round_trip():
    from flightlog_fd.logs.ulog import quaternion_to_euler

    rng = np.random.default_rng(8)
    e = np.column_stack([rng.uniform(-1.2, 1.2, 200), rng.uniform(-1.2, 1.2, 200), rng.uniform(-3.1, 3.1, 200)])
    np.testing.assert_allclose(quaternion_to_euler(euler_to_quaternion(*e.T)), e, atol=1e-12)
