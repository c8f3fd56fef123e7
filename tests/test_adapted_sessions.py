"""The adapted model's votes against its own profile on a low-rate log: weighed against another
session's measured spread (issue 28: the adapted one-flight profile of Erle board A 09-10-2014_25
called its 15-10-2014_42 "damaged, motor 3")."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from flightlog_fd.analyzers import model_votes as MV
from flightlog_fd.analyzers.base import Context
from flightlog_fd.analyzers.reliability import LOW_RATE_HZ, trust_of


def _probs(shift: np.ndarray, base: np.ndarray, n: int = 60) -> np.ndarray:
    """Windows whose floored mean log ratio is about ``base + shift`` per motor."""
    target = base + shift
    q = np.concatenate([[1.0], np.exp(target)])
    return np.tile(q / q.sum(), (n, 1))


def _ctx(probs, motors_hz, profile_model="adapted.onnx", base=None):
    flight = SimpleNamespace(motors=SimpleNamespace(rate_hz=motors_hz), rates=SimpleNamespace(rate_hz=50.0))
    profile = SimpleNamespace(model=profile_model, analyzers={"model": base} if base else {})
    return Context(flight=flight, frame=None, n_motors=4, probs=probs, covered_s=45.0, profile=profile,
                   model_sha256="sha")


def test_one_flight_reference_is_the_seen_session_raised_and_the_population_spread():
    base = {"model_sha256": "sha", "healthy_mean": [-1.6, -1.7, -1.6, -1.5], "n_flights": 1}
    ref = MV.adapted_session_reference(base)
    assert np.allclose(ref.healthy_mean, np.array(base["healthy_mean"]) + MV.ADAPTED_LOW_RATE_SESSION_OFFSET)
    assert ref.sigma == MV.ADAPTED_LOW_RATE_SESSION_SIGMA
    # damage's spread includes the session's: a far shift never reads as healthy (a Gaussian ratio
    # with the narrower damage spread would turn negative for a large shift)
    st = ref.stats(4)
    assert st.shift_sigma > ref.sigma


def test_unseen_sessions_measure_the_airframes_own_spread():
    quiet = {"model_sha256": "sha", "healthy_mean": [0, 0, 0, 0], "sessions": [[-1.6] * 4, [-1.45, -1.4, -1.5, -1.45]],
             "sessions_seen": [True, False], "n_flights": 2}
    loud = dict(quiet, sessions=[[-1.6] * 4, [1.5, -1.6, 0.5, -3.0]])
    s_quiet = MV.adapted_session_reference(quiet).sigma
    s_loud = MV.adapted_session_reference(loud).sigma
    assert MV.MODEL_MIN_HEALTHY_SIGMA <= s_quiet < MV.ADAPTED_LOW_RATE_SESSION_SIGMA < s_loud
    # a profile whose sessions were all adapted on learns nothing about unseen sessions
    seen = dict(quiet, sessions_seen=[True, True])
    assert MV.adapted_session_reference(seen).sigma == MV.ADAPTED_LOW_RATE_SESSION_SIGMA


def test_a_session_shift_like_erle_a_stays_below_agreement_but_a_large_one_is_damage():
    """Measured: Erle board A 15-10-2014_42 moved motor 3's vote +2.28 against 09-10-2014_25's adapted
    profile (healthy); rrc_straight 25 mm cuts against good flights 1 and 2: +4.4..+5.1 on motor 1."""
    mean = np.array([-1.57, -1.70, -1.64, -1.53])
    base = {"model_sha256": "sha", "healthy_mean": mean.tolist(), "n_flights": 1}
    va = MV.ModelVotes()
    erle = va.analyze(_ctx(_probs(np.array([0.26, 0.26, 2.28, -0.23]), mean), 10.0, base=base))
    cut = va.analyze(_ctx(_probs(np.array([4.6, 1.1, 0.9, 1.1]), mean), 10.0, base=base))
    e = [f.llr for f in erle.findings]
    c = [f.llr for f in cut.findings]
    # the vote's evidence as the decision reads it (over the shared eta grid): Erle's shift alone stays
    # below the uncertain bar of a quad, the cut's reaches the damaged bar
    from flightlog_fd.decision import evidence_bars

    uncertain_bar, damaged_bar = evidence_bars(4)
    assert max(e) < uncertain_bar
    assert int(np.argmax(c)) == 0 and c[0] > damaged_bar
    # the same Erle shift weighed as before (the in-sample baseline, 0.55 spread) reads as damage
    old = MV.model_llr(_probs(np.array([0.26, 0.26, 2.28, -0.23]), mean), 45.0, mean, MV.MODEL_MIN_HEALTHY_SIGMA)
    assert old[2] > uncertain_bar


def test_full_rate_and_shipped_model_keep_the_plain_baseline():
    mean = np.array([-1.57, -1.70, -1.64, -1.53])
    base = {"model_sha256": "sha", "healthy_mean": mean.tolist(), "n_flights": 1}
    p = _probs(np.array([0.26, 0.26, 2.28, -0.23]), mean)
    from flightlog_fd.analyzers.base import log_mean_exp

    plain = log_mean_exp(MV.vote_eta_llrs(MV.model_llr(p, 45.0, mean, MV.MODEL_MIN_HEALTHY_SIGMA)), axis=1)
    for hz, model in ((250.0, "adapted.onnx"), (10.0, None)):
        got = [f.llr for f in MV.ModelVotes().analyze(_ctx(p, hz, profile_model=model, base=base)).findings]
        assert np.allclose(got, plain), (hz, model)
    assert 250.0 >= LOW_RATE_HZ


def test_the_adapted_low_rate_cell_follows_the_rule_without_an_exception():
    # re-measured at the posterior's bars: 10 / 8 of 20 real cross-session pairs reach 2.5 / 3.6
    from flightlog_fd.analyzers.reliability import EXCEPTIONS

    assert trust_of("model", "low rate, profile, adapted model, quad") == "discounted"
    assert ("model", "low rate, profile, adapted model, quad") not in EXCEPTIONS


def test_each_adaptation_keeps_its_own_session_drift():
    """A profile whose adaptation records what it trained (the convergence-stopped adaptation) is
    weighed with the drift measured on its own models; older adapted profiles with theirs."""
    from types import SimpleNamespace

    import flightlog_fd.analyzers.model_votes as MV

    old = SimpleNamespace(extra={"adaptation": {"kind": "calibrated", "epochs": 8}})
    new = SimpleNamespace(extra={"adaptation": {"trained": "dense layers (convolutions frozen)"}})
    assert MV.adapted_session_drift(old) == (MV.ADAPTED_LOW_RATE_SESSION_OFFSET, MV.ADAPTED_LOW_RATE_SESSION_SIGMA)
    assert MV.adapted_session_drift(SimpleNamespace(extra=None)) == MV.adapted_session_drift(old)
    off, sig = MV.adapted_session_drift(new)
    assert (off, sig) == (MV.ADAPTED_FAST_LOW_RATE_SESSION_OFFSET, MV.ADAPTED_FAST_LOW_RATE_SESSION_SIGMA)
    base = {"healthy_mean": [-1.0, -1.2, -0.8, -1.1], "sessions": [[-1.0, -1.2, -0.8, -1.1]], "sessions_seen": [True]}
    ref = MV.adapted_session_reference(base, off, sig)
    assert np.allclose(ref.healthy_mean, np.array(base["healthy_mean"]) + off) and ref.sigma == sig
