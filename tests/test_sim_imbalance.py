"""Realistic airframe imbalance (sim/imbalance.py) and the damaged-propeller model (sim/damage.py).

Each imbalance cause has its own hover command pattern (CoG → roll/pitch, motor tilt → diagonal,
weak rotor → one motor), and only damage lowers a rotor's effectiveness.
"""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.windows import FeatureSpec, make_windows
from flightlog_fd.sim.airframe import preset, random_airframes
from flightlog_fd.sim.api import simulate_batch, simulate_flights
from flightlog_fd.sim.damage import TORQUE_EXPONENT_RANGE, Damage, DamageArrays, random_damages
from flightlog_fd.sim.dynamics import QuadDynamics, RigidBodyState, VehicleParams
from flightlog_fd.sim.imbalance import (AirframeImbalance, ImbalanceArrays, hover_commands, random_imbalances,
                                        resolve_imbalances)

X500 = preset("x500")


def _hover_commands_sim(imbalances, damages=None, airframe=X500) -> np.ndarray:
    """(n, 4) mean motor commands of simulated noise-free hovers, one per imbalance."""
    n = len(imbalances)
    b = simulate_batch(n, airframes=airframe, damages=damages or [None] * n, mission="hover", duration_s=20.0,
                       profile="training", realism=False, imbalance=list(imbalances), seed=2,
                       extra_streams={"pos": 2})
    t = b.result.times["motors"]
    pos = b.result.data["pos"].astype(float)
    tp = b.result.times["pos"]
    out = []
    for j in range(n):
        vel = np.gradient(pos[:, j], tp, axis=0)
        still = (np.linalg.norm(vel, axis=1) < 0.02) & (-pos[:, j, 2] > 2.0) & (tp > 8.0)
        m = np.interp(t, tp, still.astype(float)) > 0.99
        assert m.sum() > 100, "no steady hover"
        out.append(b.result.data["motors"][m, j].astype(float).mean(0))
    return np.array(out)


def test_each_imbalance_cause_has_its_own_hover_pattern():
    cog_front = AirframeImbalance(cog_offset=(0.06, 0.0))
    cog_right = AirframeImbalance(cog_offset=(0.0, 0.06))
    tilt = AirframeImbalance(motor_tilt_rad=tuple(np.radians([0.5, 0.5, 0.5, 0.5])))
    weak2 = AirframeImbalance(thrust_scale=(1.0, 0.92, 1.0, 1.0), torque_scale=(1.0, 0.92, 1.0, 1.0))
    u = _hover_commands_sim([AirframeImbalance(), cog_front, cog_right, tilt, weak2])
    bal, front, right, diag, weak = u - u.mean(1, keepdims=True)
    assert np.abs(bal).max() < 1e-3
    # Quad-X (PX4 order): 1 front-right, 2 rear-left, 3 front-left, 4 rear-right; 1, 2 CCW, 3, 4 CW.
    assert front[0] > 0.02 and front[2] > 0.02 and front[1] < -0.02 and front[3] < -0.02
    assert front[0] == pytest.approx(front[2], abs=2e-3)  # symmetric left/right
    assert right[0] > 0.02 and right[3] > 0.02 and right[1] < -0.02 and right[2] < -0.02
    assert right[0] == pytest.approx(right[3], abs=2e-3)
    # Tilt yaws the vehicle positively: the CW pair (3, 4) works harder against it, diagonal pattern.
    assert diag[2] > 0.03 and diag[3] > 0.03 and diag[0] < -0.03 and diag[1] < -0.03
    assert diag[0] == pytest.approx(diag[1], abs=2e-3) and diag[2] == pytest.approx(diag[3], abs=2e-3)
    # A weak rotor: its own motor runs high, by about hover · (1/0.92 − 1) · 3/4.
    assert int(np.argmax(weak)) == 1
    assert weak[1] == pytest.approx(X500.hover_command * (1 / 0.92 - 1) * 0.75, rel=0.2)
    # The static balance of hover_commands() predicts the simulated hovers.
    for imb, sim in zip([cog_front, tilt, weak2], u[[1, 3, 4]]):
        assert hover_commands(X500, imb) == pytest.approx(sim, abs=3e-3)


def _angular_acc_per_command(imb: AirframeImbalance, damage: Damage, motor: int) -> np.ndarray:
    """(3,) body angular acceleration per unit command step of ``motor`` (1..4), open loop, from hover."""
    vp = VehicleParams.from_airframes([X500])
    arrays = ImbalanceArrays.build([imb])
    dyn = QuadDynamics(vp.with_imbalance(arrays), 1e-3)
    d = DamageArrays.build([damage], np.random.default_rng(0))
    eff = d.eta.T.copy()
    drag_ratio = None if d.eta_torque is None else (d.eta_torque / d.eta).T.copy()
    acc = []
    for du in (0.0, 0.02):
        s = RigidBodyState.on_ground(1)
        s.pos[2] = -10.0
        s.landed[:] = False
        u = np.full((4, 1), X500.hover_command)
        u[motor - 1] += du
        w = X500.omega_max * np.sqrt(u)
        s.w[:] = w  # motor already at the commanded speed: the step's acceleration is the effectiveness
        dyn.step(s, w, eff, np.zeros((3, 1)), np.zeros((3, 1)), None, drag_ratio)
        acc.append(s.omega[:, 0] / dyn.dt)
    return (acc[1] - acc[0]) / 0.02


def test_damage_lowers_rotor_effectiveness_and_cog_offset_does_not():
    healthy = _angular_acc_per_command(AirframeImbalance(), Damage(), 2)
    damaged = _angular_acc_per_command(AirframeImbalance(), Damage(2, 0.8, None, 0.7), 2)
    cog = _angular_acc_per_command(AirframeImbalance(cog_offset=(0.03, -0.02)), Damage(), 2)
    tilted = _angular_acc_per_command(AirframeImbalance(motor_tilt_rad=tuple(np.radians([0.8] * 4))), Damage(), 2)
    # Roll/pitch effectiveness (thrust lever) drops by η, yaw (drag torque) by η_torque.
    rp = np.linalg.norm(healthy[:2])
    assert np.linalg.norm(damaged[:2]) / rp == pytest.approx(0.8, abs=0.01)
    assert damaged[2] / healthy[2] == pytest.approx(0.7, abs=0.01)
    # A CoG offset moves the lever arms a little; the rotor's effectiveness stays within a few %.
    assert np.linalg.norm(cog[:2]) / rp == pytest.approx(1.0, abs=0.04)
    assert cog[2] / healthy[2] == pytest.approx(1.0, abs=0.01)
    assert np.linalg.norm(tilted[:2]) / rp == pytest.approx(1.0, abs=0.01)


def test_damage_keeps_old_api_and_draws_torque_loss_and_mild_damage():
    d = Damage(1, 0.8)
    assert d.torque_eta == 0.8 and d.label == 1
    with pytest.raises(ValueError):
        Damage(1, 0.8, None, 1.5)
    afs = [X500] * 400
    dm = random_damages(afs, np.full(400, 60.0), np.random.default_rng(1), healthy_fraction=0.0, mild_fraction=0.3,
                        torque_exponent_range=TORQUE_EXPONENT_RANGE)
    eta = np.array([x.eta for x in dm])
    eta_q = np.array([x.torque_eta for x in dm])
    assert np.all(eta_q <= eta + 1e-12) and np.all(eta_q >= eta ** TORQUE_EXPONENT_RANGE[1] - 1e-12)
    mild = (eta >= 0.9) & (eta <= 0.97)
    assert 0.2 < mild.mean() < 0.5 and eta.min() < 0.75
    # Without the new options the draws are the paper's model: η_torque = η, no extra mild share.
    old = random_damages(afs, np.full(400, 60.0), np.random.default_rng(1), healthy_fraction=0.0)
    assert all(x.eta_torque is None for x in old)


def test_random_imbalance_offsets_span_real():
    """Static hover offsets of random airframes reach the real healthy ones (±0.10, imbalance.py)."""
    rng = np.random.default_rng(5)
    afs = random_airframes(300, rng)
    imbs = random_imbalances(afs, rng)
    offsets = np.array([hover_commands(a, i) - hover_commands(a, i).mean() for a, i in zip(afs, imbs)])
    worst = np.abs(offsets).max(1)
    assert 0.03 < np.median(worst) < 0.07
    assert np.percentile(worst, 90) > 0.06 and worst.max() > 0.09
    hover = np.array([hover_commands(a, i).max() for a, i in zip(afs, imbs)])
    assert hover.max() <= max(0.75, max(a.hover_command for a in afs) * 1.05) + 1e-9
    # The motor lag spread and independent thrust / torque draws are there.
    assert np.std([i.thrust_scale[0] for i in imbs]) > 0.01
    assert not np.allclose([i.thrust_scale for i in imbs], [i.torque_scale for i in imbs])
    assert np.std([i.motor_tau_scale[0] for i in imbs]) > 0.03
    with pytest.raises(ValueError):
        resolve_imbalances("bogus", afs[:2], rng)


def test_ardupilot_rcou_profile_is_like_an_old_arducopter_log():
    fl = simulate_flights(2, airframes="f450", mission="waypoints", duration_s=25.0, profile="ardupilot_rcou",
                          imbalance="random", seed=3)
    for f in fl:
        assert f.motor_kind == "signal" and f.alt_motors == {}
        assert f.motors.rate_hz == pytest.approx(10.0, rel=0.05)
        assert f.rates.rate_hz == pytest.approx(50.0, rel=0.05)
        assert f.truth["imbalance"] is not None and f.truth["profile"] == "ardupilot_rcou"
        assert len(make_windows(f, FeatureSpec()).X) > 0
