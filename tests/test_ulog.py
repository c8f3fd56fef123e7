"""PX4 ULog reader on real third-party logs (../shared; skipped when absent) and on damaged files.

Checks values, not just loading: units (rad/s, via the Euler kinematics of the logged attitude),
motor numbering (the weakened motor of labelled flights runs hardest), stream rates, airborne time
against the manifests, frames and vehicle types, armed-but-grounded handling, truncation.
"""
from __future__ import annotations

import contextlib
import io

import numpy as np
import pandas as pd
import pytest

from flightlog_fd.errors import CorruptLogError, FlightLogError, NotALogError
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.ulog import (
    intersect_intervals, quaternion_to_euler, read_ulog, read_ulog_truth, state_intervals,
)

PX4 = ("real_logs", "px4")


def _manifest(shared, folder: str) -> pd.DataFrame:
    return pd.read_csv(shared(folder, "manifest.csv"))


def _euler_rate_slopes(flight, t0: float, t1: float, chunk_s: float = 0.5) -> tuple[float, float]:
    """Least-squares slopes of the (roll, yaw) change over ``chunk_s`` chunks from the attitude
    against the same changes integrated from the body rates p, q, r through the Euler kinematics:
    1.0 when rates are rad/s in FRD (integrating first keeps gyro noise out of the slope)."""
    att = flight.attitude.between(t0, t1)
    t = att.t
    roll, pitch, yaw = att.values[:, 0], att.values[:, 1], np.unwrap(att.values[:, 2])
    p, q, r = (np.interp(t, flight.rates.t, flight.rates.values[:, i]) for i in range(3))
    roll_dot = p + (q * np.sin(roll) + r * np.cos(roll)) * np.tan(pitch)
    yaw_dot = (q * np.sin(roll) + r * np.cos(roll)) / np.cos(pitch)
    edges = np.searchsorted(t, np.arange(t[0], t[-1], chunk_s))
    slopes = []
    for angle, rate in ((roll, roll_dot), (yaw, yaw_dot)):
        integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
        predicted, measured = np.diff(integral[edges]), np.diff(angle[edges])
        slopes.append(float(np.dot(predicted, measured) / np.dot(predicted, predicted)))
    return slopes[0], slopes[1]


# ---------------------------------------------------------------- real_logs/px4


def test_px4_events_new_topic_set(shared):
    f = read_ulog(shared(*PX4, "sample_px4_events.ulg"))
    assert f.autopilot == "px4" and f.vehicle_type == "quadrotor"
    assert f.firmware.startswith("PX4 v1.15.0")
    assert f.frame.name == "quad_x" and f.frame.source.startswith("CA_ROTOR_COUNT=4")
    # CA_ROTOR0 is (+0.1515, +0.245): motor 1 front-right, CCW; CA_ROTOR2 front-left CW
    assert f.frame.rotors[0].x == pytest.approx(0.1515, abs=1e-4) and f.frame.rotors[0].y == pytest.approx(0.245, abs=1e-4)
    assert [r.spin for r in f.frame.rotors] == [1, 1, -1, -1]
    assert f.frame.position(1) == "front-right" and f.frame.position(3) == "front-left"
    assert f.motor_kind == "thrust" and f.motors.source.startswith("actuator_motors")
    assert f.motors.values.shape[1] == 4 and not np.isnan(f.motors.values).any()
    assert f.motors.rate_hz == pytest.approx(10.0, rel=0.02)
    assert 0.0 <= f.motors.values.min() and f.motors.values.max() <= 1.0
    assert f.rates.source == "vehicle_angular_velocity.xyz" and f.rates.rate_hz == pytest.approx(50.0, rel=0.02)
    assert f.thrust_curve == 0.0
    # THR_MDL_FAC = 0: the PWM signal equals the thrust setpoint (to 1 µs of PWM resolution)
    alt = f.alt_motors["actuator_outputs"]
    assert np.array_equal(alt.t, f.motors.t)
    airborne = np.concatenate([np.flatnonzero((f.motors.t > a) & (f.motors.t < b)) for a, b in f.airborne])
    assert np.abs(alt.values[airborne] - f.motors.values[airborne]).max() < 2e-3
    assert f.esc_rpm is not None and f.esc_rpm.values.shape[1] == 4
    hover_rpm = f.esc_rpm.between(*f.airborne[0]).values
    assert 2500 < np.median(hover_rpm) < 4000
    assert len(f.armed) == 1 and f.armed[0][1] - f.armed[0][0] == pytest.approx(15.204, abs=0.01)
    assert f.airborne_source == "vehicle_land_detected.landed"
    assert f.airborne_s == pytest.approx(11.392, abs=0.01)
    assert f.t_start == pytest.approx(1710773350.346) and f.duration_s == pytest.approx(31.136, abs=0.01)
    assert f.warnings == []


def test_sample_old_format_never_airborne(shared):
    f = read_ulog(shared(*PX4, "sample.ulg"))
    assert f.vehicle_type == "quadrotor" and f.frame.name == "quad_x" and f.vehicle_id == "AUAV_X21"
    assert f.rates.source == "sensor_combined.gyro_rad" and f.rates.rate_hz == pytest.approx(250.0, rel=0.01)
    assert f.attitude.source == "vehicle_attitude.q"
    # on the bench: gyro noise only, well below 0.2 rad/s (it would be ~57x larger in deg/s)
    assert np.median(np.abs(f.rates.values)) < 0.05
    assert f.motor_kind == "signal" and "1075..1950 (PWM_MIN/PWM_MAX)" in f.motors.source  # legacy names
    assert np.all(f.motors.values == 0.0)  # 900 µs disarmed output is below PWM_MIN
    assert f.armed == [] and f.airborne == []
    assert any("dropouts" in w for w in f.warnings)


def test_appended_multiple_instances(shared):
    path = shared(*PX4, "sample_appended_multiple.ulg")
    from pyulog import ULog

    with contextlib.redirect_stdout(io.StringIO()):
        raw = ULog(str(path), ["actuator_outputs"])
    assert raw.has_data_appended and len(raw.data_list) == 2
    f = read_ulog(path)
    assert f.vehicle_id == "0035002B3434511732343031" and f.frame.name == "quad_x"
    # instance 0 is the main output (disarmed 900 µs on 8 channels); instance 1 (4 x 1500 µs) is AUX
    assert "instance" not in f.motors.source and np.all(f.motors.values == 0.0)
    assert f.armed == [] and f.airborne == [] and f.airborne_source == "vehicle_land_detected.landed"
    assert np.all(np.diff(f.rates.t) >= 0)
    assert f.t_end == pytest.approx(21.88, abs=0.01)


def test_vtol_loads_and_says_so(shared):
    f = read_ulog(shared(*PX4, "sample_log_small.ulg"))
    assert f.vehicle_type == "vtol" and f.frame.name == "vtol" and not f.frame.is_quad
    assert f.rates.rate_hz == pytest.approx(404, rel=0.02)
    assert f.armed and f.armed[0][1] - f.armed[0][0] == pytest.approx(5.609, abs=0.01)


def test_tagged_logging_legacy_mixer(shared):
    f = read_ulog(shared(*PX4, "sample_logging_tagged_and_default_params.ulg"))
    assert f.vehicle_type == "quadrotor" and f.frame.name == "quad_x"
    assert f.frame.source.startswith("SYS_AUTOSTART 10016")
    assert f.params["SYS_CTRL_ALLOC"] == 0.0 and f.params["PWM_MAIN_MIN"] == 1075.0
    assert f.rates.rate_hz == pytest.approx(125.0, rel=0.01) and f.motors.rate_hz == pytest.approx(10.0, rel=0.01)
    assert f.armed == [] and f.airborne == []


def test_robologs_armed_on_ground_is_not_airborne(shared):
    f = read_ulog(shared(*PX4, "robologs_f450_ground.ulg"))
    assert f.vehicle_type == "quadrotor" and f.frame.name == "quad_x"
    assert f.vehicle_id == "000200000000353338373138511600380018"
    assert len(f.armed) == 1 and f.armed[0][1] - f.armed[0][0] == pytest.approx(8.188, abs=0.01)
    # the land detector flips to "not landed" twice while the pilot runs the motors up; the
    # altitude never rises 0.3 m, so neither counts as flight
    assert f.airborne == [] and f.airborne_s == 0.0
    assert sum("treated as on the ground" in w for w in f.warnings) == 2
    assert "1230..1950 (PWM_MAIN_MIN/PWM_MAIN_MAX)" in f.motors.source
    assert f.motors.values.max() == pytest.approx((1500 - 1230) / (1950 - 1230), abs=1e-6)
    assert f.esc_rpm is None  # esc_status is published but all zero: no ESC telemetry


@pytest.mark.parametrize("case", [1, 3, 5, 7])
def test_rflymad_motor1_loss(shared, case):
    """RflyMAD SIL: motor 1 loses efficiency at the time rfly_ctrl_lxl.mode turns 1."""
    import glob

    paths = glob.glob(str(shared(*PX4, "rflymad_sil")) + f"/TestCase_{case}_*.ulg")
    assert len(paths) == 1
    f = read_ulog(paths[0])
    assert f.vehicle_type == "quadrotor" and f.frame.name == "quad_x"
    assert any("quad-X numbering assumed" in w for w in f.warnings)  # SYS_AUTOSTART 3010
    assert f.motor_kind == "signal" and f.motors.rate_hz == pytest.approx(10.0, rel=0.01)
    # SIL timestamps jitter by a millisecond around 10 ms: the median interval is 9-11 ms
    assert f.rates.rate_hz == pytest.approx(100.0, rel=0.12)
    assert len(f.airborne) == 1 and 20.0 < f.airborne_s < 24.0
    from pyulog import ULog

    with contextlib.redirect_stdout(io.StringIO()):
        truth = ULog(paths[0], ["rfly_ctrl_lxl"]).data_list[0].data
    onset = truth["timestamp"][truth["mode"] == 1][0] / 1e6
    a, b = f.airborne[0]
    before = f.motors.between(a + 2.0, onset - 1.0).values.mean(axis=0)
    after = f.motors.between(onset + 0.5, b).values.mean(axis=0)
    assert np.ptp(before) < 0.01  # healthy hover: the four commands agree
    assert np.argmax(after) == 0 and after[0] > after[1:].max() + 0.2


def test_sih_stream_rates_and_airborne_match_manifest(shared):
    man = _manifest(shared, "px4_sih_dev").set_index("name")
    for name in ("sih_005", "sih_008", "sih_034"):
        row = man.loc[name]
        f = read_ulog(shared("px4_sih_dev", "logs", f"{name}.ulg"))
        assert f.frame.name == "quad_x" and f.motor_kind == "thrust"
        assert round(f.t_start * 1e6) == row["log_start_us"]
        assert len(f.airborne) == 1
        a, b = f.airborne[0]
        assert a - f.t_start == pytest.approx(row["takeoff_s"], abs=0.15)
        assert b - f.t_start == pytest.approx(row["touchdown_s"], abs=0.15)
        assert f.airborne_s == pytest.approx(row["airborne_s"], abs=0.2)
        assert f.motors.rate_hz == pytest.approx(row["rate_actuator_motors_hz"], rel=0.03)
        assert f.rates.rate_hz == pytest.approx(row["rate_vehicle_angular_velocity_hz"], rel=0.03)
        # motor numbering: the weakened motor needs the largest command once damaged
        onset = a
        if row["fault_onset_s"] > 0:  # mid-flight onset: both manifest columns name the same instant
            onset = row["fault_onset_boot_us"] / 1e6
            assert onset == pytest.approx(f.t_start + row["fault_onset_s"], abs=1e-3)
        means = f.motors.between(max(a, onset) + 2.0, b - 3.0).values.mean(axis=0)
        if row["faulty_motor"] == 0:
            assert np.ptp(means) < 0.02
        else:
            assert np.argmax(means) + 1 == row["faulty_motor"] and np.ptp(means) > 0.04


def test_sih_rates_are_rad_s_frd(shared):
    f = read_ulog(shared("px4_sih_dev", "logs", "sih_004.ulg"))
    a, b = f.airborne[0]
    roll_slope, yaw_slope = _euler_rate_slopes(f, a + 2.0, b - 2.0)
    assert roll_slope == pytest.approx(1.0, abs=0.05)
    assert yaw_slope == pytest.approx(1.0, abs=0.05)


def test_crazypad_quad_x_motor2_hardest(shared):
    man = _manifest(shared, "crazypad_e9")
    healthy = man[man["damage_kind"] == "none"].iloc[0]
    f = read_ulog(shared("crazypad_e9", "ulog", healthy["file"]))
    assert f.frame.name == "quad_x" and f.vehicle_id == "CRAZYFLIE21"
    assert f.rates.rate_hz == pytest.approx(100.0, rel=0.02)
    assert f.motors.rate_hz == pytest.approx(100.0, rel=0.02)
    # landed / armed follow "motors on" in these converted logs, so the airborne time includes the
    # motor spin-up on the ground: a little more than the manifest's flight time, never less
    assert len(f.airborne) == 2
    assert healthy["airborne_s"] - 0.2 < f.airborne_s < healthy["airborne_s"] + 2.5
    hover = np.concatenate([f.motors.between(a + 1.0, b - 1.0).values for a, b in f.airborne])
    means = hover.mean(axis=0)
    assert np.argmax(means) == 1  # PX4 motor 2, even when healthy (README: yaw trim)


def test_every_px4_real_log_loads(shared):
    folder = shared(*PX4)
    paths = sorted(folder.glob("*.ulg")) + sorted((folder / "rflymad_sil").glob("*.ulg"))
    assert len(paths) >= 10
    for p in paths:
        f = load_flight(p)
        assert f.autopilot == "px4" and f.rates is not None and f.t_end > f.t_start
        assert f.rates.values.shape[1] == 3 and np.all(np.diff(f.rates.t) >= 0)
        for a, b in f.airborne:
            assert any(x <= a and b <= y for x, y in f.armed)


# ---------------------------------------------------------------- damaged files


def test_truncated_real_log_loads_with_warning(shared, tmp_path):
    src = shared("px4_sih_dev", "logs", "sih_008.ulg")
    full = read_ulog(src)
    data = src.read_bytes()
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(data[: len(data) // 2 + 7])
    f = read_ulog(cut)
    assert any("truncated" in w for w in f.warnings)
    assert full.t_start < f.t_end < full.t_end - 10.0
    n = len(f.rates)
    assert 0 < n < len(full.rates)
    assert np.array_equal(f.rates.t, full.rates.t[:n]) and np.array_equal(f.rates.values, full.rates.values[:n])
    assert f.rates.t[-1] <= f.t_end
    # armed at the cut: the interval runs to the last data
    assert f.armed[-1][1] == pytest.approx(f.t_end)


def test_cut_in_definitions_raises(shared, tmp_path):
    data = shared("px4_sih_dev", "logs", "sih_008.ulg").read_bytes()
    cut = tmp_path / "head.ulg"
    cut.write_bytes(data[:3000])
    with pytest.raises(CorruptLogError, match="truncated"):
        read_ulog(cut)


def test_corrupted_bytes_never_leak(shared, tmp_path):
    data = bytearray(shared(*PX4, "robologs_f450_ground.ulg").read_bytes())
    rng = np.random.default_rng(7)
    for i in range(6):
        b = np.frombuffer(bytes(data), dtype=np.uint8).copy()
        idx = rng.integers(16, len(b), 40)
        b[idx] = rng.integers(0, 256, 40)
        p = tmp_path / f"bad{i}.ulg"
        p.write_bytes(b.tobytes())
        try:
            f = read_ulog(p)
        except FlightLogError:
            continue
        assert f.t_end >= f.t_start
        for s in (f.rates, f.motors, f.attitude):
            assert s is None or np.all(np.diff(s.t) >= 0)


@pytest.mark.parametrize("content,error", [
    (b"not a log at all, just text\n", NotALogError),
    (b"ULog\x01\x12\x36\x01" + bytes(8), CorruptLogError),  # damaged magic
    (b"ULog\x01\x12\x35\x01" + bytes(8), CorruptLogError),  # header only
])
def test_bad_files_raise_clear_errors(tmp_path, content, error):
    p = tmp_path / "x.ulg"
    p.write_bytes(content)
    with pytest.raises(error) as e:
        load_flight(p) if error is NotALogError else read_ulog(p)
    assert e.value.path == str(p) and "\n" not in e.value.message


def test_truth_reader_on_real_log_is_none(shared):
    assert read_ulog_truth(shared(*PX4, "sample_px4_events.ulg")) is None


# ---------------------------------------------------------------- helpers


def test_quaternion_to_euler_known_rotations():
    half = np.deg2rad(30.0) / 2
    q = np.array([[1, 0, 0, 0],
                  [np.cos(half), np.sin(half), 0, 0],  # roll 30°
                  [np.cos(half), 0, np.sin(half), 0],  # pitch 30°
                  [np.cos(half), 0, 0, np.sin(half)]])  # yaw 30°
    e = np.rad2deg(quaternion_to_euler(q))
    np.testing.assert_allclose(e, [[0, 0, 0], [30, 0, 0], [0, 30, 0], [0, 0, 30]], atol=1e-9)


def test_state_intervals_and_intersection():
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    s = np.array([False, True, True, False, True])
    assert state_intervals(t, s, 6.0) == [(1.0, 3.0), (4.0, 6.0)]
    assert intersect_intervals([(1.0, 3.0), (4.0, 6.0)], [(2.0, 5.0)]) == [(2.0, 3.0), (4.0, 5.0)]
