"""Loads in the simulator (sim/loads.py): mass bookkeeping, the hover pattern of a load against a
weak motor, the swinging payload, determinism, and `fdlog simulate --load`."""
from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app
from flightlog_fd.sim.airframe import GRAVITY, preset
from flightlog_fd.sim.api import simulate_batch, simulate_flights
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.loads import BATTERY_MASS_FRACTION, Load, mass_properties, parse_load, static_hover

X500 = preset("x500")
runner = CliRunner()


def test_point_mass_moves_mass_com_and_inertia_together():
    m, r = 0.5, np.array([0.1, -0.2, 0.05])
    mp = mass_properties(X500, Load("point", mass_kg=m, position=tuple(r)))
    assert mp.mass == pytest.approx(X500.mass + m) and mp.take_off_mass == pytest.approx(mp.mass)
    com = m * r / (X500.mass + m)
    assert np.allclose(mp.com, com)
    # Parallel axis by hand: the airframe about the new CoM plus the point about it.
    d0, d1 = -com, r - com

    def pt(mass, v):
        return mass * (v @ v * np.eye(3) - np.outer(v, v))

    expect = np.diag(X500.inertia) + pt(X500.mass, d0) + pt(m, d1)
    assert np.allclose(mp.inertia, expect)
    assert mp.inertia[0, 1] > 0  # x·y < 0: a positive product term −m·x·y
    # A percentage is of the take-off mass.
    mp15 = mass_properties(X500, parse_load("point:15%@motor2"))
    assert (mp15.mass - X500.mass) / mp15.mass == pytest.approx(0.15)
    rotor2 = X500.geometry().rotors[1]
    assert np.allclose(mp15.com[:2], 0.15 * np.array([rotor2.x, rotor2.y]))


def test_battery_shift_keeps_the_mass():
    mp = mass_properties(X500, parse_load("battery:0.04,-0.02"))
    assert mp.mass == pytest.approx(X500.mass)
    assert np.allclose(mp.com, BATTERY_MASS_FRACTION * np.array([0.04, -0.02, 0.0]))
    assert mp.inertia[2, 2] > X500.inertia[2]  # the battery moved away from the yaw axis


def test_line_payload_is_carried_not_part_of_the_body():
    mp = mass_properties(X500, parse_load("line:0.3@0,0,0.05:1.0"))
    assert mp.mass == pytest.approx(X500.mass) and mp.take_off_mass == pytest.approx(X500.mass + 0.3)
    assert mp.line_length == 1.0 and np.allclose(mp.line_attach, [0, 0, 0.05])


def test_random_loads_are_flyable_and_in_range():
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.loads import RANDOM_MASS_FRACTION_RANGE, check_flyable, random_loads

    rng = np.random.default_rng(7)
    afs = random_airframes(40, rng, frames=("quad_x",))
    loads = random_loads(afs, rng, weights=(2, 1, 1))
    kinds = [ld[0].kind for ld in loads]
    assert set(kinds) == {"point", "line", "battery"}
    for af, ld in zip(afs, loads):
        check_flyable(af, ld)  # raises if not
        if ld[0].kind != "battery":
            frac = ld[0].to_dict(af)["mass_fraction"]
            assert RANDOM_MASS_FRACTION_RANGE[0] - 1e-9 <= frac <= RANDOM_MASS_FRACTION_RANGE[1] + 1e-9
            assert np.hypot(*ld[0].position[:2]) <= af.arm + 1e-9
    assert random_loads(afs[:5], np.random.default_rng(1), loaded_fraction=0.0) == [()] * 5
    # simulate_flights(loads="random"): random airframes and damage, each with a load it flies with.
    fl = simulate_flights(6, loads="random", imbalance="random", seed=2, duration_s=15.0, profile="training")
    assert all(len(f.truth["loads"]) == 1 and f.truth["takeoff_s"] is not None for f in fl)


def test_static_hover_load_toward_a_motor_against_a_weak_motor():
    toward1 = static_hover(X500, parse_load("battery:0.085,0.085"))  # CoM 0.03 m toward motor 1
    weak1 = static_hover(X500, None, eta=[0.75, 1, 1, 1])
    h = X500.hover_command
    # The load: motor 1 up, the opposite motor 2 down as much, the other two unchanged.
    assert toward1[0] - h > 0.05 and h - toward1[1] == pytest.approx(toward1[0] - h, rel=1e-6)
    assert toward1[2:] == pytest.approx([h, h])
    # A weak motor: its own command up (1/eta), the other three equal.
    assert weak1[0] == pytest.approx(h / 0.75)
    assert weak1[1] == pytest.approx(weak1[2]) == pytest.approx(weak1[3])


@pytest.fixture(scope="module")
def hover_batch():
    """Noise-free hovers: healthy, a point mass toward motor 1, a weak motor 1, a mass and a weak motor."""
    load = Load("point", mass_fraction=0.15, toward_motor=1, arm_fraction=0.5)
    b = simulate_batch(4, airframes="x500", mission="hover", duration_s=35.0, profile="training", realism=False,
                       seed=3, damages=[None, None, Damage(1, 0.8, cause="motor"), Damage(3, 0.85)],
                       loads=[None, load, None, load], extra_streams={"pos": 2})
    t, tp = b.result.times["motors"], b.result.times["pos"]
    out = []
    for j in range(4):  # where the vehicle holds still in the air (the integrators have settled)
        pos = b.result.data["pos"][:, j].astype(float)
        still = (np.linalg.norm(np.gradient(pos, tp, axis=0), axis=1) < 0.02) & (-pos[:, 2] > 2.0)
        m = np.interp(t, tp, still.astype(float)) > 0.99
        assert m.sum() > 200, "no steady hover"
        out.append(b.result.data["motors"][m, j].astype(float).mean(0))
    return b, load, np.array(out)


def test_flown_hover_pattern_load_against_weak_motor(hover_batch):
    b, load, u = hover_batch
    healthy, loaded, weak, both = u
    assert np.ptp(healthy) < 1e-3
    # The added mass raises every motor's mean (the controller was not told: its integrator did it).
    assert loaded.mean() > healthy.mean() * 1.1
    # The load toward motor 1: motor 1 highest, the diagonal opposite 2 lowest, 3 and 4 between and equal.
    assert loaded[0] > loaded[2] > loaded[1] and loaded[2] == pytest.approx(loaded[3], abs=2e-3)
    assert loaded[0] - loaded[2] == pytest.approx(loaded[2] - loaded[1], rel=0.05)
    # A weak motor 1: only motor 1 rises, the other three stay equal.
    assert weak[0] > weak[1] + 0.05 and np.ptp(weak[1:]) < 2e-3
    # The flown hovers match the static balance.
    assert loaded == pytest.approx(static_hover(X500, load), abs=4e-3)
    assert both == pytest.approx(static_hover(X500, load, eta=[1, 1, 0.85, 1]), abs=4e-3)
    truth = [x for x in b.loads]
    assert truth[0] == () and truth[1] == (load,)


def test_swinging_payload_shows_its_pendulum_and_is_deterministic():
    length, frac = 1.0, 0.15
    kw = dict(airframes="x500", damages=[None, None], mission="manual", duration_s=45.0, profile="px4_default",
              seed=11, loads=[Load("line", mass_fraction=frac, position=(0.0, 0.0, 0.05), length_m=length), None])
    fl = simulate_flights(2, **kw)
    again = simulate_flights(2, **kw)
    assert np.array_equal(fl[0].rates.values, again[0].rates.values)
    assert np.array_equal(fl[0].motors.values, again[0].motors.values)
    assert fl[0].truth["loads"][0]["kind"] == "line" and fl[1].truth["loads"] == []
    assert fl[0].truth["load_mass"]["take_off_mass_kg"] == pytest.approx(X500.mass / (1 - frac))
    # The coupled pendulum's frequency, sqrt(g/L · (1 + m/M)) / 2π, in the horizontal accelerations:
    # the loaded flight has several times the unloaded one's power there.
    f_pend = np.sqrt(GRAVITY / length * (1 + frac / (1 - frac))) / (2 * np.pi)

    def band_power(f):
        a, b = f.airborne[0]
        t = f.accel.t
        x = f.accel.values[(t > a + 8) & (t < b - 3), :2]
        x = x - x.mean(0)
        fr = np.fft.rfftfreq(len(x), np.median(np.diff(t)))
        p = (np.abs(np.fft.rfft(x * np.hanning(len(x))[:, None], axis=0)) ** 2).sum(1)
        return p[(fr > 0.85 * f_pend) & (fr < 1.15 * f_pend)].mean()

    assert band_power(fl[0]) > 3 * band_power(fl[1])


def test_cli_writes_a_loaded_log_and_refuses_bad_loads(tmp_path):
    from flightlog_fd.logs.ulog import read_ulog, read_ulog_truth

    out = tmp_path / "load.ulg"
    res = runner.invoke(app, ["simulate", "-o", str(out), "--duration", "20", "--seed", "4", "--load",
                              "point:10%@motor2,0.5", "--load", "battery:0.03", "--motor", "3", "--eta", "0.85"])
    assert res.exit_code == 0, res.output
    assert "carrying point" in res.output
    fl = read_ulog(str(out))
    assert fl.motors.values.shape[1] == 4
    truth = read_ulog_truth(str(out))
    assert [x["kind"] for x in truth["loads"]] == ["point", "battery"] and truth["motor"] == 3
    for bad in ("point:abc@1,2", "point:0.1@motor9", "line:0.2@0,0:0", "point:3@motor1", "wheel:1@0,0"):
        res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "bad.ulg"), "--load", bad])
        assert res.exit_code == 2, (bad, res.output)
        assert "--load" in res.output and "Traceback" not in res.output
        assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "bad.ulg").exists()


def test_load_twins_generator_writes_flights_and_their_truth(tmp_path):
    import importlib.util
    from pathlib import Path

    from flightlog_fd.logs.ulog import read_ulog_truth

    path = Path(__file__).resolve().parent.parent / "benchmarks" / "load_twins.py"
    spec = importlib.util.spec_from_file_location("load_twins", path)
    lt = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(lt)
    rows = lt.make_load_twins(tmp_path, frames=("quad_x",), profiles=("px4_default",), duration_s=20.0, seed=5)
    assert [r["role"] for r in rows] == list(lt.ROLES)
    assert lt.read_manifest(tmp_path)[3]["file"] == rows[3]["file"]
    by_role = {r["role"]: r for r in rows}
    assert by_role["damaged"]["damaged_motor"] == by_role["damaged_load"]["damaged_motor"] > 0
    assert by_role["healthy"]["load_kind"] == "" and by_role["load"]["load_kind"] == "point"
    assert 0.05 <= by_role["load"]["load_mass_fraction"] <= 0.30
    assert by_role["load2"]["load_kind"] in ("line", "battery")
    for r in rows:  # every flight flew and its file holds the same truth
        assert r["airborne_s"] != "" and r["airborne_s"] > 10.0
        truth = read_ulog_truth(str(tmp_path / r["file"]))
        assert truth["motor"] == r["damaged_motor"]
        assert [x["kind"] for x in truth["loads"]] == ([r["load_kind"]] if r["load_kind"] else [])
    assert "load2" in lt.count_table(rows)


def test_line_coupling_conserves_momentum_and_swings_at_the_cart_pendulum_frequency(monkeypatch):
    """No controller, no drag, no damping, the line at the CoM, thrust = total weight: the body and
    payload are a pendulum on a free cart: the horizontal momentum stays 0 and the swing's
    period is that of sqrt(g/L · (1 + m/M))."""
    from dataclasses import replace

    import flightlog_fd.sim.dynamics as dyn_mod
    from flightlog_fd.sim.dynamics import QuadDynamics, RigidBodyState, VehicleParams
    from flightlog_fd.sim.loads import LoadArrays

    monkeypatch.setattr(dyn_mod, "LINE_DAMPING_RATIO", 0.0)
    af = replace(X500, drag_lin=0.0, drag_ang=0.0)
    m, length, dt = 0.5, 1.0, 0.002
    la = LoadArrays.build([(Load("line", mass_kg=m, position=(0.0, 0.0, 0.0), length_m=length),)], [af])
    vp = VehicleParams.from_airframes([af]).with_loads(la)
    d = QuadDynamics(vp, dt)
    d.set_loads(la)
    s = RigidBodyState.on_ground(1)
    s.pos[2] = -20.0
    s.landed[:] = False
    w = np.sqrt((af.mass + m) * GRAVITY / (4 * af.k_f)) * np.ones((4, 1))
    s.w[:] = w
    theta0 = np.radians(8.0)
    d.line_n[:, 0] = [np.sin(theta0), 0.0, np.cos(theta0)]
    zeros3, ones4 = np.zeros((3, 1)), np.ones((4, 1))
    nx, p = [], []
    for _ in range(int(12.0 / dt)):
        d.step(s, w, ones4, zeros3, zeros3)
        nx.append(d.line_n[0, 0])
        v_payload = s.vel[0, 0] + length * d.line_ndot[0, 0]
        p.append(af.mass * s.vel[0, 0] + m * v_payload)
    nx = np.array(nx)
    assert np.abs(p).max() < 1e-3  # kg·m/s; the payload's own swing carries ~0.2 (measured 4e-5)
    assert np.abs(s.omega).max() < 1e-9  # the line at the CoM: no moment
    up = np.flatnonzero((nx[:-1] < 0) & (nx[1:] >= 0))
    period = np.diff(up).mean() * dt
    expect = 2 * np.pi / np.sqrt(GRAVITY / length * (1 + m / af.mass))
    assert period == pytest.approx(expect, rel=0.01)
    assert np.abs(nx).max() == pytest.approx(np.sin(theta0), rel=0.03)  # undamped: the amplitude stays
