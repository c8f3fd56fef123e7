"""Windows as CSV (``fdlog diagnose --csv F``): one row per window, all logs in one file.

Columns (:data:`CSV_COLUMNS`): ``log`` (the path as given), ``t_start``, ``t_end`` (seconds on
the log's clock, 3 decimals), ``class`` (the model's most probable class, 0 healthy, k motor k),
``p_healthy``, ``p_motor1`` .. ``p_motor4`` (0..1, 4 decimals), ``phase`` (hover, climb, descent,
manoeuvre, unknown), ``smoothed_class`` (the verdict's label: -1 uncertain, 0..4), ``verdict``
(the flight's status, repeated on every row so one file of many logs can be filtered), then
(:func:`csv_columns`) the analyzers' findings, also repeated on every row, one column per
analyzer, finding and motor: ``<analyzer>_<name>_m<k>`` (e.g. ``commands_share_m1``,
``commands_thrust_m1``, ``model_vote_m1``, ``effectiveness_effectiveness_m1``; empty where an
analyzer abstained), and ``weight_m<k>`` (the decision's probability that rotor k lost thrust).
A log that could not be diagnosed contributes no rows. Comma-separated, UTF-8, ``\\n`` line ends.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence, TextIO, Union

from ..diagnose import Diagnosis

CSV_COLUMNS = ("log", "t_start", "t_end", "class", "p_healthy", "p_motor1", "p_motor2", "p_motor3",
               "p_motor4", "phase", "smoothed_class", "verdict")


def _finding_keys(diagnoses: Sequence[Diagnosis]) -> list[tuple[str, str, int]]:
    """(analyzer, name, motor) of every finding in the diagnoses: findings in report order, motors
    ascending within each."""
    columns: list[tuple[str, str]] = []
    motors: set[int] = set()
    for d in diagnoses:
        for r in (d.decision.results if d.decision is not None else []):
            for f in r.findings:
                if (r.analyzer, f.name) not in columns:
                    columns.append((r.analyzer, f.name))
                motors.add(f.motor)
    return [(a, n, k) for a, n in columns for k in sorted(motors)]


def _motor_count(diagnoses: Sequence[Diagnosis]) -> int:
    return max((len(d.decision.motors) for d in diagnoses if d.decision is not None), default=0)


def csv_columns(diagnoses: Union[Diagnosis, Sequence[Diagnosis]]) -> tuple[str, ...]:
    """The header: the window columns, then the findings' and weights' columns of these diagnoses."""
    ds = [diagnoses] if isinstance(diagnoses, Diagnosis) else list(diagnoses)
    return CSV_COLUMNS + tuple(f"{a}_{n}_m{k}" for a, n, k in _finding_keys(ds)) + tuple(
        f"weight_m{k}" for k in range(1, _motor_count(ds) + 1))


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
    keys = _finding_keys(diagnoses)
    n = _motor_count(diagnoses)
    writer.writerow(csv_columns(diagnoses))
    for d in diagnoses:
        values = {(r.analyzer, f.name, f.motor): f.value
                  for r in (d.decision.results if d.decision is not None else []) for f in r.findings}
        found = ["" if values.get(k) is None else f"{values[k]:.4f}" for k in keys]
        dec = d.decision.motors if d.decision is not None else []
        weight = [f"{m.weight:.4f}" for m in dec] + [""] * (n - len(dec))
        for w in d.windows:
            writer.writerow([d.log, f"{w.t_start:.3f}", f"{w.t_end:.3f}", w.cls,
                             *(f"{p:.4f}" for p in w.probabilities), w.phase, w.label, d.verdict.status,
                             *found, *weight])
