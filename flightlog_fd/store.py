"""The one store: flights, their diagnoses and per-motor figures, airframes and the server's jobs.

What: :class:`Store` over :mod:`flightlog_fd.database` (a SQLite path or a ``postgresql://`` URL,
one migration list, :data:`MIGRATIONS`). ``fdlog diagnose --db`` writes it
(:meth:`Store.add_result`), ``fdlog history`` reads it (:meth:`Store.history`, :func:`load_history`),
``fdlog serve`` keeps its uploads, jobs and airframes in it; the same file serves all three.

Tables (migrations 3 and 4 give them their present columns):

- ``airframe``: key (the log's own id: PX4 ``sys_uuid``, ArduPilot board UID...), its source, the
  operator's name, ``merged_into``, the calibration profile.
- ``flight``: one row per log content (``sha256`` unique): the name it was given, its airframe,
  and its latest diagnosis (verdict columns, model and profile, ``diagnosis_json`` the whole
  ``fdlog diagnose --json`` object). Re-diagnosing the same bytes replaces the diagnosis.
- ``motor_figure`` (flight, motor): :data:`MOTOR_COLUMNS`, the JSON report's per-motor fields
  under the same names (intervals as ``_lo``/``_hi``), made by :func:`motor_rows` for every writer.
- ``finding`` (flight): every analyzer's findings, :data:`FINDING_COLUMNS` (:func:`finding_rows`).
- ``flight_part`` (flight, part): each take-off to landing of a log holding several, with its own
  verdict (:data:`PART_COLUMNS`, :func:`part_rows`: the JSON report's ``flights``); none for a log
  with one flight. Migration 4 fills it from the stored diagnoses, so an older store upgrades in place.
- ``job``: the server's diagnose / calibrate queue, and the ``watch`` jobs of `fdlog watch` (a log
  found in a watched folder, diagnosed by the watcher that found it; ``args`` holds its path).
- ``watched_file`` (host, path): the size, modification time and sha256 of each file a watcher has
  taken, so a restarted watcher does not read every file again to hash it.
- ``calibration_session`` (airframe, flight): which flights the airframe's profile holds, as which
  calibration session (one flight, one session; a later calibration job adds sessions, a new one
  from scratch replaces them).

Airframe of a log without an id: ``fdlog diagnose --db`` files it under the profile's name
(``profile:NAME``) or ``unknown`` (:func:`vehicle_identity`; history does not treat ``unknown`` as
one airframe); the server gives it an airframe of its own, ``log:<sha12>`` (source ``none``), that
the operator can name or merge (merges are followed on reading, by history too).

Jobs, exactly once: a job is claimed by one conditional statement (``UPDATE job SET state =
'running' ... WHERE id = (SELECT ... WHERE state = 'queued' ... [FOR UPDATE SKIP LOCKED])
RETURNING``), in SQLite under the write lock of ``BEGIN IMMEDIATE``; its result is written in the
same transaction that moves it from ``running`` (held by this server) to ``done``. A claimed job
carries a lease (``LEASE_S``) its server renews; a job whose lease ran out belongs to a server that
stopped: :meth:`Store.recover` requeues it, or after ``MAX_ATTEMPTS`` claims makes it an error row,
so a log that brings the server down cannot loop forever.

Several writers (batch processes, servers): WAL, busy timeout and retried transactions
(:mod:`flightlog_fd.database`). Older stores are upgraded in place when opened: a server store
by its migrations, a results store of ``fdlog diagnose --db`` before migrations (``PRAGMA
user_version`` 1 or 2, a ``schema_version`` table) by copying its latest diagnosis of each log into
these tables (:func:`_adopt_results_store`).
"""
from __future__ import annotations

import json
import math
import os
import re
import socket
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Optional

from .database import Database, DatabaseError, StoreUnavailable, is_postgres_url, open_database, utc_now
from .drift import FlightRecord, find_drift

#: Seconds a claimed job's lease lasts; the server renews it every LEASE_S / 3 while it runs.
LEASE_S = 60.0
#: Claims of one job before a stopped server's job becomes an error row instead of being requeued
#: (the log may be what kills the server).
MAX_ATTEMPTS = 3
#: Length of the sha256 prefix naming an airframe of its own for a log without an id.
OWN_AIRFRAME_HEX = 12
STATES = ("queued", "running", "done", "error")
UNKNOWN_VEHICLE = "unknown"
#: Per-motor figures of a flight: the JSON report's ``motors`` fields (intervals split in lo/hi).
MOTOR_COLUMNS = ("position", "command_share", "command_share_baseline", "command_change", "effectiveness",
                 "effectiveness_ci_lo", "effectiveness_ci_hi", "model_vote", "eta_hat", "eta_ci_lo", "eta_ci_hi",
                 "weight", "llr")
#: A finding: the JSON report's ``analyzers[].findings[]`` fields (``interval`` split in lo/hi).
FINDING_COLUMNS = ("analyzer", "motor", "name", "value", "unit", "interval_lo", "interval_hi", "baseline",
                   "direction", "llr", "text")
#: Each flight of a log holding several: the JSON report's ``flights[]`` (``part`` 1..n in time order).
PART_COLUMNS = ("label", "t_start_s", "t_end_s", "airborne_s", "status", "motor", "confidence", "reason",
                "verdict_motors", "pair")
#: The columns flight_part had at migration 4 (what that migration fills; migration 8 adds the rest).
_PART_COLUMNS_V4 = PART_COLUMNS[:8]
#: Per-motor figures drawn across an airframe's flights (history page, airframe page): (column, title).
TREND_FIGURES = (("command_change", "command-share change"),
                 ("eta_hat", "eta-hat: estimated remaining thrust (1 = healthy)"),
                 ("model_vote", "model vote"), ("effectiveness", "effectiveness"),
                 ("weight", "weight: probability this rotor lost thrust"), ("llr", "log-likelihood ratio (nats)"))
_AUTOPILOT_FORMAT = {"px4": "ulog", "ardupilot": "dataflash"}

StoreError = DatabaseError


def _v3(db: Database) -> None:
    """Migration 3: per-motor and finding columns under the JSON report's names; the model and
    profile of each diagnosis on its flight."""
    for stmt in (
            "ALTER TABLE motor_figure RENAME COLUMN severity TO eta_hat",
            *(f"ALTER TABLE motor_figure ADD COLUMN {c} {{real}}" for c in ("eta_ci_lo", "eta_ci_hi", "weight", "llr")),
            "ALTER TABLE finding ADD COLUMN direction TEXT NOT NULL DEFAULT ''",
            *(f"ALTER TABLE flight ADD COLUMN {c} TEXT" for c in ("model_sha256", "model_version", "profile_path",
                                                                  "tool_version")),
            "ALTER TABLE flight ADD COLUMN exit_code INTEGER"):
        db.run(stmt)
    for flight_id, doc in _stored_diagnoses(db):
        _write_figures(db, flight_id, doc)
        db.run("UPDATE flight SET model_sha256 = ?, model_version = ?, profile_path = ?, tool_version = ?, "
               "exit_code = ? WHERE id = ?", (*_run_columns(doc), flight_id))


def _stored_diagnoses(db: Database):
    """(flight id, diagnosis dict) of every flight whose stored JSON report reads as an object."""
    for row in db.query("SELECT id, diagnosis_json FROM flight WHERE diagnosis_json IS NOT NULL"):
        try:
            doc = json.loads(row["diagnosis_json"])
        except ValueError:
            continue
        if isinstance(doc, dict):
            yield int(row["id"]), doc


def _v4(db: Database) -> None:
    """Migration 4: ``flight_part``, one row per take-off to landing of a log holding several,
    filled from each stored diagnosis's ``flights``."""
    db.run("""CREATE TABLE flight_part (
    flight_id   BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    part        INTEGER NOT NULL,  -- 1..n in time order
    label       TEXT NOT NULL,     -- "flight 2 of 5, 234.8-327.8 s"
    t_start_s   {real},            -- its bounds on the log's own clock
    t_end_s     {real},
    airborne_s  {real},
    status      TEXT,              -- its own verdict (never worse than the log's, see diagnose.py)
    motor       INTEGER,
    confidence  {real},
    reason      TEXT,
    PRIMARY KEY (flight_id, part)
)""")
    for flight_id, doc in _stored_diagnoses(db):
        _write_parts(db, flight_id, doc, _PART_COLUMNS_V4)


def verdict_motors_text(v: dict) -> str:
    """The JSON verdict's ``motors`` as the store keeps them ("1;4"; "" for none); a report from
    before schema 6 names at most its ``motor``."""
    motors = v.get("motors")
    if not isinstance(motors, list):
        motors = [v["motor"]] if isinstance(v.get("motor"), int) else []
    return ";".join(str(int(k)) for k in motors if isinstance(k, int))


def parse_verdict_motors(text: Optional[str]) -> list[int]:
    """"1;4" -> [1, 4] (the store's ``verdict_motors``)."""
    return [int(x) for x in (text or "").split(";") if x.strip().isdigit()]


def _v8(db: Database) -> None:
    """Migration 8: every propeller a verdict names (``verdict_motors`` "1;4") and whether it
    names two together (``pair``), on the flight and on each flight of a log, filled from the
    stored diagnoses."""
    for table in ("flight", "flight_part"):
        db.run(f"ALTER TABLE {table} ADD COLUMN verdict_motors TEXT NOT NULL DEFAULT ''")
        db.run(f"ALTER TABLE {table} ADD COLUMN pair INTEGER NOT NULL DEFAULT 0")
    for flight_id, doc in _stored_diagnoses(db):
        v = doc.get("verdict") or {}
        db.run("UPDATE flight SET verdict_motors = ?, pair = ? WHERE id = ?",
               (verdict_motors_text(v), int(bool(v.get("pair"))), flight_id))
        _write_parts(db, flight_id, doc)


def _v7(db: Database) -> None:
    """Migration 7: ``flight.cause``, the named rotor's likely cause (propeller | motor_or_esc |
    NULL), filled from each stored diagnosis's verdict (reports before schema 6 have none)."""
    db.run("ALTER TABLE flight ADD COLUMN cause TEXT")
    for flight_id, doc in _stored_diagnoses(db):
        cause = (doc.get("verdict") or {}).get("cause")
        if cause:
            db.run("UPDATE flight SET cause = ? WHERE id = ?", (cause, flight_id))


def _v9(db: Database) -> None:
    """Migration 9: ``flight.load_motor``, ``load_size`` and ``load_direction_deg`` (a verdict whose
    cause is a moved load: the motor nearest it, the share change of a motor straight toward it,
    its direction in the body frame), filled from each stored diagnosis's ``verdict.load``
    (reports before schema 7 have none)."""
    for column, kind in (("load_motor", "INTEGER"), ("load_size", "REAL"), ("load_direction_deg", "REAL")):
        db.run(f"ALTER TABLE flight ADD COLUMN {column} {kind}")
    for flight_id, doc in _stored_diagnoses(db):
        load = (doc.get("verdict") or {}).get("load")
        if load:
            db.run("UPDATE flight SET load_motor = ?, load_size = ?, load_direction_deg = ? WHERE id = ?",
                   _load_columns(load) + (flight_id,))


def _load_columns(load: Optional[dict]) -> tuple:
    """(load_motor, load_size, load_direction_deg) of a JSON ``verdict.load`` (Nones without one)."""
    if not load:
        return (None, None, None)
    return (load.get("motor"), _num(load.get("size")), _num(load.get("direction_deg")))


MIGRATIONS: list[tuple[int, str, Any]] = [
    (1, "flights, motor figures, jobs, airframes", """
CREATE TABLE airframe (
    key            TEXT PRIMARY KEY,   -- identity from the log (sys_uuid...), profile:NAME, unknown, or log:<sha12>
    source         TEXT NOT NULL,      -- where the key came from: sys_uuid, board_uid, BRD_SERIAL_NUM, ..., profile, none
    name           TEXT,               -- the operator's name for it (NULL: show the key)
    merged_into    TEXT,               -- the operator merged it into this airframe (NULL: itself)
    profile_path   TEXT,               -- calibration profile its later flights are diagnosed with
    profile_sha256 TEXT,
    created_at     TEXT NOT NULL
);
CREATE TABLE flight (
    id               {pk},
    sha256           TEXT NOT NULL UNIQUE,  -- content hash: the server's copy is DATA/logs/<sha[:2]>/<sha>
    name             TEXT NOT NULL,         -- the path given to fdlog diagnose, or the uploaded file's name (never a path)
    size_bytes       BIGINT NOT NULL,
    format           TEXT NOT NULL,         -- ulog | dataflash ('' when it could not be read)
    uploaded_at      TEXT NOT NULL,
    state            TEXT NOT NULL,         -- queued | running | done | error
    airframe         TEXT,                  -- airframe.key as read from the log (merges are applied on reading)
    healthy_mark     INTEGER NOT NULL DEFAULT 0,  -- the operator says this flight had healthy propellers
    autopilot        TEXT,
    firmware         TEXT,
    flight_start_utc TEXT,                  -- ISO-8601 UTC when the log has GPS time
    log_t_start_s    {real},                -- start of the log on its own clock (s since boot)
    airborne_s       {real},
    status           TEXT,                  -- healthy | damaged | stopped | uncertain | not_diagnosable
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
    command_share          {real},   -- mean thrust command / mean of all motors (1 = even)
    command_share_baseline {real},
    command_change         {real},   -- share - baseline (or - the mean of the others)
    effectiveness          {real},
    effectiveness_ci_lo    {real},
    effectiveness_ci_hi    {real},
    model_vote             {real},   -- mean model probability that this propeller is damaged
    severity               {real},   -- migration 3: eta_hat
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
    analyzer    TEXT NOT NULL,     -- the analyzer's id (model, commands, effectiveness...)
    motor       INTEGER,           -- 1..n, the autopilot's numbering
    name        TEXT NOT NULL,     -- the figure (vote, share, thrust...)
    value       {real},
    unit        TEXT,
    interval_lo {real},
    interval_hi {real},
    baseline    {real},            -- the healthy value it is compared with
    llr         {real},            -- its weight in the decision, nats (NULL: not weighed)
    text        TEXT
);
CREATE INDEX finding_flight ON finding (flight_id)
"""),
    # motor_figure: eta_hat (was severity), eta_ci_lo/hi, weight, llr; finding: direction (up |
    # down | ''); flight: model_sha256, model_version, profile_path, tool_version, exit_code.
    (3, "one store: the JSON report's per-motor names, the model and profile of each diagnosis", _v3),
    (4, "each flight of a log holding several, with its verdict", _v4),
    (5, "files seen by fdlog watch", """
CREATE TABLE watched_file (
    host        TEXT NOT NULL,     -- the machine whose folder it is (paths differ between machines)
    path        TEXT NOT NULL,     -- absolute path as the watcher saw it
    size_bytes  BIGINT NOT NULL,
    mtime_ns    BIGINT NOT NULL,   -- with the size: the file is unchanged since it was hashed
    sha256      TEXT NOT NULL,     -- flight.sha256 of its content
    seen_at     TEXT NOT NULL,
    PRIMARY KEY (host, path)
)
"""),
    (6, "each airframe's calibration sessions", """
CREATE TABLE calibration_session (
    airframe     TEXT NOT NULL,         -- airframe.key (the resolved one when it was calibrated)
    session      INTEGER NOT NULL,      -- 1..n in the order they were added (the profile's sessions_)
    flight_id    BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    job_id       BIGINT,                -- the calibration job that added it
    profile_path TEXT NOT NULL,         -- the profile file it was first part of
    created_at   TEXT NOT NULL,
    PRIMARY KEY (airframe, flight_id)
);
CREATE INDEX calibration_session_airframe ON calibration_session (airframe, session)
"""),
    (7, "the named rotor's likely cause: its propeller or its motor / ESC", _v7),
    (8, "every propeller a verdict names, and two named together", _v8),
    (9, "a verdict's moved load: the motor nearest it, its size and direction", _v9),
]
#: The schema version this fdlog writes (its newest migration).
SCHEMA_VERSION = max(v for v, _, _ in MIGRATIONS)


# ----------------------------------------------------------------------------- rows from a report

def _num(x: Any) -> Optional[float]:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _pair(x: Any) -> tuple[Optional[float], Optional[float]]:
    if isinstance(x, (list, tuple)) and len(x) == 2:
        return _num(x[0]), _num(x[1])
    return None, None


def _positions(frame: Optional[str], n: int) -> list[Optional[str]]:
    from .flight import QUAD_PLUS_POSITIONS, QUAD_X_POSITIONS

    names = {"quad_x": QUAD_X_POSITIONS, "quad_plus": QUAD_PLUS_POSITIONS}.get(frame or "", ())
    return [names[k] if k < len(names) else None for k in range(n)]


def motor_rows(doc: dict, command_share: Optional[list[float]] = None) -> list[dict]:
    """One dict per motor (``motor`` and :data:`MOTOR_COLUMNS`) from a diagnosis JSON object.

    Its ``motors`` when it has them; else (no per-motor evidence: a log the evidence could not be
    measured on) the model vote as the mean of the windows' probabilities and the command share
    ``command_share`` (as the batch measured it, mean 1), the change against the others' mean.
    Empty when it has neither."""
    out = []
    for m in doc.get("motors") or []:
        eta = m.get("eta_hat", m.get("severity"))
        if isinstance(eta, dict):
            eta = eta.get("value")
        ci, eci = _pair(m.get("effectiveness_ci")), _pair(m.get("eta_ci"))
        out.append({"motor": int(m["motor"]), "position": m.get("position"),
                    "command_share": _num(m.get("command_share")),
                    "command_share_baseline": _num(m.get("command_share_baseline")),
                    "command_change": _num(m.get("command_change")), "effectiveness": _num(m.get("effectiveness")),
                    "effectiveness_ci_lo": ci[0], "effectiveness_ci_hi": ci[1], "model_vote": _num(m.get("model_vote")),
                    "eta_hat": _num(eta), "eta_ci_lo": eci[0], "eta_ci_hi": eci[1], "weight": _num(m.get("weight")),
                    "llr": _num(m.get("llr"))})
    if out:
        return out
    probs = [w.get("probabilities") or [] for w in doc.get("windows") or [] if isinstance(w, dict)]
    if not probs and command_share is None:
        return []
    shares = [_num(x) for x in command_share] if command_share is not None else []
    n = max(len(shares), max((len(p) for p in probs), default=1) - 1, 4)
    positions = _positions(doc.get("frame"), n)
    for k in range(1, n + 1):
        votes = [p[k] for p in probs if len(p) > k]
        share = shares[k - 1] if k <= len(shares) else None
        others = [s for i, s in enumerate(shares) if i != k - 1]
        change = (share - sum(others) / len(others)) if share is not None and others and None not in others else None
        out.append({"motor": k, "position": positions[k - 1], "command_share": share,
                    "command_share_baseline": None, "command_change": change,
                    "effectiveness": None, "effectiveness_ci_lo": None, "effectiveness_ci_hi": None,
                    "model_vote": _num(sum(votes) / len(votes)) if votes else None,
                    "eta_hat": None, "eta_ci_lo": None, "eta_ci_hi": None, "weight": None, "llr": None})
    return out


def finding_rows(doc: dict) -> list[tuple]:
    """One tuple (:data:`FINDING_COLUMNS`) per finding of the report's ``analyzers``."""
    out = []
    for an in doc.get("analyzers") or []:
        for f in (an.get("findings") or []) if isinstance(an, dict) else []:
            lo, hi = _pair(f.get("interval"))
            motor = f.get("motor")
            out.append((str(f.get("analyzer") or an.get("analyzer") or ""),
                        int(motor) if isinstance(motor, int) else None, str(f.get("name") or ""),
                        _num(f.get("value")), f.get("unit") or "", lo, hi, _num(f.get("baseline")),
                        f.get("direction") or "", _num(f.get("llr")), f.get("text") or ""))
    return out


def _write_figures(db: Database, fid: int, doc: dict, command_share: Optional[list[float]] = None) -> None:
    """Replace the flight's motor and finding rows with those of ``doc`` (inside a transaction)."""
    db.run("DELETE FROM motor_figure WHERE flight_id = ?", (fid,))
    cols = ("flight_id", "motor") + MOTOR_COLUMNS
    db.run_many(f"INSERT INTO motor_figure ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                [(fid, m["motor"], *(m[c] for c in MOTOR_COLUMNS)) for m in motor_rows(doc, command_share)])
    db.run("DELETE FROM finding WHERE flight_id = ?", (fid,))
    fcols = ("flight_id",) + FINDING_COLUMNS
    db.run_many(f"INSERT INTO finding ({', '.join(fcols)}) VALUES ({', '.join('?' * len(fcols))})",
                [(fid, *f) for f in finding_rows(doc)])


def part_rows(doc: dict) -> list[tuple]:
    """(part, *PART_COLUMNS) per flight of the report's ``flights`` (empty for one flight)."""
    out = []
    for i, f in enumerate(doc.get("flights") or [], 1):
        if not isinstance(f, dict):
            continue
        v = f.get("verdict") or {}
        motor = v.get("motor")
        label = str(f.get("part") or f"flight {i}")
        bounds = re.search(r"(-?[0-9.]+)-(-?[0-9.]+) s$", label)  # "flight 2 of 5, 234.8-327.8 s"
        out.append((i, label, _num(bounds.group(1)) if bounds else None, _num(bounds.group(2)) if bounds else None,
                    _num(f.get("airborne_s")), v.get("status"), int(motor) if isinstance(motor, int) else None,
                    _num(v.get("confidence")), v.get("reason") or "", verdict_motors_text(v), int(bool(v.get("pair")))))
    return out


def _write_parts(db: Database, fid: int, doc: dict, columns: tuple = PART_COLUMNS) -> None:
    """Replace the flight's ``flight_part`` rows with those of ``doc`` (inside a transaction);
    ``columns``: the ones the table has (a migration writes those of its own version)."""
    db.run("DELETE FROM flight_part WHERE flight_id = ?", (fid,))
    cols = ("flight_id", "part") + tuple(columns)
    db.run_many(f"INSERT INTO flight_part ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                [(fid, r[0], *r[1:len(columns) + 1]) for r in part_rows(doc)])


def _run_columns(doc: dict) -> tuple:
    """(model_sha256, model_version, profile_path, tool_version, exit_code) of a report."""
    model, prof, tool = doc.get("model") or {}, doc.get("profile") or {}, doc.get("tool") or {}
    return (model.get("sha256"), model.get("version"), prof.get("path"), tool.get("version"), doc.get("exit_code"))


def own_airframe_key(sha256: str) -> str:
    """The server's airframe of a log without an id: its own, named by its content hash."""
    return f"log:{sha256[:OWN_AIRFRAME_HEX]}"


def utc_iso(posix: Optional[float]) -> Optional[str]:
    """POSIX seconds as ISO-8601 UTC with a Z, to the millisecond (None stays None)."""
    if posix is None or not math.isfinite(posix):
        return None
    return datetime.fromtimestamp(posix, tz=timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


# ----------------------------------------------------------------------------- fdlog diagnose --db

@dataclass
class RunInfo:
    """What is the same for every log of one batch: model, profile, tool."""

    model_sha256: str
    model_version: str = ""
    profile_path: Optional[str] = None
    profile_sha256: str = ""
    profile_name: Optional[str] = None  # used as the vehicle when the log names none
    tool_version: str = ""

    @staticmethod
    def for_batch(model: Any, profile: Any = None) -> "RunInfo":
        from . import __version__
        from .util import file_sha256

        ppath = getattr(profile, "path", None) if profile is not None else None
        psha = ""
        if ppath:
            try:
                psha = file_sha256(ppath)
            except OSError:
                psha = ""
        return RunInfo(model_sha256=str(getattr(model, "sha256", "")), model_version=str(getattr(model, "version", "")),
                       profile_path=str(ppath) if ppath else None, profile_sha256=psha,
                       profile_name=Path(ppath).stem if ppath else None, tool_version=__version__)


def vehicle_identity(vehicle_id: Optional[str], source: Optional[str], run: RunInfo) -> tuple[str, str]:
    """(vehicle, source) for ``fdlog diagnose --db``: the log's id, else ``profile:NAME``, else ``unknown``."""
    if vehicle_id:
        return str(vehicle_id), source or "log"
    if run.profile_name:
        return f"profile:{run.profile_name}", "profile"
    return UNKNOWN_VEHICLE, "unknown"


def _file_size(path: str) -> int:
    try:
        return os.stat(path).st_size
    except OSError:
        return 0


# ----------------------------------------------------------------------------- the store

class Store:
    """The store on a SQLite path or a PostgreSQL URL, migrated on open (module docstring).

    ``create=False`` refuses a SQLite path that does not exist (for readers such as history)."""

    def __init__(self, target, create: bool = True):
        target = str(target)
        if not is_postgres_url(target):
            p = Path(target)
            if p.is_dir():
                raise StoreError(p, "is a folder, not a database file")
            if not create and not p.exists():
                raise StoreError(p, "no such database")
        self.db: Database = open_database(target)
        try:
            self.db.migrate(MIGRATIONS, adopt=lambda tables: _adopt_results_store(self.db, tables))
        except BaseException:
            self.db.close()
            raise

    @property
    def dialect(self) -> str:
        return self.db.dialect

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ diagnoses

    def _record(self, fid: int, doc: dict, *, airframe: str, flight_start_utc: Optional[str],
                log_t_start_s: Optional[float], profile_sha256: str, sentence: Optional[str] = None,
                plot: Any = None, command_share: Optional[list[float]] = None,
                diagnosed_at: Optional[str] = None, run: Optional[RunInfo] = None) -> None:
        """Write ``doc`` (a diagnosis JSON object) as flight ``fid``'s diagnosis (inside a transaction)."""
        v = doc.get("verdict") or {}
        model_sha, model_version, profile_path, tool_version, exit_code = _run_columns(doc)
        if run is not None:
            model_sha, model_version = run.model_sha256, model_version or run.model_version
            profile_path, tool_version = run.profile_path, run.tool_version or tool_version
        self.db.run(
            "UPDATE flight SET state = 'done', airframe = ?, autopilot = ?, firmware = ?, flight_start_utc = ?, "
            "log_t_start_s = ?, airborne_s = ?, status = ?, motor = ?, verdict_motors = ?, pair = ?, confidence = ?, "
            "reason = ?, cause = ?, load_motor = ?, load_size = ?, load_direction_deg = ?, sentence = ?, "
            "profile_sha256 = ?, profile_path = ?, model_sha256 = ?, model_version = ?, tool_version = ?, "
            "exit_code = ?, diagnosis_json = ?, plot_json = ?, error = NULL, diagnosed_at = ? WHERE id = ?",
            (airframe, doc.get("autopilot"), doc.get("firmware"), flight_start_utc, _num(log_t_start_s),
             _num(doc.get("airborne_s")), v.get("status"), v.get("motor"), verdict_motors_text(v),
             int(bool(v.get("pair"))), _num(v.get("confidence")), v.get("reason"), v.get("cause"),
             *_load_columns(v.get("load")), sentence, profile_sha256 or "", profile_path, model_sha, model_version, tool_version, exit_code,
             json.dumps(doc), None if plot is None else json.dumps(plot), diagnosed_at or utc_now(), fid))
        _write_figures(self.db, fid, doc, command_share)
        _write_parts(self.db, fid, doc)

    def _airframe(self, key: str, source: str) -> None:
        self.db.run("INSERT INTO airframe (key, source, created_at) VALUES (?, ?, ?) ON CONFLICT (key) DO NOTHING",
                    (key, source, utc_now()))

    def _record_result(self, fid: int, result: Any, run: RunInfo, when: str) -> None:
        """Write a :class:`~flightlog_fd.batch.LogResult` as flight ``fid``'s diagnosis (inside a
        transaction), its airframe as ``fdlog diagnose --db`` names it (:func:`vehicle_identity`)."""
        from .report.json_report import to_dict

        doc = to_dict(result.diagnosis)
        vehicle, vsource = vehicle_identity(result.vehicle_id, result.vehicle_id_source, run)
        facts = result.diagnosis.facts
        self._airframe(vehicle, vsource)
        self._record(fid, doc, airframe=vehicle, flight_start_utc=utc_iso(result.utc_start),
                     log_t_start_s=facts.t_start if facts else None, profile_sha256=run.profile_sha256,
                     command_share=result.command_share, diagnosed_at=when, run=run)

    def add_result(self, result: Any, run: RunInfo, diagnosed_at: Optional[str] = None) -> Optional[int]:
        """Write one :class:`~flightlog_fd.batch.LogResult` of ``fdlog diagnose --db`` (one
        transaction); returns its flight id, or None for a file that could not even be read (no
        sha256 to key it on). The same bytes again replace that flight's diagnosis."""
        if not result.log_sha256:
            return None
        when = diagnosed_at or utc_now()
        fmt = _AUTOPILOT_FORMAT.get(getattr(result.diagnosis.facts, "autopilot", None) or "", "")
        db = self.db

        def tx() -> int:
            fid = int(db.one("INSERT INTO flight (sha256, name, size_bytes, format, uploaded_at, state) "
                             "VALUES (?, ?, ?, ?, ?, 'done') ON CONFLICT (sha256) DO UPDATE SET name = excluded.name "
                             "RETURNING id", (result.log_sha256, str(result.path), _file_size(str(result.path)), fmt,
                                              when))["id"])
            self._record_result(fid, result, run, when)
            return fid

        return db.transaction(tx, f"write the diagnosis of {result.path}")

    # ------------------------------------------------------------------ fdlog watch

    def claim_watched(self, sha256: str, path: str, size: int, fmt: str, worker: str) -> tuple[str, Optional[dict]]:
        """Take a log `fdlog watch` found, in one transaction: ("claimed", job) when ``worker``
        is to diagnose it (a new flight with a ``watch`` job held by ``worker``, or such a job of
        these bytes back in the queue after its watcher stopped); ("stored", None) when these
        bytes are already a flight (diagnosed, uploaded, or queued on a server); ("busy", None)
        while another watcher holds them (look again later: it may stop)."""
        db = self.db

        def tx():
            now = utc_now()
            row = db.one("SELECT id FROM flight WHERE sha256 = ?", (sha256,))
            if row is None:
                fid = db.one("INSERT INTO flight (sha256, name, size_bytes, format, uploaded_at, state) "
                             "VALUES (?, ?, ?, ?, ?, 'running') ON CONFLICT (sha256) DO NOTHING RETURNING id",
                             (sha256, path, size, fmt, now))
                if fid is None:  # another watcher inserted it between our SELECT and INSERT (PostgreSQL)
                    return "busy", None
                job = db.one("INSERT INTO job (kind, flight_id, args, state, attempts, worker, lease_until, created_at, "
                             "started_at) VALUES ('watch', ?, ?, 'running', 1, ?, ?, ?, ?) RETURNING *",
                             (fid["id"], json.dumps({"path": path}), worker, time.time() + LEASE_S, now, now))
                return "claimed", job
            jobs = db.query("SELECT id, state FROM job WHERE flight_id = ? AND kind = 'watch' ORDER BY id", (row["id"],))
            queued = [j for j in jobs if j["state"] == "queued"]
            if queued:
                job = db.one("UPDATE job SET state = 'running', worker = ?, attempts = attempts + 1, lease_until = ?, "
                             "started_at = ?, args = ? WHERE id = ? AND state = 'queued' RETURNING *",
                             (worker, time.time() + LEASE_S, now, json.dumps({"path": path}), queued[0]["id"]))
                if job:
                    db.run("UPDATE flight SET state = 'running' WHERE id = ?", (row["id"],))
                    return "claimed", job
            if any(j["state"] in ("queued", "running") for j in jobs):
                return "busy", None
            return "stored", None

        return db.transaction(tx, "claim a watched log")

    def complete_watched(self, job: dict, worker: str, result: Any, run: RunInfo) -> bool:
        """Store a watched log's diagnosis (a LogResult) and mark its job done, in one transaction;
        False (nothing written) when ``worker`` no longer holds the job."""
        db = self.db

        def tx():
            when = utc_now()
            ok = db.run("UPDATE job SET state = 'done', finished_at = ?, lease_until = NULL WHERE id = ? "
                        "AND state = 'running' AND worker = ?", (when, job["id"], worker))
            if ok != 1:
                return False
            self._record_result(int(job["flight_id"]), result, run, when)
            return True

        return db.transaction(tx, f"store the diagnosis of {result.path}")

    def watched_sha(self, host: str, path: str, size: int, mtime_ns: int) -> Optional[str]:
        """The sha256 a watcher recorded for this file, if it is unchanged since (size, mtime)."""
        row = self.db.one("SELECT sha256 FROM watched_file WHERE host = ? AND path = ? AND size_bytes = ? "
                          "AND mtime_ns = ?", (host, path, size, mtime_ns))
        return row["sha256"] if row else None

    def remember_watched(self, host: str, path: str, size: int, mtime_ns: int, sha256: str) -> None:
        self.db.transaction(lambda: self.db.run(
            "INSERT INTO watched_file (host, path, size_bytes, mtime_ns, sha256, seen_at) VALUES (?, ?, ?, ?, ?, ?) "
            "ON CONFLICT (host, path) DO UPDATE SET size_bytes = excluded.size_bytes, mtime_ns = excluded.mtime_ns, "
            "sha256 = excluded.sha256, seen_at = excluded.seen_at", (host, path, size, mtime_ns, sha256, utc_now())),
            "remember a watched file")

    def findings(self, flight_id: int) -> list[dict]:
        """A flight's findings as stored (:data:`FINDING_COLUMNS`), in the report's order."""
        return self.db.query(f"SELECT {', '.join(FINDING_COLUMNS)} FROM finding WHERE flight_id = ? "
                             f"ORDER BY {'rowid' if self.dialect == 'sqlite' else 'ctid'}", (flight_id,))

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

    def flight_parts(self, fid: int) -> list[dict]:
        """Each flight of this log (``flight_part`` rows in time order; [] for a log with one)."""
        return self.db.query(f"SELECT part, {', '.join(PART_COLUMNS)} FROM flight_part WHERE flight_id = ? "
                             f"ORDER BY part", (fid,))

    def flight_motors(self, fid: int) -> list[dict]:
        return self.db.query("SELECT * FROM motor_figure WHERE flight_id = ? ORDER BY motor", (fid,))

    def logs(self) -> list[dict]:
        """Every flight, short (the API's list)."""
        return self.db.query("SELECT id, name, sha256, state, status, motor, airframe, uploaded_at FROM flight ORDER BY id")

    def set_healthy_mark(self, fid: int, healthy: bool) -> bool:
        return self.db.transaction(lambda: self.db.run("UPDATE flight SET healthy_mark = ? WHERE id = ?",
                                                       (1 if healthy else 0, fid)) == 1)

    # ------------------------------------------------------------------ jobs

    def enqueue_calibration(self, airframe: str, flight_ids: list[int], adapt: bool,
                            add_to: Optional[str] = None) -> int:
        """Queue a calibration of ``airframe`` from ``flight_ids`` (one session each); ``add_to``:
        the profile they are added to as new sessions (None: a new profile)."""
        args = {"flights": flight_ids, "adapt": adapt, **({"add_to": add_to} if add_to else {})}

        def tx():
            row = self.db.one("INSERT INTO job (kind, airframe, args, state, created_at) VALUES "
                              "('calibrate', ?, ?, 'queued', ?) RETURNING id",
                              (airframe, json.dumps(args), utc_now()))
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
            db.run("UPDATE flight SET state = 'error', error = ?, status = 'not_diagnosable', cause = NULL, "
                   "load_motor = NULL, load_size = NULL, load_direction_deg = NULL, reason = ?, "
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
        sha = result["sha256"]
        key, source = (result["vehicle"], result["vehicle_source"]) if result.get("vehicle") else \
            (own_airframe_key(sha), "none")

        def tx():
            ok = db.run("UPDATE job SET state = 'done', finished_at = ?, lease_until = NULL WHERE id = ? "
                        "AND state = 'running' AND worker = ?", (utc_now(), job["id"], worker))
            if ok != 1:
                return False
            self._airframe(key, source)
            self._record(int(job["flight_id"]), doc, airframe=key, flight_start_utc=result.get("flight_start_utc"),
                         log_t_start_s=result.get("log_t_start_s"), profile_sha256=result.get("profile_sha256") or "",
                         sentence=result.get("sentence"), plot=result.get("plot"))
            return True

        return db.transaction(tx, "store the diagnosis")

    def complete_calibration(self, job: dict, worker: str, profile_path: str, profile_sha256: str) -> bool:
        """Store a calibration job's profile as its airframe's and mark the job done, in one
        transaction: the job's flights become the airframe's next calibration sessions (one each),
        after those it already has when the job added sessions (``args.add_to``), else replacing
        them. False (nothing written) when ``worker`` no longer holds the job."""
        args = json.loads(job.get("args") or "{}")
        flights = [int(f) for f in args.get("flights", [])]
        key = job["airframe"]

        def tx():
            ok = self.db.run("UPDATE job SET state = 'done', finished_at = ?, lease_until = NULL WHERE id = ? "
                             "AND state = 'running' AND worker = ?", (utc_now(), job["id"], worker))
            if ok != 1:
                return False
            self.db.run("UPDATE airframe SET profile_path = ?, profile_sha256 = ? WHERE key = ?",
                        (profile_path, profile_sha256, key))
            if not args.get("add_to"):
                self.db.run("DELETE FROM calibration_session WHERE airframe = ?", (key,))
            top = self.db.one("SELECT MAX(session) AS n FROM calibration_session WHERE airframe = ?", (key,))
            first = int(top["n"] or 0) + 1 if top else 1
            now = utc_now()
            for k, fid in enumerate(flights):
                self.db.run("INSERT INTO calibration_session (airframe, session, flight_id, job_id, profile_path, "
                            "created_at) VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT (airframe, flight_id) DO NOTHING",
                            (key, first + k, fid, job["id"], profile_path, now))
            return True

        return self.db.transaction(tx, "store the calibration")

    def calibration_sessions(self, airframe: str) -> list[dict]:
        """The airframe's calibration sessions in order: session, flight id, its name, when added."""
        return self.db.query("SELECT s.session, s.flight_id, f.name, f.sha256, s.job_id, s.created_at "
                             "FROM calibration_session s JOIN flight f ON f.id = s.flight_id "
                             "WHERE s.airframe = ? ORDER BY s.session, s.flight_id", (airframe,))

    def job(self, jid: int) -> Optional[dict]:
        return self.db.one("SELECT * FROM job WHERE id = ?", (jid,))

    def jobs(self, limit: int = 50) -> list[dict]:
        return self.db.query("SELECT job.*, flight.name AS flight_name FROM job LEFT JOIN flight ON flight.id = job.flight_id "
                             "ORDER BY job.id DESC LIMIT ?", (limit,))

    def calibration_jobs(self, airframe: str) -> list[dict]:
        """An airframe's calibration jobs, newest first."""
        return self.db.query("SELECT * FROM job WHERE kind = 'calibrate' AND airframe = ? ORDER BY id DESC", (airframe,))

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

    def _grouped(self, table: dict) -> dict[str, list[dict]]:
        """Resolved airframe -> its flights in time order (UTC start; flights without it after,
        by name, then upload), each with ``motors``: motor -> figures."""
        flights = self.db.query("SELECT id, sha256, name, state, airframe, healthy_mark, autopilot, firmware, "
                                "flight_start_utc, airborne_s, status, motor, verdict_motors, pair, cause, confidence, "
                                "reason, uploaded_at, diagnosed_at, error FROM flight WHERE airframe IS NOT NULL")
        figs: dict[int, dict[int, dict]] = {}
        for m in self.db.query(f"SELECT flight_id, motor, {', '.join(MOTOR_COLUMNS)} FROM motor_figure"):
            figs.setdefault(int(m["flight_id"]), {})[int(m["motor"])] = {c: m[c] for c in MOTOR_COLUMNS}
        parts: dict[int, list[dict]] = {}
        for p in self.db.query(f"SELECT flight_id, part, {', '.join(PART_COLUMNS)} FROM flight_part "
                               f"ORDER BY flight_id, part"):
            parts.setdefault(int(p["flight_id"]), []).append({k: p[k] for k in ("part",) + PART_COLUMNS})
        groups: dict[str, list[dict]] = {}
        for f in flights:
            f["motors"] = figs.get(int(f["id"]), {})
            f["parts"] = parts.get(int(f["id"]), [])
            f["verdict_motors"] = parse_verdict_motors(f.get("verdict_motors"))
            f["pair"] = bool(f.get("pair"))
            for p in f["parts"]:
                p["verdict_motors"] = parse_verdict_motors(p.get("verdict_motors"))
                p["pair"] = bool(p.get("pair"))
            groups.setdefault(self.resolve(f["airframe"], table), []).append(f)
        for fl in groups.values():
            fl.sort(key=lambda f: (f["flight_start_utc"] is None, f["flight_start_utc"] or "", f["name"],
                                   f["uploaded_at"], f["id"]))
        return groups

    def fleet(self) -> list[dict]:
        """One dict per airframe (merges applied): its row, flights in time order, drifts."""
        table = self.airframes()
        out = []
        for key, fl in self._grouped(table).items():
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

    def history(self, vehicle: Optional[str] = None) -> dict[str, list[FlightRecord]]:
        """Airframe -> its flights in time order, as `fdlog history` and the drift rule read them
        (merges applied); only ``vehicle`` when given."""
        table = self.airframes()
        out = {}
        for key, fl in sorted(self._grouped(table).items()):
            if vehicle is not None and key != vehicle:
                continue
            source = (table.get(key) or {}).get("source") or ""
            out[key] = [_record_of(f, source) for f in fl]
        return out

    def pending(self) -> list[dict]:
        """Flights not yet diagnosed (no airframe known)."""
        return self.db.query("SELECT id, name, state, uploaded_at, error FROM flight WHERE airframe IS NULL ORDER BY id")

    def count_flights_by_sha(self) -> dict[str, int]:
        rows = self.db.query("SELECT sha256, COUNT(*) AS n FROM flight GROUP BY sha256")
        return {r["sha256"]: int(r["n"]) for r in rows}


def holder_is_dead(worker: str) -> bool:
    """True when ``worker`` (``host:pid:random``, the job holder's id) ran on this machine and
    its process is gone: its jobs need not wait for their lease. A reused pid only makes us wait
    for the lease, never take a live holder's job."""
    host, _, rest = worker.partition(":")
    pid = rest.partition(":")[0]
    if host != socket.gethostname() or not pid.isdigit():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except OSError:  # exists, owned by someone else
        return False
    return False


def _record_of(f: dict, source: str) -> FlightRecord:
    return FlightRecord(id=int(f["id"]), log_path=f["name"], log_sha256=f["sha256"],
                        flight_start_utc=f["flight_start_utc"], airborne_s=f["airborne_s"], status=f["status"] or "",
                        motor=f["motor"], cause=f.get("cause"), confidence=f["confidence"], reason=f["reason"] or "",
                        verdict_motors=list(f.get("verdict_motors") or []), pair=bool(f.get("pair")),
                        diagnosed_at=f["diagnosed_at"] or "", vehicle_source=source,
                        motors={k: dict(v) for k, v in f["motors"].items()}, parts=list(f.get("parts") or []))


def drift_of(key: str, flights: list[dict]) -> list:
    """The drift rule over this airframe's diagnosed flights (the same rule as `fdlog history`;
    none for ``unknown``, which is not one airframe)."""
    if key == UNKNOWN_VEHICLE:
        return []
    return find_drift(key, [_record_of(f, "") for f in flights if f["state"] == "done" and f["motors"]])


def load_history(target, vehicle: Optional[str] = None) -> dict[str, list[FlightRecord]]:
    """:meth:`Store.history` of an existing store (refuses a path that is not one)."""
    with Store(target, create=False) as store:
        return store.history(vehicle)


# ----------------------------------------------------------------------------- older results stores

#: ``PRAGMA user_version`` of the results stores ``fdlog diagnose --db`` wrote before the one store.
RESULTS_STORE_VERSIONS = (1, 2)
_LEGACY = ("diagnosis", "motor_figure", "finding")


def _adopt_results_store(db: Database, tables: set) -> Optional[Callable[[], None]]:
    """A results store of ``fdlog diagnose --db`` from before the one store: its tables move
    aside (``legacy_*``), and after the migrations each log's latest diagnosis (the one history
    showed) becomes a flight with its motor figures and findings; None for any other file."""
    if "schema_version" not in tables or not {"diagnosis", "motor_figure"} <= tables:
        return None
    version = int(db.one("PRAGMA user_version")["user_version"])
    if version not in RESULTS_STORE_VERSIONS:
        raise StoreError(db.where, f"results database schema version {version}, this fdlog reads "
                                   f"{', '.join(map(str, RESULTS_STORE_VERSIONS))} and {SCHEMA_VERSION}")
    present = [t for t in _LEGACY if t in tables]
    for t in present:
        for idx in db.query("SELECT name FROM sqlite_master WHERE type = 'index' AND tbl_name = ? AND sql IS NOT NULL",
                            (t,)):
            db.run(f'DROP INDEX "{idx["name"]}"')
        db.run(f"ALTER TABLE {t} RENAME TO legacy_{t}")

    def finish() -> None:
        rows = db.query("SELECT * FROM legacy_diagnosis ORDER BY diagnosed_at DESC, id DESC")
        figs: dict[int, list[dict]] = {}
        for m in db.query("SELECT * FROM legacy_motor_figure ORDER BY motor"):
            figs.setdefault(int(m["diagnosis_id"]), []).append(m)
        finds: dict[int, list[dict]] = {}
        if "finding" in present:
            for f in db.query("SELECT * FROM legacy_finding ORDER BY rowid"):
                finds.setdefault(int(f["diagnosis_id"]), []).append(f)
        seen = set()
        for r in rows:
            if r["log_sha256"] in seen:  # the same log under another model or profile: the latest is kept
                continue
            seen.add(r["log_sha256"])
            db.run("INSERT INTO airframe (key, source, created_at) VALUES (?, ?, ?) ON CONFLICT (key) DO NOTHING",
                   (r["vehicle"], r["vehicle_source"], r["diagnosed_at"]))
            fid = int(db.one(
                "INSERT INTO flight (sha256, name, size_bytes, format, uploaded_at, state, airframe, autopilot, "
                "flight_start_utc, log_t_start_s, airborne_s, status, motor, confidence, reason, profile_sha256, "
                "profile_path, model_sha256, model_version, tool_version, exit_code, diagnosed_at) "
                "VALUES (?, ?, ?, ?, ?, 'done', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
                (r["log_sha256"], r["log_path"], _file_size(r["log_path"]), _AUTOPILOT_FORMAT.get(r["autopilot"] or "", ""),
                 r["diagnosed_at"], r["vehicle"], r["autopilot"], r["flight_start_utc"], r["log_t_start_s"],
                 r["airborne_s"], r["status"], r["motor"], r["confidence"], r["reason"], r["profile_sha256"],
                 r["profile_path"], r["model_sha256"], r["model_version"], r["tool_version"], r["exit_code"],
                 r["diagnosed_at"]))["id"])
            ms = figs.get(int(r["id"]), [])
            shares = [m["command_share"] for m in ms]
            for i, m in enumerate(ms):
                base, share = m["command_share_baseline"], m["command_share"]
                others = [s for j, s in enumerate(shares) if j != i]
                if share is not None and base is not None:
                    change = share - base
                elif share is not None and others and None not in others:
                    change = share - sum(others) / len(others)
                else:
                    change = None
                db.run("INSERT INTO motor_figure (flight_id, motor, position, command_share, command_share_baseline, "
                       "command_change, effectiveness, effectiveness_ci_lo, effectiveness_ci_hi, model_vote) "
                       "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (fid, m["motor"], m["position"], share, base, change, m["effectiveness"],
                        m["effectiveness_ci_lo"], m["effectiveness_ci_hi"], m["model_vote"]))
            db.run_many(f"INSERT INTO finding (flight_id, {', '.join(FINDING_COLUMNS)}) "
                        f"VALUES ({', '.join('?' * (len(FINDING_COLUMNS) + 1))})",
                        [(fid, f["analyzer"], f["motor"], f["name"], f["value"], f["unit"], f["lo"], f["hi"],
                          f["baseline"], f["direction"], f["llr"], "") for f in finds.get(int(r["id"]), [])])
        for t in ("finding", "motor_figure", "diagnosis"):
            if t in present:
                db.run(f"DROP TABLE legacy_{t}")
        db.run("DROP TABLE schema_version")

    return finish


__all__ = ["Store", "StoreError", "RunInfo", "FlightRecord", "MIGRATIONS", "SCHEMA_VERSION", "LEASE_S",
           "MAX_ATTEMPTS", "MOTOR_COLUMNS", "FINDING_COLUMNS", "PART_COLUMNS", "part_rows", "TREND_FIGURES", "UNKNOWN_VEHICLE",
           "load_history", "motor_rows", "finding_rows", "own_airframe_key", "vehicle_identity", "utc_iso", "drift_of",
           "holder_is_dead", "StoreUnavailable"]
