"""Analyzers: one file per evidence source, each returning typed per-motor findings.

Every analyzer reads one prepared :class:`~flightlog_fd.analyzers.base.Context` (the flight, its
windows' probabilities, the command shares against their baseline, the profile) and returns an
:class:`~flightlog_fd.analyzers.base.AnalyzerResult`: per-motor
:class:`~flightlog_fd.analyzers.base.Finding` s (value, unit, interval, baseline, which way damage
moves it, and its log-likelihood ratio for :mod:`flightlog_fd.decision`), or the reason it
abstained. The decision model sums the LLRs; the reports (terminal, JSON, CSV, HTML) and the
results store iterate over the findings, so none of them names an analyzer's fields.

Registered (in this order): ``model`` (:mod:`.model_votes`), ``commands``
(:mod:`.command_shares`, with each rotor's thrust eta-hat), ``throttle`` (:mod:`.throttle`),
``effectiveness`` (:mod:`.effectiveness`), ``esc`` (:mod:`.esc`: rpm per command and current per
rpm² from ESC telemetry), ``vibration`` (:mod:`.vibration`: the horizontal vibration level against
the airframe's healthy level, rotor lines in the gyro spectrum tied to a rotor; a flight-level
finding, :class:`~.vibration.VibrationResult`, the decision weighs when no rotor can be named).

How to add an analyzer
----------------------
1. Create ``flightlog_fd/analyzers/my_source.py`` with a subclass of
   :class:`~flightlog_fd.analyzers.base.Analyzer`: ``id`` (short, unique), ``description``,
   ``requires`` (the Flight streams it reads).
2. Implement ``analyze(ctx)``: return ``AnalyzerResult(self.id, abstained="why")`` when the
   streams are missing or too slow, else one ``Finding`` per motor and figure.
3. Give each weighed finding an ``llr`` in nats from measured noise (a named constant whose
   comment says which measurement set it); ``llr=None`` shows a figure without weighing it.
4. If it learns a healthy baseline, implement ``fit_baseline(flights, model)`` (JSON-able dict);
   ``fdlog calibrate`` stores it in the profile and ``ctx.baseline_for(self.id)`` returns it.
5. Add one line to ``REGISTRY`` below.
6. Add a test with a real healthy log from ../shared (no false alarm) and a damaged one.
"""
from __future__ import annotations

from typing import Sequence

from .base import Analyzer, AnalyzerResult, Context, Finding
from .command_shares import CommandShares
from .effectiveness import Effectiveness
from .esc import Esc
from .model_votes import ModelVotes
from .throttle import Throttle
from .vibration import Vibration

#: Every analyzer the diagnosis runs, in report order.
REGISTRY: list[Analyzer] = [
    ModelVotes(),
    CommandShares(),
    Throttle(),
    Effectiveness(),
    Esc(),
    Vibration(),
]


def run_analyzers(ctx: Context, analyzers: Sequence[Analyzer] | None = None) -> list[AnalyzerResult]:
    """Each registered analyzer's result for one flight (an analyzer that fails abstains with the
    error's message rather than losing the diagnosis)."""
    out = []
    for a in (REGISTRY if analyzers is None else analyzers):
        try:
            r = a.analyze(ctx)
        except (ValueError, ArithmeticError, IndexError, KeyError) as e:
            r = AnalyzerResult(a.id, abstained=f"failed: {e}")
        r.llr_cap = a.llr_cap
        r.cap_keeps_order = a.cap_keeps_order
        r.reliability_keys = tuple(a.reliability_keys)
        out.append(r)
    return out


def fit_baselines(flights: Sequence, model=None, analyzers: Sequence[Analyzer] | None = None) -> dict:
    """{analyzer id: healthy baseline} from calibration flights and the profile's model."""
    out = {}
    for a in (REGISTRY if analyzers is None else analyzers):
        b = a.fit_baseline(flights, model)
        if b is not None:
            out[a.id] = b
    return out


__all__ = ["Analyzer", "AnalyzerResult", "Context", "Finding", "REGISTRY", "run_analyzers", "fit_baselines"]
