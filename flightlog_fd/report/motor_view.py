"""The per-motor view: one row per motor, built once from a diagnosis, that every report draws.

What: :class:`MotorView` holds, for any rotor count, each motor's number (the autopilot's own),
class name (class k = motor k), position name, the figures (model vote, command share and its
change against the baseline, eta-hat and effectiveness with their 90 % intervals, throttle
against calibration, weight, LLR total and by source) and one text cell per analyzer finding.
The columns come from the analyzers the diagnosis ran (registry order), never from a fixed list.
An analyzer that abstained, or an estimate it called uninformative, is a dash with its reason:
its numbers are never shown.

Inputs: a :class:`~flightlog_fd.diagnose.Diagnosis` (:meth:`MotorView.of`) or a diagnosis JSON
document of schema 3 or later (:meth:`MotorView.from_doc`, for the web pages, whose stored
reports may predate this view). Outputs: :meth:`MotorView.table` (header and cells, for the
terminal, the HTML report and the web page), :meth:`MotorView.to_json` (the JSON report's
``motors`` and ``motor_columns``). Why: one table for every output, so they show the same
figures under the same names for any rotor count.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

#: Short column labels for finding names (an 80-column terminal); an unknown name is its own label.
FINDING_LABELS = {"vote": "vote", "share": "share", "thrust": "thrust %", "effectiveness": "effect.",
                  "throttle": "thr.", "rpm_per_command": "rpm/cmd", "current_per_rpm2": "A/rpm2",
                  "esc_damage": "esc", "rotor_line": "line"}
#: Analyzers whose findings are about the whole flight (per motor only when they can tie one to a
#: rotor): when they abstain, their reason is a note, not a column of dashes.
FLIGHT_LEVEL_ANALYZERS = {"vibration"}
#: The label of an analyzer's one column when it abstained (it returned no finding names).
ANALYZER_LABELS = {"model": "vote", "commands": "share", "throttle": "thr.", "effectiveness": "effect.",
                   "esc": "esc"}
#: What each column means (the HTML report's and the web page's legend).
FINDING_DESCRIPTIONS = {
    "vote": "the model's mean probability that this rotor lost thrust (its class k)",
    "share": "mean thrust command / mean of all motors (1 = even), and its change against the baseline",
    "thrust": "the share of its normal thrust the rotor gives (eta-hat), fitted from the steady command "
              "pattern, with its 90 % interval",
    "effectiveness": "angular acceleration per unit command relative to the other motors (1 = as they), "
                     "with its 90 % interval; only when the flight manoeuvred enough",
    "throttle": "the flight's throttle against calibration",
    "rpm_per_command": "rpm per command against the other motors (ESC telemetry)",
    "current_per_rpm2": "current per rpm squared against the other motors (ESC telemetry)",
    "esc_damage": "the ESC telemetry's damage score",
    "rotor_line": "the vibration line tied to this rotor's speed (Hz) and the tie's probability per rotor",
    "weight": "the decision's probability that this rotor lost thrust",
}
#: Words for the baseline the command changes are taken against.
BASELINE_WORDS = {"profile": "calibration", "before onset": "the flight before the onset",
                  "neighbours": "an even split"}
#: Per-motor figures of one flight in the fleet summaries (``fdlog history``, the airframe page):
#: (figure key in the stores' motor rows, label, decimals). One list, so both show the same names.
SUMMARY_FIGURES = (("model_vote", "vote", 2), ("command_change", "change", 3))
DASH = "-"


def class_names(n_motors: int) -> tuple[str, ...]:
    """("healthy", "motor 1", ..., "motor n"): class k is motor k, for any rotor count."""
    return ("healthy",) + tuple(f"motor {k}" for k in range(1, n_motors + 1))


def summary_header(motor: int) -> str:
    """The fleet summaries' column head for one motor, e.g. "m3 vote / change"."""
    return f"m{motor} " + " / ".join(label for _, label, _ in SUMMARY_FIGURES)


def summary_cell(figures: Any) -> str:
    """One motor's summary figures (a store's motor row: a mapping of figure -> value, or None)
    as e.g. "0.12 / 0.031"; a dash for a missing figure."""
    def get(key):
        try:
            return figures[key] if figures is not None else None
        except (KeyError, IndexError, TypeError):
            return None

    return " / ".join(_fmt(get(key), decimals) for key, _, decimals in SUMMARY_FIGURES)


def short_position(position: str) -> str:
    """"front-right" -> "FR", "front-right-mid" -> "FRM": an 80-column table's position column. A
    one-word position stays whole ("rear", "right"): their initials are the same letter."""
    main, _, rest = position.partition(" (")  # "rear-left (-162 deg)": the bracket is kept
    words = [w for w in main.replace(" ", "-").split("-") if w]
    short = main if len(words) < 2 else "".join(w[0].upper() for w in words)
    return f"{short} ({rest}" if rest else short


def _fmt(x: Any, decimals: int = 3) -> str:
    return DASH if not _finite(x) else f"{float(x):.{decimals}f}"


def _finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _num(x: Any, decimals: int = 4) -> Optional[float]:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return round(v, decimals) if math.isfinite(v) else None


def _pair(x: Any) -> Optional[list]:
    if x is None:
        return None
    lo, hi = _num(x[0]), _num(x[1])
    return None if lo is None or hi is None else [lo, hi]


@dataclass(frozen=True)
class Column:
    """One finding column: ``key`` "<analyzer>.<name>" (the analyzer id alone when it abstained),
    its short ``label``, what it means, and the analyzer's reason when its cells are dashes."""

    key: str
    analyzer: str
    name: str
    label: str
    description: str = ""
    abstained: Optional[str] = None

    def as_dict(self) -> dict:
        return {"key": self.key, "analyzer": self.analyzer, "name": self.name, "label": self.label,
                "description": self.description, "abstained": self.abstained}


@dataclass
class Cell:
    """What a table shows in one place: its text, and why it is a dash (None otherwise)."""

    text: str
    reason: Optional[str] = None


@dataclass
class MotorRow:
    """One motor's figures (None where unknown; ``unavailable`` says why an estimate is missing)."""

    motor: int
    position: Optional[str]
    model_vote: Optional[float] = None
    command_share: Optional[float] = None
    command_share_baseline: Optional[float] = None
    command_change: Optional[float] = None
    eta_hat: Optional[float] = None
    eta_ci: Optional[tuple[float, float]] = None
    effectiveness: Optional[float] = None
    effectiveness_ci: Optional[tuple[float, float]] = None
    throttle: Optional[float] = None
    weight: Optional[float] = None
    llr: Optional[float] = None
    llr_by_source: Optional[dict] = None
    cells: dict = field(default_factory=dict)  # column key -> text
    unavailable: dict = field(default_factory=dict)  # figure -> why it is None
    values: dict = field(default_factory=dict)  # column key -> the finding's value (the CSV's numbers)

    @property
    def class_name(self) -> str:
        return f"motor {self.motor}"

    def as_dict(self) -> dict:
        """The JSON report's per-motor object (schema 4)."""
        return {"motor": self.motor, "position": self.position, "class": self.class_name,
                "model_vote": _num(self.model_vote), "command_share": _num(self.command_share),
                "command_share_baseline": _num(self.command_share_baseline),
                "command_change": _num(self.command_change),
                "eta_hat": _num(self.eta_hat), "eta_ci": _pair(self.eta_ci),
                "effectiveness": _num(self.effectiveness), "effectiveness_ci": _pair(self.effectiveness_ci),
                "throttle": _num(self.throttle), "weight": _num(self.weight), "llr": _num(self.llr),
                "llr_by_source": None if self.llr_by_source is None else {
                    k: _num(v) for k, v in self.llr_by_source.items()},
                "cells": dict(self.cells), "unavailable": dict(self.unavailable)}


@dataclass
class MotorView:
    """Every motor of one flight, with the finding columns and the notes the table needs."""

    rows: list[MotorRow]
    columns: list[Column]
    n_motors: int
    baseline: str = ""  # "profile" | "before onset" | "neighbours" | "" (no evidence)
    sources: list[str] = field(default_factory=list)  # the analyzers the decision weighed
    notes: list[str] = field(default_factory=list)  # abstentions and analyzers' notes, one line each
    verdict_motor: Optional[int] = None
    #: The motors the verdict names as damaged: the one, or both of a pair (highlighted rows)
    verdict_motors: list[int] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.verdict_motor is not None and not self.verdict_motors:
            self.verdict_motors = [self.verdict_motor]

    def highlighted(self, motor: Any) -> bool:
        """True for a row (its motor number, or the text of its first cell) the verdict names."""
        try:
            return int(str(motor)) in self.verdict_motors
        except ValueError:
            return False

    # ------------------------------------------------------------------ building

    @classmethod
    def of(cls, diagnosis: Any) -> "MotorView":
        """The view of a :class:`~flightlog_fd.diagnose.Diagnosis` (empty rows without a decision)."""
        dec = getattr(diagnosis, "decision", None)
        results = list(dec.results) if dec is not None else []
        fit = getattr(diagnosis, "share_fit", None)
        shares = {m.motor: m for m in (fit.motors if fit is not None else [])}
        decided = {m.motor: m for m in (dec.motors if dec is not None else [])}
        n = max([len(decided), len(shares), _n_classes(diagnosis) - 1, 0])
        frame = getattr(getattr(diagnosis, "flight", None), "frame", None)
        columns, cells, findings = _columns([(r.analyzer, r.abstained, [
            (f.name, f.motor, f.text(), f) for f in r.findings]) for r in results])
        rows = []
        if dec is not None or shares:
            for k in range(1, n + 1):
                e, m = shares.get(k), decided.get(k)
                pos = getattr(e, "position", None) or (frame.position(k) if frame is not None else None)
                row = MotorRow(motor=k, position=pos,
                               model_vote=getattr(e, "model_vote", None),
                               command_share=getattr(e, "command_share", None),
                               command_share_baseline=getattr(e, "command_share_baseline", None),
                               command_change=getattr(e, "command_change", None),
                               weight=getattr(m, "weight", None), llr=getattr(m, "llr", None),
                               llr_by_source=dict(m.llr_by_source) if m is not None else None)
                _estimates(row, findings, {r.analyzer: r.abstained for r in results})
                row.cells = {c.key: cells.get((c.key, k), DASH) for c in columns}
                row.values = {c.key: findings[(c.analyzer, c.name, k)].value for c in columns
                              if (c.analyzer, c.name, k) in findings}
                rows.append(row)
        notes = [f"{r.analyzer}: {r.abstained}" for r in results if r.abstained]
        notes += [f"{r.analyzer}: {f.text()}" for r in results for f in r.findings if not f.motor]
        notes += [f"{r.analyzer}: {note}" for r in results for note in r.notes]
        if dec is not None and dec.airframe_changed:
            notes.append(f"airframe change since calibration: {dec.airframe_changed}")
        v = getattr(diagnosis, "verdict", None)
        return cls(rows=rows, columns=columns, n_motors=n, baseline=getattr(fit, "baseline", "") or "",
                   sources=list(dec.sources) if dec is not None else [], notes=notes,
                   verdict_motor=getattr(v, "motor", None),
                   verdict_motors=list(getattr(v, "motors", None) or []) if getattr(v, "pair", False) else [])

    @classmethod
    def from_doc(cls, doc: dict) -> "MotorView":
        """The view of a diagnosis JSON document: schema 4's ``motors`` and ``motor_columns`` as
        written; an older one (schema 3) rebuilt from its ``analyzers`` and ``motors``."""
        doc = doc or {}
        motors = [m for m in doc.get("motors") or [] if isinstance(m, dict) and isinstance(m.get("motor"), int)]
        analyzers = [a for a in doc.get("analyzers") or [] if isinstance(a, dict)]
        verdict = doc.get("verdict") or {}
        me = doc.get("motor_evidence") or {}
        dec = me.get("decision") or {}
        if "motor_columns" in doc:
            columns = [Column(**{k: c.get(k) for k in ("key", "analyzer", "name", "label", "description",
                                                         "abstained")}) for c in doc["motor_columns"]]
            rows = [_row_from_dict(m, m.get("cells") or {}, m.get("unavailable") or {}) for m in motors]
        else:
            columns, cells, findings = _columns([(str(a.get("analyzer") or ""), a.get("abstained"), [
                (str(f.get("name") or ""), f.get("motor"), str(f.get("text") or DASH), f)
                for f in a.get("findings") or [] if isinstance(f, dict)]) for a in analyzers])
            rows = []
            for m in motors:
                row = _row_from_dict(m, {}, {})
                row.effectiveness = row.effectiveness_ci = None  # schema 3 showed it even when uninformative
                _estimates(row, findings, {str(a.get("analyzer") or ""): a.get("abstained") for a in analyzers})
                row.cells = {c.key: cells.get((c.key, row.motor), DASH) for c in columns}
                rows.append(row)
        notes = [f"{a.get('analyzer')}: {a.get('abstained')}" for a in analyzers if a.get("abstained")]
        notes += [f"{a.get('analyzer')}: {f.get('text')}" for a in analyzers for f in a.get("findings") or []
                  if isinstance(f, dict) and not f.get("motor")]
        notes += [f"{a.get('analyzer')}: {n}" for a in analyzers for n in a.get("notes") or []]
        if me.get("airframe_changed"):
            notes.append(f"airframe change since calibration: {me['airframe_changed']}")
        return cls(rows=rows, columns=columns, n_motors=len(rows), baseline=me.get("baseline") or "",
                   sources=list(dec.get("sources") or []), notes=notes, verdict_motor=verdict.get("motor"),
                   verdict_motors=[int(k) for k in verdict.get("motors") or [] if isinstance(k, int)]
                   if verdict.get("pair") else [])

    # ------------------------------------------------------------------ drawing

    @property
    def against(self) -> str:
        """Words for the baseline, e.g. "calibration" ("" without evidence)."""
        return BASELINE_WORDS.get(self.baseline, "")

    def table(self, narrow: bool = False) -> tuple[list[str], list[list[Cell]]]:
        """(header, rows of cells): motor, position, one column per finding column, weight. A
        dash's cell carries its reason. ``narrow`` (an 80-column terminal): "#" for the motor's
        head, "FR" for "front-right". Empty without rows."""
        if not self.rows:
            return [], []
        header = ["#" if narrow else "motor", "pos" if narrow else "position"] + [c.label for c in self.columns] + ["weight"]
        out = []
        for r in self.rows:
            pos = r.position or DASH
            cells = [Cell(str(r.motor)), Cell(short_position(pos) if narrow and r.position else pos)]
            for c in self.columns:
                text = r.cells.get(c.key, DASH)
                cells.append(Cell(text, c.abstained if text == DASH else None))
            cells.append(Cell(DASH if r.weight is None else f"{r.weight:.2f}"))
            out.append(cells)
        return header, out

    def notes_beside(self, said: Sequence[str]) -> list[str]:
        """The notes to print under the table: :attr:`notes` without those the verdict's evidence
        clauses ``said`` already (a note is "analyzer: text"; either form counts), each once."""
        out: list[str] = []
        for note in self.notes:
            text = note.split(": ", 1)[1] if ": " in note else note
            if text not in said and note not in said and note not in out:
                out.append(note)
        return out

    def legend(self) -> list[tuple[str, str]]:
        """(label, meaning) of every column shown, for a report's legend."""
        out = [(c.label, c.description) for c in self.columns if c.description]
        return out + [("weight", FINDING_DESCRIPTIONS["weight"])]

    def to_json(self) -> dict:
        """The JSON report's ``motors`` and ``motor_columns`` (schema 4)."""
        return {"motors": [r.as_dict() for r in self.rows], "motor_columns": [c.as_dict() for c in self.columns]}


def _n_classes(diagnosis: Any) -> int:
    windows = getattr(diagnosis, "windows", None) or []
    return len(windows[0].probabilities) if windows else 0


def _columns(results: Sequence[tuple[str, Optional[str], list]]):
    """Columns, cells and findings from (analyzer id, abstained, [(name, motor, text, finding)]) in
    registry order: one column per per-motor finding name an analyzer returned, in its order; one
    column of dashes with the reason for an analyzer that abstained (except a flight-level one's,
    ``FLIGHT_LEVEL_ANALYZERS``). Flight-level findings (motor 0) are notes, not columns."""
    columns: list[Column] = []
    cells: dict[tuple[str, int], str] = {}
    findings: dict[tuple[str, str, int], Any] = {}
    for analyzer, abstained, items in results:
        items = [it for it in items if isinstance(it[1], int) and it[1] >= 1]
        if analyzer in FLIGHT_LEVEL_ANALYZERS and (abstained or not items):
            continue
        if abstained or not items:
            label = ANALYZER_LABELS.get(analyzer, analyzer)
            columns.append(Column(analyzer, analyzer, "", label, "", abstained or "no findings"))
            continue
        for name, motor, text, f in items:
            key = f"{analyzer}.{name}"
            if all(c.key != key for c in columns):
                columns.append(Column(key, analyzer, name, FINDING_LABELS.get(name, name),
                                      FINDING_DESCRIPTIONS.get(name, "")))
            if isinstance(motor, int):
                cells[(key, motor)] = text or DASH
                findings[(analyzer, name, motor)] = f
    return columns, cells, findings


def _get(f: Any, name: str):
    return f.get(name) if isinstance(f, dict) else getattr(f, name, None)


def _estimates(row: MotorRow, findings: dict, abstained: dict) -> None:
    """Fill the row's estimates from the analyzers' findings (eta-hat: the command analyzer's
    ``thrust``; effectiveness; throttle); a missing one gets its analyzer's reason."""
    for figure, analyzer, name, interval in (("eta_hat", "commands", "thrust", "eta_ci"),
                                             ("effectiveness", "effectiveness", "effectiveness", "effectiveness_ci"),
                                             ("throttle", "throttle", "throttle", None)):
        f = findings.get((analyzer, name, row.motor))
        value = _get(f, "value") if f is not None else None
        if f is not None and _finite(value):
            setattr(row, figure, float(value))
            if interval:
                iv = _get(f, "interval")
                setattr(row, interval, None if iv is None else (iv[0], iv[1]))
        else:
            setattr(row, figure, None)
            if interval:
                setattr(row, interval, None)
            if analyzer in abstained:
                row.unavailable[figure] = abstained[analyzer] or f"the {analyzer} analyzer gave no {name}"


def _row_from_dict(m: dict, cells: dict, unavailable: dict) -> MotorRow:
    def pair(x):
        return None if not isinstance(x, (list, tuple)) or len(x) != 2 else (x[0], x[1])

    return MotorRow(motor=int(m["motor"]), position=m.get("position"), model_vote=m.get("model_vote"),
                    command_share=m.get("command_share"), command_share_baseline=m.get("command_share_baseline"),
                    command_change=m.get("command_change"), eta_hat=m.get("eta_hat"), eta_ci=pair(m.get("eta_ci")),
                    effectiveness=m.get("effectiveness"), effectiveness_ci=pair(m.get("effectiveness_ci")),
                    throttle=m.get("throttle"), weight=m.get("weight"), llr=m.get("llr"),
                    llr_by_source=m.get("llr_by_source"), cells=dict(cells), unavailable=dict(unavailable))


__all__ = ["MotorView", "MotorRow", "Column", "Cell", "class_names", "short_position", "summary_header",
           "summary_cell", "SUMMARY_FIGURES", "FINDING_LABELS", "FLIGHT_LEVEL_ANALYZERS", "FINDING_DESCRIPTIONS", "BASELINE_WORDS", "DASH"]
