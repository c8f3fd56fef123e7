"""write_dataflash: round trips through read_dataflash and pymavlink, synthetic and real flights."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.logs import load_flight, sniff_format
from flightlog_fd.logs.dataflash import read_dataflash, thrust_to_signal
from flightlog_fd.logs.dataflash_writer import WRITER_FIRMWARE, write_dataflash

PWM_STEP = 1.0 / 1000.0  # one µs of PWM over the default 1000..2000 range


def synthetic_flight(duration=20.0, rate_hz=250.0, motor_hz=400.0, kind="thrust", frame=None, seed=0) -> Flight:
    """A quad flight with streams at different rates and jittery-looking offsets."""
    rng = np.random.default_rng(seed)
    tr = np.arange(0.5, duration, 1 / rate_hz)
    tm = np.arange(0.5, duration, 1 / motor_hz) + 0.0007
    ta = np.arange(0.5, duration, 1 / 100.0)
    rates = 0.3 * np.sin(np.outer(tr, [1.1, 0.7, 0.3])) + 0.01 * rng.standard_normal((tr.size, 3))
    thrust = np.clip(0.4 + 0.05 * np.sin(np.outer(tm, [1.0, 2.0, 3.0, 4.0])) + 0.01 * rng.standard_normal((tm.size, 4)),
                     0, 1)
    motors = thrust if kind == "thrust" else thrust_to_signal(thrust, 0.65)
    return Flight(
        path=None, autopilot="sim", firmware="flightlog-fd simulator", vehicle_type="quadrotor",
        frame=frame or Frame.quad_x(), rates=Series(tr, rates, "sim"),
        attitude=Series(ta, 0.1 * np.sin(np.outer(ta, [0.5, 0.4, 0.1])), "sim"),
        motors=Series(tm, motors, "RATE mixer" if kind == "thrust" else "RCOU"), motor_kind=kind,
        thrust_curve=0.65, esc_rpm=Series(ta, 8000 + 100 * np.sin(np.outer(ta, [1.0, 2.0, 3.0, 4.0])), "sim"),
        velocity=Series(ta, 0.5 * np.cos(np.outer(ta, [0.2, 0.3, 0.1])), "sim"),
        armed=[(1.0, duration - 1.0)], airborne=[(3.0, duration - 3.0)], t_start=0.0, t_end=duration,
        params={"MOT_SPIN_MIN": 0.15, "ATC_RAT_RLL_P": 0.135},
    )


def interp_cols(t, series):
    return np.column_stack([np.interp(t, series.t, series.values[:, k]) for k in range(series.values.shape[1])])


def test_thrust_flight_round_trip(tmp_path):
    f = synthetic_flight()
    p = write_dataflash(f, tmp_path / "sim.bin")
    assert sniff_format(p) == "dataflash"
    g = load_flight(p)
    assert g.autopilot == "ardupilot" and g.firmware == WRITER_FIRMWARE
    assert g.frame.name == "quad_x" and g.vehicle_type == "quadrotor"
    assert g.warnings == []
    # motors: RATE mixer inverted then re-applied, float32 precision, same timestamps
    assert g.motor_kind == "thrust" and g.motors.source.startswith("RATE mixer")
    np.testing.assert_allclose(g.motors.t, f.motors.t, atol=1e-6)
    np.testing.assert_allclose(g.motors.values, f.motors.values, atol=1e-6)
    # RCOU at ~10 Hz through MOT_THST_EXPO, 1 µs PWM precision
    rcou = g.alt_motors["RCOU"]
    assert 9 <= rcou.rate_hz <= 11
    expected = thrust_to_signal(interp_cols(rcou.t, f.motors), 0.65)
    np.testing.assert_allclose(rcou.values, expected, atol=PWM_STEP / 2 + 1e-9)
    # RATE (400 Hz) beats IMU (250 Hz): rates are the flight's rates at the motor times
    assert g.rates.source.startswith("RATE") and g.rates.rate_hz == pytest.approx(400, rel=0.01)
    np.testing.assert_allclose(g.rates.values, interp_cols(g.rates.t, f.rates), atol=1e-5)
    np.testing.assert_allclose(g.attitude.values, f.attitude.values, atol=1e-6)
    np.testing.assert_allclose(g.esc_rpm.values, f.esc_rpm.values, atol=0.006)
    np.testing.assert_allclose(g.velocity.values, f.velocity.values, atol=1e-6)
    assert g.thrust_curve == pytest.approx(0.65, abs=1e-6)
    assert g.params["ATC_RAT_RLL_P"] == pytest.approx(0.135, abs=1e-7)
    assert g.params["FRAME_CLASS"] == 1 and g.params["FRAME_TYPE"] == 1
    assert [(a, b) for a, b in g.armed] == [pytest.approx((1.0, 19.0))]
    assert [(a, b) for a, b in g.airborne] == [pytest.approx((3.0, 17.0))]
    assert g.airborne_source.startswith("EV")
    last_sample = max(s.t[-1] for s in (f.rates, f.motors, f.attitude, f.esc_rpm, f.velocity))
    assert g.t_start == 0.0 and g.t_end == pytest.approx(last_sample, abs=1e-6)


def test_imu_faster_than_rate_gives_exact_rates(tmp_path):
    f = synthetic_flight(rate_hz=500.0, motor_hz=200.0)
    g = read_dataflash(write_dataflash(f, tmp_path / "imu_fast.bin"))
    assert g.rates.source.startswith("IMU")
    np.testing.assert_allclose(g.rates.t, f.rates.t, atol=1e-6)
    np.testing.assert_allclose(g.rates.values, f.rates.values, atol=1e-6)


def test_signal_flight_round_trip_and_plus_frame(tmp_path):
    f = synthetic_flight(kind="signal", motor_hz=50.0, frame=Frame.quad_plus())
    g = read_dataflash(write_dataflash(f, tmp_path / "plus.bin"))
    assert g.frame.name == "quad_plus" and g.frame.position(3) == "front"
    assert g.motor_kind == "signal" and g.motors.source.startswith("RCOU")
    np.testing.assert_allclose(g.motors.t, f.motors.t, atol=1e-6)
    np.testing.assert_allclose(g.motors.values, f.motors.values, atol=PWM_STEP / 2 + 1e-9)
    assert "RCOU" not in g.alt_motors


def test_alt_rcou_written_as_is_with_servo_mapping(tmp_path):
    f = synthetic_flight()
    t10 = np.arange(0.5, 20.0, 0.1)
    sig = np.column_stack([np.full(t10.size, v) for v in (0.1, 0.2, 0.3, 0.4)])
    f.alt_motors["RCOU"] = Series(t10, sig, "sim RCOU")
    # motors 1..4 on outputs 5..8
    f.params.update({f"SERVO{k}_FUNCTION": 0.0 for k in range(1, 5)})
    f.params.update({f"SERVO{k + 4}_FUNCTION": float(32 + k) for k in range(1, 5)})
    p = write_dataflash(f, tmp_path / "alt.bin")
    g = read_dataflash(p)
    rcou = g.alt_motors["RCOU"]
    assert "C5,C6,C7,C8" in rcou.source
    np.testing.assert_allclose(rcou.values, sig, atol=1e-9)
    from flightlog_fd.logs.dataflash import read_tables

    raw = read_tables(p, ["RCOU"])["RCOU"].columns
    assert raw["C5"][0] == 1100 and raw["C8"][0] == 1400 and raw["C1"][0] == 0


def test_pymavlink_reads_written_log(tmp_path):
    from pymavlink import mavutil

    f = synthetic_flight(duration=6.0)
    p = write_dataflash(f, tmp_path / "pm.bin")
    conn = mavutil.mavlink_connection(str(p))
    counts: dict[str, int] = {}
    first: dict[str, object] = {}
    while True:
        m = conn.recv_match()
        if m is None:
            break
        counts[m.get_type()] = counts.get(m.get_type(), 0) + 1
        first.setdefault(m.get_type(), m)
    assert counts["IMU"] == len(f.rates) and counts["RATE"] == len(f.motors)
    assert counts["ATT"] == len(f.attitude) and counts["ESC"] == 4 * len(f.esc_rpm)
    assert counts["EV"] == 4
    assert first["MSG"].Message == WRITER_FIRMWARE
    assert first["IMU"].GyrX == pytest.approx(f.rates.values[0, 0], abs=1e-6)
    assert first["IMU"].TimeUS == round(f.rates.t[0] * 1e6)
    assert conn.params["FRAME_CLASS"] == 1 and conn.params["MOT_THST_EXPO"] == pytest.approx(0.65)
    assert first["ESC"].RPM == pytest.approx(f.esc_rpm.values[0, 0], abs=0.006)


def test_written_log_truncated_keeps_prefix(tmp_path):
    f = synthetic_flight(duration=8.0)
    p = write_dataflash(f, tmp_path / "full.bin")
    data = p.read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[: len(data) // 2 + 7])
    g = read_dataflash(cut)
    assert any("truncated" in w for w in g.warnings)
    n = len(g.motors)
    assert 0 < n < len(f.motors)
    np.testing.assert_allclose(g.motors.values, f.motors.values[:n], atol=1e-6)


def test_rejects_unsupported_frame_and_negative_time(tmp_path):
    f = synthetic_flight(duration=3.0)
    f.frame = Frame("hexa", (), "test")
    with pytest.raises(ValueError, match="hexa"):
        write_dataflash(f, tmp_path / "hexa.bin")
    g = synthetic_flight(duration=3.0)
    g.rates = Series(g.rates.t - 1.0, g.rates.values, "sim")
    with pytest.raises(ValueError, match=">= 0"):
        write_dataflash(g, tmp_path / "neg.bin")


def test_real_log_round_trip(shared, tmp_path):
    src = read_dataflash(shared("real_logs", "ardupilot", "erle_copter34_7.BIN"))
    g = read_dataflash(write_dataflash(src, tmp_path / "erle.bin"))
    assert g.firmware == src.firmware  # an ArduCopter >= 3.4 line is kept
    assert g.motor_kind == "thrust"
    np.testing.assert_allclose(g.motors.values, src.motors.values, atol=1e-6)
    # RCOU PWM integers survive exactly (same RC3 range through the copied params)
    np.testing.assert_allclose(g.alt_motors["RCOU"].values, src.alt_motors["RCOU"].values, atol=1e-9)
    np.testing.assert_allclose(g.rates.values, src.rates.values, atol=1e-6)
    assert g.armed == [pytest.approx(src.armed[0], abs=1e-6)]
    assert g.airborne_s == pytest.approx(src.airborne_s, abs=3.0)
