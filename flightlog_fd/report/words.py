"""The verdict in words: the cause's words every legend and label reads, the evidence clauses, and
the one legend line for confidence.

What: :func:`cause_words` turns ``decision.Verdict.cause`` (``"propeller"``, ``"motor_or_esc"``,
``"wash"``, ``"load"``, or None when no cause is known) into the words the reports put beside a
rotor: the terminal's timeline legend and cause line, the HTML page's background legend and cause
line, the CSV's ``verdict_cause`` column, the web flight page's legend and class traces, the
summaries' tag after a named motor (history, the fleet page). Why: the model's windows and the
commands say that a rotor lost thrust, not which part lost it; only a source that does not read the
commands (ESC rpm, a vibration line tied to a rotor) tells a propeller from a motor or ESC, so a
legend says "propeller damaged" only when the verdict does.

:func:`evidence_clauses` splits ``Verdict.reason`` into its clauses (the decision joins them with
"; ") without the one the cause line already says, so every report lists each clause once;
:func:`cause_line` is that cause line; :func:`confidence_legend` the one place a report states what
confidence means (:data:`~flightlog_fd.decision.CONFIDENCE_MEANING`).

Adding a cause is one more entry in :data:`CAUSE_WORDS`; everything else follows.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional


@dataclass(frozen=True)
class CauseWords:
    """One cause in words. ``lost``: a rotor's windows and class ("1-4 propeller damaged");
    ``one``: one named rotor, ``{k}`` its number ("motor {k} or its ESC weak"); ``likely``: the
    cause line ("the motor or its ESC"); ``short``: a class trace's name ("P(prop 3)");
    ``tag``: what a summary adds after "motor 3" ("" where "motor 3" already says it all)."""

    lost: str
    one: str
    likely: str
    short: str
    tag: str

    def named(self, motor) -> str:
        """:attr:`one` for rotor ``motor``: "propeller 3 damaged"."""
        return self.one.format(k=motor)


#: No cause known (no ESC rpm, no vibration line tied to the rotor, a pair, a healthy verdict):
#: what the windows and commands do say, every part that can take a rotor's thrust named.
UNKNOWN_CAUSE = CauseWords(lost="rotor lost thrust (propeller, motor or ESC, or something in its wash)",
                           one="rotor {k} lost thrust (propeller, motor or ESC, or something in its wash)",
                           likely="unknown", short="rotor", tag="")
#: Words per verdict cause (``decision.Verdict.cause``; the JSON schema's ``verdict.cause`` enum).
CAUSE_WORDS: dict[str, CauseWords] = {
    "propeller": CauseWords(lost="propeller damaged", one="propeller {k} damaged", likely="the propeller",
                            short="prop", tag="propeller"),
    "motor_or_esc": CauseWords(lost="motor or ESC weak", one="motor {k} or its ESC weak", likely="the motor or its ESC",
                               short="motor/ESC", tag="motor or ESC"),
    "wash": CauseWords(lost="rotor lost thrust (something in its wash or under it)",
                       one="rotor {k} lost thrust (something in its wash or under it)",
                       likely="something in its wash or under it", short="rotor", tag="in its wash"),
    # a healthy verdict whose commands a moved load explains: the rotors' classes keep the unknown
    # cause's words (the model's classes are rotors); the cause line and tag name the load
    "load": CauseWords(lost=UNKNOWN_CAUSE.lost, one=UNKNOWN_CAUSE.one,
                       likely="a moved or added load (the propellers are healthy)", short="rotor", tag="load"),
}


def cause_words(cause: Optional[str]) -> CauseWords:
    """The words for ``cause`` (module docstring); :data:`UNKNOWN_CAUSE` for None or a cause this
    version does not know (a report stored by a newer one)."""
    return CAUSE_WORDS.get(cause or "", UNKNOWN_CAUSE)


def _get(v: Any, name: str) -> Any:
    """A verdict's field, from a :class:`~flightlog_fd.decision.Verdict` or its JSON dict."""
    return v.get(name) if isinstance(v, dict) else getattr(v, name, None)


def split_clauses(text: str) -> list[str]:
    """``text`` split at each "; " outside brackets ("(a; b); c" is two clauses), blanks dropped."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth = max(depth - 1, 0)
        elif ch == ";" and depth == 0 and text[i + 1:i + 2] in (" ", ""):
            out.append(text[start:i].strip())
            start = i + 1
    out.append(text[start:].strip())
    return [c for c in out if c]


def cause_line(v: Any) -> str:
    """"cause: the motor or its ESC is weak, not the propeller: it turns 25 % slower ...", "cause:
    unknown: the log has no ESC telemetry, ..." for a verdict naming one rotor (or a moved load), its
    probability in brackets when the verdict states one; "" when it states no cause line (healthy without a load, stopped, not diagnosable).
    ``v``: a Verdict or the JSON report's ``verdict``."""
    ev, cause, load = _get(v, "cause_evidence"), _get(v, "cause"), _get(v, "load")
    if cause == "load" and load:
        return f"cause: {cause_words('load').likely}: {load.get('words', '')}".rstrip(": ")
    if not ev or _get(v, "status") not in ("damaged", "uncertain"):
        return ""
    p = _get(v, "cause_probability")
    sure = f" (probability {p:.2f})" if cause and isinstance(p, (int, float)) else ""
    likely, why = cause_words(cause).likely, ev.get("reason") or ""
    text = why if why.startswith(likely) else f"{likely}: {why}".rstrip(": ")
    return f"cause{sure}: {text}"


def evidence_clauses(v: Any) -> list[str]:
    """The clauses of the verdict's reason, each once, without the cause clause (:func:`cause_line`
    says it); a not-diagnosable verdict's reason only when its headline cut it short."""
    reason = _get(v, "reason") or ""
    if _get(v, "status") == "not_diagnosable":  # the headline says why, unless it had to cut the reason short
        return [] if reason in (_get(v, "headline") or "") else [reason]
    ev = _get(v, "cause_evidence") or {}
    cause_said = {f"cause: {ev.get('reason')}", ev.get("reason")} if ev.get("reason") else set()
    out: list[str] = []
    for c in split_clauses(reason):
        if c not in cause_said and c not in out:
            out.append(c)
    return out


def confidence_legend() -> str:
    """"confidence: the probability that this verdict is right, ...": the one line a report states
    what its confidence figures mean."""
    from ..decision import CONFIDENCE_MEANING

    return f"confidence: {CONFIDENCE_MEANING}"


__all__ = ["CauseWords", "CAUSE_WORDS", "UNKNOWN_CAUSE", "cause_words", "split_clauses", "cause_line",
           "evidence_clauses", "confidence_legend"]
