"""The flight verdict: one decision model over every evidence source.

For each motor k it weighs "rotor k lost thrust" against "healthy, with this airframe's normal
trim drift" as a log-likelihood ratio (LLR, nats) summed over independent sources:

- **command shares** (:func:`severity_fit`): the steady command pattern one rotor at thrust
  efficiency ``eta`` (drag torque ``eta**m``) produces in closed loop, predicted from the mixer
  geometry and the healthy baseline (the profile's, else an even split), against the observed
  shares, with the profile's throttle as a fifth observation. Noise: the airframe's
  flight-to-flight drift (the profile's measured spread, else ``DEFAULT_DRIFT_SIGMA``), or
  without a profile the spread across real healthy airframes (``NEIGHBOUR_SHARE_SIGMA``).
  The LLR is a Bayes factor: the likelihood averaged over the ``eta``, ``m`` prior grid against
  the healthy one, so a free ``eta`` buys no evidence by itself. It also gives each motor's
  severity ``eta_hat`` with a 90 % interval; it needs only means, so 10 Hz ``RCOU`` serves.
- **model votes** (:func:`model_llr`): the flight mean of the windows' ``log(p_k / p_0)``
  (floored probabilities) compared with its measured distribution on real healthy flights and on
  damaged ones. Overlapping windows are correlated, and an airframe's trims bias all windows of
  a flight alike, so the mean's noise is a between-flight spread plus a within-flight term that
  shrinks with the flight's decorrelated length, never ``1/sqrt(N windows)``.
- **effectiveness** (:func:`effectiveness_llr`), only when the fit is informative and sane:
  the motor's relative effectiveness against 1 with its bootstrap interval widened by the
  closed-loop bias.

The flight's verdict, confidence and reason come from here alone (:func:`decide_flight`):
``damaged`` when the best motor's total LLR reaches ``DAMAGED_LLR`` and beats the runner-up by
``SEPARATION_LLR``; ``uncertain`` from ``UNCERTAIN_LLR`` (the reason names the motor to inspect,
or the two it cannot tell apart); ``healthy`` below. "Airframe changed" (re-calibrate) is said
only when the shares moved beyond the drift AND no single rotor explains the move; a motor whose
excess is beyond the drift is named for inspection first.

Limits: one damaged rotor per flight; quad X/+ geometry is exact, other frames use the
minimum-norm mixer solution; the command pattern cannot separate damage from an equal and
opposite trim change (that is what the profile's drift sigma prices in).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from .flight import Frame

# ----------------------------------------------------------------------------- severity prior
#: Thrust-efficiency grid of the damage hypothesis (uniform prior). 0.4: below it a quad cannot
#: hold yaw and the flight ends; 0.99: damage too small to matter is still "damage" here but
#: carries no evidence (its pattern equals healthy).
ETA_GRID = np.round(np.arange(0.40, 0.995, 0.01), 3)
#: Drag-torque exponent grid (torque per command scales as eta**m). Physics: at a fixed rotor
#: speed a shortened blade keeps thrust ~ D^4 and torque ~ D^5 (m = 1.25), and the lighter load
#: lets the motor spin faster at the same command, which lowers m towards 0 for motors whose
#: winding resistance matters. Measured on the real rrc_straight quad: the damaged motor's
#: same-spin diagonal partner drops to eta times its command while the other pair stays near
#: (eta + eta**m) / 2 with m ~ 0.4-0.6 (20 and 25 mm cuts); SIH's weakened motors use m = 1.
M_GRID = np.array([0.25, 0.5, 0.75, 1.0, 1.25, 1.6])

# ----------------------------------------------------------------------------- share noise
#: Without a profile the healthy pattern is unknown: healthy airframes' airborne-mean command
#: shares scatter around an even split with this per-motor standard deviation. Measured:
#: 18 real healthy ArduCopter flights (../shared/real_healthy + Erle), RMS share deviation from 1
#: over all motors = 0.12 (benchmarks/bench_real_damage.py prints it).
NEIGHBOUR_SHARE_SIGMA = 0.12
#: Against the same flight before a mid-flight onset: a healthy airframe's share wander within
#: one flight. Measured: the 18 real healthy flights, rrc goods and CrazyPAD normals, shares of
#: the last two thirds against the first third: RMS 0.064 (robust 0.032; Erle 6-3-2014_6 and
#: 11-2-2015_112 drift by 0.12-0.36).
ONSET_BASELINE_SIGMA = 0.064
#: With a profile from ONE flight: a healthy airframe's share drift from flight to flight, per
#: motor. Measured on real repeated flights of one airframe: rrc_straight good 1/2/3 (per-motor
#: standard deviation 0.005-0.040, RMS 0.028) and CrazyPAD E9 normal 00/01/02 (RMS 0.006); the
#: larger airframe sets the default, since a single flight cannot show its own spread.
DEFAULT_DRIFT_SIGMA = 0.03
#: A spread measured on a few calibration flights is noisy (two flights give a one-degree-of-
#: freedom estimate), so it is pooled with DEFAULT_DRIFT_SIGMA as a prior worth this many flights
#: (scaled inverse chi-square): rrc good 1+2 agree within 0.02 yet good 3 moves motor 3 by 0.07.
DRIFT_PRIOR_FLIGHTS = 3
#: Relative hover-throttle drift between healthy flights of one airframe (battery charge,
#: temperature). Measured: rrc_straight goods 0.443/0.449/0.457 (3 %), CrazyPAD normals
#: 0.633/0.631/0.631; 0.05 leaves room for a battery swap.
THROTTLE_DRIFT_SIGMA = 0.05

# ----------------------------------------------------------------------------- model votes
#: Probability floor mixed into every window (as verdict.PROB_FLOOR_MIX) before log ratios.
PROB_FLOOR_MIX = 0.10
#: Healthy flights: mean and between-flight standard deviation of a motor's flight-mean window
#: log ratio log(q_k/q_0). Measured with the shipped model on the 18 real healthy flights:
#: all motors' values have mean -0.94, standard deviation 0.55 (the most-voted motor per flight
#: reaches -1.0 .. +0.39).
MODEL_HEALTHY_MEAN = -0.95
MODEL_HEALTHY_SIGMA = 0.55
#: Damaged flights: the damaged motor's flight-mean log ratio. Measured with the shipped model on
#: the 9 px4_sih_dev flights with eta <= 0.8 from take-off: median 0.77, standard deviation 0.75
#: (0.22 .. 2.33).
MODEL_DAMAGED_MEAN = 0.8
MODEL_DAMAGED_SIGMA = 0.75
#: Window log ratios decorrelate over this many seconds of flight (integrated autocorrelation
#: time on the real healthy flights: median 4.5 windows at 0.8 s stride).
MODEL_DECORRELATION_S = 3.6
#: Within-flight standard deviation of one window's log ratio (real healthy flights: median 0.87).
MODEL_WINDOW_SIGMA = 0.9

# ----------------------------------------------------------------------------- effectiveness
#: Floor on the effectiveness estimate's standard deviation: its closed-loop bias toward 1
#: (~0.05 on simulated flights) and the spread of real healthy motors at 10 Hz logging (0.78 seen).
EFFECTIVENESS_SIGMA_FLOOR = 0.08
#: A fit with any motor below this is physically inconsistent (wrong motor map, saturation):
#: it is never used.
EFFECTIVENESS_SANE_MIN = 0.2
#: Each source's LLR is clipped to this magnitude: no single source can outvote the others
#: without limit (a model misled by an odd airframe, a command pattern from a bent arm).
SOURCE_LLR_CAP = 8.0

# ----------------------------------------------------------------------------- decision
#: Total LLR (nats) at which one motor is called damaged: about 3 nats (20 times more likely)
#: above the largest total of any motor on the 18 real healthy flights without a profile (3.1,
#: Erle 15-10-2014_42; benchmarks/bench_real_damage.py), so none of them is called damaged.
DAMAGED_LLR = 6.0
#: The named motor must beat every other motor by this much (e^2 ~ 7 times more likely).
SEPARATION_LLR = 2.0
#: From this total LLR the flight is "uncertain" and the reason names what to inspect: half a nat
#: above that largest healthy total (3.1), so those 18 flights stay healthy.
UNCERTAIN_LLR = 3.5
#: Chi-square (per share degree of freedom) above which the healthy hypothesis fails: the shares
#: moved beyond the drift (p < 0.01 with 3 degrees of freedom: 11.3 / 3).
AIRFRAME_CHANGE_CHI2_PER_DOF = 3.8


@dataclass
class SeverityFit:
    """One motor's damage fit: LLR of "rotor k at some eta" vs healthy, and eta-hat."""

    llr: float
    eta_hat: float
    eta_ci: tuple[float, float]
    m_hat: float
    chi2: float  # at the best eta, m


@dataclass
class MotorDecision:
    """One motor's part in the decision (the report's per-motor severity and weight)."""

    motor: int
    llr: float  # total, nats
    llr_by_source: dict  # source -> nats
    eta_hat: Optional[float]  # thrust efficiency (1 = healthy), None when shares are missing
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
    """The decision model's output: verdict fields plus per-motor details."""

    status: str
    motor: Optional[int]
    confidence: float
    reason: str
    motors: list[MotorDecision] = field(default_factory=list)
    airframe_changed: Optional[str] = None
    healthy_chi2: Optional[float] = None
    share_sigma: Optional[float] = None
    sources: list[str] = field(default_factory=list)


# ----------------------------------------------------------------------------- physics

def _mixer_rows(frame: Optional[Frame], n: int) -> np.ndarray:
    """(4, n) rows: collective thrust, roll moment (-y), pitch moment (x), yaw (spin)."""
    if frame is None or frame.rotor_count != n:
        frame = Frame.quad_x()
    xs = np.array([r.x for r in frame.rotors], dtype=float)
    ys = np.array([r.y for r in frame.rotors], dtype=float)
    sp = np.array([float(r.spin) for r in frame.rotors])
    return np.stack([np.ones(n), -ys, xs, sp])


def predicted_commands(base: np.ndarray, rows: np.ndarray, motor: int, eta: float, m: float) -> np.ndarray:
    """Commands (n,) that hold the same force and moments as the healthy commands ``base`` when
    rotor ``motor`` (1-based) gives ``eta`` of its thrust and ``eta**m`` of its drag torque."""
    A1 = rows
    A = rows.copy()
    j = motor - 1
    A[:3, j] *= eta
    A[3, j] *= eta ** m
    rhs = A1 @ base
    if A.shape[0] == A.shape[1]:
        return np.linalg.solve(A, rhs)
    return np.linalg.lstsq(A, rhs, rcond=None)[0]  # over-actuated: minimum-norm allocation


def _pred_table(base: np.ndarray, rows: np.ndarray, motor: int) -> np.ndarray:
    """(len(ETA_GRID), len(M_GRID), n) predicted raw commands."""
    out = np.empty((len(ETA_GRID), len(M_GRID), len(base)))
    for a, eta in enumerate(ETA_GRID):
        for b, m in enumerate(M_GRID):
            out[a, b] = predicted_commands(base, rows, motor, float(eta), float(m))
    return out


def severity_fit(share: np.ndarray, base_share: np.ndarray, sigma: np.ndarray, frame: Optional[Frame] = None,
                 throttle_ratio: Optional[float] = None,
                 throttle_sigma: float = THROTTLE_DRIFT_SIGMA) -> tuple[float, list[SeverityFit]]:
    """Fit each motor's damage to the observed shares (mean 1) against the healthy ``base_share``.

    ``sigma`` (n,): each share's noise; ``throttle_ratio``: the flight's mean command over the
    baseline's (None without a profile). Returns the healthy chi-square and one
    :class:`SeverityFit` per motor (LLR = log Bayes factor over the eta/m prior grid)."""
    s = np.asarray(share, float)
    b = np.asarray(base_share, float)
    b = b / b.mean()
    sig = np.asarray(sigma, float)
    n = len(s)
    rows = _mixer_rows(frame, n)
    chi_h = float(np.sum(((s - b) / sig) ** 2))
    if throttle_ratio is not None and np.isfinite(throttle_ratio):
        chi_h += ((throttle_ratio - 1.0) / throttle_sigma) ** 2
    fits = []
    for k in range(1, n + 1):
        u = _pred_table(b, rows, k)  # (E, M, n)
        mean_u = u.mean(axis=2)
        pred = u / mean_u[..., None]
        chi = np.sum(((s - pred) / sig) ** 2, axis=2)  # (E, M)
        if throttle_ratio is not None and np.isfinite(throttle_ratio):
            chi = chi + ((throttle_ratio - mean_u) / throttle_sigma) ** 2
        loglik = -0.5 * chi
        top = loglik.max()
        log_marg = top + np.log(np.mean(np.exp(loglik - top)))
        llr = float(log_marg + 0.5 * chi_h)
        post_eta = np.exp(loglik - top).sum(axis=1)
        post_eta = post_eta / post_eta.sum()
        cdf = np.cumsum(post_eta)
        lo = float(ETA_GRID[min(np.searchsorted(cdf, 0.05), len(ETA_GRID) - 1)])
        hi = float(ETA_GRID[min(np.searchsorted(cdf, 0.95), len(ETA_GRID) - 1)])
        a, bm = np.unravel_index(int(np.argmax(loglik)), loglik.shape)
        eta_hat = float(ETA_GRID[a])
        # a best fit at the grid's healthy end means "no loss": report 1.0 with the interval
        if eta_hat >= ETA_GRID[-1]:
            eta_hat, hi = 1.0, 1.0
        fits.append(SeverityFit(llr=llr, eta_hat=eta_hat, eta_ci=(lo, hi), m_hat=float(M_GRID[bm]),
                                chi2=float(chi[a, bm])))
    return chi_h, fits


# ----------------------------------------------------------------------------- model votes

def _gauss_logpdf(x: float, mu: float, sd: float) -> float:
    return float(-0.5 * ((x - mu) / sd) ** 2 - np.log(sd))


def model_llr(probs: np.ndarray, covered_s: float) -> np.ndarray:
    """(n_motors,) LLR of the model's windows for "motor k damaged" vs healthy (module docstring)."""
    p = np.asarray(probs, float)
    if p.ndim != 2 or p.shape[0] == 0:
        return np.zeros(max(p.shape[-1] - 1, 0) if p.ndim == 2 else 0)
    k = p.shape[1]
    q = (1.0 - PROB_FLOOR_MIX) * p / p.sum(axis=1, keepdims=True) + PROB_FLOOR_MIX / k
    lr = np.log(q[:, 1:]) - np.log(q[:, :1])
    mean = lr.mean(axis=0)
    n_eff = max(covered_s / MODEL_DECORRELATION_S, 1.0)
    within = MODEL_WINDOW_SIGMA / np.sqrt(n_eff)
    sd_h = float(np.hypot(MODEL_HEALTHY_SIGMA, within))
    sd_d = float(np.hypot(MODEL_DAMAGED_SIGMA, within))
    return np.array([_gauss_logpdf(x, MODEL_DAMAGED_MEAN, sd_d) - _gauss_logpdf(x, MODEL_HEALTHY_MEAN, sd_h)
                     for x in mean])


# ----------------------------------------------------------------------------- effectiveness

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


# ----------------------------------------------------------------------------- the decision

def _words(frame: Optional[Frame], motor: int) -> str:
    pos = frame.position(motor) if frame is not None else None
    return f"motor {motor} ({pos})" if pos else f"motor {motor}"


def pooled_sigma(measured: Optional[float], n_flights: int, prior: float) -> float:
    """A spread measured on ``n_flights`` flights pooled with ``prior`` (worth
    ``DRIFT_PRIOR_FLIGHTS`` flights); ``prior`` alone when nothing was measured."""
    if measured is None or not np.isfinite(measured) or n_flights < 2:
        return prior
    dof = n_flights - 1
    return float(np.sqrt((DRIFT_PRIOR_FLIGHTS * prior ** 2 + dof * measured ** 2) / (DRIFT_PRIOR_FLIGHTS + dof)))


def share_sigma(baseline_kind: str, spread: Optional[Sequence[float]], n: int, n_flights: int = 1) -> np.ndarray:
    """Per-motor share noise for the kind of baseline (module constants): without a profile the
    spread across healthy airframes; with one, the airframe's drift (measured, pooled, or default)."""
    if baseline_kind == "neighbours":
        return np.full(n, NEIGHBOUR_SHARE_SIGMA)
    if baseline_kind == "before onset":
        return np.full(n, ONSET_BASELINE_SIGMA)
    if spread is not None and len(spread) == n and np.all(np.isfinite(spread)):
        measured = float(np.sqrt(np.mean(np.square(spread))))
        return np.full(n, pooled_sigma(measured, n_flights, DEFAULT_DRIFT_SIGMA))
    return np.full(n, DEFAULT_DRIFT_SIGMA)


def decide_flight(*, probs: np.ndarray, covered_s: float, shares: Optional[np.ndarray],
                  base_shares: Optional[np.ndarray], baseline_kind: str,
                  spread: Optional[Sequence[float]] = None, n_flights: int = 1,
                  throttle_ratio: Optional[float] = None, throttle_spread: Optional[float] = None,
                  effectiveness=None, frame: Optional[Frame] = None,
                  first_seen: Optional[float] = None, describe=None) -> Decision:
    """The flight's decision from every source (module docstring).

    ``probs`` (N, n+1): the flight's windows; ``shares`` (n,) observed command shares, mean 1; ``base_shares`` the healthy
    baseline at this throttle (profile, before-onset) or None for an even split
    (``baseline_kind`` "neighbours"); ``spread`` the profile's per-motor drift; ``throttle_ratio``
    the flight's throttle over the profile's (``throttle_spread`` its measured relative drift);
    ``n_flights`` how many calibration flights measured ``spread``. ``first_seen`` goes into the
    reason; ``describe(k)`` gives plain words for motor k's command figures to cite there."""
    p = np.asarray(probs, float)
    n = p.shape[1] - 1
    sources: dict[str, np.ndarray] = {}
    sources["model"] = np.clip(model_llr(p, covered_s), -SOURCE_LLR_CAP, SOURCE_LLR_CAP)
    fits: Optional[list[SeverityFit]] = None
    chi_h = None
    sig = share_sigma(baseline_kind, spread, n, n_flights)
    thr_sig = pooled_sigma(throttle_spread, n_flights, THROTTLE_DRIFT_SIGMA)
    if shares is not None and np.all(np.isfinite(shares)):
        base = np.ones(n) if base_shares is None else np.asarray(base_shares, float)
        chi_h, fits = severity_fit(np.asarray(shares, float), base, sig, frame, throttle_ratio, thr_sig)
        sources["commands"] = np.clip([f.llr for f in fits], -SOURCE_LLR_CAP, SOURCE_LLR_CAP)
    e = effectiveness_llr(effectiveness)
    if e is not None and len(e) == n:
        sources["effectiveness"] = np.clip(e, -SOURCE_LLR_CAP, SOURCE_LLR_CAP)
    total = np.sum(list(sources.values()), axis=0)
    # posterior weights with a flat prior over {healthy, motor 1..n}
    logits = np.concatenate([[0.0], total])
    w = np.exp(logits - logits.max())
    w = w / w.sum()
    motors = [MotorDecision(motor=k + 1, llr=float(total[k]),
                            llr_by_source={s: float(v[k]) for s, v in sources.items()},
                            eta_hat=None if fits is None else fits[k].eta_hat,
                            eta_ci=None if fits is None else fits[k].eta_ci,
                            weight=float(w[k + 1])) for k in range(n)]
    order = np.argsort(-total)
    best, second = int(order[0]), int(order[1]) if n > 1 else None
    kb = best + 1
    lead = float(total[best] - (total[second] if second is not None else -np.inf))

    dof = max(n - 1, 1) + (1 if throttle_ratio is not None else 0)
    airframe_changed = None
    if fits is not None and baseline_kind == "profile" and chi_h / dof > AIRFRAME_CHANGE_CHI2_PER_DOF:
        best_fit_chi = fits[best].chi2
        if best_fit_chi / max(dof - 1, 1) > AIRFRAME_CHANGE_CHI2_PER_DOF:
            airframe_changed = ("the command shares moved in a pattern no single rotor explains: " + ", ".join(
                f"motor {i + 1} {100 * (shares[i] - base_shares[i]):+.0f} %" for i in range(n)))
            if throttle_ratio is not None:
                airframe_changed += f"; throttle {100 * (throttle_ratio - 1):+.0f} % against calibration"

    def severity_words(k: int) -> str:
        m = motors[k - 1]
        if m.eta_hat is None:
            return ""
        lo, hi = m.eta_ci
        return f"gives about {100 * m.eta_hat:.0f} % of its normal thrust [{100 * lo:.0f}-{100 * hi:.0f} %]"

    def evidence_words(k: int) -> str:
        parts = [f"{s} {v[k - 1]:+.1f}" for s, v in sources.items()]
        cite = f"it {describe(k)}; " if describe is not None and "commands" in sources else ""
        return cite + "evidence for it (log-likelihood ratio, nats): " + ", ".join(parts)

    common = dict(motors=motors, airframe_changed=airframe_changed, healthy_chi2=chi_h,
                  share_sigma=float(np.mean(sig)), sources=list(sources))
    conf_best = float(w[kb])
    if total[best] >= DAMAGED_LLR and lead >= SEPARATION_LLR:
        since = f" from t={first_seen:.1f} s" if first_seen is not None else ""
        sev = severity_words(kb)
        reason = (f"{_words(frame, kb)} lost thrust{since}" + (f": it {sev}" if sev else "")
                  + f"; {evidence_words(kb)}; inspect propeller {kb}")
        return Decision("damaged", kb, conf_best, reason, **common)
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
        return Decision("uncertain", None, conf_best, reason, **common)
    if airframe_changed:
        reason = (f"no rotor explains the change since calibration ({airframe_changed}): the airframe itself "
                  f"changed (payload, battery, a re-trim); check the propellers, then re-calibrate on a "
                  f"healthy flight")
        return Decision("uncertain", None, float(w[0]), reason, **common)
    reason = (f"no rotor lost thrust: the strongest case is {_words(frame, kb)} at {total[best]:+.1f} nats "
              f"(damage needs {DAMAGED_LLR:.0f})")
    return Decision("healthy", None, float(w[0]), reason, **common)


def flight_verdict(model_verdict, t_start, t_end, probs, evidence, frame: Optional[Frame] = None):
    """The flight's :class:`~flightlog_fd.verdict.Verdict` and :class:`Decision` from the model's
    window verdict (timeline labels, mid-flight onset), the window probabilities and the per-motor
    evidence (:class:`~flightlog_fd.evidence.FlightEvidence`). A not-diagnosable model verdict
    passes through (Decision None)."""
    from .verdict import Verdict, covered_seconds

    if model_verdict.status == "not_diagnosable" or evidence is None:
        return model_verdict, None
    ts = np.asarray(t_start, float)
    te = np.asarray(t_end, float)
    p = np.asarray(probs, float)
    order = np.argsort(ts, kind="stable")
    run = model_verdict.evidence.run if model_verdict.evidence is not None else None
    onset = (run is not None and run.start_index > 0 and model_verdict.status == "damaged")
    shares = np.array([m.command_share for m in evidence.motors])
    drifting = evidence.drifting() if onset else None
    if drifting is not None:
        shares = None  # a steady rise is not the step a broken propeller makes: not one rotor's loss
    # After a mid-flight onset the model's votes are weighed from the onset on (the windows before
    # it are the healthy airframe, and the shares are taken against them), unless the commands
    # show a drift: the onset run is the stretch the model itself picked as most damaged, so
    # without a step in the commands its votes alone would count the selection as evidence (real
    # healthy Erle 11-2-2015_112 was called damaged that way).
    idx = order[run.start_index:] if (onset and drifting is None) else order
    base = (None if evidence.baseline == "neighbours"
            else np.array([m.command_share_baseline for m in evidence.motors]))
    b = evidence.baseline_
    first = (model_verdict.first_seen if onset else float(ts[order[0]])) if len(ts) else None
    d = decide_flight(probs=p[idx], covered_s=covered_seconds(ts[idx], te[idx]), shares=shares, base_shares=base,
                      baseline_kind=evidence.baseline,
                      spread=None if b is None else b.spread, n_flights=1 if b is None else b.n_flights,
                      throttle_ratio=evidence.throttle_ratio,
                      throttle_spread=None if b is None else b.throttle_spread,
                      effectiveness=evidence.effectiveness, frame=frame,
                      first_seen=first if onset else None, describe=evidence.summary)
    evidence.airframe_changed = d.airframe_changed
    if drifting is not None:
        d.reason += (f"; {_words(frame, drifting)} needed steadily more command from t={model_verdict.first_seen:.1f} s "
                     f"(a drift, not the step a broken propeller makes): inspect motor {drifting}, its ESC and mount")
    position = frame.position(d.motor) if (frame is not None and d.motor) else None
    v = Verdict(status=d.status, motor=d.motor, position=position, confidence=float(np.clip(d.confidence, 0, 1)),
                first_seen=first if d.status == "damaged" else None, reason=d.reason,
                evidence=model_verdict.evidence, window_labels=model_verdict.window_labels)
    return v, d
