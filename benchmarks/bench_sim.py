"""Simulator throughput: simulated flight-seconds per wall-clock second for one batch.

Usage: ``python benchmarks/bench_sim.py [--vehicles 256] [--duration 60] [--profiles training,px4_high]
[--imbalance random]`` (``--imbalance random``: realistic airframe imbalance and damaged-propeller
torque loss, as the shipped model's training data)

For each profile, flies one batch of random airframes on the waypoint mission and prints the wall
time of the simulation (time loop) and of the Flight assembly (logger), the logged flight-seconds
(sum of each Flight's duration) and flight-seconds per wall-second. Prints figures only; the
project's goal is >= 2000 flight-s per wall-s on a 2-core machine.
"""
from __future__ import annotations

import argparse
import time

from flightlog_fd.sim.api import flights_from_batch, simulate_batch


def bench(profile: str, vehicles: int, duration_s: float, seed: int, imbalance: str | None = None) -> dict:
    kw = {} if imbalance is None else {"imbalance": imbalance, "torque_exponent_range": (1.0, 1.6)}
    t0 = time.perf_counter()
    batch = simulate_batch(vehicles, mission="waypoints", duration_s=duration_s, profile=profile, seed=seed, **kw)
    t1 = time.perf_counter()
    flights = flights_from_batch(batch)
    t2 = time.perf_counter()
    flight_s = sum(f.duration_s for f in flights)
    steps = batch.result.t_end / batch.result.dt
    return {"profile": profile, "vehicles": vehicles, "sim_s": t1 - t0, "assemble_s": t2 - t1,
            "flight_s": flight_s, "rate": flight_s / (t2 - t0), "us_per_step": (t1 - t0) / steps * 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, default=256)
    ap.add_argument("--duration", type=float, default=60.0, help="planned flight length, s")
    ap.add_argument("--profiles", default="training,px4_high")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--imbalance", default=None, help="'random': realistic airframe imbalance (sim/imbalance.py)")
    args = ap.parse_args()
    print(f"{'profile':<15}{'vehicles':>9}{'sim s':>9}{'assemble s':>12}{'flight-s':>11}{'flight-s/s':>12}"
          f"{'us/step':>9}")
    for profile in args.profiles.split(","):
        r = bench(profile.strip(), args.vehicles, args.duration, args.seed, args.imbalance)
        print(f"{r['profile']:<15}{r['vehicles']:>9}{r['sim_s']:>9.1f}{r['assemble_s']:>12.2f}{r['flight_s']:>11.0f}"
              f"{r['rate']:>12.0f}{r['us_per_step']:>9.0f}")


if __name__ == "__main__":
    main()
