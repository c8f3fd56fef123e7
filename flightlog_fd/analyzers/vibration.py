"""Vibration analyzer: an out-of-balance propeller shakes the airframe once per revolution of its rotor.

What: three figures from :attr:`Flight.vibration` over the airborne time (``AIRBORNE_TRIM_S`` off
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
- **rotor speed** (:func:`flight_speed`): the rotors' mean speed over the same time, from ESC rpm
  (rev/s) or the commands (mean sqrt of the thrust command), so a level is compared with the
  profile's at matching rotor speed: a heavier payload turns the rotors faster and shakes more
  without any damage (``SPEED_EXPONENT``).
- **rotor line** (:mod:`.rotor_lines`): the strongest narrow line of the horizontal gyro or
  accelerometer spectrum, followed through the flight (folded where above Nyquist) and tied to
  the rotor whose speed it follows (ESC rpm, else the command through the profile's
  command-to-line curve or a fitted one); its amplitude in the accelerometer.

Weighing: ``flight_llr`` (nats) = ``level_llr`` + ``line_llr``, the log Bayes factor of "a
propeller is out of balance" against healthy:

- ``level_llr``: the level raised by a factor from ``IMBALANCE_PRIOR``. With a profile, against this
  airframe's calibrated level at the flight's rotor speed (sessions fitted as ln level = a + p ln
  speed, p ~ N(``SPEED_EXPONENT``, ``SPEED_EXPONENT_SD``), spread ``PROFILE_SPREAD_LOG``); without
  one, against the spread of healthy airframes (``HEALTHY_LEVEL_REF``, ``HEALTHY_SPREAD_LOG``),
  capped at ``NO_PROFILE_LLR_CAP`` (airframes differ 10x: a level alone is never "damaged"
  without the airframe's own baseline); floored at ``LLR_FLOOR`` (a raw lower bound at 0).
- ``line_llr``: a line that follows the rotors' speed (a once-per-revolution line, not a
  resonance) with amplitude A in the accelerometer, against the profile's own strongest healthy
  line where its calibration measured one on the same stream (``LINE_PROFILE_SPREAD_LOG``, cap
  ``LINE_PROFILE_LLR_CAP``), else against a healthy propeller's line (``HEALTHY_LINE_REF``,
  ``HEALTHY_LINE_SPREAD_LOG``, cap ``LINE_LLR_CAP``); never below 0 (A is a lower bound where the
  logged accelerometer is filtered: a small line never clears). Where the line speaks, a level
  near the healthy one does not take it back (the level is floored at 0: the broadband floor
  dilutes a line in the level, and PX4's differencing metric is mostly noise). The two parts
  measure one shaking, so their sum over-counts where both are raised; the caps bound it, and
  the healthy sets measure what it costs (results/vibration.md).

The interface the decision reads (:class:`VibrationResult`, a subclass of AnalyzerResult):

- ``flight_llr``: log Bayes factor (nats) of "some propeller is out of balance" against healthy
  (None without a level or a line): evidence for "rotor k damaged", cause "propeller", to be
  spread over the rotors by ``tie_probs``. Measured: benchmarks/bench_vibration.py (results/vibration.md).
- ``tie_probs``: n floats, P(the out-of-balance propeller is on rotor k | one is out of balance),
  from the line's tie (uniform 1/n when no tie is possible); ``line_motor``: the rotor named when
  its P reaches ``TIE_NAME_P`` (measured never wrong on the simulated sets), else None;
  ``tie_trusted``: ``line_motor`` may be named (kept for the decision that reads it);
  ``tie_source`` "esc_rpm" | "command" | ""; ``why_untied``: plain words why no rotor is named
  ("the rotors turned within 2 Hz of each other in 90 % of the flight ..."), "" when one is.
- ``line_hz`` (as logged, folded), ``line_rotor_hz`` (unfolded, when the fold is known),
  ``ratio`` (level / reference), ``against`` ("profile" / "healthy airframes" / ""),
  ``level_words``; ``level_llr`` and ``line_llr`` (the two parts of ``flight_llr``).
- Per-motor ``rotor_line`` findings: ``llr = flight_llr + log(n·max(p_k, TIE_P_FLOOR))`` when a
  rotor is named (the tie adds at most log n), None (shown, not weighed) otherwise.

Limits: needs ``MIN_AIRBORNE_S`` of airborne samples; a symmetric cut (both blades shortened)
loses thrust without imbalance and does not raise vibration (rrc quad: 3.6-6.6 m/s/s against
5.1-5.6 with good propellers); a loose mount, a bent motor shaft or a damaged bearing shakes too
(the finding says "inspect"); no real healthy log with an accelerometer fast enough for rotor
lines is in ../shared, so the healthy line reference is physics (ISO 21940 balance grades) with a
wide spread, and the line's evidence is capped.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..flight import Flight, Series
from .base import Analyzer, AnalyzerResult, Context, Finding
from .rotor_lines import (LINE_MIN_HZ, LINE_PROMINENCE, MIN_SPECTRUM_HZ, PSD_BATCH, TIE_NAME_P,  # noqa: F401
                          RotorLine, _psds, at_band_edge, find_rotor_line, strongest_accel_line, tie_motor)

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
#: Without a profile the level's LLR is capped: healthy airframes span 0.7-8.0 m/s/s, so only the
#: airframe's own baseline can make the level alone sure. Under the decision's posterior (prior of
#: damage 0.10, no rotor named) 5 nats is P(damage) about 0.9: a level far beyond every healthy
#: airframe (octo_air 10: 31 m/s/s, 4.3 spreads above the reference) is damaged naming no rotor;
#: the real healthy flights of ../shared stay at or below 0 nats (results/vibration.md).
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
#: How the healthy level grows with rotor speed: level ∝ speed^p. An imbalance force is m·r·w²
#: (p = 2), and so is every aerodynamic force on the frame; within one flight the rotor speed spans
#: only 3-12 % on the real logs (rrc, Erle 3.4), too little to measure p (slopes -7..+3 with
#: r < 0.7), so p is this prior, refined by a profile whose sessions span speeds.
SPEED_EXPONENT = 2.0
#: Standard deviation of that prior: a frame mode near the rotor rate can make the level rise
#: faster or slower; at +18 % rotor speed (a +40 % payload) it widens the comparison by 0.17 in ln.
SPEED_EXPONENT_SD = 1.0
#: Healthy propeller's once-per-revolution line in the accelerometer (m/s/s, horizontal RMS):
#: ISO 21940-11 grades G 6.3-40 on a rigid airframe give 0.01-0.15 m/s/s (sim/prop_vibration.py;
#: F450 at hover: 0.09 at G 40); a frame's plate or arm mode can amplify a line a few times. No
#: real healthy log in ../shared has an accelerometer fast enough to measure it (results/vibration.md).
HEALTHY_LINE_REF = 0.3
#: Spread (natural log) of healthy lines: one e-fold either way (0.1-0.8 m/s/s), so 2 m/s/s is
#: two standard deviations above the reference.
HEALTHY_LINE_SPREAD_LOG = 1.0
#: Prior of the line's rise over a healthy propeller's, as log-factors: 3x..300x (udesa's cut
#: propeller: >= 18 m/s/s, 60x the reference; the simulated 10-100 g·mm imbalances 3-60x).
LINE_RISE_PRIOR = np.log(np.geomspace(3.0, 300.0, 60))
#: The line's LLR is capped here, as the level's without a profile: its healthy reference is
#: physics, not measured on real flights, so a line alone says at most what a level far beyond
#: every healthy airframe says; tied to a rotor it names that rotor, and with a raised level it
#: adds to it (udesa: line +5.0, level +4.6).
LINE_LLR_CAP = 5.0
#: Against a profile whose calibration measured its accelerometer's strongest line (same stream,
#: RAW_RATE_MATCH), the line is weighed against this airframe's own: flight-to-flight spread of a
#: healthy line (natural log). A residual line goes as w², so a 20 % faster rotor (a payload)
#: moves it 0.36 in ln; one standard deviation of 0.5 keeps that within one.
LINE_PROFILE_SPREAD_LOG = 0.5
#: The line's LLR against the airframe's own line is capped here (its reference is measured).
LINE_PROFILE_LLR_CAP = 8.0
#: Per-motor LLRs read a tie probability no lower than this: on the same flights 494 tie
#: probabilities were stated below 0.01, none for the true rotor (its lowest: 0.047); fewer
#: statements cannot vouch for smaller numbers (a rotor at P 1e-6 keeps flight_llr + log(n·0.01)).
TIE_P_FLOOR = 0.01


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




# ----------------------------------------------------------------------------- rotor speed


def flight_speed(flight: Flight, intervals=None) -> tuple[Optional[float], str]:
    """(the rotors' mean speed over the airborne time, its source): ESC rpm (rev/s, "esc_rpm") where
    every motor reports it, else the mean sqrt of the thrust commands ("command", arbitrary units
    of one airframe), else (None, "")."""
    iv = _intervals(flight) if intervals is None else intervals
    if not iv:
        return None, ""
    n = flight.frame.rotor_count if flight.frame is not None else 0
    esc = flight.esc
    if esc is not None and n and all(esc.channel(k) is not None for k in range(1, n + 1)):
        meds = []
        for k in range(1, n + 1):
            c = esc.channel(k)
            ok = c.fresh() & _mask(c.t, iv)
            if ok.sum() < 10:
                meds = []
                break
            meds.append(float(np.median(c.rpm[ok])) / 60.0)
        if meds and all(m > 0 for m in meds):
            return float(np.mean(meds)), "esc_rpm"
    if flight.motors is None:
        return None, ""
    from ..streams import flight_thrust_proxy

    m = _mask(flight.motors.t, iv)
    if m.sum() < 10:
        return None, ""
    u = np.sqrt(np.clip(flight_thrust_proxy(flight), 0.0, None))[m]
    if n and u.shape[1] > n:
        u = u[:, :n]
    s = float(np.median(u.mean(axis=1)))
    return (s, "command") if s > 0 else (None, "")


# ----------------------------------------------------------------------------- evidence


def _log_bayes_factor(x: float, sigma: float, prior: np.ndarray = IMBALANCE_PRIOR) -> float:
    """log mean over the prior's δ of N(x; δ, σ) / N(x; 0, σ) (nats)."""
    d = prior
    terms = (d * x - 0.5 * d * d) / (sigma * sigma)
    top = float(terms.max())
    return top + float(np.log(np.mean(np.exp(terms - top))))


def line_llr(line: Optional[RotorLine], baseline: Optional["VibrationBaseline"] = None) -> float:
    """The line's evidence (module docstring): 0 unless it follows the rotors' speed and its
    accelerometer amplitude is known; against the profile's own healthy line where the
    calibration measured one on the same stream (between 0 and LINE_PROFILE_LLR_CAP), else
    against a healthy propeller's (between 0 and LINE_LLR_CAP)."""
    if line is None or not line.follows or line.amplitude is None or line.amplitude <= 0:
        return 0.0
    if baseline is not None and baseline.line_reference(line) is not None:
        x = float(np.log(line.amplitude / baseline.line_reference(line)))
        return float(np.clip(_log_bayes_factor(x, LINE_PROFILE_SPREAD_LOG, LINE_RISE_PRIOR), 0.0, LINE_PROFILE_LLR_CAP))
    x = float(np.log(line.amplitude / HEALTHY_LINE_REF))
    return float(np.clip(_log_bayes_factor(x, HEALTHY_LINE_SPREAD_LOG, LINE_RISE_PRIOR), 0.0, LINE_LLR_CAP))


@dataclass
class VibrationBaseline:
    """A profile's healthy vibration: the level (same ``kind`` and ``source`` as measured), each
    calibration session's level at its rotor speed (``sessions``: {"level", "speed", "flight"};
    ``speed_source`` "esc_rpm" | "command" | ""), the command-to-line map of its rotor line
    (``curve`` [c, β]: f = c·sqrt(command)^β Hz) when one was measured, and the flights."""

    level: float
    kind: str
    source: str
    spread_log: float = PROFILE_SPREAD_LOG
    flights: list = field(default_factory=list)
    rate_hz: Optional[float] = None  # the raw stream's rate (kind "raw")
    sessions: list = field(default_factory=list)
    speed_source: str = ""
    curve: Optional[list] = None
    line: Optional[dict] = None  # {"ms2", "source", "rate_hz"}: the calibration's strongest accelerometer line

    def to_dict(self) -> dict:
        return {"analyzer": ANALYZER_ID, "level": self.level, "kind": self.kind, "source": self.source,
                "spread_log": self.spread_log, "flights": list(self.flights), "rate_hz": self.rate_hz,
                "sessions": [dict(s) for s in self.sessions], "speed_source": self.speed_source,
                "curve": None if self.curve is None else [float(x) for x in self.curve],
                "line": None if self.line is None else dict(self.line)}

    @classmethod
    def from_dict(cls, d: dict) -> "VibrationBaseline":
        rate = d.get("rate_hz")
        curve = d.get("curve")
        return cls(float(d["level"]), str(d["kind"]), str(d.get("source", "")),
                   float(d.get("spread_log", PROFILE_SPREAD_LOG)), list(d.get("flights", [])),
                   None if rate is None else float(rate), [dict(s) for s in d.get("sessions") or []],
                   str(d.get("speed_source") or ""), None if not curve else [float(x) for x in curve],
                   dict(d["line"]) if d.get("line") else None)

    def line_reference(self, line: RotorLine) -> Optional[float]:
        """The calibration's strongest accelerometer line (m/s/s) when it was measured on the
        stream the line's amplitude comes from, at nearly its rate (RAW_RATE_MATCH); else None."""
        ref = self.line
        if not ref or not ref.get("ms2") or line.amplitude is None:
            return None
        rate = float(ref.get("rate_hz") or 0.0)
        if rate <= 0 or abs(line.sample_hz / rate - 1.0) > RAW_RATE_MATCH:
            return None
        return float(ref["ms2"])

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

    def expected(self, speed: Optional[float], speed_source: str) -> tuple[float, float, Optional[float]]:
        """(ln of the healthy level expected at ``speed``, its predictive spread (ln), the speed
        ratio to the sessions' mean or None): the sessions fitted as ln level = a + p ln speed with
        p ~ N(SPEED_EXPONENT, SPEED_EXPONENT_SD) and each session's scatter ``spread_log``;
        without speeds (an older profile, a log without commands or rpm), the level itself."""
        pts = [(np.log(s["level"]), np.log(s["speed"])) for s in self.sessions
               if s.get("speed") and s.get("level") and s["speed"] > 0 and s["level"] > 0]
        if speed is None or speed <= 0 or not pts or speed_source != self.speed_source:
            return float(np.log(self.level)), self.spread_log, None
        y = np.array([p[0] for p in pts])
        x = np.column_stack([np.ones(len(pts)), [p[1] for p in pts]])
        prior_prec = np.diag([1e-6, 1.0 / SPEED_EXPONENT_SD ** 2])
        prior_mean = np.array([0.0, SPEED_EXPONENT])
        prec = x.T @ x / self.spread_log ** 2 + prior_prec
        cov = np.linalg.inv(prec)
        mean = cov @ (x.T @ y / self.spread_log ** 2 + prior_prec @ prior_mean)
        xs = np.array([1.0, np.log(speed)])
        var = self.spread_log ** 2 + float(xs @ cov @ xs)
        return float(xs @ mean), float(np.sqrt(var)), float(speed / np.exp(np.mean(x[:, 1])))


def fit_vibration_baseline(flights: Sequence[Flight]) -> Optional[VibrationBaseline]:
    """The healthy level of an airframe from its calibration flights, one session each (level:
    geometric mean over flights; spread: the larger of PROFILE_SPREAD_LOG and the flights' own std
    at matching speed), each session's rotor speed, and the command-to-line map where a flight's
    rotor line follows the commands; None without a level."""
    measured = []
    for i, f in enumerate(flights):
        lv = measure_level(f)
        if lv is None or lv.value <= 0:
            continue
        sp, src = flight_speed(f)
        measured.append((lv, sp, src, f, i))
    if not measured:
        return None
    kind = measured[0][0].kind
    same = [m for m in measured if m[0].kind == kind]
    logs = np.log([m[0].value for m in same])
    srcs = {m[2] for m in same}
    speed_source = same[0][2] if len(srcs) == 1 else ""
    sessions = [{"level": float(lv.value), "speed": (float(sp) if sp is not None and speed_source else None),
                 "flight": f.path or f"flight {i}"} for lv, sp, _, f, i in same]
    spread = PROFILE_SPREAD_LOG
    if len(logs) > 1:
        resid = logs
        spd = [s["speed"] for s in sessions]
        if all(s is not None for s in spd):
            resid = logs - SPEED_EXPONENT * np.log(spd)
        spread = max(PROFILE_SPREAD_LOG, float(np.std(resid, ddof=1)))
    rates = [m[0].rate_hz for m in same if m[0].rate_hz is not None]
    lines = [x for x in (strongest_accel_line(m[3], _intervals(m[3])) for m in same) if x is not None]
    line_ref = None
    if lines:
        top = max(lines, key=lambda x: x[0])  # the largest healthy line: a later one is weighed against it
        line_ref = {"ms2": top[0], "source": top[1], "rate_hz": top[2]}
    curve = None
    for _, _, src, f, _ in same:
        if src != "command":
            continue
        line, _ = find_rotor_line(f, _intervals(f))
        if line is not None and line.follows and line.scale is not None and line.rotor_hz is not None:
            s_ref = line.s_ref or 1.0
            curve = [float(line.scale / s_ref ** line.beta), float(line.beta)]  # f = c·s^β
            break
    return VibrationBaseline(float(np.exp(logs.mean())), kind, same[0][0].source, spread,
                             [s["flight"] for s in sessions], float(np.median(rates)) if rates else None,
                             sessions, speed_source, curve, line_ref)


def add_sessions(baseline: Optional[dict], flights: Sequence[Flight]) -> Optional[dict]:
    """A profile's vibration baseline (as stored) with ``flights`` added as sessions of their
    own (``fdlog calibrate --add``: a flight with another payload turns the rotors at another
    speed, and the level is compared at matching speed); the stored one unchanged when the new
    flights measure another metric."""
    new = fit_vibration_baseline(flights)
    if baseline is None or new is None:
        return baseline if new is None else new.to_dict()
    old = VibrationBaseline.from_dict(baseline)
    if old.kind != new.kind or old.source != new.source:
        return baseline
    if not old.sessions:  # an older profile: its level is one session of unknown speed
        old.sessions = [{"level": old.level, "speed": None, "flight": ", ".join(map(str, old.flights))}]
    sessions = old.sessions + new.sessions
    speed_source = old.speed_source if old.speed_source == new.speed_source else ""
    if not speed_source:
        for s in sessions:
            s["speed"] = None
    logs = np.log([s["level"] for s in sessions])
    spread = max(old.spread_log, PROFILE_SPREAD_LOG)
    if len(logs) > 1:
        spd = [s["speed"] for s in sessions]
        resid = logs - SPEED_EXPONENT * np.log(spd) if all(s is not None for s in spd) else logs
        spread = max(PROFILE_SPREAD_LOG, float(np.std(resid, ddof=1)))
    line = old.line
    if new.line and (not line or (new.line.get("source") == line.get("source") and new.line["ms2"] > line["ms2"])):
        line = new.line
    out = VibrationBaseline(float(np.exp(logs.mean())), old.kind, old.source, spread,
                            list(old.flights) + list(new.flights), old.rate_hz, sessions, speed_source,
                            old.curve or new.curve, line)
    return out.to_dict()


def log_reference(parts: Sequence[Flight], index: int) -> Optional[VibrationBaseline]:
    """The quietest of a log's other flights as a one-flight baseline for flight ``index`` (the
    parts of :func:`~flightlog_fd.flights.split_flights`), or None with one flight or no level."""
    best = None
    for j, p in enumerate(parts):
        if j == index:
            continue
        b = fit_vibration_baseline([p])
        if b is not None and (best is None or b.level < best.level):
            best = b
            best.flights = [p.part or f"flight {j + 1}"]
    return best


@dataclass
class VibrationAnalysis:
    level: Optional[Level]
    line: Optional[RotorLine]
    flight_llr: Optional[float]
    ratio: Optional[float]  # level / reference
    against: str  # "profile" / "healthy airframes" / ""
    abstain: Optional[str] = None
    notes: list = field(default_factory=list)
    level_llr: Optional[float] = None
    line_llr: float = 0.0
    speed_ratio: Optional[float] = None  # rotor speed against the profile's sessions
    why_no_line: str = ""


def analyze_vibration(flight: Flight, baseline: Optional[VibrationBaseline] = None,
                      log_reference: Optional[VibrationBaseline] = None) -> VibrationAnalysis:
    """Level, rotor speed, rotor line and their evidence for one flight (module docstring).
    ``log_reference``: without a profile, the quietest other flight of the same log (same
    airframe, same day; :func:`log_reference`): a flight louder than it is also weighed against
    it as against a one-flight profile, and the stronger of the two comparisons counts."""
    level = measure_level(flight)
    iv = _intervals(flight)
    curve = tuple(baseline.curve) if baseline is not None and baseline.curve else None
    if flight.vibration is not None and iv:
        line, why_no_line = find_rotor_line(flight, iv, curve)
    else:
        line, why_no_line = None, "no vibration data in the airborne time"
    if level is None and line is None:
        return VibrationAnalysis(None, None, None, None, "", abstain="no vibration data in the airborne time"
                                 + (f" ({why_no_line})" if why_no_line else ""))
    lvl_llr, ratio, against, speed_ratio = None, None, "", None
    if level is not None and level.kind == "px4_metric" and not (baseline is not None and baseline.measures(level)):
        # PX4's metric has no healthy reference across airframes: without a profile of the same
        # metric, the raw accelerometer's lower bound is weighed against the healthy airframes
        level = raw_level(flight) or level
    if level is not None:
        if baseline is not None and baseline.measures(level):
            speed, src = flight_speed(flight, iv)
            ln_ref, sd, speed_ratio = baseline.expected(speed, src)
            ratio = level.value / float(np.exp(ln_ref))
            lvl_llr = _log_bayes_factor(float(np.log(ratio)), sd)
            against = "profile"
        elif level.kind in ("vibe", "raw"):
            ratio = level.value / HEALTHY_LEVEL_REF
            lvl_llr = min(_log_bayes_factor(float(np.log(ratio)), HEALTHY_SPREAD_LOG), NO_PROFILE_LLR_CAP)
            against = "healthy airframes"
            if log_reference is not None and log_reference.measures(level) and level.value > log_reference.level:
                speed, src = flight_speed(flight, iv)
                ln_ref, sd, sr = log_reference.expected(speed, src)
                r = level.value / float(np.exp(ln_ref))
                own = _log_bayes_factor(float(np.log(r)), sd)
                if own > lvl_llr:
                    lvl_llr, ratio, speed_ratio = own, r, sr
                    against = "log:" + (log_reference.flights[0] if log_reference.flights else "another flight")
        if lvl_llr is not None:
            lvl_llr = max(lvl_llr, LLR_FLOOR)
            if level.kind == "raw":
                lvl_llr = max(lvl_llr, 0.0)  # a lower bound cannot clear
    l_llr = line_llr(line, baseline)
    flight_llr = None
    if lvl_llr is not None or (line is not None and line.follows and line.amplitude is not None):
        # a level near the healthy one does not clear a raised line: the broadband floor hides a
        # line in the level (PX4's metric differences consecutive samples: noise dominates it)
        flight_llr = (lvl_llr or 0.0 if l_llr <= 0.0 else max(lvl_llr or 0.0, 0.0)) + l_llr
    notes = [line_words(line)] if line is not None else []
    return VibrationAnalysis(level, line, flight_llr, ratio, against, notes=notes, level_llr=lvl_llr,
                             line_llr=l_llr, speed_ratio=speed_ratio, why_no_line=why_no_line or "")


def line_words(line: RotorLine) -> str:
    """Plain words for the rotor line and its tie."""
    edge = not line.follows and at_band_edge(line)  # the skirt of motion below the band, no line
    words = ((f"the {line.kind} spectrum's strongest power, at {line.freq_hz:.1f} Hz" if edge else
              f"a line at {line.freq_hz:.1f} Hz in the {line.kind} spectrum") + f" ({line.prominence:.0f}x the band"
             + (f"; {line.amplitude:.1f} m/s/s RMS in the horizontal accelerometer" if line.amplitude else "")
             + ")")
    if line.folded and line.rotor_hz is not None:
        words += f", folded from {line.rotor_hz:.0f} Hz (above the {line.sample_hz / 2:.0f} Hz Nyquist frequency)"
    named = tie_motor(line)
    if named is not None:
        how = "ESC rpm" if line.tie_source == "esc_rpm" else "its commanded speed"
        words += (f" follows the speed of motor {named} ({how}, P {line.tie_probs[named - 1]:.2f}): a "
                  f"once-per-revolution rotor vibration, the signature of an out-of-balance propeller")
    elif line.follows:
        words += f" follows the rotors' speed (a rotor line); no rotor can be named: {line.why_untied}"
    else:
        words += f": {line.why_untied}" if line.why_untied else " that no rotor's speed explains"
    return words


def level_words(a: VibrationAnalysis) -> str:
    """Plain words for the level: "vibration 5.9x this airframe's healthy level (28.9 against 4.9 m/s/s)"."""
    if a.level is None or a.ratio is None:
        return ""
    if a.against.startswith("log:"):
        ref = f"this log's quietest other flight ({a.against[4:].split(',')[0]})"
    else:
        ref = "this airframe's healthy level" if a.against == "profile" else "the healthy airframes' typical level"
    if a.speed_ratio is not None and abs(a.speed_ratio - 1.0) >= 0.02:
        ref += f" at its rotor speed ({100 * (a.speed_ratio - 1):+.0f} %)"
    base = a.level.value / a.ratio
    bound = "at least " if a.level.kind == "raw" else ""
    return (f"vibration {bound}{a.ratio:.2g}x {ref} ({a.level.value:.2g} against {base:.2g} "
            f"{'m/s/s' if a.level.kind != 'px4_metric' else 'PX4 metric'}, {a.level.source})")


@dataclass
class VibrationResult(AnalyzerResult):
    """The vibration analyzer's result (the interface in the module docstring)."""

    flight_llr: Optional[float] = None
    against: str = ""  # "profile" / "healthy airframes" / ""
    ratio: Optional[float] = None
    level_words: str = ""
    line_hz: Optional[float] = None
    line_rotor_hz: Optional[float] = None
    line_motor: Optional[int] = None
    tie_source: str = ""  # "esc_rpm" | "command" | ""
    tie_trusted: bool = False  # line_motor may be named
    tie_probs: list = field(default_factory=list)
    why_untied: str = ""
    level_llr: Optional[float] = None
    line_llr: float = 0.0


#: Context.memo key of a log's quietest other flight's baseline (dict), set by the diagnosis of a
#: log holding several flights (:func:`log_reference`).
LOG_REFERENCE_KEY = "vibration.log_reference"


class Vibration(Analyzer):
    """The registry's vibration analyzer: the flight-level finding (:class:`VibrationResult`) the
    decision weighs, and per motor an LLR when its rotor line names a rotor."""

    id = ANALYZER_ID
    description = "vibration: level against the airframe's healthy level, rotor lines tied to their rotor"
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
        ref = ctx.memo.get(LOG_REFERENCE_KEY)
        a = analyze_vibration(flight, VibrationBaseline.from_dict(b) if b else None,
                              VibrationBaseline.from_dict(ref) if ref else None)
        return result_from(a, ctx.n_motors)


def tie_trusted(line: Optional[RotorLine]) -> bool:
    """True when the line names a rotor (:func:`tie_motor`)."""
    return tie_motor(line) is not None


def result_from(a: VibrationAnalysis, n: int) -> VibrationResult:
    """The :class:`VibrationResult` of one analysis. The per-motor LLR of a named rotor's tie is
    ``flight_llr + log(n·max(p_k, TIE_P_FLOOR))`` (the tie adds at most log n); an unnamed tie is
    shown, not weighed."""
    if a.abstain:
        return VibrationResult(ANALYZER_ID, abstained=a.abstain)
    out = []
    line = a.line
    named = tie_motor(line) if n >= 1 else None
    probs = list(line.tie_probs) if line is not None and len(line.tie_probs) == n else [1.0 / n] * n if n else []
    base_llr = a.flight_llr if a.flight_llr is not None else 0.0
    if a.level is not None:
        out.append(Finding(ANALYZER_ID, 0, "level", a.level.value, "m/s/s" if a.level.kind != "px4_metric" else "",
                           None, None if a.ratio is None else a.level.value / a.ratio, "up", None,
                           level_words(a) or f"{a.level.value:.1f}"))
    if line is not None and line.tie_source and n >= 1:
        for k in range(1, n + 1):
            p = probs[k - 1]
            llr = (base_llr + float(min(np.log(n * max(p, TIE_P_FLOOR)), np.log(n)))) if named else None
            out.append(Finding(ANALYZER_ID, k, "rotor_line", line.freq_hz if k == named else None, "Hz",
                               None, None, "up", llr,
                               f"{line.freq_hz:.0f}Hz {p:.2f}" if k == named else f"{p:.2f}"))
    if line is None:
        why = a.why_no_line or "no rotor line"
    elif named is None:
        why = line.why_untied or "the line's tie is too weak to name a rotor"
    else:
        why = ""
    return VibrationResult(ANALYZER_ID, out, notes=list(a.notes), flight_llr=a.flight_llr, against=a.against,
                           ratio=a.ratio, level_words=level_words(a),
                           line_hz=None if line is None else line.freq_hz,
                           line_rotor_hz=None if line is None else line.rotor_hz,
                           line_motor=named, tie_source="" if line is None else line.tie_source,
                           tie_trusted=named is not None, tie_probs=probs, why_untied=why,
                           level_llr=a.level_llr, line_llr=a.line_llr)


#: Reasons of checks.diagnosability after which vibration alone can still judge the propellers
#: (no per-motor outputs, or no damage model for the frame): the level needs neither.
VIBRATION_ONLY_REASONS = ("no per-motor outputs", "motor outputs", "propeller-damage model", "only stopped-motor")


def vibration_can_judge(reasons: Sequence[str]) -> bool:
    """True when the full diagnosis refused the log for a reason vibration does not depend on."""
    return any(w in r for r in reasons for w in VIBRATION_ONLY_REASONS)


__all__ = ["ANALYZER_ID", "Vibration", "VibrationAnalysis", "VibrationBaseline", "VibrationResult", "analyze_vibration",
           "add_sessions", "fit_vibration_baseline", "log_reference", "LOG_REFERENCE_KEY", "flight_speed", "measure_level", "find_rotor_line", "spectrum",
           "level_words", "line_words", "line_llr", "result_from", "tie_motor", "tie_trusted", "vibration_can_judge",
           "VIBRATION_ONLY_REASONS"]
