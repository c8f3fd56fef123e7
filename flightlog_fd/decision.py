"""The flight's verdict, made here alone, from one posterior over what the log can show.

Entry points: the diagnose pipeline calls :func:`decide_flight` once per flight with its
:class:`DecisionInputs`, and :func:`decide_log` once for a log holding several flights.

Precedence: a motor that stopped in the air ("stopped", :mod:`flightlog_fd.stopped`) outranks
everything; then a flight that cannot be judged (``not_diagnosable``: the pipeline's reason, or too
little flight in the :class:`~flightlog_fd.timeline.Timeline`, unless vibration can judge it); then
the evidence, weighed once (:func:`weigh`).

**The hypotheses** (:func:`hypotheses`): ``healthy``; ``rotor k`` gives eta of its normal thrust
(uniform on the shared grid :data:`~flightlog_fd.analyzers.base.ETA_GRID`); ``rotors j and k``
(quads, :data:`~flightlog_fd.analyzers.base.PAIR_ROTOR_COUNTS`); ``load``: the rotors deliver and the
centre of mass or payload moved (the command shares' :class:`~flightlog_fd.analyzers.command_shares.LoadFit`).
Each analyzer gives, per hypothesis it can speak to, log p(x | h) - log p(x | healthy) in nats,
capped by its measured reliability on this kind of log (:func:`source_weight`, the trust levels of
:mod:`flightlog_fd.analyzers.reliability`); a source that can say how much thrust a rotor lost gives
it at every eta (:meth:`~flightlog_fd.analyzers.base.AnalyzerResult.eta_profile`: the commands, the
effectiveness fit, the model's votes weighted by how well it sees each eta), and eta is integrated
once, jointly, so two sources agree only where they agree on how much. Under ``load`` the sources
that read the command pattern (:data:`PATTERN_SOURCES`) say what they say of the rotor nearest it
(a load at a corner moves them as that rotor's loss does) and the commands' shares decide between
the two (``rotor_vs_load``); the others say nothing. Vibration speaks to "propeller k is out of
balance" (its flight-level Bayes factor, shared over the rotors by the line's tie, ``tie_probs``).

**The prior** (:data:`PRIOR_DAMAGE`, a fleet sets its own: ``fdlog diagnose --prior-damage``): the
probability that a diagnosed flight has a rotor that lost thrust, before the log is read, split
over the rotors, with two rotors at once :data:`PAIR_LOG_PRIOR_ODDS` less likely than one; a moved
load :data:`PRIOR_LOAD`. The posterior P(h) is the prior times exp(evidence), normalised.

**The verdict weighs costs**: a missed damaged rotor costs :data:`MISS_COST` needless inspections.
``healthy`` when P(a rotor lost thrust) is below 1 / (1 + MISS_COST): not inspecting is then the
cheaper error. ``damaged`` when it is at least even: the rotor(s) of the most probable damage
hypothesis are named, with eta-hat and its interval and since when; two it cannot tell apart are
named as "k or j". Between, ``uncertain``: an inspection is worth it though damage is not the likelier
answer. The statuses keep their names: ``damaged`` means "a rotor lost thrust" (or a propeller shakes
out of balance); why is a judgement of its own (:func:`flightlog_fd.cause.judge_cause`: propeller,
motor or ESC, something in the rotor's wash, or unknown), stated only from a source that can see it,
and the advice follows it. A ``healthy`` verdict names a moved load when ``load`` is the likelier
healthy hypothesis, and says whether the log saw the flight (``seen``: the evidence lowered the
probability of damage below its prior, by :data:`SEEN_MIN_NATS`, over at least
:data:`SEEN_MIN_COVERED_S` of usable flight).

**Confidence** (:data:`CONFIDENCE_MEANING`): the posterior probability that the stated verdict is
right under the stated prior: damaged, P(the named rotor lost thrust, alone or with another) (a pair:
P(that pair)); uncertain, P(one of the named rotors lost thrust); healthy, P(no rotor lost thrust);
stopped 1; not diagnosable 0. Measured per set, reweighted to the prior:
benchmarks/decision_replay.py and benchmarks/bench_confidence.py.

Limits: at most two damaged rotors; the sources are treated as independent given the hypothesis
(the model reads the commands the command analyzer weighs, which is why each source is capped).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

from .analyzers import AnalyzerResult
from .analyzers.base import ETA_GRID, PAIR_ROTOR_COUNTS, SOURCE_LLR_CAP, log_mean_exp
from .analyzers.command_shares import CommandSharesResult, LoadFit
from .analyzers.reliability import FULL_RATE_HZ, LogKind, cell_of, rate_class, trust_of
from .analyzers.throttle import ThrottleResult
from .analyzers.vibration import VibrationResult
from .cause import Cause, judge_cause
from .flight import Frame
from .timeline import Timeline

#: Probability that a diagnosed flight has a rotor that lost thrust, before its log is read: one in
#: ten. No base rate of damaged flights has been measured, and which flights get diagnosed (every
#: flight of a fleet, or after a hard landing) is the user's choice, so the figure is stated with
#: every verdict and a fleet sets its own (``--prior-damage``). One in ten is a pilot who runs the
#: tool after most flights and always after a knock or a strange sound.
PRIOR_DAMAGE = 0.10
#: A missed damaged rotor costs this many needless inspections. A damaged propeller flown once more
#: can shed a blade or lose its rotor's thrust in the air: the aircraft and what it carries (about a
#: hundred inspections' worth) with a chance of a few percent in that one flight, and propeller
#: damage seldom heals, so the next flight's log gets another look. Against it, one inspection of a
#: propeller and its motor, and a pilot's trust in a tool that asks for one after every flight. The
#: verdict is healthy only while P(damage) stays below 1 / (1 + MISS_COST) = 0.25. Measured both
#: ways on ../shared and the simulated sets (benchmarks/decision_replay.py, results/verdict.md):
#: at 5 the real healthy flights without a profile are 16 of 18 healthy and 8 % of all verdicts
#: uncertain; at 3, 18 of 18 and 4 %, three px4_sih_dev weak motors without a profile called healthy
#: (not seen) instead of uncertain.
MISS_COST = 3.0
#: A moved load before the log is read, per baseline: with a profile, the load or the centre of mass
#: moved since calibration (a battery slid, a payload added or moved); without one, the airframe's
#: own trim against an even split, which most airframes have. The load and a rotor's loss share the
#: command pattern at the load's corner, and the commands' shares part them (``rotor_vs_load``):
#: with these priors a rotor is the likelier only where its fit beats the load's by
#: log(PRIOR_LOAD (1 - PRIOR_DAMAGE) n / PRIOR_DAMAGE) nats on a quad, 1.0 with a profile and 2.0
#: without, the middle of the gap measured between them where the pattern is strong
#: (benchmarks/decision_replay.py; results/load_vs_damage.md): px4_sih_dev_load's moved centres of
#: mass at most -0.3 with a profile and +1.5 without; the weak motors and cuts with strong evidence
#: (px4_sih_dev, rrc_straight 20/25 mm) from +2.5 with one and +2.3 without.
PRIOR_LOAD = {"profile": 0.075, "none": 0.20}
#: Log prior odds of one given pair of rotors against one given rotor, per baseline: two damaged
#: propellers must earn their second free efficiency. Measured (benchmarks/bench_two_props.py):
#: the best pair's excess over the best single rotor on one-propeller and healthy flights reaches
#: 4.1 (simulated, no profile; 4.55 with ESC telemetry) and 2.7 against one-flight profiles (real
#: Erle board B), so a pair is named only beyond those.
PAIR_LOG_PRIOR_ODDS = {"profile": -3.5, "none": -5.0}
#: The sources that read the motor commands' pattern, which a load at a rotor's corner moves as that
#: rotor's loss does: the command shares, the model's windows (its features carry each motor's
#: command; against px4_sih_dev_load's moved centres of mass it gives +7.1..+8.0 to the motor toward
#: the load) and the throttle, whose figure is what the throttle adds to the shares' fit
#: (:mod:`~flightlog_fd.analyzers.throttle`): a pattern explained without a moved load predicts the
#: throttle tightly, and a load that moved the centre of mass keeps it as that fit does.
PATTERN_SOURCES = ("commands", "throttle", "model")
#: The sources a profile from another session can mislead: the command shares and the throttle move
#: with the trim between sessions (Erle boards A and B: RMS share change 0.13-0.33 between sessions,
#: benchmarks/bench_cross_session.py), which is what their reliability cells measured. Within a
#: session known from the logs' UTC times (:attr:`~flightlog_fd.analyzers.reliability.LogKind.same_session`)
#: the shares' drift is the re-flight spread (RMS 0.008-0.041), so they are trusted there.
SESSION_SOURCES = ("commands", "throttle")
#: Of the rotors that lose thrust, the share whose damage also unbalances the propeller (a chip, an
#: asymmetric cut or crack) and so shakes the frame once per revolution; the rest (a symmetric cut,
#: a weak motor or ESC, a weight in the wash) do not (rrc_straight's symmetric 5-25 mm cuts: level
#: 3.6-6.6 m/s/s against 5.1-5.6 with good propellers). Without a measured base rate, even odds:
#: a quiet flight then halves the odds of a lost rotor at most, and a shaking one multiplies them.
IMBALANCED_SHARE = 0.5
#: A healthy verdict "saw" the flight (``Verdict.seen``) only from this much usable flight (seconds
#: covered by the model's windows): the healthy verdicts from less were right 4 of 32 times on the
#: real sets without a profile (CrazyPAD E9, 13.6 s each; an 8 s Erle flight), those from more 22
#: of 29 (benchmarks/bench_confidence.py, main 25a3211).
SEEN_MIN_COVERED_S = 20.0
#: ... and only where the evidence favoured healthy by at least this much (nats: e to 1): a log
#: that says nothing either way keeps the prior, and its healthy verdict is no clearance.
SEEN_MIN_NATS = 1.0
#: Chi-square (per share degree of freedom) above which no hypothesis describes the shares: they
#: moved beyond the drift (p < 0.01 with 3 degrees of freedom: 11.3 / 3) in a pattern no rotor and
#: no load explains; the verdict then says the airframe changed and to re-calibrate.
AIRFRAME_CHANGE_CHI2_PER_DOF = 3.8
#: A verdict over a timeline with at least this share of uncertain ('?') windows says what it rests
#: on instead (the model could not tell the propellers apart: the shipped octo model on its own
#: damaged sample, 92 %).
THIN_TIMELINE_SHARE = 0.5
#: The one meaning of every stated confidence (the JSON reference, the guide and the legend print it).
CONFIDENCE_MEANING = ("the probability that this verdict is right, given the stated prior of damage, "
                      "measured on real and simulated flights")
#: Severity order of verdicts when one log holds several flights (the log's verdict is its worst).
STATUS_RANK = {"not_diagnosable": 0, "healthy": 1, "uncertain": 2, "damaged": 3, "stopped": 4}


def inspect_bar(miss_cost: float = MISS_COST) -> float:
    """P(a rotor lost thrust) from which an inspection is the cheaper error: 1 / (1 + miss_cost)."""
    return 1.0 / (1.0 + miss_cost)


def evidence_bars(n: int, prior: float = PRIOR_DAMAGE) -> tuple[float, float]:
    """(uncertain, damaged): the nats one rotor alone must give to reach :func:`inspect_bar` and even
    odds under ``prior`` on an n-rotor (no load, no pair): 2.5 and 3.6 on a quad at 0.1."""
    base = np.log((1.0 - prior) * n / prior)
    return float(base + np.log(inspect_bar() / (1.0 - inspect_bar()))), float(base)


#: The most nats a source may give at each trust level of the measured reliability table
#: (:data:`~flightlog_fd.analyzers.reliability.RELIABILITY`, benchmarks/bench_reliability.py):
#: "trusted" up to its own cap (at least SOURCE_LLR_CAP, 8), so it may make a damaged verdict alone;
#: "corroborating" a nat below the damaged bar of a quad, so another source must agree;
#: "discounted" a nat below the uncertain bar, so alone it cannot even ask for an inspection.
TRUST_CAPS = {"trusted": SOURCE_LLR_CAP, "corroborating": evidence_bars(4)[1] - 1.0,
              "discounted": evidence_bars(4)[0] - 1.0}


@dataclass
class Verdict:
    """What the flight's report states; ``position`` in the frame's words, ``first_seen`` seconds
    on the log's clock (damaged: the onset's first window, or the first window; stopped: the stop)."""

    status: str  # "healthy" | "damaged" | "uncertain" | "stopped" | "not_diagnosable"
    #: The damaged (stopped) motor (the first of two), or the one propeller an uncertain verdict
    #: asks to inspect first (:func:`named_motor`); None when it names none, or two it cannot tell apart.
    motor: Optional[int] = None
    position: Optional[str] = None
    confidence: float = 0.0  # the probability of the verdict as stated (module docstring)
    first_seen: Optional[float] = None
    reason: str = ""
    #: The propellers the verdict sends the pilot to first (() = all of them, or nothing to inspect).
    inspect: tuple = ()
    #: What would resolve it (:class:`flightlog_fd.advice.Advice`), set by the diagnose pipeline.
    advice: list = field(default_factory=list)
    #: The rotors the verdict names: those that lost thrust or stopped (``motor`` is the first), an
    #: uncertain pair's two, or the one an uncertain verdict asks to inspect first; [] otherwise.
    motors: list[int] = field(default_factory=list)
    #: True when the verdict is that two rotors lost thrust together (damaged or uncertain).
    pair: bool = False
    #: The frame's words for each of ``motors`` (None where unknown).
    positions: list = field(default_factory=list)
    #: Why the named rotor lost thrust, as far as the log shows (:mod:`flightlog_fd.cause`):
    #: "propeller" | "motor_or_esc" | "wash" (something in its wash or under it) | "load" (healthy
    #: propellers, a moved load) | None (the log cannot tell, or no rotor named)
    cause: Optional[str] = None
    #: What the cause rests on (:meth:`flightlog_fd.cause.Cause.evidence`), None when no rotor is named
    cause_evidence: Optional[dict] = None
    #: The probability of ``cause`` given that the rotor lost thrust (None when no cause is stated)
    cause_probability: Optional[float] = None
    #: A healthy verdict: True when the evidence saw the flight (it lowered the probability of
    #: damage below the prior over at least ``SEEN_MIN_COVERED_S`` of usable flight), False when
    #: this log could not show damage (not a clearance); None for other verdicts.
    seen: Optional[bool] = None
    #: With ``cause`` = ``load``: where the load sits and its size (:meth:`LoadFit.as_dict` plus the
    #: nearest motor's position and direction words), else None
    load: Optional[dict] = None
    #: The first line a pilot reads (at most :data:`HEADLINE_MAX` characters): the status, the
    #: rotor, how much and what to do (:func:`headline`)
    headline: str = ""
    #: Per named rotor, how much of its normal thrust it gives: [{"motor", "eta_hat", "eta_ci"}]
    thrust: list = field(default_factory=list)
    #: P(some rotor lost thrust) after the log (None when the evidence was not weighed)
    p_damage: Optional[float] = None
    #: The prior of damage the verdict was decided under (:data:`PRIOR_DAMAGE` unless a fleet set its own)
    prior_damage: float = PRIOR_DAMAGE

    def __post_init__(self) -> None:
        if self.motor and not self.motors:
            self.motors = [self.motor]
        if self.motors and len(self.positions) != len(self.motors):
            self.positions = [self.position if (k == self.motor and self.position) else None for k in self.motors]

    def status_words(self) -> str:
        """The status with the motors it names: "damaged (motor 3)", "damaged (motors 1 and 4)",
        "uncertain (motors 1 and 4)" (a pair), "uncertain (motor 2)", "healthy"."""
        named = [k for k in self.motors] if (self.status in ("damaged", "stopped") or self.pair) else []
        if not named and self.motor:
            named = [self.motor]
        if not named:
            return self.status
        if len(named) == 1:
            return f"{self.status} (motor {named[0]})"
        return f"{self.status} (motors {', '.join(map(str, named[:-1]))} and {named[-1]})"

    def propellers(self) -> str:
        """The named propellers in words: "propeller 3 (front-left)", "propellers 1 (front-right)
        and 4 (rear-right)"; "" when none is named."""
        each = [f"{k} ({p})" if p else f"{k}" for k, p in zip(self.motors, self.positions)]
        if not each:
            return ""
        if len(each) == 1:
            return f"propeller {each[0]}"
        return "propellers " + ", ".join(each[:-1]) + f" and {each[-1]}"

    def as_dict(self) -> dict:
        """The verdict fields of the JSON report."""
        r4 = lambda x: None if x is None else round(float(x), 4)  # noqa: E731
        return {
            "status": self.status,
            "headline": self.headline,
            "motor": self.motor,
            "motors": [int(k) for k in self.motors],
            "positions": list(self.positions),
            "pair": bool(self.pair),
            "position": self.position,
            "thrust": [{"motor": int(t["motor"]), "eta_hat": r4(t["eta_hat"]),
                        "eta_ci": None if t.get("eta_ci") is None else [r4(t["eta_ci"][0]), r4(t["eta_ci"][1])]}
                       for t in self.thrust],
            "confidence": round(float(self.confidence), 4),
            "p_damage": r4(self.p_damage),
            "prior_damage": round(float(self.prior_damage), 4),
            "first_seen": None if self.first_seen is None else round(float(self.first_seen), 3),
            "reason": self.reason,
            "advice": [a.as_dict() for a in self.advice],
            "cause": self.cause,
            "cause_probability": r4(self.cause_probability),
            "cause_evidence": self.cause_evidence,
            "seen": self.seen,
            "load": self.load,
        }


def named_motor(status: str, motor: Optional[int], inspect: Sequence[int]) -> Optional[int]:
    """The motor a verdict names: a damaged or stopped verdict's own; for an uncertain one, the
    propeller it asks to inspect when it names exactly one (two it cannot tell apart name none)."""
    if status == "uncertain" and motor is None and len(inspect) == 1:
        return int(inspect[0])
    return motor


def not_diagnosable(reason: str) -> Verdict:
    """The verdict of a flight that cannot be judged, with the one-line reason."""
    v = Verdict(status="not_diagnosable", reason=reason)
    v.headline = headline(v)
    return v


@dataclass
class MotorDecision:
    """One motor's part in the decision (the report's per-motor severity and weight)."""

    motor: int
    llr: float  # the evidence for "rotor k lost thrust" against healthy, eta integrated jointly, nats
    llr_by_source: dict  # analyzer id -> nats (each capped; a source with an eta profile: its marginal)
    eta_hat: Optional[float]  # thrust efficiency (1 = healthy) at the joint evidence's peak, None without a profile source
    eta_ci: Optional[tuple[float, float]]
    weight: float  # P(this rotor lost thrust, alone or with another) after the log

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {"motor": self.motor, "llr": r(self.llr),
                "llr_by_source": {k: r(v) for k, v in self.llr_by_source.items()},
                "eta_hat": r(self.eta_hat),
                "eta_ci": None if self.eta_ci is None else [r(self.eta_ci[0]), r(self.eta_ci[1])],
                "weight": r(self.weight)}


@dataclass
class PairDecision:
    """One pair of motors in the decision: "rotors a and b both lost thrust"."""

    motors: tuple[int, int]
    llr: float  # the sources' capped sum, nats
    llr_by_source: dict  # analyzer id -> nats (each clipped to its cap)
    eta_hat: Optional[tuple[float, float]]  # the two-rotor command fit's, None when the shares are not weighed
    excess: float  # llr minus the best single rotor's
    weight: float = 0.0  # P(this pair) after the log

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {"motors": [int(k) for k in self.motors], "llr": r(self.llr),
                "llr_by_source": {k: r(v) for k, v in self.llr_by_source.items()},
                "eta_hat": None if self.eta_hat is None else [r(x) for x in self.eta_hat],
                "excess": r(self.excess), "weight": r(self.weight)}


@dataclass
class Decision:
    """Why the evidence gave its verdict: the hypotheses with their evidence and posterior, per
    motor and per pair, and the analyzers' results."""

    motors: list[MotorDecision] = field(default_factory=list)
    #: The pair hypotheses, most likely first; [] when not weighed
    pairs: list[PairDecision] = field(default_factory=list)
    airframe_changed: Optional[str] = None  # why, when the shares moved in no pattern a hypothesis explains
    healthy_chi2: Optional[float] = None
    share_sigma: Optional[float] = None
    sources: list[str] = field(default_factory=list)  # the analyzers that weighed in
    results: list[AnalyzerResult] = field(default_factory=list)
    weights: dict = field(default_factory=dict)  # analyzer id -> SourceWeight (how much it could give)
    #: {hypothesis: probability}: "healthy", "load", "rotor k", "rotors j+k"
    posterior: dict = field(default_factory=dict)
    p_damage: Optional[float] = None  # P(some rotor lost thrust)
    load_llr: Optional[float] = None  # the moved load's evidence against healthy (nats), None when not weighed


@dataclass(frozen=True)
class SourceWeight:
    """How much one source could give on this log: its reliability-table cell, the trust level
    measured there (None: no cell, the analyzer's own cap) and the cap in nats."""

    cell: str
    trust: Optional[str]
    cap: float

    def as_dict(self) -> dict:
        return {"cell": self.cell, "trust": self.trust, "cap": round(float(self.cap), 3)}


def source_weight(r: AnalyzerResult, kind: Optional[LogKind]) -> SourceWeight:
    """How much source ``r`` may give on this kind of log: the trust level of its cell in the
    measured reliability table (:func:`~flightlog_fd.analyzers.reliability.trust_of`) and the cap
    that level sets (``TRUST_CAPS``); the analyzer's own ``llr_cap`` where the table has no cell
    for it (or the kind of log is not known)."""
    if kind is None or not r.reliability_keys:
        return SourceWeight("", None, r.llr_cap)
    cell = cell_of(r.reliability_keys, kind)
    trust = trust_of(r.analyzer, cell)
    if kind.same_session and r.analyzer in SESSION_SOURCES:  # measured across sessions; within one, its drift is small
        return SourceWeight(f"{cell}, same session", "trusted", max(TRUST_CAPS["trusted"], r.llr_cap))
    if trust is None:
        return SourceWeight(cell, None, r.llr_cap)
    cap = TRUST_CAPS[trust]
    return SourceWeight(cell, trust, max(cap, r.llr_cap) if trust == "trusted" else min(cap, r.llr_cap))


# ----------------------------------------------------------------------------- the hypotheses

@dataclass
class Hypotheses:
    """One flight's hypotheses and what the sources say of each (:func:`hypotheses`)."""

    n: int
    sources: dict  # analyzer id -> (n,) capped nats for "rotor k" (a profile source: its marginal)
    weights: dict  # analyzer id -> SourceWeight
    rotor: np.ndarray  # (n,) nats for "rotor k", eta integrated jointly
    eta_post: Optional[np.ndarray]  # (n, len(ETA_GRID)) the joint evidence at each eta (None: no profile source)
    pairs: list  # PairDecision, most likely first
    load: Optional[LoadFit]
    load_llr: Optional[float]  # nats for "load" (None: not weighed)
    log_prior: dict  # hypothesis -> log prior
    posterior: dict  # hypothesis -> probability
    p_damage: float
    marginal: np.ndarray  # (n,) P(rotor k lost thrust, alone or with another)


def _vibration(results: Sequence[AnalyzerResult]) -> Optional[VibrationResult]:
    """The vibration result with a flight-level figure, if any."""
    return next((r for r in results if isinstance(r, VibrationResult) and not r.abstained
                 and r.flight_llr is not None and np.isfinite(r.flight_llr)), None)


def vibration_rotor_llr(vib: VibrationResult, n: int, cap: float) -> np.ndarray:
    """(n,) nats for "propeller k is out of balance": the flight-level Bayes factor (capped) shared
    over the rotors by the line's tie (``tie_probs``: P(the line is rotor k's), uniform without a
    tie): flight_llr + log(n p_k), so that "some propeller" (the mean over k) keeps flight_llr."""
    f = float(np.clip(vib.flight_llr, -cap, cap))
    probs = getattr(vib, "tie_probs", None)
    if probs is None or len(probs) != n:
        probs = np.full(n, 1.0 / n)
        if vib.line_motor is not None and vib.tie_trusted and 1 <= vib.line_motor <= n:
            per = vib.llr(n, cap)  # the analyzer's own tie, where it weighed one
            if per is not None:
                return per
    p = np.clip(np.asarray(probs, float), 1e-6, 1.0)
    return f + np.log(n * p / p.sum())


def _prior(n: int, prior: float, against_profile: bool, with_load: bool) -> dict:
    """Log prior of each hypothesis: healthy, load, rotor k, rotors j+k."""
    pair_odds = PAIR_LOG_PRIOR_ODDS["profile" if against_profile else "none"]
    pairs = [(a, b) for a in range(1, n + 1) for b in range(a + 1, n + 1)] if n in PAIR_ROTOR_COUNTS else []
    # one given pair is exp(pair_odds) as likely as one given rotor: split the damage prior so
    w_one = 1.0
    w_pair = float(np.exp(pair_odds))
    total = n * w_one + len(pairs) * w_pair
    load = PRIOR_LOAD["profile" if against_profile else "none"] if with_load else 0.0
    out = {"healthy": np.log((1 - prior) * (1 - load))}
    if with_load:
        out["load"] = np.log((1 - prior) * load)
    for k in range(1, n + 1):
        out[f"rotor {k}"] = np.log(prior * w_one / total)
    for a, b in pairs:
        out[f"rotors {a}+{b}"] = np.log(prior * w_pair / total)
    return out


def hypotheses(results: Sequence[AnalyzerResult], n: int, kind: Optional[LogKind],
               prior: float = PRIOR_DAMAGE) -> Hypotheses:
    """The table of hypotheses (module docstring) from the analyzers' results: each source capped by
    its measured reliability on this kind of log, eta integrated jointly per rotor, the pairs, the
    load, and the posterior under ``prior``."""
    vib = _vibration(results)
    weights, sources, profiles = {}, {}, {}
    for r in results:
        if r.abstained:
            continue
        w = source_weight(r, kind)
        if r is vib:  # "propeller k out of balance" is one way rotor k is damaged (IMBALANCED_SHARE)
            v = np.logaddexp(np.log(IMBALANCED_SHARE) + vibration_rotor_llr(vib, n, w.cap), np.log1p(-IMBALANCED_SHARE))
        else:
            v = r.llr(n, w.cap)
        if v is None:
            continue
        prof = r.eta_profile(n, w.cap) if r is not vib else None
        if prof is not None:  # a source that says how much: its tempered profile and marginal
            profiles[r.analyzer] = prof
            v = log_mean_exp(prof, axis=1)
        weights[r.analyzer], sources[r.analyzer] = w, np.asarray(v, float)
    flat = sum((v for s, v in sources.items() if s not in profiles), np.zeros(n))
    eta_post = None
    if profiles:
        eta_post = np.sum(list(profiles.values()), axis=0)  # (n, E)
        rotor = flat + log_mean_exp(eta_post, axis=1)
    else:
        rotor = flat
    cmd = next((r for r in results if isinstance(r, CommandSharesResult) and r.analyzer in sources), None)
    against_profile = cmd is not None and cmd.baseline == "profile"
    # the pairs: each source's pair evidence, capped as its single rotors
    pairs = []
    if n in PAIR_ROTOR_COUNTS:
        by_source = {}
        for r in results:
            if r.analyzer in sources and r is not vib:
                v = r.pair_llr(n, weights[r.analyzer].cap)
                if v is not None:
                    by_source[r.analyzer] = v
        if vib is not None and vib.analyzer in sources:
            per = sources[vib.analyzer]  # one out-of-balance line: a pair is as likely as its likelier rotor
            by_source[vib.analyzer] = {(a, b): float(np.logaddexp(per[a - 1], per[b - 1]) - np.log(2))
                                       for a in range(1, n + 1) for b in range(a + 1, n + 1)}
        fits = {pf.motors: pf for pf in (cmd.pairs if cmd is not None else [])}
        best_single = float(rotor.max()) if n else 0.0
        for a in range(1, n + 1):
            for b in range(a + 1, n + 1):
                parts = {s: float(v[(a, b)]) for s, v in by_source.items() if (a, b) in v}
                # a source silent on pairs says of both what it says of each rotor
                for s, v in sources.items():
                    if s not in parts:
                        parts[s] = float(v[a - 1] + v[b - 1])
                llr = float(sum(parts.values()))
                fit = fits.get((a, b))
                pairs.append(PairDecision(motors=(a, b), llr=llr, llr_by_source=parts,
                                          eta_hat=None if fit is None else tuple(fit.eta_hat), excess=llr - best_single))
    # the load: the pattern sources say of it what they say of its nearest rotor, the shares part them
    load = cmd.load if cmd is not None and cmd.load is not None and len(cmd.rotor_vs_load) == n else None
    load_llr = None
    if load is not None:
        # the other pattern sources read the load's pattern as the commands read it: rotor k at the
        # eta the commands' own fit of rotor k gives it (a small load reads as mild damage, which the
        # model hardly votes for)
        k = load.motor - 1
        i_eq = int(np.argmax(profiles[cmd.analyzer][k])) if cmd.analyzer in profiles else len(ETA_GRID) // 2
        pattern = sum(float(profiles[s][k, i_eq] if s in profiles else v[k])
                      for s, v in sources.items() if s in PATTERN_SOURCES and s != cmd.analyzer)
        load_llr = float(sources[cmd.analyzer][k] - cmd.rotor_vs_load[k] + pattern)
    logp = _prior(n, prior, against_profile, load is not None)
    logw = dict(logp)
    if load is not None:
        logw["load"] += load_llr
    for k in range(n):
        logw[f"rotor {k + 1}"] += float(rotor[k])
    for pd in pairs:
        logw[f"rotors {pd.motors[0]}+{pd.motors[1]}"] += pd.llr
    names = list(logw)
    vals = np.array([logw[h] for h in names])
    p = np.exp(vals - vals.max())
    p /= p.sum()
    post = dict(zip(names, (float(x) for x in p)))
    marginal = np.array([post[f"rotor {k}"] + sum(post[f"rotors {a}+{b}"] for a, b in (pd.motors for pd in pairs)
                                                   if k in (a, b)) for k in range(1, n + 1)])
    for pd in pairs:
        pd.weight = post[f"rotors {pd.motors[0]}+{pd.motors[1]}"]
    pairs.sort(key=lambda pd: -pd.weight)
    p_damage = float(sum(v for h, v in post.items() if h.startswith("rotor")))
    return Hypotheses(n=n, sources=sources, weights=weights, rotor=rotor, eta_post=eta_post, pairs=pairs, load=load,
                      load_llr=load_llr, log_prior=logp, posterior=post, p_damage=p_damage, marginal=marginal)


def eta_estimate(profile: Optional[np.ndarray]) -> tuple[Optional[float], Optional[tuple[float, float]]]:
    """(eta-hat, (lo, hi) 90 % interval) from one rotor's joint evidence over ETA_GRID (its posterior
    under the uniform prior); the interval opens to 0 when it reaches the grid's bottom, eta-hat 1.0
    at its healthy end. (None, None) without a profile."""
    if profile is None:
        return None, None
    post = np.exp(profile - profile.max())
    cdf = np.cumsum(post / post.sum())
    ia = min(int(np.searchsorted(cdf, 0.05)), len(ETA_GRID) - 1)
    ib = min(int(np.searchsorted(cdf, 0.95)), len(ETA_GRID) - 1)
    lo = 0.0 if ia == 0 else float(ETA_GRID[max(ia - (ia == ib), 0)])
    hi = float(ETA_GRID[min(ib + (ia == ib), len(ETA_GRID) - 1)])
    eta = float(ETA_GRID[int(np.argmax(profile))])
    if eta >= ETA_GRID[-1]:
        eta, hi = 1.0, 1.0
    return eta, (lo, hi)


# ----------------------------------------------------------------------------- words

#: The headline's most characters: a pilot reads it in five seconds, on an 80-column terminal in
#: two lines at most.
HEADLINE_MAX = 100
#: From this many rotors the verdict cannot tell apart, the headline names none ("inspect every
#: propeller"): four are every rotor of a quad, and "rotor 1 or 2 or 3 or 4 or 5 ..." no longer
#: reads in a glance (an octo judged from vibration alone covers all eight).
HEADLINE_ROTORS_NAMED = 4


def _where(frame: Optional[Frame], k: int) -> str:
    pos = frame.position(k) if frame is not None else None
    return f"{k} ({pos})" if pos else f"{k}"


def _words(frame: Optional[Frame], motor: int) -> str:
    return f"motor {_where(frame, motor)}"


def _first_step(cause: Optional[str], k: int) -> str:
    """What to inspect first for rotor k with this cause."""
    if cause == "motor_or_esc":
        return f"inspect motor {k} and its ESC"
    if cause == "wash":
        return f"check what sits under rotor {k}"
    return f"inspect propeller {k}"


def headline(v: Verdict, since: str = "", frame: Optional[Frame] = None) -> str:
    """The verdict's first line (at most :data:`HEADLINE_MAX` characters): the status, the rotor, how
    much and what to do. "Rotor 2 (rear-left) lost ~30 % thrust since take-off: inspect propeller 2"."""
    def fit(text: str) -> str:
        return text if len(text) <= HEADLINE_MAX else text[:HEADLINE_MAX - 1].rstrip() + "…"

    def loss(k: int) -> str:
        t = next((t for t in v.thrust if t["motor"] == k and t.get("eta_hat") is not None), None)
        return "" if t is None or t["eta_hat"] >= 1.0 else f" ~{100 * (1 - t['eta_hat']):.0f} %"

    pos = {k: p for k, p in zip(v.motors, v.positions)}
    name = lambda k: f"{k} ({pos[k]})" if pos.get(k) else f"{k}"  # noqa: E731
    if v.status == "not_diagnosable":
        return fit(f"Not diagnosable: {v.reason}")
    if v.status == "stopped":
        when = f" at t={v.first_seen:.1f} s" if v.first_seen is not None else ""
        return fit(f"Motor {name(v.motor)} stopped{when}: check motor {v.motor}, its ESC and wiring")
    if v.status == "healthy":
        if v.load:
            where = f"motor {v.load['motor']}" + (f" ({v.load['position']})" if v.load.get("position") else "")
            if v.seen is False:  # the log did not rule a rotor out: the load is the likelier, not shown
                return fit(f"No lost rotor shown; the pattern fits a load toward {where}: not a clearance")
            return fit(f"Healthy propellers; the load sits toward {where}: re-balance or re-calibrate")
        if v.seen is False:
            return fit("Healthy as far as this log shows, but it could not show damage: not a clearance")
        return fit("Healthy: no rotor lost thrust")
    when = f" {since}" if since else ""
    if v.status == "damaged":
        if v.pair and len(v.motors) == 2:
            a, b = v.motors
            return fit(f"Rotors {name(a)} and {name(b)} lost thrust{when}: inspect propellers {a} and {b}")
        if v.motor is not None:
            if v.cause == "propeller" and not loss(v.motor):  # ESC rpm or a vibration line, not the thrust
                return fit(f"Propeller {name(v.motor)} is damaged: inspect propeller {v.motor}")
            return fit(f"Rotor {name(v.motor)} lost{loss(v.motor)} thrust{when}: {_first_step(v.cause, v.motor)}")
        if len(v.inspect) == 1:  # one rotor, alone or with another
            k = int(v.inspect[0])
            return fit(f"Rotor {k} lost{loss(k)} thrust{when}: {_first_step(v.cause, k)}")
        if v.inspect and len(v.inspect) < HEADLINE_ROTORS_NAMED:
            ks = " or ".join(map(str, v.inspect))
            return fit(f"Rotor {ks} lost thrust{when}: inspect propellers {', '.join(map(str, v.inspect))}")
        return fit(f"Damage{when} on a rotor the log cannot name: inspect every propeller")
    # uncertain
    if v.pair and len(v.motors) == 2:
        a, b = v.motors
        return fit(f"Uncertain: rotors {a} and {b} may have lost thrust: inspect propellers {a} and {b}")
    if v.motor is not None:
        return fit(f"Uncertain: rotor {name(v.motor)} may have lost{loss(v.motor)} thrust: "
                   f"{_first_step(v.cause, v.motor)}")
    if v.inspect and len(v.inspect) < HEADLINE_ROTORS_NAMED:
        return fit(f"Uncertain: rotor {' or '.join(map(str, v.inspect))} may have lost thrust: inspect "
                   f"propellers {', '.join(map(str, v.inspect))}")
    return fit("Uncertain: a rotor the log cannot name may be damaged: inspect every propeller")


def _airframe_changed(cmd: Optional[CommandSharesResult], thr: Optional[ThrottleResult], n: int,
                      best: int) -> Optional[str]:
    """Words for "the shares moved beyond the drift and neither the leading rotor nor a load
    explains it", else None."""
    if cmd is None or cmd.abstained or cmd.baseline != "profile":
        return None
    dof = max(n - 1, 1)
    healthy_chi2 = cmd.healthy_chi2 if cmd.healthy_chi2_shares is None else cmd.healthy_chi2_shares
    fit_chi2 = cmd.fit_chi2_shares or cmd.fit_chi2
    if healthy_chi2 / dof <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    if fit_chi2[best] / max(dof - 1, 1) <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    if cmd.load is not None and cmd.load.chi2 / max(n - 3, 1) <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    shares = [cmd.finding("share", k + 1) for k in range(n)]
    text = "the command shares moved in a pattern no single rotor or load explains: " + ", ".join(
        f"motor {k + 1} {100 * (f.value - f.baseline):+.0f} %" for k, f in enumerate(shares) if f is not None)
    if thr is not None and thr.ratio is not None:
        text += f"; throttle {100 * (thr.ratio - 1):+.0f} % against calibration"
    return text


def load_verdict_fields(load: LoadFit, frame: Optional[Frame], cmd: Optional[CommandSharesResult]) -> dict:
    """``Verdict.load``: the load's direction, nearest motor and size with their words ("the load
    sits toward motor 2 (rear-left), which carries about 24 % more than at calibration")."""
    from .frames import position_word

    rad = np.radians(load.direction_deg)
    side = position_word(float(np.cos(rad)), float(np.sin(rad)))
    than = "at calibration" if cmd is not None and cmd.baseline == "profile" else "an even share"
    where = _words(frame, load.motor)
    pos = frame.position(load.motor) if frame is not None else None
    toward = where if pos == side else f"the {side}, nearest {where}"
    return {**load.as_dict(), "position": pos, "side": side,
            "words": f"the load sits toward {toward}, which carries about {100 * load.size:.0f} % more than {than}"}


def _one_flight_note(cmd: Optional[CommandSharesResult]) -> Optional[str]:
    """The note that a one-session profile cannot show the trim's session-to-session move, or None."""
    if cmd is None or cmd.abstained or cmd.baseline != "profile":
        return None
    sessions = cmd.n_sessions or 0  # 0: a profile older than schema 6, its flights pooled
    if sessions >= 2 or (sessions == 0 and (cmd.n_flights or 1) > 1):
        return None
    return ("a one-session profile cannot show how this airframe's trim moves between sessions: "
            "fdlog calibrate --add PROFILE LOG adds healthy flights of other days as sessions")


def _evidence_words(hyp: Hypotheses, k: int, cmd: Optional[CommandSharesResult]) -> str:
    """"needs 28 % more command than its neighbours; evidence for rotor 1 (nats): model +4.5, commands +2.6"."""
    parts = ", ".join(f"{s} {v[k - 1]:+.1f}" for s, v in hyp.sources.items())
    cite = f"it {cmd.words[k - 1]}; " if cmd is not None and cmd.analyzer in hyp.sources and cmd.words else ""
    return f"{cite}evidence for rotor {k} (nats): {parts}"


def _thin_timeline_words(timeline: Optional[Timeline], weights: dict) -> str:
    """What a verdict over a mostly uncertain timeline rests on ("" when the timeline is not)."""
    if timeline is None or not timeline.n_windows or timeline.abstained_share < THIN_TIMELINE_SHARE:
        return ""
    others = [f"{s} ({w.trust})" if w.trust and w.trust != "trusted" else s for s, w in weights.items() if s != "model"]
    return (f"{100 * timeline.abstained_share:.0f} % of the model's windows are uncertain ('?'), so the verdict "
            f"rests on {', '.join(others) if others else 'the model alone'}")


def not_seen_words(covered_s: Optional[float], kind: Optional[LogKind]) -> str:
    """Why this log could not show damage and what would make the next one decisive: more usable
    flight (``SEEN_MIN_COVERED_S``), motor outputs and rates at full rate, a calibration profile."""
    todo = []
    if covered_s is not None and covered_s < SEEN_MIN_COVERED_S:
        todo.append(f"fly at least {SEEN_MIN_COVERED_S:.0f} s airborne with some roll and pitch manoeuvring")
    if kind is not None and rate_class(kind.stream_hz) != "full rate":
        todo.append(f"log the motor outputs and angular rates at {FULL_RATE_HZ:.0f} Hz or more "
                    f"(now {kind.stream_hz:.0f} Hz)")
    if kind is not None and kind.profile == "none":
        todo.append("calibrate on a healthy flight of this airframe (fdlog calibrate)")
    if not todo:
        todo.append("fly a longer flight with some roll and pitch manoeuvring")
    short = f"only {covered_s:.0f} s of usable flight" if covered_s is not None and covered_s < SEEN_MIN_COVERED_S \
        else "the evidence barely moved the prior"
    return f"this log could not show damage ({short}): not a clearance; next time: {'; '.join(todo)}"


# ----------------------------------------------------------------------------- the verdict

def _stopped(stops: Sequence, frame: Optional[Frame], underneath: Optional[Verdict]) -> Verdict:
    """The "stopped" verdict for the earliest stopped motor (a motor or ESC failure, not a damaged
    propeller); the propeller verdict it replaces, if windows were judged, is kept in the reason."""
    from .stopped import describe

    first = stops[0]
    others = "".join(f"; also {describe(s)}" for s in stops[1:])
    was = (f"; the propeller diagnosis alone said {underneath.status}"
           + (f" (motor {underneath.motor})" if underneath.motor else "") if underneath is not None else "")
    stopped_motors = list(dict.fromkeys(s.motor for s in stops))
    v = Verdict(status="stopped", motor=first.motor, motors=stopped_motors,
                positions=[frame.position(k) if frame is not None else None for k in stopped_motors],
                position=frame.position(first.motor) if frame is not None else None, confidence=1.0,
                first_seen=first.t_start,
                reason=f"{describe(first)}{others}: check motor {first.motor}, its ESC, wiring and output "
                       f"assignment before the next flight{was}")
    v.headline = headline(v, frame=frame)
    return v


def weigh(results: Sequence[AnalyzerResult], n: int, frame: Optional[Frame], timeline: Optional[Timeline],
          kind: Optional[LogKind], prior: float = PRIOR_DAMAGE, judged_alone: Optional[str] = None
          ) -> tuple[Verdict, Decision]:
    """The verdict from the analyzers' evidence (module docstring). ``timeline``: the model's
    windows (None for a flight judged from vibration alone, ``judged_alone`` saying why)."""
    hyp = hypotheses(results, n, kind, prior)
    cmd = next((r for r in results if isinstance(r, CommandSharesResult) and not r.abstained), None)
    thr = next((r for r in results if isinstance(r, ThrottleResult) and not r.abstained), None)
    vib = _vibration(results)
    post, p_dmg, marginal = hyp.posterior, hyp.p_damage, hyp.marginal
    motors = []
    for k in range(n):
        eta, ci = eta_estimate(None if hyp.eta_post is None else hyp.eta_post[k])
        motors.append(MotorDecision(motor=k + 1, llr=float(hyp.rotor[k]),
                                    llr_by_source={s: float(v[k]) for s, v in hyp.sources.items()},
                                    eta_hat=eta, eta_ci=ci, weight=float(marginal[k])))
    best = int(np.argmax(hyp.rotor)) if n else 0
    decision = Decision(motors=motors, pairs=hyp.pairs, airframe_changed=_airframe_changed(cmd, thr, n, best),
                        healthy_chi2=None if cmd is None else cmd.healthy_chi2,
                        share_sigma=None if cmd is None else cmd.share_sigma, sources=list(hyp.sources),
                        results=list(results), weights=hyp.weights, posterior=post, p_damage=p_dmg,
                        load_llr=hyp.load_llr)
    onset = timeline.onset if timeline is not None else None
    if judged_alone is not None:
        since = ""
    elif onset is not None:
        since = f"since t={onset.first_seen:.1f} s"
    else:
        since = "since take-off"
    # the most probable damage hypothesis, and the rotors in it
    damage = sorted(((h, p) for h, p in post.items() if h.startswith("rotor")), key=lambda x: -x[1])
    top, p_top = damage[0] if damage else (None, 0.0)
    order = [int(i) + 1 for i in np.argsort(-marginal, kind="stable")]

    def rotors_of(h: str) -> list[int]:
        return [int(x) for x in h.split(" ")[1].split("+")]

    pair = False
    named: list[int] = []
    inspect: tuple = ()
    if p_dmg >= 0.5:
        status = "damaged"
        if top is not None and p_top >= 0.5 * p_dmg:
            named = rotors_of(top)
            pair = len(named) == 2
            confidence = p_top if pair else float(marginal[named[0] - 1])
            inspect = tuple(named)
        elif marginal[order[0] - 1] >= 0.5 * p_dmg > marginal[order[1] - 1]:  # one rotor in most of it
            named, inspect = [order[0]], (order[0],)
            confidence = float(marginal[order[0] - 1])
        else:  # damage, but two or more rotors share it: name them for inspection
            inspect = tuple(_covering(order, marginal, p_dmg))
            confidence = float(sum(marginal[k - 1] for k in inspect)) if inspect else p_dmg
            confidence = min(confidence, p_dmg)
    elif p_dmg >= inspect_bar():
        status = "uncertain"
        if top is not None and top.startswith("rotors ") and p_top >= 0.5 * p_dmg:
            named, pair = rotors_of(top), True
            confidence = p_top
        else:
            named = [order[0]] if marginal[order[0] - 1] >= 0.5 * p_dmg else []
            if not named:
                inspect = tuple(_covering(order, marginal, p_dmg))
            confidence = float(sum(marginal[k - 1] for k in (named or inspect)))
        inspect = inspect or tuple(named)
    else:
        status, confidence = "healthy", 1.0 - p_dmg
    motor = named[0] if named else None
    verdict = Verdict(status=status, motor=motor, motors=list(named), pair=pair,
                      position=frame.position(motor) if frame is not None and motor else None,
                      positions=[frame.position(k) if frame is not None else None for k in named],
                      confidence=float(np.clip(confidence, 0.0, 1.0)), inspect=inspect,
                      first_seen=(onset.first_seen if onset is not None else (timeline.t_first if timeline else None))
                      if status == "damaged" else None, p_damage=p_dmg, prior_damage=prior)
    for k in named:
        m = motors[k - 1]
        if m.eta_hat is not None:
            verdict.thrust.append({"motor": k, "eta_hat": m.eta_hat, "eta_ci": m.eta_ci})
    if pair and named:
        fit = next((pd for pd in hyp.pairs if list(pd.motors) == sorted(named)), None)
        if fit is not None and fit.eta_hat is not None:
            verdict.thrust = [{"motor": k, "eta_hat": e, "eta_ci": None} for k, e in zip(fit.motors, fit.eta_hat)]
    # the cause: a judgement of its own, for one named rotor
    cause = judge_cause(results, motor) if motor is not None and not pair else None
    if cause is not None:
        verdict.cause = cause.cause
        verdict.cause_evidence = cause.evidence()
        verdict.cause_probability = float(cause.probs[cause.cause]) if cause.cause and cause.probs else None
    # a healthy verdict: a moved load, and whether the log saw the flight
    if status == "healthy":
        covered = timeline.covered_s if timeline is not None else None
        odds, prior_odds = p_dmg / max(1.0 - p_dmg, 1e-12), prior / (1.0 - prior)
        verdict.seen = bool(np.log(prior_odds / max(odds, 1e-300)) >= SEEN_MIN_NATS
                            and (covered is None or covered >= SEEN_MIN_COVERED_S))
        if hyp.load is not None and post.get("load", 0.0) > post["healthy"]:
            verdict.load = load_verdict_fields(hyp.load, frame, cmd)
            verdict.cause = "load"
    verdict.reason = _reason(verdict, hyp, cmd, vib, cause, decision, timeline, kind, judged_alone, since)
    verdict.headline = headline(verdict, since if status == "damaged" else "", frame)
    return verdict, decision


def _covering(order: list[int], marginal: np.ndarray, p_dmg: float) -> list[int]:
    """The rotors, most probable first, until together they hold 90 % of the damage probability."""
    out, got = [], 0.0
    for k in order:
        if got >= 0.9 * p_dmg:
            break
        out.append(k)
        got += float(marginal[k - 1])
    return out


def _reason(v: Verdict, hyp: Hypotheses, cmd, vib, cause: Optional[Cause], decision: Decision,
            timeline: Optional[Timeline], kind: Optional[LogKind], judged_alone: Optional[str], since: str) -> str:
    """The evidence behind the verdict in a few clauses (the headline says what; this says why)."""
    parts = []
    p_line = f"P(damage) {v.p_damage:.2f} with a prior of {v.prior_damage:.2f}"
    if v.status in ("damaged", "uncertain") and v.motors:
        k = v.motors[0]
        eta = next((t for t in v.thrust if t["motor"] == k), None)
        if eta is not None and eta["eta_ci"] is not None and eta["eta_hat"] < 1.0:
            lo, hi = eta["eta_ci"]
            parts.append(f"rotor {k} gives about {100 * eta['eta_hat']:.0f} % of its normal thrust"
                         + (f" [{100 * lo:.0f}-{100 * hi:.0f} %]" if lo > 0 else f" [at most {100 * hi:.0f} %]"))
        if v.pair:
            pd = next((pd for pd in hyp.pairs if list(pd.motors) == sorted(v.motors)), None)
            if pd is not None:
                parts.append(f"two rotors explain the evidence {pd.excess:+.1f} nats better than one: "
                             + ", ".join(f"{s} {x:+.1f}" for s, x in pd.llr_by_source.items()))
        else:
            parts.append(_evidence_words(hyp, k, cmd))
        if cause is not None:
            parts.append(f"cause: {cause.words}")
        if v.status == "uncertain" and hyp.load is not None and hyp.posterior.get("load", 0) > 0.05:
            parts.append(f"or no rotor lost thrust and {load_verdict_fields(hyp.load, None, cmd)['words']}")
    elif v.status in ("damaged", "uncertain"):
        if len(v.inspect) == 1:
            parts.append(f"the evidence points at rotor {v.inspect[0]}, alone or with another rotor")
        elif len(v.inspect) >= HEADLINE_ROTORS_NAMED:
            parts.append(f"no rotor can be named: the evidence points at {len(v.inspect)} rotors alike")
        else:
            parts.append("the evidence points at " + " or ".join(f"rotor {k}" for k in v.inspect) + " and cannot "
                         "tell them apart" if v.inspect else "a propeller is out of balance but no rotor can be named")
        if vib is not None and vib.level_words:
            parts.append(vib.level_words)
        why = getattr(vib, "why_untied", "") if vib is not None else ""
        if why:
            parts.append(why)
    else:  # healthy
        if v.load:
            said = "propellers healthy" if v.seen else "the pattern fits a moved load better than a lost rotor"
            parts.append(f"{said}: {v.load['words']} (a moved load, {hyp.load_llr:+.1f} nats against "
                         f"none; a rotor that lost thrust would need more)")
        k = int(np.argmax(hyp.rotor)) + 1 if hyp.n else None
        if k is not None:
            parts.append(f"no rotor lost thrust: the strongest case, rotor {k}, has {hyp.rotor[k - 1]:+.1f} nats")
        if v.seen is False:
            parts.append(not_seen_words(timeline.covered_s if timeline is not None else None, kind))
    parts.append(p_line)
    if vib is not None and vib.level_words and v.motors:
        parts.append(vib.level_words)
    if decision.airframe_changed:
        parts.append(f"also {decision.airframe_changed}: re-calibrate after the inspection")
    thin = _thin_timeline_words(timeline, hyp.weights)
    if thin:
        parts.append(thin)
    if judged_alone is not None:
        parts.append(f"only vibration was judged ({judged_alone})")
    for r in decision.results:
        parts.extend(r.notes)
    one = _one_flight_note(cmd) if v.status != "healthy" else None
    if one:
        parts.append(one)
    return "; ".join(p for p in parts if p)


def decide(n_motors: int, frame: Optional[Frame] = None, *, timeline: Optional[Timeline] = None,
           results: Sequence[AnalyzerResult] = (), stopped: Sequence = (),
           not_diagnosable_reason: Optional[str] = None, kind: Optional[LogKind] = None,
           prior: float = PRIOR_DAMAGE) -> tuple[Verdict, Optional[Decision]]:
    """The flight's verdict and, when the evidence was weighed, its :class:`Decision` (module
    docstring). ``timeline``: the model's windows (None when none were judged); ``results``: the
    analyzers'; ``stopped``: :class:`~flightlog_fd.stopped.StoppedMotor` s, earliest first;
    ``not_diagnosable_reason``: why the pipeline could not judge the flight."""
    reason = not_diagnosable_reason or (timeline.shortfall if timeline is not None else None)
    if reason is None and timeline is None:
        reason = "no window of airborne data was judged"
    vib = _vibration(results)
    if reason is not None and vib is not None and n_motors:  # the log lacks what the rest needs; vibration does not
        verdict, decision = weigh([vib], n_motors, frame, None, kind, prior, judged_alone=reason)
    elif reason is not None:
        verdict, decision = not_diagnosable(reason), None
    else:
        verdict, decision = weigh(results, n_motors, frame, timeline, kind, prior)
    if stopped:  # a motor that stopped in the air outranks any propeller verdict
        verdict = _stopped(stopped, frame, verdict if timeline is not None else None)
    return verdict, decision


@dataclass
class DecisionInputs:
    """What one flight's verdict is decided from, all of it (:func:`decide_flight`).

    ``n_motors``: the rotors judged; ``timeline``: the model's windows (None when none were judged);
    ``results``: the analyzers' (only those needing no motor outputs for a log judged from vibration
    alone); ``stopped``: :class:`~flightlog_fd.stopped.StoppedMotor` s, earliest first;
    ``not_diagnosable_reason``: why the pipeline could not judge the flight; ``kind``: the kind of
    log the sources are weighed for; ``configuration_words``: the profile's load configuration the
    commands were weighed against (a profile of two or more), named in the reason; ``log``: for one
    flight of a log holding several, the whole log's verdict and decision, which the flight's
    verdict is never worse than (:func:`capped_by_log`); ``prior``: the prior of damage."""

    n_motors: int
    frame: Optional[Frame] = None
    timeline: Optional[Timeline] = None
    results: Sequence[AnalyzerResult] = ()
    stopped: Sequence = ()
    not_diagnosable_reason: Optional[str] = None
    kind: Optional[LogKind] = None
    configuration_words: Optional[str] = None
    log: Optional[tuple[Verdict, Optional[Decision]]] = None
    prior: float = PRIOR_DAMAGE


def decide_flight(inputs: DecisionInputs) -> tuple[Verdict, Optional[Decision]]:
    """The one entry point of the diagnose pipeline for a flight's verdict: :func:`decide`, the
    profile's load configuration named in the reason, and for one flight of several the cap by its
    whole log (:func:`capped_by_log`). Returns the verdict and, when the evidence was weighed, its
    :class:`Decision`."""
    verdict, decision = decide(inputs.n_motors, inputs.frame, timeline=inputs.timeline, results=inputs.results,
                               stopped=inputs.stopped, not_diagnosable_reason=inputs.not_diagnosable_reason,
                               kind=inputs.kind, prior=getattr(inputs, "prior", PRIOR_DAMAGE))
    if inputs.configuration_words and verdict.reason:
        verdict.reason = f"{verdict.reason} ({inputs.configuration_words})"
    if inputs.log is not None:
        verdict = capped_by_log(verdict, *inputs.log)
    return verdict, decision


def capped_by_log(own: Verdict, log: Verdict, decision: Optional[Decision]) -> Verdict:
    """A flight's own verdict, no worse than its whole log's: a log of n flights gives n tries at a
    false alarm. A flight worse than the log takes the log's status (a damaged flight naming another
    motor than the log's damaged one is uncertain); its reason keeps what it said alone and the
    log's figure for that motor."""
    rank = STATUS_RANK
    if own.status in ("not_diagnosable", "stopped") or rank.get(own.status, 0) < rank.get(log.status, 0):
        return own
    same = sorted(own.motors) == sorted(log.motors)
    if rank.get(own.status, 0) == rank.get(log.status, 0) and (own.motor is None or same
                                                              or own.status != "damaged"):
        return own
    if own.status == "damaged" and log.status == "damaged" and same:
        return own
    status = log.status if rank.get(log.status, 0) < rank.get(own.status, 0) else "uncertain"
    if status == "not_diagnosable":
        status = "healthy"
    said = own.status_words()
    whole = ""
    if own.motor and decision is not None and len(decision.motors) >= own.motor:
        whole = f", motor {own.motor} {decision.motors[own.motor - 1].llr:+.1f} nats over the whole log"
    inspect = (own.inspect or ((own.motor,) if own.motor else ())) if status != "healthy" else ()
    motor = named_motor(status, None, inspect)
    v = Verdict(status=status, motor=motor, position=own.position if motor is not None and motor == own.motor
                else None, confidence=log.confidence if status == log.status else min(own.confidence, log.confidence),
                first_seen=None, inspect=inspect, seen=log.seen if status == log.status else None,
                p_damage=own.p_damage, prior_damage=own.prior_damage,
                thrust=[t for t in own.thrust if t["motor"] == motor] if motor else [],
                reason=f"judged alone this flight would be {said}: {own.reason}; the whole log does not "
                       f"confirm it ({log.status}{whole}), so this flight is {status}")
    v.headline = headline(v)
    return v


def worst_flight(verdicts: Sequence[Verdict]) -> int:
    """Index of the worst of several flights' verdicts (``STATUS_RANK``, then confidence)."""
    return max(range(len(verdicts)), key=lambda i: (STATUS_RANK.get(verdicts[i].status, 0), verdicts[i].confidence))


def decide_log(parts: Sequence[tuple[str, Verdict]], whole: Optional[Verdict] = None) -> Verdict:
    """The verdict of a log holding several flights, from its flights' (``parts``: label, verdict).
    ``whole``: the log judged as one (a log with motor outputs), which stays its verdict, the reason
    listing each flight's status; without it (flights judged each on its own) the worst flight's
    (:func:`log_verdict`)."""
    if whole is None:
        return log_verdict(parts)
    return replace(whole, reason=whole.reason + "; " + "; ".join(f"{lab}: {v.status_words()}" for lab, v in parts))


def log_verdict(parts: Sequence[tuple[str, Verdict]]) -> Verdict:
    """The verdict of a log holding several flights: its worst flight's (:func:`worst_flight`),
    the headline and reason naming that flight ("Flight 2 of 2: ...") and listing every other one."""
    i = worst_flight([v for _, v in parts])
    label, worst = parts[i]
    others = "".join(f"; {lab}: {v.status_words()}" for lab, v in parts if v is not worst)
    head = f"Flight {i + 1} of {len(parts)}: {worst.headline}" if worst.headline else ""
    if len(head) > HEADLINE_MAX:
        head = head[:HEADLINE_MAX - 1].rstrip() + "…"
    return replace(worst, reason=f"{label}: {worst.reason}{others}", advice=list(worst.advice),
                   motors=list(worst.motors), positions=list(worst.positions), thrust=list(worst.thrust),
                   headline=head or worst.headline)
