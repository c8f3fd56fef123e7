"""The population prior on an airframe's session-to-session drift, measured across airframes.

    python benchmarks/session_prior.py

Every airframe in ``../shared`` with two or more healthy flights (``bench_cross_session.airframes``:
the Erle board groups, the rrc_straight good flights, the CrazyPAD E9 normals, px4_sih_dev
healthy), each flight one calibration session (:func:`flightlog_fd.calibration.session_entry`).
Prints, per airframe, its sessions' shares and throttles and the maximum-likelihood session scale
tau^2 (1 = the population drift constants ``DEFAULT_DRIFT_SIGMA`` per share and
``THROTTLE_DRIFT_SIGMA`` of throttle) from the shares and throttle together, from the shares
alone and from the throttle alone (is one scale for both right?); then the marginal likelihood of
all airframes' sessions under the scaled inverse chi-square prior of
:mod:`flightlog_fd.analyzers.session_drift` over its strength (pseudo-sessions) with the centre at
today's constants (tau0 = 1) and with the centre free, the best strength with each airframe held
out, and what the chosen prior predicts for a second session.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cross_session import SHARED, airframes  # noqa: E402

from flightlog_fd import load_flight  # noqa: E402
from flightlog_fd.analyzers.command_shares import DEFAULT_DRIFT_SIGMA, THROTTLE_DRIFT_SIGMA  # noqa: E402
from flightlog_fd.analyzers.session_drift import (SESSION_PRIOR_SESSIONS, TAU2_GRID, SessionFigures,  # noqa: E402
                                                  log_prior, logsumexp, session_loglik)
from flightlog_fd.calibration import session_entry  # noqa: E402

STRENGTHS = (0.01, 0.02, 0.05, 0.08, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 2.0, 3.0)
CENTRES = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


def figures(sessions: list[dict]) -> SessionFigures:
    n = len(sessions[0]["share"])
    return SessionFigures(shares=[s["share"] for s in sessions], throttles=[s["throttle"] for s in sessions],
                          pins=[s["pin"] if s.get("pin") is not None else [np.nan] * n for s in sessions])


def evidence(ll: np.ndarray, strength: float, centre: float, n: int) -> float:
    """log marginal likelihood of one airframe's sessions (its per-tau^2 log-likelihood ``ll``)."""
    return float(logsumexp(log_prior(TAU2_GRID, strength * n, centre) + ll + np.log(np.gradient(np.log(TAU2_GRID)))))


def main() -> None:
    if not SHARED.is_dir():
        raise SystemExit(f"{SHARED}: not found (the benchmark needs ../shared)")
    per_af: dict[str, tuple[np.ndarray, int]] = {}
    print("## Each airframe's sessions (one flight each)\n")
    print("| airframe | sessions | tau^2 (shares + throttle) | tau^2 (shares alone) | tau^2 (throttle alone) | throttles |")
    print("|---|---|---|---|---|---|")
    for af in airframes():
        sessions = []
        for p in af.healthy:
            fl = load_flight(p)
            sessions.append(session_entry([fl]))
        figs = figures(sessions)
        n = figs.shares.shape[1]
        ll, _ = session_loglik(figs, DEFAULT_DRIFT_SIGMA, THROTTLE_DRIFT_SIGMA)
        per_af[af.name] = (ll, n)
        # shares alone: the throttle scale made huge; the throttle alone: its own sample variance
        ll_sh, _ = session_loglik(figs, DEFAULT_DRIFT_SIGMA, 1e6)
        lt = np.log(figs.throttles)
        thr_tau2 = float(np.var(lt, ddof=1) / THROTTLE_DRIFT_SIGMA ** 2)
        print(f"| {af.name} | {figs.n_sessions} | {TAU2_GRID[np.argmax(ll)]:.3g} | {TAU2_GRID[np.argmax(ll_sh)]:.3g} | "
              f"{thr_tau2:.3g} | {', '.join(f'{t:.3f}' for t in figs.throttles)} |")

    def total(strength, centre, skip=None):
        return sum(evidence(ll, strength, centre, n) for k, (ll, n) in per_af.items() if k != skip)

    print("\n## Marginal log-likelihood of all airframes' sessions over the prior's strength (pseudo-sessions)\n")
    print("| strength | " + " | ".join(f"centre {c:g}" for c in CENTRES) + " |")
    print("|---|" + "---|" * len(CENTRES))
    for k in STRENGTHS:
        print(f"| {k:g} | " + " | ".join(f"{total(k, c):.2f}" for c in CENTRES) + " |")
    at_one = max(STRENGTHS, key=lambda k: total(k, 1.0))
    free = max(((k, c) for k in STRENGTHS for c in CENTRES), key=lambda kc: total(*kc))
    print(f"\nBest strength with the centre at today's constants (tau0 = 1): {at_one:g} pseudo-sessions "
          f"({total(at_one, 1.0):.2f}); with the centre free: {free[0]:g} at tau0 = {free[1]:g} ({total(*free):.2f}). "
          f"Used: SESSION_PRIOR_SESSIONS = {SESSION_PRIOR_SESSIONS:g}.")
    print("\nHeld out one airframe at a time (centre 1): " + ", ".join(
        f"without {a}: {max(STRENGTHS, key=lambda k: total(k, 1.0, skip=a)):g}" for a in per_af))


if __name__ == "__main__":
    main()
