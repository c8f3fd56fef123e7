"""read_dataflash on the real ArduPilot logs in ../shared/real_logs/ardupilot and on damaged copies.

Checks values, not just loading: columns equal pymavlink's own recv_match decoding, RATE's deg/s
converted to rad/s agree with the IMU gyro, the RATE-mixer motors match RCOU motor by motor
(proves motor order and mixer signs), airborne time agrees with the throttle trace, old field
names, timeless messages, truncation and corruption give warnings or FlightLogErrors.
"""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.errors import CorruptLogError, FlightLogError, NotALogError
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.dataflash import (
    mix,
    mixer_factors,
    parse_firmware,
    rate_sources,
    read_dataflash,
    read_tables,
    signal_to_thrust,
    thrust_to_signal,
)

ERLE_34 = ("erle_copter34_7.BIN", "erle_copter34_22.BIN")


def ap_log(shared, name):
    return shared("real_logs", "ardupilot", name)


def _airborne_mask(t, intervals):
    m = np.zeros(t.shape, dtype=bool)
    for a, b in intervals:
        m |= (t >= a) & (t <= b)
    return m


# --- pure helpers (no shared data) ----------------------------------------------------------

def test_quad_x_mixer_factors_are_arducopter_normalised():
    fac = mixer_factors(1, 1)
    # motor 1 front-right CCW: roll -, pitch +, yaw +; all magnitudes 0.5
    np.testing.assert_allclose(fac, [[-0.5, 0.5, 0.5], [0.5, -0.5, 0.5], [0.5, 0.5, -0.5], [-0.5, -0.5, -0.5]],
                               atol=1e-12)
    plus = mixer_factors(1, 0)
    # motor 1 right: pure roll; motor 3 front: pure pitch
    np.testing.assert_allclose(plus[0], [-0.5, 0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(plus[2], [0.0, 0.5, -0.5], atol=1e-12)
    assert mixer_factors(7, 0) is None  # tricopter: no matrix layout


def test_mix_is_collective_plus_differential_and_clipped():
    fac = mixer_factors(1, 1)
    out = mix(np.array([0.4, 0.99]), np.array([0.1, 0.0]), np.array([0.0, 0.0]), np.array([0.0, 0.1]), fac)
    np.testing.assert_allclose(out[0], [0.35, 0.45, 0.45, 0.35])
    np.testing.assert_allclose(out[1], [1.0, 1.0, 0.94, 0.94])  # 1.04 clipped


def test_thrust_curve_inverse_round_trip():
    thrust = np.linspace(0, 1, 11)
    for expo in (0.0, 0.5, 0.65, 1.0):
        np.testing.assert_allclose(signal_to_thrust(thrust_to_signal(thrust, expo), expo), thrust, atol=1e-12)
    # expo 0.65: half thrust needs more than half signal (thrust ~ signal^2 for expo 1)
    # s = (expo - 1 + sqrt((1 - expo)^2 + 4 expo T)) / (2 expo) = (-0.35 + sqrt(1.4225)) / 1.3
    assert thrust_to_signal(np.array([0.5]), 0.65)[0] == pytest.approx(0.64822, abs=1e-5)


def test_parse_firmware_versions():
    assert parse_firmware("APM:Copter V3.4-rc2 (f46a31d0)") == (3, 4, 0)
    assert parse_firmware("ArduCopter V4.6.2 (1ebd4d99)") == (4, 6, 2)
    assert parse_firmware("ArduCopter V3.3-dev (7f383fac)") == (3, 3, 0)
    assert parse_firmware("PX4 v1.14") is None


def test_not_a_log_and_empty(tmp_path):
    text = tmp_path / "notes.bin"
    text.write_text("hello\n" * 20)
    with pytest.raises(NotALogError, match="not an ArduPilot DataFlash"):
        read_dataflash(text)
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    with pytest.raises(NotALogError, match="empty"):
        read_dataflash(empty)
    with pytest.raises(NotALogError, match="no such file"):
        read_dataflash(tmp_path / "missing.bin")


# --- real logs ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ERLE_34)
def test_erle_copter34_quad_x_rate_mixer_and_rcou(shared, name):
    f = read_dataflash(ap_log(shared, name))
    assert f.autopilot == "ardupilot"
    assert "V3.4-rc2" in f.firmware
    assert f.vehicle_type == "quadrotor"
    assert f.frame.name == "quad_x" and f.frame.is_quad
    assert "FRAME=1" in f.frame.source
    assert f.frame.position(1) == "front-right" and f.frame.rotors[0].spin == 1
    # RATE (~20 Hz) is faster than RCOU (~10 Hz): motors rebuilt through the mixer
    assert f.motor_kind == "thrust" and f.motors.source.startswith("RATE mixer")
    assert 20 <= f.motors.rate_hz <= 26
    rcou = f.alt_motors["RCOU"]
    assert 9 <= rcou.rate_hz <= 11
    # MOT_PWM_MIN/MAX are 0 in these logs: the throttle channel's radio range is used
    assert "RC3_MIN/MAX" in rcou.source and "outputs 1..n" in rcou.source
    assert f.motors.values.shape[1] == 4 and rcou.values.shape[1] == 4
    assert f.motors.values.min() >= 0 and f.motors.values.max() <= 1
    assert f.thrust_curve == pytest.approx(0.5)
    assert f.params["MOT_THST_EXPO"] == pytest.approx(0.5)
    assert len(f.params) > 500
    assert f.attitude.values.shape[1] == 3 and np.abs(f.attitude.values[:, :2]).max() < np.radians(60)
    assert f.velocity is not None and f.velocity.source.startswith("NKF1")
    assert f.warnings == []


def test_rate_degrees_converted_to_rad_s_match_imu_gyro(shared):
    p = ap_log(shared, "erle_copter34_7.BIN")
    tables = read_tables(p, ["RATE", "IMU"])
    streams = {s.source.split(".")[0]: s for s in rate_sources(tables, (3, 4, 0))}
    rate, imu = streams["RATE"], streams["IMU"]
    assert "deg/s -> rad/s" in rate.source
    imu_on_rate = np.column_stack([np.interp(rate.t, imu.t, imu.values[:, k]) for k in range(3)])
    for k in range(3):
        slope = float(np.dot(imu_on_rate[:, k], rate.values[:, k]) / np.dot(rate.values[:, k], rate.values[:, k]))
        assert slope == pytest.approx(1.0, abs=0.1), f"axis {k}: RATE/IMU scale {slope}"
        assert np.corrcoef(imu_on_rate[:, k], rate.values[:, k])[0, 1] > 0.9
    # the flight really rotates (not a trivially zero comparison): rad/s-sized signals
    assert 0.02 < np.std(rate.values[:, 0]) < 2.0


@pytest.mark.parametrize("name", ERLE_34)
def test_rate_mixer_matches_rcou_motor_by_motor(shared, name):
    """Thrust recovered from RCOU (spin min/max and MOT_THST_EXPO undone) correlates with the
    RATE-mixer thrust of the *same* motor best: motor order and mixer signs are right."""
    f = read_dataflash(ap_log(shared, name))
    p, rcou = f.params, f.alt_motors["RCOU"]
    actuator = np.clip((rcou.values - p["MOT_SPIN_MIN"]) / (p["MOT_SPIN_MAX"] - p["MOT_SPIN_MIN"]), 0, 1)
    thrust_rcou = signal_to_thrust(actuator, p["MOT_THST_EXPO"])
    mixed = np.column_stack([np.interp(rcou.t, f.motors.t, f.motors.values[:, k]) for k in range(4)])
    m = _airborne_mask(rcou.t, f.airborne)
    assert m.sum() > 500
    d_rcou = thrust_rcou[m] - thrust_rcou[m].mean(axis=1, keepdims=True)
    d_mix = mixed[m] - mixed[m].mean(axis=1, keepdims=True)
    corr = np.corrcoef(d_mix.T, d_rcou.T)[:4, 4:]
    assert list(np.argmax(corr, axis=1)) == [0, 1, 2, 3]
    assert np.diag(corr).min() > 0.8
    for k in range(4):
        assert np.corrcoef(thrust_rcou[m, k], mixed[m, k])[0, 1] > 0.85


def test_erle_copter34_7_armed_and_airborne_plausible(shared):
    f = read_dataflash(ap_log(shared, "erle_copter34_7.BIN"))
    assert f.t_start == pytest.approx(23.21, abs=0.01) and f.t_end == pytest.approx(126.97, abs=0.01)
    assert f.armed == [(pytest.approx(23.214322), pytest.approx(126.972055))]
    assert f.airborne_source.startswith("EV") and "CTUN.ThO" in f.airborne_source
    assert 70 < f.airborne_s < 90
    (a, b), = f.airborne
    assert 40.4 <= a < 45 and 115 < b <= 126.98
    # the throttle is near hover inside and near idle outside
    ctun = read_tables(ap_log(shared, "erle_copter34_7.BIN"), ["CTUN"])["CTUN"]
    inside = _airborne_mask(ctun.t, f.airborne)
    assert np.median(ctun.columns["ThO"][inside]) > 0.25
    assert np.median(ctun.columns["ThO"][~inside]) < 0.1


def test_erle_copter34_22_ev_not_landed_at_idle_is_not_airborne(shared):
    f = read_dataflash(ap_log(shared, "erle_copter34_22.BIN"))
    assert len(f.armed) == 2
    # EV NOT_LANDED at 18.8 s with the throttle at ~1 % until disarm at 37.6 s: not a flight
    assert all(a > 100 for a, _ in f.airborne)
    assert 90 < f.airborne_s < 125
    assert all(any(a0 <= a and b <= a1 for a0, a1 in f.armed) for a, b in f.airborne)


def test_erle_copter33_old_field_names_no_rate(shared):
    f = read_dataflash(ap_log(shared, "erle_copter33_73.BIN"))
    assert "V3.3" in f.firmware
    assert f.rates.source.startswith("IMU") and 45 < f.rates.rate_hz < 55
    assert f.motor_kind == "signal" and "RCOU.Ch1,Ch2,Ch3,Ch4" in f.motors.source
    assert f.alt_motors == {}
    assert f.frame.name == "quad_x"
    assert f.thrust_curve is None and any("MOT_THST_EXPO" in w for w in f.warnings)
    # TimeMS clock in seconds
    assert f.t_start == pytest.approx(111.389) and f.t_end == pytest.approx(299.402)
    # EV has no time field: arm events take the time of the samples around them; logging
    # stopped while disarmed, so an arm right before a gap belongs after it
    assert [round(a, 2) for a, _ in f.armed] == [111.39, 161.53, 274.11]
    assert f.armed[0][1] < 161.53
    # no LAND_COMPLETE in 3.3: the throttle decides, and finds three flights' worth
    assert f.airborne_source.startswith("throttle fallback")
    assert 60 < f.airborne_s < 100
    assert f.motors.values[_airborne_mask(f.motors.t, f.airborne)].mean() > 0.4


def test_arducopter46_truncated_loads_with_warning(shared):
    f = load_flight(ap_log(shared, "arducopter46_truncated_80k.bin"))
    assert any("truncated" in w for w in f.warnings)
    assert f.firmware.startswith("ArduCopter V4.6.2")
    assert f.vehicle_id == "Pixhawk4 0047002B 34385105 36363539"
    assert f.frame.name == "quad_x" and "FRAME_CLASS=1, FRAME_TYPE=1" in f.frame.source
    assert len(f.params) > 1000
    assert f.thrust_curve == pytest.approx(f.params["MOT_THST_EXPO"])
    # RATE and RCOU both ~10 Hz here: no mixer, RCOU mapped through SERVOn_FUNCTION
    assert f.motor_kind == "signal" and "SERVOn_FUNCTION" in f.motors.source
    assert f.airborne == []  # still on the ground when the file was cut


def test_truncated_copy_keeps_prefix(shared, tmp_path):
    src = ap_log(shared, "erle_copter34_7.BIN").read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(src[:800_001])  # inside a message
    full = read_dataflash(ap_log(shared, "erle_copter34_7.BIN"))
    part = read_dataflash(cut)
    assert any("truncated" in w and "800001" in w for w in part.warnings)
    n = len(part.rates)
    assert 0 < n < len(full.rates)
    np.testing.assert_array_equal(part.rates.values, full.rates.values[:n])
    np.testing.assert_array_equal(part.rates.t, full.rates.t[:n])


def test_damaged_middle_skipped_with_warning(shared, tmp_path):
    src = ap_log(shared, "erle_copter34_7.BIN").read_bytes()
    bad = tmp_path / "bad.bin"
    bad.write_bytes(src[:700_000] + bytes(4096) + src[700_000:])
    f = read_dataflash(bad)
    assert any("4096 bytes of unreadable data skipped" in w for w in f.warnings)
    full = read_dataflash(ap_log(shared, "erle_copter34_7.BIN"))
    assert abs(len(f.rates) - len(full.rates)) <= 1


def test_header_without_data_is_corrupt(shared, tmp_path):
    src = ap_log(shared, "erle_copter34_7.BIN").read_bytes()
    p = tmp_path / "fmt_only.bin"
    p.write_bytes(src[:89] + bytes(range(256)) * 8)
    with pytest.raises(CorruptLogError, match="no data messages"):
        read_dataflash(p)
    with pytest.raises(FlightLogError):
        load_flight(p)


@pytest.mark.parametrize("name,types", [
    ("erle_copter34_7.BIN", ["RATE", "RCOU", "ATT", "EV", "PARM", "NKF1"]),
    ("erle_copter33_73.BIN", ["RCOU", "ATT", "EV", "MSG"]),
])
def test_columns_equal_pymavlink_recv_match(shared, name, types):
    from pymavlink import mavutil

    p = ap_log(shared, name)
    ours = read_tables(p, types)
    conn = mavutil.mavlink_connection(str(p))
    ref: dict[str, list[dict]] = {t: [] for t in types}
    while True:
        m = conn.recv_match(type=types)
        if m is None:
            break
        ref[m.get_type()].append(m.to_dict())
    for t in types:
        assert len(ours[t]) == len(ref[t]) > 0, t
        for col in ref[t][0]:
            if col == "mavpackettype":
                continue
            expected = [d[col] for d in ref[t]]
            if isinstance(expected[0], str):
                assert list(ours[t].columns[col]) == expected, (t, col)
            else:
                # bit-identical, including the c/C/e/E/L scaling
                np.testing.assert_array_equal(ours[t].columns[col], np.asarray(expected, dtype=np.float64),
                                              err_msg=f"{t}.{col}")


def test_crafted_log_arm_messages_gyr_and_no_rcou(tmp_path):
    """A modern-style log with ARM (no EV), raw GYR faster than IMU, and no RCOU/RATE."""
    from flightlog_fd.logs.dataflash_writer import FMT, IMU, MSG, PARM, _block, _Format, _merge

    arm = _Format(140, "ARM", "QBIBB", ("TimeUS", "ArmState", "ArmChecks", "Forced", "Method"))
    gyr = _Format(141, "GYR", "QBQfff", ("TimeUS", "I", "SampleUS", "GyrX", "GyrY", "GyrZ"))
    t_imu = np.arange(2.0, 12.0, 1 / 50)
    t_gyr = np.arange(2.0, 12.0, 1 / 1000)
    us = lambda t: np.round(np.asarray(t) * 1e6).astype(np.uint64)  # noqa: E731
    blocks = [
        _block(FMT, np.zeros(5, np.uint64), phase=0, Type=[f.type_id for f in (FMT, PARM, MSG, arm, gyr)],
               Length=[f.length for f in (FMT, PARM, MSG, arm, gyr)],
               Name=[f.name.encode() for f in (FMT, PARM, MSG, arm, gyr)],
               Format=[f.format.encode() for f in (FMT, PARM, MSG, arm, gyr)],
               Columns=[",".join(f.columns).encode() for f in (FMT, PARM, MSG, arm, gyr)]),
        _block(FMT, np.zeros(1, np.uint64), phase=0, Type=[IMU.type_id], Length=[IMU.length],
               Name=[b"IMU"], Format=[IMU.format.encode()], Columns=[",".join(IMU.columns).encode()]),
        _block(PARM, us([2.0, 2.0]), phase=0, Name=[b"FRAME_CLASS", b"FRAME_TYPE"], Value=[1.0, 0.0]),
        _block(MSG, us([2.0]), phase=0, Message=[b"ArduCopter V4.5.7 (crafted)"]),
        _block(IMU, us(t_imu), I=np.zeros(t_imu.size, np.uint8), GyrX=np.full(t_imu.size, 0.1),
               GyrY=np.zeros(t_imu.size), GyrZ=np.zeros(t_imu.size)),
        _block(gyr, us(t_gyr), I=np.zeros(t_gyr.size, np.uint8), SampleUS=us(t_gyr - 0.0005),
               GyrX=np.sin(t_gyr), GyrY=np.zeros(t_gyr.size), GyrZ=np.zeros(t_gyr.size)),
        _block(arm, us([3.0, 9.0]), ArmState=[1, 0], ArmChecks=[0, 0], Forced=[0, 0], Method=[0, 0]),
    ]
    p = tmp_path / "crafted.bin"
    _merge(blocks).tofile(p)
    f = read_dataflash(p)
    assert f.armed == [(pytest.approx(3.0), pytest.approx(9.0))]
    assert f.motors is None and f.alt_motors == {}
    assert any("no motor outputs" in w for w in f.warnings)
    assert f.frame.name == "quad_plus"
    # GYR (1 kHz, stamped by SampleUS) beats IMU (50 Hz)
    assert f.rates.source.startswith("GYR") and f.rates.rate_hz == pytest.approx(1000, rel=0.01)
    np.testing.assert_allclose(f.rates.t, t_gyr - 0.0005, atol=1e-6)
    np.testing.assert_allclose(f.rates.values[:, 0], np.sin(t_gyr), atol=1e-6)
    assert f.airborne == [] and f.airborne_source.startswith("none")


@pytest.mark.parametrize("q_enable,expected", [(0.0, "fixed_wing"), (1.0, "vtol")])
def test_crafted_plane_logs(tmp_path, q_enable, expected):
    """ArduPlane: outputs 1..4 are surfaces, so RCOU is motors only through SERVOn_FUNCTION."""
    from flightlog_fd.logs.dataflash_writer import FMT, MSG, PARM, RCOU, _block, _merge

    fmts = (FMT, PARM, MSG, RCOU)
    t = np.arange(1.0, 5.0, 0.1)
    us = np.round(t * 1e6).astype(np.uint64)
    names = ["Q_ENABLE"] + [f"SERVO{k}_FUNCTION" for k in range(5, 9)]
    pwm = {f"C{k}": np.full(t.size, 1000 + 100 * k, dtype=np.uint16) for k in range(1, 9)}
    blocks = [
        _block(FMT, np.zeros(len(fmts), np.uint64), phase=0, Type=[f.type_id for f in fmts],
               Length=[f.length for f in fmts], Name=[f.name.encode() for f in fmts],
               Format=[f.format.encode() for f in fmts], Columns=[",".join(f.columns).encode() for f in fmts]),
        _block(PARM, np.full(5, us[0]), phase=0, Name=[n.encode() for n in names],
               Value=[q_enable, 33.0, 34.0, 35.0, 36.0]),
        _block(MSG, us[:1], phase=0, Message=[b"ArduPlane V4.5.0 (crafted)"]),
        _block(RCOU, us, **pwm),
    ]
    p = tmp_path / "plane.bin"
    _merge(blocks).tofile(p)
    f = read_dataflash(p)
    assert f.vehicle_type == expected and f.frame.name == expected and not f.frame.is_quad
    # the SERVO5..8 lift motors: PWM 1500..1800 over the default 1000..2000
    assert f.motors is not None and "C5,C6,C7,C8" in f.motors.source
    np.testing.assert_allclose(f.motors.values[0], [0.5, 0.6, 0.7, 0.8])
    # without the lift-motor functions a plane has no motor outputs
    blocks[1] = _block(PARM, np.full(1, us[0]), phase=0, Name=[b"Q_ENABLE"], Value=[q_enable])
    _merge(blocks).tofile(p)
    g = read_dataflash(p)
    assert g.motors is None and any("SERVOn_FUNCTION" in w for w in g.warnings)
