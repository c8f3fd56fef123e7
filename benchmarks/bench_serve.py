"""Load benchmark of `fdlog serve` on loopback: 8 concurrent clients upload 200 logs, pages are
timed while the queue is diagnosed, and every upload must be exactly one flight row (0 lost).

    python benchmarks/bench_serve.py [--logs 200] [--clients 8] [--workers 2] [--flight-s 25] [--max-s 900]

The logs: ``--clients`` short simulated flights (``--flight-s`` s, PX4 default logging rates, one
airframe id each, every other one with a damaged propeller), each written ``logs / clients``
times as a byte-distinct ULog: the copies differ only in the simulator's ``fdlog_truth`` info
field (a copy number), which the reader ignores. So the 200 files are 200 distinct uploads (200
content hashes, 200 jobs, 200 diagnoses), but within one airframe the flight data, and so the
verdicts, are the same. The server is `fdlog serve` in a subprocess on 127.0.0.1 with its SQLite
store and ``--workers`` diagnosis processes.

Clients: each uploads its share with ``POST /api/logs`` (Bearer token), then also re-uploads the
first log of the next client (a duplicate racing the original: it must map to the same flight),
then keeps loading pages (fleet, an airframe, a flight, ``/api/logs/ID``) until the queue is empty.
Printed: upload throughput and latency, page latency p50/p95 while diagnosing (requests that
started before the queue emptied), diagnosis throughput (uploads / time to an empty queue), and
the check: every uploaded hash is exactly one row, every row has one job, all done.
Bounded: ``--max-s`` stops waiting (exit 1). Loopback only. The machine is shared: compare figures
from one run.

Measured 2026-11-23 on the current code (2 cores shared, load average 5-10 from other users;
defaults): 208 uploads in 6.5 s = 32.1 uploads/s, 12 MB/s, upload latency p50 222 ms / p95 332 ms;
200 logs diagnosed in 102.6 s = 1.95 logs/s; pages while diagnosing p50/p95: fleet 101/344 ms,
airframe 125/487 ms, flight 59/183 ms, /api/logs/ID 42/135 ms; check OK (200 rows, 0 lost, 0 twice).
An earlier run at load ~4: 91.5 uploads/s, 2.36 logs/s, fleet 75/313 ms, airframe 100/495 ms.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import random
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

TOKEN = "bench-token-0123456789abcdef"
#: Propeller efficiency of the damaged airframes (every other one).
BENCH_ETA = 0.75


def make_logs(out: Path, n_logs: int, n_frames: int, flight_s: float) -> list[list[Path]]:
    """Per airframe its byte-distinct copies (module docstring)."""
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    per = n_logs // n_frames
    groups = []
    for k in range(n_frames):
        dmg = Damage(1 + k % 4, BENCH_ETA) if k % 2 else Damage()
        fl = simulate_flights(1, airframes=[preset("x500" if k % 2 == 0 else "f450", None)], damages=[dmg],
                              duration_s=flight_s, profile="px4_default", seed=500 + k)[0]
        fl.vehicle_id = f"bench-{k}"
        base_truth = dict(fl.truth or {})
        paths = []
        for j in range(per + (1 if k < n_logs - per * n_frames else 0)):
            fl.truth = {**base_truth, "bench_copy": j}
            p = out / f"bench{k}_copy{j:03d}.ulg"
            write_ulog(fl, p)
            paths.append(p)
        groups.append(paths)
    return groups


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))] if xs else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=200)
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--flight-s", type=float, default=25.0)
    ap.add_argument("--max-s", type=float, default=900.0, help="give up waiting for the queue after this long")
    args = ap.parse_args()
    try:
        import httpx
    except ImportError:
        print("skipped: needs the [serve] extra (httpx)")
        return 0

    work = Path(tempfile.mkdtemp(prefix="fdlog-bench-serve-"))
    try:
        t0 = time.perf_counter()
        groups = make_logs(work, args.logs, args.clients, args.flight_s)
        files = [p for g in groups for p in g]
        sizes = sum(p.stat().st_size for p in files)
        print(f"logs: {len(files)} byte-distinct ULogs from {len(groups)} simulated {args.flight_s:.0f} s flights "
              f"({sizes / 1e6:.0f} MB, made in {time.perf_counter() - t0:.0f} s)")
        sha = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in files}
        (work / "tokens").write_text(TOKEN + "\n")
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        base = f"http://127.0.0.1:{port}"
        data = work / "data"
        server = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "serve",
                                   "--data", str(data), "--host", "127.0.0.1", "--port", str(port),
                                   "--token-file", str(work / "tokens"), "--workers", str(args.workers)],
                                  env={**os.environ, "OMP_NUM_THREADS": "1"}, stderr=subprocess.PIPE)
        try:
            return run(args, httpx, base, server, groups, sha, data, sizes)
        finally:
            server.terminate()
            try:
                server.wait(30)
            except subprocess.TimeoutExpired:
                server.kill()
    finally:
        shutil.rmtree(work, ignore_errors=True)


def run(args, httpx, base, server, groups, sha, data: Path, sizes: int) -> int:
    end = time.monotonic() + 60
    while True:
        try:
            httpx.get(base + "/api/health", timeout=2)
            break
        except httpx.HTTPError:
            if time.monotonic() > end or server.poll() is not None:
                print("the server did not start:", server.stderr.read().decode()[-400:] if server.stderr else "")
                return 1
            time.sleep(0.3)
    auth = {"Authorization": f"Bearer {TOKEN}"}
    lock = threading.Lock()
    ids: dict[Path, int] = {}
    dup_ids: list[tuple[Path, int]] = []
    upload_lat: list[float] = []
    page_lat: dict[str, list[float]] = {"fleet": [], "airframe": [], "flight": [], "api": []}
    failures: list[str] = []
    drained = threading.Event()
    uploads_done = threading.Barrier(args.clients)
    t_start = time.perf_counter()
    t_uploaded = [0.0]

    def client(k: int) -> None:
        rnd = random.Random(k)
        with httpx.Client(timeout=120) as c:
            mine = list(groups[k]) + [groups[(k + 1) % len(groups)][0]]  # the last one is a racing duplicate
            for i, p in enumerate(mine):
                t = time.perf_counter()
                with open(p, "rb") as fh:
                    r = c.post(base + "/api/logs", headers=auth, files={"log": (p.name, fh)})
                dt = time.perf_counter() - t
                if r.status_code != 200:
                    with lock:
                        failures.append(f"upload {p.name}: HTTP {r.status_code} {r.text[:100]}")
                    continue
                with lock:
                    upload_lat.append(dt)
                    if i == len(mine) - 1:
                        dup_ids.append((p, r.json()["id"]))
                    else:
                        ids[p] = r.json()["id"]
            if uploads_done.wait() == 0:
                t_uploaded[0] = time.perf_counter()
            while not drained.is_set():
                with lock:
                    known = list(ids.values())
                fid = rnd.choice(known) if known else 1
                for name, url in (("fleet", "/"), ("airframe", f"/airframe?key=bench-{rnd.randrange(len(groups))}"),
                                  ("flight", f"/flights/{fid}"), ("api", f"/api/logs/{fid}")):
                    if drained.is_set():
                        break
                    t = time.perf_counter()
                    r = c.get(base + url)
                    dt = time.perf_counter() - t
                    if r.status_code not in (200, 404):  # an airframe not diagnosed yet is a 404
                        with lock:
                            failures.append(f"GET {url}: HTTP {r.status_code}")
                    elif not drained.is_set():
                        with lock:
                            page_lat[name].append(dt)
                time.sleep(0.05)

    threads = [threading.Thread(target=client, args=(k,), daemon=True) for k in range(args.clients)]
    for t in threads:
        t.start()
    deadline = time.monotonic() + args.max_s
    t_drained = None
    while time.monotonic() < deadline:
        time.sleep(0.5)
        if any(t.is_alive() for t in threads) and not t_uploaded[0]:
            continue
        jobs = httpx.get(base + "/api/health", timeout=30).json()["jobs"]
        if jobs["queued"] == 0 and jobs["running"] == 0:
            t_drained = time.perf_counter()
            break
    drained.set()
    for t in threads:
        t.join(60)
    n = len(ids)
    if t_drained is None:
        print(f"gave up after {args.max_s:.0f} s with jobs still queued: {jobs}")
        return 1
    up_s = t_uploaded[0] - t_start
    all_s = t_drained - t_start
    print(f"server: 127.0.0.1, {args.workers} diagnosis worker processes, SQLite store; {args.clients} concurrent clients")
    print(f"uploads: {n + len(dup_ids)} requests ({n} distinct logs + {len(dup_ids)} racing duplicates) in {up_s:.1f} s "
          f"= {(n + len(dup_ids)) / up_s:.1f} uploads/s, {sizes / 1e6 / up_s:.1f} MB/s; upload latency "
          f"p50 {1000 * pct(upload_lat, 0.5):.0f} ms, p95 {1000 * pct(upload_lat, 0.95):.0f} ms")
    print(f"diagnosis: {n} logs from first upload to empty queue in {all_s:.1f} s = {n / all_s:.2f} logs/s")
    for name, lat in page_lat.items():
        print(f"page {name:<8} while diagnosing: {len(lat):4d} requests, p50 {1000 * pct(lat, 0.5):.0f} ms, "
              f"p95 {1000 * pct(lat, 0.95):.0f} ms")
    # the check: every upload exactly one row, one job each, all done, duplicates on the original
    con = sqlite3.connect(f"file:{data / 'fdlog.sqlite'}?mode=ro", uri=True)
    rows = con.execute("SELECT sha256, COUNT(*), MIN(id), MIN(state) FROM flight GROUP BY sha256").fetchall()
    jobs = dict(con.execute("SELECT flight_id, COUNT(*) FROM job GROUP BY flight_id").fetchall())
    states = dict(con.execute("SELECT state, COUNT(*) FROM flight GROUP BY state").fetchall())
    con.close()
    by_sha = {r[0]: r for r in rows}
    lost = [p.name for p in ids if sha[p] not in by_sha]
    twice = [r[0][:12] for r in rows if r[1] != 1]
    wrong_id = [p.name for p, fid in ids.items() if sha[p] in by_sha and by_sha[sha[p]][2] != fid]
    dup_wrong = [p.name for p, fid in dup_ids if fid != ids.get(p)]
    job_bad = [fid for fid, c in jobs.items() if c != 1]
    ok = not (lost or twice or wrong_id or dup_wrong or job_bad or failures) and len(rows) == n \
        and states.get("done", 0) == n
    print(f"check: {len(rows)} flight rows for {n} distinct uploads; {len(lost)} lost, {len(twice)} stored twice, "
          f"{len(dup_wrong)} duplicates not on their original, {len(job_bad)} flights with != 1 job, "
          f"states {states}, {len(failures)} failed requests -> {'OK' if ok else 'FAILED'}")
    for f in failures[:5]:
        print("  ", f)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
