"""`fdlog serve` jobs in the store, on SQLite and on a real PostgreSQL server started here from the
system's packages (skipped when they are absent): atomic claims, a restart that finishes queued
jobs (and one held by a killed server) exactly once, a worker process killed on a log leaving one
error row, migrations, calibration as a job, airframe merges."""
from __future__ import annotations

import json
import threading
import time

import pytest

pytest.importorskip("fastapi")

from serve_helpers import (AUTH, SAMPLES, counting_diagnose, dying_diagnose,  # noqa: E402
                           serve_client, upload, wait_done)

from flightlog_fd.database import DatabaseError  # noqa: E402
from flightlog_fd.report.json_report import validate  # noqa: E402
from flightlog_fd.store import LEASE_S, MAX_ATTEMPTS, MIGRATIONS, SCHEMA_VERSION  # noqa: E402
from flightlog_fd.store import Store as ServeStore  # noqa: E402
from flightlog_fd.serve.worker import wait_idle  # noqa: E402


@pytest.fixture(params=["sqlite", "postgres"])
def db_url(request, tmp_path):
    """A fresh store: a SQLite file, or a new database on the test's PostgreSQL server."""
    if request.param == "sqlite":
        return str(tmp_path / "store.sqlite")
    return request.getfixturevalue("postgres").url()


def test_concurrent_claims_take_each_job_once(db_url):
    store = ServeStore(db_url)
    for i in range(40):
        store.add_upload(f"{i:064x}", f"f{i}.ulg", 10, "ulog")
    taken: dict[str, list[int]] = {}

    def worker(name):
        s = ServeStore(db_url)
        got = taken.setdefault(name, [])
        while (job := s.claim_job(name)) is not None:
            got.append(int(job["id"]))
        s.close()

    threads = [threading.Thread(target=worker, args=(f"w{k}",)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    claimed = [j for ids in taken.values() for j in ids]
    all_ids = [int(r["id"]) for r in store.db.query("SELECT id FROM job")]
    assert sorted(claimed) == sorted(all_ids) and len(set(claimed)) == 40
    assert {r["attempts"] for r in store.db.query("SELECT attempts FROM job")} == {1}
    assert store.claim_job("late") is None
    store.close()


def test_restart_finishes_queued_jobs_exactly_once(tmp_path, db_url, runlog):
    names = ["px4_healthy.ulg", "px4_motor4_damaged.ulg", "ardupilot_motor1_damaged.bin", "ardupilot_healthy.bin"]
    data = tmp_path / "data"
    with serve_client(data, db=db_url, workers=0) as c:  # a server that only queues
        ids = [upload(c, SAMPLES / n).json()["id"] for n in names]
        assert all(c.get(f"/api/logs/{i}").json()["state"] == "queued" for i in ids)
    # a server killed while diagnosing the last one: its claim stays 'running' with a lease that ran out
    s = ServeStore(db_url)
    held = s.claim_job("killed-server")
    s.db.run("UPDATE job SET lease_until = ? WHERE id = ?", (time.time() - 1, held["id"]))
    s.close()
    with serve_client(data, db=db_url, workers=1, diagnose_fn=counting_diagnose) as c:
        results = [wait_done(c, i) for i in ids]
        store = c.app_.state.store
        assert wait_idle(store, 30)
        jobs = store.db.query("SELECT flight_id, state, attempts FROM job ORDER BY flight_id")
    assert [r["state"] for r in results] == ["done"] * 4
    assert all(validate(r["diagnosis"]) == [] for r in results)
    assert [j["state"] for j in jobs] == ["done"] * 4
    # the job the killed server held was claimed twice (once by it), every other once
    assert {j["flight_id"]: j["attempts"] for j in jobs} == {i: (2 if i == held["flight_id"] else 1) for i in ids}
    runs = runlog.read_text().split()
    assert sorted(runs) == sorted(r["sha256"] for r in results)  # each log diagnosed exactly once


def test_a_worker_killed_on_a_log_leaves_one_error_row(tmp_path, db_url, runlog):
    with serve_client(tmp_path / "data", db=db_url, workers=1, diagnose_fn=dying_diagnose) as c:
        bad = upload(c, SAMPLES / "ardupilot_motor2_damaged.bin", name="kill-me.bin").json()["id"]
        good = upload(c, SAMPLES / "px4_healthy.ulg").json()["id"]
        jb, jg = wait_done(c, bad), wait_done(c, good)
        # the slot started a fresh worker process and goes on
        later = wait_done(c, upload(c, SAMPLES / "px4_motor3_midflight.ulg").json()["id"])
        store = c.app_.state.store
        errors = store.db.query("SELECT flight_id, error FROM job WHERE state = 'error'")
        page = c.get(f"/flights/{bad}").text
    assert jb["state"] == "error" and "died" in jb["error"]
    assert jb["diagnosis"]["verdict"]["status"] == "not_diagnosable" and validate(jb["diagnosis"]) == []
    assert [e["flight_id"] for e in errors] == [bad]
    assert jg["state"] == "done" and later["state"] == "done"
    assert "Error row" in page and "died" in page


def test_a_log_that_keeps_killing_servers_becomes_an_error_row(db_url):
    store = ServeStore(db_url)
    fid, _ = store.add_upload("ab" * 32, "x.ulg", 1, "ulog")
    for k in range(MAX_ATTEMPTS):
        job = store.claim_job(f"server-{k}")
        assert job is not None
        store.db.run("UPDATE job SET lease_until = ? WHERE id = ?", (time.time() - 1, job["id"]))
        out = store.recover()
        assert out == ({"requeued": 1, "failed": 0} if k < MAX_ATTEMPTS - 1 else {"requeued": 0, "failed": 1})
    f = store.flight(fid)
    assert f["state"] == "error" and "server stopped" in f["error"]
    assert store.claim_job("next") is None
    # the holder of a lost job cannot write a result over it
    assert store.complete_diagnosis(job, f"server-{MAX_ATTEMPTS - 1}", {"sha256": "ab" * 32, "diagnosis": {}}) is False
    store.close()


def test_migrations_run_once_and_a_newer_store_is_refused(db_url):
    a = ServeStore(db_url)
    assert a.db.schema_version() == SCHEMA_VERSION
    assert ServeStore(db_url).db.migrate(MIGRATIONS) == []
    a.db.run("INSERT INTO schema_migrations (version, name, applied_at) VALUES (99, 'future', 'x')")
    with pytest.raises(DatabaseError, match="newer than this fdlog"):
        ServeStore(db_url)
    a.close()


def test_a_sqlite_file_of_something_else_is_refused(tmp_path):
    import sqlite3

    p = tmp_path / "other.sqlite"
    sqlite3.connect(p).execute("CREATE TABLE t (x)")
    with pytest.raises(DatabaseError, match="not an fdlog store"):
        ServeStore(str(p))
    with pytest.raises(DatabaseError, match="folder"):
        ServeStore(str(tmp_path))


def test_calibration_job_gives_later_flights_the_profile(tmp_path):
    from flightlog_fd import load_flight
    from flightlog_fd.logs.ulog_writer import write_ulog

    with serve_client(tmp_path / "data", workers=1) as c:
        healthy = upload(c, SAMPLES / "px4_healthy.ulg").json()["id"]
        key = wait_done(c, healthy)["airframe"]
        assert c.post(f"/flights/{healthy}/healthy", headers=AUTH, data={"healthy": "1"},
                      follow_redirects=False).status_code == 303
        r = c.post("/airframe/calibrate", headers=AUTH, data={"key": key}, follow_redirects=False)
        assert r.status_code == 303, r.text
        store = c.app_.state.store
        assert wait_idle(store, 120)
        job = store.db.one("SELECT * FROM job WHERE kind = 'calibrate'")
        assert job["state"] == "done", job["error"]
        assert json.loads(job["args"])["flights"] == [healthy]
        assert store.airframes()[key]["profile_path"]
        # a later flight of the same airframe (its id) is diagnosed with the profile
        f = load_flight(SAMPLES / "px4_motor1_damaged.ulg")
        f.vehicle_id = key
        later = tmp_path / "later.ulg"
        write_ulog(f, later)
        j = wait_done(c, upload(c, later).json()["id"])
        assert j["airframe"] == key and j["diagnosis"]["profile"] is not None
        before = c.get(f"/api/logs/{healthy}").json()["diagnosis"]
        assert before["profile"] is None  # flights before the calibration keep their diagnosis
        page = c.get("/airframe", params={"key": key}).text
        assert "later flights of this airframe are diagnosed with" in page.lower()
        assert 'id="profile"' in page and "rho (motor imbalance)" in page and "measured only" in page


def test_calibration_jobs_keep_the_airframes_sessions(tmp_path):
    """A first calibration job makes one session per marked flight; "add" makes the newly marked
    flights the next sessions of a new profile file (the earlier one kept) and the store keeps
    which flight is which session; a flight that looks damaged against the sessions is refused
    (the job's error, one line) and the profile stays."""
    from flightlog_fd import load_flight
    from flightlog_fd.logs.ulog_writer import write_ulog

    def again(name, key, dst):  # the same flight data under this airframe's id, as other bytes
        f = load_flight(SAMPLES / name)
        f.vehicle_id = key
        write_ulog(f, dst)
        return dst

    with serve_client(tmp_path / "data", workers=1) as c:
        store = c.app_.state.store
        first = upload(c, SAMPLES / "px4_healthy.ulg").json()["id"]
        key = wait_done(c, first)["airframe"]

        def calibrate(fid, mode):
            c.post(f"/flights/{fid}/healthy", headers=AUTH, data={"healthy": "1"}, follow_redirects=False)
            r = c.post("/airframe/calibrate", headers=AUTH, data={"key": key, "mode": mode}, follow_redirects=False)
            assert r.status_code == 303, r.text
            assert wait_idle(store, 180)
            return store.db.one("SELECT * FROM job WHERE kind = 'calibrate' ORDER BY id DESC LIMIT 1")

        job = calibrate(first, "new")
        assert job["state"] == "done", job["error"]
        p1 = store.airframes()[key]["profile_path"]
        assert [(s["session"], s["flight_id"]) for s in store.calibration_sessions(key)] == [(1, first)]
        second = wait_done(c, upload(c, again("px4_healthy.ulg", key, tmp_path / "h2.ulg")).json()["id"])["id"]
        job = calibrate(second, "add")
        assert job["state"] == "done", job["error"]
        assert json.loads(job["args"]) == {"flights": [second], "adapt": False, "add_to": p1}
        p2 = store.airframes()[key]["profile_path"]
        assert p2 != p1 and json.loads(open(p1).read())["schema"] == 7  # the earlier profile stays
        assert len(json.loads(open(p2).read())["sessions_"]) == 2
        assert [(s["session"], s["flight_id"]) for s in store.calibration_sessions(key)] == [(1, first), (2, second)]
        page = c.get("/airframe", params={"key": key}).text
        assert 'id="sessions">2' in page and 'id="session-flights"' in page and "h2.ulg" in page
        # nothing new to add: one line, no job
        r = c.post("/airframe/calibrate", headers=AUTH, data={"key": key, "mode": "add"})
        assert r.status_code == 400 and "already a session" in r.text
        bad = wait_done(c, upload(c, again("px4_motor1_damaged.ulg", key, tmp_path / "m1.ulg")).json()["id"])["id"]
        assert "airframe profile, 2 calibration sessions" in c.get(f"/flights/{bad}").text  # diagnosed with it
        job = calibrate(bad, "add")
        assert job["state"] == "error" and "looks damaged against the 2 sessions" in job["error"], job["error"]
        assert store.airframes()[key]["profile_path"] == p2 and len(store.calibration_sessions(key)) == 2


def test_operator_names_and_merges_airframes(tmp_path):
    with serve_client(tmp_path / "data", workers=1) as c:
        ids = [upload(c, SAMPLES / n).json()["id"] for n in ("ardupilot_healthy.bin", "ardupilot_motor3_damaged.bin")]
        a, b = (wait_done(c, i)["airframe"] for i in ids)
        assert a != b
        assert c.post("/airframe/rename", headers=AUTH, data={"key": a, "name": "F450 <blue>"},
                      follow_redirects=False).status_code == 303
        assert c.post("/airframe/merge", headers=AUTH, data={"key": b, "into": a},
                      follow_redirects=False).status_code == 303
        fleet = c.app_.state.store.fleet()
        assert [(x["key"], x["name"], len(x["flights"]), x["members"]) for x in fleet] == [(a, "F450 <blue>", 2, [b])]
        assert c.get(f"/api/logs/{ids[1]}").json()["airframe"] == a
        assert "F450 &lt;blue&gt;" in c.get("/").text
        # the merged key leads to the airframe it joined; a loop is refused with one line
        assert c.get("/airframe", params={"key": b}, follow_redirects=False).status_code == 303
        r = c.post("/airframe/merge", headers=AUTH, data={"key": a, "into": b})
        assert r.status_code == 400 and "already one" in r.text


def test_two_servers_share_one_store_and_diagnose_each_log_once(tmp_path, db_url, runlog):
    names = ["px4_healthy.ulg", "px4_motor2_damaged.ulg", "ardupilot_motor1_damaged.bin", "ardupilot_healthy.bin"]
    data = tmp_path / "data"
    with serve_client(data, db=db_url, workers=1, diagnose_fn=counting_diagnose) as a, \
            serve_client(data, db=db_url, workers=1, diagnose_fn=counting_diagnose) as b:
        ids = [upload(a if i % 2 else b, SAMPLES / n).json()["id"] for i, n in enumerate(names)]
        results = [wait_done(a, i) for i in ids]
        holders = {r["worker"] for r in a.app_.state.store.db.query("SELECT worker FROM job")}
    assert [r["state"] for r in results] == ["done"] * len(names)
    assert sorted(runlog.read_text().split()) == sorted(r["sha256"] for r in results)
    assert len(holders) == 2  # both servers took jobs from the one queue


def test_a_log_that_hangs_its_worker_is_stopped_and_becomes_an_error_row(tmp_path, runlog):
    from serve_helpers import sleeping_diagnose

    with serve_client(tmp_path / "data", workers=1, diagnose_fn=sleeping_diagnose, job_timeout_s=8) as c:
        hang = upload(c, SAMPLES / "ardupilot_motor2_damaged.bin", name="hang.bin").json()["id"]
        ok = upload(c, SAMPLES / "px4_healthy.ulg").json()["id"]
        jh, jo = wait_done(c, hang, 60), wait_done(c, ok, 60)
    assert jh["state"] == "error" and "longer than 8 s" in jh["error"]
    assert jo["state"] == "done"


def test_dask_scheduler_runs_the_jobs(tmp_path):
    pytest.importorskip("dask.distributed")
    with serve_client(tmp_path / "data", workers=1, scheduler="local") as c:
        j = wait_done(c, upload(c, SAMPLES / "px4_motor4_damaged.ulg").json()["id"], 120)
    assert j["state"] == "done" and j["diagnosis"]["verdict"]["motor"] == 4


def test_a_killed_server_process_restarts_and_finishes_every_log_once(tmp_path):
    """The real command: `fdlog serve` SIGKILLed (with its worker processes) while diagnosing,
    then started again on the same data folder."""
    import os
    import signal
    import sqlite3
    import urllib.request

    from serve_helpers import free_port, start_server

    names = ["px4_healthy.ulg", "px4_motor1_damaged.ulg", "px4_motor2_damaged.ulg", "px4_motor4_damaged.ulg",
             "ardupilot_healthy.bin", "ardupilot_motor3_damaged.bin"]
    data = tmp_path / "data"

    def jobs(port):
        return json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=10).read())["jobs"]

    port = free_port()
    proc = start_server(data, port, *(SAMPLES / n for n in names), workers=1)  # queues the logs at start
    try:
        end = time.monotonic() + 120
        while time.monotonic() < end and not (jobs(port)["done"] >= 1 and jobs(port)["running"] == 1):
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(30)
    db = data / "fdlog.sqlite"
    con = sqlite3.connect(db)
    held = {r[0] for r in con.execute("SELECT id FROM job WHERE state = 'running'")}
    queued = con.execute("SELECT COUNT(*) FROM job WHERE state = 'queued'").fetchone()[0]
    con.close()
    assert queued >= 1 and len(held) == 1  # the kill left work behind, one job mid-diagnosis
    port = free_port()
    t0 = time.monotonic()
    proc = start_server(data, port, workers=1)  # no logs given: only what the store holds
    try:
        end = time.monotonic() + 180
        while time.monotonic() < end and jobs(port)["done"] < len(names):
            time.sleep(0.3)
        final = jobs(port)
    finally:
        proc.terminate()
        proc.wait(30)
    assert final == {"queued": 0, "running": 0, "done": len(names), "error": 0}
    assert time.monotonic() - t0 < LEASE_S  # the dead holder's job did not wait for its lease
    con = sqlite3.connect(db)
    rows = con.execute("SELECT flight.sha256, flight.state, job.id, job.attempts FROM flight JOIN job "
                       "ON job.flight_id = flight.id").fetchall()
    con.close()
    assert len(rows) == len(names) and len({r[0] for r in rows}) == len(names)  # one row, one job per log
    assert all(r[1] == "done" for r in rows)
    # the job the dead server held was taken again at once (its process is gone), the others once
    assert {r[2]: r[3] for r in rows} == {r[2]: (2 if r[2] in held else 1) for r in rows}


def test_an_older_store_is_upgraded_in_place(db_url):
    from flightlog_fd.database import open_database

    old = open_database(db_url)
    assert old.migrate(MIGRATIONS[:1]) == [1]  # a store made by the first version
    old.run("INSERT INTO flight (sha256, name, size_bytes, format, uploaded_at, state) "
            "VALUES ('aa', 'old.ulg', 1, 'ulog', 'x', 'done')")
    old.close()
    s = ServeStore(db_url)
    assert s.db.schema_version() == SCHEMA_VERSION
    assert s.db.one("SELECT name FROM flight WHERE sha256 = 'aa'")["name"] == "old.ulg"
    assert s.db.query("SELECT * FROM finding") == []
    s.close()
