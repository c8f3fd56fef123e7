"""Per-motor evidence a pilot can check, and whether it supports the model's verdict.

Inputs: the flight's resampled airborne segments (the same ones the NIF windows are cut from:
:attr:`flightlog_fd.features.Windows.segments`), the model's window probabilities, the rotor
layout, and optionally the calibration profile's healthy baseline.

Per motor it gives:

- **command share**: the motor's mean thrust command (the NIF ``ω²`` proxy) over the airborne
  time divided by the mean of all four (1.0 = an even share). Over a whole flight the mean
  angular acceleration is ~0, so the mean commands satisfy the same moment balance as a steady
  hover: the airborne mean is the trim pattern even when the flight never hovers.
- **command change**: with a profile, the share minus the profile's healthy baseline at this
  flight's throttle (:meth:`Baseline.share_at`); without one, the share minus the mean of the
  other three ("against its neighbours").
- **effectiveness**: :mod:`flightlog_fd.effectiveness` (relative angular acceleration per unit
  command, with its bootstrap interval; ``informative`` says whether the flight manoeuvred enough).
- **model vote**: the mean probability the model gave to "this motor's propeller is damaged".

Why a command pattern alone cannot name a motor, and what it can do
--------------------------------------------------------------------
In steady flight the four commands have four degrees of freedom (thrust, roll, pitch, yaw
moment), so a centre of mass off the middle (two ADJACENT motors high), a yaw trim or motor tilt
(a DIAGONAL pair high) and thrust-curve spread explain any pattern of means. What a damaged
propeller does that those do not is raise ONE motor alone: its excess over the second-highest
motor's (``single_motor_gap``). Measured on the airborne-mean shares of the ``../shared`` flights
(the same ones `benchmarks/bench_real_airframes.py` runs): 18 real healthy ArduCopter flights (``../shared/real_healthy``, Erle)
show a top excess of 0.05-0.33 and a gap of 0.00-0.21 (one odd flight, 6-3-2014_6, 0.51 with an
inconsistent effectiveness fit); PX4 SITL flights with one weak motor show gaps of 0.14-0.15 at
η = 0.9, 0.31-0.32 at η = 0.8 and 0.48-0.52 at η = 0.7 (healthy SITL: ≤ 0.002). So without a
profile a gap of ``NEIGHBOUR_MIN_GAP`` = 0.25 confirms damage from η ≈ 0.83 down and never fires
on those real healthy airframes; milder damage needs a profile, where the change against the
airframe's own baseline is compared (``PROFILE_MIN_CHANGE``: re-flights of one healthy airframe
move a share by ≤ 0.02, CrazyPAD E9 logs 01/02 against 00; η = 0.9 moves it by ~0.1).

The effectiveness estimate is a veto, not a trigger: on simulated flights at ≥ 50 Hz it recovers η
(rmse 0.05), but on the SITL set it fits with R² 0.1-0.2 (intervals ±0.2-0.7), and on real 10 Hz
RCOU logs a healthy motor read as low as 0.78 ± 0.06: it contradicts a named motor only when it
is informative AND that motor's interval lies above ``EFFECTIVENESS_HEALTHY_LOW``.

Airframe change (with a profile): when the shares moved against the baseline in a pattern that
is not one motor (:func:`single_motor_fit` leaves ``AIRFRAME_CHANGE_RESIDUAL`` or more), or the
throttle moved by
more than ``AIRFRAME_CHANGE_THROTTLE`` (a new battery type, payload, another propeller size), the
airframe is not the one calibrated: the report says so and advises re-calibrating.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .effectiveness import EffectivenessEstimate
from .features import DEFAULT_RATE_HZ
from .flight import Frame

#: Without a profile: a motor's excess over the second-highest motor's must reach this to be a
#: one-motor (damage) pattern rather than an airframe trim (see the module docstring).
NEIGHBOUR_MIN_GAP = 0.25
#: Without a profile, a one-motor gap this large is damage on its own ("overwhelming"), even when
#: the model's windows are undecided, provided the effectiveness fit is physically consistent (the
#: log's motor map and commands make sense): SITL η = 0.8 flights 0.31-0.32, η = 0.7 0.48-0.52;
#: the 18 real healthy Erle flights at most 0.21 (one at 0.51 whose effectiveness fit is
#: inconsistent: negative values, so its commands are not trusted).
NEIGHBOUR_OVERWHELMING_GAP = 0.30
#: With a profile, a one-motor rise this large against the calibrated baseline (and a change the
#: one-motor-plus-yaw fit explains) is damage on its own: healthy re-flights of one airframe move
#: a share by <= 0.02 (CrazyPAD E9 logs 01/02 against 00, SITL ~0.00); CrazyPAD 3 mm and 2+2 mm cuts
#: rise 0.05-0.07, a SITL η = 0.9 motor ~0.1.
PROFILE_OVERWHELMING_CHANGE = 0.05
#: With a profile: the named motor's share must have risen by this much against the baseline, in
#: the one-motor-plus-yaw fit (re-flights of one healthy airframe move a share by <= 0.02).
PROFILE_MIN_CHANGE = 0.04
#: An informative effectiveness interval wholly above this says the motor works like its neighbours.
EFFECTIVENESS_HEALTHY_LOW = 0.95
#: A fit with any motor below this is physically inconsistent (wrong motor map, saturation,
#: reconstructed commands): its numbers are shown but never used.
EFFECTIVENESS_SANE_MIN = 0.2
#: After a mid-flight onset, a rise of the motor's share between the first and last third of
#: the run larger than this fraction of its whole change is a drift, not a broken propeller
#: (real "healthy" Erle flight 11-2-2015_112: motor 2 climbs from 0.58 to 0.88 PWM over 40 s
#: before a hard landing; SITL steps: the share is flat after the onset).
ONSET_DRIFT_SHARE = 0.5
#: Flight before a mid-flight onset (s) that serves as the baseline when there is no profile.
MIN_BEFORE_ONSET_S = 10.0
#: With a profile: a change the one-motor-plus-yaw fit leaves this much of (L2 norm of the
#: residual share changes) is not one motor. Measured: CrazyPAD E9 3 mm cut on motor 2 against its
#: healthy log00: 0.028 (motor 2 +0.06, yaw re-trim +0.03); real healthy Erle flights whose
#: pattern shifted mid-flight (10-11-2014_104, 15-10-2014_42): 0.057, 0.062. Or ...
AIRFRAME_CHANGE_RESIDUAL = 0.04
#: ... the throttle moved by this fraction, means the airframe changed since calibration.
AIRFRAME_CHANGE_THROTTLE = 0.20


@dataclass
class Baseline:
    """A healthy airframe's command shares as a function of throttle (from a profile).

    ``share_at(c) = share + slope * (c - throttle_ref)``; ``slope`` is 0 when the calibration
    flights did not span enough throttle.
    """

    share: np.ndarray  # (4,)
    slope: np.ndarray  # (4,) per unit throttle
    throttle_ref: float
    source: str = ""

    def share_at(self, throttle: float) -> np.ndarray:
        out = self.share + self.slope * (throttle - self.throttle_ref)
        return out / out.mean()


@dataclass
class MotorEvidence:
    """One motor's figures (the report's per-motor panel)."""

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
class FlightEvidence:
    """All per-motor evidence of one flight and what it says."""

    motors: list[MotorEvidence]
    baseline: str  # "profile" | "before onset" | "neighbours"
    throttle: float
    top_motor: int  # 1-based motor the command change singles out (largest change / best one-motor fit)
    #: Against neighbours: its change minus the second-largest change. Against a baseline
    #: (profile, before onset): its own rise in the one-motor-plus-yaw fit (single_motor_fit).
    single_motor_gap: float
    effectiveness: Optional[EffectivenessEstimate] = None
    airframe_changed: Optional[str] = None  # why, when it did
    notes: list[str] = field(default_factory=list)
    #: Since a mid-flight onset the other three motors moved apart too: not one motor changing.
    not_one_motor: bool = False
    #: Since a mid-flight onset: the top motor's share change from the first to the last third of
    #: the run (a broken propeller is a step: ~0; a motor, ESC or mount degrading drifts).
    onset_drift: Optional[float] = None

    def drifting(self, motor: int) -> bool:
        """The named motor's command rose steadily after the onset rather than in one step."""
        if self.onset_drift is None or self.top_motor != motor:
            return False
        change = self.motors[motor - 1].command_change
        return change > 0 and self.onset_drift > ONSET_DRIFT_SHARE * change

    @property
    def effectiveness_usable(self) -> bool:
        e = self.effectiveness
        return bool(e is not None and e.informative and np.all(e.values > EFFECTIVENESS_SANE_MIN))

    def pattern_supports(self, motor: int) -> bool:
        """The command pattern is one motor high, and it is ``motor`` (a step, not a drift)."""
        if self.top_motor != motor or self.not_one_motor or self.drifting(motor):
            return False
        if self.baseline in ("profile", "before onset"):
            # both the yaw-corrected rise and the raw change: a yaw re-trim alone never names a motor
            return (self.single_motor_gap >= PROFILE_MIN_CHANGE
                    and self.motors[motor - 1].command_change >= PROFILE_MIN_CHANGE)
        return self.single_motor_gap >= NEIGHBOUR_MIN_GAP

    @property
    def effectiveness_consistent(self) -> bool:
        """The effectiveness fit exists and no motor reads below ``EFFECTIVENESS_SANE_MIN``."""
        e = self.effectiveness
        return bool(e is not None and e.motors and np.all(np.isfinite(e.values))
                    and np.all(e.values > EFFECTIVENESS_SANE_MIN))

    def overwhelming(self) -> Optional[int]:
        """The motor the commands alone single out beyond doubt (no profile needed), or None."""
        if self.effectiveness_contradicts(self.top_motor) or self.airframe_changed or self.not_one_motor:
            return None
        if (self.baseline == "neighbours" and self.single_motor_gap >= NEIGHBOUR_OVERWHELMING_GAP
                and self.effectiveness_consistent):
            return self.top_motor
        if (self.baseline == "profile" and self.single_motor_gap >= PROFILE_OVERWHELMING_CHANGE
                and self.motors[self.top_motor - 1].command_change >= PROFILE_OVERWHELMING_CHANGE):
            return self.top_motor
        return None

    def effectiveness_contradicts(self, motor: int) -> bool:
        """An informative estimate says ``motor`` is as effective as its neighbours."""
        if not self.effectiveness_usable:
            return False
        lo, _ = self.effectiveness.motors[motor - 1].ci
        return lo > EFFECTIVENESS_HEALTHY_LOW

    def summary(self, motor: int) -> str:
        """Plain words for one motor, e.g. for the verdict's reason."""
        m = self.motors[motor - 1]
        if self.baseline in ("profile", "before onset"):
            against = "calibration" if self.baseline == "profile" else "before the onset"
            words = (f"needs {100 * m.command_change / max(m.command_share_baseline or 1.0, 1e-9):+.0f} % command "
                     f"share against {against} (share {m.command_share:.3f}, baseline {m.command_share_baseline:.3f})")
        else:
            words = f"runs {100 * m.command_change:+.0f} % command share against its neighbours"
        if m.effectiveness is not None and self.effectiveness_usable:
            lo, hi = m.effectiveness_ci
            words += f", effectiveness {m.effectiveness:.2f} [{lo:.2f}, {hi:.2f}] of its neighbours'"
        return words


def _spins(frame: Optional[Frame]) -> np.ndarray:
    frame = frame if frame is not None and frame.is_quad else Frame.quad_x()
    return np.array([float(r.spin) for r in frame.rotors])


def single_motor_fit(change: np.ndarray, spins: np.ndarray) -> tuple[int, float, float]:
    """Explain a share change (4,) as one motor k rising by ``a`` (the others falling by a/4 each,
    after normalisation) plus a yaw re-trim ``b`` along the rotor spins; returns the best k
    (1-based, smallest residual among rising fits), its ``a`` and the residual's L2 norm."""
    c = np.nan_to_num(np.asarray(change, dtype=np.float64))
    y = spins - spins.mean()
    best = (1, 0.0, float("inf"))
    for k in range(4):
        v = -0.25 * np.ones(4)
        v[k] += 1.0
        A = np.stack([v, y], axis=1)
        coef, *_ = np.linalg.lstsq(A, c, rcond=None)
        resid = float(np.linalg.norm(c - A @ coef))
        if coef[0] > 0 and resid < best[2]:
            best = (k + 1, float(coef[0]), resid)
    if not np.isfinite(best[2]):
        best = (int(np.argmax(c)) + 1, 0.0, float(np.linalg.norm(c - c.mean())))
    return best


def command_shares(thrust_blocks: Sequence[np.ndarray]) -> tuple[np.ndarray, float]:
    """(4,) mean thrust-command shares (mean 1) over the (n, 4) blocks of the thrust proxy
    (e.g. each segment's ``w_sq``), and the mean thrust command (throttle)."""
    blocks = [np.asarray(b, dtype=np.float64) for b in thrust_blocks if len(b)]
    u = np.vstack(blocks) if blocks else np.zeros((0, 4))
    if u.shape[0] == 0:
        return np.full(4, np.nan), float("nan")
    mean = u.mean(axis=0)
    throttle = float(mean.mean())
    return (mean / throttle if throttle > 0 else np.full(4, np.nan)), throttle


def build_evidence(segments: Sequence, probs: np.ndarray, frame: Optional[Frame],
                   effectiveness: Optional[EffectivenessEstimate] = None,
                   baseline: Optional[Baseline] = None, since: Optional[float] = None) -> FlightEvidence:
    """Per-motor evidence (see module docstring). ``probs`` (N, 5) window probabilities.

    ``since``: the model's damage onset (s, log clock) when it lies mid-flight: the shares are then
    taken from the onset on, and without a profile the flight before the onset (at least
    ``MIN_BEFORE_ONSET_S`` of it) is the baseline - the same airframe, healthy, minutes earlier.
    """
    onset_drift = None
    if since is not None:
        before = [s.w_sq[s.t < since] for s in segments]
        after = [s.w_sq[s.t >= since] for s in segments]
        onset_drift = _drift(after)
        if baseline is None and sum(len(b) for b in before) / DEFAULT_RATE_HZ >= MIN_BEFORE_ONSET_S:
            pre, pre_thr = command_shares(before)
            baseline = Baseline(share=pre, slope=np.zeros(4), throttle_ref=pre_thr, source="before onset")
        share, throttle = command_shares(after)
    else:
        share, throttle = command_shares([s.w_sq for s in segments])
    probs = np.asarray(probs, dtype=np.float64)
    votes = probs[:, 1:].mean(axis=0) if probs.size else np.zeros(4)
    notes: list[str] = []
    airframe_changed = None
    not_one_motor = False
    if baseline is not None:
        base = baseline.share_at(throttle)
        change = share - base
        # Against a baseline, a broken propeller is ONE motor rising (the other three's normalised
        # shares fall equally) plus, because it loses drag torque in another proportion than
        # thrust, a yaw re-trim (the CW pair against the CCW pair). single_motor_fit explains the
        # change that way; what it cannot explain is the airframe itself changing.
        spins = _spins(frame)
        fit_motor, rise, resid = single_motor_fit(change, spins)
        reasons = []
        if resid >= AIRFRAME_CHANGE_RESIDUAL:
            reasons.append("the motors' command shares moved in a pattern that is not one motor: " + ", ".join(
                f"motor {i + 1} {100 * change[i]:+.0f} %" for i in range(4)))
        if baseline.throttle_ref > 0 and abs(throttle / baseline.throttle_ref - 1.0) > AIRFRAME_CHANGE_THROTTLE:
            reasons.append(f"the throttle is {100 * (throttle / baseline.throttle_ref - 1.0):+.0f} % against "
                           f"calibration ({throttle:.2f} vs {baseline.throttle_ref:.2f}: weight, battery or propellers changed)")
        kind = "before onset" if baseline.source == "before onset" else "profile"
        if reasons and kind == "profile":
            airframe_changed = "; ".join(reasons)
        elif kind == "before onset" and resid >= AIRFRAME_CHANGE_RESIDUAL:
            notes.append("since the onset the other motors moved in a pattern that is not one motor")
            not_one_motor = True
        top, gap = fit_motor, rise
    else:
        base = None
        change = np.array([share[i] - np.delete(share, i).mean() for i in range(4)])
        kind = "neighbours"
        order = np.argsort(-np.nan_to_num(change, nan=-np.inf))
        top = int(order[0]) + 1
        gap = float(change[order[0]] - change[order[1]]) if np.all(np.isfinite(change)) else 0.0

    motors = []
    for i in range(4):
        eff = ci = None
        if effectiveness is not None and effectiveness.motors:
            me = effectiveness.motors[i]
            eff, ci = me.effectiveness, me.ci
        motors.append(MotorEvidence(
            motor=i + 1, position=frame.position(i + 1) if frame is not None else None,
            command_share=float(share[i]), command_share_baseline=None if base is None else float(base[i]),
            command_change=float(change[i]), effectiveness=eff, effectiveness_ci=ci, model_vote=float(votes[i])))
    if effectiveness is not None and not effectiveness.informative:
        notes.append(f"effectiveness: {effectiveness.reason}")
    elif effectiveness is not None and not np.all(effectiveness.values > EFFECTIVENESS_SANE_MIN):
        notes.append("effectiveness: the fit is physically inconsistent (a motor below "
                     f"{EFFECTIVENESS_SANE_MIN}); not used")
    drift = None
    if onset_drift is not None and np.isfinite(onset_drift[top - 1]):
        drift = float(onset_drift[top - 1])
    return FlightEvidence(motors=motors, baseline=kind, throttle=throttle, top_motor=top, single_motor_gap=gap,
                          effectiveness=effectiveness, airframe_changed=airframe_changed, notes=notes,
                          not_one_motor=not_one_motor, onset_drift=drift)


def _drift(blocks: Sequence[np.ndarray]) -> np.ndarray:
    """(4,) change of each motor's share from the first to the last third of the samples in
    ``blocks`` (time order): ~0 after a step (a propeller breaks once), large for a steady rise."""
    u = np.vstack([np.asarray(b, float) for b in blocks if len(b)]) if any(len(b) for b in blocks) else np.zeros((0, 4))
    if len(u) < 3 * DEFAULT_RATE_HZ:  # under 3 s after the onset: nothing to compare
        return np.full(4, np.nan)
    n = len(u) // 3
    first, last = u[:n].mean(axis=0), u[-n:].mean(axis=0)
    return last / last.mean() - first / first.mean()
