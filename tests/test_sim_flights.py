"""Simulated flights end to end: stability over random airframes, missions, damage onset, logger
profiles and the `Flight` contract, determinism."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.sim.api import simulate_batch, simulate_flights
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.dynamics import quat_to_euler
from flightlog_fd.sim.logger import PROFILES, thrust_to_signal
from flightlog_fd.sim.missions import LEG_GOTO


@pytest.fixture(scope="module")
def random_batch():
    return simulate_batch(16, mission="waypoints", duration_s=35.0, profile="training", seed=21,
                          extra_streams={"pos": 10})


def test_random_airframes_stay_bounded(random_batch):
    res = random_batch.result
    for name in ("rates", "attitude", "motors", "pos"):
        assert np.isfinite(res.data[name]).all(), name
    q = res.data["attitude"].astype(np.float64)
    euler = quat_to_euler(q / np.linalg.norm(q, axis=2, keepdims=True))
    tilt = np.degrees(np.arccos(np.clip(np.cos(euler[..., 0]) * np.cos(euler[..., 1]), -1, 1)))
    assert tilt.max() < 60.0
    # Every vehicle took off and landed (disarmed) within the allowed time.
    assert np.isfinite(res.t_takeoff).all() and np.isfinite(res.t_disarm).all()
    assert (res.t_disarm > res.t_takeoff + 15.0).all()
    speed = np.linalg.norm(np.diff(res.data["pos"].astype(np.float64), axis=0), axis=2) / np.diff(
        res.times["pos"])[:, None]
    assert speed.max() < 9.0  # mission speeds are at most 5 m/s


def test_position_follows_waypoints(random_batch):
    plan, res = random_batch.plan, random_batch.result
    pos = res.data["pos"].astype(np.float64)
    for j in range(plan.n):
        goto = plan.kind[j] == LEG_GOTO
        for target in plan.target[j][goto]:
            closest = np.linalg.norm(pos[:, j] - target, axis=1).min()
            assert closest < 1.5, (j, target, closest)


def test_manual_flying_is_varied_and_bounded():
    flights = simulate_flights(4, mission="manual", duration_s=40.0, profile="training", seed=5)
    for f in flights:
        assert f.airborne and f.airborne_s > 25.0
        air = f.attitude.between(*f.airborne[0])
        roll_pitch = np.degrees(air.values[:, :2])
        assert np.abs(roll_pitch).max() < 45.0
        assert roll_pitch.std(axis=0).min() > 1.0  # the pilot moves the sticks
        yaw = np.unwrap(air.values[:, 2])
        assert np.ptp(yaw) > np.radians(20.0)  # and turns
        assert np.abs(f.velocity.values).max() < 8.0


def test_same_seed_same_flights_other_seed_different():
    a = simulate_flights(3, mission="hover", duration_s=15.0, profile="px4_default", seed=7)
    b = simulate_flights(3, mission="hover", duration_s=15.0, profile="px4_default", seed=7)
    c = simulate_flights(3, mission="hover", duration_s=15.0, profile="px4_default", seed=8)
    for fa, fb in zip(a, b):
        np.testing.assert_array_equal(fa.rates.t, fb.rates.t)
        np.testing.assert_array_equal(fa.rates.values, fb.rates.values)
        np.testing.assert_array_equal(fa.motors.values, fb.motors.values)
        assert fa.truth == fb.truth
    assert not np.array_equal(a[0].motors.values[:100], c[0].motors.values[:100]) or a[0].truth != c[0].truth


def test_midflight_onset_is_recorded_and_visible_in_commands():
    eta, onset = 0.75, 20.0
    f = simulate_flights(1, airframes="x500", damages=[Damage(2, eta, onset_s=onset)], mission="hover",
                         duration_s=45.0, profile="training", seed=3)[0]
    t0 = f.truth["log_start_boot_s"]
    assert f.truth["onset_s"] == pytest.approx(onset + t0)
    assert f.truth["label"] == 2 and f.truth["motor"] == 2 and f.truth["eta"] == eta
    on = f.truth["onset_s"]
    before = f.motors.between(f.airborne[0][0] + 8.0, on - 0.5).values
    after = f.motors.between(on + 4.0, on + 10.0).values
    ratio_before = before[:, 1].mean() / np.delete(before, 1, axis=1).mean()
    ratio_after = after[:, 1].mean() / np.delete(after, 1, axis=1).mean()
    assert ratio_before == pytest.approx(1.0, abs=0.03)
    assert ratio_after == pytest.approx(1.0 / eta, rel=0.04)


def test_damage_from_takeoff_has_no_onset_and_realistic_hover_trim():
    eta = 0.8
    f = simulate_flights(1, airframes="sih", damages=Damage(3, eta), mission="hover", duration_s=35.0,
                         profile="px4_high", seed=9)[0]
    assert f.truth["onset_s"] is None and f.truth["label"] == 3
    hover = f.motors.between(f.airborne[0][0] + 10.0, f.airborne[0][0] + 18.0).values
    assert hover[:, 2].mean() / np.delete(hover, 2, axis=1).mean() == pytest.approx(1.0 / eta, rel=0.04)
    # Hover gyro noise of the order of the PX4 SIH dev flights (a few °/s), not zero, not wild.
    noise = np.degrees(f.rates.between(f.airborne[0][0] + 10.0, f.airborne[0][0] + 18.0).values.std(axis=0))
    assert (noise[:2] > 0.5).all() and (noise < 20.0).all()


@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_logger_rates_and_flight_contract(profile):
    prof = PROFILES[profile]
    flights = simulate_flights(2, airframes=["f450", "crazyflie"], mission="hover", duration_s=14.0, profile=profile,
                               seed=2)
    for f in flights:
        assert f.autopilot == prof.autopilot and f.firmware == "flightlog-fd sim"
        assert f.vehicle_type == "quadrotor" and f.frame is not None and f.frame.is_quad
        assert f.rates.rate_hz == pytest.approx(prof.rates_hz, rel=0.02)
        assert f.attitude.rate_hz == pytest.approx(prof.attitude_hz, rel=0.02)
        assert f.motors.rate_hz == pytest.approx(prof.motors_hz, rel=0.02)
        assert f.velocity.rate_hz == pytest.approx(prof.velocity_hz, rel=0.02)
        if prof.motors_from == "rcou":
            # Old ArduCopter without RATE: the parser's motors are RCOU itself (the PWM signal).
            assert f.motor_kind == "signal" and f.alt_motors == {} and f.motors.source.startswith("RCOU")
            assert f.motors.values.min() >= 0.0 and f.motors.values.max() <= 1.0
            continue
        alt_name = "actuator_outputs" if prof.autopilot == "px4" else "RCOU"
        alt = f.alt_motors[alt_name]
        assert alt.rate_hz == pytest.approx(prof.alt_motors_hz, rel=0.05)
        for s in (f.rates, f.attitude, f.motors, f.velocity, alt):
            assert (np.diff(s.t) > 0).all()
            assert np.all(np.round(s.t * 1e6) == np.round(s.t * 1e6, 3))  # whole microseconds
        lo, hi = prof.boot_offset_s
        assert lo <= f.t_start <= hi + 0.01
        assert f.rates.values.shape[1] == 3 and f.attitude.values.shape[1] == 3 and f.motors.values.shape[1] == 4
        assert f.motors.values.min() >= 0.0 and f.motors.values.max() <= 1.0
        assert f.motor_kind == "thrust"
        # The signal stream is the thrust setpoint through the autopilot's thrust curve.
        idx = np.searchsorted(f.motors.t, alt.t)
        np.testing.assert_allclose(alt.values, thrust_to_signal(f.motors.values[idx], f.thrust_curve), atol=1e-6)
        if prof.autopilot == "px4":
            assert f.thrust_curve == f.params["THR_MDL_FAC"] == 0.0
            assert f.params["CA_ROTOR_COUNT"] == 4 and "SYS_AUTOSTART" in f.params
            assert f.rates.source == "vehicle_angular_velocity.xyz"
        else:
            assert f.thrust_curve == f.params["MOT_THST_EXPO"] == 0.65
            assert f.params["FRAME_CLASS"] == 1 and f.params["FRAME_TYPE"] == 1
            assert f.params["MOT_PWM_MIN"] == 1000 and f.params["MOT_PWM_MAX"] == 2000
            assert f.motors.source.startswith("RATE mixer")
        (a0, a1), = f.armed
        (b0, b1), = f.airborne
        assert f.t_start <= a0 < b0 < b1 <= a1 <= f.t_end + 1e-6
        assert f.truth["profile"] == profile and f.truth["mission"] == "hover"
        assert set(f.truth) >= {"label", "motor", "eta", "onset_s", "airframe", "rho", "mission", "seed"}


def test_jitter_only_outside_training_profile():
    train = simulate_flights(1, airframes="sih", mission="hover", duration_s=12.0, profile="training", seed=1)[0]
    high = simulate_flights(1, airframes="sih", mission="hover", duration_s=12.0, profile="px4_high", seed=1)[0]
    dt_train = np.diff(train.rates.t)
    assert np.ptp(np.round(dt_train * 1e6)) <= 1.0  # exact 10 ms spacing (µs rounding only)
    dt_high = np.diff(high.rates.t)
    assert np.std(dt_high) > 20e-6 and np.median(dt_high) == pytest.approx(0.004, abs=1e-5)
