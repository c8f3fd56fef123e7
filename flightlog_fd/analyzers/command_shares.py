"""Command shares as evidence, with each rotor's severity from steady flight (mixer physics).

Input: the airborne-mean thrust-command shares (mean 1) against the healthy baseline the diagnose
pipeline prepared (:class:`flightlog_fd.analyzers.share_fit.ShareFit`: the profile's at this
throttle, the flight before a mid-flight onset, or none). Physics: one rotor at thrust
efficiency ``eta`` (drag torque ``eta**m``) in closed loop needs commands that hold the same force
and moments as the healthy ones; the mixer geometry (collective, roll, pitch and yaw rows)
predicts them from the baseline (:func:`predicted_commands`). For each motor the LLR is a Bayes
factor: the likelihood of the observed shares averaged over the ``eta``, ``m`` prior grid against
the healthy one, with the share noise of the baseline's kind (:func:`share_sigma`), so a free
``eta`` buys no evidence by itself. Findings per motor: ``share`` (weighed) and ``thrust``
(eta-hat with its 90 % interval, from the fit with the profile's throttle as a fifth
observation; shown, not weighed again). Needs means only, so 10 Hz ``RCOU`` serves.

Limits: quad X/+ geometry is exact; with more rotors the commands move within the allocator's
range (:func:`predicted_commands`), which also tells a coaxial octaquad rotor from its partner
(same arm, opposite spin: only the yaw pattern differs); the pattern cannot separate damage from
an equal and opposite trim change (against a profile the healthy noise includes a moved load,
``SESSION_MOVE_*``, and the decision holds the commands alone to "uncertain"); after a mid-flight onset a
steady rise (a drift: motor, ESC, mount) is not weighed; without a profile an n-rotor's healthy
spread is measured on simulated airframes only (``NROTOR_NEIGHBOUR_SHARE_SIGMA``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..flight import Frame
from .base import ETA_GRID, PAIR_ROTOR_COUNTS, Analyzer, AnalyzerResult, Context, Finding, log_mean_exp
from .session_drift import SessionDrift

#: Drag-torque exponent grid (torque per command scales as eta**m). Physics: at a fixed rotor
#: speed a shortened blade keeps thrust ~ D^4 and torque ~ D^5 (m = 1.25), and the lighter load
#: lets the motor spin faster at the same command, which lowers m towards 0 for motors whose
#: winding resistance matters. Measured on the real rrc_straight quad: the damaged motor's
#: same-spin diagonal partner drops to eta times its command while the other pair stays near
#: (eta + eta**m) / 2 with m ~ 0.4-0.6 (20 and 25 mm cuts); SIH's weakened motors use m = 1.
M_GRID = np.array([0.25, 0.5, 0.75, 1.0, 1.25, 1.6])

#: Without a profile the healthy pattern is unknown: healthy airframes' airborne-mean command
#: shares scatter around an even split with this per-motor standard deviation. Measured:
#: 18 real healthy ArduCopter flights (../shared/real_healthy + Erle), RMS share deviation from 1
#: over all motors = 0.12 (benchmarks/bench_real_damage.py prints it). Quads only: with more
#: rotors a trim is shared by more motors (below).
NEIGHBOUR_SHARE_SIGMA = 0.12
#: The same spread for hexa and octo frames, which have no real log to measure it on: simulated
#: healthy airframes with the realistic imbalance (benchmarks/bench_reliability.py collect --sets
#: nrotor: 30 hexa-X and 30 octo-X flights, seeds 10100/11100, PX4 high-rate, ArduPilot and PX4
#: default logging): RMS share deviation from 1 over all motors 0.092 (hexa; per flight 0.02-0.27)
#: and 0.070 (octo; 0.01-0.19). The reliability table weighs the n-rotor command pattern without a
#: profile by these simulated flights alone, so it never decides alone.
NROTOR_NEIGHBOUR_SHARE_SIGMA = {6: 0.092, 8: 0.070}
#: Against the same flight before a mid-flight onset: a healthy airframe's share wander within
#: one flight. Measured: the 18 real healthy flights, rrc goods and CrazyPAD normals, shares of
#: the last two thirds against the first third: RMS 0.064 (robust 0.032; Erle 6-3-2014_6 and
#: 11-2-2015_112 drift by 0.12-0.36).
ONSET_BASELINE_SIGMA = 0.064
#: With a profile from ONE flight: a healthy airframe's share drift from flight to flight, per
#: motor. Measured on real repeated flights of one airframe: rrc_straight good 1/2/3 (per-motor
#: standard deviation 0.005-0.040, RMS 0.028) and CrazyPAD E9 normal 00/01/02 (RMS 0.006); the
#: larger airframe sets the default, since a single flight cannot show its own spread.
DEFAULT_DRIFT_SIGMA = 0.03
#: A spread measured on a few calibration flights is noisy (two flights give a one-degree-of-
#: freedom estimate), so it is pooled with DEFAULT_DRIFT_SIGMA as a prior worth this many flights
#: (scaled inverse chi-square): rrc good 1+2 agree within 0.02 yet good 3 moves motor 3 by 0.07.
DRIFT_PRIOR_FLIGHTS = 3
#: Relative hover-throttle drift between healthy flights of one airframe (battery charge,
#: temperature). Measured: rrc_straight goods 0.443/0.449/0.457 (3 %), CrazyPAD normals
#: 0.633/0.631/0.631; 0.05 leaves room for a battery swap.
THROTTLE_DRIFT_SIGMA = 0.05

@dataclass
class SeverityFit:
    """One motor's damage fit: LLR of "rotor k at some eta" vs healthy, and eta-hat."""

    llr: float
    eta_hat: float
    eta_ci: tuple[float, float]
    m_hat: float
    chi2: float  # at the best eta, m
    #: the LLR over the drag-torque exponents of measured damage only (``M_GRID`` >= ``DAMAGE_MIN_M``):
    #: what "rotor k" is weighed with against a moved load (:func:`load_fit`)
    llr_vs_load: float = float("nan")
    #: (len(ETA_GRID),) the LLR at each eta (marginal over the drag-torque exponents): ``llr`` is its
    #: mean over the grid in the exp domain
    eta_llr: Optional[np.ndarray] = None


#: Thrust-efficiency grid of the two-rotor hypothesis (uniform prior over both rotors): the
#: single-rotor range on a coarser step, since the joint grid is its square (900 points per
#: pair and drag-torque exponent). Checked against the 0.01 step on 12 noisy simulated pair
#: patterns (eta 0.6-0.85, drift sigma 0.03, with the throttle): the pair LLRs agree within 0.001.
PAIR_ETA_GRID = np.round(np.arange(0.40, 0.995, 0.02), 3)


@dataclass
class PairFit:
    """The two-rotor damage fit of one pair: LLR of "rotors a and b lost thrust" vs healthy and
    both eta-hats (same order as ``motors``)."""

    motors: tuple[int, int]
    llr: float
    eta_hat: tuple[float, float]
    chi2: float


@dataclass
class CommandSharesResult(AnalyzerResult):
    """The command-share analyzer's result: its findings (``share``, ``thrust`` per motor) and the
    fit's figures the decision weighs for "airframe changed" (None when it abstained)."""

    baseline: Optional[str] = None  # "profile" | "before onset" | "neighbours"
    healthy_chi2: Optional[float] = None  # of the shares (and the throttle, ``with_throttle``) against healthy
    fit_chi2: list[float] = field(default_factory=list)  # per motor, at its best eta and m
    share_sigma: Optional[float] = None  # the share noise used (mean over motors)
    with_throttle: bool = False  # the throttle against the profile's is one of the observations
    words: list[str] = field(default_factory=list)  # per motor, plain words for its command share
    drifting: Optional[int] = None  # the motor whose command rose steadily after an onset
    healthy_chi2_shares: Optional[float] = None  # healthy_chi2 of the shares alone (no throttle)
    fit_chi2_shares: list[float] = field(default_factory=list)  # fit_chi2 of the shares alone
    pin: Optional[list[float]] = None  # (n,) how well calibration and this flight pin each share (profile only)
    n_flights: Optional[int] = None  # the profile's calibration flights (None without a profile)
    throttle_sigma: Optional[float] = None  # the relative throttle drift against the baseline
    n_sessions: Optional[int] = None  # the profile's calibration sessions (0: older than schema 6; None: no profile)
    pairs: list[PairFit] = field(default_factory=list)  # each pair's fit (with the throttle when weighed)
    load: Optional["LoadFit"] = None  # the moved-load fit of the shares (:func:`load_fit`)
    #: per motor, the shares' evidence for "rotor k lost thrust" against "a load toward some direction" (nats)
    rotor_vs_load: list[float] = field(default_factory=list)


def _mixer_rows(frame: Optional[Frame], n: int) -> np.ndarray:
    """(4, n) rows: collective thrust, roll moment (-y), pitch moment (x), yaw (spin)."""
    if frame is None or frame.rotor_count != n:
        frame = Frame.quad_x()
    xs = np.array([r.x for r in frame.rotors], dtype=float)
    ys = np.array([r.y for r in frame.rotors], dtype=float)
    sp = np.array([float(r.spin) for r in frame.rotors])
    return np.stack([np.ones(n), -ys, xs, sp])


def predicted_commands(base: np.ndarray, rows: np.ndarray, motor: int, eta: float, m: float) -> np.ndarray:
    """Commands (n,) that hold the same force and moments as the healthy commands ``base`` when
    rotor ``motor`` (1-based) gives ``eta`` of its thrust and ``eta**m`` of its drag torque.

    With more rotors than the four force/moment rows, the commands can only move within the
    allocator's range: the autopilot's mixer turns (throttle, roll, pitch, yaw) demands into motor
    commands through a fixed matrix whose columns follow the geometry (the pseudo-inverse of the
    rows for the symmetric frames), so ``u = base + pinv(rows) @ dv`` with the demand change ``dv``
    that restores the forces. On a hexa this puts the change on the weak rotor and its opposite
    (measured on the simulated hexa sample: +17 % / -17 %, the other four flat), where a
    minimum-norm solution would spread it over all six. With four rotors it is the exact solve."""
    A = rows.copy()
    j = motor - 1
    A[:3, j] *= eta
    A[3, j] *= eta ** m
    if A.shape[0] == A.shape[1]:
        return np.linalg.solve(A, rows @ base)
    alloc = np.linalg.pinv(rows)
    dv = np.linalg.solve(A @ alloc, (rows - A) @ base)
    return base + alloc @ dv


def _pred_table(base: np.ndarray, rows: np.ndarray, motor: int) -> np.ndarray:
    """(len(ETA_GRID), len(M_GRID), n) predicted raw commands: :func:`predicted_commands` for
    the whole eta/m grid in one batched solve."""
    eta, m = np.meshgrid(ETA_GRID, M_GRID, indexing="ij")  # (E, M)
    A = np.broadcast_to(rows, eta.shape + rows.shape).copy()  # (E, M, 4, n)
    j = motor - 1
    A[..., :3, j] *= eta[..., None]
    A[..., 3, j] *= eta ** m
    if rows.shape[0] == rows.shape[1]:
        return np.linalg.solve(A, np.broadcast_to(rows @ base, eta.shape + (rows.shape[0],))[..., None])[..., 0]
    alloc = np.linalg.pinv(rows)  # (n, 4)
    rhs = ((rows - A) @ base)[..., None]  # (E, M, 4, 1)
    dv = np.linalg.solve(A @ alloc, rhs)[..., 0]
    return base + dv @ alloc.T


#: A healthy airframe's shares and throttle move between sessions in two ways: a small drift
#: (the sigmas above) and, in some sessions, a real load change (a battery slid or swapped, a
#: camera moved, a re-trim). The second is a mixture component of the healthy noise, also used
#: around the damage hypothesis (damage plus a moved load), so a change within what a load move
#: makes weighs little by itself and a change beyond it weighs fully. Measured
#: (benchmarks/bench_cross_session.py, 36 one-flight healthy pairs on six real and simulated
#: airframes): per-airframe RMS share change 0.008-0.041 on four of them, 0.13 (Erle board A)
#: and 0.33 (Erle board B, poorly pinned 8-37 s flights) on two; |change| 90/99 % quantiles
#: 0.17/0.50, kurtosis 14.6 (heavy tails). Physics (benchmarks/cross_session_physics.py): a
#: centre-of-mass shift of 5 % of the arm along a diagonal moves that diagonal pair +-0.10, along
#: a body axis all four +-0.07; a 0.5 deg common motor tilt +-0.12 (yaw pattern). So: the share
#: of sessions with a load move, and its per-motor spread (a 5-10 % CoM shift).
SESSION_MOVE_P = 0.3
SESSION_MOVE_SIGMA = 0.13
#: A moved load is one event: it moves the throttle too (a battery or payload change), so in the
#: moved-load component the throttle is free, uniform within +-THROTTLE_MOVE_RANGE (relative);
#: without a move both the shares and the throttle keep their small drift. A weak rotor with no
#: load moved must therefore show its pattern AND its throttle rise. Measured: the one-flight
#: pairs' |log throttle ratio| 50/90/100 %: 0.02/0.47/1.46 (the Erle boards, whose logged output
#: range itself differs between sessions); physics: +-10 % mass moves it +-10 %.
THROTTLE_MOVE_RANGE = 0.6


def _gauss_ll(d, sigma):
    """Gaussian log-density of residuals ``d`` (..., k) with per-entry ``sigma``, summed."""
    d = np.asarray(d, float)
    return -0.5 * np.sum((d / sigma) ** 2 + np.log(2 * np.pi * np.square(sigma)), axis=-1)


def _share_likelihood(share, base_share, sigma, frame, throttle_ratio, throttle_sigma, move):
    """(shares, baseline shares (mean 1), sigma, mixer rows, with_throttle, loglik) for the fits:
    ``loglik(resid (..., n), throttle resid (...) or None) -> (...)`` the log-likelihood of share
    residuals under the small drift, mixed with a moved load when ``move`` (:func:`severity_fit`)."""
    s = np.asarray(share, float)
    b = np.asarray(base_share, float)
    b = b / b.mean()
    sig = np.asarray(sigma, float)
    rows = _mixer_rows(frame, len(s))
    with_thr = throttle_ratio is not None and np.isfinite(throttle_ratio)
    sig_big = np.sqrt(sig ** 2 + SESSION_MOVE_SIGMA ** 2)
    log_u = -np.log(2 * THROTTLE_MOVE_RANGE)  # a moved load's throttle density

    def loglik(resid, thr_resid):
        small = _gauss_ll(resid, sig)
        if with_thr:
            small = small + _gauss_ll(np.asarray(thr_resid)[..., None], np.array([throttle_sigma]))
        if not move:
            return small
        big = _gauss_ll(resid, sig_big) + (log_u if with_thr else 0.0)
        return np.logaddexp(np.log1p(-SESSION_MOVE_P) + small, np.log(SESSION_MOVE_P) + big)

    return s, b, sig, rows, with_thr, loglik


def severity_fit(share: np.ndarray, base_share: np.ndarray, sigma: np.ndarray, frame: Optional[Frame] = None,
                 throttle_ratio: Optional[float] = None,
                 throttle_sigma: float = THROTTLE_DRIFT_SIGMA, move: bool = False,
                 sessions: Optional[SessionDrift] = None,
                 flight_pin: Optional[Sequence[float]] = None) -> tuple[float, list[SeverityFit]]:
    """Fit each motor's damage to the observed shares (mean 1) against the healthy ``base_share``.

    ``sigma`` (n,): each share's noise; ``throttle_ratio``: the flight's mean command over the
    baseline's (None without a profile); ``move``: the healthy noise includes a moved load
    (SESSION_MOVE_*, THROTTLE_MOVE_RANGE: against a calibration from another session; also
    around the damage hypothesis). ``sessions``: against a profile of two or more sessions, the
    airframe's own drift (:class:`~flightlog_fd.analyzers.session_drift.SessionDrift`, with this
    flight's pinning ``flight_pin``) replaces ``sigma``, ``throttle_sigma`` and ``move``, and the
    chi-squares are its equivalents. Returns the healthy chi-square (small drift) and one
    :class:`SeverityFit` per motor (LLR = log Bayes factor over the eta/m prior grid)."""
    s, b, sig, rows, with_thr, loglik = _share_likelihood(share, base_share, sigma, frame, throttle_ratio,
                                                          throttle_sigma, move)
    n = len(s)
    if sessions is not None:
        return _session_severity_fit(s, b, rows, throttle_ratio if with_thr else None, sessions, flight_pin)
    chi_h = float(np.sum(((s - b) / sig) ** 2))
    if with_thr:
        chi_h += ((throttle_ratio - 1.0) / throttle_sigma) ** 2
    ll_h = float(loglik(s - b, throttle_ratio - 1.0 if with_thr else None))
    fits = []
    for k in range(1, n + 1):
        u = _pred_table(b, rows, k)  # (E, M, n)
        mean_u = u.mean(axis=2)
        pred = u / mean_u[..., None]
        chi = np.sum(((s - pred) / sig) ** 2, axis=2)  # (E, M)
        if with_thr:
            chi = chi + ((throttle_ratio - mean_u) / throttle_sigma) ** 2
        ll = loglik(s - pred, throttle_ratio - mean_u if with_thr else None)
        fits.append(_fit_from_grid(ll, ll_h, lambda a, bm: chi[a, bm]))
    return chi_h, fits


def _pair_pred_table(base: np.ndarray, rows: np.ndarray, a: int, b: int) -> np.ndarray:
    """(E, E, M, n) predicted raw commands with rotors ``a`` and ``b`` (1-based) at every pair of
    PAIR_ETA_GRID efficiencies and one drag-torque exponent from M_GRID (:func:`predicted_commands`)."""
    ea, eb, m = np.meshgrid(PAIR_ETA_GRID, PAIR_ETA_GRID, M_GRID, indexing="ij")
    A = np.broadcast_to(rows, ea.shape + rows.shape).copy()  # (E, E, M, 4, n)
    for j, eta in ((a - 1, ea), (b - 1, eb)):
        A[..., :3, j] *= eta[..., None]
        A[..., 3, j] *= eta ** m
    if rows.shape[0] == rows.shape[1]:
        return np.linalg.solve(A, np.broadcast_to(rows @ base, ea.shape + (rows.shape[0],))[..., None])[..., 0]
    alloc = np.linalg.pinv(rows)
    dv = np.linalg.solve(A @ alloc, ((rows - A) @ base)[..., None])[..., 0]
    return base + dv @ alloc.T


def all_pairs(n: int) -> list[tuple[int, int]]:
    """Every pair (a, b) of an n-rotor frame's motors, 1-based, a < b."""
    return [(a, b) for a in range(1, n + 1) for b in range(a + 1, n + 1)]


def pair_fit(share: np.ndarray, base_share: np.ndarray, sigma: np.ndarray, frame: Optional[Frame] = None,
             throttle_ratio: Optional[float] = None, throttle_sigma: float = THROTTLE_DRIFT_SIGMA,
             move: bool = False, pairs: Optional[Sequence[tuple[int, int]]] = None,
             tables: Optional[dict] = None, sessions: Optional[SessionDrift] = None,
             flight_pin: Optional[Sequence[float]] = None) -> list[PairFit]:
    """The two-rotor hypothesis for each pair (default :func:`all_pairs`): the same likelihood as
    :func:`severity_fit`, the commands predicted with both rotors weak (one drag-torque exponent
    for both: the same propeller type), the LLR averaged over the uniform prior on
    PAIR_ETA_GRID x PAIR_ETA_GRID x M_GRID. Its extra free efficiency buys no evidence by itself
    (the average over a prior twice as wide), but two weak rotors explain any share pattern a
    single one does, which is why :mod:`flightlog_fd.decision` asks more of a pair. ``tables``: a
    dict the predicted commands are kept in between calls on the same baseline (with and without
    the throttle). ``sessions``/``flight_pin``: against a profile of two or more sessions, the
    airframe's own drift, as for :func:`severity_fit` (the single rotors and the pairs on one
    likelihood)."""
    s, b, sig, rows, with_thr, loglik = _share_likelihood(share, base_share, sigma, frame, throttle_ratio,
                                                          throttle_sigma, move)
    if sessions is not None:
        log_thr = float(np.log(max(throttle_ratio, 1e-9))) if with_thr else None

        def loglik(resid, thr_resid):  # noqa: F811 - the session drift's likelihood replaces the fixed noise
            return sessions.loglik(resid, thr_resid, flight_pin)

        def thr_resid_of(mean_u):
            return None if log_thr is None else log_thr - np.log(np.clip(mean_u, 1e-9, None))

        def chi_at(resid, thr_resid):
            return sessions.chi2_equivalent(resid, thr_resid, flight_pin)
    else:
        def thr_resid_of(mean_u):
            return throttle_ratio - mean_u if with_thr else None

        def chi_at(resid, thr_resid):
            return float(np.sum((resid / sig) ** 2) + ((thr_resid / throttle_sigma) ** 2 if with_thr else 0.0))
    ll_h = float(loglik(s - b, thr_resid_of(np.float64(1.0))))
    out = []
    for a, c in (pairs if pairs is not None else all_pairs(len(s))):
        key = (a, c, b.tobytes(), rows.tobytes())
        u = tables.get(key) if tables is not None else None
        if u is None:
            u = _pair_pred_table(b, rows, a, c)
            if tables is not None:
                tables[key] = u
        mean_u = u.mean(axis=-1)
        pred = u / mean_u[..., None]
        thr_resid = thr_resid_of(mean_u)
        ll = loglik(s - pred, thr_resid)
        llr = log_mean_exp(ll) - ll_h
        i, j, k = np.unravel_index(int(np.argmax(ll)), ll.shape)
        chi = float(chi_at(s - pred[i, j, k], None if thr_resid is None else thr_resid[i, j, k]))
        hat = tuple(1.0 if x >= PAIR_ETA_GRID[-1] else float(x) for x in (PAIR_ETA_GRID[i], PAIR_ETA_GRID[j]))
        out.append(PairFit(motors=(a, c), llr=llr, eta_hat=hat, chi2=chi))
    return out


def _session_severity_fit(s: np.ndarray, b: np.ndarray, rows: np.ndarray, throttle_ratio: Optional[float],
                          drift: SessionDrift, flight_pin) -> tuple[float, list[SeverityFit]]:
    """:func:`severity_fit` against an airframe's own session drift: the healthy and the damaged
    shares (and the log throttle) weighed with its posterior mixture over the session scale."""
    n = len(s)
    log_thr = None if throttle_ratio is None else float(np.log(max(throttle_ratio, 1e-9)))

    def loglik(resid, thr_resid):
        return drift.loglik(resid, thr_resid, flight_pin)

    ll_h = float(loglik(s - b, log_thr))
    chi_h = drift.chi2_equivalent(s - b, log_thr, flight_pin)
    fits = []
    for k in range(1, n + 1):
        u = _pred_table(b, rows, k)  # (E, M, n)
        mean_u = u.mean(axis=2)
        pred = u / mean_u[..., None]
        thr_resid = None if log_thr is None else log_thr - np.log(np.clip(mean_u, 1e-9, None))
        ll = loglik(s - pred, thr_resid)
        fits.append(_fit_from_grid(ll, ll_h, lambda a, bm: drift.chi2_equivalent(
            s - pred[a, bm], None if thr_resid is None else thr_resid[a, bm], flight_pin)))
    return chi_h, fits


def _fit_from_grid(ll: np.ndarray, ll_h: float, chi_at) -> SeverityFit:
    """One motor's :class:`SeverityFit` from its log-likelihood over the eta/m grid (``ll`` (E, M))
    and the healthy one; ``chi_at(a, bm)``: the chi-square at the best grid point."""
    top = ll.max()
    llr = log_mean_exp(ll) - ll_h
    llr_yawed = log_mean_exp(ll[:, M_GRID >= DAMAGE_MIN_M]) - ll_h
    post_eta = np.exp(ll - top).sum(axis=1)
    cdf = np.cumsum(post_eta / post_eta.sum())
    ia = min(int(np.searchsorted(cdf, 0.05)), len(ETA_GRID) - 1)
    ib = min(int(np.searchsorted(cdf, 0.95)), len(ETA_GRID) - 1)
    # the interval never collapses: at least one grid step each side, and open below the grid
    lo = 0.0 if ia == 0 else float(ETA_GRID[max(ia - (ia == ib), 0)])
    hi = float(ETA_GRID[min(ib + (ia == ib), len(ETA_GRID) - 1)])
    a, bm = np.unravel_index(int(np.argmax(ll)), ll.shape)
    eta_hat = float(ETA_GRID[a])
    # a best fit at the grid's healthy end means "no loss": report 1.0 with the interval
    if eta_hat >= ETA_GRID[-1]:
        eta_hat, hi = 1.0, 1.0
    return SeverityFit(llr=llr, eta_hat=eta_hat, eta_ci=(lo, hi), m_hat=float(M_GRID[bm]), chi2=float(chi_at(a, bm)),
                       llr_vs_load=llr_yawed, eta_llr=log_mean_exp(ll, axis=1) - ll_h)


def pooled_sigma(measured: Optional[float], n_flights: int, prior: float) -> float:
    """A spread measured on ``n_flights`` flights pooled with ``prior`` (worth
    ``DRIFT_PRIOR_FLIGHTS`` flights); ``prior`` alone when nothing was measured."""
    if measured is None or not np.isfinite(measured) or n_flights < 2:
        return prior
    dof = n_flights - 1
    return float(np.sqrt((DRIFT_PRIOR_FLIGHTS * prior ** 2 + dof * measured ** 2) / (DRIFT_PRIOR_FLIGHTS + dof)))


def share_sigma(baseline_kind: str, spread: Optional[Sequence[float]], n: int, n_flights: int = 1,
                pins: Sequence[Optional[Sequence[float]]] = ()) -> np.ndarray:
    """Per-motor share noise for the kind of baseline (module constants): without a profile the
    spread across healthy airframes; with one, the airframe's drift (measured, pooled, or default)
    added in quadrature to how well the calibration and this flight pin their shares (``pins``:
    per-motor :func:`flightlog_fd.analyzers.share_fit.pin_spread` figures, None where unknown)."""
    if baseline_kind == "neighbours":
        return np.full(n, NEIGHBOUR_SHARE_SIGMA if n == 4 else NROTOR_NEIGHBOUR_SHARE_SIGMA.get(n, NEIGHBOUR_SHARE_SIGMA))
    if baseline_kind == "before onset":
        return np.full(n, ONSET_BASELINE_SIGMA)
    if spread is not None and len(spread) == n and np.all(np.isfinite(spread)):
        measured = float(np.sqrt(np.mean(np.square(spread))))
        out = np.full(n, pooled_sigma(measured, n_flights, DEFAULT_DRIFT_SIGMA))
    else:
        out = np.full(n, DEFAULT_DRIFT_SIGMA)
    for p in pins:
        if p is not None and len(p) == n and np.all(np.isfinite(p)):
            out = np.sqrt(out ** 2 + np.square(np.asarray(p, float)))
    return out


#: A moved or added load (a payload, camera or battery off the centre) needs a constant roll and
#: pitch moment, so it raises the motors on its side and lowers those opposite: each motor's share
#: moves by ``a * cos(angle to the load)`` (the rotor straight toward it by ``a``, the one opposite
#: by ``-a``, those across by 0), with no yaw part (the rotors on one diagonal share a spin, their
#: torques cancel). A rotor that lost thrust raises its own command alone, which carries a yaw part
#: as large as its roll/pitch part. Measured (benchmarks/load_physics.py, results/load_vs_damage.md):
#: yaw over roll/pitch 0.08-0.13 on px4_sih_dev_load's four moved centres of mass, 0.8-1.7 on
#: px4_sih_dev's weak motors, 0.6-1.2 on rrc_straight's 10-25 mm cuts, 0.99 on ArduPilot SITL's weak
#: motor. The load's size prior is uniform over a disc of this radius in share change of the motor
#: straight toward it: a centre of mass 30 % of the arm off the centre (beyond it a quad is
#: re-balanced before it flies; cross_session_physics.py: +0.6).
LOAD_MAX_SHARE = 0.6
#: Below this drag-torque exponent a weak rotor's pattern is a moved load's (its yaw part over its
#: roll/pitch part is about m: 0.26 at m = 0.25, predicted_commands), so "rotor k" is weighed against
#: a load on M_GRID from here: the smallest yaw / roll-pitch ratio measured on real damage is 0.47
#: (CrazyPAD 1.5 mm cuts; rrc_straight 10-25 mm 0.58-1.19, px4_sih_dev 0.77-1.69, ArduPilot SITL 0.99).
DAMAGE_MIN_M = 0.5
#: The grid step of the load's two share-change components (0.01: below the 0.03 drift noise of
#: the tightest profile baseline, DEFAULT_DRIFT_SIGMA).
LOAD_GRID_STEP = 0.01


@dataclass
class LoadFit:
    """The moved-load hypothesis on the command shares (:func:`load_fit`): its LLR against healthy
    (log Bayes factor over the size/direction prior), the best direction (degrees in the body
    frame: 0 forward, +90 right), its size (the share change of a motor straight toward it), the
    motor nearest that direction, and the chi-square at the best fit."""

    llr: float
    direction_deg: float
    size: float
    motor: int
    chi2: float

    def as_dict(self) -> dict:
        return {"motor": int(self.motor), "direction_deg": round(float(self.direction_deg), 1),
                "size": round(float(self.size), 4), "llr": round(float(self.llr), 4)}


def load_patterns(frame: Optional[Frame], n: int) -> np.ndarray:
    """(2, n) share-change patterns of a unit load toward body x (forward) and body y (right):
    each motor's position along that axis over the largest arm, so the rotor straight toward a
    load of size ``a`` changes by ``a``."""
    if frame is None or frame.rotor_count != n:
        frame = Frame.quad_x()
    xy = np.array([[r.x, r.y] for r in frame.rotors], dtype=float)
    arm = float(np.max(np.hypot(xy[:, 0], xy[:, 1]))) or 1.0
    return (xy / arm).T


def _load_grid() -> np.ndarray:
    """(G, 2) load components (toward x, toward y) on the uniform disc prior."""
    g = np.arange(-LOAD_MAX_SHARE, LOAD_MAX_SHARE + 1e-9, LOAD_GRID_STEP)
    ax, ay = np.meshgrid(g, g, indexing="ij")
    keep = np.hypot(ax, ay) <= LOAD_MAX_SHARE + 1e-9
    return np.stack([ax[keep], ay[keep]], axis=1)


def load_fit(share: np.ndarray, base_share: np.ndarray, sigma: np.ndarray, frame: Optional[Frame] = None,
             move: bool = False, sessions: Optional[SessionDrift] = None,
             flight_pin: Optional[Sequence[float]] = None) -> LoadFit:
    """The moved-load hypothesis on the shares alone (the throttle is free: an added mass moves it):
    shares = baseline + a load's pattern (:func:`load_patterns`), on the same likelihood as
    :func:`severity_fit` (``move``, ``sessions``: as there), averaged over the uniform disc prior
    (``LOAD_MAX_SHARE``). Limits: a weight that also takes thrust from a rotor (under its disc)
    looks like that rotor's loss, not like this."""
    s, b, sig, rows, _, loglik = _share_likelihood(share, base_share, sigma, frame, None, THROTTLE_DRIFT_SIGMA, move)
    n = len(s)
    if sessions is not None:
        def loglik(resid, thr_resid):  # noqa: F811 - the session drift's likelihood replaces the fixed noise
            return sessions.loglik(resid, thr_resid, flight_pin)
    pat = load_patterns(frame, n)
    grid = _load_grid()
    pred = b + grid @ pat  # (G, n)
    ll = loglik(s - pred, None)
    ll_h = float(loglik(s - b, None))
    llr = log_mean_exp(ll) - ll_h
    i = int(np.argmax(ll))
    ax, ay = grid[i]
    size = float(np.hypot(ax, ay))
    toward = pat.T @ np.array([ax, ay])
    chi2 = (sessions.chi2_equivalent(s - pred[i], None, flight_pin) if sessions is not None
            else float(np.sum(((s - pred[i]) / sig) ** 2)))
    return LoadFit(llr=llr, direction_deg=float(np.degrees(np.arctan2(ay, ax))), size=size,
                   motor=int(np.argmax(toward)) + 1, chi2=float(chi2))


def load_fit_for(ctx: Context) -> Optional[LoadFit]:
    """The flight's :class:`LoadFit` on the shares alone, or None; once per diagnosis, after
    :func:`fits_for` (the same inputs)."""
    key = "commands.load"
    if key not in ctx.memo:
        inputs = ctx.memo.get(("commands.inputs", False)) if fits_for(ctx, False) else None
        if inputs is None:
            ctx.memo[key] = None
        else:
            shares, base, sig, _, _, profile, drift, pin = inputs
            ctx.memo[key] = load_fit(shares, base, sig, ctx.frame, move=profile, sessions=drift, flight_pin=pin)
    return ctx.memo[key]


def fits_for(ctx: Context, with_throttle: bool) -> Optional[tuple[float, list[SeverityFit], np.ndarray]]:
    """(healthy chi-square, per-motor fits, share sigma) of the flight's shares, or None; computed
    once per diagnosis (the command-share and throttle analyzers both need them)."""
    key = ("commands.fits", with_throttle)
    if key not in ctx.memo:
        ctx.memo[key] = _fits(ctx, with_throttle)
    return ctx.memo[key]


def _fits(ctx: Context, with_throttle: bool) -> Optional[tuple[float, list[SeverityFit], np.ndarray]]:
    inputs = fit_inputs(ctx.share_fit, with_throttle)
    if inputs is None:
        return None
    shares, base, sig, ratio, thr_sig, profile, drift, pin = inputs
    chi_h, fits = severity_fit(shares, base, sig, ctx.frame, ratio, thr_sig, move=profile, sessions=drift,
                               flight_pin=pin)
    ctx.memo[("commands.inputs", with_throttle)] = inputs
    return chi_h, fits, sig


def fit_inputs(share_fit, with_throttle: bool) -> Optional[tuple]:
    """What the fits weigh a share fit with: (shares, baseline shares, share sigma, throttle ratio or
    None, throttle sigma, against a profile, the airframe's session drift or None, the flight's
    pinning); None without finite shares."""
    if share_fit is None:
        return None
    shares = np.array([m.command_share for m in share_fit.motors], float)
    if not np.all(np.isfinite(shares)):
        return None
    n = len(shares)
    base = (np.ones(n) if share_fit.baseline == "neighbours"
            else np.array([m.command_share_baseline for m in share_fit.motors], float))
    b = share_fit.baseline_
    n_flights = 1 if b is None else b.n_flights
    profile = share_fit.baseline == "profile"
    # a profile made before the pinning was measured is taken to pin no better than this flight
    pins = ((share_fit.pin if b.pin is None else b.pin), share_fit.pin) if (profile and b is not None) else ()
    sig = share_sigma(share_fit.baseline, None if b is None else b.spread, n, n_flights, pins)
    ratio = share_fit.throttle_ratio if with_throttle else None
    thr_sig = pooled_sigma(None if b is None else b.throttle_spread, n_flights, THROTTLE_DRIFT_SIGMA)
    drift = session_drift(share_fit) if profile else None
    if drift is not None:
        sig = drift.share_sigma(share_fit.pin)
    return shares, base, sig, ratio, thr_sig, profile, drift, share_fit.pin


def configuration_evidence(share_fit, frame: Optional[Frame]) -> float:
    """How well a profile configuration's baseline explains the flight's commands (log evidence,
    nats): the shares and the throttle against it on the command analyzer's own likelihood
    (:func:`severity_fit`: the profile's drift, the moved-load mixture, the airframe's session drift),
    averaged over "healthy" and "rotor k lost thrust" for every k with equal prior weight. A load
    relative to the configuration is not among the hypotheses: the configurations are the loads the
    airframe is known to fly with, and a weak rotor against the right one still fits as a rotor.
    -inf without finite shares."""
    inputs = fit_inputs(share_fit, share_fit is not None and share_fit.throttle_ratio is not None)
    if inputs is None:
        return float("-inf")
    shares, base, sig, ratio, thr_sig, profile, drift, pin = inputs
    _, fits = severity_fit(shares, base, sig, frame, ratio, thr_sig, move=profile, sessions=drift, flight_pin=pin)
    b = base / base.mean()
    if drift is not None:
        log_thr = None if ratio is None else float(np.log(max(ratio, 1e-9)))
        ll_h = float(drift.loglik(shares - b, log_thr, pin))
    else:
        *_, loglik = _share_likelihood(shares, base, sig, frame, ratio, thr_sig, profile)
        ll_h = float(loglik(shares - b, None if ratio is None else ratio - 1.0))
    return ll_h + log_mean_exp([0.0] + [f.llr for f in fits])


#: A load configuration replaces the profile's own ("as calibrated") only when its baseline explains
#: the flight's commands better by this many nats (:func:`configuration_evidence`, a Bayes factor of
#: e^3 = 20): a weak rotor's pattern can resemble another load's (a weak motor 1 raises motor 1 as a
#: load toward it does), and a flight between the two is judged as without the configuration.
#: Measured (benchmarks/bench_load_configurations.py, results/load_configurations.md): the loaded
#: flights of a configuration beat "as calibrated" by 7.1 nats (px4_sih_dev_load com_m1 at 10 Hz
#: against the com_m1 configuration); px4_sih_dev's 15 weak motors by +0.5 at most (sih_053, motor 1 at
#: 80 %: against the motor-1 load it read as motor 2 lost thrust), 14 of them not at all.
CONFIGURATION_MARGIN_NATS = 3.0


def nearest_configuration(profile, fit, frame: Optional[Frame]) -> tuple:
    """(share fit, configuration) of the profile configuration whose baseline best explains the
    flight's commands (:func:`configuration_evidence`; a load configuration by at least
    ``CONFIGURATION_MARGIN_NATS`` over "as calibrated"). ``fit(baseline)`` makes the flight's share
    fit against one baseline (:func:`~flightlog_fd.analyzers.share_fit.fit_shares` with the
    flight's segments). ``configuration``: None for a profile of one configuration, else
    ``{"name", "load", "of", "analyzers", "evidence"}`` (``of``: how many it holds; ``analyzers``:
    the configuration's own analyzer baselines, e.g. the model votes'; ``evidence``: each one's log
    evidence by name, nats). Without a profile (or motor figures): (fit(None), None)."""
    options = profile.baselines() if profile is not None else []
    if not options:
        return fit(None), None
    first = fit(options[0][2])
    if len(options) == 1:
        return first, None
    fits = [first] + [fit(b) for _, _, b, _ in options[1:]]
    ev = [configuration_evidence(f, frame) for f in fits]
    i = int(np.argmax(ev)) if np.any(np.isfinite(ev)) else 0
    if i and not ev[i] - ev[0] >= CONFIGURATION_MARGIN_NATS:
        i = 0
    name, load, _, own = options[i]
    fits[i].configuration = {"name": name, "load": load, "of": len(options), "analyzers": own,
                             "evidence": {n: round(float(e), 2) for (n, _, _, _), e in zip(options, ev)}}
    return fits[i], fits[i].configuration


def session_drift(share_fit) -> Optional[SessionDrift]:
    """The airframe's own session drift when the profile holds two or more sessions, else None."""
    b = share_fit.baseline_
    figs = None if b is None else b.sessions
    if figs is None or figs.n_sessions < 2 or figs.shares.shape[1] != len(share_fit.motors):
        return None
    return SessionDrift.fit(figs, DEFAULT_DRIFT_SIGMA, THROTTLE_DRIFT_SIGMA)


def pair_fits_for(ctx: Context, with_throttle: bool) -> Optional[list[PairFit]]:
    """Every pair's two-rotor fit (:func:`pair_fit`) of the flight's shares, or None (also on a rotor
    count outside ``PAIR_ROTOR_COUNTS``); computed once per diagnosis, after :func:`fits_for` (the
    command-share and throttle analyzers both need them), on the same likelihood as the single
    rotors (the airframe's own session drift when the profile holds two or more sessions)."""
    key = ("commands.pairs", with_throttle)
    if key not in ctx.memo:
        inputs = ctx.memo.get(("commands.inputs", with_throttle)) if fits_for(ctx, with_throttle) else None
        if inputs is None or len(inputs[0]) not in PAIR_ROTOR_COUNTS:
            ctx.memo[key] = None
        else:
            shares, base, sig, ratio, thr_sig, profile, drift, pin = inputs
            tables = ctx.memo.setdefault("commands.pair_tables", {})
            ctx.memo[key] = pair_fit(shares, base, sig, ctx.frame, ratio, thr_sig, move=profile, tables=tables,
                                     sessions=drift, flight_pin=pin)
    return ctx.memo[key]


class CommandShares(Analyzer):
    id = "commands"
    description = "the steady command pattern against the healthy baseline, with each rotor's thrust (eta-hat)"
    requires = ("motors",)
    #: Which rotor's loss fits the pattern is mixer physics: clipping each motor alone tied every
    #: rotor above the cap (simulated octaquads with a profile: the weak rotor 6-59 nats, its
    #: coaxial partner, same roll/pitch levers and the opposite spin, 1-24; both at 8, the decision
    #: could not choose in 13 of 46 damaged flights; benchmarks/bench_nrotor.py).
    cap_keeps_order = True
    #: Means only (any rate serves); the healthy spread it is weighed against depends on the profile
    #: and, without one, on the rotor count.
    reliability_keys = ("profile", "rotors")

    def analyze(self, ctx: Context) -> AnalyzerResult:
        share_fit = ctx.share_fit
        why = self.missing(ctx.flight)
        if why or share_fit is None:
            return CommandSharesResult(self.id, abstained=why or "no command shares")
        drifting = share_fit.drifting() if share_fit.baseline == "before onset" else None
        if drifting is not None:
            return CommandSharesResult(self.id, abstained=f"motor {drifting}'s command rose steadily after the onset",
                                  notes=[f"motor {drifting} needed steadily more command after the onset (a drift, not "
                                         f"the step a broken propeller makes): inspect motor {drifting}, its ESC and mount"],
                                       drifting=drifting)
        plain = fits_for(ctx, with_throttle=False)
        if plain is None:
            return CommandSharesResult(self.id, abstained="the command shares are not finite")
        chi_h, fits, sig = plain
        full = fits_for(ctx, with_throttle=True) if share_fit.throttle_ratio is not None else plain
        chi_full, fits_full, _ = full
        load = load_fit_for(ctx)  # weighed against each rotor by the decision (rotor_vs_load)
        findings = []
        for k, (m, f, ff) in enumerate(zip(share_fit.motors, fits, fits_full)):
            base = 1.0 if m.command_share_baseline is None else m.command_share_baseline  # no profile: even
            findings.append(Finding(self.id, k + 1, "share", m.command_share, "", None, base, "up", f.llr,
                                    f"{m.command_share:.3f} {100 * (m.command_share / base - 1):+.0f}%"))
            lo, hi = ff.eta_ci
            findings.append(Finding(self.id, k + 1, "thrust", ff.eta_hat, "of normal", ff.eta_ci, 1.0, "down", None,
                                    f"{100 * ff.eta_hat:.0f} ({100 * lo:.0f}-{100 * hi:.0f})"))
        pairs_plain = pair_fits_for(ctx, with_throttle=False) or []
        pairs_full = (pair_fits_for(ctx, with_throttle=True) if share_fit.throttle_ratio is not None
                      else pairs_plain) or []
        return CommandSharesResult(self.id, findings, pair_llrs={p.motors: p.llr for p in pairs_plain},
                                   eta_llrs={k + 1: f.eta_llr for k, f in enumerate(fits) if f.eta_llr is not None},
                                   load=load, rotor_vs_load=[] if load is None else [f.llr_vs_load - load.llr for f in fits],
                                   pairs=list(pairs_full), baseline=share_fit.baseline, healthy_chi2=chi_full,
                                   fit_chi2=[f.chi2 for f in fits_full], share_sigma=float(np.mean(sig)),
                                   with_throttle=share_fit.throttle_ratio is not None,
                                   words=[share_fit.summary(k + 1) for k in range(len(share_fit.motors))],
                                   healthy_chi2_shares=chi_h, fit_chi2_shares=[f.chi2 for f in fits],
                                   pin=_combined_pin(share_fit),
                                   n_flights=None if share_fit.baseline_ is None else share_fit.baseline_.n_flights,
                                   n_sessions=None if share_fit.baseline_ is None else share_fit.baseline_.n_sessions,
                                   throttle_sigma=_throttle_sigma(share_fit))


def _throttle_sigma(share_fit) -> float:
    """The relative throttle drift against the baseline (measured spread pooled with the default;
    the airframe's own session drift against a profile of two or more sessions)."""
    drift = session_drift(share_fit) if share_fit.baseline == "profile" else None
    if drift is not None:
        return drift.throttle_sigma()
    b = share_fit.baseline_
    return pooled_sigma(None if b is None else b.throttle_spread, 1 if b is None else b.n_flights,
                        THROTTLE_DRIFT_SIGMA)


def _combined_pin(share_fit) -> Optional[list[float]]:
    """(n,) how well the calibration and this flight together pin each share (quadrature), or None."""
    b = share_fit.baseline_
    if share_fit.baseline != "profile" or b is None:
        return None
    parts = [np.asarray(p, float) for p in ((share_fit.pin if b.pin is None else b.pin), share_fit.pin)
             if p is not None and len(p) == len(share_fit.motors)]
    return [float(x) for x in np.sqrt(np.sum(np.square(parts), axis=0))] if parts else None
