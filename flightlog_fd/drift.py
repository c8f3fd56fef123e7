"""The drift rule: a motor whose figure moves away from the other motors across an airframe's flights.

**Drift rule** (:func:`find_drift`), per airframe and figure, over its flights in time order (UTC
start; flights without GPS time follow, ordered by file name; one row per log, the latest
diagnosis): for each flight where every motor has the figure, motor k's robust z-score
against the others is ``z = (x_k - median(others)) / max(1.4826 * MAD(others), FLOOR)``.
A least-squares line of z over the flight index (0, 1, 2...) flags motor k when, with at least
``MIN_FLIGHTS`` flights, its slope in the figure's damage direction (model vote up, command share
up: a worn propeller needs more command, effectiveness down) is at least ``DRIFT_SLOPE_MIN`` z
per flight **and** the latest flight's z in that direction is at least ``DRIFT_Z_MIN``. A steady
offset (a motor that always needs 2 % more) has no slope and is not flagged. The ``unknown``
group (logs without identity) is not one airframe: no drift rule there. A flight whose verdict
names a moved load is left out of the command-share and model-vote series
(``LOAD_MOVED_FIGURES``). The floors keep
nearly equal neighbours from turning noise into large z: ``FIGURE_FLOORS`` (command share 0.005,
i.e. half a percent of the total; model vote 0.05; effectiveness 0.02).
Not yet measured on a real fleet (no multi-flight airframe history in ../shared): the constants
are set from the simulator's spread and should be revisited on real data.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from .report.words import cause_words

MIN_FLIGHTS = 3
DRIFT_SLOPE_MIN = 0.5  # robust z per flight, in the damage direction
DRIFT_Z_MIN = 2.0  # latest flight's robust z, in the damage direction
#: figure -> (damage direction, floor of the neighbours' spread)
FIGURE_FLOORS = {"model_vote": 0.05, "command_share": 0.005, "effectiveness": 0.02}
FIGURE_DIRECTION = {"model_vote": +1, "command_share": +1, "effectiveness": -1}
FIGURES = tuple(FIGURE_FLOORS)
#: Figures a moved or added load changes as a weak rotor does (the command pattern, and the model
#: whose windows read it): a flight whose verdict's cause is a load (``cause`` = ``load``) is left
#: out of their series, so a payload carried on some flights is not read as a motor drifting.
LOAD_MOVED_FIGURES = ("command_share", "model_vote")


def verdict_words(status: Optional[str], motor: Optional[int], motors: list, pair: bool, short: bool = False,
                  cause: Optional[str] = None) -> str:
    """A stored verdict in words: its status, and the motor it names (damaged, stopped) or both
    of a pair: "damaged m3", "uncertain m1+m4" (short); "damaged (motor 3)", "uncertain (motors 1
    and 4)"; a single motor whose ``cause`` is its motor / ESC reads "damaged (motor 3, motor or
    ESC)" ("damaged m3, motor or ESC")."""
    status = status or "-"
    named = list(motors) if pair and len(motors or []) > 1 else ([motor] if motor else [])
    if not named:
        return f"{status}, load" if cause == "load" and short else (
            f"{status} (a moved load)" if cause == "load" else status)
    tag = cause_words(cause).tag
    why = f", {tag}" if tag and len(named) == 1 else ""
    if short:
        return f"{status} " + "+".join(f"m{k}" for k in named) + why
    if len(named) == 1:
        return f"{status} (motor {named[0]}{why})"
    return f"{status} (motors {', '.join(map(str, named[:-1]))} and {named[-1]})"


@dataclass
class FlightRecord:
    """One flight of an airframe as history and the drift rule see it (its latest diagnosis);
    ``motors``: motor -> its figures, named as the JSON report's per-motor fields."""

    id: int
    log_path: str
    log_sha256: str
    flight_start_utc: Optional[str]
    airborne_s: Optional[float]
    status: str
    motor: Optional[int]
    confidence: Optional[float]
    reason: str
    diagnosed_at: str
    vehicle_source: str
    motors: dict[int, dict] = field(default_factory=dict)
    #: The named rotor's likely cause (propeller | motor_or_esc), or load (propellers healthy, a
    #: moved load); None when unknown or none named.
    cause: Optional[str] = None
    #: Each take-off to landing of a log holding several (``store.PART_COLUMNS`` and ``part``).
    parts: list[dict] = field(default_factory=list)
    #: Every propeller the verdict names (the JSON verdict's ``motors``) and whether it names two together.
    verdict_motors: list[int] = field(default_factory=list)
    pair: bool = False

    def verdict_words(self, short: bool = False) -> str:
        """The status with the motor(s) it names: "damaged m1+m4" (short) or "damaged (motors 1
        and 4)"; a pair is named for uncertain too."""
        return verdict_words(self.status, self.motor, self.verdict_motors, self.pair, short, self.cause)

    def figure(self, name: str) -> Optional[list[float]]:
        """Every motor's value of ``name`` (motor order), or None unless all are known."""
        vals = [self.motors.get(k, {}).get(name) for k in sorted(self.motors) or range(1, 5)]
        return [float(v) for v in vals] if all(v is not None for v in vals) else None


def robust_z(values: list[float], k: int, floor: float) -> float:
    """Motor k's (0-based) z-score against the median and MAD of the others."""
    others = sorted(v for i, v in enumerate(values) if i != k)
    med = others[len(others) // 2] if len(others) % 2 else 0.5 * (others[len(others) // 2 - 1] + others[len(others) // 2])
    dev = sorted(abs(v - med) for v in others)
    mad = dev[len(dev) // 2] if len(dev) % 2 else 0.5 * (dev[len(dev) // 2 - 1] + dev[len(dev) // 2])
    return (values[k] - med) / max(1.4826 * mad, floor)


def _slope(y: list[float]) -> float:
    n = len(y)
    xm = (n - 1) / 2.0
    ym = sum(y) / n
    sxx = sum((i - xm) ** 2 for i in range(n))
    return sum((i - xm) * (v - ym) for i, v in enumerate(y)) / sxx


@dataclass
class Drift:
    """A motor whose figure moves away from the others across an airframe's flights."""

    vehicle: str
    motor: int
    figure: str
    slope: float  # robust z per flight, signed as the figure
    latest_z: float
    n_flights: int

    def describe(self) -> str:
        return (f"motor {self.motor} {self.figure.replace('_', ' ')} drifts from the others: "
                f"z {self.slope:+.2f} per flight over {self.n_flights} flights, latest z {self.latest_z:+.1f}")


def find_drift(vehicle: str, flights: list[FlightRecord]) -> list[Drift]:
    """The motors flagged by the drift rule of the module docstring."""
    out = []
    for name in FIGURES:
        series = [f.figure(name) for f in flights if not (name in LOAD_MOVED_FIGURES and f.cause == "load")]
        series = [s for s in series if s is not None]
        if len(series) < MIN_FLIGHTS:
            continue
        sign = FIGURE_DIRECTION[name]
        for k in range(len(series[0])):
            z = [robust_z(s, k, FIGURE_FLOORS[name]) for s in series]
            slope = _slope(z)
            if sign * slope >= DRIFT_SLOPE_MIN and sign * z[-1] >= DRIFT_Z_MIN:
                out.append(Drift(vehicle, k + 1, name, slope, z[-1], len(series)))
    return out
