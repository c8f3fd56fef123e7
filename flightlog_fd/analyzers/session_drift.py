"""An airframe's own session-to-session drift of its command shares and throttle, learned from the
profile's calibration sessions and weighed from the second session on.

What: :class:`SessionDrift`, the healthy noise the command-share and throttle analyzers weigh a
flight with against a profile holding two or more sessions (a session: one flight, or flights the
user grouped; :attr:`flightlog_fd.profile.Profile.sessions_`). Each session gave its airborne-mean
command shares (mean 1), its mean throttle and how well it pins its shares
(:func:`~flightlog_fd.analyzers.share_fit.pin_spread`).

Model: a session's shares and log throttle are the airframe's healthy level, plus a session move
of scale ``tau`` times the population drift (each share ``tau * share_scale``, the log throttle
``tau * throttle_scale``: the constants a one-session profile is weighed with,
``command_shares.DEFAULT_DRIFT_SIGMA`` and ``THROTTLE_DRIFT_SIGMA``), plus the session's own
pinning noise. One ``tau`` for both, because one event (a battery, a payload, a re-trim, a logged
output range) moves both: measured per airframe (``benchmarks/session_prior.py``), the shares' and
the throttle's own scales rank the six airframes alike. The prior on ``tau^2`` is the population
drift: scaled inverse chi-square centred on ``tau = 1`` (today's constants), worth
``SESSION_PRIOR_SESSIONS`` pseudo-sessions; each session updates it (on a grid of ``tau^2``,
because the pinning noise differs per session), and a new flight is weighed with the posterior
mixture over ``tau``: a Student-t (n - 1 + 1 degrees of freedom per session, on top of the
prior's) when the pinning noise is negligible. Heavy-tailed with two sessions, the airframe's own
spread with many.

Limits: the shares' sum constraint is taken into account by counting n - 1 of n shares in each
variance term; the location is the equal-weight mean of the sessions (a session move is the
larger noise on every airframe measured); the flight's shares are compared at the baseline's
throttle slope, which comes from the calibration flights' chunks.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np


#: Strength of the population-drift prior on an airframe's session scale, in pseudo-sessions (a
#: session gives n degrees of freedom on an n-rotor: its n - 1 free shares and its throttle).
#: Chosen by maximum marginal likelihood over the six airframes with repeated healthy flights
#: (benchmarks/session_prior.py: Erle boards A and B, the Erle day-2014-09-07 pair, rrc_straight
#: goods, CrazyPAD E9 normals, px4_sih_dev healthy) with the prior centred on today's constants
#: (tau0 = 1): their own scales tau^2 span 0.0014 (CrazyPAD) to 141 (Erle board B), so the data
#: want a prior worth a tenth of a session (best 0.08; 0.05-0.1 with any one airframe held out).
#: A second session therefore already lets the airframe speak for itself, and with few sessions
#: the predictive stays heavy-tailed (a Student-t with 4.3 degrees of freedom from two quad
#: sessions). The centre is kept at 1 although 0.2 fits better (by 5.6 nats): it only matters
#: below tau^2 ~ 0.2, where it keeps a quiet airframe's noise from shrinking under the
#: population's small drift faster than its sessions show.
SESSION_PRIOR_SESSIONS = 0.08
#: Centre of the prior on tau (1: the population drift constants themselves).
SESSION_PRIOR_TAU = 1.0
#: Grid of tau^2 the posterior is held on (log-spaced): 1e-4 (a hundredth of the population
#: drift) to 1e5 (every share free): the measured airframes' scales lie well inside it.
TAU2_GRID = np.exp(np.linspace(np.log(1e-4), np.log(1e5), 121))


@dataclass
class SessionFigures:
    """The figures of a profile's sessions the drift is learned from: ``shares`` (S, n) each
    session's airborne-mean command shares (mean 1), ``throttles`` (S,) its mean thrust command,
    ``pins`` (S, n) how well it pins its shares (NaN where unknown)."""

    shares: np.ndarray
    throttles: np.ndarray
    pins: np.ndarray

    def __post_init__(self) -> None:
        self.shares = np.atleast_2d(np.asarray(self.shares, float))
        self.throttles = np.asarray(self.throttles, float).reshape(-1)
        self.pins = np.atleast_2d(np.asarray(self.pins, float))

    @property
    def n_sessions(self) -> int:
        return int(self.shares.shape[0])


@dataclass
class SessionDrift:
    """The posterior over an airframe's session scale ``tau`` (module docstring) and what it predicts
    for a new flight. Build with :meth:`fit`."""

    tau2: np.ndarray  # (G,) grid
    log_w: np.ndarray  # (G,) posterior log weights (normalised)
    share_scale: float
    throttle_scale: float
    session_var: np.ndarray  # (G, n) variance of the sessions' mean share (the location) at each tau
    n_sessions: int
    prior_dof: float

    @classmethod
    def fit(cls, sessions: SessionFigures, share_scale: float, throttle_scale: float,
            prior_sessions: float = SESSION_PRIOR_SESSIONS, prior_tau: float = SESSION_PRIOR_TAU,
            grid: np.ndarray = TAU2_GRID) -> "SessionDrift":
        """The posterior from ``sessions`` (at least two), the population scales and the prior."""
        s, n = sessions.shares.shape
        if s < 2:
            raise ValueError("the session drift needs at least two sessions")
        ll, session_var = session_loglik(sessions, share_scale, throttle_scale, grid)
        nu0 = prior_sessions * n
        log_post = log_prior(grid, nu0, prior_tau) + ll
        log_post -= logsumexp(log_post)
        return cls(tau2=grid, log_w=log_post, share_scale=float(share_scale), throttle_scale=float(throttle_scale),
                   session_var=session_var, n_sessions=s, prior_dof=nu0)

    # ------------------------------------------------------------------ prediction
    def share_var(self, flight_pin: Optional[Sequence[float]] = None) -> np.ndarray:
        """(G, n) variance of a new flight's shares about the sessions' mean, at each tau: the
        session move, this flight's pinning noise and the mean's own uncertainty."""
        n = self.session_var.shape[1]
        pin2 = np.zeros(n) if flight_pin is None else np.nan_to_num(np.asarray(flight_pin, float), nan=0.0) ** 2
        return self.tau2[:, None] * self.share_scale ** 2 + pin2[None] + self.session_var

    def throttle_var(self) -> np.ndarray:
        """(G,) variance of a new flight's log throttle about the sessions' mean."""
        return self.tau2 * self.throttle_scale ** 2 * (1.0 + 1.0 / self.n_sessions)

    def loglik(self, resid, thr_resid=None, flight_pin=None) -> np.ndarray:
        """Log density (...) of share residuals ``resid`` (..., n) and, when given, log-throttle
        residuals ``thr_resid`` (...), under the posterior mixture over tau (the grid points of
        negligible posterior weight, below e^-30 of the largest, left out)."""
        keep = self.log_w > self.log_w.max() - 30.0
        var = self.share_var(flight_pin)[keep]  # (G', n)
        n = var.shape[1]
        r = np.asarray(resid, float)
        ll = -0.5 * ((r ** 2) @ (1.0 / var).T + (n - 1) / n * np.sum(np.log(2 * np.pi * var), axis=-1))
        if thr_resid is not None:
            vt = self.throttle_var()[keep]
            t = np.asarray(thr_resid, float)[..., None]
            ll = ll - 0.5 * (t ** 2 / vt + np.log(2 * np.pi * vt))
        return logsumexp(ll + self.log_w[keep], axis=-1)

    def chi2_equivalent(self, resid, thr_resid=None, flight_pin=None) -> float:
        """The chi-square (n - 1 degrees of freedom, n with the throttle) with the same tail
        probability as these residuals have under the posterior mixture: what a fixed-noise
        chi-square threshold means, read on this heavy-tailed noise."""
        r = np.asarray(resid, float)
        var = self.share_var(flight_pin)
        q = np.sum(r[None] ** 2 / var, axis=-1)
        dof = var.shape[1] - 1
        if thr_resid is not None:
            q = q + float(thr_resid) ** 2 / self.throttle_var()
            dof += 1
        from scipy.special import gammaincc, gammainccinv  # here: only a multi-session profile needs it

        p = float(np.sum(np.exp(self.log_w) * gammaincc(dof / 2.0, q / 2.0)))
        return float(2.0 * gammainccinv(dof / 2.0, max(p, 1e-300)))

    # ------------------------------------------------------------------ figures for people
    def share_sigma(self, flight_pin=None) -> np.ndarray:
        """(n,) effective per-motor share noise (the root of the posterior-mean variance)."""
        return np.sqrt(np.exp(self.log_w) @ self.share_var(flight_pin))

    def throttle_sigma(self) -> float:
        """Effective relative throttle noise (the root of the posterior-mean variance)."""
        return float(np.sqrt(np.exp(self.log_w) @ self.throttle_var()))

    def tau_median(self) -> float:
        """Posterior median of tau (1 = the population drift)."""
        w = np.exp(self.log_w)
        cdf = np.cumsum(w) - 0.5 * w  # each grid point at the middle of its mass
        return float(np.exp(0.5 * np.interp(0.5, cdf, np.log(self.tau2))))


def session_loglik(sessions: SessionFigures, share_scale: float, throttle_scale: float,
                   grid: np.ndarray = TAU2_GRID) -> tuple[np.ndarray, np.ndarray]:
    """(G,) log-likelihood of the sessions' shares and log throttles at each tau^2 of ``grid``, the
    airframe's level unknown (restricted likelihood; n - 1 of the n shares free), and (G, n) the
    variance of the sessions' equal-weight mean share at each tau^2."""
    z, thr, pins = sessions.shares, sessions.throttles, sessions.pins
    s, n = z.shape
    p2 = np.where(np.isfinite(pins), pins, 0.0) ** 2  # (S, n)
    v = grid[:, None, None] * share_scale ** 2 + p2[None]  # (G, S, n)
    w = 1.0 / v
    mu = (z[None] * w).sum(axis=1, keepdims=True) / w.sum(axis=1, keepdims=True)
    q = ((z[None] - mu) ** 2 * w).sum(axis=(1, 2))
    logdet = (np.log(v).sum(axis=1) + np.log(w.sum(axis=1))).sum(axis=1)
    ll = -0.5 * q - 0.5 * (n - 1) / n * logdet
    lt = np.log(thr)
    vt = grid * throttle_scale ** 2
    ll = ll - 0.5 * ((lt - lt.mean()) ** 2).sum() / vt - 0.5 * (s - 1) * np.log(vt)
    return ll, v.sum(axis=1) / s ** 2


def log_prior(grid: np.ndarray, dof: float, tau: float) -> np.ndarray:
    """The scaled inverse chi-square prior on tau^2 (``dof`` degrees of freedom, centre ``tau``^2),
    as a normalised log density in log tau^2 (the grid's measure)."""
    from scipy.special import gammaln  # here: only a multi-session profile needs it

    a = 0.5 * dof
    return a * np.log(a * tau ** 2) - gammaln(a) - a * np.log(grid) - a * tau ** 2 / grid


def logsumexp(a, axis=None) -> np.ndarray:
    """log(sum(exp(a))) along ``axis``, without overflow."""
    a = np.asarray(a, float)
    top = np.max(a, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    out = np.log(np.sum(np.exp(a - top), axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis) if axis is not None else out.reshape(())
