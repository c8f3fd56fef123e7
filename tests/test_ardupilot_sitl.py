"""Genuine ArduCopter 4.7 firmware (SITL, ../shared/ardupilot_sitl_quad, read its README): the log a
pilot gets with fast logging on is diagnosable, and a weak motor is named as a motor or ESC fault,
not a propeller. Skipped when ../shared is absent."""
from __future__ import annotations

import pytest

from conftest import shared_path


@pytest.fixture(scope="module")
def model():
    from flightlog_fd.diagnose import resolve_model

    return resolve_model()


def _diagnose(name, model):
    from flightlog_fd import load_flight
    from flightlog_fd.checks import describe_flight
    from flightlog_fd.diagnose import diagnose_flight

    flight = load_flight(shared_path("ardupilot_sitl_quad", name))
    return describe_flight(flight), diagnose_flight(flight, model, keep_flight=False)


def test_fast_logging_flight_is_diagnosed_healthy(model):
    """LOG_BITMASK=442367 (IMU and RATE ~400 Hz): the logger dropped 126,941 messages (DSF.Dp),
    leaving holes of up to 40 ms; `fdlog info` and `fdlog diagnose` agree that it can be judged."""
    info, d = _diagnose("healthy_fastlog.BIN", model)
    assert info["diagnosable"] and info["reasons"] == []
    assert d.verdict.status == "healthy", d.verdict.reason
    assert d.timeline.n_windows > 100  # ~107 s of 110 s airborne
    assert d.verdict.cause is None and d.verdict.cause_evidence is None


def test_weak_motor_is_named_as_a_motor_or_esc_fault(model):
    """SIM_ENGINE_MUL=0.75 on motor 1 with ESC telemetry: motor 1 turns ~25 % slower per command
    than the others: the verdict names motor 1 and says motor or ESC, not propeller."""
    from flightlog_fd.report.terminal import verdict_sentence

    info, d = _diagnose("motor1_weak_esc.BIN", model)
    v = d.verdict
    assert info["diagnosable"] and v.status == "damaged" and v.motor == 1, v.reason
    assert v.cause == "motor_or_esc" and v.cause_evidence["llr"] > 20
    assert v.cause_evidence["rpm_per_command"] < -15
    assert [a.text.split(":")[0] for a in v.advice if a.kind == "inspect"][:2] == [
        "inspect motor 1 and its ESC", "then propeller 1 (right)"]  # the motor before the propeller
    assert verdict_sentence(d).startswith("Rotor 1 (right) lost") and verdict_sentence(d).endswith(
        ": inspect motor 1 and its ESC")
    # the ESC relations now count for "rotor 1 lost thrust" (they weighed -6.1 nats against a propeller)
    assert next(m for m in d.decision.motors if m.motor == 1).llr_by_source["esc"] > 6


def test_the_rotors_rpm_curve_is_fitted_on_the_flight():
    """ArduCopter 4.7 SITL's rpm follows its RCOU signal, not sqrt(thrust): against the thrust the
    log's MOT_THST_EXPO 0.65 gives, rpm ∝ command^(b/2) with b 1.31-1.34 per motor (results/cause.md).
    The analyzer fits b on the flight, so the weak motor reads against that curve; at b = 1 a load
    raising one rotor's command read as a cut propeller."""
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.esc import analyze_esc, measure_esc

    f = load_flight(shared_path("ardupilot_sitl_quad", "motor1_weak_esc.BIN"))
    m, why = measure_esc(f)
    assert why is None and abs(m.slopes["log_rpm_per_log_sqrt_command"] - 1.33) < 0.05, m.slopes
    a = analyze_esc(f)
    rpm = {x.motor: x.value for x in a.findings if x.name == "rpm_per_command"}
    assert rpm[1] < -25 and all(abs(rpm[k]) < 2 for k in (2, 3, 4)), rpm
    assert a.cause_ll[1]["motor_or_esc"] > 100 > a.cause_ll[1]["propeller"]
