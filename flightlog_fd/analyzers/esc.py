"""ESC analyzer: does one motor turn faster or slower than its command asks, and draw too little current?

What: per motor, from ESC telemetry (``Flight.esc``) and the motor commands over the airborne
time, two relations, each judged against the airframe's own healthy curve at the motor's own
command (natural log, reported in %):

- **rpm per command** ``a_k``: the airframe's rpm-versus-command curve ``log rpm = c + b·log
  sqrt(thrust command)`` (``streams.flight_thrust_proxy`` makes the command linear in thrust as the
  autopilot models it) is the same for healthy motors, and its exponent ``b`` is the airframe's:
  1 when the autopilot's thrust model fits the rotor, 1.33 on ArduCopter 4.7 SITL (MOT_THST_EXPO
  0.65 over a motor whose speed is linear in its signal), near 2 for PX4's THR_MDL_FAC 0 over such
  a motor. ``b`` is fitted on the flight itself, from every motor's own changes of command over
  time (climbs, descents, manoeuvres; the command shifted by the motor's and ESC's lag, searched on
  ``LAG_GRID_S``; a common level and trend per ``TREND_PIECE_S`` absorbs what moves every motor
  alike: battery voltage, temperature, air density); with a profile, pooled with the calibration
  flights' ``b``. ``a_k`` is motor k's level on that curve against the other motors' level: how
  much faster (up) or slower (down) it turns than a healthy motor would at **its** command. A
  lighter (cut, chipped) propeller loads its motor less, so it turns faster: ``a_k`` up (a little:
  the load droop it no longer suffers). A weak motor or ESC delivers less speed: ``a_k`` down. A
  moved load, a trim change or a weight in the wash moves the command and the rpm together
  **along** the curve: ``a_k`` stays. (Against the other motors at a fixed ``b = 1``, a moved load
  on ArduCopter SITL read as a cut propeller: motor 1's command and rpm both rose, 13,551 against
  11,666 rpm, and ``b`` is 1.33 there.)
- **current per rpm²** ``d_k``: ``log current = e + γ·log rpm²`` likewise (γ fitted the same way,
  no lag: both come from one ESC report; physics γ ≈ 1, torque ∝ rpm²). The lost blade area loses
  drag torque: ``d_k`` goes **down**; a weak motor's propeller keeps its torque per rpm² (0).

The slope's own uncertainty (jackknife over ``N_BLOCKS`` time blocks, with its physics prior) counts
in each motor's offset in proportion to how far the motor's command sits from the others' (its
``lever``): a moved load that takes one motor far from the rest on a flight whose commands barely
varied makes that motor's offset uncertain, not a finding. Both relations use 1 s bin means of the
airborne time (``BIN_S``; each ESC on its own samples, never interpolated; a bin in which any
motor's ESC is silent is skipped), each motor against a robust (Huber) level of the other motors
(one rotor far off does not move the others' reference).

Score: ``r_k = (a_k, d_k)`` is Gaussian around 0 for a healthy motor with covariance ``Σ`` =
motor-to-motor spread (``HEALTHY_SPREAD_COV``, without a profile; with one, the profile's own
flight-to-flight spread) + the measurement's uncertainty. Three causes of lost thrust move its mean
(:data:`~.base.CAUSES`): the propeller by ``ℓ·DAMAGE_DIRECTION`` (ℓ = -m·log η, the torque lost),
the motor or ESC by ``ℓ·MOTOR_DIRECTION`` (ℓ = -log η), something in the wash not at all (the
rotor turns and loads its motor as a healthy one: the ESC cannot see it). Per motor and per η of
``command_shares.ETA_GRID``: ``cause_ll_eta`` the log Bayes factor of each cause at that η against
healthy (propeller averaged over the drag exponents ``M_GRID``; wash 0); ``cause_ll`` each averaged
over the uniform η prior; ``eta_llrs`` "rotor k gives η of its thrust" against healthy, the causes
weighed by ``CAUSE_PRIOR``; ``decision_llr`` (the ``esc_damage`` finding's weight) that averaged
over η. It goes negative where a motor's relations sit where a healthy one's do (down to
log P(wash), the ESC cannot clear a loss it cannot see). ``llr`` is the one-sided generalised LLR
along the damage direction, ``(μᵀΣ⁻¹r)² / (2 μᵀΣ⁻¹μ)``: it names a motor
(:meth:`EscAnalysis.motor_named`). Without current telemetry only ``a_k`` is used, and a current
that never changes (a simulator's placeholder, an ESC without current sense that reports a fixed
value) is no current telemetry.

Inputs: a :class:`~flightlog_fd.flight.Flight` with ``esc`` (rpm for every motor; current
optional), ``motors`` and ``airborne``; optionally an :class:`EscBaseline` from healthy flights
of the same airframe (:func:`fit_esc_baseline`). Limits: needs ``MIN_BINS`` usable seconds with
every motor reporting at ``MIN_RATE_HZ`` or more, else it abstains and says why; an ESC that
regulates speed in closed loop (some AM32/BLHeli modes) hides the rpm lift, and the current
relation then carries the evidence; a healthy propeller that is simply lighter than its
neighbours looks like mild damage (that spread is in ``HEALTHY_SPREAD_COV``); the curve is a power
law, so a motor whose command sits far from the others' (a weak motor needing 1.8 times the
thrust command) reads its offset through an extrapolation (ArduCopter SITL: -32 % at the fitted
exponent, -25 % at 1); a pack that sags with the throttle (rpm per command ∝ voltage on an
open-loop ESC) lowers the fitted exponent (a 5 % sag over the flight's throttle range: about 0.1).

Constants are measured on simulated flights (``python benchmarks/bench_esc.py --measure``) and the
genuine ArduCopter SITL logs: there is no real log with ESC telemetry from a real airframe in
../shared (its only ``esc_status`` log, sample_px4_events.ulg, is a Gazebo SITL flight at 4 Hz with
identical simulated motors), so the motor-to-motor spread below is the simulator's (sim/esc.py: KV
spread σ 1.5 %, current-sense gain σ 1 % and offset 2 % of hover current; sim/imbalance.py:
propeller torque-coefficient spread σ 3 % × severity). Real fleets may spread more: measure one.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..flight import Flight
from .base import CAUSE_PRIOR, CAUSES, Analyzer, AnalyzerResult, Context, Finding

ANALYZER_ID = "esc"
#: The abstention of a log without ESC telemetry.
NO_ESC = "no ESC telemetry in this log"
#: Bin length (s) of the means the relations are fitted on: ESC latency (up to one report
#: interval, 10-100 ms) and motor lag (15-80 ms) stay small against it.
BIN_S = 1.0
#: Seconds dropped after take-off and before landing (spin-up and ground effect).
AIRBORNE_TRIM_S = 2.0
#: Every motor's ESC must report at least this fast (two reports per bin).
MIN_RATE_HZ = 2.0
#: Usable bins (seconds) needed to say anything.
MIN_BINS = 15
#: Bins in which a motor's thrust command is below this (idle, spin-up) are skipped.
MIN_COMMAND = 0.05
#: Bins in which any motor's command reaches this (of full thrust) are skipped: a saturated motor
#: cannot turn faster, so it sits below the rotors' curve there (simulated x500 with 15 % of its
#: mass toward rotor 1: that rotor at full command 2 % of the time read -2.5 % rpm per command).
SATURATED_COMMAND = 0.98
#: Time blocks for the measurement uncertainty of each offset and the jackknife of each slope.
N_BLOCKS = 6
#: Delays (s) of the rotor speed behind the command searched when fitting the rpm curve: the ESC
#: reports up to one interval late (100 ms at 10 Hz) and the motor lags 15-80 ms. Unaligned, the
#: 1 s bins of a manoeuvring flight attenuate the fitted exponent (0.88-0.92 for a true 1 at 10 Hz
#: on simulated flights, 0.97-1.0 aligned; /tmp prototype, results/cause.md).
LAG_GRID_S = tuple(np.round(np.arange(0.0, 0.25, 0.02), 3))
#: What moves every motor's rpm per command alike (the pack's voltage on an open-loop ESC, motor
#: temperature, air density) is absorbed by a common level and linear trend per piece of this
#: length (s) of each airborne stretch, so only the commands' own changes fit the exponent.
TREND_PIECE_S = 60.0
#: Physics priors of the slopes and their spread. rpm: b = 1 when the autopilot's thrust model fits
#: the rotor, up to about 2 (PX4 THR_MDL_FAC 0 over a motor whose speed is linear in its signal),
#: 1.31-1.34 measured on ArduCopter 4.7 SITL; the prior (1 ± 0.5) only matters on a flight whose
#: commands barely vary. Current: γ = 1 (torque ∝ rpm²) less the no-load current's share
#: (4 % of hover current in the simulator: 0.96); ± 0.1.
RPM_SLOPE_PRIOR = 1.0
RPM_SLOPE_PRIOR_STD = 0.5
CURRENT_SLOPE_PRIOR = 1.0
CURRENT_SLOPE_PRIOR_STD = 0.1
#: Healthy motor-to-motor covariance of (a_k, d_k) relative to the other motors, natural-log
#: units. Measured: `bench_esc.py --measure --per-cell 8 --seed 99` on 32 simulated healthy
#: flights (128 motors; random airframes 30 g-5 kg, realistic imbalance, 10 and 50 Hz ESC):
#: std a 1.19 %, d 3.30 %, correlation +0.31 (a KV spread moves both up; a light healthy
#: propeller moves them apart like damage, and is the floor of what a flight alone can tell).
#: Against the robust level of the others (ROBUST_LEVEL_K) the same run gives std a 1.20 %, d
#: 3.34 %, +0.32; trim change 0.38 % / 0.59 %; damage direction +0.074 / -0.973; largest healthy
#: llr 4.4 (p99 4.0): every constant here holds within its last digit. With the rpm curve's
#: exponent fitted on each flight (`--measure --per-cell 8 --seed 99`, results/cause.md): std a
#: 1.43 %, d 3.33 %, +0.35; the rpm offsets now carry the fitted exponent's error, which the
#: analyzer adds per motor from its lever and the slope's sd, so the constant stays the spread at a
#: known curve; largest healthy llr 4.1 (p99 3.8), 0/48 healthy and trim-changed flights named.
HEALTHY_SPREAD_STD = (0.0119, 0.0330)
HEALTHY_SPREAD_CORR = 0.31
HEALTHY_SPREAD_COV = ((HEALTHY_SPREAD_STD[0] ** 2, HEALTHY_SPREAD_CORR * HEALTHY_SPREAD_STD[0] * HEALTHY_SPREAD_STD[1]),
                      (HEALTHY_SPREAD_CORR * HEALTHY_SPREAD_STD[0] * HEALTHY_SPREAD_STD[1], HEALTHY_SPREAD_STD[1] ** 2))
#: Each motor's offsets are taken against a robust level of the other motors (_against_others):
#: Huber's location with this tuning constant, in healthy spreads (HEALTHY_SPREAD_STD): 1.345
#: keeps 95 % of the mean's efficiency on Gaussian data (Huber 1964), and a motor far off weighs
#: as if it were 1.345 spreads away.
ROBUST_LEVEL_K = 1.345
ROBUST_LEVEL_ITERATIONS = 50
#: A profile's flight-to-flight spread is never taken below this std (a, d). Measured (same
#: `--measure` run): 16 airframes flown twice with the same motors and ESCs, the second time
#: with the CoG moved 4-10 % of the arm or the yaw trim changed by 0.5-1 deg of motor tilt:
#: std of the change a 0.35 %, d 0.59 %. (With the exponent fitted on each flight the change of a is
#: 1.24 %: the exponent's error times the command's move; against a profile both flights are taken
#: at one pooled exponent and that term is added from the levers, 0/16 named, largest llr 1.3.)
PROFILE_SPREAD_FLOOR = (0.0035, 0.0059)
#: Offset per unit of lost torque ℓ = -log η_torque, (a, d). Measured (same run, 64 damaged
#: flights, η 0.6-0.9): median a/ℓ +0.073 (the motor's load droop at hover), d/ℓ -0.968 (d
#: follows the torque; the no-load current keeps it just short of 1).
DAMAGE_DIRECTION = (0.073, -0.968)
#: Per-motor llr (nats) above which :meth:`EscAnalysis.motor_named` names a motor: 6 nats is a
#: healthy motor 3.5 standard deviations along the damage direction (2e-4 per motor if the
#: spread were Gaussian). The `--measure` run's largest healthy llr: 4.5 nats (48 healthy and
#: trim-changed flights, no profile; p99 4.0).
DECISION_LLR = 6.0
#: Offset per unit of lost thrust per command ℓ = -log η of a weak motor or ESC, (a, d). Physics:
#: a drive that delivers sqrt(η) of the speed gives a = ½ log η (-0.5 per unit ℓ), less the load
#: droop the slower rotor no longer suffers; its propeller's torque per rpm² is unchanged (d 0).
#: Measured (`bench_esc.py --measure --per-cell 8 --seed 99`, sim/damage.py cause "motor", η
#: 0.6-0.9, 10 and 50 Hz ESC, 32 flights): median a/ℓ -0.459 (10-90 % -0.549..-0.378), d/ℓ -0.025;
#: 48 more flights at 10/50/100 Hz (seed 99, another draw): -0.455 and +0.025, so d is 0 within
#: the run-to-run spread. ArduCopter 4.7 SITL, SIM_ENGINE_MUL=0.75 (motor1_weak_esc.BIN): a =
#: -0.285 at ℓ = 0.575 against a curve of exponent 1, -0.50 per unit.
MOTOR_DIRECTION = (-0.46, 0.0)
#: A damaged propeller's drag-torque coefficient falls as its thrust coefficient to these powers
#: (the points of command_shares.M_GRID from 1): blade-element theory gives D^5 against D^4 for a
#: shortened blade (1.25), chips and tape up to 1.6 (sim/damage.py TORQUE_EXPONENT_RANGE). The
#: commands' lower exponents (0.25-0.75) come from the motor spinning faster at the same command,
#: which the ESC measures apart (rpm per command), not from the propeller's torque per rpm²: with
#: them a propeller at eta 0.7 could explain a current per rpm² 7 % low (a healthy spread of 2),
#: and a moved load whose commands read eta 0.7 drew P(propeller) 0.78 (bench_esc.py --loads).
MIN_DRAG_EXPONENT = 1.0


@dataclass(frozen=True)
class EscFigure:
    """One per-motor figure of :func:`analyze_esc` (the registry's :class:`Esc` turns them into
    :class:`~flightlog_fd.analyzers.base.Finding` s).

    ``value`` and ``interval`` (90 %) in ``unit``; ``baseline`` what a healthy motor shows (the
    other motors: 0 %, or the profile's value); ``direction`` "up"/"down": where damage moves
    ``value``; ``llr`` the evidence (nats) for "this rotor lost thrust" vs healthy carried by
    this figure (the ``esc_damage`` finding carries the combined one); ``abstain``: why the
    analyzer could not say anything (then value/interval are NaN and llr 0)."""

    analyzer: str
    motor: int
    name: str
    value: float
    unit: str
    interval: tuple[float, float]
    baseline: Optional[float]
    direction: str
    llr: float
    abstain: Optional[str] = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["interval"] = list(self.interval)
        return d


@dataclass
class EscBaseline:
    """A profile's healthy ESC relations: per motor (a_k, d_k) (log offsets against the other
    motors, at the slopes ``slopes``) and their flight-to-flight covariance (2x2, at least
    PROFILE_SPREAD_FLOOR); ``slopes`` (b, sd b, γ, sd γ) the calibration's curves (None: a profile
    from before the curves were fitted, whose offsets were taken at b = γ = 1 and cannot be moved
    to another slope); ``levers`` per motor (x, z): its mean log sqrt command and log rpm² against
    the others' at calibration (how its offsets move with the slopes)."""

    offsets: list[tuple[float, float]]
    cov: list[list[float]]
    flights: list[str] = field(default_factory=list)
    has_current: bool = True
    slopes: Optional[tuple[float, float, float, float]] = None
    levers: Optional[list[tuple[float, float]]] = None

    def to_dict(self) -> dict:
        return {"analyzer": ANALYZER_ID, "offsets": [list(o) for o in self.offsets], "cov": self.cov,
                "flights": list(self.flights), "has_current": self.has_current,
                "slopes": None if self.slopes is None else list(self.slopes),
                "levers": None if self.levers is None else [list(v) for v in self.levers]}

    @classmethod
    def from_dict(cls, d: dict) -> "EscBaseline":
        slopes = d.get("slopes")
        levers = d.get("levers")
        return cls([tuple(o) for o in d["offsets"]], [list(r) for r in d["cov"]], list(d.get("flights", [])),
                   bool(d.get("has_current", True)), None if slopes is None else tuple(float(x) for x in slopes),
                   None if levers is None else [tuple(float(x) for x in v) for v in levers])


@dataclass
class EscAnalysis:
    """What :func:`analyze_esc` found: ``findings`` (per motor: ``rpm_per_command``,
    ``current_per_rpm2``, ``esc_damage``), ``llr`` per motor (nats), ``abstain`` (None or why),
    ``against`` ("other motors" / "profile", with why a profile's baseline was not used), usable
    ``bins`` (s), fitted ``slopes`` (and their ``slope_sd``, the command lag)."""

    findings: list[EscFigure]
    llr: dict[int, float]
    abstain: Optional[str] = None
    against: str = "other motors"
    bins: int = 0
    slopes: dict = field(default_factory=dict)
    #: Per motor, the log Bayes factor (nats) of "rotor k lost thrust" (to any of CAUSES, weighed by
    #: CAUSE_PRIOR, η over its uniform prior) against healthy: what the decision sums (the
    #: ``esc_damage`` finding's llr). Negative where the relations sit where a healthy motor's do.
    decision_llr: dict[int, float] = field(default_factory=dict)
    #: Per motor, the log Bayes factor (nats) of "its motor or ESC lost the thrust" against "its
    #: propeller did", each loss averaged over its prior (positive: the motor / ESC).
    cause_llr: dict[int, float] = field(default_factory=dict)
    #: Per motor, {cause: log Bayes factor (nats) of "rotor k lost thrust to this cause" against
    #: healthy}, η averaged over its uniform prior on command_shares.ETA_GRID ("wash": 0, the ESC
    #: sees a rotor that lost thrust in its wash as healthy).
    cause_ll: dict[int, dict[str, float]] = field(default_factory=dict)
    #: Per motor, {cause: (len(ETA_GRID),) the same at each η}: the cause judgement weighs it by
    #: what the commands say of η (:mod:`flightlog_fd.cause`).
    cause_ll_eta: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)
    #: Per motor, (len(ETA_GRID),) "rotor k gives η of its thrust" against healthy, the causes
    #: weighed by CAUSE_PRIOR (the result's ``eta_llrs``, which the decision integrates over η).
    eta_llr: dict[int, np.ndarray] = field(default_factory=dict)

    def motor_named(self, threshold: float = DECISION_LLR) -> Optional[int]:
        """The motor whose llr is largest and above ``threshold`` (None: nothing named)."""
        if self.abstain or not self.llr:
            return None
        k = max(self.llr, key=self.llr.get)
        return k if self.llr[k] > threshold else None


@dataclass
class _Measurement:
    r: np.ndarray  # (M, 2) offsets a, d against the others' robust level (d NaN without current)
    cov: np.ndarray  # (M, 2, 2) measurement covariance of r from the time blocks (slopes held)
    has_current: bool
    bins: int
    slopes: dict
    slope_sd: np.ndarray  # (2,) sd of the rpm and current slopes (prior included)
    lever: np.ndarray  # (M, 2) each motor's mean log sqrt command / log rpm² against the others'

    def slope_pair(self) -> np.ndarray:
        """(b, γ) as fitted (γ NaN without current)."""
        return np.array([self.slopes["log_rpm_per_log_sqrt_command"],
                         self.slopes.get("log_current_per_log_rpm2", np.nan)])


# ----------------------------------------------------------------------------- measurement


def _bin_edges(airborne: list[tuple[float, float]]) -> np.ndarray:
    edges = []
    for a, b in airborne:
        a, b = a + AIRBORNE_TRIM_S, b - AIRBORNE_TRIM_S
        n = int(np.floor((b - a) / BIN_S))
        if n >= 1:
            edges.append(a + BIN_S * np.arange(n + 1))
    return edges


def _bin_means(t: np.ndarray, v: np.ndarray, edges_list: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(sums / counts, counts) of ``v`` over the bins of every airborne piece, concatenated."""
    means, counts = [], []
    for edges in edges_list:
        i = np.searchsorted(edges, t, side="right") - 1
        ok = (i >= 0) & (i < edges.size - 1) & np.isfinite(v)
        n = np.bincount(i[ok], minlength=edges.size - 1).astype(float)
        s = np.bincount(i[ok], weights=v[ok], minlength=edges.size - 1)
        means.append(np.divide(s, n, out=np.full(n.size, np.nan), where=n > 0))
        counts.append(n)
    return np.concatenate(means), np.concatenate(counts)


def _bin_pieces(edges_list: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(piece id, centre time) of every bin: a piece is at most TREND_PIECE_S of one airborne stretch."""
    piece, mid, base = [], [], 0
    for edges in edges_list:
        c = 0.5 * (edges[1:] + edges[:-1])
        p = np.floor((c - edges[0]) / TREND_PIECE_S).astype(int)
        piece.append(base + p)
        mid.append(c)
        base += int(p.max()) + 1
    return np.concatenate(piece), np.concatenate(mid)


def _constant(x: np.ndarray) -> bool:
    """True when every finite sample of ``x`` has one value (or there is none)."""
    x = x[np.isfinite(x)]
    return x.size == 0 or bool(np.all(x == x[0]))


def _airborne(t: np.ndarray, airborne: list[tuple[float, float]]) -> np.ndarray:
    """Mask of the times inside the airborne intervals."""
    out = np.zeros(t.shape, dtype=bool)
    for a, b in airborne:
        out |= (t >= a) & (t <= b)
    return out


def _bin_noise(t: np.ndarray, v: np.ndarray, edges_list: list[np.ndarray]) -> np.ndarray:
    """Sampling variance of each bin's mean of ``v`` in log units: half the mean squared successive
    difference of its samples (the fast part of the signal, which a few samples per bin catch at
    random: PX4's default log has the commands at 10 Hz), over the count and the mean squared."""
    out = []
    for edges in edges_list:
        i = np.searchsorted(edges, t, side="right") - 1
        ok = (i >= 0) & (i < edges.size - 1) & np.isfinite(v)
        nb = edges.size - 1
        n = np.bincount(i[ok], minlength=nb).astype(float)
        s = np.bincount(i[ok], weights=v[ok], minlength=nb)
        same = ok[1:] & ok[:-1] & (i[1:] == i[:-1])
        d2 = np.diff(v)[same] ** 2
        nd = np.bincount(i[1:][same], minlength=nb).astype(float)
        sd2 = np.bincount(i[1:][same], weights=d2, minlength=nb)
        mean = np.divide(s, n, out=np.full(nb, np.nan), where=n > 0)
        var = np.divide(sd2, 2.0 * nd, out=np.zeros(nb), where=nd > 0)
        out.append(np.divide(var, n * mean * mean, out=np.full(nb, np.nan), where=(n > 0) & (mean > 0)))
    return np.concatenate(out)


def _curve_fit(y: np.ndarray, x: np.ndarray, piece: np.ndarray, t: np.ndarray,
               noise: Optional[np.ndarray] = None) -> tuple[float, float]:
    """Common slope of ``y`` on ``x`` ((B, M) bin means) with a level per motor and a level and
    linear trend per piece of time (``piece``, ``t`` (B,)), least squares: (slope, residual sum of
    squares of the plain fit). Every motor's own changes over time fit the slope; what moves all
    motors alike at once within a piece's trend does not. ``noise`` (B, M): the sampling variance of
    each ``x``, taken out of its spread (errors in variables: a bin mean of 10 command samples
    scatters about the mean the rotor follows, which flattens the plain slope, 0.83-0.87 for a true
    1 on a 45 s simulated PX4 default log), at most halving it."""
    b_, m = x.shape
    cols = [np.tile(np.eye(m), (b_, 1))]
    pieces = np.unique(piece)
    for j, p in enumerate(pieces):
        sel = piece == p
        if j:
            cols.append(np.repeat(sel.astype(float), m)[:, None])
        tt = np.where(sel, t - t[sel].mean(), 0.0)
        if np.any(tt):
            cols.append(np.repeat(tt, m)[:, None])
    nuisance = np.hstack(cols)
    both = np.column_stack([x.reshape(-1), y.reshape(-1)])
    coef, *_ = np.linalg.lstsq(nuisance, both, rcond=None)
    xr, yr = (both - nuisance @ coef).T  # x and y with every nuisance term taken out (Frisch-Waugh)
    sxx, sxy = float(xr @ xr), float(xr @ yr)
    if sxx <= 0:
        return 0.0, float(yr @ yr)
    plain = sxy / sxx
    ss = float(np.sum((yr - plain * xr) ** 2))
    if noise is not None:
        sxx = max(sxx - float(np.nansum(noise)), 0.5 * sxx)
    return sxy / sxx, ss


def _slope(y: np.ndarray, x: np.ndarray, piece: np.ndarray, t: np.ndarray, prior: float,
           prior_sd: float, noise: Optional[np.ndarray] = None) -> tuple[float, float]:
    """(slope, sd): :func:`_curve_fit`'s slope with its jackknife sd over N_BLOCKS contiguous time
    blocks, combined with the physics prior (``prior`` ± ``prior_sd``)."""
    full, _ = _curve_fit(y, x, piece, t, noise)
    blocks = np.array_split(np.arange(x.shape[0]), N_BLOCKS)
    loo = []
    for blk in blocks:
        keep = np.ones(x.shape[0], dtype=bool)
        keep[blk] = False
        loo.append(_curve_fit(y[keep], x[keep], piece[keep], t[keep], None if noise is None else noise[keep])[0])
    loo = np.array(loo)
    var = (N_BLOCKS - 1) / N_BLOCKS * float(np.sum((loo - loo.mean()) ** 2))
    var = max(var, 1e-8)
    w_data, w_prior = 1.0 / var, 1.0 / prior_sd ** 2
    return (w_data * full + w_prior * prior) / (w_data + w_prior), float(np.sqrt(1.0 / (w_data + w_prior)))


def _robust_level(x: np.ndarray, scale: float) -> np.ndarray:
    """Huber's location of each row of ``x`` (rows of the other motors' intercepts) with the
    healthy spread ``scale``: the mean while the values sit within ``ROBUST_LEVEL_K`` spreads of
    each other, a value beyond counting as if it were that far (start: the median)."""
    mu = np.median(x, axis=-1)
    for _ in range(ROBUST_LEVEL_ITERATIONS):
        step = np.clip(x - mu[..., None], -ROBUST_LEVEL_K * scale, ROBUST_LEVEL_K * scale).mean(axis=-1)
        mu = mu + step
        if np.all(np.abs(step) < 1e-6 * scale):
            break
    return mu


def _against_others(c: np.ndarray, scale: float) -> np.ndarray:
    """Offsets (M,) against a robust level of the other motors (:func:`_robust_level`), from
    per-motor intercepts; ``scale``: the healthy motor-to-motor spread of this relation.

    Robust, not the mean: one motor far off (a weak motor turning 25 % slower per command) would
    move the mean of every other motor's reference by a third of that on a quad, and a healthy
    motor would then read as turning 10 % faster per command, a propeller's sign (ArduCopter SITL
    motor1_weak_esc.BIN, rpm only: +9.8 to +10.2 % on motors 2-4 against the mean, +0.7 to +1.1 %
    against the robust level). Not the median of the others: on Gaussian motors it is noisier, and it named
    the damaged motor at eta 0.9 in 18 of 24 simulated flights where the mean and this level named
    21 (bench_esc.py's eta 0.9 cells at seed 1700; largest healthy llr 5.5 mean, 5.6 this level,
    24 healthy flights)."""
    m = c.shape[-1]
    if not np.all(np.isfinite(c)):
        return np.full(c.shape, np.nan)
    others = np.array([np.delete(c, k) for k in range(m)])
    return c - _robust_level(others, scale)


def _lever(xbar: np.ndarray) -> np.ndarray:
    """(M,) each motor's mean against the mean of the others: how far its offset moves per unit of
    slope (d a_k / d b = -lever_k)."""
    m = xbar.size
    return xbar - (xbar.sum() - xbar) / max(m - 1, 1)


def _offsets(y: np.ndarray, x: np.ndarray, slope: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(offsets (M,), the same per time block (N_BLOCKS, M)) of ``y - slope·x`` against the others:
    each bin's values taken against that bin's mean over motors (everything common cancels), then
    per motor against the others' robust level."""
    def off(idx):
        ya = y[idx] - y[idx].mean(axis=1, keepdims=True)
        xa = x[idx] - x[idx].mean(axis=1, keepdims=True)
        return _against_others((ya - slope * xa).mean(axis=0), scale)
    whole = off(np.arange(y.shape[0]))
    est = np.array([off(b) for b in np.array_split(np.arange(y.shape[0]), N_BLOCKS)])
    return whole, est


def measure_esc(flight: Flight) -> tuple[Optional[_Measurement], Optional[str]]:
    """The per-motor offsets and their measurement covariance, or (None, why it abstains)."""
    esc, motors = flight.esc, flight.motors
    if esc is None or not esc.channels:
        return None, NO_ESC
    if motors is None or len(motors) < 2:
        return None, "no motor commands"
    n = motors.values.shape[1]
    missing = [k for k in range(1, n + 1) if esc.channel(k) is None]
    if missing:
        return None, f"no ESC telemetry for motor(s) {', '.join(map(str, missing))}"
    slow = [(c.motor, c.rate_hz) for c in esc.channels if c.motor <= n and c.rate_hz < MIN_RATE_HZ]
    if slow:
        return None, (f"ESC telemetry too slow (motor {slow[0][0]}: {slow[0][1]:.1f} Hz < {MIN_RATE_HZ:g} Hz)")
    edges = _bin_edges(flight.airborne)
    if not edges:
        return None, "too little airborne time"
    from ..streams import flight_thrust_proxy

    # Bin means of LINEAR quantities, logged afterwards: the rotor speed is the commanded speed
    # (∝ sqrt(thrust)) through the motor's lag, a linear filter that keeps the mean, so
    # mean(rpm) follows mean(sqrt(thrust)); means of logs would add a Jensen bias that grows
    # with each motor's own command noise and differs between trims.
    w_cmd = np.sqrt(np.clip(flight_thrust_proxy(flight), 0.0, None))
    chans = [esc.channel(k) for k in range(1, n + 1)]
    if not any(np.any(_airborne(c.t, flight.airborne) & c.fresh() & (c.rpm > 0)) for c in chans):
        return None, "the ESCs report no rpm in flight (0 throughout): no rpm telemetry"
    has_current = all(c.current is not None for c in chans)
    if has_current and all(_constant(c.current[c.fresh()]) for c in chans):
        has_current = False  # a value that never changes is no measurement (a simulator's placeholder)
    lrpm, lcur, lrpm2 = [], [], []
    for k in range(1, n + 1):
        c = esc.channel(k)
        m = c.fresh() & (c.rpm > 0)
        lrpm.append(_bin_means(c.t[m], c.rpm[m], edges)[0])
        if has_current:
            mc = m & np.isfinite(c.current) & (c.current > 0)
            lcur.append(_bin_means(c.t[mc], c.current[mc], edges)[0])
            lrpm2.append(_bin_means(c.t[mc], c.rpm[mc] ** 2, edges)[0])
    lrpm = np.column_stack(lrpm)
    piece, mid = _bin_pieces(edges)
    # the command shifted by each candidate lag: the rotor speed follows it that much later
    lu_lag = [np.column_stack([_bin_means(motors.t + lag, w_cmd[:, k], edges)[0] for k in range(n)])
              for lag in LAG_GRID_S]
    ok = np.all(np.isfinite(lrpm), axis=1)
    for k in range(n):  # a bin with any saturated command sample of any motor
        sat = (w_cmd[:, k] >= np.sqrt(SATURATED_COMMAND)).astype(float)
        ok &= ~(_bin_means(motors.t, sat, edges)[0] > 0)
    for lu in lu_lag:
        ok &= np.all(np.isfinite(lu), axis=1) & np.all(lu > np.sqrt(MIN_COMMAND), axis=1)
    if has_current:
        lcur = np.column_stack(lcur)
        lrpm2 = np.column_stack(lrpm2)
        ok_cur = ok & np.all(np.isfinite(lcur), axis=1) & np.all(np.isfinite(lrpm2), axis=1)
        # current is used when nearly every usable bin has it (an ESC without current sense reports 0)
        has_current = ok_cur.sum() >= max(MIN_BINS, 0.8 * ok.sum())
        if has_current:
            ok = ok_cur
    if ok.sum() < MIN_BINS:
        return None, (f"only {int(ok.sum())} s of airborne time with every ESC reporting and every motor "
                      f"above idle (needs {MIN_BINS} s)")
    piece, mid = piece[ok], mid[ok]
    lrpm = np.log(lrpm[ok])
    fits = [_curve_fit(lrpm, np.log(lu[ok]), piece, mid) for lu in lu_lag]
    best = int(np.argmin([ss for _, ss in fits]))
    lu = np.log(lu_lag[best][ok])
    noise = np.column_stack([_bin_noise(motors.t + LAG_GRID_S[best], w_cmd[:, k], edges) for k in range(n)])[ok]
    beta, beta_sd = _slope(lrpm, lu, piece, mid, RPM_SLOPE_PRIOR, RPM_SLOPE_PRIOR_STD, noise)
    slopes = {"log_rpm_per_log_sqrt_command": beta, "command_lag_s": float(LAG_GRID_S[best])}
    r = np.full((n, 2), np.nan)
    lever = np.zeros((n, 2))
    slope_sd = np.array([beta_sd, 0.0])
    r[:, 0], est_a = _offsets(lrpm, lu, beta, HEALTHY_SPREAD_STD[0])
    lever[:, 0] = _lever(lu.mean(axis=0))
    est_d = np.zeros_like(est_a)
    if has_current:
        lcur = np.log(lcur[ok])
        lrpm2 = np.log(lrpm2[ok])
        gamma, gamma_sd = _slope(lcur, lrpm2, piece, mid, CURRENT_SLOPE_PRIOR, CURRENT_SLOPE_PRIOR_STD)
        slopes["log_current_per_log_rpm2"] = gamma
        slope_sd[1] = gamma_sd
        r[:, 1], est_d = _offsets(lcur, lrpm2, gamma, HEALTHY_SPREAD_STD[1])
        lever[:, 1] = _lever(lrpm2.mean(axis=0))
    est = np.stack([est_a, est_d], axis=2)  # (blocks, M, 2)
    dev = est - est.mean(axis=0)
    cov = np.einsum("bmi,bmj->mij", dev, dev) / (N_BLOCKS - 1) / N_BLOCKS
    if not has_current:
        cov[:, 1, :] = cov[:, :, 1] = 0.0
    slopes["slope_sd"] = [float(x) for x in slope_sd]
    return _Measurement(r, cov, has_current, int(ok.sum()), slopes, slope_sd, lever), None


# ----------------------------------------------------------------------------- scoring


def _glr(r: np.ndarray, cov: np.ndarray, mu: np.ndarray) -> tuple[float, float]:
    """One-sided generalised LLR (nats) and the fitted loss ℓ for offset ``r`` along ``mu``."""
    inv = np.linalg.inv(cov)
    num = float(mu @ inv @ r)
    den = float(mu @ inv @ mu)
    loss = num / den
    return (num * num / (2.0 * den) if num > 0 else 0.0), max(loss, 0.0)


def damage_prior_losses() -> np.ndarray:
    """Torque losses ℓ = -m·log η of the damage hypothesis, (len(ETA_GRID), drag exponents): one per
    point of the command-share analyzer's uniform (η, m) prior grid (thrust η, torque η^m) with m at
    least MIN_DRAG_EXPONENT, so that both sources weigh "rotor k lost thrust" over the same η."""
    from .command_shares import ETA_GRID, M_GRID

    eta, m = np.meshgrid(ETA_GRID, M_GRID[M_GRID >= MIN_DRAG_EXPONENT], indexing="ij")
    return -m * np.log(eta)


def motor_prior_losses() -> np.ndarray:
    """Losses ℓ = -log η of the motor / ESC hypothesis, η on the command-share analyzer's grid
    (command_shares.ETA_GRID: thrust per command, uniform): the propeller's severity prior."""
    from .command_shares import ETA_GRID

    return -np.log(ETA_GRID)


def _log_ratio(r: np.ndarray, cov: np.ndarray, mu: np.ndarray, losses: np.ndarray) -> np.ndarray:
    """log N(r; ℓ·mu, cov) - log N(r; 0, cov) for every loss ℓ in ``losses`` (any shape)."""
    inv = np.linalg.inv(cov)
    b = float(mu @ inv @ r)
    c = float(mu @ inv @ mu)
    return losses * b - 0.5 * losses * losses * c


def _log_mean_exp(a: np.ndarray, axis=None) -> np.ndarray:
    top = np.max(a, axis=axis, keepdims=True)
    out = top + np.log(np.mean(np.exp(a - top), axis=axis, keepdims=True))
    return np.squeeze(out, axis=axis) if axis is not None else float(out.squeeze())


def _log_bayes_factor(r: np.ndarray, cov: np.ndarray, mu: np.ndarray, losses: np.ndarray) -> float:
    """log of mean over ``losses`` of N(r; ℓ·mu, cov) / N(r; 0, cov), computed stably (nats).

    A motor measured exactly healthy gets about -2.4 nats on the propeller's grid (the prior's mass
    on losses too small to see keeps it from going lower); one sitting opposite to damage (a heavier
    propeller, or a healthy motor beside a damaged one, whose "other motors" include it) less."""
    return float(_log_mean_exp(_log_ratio(r, cov, mu, np.asarray(losses, float))))


def cause_log_ratios(r: np.ndarray, cov: np.ndarray, dims: Sequence[int]) -> dict[str, np.ndarray]:
    """{cause: (len(ETA_GRID),) log N(r | rotor lost thrust to it at η) - log N(r | healthy)} for the
    offsets ``r`` (in ``dims``) with covariance ``cov``: the propeller along DAMAGE_DIRECTION
    (averaged over the drag exponents M_GRID), the motor / ESC along MOTOR_DIRECTION, the wash 0."""
    mu_p, mu_m = np.array(DAMAGE_DIRECTION)[dims], np.array(MOTOR_DIRECTION)[dims]
    prop = _log_mean_exp(_log_ratio(r, cov, mu_p, damage_prior_losses()), axis=1)
    motor = _log_ratio(r, cov, mu_m, motor_prior_losses())
    return {"propeller": prop, "motor_or_esc": motor, "wash": np.zeros_like(motor)}


def _mixture(by_cause: dict[str, np.ndarray]) -> np.ndarray:
    """log sum over CAUSES of CAUSE_PRIOR · exp(log ratio), elementwise, computed stably."""
    stack = np.array([by_cause[c] for c in CAUSES])
    w = np.array([CAUSE_PRIOR[c] for c in CAUSES])[:, None]
    top = stack.max(axis=0)
    return top + np.log(np.sum(w * np.exp(stack - top), axis=0))


def _pct(x: float) -> float:
    return float(100.0 * np.expm1(x))


def _pooled(values: Sequence[float], sds: Sequence[float]) -> tuple[float, float]:
    """Precision-weighted mean and its sd."""
    w = 1.0 / np.square(np.asarray(sds, float))
    return float(np.sum(w * np.asarray(values, float)) / w.sum()), float(np.sqrt(1.0 / w.sum()))


def analyze_esc(flight: Flight, baseline: Optional[EscBaseline] = None) -> EscAnalysis:
    """Per-motor ESC findings for ``flight`` (see module docstring), against the other motors,
    or against ``baseline`` (a profile's healthy offsets and flight-to-flight spread)."""
    meas, why = measure_esc(flight)
    n = flight.motors.values.shape[1] if flight.motors is not None else (len(flight.esc.channels) if flight.esc else 0)
    if meas is None:
        nan = (float("nan"), float("nan"))
        findings = [EscFigure(ANALYZER_ID, k, name, float("nan"), unit, nan, None, direction, 0.0, why)
                    for k in range(1, n + 1)
                    for name, unit, direction in (("rpm_per_command", "%", "up"), ("current_per_rpm2", "%", "down"),
                                                  ("esc_damage", "% torque", "up"))]
        return EscAnalysis(findings, {}, why)
    dims = [0, 1] if meas.has_current else [0]
    if baseline is not None and len(baseline.offsets) != meas.r.shape[0]:
        raise ValueError(f"ESC baseline has {len(baseline.offsets)} motors, the flight {meas.r.shape[0]}")
    against = "other motors"
    if baseline is not None and baseline.slopes is None:
        against = ("other motors (the profile's ESC baseline predates the rpm-per-command curve and cannot be "
                   "used: calibrate again)")
        baseline = None
    r = meas.r.copy()
    if baseline is not None:
        # both the flight and the calibration at one slope per relation, pooled from the two
        b_f, b_c = meas.slope_pair(), np.array(baseline.slopes[0::2])
        sd_f, sd_c = meas.slope_sd, np.array(baseline.slopes[1::2])
        lever_c = np.array(baseline.levers, dtype=float)
        slope_var, lever_diff = np.zeros(2), meas.lever - lever_c
        base = np.array(baseline.offsets, dtype=float)
        for j in dims:
            use, sd = _pooled([b_f[j], b_c[j]], [max(sd_f[j], 1e-6), max(sd_c[j], 1e-6)])
            r[:, j] = meas.r[:, j] - (use - b_f[j]) * meas.lever[:, j]
            base[:, j] = base[:, j] - (use - b_c[j]) * lever_c[:, j]
            slope_var[j] = sd * sd
        spread = np.array(baseline.cov, dtype=float)
        against = "profile"
        if not baseline.has_current:
            dims = [0]
    else:
        base = np.zeros_like(meas.r)
        spread = np.array(HEALTHY_SPREAD_COV)
        slope_var, lever_diff = meas.slope_sd ** 2, meas.lever
    mu = np.array(DAMAGE_DIRECTION)[dims]
    findings, llr, decision_llr, cause_llr, cause_ll, cause_ll_eta, eta_llr = [], {}, {}, {}, {}, {}, {}
    for k in range(r.shape[0]):
        motor = k + 1
        x = (r[k] - base[k])[dims]
        total = spread + meas.cov[k] + np.diag(slope_var * lever_diff[k] ** 2)
        cov = total[np.ix_(dims, dims)]
        score, loss = _glr(x, cov, mu)
        llr[motor] = score
        by_eta = cause_log_ratios(x, cov, dims)
        cause_ll_eta[motor] = by_eta
        cause_ll[motor] = {c: float(_log_mean_exp(v)) for c, v in by_eta.items()}
        eta_llr[motor] = _mixture(by_eta)
        decision_llr[motor] = float(_log_mean_exp(eta_llr[motor]))
        cause_llr[motor] = cause_ll[motor]["motor_or_esc"] - cause_ll[motor]["propeller"]
        for j, (name, direction) in enumerate((("rpm_per_command", "up"), ("current_per_rpm2", "down"))):
            if j not in dims:
                findings.append(EscFigure(ANALYZER_ID, motor, name, float("nan"), "%", (float("nan"),) * 2, None,
                                        direction, 0.0, "no current telemetry" if j == 1 else None))
                continue
            val = float(r[k, j])
            se = float(np.sqrt(total[j, j] - spread[j, j]))
            one, _ = _glr(np.array([x[dims.index(j)]]), np.array([[cov[dims.index(j), dims.index(j)]]]),
                          np.array([mu[dims.index(j)]]))
            findings.append(EscFigure(ANALYZER_ID, motor, name, _pct(val), "%",
                                    (_pct(val - 1.645 * se), _pct(val + 1.645 * se)), _pct(base[k, j]),
                                    direction, one))
        findings.append(EscFigure(ANALYZER_ID, motor, "esc_damage", 100.0 * loss, "% torque",
                                (float("nan"), float("nan")), 0.0, "up", score))
    return EscAnalysis(findings, llr, None, against, meas.bins, meas.slopes, decision_llr, cause_llr, cause_ll,
                       cause_ll_eta, eta_llr)


def fit_esc_baseline(flights: Sequence[Flight], names: Optional[Sequence[str]] = None) -> EscBaseline:
    """An :class:`EscBaseline` from healthy flights of one airframe: the slopes pooled over the
    flights (precision-weighted; their flight-to-flight spread when larger), each flight's offsets
    moved to them, and the offsets' mean and flight-to-flight covariance (diagonal floor
    ``PROFILE_SPREAD_FLOOR``; one flight: the floor plus its own measurement uncertainty). Raises
    ValueError when no flight is usable."""
    meas, used = [], []
    for i, f in enumerate(flights):
        m, why = measure_esc(f)
        if m is not None:
            meas.append(m)
            used.append(names[i] if names is not None else (f.path or f"flight {i}"))
    if not meas:
        raise ValueError("no flight with usable ESC telemetry to fit an ESC baseline from")
    has_current = all(m.has_current for m in meas)
    slopes = []
    r = np.array([np.nan_to_num(m.r) for m in meas])  # (F, M, 2)
    for j in (0, 1) if has_current else (0,):
        vals = [m.slope_pair()[j] for m in meas]
        use, sd = _pooled(vals, [max(m.slope_sd[j], 1e-6) for m in meas])
        if len(meas) > 1:
            sd = max(sd, float(np.std(vals, ddof=1)) / np.sqrt(len(meas)))
        for i, m in enumerate(meas):
            r[i, :, j] = r[i, :, j] - (use - vals[i]) * m.lever[:, j]
        slopes += [use, sd]
    if not has_current:
        slopes += [CURRENT_SLOPE_PRIOR, CURRENT_SLOPE_PRIOR_STD]
    offsets = r.mean(axis=0)
    levers = np.mean([m.lever for m in meas], axis=0)
    floor = np.diag(np.square(PROFILE_SPREAD_FLOOR))
    cov = floor + np.mean([m.cov.mean(axis=0) for m in meas], axis=0)
    if len(meas) > 1:
        dev = (r - offsets).reshape(-1, 2)
        cov = np.maximum(cov, np.cov(dev.T) * len(meas) / max(len(meas) - 1, 1))
    return EscBaseline([tuple(map(float, o)) for o in offsets], cov.tolist(), used, has_current,
                       tuple(float(x) for x in slopes), [tuple(map(float, v)) for v in levers])


@dataclass
class EscResult(AnalyzerResult):
    """The ESC analyzer's result: its findings and, per motor, what :mod:`flightlog_fd.cause` reads
    for the rotor a verdict names: ``cause_ll`` ({cause: log Bayes factor against healthy}, η over
    its prior), ``cause_ll_eta`` ({cause: (len(ETA_GRID),) the same at each η}), ``cause_llr`` (motor
    / ESC against propeller, kept for older readers), and ``AnalyzerResult.eta_llrs`` (the causes weighed by CAUSE_PRIOR)."""

    cause_llr: dict = field(default_factory=dict)
    cause_ll: dict = field(default_factory=dict)
    cause_ll_eta: dict = field(default_factory=dict)
    #: What the offsets were taken against ("other motors" / "profile", with why not the profile)
    against: str = ""
    #: The fitted slopes: b (log rpm per log sqrt command), γ (log current per log rpm²), their sd
    #: and the command lag (s)
    slopes: dict = field(default_factory=dict)


class Esc(Analyzer):
    """The registry's ESC analyzer: :func:`analyze_esc` against the profile's ESC baseline when it
    has one. Per motor: ``rpm_per_command`` and ``current_per_rpm2`` (shown) and ``esc_damage``
    (the torque loss, weighed with the combined llr)."""

    id = ANALYZER_ID
    description = "ESC telemetry: rpm per command against the rotors' curve (up) and current per rpm^2 (down)"
    requires = ("esc",)
    #: ESC telemetry measures the propeller's load almost directly, so it may outweigh the other
    #: sources further than they may (SOURCE_LLR_CAP 8): up to this. Measured (bench_esc.py
    #: --measure, simulated): the largest healthy GLR without a profile is 11.4 nats (one airframe
    #: whose healthy propeller has a 5.6 % lower torque coefficient), p99 of the rest 4.0; damaged
    #: eta <= 0.8 flights reach 20-60 nats. The decision gets the Bayes factor (decision_llr),
    #: which can also clear a motor: on 200 simulated healthy flights with ESC telemetry and no
    #: profile the fused verdict said damaged on 6 (10 when it got the GLR), and eta 0.6-0.8
    #: stayed 60/60 right (bench_esc.py --verdicts, seed 4242, 2026-11-24).
    llr_cap = 12.0
    reliability_keys = ("profile",)
    #: Two damaged propellers each read far above the cap (simulated quads with ESC telemetry at
    #: 10/50/100 Hz, two propellers at eta 0.6-0.85: the weaker member's LLR median +21, 10th
    #: percentile +10.4; one propeller: the second-largest motor's at most +5.3, healthy flights
    #: at most -0.2; benchmarks/bench_two_props.py --esc --seeds 31 --per-set 12): clipped motor by
    #: motor, one rotor and the pair both sat at the cap and the ESC could not tell them apart (both
    #: named in 2 of 33 such flights; with it 30 of 33).
    pair_keeps_order = True

    def fit_baseline(self, flights, model=None):
        try:
            return fit_esc_baseline(flights, [f.path or f"flight {i}" for i, f in enumerate(flights)]).to_dict()
        except ValueError:  # no calibration flight has usable ESC telemetry
            return None

    def analyze(self, ctx: Context) -> AnalyzerResult:
        flight = ctx.flight
        if flight is None or getattr(flight, "esc", None) is None:
            return EscResult(self.id, abstained=NO_ESC)
        b = ctx.baseline_for(self.id)
        baseline = EscBaseline.from_dict(b) if b else None
        if baseline is not None and len(baseline.offsets) != ctx.n_motors:
            baseline = None
        a = analyze_esc(flight, baseline)
        if a.abstain:
            return EscResult(self.id, abstained=a.abstain)
        out = []
        for f in a.findings:
            if f.abstain or not np.isfinite(f.value):
                continue
            weighed = f.name == "esc_damage"  # the combined score; the two relations are its parts
            lo, hi = f.interval
            interval = (lo, hi) if np.isfinite(lo) and np.isfinite(hi) else None
            text = f"{f.value:+.1f}%" if f.unit == "%" else f"{f.value:.0f}{f.unit[1:] if f.unit.startswith('%') else ''}"
            out.append(Finding(self.id, f.motor, f.name, f.value, f.unit, interval, f.baseline, f.direction,
                               a.decision_llr[f.motor] if weighed else None,
                               text if f.name != "esc_damage" else f"{f.value:.0f}%"))
        # a pair's evidence is its two motors' summed (AnalyzerResult.pair_llr): each motor is now
        # taken against a robust level of the others (ROBUST_LEVEL_K), so one motor far off no
        # longer lifts its neighbours (ArduCopter SITL motor1_weak_esc: motor 1 +12, the others
        # -0.8 to -1.1), and a healthy member lowers a pair
        return EscResult(self.id, out, eta_llrs=dict(a.eta_llr), cause_llr=dict(a.cause_llr),
                         cause_ll=dict(a.cause_ll), cause_ll_eta=dict(a.cause_ll_eta), against=a.against,
                         slopes=dict(a.slopes))


__all__ = ["ANALYZER_ID", "NO_ESC", "EscFigure", "Esc", "EscAnalysis", "EscBaseline", "EscResult", "analyze_esc",
           "measure_esc", "fit_esc_baseline", "cause_log_ratios", "DECISION_LLR", "MOTOR_DIRECTION",
           "DAMAGE_DIRECTION"]
