"""What a healthy airframe's load changes do to the command shares, against what a weak rotor does.

    python benchmarks/cross_session_physics.py [--sim] [--profile px4_default]

For a quad X and a quad + (the simulator's f450 preset flown as each frame): the per-motor
command-share change (thrust proxy, mean 1, the quantity ``fdlog diagnose`` weighs) and the
throttle ratio that each of these makes against the balanced airframe:

- a centre-of-mass shift of 5 % of the arm along each body axis and each diagonal (a battery slid,
  a camera swapped), and of 10 % forward;
- a yaw re-trim (every motor tilted 0.5 deg the same way: a bent mount after a crash);
- payload / battery mass +10 % and -10 %;
- one rotor at eta 0.9 and 0.8 (drag torque eta**m, m = 1 and 0.5), for comparison.

Two ways: the static force/moment balance through the geometry (``sim.imbalance.hover_commands``
and the command analyzer's ``predicted_commands``), and with ``--sim`` the 6-DoF simulator flying
60 s waypoint missions with each change, read back through the diagnose pipeline's share estimate
(so the controller, the thrust model and the logging rate are in it).
"""
from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from flightlog_fd.analyzers.command_shares import _mixer_rows, predicted_commands
from flightlog_fd.flight import Frame
from flightlog_fd.sim.airframe import preset
from flightlog_fd.sim.imbalance import AirframeImbalance, hover_commands

COM = 0.05  # fraction of the arm
CASES = [
    ("CoM +x (forward) 5 %", dict(cog=(COM, 0.0))),
    ("CoM +x (forward) 10 %", dict(cog=(2 * COM, 0.0))),
    ("CoM +y (right) 5 %", dict(cog=(0.0, COM))),
    ("CoM to front-right 5 %", dict(cog=(COM / np.sqrt(2), COM / np.sqrt(2)))),
    ("CoM to rear-right 5 %", dict(cog=(-COM / np.sqrt(2), COM / np.sqrt(2)))),
    ("yaw re-trim (tilt 0.5 deg)", dict(tilt=0.5)),
    ("mass +10 %", dict(mass=1.10)),
    ("mass -10 %", dict(mass=0.90)),
]
DAMAGES = [(1, 0.9, 1.0), (1, 0.8, 1.0), (1, 0.8, 0.5), (4, 0.8, 1.0)]


def _imbalance(c: dict) -> AirframeImbalance:
    tilt = np.radians(c.get("tilt", 0.0))
    return AirframeImbalance(cog_offset=c.get("cog", (0.0, 0.0)), motor_tilt_rad=(tilt,) * 4)


def _fmt(change: np.ndarray, thr: float) -> str:
    return " ".join(f"{x:+.3f}" for x in change) + f" | {thr:.3f}"


def static(frame_name: str) -> None:
    af = preset("f450", frame_name)
    u0 = hover_commands(af, AirframeImbalance())
    s0 = u0 / u0.mean()
    print(f"\n### {frame_name}, static balance (f450: hover command {u0.mean():.3f})\n")
    print("| change | share change m1 m2 m3 m4 | throttle ratio |")
    print("|---|---|---|")
    for name, c in CASES:
        a = replace(af, mass=af.mass * c.get("mass", 1.0))
        u = hover_commands(a, _imbalance(c))
        ch = u / u.mean() - s0
        print(f"| {name} | " + " ".join(f"{x:+.3f}" for x in ch) + f" | {u.mean() / u0.mean():.3f} |")
    frame = Frame.quad_x() if frame_name == "quad_x" else Frame.quad_plus()
    rows = _mixer_rows(frame, 4)
    for motor, eta, m in DAMAGES:
        u = predicted_commands(np.ones(4), rows, motor, eta, m)
        ch = u / u.mean() - 1.0
        print(f"| motor {motor} eta {eta} (m {m}) | " + " ".join(f"{x:+.3f}" for x in ch) + f" | {u.mean():.3f} |")


def simulated(frame_name: str, profile: str, seed: int) -> None:
    from flightlog_fd.analyzers.share_fit import shares_of as command_shares
    from flightlog_fd.analyzers.share_fit import airborne_thrust
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    af = preset("f450", frame_name)
    specs = [("balanced", af, AirframeImbalance(), Damage())]
    for name, c in CASES:
        specs.append((name, replace(af, mass=af.mass * c.get("mass", 1.0)), _imbalance(c), Damage()))
    for motor, eta, m in DAMAGES:
        specs.append((f"motor {motor} eta {eta} (m {m})", af, AirframeImbalance(), Damage(motor, eta, eta_torque=eta ** m)))
    fl = simulate_flights(len(specs), airframes=[s[1] for s in specs], imbalance=[s[2] for s in specs],
                          damages=[s[3] for s in specs], mission="waypoints", duration_s=60.0, profile=profile,
                          seed=seed)
    res = [command_shares(airborne_thrust([f])) for f in fl]
    s0, t0 = res[0]
    print(f"\n### {frame_name}, simulated ({profile} logging, 60 s waypoint missions, seed {seed})\n")
    print("| change | share change m1 m2 m3 m4 | throttle ratio |")
    print("|---|---|---|")
    for (name, *_), (s, t) in zip(specs, res):
        print(f"| {name} | " + " ".join(f"{x:+.3f}" for x in s - s0) + f" | {t / t0:.3f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sim", action="store_true", help="also fly the changes in the simulator")
    ap.add_argument("--profile", default="px4_default", help="logging profile of the simulated flights")
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args()
    for fr in ("quad_x", "quad_plus"):
        static(fr)
    if args.sim:
        for fr in ("quad_x", "quad_plus"):
            simulated(fr, args.profile, args.seed)


if __name__ == "__main__":
    main()
