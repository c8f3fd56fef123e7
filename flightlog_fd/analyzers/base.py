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
#: Rotor counts on which the sources weigh "two rotors lost thrust" (:meth:`AnalyzerResult.pair_llr`):
#: quads, where it is measured (benchmarks/bench_two_props.py). A hexa's or octo's allocator has
#: more freedom than the four force rows, so a pair there is a hypothesis nobody has measured.
PAIR_ROTOR_COUNTS = (4,)
#: Thrust-efficiency grid of the damage hypothesis "rotor k gives eta of its normal thrust",
#: shared by every source that can say how much (uniform prior over it). 0.4: below it a quad
#: cannot hold yaw and the flight ends; 0.99: damage too small to matter is still "damage" here but
#: carries no evidence (its pattern equals healthy). The decision integrates eta once, jointly,
#: over the sources' profiles on this grid (:meth:`AnalyzerResult.eta_profile`).
ETA_GRID = np.round(np.arange(0.40, 0.995, 0.01), 3)


def log_mean_exp(x: np.ndarray, axis=None) -> np.ndarray:
    """log(mean(exp(x))) along ``axis`` without overflow (the marginal over a uniform grid)."""
    x = np.asarray(x, float)
    top = np.max(x, axis=axis, keepdims=True)
    out = top + np.log(np.mean(np.exp(x - top), axis=axis, keepdims=True))
    return np.squeeze(out, axis=axis) if axis is not None else float(out.squeeze())
#: Why a rotor lost thrust (:mod:`flightlog_fd.cause`): its propeller (cut, chipped, cracked), its
#: motor or ESC (it turns slower for its command), or something in its wash or under it (a payload,
#: a strap, a guard, a load toward it: the rotor turns as its command asks and loads its motor as a
#: healthy propeller would, yet the airframe gets less lift from it). "propeller" and
#: "motor_or_esc" are stored in the results store and the JSON report; "wash" is new.
CAUSES = ("propeller", "motor_or_esc", "wash")
#: The stated prior over CAUSES for a rotor that lost thrust, before the log is read. No measured
#: base rate exists: propellers are the commonest wear part (they strike the ground and things) and
#: the part the tool is for, hence half; motor and ESC faults (heat, age, a bad joint) next; something
#: in the wash the rarest (most loads sit under the centre, not under one rotor). Every cause keeps
#: at least a fifth, so the evidence, not the prior, states a cause (cause.CAUSE_PROBABILITY_BAR is
#: well above any prior share). A fleet with its own base rates may set its own.
CAUSE_PRIOR = {"propeller": 0.5, "motor_or_esc": 0.3, "wash": 0.2}


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
    pair_keeps_order: bool = False  # likewise
    reliability_keys: tuple[str, ...] = ()  # likewise
    #: {(a, b): nats} this source's own evidence for "rotors a and b both lost thrust" (1-based,
    #: a < b), before the cap, for a source whose per-motor figures are not independent of each
    #: other; empty: :meth:`pair_llr` sums the two motors' findings
    pair_llrs: dict = field(default_factory=dict)
    #: {motor (1-based): (len(ETA_GRID),) nats}: this source's evidence for "rotor k gives eta of its
    #: normal thrust" against healthy at each eta of :data:`ETA_GRID`, before the cap; the motor's
    #: weighed finding is its marginal over the grid (:func:`log_mean_exp`). Empty: the source says
    #: the same at every eta (or cannot say how much), and :meth:`eta_profile` is None.
    eta_llrs: dict = field(default_factory=dict)

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

    def _raw_pairs(self, n_motors: int) -> dict:
        """{(a, b): nats} before the cap: ``pair_llrs``, else the two motors' findings summed."""
        pairs = [(a, b) for a in range(1, n_motors + 1) for b in range(a + 1, n_motors + 1)]
        if self.pair_llrs:
            return {pr: float(self.pair_llrs[pr]) for pr in pairs if pr in self.pair_llrs}
        per = self.raw_llr(n_motors)
        return {} if per is None else {(a, b): float(per[a - 1] + per[b - 1]) for a, b in pairs}

    @staticmethod
    def _joint_shift(per: Optional[np.ndarray], pairs: dict, cap: float) -> float:
        """With ``cap_keeps_order``: how far every hypothesis (each motor and each pair) is lowered
        so the top one sits at the cap (:meth:`llr` ``with_pairs``, :meth:`pair_llr`)."""
        tops = ([float(per.max())] if per is not None else []) + list(pairs.values())
        return max((max(tops) if tops else 0.0) - cap, 0.0)

    def llr(self, n_motors: int, cap: Optional[float] = None, with_pairs: bool = False) -> Optional[np.ndarray]:
        """(n,) :meth:`raw_llr` clipped to +-``cap`` (default ``llr_cap``); None if it weighs
        nothing. With ``cap_keeps_order`` (the analyzer's :attr:`Analyzer.cap_keeps_order`) all
        motors are first lowered by the top one's excess over the cap, so the cap bounds the
        evidence against healthy but keeps what the source says between motors; ``with_pairs``:
        lowered with the pairs of :meth:`pair_llr` (by the top of motors and pairs together), so
        the cap keeps what the source says between one rotor and two (the decision's pair step);
        ``pair_keeps_order`` does that ``with_pairs`` only (the single-rotor view clipped motor by
        motor)."""
        out = self.raw_llr(n_motors)
        if out is None:
            return None
        cap = self.llr_cap if cap is None else cap
        if (self.cap_keeps_order or self.pair_keeps_order) and with_pairs and n_motors in PAIR_ROTOR_COUNTS:
            out = out - self._joint_shift(out, self._raw_pairs(n_motors), cap)
        elif self.cap_keeps_order:
            out = out - max(float(out.max()) - cap, 0.0)
        return np.clip(out, -cap, cap)

    def eta_profile(self, n_motors: int, cap: Optional[float] = None) -> Optional[np.ndarray]:
        """(n, len(ETA_GRID)) nats: each motor's :attr:`eta_llrs` (a motor without one is flat at its
        raw LLR), bounded by ``cap`` (default ``llr_cap``) as :meth:`llr` bounds the flat figures:
        when a motor's evidence for damage (its marginal over the grid) exceeds the cap, every
        motor's profile is multiplied by the one factor in (0, 1] that brings the largest to the cap
        (a tempered likelihood: it keeps where on the grid the source speaks and the order of the
        motors, and unlike shifting it never turns a strong "here" into a "not there" elsewhere on
        the grid); evidence against damage is bounded at -cap at every eta. None when the source
        gives no profile or weighs nothing."""
        raw = self.raw_llr(n_motors)
        if raw is None or not self.eta_llrs:
            return None
        out = np.repeat(raw[:, None], len(ETA_GRID), axis=1)
        for k, prof in self.eta_llrs.items():
            prof = np.asarray(prof, float)
            if 1 <= k <= n_motors and prof.shape == ETA_GRID.shape and np.all(np.isfinite(prof)):
                out[k - 1] = prof
        cap = self.llr_cap if cap is None else cap

        def top(alpha: float) -> float:
            return float(np.max(log_mean_exp(alpha * out, axis=1)))

        if top(1.0) > cap:
            lo, hi = 0.0, 1.0  # top(0) = 0 <= cap < top(1)
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if top(mid) <= cap else (lo, mid)
            out = lo * out
        return np.maximum(out, -cap)

    def pair_llr(self, n_motors: int, cap: Optional[float] = None) -> Optional[dict]:
        """{(a, b): nats} for every pair of motors, clipped like :meth:`llr` to +-``cap`` (default
        ``llr_cap``; with ``cap_keeps_order`` every motor and pair lowered together by the top
        one's excess over the cap): ``pair_llrs`` when the analyzer gave them, else the sum of the
        two motors' weighed findings (a source whose finding about one motor does not depend on the
        others: a vibration line tied to a rotor). None when it weighs nothing, or on a rotor count
        outside ``PAIR_ROTOR_COUNTS``."""
        if n_motors not in PAIR_ROTOR_COUNTS:
            return None
        raw = self._raw_pairs(n_motors)
        if not raw:
            return None
        cap = self.llr_cap if cap is None else cap
        keeps = self.cap_keeps_order or self.pair_keeps_order
        shift = self._joint_shift(self.raw_llr(n_motors), raw, cap) if keeps else 0.0
        return {pr: float(np.clip(v - shift, -cap, cap)) for pr, v in raw.items()}

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
        """This analyzer's healthy baseline from the profile (None without one): the load
        configuration's own when the commands are weighed against one that holds it."""
        cfg = getattr(self.share_fit, "configuration", None) if self.share_fit is not None else None
        own = ((cfg or {}).get("analyzers") or {}).get(analyzer_id)
        if own is not None:
            return own
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
    #: True: in the decision's pair step only, every motor and pair is lowered together by the top
    #: one's excess over the cap (:meth:`AnalyzerResult.llr` ``with_pairs``), so a source far above
    #: its cap on two motors still says "two rather than one"; the single-rotor view is clipped
    #: motor by motor as without it.
    pair_keeps_order: bool = False
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
