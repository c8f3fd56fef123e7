"""The simulator's loads against genuine firmware, and a swinging payload's pendulum: figures for
results/sim_loads.md.

    python benchmarks/sim_loads_check.py [sih] [sitl] [pendulum] [hook]     # default: all four

- ``sih``: PX4 SIH (``../shared/px4_sih_dev_load``, the CoM moved 0.03 m toward motor 1 or 3,
  0.05 m forward) against the ``sih`` preset (SIH's own parameters) carrying the same CoM shift
  (a battery of 25 % of the mass moved by 4x the offset): each motor's median output while
  airborne (the first and last 3 s cut) on the real logs, as flown by fdlog's simulator with the
  same kind of mission (waypoints, px4_high), and the static balance (sim/loads.py static_hover).
- ``sitl``: the ArduCopter 4.7 SITL observation of issue 32 (a 3 kg quad, CoM 30 mm toward motor
  1: motor 1 +46 us, the opposite -55 us, the others unchanged; SIM_ENGINE_MUL 0.75 on motor 1:
  +197 us on it alone) against a SITL-like airframe (3 kg, + frame, rotors 0.35 m from the centre
  as SITL's diagonal_size, hover output 0.39 through MOT_THST_EXPO 0.65): the median RCOU (us) of each
  motor in a 40 s hover, minus the healthy hover's; the weak motor flown at eta 0.75 and 0.5625
  (0.75 of the speed: thrust 0.75^2).
- ``pendulum``: an X500 with a payload of 15 % of the take-off mass on a 0.5, 1 and 2 m line,
  hover / manual / waypoint missions, seeds 1-2, px4_high: the swing's own frequency (the
  ``swing`` stream), and the power of the rates and accelerations (x and y) within ±10 % of
  the coupled pendulum frequency sqrt(g/L · (1 + m/M)) / 2π against the same band of the same
  airframe flown unloaded (ratio > 1: a peak, < 1: a notch); ``hook``: the same on a hook 15 cm
  below the centre (hover and manual).
Figures only; nothing is asserted.
"""
from __future__ import annotations

import csv
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
sys.path.insert(0, str(ROOT))

CUT_S = 3.0


def airborne_median(fl, values=None, t=None) -> np.ndarray:
    """Each motor's median output while airborne, the first and last CUT_S seconds cut."""
    t = fl.motors.t if t is None else t
    v = fl.motors.values if values is None else values
    keep = np.zeros(t.shape, bool)
    for a, b in fl.airborne:
        keep |= (t > a + CUT_S) & (t < b - CUT_S)
    return np.median(v[keep], axis=0)


def sih() -> None:
    from flightlog_fd.logs.ulog import read_ulog
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.loads import Load, static_hover

    folder = SHARED / "px4_sih_dev_load"
    rows = list(csv.DictReader(open(folder / "manifest.csv")))
    af = preset("sih")
    loads = [Load("battery", mass_fraction=0.25, position=(4 * float(r["offset_x_m"]), 4 * float(r["offset_y_m"]), 0.0))
             for r in rows]
    flown = simulate_flights(len(rows) + 1, airframes="sih", damages=[None] * (len(rows) + 1), mission="waypoints",
                             duration_s=65.0, profile="px4_high", seed=5, loads=[None] + loads)
    print("## PX4 SIH: the CoM moved (motor outputs, median airborne)\n")
    print("| flight | offset x, y m | source | m1 | m2 | m3 | m4 |")
    print("|---|---|---|---|---|---|---|")
    healthy = SHARED / "px4_sih_dev" / "sih_004.ulg"
    if healthy.exists():
        print("| sih_004 healthy | 0, 0 | PX4 SIH firmware | " + " | ".join(f"{x:.3f}" for x in airborne_median(read_ulog(str(healthy)))) + " |")
    print("| healthy | 0, 0 | fdlog sim flown | " + " | ".join(f"{x:.3f}" for x in airborne_median(flown[0])) + " |")
    for r, ld, fl in zip(rows, loads, flown[1:]):
        real = airborne_median(read_ulog(str(folder / r["file"])))
        off = f"{float(r['offset_x_m']):.3f}, {float(r['offset_y_m']):.3f}"
        print(f"| {r['file']} | {off} | PX4 SIH firmware | " + " | ".join(f"{x:.3f}" for x in real) + " |")
        print(f"| | | manifest hover | " + " | ".join(f"{float(r[f'hover_m{k}']):.3f}" for k in range(1, 5)) + " |")
        print(f"| | | fdlog sim flown | " + " | ".join(f"{x:.3f}" for x in airborne_median(fl)) + " |")
        print(f"| | | fdlog static balance | " + " | ".join(f"{x:.3f}" for x in static_hover(af, ld)) + " |")
    print()


def sitl_airframe():
    """A SITL-like 3 kg quad + (module docstring)."""
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.logger import ARDUPILOT_THST_EXPO

    s = 0.39  # SITL copter hoverThrOut
    thrust_frac = (1 - ARDUPILOT_THST_EXPO) * s + ARDUPILOT_THST_EXPO * s * s
    base = preset("x500", "quad_plus")
    t_max = 3.0 * 9.80665 / (4 * thrust_frac)
    arm = 0.35  # SITL's diagonal_size 0.35 as the motor's distance from the centre: +46 us fits it (see results)
    ixx = 0.17 * 3.0 * arm ** 2  # the X500 preset's I = 0.17·m·l²
    return replace(base, name="sitl_like", mass=3.0, arm=arm, inertia=(ixx, ixx, 1.8 * ixx),
                   k_f=t_max / base.omega_max ** 2, k_tau=base.torque_ratio * t_max / base.omega_max ** 2, gains=None)


def sitl() -> None:
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage
    from flightlog_fd.sim.loads import Load

    af = sitl_airframe()
    frac = 0.25
    # + frame: motor 1 on the right (y > 0); the CoM moves by frac · displacement.
    cases = [("healthy", None, None), ("CoM 30 mm toward motor 1", None, Load("battery", mass_fraction=frac, position=(0, 0.03 / frac, 0))),
             ("CoM 50 mm toward motor 1", None, Load("battery", mass_fraction=frac, position=(0, 0.05 / frac, 0))),
             ("motor 1 weak, eta 0.75", Damage(1, 0.75, cause="motor"), None),
             ("motor 1 weak, eta 0.5625 (speed 0.75)", Damage(1, 0.5625, cause="motor"), None)]
    fl = simulate_flights(len(cases), airframes=af, damages=[c[1] for c in cases], loads=[c[2] for c in cases],
                          mission="hover", duration_s=50.0, profile="ardupilot_fast", seed=3)
    us = [1000.0 + 1000.0 * airborne_median(f, f.alt_motors["RCOU"].values, f.alt_motors["RCOU"].t) for f in fl]
    print(f"## ArduCopter SITL-like quad + (3 kg, arm {af.arm} m, hover command {af.hover_command:.3f} of full "
          f"thrust): RCOU us, median of a 40 s hover\n")
    print("| case | m1 (right) | m2 (left) | m3 (front) | m4 (rear) | change m1 / m2 / m3 / m4 | SITL (issue 32) |")
    print("|---|---|---|---|---|---|---|")
    sitl_obs = {1: "+46 / -55 / 0 / 0", 3: "+197 / 0 / 0 / 0 (SIM_ENGINE_MUL 0.75)",
                4: "+197 / 0 / 0 / 0 (SIM_ENGINE_MUL 0.75)"}
    for i, (name, _, _) in enumerate(cases):
        d = us[i] - us[0]
        print(f"| {name} | " + " | ".join(f"{x:.0f}" for x in us[i]) + " | "
              + ("-" if i == 0 else " / ".join(f"{x:+.0f}" for x in d)) + f" | {sitl_obs.get(i, '-')} |")
    print()


def pendulum(seeds=(1, 2), lengths=(0.5, 1.0, 2.0), frac=0.15, attach_z=0.05, missions=("hover", "manual", "waypoints")) -> None:
    from flightlog_fd.sim.airframe import GRAVITY
    from flightlog_fd.sim.api import simulate_batch
    from flightlog_fd.sim.loads import Load

    def spec(x, fs):
        x = x - x.mean(0)
        f = np.fft.rfftfreq(len(x), 1 / fs)
        return f, (np.abs(np.fft.rfft(x * np.hanning(len(x))[:, None], axis=0)) ** 2).sum(1)

    print(f"## A payload of {frac:.0%} of the take-off mass swinging under an X500 (attached {100 * attach_z:.0f} cm below the centre)\n")
    print("| mission | seed | L m | f pendulum sqrt(g/L)/2pi | f coupled | swing: peak Hz, max deg | rates power ratio | accel power ratio |")
    print("|---|---|---|---|---|---|---|---|")
    n = len(lengths)
    for mission in missions:
        for seed in seeds:
            b = simulate_batch(2 * n, airframes="x500", damages=[None] * (2 * n), mission=mission, duration_s=90.0,
                               profile="px4_high", seed=seed,
                               loads=[Load("line", mass_fraction=frac, position=(0, 0, attach_z), length_m=L)
                                      for L in lengths] + [None] * n, extra_streams={"swing": 25})
            r = b.result

            def seg(name, j, k=2):
                t = r.times[name]
                s = (t > r.t_takeoff[j] + 8) & (t < r.t_touchdown[j] - 3)
                return r.data[name][s, j, :k].astype(float), 1.0 / np.median(np.diff(t))

            for i, L in enumerate(lengths):
                f0 = np.sqrt(GRAVITY / L) / (2 * np.pi)
                fc = f0 * np.sqrt(1 + frac / (1 - frac))
                sw, fs = seg("swing", i)
                fsw, psw = spec(sw, fs)
                band = (fsw > 0.1) & (fsw < 3)
                swing_peak = fsw[band][np.argmax(psw[band])]
                swing_deg = np.degrees(np.arcsin(min(1.0, np.abs(sw).max())))
                ratios = []
                for name in ("rates", "accel"):
                    p = []
                    for j in (i, i + n):
                        x, fs = seg(name, j)
                        f, pw = spec(x, fs)
                        near = (f > 0.9 * fc) & (f < 1.1 * fc)
                        p.append(pw[near].mean() / len(x))
                    ratios.append(p[0] / p[1])
                print(f"| {mission} | {seed} | {L:g} | {f0:.3f} | {fc:.3f} | {swing_peak:.3f}, {swing_deg:.1f} | "
                      f"{ratios[0]:.2f} | {ratios[1]:.1f} |", flush=True)
    print()


def main(argv=None) -> int:
    which = (argv if argv is not None else sys.argv[1:]) or ["sih", "sitl", "pendulum", "hook"]
    for w in which:
        {"sih": sih, "sitl": sitl, "pendulum": pendulum,
         "hook": lambda: pendulum(attach_z=0.15, missions=("hover", "manual"))}[w]()
    return 0


if __name__ == "__main__":
    sys.exit(main())
