"""The windows' timeline on synthetic probability sequences (windows 1 s long every 0.5 s):
smoothed labels, the damage run and when it is a confirmed onset."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.timeline import (MIN_WINDOWS, UNCERTAIN_LABEL, build, covered_seconds, smooth_probabilities,
                                   timeline_labels)

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


def test_all_healthy_has_no_confirmed_run():
    rng = np.random.default_rng(0)
    ts, te = windows(60)
    tl = build(ts, te, confident(np.zeros(len(ts), int), rng))
    assert tl.shortfall is None and tl.n_windows == len(ts)
    assert tl.smoothed_share[0] == pytest.approx(1.0) and set(tl.labels) == {0}
    assert tl.run is None or not tl.run.confirmed
    assert tl.onset is None and tl.t_first == pytest.approx(ts[0])


def test_sustained_motor3_from_start_is_a_confirmed_run_but_no_onset():
    rng = np.random.default_rng(1)
    ts, te = windows(60)
    tl = build(ts, te, confident(np.full(len(ts), 3), rng))
    assert tl.run.confirmed and tl.run.motor == 3 and tl.run.start_index == 0
    assert tl.run.n_windows == len(ts) and tl.run.first_seen == pytest.approx(ts[0])
    assert tl.onset is None  # damage from take-off: nothing before it to compare with


@pytest.mark.parametrize("onset", [30.0, 45.0])
def test_mid_flight_onset_close_to_truth(onset):
    rng = np.random.default_rng(2)
    ts, te = windows(80, t0=0.0)
    labels = np.where(ts >= onset, 2, 0)
    # The model is not perfect after onset either: 25 % of damaged windows look healthy.
    flip = (labels == 2) & (rng.random(len(ts)) < 0.25)
    labels[flip] = 0
    tl = build(ts, te, confident(labels, rng))
    assert tl.onset is not None and tl.onset.motor == 2
    assert abs(tl.onset.first_seen - onset) <= 5.0 and tl.onset.t_start <= tl.onset.first_seen


def test_confident_blips_during_manoeuvres_are_no_run():
    rng = np.random.default_rng(3)
    ts, te = windows(90)
    labels = np.zeros(len(ts), int)
    # A few very confident wrong windows scattered along the flight, including near the end.
    for i, k in [(10, 1), (11, 1), (50, 4), (90, 3), (91, 3), (150, 2), (len(ts) - 3, 4), (len(ts) - 2, 4)]:
        labels[i] = k
    tl = build(ts, te, confident(labels, rng, strength=0.97))
    assert tl.run is None or not tl.run.confirmed
    assert tl.smoothed_share[0] > 0.9


def test_two_motors_competing_is_no_confirmed_run():
    rng = np.random.default_rng(5)
    ts, te = windows(60)
    # Blocks of ~3 s alternating between motors 2 and 3: sustained damage, but which motor?
    labels = np.where((np.arange(len(ts)) // 6) % 2 == 0, 2, 3)
    tl = build(ts, te, confident(labels, rng))
    assert tl.run is not None and not tl.run.confirmed and tl.run.agreement < 0.75


def test_too_few_windows_is_a_shortfall_with_uncertain_labels():
    rng = np.random.default_rng(7)
    ts, te = windows(4)
    assert len(ts) < MIN_WINDOWS
    tl = build(ts, te, confident(np.full(len(ts), 3), rng))
    assert f"only {len(ts)} windows" in tl.shortfall
    assert tl.run is None and tl.labels == [UNCERTAIN_LABEL] * len(ts)


def test_unsorted_input_labels_follow_input_order():
    rng = np.random.default_rng(8)
    ts, te = windows(60)
    p = confident(np.full(len(ts), 4), rng)
    perm = rng.permutation(len(ts))
    tl = build(ts[perm], te[perm], p[perm])
    assert tl.run.confirmed and tl.run.motor == 4
    assert tl.run.first_seen == pytest.approx(ts.min())
    assert len(tl.labels) == len(ts) and set(tl.labels) == {4}


def test_bad_shapes_raise_value_error():
    with pytest.raises(ValueError):
        build([0, 1], [1, 2], np.ones((2, 1)))  # no motor class at all
    with pytest.raises(ValueError):
        build([0, 1, 2], [1, 2, 3], np.ones((2, 5)))  # three windows, two probability rows
    with pytest.raises(ValueError):
        build([0, 1], [1, 2], np.full((2, 5), np.nan))


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


def test_short_damage_run_at_the_end_of_a_healthy_flight_is_not_an_onset():
    """A stretch of confident motor-3 windows in the last 12 s after a healthy flight (the
    pattern of a real healthy log's descent) is no onset; 30 s of it is."""
    rng = np.random.default_rng(7)
    ts, te = windows(90, t0=0.0)
    tl = build(ts, te, confident(np.where(ts >= 78.0, 3, 0), rng))
    assert tl.run is not None and tl.run.motor == 3 and not tl.run.confirmed and tl.onset is None
    tl = build(ts, te, confident(np.where(ts >= 55.0, 3, 0), rng))
    assert tl.onset is not None and tl.onset.motor == 3
    assert abs(tl.onset.first_seen - 55.0) < 2.0


def test_labels_follow_the_measured_bars_and_the_run_keeps_its_own():
    """A flight like sample_logs/px4_healthy.ulg (healthy on top in every window at 0.3-0.5, the rest
    spread over the motors) is labelled healthy, not '?'; a motor on top at 0.35, below its bar, is
    '?'; the damage run still counts labels at WINDOW_MIN_PROB (0.5), so these flat windows make no
    confirmed run."""
    from flightlog_fd.timeline import LABEL_BARS, WINDOW_MIN_PROB, label_bars

    healthy_bar, motor_bar = label_bars(5)
    assert (healthy_bar, motor_bar) == LABEL_BARS[5] and healthy_bar < motor_bar < WINDOW_MIN_PROB
    rng = np.random.default_rng(3)
    ts, te = windows(60)
    p = np.tile([0.40, 0.15, 0.15, 0.15, 0.15], (len(ts), 1)) + rng.uniform(-0.02, 0.02, (len(ts), 5))
    tl = build(ts, te, p)
    assert set(tl.labels) == {0} and tl.abstained_share == 0.0
    assert tl.run is None or not tl.run.confirmed
    q = np.tile([0.20, 0.35, 0.15, 0.15, 0.15], (len(ts), 1))  # motor 1 on top, 0.9 * 0.35 + 0.02 = 0.335
    tl = build(ts, te, q)
    assert set(tl.labels) == {UNCERTAIN_LABEL} and tl.abstained_share == 1.0
    assert tl.run is None or not tl.run.confirmed
    # above its bar a motor is labelled; the run, at 0.5, still sees '?' there and confirms nothing
    r = np.tile([0.15, 0.45, 0.15, 0.125, 0.125], (len(ts), 1))  # smoothed 0.425
    tl = build(ts, te, r)
    assert set(tl.labels) == {1} and (tl.run is None or not tl.run.confirmed)
    # octo: its healthy label needs 0.6 (the octo model's healthy windows are a coin toss below)
    o = np.full((len(ts), 9), 0.5 / 8)
    o[:, 0] = 0.5
    assert set(build(ts, te, o).labels) == {UNCERTAIN_LABEL}
