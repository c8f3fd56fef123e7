"""The command-share analyzer's estimation: each motor's share of the thrust commands against the
healthy baseline, and that baseline fitted from calibration flights.

Per flight (:func:`fit_shares`), inputs: the flight's resampled airborne segments (the same ones the NIF windows are cut from:
:attr:`flightlog_fd.windows.Windows.segments`), the model's window probabilities, the rotor
layout, and optionally the calibration profile's healthy baseline.

Per motor it gives:

- **command share**: the motor's mean thrust command (the NIF ``ω²`` proxy) over the airborne
  time divided by the mean of all motors' (1.0 = an even share). Over a whole flight the mean
  angular acceleration is ~0, so the mean commands satisfy the same moment balance as a steady
  hover: the airborne mean is the trim pattern even when the flight never hovers.
- **command change**: with a profile, the share minus the profile's healthy baseline at this
  flight's throttle (:meth:`Baseline.share_at`); without one, the share minus the mean of the
  others ("against its neighbours").
- **effectiveness**: :mod:`flightlog_fd.analyzers.effectiveness_fit` (relative angular acceleration per unit
  command, with its bootstrap interval; ``informative`` says whether the flight manoeuvred enough).
- **model vote**: the mean probability the model gave to "this motor's propeller is damaged".

What the figures mean, and what decides
---------------------------------------
These are the figures a pilot checks; they decide nothing here. The analyzers
(:mod:`flightlog_fd.analyzers`) weigh them, and :mod:`flightlog_fd.decision` makes the verdict.

With a mid-flight onset and no profile, the flight before the onset (at least
``MIN_BEFORE_ONSET_S``) is the baseline: the same airframe, healthy, minutes earlier.

From calibration flights (:func:`estimate_baseline`, the profile's ``baseline_``): the healthy
airframe's airborne-mean command shares, the same quantity the diagnosis measures (so their
biases cancel), as a line in throttle fitted over ``BASELINE_CHUNK_S`` chunks when the chunks span
at least ``BASELINE_MIN_THROTTLE_RANGE`` of throttle (else flat).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

import numpy as np

from ..flight import Flight, Frame
from ..streams import DEFAULT_RATE_HZ
from .effectiveness_fit import EffectivenessEstimate

#: Flight before a mid-flight onset (s) that serves as the baseline when there is no profile.
MIN_BEFORE_ONSET_S = 10.0
#: After a mid-flight onset, a rise of a motor's share between the first and last third of the
#: run larger than this fraction of its whole change is a drift, not a broken propeller (real
#: "healthy" Erle flight 11-2-2015_112: motor 2 climbs from 0.58 to 0.88 PWM over 40 s before a
#: hard landing; SITL steps: the share is flat after the onset).
ONSET_DRIFT_SHARE = 0.5
#: Chunk length (s) for the baseline's share-vs-throttle fit, and the throttle span it needs to fit a slope.
BASELINE_CHUNK_S = 10.0
BASELINE_MIN_THROTTLE_RANGE = 0.05


@dataclass
class Baseline:
    """A healthy airframe's command shares as a function of throttle (from a profile).

    ``share_at(c) = share + slope * (c - throttle_ref)``; ``slope`` is 0 when the calibration
    flights did not span enough throttle.
    """

    share: np.ndarray  # (n,)
    slope: np.ndarray  # (n,) per unit throttle
    throttle_ref: float
    source: str = ""
    #: (n,) each motor's flight-to-flight share spread when calibrated on >= 2 flights, else None
    spread: Optional[np.ndarray] = None
    #: relative flight-to-flight throttle spread (>= 2 flights), else None
    throttle_spread: Optional[float] = None
    n_flights: int = 1
    #: (n,) how well the calibration flights pin each share (:func:`pin_spread`), None when the
    #: profile predates it
    pin: Optional[np.ndarray] = None
    #: (lo, hi) throttle the calibration flights spanned: the slope is not extrapolated beyond it
    throttle_range: Optional[tuple[float, float]] = None
    #: the profile's calibration sessions (:class:`~flightlog_fd.analyzers.session_drift.SessionFigures`)
    #: when it holds two or more: the airframe's own session-to-session drift is weighed then
    sessions: Optional[object] = None
    #: calibration sessions the profile holds (one flight is one session unless grouped); 0 for a
    #: profile older than schema 6, whose flights were pooled
    n_sessions: int = 0

    def share_at(self, throttle: float) -> np.ndarray:
        if self.throttle_range is not None:
            throttle = float(np.clip(throttle, *self.throttle_range))
        out = self.share + self.slope * (throttle - self.throttle_ref)
        return out / out.mean()


@dataclass
class MotorShares:
    """One motor's command share against its baseline, with its effectiveness and model vote."""

    motor: int
    position: Optional[str]
    command_share: float
    command_share_baseline: Optional[float]
    command_change: float
    effectiveness: Optional[float]
    effectiveness_ci: Optional[tuple[float, float]]
    model_vote: float

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {
            "motor": self.motor, "position": self.position,
            "command_share": r(self.command_share), "command_share_baseline": r(self.command_share_baseline),
            "command_change": r(self.command_change),
            "effectiveness": r(self.effectiveness),
            "effectiveness_ci": None if self.effectiveness_ci is None else [r(x) for x in self.effectiveness_ci],
            "model_vote": r(self.model_vote),
        }


@dataclass
class ShareFit:
    """The share fit of one flight: every motor's figures and the baseline they are taken against."""

    motors: list[MotorShares]
    baseline: str  # "profile" | "before onset" | "neighbours"
    throttle: float
    effectiveness: Optional[EffectivenessEstimate] = None
    #: The baseline the changes are taken against (profile or before onset), None for neighbours.
    baseline_: Optional[Baseline] = None
    #: (n,) after a mid-flight onset: each share's change from the first to the last third of it.
    onset_drift: Optional[np.ndarray] = None
    #: (n,) how well this flight pins its own shares (:func:`pin_spread`)
    pin: Optional[np.ndarray] = None
    #: Against a profile of several load configurations, the one the baseline is
    #: (:func:`~flightlog_fd.analyzers.command_shares.nearest_configuration`: name, load, of,
    #: evidence); None otherwise.
    configuration: Optional[dict] = None

    def configuration_words(self) -> Optional[str]:
        """e.g. "against configuration 'camera' (load toward motor 2, +18 %)", or None when the
        profile holds one configuration."""
        c = self.configuration
        if not c:
            return None
        load = c.get("load")
        what = (f" (load toward motor {load['motor']}, {100 * load['size']:+.0f} %)" if load
                else " (the load the profile was calibrated with)" if c["name"] == "as calibrated" else "")
        return f"against configuration '{c['name']}'{what}, the nearest of {c['of']}"

    def drifting(self) -> Optional[int]:
        """The motor whose command rose steadily after the onset rather than in one step, or None."""
        if self.onset_drift is None:
            return None
        for m in self.motors:
            d = self.onset_drift[m.motor - 1]
            if m.command_change > 0 and np.isfinite(d) and d > ONSET_DRIFT_SHARE * m.command_change:
                return m.motor
        return None

    @property
    def throttle_ratio(self) -> Optional[float]:
        """The flight's throttle over the profile's (None without a profile)."""
        b = self.baseline_
        if b is None or self.baseline != "profile" or not b.throttle_ref > 0:
            return None
        return float(self.throttle / b.throttle_ref)

    def summary(self, motor: int) -> str:
        """Plain words for one motor's command share, e.g. for a reason."""
        m = self.motors[motor - 1]
        if self.baseline in ("profile", "before onset"):
            against = "calibration" if self.baseline == "profile" else "before the onset"
            return (f"needs {100 * m.command_change / max(m.command_share_baseline or 1.0, 1e-9):+.0f} % command "
                    f"share against {against} (share {m.command_share:.3f}, baseline {m.command_share_baseline:.3f})")
        return f"runs {100 * m.command_change:+.0f} % command share against its neighbours"


def shares_of(thrust_blocks: Sequence[np.ndarray]) -> tuple[np.ndarray, float]:
    """(n,) mean thrust-command shares (mean 1) over the (samples, n) blocks of the thrust proxy
    (e.g. each segment's ``w_sq``), and the mean thrust command (throttle)."""
    blocks = [np.asarray(b, dtype=np.float64) for b in thrust_blocks if len(b)]
    width = next((np.asarray(b).shape[1] for b in thrust_blocks if np.ndim(b) == 2), 4)
    u = np.vstack(blocks) if blocks else np.zeros((0, width))
    if u.shape[0] == 0:
        return np.full(width, np.nan), float("nan")
    mean = u.mean(axis=0)
    throttle = float(mean.mean())
    return (mean / throttle if throttle > 0 else np.full(len(mean), np.nan)), throttle


#: Pieces a flight is cut into to see how well it pins its mean shares (by time, equal samples).
PIN_PIECES = 3


def pin_spread(thrust_blocks: Sequence[np.ndarray]) -> Optional[np.ndarray]:
    """(n,) how well one flight pins its own mean shares, or None under 3 s: the standard
    deviation of each motor's share between the flight's thirds (by airborne samples, in time
    order) over sqrt(3), the standard error of the flight mean. Thirds' standard deviations
    measured (benchmarks/bench_cross_session.py flights): SIH 0.003-0.017, CrazyPAD normals
    0.007-0.027, rrc goods 0.026-0.104, Erle boards 0.010-0.227 (6-3-2014_6, 37 s at 5 Hz RCOU).
    Check: two such errors plus nothing else predict the healthy one-flight pairs' RMS share
    change on the three airframes without a moved load: SIH 0.009 (measured 0.008), CrazyPAD
    0.014 (0.009), rrc 0.045 (0.041); the thirds' deviation itself would predict 0.07 on rrc."""
    blocks = [np.asarray(b, float) for b in thrust_blocks if len(b)]
    if not blocks:
        return None
    u = np.vstack(blocks)
    if len(u) < 3 * DEFAULT_RATE_HZ:
        return None
    k = len(u) // PIN_PIECES
    parts = [shares_of([u[i * k:(i + 1) * k]])[0] for i in range(PIN_PIECES)]
    out = np.std(parts, axis=0, ddof=1) / np.sqrt(PIN_PIECES)
    return out if np.all(np.isfinite(out)) else None


def fit_shares(segments: Sequence, probs: np.ndarray, frame: Optional[Frame],
                   effectiveness: Optional[EffectivenessEstimate] = None,
                   baseline: Optional[Baseline] = None, since: Optional[float] = None) -> ShareFit:
    """The share fit of one flight (module docstring). ``probs`` (N, n+1) window probabilities.

    ``since``: the model's damage onset (s, log clock) when it lies mid-flight: the shares are then
    taken from the onset on, and without a profile the flight before the onset (at least
    ``MIN_BEFORE_ONSET_S`` of it) is the baseline - the same airframe, healthy, minutes earlier.
    """
    drift = None
    if since is not None:
        before = [s.w_sq[s.t < since] for s in segments]
        after = [s.w_sq[s.t >= since] for s in segments]
        drift = _drift(after)
        if baseline is None and sum(len(b) for b in before) / DEFAULT_RATE_HZ >= MIN_BEFORE_ONSET_S:
            pre, pre_thr = shares_of(before)
            baseline = Baseline(share=pre, slope=np.zeros(len(pre)), throttle_ref=pre_thr, source="before onset")
        share, throttle = shares_of(after)
        pin = pin_spread(after)
    else:
        share, throttle = shares_of([s.w_sq for s in segments])
        pin = pin_spread([s.w_sq for s in segments])
    probs = np.asarray(probs, dtype=np.float64)
    n = len(share)
    votes = probs[:, 1:].mean(axis=0) if probs.size else np.zeros(n)
    if baseline is not None:
        base = baseline.share_at(throttle)
        change = share - base
        kind = "before onset" if baseline.source == "before onset" else "profile"
    else:
        base = None
        change = np.array([share[i] - np.delete(share, i).mean() for i in range(n)])
        kind = "neighbours"

    motors = []
    for i in range(n):
        eff = ci = None
        if effectiveness is not None and len(effectiveness.motors) == n:
            me = effectiveness.motors[i]
            eff, ci = me.effectiveness, me.ci
        motors.append(MotorShares(
            motor=i + 1, position=frame.position(i + 1) if frame is not None else None,
            command_share=float(share[i]), command_share_baseline=None if base is None else float(base[i]),
            command_change=float(change[i]), effectiveness=eff, effectiveness_ci=ci, model_vote=float(votes[i])))
    # why the effectiveness fit says nothing is the effectiveness analyzer's to report
    return ShareFit(motors=motors, baseline=kind, throttle=throttle, effectiveness=effectiveness,
                          baseline_=baseline, onset_drift=drift, pin=pin)


def _drift(blocks: Sequence[np.ndarray]) -> Optional[np.ndarray]:
    """(n,) change of each motor's share from the first to the last third of the samples in
    ``blocks`` (time order): ~0 after a step (a propeller breaks once), large for a steady rise."""
    if not any(len(b) for b in blocks):
        return None
    u = np.vstack([np.asarray(b, float) for b in blocks if len(b)])
    if len(u) < 3 * DEFAULT_RATE_HZ:  # under 3 s after the onset: nothing to compare
        return None
    n = len(u) // 3
    first, last = u[:n].mean(axis=0), u[-n:].mean(axis=0)
    return last / last.mean() - first / first.mean()


# ----------------------------------------------------------------------------- the baseline from calibration flights

def airborne_thrust(flights: Iterable[Flight]) -> list[np.ndarray]:
    """The thrust proxy (samples, n) of every gap-free airborne segment on the feature grid: what the
    airborne-mean fallback and the command-share baseline are computed from (one resample each)."""
    from ..hover import motor_count
    from ..prepared import resample

    return [seg.w_sq for fl in flights for seg in resample(fl, rate_hz=DEFAULT_RATE_HZ, n_motors=motor_count(fl))]


def estimate_baseline(flights: Iterable[Flight], thrust_blocks: Optional[list[np.ndarray]] = None,
                      per_flight: Optional[list[list[np.ndarray]]] = None) -> dict:
    """The healthy airframe's command shares against throttle (module docstring), as the
    profile's ``baseline_`` entry: share (n,), slope (n,), throttle_ref, throttle_range, seconds,
    and with two or more flights ``spread`` (n,): each motor's flight-to-flight standard deviation
    of its share, and ``throttle_spread``: the relative one of the throttle (the decision model's
    drift noise; ``per_flight`` = each flight's thrust blocks)."""
    rate = DEFAULT_RATE_HZ
    flights = list(flights)
    if per_flight is None and thrust_blocks is None:
        per_flight = [airborne_thrust([fl]) for fl in flights]
    blocks = thrust_blocks if thrust_blocks is not None else [b for pf in per_flight for b in pf]
    spread = throttle_spread = None
    if per_flight is not None and sum(1 for pf in per_flight if pf) >= 2:
        each = [shares_of(pf) for pf in per_flight if pf]
        spread = [float(x) for x in np.std([sh for sh, _ in each], axis=0, ddof=1)]
        thr = np.array([th for _, th in each])
        throttle_spread = float(np.std(thr, ddof=1) / np.mean(thr))
    share, throttle = shares_of(blocks)
    # how well the calibration pins the shares: each flight's own between-thirds spread, pooled
    # (RMS) and divided by sqrt(flights) since independent flights average it down
    pins = [pin_spread(pf) for pf in (per_flight if per_flight is not None else [blocks])]
    pins = [p for p in pins if p is not None]
    pin = (np.sqrt(np.mean(np.square(pins), axis=0)) / np.sqrt(len(pins))) if pins else None
    shares, throttles = [], []
    n = int(BASELINE_CHUNK_S * rate)
    for w_sq in blocks:
        for a in range(0, len(w_sq) - n + 1, n):
            sh, th = shares_of([w_sq[a:a + n]])
            shares.append(sh)
            throttles.append(th)
    slope = np.zeros(len(share))
    rng = (float(min(throttles)), float(max(throttles))) if throttles else (throttle, throttle)
    if len(throttles) >= 3 and rng[1] - rng[0] >= BASELINE_MIN_THROTTLE_RANGE:
        th = np.asarray(throttles) - throttle
        slope = (np.asarray(shares) - share).T @ th / float(th @ th)
    seconds = sum(len(b) for b in blocks) / rate
    return {"share": [float(x) for x in share], "slope": [float(x) for x in slope], "throttle_ref": float(throttle),
            "throttle_range": [rng[0], rng[1]], "seconds": round(float(seconds), 1),
            "source": "airborne mean of the thrust-command shares",
            "n_flights": len(per_flight) if per_flight is not None else len(flights),
            "spread": spread, "throttle_spread": throttle_spread,
            "pin": None if pin is None else [float(x) for x in pin]}
