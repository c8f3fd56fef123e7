"""Vibration for people to look at: the level over time per IMU with its healthy reference, and the
airborne gyro spectrum with the rotor rates marked. The HTML report draws it as SVG, the web
flight page with plotly (from :meth:`VibrationPlot.to_json`, kept in the store's ``plot_json``).

Inputs: a :class:`~flightlog_fd.flight.Flight` (its ``vibration``) and optionally its
:class:`~flightlog_fd.diagnose.Diagnosis` (the vibration analyzer's level finding gives the
reference: the profile's healthy level, or the healthy airframes' typical level without one).

- **Over time**: ArduPilot VIBE per IMU as the horizontal ``sqrt(X² + Y²)`` (m/s/s, what the
  analyzer's level takes the median of); PX4 ``vehicle_imu_status`` accel vibration metric per
  IMU; else the raw accelerometer's horizontal RMS above the analyzer's ``FLOOR_HZ`` in
  ``SERIES_WINDOW_S`` blocks (a lower bound, as the analyzer says).
- **Spectrum**: the fastest continuous gyro at ``MIN_SPECTRUM_HZ`` or more (slower logs get none:
  rotor lines are above its Nyquist), Welch over the airborne time (the analyzer's own
  :func:`~flightlog_fd.analyzers.vibration.spectrum`), power in dB above its band median. Marks:
  each rotor's median rate from ESC rpm (once per revolution) where logged; otherwise the line the
  analyzer found with the rotor whose commanded speed it follows (commands give no absolute rate).

Limits: nothing here judges; the figures are the analyzer's own measurements redrawn.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from ..analyzers.vibration import FLOOR_HZ, LINE_MIN_HZ, MIN_SPECTRUM_HZ, VibrationResult, _intervals, spectrum

#: Block length (s) of the raw accelerometer RMS drawn over time (VIBE itself is ~10 Hz).
SERIES_WINDOW_S = 1.0


@dataclass
class VibrationPlot:
    """What the two vibration plots draw (module docstring); times on the log's clock."""

    series: list = field(default_factory=list)  # (name, t s, level)
    unit: str = "m/s/s"
    source: str = ""
    reference: Optional[float] = None
    reference_label: str = ""
    freq_hz: Optional[np.ndarray] = None
    power_db: Optional[np.ndarray] = None
    spectrum_source: str = ""
    marks: list = field(default_factory=list)  # (Hz, label)

    def to_json(self, line) -> dict:
        """JSON-ready, each line through ``line(name, t, y)`` (the caller's decimation)."""
        out: dict[str, Any] = {"series": [line(n, t, y) for n, t, y in self.series], "unit": self.unit,
                               "source": self.source, "reference": self.reference,
                               "reference_label": self.reference_label, "spectrum": None}
        if self.freq_hz is not None:
            out["spectrum"] = {"f": [round(float(x), 2) for x in self.freq_hz],
                               "db": [round(float(x), 2) for x in self.power_db],
                               "source": self.spectrum_source,
                               "marks": [{"hz": round(float(h), 2), "label": lab} for h, lab in self.marks]}
        return out


def _raw_series(s, name: str) -> Optional[tuple[str, np.ndarray, np.ndarray]]:
    """Horizontal RMS above FLOOR_HZ in SERIES_WINDOW_S blocks of a raw accelerometer Series; a
    block touching a missing (non-finite) sample is dropped, not the rest of the series after it
    (a running sum carries a NaN forward: one lost sample blanked the whole panel)."""
    fs = s.rate_hz
    k = max(int(round(fs / FLOOR_HZ)), 1)
    n_blk = max(int(round(fs * SERIES_WINDOW_S)), 1)
    x = s.values[:, :2]
    if x.shape[0] <= 2 * k + n_blk:
        return None
    good = np.isfinite(x).all(axis=1)
    c = np.cumsum(np.vstack([np.zeros((1, 2)), np.where(good[:, None], x, 0.0)]), axis=0)
    n_good = np.cumsum(np.r_[0, good.astype(np.int64)])
    floor = (c[k:] - c[:-k]) / k
    floor[(n_good[k:] - n_good[:-k]) < k] = np.nan  # a floor over a missing sample is unknown
    d = x[k // 2: k // 2 + floor.shape[0]] - floor
    t = s.t[k // 2: k // 2 + floor.shape[0]]
    m = (d.shape[0] // n_blk) * n_blk
    sq = (d[:m] ** 2).sum(axis=1).reshape(-1, n_blk)
    tb = t[:m].reshape(-1, n_blk)
    # a block spanning a gap in the samples (e.g. two flights), or a missing sample, is dropped
    ok = ((tb[:, -1] - tb[:, 0]) <= 1.5 * SERIES_WINDOW_S) & np.isfinite(sq).all(axis=1)
    return name, tb[ok].mean(axis=1), np.sqrt(sq[ok].mean(axis=1))


def _reference(diagnosis: Any) -> tuple[Optional[float], str, str]:
    """(reference level, its words, its unit) from the vibration analyzer's level finding."""
    subs = [diagnosis] + list(getattr(diagnosis, "flights", None) or []) if diagnosis is not None else []
    for d in subs:
        dec = getattr(d, "decision", None)
        for r in (dec.results if dec is not None else []):
            if not isinstance(r, VibrationResult) or r.abstained:
                continue
            f = r.finding("level", 0) if hasattr(r, "finding") else None
            if f is None or f.baseline is None:
                continue
            words = ("this airframe's healthy level (profile)" if r.against == "profile"
                     else "healthy airframes' typical level")
            return float(f.baseline), words, f.unit or ""
    return None, "", ""


def _marks(flight, result: Optional[VibrationResult]) -> list[tuple[float, str]]:
    esc = flight.esc
    n = flight.frame.rotor_count if flight.frame is not None else 0
    iv = _intervals(flight)
    marks = []
    if esc is not None and n:
        for k in range(1, n + 1):
            c = esc.channel(k)
            if c is None:
                continue
            air = np.zeros(len(c.t), dtype=bool)
            for a, b in iv:
                air |= (c.t >= a) & (c.t <= b)
            ok = c.fresh() & (air if iv else True)
            if ok.any():
                marks.append((float(np.median(c.rpm[ok])) / 60.0, f"motor {k} rotor rate (ESC rpm)"))
    if not marks and result is not None and result.line_hz is not None:
        if result.line_motor is not None:
            how = "ESC rpm" if result.tie_source == "esc_rpm" else "commanded speed"
            marks.append((result.line_hz, f"line {result.line_hz:.1f} Hz: follows motor {result.line_motor} "
                                          f"({how})"))
        else:
            marks.append((result.line_hz, f"line {result.line_hz:.1f} Hz (no rotor tied)"))
    return marks


def vibration_plot(flight, diagnosis: Any = None) -> Optional[VibrationPlot]:
    """The plots' data for one flight (module docstring); None when it logs no vibration or
    nothing of it can be drawn (:func:`vibration_and_gaps` says why)."""
    return vibration_and_gaps(flight, diagnosis)[0]


def vibration_and_gaps(flight, diagnosis: Any = None) -> tuple[Optional[VibrationPlot], list[str]]:
    """(the plots' data or None, what of them is not drawn and why): "vibration level (the
    accelerometer's horizontal axes hold no samples)", "gyro spectrum (gyro logged at 100 Hz; rotor
    lines need 100 Hz or more)". Every drawn line has a finite value."""
    v = getattr(flight, "vibration", None) if flight is not None else None
    if v is None:
        return None, ["vibration (no VIBE, vehicle_imu_status or raw IMU in this log)"]
    out = VibrationPlot()
    why_level = ""
    if v.metrics:
        vibe = v.metric_kind == "ardupilot_vibe"
        for inst, s in sorted(v.metrics.items()):
            x = s.values
            if x.shape[0] < 3 or not np.isfinite(x[:, 0]).any() or np.nanmax(np.abs(x[:, :2])) <= 0:
                continue  # a board that never computes it logs zeros
            y = np.hypot(x[:, 0], x[:, 1]) if vibe else x[:, 0]
            if np.isfinite(y).any():
                out.series.append((f"IMU {inst}", s.t, y))
        out.unit = "m/s/s" if vibe else "PX4 metric"
        out.source = "VIBE, horizontal sqrt(X² + Y²)" if vibe else "vehicle_imu_status.accel_vibration_metric"
        if not out.series:
            why_level = "the logged vibration metric is zero or empty throughout"
    if not out.series:
        raw = [s for s in v.imus if s.accel is not None and not s.batch and len(s.accel) > 2]
        for s in raw:
            line = _raw_series(s.accel, f"IMU {s.instance}")
            if line is not None and np.isfinite(line[2]).any():
                out.series.append(line)
        if not raw:
            why_level = why_level or "no vibration metric and no continuous raw accelerometer"
        elif not out.series:
            empty = all(not np.isfinite(s.accel.values[:, :2]).any() for s in raw)
            why_level = ("the accelerometer's horizontal axes hold no samples" if empty
                         else "too few consecutive accelerometer samples")
        out.unit = "m/s/s"
        out.source = (f"raw accelerometer, horizontal RMS above {FLOOR_HZ:.0f} Hz per {SERIES_WINDOW_S:.0f} s "
                      f"(a lower bound)")
    ref, words, unit = _reference(diagnosis)
    if ref is not None and unit == ("" if out.unit == "PX4 metric" else out.unit):
        out.reference, out.reference_label = ref, words
    g = v.fastest("gyro", batch=False)
    iv = _intervals(flight)
    why_spectrum = ("no continuous raw gyro" if g is None else
                    f"gyro logged at {g.gyro.rate_hz:.0f} Hz; rotor lines need {MIN_SPECTRUM_HZ:.0f} Hz or more"
                    if g.gyro.rate_hz < MIN_SPECTRUM_HZ else "" if iv else "no airborne stretch long enough for a spectrum")
    if not why_spectrum:
        f, p = spectrum(g.gyro, iv)
        band = (f >= LINE_MIN_HZ) & (f <= 0.95 * g.gyro.rate_hz / 2) & (p > 0)
        why_spectrum = "" if band.sum() >= 10 else "too little airborne gyro for a spectrum"
        if not why_spectrum:
            ref_p = float(np.median(p[band]))
            keep = (f > 0) & (p > 0) & np.isfinite(p)
            out.freq_hz, out.power_db = f[keep], 10.0 * np.log10(p[keep] / ref_p)
            out.spectrum_source = f"{g.gyro.source} at {g.gyro.rate_hz:.0f} Hz, horizontal, airborne"
            results = [r for d in ([diagnosis] + list(getattr(diagnosis, "flights", None) or [])
                                   if diagnosis is not None else [])
                       for r in (d.decision.results if getattr(d, "decision", None) is not None else [])
                       if isinstance(r, VibrationResult) and not r.abstained]
            out.marks = [(h, lab) for h, lab in _marks(flight, results[0] if results else None)
                         if 0 < h < g.gyro.rate_hz / 2]
    gaps = ([f"vibration level ({why_level})"] if not out.series else []) + \
        ([f"gyro spectrum ({why_spectrum})"] if out.freq_hz is None else [])
    if not out.series and out.freq_hz is None:
        return None, [f"vibration ({why_level}; {why_spectrum})"]
    return out, gaps


__all__ = ["VibrationPlot", "vibration_plot", "vibration_and_gaps", "SERIES_WINDOW_S"]
