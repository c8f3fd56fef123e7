"""Terminal report (rich): the verdict first, in plain words, then a timeline strip over the flight.

Inputs: :class:`~flightlog_fd.diagnose.Diagnosis` objects. Nothing here decides anything; it
only words and draws what the verdict says.

- :func:`verdict_sentence`: "Propeller 3 (front-left) damaged, confidence 0.93 (the probability
  that this verdict is right, ...), first seen at t=34.5 s" / "No sign of propeller damage in 38 s
  of usable flight, ..." / "Not seen: this log could not show damage ..." / "Uncertain, ...: ..." /
  "Not diagnosable: ...".
- :func:`timeline_strip`: ``TIMELINE_WIDTH`` characters spanning the first window's start to the
  last window's end (seconds on the log's clock), one per equal time slot: ``.`` healthy, ``1``-``9``
  then ``a``-``c`` the rotor judged to have lost thrust (any rotor count up to 12), ``?``
  uncertain, a space where there is no window (on the ground). The characters are the verdict's
  smoothed window labels, so the strip shows what the verdict saw; :func:`timeline_legend` words
  a rotor's character in the verdict's cause (:func:`~flightlog_fd.report.words.cause_words`).
- :func:`motor_panel`: the per-motor table of :mod:`flightlog_fd.report.motor_view`.
- :func:`window_table` (``--windows``): every window with its times, class, the probabilities of
  healthy and of each motor, phase.
- :func:`facts_line`: the log's facts, the model and the profile with its calibration sessions.
- :func:`summary_table`: one row per log when several logs are diagnosed (file names; the full
  path where two logs share a name), and one indented row per flight of a log holding several.
- :func:`render`: all of the above for one log onto a rich Console.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

from rich import box
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from ..advice import advice_line
from ..decision import CONFIDENCE_MEANING, THIN_TIMELINE_SHARE, not_seen_words
from ..diagnose import Diagnosis
from ..timeline import UNCERTAIN_LABEL, timeline_labels
from .motor_view import MotorView, class_names, short_position
from .words import cause_words

#: Characters in the timeline strip (fits an 80-column terminal with its time labels).
TIMELINE_WIDTH = 60
#: Timeline characters and styles per smoothed label: motors 1-9, then a, b, c for 10-12 (dodecahexa).
LABEL_CHARS = {UNCERTAIN_LABEL: "?", 0: ".", **{k: "123456789abc"[k - 1] for k in range(1, 13)}}
LABEL_STYLES = {UNCERTAIN_LABEL: "bold yellow", 0: "green", **{k: "bold red" for k in range(1, 13)}}
STATUS_STYLES = {"healthy": "bold green", "damaged": "bold red", "stopped": "bold red", "uncertain": "bold yellow",
                 "not_diagnosable": "bold magenta"}


def _motor_words(motor: int, position: Optional[str]) -> str:
    return f"{motor} ({position})" if position else f"{motor}"


def _propeller_cell(v) -> str:
    """The summary table's rotor cell: the damaged (stopped) motor, with its cause's tag where it
    is not the propeller ("1 (right), motor or ESC"), both of a pair (damaged or uncertain), else
    empty."""
    if v.pair and len(v.motors) > 1:
        return " + ".join(_motor_words(k, short_position(p) if p else None) for k, p in zip(v.motors, v.positions))
    tag = cause_words(v.cause).tag
    return (_motor_words(v.motor, v.position) + (f", {tag}" if tag else "")) if v.motor else ""


def confidence_words(confidence: float) -> str:
    """"confidence 0.93 (the probability that this verdict is right, ...)": the figure with its one
    meaning (:data:`~flightlog_fd.decision.CONFIDENCE_MEANING`), as every report states it."""
    return f"confidence {confidence:.2f} ({CONFIDENCE_MEANING})"


def verdict_sentence(diagnosis: Diagnosis) -> str:
    """The verdict in one plain sentence (also used as the HTML page's headline). A healthy verdict
    says whether the evidence saw the flight ("no sign of damage in N s of usable flight") or this
    log could not show damage (``Verdict.seen`` False: not a clearance, and what would make the next
    log decisive)."""
    v = diagnosis.verdict
    conf = confidence_words(v.confidence)
    if v.status == "damaged":
        first = f", first seen at t={v.first_seen:.1f} s" if v.first_seen is not None else ""
        if v.motor is None:
            return f"A propeller is damaged (no rotor named: inspect all), {conf}{first}"
        if v.pair and len(v.motors) > 1:
            return f"{v.propellers().capitalize()} damaged: inspect both, {conf}{first}"
        if v.cause == "motor_or_esc":
            return f"Motor {_motor_words(v.motor, v.position)} or its ESC is weak (not the propeller), {conf}{first}"
        if v.cause == "wash":
            return (f"Rotor {_motor_words(v.motor, v.position)} lost thrust to something in its wash (propeller and "
                    f"motor sound), {conf}{first}")
        return f"Propeller {_motor_words(v.motor, v.position)} damaged, {conf}{first}"
    if v.status == "healthy":
        tl = diagnosis.timeline
        n = tl.n_windows if tl else len(diagnosis.windows)
        if v.seen is False:
            covered = tl.covered_s if tl else None
            load = f"; {v.load['words']}" if v.cause == "load" and v.load else ""
            return f"Not seen: {not_seen_words(v.confidence, covered, diagnosis.log_kind)}{load}; {conf}"
        seen = f"in {tl.covered_s:.0f} s of usable flight" if tl else "in the vibration (the only evidence this log has)"
        thin = ""
        if tl is not None and n and tl.abstained_share >= THIN_TIMELINE_SHARE:
            thin = f" ({100 * tl.abstained_share:.0f} % of the model's windows uncertain: the other sources saw it, see below)"
        if v.cause == "load" and v.load:
            return f"No sign of propeller damage {seen}{thin}: {v.load['words']}, {conf}"
        return f"No sign of propeller damage {seen}{thin}, {conf}"
    if v.status == "uncertain":
        return f"Uncertain, {conf}: {v.reason}"
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


def timeline_legend(n_motors: int, cause) -> str:
    """The strip's legend; a rotor's characters in the verdict's cause's words
    (:func:`~flightlog_fd.report.words.cause_words`): "  . healthy   1-4 motor or ESC weak   ? uncertain"."""
    return f"  . healthy   1-{LABEL_CHARS[n_motors]} {cause_words(cause).lost}   ? uncertain"


def window_table(diagnosis: Diagnosis) -> Table:
    """Every window: start, end (s), the model's class, its probabilities (healthy ``p h``, then
    ``p1``..``pn`` for each motor; ".12" for 0.12, to fit an octocopter in 80 columns), phase,
    verdict label."""
    table = Table(title="Windows", box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 0))
    n = len(diagnosis.windows[0].probabilities) - 1 if diagnosis.windows else 0
    names = class_names(n)
    heads = ["start s", "end s", "class", "p h", *(f"p{k}" for k in range(1, n + 1)), "phase", "label"]
    for name in heads:
        table.add_column(name, justify="right" if name.startswith(("start", "end", "p")) and name != "phase"
                         else "left", no_wrap=True)
    for x in diagnosis.windows:
        table.add_row(f"{x.t_start:.2f}", f"{x.t_end:.2f}", names[x.cls],
                      *(_prob(p) for p in x.probabilities), x.phase,
                      Text(LABEL_CHARS[x.label], style=LABEL_STYLES[x.label]))
    return table


def _prob(p: float) -> str:
    """0.12 -> ".12", 1.0 -> "1.00" (a narrow probability column)."""
    t = f"{p:.2f}"
    return t[1:] if t.startswith("0.") else t


def summary_table(diagnoses: Sequence[Diagnosis]) -> Table:
    """One row per log: status, motor and position, confidence, first seen, exit code."""
    # A light box and short headers keep a row on one line in an 80-column terminal or a CI log.
    table = Table(title="Diagnosis summary", box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("log", overflow="fold")
    for name in ("verdict", "rotor", "conf.", "first seen", "exit"):
        table.add_column(name, no_wrap=True, min_width={"verdict": 9, "rotor": 15, "conf.": 5,
                                                        "first seen": 9, "exit": 4}[name],
                         justify="right" if name in ("conf.", "first seen", "exit") else "left")
    names = [Path(d.log).name for d in diagnoses]
    for d, name in zip(diagnoses, names):
        # The file name is enough unless two logs share it (same name in different folders).
        shown = name if names.count(name) == 1 else d.log
        v = d.verdict
        prop = _propeller_cell(v)
        conf = f"{v.confidence:.2f}" if v.status != "not_diagnosable" else ""
        first = f"t={v.first_seen:.1f} s" if v.first_seen is not None else ""
        table.add_row(Text(shown), Text(v.status, style=STATUS_STYLES.get(v.status, "")), Text(prop),
                      conf, first, str(d.exit_code))
        for sub in d.flights:  # each take-off to landing of a log holding several
            sv = sub.verdict
            table.add_row(Text(f"  {sub.part.split(',')[0]}"), Text(sv.status, style=STATUS_STYLES.get(sv.status, "")),
                          Text(_propeller_cell(sv)),
                          f"{sv.confidence:.2f}" if sv.status != "not_diagnosable" else "",
                          f"t={sv.first_seen:.1f} s" if sv.first_seen is not None else "", str(sub.exit_code))
    return table


def several_flights_words(diagnosis: Diagnosis) -> str:
    """How a log holding several flights was judged: from its windows as a whole (each flight no
    worse than the log), or each flight on its own from vibration (the log's verdict the worst)."""
    if diagnosis.windows:
        return "each judged from the whole log's windows (no flight is worse than the log's verdict)"
    return "each judged on its own from vibration (the log's verdict is the worst)"


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
    if diagnosis.profile is not None:
        parts.append(profile_words(diagnosis.profile))
        words = diagnosis.share_fit.configuration_words() if diagnosis.share_fit is not None else None
        if words:
            parts.append(words)
    return " | ".join(parts)


def profile_words(profile) -> str:
    """The profile used and how many calibration sessions it holds, e.g. "profile quad.json (3 sessions)"."""
    name = Path(profile.path).name if profile.path else "profile"
    n = int(getattr(profile, "sessions", 1) or 1)
    return f"profile {name} ({n} calibration session{'s' if n != 1 else ''})"


def motor_panel(diagnosis: Diagnosis, view: Optional[MotorView] = None) -> Table:
    """Per-motor findings table: what the verdict rests on, in numbers a pilot can check. A dash's
    reason is among the notes under it."""
    view = view or MotorView.of(diagnosis)
    t = Table(title=f"per-motor findings (commands against {view.against})", title_justify="left", box=None,
              padding=(0, 0, 0, 1), pad_edge=False, title_style="dim")
    header, rows = view.table(narrow=True)
    for h in header:
        t.add_column(h, justify="left" if h in ("pos", "share", "thrust %", "effect.") else "right", no_wrap=True)
    for row in rows:
        t.add_row(*[c.text for c in row])
    return t


def render(diagnosis: Diagnosis, console: Optional[Console] = None, *, show_windows: bool = False) -> Group:
    """Print (when ``console`` is given) and return the report for one log."""
    v = diagnosis.verdict
    parts: list = [Text(diagnosis.log, style="bold"),
                   Text(verdict_sentence(diagnosis), style=STATUS_STYLES.get(v.status, ""))]
    if v.status in ("damaged", "healthy", "uncertain", "stopped") and v.reason:
        parts.append(Text(f"  {v.reason}", style="dim"))
    if v.advice:
        parts.append(Text("  to resolve it:", style="bold"))
        for a in v.advice:
            parts.append(Text(f"  - {advice_line(a)}"))
    line = facts_line(diagnosis)
    if line:
        parts.append(Text(f"  {line}", style="dim"))
    if diagnosis.windows:
        parts.append(timeline_strip(diagnosis))
        n = len(diagnosis.windows[0].probabilities) - 1
        parts.append(Text(timeline_legend(n, v.cause), style="dim"))
    if diagnosis.flights:
        parts.append(Text(f"  {len(diagnosis.flights)} flights in this log, {several_flights_words(diagnosis)}:",
                          style="bold"))
        for sub in diagnosis.flights:
            parts.append(Text(f"  {sub.part}: {verdict_sentence(sub)}", style=STATUS_STYLES.get(sub.verdict.status, "")))
        parts.append(Text("  details of the whole log:" if diagnosis.windows else
                          f"  details of {diagnosis.verdict.reason.split(':')[0]}:", style="dim"))
    if diagnosis.decision is not None:
        view = MotorView.of(diagnosis)
        if view.rows:
            parts.append(motor_panel(diagnosis, view))
        for note in view.notes:
            parts.append(Text(f"  * {note}", style="dim"))
    if show_windows and diagnosis.windows:
        parts.append(window_table(diagnosis))
    for w in diagnosis.warnings:
        parts.append(Text(f"warning: {w}", style="yellow"))
    group = Group(*parts)
    if console is not None:
        console.print(group)
    return group
