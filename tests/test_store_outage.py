"""The store goes away under `fdlog serve` mid-queue (PostgreSQL stopped and started again, the
SQLite file moved away and back): pages answer 503 with one line meanwhile and show the workers
waiting, no job is failed for it, every job ends done with each log diagnosed once, and the same
server answers 200 afterwards. Also `fdlog serve --watch`: a folder's logs queued once each."""
from __future__ import annotations

import os
import shutil
import time
from collections import Counter

import pytest

pytest.importorskip("fastapi")

from serve_helpers import (AUTH, SAMPLES, counting_diagnose, pg_halt, pg_resume,  # noqa: E402
                           serve_client, upload, wait_done)

from flightlog_fd.database import RECONNECT_GAP_S, StoreUnavailable, open_database  # noqa: E402
from flightlog_fd.util import file_sha256  # noqa: E402

LOGS = ["ardupilot_motor2_damaged.bin", "px4_motor4_damaged.ulg", "ardupilot_plus_motor4_damaged.bin",
        "ardupilot_healthy.bin", "px4_motor2_damaged.ulg", "ardupilot_motor3_damaged.bin"]
#: Seconds the store stays away in these tests (results/store_outage.md: 10 s, measured).
OUTAGE_S = 4.0


@pytest.fixture(params=["sqlite", "postgres"])
def outage(request, tmp_path):
    """(store target, take it away, bring it back)."""
    if request.param == "postgres":
        pg = request.getfixturevalue("postgres")
        return pg.url(), lambda: pg_halt(pg), lambda: pg_resume(pg)
    db = str(tmp_path / "data" / "fdlog.sqlite")

    def away():
        os.replace(db, db + ".away")

    def back():
        os.replace(db + ".away", db)

    return db, away, back


def test_jobs_survive_the_store_going_away_mid_queue(tmp_path, outage, runlog):
    db, away, back = outage
    with serve_client(tmp_path / "data", db=db, diagnose_fn=counting_diagnose) as c:
        fids = [upload(c, SAMPLES / n).json()["id"] for n in LOGS]
        away()
        try:
            t_end = time.monotonic() + OUTAGE_S
            page = c.get("/")
            api = c.get(f"/api/logs/{fids[0]}", headers=AUTH)
            deadline = time.monotonic() + 15
            while True:  # the running job finishes and its slot waits for the store
                health = c.get("/api/health")
                waiting = [w for w in health.json().get("workers", []) if w["state"] == "waiting for the store"]
                if waiting or time.monotonic() > deadline:
                    break
                time.sleep(0.2)
            time.sleep(max(0.0, t_end - time.monotonic()))
        finally:
            back()
        assert page.status_code == 503 and page.headers.get("retry-after")
        assert "store is unavailable" in page.text and "try again" in page.text
        assert "workers:" in page.text  # the error page still shows the workers' state
        assert api.status_code == 503 and "store is unavailable" in api.json()["error"]
        assert health.status_code == 503 and health.json()["outage"]["reason"]
        assert waiting, health.json()
        end = time.monotonic() + 30
        while c.get("/api/health").status_code != 200 and time.monotonic() < end:
            time.sleep(0.1)  # within RECONNECT_GAP_S of a failed attempt a request is still told 503
        done = [wait_done(c, fid, timeout=180) for fid in fids]
        assert [d["state"] for d in done] == ["done"] * len(LOGS)
        assert c.get("/").status_code == 200
        health = c.get("/api/health").json()
        assert health["ok"] and health["jobs"]["done"] == len(LOGS) and health["jobs"]["error"] == 0
        jobs = [c.get(f"/api/jobs/{j}", headers=AUTH).json() for j in range(1, len(LOGS) + 1)]
        assert [j["attempts"] for j in jobs] == [1] * len(LOGS)
    runs = Counter(runlog.read_text().split())
    assert runs == Counter({file_sha256(SAMPLES / n): 1 for n in LOGS})  # each log diagnosed once


def test_a_dead_connection_is_replaced_and_a_missing_sqlite_file_is_never_made_anew(tmp_path, postgres):
    db = open_database(postgres.url())
    assert db.one("SELECT 1 AS x")["x"] == 1
    pg_halt(postgres)
    try:
        with pytest.raises(StoreUnavailable, match="store is unavailable"):
            db.one("SELECT 1 AS x")
        assert db.outage() is not None
    finally:
        pg_resume(postgres)
    time.sleep(RECONNECT_GAP_S)  # within it, other calls are told "unavailable" without trying again
    assert db.one("SELECT 1 AS x")["x"] == 1 and db.outage() is None  # same object, no restart
    db.close()

    path = tmp_path / "s.sqlite"
    lite = open_database(path)
    lite.run("CREATE TABLE t (x INTEGER)")
    lite.transaction(lambda: lite.run("INSERT INTO t VALUES (1)"))
    os.replace(path, tmp_path / "moved.sqlite")
    with pytest.raises(StoreUnavailable):
        lite.transaction(lambda: lite.run("INSERT INTO t VALUES (2)"))
    assert not path.exists()  # nothing written to the moved file, no empty store made at the path
    shutil.copyfile(tmp_path / "moved.sqlite", path)  # another file at the path (a restored copy)
    lite.transaction(lambda: lite.run("INSERT INTO t VALUES (3)"))
    assert [r["x"] for r in lite.query("SELECT x FROM t ORDER BY x")] == [1, 3]
    lite.close()


def test_serve_watch_queues_each_log_of_a_folder_once(tmp_path, runlog):
    folder = tmp_path / "share"
    folder.mkdir()
    kw = dict(diagnose_fn=counting_diagnose, watch=[folder], watch_settle_s=0.3)
    with serve_client(tmp_path / "data", **kw) as c:
        shutil.copyfile(SAMPLES / LOGS[0], folder / "a.bin")
        shutil.copyfile(SAMPLES / LOGS[1], folder / "b.ulg")
        shutil.copyfile(SAMPLES / LOGS[0], folder / "a_again.bin")
        end = time.monotonic() + 120
        while time.monotonic() < end:
            logs = c.get("/api/logs", headers=AUTH).json()["logs"]
            if len(logs) == 2 and all(f["state"] == "done" for f in logs):
                break
            time.sleep(0.3)
        assert sorted(f["state"] for f in logs) == ["done", "done"]
    with serve_client(tmp_path / "data", **kw) as c:  # restarted: the folder's logs are known
        shutil.copyfile(SAMPLES / LOGS[2], folder / "c.bin")
        end = time.monotonic() + 120
        while time.monotonic() < end:
            logs = c.get("/api/logs", headers=AUTH).json()["logs"]
            if len(logs) == 3 and all(f["state"] == "done" for f in logs):
                break
            time.sleep(0.3)
        assert len(logs) == 3 and all(f["state"] == "done" for f in logs)
    runs = Counter(runlog.read_text().split())
    assert runs == Counter({file_sha256(SAMPLES / n): 1 for n in LOGS[:3]})
