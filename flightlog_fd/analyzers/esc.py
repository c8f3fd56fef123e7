"""ESC analyzer: does one motor turn too easily for its command and draw too little current?

What: per motor, from ESC telemetry (``Flight.esc``) and the motor commands over the airborne
time, two relations, each as the motor's offset against the other motors of the same flight
(natural log, reported in %):

- **rpm per command** ``a_k``: ``log mean rpm = c_k + β·log mean sqrt(thrust command)`` (β
  fitted, prior 1: rpm ∝ sqrt(thrust); ``streams.flight_thrust_proxy`` makes the command linear
  in thrust). A lighter (cut, chipped) propeller loads its motor less, so on an
  open-loop ESC it turns faster at the same command: ``a_k`` goes **up**.
- **current per rpm²** ``d_k``: ``log mean current = e_k + γ·log mean rpm²`` (γ fitted, prior 1:
  drag torque ∝ rpm², current ∝ torque). The lost blade area loses drag torque: ``d_k`` goes **down**.

A weak motor or ESC (a failing ESC or a resistive joint delivers less voltage; a tired motor or a
bad bearing droops more) does the opposite to rpm: the rotor turns **slower** for its command, so
``a_k`` goes **down**, while ``d_k`` stays (the same propeller's torque per rpm²; a bearing's
friction raises it). Both lose the rotor thrust per command, so the command shares cannot tell
them apart; these relations can (``cause_llr``).

A trim change (centre of mass off the middle, motor tilt / yaw trim) only moves each motor along
its own curves, so neither offset moves; command shares cannot tell the two apart with four
motors. Both relations are fitted on 1 s bin means of the airborne time (``BIN_S``; each ESC on
its own samples, never interpolated; a bin in which any motor's ESC is silent is skipped), per
motor against a robust (Huber) level of the other motors (one rotor far off does not move the
others' reference), so everything common to all motors (battery voltage, air density, throttle)
cancels.

Score: ``r_k = (a_k, d_k)`` is Gaussian around 0 for a healthy motor with covariance ``Σ`` =
motor-to-motor spread (``HEALTHY_SPREAD_COV``, without a profile; with one, the profile's own
flight-to-flight spread) + the measurement's own uncertainty (from ``N_BLOCKS`` time blocks);
"rotor k lost torque ℓ ≥ 0" moves its mean to ``ℓ·DAMAGE_DIRECTION``. The per-motor score
``llr`` is the generalised log-likelihood ratio (nats) of that against healthy, maximised over
ℓ ≥ 0: ``(μᵀΣ⁻¹r)² / (2 μᵀΣ⁻¹μ)`` when ``μᵀΣ⁻¹r > 0``, else 0; it names a motor
(:meth:`EscAnalysis.motor_named`). The decision model sums another figure, ``decision_llr``: the
log Bayes factor of "rotor k lost thrust" against healthy, the loss being its propeller's (ℓ
averaged over the same damage prior as the command-share analyzer: η 0.40-0.99, torque η^m,
along ``DAMAGE_DIRECTION``) or its motor's / ESC's (η on the same grid, ℓ = -log η along
``MOTOR_DIRECTION``), weighed by ``MOTOR_CAUSE_PRIOR``. It is negative for a motor whose
relations sit where a healthy one's do, so ESC telemetry can also clear a motor that other
sources suspect. ``cause_llr`` per motor is the log Bayes factor of the motor / ESC against the
propeller (positive: the motor or its ESC). Without current telemetry only ``a_k`` is used, and
a current that never changes (a simulator's placeholder, an ESC without current sense that
reports a fixed value) is no current telemetry.

Inputs: a :class:`~flightlog_fd.flight.Flight` with ``esc`` (rpm for every motor; current
optional), ``motors`` and ``airborne``; optionally an :class:`EscBaseline` from healthy flights
of the same airframe (:func:`fit_esc_baseline`). Limits: needs ``MIN_BINS`` usable seconds with
every motor reporting at ``MIN_RATE_HZ`` or more, else it abstains and says why; an ESC that
regulates speed in closed loop (some AM32/BLHeli modes) hides the rpm lift, and the current
relation then carries the evidence; a healthy propeller that is simply lighter than its
neighbours looks like mild damage (that spread is in ``HEALTHY_SPREAD_COV``).

Constants are measured on simulated flights (``python benchmarks/bench_esc.py --measure``): there
is no public real log with ESC telemetry from a real airframe in ../shared (its only
``esc_status`` log, sample_px4_events.ulg, is a Gazebo SITL flight at 4 Hz with identical
simulated motors), so the motor-to-motor spread below is the simulator's (sim/esc.py: KV spread
σ 1.5 %, current-sense gain σ 1 % and offset 2 % of hover current; sim/imbalance.py: propeller
torque-coefficient spread σ 3 % × severity). Real fleets may spread more: measure one.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..flight import Flight
from .base import Analyzer, AnalyzerResult, Context, Finding

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
#: Time blocks for the measurement uncertainty of each offset.
N_BLOCKS = 6
#: Physics priors of the slopes (log rpm per log sqrt(thrust command): 1; log current per log
#: rpm²: 1, torque ∝ rpm²) and their weight, as a within-motor log-variation per bin that the
#: prior is worth (a flight that varies its commands by much more than 2 % fits its own slope).
RPM_SLOPE_PRIOR = 1.0
CURRENT_SLOPE_PRIOR = 1.0
SLOPE_PRIOR_SPREAD = 0.02
#: The rpm relation keeps its physics slope (1): ESC report latency (up to one interval) and
#: the motor lag misalign rpm and command bins, which attenuates a fitted slope (0.81-0.98 on
#: simulated flights) and then moves a motor's offset with its trim (up to 2.4 % when the CoG
#: moved; 0.6 % with the slope held). A wrong thrust-curve parameter (true slope 1 ± 0.1)
#: costs about 0.5 % at a 5 % trim offset. The current relation shares its samples, so it fits.
RPM_SLOPE_FIXED = True
#: Healthy motor-to-motor covariance of (a_k, d_k) relative to the other motors, natural-log
#: units. Measured: `bench_esc.py --measure --per-cell 8 --seed 99` on 32 simulated healthy
#: flights (128 motors; random airframes 30 g-5 kg, realistic imbalance, 10 and 50 Hz ESC):
#: std a 1.19 %, d 3.30 %, correlation +0.31 (a KV spread moves both up; a light healthy
#: propeller moves them apart like damage, and is the floor of what a flight alone can tell).
#: Against the robust level of the others (ROBUST_LEVEL_K) the same run gives std a 1.20 %, d
#: 3.34 %, +0.32; trim change 0.38 % / 0.59 %; damage direction +0.074 / -0.973; largest healthy
#: llr 4.4 (p99 4.0): every constant here holds within its last digit.
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
#: std of the change a 0.35 %, d 0.59 %.
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
#: -0.285 at ℓ = 0.575, -0.50 per unit.
MOTOR_DIRECTION = (-0.46, 0.0)
#: Prior probability that a rotor which lost thrust lost it to its motor or ESC rather than to its
#: propeller: even odds. No measured base rate exists (propellers are the commoner wear part on a
#: crashed or hard-landed airframe; ESC and motor faults follow heat and age), and where the loss
#: is visible the relations tell the two apart by far more than the prior (bench_esc.py
#: --causes); where the evidence is weak the verdict states no cause.
MOTOR_CAUSE_PRIOR = 0.5


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
    motors) and their flight-to-flight covariance (2x2, at least PROFILE_SPREAD_FLOOR)."""

    offsets: list[tuple[float, float]]
    cov: list[list[float]]
    flights: list[str] = field(default_factory=list)
    has_current: bool = True

    def to_dict(self) -> dict:
        return {"analyzer": ANALYZER_ID, "offsets": [list(o) for o in self.offsets], "cov": self.cov,
                "flights": list(self.flights), "has_current": self.has_current}

    @classmethod
    def from_dict(cls, d: dict) -> "EscBaseline":
        return cls([tuple(o) for o in d["offsets"]], [list(r) for r in d["cov"]], list(d.get("flights", [])),
                   bool(d.get("has_current", True)))


@dataclass
class EscAnalysis:
    """What :func:`analyze_esc` found: ``findings`` (per motor: ``rpm_per_command``,
    ``current_per_rpm2``, ``esc_damage``), ``llr`` per motor (nats), ``abstain`` (None or why),
    ``against`` ("other motors" / "profile"), usable ``bins`` (s), fitted ``slopes``."""

    findings: list[EscFigure]
    llr: dict[int, float]
    abstain: Optional[str] = None
    against: str = "other motors"
    bins: int = 0
    slopes: dict = field(default_factory=dict)
    #: Per motor, the log Bayes factor (nats) of "lost thrust to its propeller or to its motor /
    #: ESC" against healthy (:func:`_log_bayes_factor`, weighed by MOTOR_CAUSE_PRIOR): what the
    #: decision model sums. Unlike ``llr`` it goes negative when the motor's relations sit where a
    #: healthy motor's do.
    decision_llr: dict[int, float] = field(default_factory=dict)
    #: Per motor, the log Bayes factor (nats) of "its motor or ESC lost the thrust" against "its
    #: propeller did", each loss averaged over its prior (positive: the motor / ESC).
    cause_llr: dict[int, float] = field(default_factory=dict)

    def motor_named(self, threshold: float = DECISION_LLR) -> Optional[int]:
        """The motor whose llr is largest and above ``threshold`` (None: nothing named)."""
        if self.abstain or not self.llr:
            return None
        k = max(self.llr, key=self.llr.get)
        return k if self.llr[k] > threshold else None


@dataclass
class _Measurement:
    r: np.ndarray  # (M, 2) offsets a, d against the others' robust level (d NaN without current)
    cov: np.ndarray  # (M, 2, 2) measurement covariance of r
    has_current: bool
    bins: int
    slopes: dict


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


def _fe_fit(y: np.ndarray, x: np.ndarray, prior: float, fixed: bool = False) -> tuple[float, np.ndarray, np.ndarray]:
    """Pooled slope (or the prior when ``fixed``) with per-motor intercepts on (B, M) bin means,
    both taken against the mean of all motors per bin. Returns (slope, intercepts (M,), residuals)."""
    yd = y - y.mean(axis=1, keepdims=True)
    xd = x - x.mean(axis=1, keepdims=True)
    yw = yd - yd.mean(axis=0)
    xw = xd - xd.mean(axis=0)
    lam = y.size * SLOPE_PRIOR_SPREAD ** 2
    slope = prior if fixed else float((np.sum(xw * yw) + lam * prior) / (np.sum(xw * xw) + lam))
    inter = yd.mean(axis=0) - slope * xd.mean(axis=0)
    return slope, inter, yd - slope * xd - inter


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
    lu = np.column_stack([_bin_means(motors.t, w_cmd[:, k], edges)[0] for k in range(n)])
    lrpm, lcur, lrpm2 = [], [], []
    chans = [esc.channel(k) for k in range(1, n + 1)]
    if not any(np.any(_airborne(c.t, flight.airborne) & c.fresh() & (c.rpm > 0)) for c in chans):
        return None, "the ESCs report no rpm in flight (0 throughout): no rpm telemetry"
    has_current = all(c.current is not None for c in chans)
    if has_current and all(_constant(c.current[c.fresh()]) for c in chans):
        has_current = False  # a value that never changes is no measurement (a simulator's placeholder)
    for k in range(1, n + 1):
        c = esc.channel(k)
        m = c.fresh() & (c.rpm > 0)
        lrpm.append(_bin_means(c.t[m], c.rpm[m], edges)[0])
        if has_current:
            mc = m & np.isfinite(c.current) & (c.current > 0)
            lcur.append(_bin_means(c.t[mc], c.current[mc], edges)[0])
            lrpm2.append(_bin_means(c.t[mc], c.rpm[mc] ** 2, edges)[0])
    lrpm = np.column_stack(lrpm)
    ok = (np.all(np.isfinite(lrpm), axis=1) & np.all(np.isfinite(lu), axis=1)
          & np.all(lu > np.sqrt(MIN_COMMAND), axis=1))
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
    lu = np.log(lu[ok])
    lrpm = np.log(lrpm[ok])
    beta, ca, _ = _fe_fit(lrpm, lu, RPM_SLOPE_PRIOR, RPM_SLOPE_FIXED)
    slopes = {"log_rpm_per_log_sqrt_command": beta}
    r = np.full((n, 2), np.nan)
    r[:, 0] = _against_others(ca, HEALTHY_SPREAD_STD[0])
    if has_current:
        lcur = np.log(lcur[ok])
        lrpm2 = np.log(lrpm2[ok])
        gamma, cd, _ = _fe_fit(lcur, lrpm2, CURRENT_SLOPE_PRIOR)
        slopes["log_current_per_log_rpm2"] = gamma
        r[:, 1] = _against_others(cd, HEALTHY_SPREAD_STD[1])
    # measurement covariance from contiguous time blocks (slopes held at the whole-flight values)
    blocks = np.array_split(np.arange(lu.shape[0]), N_BLOCKS)
    est = []
    for b in blocks:
        xa = lu[b] - lu[b].mean(axis=1, keepdims=True)
        ya = lrpm[b] - lrpm[b].mean(axis=1, keepdims=True)
        ra = _against_others((ya - beta * xa).mean(axis=0), HEALTHY_SPREAD_STD[0])
        if has_current:
            xd = lrpm2[b] - lrpm2[b].mean(axis=1, keepdims=True)
            yd = lcur[b] - lcur[b].mean(axis=1, keepdims=True)
            rd = _against_others((yd - slopes["log_current_per_log_rpm2"] * xd).mean(axis=0), HEALTHY_SPREAD_STD[1])
        else:
            rd = np.zeros(n)
        est.append(np.column_stack([ra, rd]))
    est = np.array(est)  # (blocks, M, 2)
    cov = np.einsum("bmi,bmj->mij", est - est.mean(axis=0), est - est.mean(axis=0)) / (len(blocks) - 1) / len(blocks)
    if not has_current:
        cov[:, 1, :] = cov[:, :, 1] = 0.0
    return _Measurement(r, cov, has_current, int(ok.sum()), slopes), None


# ----------------------------------------------------------------------------- scoring


def _glr(r: np.ndarray, cov: np.ndarray, mu: np.ndarray) -> tuple[float, float]:
    """One-sided generalised LLR (nats) and the fitted loss ℓ for offset ``r`` along ``mu``."""
    inv = np.linalg.inv(cov)
    num = float(mu @ inv @ r)
    den = float(mu @ inv @ mu)
    loss = num / den
    return (num * num / (2.0 * den) if num > 0 else 0.0), max(loss, 0.0)


def damage_prior_losses() -> np.ndarray:
    """Torque losses ℓ = -m·log η of the damage hypothesis, one per point of the command-share
    analyzer's uniform (η, m) prior grid (command_shares.ETA_GRID x M_GRID: thrust η, torque η^m),
    so that both sources weigh "rotor k lost thrust" against the same prior."""
    from .command_shares import ETA_GRID, M_GRID

    eta, m = np.meshgrid(ETA_GRID, M_GRID, indexing="ij")
    return (-m * np.log(eta)).ravel()


def _log_bayes_factor(r: np.ndarray, cov: np.ndarray, mu: np.ndarray, losses: np.ndarray) -> float:
    """log of mean over ``losses`` of N(r; ℓ·mu, cov) / N(r; 0, cov), computed stably (nats).

    A motor measured exactly healthy gets about -2.4 nats on the grid (the prior's mass on losses
    too small to see keeps it from going lower); one sitting opposite to damage (a heavier
    propeller, or a healthy motor beside a damaged one, whose "other motors" include it) less."""
    inv = np.linalg.inv(cov)
    b = float(mu @ inv @ r)
    c = float(mu @ inv @ mu)
    terms = losses * b - 0.5 * losses * losses * c  # log N(r; ℓμ) - log N(r; 0)
    top = float(terms.max())
    return top + float(np.log(np.mean(np.exp(terms - top))))


def motor_prior_losses() -> np.ndarray:
    """Losses ℓ = -log η of the motor / ESC hypothesis, η on the command-share analyzer's grid
    (command_shares.ETA_GRID: thrust per command, uniform): the propeller's severity prior."""
    from .command_shares import ETA_GRID

    return -np.log(ETA_GRID)


def _mixture(log_bf: Sequence[float], weights: Sequence[float]) -> float:
    """log of sum_i weights_i · exp(log_bf_i), computed stably."""
    top = max(log_bf)
    return top + float(np.log(sum(w * np.exp(b - top) for b, w in zip(log_bf, weights))))


def _pct(x: float) -> float:
    return float(100.0 * np.expm1(x))


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
    if baseline is not None:
        if len(baseline.offsets) != meas.r.shape[0]:
            raise ValueError(f"ESC baseline has {len(baseline.offsets)} motors, the flight {meas.r.shape[0]}")
        base = np.array(baseline.offsets, dtype=float)
        spread = np.array(baseline.cov, dtype=float)
        against = "profile"
        if not baseline.has_current:
            dims = [0]
    else:
        base = np.zeros_like(meas.r)
        spread = np.array(HEALTHY_SPREAD_COV)
        against = "other motors"
    mu = np.array(DAMAGE_DIRECTION)[dims]
    mu_motor = np.array(MOTOR_DIRECTION)[dims]
    losses, motor_losses = damage_prior_losses(), motor_prior_losses()
    findings, llr, decision_llr, cause_llr = [], {}, {}, {}
    for k in range(meas.r.shape[0]):
        motor = k + 1
        x = (meas.r[k] - base[k])[dims]
        cov = (spread + meas.cov[k])[np.ix_(dims, dims)]
        score, loss = _glr(x, cov, mu)
        llr[motor] = score
        bf_prop = _log_bayes_factor(x, cov, mu, losses)
        bf_motor = _log_bayes_factor(x, cov, mu_motor, motor_losses)
        decision_llr[motor] = _mixture([bf_prop, bf_motor], [1.0 - MOTOR_CAUSE_PRIOR, MOTOR_CAUSE_PRIOR])
        cause_llr[motor] = bf_motor - bf_prop
        for j, (name, direction) in enumerate((("rpm_per_command", "up"), ("current_per_rpm2", "down"))):
            if j not in dims:
                findings.append(EscFigure(ANALYZER_ID, motor, name, float("nan"), "%", (float("nan"),) * 2, None,
                                        direction, 0.0, "no current telemetry" if j == 1 else None))
                continue
            val = float(meas.r[k, j])
            se = float(np.sqrt(meas.cov[k, j, j]))
            one, _ = _glr(np.array([x[dims.index(j)]]), np.array([[cov[dims.index(j), dims.index(j)]]]),
                          np.array([mu[dims.index(j)]]))
            findings.append(EscFigure(ANALYZER_ID, motor, name, _pct(val), "%",
                                    (_pct(val - 1.645 * se), _pct(val + 1.645 * se)), _pct(base[k, j]),
                                    direction, one))
        findings.append(EscFigure(ANALYZER_ID, motor, "esc_damage", 100.0 * loss, "% torque",
                                (float("nan"), float("nan")), 0.0, "up", score))
    return EscAnalysis(findings, llr, None, against, meas.bins, meas.slopes, decision_llr, cause_llr)


def fit_esc_baseline(flights: Sequence[Flight], names: Optional[Sequence[str]] = None) -> EscBaseline:
    """An :class:`EscBaseline` from healthy flights of one airframe: the mean offsets, and their
    flight-to-flight covariance (diagonal floor ``PROFILE_SPREAD_FLOOR``; one flight: the floor
    plus its own measurement uncertainty). Raises ValueError when no flight is usable."""
    meas, used = [], []
    for i, f in enumerate(flights):
        m, why = measure_esc(f)
        if m is not None:
            meas.append(m)
            used.append(names[i] if names is not None else (f.path or f"flight {i}"))
    if not meas:
        raise ValueError("no flight with usable ESC telemetry to fit an ESC baseline from")
    has_current = all(m.has_current for m in meas)
    r = np.array([np.nan_to_num(m.r) for m in meas])  # (F, M, 2)
    offsets = r.mean(axis=0)
    floor = np.diag(np.square(PROFILE_SPREAD_FLOOR))
    cov = floor + np.mean([m.cov.mean(axis=0) for m in meas], axis=0)
    if len(meas) > 1:
        dev = (r - offsets).reshape(-1, 2)
        cov = np.maximum(cov, np.cov(dev.T) * len(meas) / max(len(meas) - 1, 1))
    return EscBaseline([tuple(map(float, o)) for o in offsets], cov.tolist(), used, has_current)


@dataclass
class EscResult(AnalyzerResult):
    """The ESC analyzer's result: its findings and, per motor, the log Bayes factor of "its motor
    or ESC lost the thrust" against "its propeller did" (:attr:`EscAnalysis.cause_llr`), which
    :mod:`flightlog_fd.cause` reads for the rotor a verdict names."""

    cause_llr: dict = field(default_factory=dict)


class Esc(Analyzer):
    """The registry's ESC analyzer: :func:`analyze_esc` against the profile's ESC baseline when it
    has one. Per motor: ``rpm_per_command`` and ``current_per_rpm2`` (shown) and ``esc_damage``
    (the torque loss, weighed with the combined llr)."""

    id = ANALYZER_ID
    description = "ESC telemetry: rpm per command (up) and current per rpm^2 (down) against the other motors"
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
        return EscResult(self.id, out, cause_llr=dict(a.cause_llr))


__all__ = ["ANALYZER_ID", "NO_ESC", "EscFigure", "Esc", "EscAnalysis", "EscBaseline", "EscResult", "analyze_esc",
           "measure_esc", "fit_esc_baseline", "DECISION_LLR", "MOTOR_DIRECTION"]
