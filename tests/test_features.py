"""streams.py, prepared.resample and windows.py: resampling, derivative, thrust proxy, windows, labels, FeatureSpec."""
from __future__ import annotations

import json

import numpy as np
import pytest

from flightlog_fd import prepared as P
from flightlog_fd import streams as S
from flightlog_fd import windows as F
from flightlog_fd.errors import MissingDataError, NotDiagnosableError, UnsupportedVehicleError
from flightlog_fd.flight import Flight, Frame, Rotor, Series


def synthetic_flight(duration=40.0, rate_hz=250.0, motor_hz=None, airborne=None, rates_fn=None,
                     motors_fn=None, attitude_fn=None, **kw) -> Flight:
    """A Flight with analytic streams. ``*_fn(t) -> (n, k)``; defaults: still, level, equal motors."""
    t = np.arange(0.0, duration, 1.0 / rate_hz)
    tm = np.arange(0.0, duration, 1.0 / (motor_hz or rate_hz))
    rates_fn = rates_fn or (lambda t: np.zeros((t.size, 3)))
    motors_fn = motors_fn or (lambda t: np.full((t.size, 4), 0.5))
    attitude_fn = attitude_fn or (lambda t: np.zeros((t.size, 2)))
    args = dict(path="synthetic.ulg", autopilot="px4", frame=Frame.quad_x(), rates=Series(t, rates_fn(t), "rates"),
                attitude=Series(t, attitude_fn(t), "att"), motors=Series(tm, motors_fn(tm), "motors"),
                airborne=airborne if airborne is not None else [(2.0, duration - 2.0)],
                t_start=0.0, t_end=duration)
    args.update(kw)
    return Flight(**args)


def _fit_sinusoid(t, y, f):
    """Amplitude and phase of y ~ a cos + b sin at frequency f."""
    A = np.c_[np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t), np.ones_like(t)]
    a, b, _ = np.linalg.lstsq(A, y, rcond=None)[0]
    return np.hypot(a, b), np.arctan2(-b, a)


@pytest.mark.parametrize("gyro_hz", [50.0, 250.0])
@pytest.mark.parametrize("freq", [0.5, 1.5])
def test_derivative_of_sine_is_cosine(gyro_hz, freq):
    amp = 0.8  # rad/s
    fl = synthetic_flight(rate_hz=gyro_hz, motor_hz=50.0,
                          rates_fn=lambda t: np.c_[amp * np.sin(2 * np.pi * freq * t), np.zeros(t.size), np.zeros(t.size)])
    segs = P.resample(fl, 50.0)
    assert len(segs) == 1
    s = segs[0]
    got_amp, got_phase = _fit_sinusoid(s.t, s.ang_acc[:, 0], freq)
    want = amp * 2 * np.pi * freq  # d/dt A sin(wt) = A w cos(wt): phase 0 against cos
    assert got_amp == pytest.approx(want, rel=0.03)
    assert abs(got_phase) < 0.03  # rad: the symmetric filter adds no lag
    # The smoothed rate keeps the sine itself.
    r_amp, r_phase = _fit_sinusoid(s.t, s.rates[:, 0], freq)
    assert r_amp == pytest.approx(amp, rel=0.03)


def test_derivative_reduces_noise_versus_finite_difference():
    rng = np.random.default_rng(0)
    sigma = np.deg2rad(6.0)  # SIH's roll noise
    fl = synthetic_flight(rate_hz=250.0, rates_fn=lambda t: rng.normal(0, sigma, (t.size, 3)))
    s = P.resample(fl, 50.0)[0]
    naive = np.std(np.diff(fl.rates.values[:, 0]) * 250.0)
    assert np.std(s.ang_acc[:, 0]) < naive / 10.0


def _distinct_flight(**kw):
    """p = t, q = 2t, r = -3t (so p_dot, q_dot, r_dot = 1, 2, -3); motors 0.1..0.4; roll 0.01, pitch 0.02."""
    return synthetic_flight(rates_fn=lambda t: np.c_[t, 2 * t, -3 * t],
                            motors_fn=lambda t: np.tile([0.1, 0.2, 0.3, 0.4], (t.size, 1)),
                            attitude_fn=lambda t: np.tile([0.01, 0.02], (t.size, 1)), **kw)


def test_nif_windows_shape_times_and_channel_order():
    fl = _distinct_flight()
    w = F.make_windows(fl, F.FeatureSpec("nif", transform="raw"))
    # airborne 2..38 s, trimmed 1 s each side: 3..37 s -> 1701 samples at 50 Hz
    n_expected = (1701 - 80) // 40 + 1
    assert w.X.shape == (n_expected, 7, 80) and w.X.dtype == np.float32
    assert w.t_start[0] == pytest.approx(3.0)
    assert np.allclose(np.diff(w.t_start), 0.8)
    assert np.allclose(w.t_end - w.t_start, 79 / 50.0)
    assert w.t_end[-1] <= 37.0 + 1e-9
    mid = w.X[:, :, 5:-5]  # away from the filter's edge handling
    assert np.allclose(mid[:, 0], 1.0, atol=1e-3)
    assert np.allclose(mid[:, 1], 2.0, atol=1e-3)
    assert np.allclose(mid[:, 2], -3.0, atol=1e-3)
    for k, v in enumerate([0.1, 0.2, 0.3, 0.4]):
        assert np.allclose(w.X[:, 3 + k], v, atol=1e-6)
    assert w.speed_source == "command"
    assert F.FeatureSpec("nif").channels == ("p_dot", "q_dot", "r_dot", "w1_sq", "w2_sq", "w3_sq", "w4_sq")


def test_scale_free_nif_thrust_shares_and_cf_order():
    fl = _distinct_flight()
    w = F.make_windows(fl, F.FeatureSpec("nif"))
    # mean thrust 0.25 -> shares 0.4, 0.8, 1.2, 1.6
    for k, v in enumerate([0.4, 0.8, 1.2, 1.6]):
        assert np.allclose(w.X[:, 3 + k], v, atol=1e-5)
    c = F.make_windows(fl, F.FeatureSpec("cf", transform="raw"))
    assert c.X.shape[1:] == (9, 80)
    assert np.allclose(c.X[:, 0], 0.01, atol=1e-6) and np.allclose(c.X[:, 1], 0.02, atol=1e-6)
    t_mid = c.t_start[3] + 40 / 50.0
    assert c.X[3, 2, 40] == pytest.approx(t_mid, abs=1e-3)  # p = t
    assert c.X[3, 4, 40] == pytest.approx(-3 * t_mid, abs=1e-2)  # r = -3t
    for k, v in enumerate([0.1, 0.2, 0.3, 0.4]):
        assert np.allclose(c.X[:, 5 + k], np.sqrt(v), atol=1e-5)  # w = sqrt(thrust)


def test_scale_free_makes_two_scales_equal():
    base_rates = lambda t: np.c_[0.3 * np.sin(2.1 * t), 0.2 * np.sin(1.3 * t + 1), 0.1 * np.sin(0.7 * t)]
    base_motors = lambda t: 0.3 + 0.05 * np.c_[np.sin(t), np.cos(t), np.sin(2 * t), np.cos(3 * t)]
    small = synthetic_flight(rates_fn=base_rates, motors_fn=base_motors)
    # A bigger, sluggish vehicle: 4x the angular motion, 2.5x the hover command (scaled thrust).
    big = synthetic_flight(rates_fn=lambda t: 4.0 * base_rates(t), motors_fn=lambda t: 2.5 * base_motors(t))
    a = F.make_windows(small, F.FeatureSpec("nif"))
    b = F.make_windows(big, F.FeatureSpec("nif"))
    assert np.allclose(a.X, b.X, atol=1e-4)
    ra = F.make_windows(small, F.FeatureSpec("nif", transform="raw"))
    rb = F.make_windows(big, F.FeatureSpec("nif", transform="raw"))
    assert not np.allclose(ra.X, rb.X, atol=1e-2)


def test_gap_splits_segments_and_no_window_crosses_it():
    fl = _distinct_flight(duration=60.0)
    # Drop 0.8 s of motor data (logger dropout) around t = 20 s, and NaN gyro around 40 s.
    m = fl.motors
    keep = (m.t < 20.0) | (m.t > 20.8)
    fl.motors = Series(m.t[keep], m.values[keep], m.source)
    r = fl.rates.values.copy()
    r[(fl.rates.t > 40.0) & (fl.rates.t < 40.3)] = np.nan
    fl.rates = Series(fl.rates.t, r, fl.rates.source)
    segs = P.resample(fl, 50.0)
    assert len(segs) == 3
    assert segs[0].t[-1] <= 20.0 and segs[1].t[0] >= 20.8
    assert segs[1].t[-1] <= 40.0 and segs[2].t[0] >= 40.3
    w = F.make_windows(fl, F.FeatureSpec("nif"))
    for g0, g1 in [(20.0, 20.8), (40.0, 40.3)]:
        assert not np.any((w.t_start < g1) & (w.t_end > g0))
    assert set(w.segment.tolist()) == {0, 1, 2}
    # The derivative is exact right up to the gap's edges (nothing interpolated across it).
    raw = F.make_windows(fl, F.FeatureSpec("nif", transform="raw"))
    assert np.allclose(raw.X[:, 0], 1.0, atol=1e-6) and np.allclose(raw.X[:, 2], -3.0, atol=1e-6)


def test_slow_motors_are_interpolated_and_usable():
    # 10 Hz actuator_motors (PX4 default profile): a ramp is reproduced exactly on the 50 Hz grid.
    fl = synthetic_flight(motor_hz=10.0, rate_hz=50.0,
                          motors_fn=lambda t: np.c_[0.3 + 0.001 * t, 0.3 + 0.002 * t, 0.3 + 0 * t, 0.3 + 0 * t])
    segs = P.resample(fl, 50.0)
    assert len(segs) == 1
    s = segs[0]
    assert np.allclose(s.motors[:, 0], 0.3 + 0.001 * s.t, atol=1e-9)
    w = F.make_windows(fl, F.FeatureSpec("nif", transform="raw"))
    assert len(w) > 30
    # A single lost 10 Hz sample (0.2 s interval) is not a gap; three lost samples are.
    m = fl.motors
    drop1 = np.ones(len(m), bool)
    drop1[100] = False
    fl.motors = Series(m.t[drop1], m.values[drop1])
    assert len(P.resample(fl, 50.0)) == 1
    drop3 = np.ones(len(m), bool)
    drop3[100:103] = False
    fl.motors = Series(m.t[drop3], m.values[drop3])
    assert len(P.resample(fl, 50.0)) == 2


def test_trim_and_multiple_airborne_intervals():
    fl = _distinct_flight(duration=60.0, airborne=[(2.0, 20.0), (30.0, 55.0)])
    w = F.make_windows(fl, F.FeatureSpec("nif", trim_s=1.5))
    first = w.t_start[w.segment == 0]
    second = w.t_start[w.segment == 1]
    assert first.min() >= 3.5 - 1e-9 and w.t_end[w.segment == 0].max() <= 18.5 + 1e-9
    assert second.min() >= 31.5 - 1e-9 and w.t_end[w.segment == 1].max() <= 53.5 + 1e-9


def test_thrust_proxy_inverts_px4_thr_mdl_fac():
    thrust = np.linspace(0, 1, 101)
    f = 0.3
    # PX4 FunctionMotors: signal x solves f x^2 + (1-f) x = thrust.
    x = (-(1 - f) + np.sqrt((1 - f) ** 2 + 4 * f * thrust)) / (2 * f)
    assert np.allclose(S.thrust_proxy(x, "signal", f, "px4"), thrust, atol=1e-12)
    assert np.allclose(S.thrust_proxy(thrust, "thrust", f, "px4"), thrust)


def test_thrust_proxy_inverts_ardupilot_expo_with_spin_range():
    thrust = np.linspace(0, 1, 101)
    e, lo, hi = 0.65, 0.12, 0.95
    # AP Thrust_Linearization::thrust_to_actuator
    ratio = ((e - 1) + np.sqrt((1 - e) ** 2 + 4 * e * thrust)) / (2 * e)
    actuator = lo + (hi - lo) * ratio
    got = S.thrust_proxy(actuator, "signal", e, "ardupilot", spin_min=lo, spin_max=hi)
    assert np.allclose(got, thrust, atol=1e-12)
    # Defaults (0.15 / 0.95 / 0.65) when the log has no parameters: half thrust at the default curve.
    default_ratio = ((0.65 - 1) + np.sqrt(0.35 ** 2 + 4 * 0.65 * 0.5)) / (2 * 0.65)
    u = 0.15 + 0.8 * default_ratio
    assert S.thrust_proxy(np.array([u]), "signal", None, "ardupilot")[0] == pytest.approx(0.5)
    # flight_thrust_proxy reads MOT_SPIN_MIN / MAX from the log's parameters.
    fl = synthetic_flight(autopilot="ardupilot", motor_kind="signal", thrust_curve=e,
                          params={"MOT_SPIN_MIN": lo, "MOT_SPIN_MAX": hi},
                          motors_fn=lambda t: np.full((t.size, 4), actuator[50]))
    assert np.allclose(S.flight_thrust_proxy(fl), thrust[50])


def test_esc_rpm_used_in_auto_mode_only_when_fast_enough():
    rpm_t = np.arange(0, 40, 1 / 50.0)
    rpm = np.tile([10000.0, 12000.0, 10000.0, 10000.0], (rpm_t.size, 1))
    fl = synthetic_flight(esc_rpm=Series(rpm_t, rpm, "esc_status"))
    w = F.make_windows(fl, F.FeatureSpec("nif", speed_source="auto", transform="raw"))
    assert w.speed_source == "esc_rpm"
    assert np.allclose(w.X[:, 4], 1.0) and np.allclose(w.X[:, 3], (10 / 12) ** 2)
    assert F.make_windows(fl, F.FeatureSpec("nif")).speed_source == "command"
    slow_t = np.arange(0, 40, 1 / 5.0)
    fl.esc_rpm = Series(slow_t, np.tile([1e4] * 4, (slow_t.size, 1)))
    assert F.make_windows(fl, F.FeatureSpec("nif", speed_source="auto")).speed_source == "command"
    with pytest.raises(MissingDataError):
        F.make_windows(fl, F.FeatureSpec("nif", speed_source="esc_rpm"))


def test_window_labels_with_midflight_onset():
    fl = _distinct_flight(duration=60.0)
    w = F.make_windows(fl, F.FeatureSpec("nif"))
    fl.truth = {"label": 3, "motor": 3, "eta": 0.8, "onset_s": 30.0}
    y = F.window_labels(fl, w)
    assert set(y.tolist()) == {0, -1, 3}
    assert np.all(y[w.t_end < 30.0] == 0)
    assert np.all(y[w.t_start >= 30.0] == 3)
    assert np.all(y[(w.t_start < 30.0) & (w.t_end >= 30.0)] == -1)
    fl.truth = {"label": 2, "motor": 2, "eta": 0.7, "onset_s": None}
    assert np.all(F.window_labels(fl, w) == 2)
    fl.truth = {"label": 0, "motor": 0, "eta": 1.0, "onset_s": None}
    assert np.all(F.window_labels(fl, w) == 0)
    fl.truth = None
    with pytest.raises(ValueError):
        F.window_labels(fl, w)


def test_feature_spec_round_trip_fit_normalise():
    spec = F.FeatureSpec("nif", stride=20, transform="raw")
    with pytest.raises(ValueError, match="not fitted"):
        spec.normalise(np.zeros((2, 7, 80)))
    rng = np.random.default_rng(2)
    X = rng.normal(loc=np.arange(7)[None, :, None], scale=np.arange(1, 8)[None, :, None], size=(200, 7, 80))
    spec.fit(X)
    Z = spec.normalise(X)
    assert Z.dtype == np.float32
    assert np.allclose(Z.mean(axis=(0, 2)), 0, atol=1e-5) and np.allclose(Z.std(axis=(0, 2)), 1, atol=1e-4)
    d = json.loads(json.dumps(spec.to_dict()))
    back = F.FeatureSpec.from_dict(d)
    assert back.to_dict() == spec.to_dict()
    assert np.allclose(back.normalise(X), Z)
    with pytest.raises(ValueError):
        F.FeatureSpec.from_dict({**d, "channels": ["a"] * 7})
    with pytest.raises(ValueError):
        F.FeatureSpec.from_dict({**d, "bogus": 1})
    with pytest.raises(ValueError):
        F.FeatureSpec.from_dict({**d, "version": 99})


def test_bad_inputs_raise_flightlog_errors():
    fl = synthetic_flight(airborne=[])
    w = F.make_windows(fl)
    assert len(w) == 0 and "never airborne" in w.reason
    with pytest.raises(NotDiagnosableError, match="never airborne"):
        F.make_windows(fl, strict=True)
    short = synthetic_flight(airborne=[(2.0, 4.5)])
    with pytest.raises(NotDiagnosableError, match="window needs 1.6 s"):
        F.make_windows(short, strict=True)
    nomotors = synthetic_flight(motors=None)
    with pytest.raises(MissingDataError, match="motor"):
        F.make_windows(nomotors)
    hexa = synthetic_flight(frame=Frame("hexa", tuple(Rotor(1, 0, 1) for _ in range(6))))
    with pytest.raises(UnsupportedVehicleError, match="hexa"):
        F.make_windows(hexa)
    two_axes = synthetic_flight(rates_fn=lambda t: np.zeros((t.size, 2)))
    with pytest.raises(MissingDataError, match="2 axes"):
        F.make_windows(two_axes)
    noatt = synthetic_flight(attitude=None)
    assert len(F.make_windows(noatt, F.FeatureSpec("nif"))) > 0
    with pytest.raises(MissingDataError, match="attitude"):
        F.make_windows(noatt, F.FeatureSpec("cf"))


# ----------------------------------------------------------------------------- real logs (../shared)

def test_sih_logs_windows_and_damage_share(shared):
    from flightlog_fd import load_flight

    healthy = load_flight(shared("px4_sih_dev", "logs", "sih_004.ulg"))  # 250 Hz
    w = F.make_windows(healthy, F.FeatureSpec("nif"))
    assert len(w) >= 60 and w.X.shape[1:] == (7, 80) and np.all(np.isfinite(w.X))
    (a, b), = healthy.airborne
    assert w.t_start.min() >= a + 1.0 - 1e-9 and w.t_end.max() <= b - 1.0 + 1e-9
    assert np.allclose(w.X[:, 3:].mean(axis=(0, 2)), 1.0, atol=0.02)  # balanced: equal thrust shares
    default_profile = load_flight(shared("px4_sih_dev", "logs", "sih_008.ulg"))  # 10 Hz actuator_motors
    assert default_profile.motors.rate_hz == pytest.approx(10.0, rel=0.05)
    assert len(F.make_windows(default_profile, F.FeatureSpec("nif"))) >= 60
    damaged = load_flight(shared("px4_sih_dev", "logs", "sih_035.ulg"))  # motor 2, eta 0.7, from take-off
    shares = F.make_windows(damaged, F.FeatureSpec("nif")).X[:, 3:].mean(axis=(0, 2))
    assert int(np.argmax(shares)) == 1 and shares[1] > 1.15


def test_real_logs_give_windows_or_clear_reasons(shared):
    from flightlog_fd import load_flight

    erle = load_flight(shared("real_logs", "ardupilot", "erle_copter34_7.BIN"))  # 24 Hz gyro and mixer
    w = F.make_windows(erle, F.FeatureSpec("nif"))
    assert len(w) >= 50 and np.all(np.isfinite(w.X))
    ground = load_flight(shared("real_logs", "px4", "robologs_f450_ground.ulg"))
    g = F.make_windows(ground)
    assert len(g) == 0 and "never airborne" in g.reason
    vtol = load_flight(shared("real_logs", "px4", "sample_log_small.ulg"))
    with pytest.raises(UnsupportedVehicleError, match="quadrotors"):
        F.make_windows(vtol)
