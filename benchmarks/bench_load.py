"""Loading benchmark: our readers against the libraries' plain parsers, as time ratios.

- ArduPilot DataFlash: :func:`read_dataflash` (a whole Flight: index + numpy decoding of the
  needed types + assembly) against a plain pymavlink loop ``mavlink_connection(path)`` then
  ``recv_match(type=<the same message types>)`` until the end, keeping the message objects
  (no field access: a lower bound on pymavlink's cost).
- PX4 ULog: the fast reader :func:`read_ulog_fast` (on fdlog's topics, and on every topic) and
  the whole :func:`read_ulog` against pyulog's full parse ``ULog(path)`` with no message filter.

Inputs: every file in ``../shared/real_logs/ardupilot`` and ``../shared/real_logs/px4`` (skipped
when absent; ``--all-shared`` adds the SIH and crazypad ULogs), ``sample_logs/*.ulg``, plus a big
synthetic flight written by :func:`write_dataflash` (and ``write_ulog`` when available): ``--big-seconds`` (default 600) of IMU/RATE at ``--big-hz``
(default 400 Hz), ATT/ESC/XKF1 at 100 Hz, RCOU at 10 Hz, in a temporary folder.
Each of our reads is the best of ``--repeat`` runs (default 3); the library loop runs once.
Prints figures only; nothing is asserted. Run: ``python benchmarks/bench_load.py``.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "real_logs"
sys.path.insert(0, str(ROOT))

from flightlog_fd.flight import Flight, Frame, Series  # noqa: E402
from flightlog_fd.logs.dataflash import NEEDED_TYPES, read_dataflash, read_tables  # noqa: E402
from flightlog_fd.logs.dataflash_writer import write_dataflash  # noqa: E402

SLOW_STREAM_HZ = 100.0  # ATT, ESC, XKF1 in the synthetic flight
BOOT_OFFSET_S = 5.0  # the synthetic log's first sample, seconds after boot


def best_of(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def pymavlink_loop(path: Path, types: list[str]) -> int:
    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(str(path))
    kept = []
    while True:
        m = conn.recv_match(type=types)
        if m is None:
            break
        kept.append(m)
    return len(kept)


def pyulog_full(path: Path) -> int:
    from pyulog import ULog

    return len(ULog(str(path)).data_list)


def big_flight(seconds: float, fast_hz: float) -> Flight:
    """A long quad flight with every stream the writers handle (values are smooth noise)."""
    rng = np.random.default_rng(1)
    # starts at BOOT_OFFSET_S: ULog timestamps must be > 0 (0 means "not set")
    tf = BOOT_OFFSET_S + np.arange(0.0, seconds, 1.0 / fast_hz)
    ts = BOOT_OFFSET_S + np.arange(0.0, seconds, 1.0 / SLOW_STREAM_HZ)
    rates = 0.2 * np.sin(np.outer(tf, [1.3, 0.9, 0.4])) + 0.01 * rng.standard_normal((tf.size, 3))
    thrust = np.clip(0.4 + 0.05 * np.sin(np.outer(tf, [1.0, 1.5, 2.0, 2.5])), 0, 1)
    return Flight(
        path=None, autopilot="sim", firmware="benchmark", vehicle_type="quadrotor", frame=Frame.quad_x(),
        rates=Series(tf, rates, "sim"), attitude=Series(ts, 0.1 * np.sin(np.outer(ts, [0.3, 0.2, 0.1])), "sim"),
        motors=Series(tf, thrust, "sim"), motor_kind="thrust", thrust_curve=0.65,
        esc_rpm=Series(ts, 8000 + 50 * np.sin(np.outer(ts, [1.0, 2.0, 3.0, 4.0])), "sim"),
        velocity=Series(ts, np.zeros((ts.size, 3)), "sim"),
        armed=[(BOOT_OFFSET_S + 1.0, BOOT_OFFSET_S + seconds - 1.0)],
        airborne=[(BOOT_OFFSET_S + 5.0, BOOT_OFFSET_S + seconds - 5.0)],
        t_start=BOOT_OFFSET_S, t_end=BOOT_OFFSET_S + seconds,
    )


def bench_dataflash(paths: list[Path], repeat: int) -> None:
    print(f"\nArduPilot DataFlash: read_dataflash vs pymavlink recv_match over the same types")
    print(f"{'file':42s} {'MB':>6s} {'msgs':>8s} {'ours s':>8s} {'pymavlink s':>12s} {'ratio':>7s}")
    for p in paths:
        present = [t for t in NEEDED_TYPES if t in read_tables(p, NEEDED_TYPES)]
        ours = best_of(lambda: read_dataflash(p), repeat)
        t0 = time.perf_counter()
        n = pymavlink_loop(p, present)
        theirs = time.perf_counter() - t0
        print(f"{p.name[:42]:42s} {p.stat().st_size / 1e6:6.1f} {n:8d} {ours:8.3f} {theirs:12.3f} "
              f"{theirs / ours:6.1f}x")


def bench_ulog(paths: list[Path], repeat: int) -> None:
    try:
        from flightlog_fd.logs.ulog import ULOG_TOPICS, read_ulog
        from flightlog_fd.logs.ulog_fast import FastULogUnsupported, read_ulog_fast
    except ImportError:
        print("\nPX4 ULog: flightlog_fd/logs/ulog.py not available, skipped")
        return
    from flightlog_fd.errors import FlightLogError

    print("\nPX4 ULog: against pyulog ULog(path) (full parse, every topic):")
    print("  fast = read_ulog_fast on fdlog's topics (what read_ulog uses), fast all = on every topic,")
    print("  read_ulog = the whole Flight (fast reader + assembly); ratios are pyulog s / ours s")
    print(f"{'file':42s} {'MB':>6s} {'pyulog s':>9s} {'fast s':>7s} {'ratio':>6s} {'all s':>7s} {'ratio':>6s} "
          f"{'read_ulog s':>11s} {'ratio':>6s}  note")
    for p in paths:
        note = ""

        def ours_once():
            nonlocal note
            try:
                flight = read_ulog(p)
                note = "" if flight.reader.startswith("fast") else flight.reader
            except FlightLogError as e:  # e.g. the VTOL sample: timed up to the refusal
                note = f"read_ulog: {e.message}"

        def fast_once(topics):
            try:
                read_ulog_fast(p, topics)
            except FastULogUnsupported as e:
                return str(e)
            return ""

        fast = best_of(lambda: fast_once(ULOG_TOPICS), repeat)
        fast_all = best_of(lambda: fast_once(None), repeat)
        refused = fast_once(ULOG_TOPICS)
        ours = best_of(ours_once, repeat)
        t0 = time.perf_counter()
        pyulog_full(p)
        theirs = time.perf_counter() - t0
        if refused:
            note = f"fast reader refused: {refused}"
        print(f"{p.name[:42]:42s} {p.stat().st_size / 1e6:6.1f} {theirs:9.3f} {fast:7.3f} {theirs / fast:5.1f}x "
              f"{fast_all:7.3f} {theirs / fast_all:5.1f}x {ours:11.3f} {theirs / ours:5.1f}x  {note[:60]}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--big-seconds", type=float, default=600.0)
    ap.add_argument("--big-hz", type=float, default=400.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-big", action="store_true", help="only the shared real logs")
    ap.add_argument("--all-shared", action="store_true",
                    help="also every ULog of ../shared/px4_sih_dev and ../shared/crazypad_e9 (61 more files)")
    ap.add_argument("--ulog-only", action="store_true", help="skip the DataFlash part")
    args = ap.parse_args(argv)

    df_paths = sorted((SHARED / "ardupilot").glob("*")) if (SHARED / "ardupilot").is_dir() else []
    ulog_paths = sorted((ROOT / "sample_logs").glob("*.ulg"))
    ulog_paths += sorted((SHARED / "px4").rglob("*.ulg")) if (SHARED / "px4").is_dir() else []
    if args.all_shared:
        for folder in (SHARED.parent / "px4_sih_dev" / "logs", SHARED.parent / "crazypad_e9" / "ulog"):
            ulog_paths += sorted(folder.rglob("*.ulg")) if folder.is_dir() else []
    with tempfile.TemporaryDirectory() as tmp:
        if not args.no_big:
            flight = big_flight(args.big_seconds, args.big_hz)
            t0 = time.perf_counter()
            big = write_dataflash(flight, Path(tmp) / f"synthetic_{args.big_seconds:.0f}s_{args.big_hz:.0f}hz.bin")
            print(f"wrote {big.name}: {big.stat().st_size / 1e6:.1f} MB in {time.perf_counter() - t0:.2f} s "
                  f"(write_dataflash)")
            df_paths.append(big)
            try:
                from flightlog_fd.logs.ulog_writer import write_ulog

                t0 = time.perf_counter()
                bu = write_ulog(flight, Path(tmp) / f"synthetic_{args.big_seconds:.0f}s_{args.big_hz:.0f}hz.ulg")
                print(f"wrote {bu.name}: {bu.stat().st_size / 1e6:.1f} MB in {time.perf_counter() - t0:.2f} s "
                      f"(write_ulog)")
                ulog_paths.append(bu)
            except ImportError:
                pass
        if not df_paths and not ulog_paths:
            print("no logs: ../shared/real_logs is absent and --no-big was given")
            return
        if not args.ulog_only:
            bench_dataflash(df_paths, args.repeat)
        bench_ulog(ulog_paths, args.repeat)


if __name__ == "__main__":
    main()
