"""`fdlog watch`: every log that appears in a folder diagnosed once into the store, through slow
copies (partial writes), renames, duplicates, a corrupt file, a watcher killed mid-diagnosis and
the store going away (SQLite file moved away, PostgreSQL stopped), on filesystem events and on
polling."""
from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from serve_helpers import SAMPLES, pg_halt, pg_resume

from flightlog_fd.store import Store
from flightlog_fd.watch import FolderWatch, choose_mode

#: Settle time of the tests' watchers: the slow copies below pause 0.05 s between chunks.
TEST_SETTLE_S = 0.6
SMALL = ["ardupilot_motor2_damaged.bin", "px4_motor4_damaged.ulg", "ardupilot_plus_motor4_damaged.bin",
         "ardupilot_healthy.bin"]
LARGE = "px4_octo_motor2_damaged.ulg"  # the longest diagnosis of the samples: the one killed mid-way
SLOW_DIAGNOSIS = Path(__file__).parent / "slow_diagnosis"


def slow_copy(src: Path, dst: Path, chunk: int = 64 * 1024, pause_s: float = 0.05) -> None:
    """Copy in chunks with pauses, as a download or a network copy writes (each chunk flushed)."""
    with open(src, "rb") as fi, open(dst, "wb") as fo:
        while True:
            b = fi.read(chunk)
            if not b:
                break
            fo.write(b)
            fo.flush()
            time.sleep(pause_s)


def bad_log(path: Path) -> None:
    """A ULog cut in its definitions (a download that stopped early): not diagnosable."""
    path.write_bytes((SAMPLES / "px4_motor4_damaged.ulg").read_bytes()[:3000])


# ----------------------------------------------------------------------------- the watch loop alone

@pytest.mark.parametrize("poll", [None, 0.1], ids=["events", "polling"])
def test_a_file_is_taken_once_only_after_it_stops_growing(tmp_path, poll):
    folder = tmp_path / "in"
    folder.mkdir()
    store = Store(tmp_path / "s.sqlite")
    taken = []

    def sink(found):
        taken.append((Path(found.path).name, found.size, os.path.getsize(found.path)))
        return "diagnosed", "ok"

    w = FolderWatch([folder], store, sink, settle_s=TEST_SETTLE_S, poll_s=poll, rescan_s=30)
    if poll is None:
        assert w.modes[folder.resolve()][0] == ("events" if _has_watchdog() else "poll")
    t = threading.Thread(target=w.run, daemon=True)
    t.start()
    try:
        src = SAMPLES / SMALL[0]
        slow_copy(src, folder / "a.bin")  # ~1.3 s of writes, pauses far below the settle time
        (folder / "sub").mkdir()
        slow_copy(src, folder / "sub" / "b.part")  # a download in progress: never read under this name
        os.replace(folder / "sub" / "b.part", folder / "sub" / "b.bin")  # renamed in when complete
        (folder / ".hidden.bin").write_bytes(src.read_bytes())
        (folder / ".cache").mkdir()
        (folder / ".cache" / "c.bin").write_bytes(src.read_bytes())
        (folder / "README.txt").write_text("not a log")
        end = time.monotonic() + 20
        while len(taken) < 2 and time.monotonic() < end:
            time.sleep(0.1)
        time.sleep(2 * TEST_SETTLE_S)  # nothing more may come
    finally:
        w.stop()
        t.join(10)
        store.close()
    size = src.stat().st_size
    assert sorted(taken) == [("a.bin", size, size), ("b.bin", size, size)]


def test_network_shares_are_polled(tmp_path, monkeypatch):
    import flightlog_fd.watch as watch

    monkeypatch.setattr(watch, "filesystem_type", lambda folder: "nfs4")
    mode, why = choose_mode(tmp_path)
    assert mode == "poll" and "nfs4" in why
    monkeypatch.setattr(watch, "filesystem_type", lambda folder: "ext4")
    assert choose_mode(tmp_path)[0] == ("events" if _has_watchdog() else "poll")
    assert choose_mode(tmp_path, poll=True)[0] == "poll"


def _has_watchdog() -> bool:
    try:
        import watchdog.observers  # noqa: F401
    except ImportError:
        return False
    return True


# ----------------------------------------------------------------------------- fdlog watch end to end

class Watcher:
    """`fdlog watch` in a subprocess (its own process group), output in a file."""

    def __init__(self, folder: Path, db: str, out: Path, slow_name: str | None = None):
        self.out = out
        env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}
        if slow_name:  # its diagnosis of that file sleeps first (tests/slow_diagnosis/sitecustomize.py)
            env["PYTHONPATH"] = os.pathsep.join([str(SLOW_DIAGNOSIS), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
            env["FDLOG_TEST_SLOW_NAME"] = slow_name
        fh = open(out, "ab")
        self.proc = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "watch",
                                      str(folder), "--db", db, "--settle", str(TEST_SETTLE_S), "-v"],
                                     stdout=fh, stderr=fh, start_new_session=True, cwd=str(out.parent),
                                     env=env)
        fh.close()

    def kill(self) -> None:
        os.killpg(self.proc.pid, signal.SIGKILL)  # the watcher and its worker process, mid-diagnosis
        self.proc.wait(10)

    def stop(self) -> int:
        self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(60)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            raise


def _rows(db: str, sql: str) -> list[dict]:
    s = Store(db, create=False)
    try:
        return s.db.query(sql)
    finally:
        s.close()


def _wait_for(cond, what: str, timeout: float = 120.0, watcher: Watcher | None = None, db: str | None = None):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            got = cond()
        except Exception:
            got = None  # the store may be away on purpose
        if got:
            return got
        time.sleep(0.1)
    log = watcher.out.read_text(errors="replace")[-2000:] if watcher else ""
    try:
        rows = _rows(db, "SELECT name, state FROM flight") if db else ""
    except Exception as e:
        rows = repr(e)
    raise AssertionError(f"timed out waiting for {what}\n{log}\n{rows}")


def _done_names(db: str) -> set[str]:
    return {Path(r["name"]).name for r in _rows(db, "SELECT name FROM flight WHERE state = 'done'")}


@pytest.fixture(params=["sqlite", "postgres"])
def store_kind(request, tmp_path):
    if request.param == "sqlite":
        return "sqlite", str(tmp_path / "fleet.sqlite"), None
    pg = request.getfixturevalue("postgres")
    return "postgres", pg.url(), pg


def test_watch_diagnoses_each_log_once_through_copies_renames_duplicates_a_bad_file_a_restart_and_a_store_outage(
        tmp_path, store_kind):
    kind, db, pg = store_kind
    folder = tmp_path / "downloads"
    folder.mkdir()
    Store(db).close()
    out = tmp_path / "watch.out"
    w = Watcher(folder, db, out, slow_name="flight_d")  # killed while it diagnoses flight_d
    try:
        slow_copy(SAMPLES / SMALL[0], folder / "flight_a.bin")
        slow_copy(SAMPLES / SMALL[1], folder / "flight_b.ulg.part")
        os.replace(folder / "flight_b.ulg.part", folder / "flight_b.ulg")
        shutil.copyfile(SAMPLES / SMALL[0], folder / "flight_a_copy.bin")  # the same bytes again
        bad_log(folder / "corrupt.ulg")
        (folder / "garbage.bin").write_bytes(b"this is no flight log\n" * 50)  # named like one: a row
        (folder / "notes.txt").write_text("battery 3 swapped")
        _wait_for(lambda: {"flight_b.ulg", "corrupt.ulg", "garbage.bin"} <= _done_names(db)
                  and ({"flight_a.bin", "flight_a_copy.bin"} & _done_names(db)), "the first logs", watcher=w, db=db)
        first = {r["sha256"]: r["diagnosed_at"] for r in _rows(db, "SELECT sha256, diagnosed_at FROM flight")}

        # The store goes away while a log arrives; the watcher waits and stores it when it is back.
        if pg is not None:
            pg_halt(pg)
        else:
            os.replace(db, db + ".away")
        try:
            slow_copy(SAMPLES / SMALL[2], folder / "flight_c.bin")
            time.sleep(3.0)
        finally:
            if pg is not None:
                pg_resume(pg)
            else:
                os.replace(db + ".away", db)
        _wait_for(lambda: "flight_c.bin" in _done_names(db), "the log that came during the outage", watcher=w, db=db)
        assert w.proc.poll() is None, out.read_text()[-2000:]

        # Killed in the middle of a diagnosis, then started again: the log is taken again, once.
        slow_copy(SAMPLES / LARGE, folder / "flight_d.ulg")
        _wait_for(lambda: _rows(db, "SELECT id FROM job WHERE kind = 'watch' AND state = 'running'"),
                  "the last log to be claimed", watcher=w, db=db)
        w.kill()
        w = Watcher(folder, db, out)
        _wait_for(lambda: "flight_d.ulg" in _done_names(db), "the log of the killed watcher", timeout=180, watcher=w, db=db)
        time.sleep(2 * TEST_SETTLE_S)
        assert w.stop() == 0
    finally:
        if w.proc.poll() is None:
            w.kill()

    flights = _rows(db, "SELECT sha256, name, state, status, reason, diagnosed_at FROM flight")
    names = sorted(Path(f["name"]).name for f in flights)
    assert len(flights) == 6 and len({f["sha256"] for f in flights}) == 6, names  # one row per content
    assert {"flight_b.ulg", "flight_c.bin", "flight_d.ulg", "corrupt.ulg", "garbage.bin"} <= set(names)
    assert all(f["state"] == "done" for f in flights)
    bad = [f for f in flights if f["name"].endswith(("corrupt.ulg", "garbage.bin"))]
    assert all(f["status"] == "not_diagnosable" and f["reason"] for f in bad)
    assert {f["status"] for f in flights if f not in bad} <= {"healthy", "damaged", "uncertain", "stopped"}
    for f in flights:  # the restarted watcher re-read nothing it had stored
        if f["sha256"] in first:
            assert f["diagnosed_at"] == first[f["sha256"]]
    jobs = _rows(db, "SELECT j.state, j.attempts, f.name FROM job j JOIN flight f ON f.id = j.flight_id")
    assert len(jobs) == 6 and all(j["state"] == "done" for j in jobs)
    assert {Path(j["name"]).name: j["attempts"] for j in jobs if j["attempts"] != 1} == {"flight_d.ulg": 2}
    text = out.read_text(errors="replace")
    assert "Traceback" not in text
    assert "already in the store" in text  # the copy, and every file again after the restart
    assert "corrupt.ulg: not diagnosable" in text and "garbage.bin: not diagnosable" in text
    if kind == "sqlite":
        assert "store is unavailable" in text  # said while waiting
        with sqlite3.connect(db) as c:  # the file that came back is the store (no empty one made meanwhile)
            assert c.execute("SELECT COUNT(*) FROM watched_file").fetchone()[0] >= 7
