"""The flight's verdict, made here alone: from the timeline, the analyzers' results, the stopped
motors and the reasons a flight cannot be judged (:func:`decide`).

One pass down: the diagnose pipeline calls :func:`decide_flight` once per flight with its
:class:`DecisionInputs` (which also name the profile configuration the commands were weighed
against and, for one flight of a log holding several, the whole log's verdict it is never worse
than, :func:`capped_by_log`), and :func:`decide_log` once for a log of several flights. The evidence
is weighed in three parts (:func:`_weigh`): the table of hypotheses (:func:`_evidence` ->
:class:`Evidence`: healthy, rotor k, rotors j and k, a load toward a direction), the ordered rules
(:data:`RULES`, each a small named function returning a :class:`Statement` or None; the first that
states wins; a new rule is one entry), and :func:`_done`, which states it (vibration's raise,
``STATED_MIN_CONFIDENCE``, seen, notes, the load's words).

Precedence: a motor that stopped in the air ("stopped", :mod:`flightlog_fd.stopped`) outranks
everything; then a flight that cannot be judged (``not_diagnosable``: the pipeline's reason, or too
little flight in the :class:`~flightlog_fd.timeline.Timeline`); then the evidence.

The evidence: for each motor k, "rotor k lost thrust" against "healthy, with this airframe's
normal trim drift". The log-likelihood ratios (LLR, nats) of the registered analyzers'
(:mod:`flightlog_fd.analyzers`) findings are summed per motor, each analyzer's total clipped to
what its measured reliability on this kind of log allows (:func:`source_weight`: the trust level
of its cell in :mod:`flightlog_fd.analyzers.reliability`'s table, ``TRUST_CAPS``; the analyzer's
own ``llr_cap`` where the table has no cell; the command shares are capped keeping their order, so
a weak rotor stays apart from its coaxial partner). A discounted source counts toward "uncertain"
only.
The sources: the model's window votes, the command shares (mixer-physics fit, which also gives
each rotor's thrust eta-hat), the throttle against calibration, the effectiveness fit when it is
informative, and ESC telemetry where the log has it. Their noise figures are measured and written
beside their constants in their own modules.

``damaged`` when the best motor's total LLR (without the discounted sources) reaches ``DAMAGED_LLR``, beats the runner-up by
``SEPARATION_LLR`` and its command share rose against its baseline (a weak rotor must need more);
``uncertain`` from ``UNCERTAIN_LLR`` (``FULL_RATE_UNCERTAIN_LLR`` on a quad at full rate without a
profile: :func:`uncertain_bar`; the reason names the motor to inspect, or the two it cannot
tell apart); ``healthy`` below. "Airframe changed" (re-calibrate) is said only when the shares
moved beyond the drift AND no single rotor explains the move; a motor whose excess is beyond the
drift is named for inspection first.

Against a profile, the command shares and the throttle (``TRIM_SOURCES``: a moved load changes
them as a weak rotor does) reach at most ``uncertain`` unless a source that does not read the
trim (here the model counts) agrees (``TRIM_FREE_AGREE_LLR``) or the rise is beyond any moved load
(``BEYOND_DRIFT_SHARE_RISE``), and never ``damaged`` with the throttle well below calibration
(``THROTTLE_FELL_SIGMAS``); the reason then says what to inspect and when to re-calibrate.

With or without a profile, the sources that read the command pattern (``PATTERN_SOURCES``: the
commands, the throttle and the model, whose windows read the same commands) reach at most
``uncertain`` together (:func:`_pattern_held`): a load at a rotor's corner (a weight in its wash, a
payload under it) takes that rotor's thrust for its command as a damaged propeller does
(crazypad_e9_load W3, results/decisive.md). The verdict then names the rotor and the load, and what
tells them apart (inspect the propeller; fly once without the payload; ESC telemetry or vibration),
unless a source that does not read the commands agrees (``TRIM_FREE_AGREE_LLR``), the share rose
beyond what a load makes (``BEYOND_DRIFT_SHARE_RISE``) or the pattern began mid-flight (the model's
onset on that motor: a load carried from take-off does not).

Confidence (:data:`CONFIDENCE_MEANING`): the probability that the stated verdict is right, from
the per-motor LLRs under ``PRIOR_DAMAGED`` (:func:`posterior`): healthy, P(no rotor lost thrust);
damaged motor k, P(motor k); uncertain, P(one of the propellers it names lost thrust), at most
``UNCERTAIN_CONFIDENCE_CAP``; a damaged pair, P(that pair) (:func:`_pair_posterior`); an uncertain
pair, P(either of the two); "the airframe changed, no rotor explains it", P(no rotor lost thrust).
Stopped: 1; not diagnosable: 0 (no verdict stated). The LLRs it reads are each motor's total, no
motor below ``MILD_DAMAGE_LLR_FLOOR`` (damage too mild for any source to see cannot be ruled out);
the trim sources are not held here (they are for the bars). No verdict is stated below
``STATED_MIN_CONFIDENCE`` (:func:`_stated`): a healthy one below it becomes ``uncertain`` naming the
leading rotors ("P(healthy) only 0.28: motor 2 leads"), an uncertain one names the next rotors too
until they reach it. A healthy verdict is ``seen`` from ``SEEN_HEALTHY_P``; below it the log could
not show damage (not a clearance, though the status stays healthy: exit 0). Measured per set, real
and simulated, without and with a one-flight profile: benchmarks/bench_confidence.py
(results/confidence.md).

Vibration (:class:`~flightlog_fd.analyzers.vibration.VibrationResult`): besides its per-motor LLRs
(only for a line tied to a rotor by ESC rpm), its flight-level log Bayes factor "a propeller is out
of balance" raises a verdict the per-motor sums leave lower: from ``DAMAGED_LLR`` to damaged, from
``UNCERTAIN_LLR`` to uncertain, naming no rotor ("inspect all"; the tied rotor first where the tie is
ESC rpm; a tie by commanded speed alone is named as a hint only in an uncertain verdict). A log the
pipeline cannot judge (no motor outputs, no damage model for its frame) is judged from vibration
alone when its result is given, the reason saying what the log lacks.

Two propellers (:func:`_pair_step`, a step of its own after the single rotors are weighed): each
source also weighs "rotors a and b both lost thrust" for every pair (:meth:`AnalyzerResult.pair_llr`,
capped as its single rotors are: the command shares' two-rotor mixer fit, the throttle's part of
it, the effectiveness fit with both weak, the model seeing at most one of the two, ESC telemetry's
two motors summed, lowered with its rotors so its cap keeps "two rather than one", a vibration
line tied to a rotor). The best pair is named when its total
reaches ``UNCERTAIN_LLR`` and beats the best single rotor by ``PAIR_EXCESS_LLR`` (against a profile
``PAIR_EXCESS_PROFILE_LLR``: the pair's prior odds, it has a second free efficiency and is rarer), ``damaged`` under the single rotor's bars
(discounted sources not counted toward them), else ``uncertain`` naming both (a moved load or
re-trim makes the same command pattern: against a profile the commands alone reach at most
``uncertain``). An uncertain pair does not replace a single rotor that meets every bar of
``damaged`` (a noisy source can favour two rotors where the commands' physics backs one: a
simulated f450 at 10 Hz motor logging, propeller 3 weak, read the effectiveness of 2 and 3 low and
became "uncertain, propellers 2 and 3" with rotor 3 alone at +14.8 nats). ``Verdict.motors`` lists
both, ``motor`` is the first, ``inspect`` both, ``cause`` null; the confidence is P(that pair)
among healthy, every rotor and every pair (:func:`_pair_posterior`). Quads only
(``analyzers.base.PAIR_ROTOR_COUNTS``).

The verdict names the propellers to inspect (``Verdict.inspect``); what would resolve it
(``Verdict.advice``) is :mod:`flightlog_fd.advice`'s. A healthy verdict over a mostly uncertain
timeline (``THIN_TIMELINE_SHARE``) says what it rests on.

Cause (:mod:`flightlog_fd.cause`): a verdict naming one rotor (damaged, or uncertain naming it)
carries its likely cause from ESC telemetry, the propeller or the motor / ESC, or says the log
cannot tell; the advice follows it ("inspect motor k and ESC k before the propeller"). A pair's
cause is null: the ESC relations measure each motor against the others, which two weak rotors
share, and the advice is to inspect both propellers.

Limits: at most two damaged rotors; the sources are treated as independent (the model sees the
same commands the command analyzer weighs, which is why each source is capped).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

from .analyzers import AnalyzerResult
from .analyzers.base import PAIR_ROTOR_COUNTS, SOURCE_LLR_CAP
from .analyzers.command_shares import ETA_GRID, THROTTLE_DRIFT_SIGMA, CommandSharesResult, LoadFit
from .analyzers.reliability import FULL_RATE_HZ, LogKind, cell_of, rate_class, trust_of
from .analyzers.throttle import ThrottleResult
from .analyzers.vibration import VibrationResult
from .cause import Cause, judge_cause
from .flight import Frame
from .timeline import Timeline

#: Total LLR (nats) at which one motor is called damaged: about 3 nats (20 times more likely)
#: above the largest total of any motor on the 18 real healthy flights without a profile (3.1,
#: Erle 15-10-2014_42; benchmarks/bench_real_damage.py), so none of them is called damaged.
DAMAGED_LLR = 6.0
#: The named motor must beat every other motor by this much (e^2 ~ 7 times more likely).
SEPARATION_LLR = 2.0
#: From this total LLR the flight is "uncertain" and the reason names what to inspect: half a nat
#: above that largest healthy total (3.1), so those 18 flights stay healthy.
UNCERTAIN_LLR = 3.5
#: Without a profile, on a quad whose motor outputs and rates are logged at full rate
#: (:func:`~flightlog_fd.analyzers.reliability.rate_class`, from 45 Hz), the uncertain bar is the
#: lowest (in tenths of a nat) that at most 5 % of the simulated healthy airframes with realistic
#: imbalance reach (the reliability rule's share for a trusted source: an inspection asked for on
#: a healthy airframe) and no real healthy flight does: the healthy flights' leading total LLR
#: (benchmarks/bench_reliability.py bars): 150 simulated full-rate quads (seed 9100: PX4 high-rate,
#: ArduPilot 50 and 400 Hz, with and without ESC telemetry) reach 2.5 on 7 (4.7 %), 2.4 on 9; the 7
#: real full-rate healthy flights (px4_sih_dev high-rate 3, CrazyPAD E9 normals 3, Erle-Brain2
#: 50 Hz) at most -0.1. Elsewhere the bar stays UNCERTAIN_LLR, set on the real healthy flights: the
#: same rule would raise it (low-rate quads 4.7: 10 of 90 simulated ones reach 3.5; n-rotors 5.3 at
#: full rate, 4.5 at low rate), and mid rate has too few real flights (2) and no real damaged one.
FULL_RATE_UNCERTAIN_LLR = 2.5
#: Chi-square (per share degree of freedom) above which the healthy hypothesis fails: the shares
#: moved beyond the drift (p < 0.01 with 3 degrees of freedom: 11.3 / 3).
AIRFRAME_CHANGE_CHI2_PER_DOF = 3.8
#: Prior probability that a diagnosed flight has a rotor that lost thrust, split evenly over its n
#: rotors. Even odds between the two answers a pilot asks for ("healthy" or "a rotor lost
#: thrust"): no measured base rate of damaged flights exists, and which flights get diagnosed
#: (routinely, or after a bad landing) is the user's choice. The damage half is not diluted by
#: the rotor count: the thresholds above are per-motor LLRs whatever n is, so the same LLRs must
#: read as equally sure on a quad and an octo (every motor at -1 nats: healthy 0.73 for any n).
#: Checked on the golden sets (sample_logs and ../shared, 247 healthy verdicts whose truth is
#: known, most of them mild cuts the decision missed; benchmarks/golden_verdicts.py): at 0.5 the 23
#: healthy verdicts below 0.5 were truly healthy in 4, so a low figure warns; a smaller prior
#: (0.2, 0.1) lifted the mean from 0.85 to 0.94 / 0.96 while 27 % of them were truly healthy.
PRIOR_DAMAGED = 0.5
#: Sources that read the airframe's trim (the command shares and the throttle against a profile
#: from another session): a moved load changes them the way a weak rotor does (on a quad the
#: shares have exactly the 3 degrees of freedom a roll, pitch and yaw re-trim fill;
#: benchmarks/cross_session_physics.py: a CoM shift of 6 % of the arm along a diagonal, a 0.1 deg
#: yaw re-trim and a 6 % heavier battery reproduce eta 0.8, m 0.5 exactly). Against a profile they
#: alone reach at most "uncertain".
TRIM_SOURCES = ("commands", "throttle")
#: ... unless a source that does not read the trim agrees (the model's windows, effectiveness,
#: ESC telemetry, vibration tied to a rotor) by more than it does on healthy flights of other
#: sessions: the largest such sum for the leading motor over the healthy one-flight pairs
#: (bench_cross_session.py, --no-adapt profiles, shipped model) is +2.7 on Erle board A, +2.4 on
#: px4_sih_dev, +2.2 on Erle board B, at most 0 on rrc_straight, CrazyPAD and the day-2014-09-07
#: pair: a third of a nat above the largest (e^3 ~ 20 to 1). The shipped model on rrc_straight
#: 25 mm cuts: +1.7..+3.7; an adapted model on its own airframe moves further
#: (model_votes.MODEL_DAMAGE_SHIFT's note: +4.4..+5.3).
TRIM_FREE_AGREE_LLR = 3.0
#: ... or unless the named motor's share rose beyond what a moved load makes: above the largest
#: healthy cross-session rise measured (+0.58: Erle board B, profile of 6-3-2014_6 on the 8 s
#: flight 22-12-2014_37) and a CoM shift of 30 % of the arm along a diagonal (+0.6, physics;
#: beyond it a quad is re-balanced before it flies), clear of both flights' pinning noise by PIN_Z.
BEYOND_DRIFT_SHARE_RISE = 0.65
PIN_Z = 3.0
#: Damage this mild (thrust efficiency at or above it) is often invisible to every source, so no
#: flight can rule it out: measured with one-flight profiles (bench_cross_session.py): px4_sih_dev
#: eta 0.9, 9 of 16 called healthy; CrazyPAD E9 0.5-3 mm cuts and tape, 117 of 117 healthy.
UNSEEN_ETA = 0.90
#: ... hence each motor's "lost thrust" LLR never falls below the prior share of that band (the
#: severity grid's uniform prior: 10 of its 60 points, log(1/6) = -1.8 nats), which caps the
#: stated probability of a healthy verdict at (1 - p) / (1 - p + p / 6) with p = PRIOR_DAMAGED
#: (0.86 at 0.5, for any rotor count).
MILD_DAMAGE_LLR_FLOOR = float(np.log(np.mean(ETA_GRID >= UNSEEN_ETA - 1e-9)))
#: A rotor that lost thrust makes the throttle rise with the same load (physics: +2.8 % at eta 0.9,
#: +6 % at 0.8, benchmarks/cross_session_physics.py). A throttle this many drift sigmas BELOW
#: calibration (THROTTLE_DRIFT_SIGMA 0.05: below 0.90) means the load or the set-up changed since
#: calibration, so the profile does not describe this session: no damaged verdict against it.
#: Measured: healthy re-flights 0.97-1.03 (rrc, SIH, CrazyPAD), damaged ones 1.00-1.18 (rrc cuts,
#: SIH); Erle board A across sessions 0.62-1.61.
THROTTLE_FELL_SIGMAS = 2.0
#: The most nats a source may give at each trust level of the reliability table
#: (:data:`~flightlog_fd.analyzers.reliability.RELIABILITY`, measured by
#: benchmarks/bench_reliability.py): "trusted" up to its own cap (at least SOURCE_LLR_CAP, 8), so
#: it may make a damaged verdict alone; "corroborating" one nat below DAMAGED_LLR, so another
#: source must add at least a nat; "discounted" one nat below UNCERTAIN_LLR, so alone it cannot even
#: make the flight uncertain.
TRUST_CAPS = {"trusted": SOURCE_LLR_CAP, "corroborating": DAMAGED_LLR - 1.0, "discounted": UNCERTAIN_LLR - 1.0}
#: A verdict over a timeline with at least this share of uncertain ('?') windows says what it rests
#: on instead (the model could not tell the propellers apart: the shipped octo model on its own
#: damaged sample, 92 %).
THIN_TIMELINE_SHARE = 0.5
#: When the trim sources are held, their joint part of a pair's total is at most this many nats
#: (:func:`_pairs`, :func:`_pair_posterior`): once a moved load explains the pattern as well as a
#: weak rotor does, the commands add little to the prior odds (e ~ 2.7 to 1). The single rotors'
#: stated probabilities no longer hold them: held, the 8 uncertain verdicts with a one-flight
#: profile on rrc_straight 10-25 mm cuts and px4_sih_dev weakened motors were stated at 0.09-0.56
#: and all 8 named the damaged rotor (benchmarks/bench_confidence.py).
TRIM_ONLY_LLR_CAP = 1.0
#: The one meaning of every stated confidence (the JSON reference, the guide and every report
#: print this sentence).
CONFIDENCE_MEANING = "the probability that this verdict is right, measured on real and simulated flights"
#: No verdict is stated with a lower confidence: a healthy verdict whose P(healthy) is below it
#: becomes uncertain naming the leading rotors, and an uncertain verdict names further rotors, by
#: weight, until the propellers it names reach it (:func:`_stated`). Main 25a3211 without a
#: profile stated 20 healthy verdicts below it on ../shared and sample_logs, 17 of them on damaged
#: flights (rrc_straight 10 and 20 mm cuts, CrazyPAD E9 cuts, px4_sih_dev sih_049, the octo
#: sample; the other 3: two real Erle flights and a moved load); the leading rotor was a damaged
#: one on every one whose rotor is known (12 of 12; bench_confidence.py).
STATED_MIN_CONFIDENCE = 0.5
#: An uncertain verdict ("too weak to call") is stated at most this sure: uncertain verdicts were
#: right 37 of 45 times (82 %) on the real sets and 16 of 16 on the simulated ones
#: (benchmarks/bench_confidence.py: without a profile and with one-flight profiles; the 8 wrong:
#: 5 real healthy Erle flights, 3 moved loads on px4_sih_dev_load), while their raw posterior
#: reached 0.96-1.00; capped, a stated 0.9 or more is a damaged (or stopped) verdict.
UNCERTAIN_CONFIDENCE_CAP = 0.8
#: A healthy verdict from this P(healthy) on "saw" the flight (``Verdict.seen``): the evidence moved
#: the even prior odds to at least 7 : 3 for healthy. Below it the log could not show damage: on
#: the real sets the healthy verdicts stated 0.5-0.7 were right 8 of 37 times (CrazyPAD E9 mild
#: cuts 0 of 25, the 8 right ones 7 moved loads and one Erle flight), those at 0.7 or more 46 of 97
#: (bench_confidence.py, main 25a3211, with and without one-flight profiles); the real healthy
#: flights without a profile: 15 of 18 at 0.7 or more, one at 0.53, two below 0.5.
SEEN_HEALTHY_P = 0.7
#: ... and from this much usable flight (seconds covered by the model's windows): the healthy
#: verdicts from less were right 4 of 32 times on the real sets without a profile (CrazyPAD E9,
#: 13.6 s each: its normal flights and its 0.5-3 mm cuts alike; an 8 s Erle flight), those from
#: more 22 of 29 (bench_confidence.py, main 25a3211).
SEEN_MIN_COVERED_S = 20.0
#: Two propellers: a pair of rotors is named only when its total beats the best single rotor's by
#: this much. Two weak rotors explain every pattern one does and more (a second free efficiency),
#: and two damaged propellers at once are rarer than one, so the pair must earn its extra
#: freedom: this is the prior log odds of one pair against one rotor, measured per kind of
#: baseline since the freedom is worth more where the healthy noise model is cruder. Without a
#: profile (the command shares against an even split, whose independent per-motor spread
#: NEIGHBOUR_SHARE_SIGMA does not describe a healthy airframe's structured trim): the best pair's
#: excess reaches 4.09 on 72 simulated one-propeller quads (99th percentile 1.7; eta 0.6-0.85,
#: random airframes and presets with realistic imbalance, three logging rates;
#: benchmarks/bench_two_props.py --measure, seed 21), 4.55 on 36 random quads with ESC telemetry
#: and one propeller (bench_two_props.py --esc --seeds 31 --per-set 12: the model, commands and
#: effectiveness gave it, not the ESC), 0.50 and -0.9 on the healthy twins of the two sets, 0.1 on
#: the 18 real healthy flights of ../shared, -0.2 on the rrc_straight cuts, -0.6 on px4_sih_dev's
#: (bench_two_props.py --real). Above the largest.
PAIR_EXCESS_LLR = 5.0
#: ... and against a profile: 2.7 on the real healthy cross-session pairs with one-flight
#: profiles (Erle board B), 2.6 on the rrc_straight cuts against them, 1.3 on CrazyPAD's, 1.0 on
#: px4_sih_dev's; 0.67 and -0.76 on the simulated one-propeller and healthy flights above. Above
#: the largest by 0.8. Two-propeller flights of the simulated set reach a median 8.4 (2.3 without
#: a profile).
PAIR_EXCESS_PROFILE_LLR = 3.5
#: A load toward a direction (:class:`~flightlog_fd.analyzers.command_shares.LoadFit`) explains the
#: leading motor's command pattern when "rotor k lost thrust" (with the drag-torque exponents of
#: measured damage, ``command_shares.DAMAGE_MIN_M``) beats it by less than this on the shares
#: (``CommandSharesResult.rotor_vs_load``), against a profile. Measured (results/load_vs_damage.md,
#: benchmarks/bench_loads.py): px4_sih_dev_load's moved centres of mass reach -0.3 at most against
#: sih_004's --no-adapt profile; px4_sih_dev's weak motors give their rotor +4.6..+7.9 against it,
#: the real rrc_straight 20 and 25 mm cuts +2.6..+6.1 against each good flight's profile.
#: SEPARATION_LLR's e^2 (7 to 1), below the nearest cut.
LOAD_SEPARATION_LLR = 2.0
#: ... and from this much (but under LOAD_SEPARATION_LLR) the rotor fits better than the load, so a
#: flight the sources would call damaged without the load is "uncertain" naming both; below it the
#: two fit within e to 1 and the load, the likelier cause of a steady pattern, is named. No measured
#: flight falls between against a profile (loads at most -0.3, cuts from +2.6).
LOAD_EITHER_LLR = 1.0
#: Without a profile (the shares against an even split, four times the noise) real cuts come as
#: close as +2.0 (rrc_straight 25 mm, +2.0..+2.2; the SIH weak motors +2.3..+4.7), so a load
#: stands for the pattern only where it fits within e to 1 of the rotor: px4_sih_dev_load's
#: loads toward one motor (+1.3..+1.5) stay as they were (uncertain, never damaged: their
#: evidence is below the damaged bar), the load between two motors (forward, -2.9) is named.
LOAD_SEPARATION_NO_PROFILE_LLR = 1.0
#: The sources that read the motor commands' pattern, which a load moves as a weak rotor does: the
#: command shares, the throttle and the model's windows (its features carry each motor's command;
#: against px4_sih_dev_load's moved centres of mass it gives +7.1..+8.0 to the motor toward the load).
PATTERN_SOURCES = ("commands", "throttle", "model")
#: The load is weighed only when the shares' pattern needs explaining: the load's or the leading
#: rotor's evidence against an even split or the calibration reaches this (nats). A healthy
#: verdict names the load (``cause`` = ``load``) when the load's own evidence reaches it: the load
#: is seen, not only as likely as a rotor (rrc_straight's 5 mm cuts against a good flight's
#: profile: load -1.2..+0.6, not named; px4_sih_dev_load against sih_004: +2.7..+7.4, named).
LOAD_NAMED_LLR = 1.0


@dataclass
class Verdict:
    """What the flight's report states; ``position`` in the frame's words, ``first_seen`` seconds
    on the log's clock (damaged: the onset's first window, or the first window; stopped: the stop)."""

    status: str  # "healthy" | "damaged" | "uncertain" | "stopped" | "not_diagnosable"
    #: The damaged (stopped) motor (the first of two), or the one propeller an uncertain verdict
    #: asks to inspect first (:func:`named_motor`); None when it names none, or two (an uncertain
    #: pair, or two it cannot tell apart).
    motor: Optional[int] = None
    position: Optional[str] = None
    confidence: float = 0.0  # the probability of the verdict as stated (module docstring)
    first_seen: Optional[float] = None
    reason: str = ""
    #: The propellers the verdict sends the pilot to first (() = all of them, or nothing to inspect).
    inspect: tuple = ()
    #: What would resolve it (:class:`flightlog_fd.advice.Advice`), set by the diagnose pipeline.
    advice: list = field(default_factory=list)
    #: The propellers the verdict names: those that lost thrust or stopped (``motor`` is the first),
    #: an uncertain pair's two, or the one an uncertain verdict asks to inspect first; [] otherwise
    #: (two an uncertain verdict cannot tell apart are in ``inspect``).
    motors: list[int] = field(default_factory=list)
    #: True when the verdict is that two propellers lost thrust together (damaged or uncertain).
    pair: bool = False
    #: The frame's words for each of ``motors`` (None where unknown).
    positions: list = field(default_factory=list)

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
    #: The named rotor's likely cause: "propeller" | "motor_or_esc" | None (unknown, or no rotor named)
    cause: Optional[str] = None
    #: What the cause rests on (:meth:`flightlog_fd.cause.Cause.evidence`), None when no rotor is named
    cause_evidence: Optional[dict] = None
    #: A healthy verdict: True when the evidence saw the flight (P(healthy) at least
    #: ``SEEN_HEALTHY_P`` over at least ``SEEN_MIN_COVERED_S`` of usable flight), False when this log
    #: could not show damage (not a clearance); None for other verdicts.
    seen: Optional[bool] = None
    #: With ``cause`` = ``load``: where the load sits and its size (:meth:`LoadFit.as_dict` plus the
    #: nearest motor's position and direction words), else None
    load: Optional[dict] = None

    def as_dict(self) -> dict:
        """The verdict fields of the JSON report."""
        return {
            "status": self.status,
            "motor": self.motor,
            "motors": [int(k) for k in self.motors],
            "positions": list(self.positions),
            "pair": bool(self.pair),
            "position": self.position,
            "confidence": round(float(self.confidence), 4),
            "first_seen": None if self.first_seen is None else round(float(self.first_seen), 3),
            "reason": self.reason,
            "advice": [a.as_dict() for a in self.advice],
            "cause": self.cause,
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
    return Verdict(status="not_diagnosable", reason=reason)


@dataclass
class MotorDecision:
    """One motor's part in the decision (the report's per-motor severity and weight)."""

    motor: int
    llr: float  # total, nats
    llr_by_source: dict  # analyzer id -> nats
    eta_hat: Optional[float]  # thrust efficiency (1 = healthy), None when the shares are not weighed
    eta_ci: Optional[tuple[float, float]]
    weight: float  # P(this rotor lost thrust) under PRIOR_DAMAGED (:func:`posterior`)

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {"motor": self.motor, "llr": r(self.llr),
                "llr_by_source": {k: r(v) for k, v in self.llr_by_source.items()},
                "eta_hat": r(self.eta_hat),
                "eta_ci": None if self.eta_ci is None else [r(self.eta_ci[0]), r(self.eta_ci[1])],
                "weight": r(self.weight)}


@dataclass
class PairDecision:
    """One pair of motors in the decision: "rotors a and b both lost thrust" (:func:`_pair_step`)."""

    motors: tuple[int, int]
    llr: float  # what the decision counts, nats: the sources' sum, the trim part bounded (:func:`_pairs`)
    llr_by_source: dict  # analyzer id -> nats (each source clipped to its cap)
    eta_hat: Optional[tuple[float, float]]  # the two-rotor command fit's, None when the shares are not weighed
    excess: float  # llr minus the best single rotor's, as the pair step compares them (:func:`_pairs`)
    #: why the trim sources' part was bounded (no profile, no source that does not read the trim agreeing), or None
    trim_bounded: Optional[str] = None
    #: llr without the sources discounted on this kind of log (what ``damaged`` needs)
    decisive: Optional[float] = None

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {"motors": [int(k) for k in self.motors], "llr": r(self.llr),
                "llr_by_source": {k: r(v) for k, v in self.llr_by_source.items()},
                "eta_hat": None if self.eta_hat is None else [r(x) for x in self.eta_hat],
                "excess": r(self.excess)}


@dataclass
class Decision:
    """Why the evidence gave its verdict: per-motor details and the analyzers' results."""

    motors: list[MotorDecision] = field(default_factory=list)
    #: The pair hypotheses, most likely first (:func:`_pair_step`); [] when not weighed
    pairs: list[PairDecision] = field(default_factory=list)
    airframe_changed: Optional[str] = None  # why, when the shares moved in no one-rotor pattern
    healthy_chi2: Optional[float] = None
    share_sigma: Optional[float] = None
    sources: list[str] = field(default_factory=list)  # the analyzers that weighed in
    results: list[AnalyzerResult] = field(default_factory=list)
    weights: dict = field(default_factory=dict)  # analyzer id -> SourceWeight (how much it could give)
    #: The motor (1-based) the sources would call damaged but only the command-pattern sources point
    #: at (:func:`_pattern_held`: it or a load at its corner; the verdict is uncertain), else None
    pattern_held: Optional[int] = None


@dataclass(frozen=True)
class SourceWeight:
    """How much one source could give on this log: its reliability-table cell, the trust level
    measured there (None: no cell, the analyzer's own cap) and the cap in nats."""

    cell: str
    trust: Optional[str]
    cap: float

    def as_dict(self) -> dict:
        return {"cell": self.cell, "trust": self.trust, "cap": round(float(self.cap), 3)}


def posterior(total_llr: np.ndarray) -> np.ndarray:
    """(n + 1,) [P(healthy), P(motor 1), ..., P(motor n)] from the per-motor total LLRs under
    ``PRIOR_DAMAGED`` split evenly over the n motors."""
    llr = np.asarray(total_llr, float)
    n = len(llr)
    logits = np.concatenate([[np.log1p(-PRIOR_DAMAGED)], np.log(PRIOR_DAMAGED / max(n, 1)) + llr])
    w = np.exp(logits - logits.max())
    return w / w.sum()


def _words(frame: Optional[Frame], motor: int) -> str:
    pos = frame.position(motor) if frame is not None else None
    return f"motor {motor} ({pos})" if pos else f"motor {motor}"


def _airframe_changed(cmd: Optional[CommandSharesResult], thr: Optional[ThrottleResult], n: int,
                      best: int) -> Optional[str]:
    """Words for "the shares moved beyond the drift and no single rotor explains it", else None."""
    if cmd is None or cmd.abstained or cmd.baseline != "profile":
        return None
    # the shares alone: a throttle change with the shares in place is a heavier or lighter load,
    # not a change that makes the profile wrong
    dof = max(n - 1, 1)
    healthy_chi2 = cmd.healthy_chi2 if cmd.healthy_chi2_shares is None else cmd.healthy_chi2_shares
    fit_chi2 = cmd.fit_chi2_shares or cmd.fit_chi2
    if healthy_chi2 / dof <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    if fit_chi2[best] / max(dof - 1, 1) <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    shares = [cmd.finding("share", k + 1) for k in range(n)]
    text = "the command shares moved in a pattern no single rotor explains: " + ", ".join(
        f"motor {k + 1} {100 * (f.value - f.baseline):+.0f} %" for k, f in enumerate(shares) if f is not None)
    if thr is not None and thr.ratio is not None:
        text += f"; throttle {100 * (thr.ratio - 1):+.0f} % against calibration"
    return text


def _share_rise(cmd: CommandSharesResult, best: int, n: int) -> tuple[float, bool]:
    """Motor ``best``'s (0-based) share rise over its baseline, and whether it is beyond what a load
    makes (``BEYOND_DRIFT_SHARE_RISE``, clear of the flights' pinning noise by ``PIN_Z``)."""
    share = cmd.finding("share", best + 1)
    pin = cmd.pin
    noise = float(pin[best]) if pin and len(pin) == n else 0.0
    rise = share.value - share.baseline if share is not None and share.baseline is not None else 0.0
    return rise, rise - PIN_Z * noise > BEYOND_DRIFT_SHARE_RISE


def _support_outside(sources: dict, best: int, readers: Sequence[str]) -> float:
    """The evidence (nats) for motor ``best`` (0-based) from the sources that are not ``readers``
    (``TRIM_SOURCES`` or ``PATTERN_SOURCES``): what agrees without reading the trim or the pattern."""
    return float(sum(v[best] for s, v in sources.items() if s not in readers))


def _trim_held(cmd: Optional[CommandSharesResult], sources: dict, best: int, n: int) -> Optional[str]:
    """Why the trim sources alone may not call motor ``best`` (0-based) damaged, or None when
    they may: no profile baseline, a source that does not read the trim agrees, or the share rose
    beyond what a moved load makes."""
    if cmd is None or cmd.abstained or cmd.baseline != "profile":
        return None
    free = _support_outside(sources, best, TRIM_SOURCES)
    rise, beyond = _share_rise(cmd, best, n)
    if free >= TRIM_FREE_AGREE_LLR or beyond:
        return None
    return (f"the sources that do not read the trim give {free:+.1f} nats, agreement needs "
            f"{TRIM_FREE_AGREE_LLR:.0f}; a rise of {rise:+.2f} share is within what a moved load makes")


def _pattern_held(cmd: Optional[CommandSharesResult], sources: dict, best: int, n: int) -> Optional[str]:
    """Why the sources that read the command pattern (``PATTERN_SOURCES``) may not call motor
    ``best`` (0-based) damaged alone, with or without a profile, or None when they may: no command
    shares, a source that does not read the commands agrees (``TRIM_FREE_AGREE_LLR``), or the share
    rose beyond what a load makes (``BEYOND_DRIFT_SHARE_RISE``). A load at a rotor's corner (a weight
    in its wash, a payload under it) takes thrust from that rotor for its command as a damaged
    propeller does: the commands, the throttle and the model (whose windows read the same
    commands) cannot tell the two (results/decisive.md: crazypad_e9_load W3)."""
    if cmd is None or cmd.abstained or cmd.analyzer not in sources:
        return None
    free = _support_outside(sources, best, PATTERN_SOURCES)
    rise, beyond = _share_rise(cmd, best, n)
    if free >= TRIM_FREE_AGREE_LLR or beyond:
        return None
    others = [s for s in sources if s not in PATTERN_SOURCES]
    said = (f"the sources that do not read the commands ({', '.join(others)}) give {free:+.1f} nats, agreement "
            f"needs {TRIM_FREE_AGREE_LLR:.0f}" if others else "the log has no source that does not read the commands "
            "(no ESC telemetry, no vibration tied to a rotor, no effectiveness fit)")
    return f"{said}; a rise of {rise:+.2f} share is within what a load makes"


# ----------------------------------------------------------------------------- a load, not a rotor

def _load_explains(cmd: Optional[CommandSharesResult], sources: dict, n: int,
                   results: Sequence[AnalyzerResult] = (), weights: Optional[dict] = None) -> Optional[LoadFit]:
    """The command shares' :class:`LoadFit` when a load toward some direction explains the leading
    motor's pattern as well as its rotor's loss does (:func:`load_separation`), the load is seen
    (``LOAD_NAMED_LLR``) and the sources that do not read the pattern agree neither on that rotor
    nor on any pair of rotors (``TRIM_FREE_AGREE_LLR``); else None."""
    if cmd is None or cmd.abstained or cmd.load is None or len(cmd.rotor_vs_load) != n or not sources:
        return None
    best = int(np.argmax(np.sum(list(sources.values()), axis=0)))
    rotor = cmd.rotor_vs_load[best] + cmd.load.llr  # the leading rotor's own evidence on the shares
    separation = load_separation(cmd)
    if max(cmd.load.llr, rotor) < LOAD_NAMED_LLR or cmd.rotor_vs_load[best] >= separation:
        return None
    free = _support_outside(sources, best, PATTERN_SOURCES)
    if free >= TRIM_FREE_AGREE_LLR:
        return None
    if any(v >= TRIM_FREE_AGREE_LLR for v in _pair_agreement(cmd, results, sources, weights, n).values()):
        return None
    # two rotors must beat the load by the single rotor's margin and the pair's own prior odds
    if any(v - cmd.load.llr >= separation + pair_excess_bar(cmd) for v in cmd.pair_llrs.values()):
        return None
    return cmd.load


def _rotor_or_load(cmd: CommandSharesResult, sources: dict, weights: dict) -> Optional[int]:
    """The leading motor (1-based) when the sources, not held, would call it damaged (its total
    without the discounted ones reaches ``DAMAGED_LLR``) and its rotor fits the shares better than
    the load (``rotor_vs_load`` from ``LOAD_EITHER_LLR``) though by less than
    :func:`load_separation`: the flight is then uncertain between the two; else None."""
    decisive = np.sum([v for s_, v in sources.items() if weights[s_].trust != "discounted"], axis=0)
    best = int(np.argmax(decisive))
    if decisive[best] < DAMAGED_LLR or not LOAD_EITHER_LLR <= cmd.rotor_vs_load[best] < load_separation(cmd):
        return None
    return best + 1


def _pair_agreement(cmd: CommandSharesResult, results: Sequence[AnalyzerResult], sources: dict,
                    weights: Optional[dict], n: int) -> dict:
    """{pair: nats} the sources that do not read the command pattern give each pair of rotors,
    where they can tell two weak rotors from a load: a moved centre of mass shortens the lever
    arms on its side, so the effectiveness fit reads the two rotors there as weaker too
    (px4_sih_dev_load 5 cm forward: +8.0 for rotors 1 and 3, as for the simulated x500 with
    rotors 1 and 4 weak) while the throttle stays (-3.6 for that pair; the x500's +2.1). So the
    effectiveness counts for a pair only when the profile's throttle does not speak against
    lost thrust for it; without a profile, only ESC telemetry and vibration count."""
    thr = next((r for r in results if isinstance(r, ThrottleResult) and r.analyzer in sources), None)
    thr_pairs = (thr.pair_llr(n, weights[thr.analyzer].cap if weights and thr.analyzer in weights else None)
                 if thr is not None else None) or {}
    out: dict = {}
    for r in results:
        if r.analyzer in PATTERN_SOURCES or r.analyzer not in sources:
            continue
        cap = weights[r.analyzer].cap if weights and r.analyzer in weights else None
        for pair, v in (r.pair_llr(n, cap) or {}).items():
            if r.analyzer == "effectiveness" and (cmd.baseline != "profile" or thr_pairs.get(pair, -1.0) < 0.0):
                continue
            out[pair] = out.get(pair, 0.0) + v
    return out


def load_separation(cmd: CommandSharesResult) -> float:
    """How much better the rotor must fit the shares than a load to be weighed as a rotor:
    ``LOAD_SEPARATION_LLR`` against a profile, ``LOAD_SEPARATION_NO_PROFILE_LLR`` without one."""
    return LOAD_SEPARATION_LLR if cmd.baseline == "profile" else LOAD_SEPARATION_NO_PROFILE_LLR


def _held_for_load(sources: dict) -> dict:
    """The sources with the pattern sources' evidence for any rotor held to ``TRIM_ONLY_LLR_CAP``
    together (shared evenly), as for the trim sources against a profile; the pair step is not
    taken then (two rotors did not beat the load either)."""
    held = [s_ for s_ in sources if s_ in PATTERN_SOURCES]
    cap = TRIM_ONLY_LLR_CAP / max(len(held), 1)
    return {s_: (np.minimum(v, cap) if s_ in held else v) for s_, v in sources.items()}


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


# ----------------------------------------------------------------------------- the pair-hypothesis step

def _pairs(results: Sequence[AnalyzerResult], sources: dict, weights: dict, cmd: Optional[CommandSharesResult],
           n: int) -> tuple[list[PairDecision], dict]:
    """Every pair of motors as a hypothesis, most likely first, and each single rotor as the pair
    step compares it ({analyzer: (n,) nats}). Per source its clipped pair LLR
    (:meth:`AnalyzerResult.pair_llr`; only the sources that weighed the single rotors), summed;
    each pair's excess over the best single rotor, a source whose cap keeps its order (the
    command shares) lowering every rotor and pair together so the cap keeps what it says between
    one rotor and two. Without a profile the trim sources' part of a pair counts at most
    ``TRIM_ONLY_LLR_CAP`` unless the sources that do not read the trim agree
    (``TRIM_FREE_AGREE_LLR``): against an even split a pair's command pattern is also a healthy
    airframe's own trim (real healthy Erle 6-3-2014_6, shares 1.04 / 0.67 / 0.86 / 1.43: commands
    +7.9 nats for propellers 1 and 4, the centre of mass off to their side; the model -0.6); a
    single rotor's pattern is narrower and keeps its own bars. Each source is capped as for the
    single rotors (``weights``: its measured reliability on this kind of log), and a discounted
    source's part is left out of the pair's ``decisive`` total."""
    if n not in PAIR_ROTOR_COUNTS:
        return [], {}
    by_source, singles_by_source = {}, {}
    for r in results:
        if r.analyzer in sources:
            cap = weights[r.analyzer].cap
            v = r.pair_llr(n, cap)
            if v is not None:
                by_source[r.analyzer] = v
            keeps = r.cap_keeps_order or r.pair_keeps_order
            singles_by_source[r.analyzer] = r.llr(n, cap, with_pairs=True) if keeps else sources[r.analyzer]
    if not by_source:
        return [], {}
    fits = {pf.motors: pf for pf in (cmd.pairs if cmd is not None and not cmd.abstained else [])}
    against_profile = cmd is not None and not cmd.abstained and cmd.baseline == "profile"
    best_single = float(np.max(np.sum(list(singles_by_source.values()), axis=0)))
    out = []
    for a in range(1, n + 1):
        for b in range(a + 1, n + 1):
            parts = {src: float(v[(a, b)]) for src, v in by_source.items() if (a, b) in v}
            trim = sum(v for src, v in parts.items() if src in TRIM_SOURCES)
            free = sum(v for src, v in parts.items() if src not in TRIM_SOURCES)
            bounded = None
            if not against_profile and free < TRIM_FREE_AGREE_LLR and trim > TRIM_ONLY_LLR_CAP:
                bounded = (f"without a profile a pair's command pattern is also the airframe's own trim (a centre of "
                           f"mass off the middle, a yaw trim), and the sources that do not read the trim give "
                           f"{free:+.1f} nats (agreement needs {TRIM_FREE_AGREE_LLR:.0f}), so the commands' "
                           f"{trim:+.1f} count {TRIM_ONLY_LLR_CAP:.0f}")
                trim = TRIM_ONLY_LLR_CAP
            llr = float(free + trim)
            discounted = sum(v for src, v in parts.items() if weights[src].trust == "discounted")
            fit = fits.get((a, b))
            out.append(PairDecision(motors=(a, b), llr=llr, llr_by_source=parts,
                                    eta_hat=None if fit is None else tuple(fit.eta_hat), excess=llr - best_single,
                                    trim_bounded=bounded, decisive=llr - float(discounted)))
    out.sort(key=lambda pd: -pd.llr)
    return out, singles_by_source


def pair_excess_bar(cmd: Optional[CommandSharesResult]) -> float:
    """The pair's prior log odds against one rotor for this flight's baseline:
    ``PAIR_EXCESS_PROFILE_LLR`` against a profile, else ``PAIR_EXCESS_LLR``."""
    profile = cmd is not None and not cmd.abstained and cmd.baseline == "profile"
    return PAIR_EXCESS_PROFILE_LLR if profile else PAIR_EXCESS_LLR


def _pair_posterior(pairs: list[PairDecision], singles_by_source: dict, held: bool,
                    bar: float = PAIR_EXCESS_LLR) -> tuple[float, np.ndarray]:
    """(P(the top pair lost thrust), (n,) P(rotor k lost thrust, alone or in a pair)) among
    healthy, each single rotor and each pair, on the footing of the pair step's comparison
    (:func:`_pairs`): the single rotors as in :func:`posterior` (their LLRs floored), each pair
    with the prior of one rotor times exp(-``bar``) (:func:`pair_excess_bar`); with the trim
    sources held their part of every hypothesis is at most TRIM_ONLY_LLR_CAP, as for one rotor."""
    trim_single = sum((v for src, v in singles_by_source.items() if src in TRIM_SOURCES), np.zeros(1))
    singles = np.sum(list(singles_by_source.values()), axis=0)
    if held:
        singles = singles - trim_single + np.minimum(trim_single, TRIM_ONLY_LLR_CAP)
    n = len(singles)
    prior_one = np.log(PRIOR_DAMAGED / max(n, 1))

    def stated(pd: PairDecision) -> float:
        if not held:
            return pd.llr
        trim = sum(v for src, v in pd.llr_by_source.items() if src in TRIM_SOURCES)
        return pd.llr - trim + min(trim, TRIM_ONLY_LLR_CAP)

    logits = np.concatenate([[np.log1p(-PRIOR_DAMAGED)], prior_one + np.maximum(singles, MILD_DAMAGE_LLR_FLOOR),
                             [prior_one - bar + stated(pd) for pd in pairs]])
    w = np.exp(logits - logits.max())
    w = w / w.sum()
    marginal = w[1:n + 1].copy()
    for pd, wp in zip(pairs, w[n + 1:]):
        for k in pd.motors:
            marginal[k - 1] += wp
    return float(w[n + 1]), marginal


def _pair_step(pairs: list[PairDecision], singles_by_source: dict, motors: list[MotorDecision],
               cmd: Optional[CommandSharesResult], thr: Optional[ThrottleResult], n: int, frame: Optional[Frame],
               onset) -> Optional[tuple]:
    """The verdict's arguments (status, motor, confidence, reason, inspect, motors, pair) when two rotors
    explain the evidence and no single one does, else None (the single-rotor verdict follows).

    The top pair is named when its total reaches ``UNCERTAIN_LLR`` and beats the best single rotor
    by :func:`pair_excess_bar` (``PAIR_EXCESS_LLR``, against a profile ``PAIR_EXCESS_PROFILE_LLR``).
    ``damaged`` needs the single-rotor bars as well (``DAMAGED_LLR``; the
    next pair ``SEPARATION_LLR`` behind; their summed command share risen; against a profile a source
    that does not read the trim agreeing, ``TRIM_FREE_AGREE_LLR``, and the throttle not well
    below calibration); otherwise ``uncertain`` naming both, saying which bar it missed. The
    motors' weights then become P(rotor k lost thrust, alone or in a pair) (:func:`_pair_posterior`)."""
    if not pairs:
        return None
    top = pairs[0]
    bar = pair_excess_bar(cmd)
    if top.llr < UNCERTAIN_LLR or top.excess < bar:
        return None
    a, b = top.motors
    names = f"propellers {a} and {b}"
    where = (f" ({frame.position(a)} and {frame.position(b)})" if frame is not None and frame.position(a)
             and frame.position(b) else "")
    parts = ", ".join(f"{src} {v:+.1f}" for src, v in top.llr_by_source.items())
    evidence = (f"together {top.llr:+.1f} nats, {top.excess:+.1f} above the best single rotor "
                f"(log-likelihood ratio by source: {parts})")

    sev = ""
    if top.eta_hat is not None and all(x < 1.0 for x in top.eta_hat):
        sev = (f": they give about {100 * top.eta_hat[0]:.0f} % and {100 * top.eta_hat[1]:.0f} % of their normal "
               f"thrust")
    why_not = [top.trim_bounded] if top.trim_bounded else []
    decisive = top.llr if top.decisive is None else top.decisive
    if decisive < DAMAGED_LLR:
        low = "" if decisive == top.llr else f", {top.llr - decisive:+.1f} of them from sources discounted on this kind of log"
        why_not.append(f"the evidence is too weak to call ({top.llr:+.1f} nats{low}; damage needs {DAMAGED_LLR:.0f})")
    if len(pairs) > 1 and top.llr - pairs[1].llr < SEPARATION_LLR:
        c, d = pairs[1].motors
        why_not.append(f"propellers {c} and {d} fit almost as well ({pairs[1].llr:+.1f})")
    if cmd is not None and not cmd.abstained:
        # two weak rotors must need more command together, not each: the mixer moves the yaw and
        # attitude load between them (the two-rotor fit's own physics, both efficiencies below 0.9,
        # every drag exponent of M_GRID, quad X and +: a member's share falls to 0.68 of its
        # baseline, the two together never below 2.03 of 2)
        got = [cmd.finding("share", k) for k in (a, b)]
        if all(f is not None and f.baseline is not None for f in got) and sum(f.value for f in got) <= sum(
                f.baseline for f in got):
            why_not.append(f"the command shares of propellers {a} and {b} together did not rise as two rotors that "
                           f"lost thrust must")
    pair_held = False
    if cmd is not None and not cmd.abstained and cmd.baseline == "profile":
        free = sum(v for src, v in top.llr_by_source.items() if src not in TRIM_SOURCES)
        if free < TRIM_FREE_AGREE_LLR:
            pair_held = True
            why_not.append(f"only the commands point at them (the sources that do not read the trim give {free:+.1f} "
                           f"nats, agreement needs {TRIM_FREE_AGREE_LLR:.0f}), and a moved load or re-trim makes the "
                           f"same pattern: if both are sound, re-calibrate")
        thr_sigma = cmd.throttle_sigma or THROTTLE_DRIFT_SIGMA
        if thr is not None and thr.ratio is not None and thr.ratio < 1.0 - THROTTLE_FELL_SIGMAS * thr_sigma:
            why_not.append(f"the throttle is {100 * (1 - thr.ratio):.0f} % lower than at calibration, which rotors that "
                           f"lost thrust cannot do with the same load: re-calibrate after the inspection")
    confidence, marginal = _pair_posterior(pairs, singles_by_source, pair_held, bar)
    for m in motors:  # each rotor's weight: alone or in a pair
        m.weight = float(marginal[m.motor - 1])
    if not why_not:
        since = f" from t={onset.first_seen:.1f} s" if onset is not None else ""
        return ("damaged", a, confidence, f"{names}{where} lost thrust{since}{sev}; one rotor alone does not explain "
                                          f"the evidence, two do: {evidence}; inspect both", (a, b), [a, b], True)
    return ("uncertain", None, confidence, f"{names}{where} may both have lost thrust{sev}; one rotor alone does not "
                                           f"explain the evidence: {evidence}; but " + "; ".join(why_not)
            + "; inspect both", (a, b), [a, b], True)


def _one_flight_note(cmd: Optional[CommandSharesResult]) -> Optional[str]:
    """The note that a one-session profile cannot show the trim's session-to-session move, or None."""
    if cmd is None or cmd.abstained or cmd.baseline != "profile":
        return None
    sessions = cmd.n_sessions or 0  # 0: a profile older than schema 6, its flights pooled
    if sessions >= 2 or (sessions == 0 and (cmd.n_flights or 1) > 1):
        return None
    return ("the profile holds one calibration session, which cannot show how this airframe's trim moves "
            "between sessions: adding healthy flights of other days or batteries as sessions "
            "(fdlog calibrate --add PROFILE LOG) makes it stronger")


def _stopped(stops: Sequence, frame: Optional[Frame], underneath: Optional[Verdict]) -> Verdict:
    """The "stopped" verdict for the earliest stopped motor (a motor or ESC failure, not a damaged
    propeller); the propeller verdict it replaces, if windows were judged, is kept in the reason."""
    from .stopped import describe

    first = stops[0]
    others = "".join(f"; also {describe(s)}" for s in stops[1:])
    was = (f"; the propeller diagnosis alone said {underneath.status}"
           + (f" (motor {underneath.motor})" if underneath.motor else "") if underneath is not None else "")
    stopped_motors = list(dict.fromkeys(s.motor for s in stops))
    return Verdict(status="stopped", motor=first.motor, motors=stopped_motors,
                   positions=[frame.position(k) if frame is not None else None for k in stopped_motors],
                   position=frame.position(first.motor) if frame is not None else None, confidence=1.0,
                   first_seen=first.t_start,
                   reason=f"{describe(first)}{others}: check motor {first.motor}, its ESC, wiring and output "
                          f"assignment before the next flight{was}")


def decide(n_motors: int, frame: Optional[Frame] = None, *, timeline: Optional[Timeline] = None,
           results: Sequence[AnalyzerResult] = (), stopped: Sequence = (),
           not_diagnosable_reason: Optional[str] = None, kind: Optional[LogKind] = None
           ) -> tuple[Verdict, Optional[Decision]]:
    """The flight's verdict and, when the evidence was weighed, its :class:`Decision` (module
    docstring). ``timeline``: the model's windows (None when none were judged); ``results``: the
    analyzers'; ``stopped``: :class:`~flightlog_fd.stopped.StoppedMotor` s, earliest first;
    ``not_diagnosable_reason``: why the pipeline could not judge the flight."""
    reason = not_diagnosable_reason or (timeline.shortfall if timeline is not None else None)
    if reason is None and timeline is None:
        reason = "no window of airborne data was judged"
    vib = _vibration(results)
    if reason is not None and vib is not None:  # the log lacks what the rest needs; vibration does not
        verdict, decision = _vibration_only(vib, n_motors, frame, reason)
    elif reason is not None:
        verdict, decision = not_diagnosable(reason), None
    else:
        verdict, decision = _weigh(results, n_motors, frame, timeline, kind)
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
    verdict is never worse than (:func:`capped_by_log`)."""

    n_motors: int
    frame: Optional[Frame] = None
    timeline: Optional[Timeline] = None
    results: Sequence[AnalyzerResult] = ()
    stopped: Sequence = ()
    not_diagnosable_reason: Optional[str] = None
    kind: Optional[LogKind] = None
    configuration_words: Optional[str] = None
    log: Optional[tuple[Verdict, Optional[Decision]]] = None


def decide_flight(inputs: DecisionInputs) -> tuple[Verdict, Optional[Decision]]:
    """The one entry point of the diagnose pipeline for a flight's verdict: :func:`decide`, the
    profile's load configuration named in the reason, and for one flight of several the cap by its
    whole log (:func:`capped_by_log`). Returns the verdict and, when the evidence was weighed, its
    :class:`Decision`."""
    verdict, decision = decide(inputs.n_motors, inputs.frame, timeline=inputs.timeline, results=inputs.results,
                               stopped=inputs.stopped, not_diagnosable_reason=inputs.not_diagnosable_reason,
                               kind=inputs.kind)
    if inputs.configuration_words and verdict.reason:
        verdict.reason = f"{verdict.reason} ({inputs.configuration_words})"
    if inputs.log is not None:
        verdict = capped_by_log(verdict, *inputs.log)
    return verdict, decision


def capped_by_log(own: Verdict, log: Verdict, decision: Optional[Decision]) -> Verdict:
    """A flight's own verdict, no worse than its whole log's: the decision's thresholds were set on
    whole logs, and a log of n flights gives n tries at a false alarm. A flight worse than the log
    takes the log's status (a damaged flight naming another motor than the log's damaged one is
    uncertain); its reason keeps what it said alone and the log's figure for that motor."""
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
    return Verdict(status=status, motor=motor, position=own.position if motor is not None and motor == own.motor
                   else None, confidence=log.confidence if status == log.status
                   else min(own.confidence, UNCERTAIN_CONFIDENCE_CAP), first_seen=None, inspect=inspect,
                   seen=log.seen if status == log.status else None,
                   reason=f"judged alone this flight would be {said}: {own.reason}; the whole log does not "
                          f"confirm it ({log.status}{whole}), so this flight is {status}")



def uncertain_bar(kind: Optional[LogKind]) -> float:
    """The total LLR from which a flight of this kind is "uncertain": ``FULL_RATE_UNCERTAIN_LLR``
    for a quad at full rate without a profile, else ``UNCERTAIN_LLR`` (also when the kind of log
    is not known)."""
    if (kind is not None and kind.profile == "none" and kind.n_motors == 4
            and rate_class(kind.stream_hz) == "full rate"):
        return FULL_RATE_UNCERTAIN_LLR
    return UNCERTAIN_LLR


def source_weight(r: AnalyzerResult, kind: Optional[LogKind]) -> SourceWeight:
    """How much source ``r`` may give on this kind of log: the trust level of its cell in the
    measured reliability table (:func:`~flightlog_fd.analyzers.reliability.trust_of`) and the cap
    that level sets (``TRUST_CAPS``); the analyzer's own ``llr_cap`` where the table has no cell
    for it (or the kind of log is not known)."""
    if kind is None or not r.reliability_keys:
        return SourceWeight("", None, r.llr_cap)
    cell = cell_of(r.reliability_keys, kind)
    trust = trust_of(r.analyzer, cell)
    if trust is None:
        return SourceWeight(cell, None, r.llr_cap)
    cap = TRUST_CAPS[trust]
    return SourceWeight(cell, trust, max(cap, r.llr_cap) if trust == "trusted" else min(cap, r.llr_cap))


@dataclass
class Statement:
    """What a rule of :data:`RULES` states, before :func:`_done` states it (vibration's raise,
    ``STATED_MIN_CONFIDENCE``, notes, the load's words): status, motor, confidence, reason, the
    propellers to inspect, the cause named, the motors of a pair and whether it is one."""

    status: str
    motor: Optional[int]
    confidence: float
    reason: str
    inspect: Sequence[int] = ()
    named: Optional[Cause] = None
    motors: Optional[list[int]] = None
    pair: bool = False


@dataclass
class Evidence:
    """The hypotheses of one flight and what each source says of them (:func:`_evidence`): healthy,
    rotor k lost thrust (``total``, ``decisive``, ``w``, ``motors``), rotors j and k both
    (``decision.pairs``, ``singles_for_pairs``), a load toward a direction (``load``, ``either``);
    and the facts the rules test (the leading rotor ``kb``, its ``lead``, the holds ``trim_held``
    and ``pattern_held``, ``unsupported``, ``throttle_fell``). Built once; :data:`RULES` read it."""

    n: int
    frame: Optional[Frame]
    timeline: Timeline
    kind: Optional[LogKind]
    results: Sequence[AnalyzerResult]
    sources: dict  # analyzer id -> (n,) nats, each clipped to its cap (held where a load explains the pattern)
    weights: dict  # analyzer id -> SourceWeight
    cmd: Optional[CommandSharesResult]
    thr: Optional[ThrottleResult]
    load: Optional[LoadFit]  # the load that explains the command pattern, or None
    either: Optional[int]  # the rotor a load explains nearly as well, where it alone would make the flight damaged
    total: np.ndarray  # (n,) nats per rotor
    decisive: np.ndarray  # total without the discounted sources (what "damaged" needs)
    trim_held: Optional[str]
    w: np.ndarray  # (n + 1,) the stated probabilities (:func:`posterior`)
    motors: list  # MotorDecision per rotor
    best: int  # index of the leading rotor
    second: Optional[int]
    kb: int  # the leading rotor, 1-based
    cause: Cause  # what to inspect first when the verdict names kb
    inspect_kb: str
    lead: float  # nats the leading rotor is ahead of the runner-up
    notes: list
    decision: Decision
    onset: object
    first_seen: Optional[float]
    pattern_held: Optional[str]
    vib: Optional[VibrationResult]
    share: object  # the leading rotor's command-share finding, or None
    unsupported: bool  # its command share did not rise against its baseline
    throttle_fell: bool
    single_damaged: bool  # every bar of the single-rotor "damaged" met
    singles_for_pairs: dict

    @property
    def called(self) -> bool:
        """The leading rotor reaches ``DAMAGED_LLR`` (decisive sources) and leads by ``SEPARATION_LLR``."""
        return self.decisive[self.best] >= DAMAGED_LLR and self.lead >= SEPARATION_LLR

    def severity_words(self, k: int) -> str:
        m = self.motors[k - 1]
        if m.eta_hat is None or m.eta_ci is None:
            return ""
        lo, hi = m.eta_ci
        if lo <= 0.0:  # the fit reached the bottom of its grid: only an upper bound is known
            return f"gives at most {100 * hi:.0f} % of its normal thrust"
        return f"gives about {100 * m.eta_hat:.0f} % of its normal thrust [{100 * lo:.0f}-{100 * hi:.0f} %]"

    def evidence_words(self, k: int) -> str:
        parts = [f"{s} {v[k - 1]:+.1f}" for s, v in self.sources.items()]
        cmd = self.cmd
        cite = f"it {cmd.words[k - 1]}; " if cmd is not None and cmd.analyzer in self.sources and cmd.words else ""
        return cite + "evidence for it (log-likelihood ratio, nats): " + ", ".join(parts)

    def discounted_words(self, k: int) -> str:
        """", +2.4 of them from commands, discounted on this kind of log" ("" when none gave any)."""
        low = [s_ for s_, wt in self.weights.items() if wt.trust == "discounted" and self.sources[s_][k - 1] > 0]
        part = float(sum(self.sources[s_][k - 1] for s_ in low))
        return f", {part:+.1f} of them from {', '.join(low)}, discounted on this kind of log" if low else ""


def _evidence(results: Sequence[AnalyzerResult], n: int, frame: Optional[Frame], timeline: Timeline,
              kind: Optional[LogKind]) -> Evidence:
    """The table of hypotheses (:class:`Evidence`) from the analyzers' results: each source's LLRs
    capped by its measured reliability on this kind of log, a load that explains the pattern holding
    what reads it, the per-rotor totals and posterior, the pairs, and the holds."""
    weights = {r.analyzer: source_weight(r, kind) for r in results}
    sources = {r.analyzer: r.llr(n, weights[r.analyzer].cap) for r in results}
    sources = {k: v for k, v in sources.items() if v is not None}
    weights = {k: w for k, w in weights.items() if k in sources}
    cmd = next((r for r in results if isinstance(r, CommandSharesResult)), None)
    thr = next((r for r in results if isinstance(r, ThrottleResult)), None)
    load = _load_explains(cmd, sources, n, results, weights)
    either = None
    if load is not None:  # the load stands for the pattern: what reads it says little of a rotor
        either = _rotor_or_load(cmd, sources, weights)
        sources = _held_for_load(sources)
    total = np.sum(list(sources.values()), axis=0) if sources else np.zeros(n)
    # a discounted source (frequent false alarms on this kind of log) counts toward "uncertain" only
    discounted = [v for s_, v in sources.items() if weights[s_].trust == "discounted"]
    decisive = total - np.sum(discounted, axis=0) if discounted else total
    trim_held = _trim_held(cmd, sources, int(np.argmax(total)), n)
    # the stated probabilities: mild damage no source sees is never ruled out
    w = posterior(np.maximum(total, MILD_DAMAGE_LLR_FLOOR))
    motors = []
    for k in range(n):
        thrust = cmd.finding("thrust", k + 1) if cmd is not None else None
        motors.append(MotorDecision(
            motor=k + 1, llr=float(total[k]), llr_by_source={s: float(v[k]) for s, v in sources.items()},
            eta_hat=None if thrust is None else thrust.value, eta_ci=None if thrust is None else thrust.interval,
            weight=float(w[k + 1])))
    order = np.argsort(-total)
    best = int(order[0])
    second = int(order[1]) if n > 1 else None
    kb = best + 1
    cause = judge_cause(results, kb)
    lead = float(total[best] - (total[second] if second is not None else -np.inf))
    airframe_changed = _airframe_changed(cmd, thr, n, best)
    if load is not None and load.chi2 / max(n - 3, 1) <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        airframe_changed = None  # the load explains the change since calibration
    decision = Decision(motors=motors, airframe_changed=airframe_changed,
                        healthy_chi2=None if cmd is None else cmd.healthy_chi2,
                        share_sigma=None if cmd is None else cmd.share_sigma,
                        sources=list(sources), results=list(results), weights=weights)
    onset = timeline.onset
    # a load carried from take-off makes its pattern from the first window: a change after a healthy
    # stretch (the model's onset, on the leading motor) is not one
    pattern_held = (None if load is not None or (onset is not None and onset.motor == kb)
                    else _pattern_held(cmd, sources, best, n))
    share = cmd.finding("share", kb) if cmd is not None else None
    unsupported = share is not None and share.baseline is not None and share.value <= share.baseline
    thr_sigma = (cmd.throttle_sigma if cmd is not None else None) or THROTTLE_DRIFT_SIGMA
    throttle_fell = thr is not None and thr.ratio is not None and thr.ratio < 1.0 - THROTTLE_FELL_SIGMAS * thr_sigma
    single_damaged = (decisive[best] >= DAMAGED_LLR and lead >= SEPARATION_LLR and not unsupported
                      and not throttle_fell and trim_held is None and pattern_held is None)
    decision.pairs, singles_for_pairs = _pairs(results, sources, weights, cmd, n)
    return Evidence(
        n=n, frame=frame, timeline=timeline, kind=kind, results=results, sources=sources, weights=weights, cmd=cmd,
        thr=thr, load=load, either=either, total=total, decisive=decisive, trim_held=trim_held, w=w, motors=motors,
        best=best, second=second, kb=kb, cause=cause, inspect_kb=f"{cause.words}; {cause.advice}", lead=lead,
        notes=[note for r in results for note in r.notes], decision=decision, onset=onset,
        first_seen=onset.first_seen if onset is not None else timeline.t_first, pattern_held=pattern_held,
        vib=_vibration(results), share=share, unsupported=unsupported, throttle_fell=throttle_fell,
        single_damaged=single_damaged, singles_for_pairs=singles_for_pairs)


# The rules, in precedence order: each states the verdict (a Statement) or passes (None).

def _rule_pair(ev: Evidence) -> Optional[Statement]:
    """Two rotors explain the evidence where no single one does (:func:`_pair_step`); an uncertain
    pair does not replace a single rotor that meets every bar of "damaged". Not with a load."""
    single_weights = [m.weight for m in ev.motors]
    call = None if ev.load is not None else _pair_step(ev.decision.pairs, ev.singles_for_pairs, ev.motors, ev.cmd,
                                                        ev.thr, ev.n, ev.frame, ev.onset)
    if call is not None and not (call[0] == "uncertain" and ev.single_damaged):
        status, motor, confidence, reason, inspect, pair_motors, pair = call
        return Statement(status, motor, confidence, reason, inspect, None, pair_motors, pair)
    for m, wt in zip(ev.motors, single_weights):  # the pair step's weights are the pair's only
        m.weight = wt
    return None


def _rule_throttle_fell(ev: Evidence) -> Optional[Statement]:
    """Called, but the throttle fell well below calibration: the load or set-up changed."""
    if not (ev.throttle_fell and ev.called and not ev.unsupported):
        return None
    kb, frame = ev.kb, ev.frame
    return Statement("uncertain", None, ev.w[kb],
                     f"the evidence points at {_words(frame, kb)} ({ev.total[ev.best]:+.1f} nats), but the throttle is "
                     f"{100 * (1 - ev.thr.ratio):.0f} % lower than at calibration, which a rotor that lost thrust cannot "
                     f"do with the same load: the load or the set-up changed since calibration; {ev.inspect_kb}, "
                     f"then re-calibrate on a healthy flight; {ev.evidence_words(kb)}", (kb,), ev.cause)


def _rule_trim_held(ev: Evidence) -> Optional[Statement]:
    """Called, but only the commands against another session's calibration point at it (:func:`_trim_held`)."""
    if not (ev.trim_held is not None and ev.called and not ev.unsupported):
        return None
    kb, frame, share = ev.kb, ev.frame, ev.share
    sev = ev.severity_words(kb)
    rise = 100 * (share.value / share.baseline - 1) if share is not None and share.baseline else float("nan")
    parts = ", ".join(f"{s_} {v[kb - 1]:+.1f}" for s_, v in ev.sources.items())
    return Statement("uncertain", None, ev.w[kb],
                     f"{_words(frame, kb)} needs {rise:.0f} % more command than at calibration"
                     + (f" (if its propeller were the cause, it {sev})" if sev else "")
                     + f": {ev.inspect_kb}; if nothing is found, the load moved (battery, payload, centre of mass): "
                       f"re-calibrate. Only the commands point at it: {ev.trim_held}; evidence for it "
                       f"(log-likelihood ratio, nats): {parts}", (kb,), ev.cause)


def _rule_pattern_held(ev: Evidence) -> Optional[Statement]:
    """Called, but only the sources that read the command pattern point at it (:func:`_pattern_held`):
    a rotor's loss or a load at its corner."""
    if not (ev.pattern_held is not None and ev.called and not ev.unsupported):
        return None
    kb, frame = ev.kb, ev.frame
    ev.decision.pattern_held = kb
    sev = ev.severity_words(kb)
    return Statement("uncertain", None, ev.w[kb],
                     f"{_words(frame, kb)} lost thrust" + (f" (it {sev})" if sev else "")
                     + f", or a load sits at its corner (a weight in its propeller's wash, a payload under it): "
                       f"only the sources that read the command pattern point at it, and a load there moves them as a "
                       f"damaged propeller does ({ev.pattern_held}); {ev.inspect_kb}; if it is sound, fly once without "
                       f"the payload, or log ESC telemetry or vibration, to tell; {ev.evidence_words(kb)}", (kb,),
                     ev.cause)


def _rule_share_did_not_rise(ev: Evidence) -> Optional[Statement]:
    """Called, but the rotor's command share did not rise as a weak rotor's must."""
    if not (ev.called and ev.unsupported):
        return None
    kb, share = ev.kb, ev.share
    return Statement("uncertain", None, ev.w[kb],
                     f"the evidence points at {_words(ev.frame, kb)} ({ev.total[ev.best]:+.1f} nats), but its command "
                     f"share did not rise as a rotor that lost thrust must ({share.value:.3f} against "
                     f"{share.baseline:.3f}); {ev.evidence_words(kb)}; {ev.inspect_kb}, and the others", (kb,), ev.cause)


def _rule_damaged(ev: Evidence) -> Optional[Statement]:
    """Every bar of "damaged" met: rotor kb lost thrust."""
    if not ev.called:
        return None
    kb = ev.kb
    since = f" from t={ev.onset.first_seen:.1f} s" if ev.onset is not None else ""
    sev = ev.severity_words(kb)
    return Statement("damaged", kb, ev.w[kb], f"{_words(ev.frame, kb)} lost thrust{since}"
                     + (f": it {sev}" if sev else "") + f"; {ev.evidence_words(kb)}; {ev.inspect_kb}", (kb,), ev.cause)


def _rule_rotor_or_load(ev: Evidence) -> Optional[Statement]:
    """A rotor that alone would make the flight damaged, which a load explains nearly as well."""
    if ev.either is None:
        return None
    ke, cmd = ev.either, ev.cmd
    gap = cmd.rotor_vs_load[ke - 1]
    return Statement("uncertain", None, ev.w[ke],
                     f"{_words(ev.frame, ke)} lost thrust, or no rotor did and "
                     f"{load_verdict_fields(ev.load, ev.frame, cmd)['words']}: the command pattern fits a weak rotor "
                     f"{ke} only {gap:+.1f} nats better than the load (it needs {load_separation(cmd):.0f} to tell); "
                     f"inspect propeller {ke}; if it is sound, fly once without the payload (or turn on ESC "
                     f"telemetry) to tell; {ev.evidence_words(ke)}", (ke,), ev.cause if ke == ev.kb else None)


def _rule_weak(ev: Evidence) -> Optional[Statement]:
    """The leading rotor reaches :func:`uncertain_bar`: it, or the two it cannot tell apart."""
    bar = uncertain_bar(ev.kind)
    total, best, second, kb, frame, w = ev.total, ev.best, ev.second, ev.kb, ev.frame, ev.w
    if not total[best] >= bar:
        return None
    named: tuple[int, ...] = (kb,)
    named_cause: Optional[Cause] = None
    if ev.lead < SEPARATION_LLR and second is not None and total[second] >= bar:
        k2 = second + 1
        named = (kb, k2)
        confidence = w[kb] + w[k2]
        reason = (f"the evidence points at {_words(frame, kb)} ({total[best]:+.1f} nats) or "
                  f"{_words(frame, k2)} ({total[second]:+.1f}) and cannot tell them apart; "
                  f"inspect propellers {kb} and {k2}")
    else:
        sev = ev.severity_words(kb)
        confidence = w[kb]
        reason = (f"{_words(frame, kb)} may have lost thrust" + (f" (it {sev})" if sev else "")
                  + f", but the evidence is too weak to call ({total[best]:+.1f} nats{ev.discounted_words(kb)}; "
                    f"damage needs {DAMAGED_LLR:.0f}); {ev.evidence_words(kb)}; {ev.inspect_kb}")
        named_cause = ev.cause
        if ev.cmd is not None and ev.cmd.baseline == "profile":
            reason += "; if nothing is found, the load moved since calibration (battery, payload): re-calibrate"
    if ev.decision.airframe_changed:
        reason += f"; also {ev.decision.airframe_changed}: after the inspection, re-calibrate"
    return Statement("uncertain", None, confidence, reason, named, named_cause)


def _rule_airframe_changed(ev: Evidence) -> Optional[Statement]:
    """The shares moved beyond the drift and no rotor explains it."""
    changed = ev.decision.airframe_changed
    if not changed:
        return None
    return Statement("uncertain", None, ev.w[0],
                     f"no rotor explains the change since calibration ({changed}): the airframe itself "
                     f"changed (payload, battery, a re-trim); check the propellers, then re-calibrate on a "
                     f"healthy flight")


def _rule_healthy(ev: Evidence) -> Statement:
    """No rotor lost thrust (the last rule: it always states)."""
    return Statement("healthy", None, ev.w[0], f"no rotor lost thrust: the strongest case is {_words(ev.frame, ev.kb)} "
                                               f"at {ev.total[ev.best]:+.1f} nats (damage needs {DAMAGED_LLR:.0f})"
                     + _thin_timeline_words(ev.timeline, ev.weights, ev.cmd))


#: The rules in precedence order; the first that states wins. A new rule is one entry here.
RULES = (_rule_pair, _rule_throttle_fell, _rule_trim_held, _rule_pattern_held, _rule_share_did_not_rise,
         _rule_damaged, _rule_rotor_or_load, _rule_weak, _rule_airframe_changed, _rule_healthy)


def _weigh(results: Sequence[AnalyzerResult], n: int, frame: Optional[Frame],
           timeline: Timeline, kind: Optional[LogKind] = None) -> tuple[Verdict, Decision]:
    """The verdict from the analyzers' evidence (module docstring): the hypotheses' table
    (:func:`_evidence`), the first of :data:`RULES` that states, stated by :func:`_done`."""
    ev = _evidence(results, n, frame, timeline, kind)
    statement = next(s for s in (rule(ev) for rule in RULES) if s is not None)
    return _done(ev, statement)


def _done(ev: Evidence, st: Statement) -> tuple[Verdict, Decision]:
    """The verdict as stated: raised by the flight-level vibration finding, else never below
    ``STATED_MIN_CONFIDENCE`` (:func:`_stated`); an uncertain one at most ``UNCERTAIN_CONFIDENCE_CAP``;
    a healthy one seen or not (``SEEN_HEALTHY_P``); the analyzers' notes, the one-session note and
    the load's words added."""
    status, motor, confidence, reason = st.status, st.motor, st.confidence, st.reason
    inspect, named, motors, pair = st.inspect, st.named, st.motors, st.pair
    vib, frame, load, cmd, timeline = ev.vib, ev.frame, ev.load, ev.cmd, ev.timeline
    raised = _raised_by_vibration(vib, status)
    if raised is not None:
        named = None  # the vibration's verdict names no rotor
        status, motor, motors, pair = raised, None, None, False
        inspect = (vib.line_motor,) if vib.line_motor is not None and vib.tie_trusted else ()
        confidence = _p_imbalance(vib)
        reason = (f"a propeller is {'likely damaged' if status == 'damaged' else 'possibly out of balance'}: "
                  f"{vib.level_words}; {_vibration_advice(vib, status, frame)}; "
                  f"the per-rotor evidence alone said: {reason}")
    if raised is None:  # the per-rotor statement: never stated below STATED_MIN_CONFIDENCE
        status, inspect, confidence, reason, restated = _stated(status, tuple(inspect), confidence, reason, ev.w,
                                                                ev.decision.motors, pair, frame)
        if restated:
            named = ev.cause if tuple(inspect) == (ev.kb,) else None
            motor, motors = None, None
    if status == "uncertain":
        confidence = min(confidence, UNCERTAIN_CONFIDENCE_CAP)
    seen = None
    if status == "healthy":
        seen = bool(confidence >= SEEN_HEALTHY_P and timeline.covered_s >= SEEN_MIN_COVERED_S)
        if not seen:
            reason = f"{not_seen_words(confidence, timeline.covered_s, ev.kind)}; {reason}"
    for note in ev.notes:
        reason += f"; {note}"
    one = _one_flight_note(cmd) if status != "healthy" else None
    if one:
        reason += f"; {one}"
    load_dict = None
    if load is not None and status == "healthy" and raised is None and load.llr >= LOAD_NAMED_LLR:
        load_dict = load_verdict_fields(load, frame, cmd)
        reason = f"propellers healthy: {load_dict['words']}; {reason}"
        named = None
    elif load is not None and status == "uncertain" and raised is None and ev.either is None:
        reason += (f"; or no rotor lost thrust and {load_verdict_fields(load, frame, cmd)['words']}: "
                   f"inspect the propeller, fly once without the payload, or turn on ESC telemetry to tell")
    inspect = tuple(inspect) if status != "healthy" else ()
    motor = named_motor(status, motor, inspect)
    motors = list(motors) if motors is not None else ([motor] if motor else [])
    return Verdict(status=status, motor=motor, position=frame.position(motor) if (frame is not None and motor)
                   else None, confidence=float(np.clip(confidence, 0.0, 1.0)),
                   first_seen=ev.first_seen if status == "damaged" else None, reason=reason,
                   inspect=inspect, motors=motors, pair=pair,
                   positions=[frame.position(k) if frame is not None else None for k in motors],
                   cause="load" if load_dict else (named.cause if named else None),
                   cause_evidence=named.evidence() if named else None,
                   seen=seen, load=load_dict), ev.decision


def not_seen_words(p_healthy: float, covered_s: Optional[float], kind: Optional[LogKind]) -> str:
    """Why this log could not show damage and what would make the next one decisive: more usable
    flight (``SEEN_MIN_COVERED_S``), motor outputs and rates at full rate, a calibration profile."""
    why = []
    if covered_s is not None and covered_s < SEEN_MIN_COVERED_S:
        why.append(f"only {covered_s:.0f} s of usable flight")
    if p_healthy < SEEN_HEALTHY_P:
        why.append(f"the evidence left P(healthy) at {p_healthy:.2f}, near the even prior")
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
    return (f"this log could not show damage ({'; '.join(why)}): not a clearance; what would make the next log "
            f"decisive: {'; '.join(todo)}")


def _leading(w: np.ndarray, first: Sequence[int] = ()) -> tuple[tuple[int, ...], float]:
    """The propellers ``first`` and then the next by weight (``w`` from :func:`posterior`) until
    together they reach ``STATED_MIN_CONFIDENCE`` (or all are named), and their probability."""
    named = list(first)
    for k in (int(i) + 1 for i in np.argsort(-w[1:], kind="stable")):
        if sum(w[j] for j in named) >= STATED_MIN_CONFIDENCE:
            break
        if k not in named:
            named.append(k)
    return tuple(named), float(sum(w[j] for j in named))


def _stated(status: str, inspect: tuple, confidence: float, reason: str, w: np.ndarray,
            motors: Sequence[MotorDecision], pair: bool, frame: Optional[Frame]
            ) -> tuple[str, tuple, float, str, bool]:
    """(status, inspect, confidence, reason, restated) so that no verdict is stated below
    ``STATED_MIN_CONFIDENCE``: a healthy verdict (or "the airframe changed") whose P(healthy) is
    below it becomes uncertain naming the leading rotors; an uncertain pair is stated as P(either
    of the two); an uncertain verdict below it names the next rotors too. ``w``: the single-rotor
    posterior; ``motors``: each rotor's weight (alone or in a pair)."""
    if status == "uncertain" and pair and len(inspect) == 2 and confidence < STATED_MIN_CONFIDENCE:
        a, b = inspect  # the weights are then P(rotor k lost thrust, alone or in a pair)
        either = motors[a - 1].weight + motors[b - 1].weight - confidence
        return status, inspect, max(confidence, float(either)), reason, False
    if status not in ("healthy", "uncertain") or confidence >= STATED_MIN_CONFIDENCE or pair:
        return status, inspect, confidence, reason, False
    healthy_like = status == "healthy" or not inspect
    named, p = _leading(w, () if healthy_like else inspect)
    lead = " and ".join(f"{_words(frame, k)}, P {w[k]:.2f}" for k in named[:2]) + (
        f" and {len(named) - 2} more" if len(named) > 2 else "")
    props = f"propeller{'s' if len(named) > 1 else ''} {', '.join(map(str, named[:-1]))}" + (
        f" and {named[-1]}" if len(named) > 1 else f"{named[0]}")
    if len(named) == len(w) - 1 and len(named) > 2:
        props = f"every propeller, propeller {named[0]} first"
    if healthy_like:
        said = "healthy" if status == "healthy" else "the airframe changed"
        words = (f"the evidence cannot say healthy (P(healthy) only {w[0]:.2f}): "
                 f"{'the leading rotors are' if len(named) > 1 else 'the leading rotor is'} {lead}; inspect "
                 f"{props}; the per-rotor bars alone said {said}: {reason}")
    else:
        words = (f"{reason}; no one of them is likely enough alone, so the verdict names the rotors that "
                 f"together reach P {p:.2f}: {lead}")
    return "uncertain", named, p, words, True


def _thin_timeline_words(timeline: Timeline, weights: dict, cmd: Optional[CommandSharesResult]) -> str:
    """Why a healthy verdict stands over a mostly uncertain timeline ("" when the timeline is not):
    what it rests on instead (and how far those sources are trusted on this kind of log), and what
    would let more of them weigh in."""
    share = timeline.abstained_share if timeline.n_windows else 0.0
    if share < THIN_TIMELINE_SHARE:
        return ""
    others = [f"{s} ({w.trust})" if w.trust and w.trust != "trusted" else s
              for s, w in weights.items() if s != "model"]
    text = (f"; {100 * share:.0f} % of the model's windows are uncertain ('?'): it could not tell this flight's "
            f"propellers apart, so the verdict rests on " + (", ".join(others) if others else "the model's weak "
                                                               "leaning alone"))
    if cmd is not None and cmd.baseline != "profile":
        text += "; calibrating on a healthy flight of this airframe lets its command pattern weigh in fully"
    return text


#: Severity order of verdicts when one log holds several flights (the log's verdict is its worst).
STATUS_RANK = {"not_diagnosable": 0, "healthy": 1, "uncertain": 2, "damaged": 3, "stopped": 4}


def _vibration(results: Sequence[AnalyzerResult]) -> Optional[VibrationResult]:
    """The vibration result with a flight-level figure, if any."""
    return next((r for r in results if isinstance(r, VibrationResult) and not r.abstained
                 and r.flight_llr is not None and np.isfinite(r.flight_llr)), None)


def _vibration_llr(vib: VibrationResult) -> float:
    return float(min(vib.flight_llr, vib.llr_cap))


def _p_imbalance(vib: VibrationResult) -> float:
    """P(a propeller is out of balance) from the flight-level LLR under even odds."""
    return float(1.0 / (1.0 + np.exp(-_vibration_llr(vib))))


def _raised_by_vibration(vib: Optional[VibrationResult], status: str) -> Optional[str]:
    """The status the flight-level vibration finding raises ``status`` to, or None."""
    if vib is None:
        return None
    llr = _vibration_llr(vib)
    if llr >= DAMAGED_LLR and status not in ("damaged", "stopped"):
        return "damaged"
    if llr >= UNCERTAIN_LLR and status == "healthy":
        return "uncertain"
    return None


def _vibration_advice(vib: VibrationResult, status: str, frame: Optional[Frame], *, no_outputs: bool = False) -> str:
    """What to inspect after a vibration finding: the rotor its line follows where the tie is ESC
    rpm; a tie by commanded speed only as a hint in an uncertain verdict; else all propellers."""
    k = vib.line_motor
    if k is not None and vib.tie_trusted:
        how = "ESC rpm" if vib.tie_source == "esc_rpm" else "its commanded speed"
        return f"the line follows {_words(frame, k)} ({how}): inspect propeller {k} first, then the others"
    head = ("this log has no motor outputs, so it cannot say which: inspect all propellers" if no_outputs
            else "no rotor can be named from it: inspect all propellers")
    if k is not None and status == "uncertain":
        head += f" (the line follows the commanded speed of {_words(frame, k)}: start there)"
    return head


def _vibration_only(vib: VibrationResult, n: int, frame: Optional[Frame], reason: str) -> tuple[Verdict, Decision]:
    """The verdict from vibration alone, for a flight the rest of the pipeline cannot judge."""
    llr = _vibration_llr(vib)
    p = _p_imbalance(vib)
    # below UNCERTAIN_LLR still uncertain when "out of balance" is the likelier (STATED_MIN_CONFIDENCE)
    status = "damaged" if llr >= DAMAGED_LLR else (
        "uncertain" if llr >= UNCERTAIN_LLR or 1.0 - p < STATED_MIN_CONFIDENCE else "healthy")
    no_outputs = "motor outputs" in reason
    if status == "damaged":
        text = f"a propeller is likely damaged: {vib.level_words}; {_vibration_advice(vib, status, frame, no_outputs=no_outputs)}"
    elif status == "uncertain":
        text = (f"a propeller may be out of balance: {vib.level_words}; "
                f"{_vibration_advice(vib, status, frame, no_outputs=no_outputs)}"
                + ("; calibrate on a healthy flight of this airframe to tell" if vib.against != "profile" else ""))
    else:
        text = f"no propeller out of balance: {vib.level_words}"
    text += f"; only vibration was judged ({reason})"
    for note in vib.notes:
        text += f"; {note}"
    sources = [vib.analyzer] if vib.llr(n) is not None else []
    decision = Decision(sources=sources, results=[vib])
    tied = (vib.line_motor,) if vib.line_motor is not None and vib.tie_trusted and status != "healthy" else ()
    motor = named_motor(status, None, tied)
    confidence = {"healthy": 1.0 - p, "uncertain": min(p, UNCERTAIN_CONFIDENCE_CAP)}.get(status, p)
    return Verdict(status=status, motor=motor, position=frame.position(motor) if (frame is not None and motor) else None,
                   confidence=confidence, reason=text, inspect=tied,
                   seen=bool(confidence >= SEEN_HEALTHY_P) if status == "healthy" else None), decision


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
    the reason naming that flight and listing every other one."""
    label, worst = parts[worst_flight([v for _, v in parts])]
    others = "".join(f"; {lab}: {v.status_words()}" for lab, v in parts if v is not worst)
    return Verdict(status=worst.status, motor=worst.motor, position=worst.position, confidence=worst.confidence,
                   first_seen=worst.first_seen, reason=f"{label}: {worst.reason}{others}", inspect=worst.inspect,
                   motors=list(worst.motors), pair=worst.pair, positions=list(worst.positions),
                   cause=worst.cause, cause_evidence=worst.cause_evidence, seen=worst.seen, load=worst.load)
