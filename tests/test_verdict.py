"""Verdict on synthetic probability sequences (windows 1 s long every 0.5 s)."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.flight import Frame
from flightlog_fd.verdict import (MIN_WINDOWS, Verdict, VerdictSettings, covered_seconds, decide,
                                  smooth_probabilities, timeline_labels)

WINDOW_S = 1.0
STRIDE_S = 0.5


def windows(duration_s: float, t0: float = 10.0):
    ts = np.arange(t0, t0 + duration_s - WINDOW_S + 1e-9, STRIDE_S)
    return ts, ts + WINDOW_S


def confident(labels, rng, strength: float = 0.85):
    """Probabilities peaked (``strength`` on average) on each window's label, noise elsewhere."""
    n = len(labels)
    p = rng.dirichlet(np.ones(5), size=n) * (1.0 - strength)
    p[np.arange(n), labels] += strength
    return p


def test_all_healthy_is_healthy():
    rng = np.random.default_rng(0)
    ts, te = windows(60)
    v = decide(ts, te, confident(np.zeros(len(ts), int), rng), frame=Frame.quad_x())
    assert v.status == "healthy"
    assert v.motor is None and v.first_seen is None
    assert v.confidence > 0.7
    assert v.evidence.n_windows == len(ts)
    assert v.evidence.smoothed_share[0] == pytest.approx(1.0)
    assert set(v.window_labels) == {0}


def test_sustained_motor3_from_start_is_damaged_front_left():
    rng = np.random.default_rng(1)
    ts, te = windows(60)
    v = decide(ts, te, confident(np.full(len(ts), 3), rng), frame=Frame.quad_x())
    assert v.status == "damaged"
    assert v.motor == 3 and v.position == "front-left"
    assert v.first_seen == pytest.approx(ts[0])
    assert v.confidence > 0.7
    assert "motor 3 (front-left) damaged in 100 % of" in v.reason
    assert v.evidence.run.n_windows == len(ts)


@pytest.mark.parametrize("onset", [30.0, 45.0])
def test_mid_flight_onset_first_seen_close_to_truth(onset):
    rng = np.random.default_rng(2)
    ts, te = windows(80, t0=0.0)
    labels = np.where(ts >= onset, 2, 0)
    # The model is not perfect after onset either: 25 % of damaged windows look healthy.
    flip = (labels == 2) & (rng.random(len(ts)) < 0.25)
    labels[flip] = 0
    v = decide(ts, te, confident(labels, rng))
    assert v.status == "damaged" and v.motor == 2
    assert abs(v.first_seen - onset) <= 5.0  # target: within 10 s of the true onset
    assert v.position is None  # no frame given: no guessed position
    assert f"from t={v.first_seen:.1f} s" in v.reason


def test_confident_blips_during_manoeuvres_stay_healthy():
    rng = np.random.default_rng(3)
    ts, te = windows(90)
    labels = np.zeros(len(ts), int)
    # A few very confident wrong windows scattered along the flight, including near the end.
    for i, k in [(10, 1), (11, 1), (50, 4), (90, 3), (91, 3), (150, 2), (len(ts) - 3, 4), (len(ts) - 2, 4)]:
        labels[i] = k
    p = confident(labels, rng, strength=0.97)
    v = decide(ts, te, p, frame=Frame.quad_x())
    assert v.status == "healthy", v.reason
    assert v.evidence.raw_share[0] < 1.0  # the blips were there in the raw windows


def test_short_damage_at_the_very_end_is_not_a_false_alarm():
    rng = np.random.default_rng(4)
    ts, te = windows(60)
    labels = np.where(ts >= ts[-1] - 2.0, 1, 0)  # last ~3 s only
    v = decide(ts, te, confident(labels, rng), frame=Frame.quad_x())
    assert v.status == "healthy"
    assert "too short to confirm" in v.reason


def test_two_motors_competing_is_uncertain():
    rng = np.random.default_rng(5)
    ts, te = windows(60)
    # Blocks of ~3 s alternating between motors 2 and 3: sustained damage, but which motor?
    labels = np.where((np.arange(len(ts)) // 6) % 2 == 0, 2, 3)
    v = decide(ts, te, confident(labels, rng), frame=Frame.quad_x())
    assert v.status == "uncertain"
    assert v.motor is None
    assert "disagree" in v.reason and "motor 2" in v.reason and "motor 3" in v.reason


def test_weak_evidence_is_uncertain():
    rng = np.random.default_rng(6)
    ts, te = windows(60)
    # The model leans to motor 4 everywhere but never with conviction.
    p = np.tile([0.30, 0.05, 0.05, 0.05, 0.55], (len(ts), 1)) + rng.uniform(0, 0.02, (len(ts), 5))
    p[::2] = [0.45, 0.05, 0.05, 0.05, 0.40]
    v = decide(ts, te, p, frame=Frame.quad_x())
    assert v.status == "uncertain", v.reason
    assert v.motor is None


def test_too_few_windows_is_not_diagnosable():
    rng = np.random.default_rng(7)
    ts, te = windows(4)
    assert len(ts) < MIN_WINDOWS
    v = decide(ts, te, confident(np.full(len(ts), 3), rng))
    assert v.status == "not_diagnosable"
    assert v.confidence == 0.0 and v.motor is None
    assert f"only {len(ts)} windows" in v.reason


def test_unsorted_input_labels_follow_input_order():
    rng = np.random.default_rng(8)
    ts, te = windows(60)
    labels = np.full(len(ts), 4)
    p = confident(labels, rng)
    perm = rng.permutation(len(ts))
    v = decide(ts[perm], te[perm], p[perm])
    assert v.status == "damaged" and v.motor == 4
    assert v.first_seen == pytest.approx(ts.min())
    assert len(v.window_labels) == len(ts)


def test_settings_change_the_decision():
    rng = np.random.default_rng(9)
    ts, te = windows(60)
    labels = np.where(rng.random(len(ts)) < 0.55, 1, 0)  # motor 1 in about half the windows
    p = confident(labels, rng)
    strict = decide(ts, te, p, settings=VerdictSettings(damaged_min_share=0.95))
    assert strict.status in ("uncertain", "healthy")
    assert strict.status != "damaged"


def test_bad_shapes_raise_value_error():
    with pytest.raises(ValueError):
        decide([0, 1], [1, 2], np.ones((2, 1)))  # no motor class at all
    with pytest.raises(ValueError):
        decide([0, 1, 2], [1, 2, 3], np.ones((2, 5)))  # three windows, two probability rows
    with pytest.raises(ValueError):
        decide([0, 1], [1, 2], np.full((2, 5), np.nan))


def test_as_dict_fields():
    v = Verdict("damaged", 3, "front-left", 0.93456, 34.5, "x")
    assert v.as_dict() == {"status": "damaged", "motor": 3, "position": "front-left",
                           "confidence": 0.9346, "first_seen": 34.5, "reason": "x"}


def test_helpers():
    assert covered_seconds(np.array([0.0, 0.5, 10.0]), np.array([1.0, 1.5, 11.0])) == pytest.approx(2.5)
    c = np.arange(10, dtype=float)
    q = np.zeros((10, 5))
    q[:, 0] = np.arange(10)
    sm = smooth_probabilities(c, q, span_s=2.0)  # neighbours at +-1
    assert sm[5, 0] == pytest.approx(5.0) and sm[0, 0] == pytest.approx(0.5)
    slots = timeline_labels([0, 10], [10, 20], [0, 3], 0, 20, 4)
    assert slots == [0, 0, 3, 3]
    assert timeline_labels([0], [5], [1], 0, 20, 4) == [1, None, None, None]


def test_short_damage_run_at_the_end_of_a_healthy_flight_is_not_a_damaged_verdict():
    """A stretch of confident motor-3 windows in the last 12 s after a healthy flight (the
    pattern of a real healthy log's descent) is at most uncertain; 30 s of it is damage."""
    rng = np.random.default_rng(7)
    ts, te = windows(90, t0=0.0)
    short = np.where(ts >= 78.0, 3, 0)
    v = decide(ts, te, confident(short, rng), frame=Frame.quad_x())
    assert v.status in ("uncertain", "healthy")
    assert v.status != "damaged"
    if v.status == "uncertain":
        assert "confirmed after 20 s" in v.reason
    long = np.where(ts >= 55.0, 3, 0)
    v = decide(ts, te, confident(long, rng), frame=Frame.quad_x())
    assert v.status == "damaged" and v.motor == 3
    assert abs(v.first_seen - 55.0) < 2.0
