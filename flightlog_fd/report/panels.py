"""What a log's plots cannot show, in one line: the HTML report and the web flight page say which
streams the log lacks instead of drawing an empty panel (or failing on one).

What: :func:`missing_panels` lists, for a diagnosis with its flight, each stream that is not
drawn and why: angular rates, motor commands, the vibration level and the gyro spectrum
(:func:`flightlog_fd.report.vibration_view.vibration_and_gaps` gives their reasons), ESC
telemetry (rotor rpm), the model's windows. :func:`missing_line` words the list as one sentence.
Limits: a log that could not be read has no flight and no list (its verdict says why).
"""
from __future__ import annotations

from typing import Any, Sequence


def _empty(series: Any) -> bool:
    return series is None or len(series) == 0


def missing_panels(diagnosis: Any, vibration_gaps: Sequence[str]) -> list[str]:
    """Each stream the plots of ``diagnosis.flight`` cannot draw, with why ([] when every panel
    is drawn, or without a flight); ``vibration_gaps`` from ``vibration_and_gaps``."""
    fl = getattr(diagnosis, "flight", None)
    if fl is None:
        return []
    out = []
    if _empty(fl.rates):
        out.append("angular rates (not logged)")
    if _empty(fl.motors):
        out.append("motor commands (not logged)")
    out += list(vibration_gaps)
    if getattr(fl, "esc", None) is None:
        out.append("ESC telemetry (no rotor rpm: the cause, propeller or motor / ESC, cannot be told)")
    if not getattr(diagnosis, "windows", None):
        out.append("class probabilities (the model judged no window: see the reason)")
    return out


def missing_line(items: Sequence[str]) -> str:
    """"Not in this log, so not drawn: a; b." ("" for none)."""
    return f"Not in this log, so not drawn: {'; '.join(items)}." if items else ""


__all__ = ["missing_panels", "missing_line"]
