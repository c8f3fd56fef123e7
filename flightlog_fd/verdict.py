"""The flight verdict: per-window class probabilities -> one decision for the whole flight.

Inputs
------
``t_start``, ``t_end``: (N,) seconds on the log's clock, one pair per window (any order,
overlapping or not, gaps allowed where the vehicle was on the ground).
``probs``: (N, 5) class probabilities from the model; class 0 healthy, class k = propeller of
motor k damaged (autopilot numbering). Rows are renormalised to sum to 1.

What it decides
---------------
``healthy``, ``damaged`` (with motor, position, ``first_seen``), ``uncertain`` (the evidence is
weak or windows disagree between motors) or ``not_diagnosable`` (too few windows to judge).
The verdict never rests on one window; it uses two views of the whole sequence:

1. **Smoothing (who is voting for what).** Each window's probabilities are floored
   (``(1 - PROB_FLOOR_MIX) * p + PROB_FLOOR_MIX / 5``, so no window is ever "certain") and
   averaged over the windows whose centres lie within ``SMOOTH_SPAN_S`` of its own centre.
   The smoothed window's label is its most probable class if that probability is at least
   ``WINDOW_MIN_PROB``, else -1 ("uncertain"). A few confident wrong windows (an aggressive
   manoeuvre) are outvoted by their neighbours here. These labels make the timeline.
2. **Onset (when damage began).** A propeller does not heal during a flight, so the flight is
   modelled as "healthy until window j, then motor k damaged to the end" - a one-way hidden
   Markov model with an absorbing damaged state, whose most likely path is found exactly by the
   best suffix sum of per-window log-likelihood ratios ``log(q_k / q_0)`` on the floored
   probabilities (j = N means "healthy throughout"). Damage that shows for a while mid-flight
   and then disappears is therefore never taken as the onset; a single blip cannot move the
   onset either, because every confidently healthy window after it pulls the sum back down.

The run from the onset to the end of the flight is then judged by its smoothed labels:
``damaged`` needs at least ``MIN_RUN_WINDOWS`` windows covering ``MIN_RUN_S`` seconds of flight,
``DAMAGED_MIN_SHARE`` of them voting for the motor and ``MOTOR_MIN_AGREEMENT`` of the damage
votes agreeing on it; a run with damage more likely than health on average but short of those
bars is ``uncertain``; a flight with no such run is ``healthy`` provided ``HEALTHY_MIN_SHARE``
of its windows vote healthy (else ``uncertain``: the model could not decide). ``first_seen`` is
the start time of the first window of the run that the raw model already gave to the motor.

Confidence (0..1) is the mean probability the model gave to the chosen class over the windows
the decision rests on (the run for ``damaged``, all windows for ``healthy``; for ``uncertain``
the leading class over the run, or over the flight); 0 for ``not_diagnosable``.

A run that starts after healthy flight (mid-flight onset) must also last ``MIN_ONSET_RUN_S``.

Limits: one damaged propeller per flight (the model has no multi-fault class); damage present
only in the last ``MIN_RUN_S`` seconds (``MIN_ONSET_RUN_S`` after healthy flight) cannot be
confirmed; the thresholds are tuned for windows
of about 0.5-2 s with any overlap.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .flight import Frame

#: Classes of the quad model (healthy + 4 motors); an n-rotor model has n + 1 and the verdict
#: takes its class count from the probabilities it is given.
N_CLASSES = 5
HEALTHY = 0
UNCERTAIN_LABEL = -1

#: Mixed into every window's probabilities so that no single window can dominate the onset
#: likelihood: with 0.1 a window's log-ratio is bounded by log(0.92 / 0.02) ~ 3.8.
PROB_FLOOR_MIX = 0.10
#: Centred smoothing span in seconds: long enough to outvote a manoeuvre's few wrong windows,
#: short enough (below MIN_RUN_S) that real onsets still show within a few seconds.
SMOOTH_SPAN_S = 4.0
#: A smoothed window votes for a class only if that class has at least this probability;
#: below it the window abstains (-1): with 5 classes, 0.5 means "more likely than all others".
WINDOW_MIN_PROB = 0.5

#: Fewer windows than this cannot support any verdict (too little flight to judge).
MIN_WINDOWS = 8
#: Nor can less flight time than this, in seconds, covered by windows.
MIN_COVERED_S = 5.0

#: A damaged run must hold at least this many windows ...
MIN_RUN_WINDOWS = 6
#: ... covering at least this many seconds of flight (window union, ground gaps excluded).
MIN_RUN_S = 5.0
#: A run that starts after healthy flight (a mid-flight onset) must last this long to be called
#: damaged: a propeller that breaks stays broken to the end of the flight, while a stretch of
#: odd windows at the end of a healthy flight (a descent in wind, a landing approach) is the
#: commonest false alarm on real healthy logs. Shorter runs are at most "uncertain".
MIN_ONSET_RUN_S = 20.0
#: Share of the run's windows that must vote for the motor to call it damaged.
DAMAGED_MIN_SHARE = 0.60
#: Share of the run's damage votes (any motor) that must name the same motor; below it the
#: windows disagree between motors and the verdict is uncertain.
MOTOR_MIN_AGREEMENT = 0.75
#: If the run's mean smoothed probability of "some propeller damaged" reaches this, a run that
#: fails the damaged bars still makes the flight uncertain rather than healthy.
UNCERTAIN_DAMAGE_PROB = 0.5
#: Share of all windows that must vote healthy for a healthy verdict.
HEALTHY_MIN_SHARE = 0.60


@dataclass(frozen=True)
class VerdictSettings:
    """The thresholds above, as one object so a caller (or a test) can change them."""

    prob_floor_mix: float = PROB_FLOOR_MIX
    smooth_span_s: float = SMOOTH_SPAN_S
    window_min_prob: float = WINDOW_MIN_PROB
    min_windows: int = MIN_WINDOWS
    min_covered_s: float = MIN_COVERED_S
    min_run_windows: int = MIN_RUN_WINDOWS
    min_run_s: float = MIN_RUN_S
    min_onset_run_s: float = MIN_ONSET_RUN_S
    damaged_min_share: float = DAMAGED_MIN_SHARE
    motor_min_agreement: float = MOTOR_MIN_AGREEMENT
    uncertain_damage_prob: float = UNCERTAIN_DAMAGE_PROB
    healthy_min_share: float = HEALTHY_MIN_SHARE


@dataclass
class DamageRun:
    """The most likely "damaged from here to the end" stretch for one motor."""

    motor: int  # 1..4
    start_index: int  # index into the time-sorted windows
    n_windows: int
    t_start: float  # start of the run's first window, seconds
    covered_s: float  # flight time covered by the run's windows (union), seconds
    share: float  # share of the run's smoothed votes for `motor`
    agreement: float  # votes for `motor` / votes for any motor, within the run (0 if none)
    damage_prob: float  # mean smoothed probability of any damage over the run
    log_likelihood_ratio: float  # of the onset model against "healthy throughout"


@dataclass
class Evidence:
    """The numbers behind a verdict (all shares are 0..1)."""

    n_windows: int
    covered_s: float
    raw_share: list[float]  # share of windows whose raw argmax is class 0..4
    smoothed_share: list[float]  # share of smoothed votes for class 0..4
    abstained_share: float  # share of smoothed windows below WINDOW_MIN_PROB
    run: Optional[DamageRun] = None


@dataclass
class Verdict:
    """The flight's verdict; ``window_labels`` are the smoothed labels in the input order."""

    status: str  # "healthy" | "damaged" | "uncertain" | "not_diagnosable"
    motor: Optional[int] = None
    position: Optional[str] = None
    confidence: float = 0.0
    first_seen: Optional[float] = None
    reason: str = ""
    evidence: Optional[Evidence] = None
    window_labels: list[int] = field(default_factory=list)  # -1 uncertain, 0 healthy, k motor k

    def as_dict(self) -> dict:
        """The verdict fields of the JSON report."""
        return {
            "status": self.status,
            "motor": self.motor,
            "position": self.position,
            "confidence": round(float(self.confidence), 4),
            "first_seen": None if self.first_seen is None else round(float(self.first_seen), 3),
            "reason": self.reason,
        }


def not_diagnosable(reason: str) -> Verdict:
    """A verdict for a flight that cannot be judged (also used by the diagnose pipeline)."""
    return Verdict(status="not_diagnosable", reason=reason)


def _position(frame: Optional[Frame], motor: int) -> Optional[str]:
    return frame.position(motor) if frame is not None else None


def _motor_words(frame: Optional[Frame], motor: int) -> str:
    pos = _position(frame, motor)
    return f"motor {motor} ({pos})" if pos else f"motor {motor}"


def _pct(x: float) -> str:
    return f"{100.0 * x:.0f} %"


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


def decide(t_start, t_end, probs, *, settings: VerdictSettings = VerdictSettings(),
           frame: Optional[Frame] = None) -> Verdict:
    """Decide the flight's verdict from all its windows (see the module docstring)."""
    s = settings
    ts, te, p = _check_inputs(t_start, t_end, probs)
    n = p.shape[0]
    covered = covered_seconds(ts, te)
    if n < s.min_windows or covered < s.min_covered_s:
        v = not_diagnosable(
            f"only {n} window{'s' if n != 1 else ''} covering {covered:.1f} s of flight "
            f"(need at least {s.min_windows} windows and {s.min_covered_s:.0f} s)")
        v.window_labels = [UNCERTAIN_LABEL] * n
        return v

    order = np.argsort(ts, kind="stable")
    ts_o, te_o = ts[order], te[order]
    n_classes = p.shape[1]
    q = (1.0 - s.prob_floor_mix) * p[order] + s.prob_floor_mix / n_classes
    centres = 0.5 * (ts_o + te_o)
    c_order = np.argsort(centres, kind="stable")  # centres follow starts except for odd window lengths
    smoothed = np.empty_like(q)
    smoothed[c_order] = smooth_probabilities(centres[c_order], q[c_order], s.smooth_span_s)
    best = smoothed.argmax(axis=1)
    labels = np.where(smoothed.max(axis=1) >= s.window_min_prob, best, UNCERTAIN_LABEL)
    p_sorted = p[order]
    raw_label = p_sorted.argmax(axis=1)

    raw_share = [float(np.mean(raw_label == k)) for k in range(n_classes)]
    smoothed_share = [float(np.mean(labels == k)) for k in range(n_classes)]
    abstained = float(np.mean(labels == UNCERTAIN_LABEL))
    evidence = Evidence(n, covered, raw_share, smoothed_share, abstained)
    window_labels = np.empty(n, dtype=int)
    window_labels[order] = labels

    # Onset: the motor whose "damaged from window j on" model beats "healthy throughout" most.
    log_q = np.log(q)
    candidates = []
    for k in range(1, n_classes):
        j, score = _best_run(log_q[:, k] - log_q[:, HEALTHY])
        if j < n:
            candidates.append((score, k, j))
    run: Optional[DamageRun] = None
    if candidates:
        score, k, j = max(candidates)
        run_labels = labels[j:]
        damage_votes = int(np.sum(run_labels >= 1))
        votes_k = int(np.sum(run_labels == k))
        run = DamageRun(
            motor=k, start_index=j, n_windows=n - j, t_start=float(ts_o[j]),
            covered_s=covered_seconds(ts_o[j:], te_o[j:]),
            share=votes_k / (n - j),
            agreement=votes_k / damage_votes if damage_votes else 0.0,
            damage_prob=float(np.mean(1.0 - smoothed[j:, HEALTHY])),
            log_likelihood_ratio=score)
        evidence.run = run

    def verdict(status, motor=None, confidence=0.0, first_seen=None, reason="") -> Verdict:
        return Verdict(status=status, motor=motor, position=_position(frame, motor) if motor else None,
                       confidence=float(np.clip(confidence, 0.0, 1.0)), first_seen=first_seen,
                       reason=reason, evidence=evidence, window_labels=window_labels.tolist())

    long_enough = run is not None and run.n_windows >= s.min_run_windows and run.covered_s >= s.min_run_s
    if long_enough:
        k, j = run.motor, run.start_index
        onset_confirmed = j == 0 or run.covered_s >= s.min_onset_run_s
        if run.share >= s.damaged_min_share and run.agreement >= s.motor_min_agreement and onset_confirmed:
            # first_seen: the first window of the run the model itself already gave to motor k
            # (the onset model starts the run on such a window whenever one exists).
            hits = np.nonzero(raw_label[j:] == k)[0]
            first = float(ts_o[j + hits[0]]) if hits.size else run.t_start
            return verdict("damaged", k, float(np.mean(p_sorted[j:, k])), first,
                           f"{_motor_words(frame, k)} damaged in {_pct(run.share)} of {run.n_windows} "
                           f"windows from t={first:.1f} s")
        if run.damage_prob >= s.uncertain_damage_prob:
            run_labels = labels[j:]
            votes = {m: float(np.mean(run_labels == m)) for m in range(1, n_classes)}
            ranked = sorted(votes, key=lambda m: -votes[m])
            top, second = ranked[0], ranked[1]
            if not onset_confirmed and run.share >= s.damaged_min_share and run.agreement >= s.motor_min_agreement:
                why = (f"{_motor_words(frame, k)} looks damaged only in the last {run.covered_s:.0f} s "
                       f"(from t={run.t_start:.1f} s) after healthy flight; damage that starts mid-flight "
                       f"is confirmed after {s.min_onset_run_s:.0f} s")
            elif run.agreement < s.motor_min_agreement and votes[second] > 0:
                why = (f"windows disagree between {_motor_words(frame, top)} ({_pct(votes[top])}) and "
                       f"{_motor_words(frame, second)} ({_pct(votes[second])}) in {run.n_windows} "
                       f"windows from t={run.t_start:.1f} s")
            else:
                why = (f"weak evidence: {_motor_words(frame, k)} looks damaged in only {_pct(run.share)} of "
                       f"{run.n_windows} windows from t={run.t_start:.1f} s "
                       f"(a damaged verdict needs {_pct(s.damaged_min_share)})")
            return verdict("uncertain", None, float(np.mean(p_sorted[j:, top])), None, why)

    healthy_share = smoothed_share[HEALTHY]
    if healthy_share >= s.healthy_min_share:
        note = ""
        if run is not None and not long_enough and run.share > 0:
            note = (f"; {_motor_words(frame, run.motor)} looked damaged in the last "
                    f"{run.covered_s:.1f} s only, too short to confirm")
        return verdict("healthy", None, float(np.mean(p_sorted[:, HEALTHY])), None,
                       f"healthy in {_pct(healthy_share)} of {n} windows{note}")
    if abstained >= 1.0 - s.healthy_min_share:
        why = f"the model could not decide on {_pct(abstained)} of {n} windows"
    else:
        top = int(np.argmax(smoothed_share[1:])) + 1
        why = (f"healthy in only {_pct(healthy_share)} of {n} windows, "
               f"{_motor_words(frame, top)} in {_pct(smoothed_share[top])} without a sustained run")
    return verdict("uncertain", None, float(np.max(np.mean(p_sorted, axis=0))), None, why)


def timeline_labels(t_start: Sequence[float], t_end: Sequence[float], labels: Sequence[int],
                    t0: float, t1: float, slots: int) -> list[Optional[int]]:
    """One label per equal time slot of [t0, t1] for a timeline strip: the label of the window
    covering most of the slot (the latest-starting one on ties), or None where no window is.

    Used by the terminal and HTML reports; ``labels`` as in :attr:`Verdict.window_labels`.
    """
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
