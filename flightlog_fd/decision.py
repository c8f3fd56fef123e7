"""The flight verdict: one decision model over every analyzer's findings.

For each motor k it weighs "rotor k lost thrust" against "healthy, with this airframe's normal
trim drift": the log-likelihood ratios (LLR, nats) of the registered analyzers'
(:mod:`flightlog_fd.analyzers`) findings are summed per motor, each analyzer's total clipped to
its ``llr_cap`` (``analyzers.base.SOURCE_LLR_CAP`` unless the analyzer says otherwise; the command
shares are capped keeping their order, so a weak rotor stays apart from its coaxial partner,
``Analyzer.cap_keeps_order``). The sources today: the model's window votes, the command
shares (mixer-physics severity fit, which also gives each rotor's thrust eta-hat), the throttle
against calibration, the effectiveness fit when it is informative, and ESC telemetry where the
log has it (a Bayes factor that can also clear a motor). Their noise figures are measured and
written beside their constants in their own modules.

The flight's verdict, confidence and reason come from here alone (:func:`decide`): ``damaged``
when the best motor's total LLR reaches ``DAMAGED_LLR`` and beats the runner-up by
``SEPARATION_LLR`` and its command share rose against its baseline (a weak rotor must need more);
``uncertain`` from ``UNCERTAIN_LLR`` (the reason names the motor to inspect,
or the two it cannot tell apart); ``healthy`` below. "Airframe changed" (re-calibrate) is said
only when the shares moved beyond the drift AND no single rotor explains the move; a motor whose
excess is beyond the drift is named for inspection first. The confidence is the posterior
probability of the verdict's hypothesis among {healthy, motor 1..n} with a flat prior.

Limits: one damaged rotor per flight; the sources are treated as independent (the model sees the
same commands the command analyzer weighs, which is why each source is capped).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .analyzers import AnalyzerResult, Context, run_analyzers
from .flight import Frame

#: Total LLR (nats) at which one motor is called damaged: about 3 nats (20 times more likely)
#: above the largest total of any motor on the 18 real healthy flights without a profile (3.1,
#: Erle 15-10-2014_42; benchmarks/bench_real_damage.py), so none of them is called damaged.
DAMAGED_LLR = 6.0
#: The named motor must beat every other motor by this much (e^2 ~ 7 times more likely).
SEPARATION_LLR = 2.0
#: From this total LLR the flight is "uncertain" and the reason names what to inspect: half a nat
#: above that largest healthy total (3.1), so those 18 flights stay healthy.
UNCERTAIN_LLR = 3.5
#: A damaged verdict needs the named motor's command share to have risen against its baseline
#: whenever the command analyzer weighed in: a rotor that lost thrust must need more command in
#: closed loop (physics, not a fitted figure), so a motor named while its command fell is at most
#: "uncertain". (CrazyPAD E9 cut_M3_2mm logs 03-05 with a profile: the adapted model leans to
#: motor 1, whose command fell; the cut propeller is motor 2.)
#: Chi-square (per share degree of freedom) above which the healthy hypothesis fails: the shares
#: moved beyond the drift (p < 0.01 with 3 degrees of freedom: 11.3 / 3).
AIRFRAME_CHANGE_CHI2_PER_DOF = 3.8


@dataclass
class MotorDecision:
    """One motor's part in the decision (the report's per-motor severity and weight)."""

    motor: int
    llr: float  # total, nats
    llr_by_source: dict  # analyzer id -> nats
    eta_hat: Optional[float]  # thrust efficiency (1 = healthy), None when the shares are not weighed
    eta_ci: Optional[tuple[float, float]]
    weight: float  # posterior probability of "this rotor lost thrust" among {healthy, 1..n}

    def as_dict(self) -> dict:
        r = lambda x: None if x is None or not np.isfinite(x) else round(float(x), 4)  # noqa: E731
        return {"motor": self.motor, "llr": r(self.llr),
                "llr_by_source": {k: r(v) for k, v in self.llr_by_source.items()},
                "eta_hat": r(self.eta_hat),
                "eta_ci": None if self.eta_ci is None else [r(self.eta_ci[0]), r(self.eta_ci[1])],
                "weight": r(self.weight)}


@dataclass
class Decision:
    """The decision model's output: verdict fields, per-motor details and the analyzers' results."""

    status: str
    motor: Optional[int]
    confidence: float
    reason: str
    motors: list[MotorDecision] = field(default_factory=list)
    airframe_changed: Optional[str] = None
    healthy_chi2: Optional[float] = None
    share_sigma: Optional[float] = None
    sources: list[str] = field(default_factory=list)  # the analyzers that weighed in
    results: list[AnalyzerResult] = field(default_factory=list)


def _words(frame: Optional[Frame], motor: int) -> str:
    pos = frame.position(motor) if frame is not None else None
    return f"motor {motor} ({pos})" if pos else f"motor {motor}"


def _finding(results: Sequence[AnalyzerResult], analyzer: str, name: str, motor: int):
    for r in results:
        if r.analyzer == analyzer:
            for f in r.findings:
                if f.name == name and f.motor == motor:
                    return f
    return None


def _airframe_changed(results: Sequence[AnalyzerResult], n: int, best: int) -> Optional[str]:
    """Words for "the shares moved beyond the drift and no single rotor explains it", else None."""
    cmd = next((r for r in results if r.analyzer == "commands" and not r.abstained), None)
    if cmd is None or cmd.extra.get("baseline") != "profile":
        return None
    dof = max(n - 1, 1) + (1 if cmd.extra.get("with_throttle") else 0)
    if cmd.extra["healthy_chi2"] / dof <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    if cmd.extra["fit_chi2"][best] / max(dof - 1, 1) <= AIRFRAME_CHANGE_CHI2_PER_DOF:
        return None
    shares = [_finding(results, "commands", "share", k + 1) for k in range(n)]
    text = "the command shares moved in a pattern no single rotor explains: " + ", ".join(
        f"motor {k + 1} {100 * (f.value - f.baseline):+.0f} %" for k, f in enumerate(shares) if f is not None)
    thr = _finding(results, "throttle", "throttle", 1)
    if thr is not None:
        text += f"; throttle {100 * (thr.value - 1):+.0f} % against calibration"
    return text


def decide(results: Sequence[AnalyzerResult], n_motors: int, frame: Optional[Frame] = None,
           first_seen: Optional[float] = None, describe=None) -> Decision:
    """The flight's decision from the analyzers' results (module docstring). ``first_seen`` goes
    into the reason; ``describe(k)`` gives plain words for motor k's command figures to cite."""
    n = n_motors
    sources = {r.analyzer: r.llr(n) for r in results}
    sources = {k: v for k, v in sources.items() if v is not None}
    total = np.sum(list(sources.values()), axis=0) if sources else np.zeros(n)
    logits = np.concatenate([[0.0], total])
    w = np.exp(logits - logits.max())
    w = w / w.sum()
    motors = []
    for k in range(n):
        thrust = _finding(results, "commands", "thrust", k + 1)
        motors.append(MotorDecision(
            motor=k + 1, llr=float(total[k]), llr_by_source={s: float(v[k]) for s, v in sources.items()},
            eta_hat=None if thrust is None else thrust.value, eta_ci=None if thrust is None else thrust.interval,
            weight=float(w[k + 1])))
    order = np.argsort(-total)
    best = int(order[0])
    second = int(order[1]) if n > 1 else None
    kb = best + 1
    lead = float(total[best] - (total[second] if second is not None else -np.inf))
    airframe_changed = _airframe_changed(results, n, best)
    cmd = next((r for r in results if r.analyzer == "commands"), None)
    notes = [note for r in results for note in r.notes]

    def severity_words(k: int) -> str:
        m = motors[k - 1]
        if m.eta_hat is None or m.eta_ci is None:
            return ""
        lo, hi = m.eta_ci
        return f"gives about {100 * m.eta_hat:.0f} % of its normal thrust [{100 * lo:.0f}-{100 * hi:.0f} %]"

    def evidence_words(k: int) -> str:
        parts = [f"{s} {v[k - 1]:+.1f}" for s, v in sources.items()]
        cite = f"it {describe(k)}; " if describe is not None and "commands" in sources else ""
        return cite + "evidence for it (log-likelihood ratio, nats): " + ", ".join(parts)

    def done(status, motor, confidence, reason) -> Decision:
        for note in notes:
            reason += f"; {note}"
        return Decision(status, motor, float(confidence), reason, motors=motors, airframe_changed=airframe_changed,
                        healthy_chi2=None if cmd is None else cmd.extra.get("healthy_chi2"),
                        share_sigma=None if cmd is None else cmd.extra.get("share_sigma"),
                        sources=list(sources), results=list(results))

    share = _finding(results, "commands", "share", kb)
    unsupported = share is not None and share.baseline is not None and share.value <= share.baseline
    if total[best] >= DAMAGED_LLR and lead >= SEPARATION_LLR and unsupported:
        return done("uncertain", None, w[kb],
                    f"the evidence points at {_words(frame, kb)} ({total[best]:+.1f} nats), but its command share "
                    f"did not rise as a rotor that lost thrust must ({share.value:.3f} against {share.baseline:.3f}); "
                    f"{evidence_words(kb)}; inspect propeller {kb} and the others")
    if total[best] >= DAMAGED_LLR and lead >= SEPARATION_LLR:
        since = f" from t={first_seen:.1f} s" if first_seen is not None else ""
        sev = severity_words(kb)
        return done("damaged", kb, w[kb], f"{_words(frame, kb)} lost thrust{since}" + (f": it {sev}" if sev else "")
                    + f"; {evidence_words(kb)}; inspect propeller {kb}")
    if total[best] >= UNCERTAIN_LLR:
        if lead < SEPARATION_LLR and second is not None and total[second] >= UNCERTAIN_LLR:
            k2 = second + 1
            reason = (f"the evidence points at {_words(frame, kb)} ({total[best]:+.1f} nats) or "
                      f"{_words(frame, k2)} ({total[second]:+.1f}) and cannot tell them apart; "
                      f"inspect propellers {kb} and {k2}")
        else:
            sev = severity_words(kb)
            reason = (f"{_words(frame, kb)} may have lost thrust" + (f" (it {sev})" if sev else "")
                      + f", but the evidence is too weak to call ({total[best]:+.1f} nats, damage needs "
                      f"{DAMAGED_LLR:.0f}); {evidence_words(kb)}; inspect propeller {kb}")
        if airframe_changed:
            reason += f"; also {airframe_changed}: after the inspection, re-calibrate"
        return done("uncertain", None, w[kb], reason)
    if airframe_changed:
        return done("uncertain", None, w[0],
                    f"no rotor explains the change since calibration ({airframe_changed}): the airframe itself "
                    f"changed (payload, battery, a re-trim); check the propellers, then re-calibrate on a "
                    f"healthy flight")
    return done("healthy", None, w[0], f"no rotor lost thrust: the strongest case is {_words(frame, kb)} at "
                                       f"{total[best]:+.1f} nats (damage needs {DAMAGED_LLR:.0f})")


def flight_verdict(model_verdict, t_start, t_end, probs, evidence, frame: Optional[Frame] = None, *,
                   flight=None, profile=None, segments=(), analyzers=None, model_sha256: str = ""):
    """The flight's :class:`~flightlog_fd.verdict.Verdict` and :class:`Decision` from the model's
    window verdict (timeline labels, mid-flight onset), the window probabilities, the per-motor
    evidence (:class:`~flightlog_fd.analyzers.share_fit.FlightEvidence`) and the registered analyzers
    (``analyzers`` overrides the registry, for tests). A not-diagnosable model verdict passes
    through (Decision None)."""
    from .verdict import Verdict, covered_seconds

    if model_verdict.status == "not_diagnosable" or evidence is None:
        return model_verdict, None
    ts = np.asarray(t_start, float)
    te = np.asarray(t_end, float)
    p = np.asarray(probs, float)
    order = np.argsort(ts, kind="stable")
    run = model_verdict.evidence.run if model_verdict.evidence is not None else None
    onset = (run is not None and run.start_index > 0 and model_verdict.status == "damaged")
    drifting = evidence.drifting() if onset else None
    # After a mid-flight onset the model's votes are weighed from the onset on (the windows before
    # it are the healthy airframe, and the shares are taken against them), unless the commands
    # show a drift: the onset run is the stretch the model itself picked as most damaged, so
    # without a step in the commands its votes alone would count the selection as evidence (real
    # healthy Erle 11-2-2015_112 was called damaged that way).
    idx = order[run.start_index:] if (onset and drifting is None) else order
    n = p.shape[1] - 1
    ctx = Context(flight=flight, frame=frame, n_motors=n, probs=p[idx], covered_s=covered_seconds(ts[idx], te[idx]),
                  segments=segments, evidence=evidence, profile=profile, model_sha256=model_sha256)
    results = run_analyzers(ctx, analyzers)
    first = (model_verdict.first_seen if onset else float(ts[order[0]])) if len(ts) else None
    d = decide(results, n, frame, first_seen=first if onset else None, describe=evidence.summary)
    evidence.airframe_changed = d.airframe_changed
    position = frame.position(d.motor) if (frame is not None and d.motor) else None
    v = Verdict(status=d.status, motor=d.motor, position=position, confidence=float(np.clip(d.confidence, 0, 1)),
                first_seen=first if d.status == "damaged" else None, reason=d.reason,
                evidence=model_verdict.evidence, window_labels=model_verdict.window_labels)
    return v, d
