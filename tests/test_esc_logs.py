"""ESC telemetry (Flight.esc): every message generation written by our writers and read back.

ArduPilot: ESC with RawRPM (4.3+), ESC with float fields (4.1-4.2), ESC with scaled integers (4.0),
ESC1..ESC8 (3.3-3.6); PX4: esc_status with and without actuator_function. Plus offline ESCs,
telemetry gaps, motor mapping through SERVOn_FUNCTION / actuator_function, FMTU units.
"""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.flight import EscChannel, EscTelemetry, Flight, Frame, Series
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.dataflash import read_tables
from flightlog_fd.logs.dataflash_writer import ESC_LAYOUT_NAMES, write_dataflash
from flightlog_fd.logs.ulog_writer import write_ulog

T0, T1 = 10.0, 30.0


def esc_channels(rate_hz=20.0, seed=0, n=4, offline=None, gap=None, esc_index=None):
    """Per-motor ESC reports: rpm 6000-9000 integers, current 2-12 A (0.01 A), voltage 15-16 V,
    temperature 30-50 degC (whole degrees, as DShot/BLHeli report). ``offline``: (motor, t0, t1)
    reports flagged offline; ``gap``: (motor, t0, t1) with no report at all."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        t = np.round((T0 + 0.2 + np.arange(int((T1 - T0 - 0.5) * rate_hz)) / rate_hz
                      + rng.uniform(0, 0.2 / rate_hz)) * 1e6 + k * 37) / 1e6
        rpm = np.round(7000 + 1500 * np.sin(0.3 * t + k) + 100 * k)
        cur = np.round((7 + 5 * np.sin(0.3 * t + k)) * 100) / 100
        volt = np.round((16.0 - 0.05 * (t - T0)) * 100) / 100
        temp = np.round(30 + (t - T0) + k)
        online = np.ones(t.size, dtype=bool)
        if offline is not None and offline[0] == k + 1:
            online &= ~((t >= offline[1]) & (t < offline[2]))
        if gap is not None and gap[0] == k + 1:
            keep = ~((t >= gap[1]) & (t < gap[2]))
            t, rpm, cur, volt, temp, online = (a[keep] for a in (t, rpm, cur, volt, temp, online))
        idx = k if esc_index is None else esc_index[k]
        out.append(EscChannel(k + 1, t, rpm, cur, volt, temp, online=online, esc_index=idx, source="sim"))
    return out


def flight_with_esc(channels, params=None) -> Flight:
    tm = np.arange(T0, T1, 0.01)
    motors = np.clip(0.4 + 0.05 * np.sin(np.outer(tm, [1.0, 2.0, 3.0, 4.0])), 0, 1)
    tr = np.arange(T0, T1, 0.004)
    return Flight(path=None, autopilot="sim", vehicle_type="quadrotor", frame=Frame.quad_x(0.25),
                  rates=Series(tr, 0.1 * np.sin(np.outer(tr, [1.0, 0.7, 0.3])), "sim"),
                  attitude=Series(tm, 0.05 * np.sin(np.outer(tm, [0.5, 0.4, 0.1])), "sim"),
                  motors=Series(tm, motors, "sim"), motor_kind="thrust", thrust_curve=0.3,
                  velocity=Series(tm[::10], np.zeros((tm[::10].size, 3)), "sim"),
                  esc=EscTelemetry(channels, "sim"), armed=[(T0 + 0.1, T1 - 0.1)], airborne=[(T0 + 1, T1 - 1)],
                  t_start=T0, t_end=T1, params=params or {})


def assert_same_fresh(read: EscTelemetry, written: list[EscChannel], *, rpm_atol=0.0, fields=("current", "voltage", "temperature"),
                      atol=1e-5):
    assert read.motors == [c.motor for c in written]
    for c in written:
        r = read.channel(c.motor)
        m, rm = c.fresh(), r.fresh()
        np.testing.assert_allclose(r.t[rm], c.t[m], atol=1e-6)
        np.testing.assert_allclose(r.rpm[rm], c.rpm[m], atol=rpm_atol + 1e-3)
        for q in fields:
            np.testing.assert_allclose(r.quantity(q)[rm], c.quantity(q)[m], atol=atol, err_msg=f"motor {c.motor} {q}")


@pytest.mark.parametrize("layout", ESC_LAYOUT_NAMES)
def test_dataflash_every_esc_generation_round_trips(tmp_path, layout):
    chans = esc_channels()
    p = write_dataflash(flight_with_esc(chans), tmp_path / f"{layout}.bin", esc_layout=layout)
    f = load_flight(p)
    assert f.esc is not None
    names = set(read_tables(p, ["ESC", "ESC1", "FMTU"]))
    if layout == "escn":
        assert names == {"ESC1"} and f.esc.source.startswith("ESC1..ESC8")
        # ESCn keep rpm/10 in an int16: 10 rpm resolution; the reader scales the krpm column back
        assert "x1000" in f.esc.units["rpm"]
        assert_same_fresh(f.esc, chans, rpm_atol=10.0, atol=0.006)
    else:
        assert {"ESC", "FMTU"} <= names
        assert ("RawRPM" in f.esc.source) == (layout == "esc_rawrpm")
        assert "FMTU" in f.esc.units["rpm"]
        # float fields exact (float32 of whole rpm / centi-units); scaled integers to 0.01
        assert_same_fresh(f.esc, chans, atol=0.006 if layout == "esc_int" else 2e-6 * 20)
    assert f.esc_rpm is not None  # the resampled rpm stream for the features stays


def test_dataflash_instance_follows_servo_function(tmp_path):
    # motors 1..4 on outputs 3,4,1,2: ESC instance = output - 1, mapped back to motor numbers
    params = {"SERVO1_FUNCTION": 35.0, "SERVO2_FUNCTION": 36.0, "SERVO3_FUNCTION": 33.0, "SERVO4_FUNCTION": 34.0}
    chans = esc_channels(esc_index=[2, 3, 0, 1])
    f = load_flight(write_dataflash(flight_with_esc(chans, params), tmp_path / "map.bin"))
    assert [c.esc_index for c in f.esc.channels] == [2, 3, 0, 1]
    assert_same_fresh(f.esc, chans, atol=2e-5)


def test_dataflash_fmtu_unit_mismatch_drops_the_column(tmp_path, monkeypatch):
    from flightlog_fd.logs import dataflash_writer as W

    fmt, units, mults = W.ESC_LAYOUTS["esc_rawrpm"]
    # Curr declared in volts ('v') by the log's FMTU: not read as a current
    monkeypatch.setitem(W.ESC_LAYOUTS, "esc_rawrpm", (fmt, units[:5] + "v" + units[6:], mults))
    f = load_flight(W.write_dataflash(flight_with_esc(esc_channels()), tmp_path / "u.bin"))
    assert all(c.current is None for c in f.esc.channels)
    assert "not 'A'" in f.esc.units["current"]
    assert f.esc.channel(1).voltage is not None


def test_dataflash_fmtu_multiplier_applied_to_raw_integers(tmp_path, monkeypatch):
    from flightlog_fd.logs import dataflash_writer as W

    # a generation that logs current as a raw int16 in centi-amps with FMTU mult 'B' (x0.01)
    fmt = W._Format(137, "ESC", "QBfffhc", ("TimeUS", "Instance", "RPM", "RawRPM", "Volt", "Curr", "Temp"))
    monkeypatch.setitem(W.ESC_LAYOUTS, "esc_rawrpm", (fmt, "s#qqvAO", "F-00-BB"))
    chans = esc_channels()
    for c in chans:
        c.current[:] = np.round(c.current * 100)  # the writer stores the value as given: centi-amps
    f = load_flight(W.write_dataflash(flight_with_esc(chans), tmp_path / "m.bin"))
    np.testing.assert_allclose(f.esc.channel(2).current, chans[1].current / 100, atol=1e-9)
    assert "FMTU mult 0.01" in f.esc.units["current"]


def test_dataflash_gap_and_missing_esc(tmp_path):
    chans = esc_channels(gap=(2, 15.0, 17.0))[:3]  # motor 4's ESC never reports
    f = load_flight(write_dataflash(flight_with_esc(chans), tmp_path / "gap.bin"))
    assert f.esc.motors == [1, 2, 3]
    gaps = f.esc.channel(2).gaps()
    assert len(gaps) == 1 and gaps[0][0] < 15.0 + 0.06 and gaps[0][1] > 17.0 - 0.06
    assert f.esc.channel(1).gaps() == []
    # offline reports are not logged by ArduPilot: they read back as a gap
    chans = esc_channels(offline=(3, 20.0, 21.0))
    f = load_flight(write_dataflash(flight_with_esc(chans), tmp_path / "off.bin"))
    assert len(f.esc.channel(3).gaps()) == 1 and f.esc.channel(3).online.all()


@pytest.mark.parametrize("layout", ["current", "legacy"])
def test_ulog_esc_status_round_trips(tmp_path, layout):
    chans = esc_channels(offline=(2, 20.0, 21.0), gap=(3, 15.0, 16.5))
    f = load_flight(write_ulog(flight_with_esc(chans), tmp_path / f"{layout}.ulg", esc_layout=layout))
    assert f.esc is not None
    assert ("actuator_function" in f.esc.source) == (layout == "current")
    assert_same_fresh(f.esc, chans, atol=2e-5 * 16)
    # the offline second is not fresh, and shows as a gap; so does the silent 1.5 s of motor 3
    g2 = f.esc.channel(2).gaps()
    assert len(g2) == 1 and 19.9 < g2[0][0] <= 20.0 and 21.0 <= g2[0][1] < 21.1
    g3 = f.esc.channel(3).gaps()
    assert len(g3) == 1 and g3[0][0] < 15.0 and g3[0][1] > 16.5
    # stale repeats (the slot's own timestamp did not move) are kept but marked offline
    c3 = f.esc.channel(3)
    assert len(c3) > c3.fresh().sum()


def test_ulog_actuator_function_maps_slots_to_motors(tmp_path):
    chans = esc_channels(esc_index=[3, 2, 1, 0])  # ESC slot 0 drives motor 4
    f = load_flight(write_ulog(flight_with_esc(chans), tmp_path / "af.ulg"))
    assert [f.esc.channel(m).esc_index for m in (1, 2, 3, 4)] == [3, 2, 1, 0]
    assert_same_fresh(f.esc, chans, atol=2e-5 * 16)
    with pytest.raises(ValueError, match="legacy"):
        write_ulog(flight_with_esc(chans), tmp_path / "bad.ulg", esc_layout="legacy")


def test_ulog_zero_esc_status_is_no_telemetry(tmp_path):
    chans = esc_channels()
    for c in chans:
        c.rpm[:] = 0
        c.current[:] = 0
        c.voltage[:] = 0
        c.temperature[:] = 0
    f = load_flight(write_ulog(flight_with_esc(chans), tmp_path / "zero.ulg"))
    assert f.esc is None


def test_eight_motor_esc_channels_model():
    t = np.arange(0, 5, 0.1)
    chans = [EscChannel(k, t, np.full(t.size, 5000.0 + k)) for k in range(8, 0, -1)]
    esc = EscTelemetry(chans, "x")
    assert esc.motors == list(range(1, 9)) and esc.channel(8).rpm[0] == 5008
    with pytest.raises(ValueError):
        EscTelemetry(chans + [EscChannel(1, t, t)], "dup")
    d = esc.describe(0.0, 10.0)
    # 5 s without telemetry after the last sample is a gap
    assert d["motors"][0]["gaps"] == [[4.9, 10.0]] and d["quantities"] == ["rpm"]


def test_ulog_eight_motor_esc_status(tmp_path):
    from flightlog_fd.flight import Rotor

    ang = np.radians(22.5 + 45 * np.arange(8))
    octo = Frame("octo", tuple(Rotor(float(np.cos(a)), float(np.sin(a)), 1 if i % 2 else -1) for i, a in enumerate(ang)),
                 "test")
    chans = esc_channels(n=8)
    f = flight_with_esc(chans)
    f.frame, f.vehicle_type = octo, "octorotor"
    f.motors = Series(f.motors.t, np.tile(f.motors.values, (1, 2)), "sim")
    g = load_flight(write_ulog(f, tmp_path / "octo.ulg"))
    assert g.frame.rotor_count == 8 and g.esc.motors == list(range(1, 9))
    assert_same_fresh(g.esc, chans, atol=2e-5 * 16)


def test_sanitise_drops_an_implausible_esc_timestamp():
    from flightlog_fd.flight import sanitise_flight

    chans = esc_channels()
    t = chans[1].t.copy()
    t[200] += 2.0 ** 30 * 1e-6 * 4096  # one flipped high bit in a µs timestamp
    chans[1] = EscChannel(2, np.sort(t), chans[1].rpm, chans[1].current, chans[1].voltage, chans[1].temperature,
                          esc_index=1, source="sim")
    f = sanitise_flight(flight_with_esc(chans))
    assert any("esc motor 2" in w for w in f.warnings)
    assert f.esc.channel(2).t.max() < T1 + 1 and len(f.esc.channel(2)) == len(chans[1]) - 1
