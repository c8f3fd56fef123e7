"""What kind of log this is, for weighing each source by its measured reliability on such logs.

:class:`LogKind`: the properties of a log that decide how much evidence a source can carry:
the motor-output and rate-stream rates, the airborne time the windows cover, the share of
manoeuvring windows, and whether a profile (and its adapted model) describes the airframe.
Built once per diagnosis (:func:`log_kind`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Optional, Sequence

import numpy as np

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
    #: Against a profile: True when the flight is known to be of a calibration session (its UTC start
    #: within SAME_SESSION_S of a calibration log's), False when known to be of another, None unknown
    #: (no profile, or a log without GPS/UTC time)
    same_session: Optional[bool] = None

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
                   covered_s=float(covered_s), manoeuvre_share=float(man), profile=kind, n_motors=int(n_motors),
                   same_session=same_session(flight, profile))


#: Two flights within this many seconds of each other (UTC starts) are one session: one battery
#: swap to the next, the same day's set-up. Within a session a healthy airframe's command shares
#: move by their re-flight spread (RMS 0.008-0.041 on the real rrc_straight, px4_sih_dev and
#: CrazyPAD re-flights, benchmarks/bench_cross_session.py); across sessions by up to 0.13-0.33
#: (Erle boards A and B), as a moved load or a re-trim does.
SAME_SESSION_S = 6 * 3600.0


def same_session(flight: Any, profile: Any) -> Optional[bool]:
    """Whether ``flight`` flew in one of ``profile``'s calibration sessions (:data:`SAME_SESSION_S`),
    from the UTC starts the log and the profile's calibration logs record; None when either lacks
    them (or there is no profile)."""
    utc = getattr(flight, "utc_start", None)
    if profile is None or utc is None or not np.isfinite(utc):
        return None
    logs = list(getattr(profile, "source_logs", None) or [])
    for sess in getattr(profile, "sessions_", None) or []:
        logs += list(sess.get("logs", []) if isinstance(sess, dict) else [])
    times = [float(e["utc_start"]) for e in logs if isinstance(e, dict) and e.get("utc_start") is not None]
    if not times:
        return None
    return bool(min(abs(float(utc) - t) for t in times) <= SAME_SESSION_S)


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
#: "discounted" cannot make even an uncertain verdict alone (decision.TRUST_CAPS sets the nats).
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
#: above, at the posterior's bars 2.5 / 3.6) on the real flights in ../shared and simulated
#: airframes, healthy and damaged; the figures behind each level are in results/reliability.md.
#: Where the code departs from the rule the rule's level stands here and EXCEPTIONS holds the code's.
#: A cell not listed is weighed by the analyzer's own cap.
RELIABILITY: dict[str, dict[str, str]] = {
    "commands": {
        "no profile, n-rotor": "discounted",
        "no profile, quad": "corroborating",
        "profile, n-rotor": "trusted",
        "profile, quad": "discounted",
    },
    "effectiveness": {
        "full rate": "trusted",
        "low rate": "corroborating",
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
        "low rate, no profile, quad": "discounted",
        "low rate, profile, adapted model, quad": "discounted",
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
#: Both were weighed on benchmarks/decision_replay.py's 684 flights with truth (results/reliability.md,
#: "Re-measured at the posterior's bars"): the rule's level moves no healthy verdict there and
#: costs verdicts on damaged flights.
EXCEPTIONS: dict[tuple[str, str], tuple[str, str]] = {
    ("commands", "profile, quad"): (
        "corroborating",
        "the rule's count is cross-session pairs (10 / 6 of 72 real healthy reach 2.5 / 3.6: Erle's "
        "trims moved between days); within a session the decision trusts the commands anyway "
        "(SESSION_SOURCES). Discounted, the replay loses rrc_straight 25 mm 9/9 -> 8/9, rrc cuts "
        "damaged 28 -> 23 and 8 CrazyPAD M3 cuts named right against the 3-flight profile; no "
        "healthy verdict moves. Corroborating cannot make damaged alone."),
    ("model", "low rate, no profile, quad"): (
        "corroborating",
        "the rule's count is simulated (6 / 90 healthy airframes reach 3.6 alone; real: 0 of 19 reach "
        "2.5). Discounted, the replay moves 5 damaged flights toward healthy (make-demo px4_motor4 "
        "damaged -> uncertain; an rrc 25 mm cut and SIH sih_029 uncertain -> healthy; two simulated) "
        "and no healthy verdict. Corroborating cannot make damaged alone."),
}


def trust_of(source: str, cell: str) -> Optional[str]:
    """The level the decision uses for ``source`` in ``cell``: an exception's, else the table's
    (None: no cell, the analyzer's own cap)."""
    held = EXCEPTIONS.get((source, cell))
    return held[0] if held is not None else RELIABILITY.get(source, {}).get(cell)
