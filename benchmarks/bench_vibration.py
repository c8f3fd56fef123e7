"""Vibration analyzer on simulated flights: detection against propeller imbalance size and logging
rate, and false alarms on healthy flights, without and with a profile.

Flights: 60 s waypoint missions of random quads (30 g-5 kg, realistic airframe imbalance,
sim/imbalance.py); every propeller keeps its healthy residual imbalance and each airframe its
broadband vibration floor (sim/prop_vibration.py: floor 0.7-8 m/s/s horizontal VIBE, the real
healthy span). For each airframe a healthy calibration flight and a test flight (another mission
seed); on the test flight one random motor gets a mass imbalance sized by the line it makes at
hover, ``a = m·r·w_hover² / M`` in m/s/s (``--sizes``; on an F450, 1 m/s/s is about 3.3 g·mm;
octo_air's 15-35 mm cuts raised its VIBE by 24-26 m/s/s). The controls are those of the balanced
vehicle (the line does not feed back), so each logging profile is flown once and the imbalance
sizes are added to the same recording.

Logging (``CONFIGS``): ArduPilot default (VIBE 10 Hz + IMU 50 Hz), ArduPilot raw IMU logging
(ACC/GYR) at 200 Hz (rotor lines alias) and 1 kHz, PX4 default (vehicle_imu_status + sensor_combined
50 Hz), PX4 high rate (sensor_combined 250 Hz) and PX4 sensor_accel/gyro at 1 kHz.

Printed per (logging, size), ``n`` airframes:

- vibration analyzer without a profile: flights whose flight-level log Bayes factor reaches
  decision.UNCERTAIN_LLR ("unc") and DAMAGED_LLR ("dmg"); the rotor line tied to the unbalanced
  motor / to another / no line or no tie;
- with a profile (the vibration baseline fitted on the healthy calibration flight): the same
  flight-level counts;
- the final verdict of ``diagnose_flight`` (shipped model, every analyzer) without and with a
  profile (``calibration.calibrate`` on the calibration flight, as ``fdlog calibrate --no-adapt``): damaged with the right motor (R) / another motor (W) / no motor named, "inspect
  all" (A) / uncertain (U) / healthy (H).

Size 0 rows are the healthy flights: every count there is a false alarm (0 expected).
Bounded: ~4-5 min on one core with the defaults (12 airframes).

    python benchmarks/bench_vibration.py [--airframes N] [--seed S] [--sizes 2,5,10,20]
"""
from __future__ import annotations

import argparse
import time
from collections import Counter
from dataclasses import replace

import numpy as np

from flightlog_fd.analyzers.vibration import analyze_vibration, fit_vibration_baseline
from flightlog_fd.decision import DAMAGED_LLR, UNCERTAIN_LLR
from flightlog_fd.sim.airframe import random_airframes
from flightlog_fd.sim.api import flights_from_batch, simulate_batch
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.imbalance import random_imbalances
from flightlog_fd.sim.prop_vibration import PropImbalance

#: (label, simulator logging profile, raw IMU rate Hz or None)
CONFIGS = (
    ("AP default: VIBE 10 Hz + IMU 50 Hz", "ardupilot", None),
    ("AP raw IMU ACC/GYR 200 Hz", "ardupilot", 200.0),
    ("AP raw IMU ACC/GYR 1 kHz", "ardupilot", 1000.0),
    ("PX4 default: imu_status + 50 Hz", "px4_default", None),
    ("PX4 sensor_combined 250 Hz", "px4_high", None),
    ("PX4 sensor_accel/gyro 1 kHz", "px4_high", 1000.0),
)
SIZES = (2.0, 5.0, 10.0, 20.0)
DURATION_S = 60.0
F450_GMM_PER_MS2 = 1.5 / (1000.0 * np.sqrt(0.46)) ** 2 * 1e6  # m·r (g·mm) of 1 m/s/s on the F450 preset


def fly(profile: str, afs, imbs, seed: int):
    """One flown batch of healthy airframes with the propeller model recording."""
    return simulate_batch(len(afs), airframes=afs, damages=[Damage()] * len(afs), duration_s=DURATION_S,
                          profile=profile, seed=seed, imbalance=imbs, healthy_fraction=0.0,
                          prop_imbalance="residual")


def specs_for(afs, size: float, motors: list[int]):
    """Per airframe: mass imbalance on its motor giving a hover line of ``size`` m/s/s (None for 0)."""
    if size <= 0:
        return "residual"
    out = []
    for af, k in zip(afs, motors):
        w_hover = af.omega_max * np.sqrt(af.hover_command)
        out.append(PropImbalance.on(k, mass=size * af.mass / w_hover ** 2, rotors=af.rotor_count))
    return out


def verdict_class(v, motor: int) -> str:
    if v.status == "damaged":
        return "all" if v.motor is None else "right" if v.motor == motor else "other"
    return v.status


def run(n: int, seed: int, sizes: tuple[float, ...], verdicts: bool = True) -> None:
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.calibration import calibrate

    t0 = time.time()
    model = resolve_model() if verdicts else None
    rng = np.random.default_rng(seed)
    afs = random_airframes(n, rng)
    imbs = random_imbalances(afs, rng)
    motors = [int(rng.integers(1, af.rotor_count + 1)) for af in afs]
    flown = {}
    print(f"Vibration analyzer, simulated flights: {n} random quads, {DURATION_S:.0f} s waypoints, one motor "
          f"unbalanced (size = its hover line m·r·w²/M in m/s/s; F450: 1 m/s/s = {F450_GMM_PER_MS2:.1f} g·mm); "
          f"thresholds: uncertain >= {UNCERTAIN_LLR:g} nats, damaged >= {DAMAGED_LLR:g}")
    head = (f"{'logging':<36} {'size':>5} {'level':>6} | {'no profile':^9} | {'line tied':^11} | {'profile':^9} | "
            f"{'verdict, no profile':^19} | {'verdict, profile':^19}")
    cls = ("right", "other", "all", "uncertain", "healthy")
    sub = (f"{'':<36} {'m/s2':>5} {'ratio':>6} | {'unc':>4} {'dmg':>4} | {'rgt':>3} {'oth':>3} {'no':>3} | "
           f"{'unc':>4} {'dmg':>4} | " + " ".join(f"{x:>3}" for x in "RWAUH") + " | " + " ".join(f"{x:>3}" for x in "RWAUH"))
    print(head)
    print(sub)
    summary = []
    for label, profile, raw in CONFIGS:
        if profile not in flown:
            flown[profile] = (fly(profile, afs, imbs, seed + 1), fly(profile, afs, imbs, seed + 2))
        calib_b, test_b = flown[profile]
        calib = flights_from_batch(replace(calib_b, imu_rate_hz=raw))
        bases = [fit_vibration_baseline([c]) for c in calib]
        profs = []
        if verdicts:
            profs = [calibrate([c]) for c in calib]
        for size in (0.0,) + tuple(sizes):
            flights = flights_from_batch(replace(test_b, prop_imbalance=specs_for(afs, size, motors), imu_rate_hz=raw))
            c = Counter()
            ratios = []
            for i, f in enumerate(flights):
                k = motors[i] if size > 0 else 0
                a0 = analyze_vibration(f)
                a1 = analyze_vibration(f, bases[i])
                if a1.ratio is not None:
                    ratios.append(a1.ratio)
                for tag, a in (("np", a0), ("p", a1)):
                    llr = a.flight_llr if a.flight_llr is not None else -np.inf
                    c[tag + "_unc"] += llr >= UNCERTAIN_LLR
                    c[tag + "_dmg"] += llr >= DAMAGED_LLR
                tied = a0.line.motor if a0.line is not None else None
                c["line_" + ("no" if tied is None else "right" if tied == k else "other")] += 1
                if verdicts:
                    c["v_" + verdict_class(diagnose_flight(f, model, keep_flight=False).verdict, k)] += 1
                    c["vp_" + verdict_class(diagnose_flight(f, model, profs[i], keep_flight=False).verdict, k)] += 1
            ratio = f"{np.median(ratios):6.2f}" if ratios else f"{'-':>6}"
            v = " ".join(f"{c['v_' + x]:3d}" for x in cls)
            vp = " ".join(f"{c['vp_' + x]:3d}" for x in cls)
            print(f"{label:<36} {size:5g} {ratio} | {c['np_unc']:4d} {c['np_dmg']:4d} | {c['line_right']:3d} "
                  f"{c['line_other']:3d} {c['line_no']:3d} | {c['p_unc']:4d} {c['p_dmg']:4d} | {v} | {vp}")
            summary.append((label, size, c))
    n_fa = sum(c["np_dmg"] + c["p_dmg"] for _, s, c in summary if s == 0)
    n_fv = sum(c[p + x] for _, s, c in summary if s == 0 for p in ("v_", "vp_") for x in ("right", "other", "all"))
    print(f"healthy flights: {n_fa} vibration 'damaged' (flight level, with and without a profile), "
          f"{n_fv} damaged verdicts, over {len(CONFIGS)} x {n} flights x 2")
    print(f"({time.time() - t0:.0f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--airframes", type=int, default=12)
    ap.add_argument("--seed", type=int, default=2300)
    ap.add_argument("--sizes", default=",".join(f"{s:g}" for s in SIZES), help="hover line sizes, m/s/s")
    ap.add_argument("--no-verdicts", action="store_true", help="skip diagnose_flight (analyzer figures only)")
    args = ap.parse_args()
    run(args.airframes, args.seed, tuple(float(s) for s in args.sizes.split(",")), not args.no_verdicts)


if __name__ == "__main__":
    main()
