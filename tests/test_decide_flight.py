"""The decision's one entry point per flight (:func:`flightlog_fd.decision.decide_flight`) and per
log of several flights (``decide_log``): what DecisionInputs carry reaches the verdict, a flight
of several is capped by its whole log, the profile configuration is named in a weighed reason."""
from __future__ import annotations

from flightlog_fd import decision as D
from flightlog_fd.analyzers import AnalyzerResult, Finding
from flightlog_fd.flight import Frame
from flightlog_fd.timeline import Timeline


def _one_rotor(llr: float, motor: int = 2) -> list:
    """One source seeing rotor ``motor`` at ``llr`` nats, the others at -3."""
    return [AnalyzerResult("x", [Finding("x", k, "f", 0.0, llr=llr if k == motor else -3.0) for k in range(1, 5)])]


def test_decide_flight_weighs_names_the_configuration_and_caps_by_the_log():
    inputs = D.DecisionInputs(4, Frame.quad_x(), timeline=Timeline(60, 60.0, 0.0), results=_one_rotor(9.0))
    alone, dec = D.decide_flight(inputs)
    assert alone.status == "damaged" and alone.motor == 2 and dec is not None
    said = D.decide_flight(D.DecisionInputs(**{**vars(inputs), "configuration_words": "camera on"}))[0]
    assert said.reason == alone.reason + " (camera on)"
    healthy_log = D.Verdict("healthy", confidence=0.8, reason="no rotor lost thrust")
    capped = D.decide_flight(D.DecisionInputs(**{**vars(inputs), "log": (healthy_log, None)}))[0]
    assert capped.status == "healthy" and capped.motor is None  # never worse than its log
    assert capped.reason.startswith("judged alone this flight would be damaged (motor 2)")


def test_decide_flight_passes_not_diagnosable_through_and_decide_log_lists_the_flights():
    v, d = D.decide_flight(D.DecisionInputs(0, not_diagnosable_reason="bad file"))
    assert v.status == "not_diagnosable" and v.reason == "bad file" and d is None
    whole = D.Verdict("healthy", confidence=0.9, reason="no rotor lost thrust")
    parts = [("flight 1", D.Verdict("healthy")), ("flight 2", D.Verdict("uncertain", motor=3))]
    assert D.decide_log(parts, whole=whole).reason == ("no rotor lost thrust; flight 1: healthy; "
                                                       "flight 2: uncertain (motor 3)")
    worst = D.decide_log(parts)  # flights judged each on its own: the worst one's
    assert worst.status == "uncertain" and worst.reason.startswith("flight 2: ")
