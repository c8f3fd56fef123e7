"""Propeller or motor: the likely cause of a named rotor's lost thrust, from ESC telemetry.

What: :func:`judge_cause` reads, for the rotor a verdict names, the ESC analyzer's
``cause_llr`` (the log Bayes factor of "its motor or ESC lost the thrust" against "its propeller
did", :mod:`flightlog_fd.analyzers.esc`) and its two relations against the other motors, and
states one of:

- ``"propeller"``: the rotor turns as fast or faster for its command and draws less current per
  rpm² (a lighter, shorter, cut or chipped propeller loads its motor less);
- ``"motor_or_esc"``: it turns slower for its command (a weak motor, a failing ESC, a bad bearing,
  a resistive joint): the command rose, its speed did not;
- None, saying why: the log has no usable ESC rpm (the commands alone cannot tell the two apart:
  the rotor gives less thrust per command either way), or the relations are within
  ``CAUSE_LLR`` of even. It never guesses.

Why: the advice differs (a new propeller does not mend a failing ESC), and a verdict that names
a rotor must say which part to inspect first. Inputs: the analyzers' results and the motor
(1-based). Limits: one cause for one named rotor; a bearing's friction raises the current per
rpm² as well as slowing the rotor, which the motor / ESC hypothesis (current per rpm² unchanged)
fits less well than a failing ESC, but still far better than a propeller.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from .analyzers import AnalyzerResult
from .analyzers.esc import ANALYZER_ID as ESC_ID
from .analyzers.esc import NO_ESC

#: |cause LLR| (nats) from which a cause is stated: e^3 = 20 to 1. Measured
#: (`benchmarks/bench_esc.py --causes --per-cell 6 --seed 2026`): on 144 simulated damaged
#: propellers and weak motors (eta 0.6-0.9, ESC at 10/50/100 Hz, random airframes 30 g-5 kg) no
#: cause LLR lay beyond 1 nat on the wrong side, and the lowest toward the truth were +4.1
#: (propeller) and +3.8 (motor, eta 0.9); the ArduCopter SITL weak motor: +284.
CAUSE_LLR = 3.0
CAUSES = ("propeller", "motor_or_esc")
#: Every cause a verdict can state: the ESC relations' two, and a moved load (decision.py: healthy
#: propellers, a load explains the command pattern).
VERDICT_CAUSES = CAUSES + ("load",)


@dataclass(frozen=True)
class Cause:
    """The likely cause of motor ``motor``'s lost thrust: ``cause`` ("propeller",
    "motor_or_esc" or None), ``llr`` (nats, motor / ESC against propeller; None without ESC
    rpm), the relations behind it (% against the other motors; None when not measured) and
    ``words``, the clause a verdict's reason carries."""

    motor: int
    cause: Optional[str]
    llr: Optional[float]
    rpm_per_command: Optional[float]
    current_per_rpm2: Optional[float]
    words: str

    @property
    def advice(self) -> str:
        """What to inspect, first things first."""
        k = self.motor
        if self.cause == "motor_or_esc":
            return (f"inspect motor {k} and ESC {k} (bearings, windings, wiring and solder joints, the ESC) "
                    f"before the propeller")
        if self.cause is None:
            return f"inspect propeller {k}, then motor {k} and its ESC"
        return f"inspect propeller {k}"

    def evidence(self) -> dict:
        """The JSON report's ``verdict.cause_evidence``."""
        def r(x):
            return None if x is None or not np.isfinite(x) else round(float(x), 2)
        return {"motor": self.motor, "llr": r(self.llr), "rpm_per_command": r(self.rpm_per_command),
                "current_per_rpm2": r(self.current_per_rpm2), "reason": self.words}


def _figure(result: AnalyzerResult, name: str, motor: int) -> Optional[float]:
    f = result.finding(name, motor)
    return None if f is None or f.value is None or not np.isfinite(f.value) else float(f.value)


def judge_cause(results: Sequence[AnalyzerResult], motor: int) -> Cause:
    """The likely cause of ``motor``'s lost thrust from the analyzers' ``results`` (module docstring)."""
    k = motor
    unknown = "a damaged propeller cannot be told from a weak motor or ESC (both need more command)"
    esc = next((r for r in results if r.analyzer == ESC_ID), None)
    llr = None if esc is None else getattr(esc, "cause_llr", {}).get(k)
    if esc is None or esc.abstained or llr is None or not np.isfinite(llr):
        if esc is None or esc.abstained == NO_ESC:
            why = "the log has no ESC telemetry"
        else:
            why = f"its ESC telemetry could not be used ({esc.abstained or 'no relation for this motor'})"
        return Cause(k, None, None, None, None, f"{why}, so {unknown}")
    rpm, cur = _figure(esc, "rpm_per_command", k), _figure(esc, "current_per_rpm2", k)
    figures = f"rpm per command {rpm:+.1f} %" + (f", current per rpm² {cur:+.1f} %" if cur is not None else "")
    if llr >= CAUSE_LLR:
        return Cause(k, "motor_or_esc", llr, rpm, cur,
                     f"the motor or its ESC is weak, not the propeller: it turns {abs(rpm):.0f} % slower for its "
                     f"command than the other motors (ESC rpm; {llr:+.0f} nats against a propeller)")
    if llr <= -CAUSE_LLR:
        return Cause(k, "propeller", llr, rpm, cur,
                     f"the propeller, not the motor or ESC: against the other motors {figures} (a lighter, cut or "
                     f"chipped propeller loads its motor less; {-llr:.0f} nats against a weak motor or ESC)")
    return Cause(k, None, llr, rpm, cur,
                 f"from its ESC telemetry {unknown} ({figures} against the other motors; {llr:+.1f} nats, a "
                 f"cause needs {CAUSE_LLR:.0f})")
