"""Stopped-motor finding: the SITL hexa set (right motor, time within 2 s of its README), no
finding on real healthy quads, and the rules on synthetic flights."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.flight import Flight, Series
from flightlog_fd.frames import ardupilot_frame
from flightlog_fd.stopped import (OTHERS_MIN_LEVEL, STOP_MIN_S, StoppedMotor, describe, diagnose_stopped)

#: ../shared/ardupilot_sitl_hexa/README.md: stopped motor and first RCOU at 1000 us (s).
SITL_TRUTH = {1: 80.98, 2: 79.19, 3: 73.87, 4: 79.07, 5: 74.07, 6: 79.08}
#: The README's bar for the time.
TIME_TOLERANCE_S = 2.0


@pytest.mark.parametrize("motor", sorted(SITL_TRUTH))
def test_every_sitl_hexa_flight_names_the_stopped_motor_and_its_time(shared, motor):
    from flightlog_fd import load_flight

    f = load_flight(shared("ardupilot_sitl_hexa", f"hexa_cwx_m{motor}.bin"))
    found = diagnose_stopped(f)
    assert [x.motor for x in found] == [motor]
    assert abs(found[0].t_start - SITL_TRUTH[motor]) <= TIME_TOLERANCE_S
    assert found[0].duration_s > 10 and found[0].source.startswith("RCOU")
    assert f"motor {motor} ({f.frame.position(motor)})" in found[0].evidence and "SERVO" in found[0].evidence


def _healthy_logs(shared):
    paths = sorted(shared("real_healthy", "logs").glob("*.BIN"))
    paths += sorted(p for p in shared("real_logs").rglob("*") if p.suffix.lower() in (".bin", ".ulg"))
    paths += sorted(shared("real_damaged", "rrc_straight").glob("good_prop_*.BIN"))
    return paths


def test_no_stopped_motor_on_real_healthy_quads(shared):
    from flightlog_fd import load_flight
    from flightlog_fd.errors import FlightLogError

    checked = 0
    for path in _healthy_logs(shared):
        try:
            f = load_flight(path)
        except FlightLogError:
            continue
        assert diagnose_stopped(f) == [], path.name
        checked += bool(f.airborne)
    assert checked >= 20  # real_healthy (15), real_logs (erle x3, RflyMAD x4, PX4 SITL), rrc good props (3)


def _hexa(stop_motor=None, t0=10.0, t1=None, others=0.55, rate=10.0, stop_value=0.0):
    t = np.arange(0.0, 40.0, 1.0 / rate)
    rng = np.random.default_rng(1)
    v = np.clip(others + 0.05 * rng.standard_normal((len(t), 6)), 0, 1)
    if stop_motor is not None:
        m = (t >= t0) & (t <= (t1 if t1 is not None else t[-1]))
        v[m, stop_motor - 1] = stop_value
    return Flight(path="h.bin", autopilot="ardupilot", vehicle_type="hexarotor", frame=ardupilot_frame(2, 1),
                  motors=Series(t, v, "RCOU.C1..C6"), motor_kind="signal", airborne=[(2.0, 38.0)],
                  t_start=0.0, t_end=40.0)


def test_synthetic_stop_is_found_with_its_time():
    found = diagnose_stopped(_hexa(3, t0=12.3))
    assert len(found) == 1 and isinstance(found[0], StoppedMotor)
    assert found[0].motor == 3 and found[0].t_start == pytest.approx(12.3, abs=0.11)
    assert found[0].t_end == pytest.approx(38.0, abs=0.11)
    assert describe(found[0]).startswith("motor 3 stopped at t=12.30 s") and "front-left" in found[0].evidence


def test_short_dips_spooled_down_vehicles_and_ground_time_are_not_stops():
    assert diagnose_stopped(_hexa(2, t0=10.0, t1=10.0 + STOP_MIN_S - 0.2)) == []  # shorter than STOP_MIN_S
    assert diagnose_stopped(_hexa(2, t0=10.0, others=OTHERS_MIN_LEVEL * 0.5)) == []  # all motors low
    assert diagnose_stopped(_hexa(2, t0=10.0, stop_value=0.15)) == []  # at MOT_SPIN_MIN: still turning
    f = _hexa(5, t0=38.5)  # stopped after landing
    assert diagnose_stopped(f) == []
    f.airborne = []
    assert diagnose_stopped(_hexa(None)) == [] and diagnose_stopped(f) == []


def test_a_motor_stopped_across_a_bounce_is_one_finding():
    f = _hexa(4, t0=10.0)
    f.airborne = [(2.0, 20.0), (21.0, 38.0)]
    found = diagnose_stopped(f)
    assert [(x.motor, round(x.t_start, 1), round(x.t_end, 1)) for x in found] == [(4, 10.0, 38.0)]


def test_ardupilot_rate_mixer_rebuild_is_not_read_as_outputs():
    f = _hexa(1, t0=10.0)
    f.motor_kind = "thrust"  # the reader rebuilt the motors from RATE and kept no RCOU
    assert diagnose_stopped(f) == []
    f.alt_motors["RCOU"] = f.motors
    assert [x.motor for x in diagnose_stopped(f)] == [1]


def test_esc_rpm_that_vanishes_is_a_stop_and_all_zero_telemetry_is_ignored():
    f = _hexa(None)
    t = np.arange(0.0, 40.0, 0.05)
    rpm = np.full((len(t), 6), 6000.0)
    rpm[t >= 15.0, 5] = 0.0
    f.esc_rpm = Series(t, rpm, "ESC.RPM")
    found = diagnose_stopped(f)
    assert [x.motor for x in found] == [6] and found[0].t_start == pytest.approx(15.0, abs=0.06)
    assert "ESC reports 0 rpm" in found[0].evidence
    f.esc_rpm = Series(t, np.zeros((len(t), 6)), "ESC.RPM")  # ArduPilot SITL: 0 everywhere
    assert diagnose_stopped(f) == []
    # outputs and ESC agreeing on one stop give one finding with both pieces of evidence
    g = _hexa(6, t0=15.0)
    g.esc_rpm = Series(t, rpm, "ESC.RPM")
    found = diagnose_stopped(g)
    assert len(found) == 1 and "output at" in found[0].evidence and "ESC reports" in found[0].evidence


def test_px4_thrust_setpoints_are_used_without_outputs():
    f = _hexa(2, t0=20.0)
    f.autopilot, f.motor_kind = "px4", "thrust"
    assert [x.motor for x in diagnose_stopped(f)] == [2]
