"""The model's votes weighed by the log's rate class without a profile (issue 28 part 3): the vote
share on a quad at full rate, the flight mean below it and on other frames, the profile's own
baseline at every rate."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy.special import betaln as scipy_betaln

from flightlog_fd import decision as D
from flightlog_fd.analyzers import Context, run_analyzers
from flightlog_fd.analyzers import model_votes as MV
from flightlog_fd.analyzers.reliability import flight_rate_class, rate_class


def _flight(hz: float) -> SimpleNamespace:
    return SimpleNamespace(motors=SimpleNamespace(rate_hz=hz), rates=SimpleNamespace(rate_hz=max(hz, 50.0)))


def _votes(motor: int, share: float, n: int = 75) -> np.ndarray:
    """n windows: the first ``share`` of them name ``motor`` (p 0.7), the rest healthy (p 0.7)."""
    p = np.full((n, 5), 0.075)
    k = int(round(share * n))
    p[:k, motor] = 0.7
    p[k:, 0] = 0.7
    return p


def _model(probs, hz: float, covered_s: float = 60.0, profile=None):
    """The vote statistic's LLR per motor as measured (the evidence at severe damage: the first
    point of the shared eta grid, where the model sees all it can)."""
    ctx = Context(flight=_flight(hz), frame=None, n_motors=probs.shape[1] - 1, probs=probs, covered_s=covered_s,
                  profile=profile, model_sha256="m")
    (r,) = run_analyzers(ctx, [MV.ModelVotes()])
    return np.array([r.eta_llrs[k + 1][0] for k in range(probs.shape[1] - 1)])


def test_rate_classes_and_betaln():
    assert [rate_class(x) for x in (10.0, 24.0, 100.0)] == ["low rate", "mid rate", "full rate"]
    assert flight_rate_class(_flight(250.0)) == "full rate" and flight_rate_class(_flight(10.0)) == "low rate"
    assert flight_rate_class(SimpleNamespace(motors=[1])) is None  # no rates known: the constants before
    a, b = np.array([0.2, 1.5, 14.6]), np.array([0.7, 0.12, 500.0])
    assert np.allclose(MV.betaln(a, b), scipy_betaln(a, b), atol=1e-9)


def test_full_rate_weighs_how_consistently_the_windows_name_a_motor():
    consistent = _model(_votes(3, 1.0), 250.0)
    uncertain_bar, damaged_bar = D.evidence_bars(4)
    assert int(np.argmax(consistent)) == 2 and consistent[2] >= uncertain_bar
    # the model alone never reaches "damaged" without a profile: a healthy airframe's trim can make
    # every window name one motor (about 1 healthy motor in 75 on realistic simulated airframes)
    w = D.source_weight(SimpleNamespace(analyzer="model", reliability_keys=MV.ModelVotes.reliability_keys,
                                        llr_cap=MV.ModelVotes.llr_cap), D.LogKind(250.0, 250.0, 60.0, 0.3, "none"))
    assert min(consistent[2], w.cap) < damaged_bar
    half = _model(_votes(3, 0.5), 250.0)
    healthy = _model(_votes(3, 0.0), 250.0)
    assert healthy[2] < 0 < half[2] < consistent[2]
    # a shorter flight (fewer independent windows) says less either way
    short = _model(_votes(3, 1.0, n=15), 250.0, covered_s=12.0)
    assert 0 < short[2] < consistent[2]


def test_below_full_rate_the_flight_mean_is_weighed():
    p = _votes(2, 1.0)
    for hz in (10.0, 24.0):
        llr = _model(p, hz)
        assert np.allclose(llr, MV.model_llr(p, 60.0)) and int(np.argmax(llr)) == 1 and llr[1] > 0
    # an unknown rate (a synthetic flight) too
    ctx = Context(flight=SimpleNamespace(motors=[1]), frame=None, n_motors=4, probs=p, covered_s=60.0)
    (r,) = run_analyzers(ctx, [MV.ModelVotes()])
    assert np.allclose([r.eta_llrs[k + 1][0] for k in range(4)], MV.model_llr(p, 60.0))
    # and on an n-rotor at full rate (its own model, its own statistics)
    octo = np.full((60, 9), 0.05)
    octo[:, 3] = 0.6
    assert np.allclose(_model(octo / octo.sum(1, keepdims=True), 250.0),
                       MV.model_llr(octo / octo.sum(1, keepdims=True), 60.0))


def test_a_profile_keeps_the_airframes_own_baseline_at_every_rate():
    p = _votes(4, 0.8)
    base = {"model_sha256": "m", "healthy_mean": [-1.0, -1.2, -0.9, -1.1], "spread": None, "n_flights": 1}
    prof = SimpleNamespace(analyzers={"model": base})
    expected = MV.model_llr(p, 60.0, base["healthy_mean"], MV.MODEL_MIN_HEALTHY_SIGMA)
    for hz in (10.0, 24.0, 250.0):
        assert np.allclose(_model(p, hz, profile=prof), expected)


def test_real_full_rate_flights_without_a_profile(shared):
    """px4_sih_dev at 250 Hz: the healthy flights' model evidence stays below zero on every motor;
    a propeller at eta 0.7 from take-off is named by the model alone at the uncertain bar."""
    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    model = resolve_model()
    for name, motor in (("sih_004", 0), ("sih_043", 0), ("sih_035", 2), ("sih_047", 4)):
        d = diagnose_flight(load_flight(shared("px4_sih_dev", "logs", f"{name}.ulg")), model, None)
        llr = next(r for r in d.decision.results if r.analyzer == "model").raw_llr(4)
        if motor == 0:
            assert llr.max() < 0, (name, llr)
            assert d.verdict.status == "healthy", d.verdict.reason
        else:
            assert int(np.argmax(llr)) + 1 == motor and llr[motor - 1] >= D.evidence_bars(4)[0], (name, llr)
            # the model and the commands: that rotor lost thrust, why unknown (no ESC, no vibration tie)
            assert (d.verdict.status, d.verdict.motor, d.verdict.cause) == ("damaged", motor, None), d.verdict.reason




def test_full_rate_without_a_profile_the_real_healthy_flights_stay_well_below_the_bars(shared):
    """px4_sih_dev's sih_056 (motor 2 at eta 0.8 from take-off; the windows name it 92 % of the
    time) leads on motor 2; the real full-rate healthy flights stay healthy, well below the uncertain
    bar (CrazyPAD E9 normals, whose motor 2 runs hardest)."""
    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    model = resolve_model()
    d = diagnose_flight(load_flight(shared("px4_sih_dev", "logs", "sih_056.ulg")), model, None)
    top = max(d.decision.motors, key=lambda m: m.llr)
    assert top.motor == 2 and top.llr > 0, top
    for i in range(3):
        p = shared("crazypad_e9", "ulog", f"normal_flight__E9_log0{i}.ulg")
        d = diagnose_flight(load_flight(p), model, None)
        assert d.verdict.status == "healthy", (p.name, d.verdict.reason)
        assert max(m.llr for m in d.decision.motors) < D.evidence_bars(4)[0] - 1.0  # measured: at most -0.1
