"""Windows as CSV (``fdlog diagnose --csv F``): one row per window, all logs in one file.

Columns (:func:`csv_columns`, for n = the most rotors among the logs): ``log`` (the path as
given), ``t_start``, ``t_end`` (seconds on the log's clock, 3 decimals), ``class`` (the model's
most probable class, 0 healthy, k motor k), ``p_healthy``, ``p_motor1`` .. ``p_motor<n>`` (0..1,
4 decimals; empty past a log's own rotor count), ``phase`` (hover, climb, descent, manoeuvre,
unknown), ``smoothed_class`` (the verdict's label: -1 uncertain, 0..n), ``verdict`` (the flight's
status, repeated on every row so one file of many logs can be filtered), ``verdict_headline`` (the
first line every report prints: the status, the rotor, how much, what to do), ``verdict_motor`` (the
damaged or stopped motor, or the one propeller an uncertain verdict asks to inspect first; empty
when it names none or two), ``verdict_motors`` (every propeller the verdict names, "1;4" when two
lost thrust together; empty when none), ``flight`` (which take-off
to landing of a log holding several the window lies in, "flight 2 of 5"; empty for a log's only
one), ``flight_verdict`` (that flight's own status, else the log's), ``verdict_cause``
(why the named rotor lost thrust: ``propeller``, ``motor_or_esc``, ``wash``: something in its
wash or under it; ``load``: healthy propellers, a moved load; empty when unknown)
and ``load_motor`` (with cause ``load``: the motor nearest the load), then the per-motor view's
(:mod:`flightlog_fd.report.motor_view`) findings, also repeated on every row, one column per
analyzer, finding and motor: ``<analyzer>_<name>_m<k>`` (e.g. ``commands_share_m1``,
``commands_thrust_m1``, ``model_vote_m1``, ``effectiveness_effectiveness_m1``; empty where an
analyzer abstained), and ``weight_m<k>`` (the decision's probability that rotor k lost thrust).
Every row has as many fields as the header. A log that could not be diagnosed contributes no rows.
Comma-separated, UTF-8, ``\\n`` line ends.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence, TextIO, Union

from ..diagnose import Diagnosis
from .motor_view import MotorView
from .terminal import verdict_sentence

#: The window columns before the class probabilities, and after them.
LEAD_COLUMNS = ("log", "t_start", "t_end", "class", "p_healthy")
TAIL_COLUMNS = ("phase", "smoothed_class", "verdict", "verdict_headline", "verdict_motor", "verdict_motors", "flight",
                "flight_verdict", "verdict_cause", "load_motor")


def _finding_keys(views: Sequence[MotorView]) -> list[tuple[str, str, int]]:
    """(analyzer, name, motor) of every finding column in the views: columns in report order,
    motors ascending within each."""
    columns: list[tuple[str, str]] = []
    motors: set[int] = set()
    for v in views:
        for c in v.columns:
            if c.name and (c.analyzer, c.name) not in columns:
                columns.append((c.analyzer, c.name))
        motors.update(r.motor for r in v.rows if r.values)
    return [(a, n, k) for a, n in columns for k in sorted(motors)]


def _motor_count(diagnoses: Sequence[Diagnosis], views: Sequence[MotorView]) -> int:
    """The most motors among the diagnoses (their views' rows, their windows' classes)."""
    return max([len(v.rows) for v in views]
               + [len(w.probabilities) - 1 for d in diagnoses for w in d.windows[:1]] + [0])


def _header(diagnoses: Sequence[Diagnosis], views: Sequence[MotorView]) -> tuple[str, ...]:
    n = _motor_count(diagnoses, views)
    return (LEAD_COLUMNS + tuple(f"p_motor{k}" for k in range(1, n + 1)) + TAIL_COLUMNS
            + tuple(f"{a}_{name}_m{k}" for a, name, k in _finding_keys(views))
            + tuple(f"weight_m{k}" for k in range(1, n + 1)))


def csv_columns(diagnoses: Union[Diagnosis, Sequence[Diagnosis]]) -> tuple[str, ...]:
    """The header: the window columns, then the findings' and weights' columns of these diagnoses."""
    ds = [diagnoses] if isinstance(diagnoses, Diagnosis) else list(diagnoses)
    return _header(ds, [MotorView.of(d) for d in ds])


def write_csv(diagnoses: Union[Diagnosis, Sequence[Diagnosis]], out: Union[str, Path, TextIO]) -> None:
    """Write the windows of one or more diagnoses to a path or an open text file."""
    if isinstance(diagnoses, Diagnosis):
        diagnoses = [diagnoses]
    if isinstance(out, (str, Path)):
        with open(out, "w", newline="", encoding="utf-8") as fh:
            _write(diagnoses, fh)
    else:
        _write(diagnoses, out)


def render_csv(diagnoses: Union[Diagnosis, Sequence[Diagnosis]]) -> str:
    """The CSV text (for tests and for printing)."""
    buf = io.StringIO()
    write_csv(diagnoses, buf)
    return buf.getvalue()


def _write(diagnoses: Sequence[Diagnosis], fh: TextIO) -> None:
    writer = csv.writer(fh, lineterminator="\n")
    views = [MotorView.of(d) for d in diagnoses]
    keys = _finding_keys(views)
    n = _motor_count(diagnoses, views)
    writer.writerow(_header(diagnoses, views))
    for d, view in zip(diagnoses, views):
        values = {(c.analyzer, c.name, r.motor): r.values.get(c.key) for r in view.rows for c in view.columns}
        found = ["" if values.get(k) is None else f"{values[k]:.4f}" for k in keys]
        weight = ["" if r.weight is None else f"{r.weight:.4f}" for r in view.rows] + [""] * (n - len(view.rows))
        headline = verdict_sentence(d)
        parts = [(f.facts.t_start, f.facts.t_end, f.part.split(",")[0], f.verdict.status)
                 for f in d.flights if f.facts is not None]
        for w in d.windows:
            probs = [f"{p:.4f}" for p in w.probabilities[1:]]
            part = next((p for p in parts if p[0] - 1e-6 <= w.t_start and w.t_end <= p[1] + 1e-6), None)
            writer.writerow([d.log, f"{w.t_start:.3f}", f"{w.t_end:.3f}", w.cls, f"{w.probabilities[0]:.4f}",
                             *probs, *[""] * (n - len(probs)), w.phase, w.label, d.verdict.status, headline,
                             d.verdict.motor or "", ";".join(str(k) for k in d.verdict.motors),
                             part[2] if part else "", part[3] if part else d.verdict.status, d.verdict.cause or "",
                             (d.verdict.load or {}).get("motor", ""), *found, *weight])
