"""For every log under ../shared/real_logs (plus a few px4_sih_dev and crazypad_e9 logs): how many
NIF windows and steady-hover segments it yields, the motor-speed ratios rho measured in that hover,
or why it yields none (the one-line FlightLogError message). Prints a table; asserts nothing.

Usage: python benchmarks/real_logs_windows.py [extra log paths...]
Skips cleanly (exit 0) when ../shared is absent.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from flightlog_fd import load_flight
from flightlog_fd.errors import FlightLogError
from flightlog_fd.windows import FeatureSpec, make_windows
from flightlog_fd.hover import hover_segments, hover_seconds

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
EXTRA = [
    "px4_sih_dev/logs/sih_004.ulg",  # healthy, 250 Hz
    "px4_sih_dev/logs/sih_008.ulg",  # healthy, default profile (10 Hz motors)
    "px4_sih_dev/logs/sih_034.ulg",  # motor 4 eta 0.7 from mid-flight
    "crazypad_e9/ulog/normal_flight__E9_log00.ulg",  # real healthy Crazyflie
    "crazypad_e9/ulog/cut_M2_0.5mm_46.5mm__E9_log00.ulg",  # real, PX4 motor 4 cut
]


def describe(path: Path) -> str:
    t0 = time.perf_counter()
    try:
        fl = load_flight(path)
    except FlightLogError as e:
        return f"load: {e.message}"
    load_s = time.perf_counter() - t0
    motors = fl.motors
    head = (f"{fl.autopilot:9s} {fl.frame.name if fl.frame else '?':9s} air {fl.airborne_s:6.1f} s  "
            f"gyro {fl.rates.rate_hz if fl.rates is not None else 0:5.0f} Hz  "
            f"motors {motors.rate_hz if motors is not None else 0:5.0f} Hz ({fl.motor_kind})")
    try:
        t1 = time.perf_counter()
        w = make_windows(fl, FeatureSpec("nif"))
        win_s = time.perf_counter() - t1
    except FlightLogError as e:
        return f"{head} | windows: {e.message}"
    out = f"{head} | {len(w):4d} windows in {w.n_segments} segments ({load_s:.2f} s load, {win_s * 1e3:.0f} ms windows)"
    if not len(w):
        out += f" - {w.reason}"
    try:
        hs = hover_segments(fl)
    except FlightLogError as e:
        return f"{out} | hover: {e.message}"
    if hs:
        sp = np.average([h.mean_speed for h in hs], axis=0, weights=[h.duration_s for h in hs])
        rho = " ".join(f"{x:.3f}" for x in sp / sp[0])
        thr = np.average([h.throttle for h in hs], weights=[h.duration_s for h in hs])
        out += f" | hover {len(hs)} seg {hover_seconds(hs):5.1f} s thr {thr:.3f} rho [{rho}]"
    else:
        out += " | no steady hover"
    return out


def main(argv: list[str]) -> int:
    paths = [Path(a) for a in argv]
    if not paths:
        if not SHARED.exists():
            print(f"skipped: {SHARED} not found")
            return 0
        paths = sorted(p for p in (SHARED / "real_logs").rglob("*") if p.is_file() and p.suffix.lower() != ".md")
        paths += [SHARED / e for e in EXTRA if (SHARED / e).exists()]
    for p in paths:
        name = str(p.relative_to(SHARED)) if SHARED in p.parents else str(p)
        print(f"{name:60s} {describe(p)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
