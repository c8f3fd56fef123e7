"""What kind of log this is, for weighing each source by its measured reliability on such logs.

:class:`LogKind`: the properties of a log that decide how much evidence a source can carry:
the motor-output and rate-stream rates, the airborne time the windows cover, the share of
manoeuvring windows, and whether a profile (and its adapted model) describes the airframe.
Built once per diagnosis (:func:`log_kind`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Optional, Sequence

#: Profile kinds: no profile; a profile whose model is the shipped one (``--no-adapt``); a profile
#: whose model was adapted to the airframe (the default ``fdlog calibrate``).
PROFILE_KINDS = ("none", "profile", "adapted")


@dataclass(frozen=True)
class LogKind:
    """The log properties the reliability table is indexed by (rates in Hz, times in s)."""

    motors_hz: float
    rates_hz: float
    covered_s: float
    manoeuvre_share: float
    profile: str  # one of PROFILE_KINDS
    n_motors: int = 4

    @property
    def stream_hz(self) -> float:
        """The slower of the motor-output and rate streams: what the model's windows resolve."""
        return min(self.motors_hz, self.rates_hz)

    def as_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "LogKind":
        return LogKind(**{k: d[k] for k in LogKind.__dataclass_fields__ if k in d})


def log_kind(flight: Any, phases: Sequence[str], covered_s: float, profile: Any, adapted: bool,
             n_motors: int) -> LogKind:
    """The :class:`LogKind` of a diagnosed flight: its streams' rates, the windows' covered time and
    phases, and the profile (``adapted``: the model judging is the profile's own)."""
    motors = getattr(flight, "motors", None)
    rates = getattr(flight, "rates", None)
    man = sum(p == "manoeuvre" for p in phases) / len(phases) if len(phases) else 0.0
    kind = "none" if profile is None else ("adapted" if adapted else "profile")
    return LogKind(motors_hz=float(motors.rate_hz) if motors is not None else 0.0,
                   rates_hz=float(rates.rate_hz) if rates is not None else 0.0,
                   covered_s=float(covered_s), manoeuvre_share=float(man), profile=kind, n_motors=int(n_motors))


#: Below this the slower of the motor-output and rate streams is "low": PX4's default
#: ``actuator_motors`` and ArduCopter's ``RCOU`` at 10 Hz, the old ArduCopter logs at 3-11 Hz.
#: The model's windows are resampled at 50 Hz over 1.6 s: a 10 Hz stream puts 16 samples in one.
LOW_RATE_HZ = 15.0
#: From here the streams fill the model's 50 Hz windows ("full": PX4's high-rate profile 250 Hz,
#: ArduPilot's RATE at the loop rate, CrazyPAD's 100 Hz); between the two "mid" (ArduCopter 3.x
#: RATE and IMU at 20-25 Hz).
FULL_RATE_HZ = 45.0

#: The rate classes, slowest first.
RATE_CLASSES = ("low rate", "mid rate", "full rate")


def rate_class(stream_hz: float) -> str:
    """The rate class of the slower of the motor-output and rate streams (``LOW_RATE_HZ``,
    ``FULL_RATE_HZ``)."""
    return "low rate" if stream_hz < LOW_RATE_HZ else ("mid rate" if stream_hz < FULL_RATE_HZ else "full rate")


def flight_rate_class(flight: Any) -> Optional[str]:
    """:func:`rate_class` of a flight's motor-output and rate streams; None when it has no rate
    figures for both (a synthetic or partial flight)."""
    try:
        hz = [float(getattr(getattr(flight, s, None), "rate_hz")) for s in ("motors", "rates")]
    except (AttributeError, TypeError, ValueError):
        return None
    return rate_class(min(hz)) if all(x > 0 for x in hz) else None


#: What each cell property reads from a :class:`LogKind`.
PROPERTIES = {
    "rate": lambda k: rate_class(k.stream_hz),
    "profile": lambda k: "no profile" if k.profile == "none" else "profile",
    # the profile's own adapted model (only the model's evidence depends on it): "" when not
    "adapted": lambda k: "adapted model" if k.profile == "adapted" else "",
    "rotors": lambda k: "quad" if k.n_motors == 4 else "n-rotor",
}

#: How far a source is trusted (decision.py turns a level into the most nats the source may give):
#: "trusted" may make a damaged verdict alone; "corroborating" needs another source to agree;
#: "discounted" cannot make even an uncertain verdict alone, and never counts toward "damaged".
TRUST_LEVELS = ("trusted", "corroborating", "discounted")


def cell_of(keys: Sequence[str], kind: LogKind) -> str:
    """The reliability-table cell of a source whose evidence depends on ``keys`` (PROPERTIES)."""
    return ", ".join(x for x in (PROPERTIES[k](kind) for k in keys) if x)


#: How the table below was measured (benchmarks/bench_reliability.py applies this rule and prints
#: the table): from each origin's (real, simulated) healthy flights of the cell, what the source
#: ALONE would say on them (its leading LLR, the largest over the motors, against the decision's
#: bars). Trusted: at most TRUST_RATE of them reach the uncertain bar and none the damaged bar.
#: Discounted: at least DAMAGED_RATE of them reach the damaged bar, or DISCOUNT_RATE the uncertain
#: bar (its false alarms are verdicts, not leanings). Corroborating otherwise.
#: Fewer healthy flights than this of one origin measure nothing.
MIN_MEASURED = 10
TRUST_RATE = 0.05
DAMAGED_RATE = 0.05
DISCOUNT_RATE = 0.20


def trust_level(n_healthy: int, uncertain: int, damaged: int) -> Optional[str]:
    """The trust level one origin's healthy flights support (None: too few to measure):
    ``uncertain``, ``damaged``: how many of them the source alone takes to the decision's bars."""
    if n_healthy < MIN_MEASURED:
        return None
    if damaged / n_healthy >= DAMAGED_RATE or uncertain / n_healthy >= DISCOUNT_RATE:
        return "discounted"
    return "trusted" if uncertain / n_healthy <= TRUST_RATE and damaged == 0 else "corroborating"


def cell_trust(real: Optional[str], simulated: Optional[str], learned: bool = False) -> str:
    """A cell's level from its origins' levels (None: too few flights): the worse of the two;
    "corroborating" when neither measured enough. A ``learned`` source (the model, trained on
    simulation) is "trusted" only where real flights were measured too: simulated flights can show
    it unreliable, but its quiet on them is in-sample."""
    measured = [x for x in (real, simulated) if x is not None]
    level = max(measured, key=TRUST_LEVELS.index) if measured else "corroborating"
    return "corroborating" if level == "trusted" and learned and real is None else level


#: Each source's trust level per cell, measured (benchmarks/bench_reliability.py table; the rule
#: above) on the real flights in ../shared and simulated airframes, healthy and damaged; the
#: figures behind each level are in results/reliability.md. A cell not listed is weighed by the
#: analyzer's own cap.
RELIABILITY: dict[str, dict[str, str]] = {
    "commands": {
        "no profile, n-rotor": "discounted",
        "no profile, quad": "corroborating",
        "profile, n-rotor": "trusted",
        "profile, quad": "corroborating",
    },
    "effectiveness": {
        "full rate": "trusted",
        "low rate": "trusted",
        "mid rate": "trusted",
    },
    "esc": {
        "no profile": "trusted",
        "profile": "trusted",
    },
    "model": {
        "full rate, no profile, n-rotor": "corroborating",
        "full rate, no profile, quad": "corroborating",
        "full rate, profile, adapted model, quad": "corroborating",
        "full rate, profile, n-rotor": "corroborating",
        "full rate, profile, quad": "trusted",
        "low rate, no profile, n-rotor": "corroborating",
        "low rate, no profile, quad": "corroborating",
        # re-measured after the adapted model's votes are weighed against another session's spread
        # (model_votes.adapted_session_reference): of the 16 real healthy cross-session pairs 1 reaches
        # 3.5 (+4.9, Erle board A 15-10-2014_42 against 09-10-2014_31), none 6, 1 reaches 2; the
        # table row in results/reliability.md is the measurement before it (6 / 3 of 16)
        "low rate, profile, adapted model, quad": "corroborating",
        "low rate, profile, n-rotor": "corroborating",
        "low rate, profile, quad": "trusted",
        "mid rate, no profile, quad": "corroborating",
        "mid rate, profile, quad": "corroborating",
    },
    "throttle": {
        "profile": "trusted",
    },
}


#: Cells where the code departs from the rule, each with its reason (the benchmark prints both).
#: None today: the adapted model at low rate, once an exception here, is weighed against the
#: session-to-session spread of its votes (model_votes.adapted_session_reference), and the rule
#: gives it "corroborating" (results/cross_session.md, "Adapted model across sessions").
EXCEPTIONS: dict[tuple[str, str], tuple[str, str]] = {}


def trust_of(source: str, cell: str) -> Optional[str]:
    """The level the decision uses for ``source`` in ``cell``: an exception's, else the table's
    (None: no cell, the analyzer's own cap)."""
    held = EXCEPTIONS.get((source, cell))
    return held[0] if held is not None else RELIABILITY.get(source, {}).get(cell)
