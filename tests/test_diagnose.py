"""diagnose_flight / diagnose_path on synthetic Flights with a small fake model.

The fake model reads the same NIF windows a real one would get (built by windows.py from the
model's feature spec) and calls a motor damaged when its scale-free thrust share stands out.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from flightlog_fd.diagnose import (EXIT_DAMAGED_OR_UNCERTAIN, EXIT_HEALTHY, EXIT_NOT_DIAGNOSABLE,
                                   NO_PROFILE_OWN_MODEL_WARNING, Diagnosis, diagnose_flight, diagnose_path,
                                   model_info, profile_info)
from flightlog_fd.windows import FeatureSpec
from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.profile import Profile

HOVER_COMMAND = 0.5
#: A motor whose mean thrust share exceeds the window mean by this much is "damaged" for the fake.
FAKE_SHARE_EXCESS = 0.04


class ShareModel:
    """Fake FaultModel: same attributes and methods, decides from the motor thrust shares."""

    classes = ["healthy", "motor 1", "motor 2", "motor 3", "motor 4"]
    version = "fake-share-1"
    sha256 = "ab" * 32
    path = "/models/fake.onnx"

    def __init__(self):
        self.feature_spec = FeatureSpec(features="nif").to_dict()
        self.standardised = 0

    def standardise(self, X):
        self.standardised += 1
        return np.asarray(X, dtype=np.float32)

    def predict_proba(self, X):
        shares = X[:, 3:7, :].mean(axis=2)  # scale-free: each motor's share of the mean thrust
        excess = shares.max(axis=1) - 1.0
        motor = shares.argmax(axis=1) + 1
        p = np.full((X.shape[0], 5), 0.05)
        cls = np.where(excess > FAKE_SHARE_EXCESS, motor, 0)
        p[np.arange(X.shape[0]), cls] = 0.8
        return p


class FakeProfile:
    """Only what diagnose reads from a profile: its path, model entry, compatibility check and
    healthy command-share baseline (even shares at hover throttle 0.5)."""

    def __init__(self, path="/profiles/e9.json", model=None):
        self.path = path
        self.model = model

    def check_compatible(self, flight):
        return []

    def baseline(self):
        from flightlog_fd.analyzers.share_fit import Baseline

        return Baseline(share=np.ones(4), slope=np.zeros(4), throttle_ref=0.5, source="test")

    def baselines(self):
        """One configuration, as calibrated (``Profile.baselines``)."""
        from flightlog_fd.profile import AS_CALIBRATED

        return [(AS_CALIBRATED, None, self.baseline(), {})]


def synthetic_flight(damaged_motor=None, onset_s=None, airborne=(2.0, 62.0), path="synthetic.ulg",
                     harder: float = 1.12) -> Flight:
    """Hover at 0.5 command with gyro noise; from ``onset_s`` one motor works ``harder`` (12 %)."""
    rng = np.random.default_rng(42)
    t_end = airborne[1] + 2.0
    t_rates = np.arange(0.0, t_end, 1 / 250)
    rates = rng.normal(0.0, 0.05, (t_rates.size, 3))
    t_mot = np.arange(0.0, t_end, 1 / 50)
    motors = HOVER_COMMAND + rng.normal(0.0, 0.005, (t_mot.size, 4))
    if damaged_motor is not None:
        after = t_mot >= (onset_s if onset_s is not None else 0.0)
        motors[after, damaged_motor - 1] *= harder
    ground = (t_mot < airborne[0]) | (t_mot > airborne[1])
    motors[ground] = 0.0
    vel = np.zeros((t_mot.size, 3))
    return Flight(path=path, autopilot="px4", firmware="v1.14.0", vehicle_type="quadrotor",
                  frame=Frame.quad_x(), rates=Series(t_rates, rates, "vehicle_angular_velocity.xyz"),
                  motors=Series(t_mot, motors, "actuator_motors.control"), motor_kind="thrust",
                  velocity=Series(t_mot, vel, "vehicle_local_position.v"),
                  armed=[(1.0, t_end - 1.0)], airborne=[airborne], t_start=0.0, t_end=t_end,
                  warnings=["test: synthetic"])


def test_healthy_flight_is_healthy_exit_0():
    model = ShareModel()
    d = diagnose_flight(synthetic_flight(), model)
    assert isinstance(d, Diagnosis)
    assert d.verdict.status == "healthy"
    assert d.exit_code == EXIT_HEALTHY
    assert model.standardised == 1
    assert len(d.windows) > 50
    assert all(w.cls == 0 and w.phase == "hover" for w in d.windows)
    # the fake is not the shipped model: the advice does not claim the shipped one was used
    assert NO_PROFILE_OWN_MODEL_WARNING in d.warnings and "test: synthetic" in d.warnings
    assert d.facts.autopilot == "px4" and d.facts.frame == "quad_x" and d.facts.airborne_s == 60.0
    assert d.model.version == "fake-share-1" and d.model.calibrated is False
    # windows are in time order, inside the airborne interval (features trims 1 s each end)
    starts = [w.t_start for w in d.windows]
    assert starts == sorted(starts) and starts[0] >= 3.0 - 1e-9 and d.windows[-1].t_end <= 61.0 + 1e-9


def test_damage_from_mid_flight_found_with_onset():
    # a step that a broken propeller makes: 35 % more command from t=30 s (a 12 % step without a
    # profile is "uncertain": the within-flight wander of real healthy airframes is 6 %)
    d = diagnose_flight(synthetic_flight(damaged_motor=3, onset_s=30.0, harder=1.35), ShareModel())
    v = d.verdict
    assert v.status == "damaged", v.reason
    assert v.motor == 3 and v.position == "front-left"
    assert 28.0 <= v.first_seen <= 33.0
    assert d.exit_code == EXIT_DAMAGED_OR_UNCERTAIN
    assert "motor 3 (front-left)" in v.reason
    late = [w for w in d.windows if w.t_start > 35.0]
    assert late and all(w.cls == 3 and w.label == 3 for w in late)


def test_never_airborne_is_not_diagnosable_exit_2():
    f = synthetic_flight()
    f.airborne = []
    d = diagnose_flight(f, ShareModel())
    assert d.verdict.status == "not_diagnosable"
    assert d.exit_code == EXIT_NOT_DIAGNOSABLE
    assert "never flew" in d.verdict.reason
    assert d.windows == []


def test_too_short_flight_is_not_diagnosable():
    d = diagnose_flight(synthetic_flight(airborne=(2.0, 11.0)), ShareModel())
    assert d.verdict.status == "not_diagnosable"
    assert d.exit_code == EXIT_NOT_DIAGNOSABLE
    assert d.verdict.reason


def real_profile(frame="quad_x", firmware="v1.13.0", path="/profiles/e9.json") -> Profile:
    return Profile(autopilot="px4", frame=frame, rotor_count=4, rho_=[1.0, 1.0, 1.0, 1.0],
                   rho_spread_=[0.0] * 4, hover_throttle_=HOVER_COMMAND,
                   feature_spec=FeatureSpec().to_dict(), firmware=firmware, path=path)


def test_incompatible_profile_is_not_diagnosable_with_its_message():
    d = diagnose_flight(synthetic_flight(), ShareModel(), real_profile(frame="quad_plus"))
    assert d.verdict.status == "not_diagnosable"
    assert d.exit_code == EXIT_NOT_DIAGNOSABLE
    assert "profile was made for px4 quad_plus" in d.verdict.reason
    assert d.profile.path == "/profiles/e9.json"
    assert not any(w.startswith("no calibration profile") for w in d.warnings)


def test_compatible_profile_passes_its_warnings_on():
    d = diagnose_flight(synthetic_flight(), ShareModel(), real_profile(firmware="v1.13.0"))
    assert d.verdict.status == "healthy"
    assert any("firmware v1.13.0" in w and "v1.14.0" in w for w in d.warnings)
    assert not any(w.startswith("no calibration profile") for w in d.warnings)


def test_profile_model_marks_calibrated_and_resolves_relative_path():
    model = ShareModel()
    prof = FakeProfile(model={"path": "e9.onnx", "sha256": model.sha256})
    info = profile_info(prof)
    assert info.model_path == "/profiles/e9.onnx"
    assert model_info(model, prof).calibrated is True
    assert model_info(model, FakeProfile(model={"path": "e9.onnx", "sha256": "00" * 32})).calibrated is False
    d = diagnose_flight(synthetic_flight(), model, prof)
    assert d.verdict.status == "healthy" and d.model.calibrated


def test_diagnose_path_bad_file_is_not_diagnosable(tmp_path):
    bad = tmp_path / "notes.ulg"
    bad.write_text("this is not a flight log")
    d = diagnose_path(bad, ShareModel())
    assert d.verdict.status == "not_diagnosable"
    assert d.exit_code == EXIT_NOT_DIAGNOSABLE
    assert d.log == str(bad)
    assert "not a PX4 ULog or ArduPilot DataFlash log" in d.verdict.reason
    missing = diagnose_path(tmp_path / "missing.bin", ShareModel())
    assert missing.exit_code == EXIT_NOT_DIAGNOSABLE and "no such file" in missing.verdict.reason


def test_model_with_wrong_class_count_is_refused():
    model = ShareModel()
    model.classes = ["healthy", "damaged"]
    d = diagnose_flight(synthetic_flight(), model)
    assert d.verdict.status == "not_diagnosable"
    assert "2 classes" in d.verdict.reason


@pytest.mark.shared
def test_real_healthy_px4_log_runs_through(shared):
    """A real third-party log goes through the whole pipeline without a traceback."""
    path = shared("real_logs", "px4", "sample_px4_events.ulg")
    d = diagnose_path(path, ShareModel())
    assert d.verdict.status in ("healthy", "uncertain", "damaged", "not_diagnosable")
    assert d.exit_code in (0, 1, 2)
    assert d.log == str(path)


def test_keep_flight_false_drops_the_flight_but_keeps_the_result():
    from flightlog_fd.report.html_report import render_html

    d = diagnose_flight(synthetic_flight(damaged_motor=1, onset_s=0.0, harder=1.45), ShareModel(), keep_flight=False)
    assert d.flight is None
    assert (d.verdict.status, d.verdict.motor, d.verdict.position) == ("damaged", 1, "front-right")
    page = render_html(d)
    assert page.count("<svg") == 1  # only the probabilities plot without the flight's streams


# ---------------------------------------------------------------- with a real FaultModel (ONNX)

def tiny_onnx_model(path) -> None:
    """A 5-class ONNX classifier of NIF windows, in the file format FaultModel reads: mean over
    time, then healthy logit 4 against 2 x each motor's standardised thrust share."""
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper, numpy_helper

    spec = FeatureSpec(features="nif").to_dict()
    spec["mean"] = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
    spec["std"] = [1.0, 1.0, 1.0, 0.02, 0.02, 0.02, 0.02]
    weights = np.zeros((7, 5), dtype=np.float32)
    for k in range(4):
        weights[3 + k, 1 + k] = 2.0
    bias = np.array([4.0, 0.0, 0.0, 0.0, 0.0], dtype=np.float32)
    graph = helper.make_graph(
        [helper.make_node("ReduceMean", ["windows"], ["m"], axes=[2], keepdims=0),
         helper.make_node("Gemm", ["m", "W", "b"], ["logits"]),
         helper.make_node("Softmax", ["logits"], ["probabilities"], axis=1)],
        "tiny", [helper.make_tensor_value_info("windows", TensorProto.FLOAT, ["N", 7, 80])],
        [helper.make_tensor_value_info("probabilities", TensorProto.FLOAT, ["N", 5])],
        [numpy_helper.from_array(weights, "W"), numpy_helper.from_array(bias, "b")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    meta = {"version": "tiny-1", "feature_spec": spec, "classes": ["healthy", "motor1", "motor2", "motor3", "motor4"],
            "training": {"data": "hand-set weights for tests"}, "created": "2024-01-01T00:00:00+00:00"}
    helper.set_model_props(model, {"flightlog_fd": json.dumps(meta)})
    onnx.save(model, str(path))


def test_real_fault_model_end_to_end_and_resolve_model(tmp_path):
    from flightlog_fd.diagnose import resolve_model
    from flightlog_fd.errors import ProfileError
    from flightlog_fd.model import FaultModel

    model_file = tmp_path / "tiny.onnx"
    tiny_onnx_model(model_file)
    model = resolve_model(model_file)
    assert isinstance(model, FaultModel) and model.version == "tiny-1"

    damaged = diagnose_flight(synthetic_flight(damaged_motor=4, onset_s=20.0, harder=1.35), model)
    assert damaged.verdict.status == "damaged" and damaged.verdict.motor == 4
    assert damaged.verdict.position == "rear-right"
    assert 18.0 <= damaged.verdict.first_seen <= 23.0
    assert diagnose_flight(synthetic_flight(), model).verdict.status == "healthy"

    # The profile's own model: found relative to the profile's folder, marked calibrated.
    prof = real_profile(path=str(tmp_path / "profile.json"))
    prof.set_model(model_file)
    from_profile = resolve_model(None, prof)
    assert from_profile.sha256 == model.sha256
    d = diagnose_flight(synthetic_flight(), from_profile, prof)
    assert d.model.calibrated and d.profile.model_path == str(model_file)

    # A model file changed after calibration is refused.
    prof.model = {"path": "tiny.onnx", "sha256": "0" * 64}
    with pytest.raises(ProfileError):
        resolve_model(None, prof)


def test_evidence_decides_between_model_and_airframe_trim():
    """A motor 12 % high from take-off: with a profile whose baseline is even, named and the
    reason cites the command change against calibration and the rotor's thrust; a strong
    one-motor pattern (45 %) is named without a profile, cited against the neighbours, with a
    lower eta-hat. The commands and the model alone: uncertain, the rotor or a load at its corner."""
    mild = synthetic_flight(damaged_motor=2, onset_s=0.0)
    d = diagnose_flight(mild, ShareModel(), FakeProfile())
    assert (d.verdict.status, d.verdict.motor) == ("uncertain", 2) and "or a load sits at its corner" in d.verdict.reason
    assert "against calibration" in d.verdict.reason and "of its normal thrust" in d.verdict.reason
    assert d.motors[1].command_share_baseline == pytest.approx(1.0)
    strong = diagnose_flight(synthetic_flight(damaged_motor=2, onset_s=0.0, harder=1.45), ShareModel())
    assert (strong.verdict.status, strong.verdict.motor) == ("uncertain", 2)
    assert "against its neighbours" in strong.verdict.reason
    assert strong.motors[1].command_change > 0.3 and strong.share_fit.baseline == "neighbours"
    assert strong.decision.motors[1].eta_hat < d.decision.motors[1].eta_hat < 1.0


