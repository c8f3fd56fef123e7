"""The effectiveness fit as evidence: angular acceleration per unit command, relative to the others.

Input: :func:`.effectiveness_fit.estimate_effectiveness` (computed once by the diagnose
pipeline on the windows' segments; ``ShareFit.effectiveness``). Finding per motor:
``effectiveness`` (1 = as effective as its neighbours) with its 90 % block-bootstrap interval
and its LLR: likelihood of the value under a damaged rotor (eta uniform on the severity grid)
against a healthy one (1), with the interval widened by ``EFFECTIVENESS_SIGMA_FLOOR``.
Limits: abstains when the fit says the flight did not manoeuvre enough, or when it is physically
inconsistent (a motor below ``EFFECTIVENESS_SANE_MIN``: wrong motor map, saturation); in closed
loop it understates damage (about 5 points at eta 0.6-0.7 on simulated flights).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .base import Analyzer, AnalyzerResult, Context, Finding
from .command_shares import ETA_GRID

#: Floor on the estimate's standard deviation: its closed-loop bias toward 1 (~0.05 on simulated
#: flights) and the spread of real healthy motors at 10 Hz logging (0.78 seen on Erle flights).
EFFECTIVENESS_SIGMA_FLOOR = 0.08
#: A fit with any motor below this is physically inconsistent: it is never used.
EFFECTIVENESS_SANE_MIN = 0.2


def effectiveness_usable(eff) -> bool:
    """An informative, physically consistent effectiveness estimate."""
    return bool(eff is not None and eff.informative and eff.motors
                and np.all(np.isfinite(eff.values)) and np.all(eff.values > EFFECTIVENESS_SANE_MIN))


def effectiveness_llr(eff) -> Optional[np.ndarray]:
    """(n,) LLR per motor from an informative effectiveness fit, or None when it says nothing."""
    if not effectiveness_usable(eff):
        return None
    v = eff.values
    ci = eff.ci
    sd = np.sqrt(((ci[:, 1] - ci[:, 0]) / 3.29) ** 2 + EFFECTIVENESS_SIGMA_FLOOR ** 2)
    out = []
    for x, s in zip(v, sd):
        dens = np.exp(-0.5 * ((x - ETA_GRID) / s) ** 2).mean()
        out.append(float(np.log(max(dens, 1e-300)) + 0.5 * ((x - 1.0) / s) ** 2))
    return np.array(out)


class Effectiveness(Analyzer):
    id = "effectiveness"
    description = "angular acceleration per unit command, relative to the other motors (when the flight manoeuvred)"
    requires = ("rates", "motors")
    #: Angular acceleration is a derivative of the rate stream: its reliability follows the rates.
    reliability_keys = ("rate",)

    def analyze(self, ctx: Context) -> AnalyzerResult:
        eff = None if ctx.share_fit is None else ctx.share_fit.effectiveness
        if eff is None or not eff.motors:
            why = getattr(eff, "reason", "") if eff is not None else ""
            return AnalyzerResult(self.id, abstained=self.missing(ctx.flight) or why or "no effectiveness fit")
        if not eff.informative:
            return AnalyzerResult(self.id, abstained=eff.reason)
        llr = effectiveness_llr(eff)
        if llr is None:
            return AnalyzerResult(self.id, abstained=f"the fit is physically inconsistent (a motor below "
                                                     f"{EFFECTIVENESS_SANE_MIN})")
        return AnalyzerResult(self.id, [
            Finding(self.id, k + 1, "effectiveness", float(m.effectiveness), "of neighbours",
                    (float(m.ci[0]), float(m.ci[1])), 1.0, "down", float(llr[k]),
                    f"{m.effectiveness:.2f} {_short(m.ci[0])}-{_short(m.ci[1])}")
            for k, m in enumerate(eff.motors)])


def _short(x: float) -> str:
    """0.77 -> ".77" (narrow interval bounds for an 80-column table)."""
    t = f"{x:.2f}"
    return t[1:] if t.startswith("0.") else t
