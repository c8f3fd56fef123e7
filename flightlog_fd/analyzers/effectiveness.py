"""The effectiveness fit as evidence: angular acceleration per unit command, relative to the others.

Input: :func:`.effectiveness_fit.estimate_effectiveness` (computed once by the diagnose
pipeline on the windows' segments; ``ShareFit.effectiveness``). Finding per motor:
``effectiveness`` (1 = as effective as its neighbours) with its 90 % block-bootstrap interval
and its LLR: likelihood of the value under a damaged rotor (eta uniform on the severity grid)
against a healthy one (1), with the interval widened by ``EFFECTIVENESS_SIGMA_FLOOR``; per pair
of motors, the same with both weak (:func:`effectiveness_pair_llrs`).
Limits: abstains when the fit says the flight did not manoeuvre enough, or when it is physically
inconsistent (a motor below ``EFFECTIVENESS_SANE_MIN``: wrong motor map, saturation); in closed
loop it understates damage (about 5 points at eta 0.6-0.7 on simulated flights).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .base import Analyzer, AnalyzerResult, Context, Finding
from .command_shares import ETA_GRID, PAIR_ETA_GRID, all_pairs
from .effectiveness_fit import relative_to_others

#: Floor on the estimate's standard deviation: its closed-loop bias toward 1 (~0.05 on simulated
#: flights) and the spread of real healthy motors at 10 Hz logging (0.78 seen on Erle flights).
EFFECTIVENESS_SIGMA_FLOOR = 0.08
#: A fit with any motor below this is physically inconsistent: it is never used.
EFFECTIVENESS_SANE_MIN = 0.2


def effectiveness_usable(eff) -> bool:
    """An informative, physically consistent effectiveness estimate."""
    return bool(eff is not None and eff.informative and eff.motors
                and np.all(np.isfinite(eff.values)) and np.all(eff.values > EFFECTIVENESS_SANE_MIN))


def _log_mean_exp_half_neg(chi: np.ndarray) -> float:
    """log(mean(exp(-chi / 2))) without underflow."""
    top = -0.5 * float(np.min(chi))
    return top + float(np.log(np.mean(np.exp(-0.5 * chi - top))))


def effectiveness_eta_llr(eff, frame=None) -> Optional[np.ndarray]:
    """(n, len(ETA_GRID)) per motor and per eta of the shared grid: the log-likelihood ratio of
    "rotor k gives eta of its thrust" against healthy from an informative effectiveness fit (None
    when it says nothing); every motor's value predicted through the estimator's own normalisation
    (:func:`.effectiveness_fit.relative_to_others`): on a quad X the others read 1 either way; on a
    quad + the weak rotor's partner on its axis reads 1/eta."""
    if not effectiveness_usable(eff):
        return None
    v = np.asarray(eff.values, float)
    ci = np.asarray(eff.ci, float)
    n = len(v)
    sd = np.sqrt(((ci[:, 1] - ci[:, 0]) / 3.29) ** 2 + EFFECTIVENESS_SIGMA_FLOOR ** 2)
    healthy_chi = float(np.sum(((v - 1.0) / sd) ** 2))
    out = []
    for k in range(n):
        e = np.ones((len(ETA_GRID), n))
        e[:, k] = ETA_GRID
        chi = np.sum(((v - relative_to_others(e, frame)) / sd) ** 2, axis=-1)
        out.append(-0.5 * chi + 0.5 * healthy_chi)
    return np.array(out)


def effectiveness_llr(eff, frame=None) -> Optional[np.ndarray]:
    """(n,) LLR per motor from an informative effectiveness fit, or None when it says nothing:
    "rotor k at eta" (uniform on ETA_GRID) against healthy (:func:`effectiveness_eta_llr` averaged
    over the grid)."""
    per_eta = effectiveness_eta_llr(eff, frame)
    if per_eta is None:
        return None
    return np.array([_log_mean_exp(row) for row in per_eta])


def _log_mean_exp(a: np.ndarray) -> float:
    top = float(np.max(a))
    return top + float(np.log(np.mean(np.exp(a - top))))


def effectiveness_pair_llrs(eff, frame=None) -> dict:
    """{(a, b): nats} from an informative effectiveness fit: "rotors a and b lost thrust" (both
    efficiencies uniform on PAIR_ETA_GRID) against healthy. The estimate is relative (per axis,
    each motor against the median of the others with a lever on that axis), so the prediction
    goes through the same normalisation (:func:`.effectiveness_fit.relative_to_others`): on a quad X
    each weak rotor reads its own efficiency and the healthy ones 1 / the larger of the two; on a
    quad + two rotors on one axis read 1 (an axis whose rotors are all weak looks like a weaker
    axis), so such a pair gets no evidence here, for or against."""
    if not effectiveness_usable(eff):
        return {}
    v = np.asarray(eff.values, float)
    ci = np.asarray(eff.ci, float)
    n = len(v)
    sd = np.sqrt(((ci[:, 1] - ci[:, 0]) / 3.29) ** 2 + EFFECTIVENESS_SIGMA_FLOOR ** 2)
    ea, eb = np.meshgrid(PAIR_ETA_GRID, PAIR_ETA_GRID, indexing="ij")
    healthy_chi = float(np.sum(((v - 1.0) / sd) ** 2))
    out = {}
    for a, b in all_pairs(n):
        e = np.ones(ea.shape + (n,))
        e[..., a - 1] = ea
        e[..., b - 1] = eb
        pred = relative_to_others(e, frame)  # (E, E, n)
        chi = np.sum(((v - pred) / sd) ** 2, axis=-1)
        out[(a, b)] = _log_mean_exp_half_neg(chi) + 0.5 * healthy_chi
    return out


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
        per_eta = effectiveness_eta_llr(eff, ctx.frame)
        llr = None if per_eta is None else np.array([_log_mean_exp(row) for row in per_eta])
        if llr is None:
            return AnalyzerResult(self.id, abstained=f"the fit is physically inconsistent (a motor below "
                                                     f"{EFFECTIVENESS_SANE_MIN})")
        return AnalyzerResult(self.id, [
            Finding(self.id, k + 1, "effectiveness", float(m.effectiveness), "of neighbours",
                    (float(m.ci[0]), float(m.ci[1])), 1.0, "down", float(llr[k]),
                    f"{m.effectiveness:.2f} {_short(m.ci[0])}-{_short(m.ci[1])}")
            for k, m in enumerate(eff.motors)], pair_llrs=effectiveness_pair_llrs(eff, ctx.frame),
            eta_llr={k + 1: per_eta[k] for k in range(len(eff.motors))})


def _short(x: float) -> str:
    """0.77 -> ".77" (narrow interval bounds for an 80-column table)."""
    t = f"{x:.2f}"
    return t[1:] if t.startswith("0.") else t
