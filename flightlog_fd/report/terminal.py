"""Terminal report (rich): the verdict's headline first, then its cause, its evidence, what to do,
the flight, a timeline strip and the per-motor table; every line fits an 80-column terminal.

Inputs: :class:`~flightlog_fd.diagnose.Diagnosis` objects. Nothing here decides anything; it
only words and draws what the verdict says.

- :func:`verdict_sentence`: the verdict's headline (``Verdict.headline``, at most 100 characters:
  the status, the rotor, how much and what to do), the first line of every report.
- :func:`report_lines`: what follows it, in every report's order: the status and confidence, the
  cause line, the evidence clauses (each once), what to do (:mod:`flightlog_fd.advice`).
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
- :func:`summary_table`: one row per log when several logs are diagnosed (file names whole; the
  full path where two logs share a name), and one indented row per flight of a log holding several.
- :func:`confidence_legend`: what every confidence figure means, said once per run.
- :func:`render`: all of the above for one log onto a rich Console.

Prose is laid out with hanging indents (:func:`item`), so it wraps at the console's width even on
the CLI's soft-wrapping console; a command to copy stays one line (the terminal wraps it).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

from rich import box
from rich.console import Console, Group, RenderableType
from rich.table import Table
from rich.text import Text

from ..decision import headline as verdict_headline
from ..diagnose import Diagnosis
from ..timeline import UNCERTAIN_LABEL, timeline_labels
from .motor_view import MotorView, class_names, short_position
from .words import cause_line, cause_words, confidence_legend, evidence_clauses

#: Characters in the timeline strip (fits an 80-column terminal with its time labels).
TIMELINE_WIDTH = 60
#: Timeline characters and styles per smoothed label: motors 1-9, then a, b, c for 10-12 (dodecahexa).
LABEL_CHARS = {UNCERTAIN_LABEL: "?", 0: ".", **{k: "123456789abc"[k - 1] for k in range(1, 13)}}
LABEL_STYLES = {UNCERTAIN_LABEL: "bold yellow", 0: "green", **{k: "bold red" for k in range(1, 13)}}
STATUS_STYLES = {"healthy": "bold green", "damaged": "bold red", "stopped": "bold red", "uncertain": "bold yellow",
                 "not_diagnosable": "bold magenta"}


class Hanging:
    """``text`` after ``prefix`` with a hanging indent: wrapped at the console's width, its wrapped
    lines start under the text (a word longer than the line, a path, is folded); no trailing blanks."""

    def __init__(self, prefix: str, text, style: str = ""):
        self.prefix, self.style = prefix, style
        self.text = text if isinstance(text, Text) else Text(text, style=style)

    def __rich_console__(self, console: Console, options):
        width = max(options.max_width - len(self.prefix), 8)
        for i, line in enumerate(self.text.wrap(console, width, overflow="fold")):
            line.rstrip()
            yield Text(self.prefix if i == 0 else " " * len(self.prefix), style=self.style) + line

    def __rich_measure__(self, console: Console, options):
        from rich.measure import Measurement

        return Measurement(len(self.prefix) + 1, min(options.max_width, len(self.prefix) + self.text.cell_len))


def item(prefix: str, text, style: str = "") -> Hanging:
    """One report line: ``text`` after ``prefix``, wrapped with a hanging indent (:class:`Hanging`)."""
    return Hanging(prefix, text, style)


def verdict_sentence(diagnosis: Diagnosis) -> str:
    """The verdict's headline (``Verdict.headline``; made by :func:`flightlog_fd.decision.headline`
    for a verdict that carries none): the first line of every report, at most 100 characters. Also
    the HTML page's first line, the web flight page's and the watcher's."""
    v = diagnosis.verdict
    return v.headline or verdict_headline(v)


def status_words(diagnosis: Diagnosis) -> str:
    """The status name and its confidence, "damaged, confidence 0.97" ("not_diagnosable" alone):
    the line under the headline (what the figure means is in the legend, :func:`confidence_legend`)."""
    v = diagnosis.verdict
    return v.status if v.status == "not_diagnosable" else f"{v.status}, confidence {v.confidence:.2f}"


def verdict_details(v) -> list[RenderableType]:
    """The lines under the headline and status, in every report's order: the cause line, the
    evidence clauses (each once), what to do (a command on a line of its own, to copy whole)."""
    out: list[RenderableType] = []
    cause = cause_line(v)
    if cause:
        out.append(item("  ", cause))
    clauses = evidence_clauses(v)
    if clauses:
        out.append(Text("  evidence:", style="bold"))
        out += [item("  - ", c) for c in clauses]
    if v.advice:
        out.append(Text("  to do:", style="bold"))
        for a in v.advice:
            out.append(item("  - ", a.text + (":" if a.command else "")))
            if a.command:
                out.append(Text(f"      {a.command}"))
    return out


def _motor_words(motor: int, position: Optional[str]) -> str:
    return f"{motor} ({position})" if position else f"{motor}"


def verdict_cell(v) -> str:
    """The summary table's verdict cell: the status and the rotors it names with short positions,
    "damaged 3 FL", "uncertain 1 FR+4 RR" (a pair), "healthy"."""
    named = list(v.motors) if v.pair and len(v.motors) > 1 else ([v.motor] if v.motor else [])
    pos = {k: p for k, p in zip(v.motors, v.positions) if p}
    if v.motor and v.position:
        pos.setdefault(v.motor, v.position)
    rotors = "+".join(f"{k} {short_position(pos[k])}" if pos.get(k) else f"{k}" for k in named)
    return f"{v.status} {rotors}".rstrip()


def cause_cell(v) -> str:
    """The summary table's cause cell: "propeller", "motor or ESC", "in its wash", "load"; "" unknown."""
    return cause_words(v.cause).tag if v.cause else ""


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
    (:func:`~flightlog_fd.report.words.cause_words`): ". healthy   ? uncertain   1-4 motor or ESC weak"."""
    return f". healthy   ? uncertain   1-{LABEL_CHARS[n_motors]} {cause_words(cause).lost}"


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
    """One row per log: file name, verdict (status and rotors), cause, confidence, exit code; one
    indented row per flight of a log holding several. The file name is never cut: the other
    columns are narrow enough for names of 35 characters in 80 columns (a longer one folds)."""
    table = Table(title="Diagnosis summary", box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("log", overflow="fold")
    for name in ("verdict", "cause", "conf.", "exit"):
        table.add_column(name, no_wrap=True, justify="right" if name in ("conf.", "exit") else "left")
    names = [Path(d.log).name for d in diagnoses]
    for d, name in zip(diagnoses, names):
        # The file name is enough unless two logs share it (same name in different folders).
        shown = name if names.count(name) == 1 else d.log
        rows = [(Text(shown), d)] + [(Text(f"  {sub.part.split(',')[0]}"), sub) for sub in d.flights]
        for label, x in rows:  # each take-off to landing of a log holding several, under it
            v = x.verdict
            table.add_row(label, Text(verdict_cell(v), style=STATUS_STYLES.get(v.status, "")), cause_cell(v),
                          f"{v.confidence:.2f}" if v.status != "not_diagnosable" else "", str(x.exit_code))
    return table


def legend(text: Optional[str] = None) -> Table:
    """The confidence legend line (:func:`~flightlog_fd.report.words.confidence_legend`), dim."""
    return item("", text or confidence_legend(), "dim")


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
    title = "per-motor findings" + (f" (commands against {view.against})" if view.against else "")
    t = Table(title=title, title_justify="left", box=None, padding=(0, 0, 0, 1), pad_edge=False, title_style="dim",
              min_width=len(title))  # a narrow table (weights only) would fold its title
    header, rows = view.table(narrow=True)
    for h in header:
        t.add_column(h, justify="left" if h in ("pos", "share", "thrust %", "effect.") else "right", no_wrap=True)
    for row in rows:
        t.add_row(*[c.text for c in row])
    return t


def render(diagnosis: Diagnosis, console: Optional[Console] = None, *, show_windows: bool = False,
           with_legend: bool = True) -> Group:
    """Print (when ``console`` is given) and return the report for one log: the headline, the status
    and confidence with the log's path, the cause, the evidence, what to do, the log's facts, the
    timeline, its flights, the per-motor table, the windows (``show_windows``), warnings, and
    (``with_legend``; the CLI says it once under the summary of several logs) the confidence legend."""
    v = diagnosis.verdict
    parts: list = [item("", verdict_sentence(diagnosis), STATUS_STYLES.get(v.status, "bold")),
                   item("  ", f"{status_words(diagnosis)} | {diagnosis.log}", "dim"), *verdict_details(v)]
    line = facts_line(diagnosis)
    if line:
        parts.append(item("  ", line, "dim"))
    if diagnosis.windows:
        parts.append(timeline_strip(diagnosis))
        n = len(diagnosis.windows[0].probabilities) - 1
        parts.append(item("  ", timeline_legend(n, v.cause), "dim"))
    if diagnosis.flights:
        parts.append(item("  ", f"{len(diagnosis.flights)} flights in this log, {several_flights_words(diagnosis)}:",
                          "bold"))
        for sub in diagnosis.flights:
            parts.append(item("  - ", f"{sub.part}: {verdict_sentence(sub)} ({status_words(sub)})",
                              STATUS_STYLES.get(sub.verdict.status, "")))
        parts.append(item("  ", "details of the whole log:" if diagnosis.windows else
                          f"details of {diagnosis.verdict.reason.split(':')[0]}:", "dim"))
    if diagnosis.decision is not None:
        view = MotorView.of(diagnosis)
        if view.rows:
            parts.append(motor_panel(diagnosis, view))
        for note in view.notes_beside(evidence_clauses(v)):
            parts.append(item("  * ", note, "dim"))
    if show_windows and diagnosis.windows:
        parts.append(window_table(diagnosis))
    for w in diagnosis.warnings:
        parts.append(item("warning: ", w, "yellow"))
    if with_legend and v.status != "not_diagnosable":
        parts.append(legend())
    group = Group(*parts)
    if console is not None:
        console.print(group)
    return group
