"""The model's window votes as evidence for "propeller k damaged", per motor.

Input: the windows' class probabilities (N, n+1) and the flight time they cover. Finding per
motor: ``vote`` (mean probability that this propeller is damaged, 0..1) with its LLR, from one of
two statistics of the windows, the one that measured better for the kind of log
(benchmarks/bench_reliability.py votes):

- the **flight mean** of ``log(q_k / q_0)`` (floored probabilities) against its measured
  distribution on healthy flights and on damaged ones. Overlapping windows are correlated, and an
  airframe's trims bias all windows of a flight alike, so the mean's noise is a between-flight
  spread plus a within-flight term that shrinks with the flight's decorrelated length, never
  1/sqrt(N windows). With a profile, the airframe's own healthy mean per motor is measured on the
  calibration flights with the profile's model (:meth:`ModelVotes.fit_baseline`), and damage is
  expected ``MODEL_DAMAGE_SHIFT`` above it. An adapted model on a low-rate log is weighed against
  the level and spread its votes take in a session it never saw (:func:`adapted_session_reference`):
  it votes lowest on the flights it was adapted on, and another day's flight of some airframes
  moves its votes by several times a re-flight's spread (Erle boards: up to +4.6). Without a
  profile: the levels measured on real healthy
  flights and real damaged ones (:data:`QUAD_VOTE_STATS`; the hexa and octo models have their
  own, :data:`NROTOR_VOTE_STATS`);
- the **vote share**, how consistently the windows name motor k (the share of windows whose most
  probable class is k, beta-binomial over the flight's effective window count): a quad log at
  full rate (:func:`~flightlog_fd.analyzers.reliability.rate_class`) without a profile
  (:data:`QUAD_VOTE_SHARE_STATS`), where it named as many real damaged flights as the flight mean
  with fewer simulated healthy airframes reaching the decision's bars.

Without a profile neither statistic can tell a damaged propeller from a trim the model reads as
one: on simulated healthy airframes whose trims are as wide as real airframes', the windows of
about 7 % name one motor as consistently, and with as large a mean, as on damaged flights of
eta <= 0.8 (results/reliability.md); a profile removes the airframe's own trim.
For two damaged propellers (:func:`model_pair_llrs`) the model, whose classes are single motors,
sees at most one member: measured levels in :data:`PAIR_VOTE_STATS`.
Limits: measured with the shipped models (a user's own model is weighed with them too); the
healthy re-flight spread with a profile is the quads' for every frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import math

import numpy as np

from ..timeline import floored  # the same floor the timeline's votes use
from .base import ETA_GRID, Analyzer, AnalyzerResult, Context, Finding, log_mean_exp
from .reliability import flight_rate_class

#: Healthy flights: mean and between-flight standard deviation of a motor's flight-mean window
#: log ratio log(q_k/q_0). Measured with the shipped model on the 18 real healthy flights
#: (benchmarks/bench_real_damage.py): all motors' values have mean -0.94, standard deviation 0.55
#: (the most-voted motor per flight reaches -1.0 .. +0.39). Re-measured per rate class
#: (benchmarks/bench_reliability.py votes, maximum likelihood with the within-flight term): the 19
#: real low-rate healthy flights (Erle, rrc goods, SIH default profile) give -0.83 +- 0.46, the
#: 3 real mid-rate and 7 full-rate ones too few to fit alone; simulated airframes with realistic
#: trims spread wider as the model reads them (-1.0 +- 0.94 at low rate), a sim-to-real gap of the
#: model, so the real flights' figures are kept at every rate.
MODEL_HEALTHY_MEAN = -0.95
MODEL_HEALTHY_SIGMA = 0.55
#: Damaged flights: the damaged motor's flight-mean log ratio. Measured with the shipped model on
#: the 9 px4_sih_dev flights with eta <= 0.8 from take-off: median 0.77, standard deviation 0.75
#: (0.22 .. 2.33); the only real damaged flights whose motor is known (re-measured at full rate,
#: 10 flights with the mid-flight onsets' post-onset windows: +1.18 +- 0.75).
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


@dataclass(frozen=True)
class PairVoteStats:
    """The model's flight-mean window log ratio on two-propeller flights against one-propeller
    flights of the same airframes: the more-voted member of a pair (level, between-flight spread)
    and a single damaged motor, without a profile and against the airframe's own healthy level."""

    pair: tuple[float, float]
    single: tuple[float, float]
    pair_shift: tuple[float, float]
    single_shift: tuple[float, float]


#: Two damaged propellers: the shipped quad model (classes are single motors) sees at most one of
#: them. Measured with ``benchmarks/bench_two_props.py --measure`` (seed 21, not a scoring seed: 69
#: simulated quads with two propellers at eta 0.6-0.85, adjacent and opposite, and 72 with one;
#: 36 random airframes 30 g-5 kg and 36 x500/f450/sih presets, all with realistic imbalance,
#: px4_high / ardupilot / px4_default logging, 60 s; each beside a healthy twin): the more-voted
#: member's flight mean sits at +0.05, between-flight spread 0.88, a single damaged motor's at
#: +0.65 +- 1.04 on the same airframes; against the twin (the profile's level) +1.02 +- 0.82 and
#: +1.77 +- 0.89. The other member sits at the healthy level (-1.33 +- 0.79 against the healthy
#: motors' -1.10 +- 0.66; -0.15 +- 1.10 against the twin).
QUAD_PAIR_VOTE_STATS = PairVoteStats(pair=(0.05, 0.88), single=(0.65, 1.04), pair_shift=(1.02, 0.82),
                                     single_shift=(1.77, 0.89))
#: Pair statistics per rotor count; without them (hexa, octo: not measured) a pair member is
#: weighed as a single damaged motor.
PAIR_VOTE_STATS = {4: QUAD_PAIR_VOTE_STATS}


#: A motor's window votes (the windows whose most probable class is that motor) decorrelate over
#: this many seconds of flight at full rate: the integrated autocorrelation time of the vote
#: indicator, the larger of the real and the simulated figure (benchmarks/bench_reliability.py
#: votes: real 1.5 s on the 18 SIH and Erle-Brain2 flights of >= 25 windows, simulated 1.1 s).
#: Windows overlap by half (1.6 s every 0.8 s).
VOTE_DECORRELATION_S = {"full rate": 1.5}


@dataclass(frozen=True)
class VoteShareStats:
    """Between flights, the probability that a window votes for a given motor (its vote share):
    on a healthy airframe a two-Beta mixture (``healthy``: a1, b1, a2, b2, w; most motors near 0,
    weight w of motors an airframe's trim draws votes to), for the damaged motor one Beta
    (``damaged``: a, b). The flight's votes for motor k are then beta-binomial over its effective
    window count (covered seconds / :data:`VOTE_DECORRELATION_S`)."""

    healthy: tuple[float, float, float, float, float]
    damaged: tuple[float, float]


#: The shipped quad model's vote shares at full rate without a profile, maximum likelihood
#: (beta-binomial, effective window counts as above; benchmarks/bench_reliability.py votes), each
#: hypothesis on the real flights of ../shared where 10 from more than one airframe are there, else
#: on them pooled with simulated flights of seed 12100 (collect --sets simfit: 30 random airframes
#: with realistic imbalance per logging profile, each flown healthy and damaged from take-off).
#: Healthy: 97 flights (7 real: SIH, CrazyPAD normals, Erle-Brain2), a motor's share >= 0.5 on
#: 4.6 % of healthy motors fitted (3.9 % measured), >= 0.9 on 1.3 % (1.5 %). Damaged: 79 flights
#: with eta <= 0.8 (10 real, all px4_sih_dev: one perfectly balanced airframe, shares 0.92-1.0),
#: median share 0.99 with a tail the model never names: fitted on SIH alone (Beta 2.86, 0.19) a
#: damaged motor the windows miss read -10.7 nats at the simulated eta 0.9 flights' p10 (pooled
#: -3.0) and vetoed ESC telemetry on the demo's ardupilot_esc_motor3_damaged (model -5.0 against
#: esc +12: damaged -> uncertain). Checked on the table's own simulated set (seed 9100) and the real
#: flights. At low and mid rate the flight mean measured better: the share cannot say "healthy" as
#: firmly where a motor's windows never name it (real Erle 6-3-2014_6, whose command pattern alone
#: reaches +5 nats).
QUAD_VOTE_SHARE_STATS = {
    "full rate": VoteShareStats(healthy=(0.1896, 14.6422, 0.1501, 0.6639, 0.2841), damaged=(0.4824, 0.1201)),
}


def vote_share_stats(n_motors: int, rate: str | None) -> VoteShareStats | None:
    """The vote-share statistics for a flight without a profile (None where they are not the
    statistic weighed: another rotor count or rate class, or an unknown rate)."""
    return QUAD_VOTE_SHARE_STATS.get(rate) if int(n_motors) == 4 and rate is not None else None


def betaln(a, b) -> np.ndarray:
    """log B(a, b), elementwise (math.lgamma: scipy.special is not needed for a few motors)."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    return np.array([math.lgamma(x) + math.lgamma(y) - math.lgamma(x + y) for x, y in zip(a.ravel(), b.ravel())]
                    ).reshape(a.shape)


def _log_beta_binomial(k: np.ndarray, n: np.ndarray, params: tuple) -> np.ndarray:
    """log P(k votes of n effective windows) under a Beta (a, b) or a two-Beta mixture
    (a1, b1, a2, b2, w) of the vote share; k and n need not be integers (the binomial
    coefficient, the same under every hypothesis, is left out)."""
    if len(params) == 2:
        a, b = params
        return betaln(k + a, n - k + b) - betaln(a, b)
    a1, b1, a2, b2, w = params
    return np.logaddexp(np.log1p(-w) + betaln(k + a1, n - k + b1) - betaln(a1, b1),
                        np.log(w) + betaln(k + a2, n - k + b2) - betaln(a2, b2))


def vote_shares(probs: np.ndarray) -> np.ndarray:
    """(n_motors,) the share of windows whose most probable class is each motor."""
    p = np.asarray(probs, float)
    cls = np.argmax(p, axis=1)
    return np.array([np.mean(cls == k + 1) for k in range(p.shape[1] - 1)])


def effective_windows(covered_s: float, rate: str) -> float:
    """The flight's effective window count for the votes (at least 1)."""
    return max(float(covered_s) / VOTE_DECORRELATION_S[rate], 1.0)


def vote_share_llr(probs: np.ndarray, covered_s: float, stats: VoteShareStats, rate: str) -> np.ndarray:
    """(n_motors,) LLR of "motor k damaged" against a healthy airframe from the windows' vote
    shares (:class:`VoteShareStats`): how consistently the windows name motor k, weighed by how
    many independent windows the flight holds."""
    n = effective_windows(covered_s, rate)
    k = vote_shares(probs) * n
    return _log_beta_binomial(k, n, stats.damaged) - _log_beta_binomial(k, n, stats.healthy)


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
    """(n_motors,) LLR of the model's windows' flight mean for "motor k damaged" vs healthy (module
    docstring); ``healthy_mean`` (n,) and ``healthy_sigma``: the airframe's own healthy means and
    their spread (a profile), else the model's healthy level; ``stats``: the model's vote
    statistics (default: :func:`vote_stats` for the probabilities' rotor count)."""
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


def model_pair_llrs(probs: np.ndarray, covered_s: float, healthy_mean=None, healthy_sigma=None,
                    single: np.ndarray | None = None) -> dict:
    """{(a, b): nats} for "rotors a and b lost thrust" against healthy. The model sees one of the
    two (either, even odds) and the other at the healthy level, so the pair's LLR is
    log(mean(exp(L'_a), exp(L'_b))), where L'_k is motor k's single-rotor LLR (:func:`model_llr`,
    the same levels and profile) plus the log ratio of the pair member's to the single damaged
    motor's vote density measured on the same airframes (:data:`PAIR_VOTE_STATS`): the pair and
    the single rotor are weighed on one footing, and a vote that looks like one damaged rotor
    favours one damaged rotor by what the measurement says, no more. ``single``: the single-rotor
    LLRs the analyzer reports, when another statistic gave them (the vote share at full rate, an
    adapted model's session reference): the pair term is then still the flight mean's measured
    ratio (not re-measured for those statistics)."""
    p = np.asarray(probs, float)
    if p.ndim != 2 or p.shape[0] == 0:
        return {}
    single = model_llr(p, covered_s, healthy_mean, healthy_sigma) if single is None else np.asarray(single, float)
    n = len(single)
    stats = PAIR_VOTE_STATS.get(n)
    ratio = np.zeros(n)
    if stats is not None:
        x = mean_log_ratio(p)
        within = MODEL_WINDOW_SIGMA / np.sqrt(max(covered_s / MODEL_DECORRELATION_S, 1.0))
        if healthy_mean is None:
            (mp, sp), (ms, ss), ref = stats.pair, stats.single, np.zeros(n)
        else:
            (mp, sp), (ms, ss), ref = stats.pair_shift, stats.single_shift, np.asarray(healthy_mean, float)
        ratio = np.array([_gauss_logpdf(v - r, mp, float(np.hypot(sp, within)))
                          - _gauss_logpdf(v - r, ms, float(np.hypot(ss, within))) for v, r in zip(x, ref)])
    seen = single + ratio
    return {(a, b): float(np.logaddexp(seen[a - 1], seen[b - 1]) - np.log(2.0))
            for a in range(1, n + 1) for b in range(a + 1, n + 1)}


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


#: An adapted model against its own profile on a log whose slower motor/rate stream is below
#: reliability.LOW_RATE_HZ (10 Hz RCOU): another session's healthy flight moves every motor's
#: flight-mean log ratio against the profile's vote baseline (measured on the sessions the model
#: was adapted on) by this much on average, with this session-to-session spread. Measured
#: (benchmarks/adapted_vote_drift.py; results/cross_session.md "Adapted model across sessions"):
#: the 16 real healthy cross-session pairs with one-flight adapted profiles (Erle board A 3x2,
#: board B 2x2, rrc_straight goods 3x2; 64 motor values): mean +0.17, standard deviation 1.17
#: (Erle 1.46, up to +4.61 on board A 15-10-2014_42 against 09-10-2014_31; rrc goods 0.35). The
#: decorrelated within-flight term is added on top, as for every profile.
ADAPTED_LOW_RATE_SESSION_OFFSET = 0.17
ADAPTED_LOW_RATE_SESSION_SIGMA = 1.17
#: The same shift and spread for a model made by the convergence-stopped adaptation (profiles whose
#: ``extra.adaptation`` records what was ``trained``: `fdlog calibrate` from the calibration-speed
#: work on, dense layers adapted): the same 16 pairs calibrated again with it (seeds 0 and 1 for
#: Erle A; benchmarks/adapted_vote_drift.py, results/calibrate_speed.md): mean +1.24, standard
#: deviation 1.22 (Erle A +1.65, Erle B +1.76, rrc +0.48). Its votes move a nat more between
#: sessions than the older adaptation's, healthy and damaged alike (rrc 25 mm cuts +5.2..+6.0
#: against +1.9..+5.1), so each adaptation keeps the figures measured on its own models.
ADAPTED_FAST_LOW_RATE_SESSION_OFFSET = 1.24
ADAPTED_FAST_LOW_RATE_SESSION_SIGMA = 1.22
#: The population spread above is a prior worth this many sessions when the profile holds sessions
#: the model never saw (added with ``fdlog calibrate --add``): their votes measure the airframe's own
#: session-to-session spread (the weight command_shares.DRIFT_PRIOR_FLIGHTS gives the shares' prior).
#: The three airframes' own spreads differ fourfold (RMS about the offset: rrc 0.34, Erle A 1.25,
#: Erle B 1.69), and their marginal likelihood prefers a prior worth 0.1-0.25 sessions; but this
#: pools a point estimate, not a heavy-tailed predictive, and at 1 or 0.25 the leave-one-out profile
#: Erle A 09-10-2014_25 + 31 (two sessions) calls 15-10-2014_42 damaged again (model +4.3 / +5.0,
#: measured): with two or three sessions the estimate is too noisy to let the airframe speak alone.
ADAPTED_SESSION_PRIOR_SESSIONS = 3


@dataclass(frozen=True)
class SessionReference:
    """The healthy level a new session's votes are weighed against (per motor) and its spread."""

    healthy_mean: np.ndarray
    sigma: float

    def stats(self, n_motors: int) -> VoteStats:
        """The model's vote statistics with damage's spread widened by the session spread: a damaged
        flight of another session moves by the damage AND by the session."""
        st = vote_stats(n_motors)
        return VoteStats(st.healthy_mean, self.sigma, st.damaged_mean, st.damaged_sigma, st.damage_shift,
                         float(np.hypot(st.shift_sigma, self.sigma)))


def _adapted_at_low_rate(ctx: Context) -> bool:
    """The profile's own adapted model judges a log whose slower motor/rate stream is low-rate (the
    cell where its session drift was measured, ADAPTED_LOW_RATE_SESSION_SIGMA)."""
    from .reliability import LOW_RATE_HZ

    prof = ctx.profile
    if prof is None or not getattr(prof, "model", None):
        return False
    fl = ctx.flight
    # the slower of the two streams, as reliability.LogKind.stream_hz reads it (a missing one is 0)
    rates = [float(getattr(getattr(fl, s, None), "rate_hz", 0.0) or 0.0) for s in ("motors", "rates")]
    return min(rates) < LOW_RATE_HZ


def adapted_session_drift(profile) -> tuple[float, float]:
    """(offset, spread) of an adapted model's votes in a session it never saw, for the adaptation
    that made the profile's model: ADAPTED_FAST_* when its ``extra.adaptation`` records what was
    ``trained`` (the convergence-stopped adaptation), else ADAPTED_LOW_RATE_SESSION_* (profiles made
    before it, whose models those were measured on)."""
    adaptation = ((getattr(profile, "extra", None) or {}).get("adaptation") or {}) if profile is not None else {}
    if isinstance(adaptation, dict) and adaptation.get("trained"):
        return ADAPTED_FAST_LOW_RATE_SESSION_OFFSET, ADAPTED_FAST_LOW_RATE_SESSION_SIGMA
    return ADAPTED_LOW_RATE_SESSION_OFFSET, ADAPTED_LOW_RATE_SESSION_SIGMA


def adapted_session_reference(base: dict, offset: float = ADAPTED_LOW_RATE_SESSION_OFFSET,
                              prior: float = ADAPTED_LOW_RATE_SESSION_SIGMA) -> SessionReference | None:
    """The adapted model's healthy vote level for a session it never saw, and its spread, from the
    profile's vote baseline (:func:`combine_sessions`): each session the model was adapted on
    (``sessions_seen``; a profile without the flags: every session, as ``fdlog calibrate`` adapts
    on all of its flights) raised by ``offset``, the sessions added later as measured; the spread
    of those levels across sessions pooled with ``prior`` (worth ADAPTED_SESSION_PRIOR_SESSIONS
    sessions); both from :func:`adapted_session_drift` for the profile's adaptation. None without
    a usable baseline. Limits: measured at low rate only (full-rate adapted pairs stayed below
    +0.7 nats, results/reliability.md item 3)."""
    rows = base.get("sessions") or [base.get("healthy_mean")]
    rows = [r for r in rows if r]
    if not rows:
        return None
    m = np.array(rows, float)
    seen = base.get("sessions_seen")
    seen = np.array([bool(x) for x in seen], bool) if seen and len(seen) == len(m) else np.ones(len(m), bool)
    level = m + np.where(seen, offset, 0.0)[:, None]
    if len(m) >= 2 and not seen.all():
        own = float(np.sqrt(np.mean(level.std(axis=0, ddof=1) ** 2)))
        dof = len(m) - 1
        k = ADAPTED_SESSION_PRIOR_SESSIONS
        sigma = float(np.sqrt((k * prior ** 2 + dof * own ** 2) / (k + dof)))
    else:
        sigma = prior
    return SessionReference(level.mean(axis=0), max(sigma, MODEL_MIN_HEALTHY_SIGMA))


#: How much of its vote evidence the model has for a rotor at each thrust efficiency eta: the share
#: of held-out simulated windows naming the right motor above chance (7 %: the healthy windows that
#: name some motor, 27.8 %, over four motors), by the damaged propeller's eta (results/model_why.md
#: section 1, shipped model: 0.50-0.65 100 %, 0.65-0.75 96.2 %, 0.75-0.85 73.5 %, 0.85-0.90 36.2 %,
#: 0.90-0.97 13.3 %), at the bins' centres and 0 at eta 1 (healthy), linear between. The vote LLR the
#: statistics give is the evidence at severe damage; at eta the model has this fraction of it, so
#: "the model sees no damage" says little against a 10 % loss the commands can see, and a vote for
#: a motor points at severe damage (:attr:`AnalyzerResult.eta_llrs`).
MODEL_ETA_SENSITIVITY = np.interp(ETA_GRID, [0.575, 0.70, 0.80, 0.875, 0.935, 1.0],
                                  [1.0, 0.96, 0.71, 0.31, 0.07, 0.0])


def vote_eta_llrs(llr: np.ndarray) -> np.ndarray:
    """(n, len(ETA_GRID)): each motor's vote LLR at each eta (:data:`MODEL_ETA_SENSITIVITY`)."""
    return np.outer(np.asarray(llr, float), MODEL_ETA_SENSITIVITY)


class ModelVotes(Analyzer):
    id = "model"
    description = "the model's window votes (mean probability per motor), weighed as one flight"
    requires = ()
    #: Where the reliability table has no cell for the log (or the kind of log is unknown: synthetic
    #: flights, tools) the model gives at most this, the "corroborating" cap the table was measured
    #: with (a nat below the damaged bar of the decision of issue 22-36): it was trained on simulated
    #: airframes, and on a real one a session's trim can look like damage to it (CrazyPAD E9
    #: cut_propeller_M3_2mm logs 04-05: a calibrated model 6 sigma sure of motor 1, whose command
    #: rose only 4 %, while the label says motor 2). Every real log has a cell, whose trust level
    #: sets the cap instead (decision.TRUST_CAPS: up to SOURCE_LLR_CAP where it is trusted, a nat
    #: below the posterior's damaged bar where it corroborates).
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
            reference = (adapted_session_reference(base, *adapted_session_drift(ctx.profile))
                         if _adapted_at_low_rate(ctx) else None)
            if reference is not None:
                llr = model_llr(p, ctx.covered_s, reference.healthy_mean, reference.sigma,
                                reference.stats(p.shape[1] - 1))
            else:
                from .command_shares import pooled_sigma

                sigma = max(pooled_sigma(base.get("spread"), int(base.get("n_flights", 1)), MODEL_HEALTHY_SIGMA),
                            MODEL_MIN_HEALTHY_SIGMA)
                llr = model_llr(p, ctx.covered_s, base["healthy_mean"], sigma)
            level = (reference.healthy_mean if reference is not None else base["healthy_mean"])
            pairs = model_pair_llrs(p, ctx.covered_s, level, single=llr)
        else:
            if base:
                notes.append("the profile's model-vote baseline was measured with another model: not used")
            rate = flight_rate_class(ctx.flight)
            shares = vote_share_stats(p.shape[1] - 1, rate)
            llr = vote_share_llr(p, ctx.covered_s, shares, rate) if shares is not None else model_llr(p, ctx.covered_s)
            pairs = model_pair_llrs(p, ctx.covered_s, single=llr)
        votes = p[:, 1:].mean(axis=0)
        per_eta = vote_eta_llrs(llr)
        marginal = log_mean_exp(per_eta, axis=1)  # the vote's evidence over the shared eta prior
        return AnalyzerResult(self.id, [Finding(self.id, k + 1, "vote", float(votes[k]), "", None, None, "up",
                                                float(marginal[k]), f"{votes[k]:.2f}") for k in range(len(llr))],
                              notes=notes, pair_llrs=pairs, eta_llrs={k + 1: per_eta[k] for k in range(len(llr))})
