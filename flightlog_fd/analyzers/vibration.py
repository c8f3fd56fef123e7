"""Vibration analyzer: an out-of-balance propeller shakes the airframe once per revolution.

What: two figures from :attr:`Flight.vibration` over the airborne time (``AIRBORNE_TRIM_S`` off
each end of each airborne interval):

- **level**: the horizontal vibration ``sqrt(X² + Y²)`` in m/s/s, where X, Y are the RMS of the
  accelerometer above a 5 Hz floor (ArduPilot's ``VIBE`` definition: AP_InertialSensor computes it
  on every raw sample). From the logged ``VIBE`` where present (median over the flight per IMU,
  then the median over IMUs, so one oddly mounted IMU does not decide); else from the fastest raw
  accelerometer stream, where it is a LOWER bound (the logged stream is low-passed, integrated or
  decimated, which only removes power), so it can raise an alarm but never clear one. The
  imbalance force is in the rotor plane, so the horizontal axes carry it (measured on the octo_air
  logs: a 15-35 mm cut moved X/Y 5-7x, Z 2x). PX4's ``vehicle_imu_status`` metric has its own
  definition: it is compared only with a profile's baseline of the same metric.
- **rotor line**: where the fastest gyro stream resolves rotor rates (``MIN_SPECTRUM_HZ``), the
  strongest narrow line of the horizontal gyro spectrum above ``LINE_MIN_HZ``; its frequency
  track in ``TRACK_WINDOW_S`` windows is regressed on each rotor's speed (ESC rpm where logged,
  else ``sqrt`` of its thrust command: rotor speed ∝ sqrt(thrust)); the rotor whose speed explains
  the track best is the one the line is tied to.

Weighing: the level gives a flight-level log Bayes factor ``flight_llr`` (nats) of "a propeller
is out of balance" (level raised by a factor from the prior ``IMBALANCE_PRIOR``) against healthy:
with a profile, against this airframe's calibrated level and its flight-to-flight spread
(``PROFILE_SPREAD_LOG``); without one, against the spread of healthy airframes
(``HEALTHY_LEVEL_REF``, ``HEALTHY_SPREAD_LOG``), capped at ``NO_PROFILE_LLR_CAP`` (airframes differ
10x, so a level alone is never "damaged" without the airframe's own baseline). When the line is
tied to a rotor, the per-motor LLR is ``flight_llr + log(n·p_k)`` with ``p_k`` the tie's posterior
(under healthy the strongest residual line belongs to any rotor; under "rotor k out of balance" to
k), so the tie can add at most log n; only a tie by ESC rpm at once per revolution is weighed per
motor (a tie by the commanded speed alone can follow the wrong rotor: simulated 1 kHz flights tied
2-4 of 12 lines at 20 m/s/s to another motor). The flight-level finding goes to the decision in
:class:`VibrationResult` ("a propeller is out of balance; inspect all"), tied or not: the per-motor
sums add the other analyzers' evidence about thrust loss, which a mass imbalance does not cause,
so a tied line must not weigh less than an untied one.

Limits: needs ``MIN_AIRBORNE_S`` of airborne samples; a symmetric cut (both blades shortened)
loses thrust without imbalance and does not raise vibration (rrc quad: 3.6-6.6 m/s/s against
5.1-5.6 with good propellers); a loose mount, a bent motor shaft or a damaged bearing shakes too
(the finding says "inspect"); rotor lines above the gyro's Nyquist frequency alias and are not used.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..flight import Flight, Series
from .base import Analyzer, AnalyzerResult, Context, Finding

ANALYZER_ID = "vibration"
#: Seconds dropped after take-off and before landing (spin-up, ground contact).
AIRBORNE_TRIM_S = 5.0
#: In-flight time (s) the level needs.
MIN_AIRBORNE_S = 10.0
#: ArduPilot's vibration floor filter (AP_INERTIAL_SENSOR_ACCEL_VIBE_FLOOR_FILT_HZ): the level is
#: the RMS above it.
FLOOR_HZ = 5.0
#: No-profile healthy reference (m/s/s, horizontal VIBE): the median of the healthy airframes'
#: levels in ../shared (results/vibration.md): rrc quad 5.1-5.6 (3 flights), octo_air 4.9 / 6.0,
#: Erle 3.4 (copter34_22) 7.6-8.0 (3 flights), Erle 3.4 (copter34_7) 0.7; median of airframes 5.4.
HEALTHY_LEVEL_REF = 5.4
#: Spread (natural log) of healthy levels across airframes above that reference: the highest
#: healthy airframe (8.0) is ln(8.0 / 5.4) = 0.39 above it; one standard deviation.
HEALTHY_SPREAD_LOG = 0.40
#: Flight-to-flight spread (natural log) of one airframe's level with intact propellers: measured
#: std 0.03 (rrc, 3 good flights), 0.03 (Erle copter34_22, 3 flights in one log), 0.20 (octo_air
#: 14 against the first flight of 03, another day); rrc with symmetric cuts (no imbalance) spread
#: 0.19 over 15 flights. The largest, 0.20, with a margin for payload and battery changes.
PROFILE_SPREAD_LOG = 0.25
#: Prior of the level rise an out-of-balance propeller causes, as log-factors: uniform on
#: 1.5x..10x (octo_air: 15 mm and 35 mm cuts, 5-7x its healthy level; ArduPilot calls > 30 m/s/s
#: a problem, 6x a typical healthy frame).
IMBALANCE_PRIOR = np.log(np.linspace(1.5, 10.0, 60))
#: Without a profile the level's LLR is capped below decision.DAMAGED_LLR (6): healthy airframes
#: span 0.7-8.0 m/s/s, so only the airframe's own baseline can prove damage from the level alone.
NO_PROFILE_LLR_CAP = 5.0
#: The level's LLR is floored here (a quiet flight clears only so far: a mild imbalance can hide
#: under a quiet airframe's spread).
LLR_FLOOR = -3.0
#: Against a profile, a raw accelerometer level is weighed only from a stream of at least this rate.
#: Slower raw streams are the autopilot's filtered accelerometer (ArduPilot INS_ACCEL_FILTER, 20 Hz
#: by default; PX4 IMU_ACCEL_CUTOFF, 30 Hz), which removes the rotor rates (30-150 Hz): what is
#: left is manoeuvring and the filter's leak, which move with firmware and filter settings between
#: sessions (a real healthy Erle board-B pair, IMU logged at 50 Hz, firmware 3.4 vs 3.3: 0.61 vs
#: 2.6 m/s/s). Such a level is weighed against the healthy airframes (capped) instead.
RAW_PROFILE_MIN_HZ = 100.0
#: A raw level sees the band FLOOR_HZ..rate/2, so two raw levels compare only at nearly one
#: logging rate: within this fraction of the calibration's.
RAW_RATE_MATCH = 0.15
#: The gyro stream must run at least this fast for a spectrum (Nyquist 50 Hz: 10-inch rotors
#: turn at 70-100 Hz at hover, larger ones 40-70 Hz).
MIN_SPECTRUM_HZ = 100.0
#: Lines are searched from here up to 0.95 of the Nyquist frequency (below: airframe modes and
#: control motion).
LINE_MIN_HZ = 30.0
#: A line is reported when it stands this far above the median of the band (power ratio):
#: healthy flights measured 1.6-4.0 (CrazyPAD 100 Hz; RflyMAD SIL 250 Hz), udesa prop 13: 1125.
LINE_PROMINENCE = 20.0
#: Window (s) of the line's frequency track; its windows overlap by half.
TRACK_WINDOW_S = 0.5
#: Correlation time (s) of the track's residuals: the tie's likelihoods count one sample per this.
TRACK_CORRELATION_S = 1.0
#: The tie is made only when the best rotor's speed explains the track with this correlation or
#: more (a rotor line follows its rotor's speed).
TIE_MIN_CORRELATION = 0.3
#: Minimum windows in the track.
MIN_TRACK_WINDOWS = 20


@dataclass
class Level:
    """The flight's horizontal vibration level and where it came from."""

    value: float  # m/s/s (or the PX4 metric's unit)
    source: str
    kind: str  # "vibe" (logged VIBE), "raw" (lower bound from a raw stream), "px4_metric"
    per_imu: dict = field(default_factory=dict)
    z: Optional[float] = None
    seconds: float = 0.0
    rate_hz: Optional[float] = None  # the raw stream's rate (kind "raw")


@dataclass
class RotorLine:
    """The strongest spectral line, its frequency track and its tie to a rotor."""

    freq_hz: float
    prominence: float
    source: str
    amplitude: Optional[float] = None  # RMS of the line in the horizontal accelerometer (m/s/s), lower bound
    motor: Optional[int] = None
    correlation: dict = field(default_factory=dict)  # motor -> r of log f against log rotor speed
    tie_posterior: dict = field(default_factory=dict)  # motor -> p_k
    speed_source: str = ""
    rev_per_speed: Optional[float] = None  # line frequency / rotor speed (Hz per rev/s) with ESC rpm


@dataclass
class VibrationAnalysis:
    level: Optional[Level]
    line: Optional[RotorLine]
    flight_llr: Optional[float]
    ratio: Optional[float]  # level / reference
    against: str  # "profile" / "healthy airframes" / ""
    abstain: Optional[str] = None
    notes: list = field(default_factory=list)


# ----------------------------------------------------------------------------- measurement


def _intervals(flight: Flight) -> list[tuple[float, float]]:
    return [(a + AIRBORNE_TRIM_S, b - AIRBORNE_TRIM_S) for a, b in flight.airborne if b - a > 2 * AIRBORNE_TRIM_S]


def _mask(t: np.ndarray, intervals) -> np.ndarray:
    m = np.zeros(t.shape, dtype=bool)
    for a, b in intervals:
        m |= (t >= a) & (t <= b)
    return m


def _seconds(s: Series, intervals) -> float:
    return float(np.count_nonzero(_mask(s.t, intervals)) / s.rate_hz) if s.rate_hz > 0 else 0.0


def _raw_level(s: Series, intervals) -> tuple[np.ndarray, float]:
    """Per-axis RMS above FLOOR_HZ (m/s/s) of a raw accelerometer stream over the intervals."""
    fs = s.rate_hz
    k = max(int(round(fs / FLOOR_HZ)), 1)  # moving-average floor ~ FLOOR_HZ
    acc, n, secs = np.zeros(3), 0, 0.0
    for a, b in intervals:
        m = (s.t >= a) & (s.t <= b)
        idx = np.flatnonzero(m)
        x = s.values[idx[0]:idx[-1] + 1] if idx.size and idx[-1] - idx[0] + 1 == idx.size else s.values[m]
        if x.shape[0] <= 2 * k:
            continue
        # Axes as rows (a leading zero column for the running sum): the same sums in the same
        # order as along the rows of x, without strided passes over the (n, 3) array.
        # The squares are summed by a running sum, sample after sample, as the column sum of
        # the (n, 3) array adds them.
        xt = np.zeros((3, x.shape[0] + 1))
        xt[:, 1:] = x[:, :3].T
        c = np.cumsum(xt, axis=1)
        floor = (c[:, k:] - c[:, :-k]) / k
        d = xt[:, 1 + k // 2: 1 + k // 2 + floor.shape[1]] - floor
        acc += np.cumsum(d * d, axis=1)[:, -1]
        n += d.shape[1]
        secs += d.shape[1] / fs
    return (np.sqrt(acc / n) if n else np.full(3, np.nan)), secs


def measure_level(flight: Flight) -> Optional[Level]:
    """The horizontal level (see module docstring), or None without a usable source."""
    v = flight.vibration
    iv = _intervals(flight)
    if v is None or not iv:
        return None
    if v.metrics:
        per, zs, secs = {}, [], 0.0
        for inst, s in sorted(v.metrics.items()):
            m = _mask(s.t, iv)
            x = s.values[m]
            if x.shape[0] < 3 or not np.isfinite(x[:, 0]).any() or np.nanmax(np.abs(x[:, :2])) <= 0:
                continue  # a board that never computes it logs zeros
            if v.metric_kind == "ardupilot_vibe":
                per[inst] = float(np.nanmedian(np.hypot(x[:, 0], x[:, 1])))
                zs.append(float(np.nanmedian(x[:, 2])))
            else:
                per[inst] = float(np.nanmedian(x[:, 0]))
            secs = max(secs, _seconds(s, iv))
        if per and secs >= MIN_AIRBORNE_S:
            kind = "vibe" if v.metric_kind == "ardupilot_vibe" else "px4_metric"
            src = "VIBE" if kind == "vibe" else "vehicle_imu_status.accel_vibration_metric"
            return Level(float(np.median(list(per.values()))), src, kind, per,
                         float(np.median(zs)) if zs else None, secs)
    return raw_level(flight)


def raw_level(flight: Flight) -> Optional[Level]:
    """The horizontal level above ``FLOOR_HZ`` from the fastest continuous raw accelerometer: a
    LOWER bound of VIBE's (the logged stream is filtered or decimated), or None."""
    v = flight.vibration
    iv = _intervals(flight)
    s = v.fastest("accel", batch=False) if v is not None else None
    if s is None or not iv:
        return None
    rms, secs = _raw_level(s.accel, iv)
    if secs < MIN_AIRBORNE_S or not np.isfinite(rms).all():
        return None
    return Level(float(np.hypot(rms[0], rms[1])), s.accel.source, "raw", {s.instance: float(np.hypot(rms[0], rms[1]))},
                 float(rms[2]), secs, float(s.accel.rate_hz))


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


def spectrum(s: Series, intervals, seconds: float = 1.0, axes=(0, 1)) -> tuple[np.ndarray, np.ndarray]:
    """Welch spectrum (frequencies Hz, power summed over ``axes``; arbitrary units) of a stream over
    the intervals, ``seconds``-long Hann windows overlapping by half."""
    fs = s.rate_hz
    nper = max(int(fs * seconds), 8)
    parts = [np.zeros((1, nper // 2 + 1))]
    for a, b in intervals:
        m = (s.t >= a) & (s.t <= b)
        x = s.values[m][:, list(axes)]
        parts.append(_psds(x, nper, nper, range(0, x.shape[0] - nper + 1, nper // 2)))
    n = sum(p.shape[0] for p in parts) - 1
    acc = np.cumsum(np.concatenate(parts), axis=0)[-1]  # summed in window order, as one by one
    return np.fft.rfftfreq(nper, 1.0 / fs), (acc / n if n else acc)


def _rotor_speeds(flight: Flight, centres: np.ndarray, half: float) -> tuple[Optional[np.ndarray], str]:
    """(windows, motors) rotor speed per window (rev/s from ESC rpm, else sqrt(thrust command) in
    arbitrary units) and its source."""
    esc = flight.esc
    n = flight.frame.rotor_count if flight.frame is not None else 0
    if esc is not None and n and all(esc.channel(k) is not None for k in range(1, n + 1)):
        out = np.full((centres.size, n), np.nan)
        for k in range(1, n + 1):
            c = esc.channel(k)
            ok = c.fresh()
            t, r = c.t[ok], c.rpm[ok]
            for i, tc in enumerate(centres):
                m = (t >= tc - half) & (t < tc + half)
                if m.any():
                    out[i, k - 1] = r[m].mean() / 60.0
        if np.isfinite(out).all(axis=1).sum() >= MIN_TRACK_WINDOWS:
            return out, "ESC rpm"
    if flight.motors is None:
        return None, ""
    from ..streams import flight_thrust_proxy

    u = np.sqrt(np.clip(flight_thrust_proxy(flight), 0.0, None))
    t = flight.motors.t
    idx_lo = np.searchsorted(t, centres - half)
    idx_hi = np.searchsorted(t, centres + half)
    c = np.vstack([np.zeros((1, u.shape[1])), np.cumsum(u, axis=0)])
    cnt = (idx_hi - idx_lo)[:, None]
    out = np.where(cnt > 0, (c[idx_hi] - c[idx_lo]) / np.maximum(cnt, 1), np.nan)
    return out, "sqrt(thrust command)"


def find_line(flight: Flight) -> tuple[Optional[RotorLine], Optional[str]]:
    """The strongest rotor line and its tie, or (None, why not)."""
    v = flight.vibration
    iv = _intervals(flight)
    s = v.fastest("gyro", batch=False) if v is not None else None
    if s is None:
        return None, "no gyro stream for a spectrum"
    g = s.gyro
    fs = g.rate_hz
    if fs < MIN_SPECTRUM_HZ:
        return None, f"gyro logged at {fs:.0f} Hz: too slow for rotor lines (needs {MIN_SPECTRUM_HZ:.0f} Hz)"
    f, p = spectrum(g, iv)
    band = (f >= LINE_MIN_HZ) & (f <= 0.95 * fs / 2)
    if band.sum() < 10 or not np.any(p[band] > 0):
        return None, "too little airborne gyro data for a spectrum"
    i = np.flatnonzero(band)[int(np.argmax(p[band]))]
    prom = float(p[i] / np.median(p[band]))
    if prom < LINE_PROMINENCE:
        return None, f"no line in the gyro spectrum (strongest {f[i]:.1f} Hz at {prom:.1f}x the band median)"
    line = RotorLine(float(f[i]), prom, g.source)
    a = v.fastest("accel", batch=False)
    if a is not None and a.accel.rate_hz >= MIN_SPECTRUM_HZ:
        fa, pa = spectrum(a.accel, iv)
        near = (fa > line.freq_hz * 0.9) & (fa < line.freq_hz * 1.1)
        w = np.hanning(max(int(a.accel.rate_hz), 8))
        if near.any():  # Parseval: sum |X|^2 / (N * sum w^2) over both sides
            line.amplitude = float(np.sqrt(2.0 * pa[near].sum() / (w.size * np.sum(w * w))))
    _tie(flight, g, iv, line)
    return line, None


def _tie(flight: Flight, g: Series, iv, line: RotorLine) -> None:
    """Track the line in short windows and tie it to the rotor whose speed explains it best."""
    fs = g.rate_hz
    nper = max(int(TRACK_WINDOW_S * fs), 16)
    pad = 8 * nper
    fr = np.fft.rfftfreq(pad, 1.0 / fs)
    band = (fr > line.freq_hz * 0.8) & (fr < min(line.freq_hz * 1.25, 0.98 * fs / 2))
    if not band.any():
        return
    centres, freqs = [], []
    for a, b in iv:
        m = (g.t >= a) & (g.t <= b)
        t, x = g.t[m], g.values[m][:, :2]
        starts = np.arange(0, x.shape[0] - nper + 1, nper // 2)
        if starts.size == 0:
            continue
        p = _psds(x, nper, pad, starts)
        j = np.flatnonzero(band)[np.argmax(p[:, band], axis=1)]
        centres.extend(np.lib.stride_tricks.sliding_window_view(t, nper)[starts].mean(axis=1).tolist())
        freqs.extend(fr[j].tolist())
    if len(freqs) < MIN_TRACK_WINDOWS:
        return
    centres, y = np.array(centres), np.log(np.array(freqs))
    speeds, source = _rotor_speeds(flight, centres, TRACK_WINDOW_S / 2)
    if speeds is None:
        return
    line.speed_source = source
    ok = np.all(np.isfinite(speeds) & (speeds > 0), axis=1)
    if ok.sum() < MIN_TRACK_WINDOWS:
        return
    xs, y = np.log(speeds[ok]), y[ok]
    n_eff = max(ok.sum() * (TRACK_WINDOW_S / 2) / TRACK_CORRELATION_S, 2.0)
    loglik = {}
    for k in range(xs.shape[1]):
        x = xs[:, k]
        if np.std(x) <= 0:
            continue
        r = float(np.corrcoef(x, y)[0, 1])
        line.correlation[k + 1] = r
        slope, icpt = np.polyfit(x, y, 1)
        rss = float(np.mean((y - slope * x - icpt) ** 2)) if slope > 0 else float(np.var(y))
        loglik[k + 1] = -0.5 * n_eff * np.log(max(rss, 1e-12))
    if not loglik:
        return
    top = max(loglik.values())
    z = {k: np.exp(v - top) for k, v in loglik.items()}
    tot = sum(z.values())
    line.tie_posterior = {k: float(v / tot) for k, v in z.items()}
    best = max(line.correlation, key=line.correlation.get)
    if line.correlation[best] >= TIE_MIN_CORRELATION:
        line.motor = best
        if source == "ESC rpm":
            line.rev_per_speed = float(np.exp(np.median(y - xs[:, best - 1])))


def _log_bayes_factor(x: float, sigma: float) -> float:
    """log mean over IMBALANCE_PRIOR δ of N(x; δ, σ) / N(x; 0, σ) (nats)."""
    d = IMBALANCE_PRIOR
    terms = (d * x - 0.5 * d * d) / (sigma * sigma)
    top = float(terms.max())
    return top + float(np.log(np.mean(np.exp(terms - top))))


@dataclass
class VibrationBaseline:
    """A profile's healthy vibration: the level (same ``kind`` and ``source`` as measured) and the
    flights it came from."""

    level: float
    kind: str
    source: str
    spread_log: float = PROFILE_SPREAD_LOG
    flights: list = field(default_factory=list)
    rate_hz: Optional[float] = None  # the raw stream's rate (kind "raw")

    def to_dict(self) -> dict:
        return {"analyzer": ANALYZER_ID, "level": self.level, "kind": self.kind, "source": self.source,
                "spread_log": self.spread_log, "flights": list(self.flights), "rate_hz": self.rate_hz}

    @classmethod
    def from_dict(cls, d: dict) -> "VibrationBaseline":
        rate = d.get("rate_hz")
        return cls(float(d["level"]), str(d["kind"]), str(d.get("source", "")),
                   float(d.get("spread_log", PROFILE_SPREAD_LOG)), list(d.get("flights", [])),
                   None if rate is None else float(rate))

    def measures(self, level: "Level") -> bool:
        """True when ``level`` is the metric this baseline holds: the same kind, and for a raw
        level the same source from a fast stream at nearly the same rate (``RAW_PROFILE_MIN_HZ``,
        ``RAW_RATE_MATCH``)."""
        if level.kind != self.kind:
            return False
        if level.kind != "raw":
            return True
        return (level.source == self.source and self.rate_hz is not None and level.rate_hz is not None
                and level.rate_hz >= RAW_PROFILE_MIN_HZ and abs(level.rate_hz / self.rate_hz - 1.0) <= RAW_RATE_MATCH)


def fit_vibration_baseline(flights: Sequence[Flight]) -> Optional[VibrationBaseline]:
    """The healthy level of an airframe from its calibration flights (geometric mean over flights;
    spread: the larger of PROFILE_SPREAD_LOG and the flights' own std), None without a level."""
    levels = [(measure_level(f), f) for f in flights]
    levels = [(lv, f) for lv, f in levels if lv is not None and lv.value > 0]
    if not levels:
        return None
    kind = levels[0][0].kind
    same = [(lv, f) for lv, f in levels if lv.kind == kind]
    logs = np.log([lv.value for lv, _ in same])
    spread = max(PROFILE_SPREAD_LOG, float(np.std(logs, ddof=1)) if len(logs) > 1 else 0.0)
    rates = [lv.rate_hz for lv, _ in same if lv.rate_hz is not None]
    return VibrationBaseline(float(np.exp(logs.mean())), kind, same[0][0].source, spread,
                             [f.path or f"flight {i}" for i, (_, f) in enumerate(same)],
                             float(np.median(rates)) if rates else None)


def analyze_vibration(flight: Flight, baseline: Optional[VibrationBaseline] = None) -> VibrationAnalysis:
    """Level, rotor line and their evidence for one flight (module docstring)."""
    level = measure_level(flight)
    line, why_no_line = find_line(flight) if flight.vibration is not None else (None, "no vibration data")
    notes = []
    if level is None and line is None:
        return VibrationAnalysis(None, None, None, None, "", abstain="no vibration data in the airborne time"
                                 + (f" ({why_no_line})" if why_no_line else ""))
    flight_llr, ratio, against = None, None, ""
    if level is not None and level.kind == "px4_metric" and not (baseline is not None and baseline.measures(level)):
        # PX4's metric has no healthy reference across airframes: without a profile of the same
        # metric, the raw accelerometer's lower bound is weighed against the healthy airframes
        level = raw_level(flight) or level
    if level is not None:
        if baseline is not None and baseline.measures(level):
            ratio = level.value / baseline.level
            x = float(np.log(ratio))
            flight_llr = _log_bayes_factor(x, baseline.spread_log)
            against = "profile"
        elif level.kind in ("vibe", "raw"):
            ratio = level.value / HEALTHY_LEVEL_REF
            x = float(np.log(ratio))
            flight_llr = min(_log_bayes_factor(x, HEALTHY_SPREAD_LOG), NO_PROFILE_LLR_CAP)
            against = "healthy airframes"
        if flight_llr is not None:
            flight_llr = max(flight_llr, LLR_FLOOR)
            if level.kind == "raw":
                flight_llr = max(flight_llr, 0.0)  # a lower bound cannot clear
    if line is not None:
        words = (f"a line at {line.freq_hz:.1f} Hz in the gyro spectrum ({line.prominence:.0f}x the band"
                 + (f"; {line.amplitude:.1f} m/s/s RMS in the horizontal accelerometer" if line.amplitude else "")
                 + ")")
        if line.motor is not None:
            r = line.correlation[line.motor]
            words += (f" follows the speed of motor {line.motor} ({line.speed_source}, r={r:.2f}): a "
                      f"once-per-revolution rotor vibration, the signature of an out-of-balance propeller")
            if line.rev_per_speed is not None:
                words += f" ({line.rev_per_speed:.2f} x its rotation rate)"
        else:
            words += " that no rotor's speed explains"
        notes.append(words)
    return VibrationAnalysis(level, line, flight_llr, ratio, against, notes=notes)


def level_words(a: VibrationAnalysis) -> str:
    """Plain words for the level: "vibration 5.9x this airframe's healthy level (28.9 against 4.9 m/s/s)"."""
    if a.level is None or a.ratio is None:
        return ""
    ref = "this airframe's healthy level" if a.against == "profile" else "the healthy airframes' typical level"
    base = a.level.value / a.ratio
    bound = "at least " if a.level.kind == "raw" else ""
    return (f"vibration {bound}{a.ratio:.2g}x {ref} ({a.level.value:.2g} against {base:.2g} "
            f"{'m/s/s' if a.level.kind != 'px4_metric' else 'PX4 metric'}, {a.level.source})")


#: A line tied by ESC rpm is trusted (the advice names its rotor) when its frequency is this close
#: to once per revolution of that rotor: a mis-set pole count or a line of another origin (a frame
#: mode, twice per revolution) scales the ratio by a whole factor (0.5, 2, 14/12...).
ONCE_PER_REV_TOLERANCE = 0.1


@dataclass
class VibrationResult(AnalyzerResult):
    """The vibration analyzer's result: per-motor ``rotor_line`` findings (weighed only when the
    tie is trusted) and the flight-level finding the decision reads: ``flight_llr`` (nats, "a
    propeller is out of balance" against healthy; None without a level), the level's plain words,
    and the line with the rotor it follows (``line_motor``; ``tie_trusted`` when tied by ESC rpm at
    once per revolution: a tie by the commanded speed alone can follow the wrong rotor, since all
    rotors' commands move together in manoeuvres)."""

    flight_llr: Optional[float] = None
    against: str = ""  # "profile" / "healthy airframes" / ""
    ratio: Optional[float] = None
    level_words: str = ""
    line_hz: Optional[float] = None
    line_motor: Optional[int] = None
    tie_source: str = ""
    tie_trusted: bool = False


class Vibration(Analyzer):
    """The registry's vibration analyzer: per motor an LLR when a rotor line is tied to a rotor by
    ESC rpm, and the flight-level finding (:class:`VibrationResult`) the decision weighs."""

    id = ANALYZER_ID
    description = "vibration: level against the airframe's healthy level, rotor lines in the gyro spectrum"
    requires = ("vibration",)
    needs_motor_outputs = False

    def fit_baseline(self, flights, model=None):
        from ..flights import split_flights

        b = fit_vibration_baseline([part for f in flights for part in split_flights(f)])
        return None if b is None else b.to_dict()

    def analyze(self, ctx: Context) -> AnalyzerResult:
        flight = ctx.flight
        if flight is None or getattr(flight, "vibration", None) is None:
            return VibrationResult(self.id, abstained="no vibration data in this log")
        b = ctx.baseline_for(self.id)
        a = analyze_vibration(flight, VibrationBaseline.from_dict(b) if b else None)
        return result_from(a, ctx.n_motors)


def tie_trusted(line: Optional[RotorLine]) -> bool:
    """True when the line is tied by ESC rpm at once per revolution (``ONCE_PER_REV_TOLERANCE``)."""
    return (line is not None and line.motor is not None and line.speed_source == "ESC rpm"
            and line.rev_per_speed is not None and abs(line.rev_per_speed - 1.0) <= ONCE_PER_REV_TOLERANCE)


def result_from(a: VibrationAnalysis, n: int) -> VibrationResult:
    """The :class:`VibrationResult` of one analysis. The per-motor LLR of a trusted tie is
    ``flight_llr + log(n·p_k)`` (the tie adds at most log n); an untrusted tie is shown, not weighed."""
    if a.abstain:
        return VibrationResult(ANALYZER_ID, abstained=a.abstain)
    out = []
    line = a.line
    trusted = tie_trusted(line) and bool(line.tie_posterior) and n >= 1
    base_llr = a.flight_llr if a.flight_llr is not None else 0.0
    if a.level is not None:
        out.append(Finding(ANALYZER_ID, 0, "level", a.level.value, "m/s/s" if a.level.kind != "px4_metric" else "",
                           None, None if a.ratio is None else a.level.value / a.ratio, "up", None,
                           level_words(a) or f"{a.level.value:.1f}"))
    if line is not None and line.motor is not None and line.tie_posterior and n >= 1:
        for k in range(1, n + 1):
            p = line.tie_posterior.get(k, 0.0)
            llr = (base_llr + float(np.clip(np.log(max(n * p, 1e-12)), -np.log(n), np.log(n)))) if trusted else None
            out.append(Finding(ANALYZER_ID, k, "rotor_line", line.freq_hz if k == line.motor else None, "Hz",
                               None, None, "up", llr,
                               f"{line.freq_hz:.0f}Hz {p:.2f}" if k == line.motor else f"{p:.2f}"))
    return VibrationResult(ANALYZER_ID, out, notes=list(a.notes), flight_llr=a.flight_llr, against=a.against,
                           ratio=a.ratio, level_words=level_words(a),
                           line_hz=None if line is None else line.freq_hz,
                           line_motor=None if line is None else line.motor,
                           tie_source="" if line is None else line.speed_source, tie_trusted=trusted)


#: Reasons of checks.diagnosability after which vibration alone can still judge the propellers
#: (no per-motor outputs, or no damage model for the frame): the level needs neither.
VIBRATION_ONLY_REASONS = ("no per-motor outputs", "motor outputs", "propeller-damage model", "only stopped-motor")


def vibration_can_judge(reasons: Sequence[str]) -> bool:
    """True when the full diagnosis refused the log for a reason vibration does not depend on."""
    return any(w in r for r in reasons for w in VIBRATION_ONLY_REASONS)


__all__ = ["ANALYZER_ID", "Vibration", "VibrationAnalysis", "VibrationBaseline", "VibrationResult", "analyze_vibration",
           "fit_vibration_baseline", "measure_level", "find_line", "spectrum", "level_words", "result_from",
           "tie_trusted", "vibration_can_judge", "VIBRATION_ONLY_REASONS"]
