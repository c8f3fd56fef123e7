"""Terminal report (rich): the verdict first, in plain words, then a timeline strip over the flight.

Inputs: :class:`~flightlog_fd.diagnose.Diagnosis` objects. Nothing here decides anything; it
only words and draws what the verdict says.

- :func:`verdict_sentence`: "Propeller 3 (front-left) damaged, confidence 0.93, first seen at
  t=34.5 s" / "No propeller damage found ..." / "Uncertain: ..." / "Not diagnosable: ...".
- :func:`timeline_strip`: ``TIMELINE_WIDTH`` characters spanning the first window's start to the
  last window's end (seconds on the log's clock), one per equal time slot: ``.`` healthy, ``1``-``4``
  the motor judged damaged, ``?`` uncertain, a space where there is no window (on the ground).
  The characters are the verdict's smoothed window labels, so the strip shows what the verdict saw.
- :func:`window_table` (``--windows``): every window with its times, class, probabilities, phase.
- :func:`summary_table`: one row per log when several logs are diagnosed (file names; the full
  path where two logs share a name).
- :func:`render`: all of the above for one log onto a rich Console.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

from rich import box
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from ..diagnose import Diagnosis
from ..timeline import UNCERTAIN_LABEL, timeline_labels

#: Characters in the timeline strip (fits an 80-column terminal with its time labels).
TIMELINE_WIDTH = 60
#: Timeline characters and styles per smoothed label.
#: Timeline characters: motors 1-9, then a, b, c for 10-12 (dodecahexa).
LABEL_CHARS = {UNCERTAIN_LABEL: "?", 0: ".", **{k: "123456789abc"[k - 1] for k in range(1, 13)}}
LABEL_STYLES = {UNCERTAIN_LABEL: "bold yellow", 0: "green", **{k: "bold red" for k in range(1, 13)}}
STATUS_STYLES = {"healthy": "bold green", "damaged": "bold red", "stopped": "bold red", "uncertain": "bold yellow",
                 "not_diagnosable": "bold magenta"}
CLASS_NAMES = ("healthy", "motor 1", "motor 2", "motor 3", "motor 4")


def _motor_words(motor: int, position: Optional[str]) -> str:
    return f"{motor} ({position})" if position else f"{motor}"


def verdict_sentence(diagnosis: Diagnosis) -> str:
    """The verdict in one plain sentence (also used as the HTML page's headline)."""
    v = diagnosis.verdict
    if v.status == "damaged":
        first = f", first seen at t={v.first_seen:.1f} s" if v.first_seen is not None else ""
        return f"Propeller {_motor_words(v.motor, v.position)} damaged, confidence {v.confidence:.2f}{first}"
    if v.status == "healthy":
        tl = diagnosis.timeline
        n = tl.n_windows if tl else len(diagnosis.windows)
        covered = f", {tl.covered_s:.0f} s of flight" if tl else ""
        return f"No propeller damage found, confidence {v.confidence:.2f} ({n} windows{covered})"
    if v.status == "uncertain":
        return f"Uncertain: {v.reason}"
    if v.status == "stopped":
        return f"Motor {_motor_words(v.motor, v.position)} stopped in flight at t={v.first_seen:.1f} s"
    return f"Not diagnosable: {v.reason}"


def timeline_strip(diagnosis: Diagnosis, width: int = TIMELINE_WIDTH) -> Text:
    """The coloured strip with the time at both ends; empty Text when there are no windows."""
    w = diagnosis.windows
    if not w:
        return Text("")
    t0, t1 = min(x.t_start for x in w), max(x.t_end for x in w)
    slots = timeline_labels([x.t_start for x in w], [x.t_end for x in w], [x.label for x in w], t0, t1, width)
    text = Text(f"t={t0:.1f} s ", style="dim")
    for label in slots:
        if label is None:
            text.append(" ")
        else:
            text.append(LABEL_CHARS[label], style=LABEL_STYLES[label])
    text.append(f" t={t1:.1f} s", style="dim")
    return text


def window_table(diagnosis: Diagnosis) -> Table:
    """Every window: start, end (s), the model's class, its five probabilities, phase, verdict label."""
    table = Table(title="Windows", show_lines=False)
    for name in ("t_start s", "t_end s", "class", "p healthy", "p m1", "p m2", "p m3", "p m4", "phase", "label"):
        table.add_column(name, justify="right" if name.startswith(("t_", "p ")) else "left")
    for x in diagnosis.windows:
        table.add_row(f"{x.t_start:.2f}", f"{x.t_end:.2f}", CLASS_NAMES[x.cls],
                      *(f"{p:.2f}" for p in x.probabilities), x.phase,
                      Text(LABEL_CHARS[x.label], style=LABEL_STYLES[x.label]))
    return table


def summary_table(diagnoses: Sequence[Diagnosis]) -> Table:
    """One row per log: status, motor and position, confidence, first seen, exit code."""
    # A light box and short headers keep a row on one line in an 80-column terminal or a CI log.
    table = Table(title="Diagnosis summary", box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("log", overflow="fold")
    for name in ("verdict", "propeller", "conf.", "first seen", "exit"):
        table.add_column(name, no_wrap=True, min_width={"verdict": 9, "propeller": 15, "conf.": 5,
                                                        "first seen": 9, "exit": 4}[name],
                         justify="right" if name in ("conf.", "first seen", "exit") else "left")
    names = [Path(d.log).name for d in diagnoses]
    for d, name in zip(diagnoses, names):
        # The file name is enough unless two logs share it (same name in different folders).
        shown = name if names.count(name) == 1 else d.log
        v = d.verdict
        prop = _motor_words(v.motor, v.position) if v.motor else ""
        conf = f"{v.confidence:.2f}" if v.status != "not_diagnosable" else ""
        first = f"t={v.first_seen:.1f} s" if v.first_seen is not None else ""
        table.add_row(Text(shown), Text(v.status, style=STATUS_STYLES.get(v.status, "")), Text(prop),
                      conf, first, str(d.exit_code))
    return table


def facts_line(diagnosis: Diagnosis) -> str:
    """Log facts in one line: autopilot, firmware, frame, duration, airborne time, model."""
    f = diagnosis.facts
    parts = []
    if f is not None:
        parts.append(f.autopilot + (f" {f.firmware}" if f.firmware else ""))
        if f.frame:
            parts.append(f.frame)
        parts.append(f"{f.duration_s:.0f} s log, {f.airborne_s:.0f} s airborne")
    if diagnosis.model is not None:
        m = diagnosis.model
        parts.append(f"model {m.version or '?'}" + (" (calibrated)" if m.calibrated else ""))
    return " | ".join(parts)


def motor_table(diagnosis: Diagnosis) -> tuple[list[str], list[list[str]]]:
    """The per-motor panel as (headers, rows) of text cells, shared by the terminal and HTML:
    motor, position, one column per finding the analyzers returned (in registry order; each
    analyzer formats its own cell), and the decision's weight. Empty without a decision."""
    dec = diagnosis.decision
    if dec is None or not dec.motors:
        return [], []
    columns: list[tuple[str, str]] = []
    cells: dict[tuple[str, str, int], str] = {}
    for r in dec.results:
        for f in r.findings:
            key = (r.analyzer, f.name)
            if key not in columns:
                columns.append(key)
            cells[(r.analyzer, f.name, f.motor)] = f.text()
    frame = diagnosis.flight.frame if diagnosis.flight is not None else None
    positions = {m.motor: m.position for m in diagnosis.motors}
    headers = ["motor", "position"] + [FINDING_HEADERS.get(name, name) for _, name in columns] + ["weight"]
    rows = []
    for m in dec.motors:
        pos = positions.get(m.motor) or (frame.position(m.motor) if frame is not None else None) or "-"
        rows.append([str(m.motor), pos] + [cells.get((a, n, m.motor), "-") for a, n in columns] + [f"{m.weight:.2f}"])
    return headers, rows


#: Short column heads for finding names (an 80-column terminal): share = command share and its
#: change against the baseline; thrust % = eta-hat with its 90 % interval; effect. = relative
#: effectiveness with its 90 % interval; weight = the decision's probability that the rotor lost thrust.
FINDING_HEADERS = {"share": "share", "thrust": "thrust %", "effectiveness": "effect.", "vote": "vote",
                   "throttle": "thr.", "rpm_per_command": "rpm/cmd", "current_per_rpm2": "A/rpm2",
                   "esc_damage": "esc"}


def short_position(position: str) -> str:
    """"front-right" -> "FR", "rear" -> "R": an 80-column table's position column."""
    return "".join(w[0].upper() for w in position.replace(" ", "-").split("-") if w) or position


def analyzer_notes(diagnosis: Diagnosis) -> list[str]:
    """One line per analyzer that abstained (why) and per note an analyzer left."""
    dec = diagnosis.decision
    if dec is None:
        return []
    out = [f"{r.analyzer}: {r.abstained}" for r in dec.results if r.abstained]
    out += [f"{r.analyzer}: {n}" for r in dec.results for n in r.notes]
    if dec.airframe_changed:
        out.append(f"airframe change since calibration: {dec.airframe_changed}")
    return out


def motor_panel(diagnosis: Diagnosis) -> Table:
    """Per-motor findings table: what the verdict rests on, in numbers a pilot can check."""
    ev = diagnosis.evidence
    against = {"profile": "calibration", "before onset": "the flight before the onset",
               "neighbours": "an even split"}.get(getattr(ev, "baseline", ""), "")
    t = Table(title=f"per-motor findings (commands against {against})", title_justify="left", box=None,
              padding=(0, 0, 0, 1), pad_edge=False, title_style="dim")
    headers, rows = motor_table(diagnosis)
    headers = ["pos" if h == "position" else h for h in headers]
    for h in headers:
        t.add_column(h, justify="left" if h in ("pos", "share", "thrust %", "effect.") else "right", no_wrap=True)
    for row in rows:
        t.add_row(*[short_position(c) if i == 1 and c != "-" else c for i, c in enumerate(row)])
    return t


def render(diagnosis: Diagnosis, console: Optional[Console] = None, *, show_windows: bool = False) -> Group:
    """Print (when ``console`` is given) and return the report for one log."""
    v = diagnosis.verdict
    parts: list = [Text(diagnosis.log, style="bold"),
                   Text(verdict_sentence(diagnosis), style=STATUS_STYLES.get(v.status, ""))]
    if v.status in ("damaged", "healthy", "uncertain", "stopped") and v.reason:
        parts.append(Text(f"  {v.reason}", style="dim"))
    line = facts_line(diagnosis)
    if line:
        parts.append(Text(f"  {line}", style="dim"))
    if diagnosis.windows:
        parts.append(timeline_strip(diagnosis))
        n = len(diagnosis.windows[0].probabilities) - 1
        parts.append(Text(f"  . healthy   1-{LABEL_CHARS[n]} propeller damaged   ? uncertain", style="dim"))
    if diagnosis.decision is not None:
        parts.append(motor_panel(diagnosis))
        for note in analyzer_notes(diagnosis):
            parts.append(Text(f"  * {note}", style="dim"))
    if show_windows and diagnosis.windows:
        parts.append(window_table(diagnosis))
    for w in diagnosis.warnings:
        parts.append(Text(f"warning: {w}", style="yellow"))
    group = Group(*parts)
    if console is not None:
        console.print(group)
    return group
