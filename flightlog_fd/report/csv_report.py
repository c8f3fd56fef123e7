"""Windows as CSV (``fdlog diagnose --csv F``): one row per window, all logs in one file.

Columns (:data:`CSV_COLUMNS`): ``log`` (the path as given), ``t_start``, ``t_end`` (seconds on
the log's clock, 3 decimals), ``class`` (the model's most probable class, 0 healthy, k motor k),
``p_healthy``, ``p_motor1`` .. ``p_motor4`` (0..1, 4 decimals), ``phase`` (hover, climb, descent,
manoeuvre, unknown), ``smoothed_class`` (the verdict's label: -1 uncertain, 0..4), ``verdict``
(the flight's status, repeated on every row so one file of many logs can be filtered), then the
per-motor evidence, also repeated on every row: ``change_m1`` .. ``change_m4`` (command share
against the baseline, 4 decimals), ``effectiveness_m1`` .. ``effectiveness_m4`` (relative
effectiveness, empty when it could not be estimated or the fit was uninformative), ``eta_m1`` ..
``eta_m4`` (the decision model's thrust efficiency eta-hat, 1 = healthy) and ``weight_m1`` ..
``weight_m4`` (its probability that the rotor lost thrust).
A log that could not be diagnosed contributes no rows. Comma-separated, UTF-8, ``\\n`` line ends.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Sequence, TextIO, Union

from ..diagnose import Diagnosis

CSV_COLUMNS = ("log", "t_start", "t_end", "class", "p_healthy", "p_motor1", "p_motor2", "p_motor3",
               "p_motor4", "phase", "smoothed_class", "verdict",
               "change_m1", "change_m2", "change_m3", "change_m4",
               "effectiveness_m1", "effectiveness_m2", "effectiveness_m3", "effectiveness_m4",
               "eta_m1", "eta_m2", "eta_m3", "eta_m4", "weight_m1", "weight_m2", "weight_m3", "weight_m4")


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
    writer.writerow(CSV_COLUMNS)
    for d in diagnoses:
        motors = d.motors
        change = [f"{m.command_change:.4f}" for m in motors] or [""] * 4
        usable = d.evidence is not None and d.evidence.effectiveness_usable
        eff = [("" if m.effectiveness is None or not usable else f"{m.effectiveness:.4f}") for m in motors] or [""] * 4
        dec = d.decision.motors if d.decision is not None else []
        eta = [("" if m.eta_hat is None else f"{m.eta_hat:.3f}") for m in dec] or [""] * 4
        weight = [f"{m.weight:.4f}" for m in dec] or [""] * 4
        for w in d.windows:
            writer.writerow([d.log, f"{w.t_start:.3f}", f"{w.t_end:.3f}", w.cls,
                             *(f"{p:.4f}" for p in w.probabilities), w.phase, w.label, d.verdict.status,
                             *change, *eff, *eta, *weight])
