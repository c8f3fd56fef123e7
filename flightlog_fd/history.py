"""Per-airframe history for `fdlog history`: flights in time order, drift flags, HTML and text.
A log holding several take-offs to landings shows each under its row with its own verdict
(``parts``, the store's ``flight_part``).

Reads what :meth:`flightlog_fd.store.Store.history` returns; the drift rule is
:mod:`flightlog_fd.drift`. The per-motor cell and the trend plots are those of the web airframe
page (:func:`~flightlog_fd.report.motor_view.summary_cell`, :data:`~flightlog_fd.store.TREND_FIGURES`), under the
JSON report's names. ``unknown`` (logs with no identity, no profile) is not one airframe.
"""
from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Iterable, Optional

from .drift import DRIFT_SLOPE_MIN, DRIFT_Z_MIN, FIGURE_FLOORS, MIN_FLIGHTS, FlightRecord, find_drift, verdict_words
from .report.motor_view import summary_cell, summary_header
from .report.words import cause_words
from .store import TREND_FIGURES, UNKNOWN_VEHICLE

def history_summary(history: dict[str, list[FlightRecord]]) -> dict:
    """JSON-ready: per vehicle its flights, drifts and whether its latest flight is damaged, or
    uncertain naming propellers to inspect (``latest_inspect``: exit 1 as ``fdlog diagnose`` gives it).

    ``unknown`` (logs with no identity, no profile) is not one airframe: no drift there, and any
    damaged flight in it counts as a latest flight."""
    vehicles = []
    for vehicle, flights in history.items():
        drifts = find_drift(vehicle, flights) if vehicle != UNKNOWN_VEHICLE else []
        latest = flights[-1] if flights else None
        if vehicle == UNKNOWN_VEHICLE:
            latest = next((f for f in reversed(flights) if f.status == "damaged"), latest)
        vehicles.append({
            "vehicle": vehicle,
            "vehicle_source": latest.vehicle_source if latest else None,
            "flights": [{"log": f.log_path, "log_sha256": f.log_sha256, "flight_start_utc": f.flight_start_utc,
                         "airborne_s": f.airborne_s, "status": f.status, "motor": f.motor, "cause": f.cause,
                         "verdict_motors": list(f.verdict_motors), "pair": bool(f.pair),
                         "confidence": f.confidence, "reason": f.reason, "diagnosed_at": f.diagnosed_at,
                         "motors": [{"motor": k, **f.motors[k]} for k in sorted(f.motors)],
                         "parts": [dict(p) for p in f.parts]} for f in flights],
            "drift": [{"motor": d.motor, "figure": d.figure, "slope_z_per_flight": d.slope,
                       "latest_z": d.latest_z, "n_flights": d.n_flights, "text": d.describe()} for d in drifts],
            "latest_damaged": bool(latest and latest.status == "damaged"),
            "latest_inspect": bool(latest and latest.status == "uncertain" and (latest.motor or latest.verdict_motors)),
            "latest": None if latest is None else {"log": latest.log_path, "motor": latest.motor,
                                                   "motors": _named_motors(latest), "cause": latest.cause},
        })
    flagged = any(v["drift"] or v["latest_damaged"] or v["latest_inspect"] for v in vehicles)
    return {"schema": 1, "rule": {"min_flights": MIN_FLIGHTS, "drift_slope_min": DRIFT_SLOPE_MIN,
                                  "drift_z_min": DRIFT_Z_MIN, "floors": FIGURE_FLOORS},
            "vehicles": vehicles, "flagged": flagged}


def _named_motors(f: FlightRecord) -> list[int]:
    """The motors a flight's verdict names: both of a pair (or every propeller an uncertain verdict
    names), else its motor."""
    several = (f.pair or f.status == "uncertain") and len(f.verdict_motors) > 1
    return list(f.verdict_motors) if several else ([f.motor] if f.motor else list(f.verdict_motors))


def _inspect_words(latest: dict) -> str:
    """"uncertain: inspect propeller 2" / "uncertain: inspect propellers 1 and 2" for the
    latest-flight flag of an uncertain verdict."""
    motors = latest.get("motors") or ([latest["motor"]] if latest.get("motor") else [])
    named = (f"propellers {', '.join(map(str, motors[:-1]))} and {motors[-1]}" if len(motors) > 1
             else f"propeller {motors[0]}" if motors else "the propellers")
    return f"uncertain: inspect {named}"


def _latest_words(latest: dict) -> str:
    """"propeller 3 damaged" / "rotors 1 and 4 lost thrust" / "motor 2 or its ESC weak" / "rotor 3
    lost thrust (propeller, motor or ESC, or something in its wash)" (no cause known) for the
    latest-flight flag: a propeller only where the verdict's cause says so."""
    motors = latest.get("motors") or ([latest["motor"]] if latest.get("motor") else [])
    if len(motors) > 1:
        return f"rotors {', '.join(map(str, motors[:-1]))} and {motors[-1]} lost thrust"
    motor = motors[0] if motors else latest.get("motor")
    return cause_words(latest.get("cause")).named(motor)


# ----------------------------------------------------------------------------- html

MOTOR_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def _motor_numbers(flights: list[dict]) -> list[int]:
    """Every motor number the flights carry figures for (1..4 when none)."""
    return sorted({m["motor"] for f in flights for m in f["motors"]}) or [1, 2, 3, 4]


def _svg_trend(flights: list[dict], figure: str, width: int = 560, height: int = 180) -> str:
    """Inline SVG: each motor's ``figure`` over the flights (x = flight index)."""
    pts = {k: [] for k in _motor_numbers(flights)}
    for i, f in enumerate(flights):
        for m in f["motors"]:
            v = m.get(figure)
            if v is not None:
                pts[m["motor"]].append((i, float(v)))
    vals = [v for p in pts.values() for _, v in p]
    if not vals:
        return ""
    lo, hi = min(vals), max(vals)
    if hi - lo < 1e-9:
        lo, hi = lo - 0.5 * max(abs(lo), 1e-3), hi + 0.5 * max(abs(hi), 1e-3)
    pad_l, pad_r, pad_t, pad_b = 50, 90, 10, 28
    n = max(len(flights) - 1, 1)

    def xy(i: int, v: float) -> tuple[float, float]:
        x = pad_l + (width - pad_l - pad_r) * i / n
        y = pad_t + (height - pad_t - pad_b) * (1 - (v - lo) / (hi - lo))
        return x, y

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" role="img" '
             f'aria-label="{html.escape(figure)} per motor over flights">',
             f'<rect x="{pad_l}" y="{pad_t}" width="{width - pad_l - pad_r}" height="{height - pad_t - pad_b}" '
             f'fill="none" stroke="#bbb"/>',
             f'<text x="4" y="{pad_t + 10}" font-size="10">{hi:.3g}</text>',
             f'<text x="4" y="{height - pad_b}" font-size="10">{lo:.3g}</text>',
             f'<text x="{pad_l}" y="{height - 8}" font-size="10">flight 1</text>',
             f'<text x="{width - pad_r - 40}" y="{height - 8}" font-size="10">flight {len(flights)}</text>']
    for k, p in pts.items():
        if not p:
            continue
        c = MOTOR_COLOURS[(k - 1) % len(MOTOR_COLOURS)]
        coords = " ".join(f"{x:.1f},{y:.1f}" for x, y in (xy(i, v) for i, v in p))
        parts.append(f'<polyline points="{coords}" fill="none" stroke="{c}" stroke-width="1.5"/>')
        for i, v in p:
            x, y = xy(i, v)
            parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.5" fill="{c}"><title>motor {k}, flight {i + 1}: '
                         f'{v:.4g}</title></circle>')
        parts.append(f'<text x="{width - pad_r + 8}" y="{pad_t + 14 * k}" font-size="11" fill="{c}">motor {k}</text>')
    parts.append("</svg>")
    return "".join(parts)


def render_html(summary: dict) -> str:
    """A small self-contained page: per airframe its flights, flags and trend plots (inline SVG)."""
    e = html.escape
    out = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>fdlog fleet history</title>",
           "<style>body{font-family:sans-serif;margin:2em;max-width:1000px}table{border-collapse:collapse}"
           "td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}.flag{color:#b00;font-weight:bold}</style>",
           "</head><body><h1>fdlog fleet history</h1>",
           f"<p>Drift rule: at least {MIN_FLIGHTS} flights; robust z of a motor's figure against the others, "
           f"least-squares slope &ge; {DRIFT_SLOPE_MIN} z per flight in the damage direction and latest z "
           f"&ge; {DRIFT_Z_MIN}.</p>"]
    for v in summary["vehicles"]:
        out.append(f"<h2>{e(v['vehicle'])} <small>({e(str(v['vehicle_source']))}, {len(v['flights'])} flights)</small></h2>")
        for d in v["drift"]:
            out.append(f"<p class='flag'>{e(d['text'])}</p>")
        if v["latest_damaged"]:
            f = v["latest"]
            out.append(f"<p class='flag'>latest flight: {e(_latest_words(f))} ({e(f['log'])})</p>")
        elif v.get("latest_inspect"):
            f = v["latest"]
            out.append(f"<p class='flag'>latest flight: {e(_inspect_words(f))} ({e(f['log'])})</p>")
        out.append("<table><tr><th>#</th><th>start (UTC)</th><th>log</th><th>verdict</th><th>confidence</th>"
                   + "".join(f"<th>{html.escape(summary_header(k))}</th>" for k in _motor_numbers(v["flights"])) + "</tr>")
        for i, f in enumerate(v["flights"], 1):
            verdict = verdict_words(f["status"], f["motor"], f.get("verdict_motors") or [], f.get("pair", False),
                                    cause=f.get("cause"))
            cells = []
            by_motor = {m["motor"]: m for m in f["motors"]}
            for k in _motor_numbers(v["flights"]):
                m = by_motor.get(k, {})
                cells.append(f"<td>{_cell(m, ' / ')}</td>")
            out.append(f"<tr><td>{i}</td><td>{e(f['flight_start_utc'] or '-')}</td><td>{e(Path(f['log']).name)}</td>"
                       f"<td>{e(verdict)}</td><td>{_fmt(f['confidence'])}</td>{''.join(cells)}</tr>")
            for p in f.get("parts") or []:
                out.append(f"<tr class='part'><td></td><td></td><td>&nbsp;&nbsp;{e(p['label'])}</td>"
                           f"<td title='{e(p.get('reason') or '')}'>{e(_part_verdict(p))}</td>"
                           f"<td>{_fmt(p.get('confidence'))}</td>"
                           f"<td colspan='{len(_motor_numbers(v['flights']))}'></td></tr>")
        out.append("</table>")
        for figure, title in TREND_FIGURES:
            svg = _svg_trend(v["flights"], figure)
            if svg:
                out.append(f"<h3>{e(title)}</h3>{svg}")
    out.append("</body></html>")
    return "\n".join(out)


def _part_verdict(p: dict) -> str:
    """One flight of a log holding several: its status (and motor), short."""
    return verdict_words(p.get("status"), p.get("motor"), p.get("verdict_motors") or [], bool(p.get("pair")), short=True)


def _fmt(x: Optional[float], decimals: int = 3) -> str:
    return "-" if x is None else f"{x:.{decimals}f}"


def _cell(m: Optional[dict], sep: str) -> str:
    """One motor's cell of the flights table: the fleet summary's figures (motor_view)."""
    return summary_cell(m).replace(" / ", sep)


def iter_text_lines(summary: dict) -> Iterable[str]:
    """Plain-text history: per airframe its flights and each motor's figures, then flags."""
    for v in summary["vehicles"]:
        yield f"{v['vehicle']}  ({v['vehicle_source']}, {len(v['flights'])} flights)"
        yield f"  {'#':>3} {'start (UTC)':<24} {'verdict':<18} {'conf':>5}  " + "  ".join(
            summary_header(k).replace(" / ", "/") for k in _motor_numbers(v["flights"])) + "  log"
        for i, f in enumerate(v["flights"], 1):
            verdict = verdict_words(f["status"], f["motor"], f.get("verdict_motors") or [], f.get("pair", False),
                                    short=True, cause=f.get("cause"))
            by_motor = {m["motor"]: m for m in f["motors"]}
            figs = "  ".join(_cell(by_motor.get(k, {}), "/") for k in _motor_numbers(v["flights"]))
            yield (f"  {i:>3} {(f['flight_start_utc'] or '-'):<24} {verdict:<18} {_fmt(f['confidence']):>5}  "
                   f"{figs}  {Path(f['log']).name}")
            for p in f.get("parts") or []:
                yield f"  {'':>3} {'  ' + p['label']:<24} {_part_verdict(p):<18} {_fmt(p.get('confidence')):>5}"
        for d in v["drift"]:
            yield f"  FLAG: {d['text']}"
        if v["latest_damaged"]:
            f = v["latest"]
            yield f"  FLAG: latest flight: {_latest_words(f)} ({Path(f['log']).name})"
        elif v.get("latest_inspect"):
            f = v["latest"]
            yield f"  FLAG: latest flight {_inspect_words(f)} ({Path(f['log']).name})"
        yield ""


def summary_json(summary: dict) -> str:
    return json.dumps(summary, indent=2)
