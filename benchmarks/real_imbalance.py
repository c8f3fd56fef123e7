"""Hover noise and steady motor offsets of healthy real logs, and of simulated healthy airframes.

Usage: ``python benchmarks/real_imbalance.py [LOG ...] [--sim 24]``

Without logs it reads the healthy sets under ``../shared`` (the Erle ArduCopter logs of
``real_logs/ardupilot`` and ``real_healthy/logs``, CrazyPAD E9 ``normal_flight`` ULogs, the rrc_straight
good-propeller flights, the px4_sih_dev healthy flights: a perfectly balanced simulated airframe), skipping
what is absent. Per log: stream rates, gyro noise std (°/s, roll/pitch/yaw, airborne minus 2 s at
each end, after removing a 0.5 s moving-average trend), motor command noise std (same
detrending, full scale 1), and the steady per-motor offsets (training/peer_rule.steady_means
minus the mean of the four: hover segments, else all airborne time). ``--sim N`` flies N healthy
random airframes with realistic imbalance (sim/imbalance.py) and ``noise="real_logs"`` per (profile, mission) in
``ardupilot_rcou``/manual, ``ardupilot_rcou``/waypoints, ``px4_default``/hover and prints the same
figures as percentiles over flights. Prints figures only.
"""
from __future__ import annotations

import argparse
import glob
import warnings
from pathlib import Path

import numpy as np

from flightlog_fd import load_flight
from flightlog_fd.training.peer_rule import steady_means

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared"
DEFAULT_GLOBS = ("real_logs/ardupilot/erle_*.BIN", "real_healthy/logs/*.BIN", "crazypad_e9/ulog/normal_flight*.ulg",
                 "real_damaged/rrc_straight/good_prop_*.BIN", "px4_sih_dev/logs/sih_004.ulg", "px4_sih_dev/logs/sih_008.ulg",
                 "px4_sih_dev/logs/sih_039.ulg", "px4_sih_dev/logs/sih_043.ulg")
TREND_S = 0.5
EDGE_S = 2.0


def detrended_std(t: np.ndarray, x: np.ndarray, win_s: float = TREND_S) -> np.ndarray:
    """Per-column std of ``x`` minus its ``win_s`` moving average (edges dropped)."""
    if len(t) < 10:
        return np.full(x.shape[1], np.nan)
    hz = (len(t) - 1) / (t[-1] - t[0])
    k = max(3, int(round(win_s * hz)) | 1)
    ker = np.ones(k) / k
    return np.array([(x[:, j] - np.convolve(x[:, j], ker, mode="same"))[k:-k].std() for j in range(x.shape[1])])


def airborne_mask(fl, t: np.ndarray) -> np.ndarray:
    m = np.zeros(len(t), bool)
    for a, b in fl.airborne:
        m |= (t >= a + EDGE_S) & (t <= b - EDGE_S)
    return m


def figures(fl) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """(gyro std °/s (3,), motor std (4,), offsets (4,), offset source)."""
    r, m = fl.rates, fl.motors
    means, steady_s, src = steady_means(fl)
    ma, mm = airborne_mask(fl, r.t), airborne_mask(fl, m.t)
    g = np.degrees(detrended_std(r.t[ma], r.values[ma])) if ma.sum() > 50 else np.full(3, np.nan)
    ms = detrended_std(m.t[mm], m.values[mm][:, :4]) if mm.sum() > 50 else np.full(4, np.nan)
    return g, ms, means - means.mean(), f"{src} {steady_s:.0f}s"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="*")
    ap.add_argument("--sim", type=int, default=0, help="healthy simulated flights per (profile, mission)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    logs = args.logs or [p for g in DEFAULT_GLOBS for p in sorted(glob.glob(str(SHARED / g)))]
    for p in logs:
        try:
            fl = load_flight(p)
            g, ms, off, src = figures(fl)
        except Exception as e:  # a benchmark over third-party logs reports and goes on
            print(f"{Path(p).name}: {e}")
            continue
        print(f"{Path(p).name[:45]:45s} rates {fl.rates.rate_hz:4.0f} Hz motors {fl.motors.rate_hz:4.0f} Hz "
              f"{fl.motor_kind:6s} gyro std dps {np.round(g, 1)} motor std {np.round(ms, 3)} "
              f"offsets [{src}] {np.round(off, 3)}")
    if args.sim:
        from flightlog_fd.sim.api import simulate_flights

        gs, ms_all, worst = [], [], []
        for prof, mission in (("ardupilot_rcou", "manual"), ("ardupilot_rcou", "waypoints"), ("px4_default", "hover")):
            for fl in simulate_flights(args.sim, profile=prof, mission=mission, duration_s=50.0, imbalance="random",
                                       healthy_fraction=1.0, noise="real_logs", seed=3):
                g, ms, off, _ = figures(fl)
                gs.append(g)
                ms_all.append(np.nanmean(ms))
                worst.append(np.abs(off).max())
        gs = np.array(gs)
        pct = [10, 50, 90, 100]
        print(f"sim: max |offset| per flight p10/50/90/max {np.round(np.nanpercentile(worst, pct), 3)}")
        print(f"sim: gyro std roll/pitch dps p10/50/90/max {np.round(np.nanpercentile(gs[:, :2], pct), 1)}, "
              f"yaw {np.round(np.nanpercentile(gs[:, 2], pct), 1)}")
        print(f"sim: motor std p10/50/90/max {np.round(np.nanpercentile(ms_all, pct), 3)}")


if __name__ == "__main__":
    main()
