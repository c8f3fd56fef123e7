"""Per-motor effectiveness from the log alone: the paper's NIF relation made explicit.

What it estimates
-----------------
The rigid body obeys ``J·ω̇ = Σ_i r_i × F_i + τ_drag + τ_ext``: each rotor's thrust ``F_i`` acts on
its lever arm (roll: ``−y_i``, pitch: ``x_i``) and its drag torque on yaw (``spin_i``). With the
thrust proxy ``u_i`` (the NIF ``ω_i²`` channel, ``features.thrust_proxy``) standing for thrust,

    ṗ(t) = g_p · Σ_i (−y_i) · e_i · u_i(t) + c_p(t),     q̇ = g_q · Σ_i x_i · e_i · u_i + c_q,
    ṙ(t) = g_r · Σ_i spin_i · d_i · u_i(t) + c_r(t)

where ``g_a`` is an axis gain (arm / inertia, unknown and not needed), ``e_i`` the rotor's thrust
effectiveness and ``d_i`` its drag-torque effectiveness (1 for a healthy rotor, ``η`` for a
damaged one), and ``c_a(t)`` everything slow: constant trims (centre of mass off the middle, yaw
trim, motor tilt) and slowly varying aerodynamic moments. Per axis the coefficients
``b_{a,i} = g_a·s_{a,i}·e_i`` are fitted by least squares over the whole airborne time, after
removing ``c_a(t)`` by high-passing both sides with the same centred moving average
(``DETREND_S``): a trim or a wind moment is absorbed, the fast command → acceleration relation
that a rotor's effectiveness sets is kept. ``b_{a,i}/s_{a,i}`` is motor i's effectiveness on that
axis up to the axis gain; roll and pitch are combined with inverse-variance weights, and each
motor's **relative effectiveness** is its value divided by the median of the other three (1.0 =
as effective as its neighbours; a rotor with ``η = 0.7`` reads ≈ 0.70 when the others are
healthy). Yaw (drag torque) is reported apart, because a cut tip loses drag torque in another
proportion than thrust and yaw is excited far less in ordinary flight.

Streams and lag: the same :func:`flightlog_fd.features.resample` as the NIF windows (50 Hz grid,
airborne time only, gaps split segments, Savitzky-Golay ``ṗ q̇ ṙ``); the commands are passed
through the same Savitzky-Golay smoothing as the gyro (so both sides carry the same filter) and a
first-order motor lag whose time constant is chosen per flight from ``MOTOR_LAG_GRID_S`` by the
best fit.

Confidence: a moving-block bootstrap over the flight (``BLOCK_S`` blocks, ``N_BOOTSTRAP``
resamples, seeded) gives a 90 % interval per motor (``CI_LEVEL``). A flight with too little
manoeuvring (any motor's interval wider than ``MAX_CI_WIDTH``, or under ``MIN_SECONDS`` of usable
flight) is reported as ``informative = False`` with the reason: its numbers are shown but must not
decide anything.

Limits: quadrotors with known rotor geometry (``Flight.frame``; quad-X by default); the commands
stand for thrust, so a saturated motor or a motor whose thrust curve is far from the proxy biases
its value; a centre of mass off the middle by ``δ`` of the arm changes the roll/pitch levers by
about ``δ`` and so the healthy motors' values by a few %; slow motor logging (10 Hz RCOU) keeps only
manoeuvres below ~3 Hz and widens the intervals (``benchmarks/bench_effectiveness.py`` prints how
much).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from scipy.signal import lfilter, savgol_filter

from .errors import FlightLogError
from .features import DEFAULT_RATE_HZ, DEFAULT_SAVGOL_WINDOW_S, SAVGOL_POLYORDER, Segment, _odd_window, resample
from .flight import Flight, Frame

#: Centred moving-average length (s) removed from both sides before the fit (0.3-0.5 s gave the
#: smallest error on simulated flights with known η: rmse 0.05 against 0.08 at 1 s and 0.10 at 2 s,
#: px4_high, 16 flights): longer than a
#: manoeuvre's command → response (0.05-0.5 s), shorter than trims and wind changes.
DETREND_S = 0.4
#: Candidate first-order motor time constants (s); the best least-squares fit wins.
MOTOR_LAG_GRID_S = (0.0, 0.02, 0.04, 0.06, 0.09, 0.13)
#: Bootstrap block length (s) and number of resamples; blocks keep the residuals' correlation.
BLOCK_S = 2.0
N_BOOTSTRAP = 200
CI_LEVEL = 0.90
#: Below this much usable airborne time (s) nothing is estimated.
MIN_SECONDS = 10.0
#: An interval wider than this (relative effectiveness units) means the flight did not
#: manoeuvre enough to say anything about that motor.
MAX_CI_WIDTH = 0.25
#: Seed of the bootstrap: the same log always gives the same interval.
BOOTSTRAP_SEED = 20261123


@dataclass
class MotorEffectiveness:
    """One motor's estimate: relative thrust effectiveness (1 = as its neighbours) with its
    interval, and the drag-torque (yaw) effectiveness with its interval (None when yaw was not
    excited enough to fit)."""

    motor: int
    effectiveness: float
    ci: tuple[float, float]
    yaw_effectiveness: Optional[float] = None
    yaw_ci: Optional[tuple[float, float]] = None


@dataclass
class EffectivenessEstimate:
    """Per-motor relative effectiveness of one flight (see the module docstring)."""

    motors: list[MotorEffectiveness] = field(default_factory=list)
    informative: bool = False
    reason: str = ""
    seconds: float = 0.0
    motor_lag_s: float = 0.0
    r2: tuple[float, float, float] = (0.0, 0.0, 0.0)  # fit quality per axis (roll, pitch, yaw)

    @property
    def values(self) -> np.ndarray:
        return np.array([m.effectiveness for m in self.motors]) if self.motors else np.full(4, np.nan)

    @property
    def ci(self) -> np.ndarray:
        return np.array([m.ci for m in self.motors]) if self.motors else np.full((4, 2), np.nan)

    def weakest(self) -> Optional[int]:
        """1-based motor with the lowest effectiveness (None without an estimate)."""
        v = self.values
        return int(np.nanargmin(v)) + 1 if np.isfinite(v).any() else None

    def as_dict(self) -> dict:
        return {
            "informative": self.informative, "reason": self.reason, "seconds": round(self.seconds, 1),
            "motor_lag_s": self.motor_lag_s, "r2": [round(float(x), 3) for x in self.r2],
        }


def axis_signs(frame: Optional[Frame]) -> np.ndarray:
    """(3, 4) lever signs of each motor on roll, pitch, yaw, normalised to mean |s| = 1 per axis."""
    frame = frame if frame is not None and frame.is_quad else Frame.quad_x()
    s = np.array([[-r.y for r in frame.rotors], [r.x for r in frame.rotors],
                  [float(r.spin) for r in frame.rotors]], dtype=np.float64)
    scale = np.mean(np.abs(s), axis=1, keepdims=True)
    return s / np.where(scale > 0, scale, 1.0)


def _moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving average along axis 0 with edge-shrinking windows (same length as x)."""
    if n <= 1:
        return x.copy()
    c = np.vstack([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    i = np.arange(x.shape[0])
    lo = np.clip(i - n // 2, 0, x.shape[0])
    hi = np.clip(i + n // 2 + 1, 0, x.shape[0])
    return (c[hi] - c[lo]) / (hi - lo)[:, None]


def _lag(u: np.ndarray, tau_s: float, rate_hz: float) -> np.ndarray:
    """First-order lag (time constant ``tau_s``) of each column, started at its first value."""
    if tau_s <= 0:
        return u
    a = np.exp(-1.0 / (tau_s * rate_hz))
    zi = (a * u[0])[None, :]
    y, _ = lfilter([1.0 - a], [1.0, -a], u, axis=0, zi=zi)
    return y


def _usable(segments: list[Segment], savgol_n: int, detrend_n: int) -> list[Segment]:
    return [seg for seg in segments if len(seg) >= max(savgol_n, detrend_n // 2)]


def _detrended_acc(segments: list[Segment], detrend_n: int) -> tuple[np.ndarray, np.ndarray]:
    """Detrended angular accelerations (n, 3) and each row's time (n,), segments stacked."""
    if not segments:
        return np.zeros((0, 3)), np.zeros(0)
    ys = [np.asarray(seg.ang_acc, dtype=np.float64) for seg in segments]
    return np.vstack([y - _moving_average(y, detrend_n) for y in ys]), np.concatenate([seg.t for seg in segments])


def _detrended_commands(segments: list[Segment], tau_s: float, rate_hz: float, savgol_n: int,
                        detrend_n: int) -> np.ndarray:
    """Lagged, smoothed and detrended thrust commands (n, 4), rows as in _detrended_acc."""
    if not segments:
        return np.zeros((0, 4))
    xs = []
    for seg in segments:
        u = _lag(np.asarray(seg.w_sq, dtype=np.float64), tau_s, rate_hz)
        u = savgol_filter(u, savgol_n, SAVGOL_POLYORDER, deriv=0, axis=0)
        xs.append(u - _moving_average(u, detrend_n))
    return np.vstack(xs)


def _relative(b: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Per-axis effectiveness b/s -> relative to the median of the other three motors.

    ``b`` (..., 3, 4) coefficients; returns (..., 3, 4), NaN where a motor has no lever on an axis.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(np.abs(signs) > 1e-9, b / signs, np.nan)
    out = np.full_like(e, np.nan)
    for i in range(4):
        others = np.delete(e, i, axis=-1)
        ref = np.nanmedian(others, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[..., i] = e[..., i] / ref
    return out


def _combine(rel: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Inverse-variance mean of roll and pitch estimates per motor: rel/var (..., 2, 4)."""
    w = np.where(np.isfinite(rel) & np.isfinite(var) & (var > 0), 1.0 / np.where(var > 0, var, 1.0), 0.0)
    num = np.nansum(np.where(w > 0, rel * w, 0.0), axis=-2)
    den = w.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def estimate_effectiveness(flight: Flight, *, rate_hz: float = DEFAULT_RATE_HZ,
                           savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S,
                           segments: Optional[list[Segment]] = None,
                           n_bootstrap: int = N_BOOTSTRAP, seed: int = BOOTSTRAP_SEED) -> EffectivenessEstimate:
    """Relative per-motor effectiveness of ``flight`` (see the module docstring).

    ``segments`` may be given when the caller already resampled the flight at ``rate_hz``.
    Never raises for a flight that simply has too little data: returns ``informative=False``
    with the reason.
    """
    if segments is None:
        try:
            segments = resample(flight, rate_hz=rate_hz, savgol_window_s=savgol_window_s)
        except FlightLogError as e:
            return EffectivenessEstimate(reason=e.message)
    seconds = float(sum(s.duration_s for s in segments))
    if seconds < MIN_SECONDS:
        return EffectivenessEstimate(reason=f"only {seconds:.0f} s of usable airborne data "
                                            f"(the estimate needs {MIN_SECONDS:.0f} s)", seconds=seconds)
    signs = axis_signs(flight.frame)
    savgol_n = _odd_window(savgol_window_s, rate_hz)
    detrend_n = max(3, int(round(DETREND_S * rate_hz)) | 1)

    usable = _usable(segments, savgol_n, detrend_n)
    Y, t = _detrended_acc(usable, detrend_n)  # the lag only changes the commands
    best = None
    for tau in MOTOR_LAG_GRID_S:
        X = _detrended_commands(usable, tau, rate_hz, savgol_n, detrend_n)
        if X.shape[0] < 5 * X.shape[1]:
            continue
        coef, *_ = np.linalg.lstsq(X, Y, rcond=None)  # (4, 3)
        resid = Y - X @ coef
        sse = float(np.sum(resid[:, :2] ** 2))  # roll/pitch decide the lag (yaw is weakly excited)
        if best is None or sse < best[0]:
            best = (sse, tau, X, coef)
    if best is None:
        return EffectivenessEstimate(reason="too few samples for the fit", seconds=seconds)
    _, tau, X, coef = best
    tss = np.sum(Y ** 2, axis=0)
    r2 = tuple(float(1.0 - np.sum((Y[:, a] - X @ coef[:, a]) ** 2) / tss[a]) if tss[a] > 0 else 0.0
               for a in range(3))

    # Moving-block bootstrap over the flight: per-block normal equations, summed with
    # multinomial block counts, so each resample is a 4x4 solve.
    block = np.floor((t - t[0]) / BLOCK_S).astype(int)
    _, block = np.unique(block, return_inverse=True)
    nb = int(block.max()) + 1
    XtX = np.zeros((nb, 4, 4))
    XtY = np.zeros((nb, 4, 3))
    np.add.at(XtX, block, X[:, :, None] * X[:, None, :])
    np.add.at(XtY, block, X[:, :, None] * Y[:, None, :])
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(nb, np.full(nb, 1.0 / nb), size=n_bootstrap).astype(np.float64)  # (B, nb)
    A = np.einsum("bk,kij->bij", counts, XtX) + 1e-12 * np.eye(4)
    B = np.einsum("bk,kij->bij", counts, XtY)
    try:
        boot = np.linalg.solve(A, B)  # (B, 4, 3)
    except np.linalg.LinAlgError:
        return EffectivenessEstimate(reason="the motor commands never varied independently", seconds=seconds)
    b_all = np.concatenate([coef.T[None], np.transpose(boot, (0, 2, 1))], axis=0)  # (1+B, 3, 4)
    rel = _relative(b_all, signs)  # (1+B, 3, 4)
    with warnings.catch_warnings():  # a motor without a lever on an axis (quad-+) is all-NaN there
        warnings.simplefilter("ignore", RuntimeWarning)
        var = np.nanvar(rel[1:], axis=0)  # (3, 4)
    thrust = _combine(rel[:, :2], var[None, :2].repeat(rel.shape[0], axis=0))  # (1+B, 4)
    lo_q, hi_q = (1.0 - CI_LEVEL) / 2.0, 1.0 - (1.0 - CI_LEVEL) / 2.0
    point = thrust[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lo = np.nanquantile(thrust[1:], lo_q, axis=0)
        hi = np.nanquantile(thrust[1:], hi_q, axis=0)
        yaw_point = rel[0, 2]
        yaw_lo = np.nanquantile(rel[1:, 2], lo_q, axis=0)
        yaw_hi = np.nanquantile(rel[1:, 2], hi_q, axis=0)

    motors = []
    for i in range(4):
        yaw_ok = np.isfinite(yaw_point[i]) and (yaw_hi[i] - yaw_lo[i]) <= 2 * MAX_CI_WIDTH
        motors.append(MotorEffectiveness(
            motor=i + 1, effectiveness=float(point[i]), ci=(float(lo[i]), float(hi[i])),
            yaw_effectiveness=float(yaw_point[i]) if yaw_ok else None,
            yaw_ci=(float(yaw_lo[i]), float(yaw_hi[i])) if yaw_ok else None))
    widths = hi - lo
    informative = bool(np.all(np.isfinite(point)) and np.all(widths <= MAX_CI_WIDTH))
    if not np.all(np.isfinite(point)):
        reason = "the fit failed (no roll/pitch response to the motor commands)"
    elif not informative:
        reason = (f"too little manoeuvring to estimate it: the widest interval is ±{np.nanmax(widths) / 2:.2f} "
                  f"(needs ±{MAX_CI_WIDTH / 2:.2f}); a flight with more roll/pitch changes would do")
    else:
        reason = f"from {seconds:.0f} s of airborne data"
    return EffectivenessEstimate(motors=motors, informative=informative, reason=reason, seconds=seconds,
                                 motor_lag_s=float(tau), r2=r2)
