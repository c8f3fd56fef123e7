"""Per-motor effectiveness from the log alone: the paper's NIF relation made explicit.

What it estimates
-----------------
The rigid body obeys ``J·ω̇ = Σ_i r_i × F_i + τ_drag + τ_ext``: each rotor's thrust ``F_i`` acts on
its lever arm (roll: ``−y_i``, pitch: ``x_i``) and its drag torque on yaw (``spin_i``). With the
thrust proxy ``u_i`` (the NIF ``ω_i²`` channel, ``streams.thrust_proxy``) standing for thrust,

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

Streams and lag: the same :func:`flightlog_fd.prepared.resample` as the NIF windows (50 Hz grid,
airborne time only, gaps split segments, Savitzky-Golay ``ṗ q̇ ṙ``), without the first and last
seconds of each airborne interval (``EDGE_TRIM_S``: the land detector's "airborne" includes
ground contact); the commands go through the gyro's low-pass (:func:`flightlog_fd.streams.gyro_cutoff_hz`), a
first-order motor lag whose time constant is searched per flight (``MOTOR_LAG_GRID_S``, refined
to ``MOTOR_LAG_REFINE_S``) and the same Savitzky-Golay smoothing as the gyro, all on the gyro
derivative's fine grid when the motors are logged faster than the grid. The candidate lags are
fitted all at once (:class:`_SegmentLags`): the same numbers within float noise as one lag at a time
(:func:`_detrended_commands`, the definition), 5-10x faster. The search runs on at most
``LAG_SEARCH_MAX_S`` of the flight, spread over it; the fit at the lag found uses every sample.

Body-rate terms: the rates and their products (damping, gyroscopic ``ω × Iω``) are fitted beside
the commands (:func:`_body_rate_terms`). Without them a yawing vehicle's gyroscopic torque lands on
the diagonal motor pairs: noiseless simulated x500 flights (η 0.6 and 0.8, each motor) read a
damaged rotor +0.077 high on average (2 of 8 within ±0.03); with them +0.012 (6 of 8).

The accelerometer's vertical equation is not used: joined to roll and pitch (measured with
``benchmarks/bench_effectiveness.py``, random airframes, px4_high, 60 s flights) it put 25 % of
damaged flights (η ≤ 0.9) within ±0.03 against 31 % without, and the healthy flights' largest
deviation at 0.090 against 0.054.

On real healthy flights (the 18 Erle ArduCopter logs of ../shared, 10 Hz RCOU): the largest
deviation of any motor from 1 has median 0.18 and 75th percentile 0.36, against 0.22 and 0.65
without the ground trim, the fine lag search and the body-rate terms; 5 of 18 are informative. Their lags come out at 0.04-0.16 s (10 Hz logging adds to the motor's).

Known bias (``benchmarks/bench_effectiveness.py``): in closed loop the commands answer what the
gyro measures, so they correlate with the unmeasured turbulence (which pulls a damaged rotor's
value toward 1) and with the gyro noise (which pulls it away); on noisy simulated flights the
net is toward 1: η 0.6 / 0.7 / 0.8 / 0.9 read 0.66 / 0.78 / 0.83 / 0.92 on average at the
high-rate profile (60 s flights), and the bootstrap interval does not cover that bias. Without
disturbances the estimate is within 0.01-0.04. Rate setpoints as instruments were tried (in the
simulator): weak (first-stage R² 0.05-0.27) and no less biased.

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

from ..errors import FlightLogError
from ..filters import (LAG_TRUNCATION, correlate1d_zero_ends, lag, lag_coefficient, savgol_at, savgol_coeffs,
                       savgol_edge_matrix, scan_inplace)
from ..flight import Frame
from ..prepared import PreparedFlight, resample
from ..streams import (DEFAULT_MAX_GAP_S, DEFAULT_RATE_HZ, DEFAULT_SAVGOL_WINDOW_S, MAX_FINE_FACTOR, SAVGOL_POLYORDER,
                       Segment, odd_window)

#: The start of the reason an informative-enough fit was not reached (the advice reads it).
LITTLE_MANOEUVRING = "too little manoeuvring"
#: Centred moving-average length (s) removed from both sides before the fit (0.3-0.5 s gave the
#: smallest error on simulated flights with known η: rmse 0.05 against 0.08 at 1 s and 0.10 at 2 s,
#: px4_high, 16 flights): longer than a
#: manoeuvre's command → response (0.05-0.5 s), shorter than trims and wind changes.
DETREND_S = 0.4
#: Candidate first-order motor time constants (s); the best roll/pitch least-squares fit wins,
#: then the search is refined around it in ``MOTOR_LAG_REFINE_S`` steps. The lag must be close:
#: on noiseless simulated flights (realism off) the fit at the true motor time constant recovers
#: η within 0.01 (R² 0.999), at 0.5x or 1.5x of it the damaged motor's value is off by 0.03-0.10
#: (R² 0.95-0.98); a 6-point grid (0, 0.02 ... 0.13 s) read η 0.6/0.7/0.8/0.9 as
#: 0.52/0.65/0.72/0.83 on such flights.
MOTOR_LAG_GRID_S = tuple(round(0.01 * k, 3) for k in range(16))  # 0 ... 0.15 s
MOTOR_LAG_REFINE_S = 0.002
#: Condition number of a lag's normal equations below which they are solved directly; above it
#: (collinear commands) that lag gets a least-squares solve, as every lag did before. At 1e8 the
#: normal equations lose at most ~8 of float64's 16 digits, far below the residual differences
#: between candidate lags.
MAX_NORMAL_COND = 1e8
#: Condition number of the body-rate terms below which their basis comes from CholeskyQR2
#: (_orthonormal_basis); above it from Householder QR. The detrended body-rate terms of the 60
#: comparison logs (sample_logs, ../shared) are far below it; 1e6 leaves a factor 100 to the
#: ~1e8 where CholeskyQR2 loses orthogonality.
MAX_CHOLQR_COND = 1e6
#: Bootstrap block length (s) and number of resamples; blocks keep the residuals' correlation.
BLOCK_S = 2.0
N_BOOTSTRAP = 200
CI_LEVEL = 0.90
#: Below this much usable airborne time (s) nothing is estimated.
MIN_SECONDS = 10.0
#: An interval wider than this (relative effectiveness units) means the flight did not
#: manoeuvre enough to say anything about that motor.
MAX_CI_WIDTH = 0.25
#: Seconds left out after the start and before the end of each airborne interval. The land
#: detector's "airborne" starts before lift-off and ends after touchdown (simulated PX4 flights:
#: 0.5-0.8 s before lift-off, 1.7-2.9 s after touchdown), and on the ground the commands no
#: longer move the vehicle: keeping those seconds (the 1 s trim of the NIF windows) read η 0.6 /
#: 0.7 / 0.8 / 0.9 as 0.40-0.51 / 0.55-0.60 / 0.74 / 0.83-0.90 on noiseless simulated flights,
#: leaving them out 0.61-0.62 / 0.71 / 0.82 / 0.90-0.91 (R² 0.91 → 0.99).
EDGE_TRIM_S = (2.0, 4.0)
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


def _moving_average(x: np.ndarray, n: int, axis: int = 0) -> np.ndarray:
    """Centred moving average along ``axis`` with edge-shrinking windows (same shape as x)."""
    if n <= 1:
        return x.copy()
    m = x.shape[axis]
    h = n // 2

    def along(i) -> tuple:
        return (slice(None),) * axis + (i,)

    shape = list(x.shape)
    shape[axis] = m + 1
    c = np.zeros(shape)
    np.cumsum(x, axis=axis, out=c[along(slice(1, None))])
    out = np.empty(x.shape)
    if m > 2 * h:  # full windows: slices (the same sums and divisor as the edge rows below)
        mid = out[along(slice(h, m - h))]
        np.subtract(c[along(slice(2 * h + 1, None))], c[along(slice(0, m - 2 * h))], out=mid)
        mid /= float(2 * h + 1)
        edges = np.r_[0:h, m - h:m]
    else:
        edges = np.arange(m)
    if edges.size:  # the shrinking windows at the ends, all at once
        lo, hi = np.maximum(edges - h, 0), np.minimum(edges + h + 1, m)
        count = (hi - lo).astype(np.float64).reshape((-1,) + (1,) * (x.ndim - 1 - axis))
        out[along(edges)] = (np.take(c, hi, axis=axis) - np.take(c, lo, axis=axis)) / count
    return out


def _lag(u: np.ndarray, tau_s: float, rate_hz: float) -> np.ndarray:
    """First-order lag (time constant ``tau_s``) of each column, started at its first value
    (:func:`flightlog_fd.filters.lag`: ``lfilter``'s values within float noise, without scipy.signal)."""
    return lag(u, tau_s, rate_hz)


def _usable(segments: list[Segment], savgol_n: int, detrend_n: int) -> list[Segment]:
    return [seg for seg in segments if len(seg) >= max(savgol_n, detrend_n // 2)]


def _away_from_ground(segments: list[Segment], airborne: list[tuple[float, float]]) -> list[Segment]:
    """The segments without the first/last ``EDGE_TRIM_S`` seconds of each airborne interval."""
    out = []
    for seg in segments:
        keep = np.zeros(len(seg), dtype=bool)
        for a, b in airborne:
            keep |= (seg.t >= a + EDGE_TRIM_S[0]) & (seg.t <= b - EDGE_TRIM_S[1])
        if keep.all():
            out.append(seg)
            continue
        idx = np.flatnonzero(keep)
        if idx.size < 2:
            continue
        # Trimming only cuts the ends of a segment (it lies within one airborne interval).
        out.append(_slice_segment(seg, slice(int(idx[0]), int(idx[-1]) + 1)))
    return out


def _detrended_acc(segments: list[Segment], detrend_n: int) -> tuple[np.ndarray, np.ndarray]:
    """Detrended angular accelerations (n, 3) and each row's time (n,), segments stacked."""
    if not segments:
        return np.zeros((0, 3)), np.zeros(0)
    ys = [np.asarray(seg.ang_acc, dtype=np.float64) for seg in segments]
    return np.vstack([y - _moving_average(y, detrend_n) for y in ys]), np.concatenate([seg.t for seg in segments])


@dataclass
class _FineCommands:
    """One segment's thrust proxy on the fine grid the gyro derivative was taken on (streams.resample_streams):
    ``u`` (m, 4) at ``fine_hz``, already through the gyro's low-pass, and the fine-grid indices of
    the segment's grid samples."""

    u: np.ndarray
    fine_hz: float
    on_grid: np.ndarray


def _fine_commands(flight, segments: list[Segment], rate_hz: float) -> Optional[list[_FineCommands]]:
    """The thrust proxy of each segment on a fine grid (the motor stream's rate, at most
    ``MAX_FINE_FACTOR`` x the grid rate), or None when the motor stream is no faster than the grid.
    ``flight``: a Flight or a PreparedFlight (whose thrust-proxy stream and gyro cutoff it reuses).

    Why: the motor lag (10-60 ms) is as short as a 50 Hz grid step; a first-order filter run at
    the grid rate on decimated commands misses it (noiseless simulated flights: R² 0.91 and η 0.8
    read 0.72; at the fine rate R² 0.99)."""
    prep = PreparedFlight.of(flight)
    flight = prep.flight
    try:
        proxy, _ = prep.speed_stream("command", rate_hz, DEFAULT_MAX_GAP_S)
    except FlightLogError:
        return None
    if flight.motors is None or flight.motors.rate_hz < 1.5 * rate_hz:
        return None
    k = int(min(MAX_FINE_FACTOR, max(1, round(flight.motors.rate_hz / rate_hz))))
    fine_hz = rate_hz * k
    cutoff = prep.gyro_cutoff_hz
    tau_gyro = 1.0 / (2.0 * np.pi * cutoff) if cutoff is not None and cutoff < fine_hz / 2 else 0.0
    out = []
    for seg in segments:
        j0, j1 = int(round(seg.t[0] * fine_hz)), int(round(seg.t[-1] * fine_hz))
        j = np.arange(j0, j1 + 1)
        on_grid = np.rint(seg.t * fine_hz).astype(np.int64) - j0
        if on_grid.min() < 0 or on_grid.max() >= j.size:
            return None
        out.append(_FineCommands(_lag(proxy.interp(j / fine_hz), tau_gyro, fine_hz), fine_hz, on_grid))
    return out


def _detrended_commands(segments: list[Segment], tau_s: float, rate_hz: float, savgol_n: int,
                        detrend_n: int, fine: Optional[list[_FineCommands]] = None,
                        savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S) -> np.ndarray:
    """Lagged, smoothed and detrended thrust commands (n, 4), rows as in _detrended_acc.

    With ``fine`` the lag and the smoothing run on the fine grid, with the same
    Savitzky-Golay window as the gyro derivative, and the grid samples are taken afterwards.
    The definition, one lag at a time: :class:`_LagSearch` computes the same numbers (within
    float noise) for many lags at once."""
    if not segments:
        return np.zeros((0, 4))
    xs = []
    for i, seg in enumerate(segments):
        if fine is not None:
            fc = fine[i]
            n_fine = odd_window(savgol_window_s, fc.fine_hz)
            u = _lag(fc.u, tau_s, fc.fine_hz)
            u = savgol_at(u, min(n_fine, u.shape[0] - (1 - u.shape[0] % 2)), SAVGOL_POLYORDER, fc.on_grid)
        else:
            u = _lag(np.asarray(seg.w_sq, dtype=np.float64), tau_s, rate_hz)
            u = savgol_at(u, savgol_n, SAVGOL_POLYORDER, np.arange(u.shape[0]))
        xs.append(u - _moving_average(u, detrend_n))
    return np.vstack(xs)


class _SegmentLags:
    """One segment's commands ``u`` (m, C) on a grid at ``rate_hz`` of which every k-th sample
    (0, k, ..., m-1) is kept: ``smoothed(taus)`` = Savitzky-Golay(``n``) of the first-order lag of
    ``u`` at the kept samples, for many time constants at once, i.e.
    ``savgol_filter(lag(u, tau), n, 2)[::k]`` for each tau, within float noise.

    How: both filters are linear and time-invariant, so away from the ends (where savgol_filter
    fits polynomials) the lag of the smoothed commands equals the smoothing of the lagged ones
    (the lag starts from u[0], as if u had been constant before). The smoothing then runs once;
    the lag, sampled every k, is ``V_i = a^k V_(i-1) + (1-a) Σ_l a^l s[g_i - l]``: a k-tap
    contraction for all lags in one product and a doubling scan at the grid rate. The end samples
    are the polynomial fits of the lagged commands there, computed from their exact sums.
    """

    def __init__(self, u: np.ndarray, rate_hz: float, n: int, k: int) -> None:
        self.u = u = np.asarray(u, dtype=np.float64)
        self.rate_hz, self.n, self.k = rate_hz, n, k
        m = u.shape[0]
        h = n // 2
        self.ng = (m - 1) // k + 1
        self.i0 = -(-h // k)  # first kept sample with a full smoothing window
        self.i1 = (m - 1 - h) // k  # last one
        c = savgol_coeffs(n, SAVGOL_POLYORDER)[::-1]
        self.sigma = float(np.sum(c))
        if self.i1 >= self.i0:
            g1 = self.i1 * k
            pad = np.concatenate([np.repeat(u[:1], 2 * h, axis=0), u[:g1 + h + 1]])
            # s[r] = smoothed u_ext at r - h, r = 0 .. g1 + h (u_ext = u[0] before the start)
            self.s = correlate1d_zero_ends(pad, c)[h:h + g1 + h + 1]
            # the k samples before each kept one (after the first), as (k, blocks x C) for one product
            nb, L0 = self.i1 - self.i0, self.i0 * k + h + 1
            self.blocks = self.s[L0:L0 + nb * k].reshape(nb, k, -1).transpose(1, 0, 2).reshape(k, -1)
        self.head_pos = np.arange(0, min(self.i0, self.ng)) * k
        self.tail_pos = np.arange(max(self.i1 + 1, self.i0), self.ng) * k
        self.E_head = savgol_edge_matrix(n, SAVGOL_POLYORDER, self.head_pos) if self.head_pos.size else None
        self.E_tail = (savgol_edge_matrix(n, SAVGOL_POLYORDER, self.tail_pos - (m - n))
                       if self.tail_pos.size else None)

    def smoothed(self, taus) -> np.ndarray:
        """(len(taus), ng, C) smoothed lagged commands at the kept samples."""
        u, n, k = self.u, self.n, self.k
        m, C = u.shape
        h = n // 2
        a = np.array([lag_coefficient(t, self.rate_hz) for t in taus])
        out = np.empty((a.size, self.ng, C))
        if self.i1 >= self.i0:
            i0, i1 = self.i0, self.i1
            g0 = i0 * k
            L0 = g0 + h + 1
            w0 = (1.0 - a)[None, :] * a[None, :] ** np.arange(L0)[:, None]  # (L0, T)
            out[:, i0] = (self.s[L0 - 1::-1].T @ w0).T + self.sigma * (a ** L0)[:, None] * u[0][None, :]
            if i1 > i0:
                nb = i1 - i0
                wb = (1.0 - a)[:, None] * a[:, None] ** np.arange(k - 1, -1, -1)[None, :]  # (T, k)
                out[:, i0 + 1:i1 + 1] = (wb @ self.blocks).reshape(a.size, nb, C)
            for t in range(a.size):  # y[i] = a^k y[i-1] + x[i], each lag on its own contiguous block
                scan_inplace(out[t, i0:i1 + 1], a[t] ** k)
        if self.E_head is not None:
            out[:, :self.head_pos.size] = np.einsum("pr,rct->tpc", self.E_head, self._lagged(0, n, a))
        if self.E_tail is not None:
            out[:, self.ng - self.tail_pos.size:] = np.einsum("pr,rct->tpc", self.E_tail, self._lagged(m - n, n, a))
        return out

    def _lagged(self, p0: int, count: int, a: np.ndarray) -> np.ndarray:
        """(count, C, T) lag of u at samples p0 .. p0+count-1 for each coefficient in ``a``,
        from its exact sum y[p] = (1-a) Σ_{j<=p} a^(p-j) u[j] + a^(p+1) u[0] (terms below
        LAG_TRUNCATION of the signal dropped)."""
        u = self.u
        if p0 == 0:
            prev = np.repeat(u[0][:, None], a.size, axis=1)  # y[-1] = u[0]
        else:
            amax = float(np.max(a))
            span = p0 if amax <= 0 else min(p0, int(np.ceil(np.log(LAG_TRUNCATION) / np.log(amax))) + 1)
            d = np.arange(span - 1, -1, -1)[:, None]  # p0-1 - j for j = p0-span .. p0-1
            prev = u[p0 - span:p0].T @ ((1.0 - a)[None, :] * a[None, :] ** d) + u[0][:, None] * (a ** p0)[None, :]
        r = np.arange(count)
        d = r[:, None] - r[None, :]
        W = np.where(d[..., None] >= 0, (1.0 - a) * a ** np.maximum(d, 0)[..., None], 0.0)  # (count, count, T)
        y = np.einsum("rlt,lc->rct", W, u[p0:p0 + count])
        y += (a[None, :] ** (r[:, None] + 1))[:, None, :] * prev[None, :, :]
        return y


def _lag_search_inputs(segments: list[Segment], rate_hz: float, savgol_n: int,
                       fine: Optional[list[_FineCommands]], savgol_window_s: float) -> Optional[list[_SegmentLags]]:
    """One :class:`_SegmentLags` per segment, or None when a segment's kept samples are not every
    k-th fine sample from the first to the last (then the lags are searched one at a time)."""
    out = []
    for i, seg in enumerate(segments):
        if fine is not None:
            fc = fine[i]
            u, hz = fc.u, fc.fine_hz
            n = min(odd_window(savgol_window_s, hz), u.shape[0] - (1 - u.shape[0] % 2))
            kept = fc.on_grid
        else:
            u, hz, n = np.asarray(seg.w_sq, dtype=np.float64), rate_hz, savgol_n
            kept = np.arange(u.shape[0])
        k = int(kept[1] - kept[0]) if kept.size > 1 else 1
        if kept.size < 2 or k < 1 or kept[0] != 0 or kept[-1] != u.shape[0] - 1 or \
                not np.array_equal(kept, np.arange(kept.size) * k) or n > u.shape[0] or n <= SAVGOL_POLYORDER:
            return None
        out.append(_SegmentLags(u, hz, n, k))
    return out


def _detrended_commands_many(lags: list[_SegmentLags], taus: np.ndarray, detrend_n: int) -> np.ndarray:
    """(T, n, 4) :func:`_detrended_commands` for each of ``taus`` (within float noise)."""
    xs = []
    for sl in lags:
        v = sl.smoothed(taus)  # (T, ng, C)
        v -= _moving_average(v, detrend_n, axis=1)
        xs.append(v)
    return xs[0] if len(xs) == 1 else np.concatenate(xs, axis=1)


#: The motor-lag search runs on at most this much airborne time (s), in ``LAG_SEARCH_CHUNK_S``
#: stretches spread evenly over the flight; the coefficients at the lag found use every sample.
#: Why: the search is most of the estimate's cost and grows with the flight, while the lag is one
#: number per airframe. Measured with benchmarks/bench_effectiveness.py --lag-search (every log of
#: ../shared and sample_logs longer than this, 2026-11-24): see results/effectiveness_lag_search.md.
LAG_SEARCH_MAX_S = 120.0
LAG_SEARCH_CHUNK_S = 15.0


def _slice_segment(seg: Segment, sl: slice) -> Segment:
    return Segment(t=seg.t[sl], rates=seg.rates[sl], attitude=seg.attitude[sl], motors=seg.motors[sl],
                   w_sq=seg.w_sq[sl], ang_acc=seg.ang_acc[sl], speed_source=seg.speed_source)


def _lag_search_segments(segments: list[Segment], max_s: Optional[float] = None,
                         chunk_s: Optional[float] = None) -> list[Segment]:
    """``segments`` itself when they last at most ``max_s`` (``LAG_SEARCH_MAX_S``); else
    ``max_s / chunk_s`` stretches of ``chunk_s`` seconds centred at evenly spaced points of the
    segments' joined timeline (each inside one segment, shorter where its segment is)."""
    max_s = LAG_SEARCH_MAX_S if max_s is None else max_s
    chunk_s = LAG_SEARCH_CHUNK_S if chunk_s is None else chunk_s
    durations = np.array([seg.duration_s for seg in segments])
    total = float(durations.sum())
    if total <= max_s or chunk_s <= 0:
        return segments
    n_chunks = max(1, int(max_s // chunk_s))
    ends = np.cumsum(durations)
    out = []
    for j in range(n_chunks):
        c = (j + 0.5) / n_chunks * total
        i = int(min(np.searchsorted(ends, c), len(segments) - 1))
        seg = segments[i]
        tc = seg.t[0] + (c - (ends[i] - durations[i]))
        lo = int(np.searchsorted(seg.t, tc - chunk_s / 2))
        hi = int(np.searchsorted(seg.t, tc + chunk_s / 2))
        if hi - lo >= 2:
            out.append(_slice_segment(seg, slice(lo, hi)))
    return out


class _LagFit:
    """The regression of one set of segments, ready for many candidate motor lags: detrended
    roll/pitch/yaw accelerations ``Y`` (body-rate terms partialled out), the row times ``t``, and
    the lagged commands for any lag (``commands``); ``best_lag`` runs the grid search."""

    def __init__(self, prep: PreparedFlight, segments: list[Segment], rate_hz: float, savgol_n: int,
                 detrend_n: int, savgol_window_s: float) -> None:
        self.segments, self.rate_hz, self.savgol_n, self.detrend_n = segments, rate_hz, savgol_n, detrend_n
        self.savgol_window_s = savgol_window_s
        Y, self.t = _detrended_acc(segments, detrend_n)  # the lag only changes the commands
        self.fine = _fine_commands(prep, segments, rate_hz)
        # Body-rate terms (gyroscopic ω × Iω, aerodynamic damping) are fitted beside the commands
        # and partialled out of both sides (Frisch-Waugh), so the commands' coefficients are those
        # of the full regression. One orthonormal basis of them serves every candidate lag.
        nuisance = _body_rate_terms(segments, detrend_n)
        self.basis = _orthonormal_basis(nuisance) if nuisance is not None else None
        self.Y = self.partial_out(Y)
        self.lags = _lag_search_inputs(segments, rate_hz, savgol_n, self.fine, savgol_window_s)
        self.n_rows = sum(len(seg) for seg in segments)

    def partial_out(self, M: np.ndarray) -> np.ndarray:
        return M if self.basis is None else M - self.basis @ (self.basis.T @ M)

    def commands(self, taus: list[float]) -> np.ndarray:
        """(T, n, 4) detrended commands, one block per candidate lag (body-rate terms not yet out)."""
        return _detrended_commands_many(self.lags, np.asarray(taus, dtype=np.float64), self.detrend_n)

    def roll_pitch_sse(self, taus: list[float]) -> list[float]:
        """The roll/pitch residual of each candidate lag, from the normal equations of all lags at
        once with the body-rate terms partialled out through their Gram blocks
        (X'X - (Q'X)'(Q'X)); lstsq where ill-posed. Roll and pitch decide the lag (yaw is weakly
        excited)."""
        X = self.commands(taus)
        Xt = X.transpose(0, 2, 1)
        XtX = np.matmul(Xt, X)
        P = None
        if self.basis is not None:
            P = np.matmul(self.basis.T, X)  # (T, k, 4)
            XtX -= np.matmul(P.transpose(0, 2, 1), P)
        Yrp = np.ascontiguousarray(self.Y[:, :2])  # partialled out already: X'Y = X_perp'Y
        XtY = np.matmul(Xt, Yrp)
        yy = float(np.sum(Yrp ** 2))
        cond = np.linalg.cond(XtX)
        out = []
        for i in range(len(taus)):
            if cond[i] < MAX_NORMAL_COND:
                c = np.linalg.solve(XtX[i], XtY[i])
                out.append(yy - float(np.sum(XtY[i] * c)))
            else:
                Xi = X[i] if P is None else X[i] - self.basis @ P[i]
                c = np.linalg.lstsq(Xi, Yrp, rcond=None)[0]
                out.append(float(np.sum((Yrp - Xi @ c) ** 2)))
        return out

    def best_lag(self) -> Optional[float]:
        """The ``MOTOR_LAG_GRID_S`` lag with the smallest roll/pitch residual, refined around it in
        ``MOTOR_LAG_REFINE_S`` steps (in order; the first smallest wins), or None with too few rows."""
        if self.n_rows < 5 * 4:
            return None
        best = None
        for taus in (list(MOTOR_LAG_GRID_S), None):
            if taus is None:  # the refinement around the grid's best
                step = MOTOR_LAG_GRID_S[1] - MOTOR_LAG_GRID_S[0]
                taus = [round(tau, 4) for k in range(1, int(round(step / MOTOR_LAG_REFINE_S)))
                        for tau in (best[1] - k * MOTOR_LAG_REFINE_S, best[1] + k * MOTOR_LAG_REFINE_S) if tau > 0]
            for tau, sse in zip(taus, self.roll_pitch_sse(taus) if taus else []):
                if best is None or sse < best[0]:
                    best = (sse, tau)
        return best[1]


def _body_rate_terms(segments: list[Segment], detrend_n: int) -> Optional[np.ndarray]:
    """Detrended (n, 6) p, q, r, q·r, p·r, p·q of the segments (rows as in _detrended_acc): the
    rigid body's damping and gyroscopic torques, which the commands do not explain."""
    if not segments:
        return None
    out = []
    for seg in segments:
        w = np.asarray(seg.rates, dtype=np.float64)
        p, q, r = w[:, 0], w[:, 1], w[:, 2]
        terms = np.column_stack([p, q, r, q * r, p * r, p * q])
        out.append(terms - _moving_average(terms, detrend_n))
    return np.vstack(out)


def _orthonormal_basis(M: np.ndarray) -> np.ndarray:
    """An orthonormal basis (n, k) of the columns of a tall ``M``: CholeskyQR2 (two Cholesky
    passes on the k x k Gram matrix) when M is well conditioned, else Householder QR.

    Why: only the projection onto the span is used (any orthonormal basis gives the same one),
    and LAPACK's QR of a 30000 x 6 matrix took 11.5 ms against ~1 ms. CholeskyQR2 is orthonormal
    to machine precision for cond(M) up to ~1e8 (Yamamoto et al. 2015); ``MAX_CHOLQR_COND``
    keeps a wide margin."""
    G = M.T @ M
    try:
        if np.linalg.cond(G) < MAX_CHOLQR_COND ** 2:
            Q = M
            for _ in range(2):
                R = np.linalg.cholesky(Q.T @ Q).T  # upper, Q'Q = R'R
                Q = Q @ np.linalg.inv(R)
            return Q
    except np.linalg.LinAlgError:
        pass
    return np.linalg.qr(M)[0]


_OTHERS = np.array([[j for j in range(4) if j != i] for i in range(4)])


def _relative(b: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Per-axis effectiveness b/s -> relative to the median of the other three motors.

    ``b`` (..., axes, 4) coefficients, ``signs`` (axes, 4); returns the same shape, NaN where a motor
    has no lever on an axis.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(np.abs(signs) > 1e-9, b / signs, np.nan)
    others = e[..., _OTHERS]  # (..., 4, 3): each motor's three neighbours
    with warnings.catch_warnings():  # all three NaN (a motor-less axis) gives NaN, as it should
        warnings.simplefilter("ignore", RuntimeWarning)
        ref = np.nanmedian(others, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return e / ref


def _combine(rel: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Inverse-variance mean of roll and pitch estimates per motor: rel/var (..., 2, 4)."""
    w = np.where(np.isfinite(rel) & np.isfinite(var) & (var > 0), 1.0 / np.where(var > 0, var, 1.0), 0.0)
    num = np.nansum(np.where(w > 0, rel * w, 0.0), axis=-2)
    den = w.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def estimate_effectiveness(flight, *, rate_hz: float = DEFAULT_RATE_HZ,
                           savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S,
                           segments: Optional[list[Segment]] = None,
                           n_bootstrap: int = N_BOOTSTRAP, seed: int = BOOTSTRAP_SEED) -> EffectivenessEstimate:
    """Relative per-motor effectiveness of ``flight`` (a Flight or a
    :class:`~flightlog_fd.prepared.PreparedFlight`, see the module docstring).

    ``segments`` may be given when the caller already resampled the flight at ``rate_hz`` (the
    diagnosis passes its windows' own). Never raises for a flight that simply has too little data
    or more than four rotors: returns ``informative=False`` with the reason.
    """
    prep = PreparedFlight.of(flight)
    flight = prep.flight
    n_rotors = flight.frame.rotor_count if flight.frame is not None else 4
    if n_rotors != 4:
        # In closed loop an n-rotor's commands follow the allocator's four directions (roll, pitch,
        # yaw, thrust): on simulated hexa and octo flights singular values 5..n of the command
        # matrix are 0, so each rotor's effectiveness cannot be told from the others'.
        return EffectivenessEstimate(reason=f"not identifiable with {n_rotors} rotors: the "
                                            f"controller drives them along four directions only")
    if segments is None:
        try:
            segments = resample(prep, rate_hz=rate_hz, savgol_window_s=savgol_window_s)
        except FlightLogError as e:
            return EffectivenessEstimate(reason=e.message)
    segments = _away_from_ground(segments, flight.airborne)
    seconds = float(sum(s.duration_s for s in segments))
    if seconds < MIN_SECONDS:
        return EffectivenessEstimate(reason=f"only {seconds:.0f} s of usable airborne data "
                                            f"(the estimate needs {MIN_SECONDS:.0f} s)", seconds=seconds)
    signs = axis_signs(flight.frame)
    savgol_n = odd_window(savgol_window_s, rate_hz)
    detrend_n = max(3, int(round(DETREND_S * rate_hz)) | 1)

    usable = _usable(segments, savgol_n, detrend_n)
    search = _lag_search_segments(usable)
    if search is not usable:  # stretches cut short by their segment's end may be too short to filter
        search = _usable(search, savgol_n, detrend_n) or usable
    fit = _LagFit(prep, search, rate_hz, savgol_n, detrend_n, savgol_window_s)
    tau = fit.best_lag()
    if tau is None:
        return EffectivenessEstimate(reason="too few samples for the fit", seconds=seconds)
    if search is not usable:  # the lag came from a subset; the coefficients use every sample
        fit = _LagFit(prep, usable, rate_hz, savgol_n, detrend_n, savgol_window_s)
    Y, t = fit.Y, fit.t
    n_axes = Y.shape[1]  # roll, pitch, yaw
    X = np.ascontiguousarray(fit.partial_out(fit.commands([tau])[0]))
    coef, *_ = np.linalg.lstsq(X, Y, rcond=None)  # (4, axes)
    tss = np.sum(Y ** 2, axis=0)
    resid = Y - X @ coef
    r2 = tuple(float(1.0 - np.sum(resid[:, a] ** 2) / tss[a]) if tss[a] > 0 else 0.0 for a in range(n_axes))

    # Moving-block bootstrap over the flight: per-block normal equations, summed with
    # multinomial block counts, so each resample is a 4x4 solve.
    block = np.floor((t - t[0]) / BLOCK_S).astype(int)
    _, block = np.unique(block, return_inverse=True)
    nb = int(block.max()) + 1
    XtX = np.zeros((nb, 4, 4))
    XtY = np.zeros((nb, 4, n_axes))
    starts = np.flatnonzero(np.r_[True, np.diff(block) != 0])
    if np.all(np.diff(block) >= 0) and starts.size == nb:  # time-ordered rows: one reduceat per matrix
        # on the transposed (columns x rows) arrays, whose products run one long loop per pair
        # of columns: the same sums in the same order, 5.5 -> 0.8 ms on 30 000 rows
        Xt, Yt = np.ascontiguousarray(X.T), np.ascontiguousarray(Y.T)
        XtX[:] = np.add.reduceat(Xt[:, None, :] * Xt[None, :, :], starts, axis=2).transpose(2, 0, 1)
        XtY[:] = np.add.reduceat(Xt[:, None, :] * Yt[None, :, :], starts, axis=2).transpose(2, 0, 1)
    else:
        np.add.at(XtX, block, X[:, :, None] * X[:, None, :])
        np.add.at(XtY, block, X[:, :, None] * Y[:, None, :])
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(nb, np.full(nb, 1.0 / nb), size=n_bootstrap).astype(np.float64)  # (B, nb)
    A = (counts @ XtX.reshape(nb, -1)).reshape(-1, 4, 4) + 1e-12 * np.eye(4)  # one BLAS product each
    B = (counts @ XtY.reshape(nb, -1)).reshape(-1, 4, n_axes)
    try:
        boot = np.linalg.solve(A, B)  # (B, 4, axes)
    except np.linalg.LinAlgError:
        return EffectivenessEstimate(reason="the motor commands never varied independently", seconds=seconds)
    b_all = np.concatenate([coef.T[None], np.transpose(boot, (0, 2, 1))], axis=0)[:, :3]  # (1+B, 3, 4)
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
        reason = (f"{LITTLE_MANOEUVRING} to estimate it: the widest interval is ±{np.nanmax(widths) / 2:.2f} "
                  f"(needs ±{MAX_CI_WIDTH / 2:.2f}); a flight with more roll/pitch changes would do")
    else:
        reason = f"from {seconds:.0f} s of airborne data"
    return EffectivenessEstimate(motors=motors, informative=informative, reason=reason, seconds=seconds,
                                 motor_lag_s=float(tau), r2=r2)
