"""The model's windows over time: smoothed labels for the timeline strip, and the damage onset.

Inputs: ``t_start``, ``t_end`` (N,) seconds on the log's clock, one pair per window (any order,
overlapping or not, gaps where the vehicle was on the ground); ``probs`` (N, n + 1) the model's
class probabilities, class 0 healthy, class k = motor k (autopilot numbering). Rows are
renormalised to sum to 1.

1. **Smoothing.** Each window's probabilities are floored (``(1 - PROB_FLOOR_MIX) * p +
   PROB_FLOOR_MIX / (n + 1)``, so no window is ever certain) and averaged over the windows whose
   centres lie within ``SMOOTH_SPAN_S`` of its own centre: a manoeuvre's few confident wrong
   windows are outvoted by their neighbours. A smoothed window's label (the timeline strip the
   reports draw) is its most probable class where that probability reaches the class's bar in
   ``LABEL_BARS`` (where windows so labelled are right more often than not on held-out simulated
   flights), else ``UNCERTAIN_LABEL`` ('?': the window cannot tell). The damage run below
   counts labels at ``WINDOW_MIN_PROB`` instead, the bar its own thresholds were measured with.
2. **Onset.** A propeller does not heal in flight, so the flight is modelled as "healthy until
   window j, then motor k to the end" (a one-way hidden Markov model with an absorbing state),
   whose most likely path is the best suffix sum of the windows' ``log(q_k / q_0)`` on the floored
   probabilities. Damage that shows for a while and then goes is never taken as the onset, and a
   single blip cannot move it. The best such run is :class:`DamageRun`.
3. **Confirmed run.** The run is confirmed when it holds ``MIN_RUN_WINDOWS`` windows covering
   ``MIN_RUN_S`` of flight, ``RUN_MIN_SHARE`` of its smoothed labels name its motor and
   ``MOTOR_MIN_AGREEMENT`` of its labels naming any motor agree; a run that starts after the
   first window must also last ``MIN_ONSET_RUN_S``. A confirmed run after the first window is the
   flight's mid-flight :class:`Onset`: the pipeline then takes the command shares from the onset
   on against the flight before it, and weighs the model's windows from there.

Too few windows (``MIN_WINDOWS``, ``MIN_COVERED_S``) leave every label uncertain and no run;
:attr:`Timeline.shortfall` says what is missing. Nothing here is a verdict: the decision
(:mod:`flightlog_fd.decision`) makes it.

Limits: one damaged motor per flight; damage present only in the last ``MIN_RUN_S`` seconds
(``MIN_ONSET_RUN_S`` after healthy flight) is not confirmed; the figures hold for windows of about
0.5-2 s with any overlap.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

HEALTHY = 0
#: The label of a smoothed window whose best class stays below WINDOW_MIN_PROB.
UNCERTAIN_LABEL = -1

#: Mixed into every window's probabilities so that no single window can dominate the onset
#: likelihood: with 0.1 (a quad's 5 classes) a window's log-ratio is bounded by log(0.92 / 0.02) ~ 3.8.
PROB_FLOOR_MIX = 0.10
#: Centred smoothing span in seconds: long enough to outvote a manoeuvre's few wrong windows,
#: short enough (below MIN_RUN_S) that real onsets still show within a few seconds.
SMOOTH_SPAN_S = 4.0
#: For the damage run's bars (RUN_MIN_SHARE, MOTOR_MIN_AGREEMENT, measured with it) a smoothed
#: window names a class only if that class has at least this probability: 0.5 means "more likely
#: than all others together". The timeline's own labels use LABEL_BARS instead.
WINDOW_MIN_PROB = 0.5

#: Bars of the timeline's labels, per class count (5 quad, 7 hexa, 9 octo): a smoothed window is
#: labelled with its most probable class when that class's smoothed probability reaches the bar
#: (healthy, motor), else '?'. Set from the reliability of the shipped models' smoothed windows on
#: held-out simulated flights (benchmarks/model_why.py report): the lowest bin from which windows
#: so labelled are right more often than not, with healthy and damaged windows weighed as equally
#: common (results/model_why.md: 320 quad flights, 160 hexa and 160 octo, seed 1000). Quad: healthy
#: on top from 0.25 right 60-75 % (0.20-0.25: 34 %), a motor from 0.40 right 53-88 % (0.35-0.40:
#: 39 %). Hexa: healthy from 0.25 54-69 % (48 % below), a motor from 0.45 54-90 % (34 % below).
#: Octo: healthy on top is a coin toss in every bin below 0.6 (46-56 %: the octo model calls most
#: damaged windows healthy), so its windows are labelled healthy only from 0.60 (65 %, few); a
#: motor from 0.50 53-64 % (47 % below; 30 % above 0.7).
#: Measured with the shipped models; a user's or an adapted model is read with the same bars
#: (re-measure them after retraining).
LABEL_BARS = {5: (0.25, 0.40), 7: (0.25, 0.45), 9: (0.60, 0.50)}


def label_bars(n_classes: int) -> tuple[float, float]:
    """(healthy bar, motor bar) of the timeline's labels for ``n_classes`` classes
    (:data:`LABEL_BARS`; another class count: 1.5 and 2 times chance)."""
    return LABEL_BARS.get(int(n_classes), (1.5 / n_classes, 2.0 / n_classes))


#: Fewer windows than this cannot support any verdict (too little flight to judge).
MIN_WINDOWS = 8
#: Nor can less flight time than this, in seconds, covered by windows.
MIN_COVERED_S = 5.0

#: A confirmed run holds at least this many windows ...
MIN_RUN_WINDOWS = 6
#: ... covering at least this many seconds of flight (window union, ground gaps excluded).
MIN_RUN_S = 5.0
#: A run that starts after healthy flight (a mid-flight onset) must last this long: a propeller
#: that breaks stays broken to the end of the flight, while a stretch of odd windows at the end of
#: a healthy flight (a descent in wind, a landing approach) is the commonest false onset on real
#: healthy logs.
MIN_ONSET_RUN_S = 20.0
#: Share of the run's smoothed labels that must name its motor.
RUN_MIN_SHARE = 0.60
#: Share of the run's labels naming any motor that must name the same one; below it the windows
#: disagree between motors.
MOTOR_MIN_AGREEMENT = 0.75


@dataclass
class DamageRun:
    """The most likely "motor k from window j to the end" stretch (indices into the time-sorted windows)."""

    motor: int
    start_index: int
    n_windows: int
    t_start: float  # start of the run's first window, seconds
    covered_s: float  # flight time covered by the run's windows (union), seconds
    share: float  # share of the run's smoothed labels naming `motor`
    agreement: float  # labels naming `motor` / labels naming any motor, within the run (0 if none)
    log_likelihood_ratio: float  # of the onset model against "healthy throughout"
    first_seen: float  # start of the run's first window the raw model gave to `motor` (else t_start)
    confirmed: bool  # passes the run bars (module docstring)


@dataclass
class Onset:
    """A confirmed run that starts after healthy flight: when damage began."""

    motor: int
    start_index: int  # first window of the run among the time-sorted windows
    t_start: float  # the run's start (the command shares are split here)
    first_seen: float  # the first window of the run the raw model gave to the motor


@dataclass
class Timeline:
    """The windows over time (module docstring); shares are 0..1 over the windows."""

    n_windows: int
    covered_s: float
    t_first: Optional[float]  # start of the earliest window
    labels: list[int] = field(default_factory=list)  # smoothed label per window, in the input order
    smoothed_share: list[float] = field(default_factory=list)  # share of labels per class 0..n
    abstained_share: float = 0.0  # share of labels UNCERTAIN_LABEL
    run: Optional[DamageRun] = None
    shortfall: Optional[str] = None  # why there is too little flight to judge, else None

    @property
    def onset(self) -> Optional[Onset]:
        """The confirmed run when it starts after the first window, else None."""
        r = self.run
        if r is None or not r.confirmed or r.start_index == 0:
            return None
        return Onset(r.motor, r.start_index, r.t_start, r.first_seen)


def covered_seconds(t_start: np.ndarray, t_end: np.ndarray) -> float:
    """Length in seconds of the union of the intervals [t_start, t_end] (overlaps counted once)."""
    if len(t_start) == 0:
        return 0.0
    order = np.argsort(t_start, kind="stable")
    total = 0.0
    cur_a, cur_b = float(t_start[order[0]]), float(t_end[order[0]])
    for i in order[1:]:
        a, b = float(t_start[i]), float(t_end[i])
        if a > cur_b:
            total += cur_b - cur_a
            cur_a, cur_b = a, b
        else:
            cur_b = max(cur_b, b)
    return total + (cur_b - cur_a)


def floored(probs: np.ndarray) -> np.ndarray:
    """Rows of ``probs`` (N, classes) renormalised and floored with PROB_FLOOR_MIX."""
    p = np.asarray(probs, float)
    return (1.0 - PROB_FLOOR_MIX) * p / p.sum(axis=1, keepdims=True) + PROB_FLOOR_MIX / p.shape[1]


def smooth_probabilities(centres: np.ndarray, q: np.ndarray, span_s: float) -> np.ndarray:
    """Mean of ``q`` over the windows whose centres lie within ``span_s / 2`` of each centre.

    ``centres`` must be sorted ascending. Runs in O(N) with cumulative sums.
    """
    half = span_s / 2.0
    lo = np.searchsorted(centres, centres - half, side="left")
    hi = np.searchsorted(centres, centres + half, side="right")
    csum = np.vstack([np.zeros((1, q.shape[1])), np.cumsum(q, axis=0)])
    return (csum[hi] - csum[lo]) / (hi - lo)[:, None]


def _check_inputs(t_start, t_end, probs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ts = np.asarray(t_start, dtype=np.float64).reshape(-1)
    te = np.asarray(t_end, dtype=np.float64).reshape(-1)
    p = np.asarray(probs, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < 2:
        raise ValueError(f"probabilities must be (N, 1 + motors), got {p.shape}")
    if not (ts.shape[0] == te.shape[0] == p.shape[0]):
        raise ValueError(f"{ts.shape[0]} window starts, {te.shape[0]} ends, {p.shape[0]} probability rows")
    if p.size and (not np.all(np.isfinite(p)) or np.any(p < 0)):
        raise ValueError("probabilities must be finite and non-negative")
    if not (np.all(np.isfinite(ts)) and np.all(np.isfinite(te))) or np.any(te < ts):
        raise ValueError("window times must be finite with t_end >= t_start")
    row = p.sum(axis=1, keepdims=True)
    if p.size and np.any(row <= 0):
        raise ValueError("a probability row sums to zero")
    return ts, te, p / np.where(row > 0, row, 1.0)


def _best_run(llr: np.ndarray) -> tuple[int, float]:
    """Best onset j for one motor: max over j of sum(llr[j:]); returns (j, score), j = N if none > 0."""
    n = llr.shape[0]
    suffix = np.concatenate([np.cumsum(llr[::-1])[::-1], [0.0]])  # suffix[j] = sum(llr[j:]), suffix[n] = 0
    j = int(np.argmax(suffix))  # first maximum: the earliest onset among equally likely ones
    return (j, float(suffix[j])) if j < n else (n, 0.0)


def shortfall(n: int, covered: float) -> Optional[str]:
    """Why ``n`` windows covering ``covered`` seconds are too little flight to judge, or None."""
    if n < MIN_WINDOWS or covered < MIN_COVERED_S:
        return (f"only {n} window{'s' if n != 1 else ''} covering {covered:.1f} s of flight "
                f"(need at least {MIN_WINDOWS} windows and {MIN_COVERED_S:.0f} s)")
    return None


def build(t_start, t_end, probs) -> Timeline:
    """The :class:`Timeline` of a flight's windows (module docstring)."""
    ts, te, p = _check_inputs(t_start, t_end, probs)
    n = p.shape[0]
    covered = covered_seconds(ts, te)
    t_first = float(ts.min()) if n else None
    short = shortfall(n, covered)
    if short is not None:
        return Timeline(n, covered, t_first, labels=[UNCERTAIN_LABEL] * n, shortfall=short)

    order = np.argsort(ts, kind="stable")
    ts_o, te_o = ts[order], te[order]
    n_classes = p.shape[1]
    q = (1.0 - PROB_FLOOR_MIX) * p[order] + PROB_FLOOR_MIX / n_classes
    centres = 0.5 * (ts_o + te_o)
    c_order = np.argsort(centres, kind="stable")  # centres follow starts except for odd window lengths
    smoothed = np.empty_like(q)
    smoothed[c_order] = smooth_probabilities(centres[c_order], q[c_order], SMOOTH_SPAN_S)
    top, best = smoothed.max(axis=1), smoothed.argmax(axis=1)
    labels = np.where(top >= WINDOW_MIN_PROB, best, UNCERTAIN_LABEL)  # the run's (module docstring)
    healthy_bar, motor_bar = label_bars(n_classes)
    shown = np.where(top >= np.where(best == HEALTHY, healthy_bar, motor_bar), best, UNCERTAIN_LABEL)
    raw_label = p[order].argmax(axis=1)
    window_labels = np.empty(n, dtype=int)
    window_labels[order] = shown
    tl = Timeline(n, covered, t_first, labels=window_labels.tolist(),
                  smoothed_share=[float(np.mean(shown == k)) for k in range(n_classes)],
                  abstained_share=float(np.mean(shown == UNCERTAIN_LABEL)))

    log_q = np.log(q)
    candidates = []
    for k in range(1, n_classes):
        j, score = _best_run(log_q[:, k] - log_q[:, HEALTHY])
        if j < n:
            candidates.append((score, k, j))
    if candidates:
        score, k, j = max(candidates)
        run_labels = labels[j:]
        damage_votes = int(np.sum(run_labels >= 1))
        votes_k = int(np.sum(run_labels == k))
        run_covered = covered_seconds(ts_o[j:], te_o[j:])
        share = votes_k / (n - j)
        agreement = votes_k / damage_votes if damage_votes else 0.0
        # the onset model starts the run on a window the raw model gave to k whenever one exists
        hits = np.nonzero(raw_label[j:] == k)[0]
        confirmed = (n - j >= MIN_RUN_WINDOWS and run_covered >= MIN_RUN_S and share >= RUN_MIN_SHARE
                     and agreement >= MOTOR_MIN_AGREEMENT and (j == 0 or run_covered >= MIN_ONSET_RUN_S))
        tl.run = DamageRun(motor=k, start_index=j, n_windows=n - j, t_start=float(ts_o[j]), covered_s=run_covered,
                           share=share, agreement=agreement, log_likelihood_ratio=score,
                           first_seen=float(ts_o[j + hits[0]]) if hits.size else float(ts_o[j]), confirmed=confirmed)
    return tl


def timeline_labels(t_start: Sequence[float], t_end: Sequence[float], labels: Sequence[int],
          t0: float, t1: float, slots: int) -> list[Optional[int]]:
    """One label per equal time slot of [t0, t1] for a timeline strip: the label of the window
    covering most of the slot (the latest-starting one on ties), or None where no window is."""
    if slots <= 0 or t1 <= t0:
        return []
    edges = np.linspace(t0, t1, slots + 1)
    ts = np.asarray(t_start, dtype=np.float64)
    te = np.asarray(t_end, dtype=np.float64)
    out: list[Optional[int]] = []
    for a, b in zip(edges[:-1], edges[1:]):
        overlap = np.minimum(te, b) - np.maximum(ts, a)
        if overlap.size == 0 or overlap.max() <= 0:
            out.append(None)
            continue
        cand = np.nonzero(overlap >= overlap.max() - 1e-9)[0]
        out.append(int(labels[cand[np.argmax(ts[cand])]]))
    return out
