"""How well the per-motor effectiveness estimate recovers a damaged rotor's η, by logging rate.

    python benchmarks/bench_effectiveness.py [--per-eta 4] [--duration 60]

Simulates flights on random airframes (balanced motors, so the truth is exactly η for the
damaged rotor and 1 for the others) with one rotor at η in {0.6, 0.7, 0.8, 0.9, 0.95} and
healthy ones, for the high-rate PX4 profile (250 Hz motors), ArduPilot RATE at 50 Hz, and the
10 Hz motor logging of PX4's default profile; then prints per profile and η: the mean and the
largest absolute error of the damaged rotor's estimate, how often it is the weakest motor, how
often the estimate says it is informative, the median interval width, and for healthy flights the
largest deviation of any motor from 1. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

ETAS = (0.6, 0.7, 0.8, 0.9, 0.95)
PROFILES = ("px4_high", "ardupilot", "px4_default")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-eta", type=int, default=4)
    ap.add_argument("--duration", type=float, default=60.0, help="simulated flight length, s")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--profiles", default=",".join(PROFILES))
    args = ap.parse_args()

    from flightlog_fd.analyzers.effectiveness_fit import estimate_effectiveness
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    rng = np.random.default_rng(args.seed)
    damages = [Damage(0, 1.0)] * args.per_eta
    for eta in ETAS:
        damages += [Damage(int(rng.integers(1, 5)), eta) for _ in range(args.per_eta)]
    print(f"{len(damages)} flights per profile, {args.duration:.0f} s, random airframes, balanced motors")
    print(f"{'profile':12s} {'inputs':8s} {'eta':>5s} {'mean est':>8s} {'max |err|':>9s} {'±0.03':>6s} "
          f"{'weakest':>7s} {'informative':>11s} {'CI width':>8s}")
    for prof in args.profiles.split(","):
        t0 = time.perf_counter()
        flights = simulate_flights(len(damages), damages=damages, duration_s=args.duration, profile=prof,
                                   seed=args.seed, rho=None)
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        runs = {"gyro": [estimate_effectiveness(f) for f in flights]}
        t_est = (time.perf_counter() - t0) / len(flights)
        for inputs in runs:
            ests = runs[inputs]
            healthy = [e for d, e in zip(damages, ests) if d.motor == 0]
            dev = [np.nanmax(np.abs(e.values - 1.0)) for e in healthy]
            inf = np.mean([e.informative for e in healthy])
            print(f"{prof:12s} {inputs:8s} {'1.00':>5s} {'':>8s} {np.max(dev):9.3f} "
                  f"{np.mean(np.array(dev) <= 0.03):6.0%} {'':>7s} {inf:11.0%} "
                  f"{np.median([np.nanmax(e.ci[:, 1] - e.ci[:, 0]) for e in healthy]):8.3f}   "
                  f"(healthy: largest |e-1|)")
            within = []
            for eta in ETAS:
                rows = [(d, e) for d, e in zip(damages, ests) if d.motor and abs(d.eta - eta) < 1e-9]
                est = np.array([e.values[d.motor - 1] for d, e in rows])
                weakest = np.mean([e.weakest() == d.motor for d, e in rows])
                informative = np.mean([e.informative for _, e in rows])
                width = np.median([e.ci[d.motor - 1, 1] - e.ci[d.motor - 1, 0] for d, e in rows])
                ok = np.abs(est - eta) <= 0.03
                if eta <= 0.9:
                    within += list(ok)
                print(f"{prof:12s} {inputs:8s} {eta:5.2f} {np.nanmean(est):8.3f} {np.nanmax(np.abs(est - eta)):9.3f} "
                      f"{np.mean(ok):6.0%} {weakest:7.0%} {informative:11.0%} {width:8.3f}")
            print(f"{prof:12s} {inputs:8s} eta<=0.9: {np.mean(within):.0%} of damaged flights within ±0.03")
        print(f"{prof:12s} simulated in {t_sim:.1f} s; "
              f"estimate {1000 * t_est:.0f} ms per flight")


if __name__ == "__main__":
    main()
