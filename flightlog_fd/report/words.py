"""The verdict's cause in words: the one mapping every legend and label reads.

What: :func:`cause_words` turns ``decision.Verdict.cause`` (``"propeller"``, ``"motor_or_esc"``,
or None when no cause is known) into the words the reports put beside a rotor: the terminal's
timeline legend, the HTML page's background legend and likely-cause row, the CSV's
``verdict_cause`` column, the web flight page's legend and class traces, the summaries' tag after
a named motor (history, the fleet page). Why: the model's windows and the commands say that a
rotor lost thrust, not which part lost it; only the ESC relations (:mod:`flightlog_fd.cause`) tell
a propeller from a motor or ESC, so a legend says "propeller damaged" only when the verdict does.

Adding a cause (e.g. a load) is one more entry in :data:`CAUSE_WORDS`; everything else follows.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional


@dataclass(frozen=True)
class CauseWords:
    """One cause in words. ``lost``: a rotor's windows and class ("1-4 propeller damaged");
    ``one``: one named rotor, ``{k}`` its number ("motor {k} or its ESC weak"); ``likely``: the
    likely-cause row ("the motor or its ESC"); ``short``: a class trace's name ("P(prop 3)");
    ``tag``: what a summary adds after "motor 3" ("" where "motor 3" already says it all)."""

    lost: str
    one: str
    likely: str
    short: str
    tag: str

    def named(self, motor) -> str:
        """:attr:`one` for rotor ``motor``: "propeller 3 damaged"."""
        return self.one.format(k=motor)


#: Words per verdict cause (``decision.Verdict.cause``, ``cause.VERDICT_CAUSES``).
CAUSE_WORDS: dict[str, CauseWords] = {
    "propeller": CauseWords(lost="propeller damaged", one="propeller {k} damaged", likely="the propeller",
                            short="prop", tag=""),
    "motor_or_esc": CauseWords(lost="motor or ESC weak", one="motor {k} or its ESC weak", likely="the motor or its ESC",
                               short="motor/ESC", tag="motor or ESC"),
    # the rotor turns as its command asks (ESC rpm), yet needs more command: something under it
    "wash": CauseWords(lost="rotor lost thrust (something in its wash)", one="rotor {k} lost thrust (something in its wash)",
                       likely="something in the rotor's wash or under it (its propeller and motor look sound)",
                       short="rotor", tag="wash"),
    # a healthy verdict whose commands a moved load explains: the rotors' classes keep the unknown
    # cause's words (the model's classes are rotors); the likely-cause row and tag name the load
    "load": CauseWords(lost="rotor lost thrust (propeller, motor or ESC)",
                       one="rotor {k} lost thrust (propeller, motor or ESC)",
                       likely="a moved or added load (the propellers are healthy)", short="rotor", tag="load"),
}
#: No cause known (no ESC rpm, a pair, a healthy verdict): what the windows and commands do say.
UNKNOWN_CAUSE = CauseWords(lost="rotor lost thrust (propeller, motor or ESC)",
                           one="rotor {k} lost thrust (propeller, motor or ESC)", likely="unknown", short="rotor",
                           tag="")


def cause_words(cause: Optional[str]) -> CauseWords:
    """The words for ``cause`` (module docstring); :data:`UNKNOWN_CAUSE` for None or a cause this
    version does not know (a report stored by a newer one)."""
    return CAUSE_WORDS.get(cause or "", UNKNOWN_CAUSE)


__all__ = ["CauseWords", "CAUSE_WORDS", "UNKNOWN_CAUSE", "cause_words"]
