"""hover.py: steady segments on a synthetic take-off / hover / manoeuvre / yaw turn / land flight,
and on real logs when the parsers and ../shared are there."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.hover import hover_segments, hover_seconds, hover_summary

#: Mission timeline (s): what happens when.
GROUND = (0.0, 2.0)
CLIMB = (2.0, 5.5)
HOVER_1 = (5.5, 14.0)
MANOEUVRE = (14.0, 22.0)
HOVER_2 = (22.0, 30.0)
YAW_TURN = (30.0, 33.0)
HOVER_3 = (33.0, 36.0)
LAND = (36.0, 38.0)
DURATION = 40.0


def _inside(t, span):
    return (t >= span[0]) & (t < span[1])


def mission_flight(rho=(1.0, 1.0, 1.0, 1.0), gyro_hz=250.0, motor_hz=250.0, gyro_noise_deg=6.0,
                   motor_noise=0.01, hover_thrust=0.5, with_velocity=True, with_attitude=True, seed=0,
                   path="mission.ulg", autopilot="px4", frame=None) -> Flight:
    """A quad with speed ratios ``rho`` (thrust ratios rho^2) flying the timeline above."""
    rng = np.random.default_rng(seed)
    rho = np.asarray(rho, dtype=float)
    tg = np.arange(0.0, DURATION, 1.0 / gyro_hz)
    rates = rng.normal(0.0, np.deg2rad(gyro_noise_deg), (tg.size, 3))
    w = 2 * np.pi * 0.5
    m = _inside(tg, MANOEUVRE)
    rates[m, 0] += 0.8 * np.sin(w * tg[m])
    rates[m, 1] += 0.6 * np.cos(w * tg[m])
    rates[_inside(tg, YAW_TURN), 2] += 0.6
    att = np.zeros((tg.size, 2))
    att[m, 0] = -0.8 / w * np.cos(w * tg[m]) * 0.5
    att[m, 1] = 0.6 / w * np.sin(w * tg[m]) * 0.5

    tm = np.arange(0.0, DURATION, 1.0 / motor_hz)
    collective = np.full(tm.size, hover_thrust)
    collective[_inside(tm, (2.0, 3.0))] *= 1.25
    collective[_inside(tm, (4.5, 5.5))] *= 0.8
    mm = _inside(tm, MANOEUVRE)
    collective[mm] *= 1.0 + 0.1 * np.sin(2 * np.pi * 0.3 * tm[mm])
    collective[_inside(tm, LAND)] *= 0.9
    share = rho ** 2 / np.mean(rho ** 2)
    motors = collective[:, None] * share[None, :]
    diff = np.zeros((tm.size, 4))
    diff[mm] = 0.1 * np.sin(w * tm[mm])[:, None] * np.array([1, -1, 1, -1])
    diff[_inside(tm, YAW_TURN)] = 0.06 * np.array([1, 1, -1, -1])  # CCW 1,2 vs CW 3,4
    motors = motors + diff + rng.normal(0, motor_noise, motors.shape)
    motors[_inside(tm, GROUND)] = 0.0
    motors[tm >= LAND[1]] = 0.0

    tv = np.arange(0.0, DURATION, 0.1)
    vel = np.zeros((tv.size, 3))
    vel[_inside(tv, (2.5, 5.0)), 2] = -1.5
    vel[_inside(tv, MANOEUVRE), 0] = 3.0
    vel[_inside(tv, LAND), 2] = 1.0
    return Flight(path=path, autopilot=autopilot, frame=frame or Frame.quad_x(), rates=Series(tg, rates, "gyro"),
                  attitude=Series(tg, att, "att") if with_attitude else None,
                  motors=Series(tm, np.clip(motors, 0, 1), "motors"),
                  velocity=Series(tv, vel, "vel") if with_velocity else None,
                  airborne=[(GROUND[1], LAND[1])], armed=[(0.5, 39.0)], t_start=0.0, t_end=DURATION)


def _overlap(seg, span):
    return max(0.0, min(seg.t1, span[1]) - max(seg.t0, span[0]))


@pytest.mark.parametrize("kw", [
    dict(),  # 1 kg SIH-like: 250 Hz, 6 deg/s gyro noise
    dict(gyro_hz=50.0, motor_hz=10.0),  # PX4 default logging profile
    dict(gyro_hz=100.0, motor_hz=100.0, gyro_noise_deg=2.0, hover_thrust=0.65, with_velocity=False),  # Crazyflie-like
])
def test_hover_segments_found_only_in_hover(kw):
    fl = mission_flight(**kw)
    segs = hover_segments(fl)
    assert segs, "no hover found"
    for s in segs:
        assert s.duration_s >= 2.0 - 1e-9
        for busy in ((CLIMB[0], 4.6), MANOEUVRE, YAW_TURN):
            # the 1 s judging window may reach 0.5 s into a neighbouring phase, no further
            assert _overlap(s, (busy[0] + 0.5, busy[1] - 0.5)) == 0.0, (s, busy)
    covered = [sum(_overlap(s, span) for s in segs) for span in (HOVER_1, HOVER_2)]
    assert covered[0] >= 6.0 and covered[1] >= 6.0
    assert hover_seconds(segs) >= 12.0
    # hover throttle = mean thrust over the motors (equal rho -> hover_thrust)
    for s in segs:
        assert s.throttle == pytest.approx(kw.get("hover_thrust", 0.5), rel=0.03)
        assert s.mean_motors.shape == (4,) and s.mean_speed.shape == (4,)
    assert "hover segments" in hover_summary(fl, segs)


def test_no_hover_in_a_flight_that_never_steadies():
    fl = mission_flight()
    # Replace the two hovers by a constant 25 deg/s yaw: steady throttle, level, still - but turning.
    r = fl.rates.values.copy()
    r[:, 2] += np.deg2rad(25.0)
    fl.rates = Series(fl.rates.t, r)
    assert hover_segments(fl) == []
    assert hover_summary(fl, []) == "no steady hover"


def test_min_duration_is_respected():
    fl = mission_flight()
    long_only = hover_segments(fl, min_duration_s=7.0)
    assert long_only and all(s.duration_s >= 7.0 for s in long_only)
    assert len(long_only) < len(hover_segments(fl))


def test_sih_healthy_logs_hover(shared):
    from flightlog_fd import load_flight

    for name, min_hover in (("sih_004.ulg", 8.0), ("sih_008.ulg", 6.0)):  # high-rate and default profile
        fl = load_flight(shared("px4_sih_dev", "logs", name))
        segs = hover_segments(fl)
        assert hover_seconds(segs) >= min_hover
        for s in segs:
            assert 0.4 < s.throttle < 0.6  # SIH 1 kg quad hovers near half thrust
            ratios = s.mean_speed / s.mean_speed[0]
            assert np.all(np.abs(ratios - 1.0) < 0.03)  # perfectly balanced airframe


def test_crazypad_healthy_hover(shared):
    from flightlog_fd import load_flight

    fl = load_flight(shared("crazypad_e9", "ulog", "normal_flight__E9_log00.ulg"))
    segs = hover_segments(fl)
    assert hover_seconds(segs) >= 4.0  # two ~8 s flights, mostly slow
    for s in segs:
        assert s.mean_motors[1] == max(s.mean_motors)  # README: motor 2 runs hardest
