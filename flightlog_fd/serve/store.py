"""The server's store: uploaded flights, their diagnoses, jobs and airframes, in SQLite or PostgreSQL.

What: :class:`ServeStore` over :mod:`flightlog_fd.database` (one schema, :data:`MIGRATIONS`, for
both databases). Tables: ``flight`` (one row per uploaded file, keyed by its sha256: the same bytes
twice are one flight), ``motor_figure`` (its per-motor figures), ``finding`` (every analyzer's
findings, migration 2), ``job`` (diagnose / calibrate
work, the queue), ``airframe`` (identity, the operator's name, merges, calibration profile).

Jobs, exactly once: a job is claimed by one conditional statement (``UPDATE job SET state =
'running' ... WHERE id = (SELECT ... WHERE state = 'queued' ... [FOR UPDATE SKIP LOCKED])
RETURNING``), in SQLite under the write lock of ``BEGIN IMMEDIATE``; its result is written in the
same transaction that moves it from ``running`` (held by this server) to ``done``, so a result is
stored once whoever else looks at the job. A claimed job carries a lease (``LEASE_S``) that its
server renews; a job whose lease ran out belongs to a server that stopped (killed, crashed):
:meth:`ServeStore.recover` puts it back in the queue, or, after ``MAX_ATTEMPTS`` claims, makes it
an error row, so a log that brings the whole server down cannot loop forever. A holder known to be
dead (a server process on this machine that is gone) need not wait for its lease. A worker process
that dies on a log is known at once and turns that job into an error row
(:meth:`ServeStore.fail_job`).

Airframes: a flight's airframe is the log's own id (``Flight.vehicle_id``, as in `fdlog history`: PX4 ``sys_uuid``,
ArduPilot board UID...). A log without one is NOT put into a shared "unknown" history: it gets an
airframe of its own, ``log:<first 12 hex of its sha256>`` (source ``none``), that the operator can
name or merge into another airframe (``airframe.merged_into``; merges are followed to the end).
"""
from __future__ import annotations

import json
import time
from typing import Any, Callable, Optional

from ..database import Database, DatabaseError, open_database, utc_now
from ..drift import FIGURE_DIRECTION, FIGURE_FLOORS, find_drift
from ..store import FlightRecord

#: Seconds a claimed job's lease lasts; the server renews it every LEASE_S / 3 while it runs.
LEASE_S = 60.0
#: Claims of one job before a stopped server's job becomes an error row instead of being requeued
#: (the log may be what kills the server).
MAX_ATTEMPTS = 3
#: Length of the sha256 prefix naming an airframe of its own for a log without an id.
OWN_AIRFRAME_HEX = 12
#: The per-motor figures kept per flight (from the diagnosis JSON's ``motors``).
MOTOR_COLUMNS = ("position", "command_share", "command_share_baseline", "command_change", "effectiveness",
                 "effectiveness_ci_lo", "effectiveness_ci_hi", "model_vote", "severity")
STATES = ("queued", "running", "done", "error")

MIGRATIONS: list[tuple[int, str, str]] = [
    (1, "flights, motor figures, jobs, airframes", """
CREATE TABLE airframe (
    key            TEXT PRIMARY KEY,   -- identity from the log (sys_uuid...) or log:<sha12> for a log without one
    source         TEXT NOT NULL,      -- where the key came from: sys_uuid, board_uid, BRD_SERIAL_NUM, ..., none
    name           TEXT,               -- the operator's name for it (NULL: show the key)
    merged_into    TEXT,               -- the operator merged it into this airframe (NULL: itself)
    profile_path   TEXT,               -- calibration profile its later flights are diagnosed with
    profile_sha256 TEXT,
    created_at     TEXT NOT NULL
);
CREATE TABLE flight (
    id               {pk},
    sha256           TEXT NOT NULL UNIQUE,  -- content hash: the stored file is DATA/logs/<sha[:2]>/<sha>
    name             TEXT NOT NULL,         -- file name the client sent: shown (escaped), never used as a path
    size_bytes       BIGINT NOT NULL,
    format           TEXT NOT NULL,         -- ulog | dataflash (sniffed from the bytes)
    uploaded_at      TEXT NOT NULL,
    state            TEXT NOT NULL,         -- queued | running | done | error
    airframe         TEXT,                  -- airframe.key as read from the log (merges are applied on reading)
    healthy_mark     INTEGER NOT NULL DEFAULT 0,  -- the operator says this flight had healthy propellers
    autopilot        TEXT,
    firmware         TEXT,
    flight_start_utc TEXT,                  -- ISO-8601 UTC when the log has GPS time
    log_t_start_s    {real},
    airborne_s       {real},
    status           TEXT,                  -- healthy | damaged | uncertain | not_diagnosable
    motor            INTEGER,
    confidence       {real},
    reason           TEXT,
    sentence         TEXT,                  -- the verdict sentence of the terminal report
    profile_sha256   TEXT,                  -- profile used ('' none)
    diagnosis_json   TEXT,                  -- `fdlog diagnose --json` object of this flight
    plot_json        TEXT,                  -- decimated rates / motor commands for the flight page
    error            TEXT,                  -- why it is an error row
    diagnosed_at     TEXT
);
CREATE INDEX flight_airframe ON flight (airframe, flight_start_utc);
CREATE TABLE motor_figure (
    flight_id              BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    motor                  INTEGER NOT NULL,
    position               TEXT,
    command_share          {real},   -- mean thrust command / mean of the four (1 = even)
    command_share_baseline {real},
    command_change         {real},   -- share - baseline (or - the other three)
    effectiveness          {real},
    effectiveness_ci_lo    {real},
    effectiveness_ci_hi    {real},
    model_vote             {real},   -- mean model probability that this propeller is damaged
    severity               {real},   -- estimated remaining thrust (eta-hat) when the report has it
    PRIMARY KEY (flight_id, motor)
);
CREATE TABLE job (
    id          {pk},
    kind        TEXT NOT NULL,      -- diagnose | calibrate
    flight_id   BIGINT REFERENCES flight(id),
    airframe    TEXT,               -- calibrate: the airframe
    args        TEXT NOT NULL,      -- JSON: calibrate's flight ids and mode
    state       TEXT NOT NULL,      -- queued | running | done | error
    attempts    INTEGER NOT NULL DEFAULT 0,   -- claims so far
    worker      TEXT,               -- the server that holds it
    lease_until {real},             -- POSIX s: past it the holder is taken for dead
    error       TEXT,
    created_at  TEXT NOT NULL,
    started_at  TEXT,
    finished_at TEXT
);
CREATE INDEX job_state ON job (state, id);
CREATE INDEX job_flight ON job (flight_id)
"""),
    (2, "findings of every analyzer", """
CREATE TABLE finding (
    flight_id   BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    analyzer    TEXT NOT NULL,     -- the evidence source (model, commands, effectiveness...)
    motor       INTEGER,
    name        TEXT NOT NULL,
    value       {real},
    unit        TEXT,
    interval_lo {real},
    interval_hi {real},
    baseline    {real},
    llr         {real},            -- log-likelihood ratio for "this rotor lost thrust", nats
    text        TEXT
);
CREATE INDEX finding_flight ON finding (flight_id)
"""),
]


def own_airframe_key(sha256: str) -> str:
    """The airframe of a log without an id: its own, named by its content hash."""
    return f"log:{sha256[:OWN_AIRFRAME_HEX]}"


def _num(x: Any) -> Optional[float]:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if v == v and v not in (float("inf"), float("-inf")) else None


def motor_rows(diagnosis: dict) -> list[dict]:
    """Per-motor figures from a diagnosis JSON object; fields it lacks are None."""
    out = []
    for m in diagnosis.get("motors") or []:
        ci = m.get("effectiveness_ci") or [None, None]
        sev = m.get("severity", m.get("eta_hat"))
        if isinstance(sev, dict):
            sev = sev.get("value")
        out.append({"motor": int(m["motor"]), "position": m.get("position"),
                    "command_share": _num(m.get("command_share")),
                    "command_share_baseline": _num(m.get("command_share_baseline")),
                    "command_change": _num(m.get("command_change")),
                    "effectiveness": _num(m.get("effectiveness")),
                    "effectiveness_ci_lo": _num(ci[0]) if len(ci) > 0 else None,
                    "effectiveness_ci_hi": _num(ci[1]) if len(ci) > 1 else None,
                    "model_vote": _num(m.get("model_vote")), "severity": _num(sev)})
    return out


def finding_rows(diagnosis: dict) -> list[tuple]:
    """(analyzer, motor, name, value, unit, lo, hi, baseline, llr, text) per finding of the
    report's ``analyzers`` (none for a report without them)."""
    out = []
    for an in diagnosis.get("analyzers") or []:
        for f in (an.get("findings") or []) if isinstance(an, dict) else []:
            iv = f.get("interval") or [None, None]
            motor = f.get("motor")
            out.append((str(f.get("analyzer") or an.get("analyzer") or ""), int(motor) if isinstance(motor, int) else None,
                        str(f.get("name") or ""), _num(f.get("value")), f.get("unit"),
                        _num(iv[0]) if len(iv) > 0 else None, _num(iv[1]) if len(iv) > 1 else None,
                        _num(f.get("baseline")), _num(f.get("llr")), f.get("text")))
    return out


class ServeStore:
    """The server's store on a SQLite path or a PostgreSQL URL (migrated on open)."""

    def __init__(self, target):
        self.db: Database = open_database(target)
        self.db.migrate(MIGRATIONS)

    def close(self) -> None:
        self.db.close()

    # ------------------------------------------------------------------ uploads

    def add_upload(self, sha256: str, name: str, size: int, fmt: str) -> tuple[int, bool]:
        """(flight id, created): a new flight and its diagnose job, or the existing flight of
        these bytes (no new job)."""
        db = self.db

        def tx():
            row = db.one("SELECT id FROM flight WHERE sha256 = ?", (sha256,))
            if row:
                return int(row["id"]), False
            now = utc_now()
            fid = db.one("INSERT INTO flight (sha256, name, size_bytes, format, uploaded_at, state) "
                         "VALUES (?, ?, ?, ?, ?, 'queued') ON CONFLICT (sha256) DO NOTHING RETURNING id",
                         (sha256, name, size, fmt, now))
            if fid is None:  # another server inserted it between our SELECT and INSERT (PostgreSQL)
                return int(db.one("SELECT id FROM flight WHERE sha256 = ?", (sha256,))["id"]), False
            db.run("INSERT INTO job (kind, flight_id, args, state, created_at) VALUES ('diagnose', ?, '{}', 'queued', ?)",
                   (fid["id"], now))
            return int(fid["id"]), True

        return db.transaction(tx, "record the upload")

    def flight(self, fid: int) -> Optional[dict]:
        return self.db.one("SELECT * FROM flight WHERE id = ?", (fid,))

    def flight_motors(self, fid: int) -> list[dict]:
        return self.db.query("SELECT * FROM motor_figure WHERE flight_id = ? ORDER BY motor", (fid,))

    def set_healthy_mark(self, fid: int, healthy: bool) -> bool:
        return self.db.transaction(lambda: self.db.run("UPDATE flight SET healthy_mark = ? WHERE id = ?",
                                                       (1 if healthy else 0, fid)) == 1)

    # ------------------------------------------------------------------ jobs

    def enqueue_calibration(self, airframe: str, flight_ids: list[int], adapt: bool) -> int:
        def tx():
            row = self.db.one("INSERT INTO job (kind, airframe, args, state, created_at) VALUES "
                              "('calibrate', ?, ?, 'queued', ?) RETURNING id",
                              (airframe, json.dumps({"flights": flight_ids, "adapt": adapt}), utc_now()))
            return int(row["id"])

        return self.db.transaction(tx, "queue the calibration")

    def claim_job(self, worker: str, kinds: tuple[str, ...] = ("diagnose", "calibrate")) -> Optional[dict]:
        """Atomically take the oldest queued job for ``worker`` (None when the queue is empty)."""
        db = self.db
        marks = ", ".join("?" * len(kinds))
        lock = " FOR UPDATE SKIP LOCKED" if db.dialect == "postgres" else ""
        sql = (f"UPDATE job SET state = 'running', worker = ?, attempts = attempts + 1, lease_until = ?, "
               f"started_at = ? WHERE id = (SELECT id FROM job WHERE state = 'queued' AND kind IN ({marks}) "
               f"ORDER BY id LIMIT 1{lock}) AND state = 'queued' RETURNING *")

        def tx():
            job = db.one(sql, (worker, time.time() + LEASE_S, utc_now(), *kinds))
            if job and job["flight_id"] is not None:
                db.run("UPDATE flight SET state = 'running' WHERE id = ?", (job["flight_id"],))
            return job

        return db.transaction(tx, "claim a job")

    def renew_leases(self, worker: str, job_ids: list[int]) -> None:
        if not job_ids:
            return
        marks = ", ".join("?" * len(job_ids))
        self.db.transaction(lambda: self.db.run(
            f"UPDATE job SET lease_until = ? WHERE worker = ? AND state = 'running' AND id IN ({marks})",
            (time.time() + LEASE_S, worker, *job_ids)), "renew job leases")

    def recover(self, is_dead: Optional[Callable[[str], bool]] = None) -> dict:
        """Jobs whose server stopped: back to the queue, or error rows after MAX_ATTEMPTS claims.
        A server is taken for stopped when its lease ran out, or at once when ``is_dead(worker)``
        says so (a server on this machine whose process is gone). Returns {"requeued", "failed"}."""
        db = self.db

        def tx():
            now = time.time()
            stale = db.query("SELECT id, flight_id, attempts, worker, lease_until FROM job WHERE state = 'running'")
            stale = [j for j in stale if (j["lease_until"] is not None and j["lease_until"] < now)
                     or (is_dead is not None and j["worker"] and is_dead(j["worker"]))]
            out = {"requeued": 0, "failed": 0}
            for j in stale:
                if j["attempts"] >= MAX_ATTEMPTS:
                    reason = (f"the server stopped {j['attempts']} times while working on this log "
                              f"(limit {MAX_ATTEMPTS}): not tried again")
                    self._finish_error(j, reason)
                    out["failed"] += 1
                else:
                    db.run("UPDATE job SET state = 'queued', worker = NULL, lease_until = NULL WHERE id = ? "
                           "AND state = 'running'", (j["id"],))
                    if j["flight_id"] is not None:
                        db.run("UPDATE flight SET state = 'queued' WHERE id = ?", (j["flight_id"],))
                    out["requeued"] += 1
            return out

        return db.transaction(tx, "recover stopped jobs")

    def release_jobs(self, worker: str) -> int:
        """A server stopping on purpose hands its running jobs back to the queue (not counted as
        an attempt: the log did nothing wrong)."""
        db = self.db

        def tx():
            held = db.query("SELECT id, flight_id FROM job WHERE worker = ? AND state = 'running'", (worker,))
            for j in held:
                db.run("UPDATE job SET state = 'queued', worker = NULL, lease_until = NULL, "
                       "attempts = attempts - 1 WHERE id = ?", (j["id"],))
                if j["flight_id"] is not None:
                    db.run("UPDATE flight SET state = 'queued' WHERE id = ?", (j["flight_id"],))
            return len(held)

        return db.transaction(tx, "release the jobs")

    def _finish_error(self, job: dict, reason: str, diagnosis_json: Optional[str] = None) -> None:
        db = self.db
        db.run("UPDATE job SET state = 'error', error = ?, finished_at = ?, lease_until = NULL WHERE id = ?",
               (reason, utc_now(), job["id"]))
        if job.get("flight_id") is not None:
            db.run("UPDATE flight SET state = 'error', error = ?, status = 'not_diagnosable', reason = ?, "
                   "diagnosis_json = COALESCE(?, diagnosis_json), diagnosed_at = ? WHERE id = ?",
                   (reason, reason, diagnosis_json, utc_now(), job["flight_id"]))

    def fail_job(self, job: dict, worker: str, reason: str, diagnosis_json: Optional[str] = None) -> bool:
        """The job's worker died or the job failed: an error row (only if ``worker`` still holds it)."""
        def tx():
            held = self.db.one("SELECT id FROM job WHERE id = ? AND state = 'running' AND worker = ?",
                               (job["id"], worker))
            if not held:
                return False
            self._finish_error(job, reason, diagnosis_json)
            return True

        return self.db.transaction(tx, "record the failed job")

    def complete_diagnosis(self, job: dict, worker: str, result: dict) -> bool:
        """Store a diagnose job's result and mark it done, in one transaction; False (nothing
        written) when ``worker`` no longer holds the job (its lease ran out and another took it)."""
        db = self.db
        doc = result["diagnosis"]
        v = doc.get("verdict") or {}
        sha = result["sha256"]
        key, source = (result["vehicle"], result["vehicle_source"]) if result.get("vehicle") else \
            (own_airframe_key(sha), "none")
        motors = motor_rows(doc)

        def tx():
            ok = db.run("UPDATE job SET state = 'done', finished_at = ?, lease_until = NULL WHERE id = ? "
                        "AND state = 'running' AND worker = ?", (utc_now(), job["id"], worker))
            if ok != 1:
                return False
            db.run("INSERT INTO airframe (key, source, created_at) VALUES (?, ?, ?) ON CONFLICT (key) DO NOTHING",
                   (key, source, utc_now()))
            db.run("UPDATE flight SET state = 'done', airframe = ?, autopilot = ?, firmware = ?, flight_start_utc = ?, "
                   "log_t_start_s = ?, airborne_s = ?, status = ?, motor = ?, confidence = ?, reason = ?, sentence = ?, "
                   "profile_sha256 = ?, diagnosis_json = ?, plot_json = ?, error = NULL, diagnosed_at = ? WHERE id = ?",
                   (key, doc.get("autopilot"), doc.get("firmware"), result.get("flight_start_utc"),
                    result.get("log_t_start_s"), _num(doc.get("airborne_s")), v.get("status"), v.get("motor"),
                    _num(v.get("confidence")), v.get("reason"), result.get("sentence"),
                    result.get("profile_sha256") or "", json.dumps(doc), json.dumps(result.get("plot")),
                    utc_now(), job["flight_id"]))
            db.run("DELETE FROM motor_figure WHERE flight_id = ?", (job["flight_id"],))
            cols = ("flight_id", "motor") + MOTOR_COLUMNS
            db.run_many(f"INSERT INTO motor_figure ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                        [(job["flight_id"], m["motor"], *(m[c] for c in MOTOR_COLUMNS)) for m in motors])
            db.run("DELETE FROM finding WHERE flight_id = ?", (job["flight_id"],))
            db.run_many("INSERT INTO finding (flight_id, analyzer, motor, name, value, unit, interval_lo, interval_hi, "
                        "baseline, llr, text) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                        [(job["flight_id"], *f) for f in finding_rows(doc)])
            return True

        return db.transaction(tx, "store the diagnosis")

    def complete_calibration(self, job: dict, worker: str, profile_path: str, profile_sha256: str) -> bool:
        def tx():
            ok = self.db.run("UPDATE job SET state = 'done', finished_at = ?, lease_until = NULL WHERE id = ? "
                             "AND state = 'running' AND worker = ?", (utc_now(), job["id"], worker))
            if ok != 1:
                return False
            self.db.run("UPDATE airframe SET profile_path = ?, profile_sha256 = ? WHERE key = ?",
                        (profile_path, profile_sha256, job["airframe"]))
            return True

        return self.db.transaction(tx, "store the calibration")

    def job(self, jid: int) -> Optional[dict]:
        return self.db.one("SELECT * FROM job WHERE id = ?", (jid,))

    def jobs(self, limit: int = 50) -> list[dict]:
        return self.db.query("SELECT job.*, flight.name AS flight_name FROM job LEFT JOIN flight ON flight.id = job.flight_id "
                             "ORDER BY job.id DESC LIMIT ?", (limit,))

    def job_counts(self) -> dict[str, int]:
        rows = self.db.query("SELECT state, COUNT(*) AS n FROM job GROUP BY state")
        return {s: 0 for s in STATES} | {r["state"]: int(r["n"]) for r in rows}

    # ------------------------------------------------------------------ airframes

    def airframes(self) -> dict[str, dict]:
        return {r["key"]: r for r in self.db.query("SELECT * FROM airframe")}

    def resolve(self, key: Optional[str], table: Optional[dict] = None) -> Optional[str]:
        """The airframe ``key`` ends in after following merges (cycles stop where they loop)."""
        table = self.airframes() if table is None else table
        seen = set()
        while key in table and table[key]["merged_into"] and key not in seen:
            seen.add(key)
            key = table[key]["merged_into"]
        return key

    def rename_airframe(self, key: str, name: str) -> bool:
        return self.db.transaction(lambda: self.db.run("UPDATE airframe SET name = ? WHERE key = ?",
                                                       (name or None, key)) == 1, "rename the airframe")

    def merge_airframe(self, key: str, into: str) -> None:
        """Merge ``key`` (with what was merged into it) into ``into``; refuses a loop."""
        table = self.airframes()
        if key not in table or into not in table:
            raise DatabaseError(None, "no such airframe")
        if self.resolve(into, table) == self.resolve(key, table):
            raise DatabaseError(None, "these airframes are already one")
        self.db.transaction(lambda: self.db.run("UPDATE airframe SET merged_into = ? WHERE key = ?",
                                                (self.resolve(into, table), key)), "merge the airframes")

    def profiles(self) -> dict[str, str]:
        """Raw airframe key -> profile path, for every key whose (merged) airframe has a profile."""
        table = self.airframes()
        out = {}
        for key in table:
            root = table.get(self.resolve(key, table))
            if root and root["profile_path"]:
                out[key] = root["profile_path"]
        return out

    def fleet(self) -> list[dict]:
        """One dict per airframe (merges applied): its row, flights in time order, drifts."""
        table = self.airframes()
        flights = self.db.query("SELECT id, sha256, name, state, airframe, healthy_mark, autopilot, firmware, "
                                "flight_start_utc, airborne_s, status, motor, confidence, reason, uploaded_at, "
                                "diagnosed_at, error FROM flight WHERE airframe IS NOT NULL")
        figs: dict[int, dict[int, dict]] = {}
        for m in self.db.query("SELECT * FROM motor_figure"):
            figs.setdefault(int(m["flight_id"]), {})[int(m["motor"])] = m
        groups: dict[str, list[dict]] = {}
        for f in flights:
            f["motors"] = figs.get(int(f["id"]), {})
            groups.setdefault(self.resolve(f["airframe"], table), []).append(f)
        out = []
        for key, fl in groups.items():
            fl.sort(key=lambda f: (f["flight_start_utc"] is None, f["flight_start_utc"] or "", f["uploaded_at"], f["id"]))
            row = table.get(key) or {"key": key, "source": "?", "name": None, "profile_path": None}
            members = sorted(k for k in table if k != key and self.resolve(k, table) == key)
            out.append({"key": key, "name": row.get("name") or key, "source": row.get("source"),
                        "profile_path": row.get("profile_path"), "members": members, "flights": fl,
                        "drift": drift_of(key, fl), "latest": fl[-1] if fl else None})
        return out

    def airframe_view(self, key: str) -> Optional[dict]:
        for a in self.fleet():
            if a["key"] == key:
                return a
        return None

    def pending(self) -> list[dict]:
        """Flights not yet diagnosed (no airframe known)."""
        return self.db.query("SELECT id, name, state, uploaded_at, error FROM flight WHERE airframe IS NULL ORDER BY id")

    def count_flights_by_sha(self) -> dict[str, int]:
        rows = self.db.query("SELECT sha256, COUNT(*) AS n FROM flight GROUP BY sha256")
        return {r["sha256"]: int(r["n"]) for r in rows}


def drift_of(key: str, flights: list[dict]) -> list:
    """store.find_drift over this airframe's diagnosed flights (the same rule as `fdlog history`)."""
    recs = []
    for f in flights:
        if f["state"] != "done" or not f["motors"]:
            continue
        recs.append(FlightRecord(id=int(f["id"]), log_path=f["name"], log_sha256=f["sha256"],
                                 flight_start_utc=f["flight_start_utc"], airborne_s=f["airborne_s"],
                                 status=f["status"] or "", motor=f["motor"], confidence=f["confidence"],
                                 reason=f["reason"] or "", diagnosed_at=f["diagnosed_at"] or "",
                                 vehicle_source="", motors={k: dict(v) for k, v in f["motors"].items()}))
    return find_drift(key, recs)


__all__ = ["ServeStore", "MIGRATIONS", "LEASE_S", "MAX_ATTEMPTS", "own_airframe_key", "motor_rows",
           "FIGURE_DIRECTION", "FIGURE_FLOORS"]
