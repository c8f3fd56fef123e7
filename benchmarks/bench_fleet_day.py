"""A fleet's day: 200 logs through `fdlog diagnose DIR --jobs 2 --db` and through `fdlog serve`'s queue.

    python benchmarks/bench_fleet_day.py [--logs 200] [--cache DIR] [--before REV] [--no-serve] [--no-cli] [--max-s 3600]

The logs: every ULog / DataFlash log in ../shared (117 real and SITL logs of many airframes,
formats and rates) and, to make up ``--logs``, simulated flights of mixed format, logging rate
and length (:data:`BASE_FLIGHTS`: PX4 default and high-rate ULogs, ArduPilot DataFlash at 20-400
Hz, 2-10 minutes, a third with a damaged propeller), each written as several byte-distinct logs
of their own vehicle id (a fleet of aircraft flying the same missions). Simulating is slow
(~20 s CPU per 300 s flight): ``--cache DIR`` keeps the simulated logs between runs.

Each tree (this one, and with ``--before REV`` the tree of git revision REV, alternating) runs:
  cli    ``fdlog diagnose DIR --jobs 2 --db X.sqlite`` (text report to /dev/null): wall time, CPU
         time of the process and its workers (rusage of the children), the largest process's
         peak memory, mean wall time per log (wall x 2 / logs);
  serve  ``fdlog serve --workers 2`` on a free loopback port; one client uploads every log
         (``POST /api/logs``), then the queue is waited for until empty: wall time from the first
         upload, CPU of the server and its workers (psutil, summed over the process tree), peak
         memory of the tree (sampled), per-log latency from upload to verdict and the diagnosis
         time of a log (the store's job created / started / finished times).
Flight-hours are the airborne time of the diagnosed logs as the store records it; the figure is
flight-hours diagnosed per CPU-hour (issue 29's goal for the CLI batch: at least 5,000). Prints the
load average: the machine is shared, so compare trees within one run (CPU time is disturbed less
than wall time). Figures: results/fleet_day.md.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cli import extract  # noqa: E402  the package tree of a git revision
SHARED = ROOT.parent / "shared"
GOAL_FLIGHT_HOURS_PER_CPU_HOUR = 5000.0
TOKEN = "fleet-day-token-0123456789abcdef"
#: (logging profile, writer format, planned flight seconds, damaged motor or 0): the simulated part
#: of the fleet. Mostly the autopilots' default logging rates (what fleets keep), some high-rate.
BASE_FLIGHTS = [
    ("px4_default", "ulog", 120, 0), ("px4_default", "ulog", 300, 2), ("px4_default", "ulog", 600, 0),
    ("px4_default", "ulog", 240, 0), ("px4_high", "ulog", 120, 0), ("px4_high", "ulog", 180, 3),
    ("ardupilot", "dataflash", 300, 0), ("ardupilot", "dataflash", 420, 1), ("ardupilot", "dataflash", 180, 0),
    ("ardupilot_fast", "dataflash", 180, 0), ("ardupilot_slow", "dataflash", 300, 4),
    ("ardupilot_rcou", "dataflash", 240, 0),
]
_MAIN = "import sys; sys.argv = ['fdlog'] + sys.argv[1:]; from flightlog_fd.cli import main; main()"


def real_logs() -> list[Path]:
    if not SHARED.is_dir():
        return []
    return sorted(p for p in SHARED.rglob("*") if p.is_file() and p.suffix.lower() in (".ulg", ".bin"))


def simulated_logs(cache: Path, n: int) -> list[Path]:
    """``n`` byte-distinct simulated logs in ``cache`` (made once: module docstring)."""
    from flightlog_fd.logs.dataflash_writer import write_dataflash
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    cache.mkdir(parents=True, exist_ok=True)
    want = [(i, i % len(BASE_FLIGHTS)) for i in range(n)]
    paths = [cache / f"fleet{i:03d}_{BASE_FLIGHTS[b][0]}_{BASE_FLIGHTS[b][2]}s.{'ulg' if BASE_FLIGHTS[b][1] == 'ulog' else 'bin'}"
             for i, b in want]
    missing = [(i, b) for (i, b), p in zip(want, paths) if not p.exists()]
    by_base: dict[int, list[int]] = {}
    for i, b in missing:
        by_base.setdefault(b, []).append(i)
    for b, copies in by_base.items():
        profile, fmt, seconds, motor = BASE_FLIGHTS[b]
        t = time.perf_counter()
        fl = simulate_flights(1, airframes="x500", mission="waypoints", duration_s=seconds, profile=profile,
                              damages=[Damage(motor, 0.75) if motor else Damage()], seed=900 + b)[0]
        for i in copies:
            fl.vehicle_id = f"fleet-{i:03d}"
            (write_ulog if fmt == "ulog" else write_dataflash)(fl, paths[i])
        print(f"  simulated {profile} {seconds} s ({len(copies)} logs) in {time.perf_counter() - t:.0f} s", flush=True)
    return paths


def _env(tree: Path | None) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    return env


def _store_figures(db: Path) -> dict:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        airborne = con.execute("SELECT COALESCE(SUM(airborne_s), 0), COUNT(*) FROM flight").fetchone()
        statuses = dict(con.execute("SELECT COALESCE(status, state), COUNT(*) FROM flight GROUP BY 1").fetchall())
        jobs = con.execute("SELECT created_at, started_at, finished_at FROM job WHERE kind = 'diagnose' "
                           "AND finished_at IS NOT NULL").fetchall()
    finally:
        con.close()
    return {"airborne_s": float(airborne[0]), "flights": int(airborne[1]), "statuses": statuses, "jobs": jobs}


def run_cli(tree: Path | None, folder: Path, work: Path, name: str) -> dict:
    db = work / f"cli_{name}.sqlite"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", _MAIN, "diagnose", str(folder), "--jobs", "2", "--db", str(db)],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=_env(tree), cwd=work)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    fig = _store_figures(db)
    return {"wall_s": wall, "cpu_s": cpu, "peak_mb": after.ru_maxrss / 1024, "exit": res.returncode, **fig}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_serve(tree: Path | None, logs: list[Path], work: Path, name: str, max_s: float) -> dict:
    import httpx
    import psutil

    data = work / f"serve_{name}"
    tokens = work / "tokens"
    tokens.write_text(TOKEN + "\n")
    port = _free_port()
    base = f"http://127.0.0.1:{port}"
    server = subprocess.Popen([sys.executable, "-c", _MAIN, "serve", "--data", str(data), "--host", "127.0.0.1",
                               "--port", str(port), "--token-file", str(tokens), "--workers", "2"],
                              env=_env(tree), cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    proc = psutil.Process(server.pid)
    peak = [0.0]
    cpu_seen: dict[int, float] = {}
    stop = threading.Event()

    def sample() -> None:  # memory and CPU of the tree, also of workers that end before the server
        while not stop.is_set():
            try:
                members = [proc] + proc.children(recursive=True)
                rss = 0.0
                for p in members:
                    try:
                        rss += p.memory_info().rss
                        ct = p.cpu_times()
                        cpu_seen[p.pid] = ct.user + ct.system + ct.children_user + ct.children_system
                    except psutil.Error:
                        pass
                peak[0] = max(peak[0], rss / 1e6)
            except psutil.Error:
                pass
            stop.wait(0.5)

    try:
        end = time.monotonic() + 120
        while True:
            try:
                httpx.get(base + "/api/health", timeout=2)
                break
            except httpx.HTTPError:
                if time.monotonic() > end or server.poll() is not None:
                    raise RuntimeError("the server did not start: " + (server.stderr.read().decode()[-300:]
                                                                       if server.stderr else ""))
                time.sleep(0.3)
        cpu_start = sum(proc.cpu_times()[:2])
        threading.Thread(target=sample, daemon=True).start()
        t0 = time.perf_counter()
        with httpx.Client(timeout=120) as c:
            for p in logs:
                with open(p, "rb") as fh:
                    r = c.post(base + "/api/logs", headers={"Authorization": f"Bearer {TOKEN}"}, files={"log": (p.name, fh)})
                if r.status_code != 200:
                    print(f"  upload {p.name}: HTTP {r.status_code} {r.text[:100]}")
        t_up = time.perf_counter() - t0
        deadline = time.monotonic() + max_s
        while time.monotonic() < deadline:
            jobs = httpx.get(base + "/api/health", timeout=60).json()["jobs"]
            if jobs["queued"] == 0 and jobs["running"] == 0:
                break
            time.sleep(0.5)
        wall = time.perf_counter() - t0
        stop.set()
        time.sleep(0.6)
        members = [proc] + proc.children(recursive=True)
        for p in members:
            try:
                ct = p.cpu_times()
                cpu_seen[p.pid] = ct.user + ct.system + ct.children_user + ct.children_system
            except psutil.Error:
                pass
        cpu = sum(cpu_seen.values()) - cpu_start
    finally:
        stop.set()
        server.terminate()
        try:
            server.wait(30)
        except subprocess.TimeoutExpired:
            server.kill()
    fig = _store_figures(data / "fdlog.sqlite")
    return {"wall_s": wall, "upload_s": t_up, "cpu_s": cpu, "peak_mb": peak[0], **fig}


def _ts(x) -> float:
    if isinstance(x, (int, float)):
        return float(x)
    from datetime import datetime

    return datetime.fromisoformat(str(x)).timestamp()


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def report(kind: str, name: str, r: dict, n_logs: int) -> None:
    fh = r["airborne_s"] / 3600
    rate = r["airborne_s"] / r["cpu_s"] if r["cpu_s"] > 0 else float("nan")
    line = (f"{kind:5s} {name:6s} {r['flights']:4d} logs, {fh:6.2f} flight-h airborne: wall {r['wall_s']:7.1f} s, "
            f"CPU {r['cpu_s']:7.1f} s -> {rate:7.0f} flight-h per CPU-h")
    if kind == "cli":
        line += (f"; {r['wall_s'] * 2 / n_logs:.2f} s wall per log per worker; peak {r['peak_mb']:.0f} MB (largest "
                 f"process); exit {r['exit']}")
        if rate < GOAL_FLIGHT_HOURS_PER_CPU_HOUR:
            line += f"  (goal >= {GOAL_FLIGHT_HOURS_PER_CPU_HOUR:.0f})"
    else:
        lat = [_ts(f) - _ts(c) for c, s, f in r["jobs"]]
        svc = [_ts(f) - _ts(s) for c, s, f in r["jobs"] if s is not None]
        line += (f"; uploads {r['upload_s']:.1f} s; latency upload->verdict p50 {pct(lat, 0.5):.1f} s p95 "
                 f"{pct(lat, 0.95):.1f} s; diagnosis per log p50 {pct(svc, 0.5):.2f} s p95 {pct(svc, 0.95):.2f} s "
                 f"max {max(svc) if svc else float('nan'):.2f} s; peak {r['peak_mb']:.0f} MB (tree)")
    print(line, flush=True)
    print(f"      statuses {json.dumps(r['statuses'], sort_keys=True)}", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=200)
    ap.add_argument("--cache", type=Path, default=None, help="keep the simulated logs here between runs")
    ap.add_argument("--before", help="also run this git revision's tree, alternating with this one")
    ap.add_argument("--no-serve", action="store_true")
    ap.add_argument("--no-cli", action="store_true")
    ap.add_argument("--max-s", type=float, default=3600.0, help="give up waiting for the serve queue after this long")
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="fdlog-fleet-day-"))
    try:
        real = real_logs()[:args.logs]
        cache = args.cache or work / "sim"
        print(f"logs: {len(real)} from {SHARED}; simulating {args.logs - len(real)} into {cache}", flush=True)
        sim = simulated_logs(cache, args.logs - len(real))
        folder = work / "fleet"
        folder.mkdir()
        logs = []
        for i, p in enumerate(real + sim):
            link = folder / f"{i:03d}_{p.name}"
            link.symlink_to(p.resolve())
            logs.append(link)
        size = sum(p.stat().st_size for p in logs)
        print(f"fleet: {len(logs)} logs, {size / 1e6:.0f} MB ({sum(p.suffix.lower() == '.ulg' for p in logs)} ULog, "
              f"{sum(p.suffix.lower() == '.bin' for p in logs)} DataFlash)", flush=True)
        trees: dict[str, Path | None] = {"after": None}
        if args.before:
            trees = {"before": extract(args.before, work), "after": None}
        la = os.getloadavg()
        print(f"load average at start: {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}", flush=True)
        for name, tree in trees.items() if not args.no_cli else ():
            report("cli", name, run_cli(tree, folder, work, name), len(logs))
        if not args.no_serve:
            for name, tree in trees.items():
                report("serve", name, run_serve(tree, logs, work, name, args.max_s), len(logs))
        la = os.getloadavg()
        print(f"load average at end: {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
