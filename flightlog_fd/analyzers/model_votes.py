"""The model's window votes as evidence: per motor, the flight mean of the windows' log ratio.

Input: the windows' class probabilities (N, n+1) and the flight time they cover. Finding per
motor: ``vote`` (mean probability that this propeller is damaged, 0..1) with its LLR: the flight
mean of ``log(q_k / q_0)`` (floored probabilities) against its measured distribution on real
healthy flights and on damaged ones. Overlapping windows are correlated, and an airframe's trims
bias all windows of a flight alike, so the mean's noise is a between-flight spread plus a
within-flight term that shrinks with the flight's decorrelated length, never 1/sqrt(N windows).
With a profile, the airframe's own healthy mean per motor is measured on the calibration flights
with the profile's model (:meth:`ModelVotes.fit_baseline`), and damage is expected
``MODEL_DAMAGE_SHIFT`` above it; without one, the means measured across real healthy airframes
are used. The levels and spreads are the shipped model's for the flight's rotor count
(:data:`NROTOR_VOTE_STATS` for the hexa and octo models, measured on simulated flights).
Limits: measured with the shipped models (a user's own model is weighed with them too); the
healthy re-flight spread with a profile is the quads' for every frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..timeline import floored  # the same floor the timeline's votes use
from .base import Analyzer, AnalyzerResult, Context, Finding

#: Healthy flights: mean and between-flight standard deviation of a motor's flight-mean window
#: log ratio log(q_k/q_0). Measured with the shipped model on the 18 real healthy flights
#: (benchmarks/bench_real_damage.py): all motors' values have mean -0.94, standard deviation 0.55
#: (the most-voted motor per flight reaches -1.0 .. +0.39).
MODEL_HEALTHY_MEAN = -0.95
MODEL_HEALTHY_SIGMA = 0.55
#: Damaged flights: the damaged motor's flight-mean log ratio. Measured with the shipped model on
#: the 9 px4_sih_dev flights with eta <= 0.8 from take-off: median 0.77, standard deviation 0.75
#: (0.22 .. 2.33).
MODEL_DAMAGED_MEAN = 0.8
MODEL_DAMAGED_SIGMA = 0.75
#: Against an airframe's own healthy mean (a profile), damage is expected this far above it: the
#: two means above (0.8 - (-0.95)). Calibrated models on their own airframes move further
#: (rrc_straight 20/25 mm cuts: +4.4..+5.3 against good 1; SIH eta <= 0.8: +3..+7), so this
#: is the conservative end.
MODEL_DAMAGE_SHIFT = MODEL_DAMAGED_MEAN - MODEL_HEALTHY_MEAN
#: A healthy mean measured on a few calibration flights is pooled with MODEL_HEALTHY_SIGMA as the
#: between-flight spread (a calibrated model's healthy re-flights move a motor's mean by up to
#: 1.0-1.1: rrc_straight goods 2/3 against 1, CrazyPAD normal 01/02 against 00), never below it.
MODEL_MIN_HEALTHY_SIGMA = MODEL_HEALTHY_SIGMA
#: Window log ratios decorrelate over this many seconds of flight (integrated autocorrelation
#: time on the real healthy flights: median 4.5 windows at 0.8 s stride).
MODEL_DECORRELATION_S = 3.6
#: Within-flight standard deviation of one window's log ratio (real healthy flights: median 0.81-0.87).
MODEL_WINDOW_SIGMA = 0.9


@dataclass(frozen=True)
class VoteStats:
    """One model's flight-mean window log ratio: healthy level and between-flight spread, the
    damaged motor's level and spread (no profile), and the shift damage makes against the
    airframe's own healthy level with its spread (a profile)."""

    healthy_mean: float
    healthy_sigma: float
    damaged_mean: float
    damaged_sigma: float
    damage_shift: float
    shift_sigma: float


#: The shipped quad model: the constants above (real healthy flights, px4_sih_dev damage).
QUAD_VOTE_STATS = VoteStats(MODEL_HEALTHY_MEAN, MODEL_HEALTHY_SIGMA, MODEL_DAMAGED_MEAN, MODEL_DAMAGED_SIGMA,
                            MODEL_DAMAGE_SHIFT, MODEL_DAMAGED_SIGMA)
#: The shipped hexa and octo models (``default_hexa.onnx`` default-2-6rotor, ``default_octo.onnx``
#: default-2-8rotor) are weaker than the quad's and vote differently: a damaged octo motor's flight
#: mean sits at -0.49 +- 0.99, not the quad's +0.8 +- 0.75, so the quad's figures priced an n-rotor
#: model that did not see the damage as 3-5 nats against the damaged motor. Measured with
#: ``benchmarks/nrotor_vote_stats.py`` (simulated hexa-X/+, octo-X and octaquad-X flights, random
#: airframes with realistic imbalance, damaged eta 0.55-0.8, each with a healthy twin; seeds 7000
#: and 8000, neither the benchmark's nor training's; 384 flights per rotor count): healthy every
#: motor, the damaged motor, and the damaged motor against its twin, between-flight spreads
#: (the within-flight term at the median 44 s removed). There is no real hexa or octo log to
#: measure on. Re-measure after retraining a model.
NROTOR_VOTE_STATS = {
    6: VoteStats(healthy_mean=-1.48, healthy_sigma=0.85, damaged_mean=0.14, damaged_sigma=1.40,
                 damage_shift=1.54, shift_sigma=1.42),
    8: VoteStats(healthy_mean=-1.46, healthy_sigma=0.88, damaged_mean=-0.49, damaged_sigma=0.99,
                 damage_shift=0.96, shift_sigma=1.07),
}


def vote_stats(n_motors: int) -> VoteStats:
    """The vote statistics of the shipped model for ``n_motors`` rotors (the quad's otherwise)."""
    return NROTOR_VOTE_STATS.get(int(n_motors), QUAD_VOTE_STATS)


def _gauss_logpdf(x: float, mu: float, sd: float) -> float:
    return float(-0.5 * ((x - mu) / sd) ** 2 - np.log(sd))


def mean_log_ratio(probs: np.ndarray) -> np.ndarray:
    """(n_motors,) flight mean of the windows' log(q_k / q_0) on floored probabilities."""
    q = floored(probs)
    return (np.log(q[:, 1:]) - np.log(q[:, :1])).mean(axis=0)


def model_llr(probs: np.ndarray, covered_s: float, healthy_mean=None, healthy_sigma=None,
              stats: VoteStats | None = None) -> np.ndarray:
    """(n_motors,) LLR of the model's windows for "motor k damaged" vs healthy (module docstring);
    ``healthy_mean`` (n,) and ``healthy_sigma``: the airframe's own healthy means and their spread
    (a profile), else the model's healthy level; ``stats``: the model's vote statistics (default:
    :func:`vote_stats` for the probabilities' rotor count)."""
    p = np.asarray(probs, float)
    if p.ndim != 2 or p.shape[0] == 0:
        return np.zeros(max(p.shape[-1] - 1, 0) if p.ndim == 2 else 0)
    mean = mean_log_ratio(p)
    n = len(mean)
    st = vote_stats(n) if stats is None else stats
    if healthy_sigma is None:
        healthy_sigma = st.healthy_sigma
    mu_h = np.full(n, st.healthy_mean) if healthy_mean is None else np.asarray(healthy_mean, float)
    mu_d = np.full(n, st.damaged_mean) if healthy_mean is None else mu_h + st.damage_shift
    n_eff = max(covered_s / MODEL_DECORRELATION_S, 1.0)
    within = MODEL_WINDOW_SIGMA / np.sqrt(n_eff)
    sd_h = float(np.hypot(healthy_sigma, within))
    sd_d = float(np.hypot(st.damaged_sigma if healthy_mean is None else st.shift_sigma, within))
    return np.array([_gauss_logpdf(x, mu_d[k], sd_d) - _gauss_logpdf(x, mu_h[k], sd_h) for k, x in enumerate(mean)])


def combine_sessions(sessions: list[dict], seen: list[bool] | None = None) -> dict | None:
    """One model-vote baseline from each calibration session's (:meth:`ModelVotes.fit_baseline` of
    its flights, all with the same model): the mean of the sessions' healthy means, their
    session-to-session spread (``n_flights``: the sessions it rests on), each session's means
    (``sessions``), so a session added later is weighed in the same way, and whether the model was
    adapted on each (``sessions_seen``; an adapted model votes lower on its own flights than on a
    session it never saw). None without any."""
    keep = [i for i, s in enumerate(sessions) if s and s.get("healthy_mean")]
    if not keep:
        return None
    m = np.array([sessions[i]["healthy_mean"] for i in keep], float)
    spread = float(np.sqrt(np.mean(m.std(axis=0, ddof=1) ** 2))) if len(m) > 1 else None
    return {"model_sha256": sessions[keep[0]].get("model_sha256", ""), "healthy_mean": [float(x) for x in m.mean(axis=0)],
            "spread": spread, "n_flights": len(m), "sessions": [[float(x) for x in row] for row in m],
            "sessions_seen": [bool(seen[i]) if seen is not None else False for i in keep]}


class ModelVotes(Analyzer):
    id = "model"
    description = "the model's window votes (mean probability per motor), weighed as one flight"
    requires = ()
    #: Where the reliability table has no cell for the log (or the kind of log is unknown) the model
    #: alone never makes a damaged verdict (decision.DAMAGED_LLR 6): it was trained on simulated
    #: airframes, and on a real one a session's trim can look like damage to it (CrazyPAD E9
    #: cut_propeller_M3_2mm logs 04-05: a calibrated model 6 sigma sure of motor 1, whose command
    #: rose only 4 %, while the label says motor 2). Another source must add at least a nat. Where
    #: the table trusts it (measured quiet on real flights of that kind) it may give up to
    #: SOURCE_LLR_CAP.
    llr_cap = 5.0
    #: Its reliability depends on how well the streams fill its windows, on the profile (an adapted
    #: model, or the airframe's own vote baseline) and on the rotor count (another shipped model).
    reliability_keys = ("rate", "profile", "adapted", "rotors")
    learned = True

    def fit_baseline(self, flights, model=None):
        """Each motor's flight-mean window log ratio on the calibration flights with ``model``
        (the profile's): the airframe's own healthy level, keyed to the model's sha256."""
        from ..windows import FeatureSpec, make_windows

        if model is None:
            return None
        spec = FeatureSpec.from_dict(model.feature_spec)
        means = []
        for fl in flights:
            win = make_windows(fl, spec)
            if len(win.t_start):
                means.append(mean_log_ratio(model.predict_proba(model.standardise(win.X))))
        if not means:
            return None
        m = np.array(means)
        spread = float(np.sqrt(np.mean(m.std(axis=0, ddof=1) ** 2))) if len(m) > 1 else None
        return {"model_sha256": str(getattr(model, "sha256", "")), "healthy_mean": [float(x) for x in m.mean(axis=0)],
                "spread": spread, "n_flights": len(m)}

    def analyze(self, ctx: Context) -> AnalyzerResult:
        p = np.asarray(ctx.probs, float)
        if p.ndim != 2 or p.shape[0] == 0:
            return AnalyzerResult(self.id, abstained="no window to vote")
        base = ctx.baseline_for(self.id)
        notes = []
        if base and base.get("model_sha256") == ctx.model_sha256 and len(base.get("healthy_mean", [])) == p.shape[1] - 1:
            from .command_shares import pooled_sigma

            sigma = max(pooled_sigma(base.get("spread"), int(base.get("n_flights", 1)), MODEL_HEALTHY_SIGMA),
                        MODEL_MIN_HEALTHY_SIGMA)
            llr = model_llr(p, ctx.covered_s, base["healthy_mean"], sigma)
        else:
            if base:
                notes.append("the profile's model-vote baseline was measured with another model: not used")
            llr = model_llr(p, ctx.covered_s)
        votes = p[:, 1:].mean(axis=0)
        return AnalyzerResult(self.id, [Finding(self.id, k + 1, "vote", float(votes[k]), "", None, None, "up",
                                                float(llr[k]), f"{votes[k]:.2f}") for k in range(len(llr))],
                              notes=notes)
