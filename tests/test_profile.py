"""profile.py: Profile JSON round trip and validation; calibration.py: rho estimation, calibrate_profile."""
from __future__ import annotations

import json

import numpy as np
import pytest

from flightlog_fd.errors import NotDiagnosableError, ProfileError, UnsupportedVehicleError
from flightlog_fd.windows import FeatureSpec
from flightlog_fd.flight import Frame, Rotor
from flightlog_fd.calibration import calibrate_profile, estimate_imbalance
from flightlog_fd.profile import PROFILE_SCHEMA, Profile
from flightlog_fd.util import file_sha256
from test_hover import mission_flight

RHO = (1.0, 1.06, 0.96, 1.02)


@pytest.mark.parametrize("kw", [
    dict(),
    dict(gyro_hz=50.0, motor_hz=10.0),
    dict(gyro_hz=100.0, motor_hz=100.0, gyro_noise_deg=2.0, hover_thrust=0.65, with_velocity=False),
])
def test_rho_recovered_on_synthetic_hover(kw):
    est = estimate_imbalance([mission_flight(rho=RHO, **kw)])
    # motor noise 0.01 on a 0.5 command, >= 12 s of hover: ratios within 0.3 %
    assert np.allclose(est.rho, RHO, atol=0.003)
    assert est.rho[0] == 1.0
    assert est.n_segments == 3 and est.hover_s >= 12.0
    assert np.all(est.rho_spread < 0.005) and est.rho_spread[0] == 0.0
    assert est.hover_throttle == pytest.approx(kw.get("hover_thrust", 0.5), rel=0.01)


def test_rho_with_pwm_signal_and_thrust_curve():
    # ArduPilot RCOU: commands are actuator values after MOT_THST_EXPO and the spin range; the
    # speed ratios come back only if the curve is undone.
    e, lo, hi = 0.65, 0.15, 0.95
    fl = mission_flight(rho=RHO, autopilot="ardupilot", motor_noise=0.002)
    thrust = fl.motors.values
    ratio = ((e - 1) + np.sqrt((1 - e) ** 2 + 4 * e * thrust)) / (2 * e)
    fl.motors.values = lo + (hi - lo) * ratio
    fl.motor_kind, fl.thrust_curve = "signal", e
    fl.params = {"MOT_SPIN_MIN": lo, "MOT_SPIN_MAX": hi}
    est = estimate_imbalance([fl])
    assert np.allclose(est.rho, RHO, atol=0.003)


def test_too_little_hover_falls_back_to_steady_flight_then_airborne_then_raises():
    fl = mission_flight(rho=RHO)
    est = estimate_imbalance([fl], min_hover_s=60.0)  # no 60 s of hover or steady flight
    assert est.source == "airborne mean" and est.hover_s >= 20.0
    assert np.allclose(est.rho, RHO, atol=0.03)  # the airborne mean still carries the trim pattern
    a, b = fl.airborne[0]
    fl.airborne = [(a, a + 12.0)]
    with pytest.raises(NotDiagnosableError) as ei:
        estimate_imbalance([fl], min_hover_s=60.0)
    msg = str(ei.value)
    assert "mission.ulg" in msg and "steady flight" in msg and "20 s of airborne flight" in msg
    fl.airborne = []
    with pytest.raises(NotDiagnosableError, match="found 0.0 s of steady hover"):
        estimate_imbalance([fl])


def _profile(tmp_path):
    fl = mission_flight(rho=RHO, path=str(tmp_path / "healthy.ulg"))
    (tmp_path / "healthy.ulg").write_bytes(b"ULog fake bytes for the hash")
    return calibrate_profile([fl], spec=FeatureSpec("nif"))


def test_calibrate_profile_values(tmp_path):
    p = _profile(tmp_path)
    assert p.autopilot == "px4" and p.frame == "quad_x" and p.rotor_count == 4
    assert np.allclose(p.rho_, RHO, atol=0.003)
    assert p.hover_throttle_ == pytest.approx(0.5, rel=0.01)
    spec = p.spec
    assert spec.fitted and spec.features == "nif" and p.n_windows_ > 10
    assert p.source_logs == [{"name": "healthy.ulg", "sha256": file_sha256(tmp_path / "healthy.ulg")}]
    assert p.stream_rates["rates"] == pytest.approx(250.0, rel=1e-3)
    assert p.created.endswith("+00:00") and p.tool_version
    # thrust shares of the healthy windows: mean of motor 2's channel ~ its share rho^2/mean(rho^2)
    share = np.asarray(RHO) ** 2 / np.mean(np.asarray(RHO) ** 2)
    assert np.allclose(spec.mean[3:], share, atol=0.02)


def test_profile_round_trip_and_overwrite_refusal(tmp_path):
    p = _profile(tmp_path)
    path = tmp_path / "quad.profile.json"
    p.save(path)
    q = Profile.load(path)
    assert q.to_dict() == p.to_dict()
    assert json.loads(path.read_text())["schema"] == PROFILE_SCHEMA
    with pytest.raises(ProfileError, match="already exists"):
        p.save(path)
    p.hover_throttle_ = 0.4
    p.save(path, overwrite=True)
    assert Profile.load(path).hover_throttle_ == 0.4


def test_model_entry(tmp_path):
    p = _profile(tmp_path)
    path = tmp_path / "quad.profile.json"
    (tmp_path / "models").mkdir()
    model = tmp_path / "models" / "quad.onnx"
    model.write_bytes(b"onnx bytes")
    p.save(path)
    p.set_model(model)
    p.save(path, overwrite=True)
    q = Profile.load(path)
    assert q.model == {"path": "models/quad.onnx", "sha256": file_sha256(model)}
    assert q.model_path() == model.resolve()
    model.write_bytes(b"changed")
    with pytest.raises(ProfileError, match="sha256 mismatch"):
        q.model_path()
    outside = tmp_path.parent / "elsewhere.onnx"
    outside.write_bytes(b"x")
    with pytest.raises(ProfileError, match="next to the profile"):
        q.set_model(outside)


_BASE = {"share": [1.0, 1.0, 1.0, 1.0], "slope": [0.0] * 4, "throttle_ref": 0.5, "throttle_range": [0.45, 0.55]}
_SESSION = {"logs": [{"name": "a.ulg", "sha256": None}], "created": "2026-01-01T00:00:00+00:00", "seconds": 60.0,
            "share": [1.02, 0.98, 1.01, 0.99], "throttle": 0.5, "pin": [0.01, 0.01, 0.01, 0.01]}


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.pop("schema"), 'no "schema" key'),
    (lambda d: d.update(schema=8), "schema 8 is not supported"),
    (lambda d: d.update(sessions_={"share": [1.0] * 4}), "sessions_ must be a list"),
    (lambda d: d.update(sessions_=[_SESSION | {"share": [1.0] * 3}]), r"sessions_\[1\].share must be a list of 4"),
    (lambda d: d.update(sessions_=[_SESSION, _SESSION | {"throttle": 0}]), r"sessions_\[2\].throttle"),
    (lambda d: d.update(sessions_=[_SESSION | {"pin": [0.01, -0.01, 0.0, 0.0]}]), r"sessions_\[1\].pin values"),
    (lambda d: d.update(sessions_=[_SESSION | {"logs": ["a.ulg"]}]), r"sessions_\[1\].logs"),
    (lambda d: d.update(baseline_=_BASE | {"pin": [0.01, -0.01, 0.0, 0.0]}), "baseline_.pin values must be >= 0"),
    (lambda d: d.update(baseline_=_BASE | {"pin": [0.01, 0.01]}), "baseline_.pin"),
    (lambda d: d.pop("rho_"), "missing key"),
    (lambda d: d.update(rho_=[1.0, 1.1, 1.0]), "rho_ must be a list of 4"),
    (lambda d: d.update(rho_=[1.0, "x", 1.0, 1.0]), "rho_ must be a list of 4"),
    (lambda d: d.update(rho_=[1.2, 1.1, 1.0, 1.0]), "motor 1 is the reference"),
    (lambda d: d.update(rho_=[1.0, 9.0, 1.0, 1.0]), "within"),
    (lambda d: d.update(rho_spread_=[0, -1, 0, 0]), ">= 0"),
    (lambda d: d.update(hover_throttle_=0), "hover_throttle_"),
    (lambda d: d.update(autopilot="betaflight"), "autopilot must be"),
    (lambda d: d.update(rotor_count=5), "rotor_count must be one of 4, 6, 8"),
    (lambda d: d.update(rotor_count=6), "rho_ must be a list of 6"),
    (lambda d: d.update(bogus=1), "unknown key"),
    (lambda d: d["feature_spec"].update(window=-1), "feature_spec"),
    (lambda d: d.update(model={"path": "/abs/model.onnx", "sha256": "0" * 64}), "relative"),
    (lambda d: d.update(model={"path": "../model.onnx", "sha256": "0" * 64}), "relative"),
    (lambda d: d.update(model={"path": "m.onnx", "sha256": "xyz"}), "sha256"),
])
def test_profile_validation_errors(tmp_path, mutate, message):
    d = _profile(tmp_path).to_dict()
    mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ProfileError, match=message) as ei:
        Profile.load(path)
    assert str(path) in str(ei.value)


def test_profile_load_unreadable_files(tmp_path):
    with pytest.raises(ProfileError, match="no such profile"):
        Profile.load(tmp_path / "absent.json")
    junk = tmp_path / "junk.json"
    junk.write_text("{not json")
    with pytest.raises(ProfileError, match="not a JSON profile"):
        Profile.load(junk)
    arr = tmp_path / "list.json"
    arr.write_text("[1, 2]")
    with pytest.raises(ProfileError, match="JSON object"):
        Profile.load(arr)


def test_check_compatible(tmp_path):
    p = _profile(tmp_path)
    assert p.check_compatible(mission_flight()) == []
    plus = mission_flight(frame=Frame.quad_plus())
    with pytest.raises(ProfileError, match="profile was made for px4 quad_x, this log is px4 quad_plus"):
        p.check_compatible(plus)
    ardu = mission_flight(autopilot="ardupilot")
    with pytest.raises(ProfileError, match="this log is ardupilot quad_x"):
        p.check_compatible(ardu)
    p.vehicle_id = "A1"
    other = mission_flight()
    other.vehicle_id = "B2"
    assert p.check_compatible(other) == ["profile was made on vehicle A1, this log is from B2"]


def test_calibrate_refuses_mixed_damaged_and_non_quad(tmp_path):
    with pytest.raises(ProfileError, match="one airframe"):
        calibrate_profile([mission_flight(), mission_flight(frame=Frame.quad_plus())])
    damaged = mission_flight()
    damaged.truth = {"label": 2, "motor": 2, "eta": 0.8, "onset_s": None}
    with pytest.raises(ProfileError, match="healthy"):
        calibrate_profile([damaged])
    hexa = mission_flight(frame=Frame("hexa", tuple(Rotor(1, 0, 1) for _ in range(6))))
    with pytest.raises(UnsupportedVehicleError):
        calibrate_profile([hexa])


def test_sih_healthy_rho_is_one(shared):
    from flightlog_fd import load_flight

    fl = load_flight(shared("px4_sih_dev", "logs", "sih_004.ulg"))
    est = estimate_imbalance([fl])
    assert np.allclose(est.rho, 1.0, atol=0.01)  # SIH is perfectly balanced


def test_crazypad_motor2_runs_hardest(shared):
    from flightlog_fd import load_flight

    est = estimate_imbalance([load_flight(shared("crazypad_e9", "ulog", "normal_flight__E9_log00.ulg"))])
    assert est.rho[1] > 1.03 and int(np.argmax(est.rho)) == 1  # README: hover offset ~ +0.075 on motor 2
    prof = calibrate_profile([shared("crazypad_e9", "ulog", "normal_flight__E9_log01.ulg")])
    assert prof.rho_[1] > 1.03 and prof.source_logs[0]["name"] == "normal_flight__E9_log01.ulg"
    assert len(prof.source_logs[0]["sha256"]) == 64


def test_baseline_pin_and_range_read_back_and_older_schemas_load(tmp_path):
    """Schema 5's ``baseline_.pin`` is read into the Baseline with the calibrated throttle range;
    a schema-4 profile without it still loads (its pin is None: the flight's own stands in)."""
    d = _profile(tmp_path).to_dict()
    d["baseline_"] = _BASE | {"pin": [0.01, 0.02, 0.0, 0.03]}
    path = tmp_path / "p5.json"
    path.write_text(json.dumps(d))
    b = Profile.load(path).baseline()
    assert np.allclose(b.pin, [0.01, 0.02, 0.0, 0.03]) and b.throttle_range == (0.45, 0.55)
    d["schema"] = 4
    d["baseline_"] = dict(_BASE)
    path.write_text(json.dumps(d))
    assert Profile.load(path).baseline().pin is None


def test_schema_6_sessions_read_back_and_schemas_5_and_4_are_one_session(tmp_path):
    """Schema 6's ``sessions_``: two or more give the Baseline the sessions' figures (the airframe's
    own drift is weighed); a schema-5 or -4 profile (no ``sessions_``) loads as one session."""
    d = _profile(tmp_path).to_dict()
    assert d["schema"] == PROFILE_SCHEMA == 7 and len(d["sessions_"]) == 1
    two = [_SESSION, _SESSION | {"share": [0.98, 1.02, 0.99, 1.01], "throttle": 0.52, "pin": None}]
    d["sessions_"] = two
    path = tmp_path / "p6.json"
    path.write_text(json.dumps(d))
    p = Profile.load(path)
    assert p.n_sessions == 2 and p.to_dict()["sessions_"] == two
    figs = p.baseline().sessions
    assert figs.n_sessions == 2 and np.allclose(figs.throttles, [0.5, 0.52]) and np.isnan(figs.pins[1]).all()
    assert p.baseline().n_sessions == 2
    for schema in (5, 4):
        old = {k: v for k, v in d.items() if k != "sessions_"} | {"schema": schema}
        path.write_text(json.dumps(old))
        q = Profile.load(path)
        assert q.n_sessions == 1 and q.sessions_ == [] and q.baseline().sessions is None
        assert q.baseline().n_sessions == 0  # pooled flights, not sessions
        assert q.to_dict()["schema"] == 7  # read as the current schema, written back as it
