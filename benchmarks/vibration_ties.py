"""The rotor-line tie's calibration: stated P(rotor k) against the fraction right on simulated
flights with one propeller out of balance, for candidate ``TRACK_CORRELATION_S`` values; and the
smallest tie probability ever stated for the true rotor (what ``TIE_P_FLOOR`` and ``TIE_NAME_P``
read).

Flights: ``--per-batch`` random airframes per (frame, logging profile), 60 s waypoints, a mass
imbalance on a random motor sized so its hover line is 4-20 m/s/s (log-uniform), flown as one
vectorised batch (sim.api.simulate_batch; no log file: the analyzer's tie only). Profiles whose
IMU runs >= 100 Hz (px4_high sensor_combined 250 Hz, ardupilot_fast IMU 400 Hz, and PX4 with
raw 1 kHz sensor_accel/gyro), frames quad X/+, hexa X, octo X, octaquad X; with and without ESC
telemetry (50 Hz).

    python benchmarks/vibration_ties.py [--per-batch N] [--seed S]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from flightlog_fd.analyzers import rotor_lines as RL
from flightlog_fd.analyzers.vibration import _intervals
from flightlog_fd.sim.airframe import random_airframes
from flightlog_fd.sim.api import flights_from_batch, simulate_batch
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.prop_vibration import PropImbalance

CONFIGS = (("px4_high", None), ("ardupilot_fast", None), ("px4_high", 1000.0))
FRAMES = ("quad_x", "quad_plus", "hexa_x", "octo_x", "octaquad_x")
CORRELATION_S = (0.25, 0.5, 1.0, 2.0)
LINE_MS2 = (4.0, 20.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-batch", type=int, default=6)
    ap.add_argument("--seed", type=int, default=3801)
    args = ap.parse_args()
    t0 = time.time()
    rng = np.random.default_rng(args.seed)
    rows = {c: [] for c in CORRELATION_S}  # (probs, truth, parted)
    named = {c: [] for c in CORRELATION_S}
    for esc in (None, 50.0):
        for prof, raw in CONFIGS:
            for frame in FRAMES:
                afs = random_airframes(args.per_batch, rng, frames=(frame,))
                specs, truth = [], []
                for af in afs:
                    k = int(rng.integers(1, af.rotor_count + 1))
                    a = float(np.exp(rng.uniform(*np.log(LINE_MS2))))
                    w = af.omega_max * np.sqrt(af.hover_command)
                    specs.append(PropImbalance.on(k, mass=a * af.mass / w ** 2, rotors=af.rotor_count))
                    truth.append(k)
                batch = simulate_batch(len(afs), airframes=afs, damages=[Damage()] * len(afs), duration_s=60.0,
                                       profile=prof, seed=int(rng.integers(1 << 30)), prop_imbalance=specs,
                                       imu_rate_hz=raw, healthy_fraction=0.0, esc=esc,
                                       imbalance="random" if esc else None)
                for fl, k in zip(flights_from_batch(batch), truth):
                    for c in CORRELATION_S:
                        RL.TRACK_CORRELATION_S = c
                        line, _ = RL.find_rotor_line(fl, _intervals(fl))
                        if line is None or not line.tie_source or not line.follows:
                            continue
                        rows[c].append((list(line.tie_probs), k, RL.rotors_parted(line), line.tie_source))
                print(f"  {prof}{'' if raw is None else f'+{raw:g} Hz raw'}{' +ESC' if esc else ''} {frame}: "
                      f"{len(rows[CORRELATION_S[0]])} tied so far ({time.time() - t0:.0f} s)", flush=True)
    RL.TRACK_CORRELATION_S = 1.0
    for c in CORRELATION_S:
        p = np.array([q for probs, _, _, _ in rows[c] for q in probs])
        y = np.array([j + 1 == k for probs, k, _, _ in rows[c] for j in range(len(probs))], dtype=float)
        best = [(max(probs), int(np.argmax(probs)) + 1 == k) for probs, k, _, _ in rows[c]]
        truth_p = [probs[k - 1] for probs, k, _, _ in rows[c]]
        print(f"TRACK_CORRELATION_S {c:g}: {len(rows[c])} flights whose line follows the rotors; "
              f"smallest P stated for the true rotor {min(truth_p):.2g}")
        for lo, hi in ((0.0, 0.001), (0.001, 0.01), (0.01, 0.05), (0.05, 0.2), (0.2, 0.5), (0.5, 0.8),
                       (0.8, 0.9), (0.9, 0.95), (0.95, 0.99), (0.99, 1.01)):
            m = (p >= lo) & (p < hi)
            if m.any():
                print(f"   P {lo:.3f}-{min(hi, 1):.3f}: {int(m.sum()):4d} stated, mean {p[m].mean():.3f}, right {y[m].mean():.3f}")
        for bar in (0.8, 0.9, 0.95, 0.99):
            sel = [ok for mx, ok in best if mx >= bar]
            print(f"   named at P >= {bar}: {len(sel)} flights, wrong {sum(not ok for ok in sel)}")
    print(f"({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
