"""Simulator physics and control: airframes, rotor geometry/spin signs, mixer, hover trim, damage, ρ."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flightlog_fd.sim.airframe import GRAVITY, PRESETS, preset, random_airframes
from flightlog_fd.sim.api import simulate_batch
from flightlog_fd.sim.controller import mix, mixer_matrices
from flightlog_fd.sim.damage import MAX_DAMAGED_COMMAND, MAX_STATIC_TILT_DEG, Damage, min_feasible_eta, random_damages
from flightlog_fd.sim.dynamics import QuadDynamics, RigidBodyState, VehicleParams
from flightlog_fd.sim.logger import thrust_to_signal
from flightlog_fd.sim.sensors import SensorParams, Sensors
from flightlog_fd.sim.rho import resolve_rho

PRESET_SET = [preset("sih"), preset("x500"), preset("crazyflie"), preset("heavy"), preset("f450", "quad_plus")]


def _steady_hover_mask(batch, j: int, min_alt: float = 2.0) -> np.ndarray:
    """Samples (on the 'pos' stream grid) where vehicle j is airborne and nearly still."""
    pos = batch.result.data["pos"][:, j].astype(np.float64)
    t = batch.result.times["pos"]
    vel = np.gradient(pos, t, axis=0)
    still = (np.linalg.norm(vel, axis=1) < 0.05) & (-pos[:, 2] > min_alt)
    # Keep the middle of the longest still stretch (the hover leg), away from its ends.
    idx = np.flatnonzero(still)
    assert idx.size > 50, "no steady hover found"
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    run = max(runs, key=len)
    m = np.zeros(t.shape[0], dtype=bool)
    m[run[len(run) // 4: 3 * len(run) // 4]] = True
    return m


def test_sih_preset_matches_px4_sih_parameters():
    sih = preset("sih")
    assert sih.mass == pytest.approx(1.0)
    assert sih.inertia == pytest.approx((0.025, 0.025, 0.030))
    # SIH_L_ROLL is the lateral rotor offset: arm · sin 45° = 0.2 m.
    assert sih.arm / np.sqrt(2.0) == pytest.approx(0.2)
    assert sih.thrust_max == pytest.approx(5.0)  # SIH_T_MAX, thrust linear in the command
    assert sih.k_tau * sih.omega_max ** 2 == pytest.approx(0.1)  # SIH_Q_MAX
    assert sih.motor_tau == pytest.approx(0.05)
    assert sih.hover_command == pytest.approx(GRAVITY / 20.0)


def test_presets_span_nano_to_heavy():
    masses = {k: a.mass for k, a in PRESETS.items()}
    assert masses["crazyflie"] == pytest.approx(0.03)
    assert 1.3 < masses["f450"] < 1.7 and 1.8 < masses["x500"] < 2.2 and 4.5 < masses["heavy"] < 5.5
    for a in PRESETS.values():
        assert 1.6 <= a.thrust_to_weight <= 3.5


def test_random_airframes_are_physically_consistent():
    afs = random_airframes(200, np.random.default_rng(3))
    m = np.array([a.mass for a in afs])
    twr = np.array([a.thrust_to_weight for a in afs])
    tau = np.array([a.motor_tau for a in afs])
    assert m.min() >= 0.03 and m.max() <= 5.0 and m.min() < 0.1 and m.max() > 2.5
    assert twr.min() >= 1.6 - 1e-9 and twr.max() <= 3.5 + 1e-9
    assert tau.min() >= 0.015 - 1e-12 and tau.max() <= 0.08 + 1e-12
    ratio = np.array([a.inertia[0] / (a.mass * a.arm ** 2) for a in afs])
    assert ratio.min() >= 0.15 - 1e-9 and ratio.max() <= 0.35 + 1e-9
    assert all(a.inertia[2] > a.inertia[0] for a in afs)
    frames = {a.frame for a in afs}
    assert frames == {"quad_x", "quad_plus"}
    # Heavier vehicles have slower motors and lower rate-loop gains.
    heavy = [a for a in afs if a.mass > 2.0]
    light = [a for a in afs if a.mass < 0.1]
    assert np.mean([a.gains.rate_kp[0] for a in heavy]) < np.mean([a.gains.rate_kp[0] for a in light])


@pytest.mark.parametrize("frame", ["quad_x", "quad_plus"])
def test_rotor_torque_signs(frame):
    """Each rotor alone: roll/pitch from its position, yaw from its spin (CCW → positive yaw in FRD)."""
    af = preset("x500", frame)
    vp = VehicleParams.from_airframes([af] * 4)
    dyn = QuadDynamics(vp, 0.002)
    st = RigidBodyState.on_ground(4)
    st.pos[2] = -10.0
    st.landed[:] = False
    w_com = np.zeros((4, 4))
    for k in range(4):  # vehicle k spins only rotor k at full speed
        w_com[k, k] = af.omega_max
        st.w[k, k] = af.omega_max
    dyn.step(st, w_com, np.ones((4, 4)), np.zeros((3, 4)), np.zeros((3, 4)))
    rate = st.omega  # (3, vehicles) after one step from rest: sign of the torque
    if frame == "quad_x":
        roll_sign, pitch_sign = [-1, 1, 1, -1], [1, -1, 1, -1]  # FR, RL, FL, RR
    else:
        roll_sign, pitch_sign = [-1, 1, 0, 0], [0, 0, 1, -1]  # right, left, front, rear
    yaw_sign = [1, 1, -1, -1]  # 1, 2 CCW; 3, 4 CW
    for k in range(4):
        assert np.sign(np.round(rate[0, k], 9)) == roll_sign[k]
        assert np.sign(np.round(rate[1, k], 9)) == pitch_sign[k]
        assert np.sign(rate[2, k]) == yaw_sign[k]


def _mix_one(frame: str, torque) -> np.ndarray:
    vp = VehicleParams.from_airframes([preset("x500", frame)])
    mr, mp, my = mixer_matrices(vp)
    thrust = np.array([0.5 * 4 * vp.thrust_max[0]])
    u, _, _ = mix(thrust, np.asarray(torque, float)[:, None], mr, mp, my, vp.thrust_max, np.array([True]))
    return u[:, 0]


def test_quad_x_mixer_maps_torques_to_the_right_motors():
    u = _mix_one("quad_x", [0.3, 0.0, 0.0])  # roll right (right side down): left motors up
    assert u[1] > 0.5 and u[2] > 0.5 and u[0] < 0.5 and u[3] < 0.5
    u = _mix_one("quad_x", [0.0, 0.3, 0.0])  # pitch up: front motors (1, 3) up
    assert u[0] > 0.5 and u[2] > 0.5 and u[1] < 0.5 and u[3] < 0.5
    u = _mix_one("quad_x", [0.0, 0.0, 0.05])  # yaw right: CCW motors (1, 2) up
    assert u[0] > 0.5 and u[1] > 0.5 and u[2] < 0.5 and u[3] < 0.5
    assert u.mean() == pytest.approx(0.5)


def test_quad_plus_mixer_maps_torques_to_the_right_motors():
    u = _mix_one("quad_plus", [0.3, 0.0, 0.0])  # roll right: left motor (2) up, right (1) down
    assert u[1] > 0.5 and u[0] < 0.5 and u[2] == pytest.approx(u[3])
    u = _mix_one("quad_plus", [0.0, 0.3, 0.0])  # pitch up: front (3) up, rear (4) down
    assert u[2] > 0.5 and u[3] < 0.5 and u[0] == pytest.approx(u[1])
    u = _mix_one("quad_plus", [0.0, 0.0, 0.05])
    assert u[0] > 0.5 and u[1] > 0.5 and u[2] < 0.5 and u[3] < 0.5


def test_mixer_saturation_keeps_roll_and_gives_up_yaw():
    vp = VehicleParams.from_airframes([preset("x500")])
    mr, mp, my = mixer_matrices(vp)
    thrust = np.array([0.9 * 4 * vp.thrust_max[0]])  # high collective
    u, rp_sat, yaw_sat = mix(thrust, np.array([[1.0], [0.0], [5.0]]), mr, mp, my, vp.thrust_max, np.array([True]))
    u = u[:, 0]
    assert u.min() >= 0.0 and u.max() <= 1.0
    assert yaw_sat[0]
    # Roll differential (left minus right) survives intact; the collective was shifted down.
    roll_only, _, _ = mix(thrust, np.array([[1.0], [0.0], [0.0]]), mr, mp, my, vp.thrust_max, np.array([True]))
    roll_only = roll_only[:, 0]
    assert (u[1] + u[2]) - (u[0] + u[3]) == pytest.approx((roll_only[1] + roll_only[2]) - (roll_only[0] + roll_only[3]))


@pytest.fixture(scope="module")
def hover_batch():
    """Five preset airframes (one quad-+), noise-free hover; motor 2/3/1/4 at η 0.8 on four of them."""
    damages = [Damage(), Damage(2, 0.8), Damage(3, 0.8), Damage(1, 0.8), Damage(4, 0.8)]
    return simulate_batch(5, airframes=PRESET_SET, damages=damages, mission="hover", duration_s=34.0,
                          profile="training", realism=False, seed=11,
                          extra_streams={"pos": 4, "thrust": 4, "w_com": 4, "motors": 4})


def test_hover_thrust_equals_weight(hover_batch):
    res = hover_batch.result
    for j, af in enumerate(hover_batch.airframes):
        m = _steady_hover_mask(hover_batch, j)
        total = res.data["thrust"][m, j].astype(np.float64).sum(axis=1).mean()
        assert total == pytest.approx(af.mass * GRAVITY, rel=0.01), af.name


def test_damaged_motor_is_commanded_one_over_eta_higher(hover_batch):
    res = hover_batch.result
    for j, d in enumerate(hover_batch.damages):
        m = _steady_hover_mask(hover_batch, j)
        u = res.data["motors"][m, j].astype(np.float64).mean(axis=0)
        if d.motor == 0:
            assert u.max() / u.min() == pytest.approx(1.0, abs=0.01)
            continue
        k = d.motor - 1
        others = np.delete(u, k).mean()
        assert u[k] / others == pytest.approx(1.0 / d.eta, rel=0.02)


def test_rho_physical_mode_reproduces_rho_in_hover():
    rho = np.array([1.0, 1.03, 0.97, 1.05])
    b = simulate_batch(2, airframes=[preset("sih"), preset("f450", "quad_plus")], damages=None, healthy_fraction=1.0,
                       mission="hover", duration_s=30.0, profile="training", realism=False, rho=rho, seed=4,
                       extra_streams={"pos": 4, "w_com": 4})
    for j in range(2):
        m = _steady_hover_mask(b, j)
        w = b.result.data["w_com"][m, j].astype(np.float64).mean(axis=0)
        np.testing.assert_allclose(w / w[0], rho, rtol=0.01)


def test_rho_paper_mode_applies_the_literal_speed_formula():
    """Paper mode: the air sees w_a = ρ·w²/w_max, so equal hover thrusts need w_i ∝ 1/sqrt(ρ_i)."""
    rho = np.array([1.0, 1.04, 0.96, 1.02])
    b = simulate_batch(1, airframes="sih", damages=None, healthy_fraction=1.0, mission="hover", duration_s=30.0,
                       profile="training", realism=False, rho=rho, rho_mode="paper", seed=4,
                       extra_streams={"pos": 4, "w": 4, "thrust": 4})
    m = _steady_hover_mask(b, 0)
    w = b.result.data["w"][m, 0].astype(np.float64).mean(axis=0)
    np.testing.assert_allclose(w / w[0], np.sqrt(rho[0] / rho), rtol=0.01)
    af = b.airframes[0]
    assert b.result.data["thrust"][m, 0].astype(np.float64).sum(axis=1).mean() == pytest.approx(af.mass * GRAVITY,
                                                                                                rel=0.01)


def test_min_feasible_eta_leaves_control_margin():
    for af in list(PRESETS.values()) + random_airframes(50, np.random.default_rng(8)):
        eta = min_feasible_eta(af)
        # Hover command of the damaged motor within MAX_DAMAGED_COMMAND...
        assert af.hover_command / eta <= MAX_DAMAGED_COMMAND + 1e-9
        # ...and the P-only tilt from the damage torque within MAX_STATIC_TILT_DEG.
        lever = af.arm if af.frame == "quad_plus" else af.arm / np.sqrt(2.0)
        alpha = (1.0 - eta) * af.mass * GRAVITY / 4.0 * lever / min(af.inertia[:2])
        assert np.degrees(alpha / (af.gains.rate_kp[0] * af.gains.att_p[0])) <= MAX_STATIC_TILT_DEG + 1e-6
    afs = random_airframes(40, np.random.default_rng(9))
    dmg = random_damages(afs, np.full(40, 60.0), np.random.default_rng(10), healthy_fraction=0.0)
    assert all(d.eta >= min_feasible_eta(a) - 1e-12 and 1 <= d.motor <= 4 for a, d in zip(afs, dmg))
    with pytest.raises(ValueError):
        Damage(5, 0.8)
    with pytest.raises(ValueError):
        Damage(0, 0.9)


def test_resolve_rho_modes():
    rng = np.random.default_rng(0)
    np.testing.assert_array_equal(resolve_rho(None, 3, rng), np.ones((3, 4)))
    r = resolve_rho("random", 500, rng)
    assert (r[:, 0] == 1.0).all() and np.abs(r - 1).max() <= 0.08 + 1e-12 and r[:, 1:].std() > 0.02
    np.testing.assert_array_equal(resolve_rho([1, 1.1, 0.9, 1], 2, rng), [[1, 1.1, 0.9, 1]] * 2)
    with pytest.raises(ValueError):
        resolve_rho([1, 1, 1], 2, rng)


def test_thrust_curve_signal_inverts_the_autopilot_model():
    u = np.linspace(0.0, 1.0, 11)
    for curve in (0.0, 0.3, 0.65):
        s = thrust_to_signal(u, curve)
        np.testing.assert_allclose((1 - curve) * s + curve * s * s, u, atol=1e-12)
        assert (s >= u - 1e-12).all()  # an expo curve needs more signal than thrust


def test_damaged_propeller_vibration_at_its_rotation_frequency():
    """Noise-free gyro with one unbalanced rotor: the sampled vibration sits at that rotor's
    (aliased) rotation frequency with the filtered amplitude of damage.py / sensors.py."""
    af = preset("sih")
    vp = VehicleParams.from_airframes([af])
    sp = replace(SensorParams.draw([af], np.random.default_rng(1)), gyro_noise_density=np.zeros(1),
                 gyro_bias=np.zeros((1, 3)), turbulence_std=np.zeros((1, 3)), vibration_gain=1.2)
    dt = 1.0 / 250.0
    sens = Sensors(sp, vp, dt, 10 * dt, np.random.default_rng(2))
    w = np.array([[700.0], [650.0], [600.0], [550.0]])  # rad/s, rotor 2 is the damaged one
    imbalance = np.array([[0.0], [0.3], [0.0], [0.0]])
    pos, vel = np.zeros((3, 1)), np.zeros((3, 1))
    out = []
    for i in range(2500):
        if i % 10 == 0:
            sens.nav(pos, vel, w, imbalance)
        out.append(sens.gyro_and_disturbance(np.zeros((3, 1)))[0][:, 0].copy())
    roll = np.array(out)[500:, 0]
    f_rot = 650.0 / (2 * np.pi)
    expected_amp = 1.2 * 0.3 * (650.0 / af.omega_max) ** 2 / np.sqrt(1 + (f_rot / af.gyro_cutoff_hz) ** 4)
    assert roll.std() * np.sqrt(2.0) == pytest.approx(expected_amp, rel=0.05)
    spec = np.abs(np.fft.rfft(roll * np.hanning(roll.size)))
    freqs = np.fft.rfftfreq(roll.size, dt)
    alias = abs(((f_rot + 125.0) % 250.0) - 125.0)  # folded into 0..125 Hz by 250 Hz sampling
    assert freqs[spec.argmax()] == pytest.approx(alias, abs=0.5)


def test_random_damage_on_a_weak_airframe_stays_a_real_damage():
    weak = replace(preset("x500"), k_f=preset("x500").k_f * 0.65, gains=None)  # hover command 0.73
    dmg = random_damages([weak] * 30, np.full(30, 60.0), np.random.default_rng(1), healthy_fraction=0.0,
                         eta_range=(0.6, 0.95))
    assert all(1 <= d.motor <= 4 and d.eta == pytest.approx(0.95) for d in dmg)


def test_paper_speed_gain_divides_each_vehicle_by_its_own_speed_scale():
    """(rotors, vehicles) arrays against (vehicles,) speed scales: 3 vehicles used to fail to
    broadcast, and 4 divided rotor i by vehicle i's scale."""
    from flightlog_fd.sim.rho import paper_speed_gain

    rho = np.array([[1.0, 1.0, 1.0, 1.0], [1.1, 1.1, 1.1, 1.1], [0.9, 0.9, 0.9, 0.9], [1.0, 1.0, 1.0, 1.0]])
    for n in (3, 4):
        omega_max = np.array([1000.0, 2000.0, 4000.0, 8000.0])[:n]
        w = np.tile(omega_max / 2, (4, 1))  # every rotor at half its vehicle's scale
        gain = paper_speed_gain(rho[:, :n], w, omega_max)
        np.testing.assert_allclose(gain, rho[:, :n] / 2)


def test_weak_motor_turns_slower_for_its_command_with_its_propeller_intact():
    """sim/damage.py cause "motor": the rotor turns at sqrt(eta) of its commanded speed, so it is
    commanded 1/eta as a damaged propeller is, but turns slower per command (the propeller
    turns as fast as commanded) and gives its share of thrust at a lower speed per command."""
    damages = [Damage(2, 0.8, cause="motor"), Damage(2, 0.8)]
    b = simulate_batch(2, airframes=[preset("f450")] * 2, damages=damages, mission="hover", duration_s=34.0,
                       profile="training", realism=False, seed=11, extra_streams={"pos": 4, "w": 4, "motors": 4})
    res = b.result
    speed_per_command = []
    for j in range(2):
        m = _steady_hover_mask(b, j)
        u = res.data["motors"][m, j].astype(np.float64)
        w = res.data["w"][m, j].astype(np.float64).mean(axis=0)
        assert u.mean(axis=0)[1] / np.delete(u.mean(axis=0), 1).mean() == pytest.approx(1.0 / 0.8, rel=0.02)
        per = w / np.sqrt(u).mean(axis=0)
        speed_per_command.append(per[1] / np.delete(per, 1).mean())
    assert speed_per_command[0] == pytest.approx(np.sqrt(0.8), rel=0.01)  # weak motor: slower per command
    assert speed_per_command[1] == pytest.approx(1.0, rel=0.01)  # damaged propeller: as commanded
    with pytest.raises(ValueError, match="cause"):
        Damage(1, 0.8, cause="esc")
