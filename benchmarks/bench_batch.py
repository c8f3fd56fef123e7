"""Logs per second of a batch: `--jobs 2` (process pool) against `--scheduler local` (a Dask
LocalCluster of 2 worker processes, 1 thread each), on the same logs, measured in one run.

    python benchmarks/bench_batch.py [--min-logs 40] [--serial]

Logs: sample_logs/ plus the diagnosable logs of ../shared (px4_sih_dev/logs, real_healthy/logs,
real_logs/px4, real_logs/ardupilot, crazypad_e9/ulog; a log counts when its diagnosis has a
verdict), the list repeated until it holds at least ``--min-logs``. The script prints which logs
it used. Each engine's time is the wall time of :func:`flightlog_fd.batch.run_batch`, start-up
included (pool processes loading the model; the LocalCluster starting its scheduler and workers
and receiving the scattered model), since that is what a user waits for. The Dask start-up alone
is printed too. The machine is shared: compare figures from one run, not across runs.

Measured 2026-11-23 (2 cores, load average 3.9-4.7 from other users; 94 distinct logs: 42
crazypad_e9, 19 px4_sih_dev, 15 real_healthy, 3+1+4 real_logs, 10 sample_logs):
``--jobs 2`` 13.0 s, 7.26 logs/s; ``--scheduler local`` 19.6 s, 4.80 logs/s (cluster start-up
alone 1.7 s).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
SHARED_DIRS = ("px4_sih_dev/logs", "real_healthy/logs", "real_logs/px4", "real_logs/ardupilot", "crazypad_e9/ulog")


def candidate_logs() -> list[Path]:
    from flightlog_fd.logs import collect_logs

    paths = [ROOT / "sample_logs"] + [SHARED / d for d in SHARED_DIRS if (SHARED / d).is_dir()]
    files, _ = collect_logs(paths)
    return files


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min-logs", type=int, default=40)
    ap.add_argument("--serial", action="store_true", help="Also time the serial engine.")
    args = ap.parse_args()

    from flightlog_fd.batch import run_batch
    from flightlog_fd.diagnose import resolve_model

    model = resolve_model()
    files = candidate_logs()
    t = time.perf_counter()
    probe = run_batch(files, model, None, jobs=2)
    usable = [Path(r.path) for r in probe if r.diagnosis.verdict.status != "not_diagnosable"]
    print(f"{len(usable)} diagnosable logs of {len(files)} found ({time.perf_counter() - t:.1f} s to sort them):")
    by_dir: dict[str, int] = {}
    for f in usable:
        key = str(f.parent.relative_to(ROOT.parent)) if f.is_relative_to(ROOT.parent) else str(f.parent)
        by_dir[key] = by_dir.get(key, 0) + 1
    for k, n in sorted(by_dir.items()):
        print(f"  {n:3d}  {k}")
    batch = (usable * (args.min_logs // max(len(usable), 1) + 1))[:max(args.min_logs, len(usable))]
    print(f"batch: {len(batch)} logs ({len(usable)} distinct, repeated to reach {args.min_logs})")

    def timed(label: str, **kw) -> None:
        t0 = time.perf_counter()
        res = run_batch(batch, model, None, **kw)
        dt = time.perf_counter() - t0
        bad = sum(r.diagnosis.verdict.status == "not_diagnosable" for r in res)
        busy = sum(r.elapsed_s for r in res)
        print(f"{label:<34} {dt:7.1f} s  {len(res) / dt:6.2f} logs/s  (worker time {busy:6.1f} s, "
              f"{bad} not diagnosable)")

    if args.serial:
        timed("serial (1 process)")
    import os

    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    timed("--jobs 2 (process pool)", jobs=2)
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, Client(c):
        print(f"{'(LocalCluster start-up alone)':<34} {time.perf_counter() - t0:7.1f} s")
    timed("--scheduler local (2 workers)", jobs=2, scheduler="local")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
