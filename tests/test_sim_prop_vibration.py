"""Propeller imbalance in the simulator (sim/prop_vibration.py): the physics of the rotor line,
the autopilots' vibration metrics, and simulated flights written as ULog / DataFlash and read
back with the same vibration streams and findings."""
from dataclasses import replace

import numpy as np
import pytest

from flightlog_fd.analyzers.vibration import analyze_vibration, tie_motor
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.dataflash_writer import write_dataflash
from flightlog_fd.logs.ulog_writer import write_ulog
from flightlog_fd.sim.airframe import preset
from flightlog_fd.sim.api import flights_from_batch, simulate_batch, simulate_flights
from flightlog_fd.sim.prop_vibration import (SENSOR_RATE_HZ, PropImbalance, ardupilot_vibe, butterworth2,
                                             px4_metrics)

GMM = 1e-6  # kg·m per g·mm


@pytest.fixture(scope="module")
def hover_batch():
    """f450 and x500 hovering, no noise or wind (realism off), the propeller model recording."""
    return simulate_batch(2, airframes=[preset("f450"), preset("x500")], mission="hover", duration_s=30.0,
                          profile="ardupilot", seed=11, realism=False, healthy_fraction=1.0,
                          prop_imbalance=PropImbalance(residual=False), imu_rate_hz=SENSOR_RATE_HZ)


def _line(f, axes=(0, 1)):
    """(frequency Hz, amplitude per axis, complex spectrum at the peak) of the raw 1 kHz accelerometer, hovering."""
    s = f.vibration.fastest("accel").accel
    a, b = f.airborne[0]
    m = (s.t > a + 8.0) & (s.t < b - 10.0)  # steady hover: climb and descent excluded
    x = s.values[m] - s.values[m].mean(axis=0)
    w = np.hanning(x.shape[0])
    spec = np.fft.rfft(x * w[:, None], axis=0)
    fr = np.fft.rfftfreq(x.shape[0], 1.0 / s.rate_hz)
    band = fr > 20.0
    i = np.flatnonzero(band)[np.argmax(np.abs(spec[band][:, list(axes)]).sum(axis=1))]
    near = slice(i - 4, i + 5)  # Parseval over the line's Hann main lobe: no scalloping loss
    amp = 2.0 * np.sqrt((np.abs(spec[near]) ** 2).sum(axis=0) / (x.shape[0] * (w * w).sum()))
    return fr[i], amp, spec[i]


def _with(batch, specs):
    return flights_from_batch(replace(batch, prop_imbalance=specs))


def test_line_at_the_rotor_rate_amplitude_m_r_w2_over_mass(hover_batch):
    amps = {}
    for mr in (10.0, 20.0):
        flights = _with(hover_batch, [PropImbalance.on(2, mass=mr * GMM, residual=False)] * 2)
        for f in flights:
            tr = f.truth["prop_imbalance"]
            f_rotor = tr["rotor_hz"][1]
            freq, amp, _ = _line(f)
            assert abs(freq - f_rotor) < 0.5, (freq, f_rotor)  # once per revolution of motor 2
            expected = mr * GMM * (2 * np.pi * f_rotor) ** 2 / f.truth["airframe"]["mass"]
            assert amp[0] == pytest.approx(expected, rel=0.03) and amp[1] == pytest.approx(expected, rel=0.03)
            assert amp[2] < 1e-3 * expected  # in the rotor plane
            amps[(mr, f.truth["airframe"]["name"])] = amp[0]
    for name in ("f450", "x500"):  # linear in m·r
        assert amps[(20.0, name)] / amps[(10.0, name)] == pytest.approx(2.0, rel=0.01)


def test_spin_direction_and_gyro_line(hover_batch):
    f_ccw, _ = _with(hover_batch, [PropImbalance.on(1, mass=20 * GMM, residual=False), None])  # quad-X motor 1: CCW
    f_cw, _ = _with(hover_batch, [PropImbalance.on(3, mass=20 * GMM, residual=False), None])  # motor 3: CW
    turn = []
    for f in (f_ccw, f_cw):
        _, _, c = _line(f)
        turn.append(np.sign(np.angle(c[1] / c[0])))  # y leads or lags x by a quarter turn
        g = f.vibration.fastest("gyro").gyro
        assert np.std(g.values[:, 2]) > 0  # the arm's moment of the in-plane force shakes yaw
    assert turn[0] == -turn[1] != 0


def test_aerodynamic_imbalance_shakes_the_gyro(hover_batch):
    f, _ = _with(hover_batch, [PropImbalance.on(2, aero=0.2, residual=False), None])
    g = f.vibration.fastest("gyro").gyro
    a, b = f.airborne[0]
    m = (g.t > a + 8.0) & (g.t < b - 10.0)
    x = g.values[m, 0] - g.values[m, 0].mean()
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    fr = np.fft.rfftfreq(x.size, 1.0 / g.rate_hz)
    assert abs(fr[np.argmax(spec * (fr > 20))] - f.truth["prop_imbalance"]["rotor_hz"][1]) < 0.5


def test_logged_imu_aliases_the_filtered_line(hover_batch):
    f, _ = _with(hover_batch, [PropImbalance.on(2, mass=40 * GMM, residual=False), None])
    s = f.accel  # IMU.AccX/Y at 50 Hz after the 20 Hz accelerometer filter
    a, b = f.airborne[0]
    m = (s.t > a + 8.0) & (s.t < b - 10.0)  # steady hover: climb and descent excluded
    x = s.values[m, 0] - s.values[m, 0].mean()
    w = np.hanning(x.size)
    spec = np.abs(np.fft.rfft(x * w)) ** 2
    fr = np.fft.rfftfreq(x.size, 1.0 / s.rate_hz)
    f_rotor = f.truth["prop_imbalance"]["rotor_hz"][1]
    alias = abs(f_rotor - round(f_rotor / s.rate_hz) * s.rate_hz)
    i = np.argmax(spec * (fr > 1.0))
    assert abs(fr[i] - alias) < 0.5
    amp = 2.0 * np.sqrt(spec[i - 4:i + 5].sum() / (x.size * (w * w).sum()))
    full = 40 * GMM * (2 * np.pi * f_rotor) ** 2 / f.truth["airframe"]["mass"]
    assert amp == pytest.approx(full * abs(butterworth2(np.array([f_rotor]), 20.0)[0]), rel=0.1)


def test_metrics_of_a_rotating_line_and_of_white_noise():
    fs, f0, amp = SENSOR_RATE_HZ, 100.0, 6.0
    t = np.arange(0, 20.0, 1.0 / fs)
    rot = np.column_stack([amp * np.cos(2 * np.pi * f0 * t), amp * np.sin(2 * np.pi * f0 * t), np.zeros(t.size)])
    v = ardupilot_vibe(rot, fs)[-5000:]
    assert np.median(v[:, 0]) == pytest.approx(amp / np.sqrt(2), rel=0.03)
    noise = np.random.default_rng(0).normal(0.0, 2.0, (t.size, 3))
    assert np.median(ardupilot_vibe(noise, fs)[-5000:, 1]) == pytest.approx(2.0, rel=0.05)
    m = px4_metrics(rot, np.zeros_like(rot))[-1000:, 0]
    assert np.median(m) == pytest.approx(2 * amp * np.sin(np.pi * f0 / fs), rel=0.01)


def test_deterministic_and_flown_trajectory_unchanged():
    kw = dict(airframes="f450", mission="hover", duration_s=20.0, profile="px4_default", seed=5, healthy_fraction=1.0)
    plain = simulate_flights(1, **kw)[0]
    a = simulate_flights(1, prop_imbalance=PropImbalance.on(1, mass=20 * GMM), imu_rate_hz=500.0, **kw)[0]
    b = simulate_flights(1, prop_imbalance=PropImbalance.on(1, mass=20 * GMM), imu_rate_hz=500.0, **kw)[0]
    assert np.array_equal(plain.motors.values, a.motors.values)  # the controls are the balanced vehicle's
    assert np.array_equal(plain.attitude.values, a.attitude.values)
    assert not np.array_equal(plain.rates.values, a.rates.values)  # the logged gyro carries the line
    assert np.array_equal(a.vibration.metrics[0].values, b.vibration.metrics[0].values)
    assert np.array_equal(a.vibration.imus[0].gyro.values, b.vibration.imus[0].gyro.values)
    assert a.vibration.imus[0].gyro.rate_hz == pytest.approx(500.0, rel=0.01)
    assert plain.vibration is None


def test_healthy_residual_and_floor_are_the_airframes():
    kw = dict(airframes="f450", mission="hover", duration_s=20.0, profile="ardupilot", healthy_fraction=1.0,
              prop_imbalance="residual")
    one, two = simulate_flights(1, seed=1, **kw)[0], simulate_flights(1, seed=2, **kw)[0]
    t1, t2 = one.truth["prop_imbalance"], two.truth["prop_imbalance"]
    assert t1["mass_kgm"] == t2["mass_kgm"] and t1["added_mass_kgm"] == [0.0] * 4
    assert 0.5 < t1["floor_ms2"] / t2["floor_ms2"] < 2.0 and t1["floor_ms2"] != t2["floor_ms2"]
    assert max(t1["line_ms2"]) < 1.0  # a balanced propeller's line is far below the floor


@pytest.fixture(scope="module")
def unbalanced_flights():
    """The same unbalanced f450 (30 g·mm on motor 3) logged as ArduPilot and PX4, with raw IMU at 1 kHz."""
    kw = dict(airframes="f450", duration_s=45.0, seed=21, healthy_fraction=1.0, imu_rate_hz=SENSOR_RATE_HZ,
              prop_imbalance=PropImbalance.on(3, mass=30 * GMM))
    return {"dataflash": simulate_flights(1, profile="ardupilot", **kw)[0],
            "ulog": simulate_flights(1, profile="px4_high", **kw)[0]}


@pytest.mark.parametrize("fmt", ["dataflash", "ulog"])
def test_written_and_read_back_gives_the_same_vibration(unbalanced_flights, fmt, tmp_path):
    f = unbalanced_flights[fmt]
    path = tmp_path / ("sim.bin" if fmt == "dataflash" else "sim.ulg")
    (write_dataflash if fmt == "dataflash" else write_ulog)(f, path)
    g = load_flight(path)
    v, w = f.vibration, g.vibration
    assert w is not None and w.metric_kind == v.metric_kind
    assert np.allclose(w.metrics[0].t, v.metrics[0].t, atol=1e-6)
    assert np.allclose(w.metrics[0].values, v.metrics[0].values, rtol=1e-5, atol=1e-6)  # float32 in the file
    assert [s.source for s in w.imus] == [s.source for s in v.imus]
    for s, r in zip(v.imus, w.imus):
        for kind in ("accel", "gyro"):
            a, b = getattr(s, kind), getattr(r, kind)
            assert np.allclose(a.t, b.t, atol=1e-6) and np.allclose(a.values, b.values, rtol=1e-5, atol=1e-5)
    x, y = analyze_vibration(f), analyze_vibration(g)
    assert y.level.kind == x.level.kind and y.level.value == pytest.approx(x.level.value, rel=0.01)
    assert x.line is not None and y.line is not None
    assert y.line.freq_hz == pytest.approx(x.line.freq_hz, abs=0.01)
    assert tie_motor(x.line) == tie_motor(y.line) == 3  # the line is tied to the unbalanced rotor
    assert (x.flight_llr is None) == (y.flight_llr is None)
    if x.flight_llr is not None:
        assert y.flight_llr == pytest.approx(x.flight_llr, abs=0.05)


def test_cli_simulate_imbalance_is_deterministic_and_checks_its_input(tmp_path):
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    runner = CliRunner()
    args = ["simulate", "-f", "dataflash", "--log-profile", "ardupilot", "--airframe", "f450", "--duration", "20",
            "--mission", "hover", "--imbalance", "2:30", "--imu-rate", "500", "--seed", "4"]
    outs = []
    for name in ("a.bin", "b.bin"):
        r = runner.invoke(app, args + ["-o", str(tmp_path / name)])
        assert r.exit_code == 0, r.output
        assert "propeller imbalance 2: 30 g·mm" in r.output
        outs.append((tmp_path / name).read_bytes())
    assert outs[0] == outs[1]
    f = load_flight(tmp_path / "a.bin")
    assert f.vibration.metric_kind == "ardupilot_vibe" and f.vibration.fastest("gyro").gyro.rate_hz == pytest.approx(500, rel=0.01)
    for bad in (["--imbalance", "5:30"], ["--imbalance", "2:x"], ["--imu-rate", "300"]):
        r = runner.invoke(app, ["simulate", "-o", str(tmp_path / "c.bin"), "-f", "dataflash"] + bad)
        assert r.exit_code == 2 and "Traceback" not in r.output
