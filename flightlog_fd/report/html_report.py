"""HTML report (``fdlog diagnose --html F``): ONE self-contained page, no scripts, no CDN.

Inputs: one or more :class:`~flightlog_fd.diagnose.Diagnosis` (with their ``flight`` for the
plots). For each log the page shows the verdict's headline first (the page's title line for one
log), then as every report does: the status and confidence, the cause line, the evidence clauses,
what to do; then the log's facts (autopilot, firmware, frame, durations, model, profile, warnings)
and three inline SVG plots drawn here:

- angular rates p, q, r in deg/s,
- motor commands 1-n (0..1, autopilot numbering, labelled with their positions),
- class probabilities per window (healthy and each motor, plotted at the window's centre),
- where the log has vibration data: the level over time per IMU with its healthy reference
  dashed, and the airborne gyro spectrum with the rotor rates marked
  (:mod:`flightlog_fd.report.vibration_view`),

all over the same time axis (seconds on the log's clock), with the background shaded by the
verdict's smoothed window labels (green healthy, red damaged, amber uncertain, white no window).
Beside the facts, the per-motor table of :mod:`flightlog_fd.report.motor_view` (a dash's reason is
its tooltip and a note under the table). Several logs get a summary table at the top (each log's
headline). A window table sits in a closed ``<details>``. What confidence means is said once, in
the page's legend at its foot.

Every text that comes from the log or the user (file names, firmware strings, frame sources,
warnings, reasons) is HTML-escaped; nothing is ever inserted raw. Lines are decimated to at most
``MAX_POINTS_PER_LINE`` points (min/max per bucket, so spikes survive) to keep the page small.
"""
from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Optional, Sequence, Union

import numpy as np

from .. import __version__
from ..diagnose import Diagnosis
from ..flight import Series
from ..timeline import UNCERTAIN_LABEL, timeline_labels
from .motor_view import MotorView, class_names
from .panels import missing_line, missing_panels
from .terminal import status_words, verdict_sentence
from .vibration_view import VibrationPlot, vibration_and_gaps, vibration_plot
from .words import cause_line, cause_words, confidence_legend, evidence_clauses

#: Points kept per plotted line: ~2 per horizontal pixel of the plot area.
MAX_POINTS_PER_LINE = 1600
PLOT_WIDTH = 900
PLOT_HEIGHT = 210
MARGIN_LEFT, MARGIN_RIGHT, MARGIN_TOP, MARGIN_BOTTOM = 60, 150, 24, 30
#: Time slots used to shade the plots' background by window label.
SHADING_SLOTS = 400
RAD_TO_DEG = 180.0 / math.pi

#: Line colours (motors 1-12 and the rates p, q, r; distinct enough for a dodecahexa).
LINE_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                "#bcbd22", "#17becf", "#393b79", "#ad494a")
HEALTHY_COLOUR = "#2e7d32"  # the healthy class's probability line
#: Background per smoothed label: healthy, any motor damaged, uncertain.
SHADE_HEALTHY, SHADE_DAMAGED, SHADE_UNCERTAIN = "#e8f5e9", "#ffebee", "#fff8e1"
STATUS_COLOURS = {"healthy": "#2e7d32", "damaged": "#c62828", "stopped": "#c62828", "uncertain": "#ef6c00",
                  "not_diagnosable": "#6a1b9a"}

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:24px;color:#222;max-width:1100px}
h1{font-size:1.4em} h2{font-size:1.15em;margin-top:2em;border-bottom:1px solid #ddd}
.verdict{font-size:1.3em;font-weight:600;padding:10px 14px;border-left:6px solid;background:#fafafa}
table{border-collapse:collapse;font-size:.9em} td,th{border:1px solid #ddd;padding:3px 8px;text-align:left}
th{background:#f5f5f5} .warn{color:#8a5a00} .muted{color:#777;font-size:.85em}
svg{display:block;margin:6px 0 14px 0} svg text{font-size:11px;fill:#333}
.row{display:flex;flex-wrap:wrap;gap:18px;align-items:flex-start} .motors h3{font-size:1em;margin:0 0 4px 0}
.motors{max-width:520px} tr.top td{background:#ffebee;font-weight:600}
.status{margin:2px 0 8px 20px} .cause{margin:4px 0} ul.evidence,ol.advice{margin:2px 0 10px 0}
.advice code{white-space:pre-wrap;word-break:break-all}
"""


def esc(value) -> str:
    """HTML-escape any value's text (quotes too, so it is safe in attributes)."""
    return html.escape("" if value is None else str(value), quote=True)


def nice_ticks(lo: float, hi: float, target: int = 6) -> list[float]:
    """Round tick values covering [lo, hi] (steps of 1, 2 or 5 times a power of ten)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo] if math.isfinite(lo) else []
    raw = (hi - lo) / max(target, 1)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step) * step
    return [round(first + i * step, 10) for i in range(int((hi - first) / step + 1e-9) + 1)]


def decimate(t: np.ndarray, y: np.ndarray, max_points: int = MAX_POINTS_PER_LINE) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_points`` points: each bucket keeps its minimum and maximum, in time order (the
    first of equal ones; NaN ignored; a bucket without a finite value is dropped). All buckets at
    once: one Python loop per bucket was 80 % of a `fdlog serve` job (0.3 s of a 300 s log)."""
    n = t.shape[0]
    if n <= max_points:
        return t, y
    buckets = max_points // 2
    edges = np.linspace(0, n, buckets + 1).astype(int)
    starts = edges[:-1][edges[1:] > edges[:-1]]
    y = np.asarray(y)
    bucket = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, n]))
    nan = np.isnan(y)
    low = np.where(nan, np.inf, y)
    high = np.where(nan, -np.inf, y)
    has_finite = np.logical_or.reduceat(np.isfinite(y), starts)

    def first(hit: np.ndarray) -> np.ndarray:  # each bucket's first index where ``hit``
        idx = np.flatnonzero(hit)
        _, at = np.unique(bucket[idx], return_index=True)
        return idx[at]
    i_min = first(low == np.minimum.reduceat(low, starts)[bucket])
    i_max = first(high == np.maximum.reduceat(high, starts)[bucket])
    keep = has_finite[bucket[i_min]]  # both lists hold one index per bucket, in bucket order
    idx = np.unique(np.concatenate([i_min[keep], i_max[has_finite[bucket[i_max]]]]))
    return t[idx], y[idx]


def _shading_rects(d: Diagnosis, t0: float, t1: float, x_of, y_top: float, height: float) -> list[str]:
    w = d.windows
    if not w:
        return []
    slots = timeline_labels([x.t_start for x in w], [x.t_end for x in w], [x.label for x in w],
                            t0, t1, SHADING_SLOTS)
    names = class_names(len(w[0].probabilities) - 1)
    edges = np.linspace(t0, t1, len(slots) + 1)
    rects, i = [], 0
    while i < len(slots):
        j = i
        while j + 1 < len(slots) and slots[j + 1] == slots[i]:
            j += 1
        label = slots[i]
        if label is not None:
            xa, xb = x_of(edges[i]), x_of(edges[j + 1])
            title = "uncertain" if label == UNCERTAIN_LABEL else names[label]
            fill = SHADE_UNCERTAIN if label == UNCERTAIN_LABEL else SHADE_HEALTHY if label == 0 else SHADE_DAMAGED
            rects.append(f'<rect x="{xa:.1f}" y="{y_top:.1f}" width="{max(xb - xa, 0.5):.1f}" '
                         f'height="{height:.1f}" fill="{fill}"><title>{esc(title)}</title></rect>')
        i = j + 1
    return rects


def svg_plot(title: str, y_label: str, lines: Sequence[tuple[str, np.ndarray, np.ndarray]],
             t0: float, t1: float, diagnosis: Optional[Diagnosis] = None,
             y_range: Optional[tuple[float, float]] = None, colours: Optional[Sequence[str]] = None,
             x_label: str = "s (log clock)", dashed: Sequence[str] = ()) -> str:
    """One plot as an ``<svg>`` element: ``lines`` are (name, x, values) with x in seconds on the
    log's clock unless ``x_label`` says otherwise, drawn in ``colours`` (default
    :data:`LINE_COLOURS`, cycled); lines named in ``dashed`` are dashed (references, marks)."""
    w, h = PLOT_WIDTH, PLOT_HEIGHT
    left, right = MARGIN_LEFT, w - MARGIN_RIGHT
    top, bottom = MARGIN_TOP, h - MARGIN_BOTTOM
    finite = [v[np.isfinite(v)] for _, _, v in lines if v.size]
    finite = [v for v in finite if v.size]
    if y_range is not None:
        ylo, yhi = y_range
    elif finite:
        ylo, yhi = float(min(v.min() for v in finite)), float(max(v.max() for v in finite))
    else:
        ylo, yhi = 0.0, 1.0
    if yhi - ylo < 1e-9:
        ylo, yhi = ylo - 1.0, yhi + 1.0
    if t1 <= t0:
        t1 = t0 + 1.0

    def x_of(t):
        return left + (t - t0) / (t1 - t0) * (right - left)

    def y_of(v):
        return bottom - (v - ylo) / (yhi - ylo) * (bottom - top)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" '
             f'role="img" aria-label="{esc(title)}">', f"<title>{esc(title)}</title>"]
    if diagnosis is not None:
        parts += _shading_rects(diagnosis, t0, t1, x_of, top, bottom - top)
    parts.append(f'<rect x="{left}" y="{top}" width="{right - left}" height="{bottom - top}" '
                 f'fill="none" stroke="#999"/>')
    for tv in nice_ticks(t0, t1, 10):
        x = x_of(tv)
        parts.append(f'<line x1="{x:.1f}" y1="{bottom}" x2="{x:.1f}" y2="{bottom + 4}" stroke="#999"/>')
        parts.append(f'<text x="{x:.1f}" y="{bottom + 16}" text-anchor="middle">{tv:g}</text>')
    for yv in nice_ticks(ylo, yhi, 5):
        y = y_of(yv)
        parts.append(f'<line x1="{left}" y1="{y:.1f}" x2="{right}" y2="{y:.1f}" stroke="#eee"/>')
        parts.append(f'<text x="{left - 5}" y="{y + 4:.1f}" text-anchor="end">{yv:g}</text>')
    parts.append(f'<text x="12" y="{(top + bottom) / 2:.0f}" text-anchor="middle" '
                 f'transform="rotate(-90 12 {(top + bottom) / 2:.0f})">{esc(y_label)}</text>')
    parts.append(f'<text x="{left}" y="{top - 8}" font-weight="bold">{esc(title)}</text>')
    parts.append(f'<text x="{right + 18}" y="{bottom + 16}">{esc(x_label)}</text>')
    for i, (name, t, v) in enumerate(lines):
        palette = colours or LINE_COLOURS
        colour = palette[i % len(palette)]
        m = (t >= t0) & (t <= t1) & np.isfinite(v)
        td, vd = decimate(t[m], v[m])
        if td.size:
            pts = " ".join(f"{x_of(a):.1f},{y_of(b):.1f}" for a, b in zip(td, vd))
            dash = ' stroke-dasharray="5,3"' if name in dashed else ""
            parts.append(f'<polyline fill="none" stroke="{colour}" stroke-width="1.2"{dash} points="{pts}">'
                         f"<title>{esc(name)}</title></polyline>")
        parts.append(f'<line x1="{right + 10}" y1="{top + 10 + 16 * i}" x2="{right + 28}" '
                     f'y2="{top + 10 + 16 * i}" stroke="{colour}" stroke-width="3"/>')
        parts.append(f'<text x="{right + 32}" y="{top + 14 + 16 * i}">{esc(name)}</text>')
    parts.append("</svg>")
    return "".join(parts)


def _series_lines(series: Optional[Series], names: Sequence[str], scale: float = 1.0):
    if series is None or len(series) == 0:
        return []
    return [(names[k] if k < len(names) else f"{k + 1}", series.t, series.values[:, k] * scale)
            for k in range(series.values.shape[1])]


def _time_span(d: Diagnosis) -> tuple[float, float]:
    if d.facts is not None and d.facts.t_end > d.facts.t_start:
        return d.facts.t_start, d.facts.t_end
    if d.windows:
        return min(w.t_start for w in d.windows), max(w.t_end for w in d.windows)
    return 0.0, 1.0


def _facts_table(d: Diagnosis) -> str:
    rows: list[tuple[str, str]] = [("log", d.log)]
    f = d.facts
    if f is not None:
        rows += [("autopilot", f.autopilot), ("firmware", f.firmware or "-"), ("vehicle", f.vehicle_type),
                 ("frame", f"{f.frame or '-'}" + (f" ({f.frame_source})" if f.frame_source else "")),
                 ("log duration", f"{f.duration_s:.1f} s (t={f.t_start:.1f} to {f.t_end:.1f} s)"),
                 ("airborne", f"{f.airborne_s:.1f} s in {len(f.airborne)} segment(s)")]
    if d.model is not None:
        m = d.model
        rows += [("model", f"{m.path or '-'} version {m.version or '-'}"),
                 ("model sha256", m.sha256 or "-"),
                 ("calibrated", "yes (profile's own model)" if m.calibrated else "no")]
    rows.append(("profile", "none" if d.profile is None else
                 f"{d.profile.path or 'in memory'} ({d.profile.sessions} calibration session"
                 f"{'s' if d.profile.sessions != 1 else ''})"))
    words = d.share_fit.configuration_words() if d.profile is not None and d.share_fit is not None else None
    if words:
        rows.append(("configuration", words))
    if d.timeline is not None and d.timeline.shortfall is None:
        ev = d.timeline
        names = class_names(len(ev.smoothed_share) - 1)
        share = ", ".join(f"{names[k]} {100 * s:.0f} %" for k, s in enumerate(ev.smoothed_share))
        rows.append(("windows", f"{ev.n_windows} covering {ev.covered_s:.1f} s; votes: {share}; "
                                f"abstained {100 * ev.abstained_share:.0f} %"))
    rows.append(("exit code", str(d.exit_code)))
    body = "".join(f"<tr><th>{esc(k)}</th><td>{esc(val)}</td></tr>" for k, val in rows)
    return f"<table class=\"facts\">{body}</table>"


def verdict_block(d: Diagnosis) -> str:
    """What follows the headline, in every report's order: the status and confidence, the cause
    line, the evidence clauses (each once) and what to do (a command in ``<code>``)."""
    v = d.verdict
    out = [f'<p class="status muted">{esc(status_words(d))} | {esc(d.log)}</p>']
    cause = cause_line(v)
    if cause:
        out.append(f'<p class="cause">{esc(cause)}</p>')
    clauses = evidence_clauses(v)
    if clauses:
        out.append('<p class="cause"><b>Evidence</b></p><ul class="evidence">'
                   + "".join(f"<li>{esc(c)}</li>" for c in clauses) + "</ul>")
    if v.advice:
        out.append('<p class="cause"><b>To do</b></p><ol class="advice">' + "".join(
            f'<li class="advice-{esc(a.kind)}">{esc(a.text)}'
            + (f": <code>{esc(a.command)}</code>" if a.command else "") + "</li>" for a in v.advice) + "</ol>")
    return "".join(out)


def _window_table(d: Diagnosis) -> str:
    n = len(d.windows[0].probabilities) - 1 if d.windows else 0
    names = class_names(n)
    head = "".join(f"<th>{esc(c)}</th>" for c in ("t_start s", "t_end s", "class", "p healthy",
                                                    *(f"p m{k}" for k in range(1, n + 1)), "phase", "verdict label"))
    rows = []
    for w in d.windows:
        label = "uncertain" if w.label == UNCERTAIN_LABEL else names[w.label]
        cells = [f"{w.t_start:.2f}", f"{w.t_end:.2f}", names[w.cls],
                 *(f"{p:.3f}" for p in w.probabilities), w.phase, label]
        rows.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in cells) + "</tr>")
    return (f"<details><summary>{len(d.windows)} windows</summary>"
            f"<table><tr>{head}</tr>{''.join(rows)}</table></details>")


def motor_table_html(view: MotorView, table_id: str = "") -> str:
    """The per-motor table as HTML (the web flight page draws the same): the verdict's motor is
    highlighted; a dash's reason is its tooltip."""
    header, rows = view.table()
    if not rows:
        return ""
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = []
    for r in rows:
        top = view.highlighted(r[0].text)
        tds = "".join(f'<td title="{esc(c.reason)}">{esc(c.text)}</td>' if c.reason else f"<td>{esc(c.text)}</td>"
                      for c in r)
        body.append(("<tr class=\"top\">" if top else "<tr>") + tds + "</tr>")
    ident = f' id="{esc(table_id)}"' if table_id else ""
    return f'<table class="motor-panel"{ident}><tr>{head}</tr>{"".join(body)}</table>'


def motor_panel(d: Diagnosis) -> str:
    """The per-motor findings panel (the terminal's table), beside the timeline."""
    view = MotorView.of(d)
    table = motor_table_html(view)
    if not table:
        return ""
    legend = "; ".join(f"{esc(label)}: {esc(text)}" for label, text in view.legend())
    sources = ", ".join(view.sources)
    notes = "".join(f'<p class="muted">{esc(n)}</p>' for n in view.notes_beside(evidence_clauses(d.verdict)))
    return (f'<div class="motors"><h3>Per-motor evidence</h3>{table}'
            f'<p class="muted">Commands against {esc(view.against)}. {legend}. The weight comes from '
            f'{esc(sources)}; the shaded windows are the model\'s alone.</p>{notes}</div>')


def headline_html(d: Diagnosis, tag: str = "h2") -> str:
    """The verdict's headline as the page's (``h1``, one log) or its section's (``h2``) first line."""
    colour = STATUS_COLOURS.get(d.verdict.status, "#333")
    return f'<{tag} class="verdict" style="border-color:{colour};color:{colour}">{esc(verdict_sentence(d))}</{tag}>'


def log_section(d: Diagnosis, headline: bool = True) -> str:
    """The headline (``headline``; the page's title line says it for a page of one log), the verdict
    block, facts, plots and window table of one log."""
    v = d.verdict
    out = ["<section>", headline_html(d) if headline else "", verdict_block(d)]
    if d.warnings:
        out.append("<ul>" + "".join(f'<li class="warn">{esc(w)}</li>' for w in d.warnings) + "</ul>")
    out.append(f'<div class="row">{_facts_table(d)}{motor_panel(d)}</div>')
    t0, t1 = _time_span(d)
    fl = d.flight
    vp, gaps = vibration_and_gaps(fl, d) if fl is not None else (None, [])
    missing = missing_line(missing_panels(d, gaps))
    if missing:
        out.append(f'<p class="muted missing">{esc(missing)}</p>')
    if fl is not None:
        if fl.rates is not None:
            out.append(svg_plot("Angular rates", "deg/s", _series_lines(fl.rates, ("p (roll)", "q (pitch)", "r (yaw)"),
                                                                       RAD_TO_DEG), t0, t1, d))
        if fl.motors is not None:
            names = [f"{k + 1} {fl.frame.position(k + 1)}" if fl.frame and k < fl.frame.rotor_count
                     else f"motor {k + 1}" for k in range(fl.motors.values.shape[1])]
            out.append(svg_plot(f"Motor commands ({fl.motor_kind})", "command 0..1",
                                _series_lines(fl.motors, names), t0, t1, d, y_range=(0.0, 1.0)))
    if vp is not None:
        out.append(vibration_svgs(d, vp))
    if d.windows:
        centres = np.array([(w.t_start + w.t_end) / 2 for w in d.windows])
        probs = np.array([w.probabilities for w in d.windows])
        names = class_names(probs.shape[1] - 1)
        lines = [(names[k], centres, probs[:, k]) for k in range(probs.shape[1])]
        out.append(svg_plot("Class probabilities per window", "probability", lines, t0, t1, d, y_range=(0.0, 1.0),
                            colours=(HEALTHY_COLOUR,) + LINE_COLOURS))
        out.append(f'<p class="muted">Background: green healthy, red {esc(cause_words(v.cause).lost)}, amber '
                   "uncertain (the verdict's smoothed window labels); white: no window (on the ground or not "
                   "used).</p>")
        out.append(_window_table(d))
    out.append("</section>")
    return "".join(out)


def vibration_svgs(d: Diagnosis, vp: Optional[VibrationPlot] = None) -> str:
    """Vibration over time per IMU with its healthy reference (dashed), and the gyro spectrum with
    the rotor rates marked (:mod:`flightlog_fd.report.vibration_view`; ``vp`` when already made);
    "" without vibration data to draw."""
    vp = vp if vp is not None else vibration_plot(d.flight, d)
    if vp is None:
        return ""
    out = ['<h3>Vibration</h3>']
    t0, t1 = _time_span(d)
    if vp.series:
        lines = list(vp.series)
        dashed = []
        if vp.reference is not None:
            name = "healthy reference"
            lines.append((name, np.array([t0, t1]), np.array([vp.reference, vp.reference])))
            dashed.append(name)
        top = max((float(np.nanmax(y)) for _, _, y in lines if np.isfinite(y).any()), default=1.0)
        out.append(svg_plot(f"Vibration level per IMU ({vp.unit})", vp.unit, lines, t0, t1, d,
                            y_range=(0.0, max(top * 1.05, 1e-6)), dashed=dashed))
        ref = (f"; dashed: {vp.reference_label} ({vp.reference:.3g} {vp.unit})" if vp.reference is not None
               else "; no healthy reference in this unit")
        out.append(f'<p class="muted">{esc(vp.source)}{esc(ref)}.</p>')
    if vp.freq_hz is not None:
        f, db = vp.freq_hz, vp.power_db
        lo, hi = float(np.min(db)), float(np.max(db))
        lines = [("gyro", f, db)]
        names = []
        for i, (hz, label) in enumerate(vp.marks):
            short = label.split(":")[0].split(" (")[0] if label.startswith("line") else label.split(" rotor")[0]
            lines.append((short, np.array([hz, hz]), np.array([lo, hi])))
            names.append(short)
        out.append(svg_plot("Gyro spectrum (airborne)", "dB above band median", lines, float(f[0]), float(f[-1]),
                            y_range=(lo, hi), x_label="Hz", dashed=names))
        marks = "; ".join(f"{hz:.1f} Hz: {label}" for hz, label in vp.marks) or "no rotor rate known"
        out.append(f'<p class="muted">{esc(vp.spectrum_source)}. Dashed: {esc(marks)}.</p>')
    return "".join(out)


def _summary(diagnoses: Sequence[Diagnosis]) -> str:
    head = "".join(f"<th>{c}</th>" for c in ("log", "verdict", "status", "confidence", "exit"))
    rows = []
    for d in diagnoses:
        v = d.verdict
        cells = [d.log, verdict_sentence(d), v.status, f"{v.confidence:.2f}" if v.status != "not_diagnosable" else "",
                 str(d.exit_code)]
        rows.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in cells) + "</tr>")
    return f"<h2>Summary</h2><table><tr>{head}</tr>{''.join(rows)}</table>"


def render_html(diagnoses: Union[Diagnosis, Sequence[Diagnosis]]) -> str:
    """The complete page for one or more diagnoses."""
    if isinstance(diagnoses, Diagnosis):
        diagnoses = [diagnoses]
    one = len(diagnoses) == 1
    title = ("fdlog diagnosis: " + diagnoses[0].log) if one else f"fdlog diagnosis: {len(diagnoses)} logs"
    # one log: its headline is the page's first line; several: the summary of their headlines
    body = [headline_html(diagnoses[0], "h1")] if one else [f"<h1>{esc(title)}</h1>", _summary(diagnoses)]
    body += [log_section(d, headline=not one) for d in diagnoses]
    body.append(f'<p class="muted legend">{esc(confidence_legend().capitalize())}.</p>')
    body.append(f'<p class="muted">flightlog-fd {esc(__version__)}. Motor numbering is the autopilot\'s own; '
                "times are seconds on the log's clock.</p>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{esc(title)}</title><style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")


def write_html(diagnoses: Union[Diagnosis, Sequence[Diagnosis]], path: Union[str, Path]) -> None:
    """Write the page to ``path`` (UTF-8)."""
    Path(path).write_text(render_html(diagnoses), encoding="utf-8")
