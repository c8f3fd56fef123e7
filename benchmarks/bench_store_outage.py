"""The store goes away under `fdlog serve`: PostgreSQL stopped (or the SQLite file moved away) with
uploads queued, then back. Does every job end `done`, once, without restarting the server?

    python benchmarks/bench_store_outage.py [--store postgres|sqlite|both] [--logs 6] [--outage-s 10]
                                            [--code DIR] [--max-s 240]

``--code DIR``: run the server from another checkout of the package (``PYTHONPATH=DIR``; e.g. one
made with ``git archive d8a1d2f | tar -x -C DIR``), to measure the code before a change in the same
run as after it.

What it does, per store: `fdlog serve` in a subprocess on a free loopback port (one worker
process), ``--logs`` sample logs uploaded, then at once the store is taken away for
``--outage-s`` seconds: PostgreSQL by ``pg_ctl stop -m fast`` (every client cut off) and
``pg_ctl start``; SQLite by renaming the database file (and its -wal / -shm) away and back.
During the outage and after it, ``/`` and ``/api/health`` are requested every 0.25 s. Printed:
the status codes seen during the outage; after the store is back, the seconds to the first 200 of
``/``; the seconds until every job is done (or ``--max-s``); each job's final state and claims
(``attempts``: 1 = diagnosed once); whether the server process is still the same one.

``--watch``: the same outage under `fdlog watch DIR --db STORE` instead: every sample log copied
slowly into the watched folder (64 KB chunks every 20 ms), the store taken away for
``--outage-s`` after the first third, copies going on meanwhile; `fdlog serve --db STORE
--workers 0` reads the same store. Printed: the seconds from the store's return to the next
diagnosis stored, to all stored; flights, claims per log, and whether the fleet page (200) names
every file.

Measured figures and the machine's load: results/store_outage.md.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
SAMPLES = sorted((ROOT / "sample_logs").glob("*.ulg")) + sorted((ROOT / "sample_logs").glob("*.bin"))
TOKEN = "bench-token-0123456789abcdef"
#: Seconds between page requests while watching the server through the outage.
PROBE_S = 0.25
SQLITE_SIDECARS = ("", "-wal", "-shm")


def start_server(data: Path, db: str, port: int, code: str | None, workers: int = 1) -> subprocess.Popen:
    import urllib.request

    tokens = data.parent / "tokens"
    tokens.write_text(TOKEN + "\n")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    if code:
        env["PYTHONPATH"] = code
    log = open(data.parent / "serve.log", "wb")
    proc = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "serve", "--data",
                             str(data), "--db", db, "--port", str(port), "--token-file", str(tokens), "--workers", str(workers)],
                            env=env, stdout=subprocess.DEVNULL, stderr=log, start_new_session=True,
                            cwd=str(data.parent))  # not the repo: `python -c` puts the cwd first on sys.path
    log.close()
    end = time.monotonic() + 90
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise RuntimeError((data.parent / "serve.log").read_text()[-800:])
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=2).read()
            return proc
        except OSError:
            time.sleep(0.3)
    raise RuntimeError("the server did not answer in 90 s")


class Prober(threading.Thread):
    """Requests / and /api/health every PROBE_S; keeps (monotonic time, path, status or error)."""

    def __init__(self, base: str):
        super().__init__(daemon=True)
        self.base, self.seen, self.halt = base, [], threading.Event()

    def run(self) -> None:
        import httpx

        with httpx.Client(timeout=15) as c:
            while not self.halt.is_set():
                for path in ("/", "/api/health"):
                    t = time.monotonic()
                    try:
                        r = c.get(self.base + path)
                        self.seen.append((t, path, r.status_code, r.text[:160] if r.status_code != 200 else ""))
                    except Exception as e:
                        self.seen.append((t, path, type(e).__name__, ""))
                self.halt.wait(PROBE_S)


def job_rows(db: str) -> list[dict]:
    if db.startswith("postgresql://"):
        import psycopg
        from psycopg.rows import dict_row

        with psycopg.connect(db, row_factory=dict_row) as c:
            return list(c.execute("SELECT id, state, attempts, error FROM job ORDER BY id"))
    c = sqlite3.connect(db)
    c.row_factory = sqlite3.Row
    try:
        return [dict(r) for r in c.execute("SELECT id, state, attempts, error FROM job ORDER BY id")]
    finally:
        c.close()


def run_one(kind: str, n_logs: int, outage_s: float, code: str | None, max_s: float) -> dict:
    import httpx
    from serve_helpers import Postgres, free_port, pg_halt, pg_resume

    tmp = Path(tempfile.mkdtemp(prefix=f"fdlog-outage-{kind}-"))
    pg = None
    proc = None
    try:
        data = tmp / "data"
        if kind == "postgres":
            pg = Postgres()
            db = pg.url()
        else:
            data.mkdir()
            db = str(data / "fdlog.sqlite")
        port = free_port()
        proc = start_server(data, db, port, code)
        pid = proc.pid
        base = f"http://127.0.0.1:{port}"
        with httpx.Client(timeout=60) as c:
            for p in SAMPLES[:n_logs]:
                with open(p, "rb") as fh:
                    r = c.post(base + "/api/logs", headers={"Authorization": f"Bearer {TOKEN}"}, files={"log": (p.name, fh)})
                r.raise_for_status()
        probe = Prober(base)
        probe.start()
        t_down = time.monotonic()
        if pg is not None:
            pg_halt(pg)
        else:
            for s in SQLITE_SIDECARS:
                if Path(db + s).exists():
                    os.replace(db + s, db + s + ".away")
        time.sleep(outage_s)
        if pg is not None:
            pg_resume(pg)
        else:
            for s in SQLITE_SIDECARS:
                if Path(db + s + ".away").exists():
                    os.replace(db + s + ".away", db + s)
        t_back = time.monotonic()
        end = t_back + max_s
        done_at = None
        rows = []
        while time.monotonic() < end:
            try:
                rows = job_rows(db)
            except Exception:
                rows = []
            if rows and all(r["state"] in ("done", "error") for r in rows):
                done_at = time.monotonic()
                break
            time.sleep(0.5)
        time.sleep(2 * PROBE_S)
        probe.halt.set()
        probe.join(20)
        during = Counter(f"{p} {s}" for t, p, s, _ in probe.seen if t_down <= t < t_back)
        lines = sorted({f"{p} {s}: {txt}" for t, p, s, txt in probe.seen if txt})[:6]
        first_ok = next((t - t_back for t, p, s, _ in probe.seen if t >= t_back and p == "/" and s == 200), None)
        last = [s for t, p, s, _ in probe.seen if p == "/"][-1:] or ["-"]
        return {"store": kind, "logs": n_logs, "outage_s": outage_s, "during": dict(during), "texts": lines,
                "first_200_after_s": first_ok, "all_done_after_s": None if done_at is None else done_at - t_back,
                "final": Counter(r["state"] for r in rows), "attempts": Counter(int(r["attempts"]) for r in rows),
                "errors": sorted({r["error"] for r in rows if r["error"]}), "last_page": last[0],
                "same_server": proc.poll() is None and proc.pid == pid,
                "log_tail": (tmp / "serve.log").read_text(errors="replace").strip().splitlines()[-3:]}
    finally:
        if proc is not None and proc.poll() is None:
            os.killpg(proc.pid, 9)
            proc.wait(10)
        if pg is not None:
            pg.stop()
        shutil.rmtree(tmp, ignore_errors=True)


def slow_copy(src: Path, dst: Path, chunk: int = 64 * 1024, pause_s: float = 0.02) -> None:
    with open(src, "rb") as fi, open(dst, "wb") as fo:
        while b := fi.read(chunk):
            fo.write(b)
            fo.flush()
            time.sleep(pause_s)


def run_watch(kind: str, outage_s: float, max_s: float) -> dict:
    import httpx
    from serve_helpers import Postgres, free_port, pg_halt, pg_resume

    tmp = Path(tempfile.mkdtemp(prefix=f"fdlog-watch-outage-{kind}-"))
    pg = watcher = server = None
    try:
        folder, data = tmp / "downloads", tmp / "data"
        folder.mkdir()
        data.mkdir()
        if kind == "postgres":
            pg = Postgres()
            db = pg.url()
        else:
            db = str(tmp / "fleet.sqlite")
        out = open(tmp / "watch.log", "wb")
        watcher = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "watch", str(folder),
                                    "--db", db, "--settle", "1"], stdout=out, stderr=out, start_new_session=True,
                                   cwd=str(tmp), env={**os.environ, "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"})
        out.close()
        time.sleep(3)
        port = free_port()
        subprocess.run([sys.executable, "-c", "from flightlog_fd.store import Store; import sys; Store(sys.argv[1]).close()",
                        db], check=True, cwd=str(tmp))
        server = start_server(data, db, port, None, workers=0)

        def stored() -> int:
            return sum(1 for r in job_rows(db) if r["state"] == "done")

        third = len(SAMPLES) // 3
        t_back = None
        for k, p in enumerate(SAMPLES):
            if k == third:
                while True:  # the first third stored, then the store goes away
                    try:
                        if stored() >= third:
                            break
                    except Exception:
                        pass
                    time.sleep(0.2)
                if pg is not None:
                    pg_halt(pg)
                else:
                    os.replace(db, db + ".away")
                t_down = time.monotonic()
            slow_copy(p, folder / p.name)
            if t_back is None and k >= third and time.monotonic() - t_down >= outage_s:
                t_back = _back(pg, db, pg_resume)
        if t_back is None:
            time.sleep(max(0.0, outage_s - (time.monotonic() - t_down)))
            t_back = _back(pg, db, pg_resume)
        n_before = stored()
        first_after = all_after = None
        end = t_back + max_s
        while time.monotonic() < end:
            n = stored()
            if first_after is None and n > n_before:
                first_after = time.monotonic() - t_back
            if n >= len(SAMPLES):
                all_after = time.monotonic() - t_back
                break
            time.sleep(0.2)
        rows = job_rows(db)
        page = httpx.get(f"http://127.0.0.1:{port}/", timeout=30)
        named = sum(p.name in page.text for p in SAMPLES)
        watcher.send_signal(15)
        code = watcher.wait(60)
        return {"store": kind, "logs": len(SAMPLES), "stored_before_back": n_before, "first_after_s": first_after,
                "all_after_s": all_after, "jobs": Counter(r["state"] for r in rows),
                "attempts": Counter(int(r["attempts"]) for r in rows), "page": page.status_code, "named": named,
                "watch_exit": code, "watch_tail": (tmp / "watch.log").read_text(errors="replace").strip().splitlines()[-4:]}
    finally:
        for proc in (watcher, server):
            if proc is not None and proc.poll() is None:
                os.killpg(proc.pid, 9)
                proc.wait(10)
        if pg is not None:
            pg.stop()
        shutil.rmtree(tmp, ignore_errors=True)


def _back(pg, db: str, pg_resume) -> float:
    if pg is not None:
        pg_resume(pg)
    else:
        os.replace(db + ".away", db)
    return time.monotonic()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--store", choices=("postgres", "sqlite", "both"), default="both")
    ap.add_argument("--logs", type=int, default=6)
    ap.add_argument("--outage-s", type=float, default=10.0)
    ap.add_argument("--code", default=None, help="run the server from this checkout (PYTHONPATH)")
    ap.add_argument("--max-s", type=float, default=240.0)
    ap.add_argument("--watch", action="store_true", help="the outage under `fdlog watch` (module docstring)")
    a = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}; code {a.code or ROOT}")
    ok = True
    if a.watch:
        for kind in (("postgres", "sqlite") if a.store == "both" else (a.store,)):
            r = run_watch(kind, a.outage_s, a.max_s)
            good = (r["jobs"].get("done", 0) == r["logs"] and set(r["attempts"]) == {1} and r["page"] == 200
                    and r["named"] == r["logs"])
            ok &= good
            print(f"\n== fdlog watch --db {kind}: {r['logs']} logs copied slowly, store away {a.outage_s:.0f} s after "
                  f"{r['stored_before_back']} were stored")
            print(f"  after it is back: next diagnosis stored after {r['first_after_s']} s, all after {r['all_after_s']} s")
            print(f"  jobs: {dict(r['jobs'])}; claims per log: {dict(r['attempts'])}; fleet page {r['page']} naming "
                  f"{r['named']}/{r['logs']} files; watch exit code {r['watch_exit']}")
            print(f"  watch output tail: {r['watch_tail']}")
            print(f"  {'OK' if good else 'FAILED'}")
        return 0 if ok else 1
    for kind in (("postgres", "sqlite") if a.store == "both" else (a.store,)):
        r = run_one(kind, a.logs, a.outage_s, a.code, a.max_s)
        good = (r["final"].get("done", 0) == a.logs and set(r["attempts"]) == {1} and r["last_page"] == 200
                and r["same_server"])
        ok &= good
        print(f"\n== {kind}: {a.logs} uploads, store away {a.outage_s:.0f} s")
        print(f"  during the outage: {r['during']}")
        for t in r["texts"]:
            print(f"  answer: {t}")
        print(f"  after it is back: first 200 of / after {r['first_200_after_s']} s; every job finished after "
              f"{r['all_done_after_s']} s")
        print(f"  jobs: {dict(r['final'])}; claims per job: {dict(r['attempts'])}; errors: {r['errors']}")
        print(f"  last page status {r['last_page']}; same server process: {r['same_server']}")
        print(f"  server log tail: {r['log_tail']}")
        print(f"  {'OK' if good else 'FAILED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
