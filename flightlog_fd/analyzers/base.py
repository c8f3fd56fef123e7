"""The analyzer contract: typed per-motor findings, what an analyzer sees, and its base class."""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

#: Each analyzer's LLR per motor is clipped to this magnitude before the decision sums them: no
#: single source can outvote the others without limit (a model misled by an odd airframe, a
#: command pattern from a bent arm). 8 nats: e^8 ~ 3000 to 1.
SOURCE_LLR_CAP = 8.0


@dataclass
class Finding:
    """One figure about one motor, with what the decision needs to weigh it.

    ``value`` in ``unit`` with an ``interval`` (lo, hi) or None; ``baseline``: the healthy value it
    is compared with (None when there is none); ``direction``: which way damage moves it ("up",
    "down", or "" for information only); ``llr``: its evidence for "this rotor lost thrust" against
    healthy in nats (None: shown, not weighed)."""

    analyzer: str
    motor: int
    name: str
    value: Optional[float]
    unit: str = ""
    interval: Optional[tuple[float, float]] = None
    baseline: Optional[float] = None
    direction: str = ""
    llr: Optional[float] = None
    display: str = ""  # how a report shows it (the analyzer knows its figure best); "" = generic

    def text(self) -> str:
        """The cell a report prints: ``display``, else the value with its interval."""
        if self.display:
            return self.display
        if self.value is None or not np.isfinite(self.value):
            return "-"
        out = f"{self.value:.3g}"
        if self.interval is not None:
            out += f" [{self.interval[0]:.3g}-{self.interval[1]:.3g}]"
        return out

    def as_dict(self) -> dict:
        def r(x):
            return None if x is None or not np.isfinite(x) else round(float(x), 4)
        return {"analyzer": self.analyzer, "motor": int(self.motor), "name": self.name, "value": r(self.value),
                "unit": self.unit, "interval": None if self.interval is None else [r(self.interval[0]), r(self.interval[1])],
                "baseline": r(self.baseline), "direction": self.direction, "llr": r(self.llr), "text": self.text()}


@dataclass
class AnalyzerResult:
    """What one analyzer said about the flight: its findings, or why it abstained. An analyzer
    with figures the decision reads beyond its findings returns a typed subclass of its own."""

    analyzer: str
    findings: list[Finding] = field(default_factory=list)
    abstained: Optional[str] = None  # the reason, when it had nothing to say
    notes: list[str] = field(default_factory=list)
    llr_cap: float = SOURCE_LLR_CAP  # set from the analyzer by run_analyzers
    cap_keeps_order: bool = False  # likewise
    reliability_keys: tuple[str, ...] = ()  # likewise

    def finding(self, name: str, motor: int) -> Optional[Finding]:
        """Its finding ``name`` about ``motor`` (1-based), or None."""
        return next((f for f in self.findings if f.name == name and f.motor == motor), None)

    def raw_llr(self, n_motors: int) -> Optional[np.ndarray]:
        """(n,) summed LLR of this analyzer's weighed findings as it computed them (no cap); None if
        it weighs nothing."""
        out = np.zeros(n_motors)
        weighed = False
        for f in self.findings:
            if f.llr is not None and np.isfinite(f.llr) and 1 <= f.motor <= n_motors:
                out[f.motor - 1] += f.llr
                weighed = True
        return out if weighed else None

    def llr(self, n_motors: int, cap: Optional[float] = None) -> Optional[np.ndarray]:
        """(n,) :meth:`raw_llr` clipped to +-``cap`` (default ``llr_cap``); None if it weighs
        nothing. With ``cap_keeps_order`` (the analyzer's :attr:`Analyzer.cap_keeps_order`) all
        motors are first lowered by the top one's excess over the cap, so the cap bounds the
        evidence against healthy but keeps what the source says between motors."""
        out = self.raw_llr(n_motors)
        if out is None:
            return None
        cap = self.llr_cap if cap is None else cap
        if self.cap_keeps_order:
            out = out - max(float(out.max()) - cap, 0.0)
        return np.clip(out, -cap, cap)

    def as_dict(self) -> dict:
        return {"analyzer": self.analyzer, "abstained": self.abstained, "notes": list(self.notes),
                "findings": [f.as_dict() for f in self.findings]}


@dataclass
class Context:
    """Everything an analyzer may read about one flight, prepared once by the diagnose pipeline.

    ``probs`` (N, n+1) and ``covered_s``: the windows the decision rests on; ``share_fit``: the
    command shares against their baseline (:class:`flightlog_fd.analyzers.share_fit.ShareFit`);
    ``profile``: the calibration profile or None (``profile.analyzers.get(id)`` holds each
    analyzer's fitted baseline)."""

    flight: Any
    frame: Any
    n_motors: int
    probs: np.ndarray
    covered_s: float
    segments: Sequence = ()
    share_fit: Any = None
    profile: Any = None
    model_sha256: str = ""  # the model that judged the windows (a baseline fitted with another is not used)
    #: Results analyzers share within one diagnosis (e.g. the command-share fits the throttle
    #: analyzer reuses), keyed by whoever computes them.
    memo: dict = field(default_factory=dict)

    def baseline_for(self, analyzer_id: str) -> Optional[dict]:
        """This analyzer's healthy baseline from the profile (None without one)."""
        p = self.profile
        return (getattr(p, "analyzers", None) or {}).get(analyzer_id) if p is not None else None


class Analyzer(ABC):
    """Base class: set ``id``, ``description``, ``requires``; implement :meth:`analyze`, and
    :meth:`fit_baseline` when the analyzer learns a healthy baseline from calibration flights."""

    id: str = ""
    description: str = ""
    #: Flight streams it needs (attribute names of Flight); it abstains when one is missing.
    requires: tuple[str, ...] = ()
    #: Its LLR per motor is clipped to +- this before the decision sums the sources: the most it may
    #: give where the reliability table trusts it, and all it gives where the table has no cell.
    llr_cap: float = SOURCE_LLR_CAP
    #: The log properties its evidence depends on (:data:`.reliability.PROPERTIES`: "rate",
    #: "profile", "rotors"): the cell of the measured reliability table the decision weighs it by
    #: (:data:`.reliability.RELIABILITY`); () = weighed by ``llr_cap`` alone.
    reliability_keys: tuple[str, ...] = ()
    #: True when its evidence comes from a model trained on simulated flights: simulated flights then
    #: measure its reliability in-sample, so the table trusts it only where real flights showed it quiet.
    learned: bool = False
    #: True: the cap lowers every motor by the top one's excess before clipping (the differences
    #: between motors survive); False: each motor is clipped alone (motors above the cap tie).
    #: For a source whose motor-to-motor differences are physics, not a classifier's leaning.
    cap_keeps_order: bool = False
    #: False when it can judge (and fit its baseline on) a log without per-motor outputs.
    needs_motor_outputs: bool = True

    def missing(self, flight: Any) -> Optional[str]:
        """The reason to abstain when a required stream is absent, else None."""
        for name in self.requires:
            s = getattr(flight, name, None)
            if s is None or (hasattr(s, "__len__") and len(s) == 0):
                return f"the log has no {name} stream"
        return None

    def fit_baseline(self, flights: Sequence[Any], model: Any = None) -> Optional[dict]:
        """The healthy baseline from calibration flights (and the profile's model), stored in the
        profile (JSON-able)."""
        return None

    @abstractmethod
    def analyze(self, ctx: Context) -> AnalyzerResult:
        """Per-motor findings for one flight, or an abstention with its reason."""
