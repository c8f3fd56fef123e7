"""Why a rotor lost thrust: its propeller, its motor or ESC, or something in its wash.

What: :func:`judge_cause` weighs, for the rotor a verdict names, the three causes of
:data:`~flightlog_fd.analyzers.base.CAUSES` from a stated prior (``CAUSE_PRIOR``) and the two
sources that can see them, and returns a :class:`Cause` with their probabilities (``probs``):

- **ESC rpm and current** (:mod:`flightlog_fd.analyzers.esc`): per cause, the log Bayes factor of
  the motor's relations against healthy at each η (``EscResult.cause_ll_eta``). A damaged propeller
  turns faster for its command than the rotors' curve and draws less current per rpm²; a weak motor
  or ESC turns slower; a rotor that lost thrust in its wash (or a load toward it, which only moves
  its command) turns as its command asks: to the ESC it is healthy. η is weighed by what the
  sources that read the commands say of it (their ``eta_llrs``, else the commands' ``thrust``
  finding), with ``ETA_PRIOR_FLOOR`` of the uniform prior kept: a propeller that lost 40 % of its
  thrust must show it in its current, one that lost 5 % need not.
- **A vibration line tied to the rotor** (:mod:`flightlog_fd.analyzers.vibration`: ``flight_llr``,
  the log Bayes factor of "a propeller out of balance" against healthy, and ``tie_probs``, where
  the unbalanced propeller is): a propeller that lost thrust is out of balance with probability
  ``UNBALANCED_SHARE``; a rotor that lost thrust to something else has a propeller out of balance
  by chance with probability ``INCIDENTAL_UNBALANCE``. The line's evidence for the propeller is
  therefore bounded (at most log(UNBALANCED_SHARE·n/INCIDENTAL_UNBALANCE), 3 nats on a quad, when
  the line is certainly on this rotor), and a flight whose vibration shows no unbalance counts a
  little against it (log((1 - UNBALANCED_SHARE)/(1 - INCIDENTAL_UNBALANCE)), -0.6 nats).

``Cause.cause`` is the cause whose probability reaches ``CAUSE_PROBABILITY_BAR``, else None
(unknown); the words never claim what the log cannot show, and the advice lists the three things
to inspect, most probable first.

Why: the advice differs (a new propeller does not mend a failing ESC, and neither moves a strap in
the wash), and the commands alone cannot tell them apart: each needs more command for the same
thrust. Inputs: the analyzers' results and the motor (1-based). Limits: one cause for one named
rotor; a bearing's friction slows the rotor and raises its current per rpm², which the motor / ESC
hypothesis (current per rpm² unchanged) fits less well than a failing ESC, but far better than a
propeller; a damaged propeller that lost little thrust (η 0.9) on a log with rpm but no current is
barely distinguishable from a wash (the lighter propeller turns about 1 % faster).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .analyzers import AnalyzerResult
from .analyzers.base import CAUSE_PRIOR, CAUSES
from .analyzers.esc import ANALYZER_ID as ESC_ID
from .analyzers.esc import NO_ESC

#: A cause is stated when its probability reaches this bar: 0.9, the odds of the old 3-nat bar at
#: even prior odds less a margin (e^3 = 20 to 1 is 0.95), since three causes share the mass.
#: Measured (`benchmarks/bench_esc.py --causes`, results/cause.md): on simulated damaged propellers,
#: weak motors and rotors that lost thrust in their wash (η 0.6-0.9, ESC at 10/50/100 Hz) and moved
#: loads, how often a cause is stated and how often wrongly at each bar.
CAUSE_PROBABILITY_BAR = 0.9
#: Share of the uniform η prior kept beside what the commands say of η: the commands' η can be off
#: (a baseline from the neighbours, a trim), and the ESC relations are sharp, so a propeller whose
#: η the commands misjudged must still be found at its own η (a fifth: log(0.2/60) = -5.7 nats to
#: reach one point of the 60-point grid).
ETA_PRIOR_FLOOR = 0.2
#: P(a propeller that lost thrust is out of balance): a chip, a crack or an uneven cut is; a blade
#: trimmed evenly or a propeller that lost pitch need not be. No measured share: the real damaged
#: sets in ../shared are cuts of one blade (unbalanced by construction) except where both blades
#: were cut; half is a choice that keeps the line's evidence bounded either way.
UNBALANCED_SHARE = 0.5
#: P(some propeller is out of balance by chance on an airframe whose rotor lost thrust to
#: something else): healthy propellers are never perfect, and a strong enough line is seen on a
#: tenth of flights. A choice, not a measurement: the vibration analyzer's own healthy false-alarm
#: rate is what it should be (results/vibration.md); it bounds the line's evidence for a propeller.
INCIDENTAL_UNBALANCE = 0.1
#: Words for each cause in the probabilities clause and what to inspect for it.
CAUSE_NAMES = {"propeller": "propeller", "motor_or_esc": "motor or ESC", "wash": "something in its wash"}
#: Every cause a verdict can state: the three of CAUSES, and a moved load (decision.py: healthy
#: propellers, a load explains the command pattern).
VERDICT_CAUSES = CAUSES + ("load",)


@dataclass(frozen=True)
class Cause:
    """The likely cause of motor ``motor``'s lost thrust: ``cause`` (one of CAUSES, or None when no
    cause reaches CAUSE_PROBABILITY_BAR), ``probs`` ({cause: probability}, summing to 1; the prior
    when no source spoke), ``llr`` (the ESC's log Bayes factor of motor / ESC against propeller,
    nats; None without ESC rpm), the ESC relations behind it (% against the rotors' curve; None when
    not measured), ``sources`` (the sources that spoke: "esc", "vibration") and ``words``, the clause
    a verdict's reason carries."""

    motor: int
    cause: Optional[str]
    llr: Optional[float]
    rpm_per_command: Optional[float]
    current_per_rpm2: Optional[float]
    words: str
    probs: dict = field(default_factory=dict)
    sources: tuple = ()

    def ordered(self) -> list[str]:
        """CAUSES, most probable first (the prior's order on a tie)."""
        probs = self.probs or CAUSE_PRIOR
        return sorted(CAUSES, key=lambda c: (-round(probs.get(c, 0.0), 6), -CAUSE_PRIOR[c]))

    @property
    def advice(self) -> str:
        """What to inspect, most probable cause first (the first with what to look for)."""
        k = self.motor
        first = {"propeller": f"propeller {k}",
                 "motor_or_esc": f"motor {k} and ESC {k} (bearings, windings, wiring and solder joints, the ESC)",
                 "wash": f"what sits under rotor {k} (a payload, a strap, a guard, anything in its wash)"}
        then = {"propeller": f"propeller {k}", "motor_or_esc": f"motor {k} and its ESC",
                "wash": f"what sits under rotor {k}"}
        order = self.ordered()
        if order[0] == "motor_or_esc" and self.cause == "motor_or_esc":
            return f"inspect {first['motor_or_esc']} before the propeller, then " + ", then ".join(then[c] for c in order[1:])
        return f"inspect {first[order[0]]}, then " + ", then ".join(then[c] for c in order[1:])

    def evidence(self) -> dict:
        """The JSON report's ``verdict.cause_evidence``."""
        def r(x):
            return None if x is None or not np.isfinite(x) else round(float(x), 2)
        return {"motor": self.motor, "llr": r(self.llr), "rpm_per_command": r(self.rpm_per_command),
                "current_per_rpm2": r(self.current_per_rpm2), "reason": self.words,
                "probs": {c: round(float(p), 3) for c, p in self.probs.items()}, "sources": list(self.sources)}


def _figure(result: AnalyzerResult, name: str, motor: int) -> Optional[float]:
    f = result.finding(name, motor)
    return None if f is None or f.value is None or not np.isfinite(f.value) else float(f.value)


def eta_weights(results: Sequence[AnalyzerResult], motor: int) -> np.ndarray:
    """(len(ETA_GRID),) weights over η for ``motor``, summing to 1: what the sources other than the
    ESC say of how much thrust it lost, multiplied (each its ``eta_llrs``; the command shares without
    one: a normal on their ``thrust`` eta-hat with its 90 % interval), ETA_PRIOR_FLOOR of the uniform
    prior kept; uniform when none says."""
    from .analyzers.command_shares import ETA_GRID

    total, said = np.zeros(len(ETA_GRID)), False
    for r in results:
        if r.analyzer == ESC_ID or r.abstained:
            continue
        v = (getattr(r, "eta_llrs", None) or {}).get(motor)
        if v is not None and len(v) == len(ETA_GRID):
            total += np.asarray(v, float)
            said = True
            continue
        f = r.finding("thrust", motor) if r.analyzer == "commands" else None
        if f is not None and f.value is not None and np.isfinite(f.value):
            lo, hi = f.interval if f.interval is not None else (f.value - 0.1, f.value + 0.1)
            sd = max((hi - lo) / (2 * 1.645), 0.01)
            total += -0.5 * ((ETA_GRID - min(float(f.value), float(ETA_GRID[-1]))) / sd) ** 2
            said = True
    uniform = np.full(len(ETA_GRID), 1.0 / len(ETA_GRID))
    if not said:
        return uniform
    w = np.exp(total - total.max())
    return (1.0 - ETA_PRIOR_FLOOR) * w / w.sum() + ETA_PRIOR_FLOOR * uniform


def _esc_log_likelihoods(esc: AnalyzerResult, motor: int, weights: np.ndarray) -> Optional[dict]:
    """{cause: log Bayes factor against healthy} of the ESC relations, η weighed by ``weights``;
    None when the ESC result has none for ``motor``."""
    by_eta = (getattr(esc, "cause_ll_eta", None) or {}).get(motor)
    if by_eta is not None:
        out = {}
        for c in CAUSES:
            v = np.asarray(by_eta[c], float)
            top = v.max()
            out[c] = float(top + np.log(np.sum(weights * np.exp(v - top))))
        return out
    flat = (getattr(esc, "cause_ll", None) or {}).get(motor)
    return None if flat is None else {c: float(flat[c]) for c in CAUSES}


def _vibration_log_likelihood(vib: Optional[AnalyzerResult], motor: int) -> tuple[Optional[float], Optional[float]]:
    """(log likelihood ratio of the vibration for "the propeller" against the other causes, the
    probability that the unbalanced propeller is on ``motor``) (module docstring); (None, None)
    when the vibration says nothing."""
    if vib is None or vib.abstained:
        return None, None
    flight_llr = getattr(vib, "flight_llr", None)
    if flight_llr is None or not np.isfinite(flight_llr):
        return None, None
    tie = getattr(vib, "tie_probs", None)
    if tie is not None and len(tie) >= motor:
        n, on_k = len(tie), float(tie[motor - 1])
    else:  # a result without tie probabilities: its line's rotor when the tie is trusted, else anywhere
        n = max(1, len({f.motor for f in vib.findings}) or 4)
        line = getattr(vib, "line_motor", None)
        on_k = (1.0 if line == motor else 0.0) if line is not None and getattr(vib, "tie_trusted", False) else 1.0 / n
    f = float(np.clip(flight_llr, -50.0, 50.0))
    num = np.logaddexp(np.log(max(UNBALANCED_SHARE * n * on_k, 1e-300)) + f, np.log(1.0 - UNBALANCED_SHARE))
    den = np.logaddexp(np.log(INCIDENTAL_UNBALANCE) + f, np.log(1.0 - INCIDENTAL_UNBALANCE))
    return float(num - den), on_k


def _probs(ll: dict[str, float]) -> dict[str, float]:
    logp = np.array([np.log(CAUSE_PRIOR[c]) + ll.get(c, 0.0) for c in CAUSES])
    p = np.exp(logp - logp.max())
    p /= p.sum()
    return {c: float(x) for c, x in zip(CAUSES, p)}


def judge_cause(results: Sequence[AnalyzerResult], motor: int) -> Cause:
    """The likely cause of ``motor``'s lost thrust from the analyzers' ``results`` (module docstring)."""
    k = motor
    esc = next((r for r in results if r.analyzer == ESC_ID), None)
    vib = next((r for r in results if r.analyzer == "vibration"), None)
    ll = {c: 0.0 for c in CAUSES}
    sources = []
    esc_ll = None if esc is None or esc.abstained else _esc_log_likelihoods(esc, k, eta_weights(results, k))
    llr = rpm = cur = None
    if esc_ll is not None:
        sources.append("esc")
        for c in CAUSES:
            ll[c] += esc_ll[c]
        llr = esc_ll["motor_or_esc"] - esc_ll["propeller"]
        rpm, cur = _figure(esc, "rpm_per_command", k), _figure(esc, "current_per_rpm2", k)
    vib_ll, on_k = _vibration_log_likelihood(vib, k)
    if vib_ll is not None:
        sources.append("vibration")
        ll["propeller"] += vib_ll
    probs = _probs(ll)
    best = max(probs, key=probs.get)
    cause = best if probs[best] >= CAUSE_PROBABILITY_BAR else None
    words = _words(k, cause, probs, esc, esc_ll is not None, rpm, cur, vib, vib_ll, on_k)
    return Cause(k, cause, llr, rpm, cur, words, probs, tuple(sources))


def _esc_figures(rpm: Optional[float], cur: Optional[float]) -> str:
    out = f"rpm per command {rpm:+.1f} %" if rpm is not None else "rpm per command not measured"
    return out + (f", current per rpm² {cur:+.1f} %" if cur is not None else "")


def _probs_words(probs: dict) -> str:
    return ", ".join(f"{CAUSE_NAMES[c]} {probs[c]:.2f}" for c in sorted(probs, key=probs.get, reverse=True))


def _words(k: int, cause: Optional[str], probs: dict, esc, esc_spoke: bool, rpm, cur, vib, vib_ll, on_k) -> str:
    """The clause a verdict's reason carries (module docstring): never a cause the log cannot show."""
    line = (vib_ll is not None and vib_ll > 1.0 and on_k is not None and on_k >= 0.5)
    line_words = f"a once-per-revolution vibration line follows rotor {k} (a propeller out of balance)"
    if cause == "propeller":
        parts = []
        if esc_spoke and rpm is not None:
            parts.append(f"against the rotors' rpm curve {_esc_figures(rpm, cur)} (a lighter, cut or chipped "
                         f"propeller loads its motor less)")
        if line:
            parts.append(line_words)
        return f"the propeller ({'; '.join(parts) or 'ESC rpm and vibration'}; P {probs['propeller']:.2f})"
    if cause == "motor_or_esc":
        slower = f"{abs(rpm):.0f} % slower" if rpm is not None else "slower"
        return (f"the motor or its ESC is weak, not the propeller: it turns {slower} for its command than the "
                f"rotors' rpm curve (ESC rpm; P {probs['motor_or_esc']:.2f})")
    if cause == "wash":
        return (f"something in its wash or under it, or a load toward it: the rotor turns as its command asks "
                f"({_esc_figures(rpm, cur)} against the rotors' curve), so neither its propeller nor its motor "
                f"shows a fault (ESC; P {probs['wash']:.2f})")
    if esc_spoke:
        esc_part = f"ESC {_esc_figures(rpm, cur)} against the rotors' curve"
    elif esc is None or esc.abstained in (None, NO_ESC):
        esc_part = "no ESC rpm"
    else:
        esc_part = f"no usable ESC rpm ({esc.abstained})"
    shakes = vib_ll is not None and vib_ll > 1.0 and not line
    vib_part = (line_words if line else "a propeller shakes, but the vibration ties its line to no rotor" if shakes
                else "no vibration line tied to it")
    if not esc_spoke and not line and not shakes:
        return f"the log cannot tell a propeller from a motor or something in its wash: {esc_part}, {vib_part}"
    return (f"the cause is not clear: {esc_part}; {vib_part} (P {_probs_words(probs)}; a cause needs "
            f"{CAUSE_PROBABILITY_BAR:.1f})")


__all__ = ["Cause", "judge_cause", "eta_weights", "CAUSES", "CAUSE_PRIOR", "CAUSE_PROBABILITY_BAR", "VERDICT_CAUSES"]
