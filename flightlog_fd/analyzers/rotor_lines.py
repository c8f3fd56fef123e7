"""Once-per-revolution rotor lines: found in the gyro and accelerometer spectra, followed through
the flight (folded back where they lie above the logged Nyquist frequency) and tied to the rotor
whose speed they follow.

What: :func:`find_rotor_line` takes a flight and its airborne intervals and returns the strongest
narrow line of the horizontal gyro or accelerometer spectrum (:class:`RotorLine`), its frequency
track in ``TRACK_WINDOW_S`` windows, its amplitude in the accelerometer, and the tie:

- **speeds**: each rotor's speed per window, from ESC rpm where every motor reports it
  (``tie_source`` "esc_rpm"; the line must sit at once per revolution of its rotor, within
  ``ESC_SCALE_TOLERANCE``), else from its command (``"command"``: s = sqrt(thrust command), the
  thrust proxy of :func:`~flightlog_fd.streams.flight_thrust_proxy` being ∝ speed², and the line
  at f = c·(s / s_ref)^β: the map from the profile's command-to-line curve where it holds one
  (within ``CURVE_TOLERANCE_LOG``), else c free over ``ROTOR_HZ_RANGE`` and β over ``BETA_RANGE``
  with a prior around 1, ``BETA_PRIOR_SD_LOG``: real motors need not follow the thrust model);
- **folding**: a rotor at f Hz is seen at ``fold(f) = |f - m·fs|`` (the nearest multiple m of the
  sampling rate fs): the prediction each rotor makes is folded the same way, so a line above
  Nyquist is followed as well as one below it (an odd fold moves the other way as the rotor
  speeds up, which is what tells the folds apart);
- **the tie**: each hypothesis "the line is rotor k's" (and "the line follows all rotors alike",
  ``common``) is scored by its track residuals (squared, clipped at ``RESIDUAL_CLIP_HZ`` so a
  window where another line won does not decide; the map (c, β) marginalised over its grid), with
  ``n_eff`` = windows · hop / ``TRACK_CORRELATION_S`` independent samples:
  ``log L_k = log mean_(c,β) exp(-n_eff/2 · ln S_k(c, β))``. ``tie_probs[k] = (L_k + L_common / n) /
  (Σ L_j + L_common)``: P(the out-of-balance propeller is on rotor k | one is), uniform when
  the rotors turned together (their predictions coincide) or the line follows their mean;
- **follows**: the line follows the rotors' speed when the best hypothesis beats a fixed frequency
  (a frame or mount resonance, a sensor artefact) by ``FOLLOWS_MIN_LLR`` nats;
- **named** (:func:`tie_motor`): the best rotor when its P reaches ``TIE_NAME_P``;
- **why untied** (:func:`why_untied`): plain words with the measure: how close the rotors'
  predicted lines stayed (``SPREAD_QUANTILE`` of the windows) against the track's own scatter.

Limits: the strongest line only (a healthy airframe's residual lines of n rotors lie together and
beat; a second damaged propeller's line is not searched); at most ``MAX_TRACK_WINDOWS`` windows
(a longer flight is subsampled evenly); a command tie assumes each rotor's speed is the same
function of its command (motors and propellers of one kind), which a weak motor breaks.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..flight import Flight, Series

#: The gyro or accelerometer must run at least this fast for a spectrum (Nyquist 50 Hz: with
#: folding any rotor line lands somewhere in 0..50 Hz, but below LINE_MIN_HZ it is lost among
#: manoeuvres and frame modes).
MIN_SPECTRUM_HZ = 100.0
#: Lines are searched from here up to 0.95 of the Nyquist frequency. Below: control motion (< 10
#: Hz) and airframe modes. 20 Hz keeps folded lines of fast rotors (a Crazyflie's 270 Hz at 250 Hz
#: logging folds to 20 Hz) in reach.
LINE_MIN_HZ = 20.0
#: A line is reported when it stands this far above the band (:func:`tracked_prominence`: the
#: median over TRACK_WINDOW_S windows of its peak over the window's band median): without a line
#: the peak of noise measured 2.7-11.4 (simulated healthy twins, PX4 SIH 7.7-8.2, RflyMAD SIL
#: 3.7-11.4); udesa propeller 13: 2800 (gyro); a simulated 4.6 m/s/s line folded to 31 Hz: 32.
LINE_PROMINENCE = 20.0
#: Window (s) of the line's frequency track; windows overlap by half. 0.5 s resolves 2 Hz
#: (zero-padded ``PAD_FACTOR`` times for the peak), short against the speed changes of a manoeuvre.
TRACK_WINDOW_S = 0.5
PAD_FACTOR = 8
#: The track searches each window within this fraction of the line's frequency, and at least
#: TRACK_BAND_MIN_HZ either side (a folded line near 0 Hz moves by its rotor's swing, not by a
#: fraction of where it folded to).
TRACK_BAND = 0.25
TRACK_BAND_MIN_HZ = 10.0
#: A window where another line or the noise won gives a residual of up to TRACK_BAND x the line:
#: residuals are clipped here (two 0.5 s bins) so such windows weigh alike for every rotor.
RESIDUAL_CLIP_HZ = 4.0
#: Floor on the mean squared residual (Hz²): the zero-padded peak's quantisation (bin/PAD_FACTOR
#: = 0.25 Hz, variance bin²/12) and the rotors' own spin-up lag; keeps a perfect fit finite.
RESIDUAL_FLOOR_HZ2 = 0.05
#: Correlation time (s) of the track's residuals: n_eff = windows x hop / this. Set so that the
#: stated tie probability matches the fraction right on 123 simulated flights whose line follows
#: the rotors (benchmarks/vibration_ties.py, results/vibration.md): at 0.5 s stated 0.12 / 0.28 /
#: 0.65 were right 0.07 / 0.30 / 0.69 of the time; 1 s is under-confident (0.68 stated, 0.95
#: right), 0.25 s over-confident (0.68 stated, 0.17 right; the true rotor once at 0.004).
TRACK_CORRELATION_S = 0.5
#: Minimum windows in the track.
MIN_TRACK_WINDOWS = 20
#: At most this many windows are tracked (a longer flight is subsampled evenly: bounded time).
MAX_TRACK_WINDOWS = 2400
#: Rotor rates (Hz) a free scale may put the line at: 20 Hz (a 30-inch propeller at hover) to
#: 600 Hz (a 3-inch racer at full throttle, 36 000 rpm).
ROTOR_HZ_RANGE = (20.0, 600.0)
#: Step (natural log) of the free scale's grid: 0.2 % of the frequency (0.2 Hz at 100 Hz), about
#: the track's quantisation.
SCALE_STEP_LOG = 0.002
#: Exponent β of the command-to-line map f = c·(s/s_ref)^β, s = sqrt(thrust command): 1 where the
#: thrust model holds (the simulator); real logs differ (udesa's F450 with THR_MDL_FAC 0 and
#: mixer-reconstructed commands: the line moves as s^0.33), so β is free over this range (log grid).
BETA_RANGE = (0.2, 2.0)
BETA_STEPS = 11
#: Prior on β: log-normal around 1 with this sd (natural log; 0.4-2.5 within 1.3 sd): where aliases
#: of a folded line fit alike (410 Hz as s^0.4 folds like 160 Hz as s^1), the physical map wins;
#: udesa's 0.4 costs under 1 nat against a track worth dozens.
BETA_PRIOR_SD_LOG = 0.7
#: ESC rpm gives the rotor's speed itself: the line sits at once per revolution within this
#: fraction (ESC rpm averaging, clock); a mis-set pole count is a whole factor off and does not tie.
ESC_SCALE_TOLERANCE = 0.05
#: A profile's command-to-speed curve holds to this (natural log): a battery's sag changes the
#: speed per command by up to ~8 % over a flight (ArduPilot without MOT_BAT_VOLT compensation).
CURVE_TOLERANCE_LOG = 0.10
#: The line follows the rotors' speed when the best hypothesis beats a fixed frequency by this
#: much (nats): a resonance of the frame or the mount does not move with the rotors.
FOLLOWS_MIN_LLR = 3.0
#: The rotors' predicted lines are compared at this quantile of the windows (why_untied's measure).
SPREAD_QUANTILE = 0.9
#: Prior weight of "the line follows the rotors alike" against one rotor's.
COMMON_PRIOR = 1.0
#: A rotor is named (:func:`tie_motor`) when its tie probability reaches this: on 123 simulated
#: flights whose line follows the rotors (benchmarks/vibration_ties.py), 88 reached it and none
#: named the wrong rotor (none down to 0.8 either).
TIE_NAME_P = 0.9


@dataclass
class Spectra:
    """Per-window horizontal periodograms of one stream over the airborne intervals."""

    source: str
    kind: str  # "gyro" | "accel"
    fs: float
    nper: int
    freqs: np.ndarray  # (bins,) zero-padded
    power: np.ndarray  # (windows, bins)
    centres: np.ndarray  # (windows,) s

    @property
    def mean(self) -> np.ndarray:
        return self.power.mean(axis=0)

    def band(self, lo: float = LINE_MIN_HZ) -> np.ndarray:
        return (self.freqs >= lo) & (self.freqs <= 0.95 * self.fs / 2)

    def rms(self, power_sum: np.ndarray) -> np.ndarray:
        """RMS (stream units) of the summed periodogram power ``power_sum`` (Parseval, one-sided,
        Hann window, zero-padded bins)."""
        w = np.hanning(self.nper)
        return np.sqrt(2.0 * power_sum / (self.nper * np.sum(w * w) * PAD_FACTOR))


@dataclass
class RotorLine:
    """The strongest rotor line, its track and its tie (module docstring)."""

    freq_hz: float  # as seen in the logged stream (folded where it lies above Nyquist)
    prominence: float
    source: str  # the stream it was found in
    kind: str = "gyro"  # "gyro" | "accel"
    sample_hz: float = 0.0
    amplitude: Optional[float] = None  # horizontal RMS of the line in the accelerometer (m/s/s)
    band_rms: Optional[float] = None  # horizontal RMS of the accelerometer's band (m/s/s)
    rotor_hz: Optional[float] = None  # the rotor rate it sits at (unfolded), when the fold is known
    folded: Optional[bool] = None
    tie_source: str = ""  # "esc_rpm" | "command" | ""
    tie_probs: list = field(default_factory=list)  # P(rotor k | one out of balance), k = 1..n
    follows: bool = False  # the track follows the rotors' speed (FOLLOWS_MIN_LLR)
    follows_llr: float = 0.0  # best hypothesis against a fixed frequency, nats
    scale: Optional[float] = None  # the map f = scale·(s / s_ref)^beta (ESC rpm: 1 = once per revolution)
    beta: Optional[float] = None
    s_ref: Optional[float] = None
    scale_known: bool = False  # the scale came from ESC rpm or the profile's curve
    track_sigma_hz: Optional[float] = None  # RMS residual of the best hypothesis
    spread_hz: Optional[float] = None  # the rotors' predicted lines: max - min at SPREAD_QUANTILE
    windows: int = 0
    why_untied: str = ""

    @property
    def best_motor(self) -> Optional[int]:
        return int(np.argmax(self.tie_probs)) + 1 if self.tie_probs else None


def fold(f, fs: float):
    """The frequency a sine at ``f`` Hz shows at when sampled at ``fs`` Hz (0..fs/2)."""
    r = np.mod(f, fs)
    return np.minimum(r, fs - r)


# ----------------------------------------------------------------------------- spectra


#: Windows transformed at once by :func:`_psds` (bounds its memory: 256 x 1600 x 2 complex = 13 MB).
PSD_BATCH = 256


def _psds(x: np.ndarray, nper: int, pad: int, starts) -> np.ndarray:
    """(windows, pad // 2 + 1) periodograms (Hann window, mean removed, summed over columns) of
    the ``nper``-sample windows of ``x`` (n, C) starting at ``starts``: one FFT call per
    ``PSD_BATCH`` windows, the same numbers as one call per window (one call each was half of
    the vibration analyzer's time on a 600 s log)."""
    starts = np.asarray(starts, dtype=np.int64)
    out = np.empty((starts.size, pad // 2 + 1))
    if starts.size == 0:
        return out
    w = np.hanning(nper)[:, None]
    views = np.lib.stride_tricks.sliding_window_view(x, nper, axis=0)  # (n - nper + 1, C, nper)
    for lo in range(0, starts.size, PSD_BATCH):
        seg = views[starts[lo:lo + PSD_BATCH]].transpose(0, 2, 1)  # (b, nper, C)
        seg = seg - seg.mean(axis=1, keepdims=True)
        out[lo:lo + PSD_BATCH] = (np.abs(np.fft.rfft(seg * w, n=pad, axis=1)) ** 2).sum(axis=2)
    return out


def _windows(s: Series, intervals, nper: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Window start indices per interval (hop nper/2) and the window centre times."""
    starts, centres = [], []
    for a, b in intervals:
        idx = np.flatnonzero((s.t >= a) & (s.t <= b))
        if idx.size < nper:
            continue
        st = idx[0] + np.arange(0, idx.size - nper + 1, nper // 2)
        starts.append(st)
        centres.append(0.5 * (s.t[st] + s.t[st + nper - 1]))
    if not starts:
        return [], np.zeros(0)
    return starts, np.concatenate(centres)


def spectra(s: Series, intervals, kind: str, source: str) -> Optional[Spectra]:
    """Horizontal (axes 0, 1) periodograms of ``s`` in TRACK_WINDOW_S Hann windows, zero-padded
    PAD_FACTOR times, over the intervals; None when too little data."""
    fs = s.rate_hz
    nper = max(int(round(TRACK_WINDOW_S * fs)), 16)
    starts, centres = _windows(s, intervals, nper)
    if centres.size < MIN_TRACK_WINDOWS:
        return None
    allst = np.concatenate(starts)
    if allst.size > MAX_TRACK_WINDOWS:  # evenly subsampled: bounded time on long flights
        keep = np.linspace(0, allst.size - 1, MAX_TRACK_WINDOWS).round().astype(int)
        allst, centres = allst[keep], centres[keep]
    pad = PAD_FACTOR * nper
    x = s.values[:, :2]
    power = _psds(x, nper, pad, allst)
    return Spectra(source, kind, fs, nper, np.fft.rfftfreq(pad, 1.0 / fs), power, centres)


def _peak(sp: Spectra) -> tuple[float, float]:
    """(frequency, prominence) of the strongest bin of the flight's mean spectrum in the line
    band, each window first divided by its own band median (so a few loud windows, a manoeuvre,
    do not choose the line): prominence = that bin's normalised power (noise: ~1)."""
    band = sp.band()
    if band.sum() < 10:
        return float("nan"), 0.0
    med = np.median(sp.power[:, band], axis=1, keepdims=True)
    ok = med[:, 0] > 0
    if not ok.any():
        return float("nan"), 0.0
    m = (sp.power[ok][:, band] / med[ok]).mean(axis=0)
    i = int(np.argmax(m))
    return float(sp.freqs[band][i]), float(m[i])


def tracked_prominence(sp: Spectra, f0: float) -> float:
    """Median over windows of the line's peak (its track within TRACK_BAND of ``f0``) over the
    window's band median: a line that moves with the rotors stays prominent window by window
    where the flight's mean spectrum smears it."""
    band = sp.band()
    half = max(f0 * TRACK_BAND, TRACK_BAND_MIN_HZ)
    lo, hi = f0 - half, min(f0 + half, 0.995 * sp.fs / 2)
    near = (sp.freqs >= max(lo, 1.0)) & (sp.freqs <= hi)
    med = np.median(sp.power[:, band], axis=1)
    ok = med > 0
    if not ok.any() or not near.any():
        return 0.0
    return float(np.median(sp.power[ok][:, near].max(axis=1) / med[ok]))


def track(sp: Spectra, f0: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequency (windows,), band-limited power of the line (windows,)): each window's peak
    within TRACK_BAND of ``f0`` (within 0..Nyquist), refined by a parabola on the log power; the
    power summed over ±1 unpadded bin around it."""
    half = max(f0 * TRACK_BAND, TRACK_BAND_MIN_HZ)
    lo, hi = f0 - half, min(f0 + half, 0.995 * sp.fs / 2)
    band = np.flatnonzero((sp.freqs >= max(lo, 1.0)) & (sp.freqs <= hi))
    p = sp.power[:, band]
    j = np.argmax(p, axis=1)
    df = sp.freqs[1] - sp.freqs[0]
    lp = np.log(np.maximum(p, 1e-300))
    jl, jr = np.clip(j - 1, 0, band.size - 1), np.clip(j + 1, 0, band.size - 1)
    rows = np.arange(p.shape[0])
    a, b, c = lp[rows, jl], lp[rows, j], lp[rows, jr]
    den = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where((den < 0) & (jl != j) & (jr != j), 0.5 * (a - c) / den, 0.0)
    f = sp.freqs[band][j] + np.clip(off, -0.5, 0.5) * df
    half = PAD_FACTOR  # one unpadded bin either side
    cs = np.concatenate([np.zeros((p.shape[0], 1)), np.cumsum(sp.power, axis=1)], axis=1)
    jj = band[j]
    lo_i, hi_i = np.clip(jj - half, 0, sp.power.shape[1]), np.clip(jj + half + 1, 0, sp.power.shape[1])
    line_power = cs[rows, hi_i] - cs[rows, lo_i]
    return f, line_power


# ----------------------------------------------------------------------------- rotor speeds


def rotor_speeds(flight: Flight, centres: np.ndarray, half: float) -> tuple[Optional[np.ndarray], str]:
    """(windows, n) each rotor's speed per window and its source: "esc_rpm" (rev/s) where every
    motor reports rpm in MIN_TRACK_WINDOWS windows, else "command" (sqrt of the thrust command,
    arbitrary units), else (None, "")."""
    esc = flight.esc
    n = flight.frame.rotor_count if flight.frame is not None else 0
    if esc is not None and n and all(esc.channel(k) is not None for k in range(1, n + 1)):
        out = np.full((centres.size, n), np.nan)
        for k in range(1, n + 1):
            c = esc.channel(k)
            ok = c.fresh()
            t, r = c.t[ok], c.rpm[ok]
            lo, hi = np.searchsorted(t, centres - half), np.searchsorted(t, centres + half)
            cs = np.concatenate([[0.0], np.cumsum(r)])
            cnt = hi - lo
            out[:, k - 1] = np.where(cnt > 0, (cs[hi] - cs[lo]) / np.maximum(cnt, 1), np.nan) / 60.0
        if np.isfinite(out).all(axis=1).sum() >= MIN_TRACK_WINDOWS:
            return out, "esc_rpm"
    if flight.motors is None:
        return None, ""
    from ..streams import flight_thrust_proxy

    u = np.sqrt(np.clip(flight_thrust_proxy(flight), 0.0, None))
    if n and u.shape[1] > n:
        u = u[:, :n]
    t = flight.motors.t
    lo, hi = np.searchsorted(t, centres - half), np.searchsorted(t, centres + half)
    c = np.vstack([np.zeros((1, u.shape[1])), np.cumsum(u, axis=0)])
    cnt = (hi - lo)[:, None]
    out = np.where(cnt > 0, (c[hi] - c[lo]) / np.maximum(cnt, 1), np.nan)
    return out, "command"


# ----------------------------------------------------------------------------- the tie


def _grid(speeds: np.ndarray, source: str, curve: Optional[tuple]) -> tuple[np.ndarray, np.ndarray, bool]:
    """Candidate (scale c, exponent β) pairs of the speed-to-line map f = c·(s / s_ref)^β, with
    s_ref the median speed (ESC rpm: s_ref = 1 rev/s, β = 1), and whether the map is known."""
    if source == "esc_rpm":
        c = np.exp(np.linspace(np.log(1 - ESC_SCALE_TOLERANCE), np.log(1 + ESC_SCALE_TOLERANCE), 41))
        return c, np.ones_like(c), True
    betas = np.exp(np.linspace(np.log(BETA_RANGE[0]), np.log(BETA_RANGE[1]), BETA_STEPS))
    if curve is not None and curve[0] > 0:
        c0, b0 = curve
        c = c0 * np.exp(np.linspace(-CURVE_TOLERANCE_LOG, CURVE_TOLERANCE_LOG, 41))
        b = b0 * np.exp(np.linspace(-CURVE_TOLERANCE_LOG, CURVE_TOLERANCE_LOG, 5))
        cc, bb = np.meshgrid(c, b, indexing="ij")
        return cc.ravel(), bb.ravel(), True
    c = np.exp(np.arange(np.log(ROTOR_HZ_RANGE[0]), np.log(ROTOR_HZ_RANGE[1]), SCALE_STEP_LOG))
    cc, bb = np.meshgrid(c, betas, indexing="ij")
    return cc.ravel(), bb.ravel(), False


def _mean_sq(y: np.ndarray, pred: np.ndarray) -> np.ndarray:
    """Mean over windows (axis -1) of the clipped squared residual."""
    r = y - pred
    return np.mean(np.minimum(r * r, RESIDUAL_CLIP_HZ ** 2), axis=-1)


def _logsumexp(x: np.ndarray, axis: int = 0) -> np.ndarray:
    top = np.max(x, axis=axis, keepdims=True)
    return np.squeeze(top, axis=axis) + np.log(np.sum(np.exp(x - top), axis=axis))


def tie(y: np.ndarray, speeds: np.ndarray, fs: float, source: str, curve: Optional[tuple] = None,
        hop_s: float = TRACK_WINDOW_S / 2) -> dict:
    """Score each rotor (and their mean, and a fixed frequency) as the line's source (module
    docstring). ``y`` (N,) folded track, Hz; ``speeds`` (N, n); ``curve`` (c, β) of the
    command-to-line map f = c·s^β from a profile. Returns tie_probs, follows_llr, the map and its
    fit, the rotors' predicted spread."""
    n = speeds.shape[1]
    hyp = np.column_stack([speeds, speeds.mean(axis=1)])  # (N, n + 1): rotor k, then "common"
    s_ref = 1.0 if (source == "esc_rpm" or curve is not None) else float(np.median(hyp[:, n]))
    lx = np.log(hyp / s_ref).T  # (n + 1, N)
    cs, bs, known = _grid(speeds, source, curve if source == "command" else None)
    n_eff = max(y.size * hop_s / TRACK_CORRELATION_S, 2.0)
    s2 = np.empty((cs.size, n + 1))
    chunk = max(1, int(4e6 // max(y.size * (n + 1), 1)))
    for lo in range(0, cs.size, chunk):
        c, b = cs[lo:lo + chunk], bs[lo:lo + chunk]
        pred = fold(c[:, None, None] * np.exp(b[:, None, None] * lx[None, :, :]), fs)  # (grid, n + 1, N)
        s2[lo:lo + chunk] = _mean_sq(y[None, None, :], pred)
    ll = -0.5 * n_eff * np.log(s2 + RESIDUAL_FLOOR_HZ2)  # (grid, n + 1)
    if not known:  # the thrust model makes sqrt(command) ∝ speed: β near 1 unless the track says otherwise
        ll = ll - 0.5 * (np.log(bs) / BETA_PRIOR_SD_LOG)[:, None] ** 2
    logl = _logsumexp(ll, axis=0) - np.log(cs.size)
    # a fixed frequency (a resonance): the best constant, scored alike
    const = -0.5 * n_eff * np.log(_mean_sq(y, np.full_like(y, np.median(y))) + RESIDUAL_FLOOR_HZ2)
    top = float(np.max(logl))
    lik = np.exp(logl - top)
    tot = lik[:n].sum() + COMMON_PRIOR * lik[n]
    probs = (lik[:n] + COMMON_PRIOR * lik[n] / n) / tot
    best = int(np.argmax(logl))
    ib = int(np.argmax(ll[:, best]))
    c_best, b_best = float(cs[ib]), float(bs[ib])
    pred_all = c_best * np.exp(b_best * lx[:n].T)  # (N, n) unfolded predicted line of each rotor
    spread = float(np.quantile(pred_all.max(axis=1) - pred_all.min(axis=1), SPREAD_QUANTILE))
    # the map is pinned when the best hypothesis's posterior puts the line in one fold zone
    post = np.exp(ll[:, best] - ll[:, best].max())
    post /= post.sum()
    at_median = cs * np.exp(bs * np.median(lx[best]))
    order = np.argsort(at_median)
    cdf = np.cumsum(post[order])
    f_lo = at_median[order][np.searchsorted(cdf, 0.05)]
    f_hi = at_median[order][min(np.searchsorted(cdf, 0.95), cs.size - 1)]
    pinned = known or np.floor(f_lo / (fs / 2)) == np.floor(f_hi / (fs / 2))
    return {"probs": probs.tolist(), "follows_llr": float(top - const), "scale": c_best, "beta": b_best,
            "s_ref": s_ref, "scale_known": known, "pinned": bool(pinned), "sigma": float(np.sqrt(s2[ib, best])),
            "spread": spread, "rotor_hz": float(c_best * np.exp(b_best * np.median(lx[best]))), "best": best}


def rotors_parted(line: Optional[RotorLine]) -> bool:
    """True when the rotors' predicted lines parted (at SPREAD_QUANTILE of the windows) by more
    than twice the track's scatter: a rotor can be singled out in this flight."""
    if line is None or not line.tie_source or line.spread_hz is None:
        return False
    sig = max(line.track_sigma_hz or 0.0, float(np.sqrt(RESIDUAL_FLOOR_HZ2)))
    return line.spread_hz >= 2.0 * sig


def tie_motor(line: Optional[RotorLine]) -> Optional[int]:
    """The rotor a line names: its tie probability reaches TIE_NAME_P, the line following the rotors."""
    if line is None or not line.follows or not line.tie_probs:
        return None
    k = line.best_motor
    return k if line.tie_probs[k - 1] >= TIE_NAME_P else None


def at_band_edge(line: RotorLine) -> bool:
    """The line sits within one resolution (1 / TRACK_WINDOW_S) of the band's lower edge: there the
    strongest power can be the skirt of motion below the band (it then follows nothing), or a
    rotor's line folded just below it, which follows its rotor (results/vibration.md), so the edge
    stays a candidate and only the words differ."""
    return line.freq_hz < LINE_MIN_HZ + 1.0 / TRACK_WINDOW_S


def why_untied(line: RotorLine, n: int) -> str:
    """Plain words: why the line names no rotor (module docstring), with the measure; "" when it names one."""
    if not line.tie_source:
        return "this log has no motor outputs or ESC rpm, so the line cannot be tied to a rotor"
    if not line.follows:
        if at_band_edge(line):
            return (f"it sits at the band's lower edge and does not follow the rotors' speed "
                    f"({line.follows_llr:+.1f} nats against a fixed frequency): motion or a frame mode below "
                    f"{LINE_MIN_HZ:.0f} Hz, not a rotor")
        return (f"the line at {line.freq_hz:.1f} Hz does not follow the rotors' speed (a fixed frequency "
                f"explains it as well, {line.follows_llr:+.1f} nats): a frame or mount resonance, not a rotor")
    sig = line.track_sigma_hz or 0.0
    if not rotors_parted(line):
        return (f"the rotors turned within {line.spread_hz:.1f} Hz of each other in {SPREAD_QUANTILE:.0%} of "
                f"the flight, closer than the line's track is known (±{sig:.1f} Hz): no rotor can be singled out")
    if tie_motor(line) is not None:
        return ""
    order = np.argsort(line.tie_probs)[::-1]
    a, b = int(order[0]) + 1, int(order[1]) + 1 if n > 1 else None
    if b is None:
        return ""
    return (f"the line follows motors {a} and {b} alike (P {line.tie_probs[a - 1]:.2f} / "
            f"{line.tie_probs[b - 1]:.2f}): their speeds moved together in this flight")


def find_rotor_line(flight: Flight, intervals, curve: Optional[tuple] = None) -> tuple[Optional[RotorLine], Optional[str]]:
    """The strongest rotor line of the horizontal gyro or accelerometer spectrum (the stream where
    it stands out more), its amplitude in the accelerometer and its tie (module docstring); or
    (None, why not). ``curve``: the profile's command-to-line map (c, β): f = c·s^β Hz with s the
    sqrt of the thrust command, or None."""
    v = flight.vibration
    if v is None:
        return None, "no IMU stream for a spectrum"
    cands = []
    slow = []
    for kind in ("gyro", "accel"):
        s = v.fastest(kind, batch=False)
        if s is None:
            continue
        x = getattr(s, kind)
        if x.rate_hz < MIN_SPECTRUM_HZ:
            slow.append(f"{kind} {x.rate_hz:.0f} Hz")
            continue
        sp = spectra(x, intervals, kind, x.source)
        if sp is not None:
            cands.append(sp)
    if not cands:
        if slow:
            return None, (f"IMU logged at {', '.join(slow)}: too slow for rotor lines (needs "
                          f"{MIN_SPECTRUM_HZ:.0f} Hz)")
        return None, "too little airborne IMU data for a spectrum"
    peaks = []
    for sp in cands:
        f, _ = _peak(sp)
        peaks.append(((f, tracked_prominence(sp, f) if np.isfinite(f) else 0.0), sp))
    (f0, prom), sp = max(peaks, key=lambda x: x[0][1])
    if not np.isfinite(f0) or prom < LINE_PROMINENCE:
        return None, (f"no line in the gyro or accelerometer spectrum (strongest {f0:.1f} Hz at "
                      f"{prom:.1f}x the band median window by window, {sp.kind})")
    line = RotorLine(f0, prom, sp.source, sp.kind, sp.fs)
    y, _ = track(sp, f0)
    line.windows = int(y.size)
    acc = next((c for c in cands if c.kind == "accel"), None)
    if acc is not None and abs(acc.fs / sp.fs - 1.0) < 0.01 and acc.centres.size == sp.centres.size:
        _, lp = track(acc, f0) if acc is not sp else track(sp, f0)
        band = acc.band()
        line.amplitude = float(acc.rms(np.mean(lp)))
        line.band_rms = float(acc.rms(np.mean(acc.power[:, band].sum(axis=1))))
    speeds, source = rotor_speeds(flight, sp.centres, TRACK_WINDOW_S / 2)
    n = flight.frame.rotor_count if flight.frame is not None else (speeds.shape[1] if speeds is not None else 0)
    line.tie_probs = [1.0 / n] * n if n else []
    if speeds is None:
        line.why_untied = why_untied(line, n)
        return line, None
    ok = np.all(np.isfinite(speeds) & (speeds > 0), axis=1)
    if ok.sum() < MIN_TRACK_WINDOWS:
        line.why_untied = "too few windows with every rotor's speed to tie the line"
        return line, None
    line.tie_source = source
    r = tie(y[ok], speeds[ok], sp.fs, source, curve)
    line.tie_probs = r["probs"]
    line.follows_llr = r["follows_llr"]
    line.follows = r["follows_llr"] >= FOLLOWS_MIN_LLR
    line.scale, line.beta, line.s_ref, line.scale_known = r["scale"], r["beta"], r["s_ref"], r["scale_known"]
    line.track_sigma_hz, line.spread_hz = r["sigma"], r["spread"]
    if r["pinned"]:
        line.rotor_hz = r["rotor_hz"]
        line.folded = bool(r["rotor_hz"] > sp.fs / 2)
    if not line.follows:
        line.tie_probs = [1.0 / n] * n
    line.why_untied = why_untied(line, n)
    return line, None


def strongest_accel_line(flight: Flight, intervals) -> Optional[tuple[float, str, float]]:
    """(horizontal RMS in m/s/s of the accelerometer's strongest bin ±1 in the line band, the
    stream, its rate) whatever its prominence: a healthy flight's largest line (a profile's
    reference for a later line); None without an accelerometer fast enough."""
    v = flight.vibration
    s = v.fastest("accel", batch=False) if v is not None else None
    if s is None or s.accel.rate_hz < MIN_SPECTRUM_HZ:
        return None
    sp = spectra(s.accel, intervals, "accel", s.accel.source)
    if sp is None:
        return None
    f0, _ = _peak(sp)
    if not np.isfinite(f0):
        return None
    _, lp = track(sp, f0)
    return float(sp.rms(np.mean(lp))), sp.source, float(sp.fs)


__all__ = ["RotorLine", "Spectra", "at_band_edge", "find_rotor_line", "fold", "rotor_speeds", "rotors_parted", "spectra",
           "strongest_accel_line", "tie", "tie_motor", "track", "tracked_prominence", "why_untied",
           "LINE_MIN_HZ", "LINE_PROMINENCE", "MIN_SPECTRUM_HZ", "TIE_NAME_P", "TRACK_WINDOW_S"]
