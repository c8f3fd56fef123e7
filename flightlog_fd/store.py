"""The results store: every diagnosis appended to one SQLite file, and per-airframe history.

``fdlog diagnose LOGS --db results.sqlite`` calls :meth:`ResultStore.add` for each log as its
result arrives (in the client process, also for Dask batches); ``fdlog history --db`` reads it
back (:func:`load_history`; :mod:`flightlog_fd.drift`, :mod:`flightlog_fd.history`). Standard library ``sqlite3``.

Schema (``SCHEMA_VERSION`` 2; kept in ``PRAGMA user_version`` and in the ``schema_version``
table, which also marks the file as an fdlog store): :data:`SCHEMA`, the CREATE statements
with a comment on every column that needs one.

**Upsert.** Re-running the same log (same bytes) with the same model and profile replaces its
row and motor rows instead of adding one: the key is (log sha256, model sha256, profile sha256).

**Vehicle identity**: the log's own id when it has one (``Flight.vehicle_id``: PX4 ``sys_uuid``,
else the board type ``ver_hw``; ArduPilot board UID line, ``BRD_SERIAL_NUM``, ``SYSID_THISMAV``),
else the calibration profile's file name (``profile:NAME``), else ``"unknown"``. ``ver_hw`` and
``SYSID_THISMAV`` (1 on most vehicles) can be shared by several airframes: their source is stored
so a user can tell.

**Concurrent writers** (several batch processes on one file): WAL journal mode, a busy timeout of
``BUSY_TIMEOUT_S``, one ``BEGIN IMMEDIATE`` transaction per diagnosis, and up to ``MAX_RETRIES``
retries with exponential backoff (``RETRY_BASE_S`` x 2^k plus jitter) on ``database is locked``.
WAL needs a local file system (not NFS).

**Per-motor figures** go through one adapter, :func:`motor_figures`: it uses
``Diagnosis.motors`` (MotorEvidence: motor, position, command_share, command_share_baseline,
effectiveness, effectiveness_ci, model_vote) when the Diagnosis has them, else what can be
computed here: ``model_vote`` = mean over the windows of the model's probability for that motor,
``command_share`` from the Flight (:func:`flightlog_fd.batch.command_shares`).

**Drift rule and history**: :mod:`flightlog_fd.drift` and :mod:`flightlog_fd.history` read
what :func:`load_history` returns.

"""
from __future__ import annotations

import math
import random
import sqlite3
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Optional

from .errors import FlightLogError

SCHEMA_VERSION = 2
#: Older store versions this fdlog opens and upgrades in place (1 -> 2 adds the ``finding`` table).
UPGRADABLE_VERSIONS = (1,)
BUSY_TIMEOUT_S = 30.0
MAX_RETRIES = 10
RETRY_BASE_S = 0.05

UNKNOWN_VEHICLE = "unknown"
MOTOR_FIELDS = ("position", "command_share", "command_share_baseline", "effectiveness",
                "effectiveness_ci_lo", "effectiveness_ci_hi", "model_vote")

SCHEMA = """
CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL, tool_version TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS diagnosis (
    id               INTEGER PRIMARY KEY,
    log_path         TEXT NOT NULL,    -- as given on the command line
    log_sha256       TEXT NOT NULL,
    vehicle          TEXT NOT NULL,    -- airframe identity (module docstring)
    vehicle_source   TEXT NOT NULL,    -- sys_uuid, ver_hw, board_uid, BRD_SERIAL_NUM, SYSID_THISMAV, profile, unknown
    autopilot        TEXT,
    flight_start_utc TEXT,             -- ISO-8601 UTC ("2024-05-01T09:30:00Z") when the log has GPS time, else NULL
    log_t_start_s    REAL,             -- start of the log on its own clock (s since boot)
    airborne_s       REAL,
    status           TEXT NOT NULL,    -- healthy | damaged | stopped | uncertain | not_diagnosable
    motor            INTEGER,          -- 1..4 for damaged
    confidence       REAL,
    reason           TEXT,
    exit_code        INTEGER NOT NULL,
    model_version    TEXT,
    model_sha256     TEXT NOT NULL,
    profile_path     TEXT,
    profile_sha256   TEXT NOT NULL,    -- '' without a profile (NULLs would never conflict)
    tool_version     TEXT NOT NULL,
    diagnosed_at     TEXT NOT NULL,    -- ISO-8601 UTC
    UNIQUE (log_sha256, model_sha256, profile_sha256)
);
CREATE TABLE IF NOT EXISTS motor_figure (
    diagnosis_id           INTEGER NOT NULL REFERENCES diagnosis(id) ON DELETE CASCADE,
    motor                  INTEGER NOT NULL,   -- 1..4
    position               TEXT,
    command_share          REAL,   -- mean thrust command / mean of the four while airborne (1 = even)
    command_share_baseline REAL,   -- the same from the calibration profile
    effectiveness          REAL,   -- 1.0 = as effective as its neighbours
    effectiveness_ci_lo    REAL,
    effectiveness_ci_hi    REAL,
    model_vote             REAL,   -- mean model probability that this motor is damaged
    PRIMARY KEY (diagnosis_id, motor)
);
CREATE TABLE IF NOT EXISTS finding (      -- every analyzer's per-motor findings (flightlog_fd.analyzers)
    diagnosis_id INTEGER NOT NULL REFERENCES diagnosis(id) ON DELETE CASCADE,
    analyzer     TEXT NOT NULL,             -- the analyzer's id (model, commands, throttle, ...)
    motor        INTEGER NOT NULL,          -- 1..n, the autopilot's numbering
    name         TEXT NOT NULL,             -- the figure (vote, share, thrust, ...)
    value        REAL,
    unit         TEXT NOT NULL,
    lo           REAL,                      -- its interval, when it has one
    hi           REAL,
    baseline     REAL,                      -- the healthy value it is compared with
    direction    TEXT NOT NULL,             -- up | down | '' (which way damage moves it)
    llr          REAL,                      -- its weight in the decision (nats), NULL if not weighed
    PRIMARY KEY (diagnosis_id, analyzer, name, motor)
);
CREATE INDEX IF NOT EXISTS diagnosis_vehicle ON diagnosis (vehicle, flight_start_utc);
CREATE INDEX IF NOT EXISTS diagnosis_sha256 ON diagnosis (log_sha256);
CREATE INDEX IF NOT EXISTS diagnosis_flight_time ON diagnosis (flight_start_utc);
"""


class StoreError(FlightLogError):
    """The database is missing, not an fdlog store, or of another schema version."""


# ----------------------------------------------------------------------------- figures

def _positions(diagnosis: Any) -> list[Optional[str]]:
    from .flight import QUAD_PLUS_POSITIONS, QUAD_X_POSITIONS

    flight = getattr(diagnosis, "flight", None)
    if flight is not None and flight.frame is not None:
        return [flight.frame.position(k) for k in range(1, max(flight.frame.rotor_count, 4) + 1)]
    frame = getattr(getattr(diagnosis, "facts", None), "frame", None)
    if frame == "quad_x":
        return list(QUAD_X_POSITIONS)
    if frame == "quad_plus":
        return list(QUAD_PLUS_POSITIONS)
    return [None] * 4


def _num(x: Any) -> Optional[float]:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def motor_figures(diagnosis: Any, command_share: Optional[list[float]] = None) -> list[dict]:
    """One dict per motor (keys ``motor`` and :data:`MOTOR_FIELDS`, values None when unknown).

    Prefers ``diagnosis.motors`` (MotorEvidence objects) when present and non-empty; otherwise
    model_vote from the windows' probabilities and command_share from ``command_share`` (as the
    batch worker measured it) or from the kept Flight. Empty for a log with no verdict data."""
    evidence = getattr(diagnosis, "motors", None)
    if evidence:
        out = []
        for m in evidence:
            ci = getattr(m, "effectiveness_ci", None) or (None, None)
            out.append({"motor": int(m.motor), "position": getattr(m, "position", None),
                        "command_share": _num(getattr(m, "command_share", None)),
                        "command_share_baseline": _num(getattr(m, "command_share_baseline", None)),
                        "effectiveness": _num(getattr(m, "effectiveness", None)),
                        "effectiveness_ci_lo": _num(ci[0]), "effectiveness_ci_hi": _num(ci[1]),
                        "model_vote": _num(getattr(m, "model_vote", None))})
        return out
    windows = getattr(diagnosis, "windows", None) or []
    if command_share is None and getattr(diagnosis, "flight", None) is not None:
        from .batch import command_shares

        command_share = command_shares(diagnosis.flight)
    if not windows and command_share is None:
        return []
    positions = _positions(diagnosis)
    n = max(len(command_share) if command_share else 0, (len(windows[0].probabilities) - 1) if windows else 0, 4)
    positions = positions + [None] * (n - len(positions))
    out = []
    for k in range(1, n + 1):
        vote = None
        if windows:
            probs = [w.probabilities[k] for w in windows if len(w.probabilities) > k]
            vote = sum(probs) / len(probs) if probs else None
        out.append({"motor": k, "position": positions[k - 1],
                    "command_share": _num(command_share[k - 1]) if command_share and k <= len(command_share) else None,
                    "command_share_baseline": None, "effectiveness": None,
                    "effectiveness_ci_lo": None, "effectiveness_ci_hi": None, "model_vote": _num(vote)})
    return out


# ----------------------------------------------------------------------------- writing

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


def _utc_iso(posix: Optional[float]) -> Optional[str]:
    if posix is None or not math.isfinite(posix):
        return None
    return datetime.fromtimestamp(posix, tz=timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def vehicle_identity(vehicle_id: Optional[str], source: Optional[str], run: RunInfo) -> tuple[str, str]:
    """(vehicle, source): the log's id, else ``profile:NAME``, else ``unknown``."""
    if vehicle_id:
        return str(vehicle_id), source or "log"
    if run.profile_name:
        return f"profile:{run.profile_name}", "profile"
    return UNKNOWN_VEHICLE, "unknown"


def _is_locked(e: sqlite3.OperationalError) -> bool:
    msg = str(e).lower()
    return "locked" in msg or "busy" in msg


def _retrying(fn, what: str, path):
    """Run ``fn()`` (one transaction), retrying with backoff while the database is locked."""
    for attempt in range(MAX_RETRIES + 1):
        try:
            return fn()
        except sqlite3.Error as e:  # OperationalError (locked, disk full), DatabaseError (damaged file)...
            if not (isinstance(e, sqlite3.OperationalError) and _is_locked(e)) or attempt == MAX_RETRIES:
                raise StoreError(path, f"cannot {what}: {e}") from None
            time.sleep(RETRY_BASE_S * (2 ** attempt) * (0.5 + random.random()))


class ResultStore:
    """An open results store. ``create=True`` makes the file and schema when missing."""

    def __init__(self, path, create: bool = True):
        self.path = Path(path)
        if not create:
            check_store(self.path)
        elif self.path.is_dir():
            raise StoreError(self.path, "is a folder, not a database file")
        try:
            # isolation_level=None: we issue BEGIN IMMEDIATE / COMMIT ourselves.
            self.conn = sqlite3.connect(str(self.path), timeout=BUSY_TIMEOUT_S, isolation_level=None)
            self.conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
            self.conn.execute("PRAGMA foreign_keys = ON")
        except sqlite3.Error as e:
            raise StoreError(self.path, f"cannot open the database: {e}") from None
        if create:
            _retrying(self._init_schema, "create the schema", self.path)

    def _init_schema(self) -> None:
        from . import __version__

        c = self.conn
        try:
            mode = c.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        except sqlite3.DatabaseError as e:
            if isinstance(e, sqlite3.OperationalError) and _is_locked(e):
                raise
            raise StoreError(self.path, f"not an fdlog results database ({e})") from None
        if str(mode).lower() != "wal":
            raise StoreError(self.path, f"cannot switch the database to WAL journal mode (got {mode})")
        c.execute("BEGIN IMMEDIATE")
        try:
            version = c.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if (version not in (0, SCHEMA_VERSION, *UPGRADABLE_VERSIONS)
                    or (version == 0 and tables and "schema_version" not in tables)):
                raise StoreError(self.path, "not an fdlog results database (other tables or schema version "
                                            f"{version}; fdlog writes version {SCHEMA_VERSION})")
            for stmt in filter(str.strip, SCHEMA.split(";")):
                c.execute(stmt)
            if not c.execute("SELECT 1 FROM schema_version").fetchone():
                c.execute("INSERT INTO schema_version VALUES (?, ?)", (SCHEMA_VERSION, __version__))
            else:  # an upgraded store (the CREATE statements above added what it lacked)
                c.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION,))
            c.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
            c.execute("COMMIT")
        except BaseException:
            c.execute("ROLLBACK")
            raise

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> "ResultStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def add(self, result: Any, run: RunInfo, diagnosed_at: Optional[str] = None) -> Optional[int]:
        """Write one :class:`~flightlog_fd.batch.LogResult` (one transaction); returns its row id,
        or None for a file that could not even be read (no sha256 to key it on)."""
        if not result.log_sha256:
            return None
        d = result.diagnosis
        v = d.verdict
        vehicle, vsource = vehicle_identity(result.vehicle_id, result.vehicle_id_source, run)
        facts = d.facts
        row = {
            "log_path": str(result.path), "log_sha256": result.log_sha256, "vehicle": vehicle,
            "vehicle_source": vsource, "autopilot": facts.autopilot if facts else None,
            "flight_start_utc": _utc_iso(result.utc_start),
            "log_t_start_s": facts.t_start if facts else None,
            "airborne_s": facts.airborne_s if facts else None,
            "status": v.status, "motor": v.motor, "confidence": _num(v.confidence), "reason": v.reason,
            "exit_code": d.exit_code,
            "model_version": d.model.version if d.model else run.model_version,
            "model_sha256": run.model_sha256, "profile_path": run.profile_path,
            "profile_sha256": run.profile_sha256, "tool_version": run.tool_version,
            "diagnosed_at": diagnosed_at or datetime.now(timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z"),
        }
        motors = motor_figures(d, result.command_share)
        cols = ", ".join(row)
        marks = ", ".join(f":{k}" for k in row)
        updates = ", ".join(f"{k} = excluded.{k}" for k in row if k not in ("log_sha256", "model_sha256", "profile_sha256"))
        sql = (f"INSERT INTO diagnosis ({cols}) VALUES ({marks}) ON CONFLICT (log_sha256, model_sha256, "
               f"profile_sha256) DO UPDATE SET {updates} RETURNING id")
        mcols = ("diagnosis_id", "motor") + MOTOR_FIELDS
        msql = f"INSERT INTO motor_figure ({', '.join(mcols)}) VALUES ({', '.join('?' * len(mcols))})"
        findings = [f for r in (d.decision.results if getattr(d, "decision", None) is not None else [])
                    for f in r.findings]
        fsql = ("INSERT OR REPLACE INTO finding (diagnosis_id, analyzer, motor, name, value, unit, lo, hi, baseline, "
                "direction, llr) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")

        def write() -> int:
            c = self.conn
            c.execute("BEGIN IMMEDIATE")
            try:
                rid = c.execute(sql, row).fetchone()[0]
                c.execute("DELETE FROM motor_figure WHERE diagnosis_id = ?", (rid,))
                c.executemany(msql, [(rid, m["motor"], *(m.get(k) for k in MOTOR_FIELDS)) for m in motors])
                c.execute("DELETE FROM finding WHERE diagnosis_id = ?", (rid,))
                c.executemany(fsql, [(rid, f.analyzer, f.motor, f.name, _num(f.value), f.unit,
                                      _num(f.interval[0]) if f.interval else None,
                                      _num(f.interval[1]) if f.interval else None, _num(f.baseline), f.direction,
                                      _num(f.llr)) for f in findings])
                c.execute("COMMIT")
                return int(rid)
            except BaseException:
                c.execute("ROLLBACK")
                raise

        return _retrying(write, f"write the diagnosis of {result.path}", self.path)


# ----------------------------------------------------------------------------- reading

def check_store(path) -> None:
    """Raise StoreError unless ``path`` is an fdlog results database of this schema version."""
    p = Path(path)
    if not p.exists():
        raise StoreError(p, "no such database")
    if p.is_dir():
        raise StoreError(p, "is a folder, not a database file")
    try:
        conn = sqlite3.connect(f"file:{p}?mode=ro", uri=True, timeout=BUSY_TIMEOUT_S)
        try:
            version = conn.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            conn.close()
    except sqlite3.DatabaseError as e:
        raise StoreError(p, f"not an fdlog results database ({e})") from None
    if not {"schema_version", "diagnosis", "motor_figure"} <= tables:
        raise StoreError(p, "not an fdlog results database (no fdlog tables)")
    if version not in (SCHEMA_VERSION, *UPGRADABLE_VERSIONS):
        raise StoreError(p, f"results database schema version {version}, this fdlog reads {SCHEMA_VERSION}")


def load_findings(path, diagnosis_id: int) -> list[dict]:
    """One diagnosis's findings as stored (analyzer, motor, name, value, unit, lo, hi, baseline,
    direction, llr); [] for a version-1 store, which has none."""
    check_store(path)
    conn = sqlite3.connect(f"file:{Path(path)}?mode=ro", uri=True, timeout=BUSY_TIMEOUT_S)
    conn.row_factory = sqlite3.Row
    try:
        if not conn.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'finding'").fetchone():
            return []
        return [dict(r) for r in conn.execute(
            "SELECT analyzer, motor, name, value, unit, lo, hi, baseline, direction, llr FROM finding "
            "WHERE diagnosis_id = ? ORDER BY rowid", (diagnosis_id,))]
    finally:
        conn.close()


@dataclass
class FlightRecord:
    """One flight of an airframe as history shows it (the latest diagnosis of that log)."""

    id: int
    log_path: str
    log_sha256: str
    flight_start_utc: Optional[str]
    airborne_s: Optional[float]
    status: str
    motor: Optional[int]
    confidence: Optional[float]
    reason: str
    diagnosed_at: str
    vehicle_source: str
    motors: dict[int, dict] = field(default_factory=dict)  # motor -> figures

    def figure(self, name: str) -> Optional[list[float]]:
        """Every motor's value of ``name`` (motor order), or None unless all are known."""
        vals = [self.motors.get(k, {}).get(name) for k in sorted(self.motors) or range(1, 5)]
        return [float(v) for v in vals] if all(v is not None for v in vals) else None


def load_history(path, vehicle: Optional[str] = None) -> dict[str, list[FlightRecord]]:
    """vehicle -> its flights in time order (UTC start; those without it after, by file name)."""
    check_store(path)
    conn = sqlite3.connect(f"file:{Path(path)}?mode=ro", uri=True, timeout=BUSY_TIMEOUT_S)
    conn.row_factory = sqlite3.Row
    try:
        where, args = ("WHERE vehicle = ?", (vehicle,)) if vehicle is not None else ("", ())
        rows = conn.execute(
            f"SELECT * FROM diagnosis {where} ORDER BY vehicle, flight_start_utc IS NULL, flight_start_utc, "
            f"log_path, diagnosed_at DESC, id DESC", args).fetchall()
        figs: dict[int, dict[int, dict]] = {}
        for m in conn.execute("SELECT * FROM motor_figure"):
            figs.setdefault(m["diagnosis_id"], {})[m["motor"]] = {k: m[k] for k in MOTOR_FIELDS}
    finally:
        conn.close()
    out: dict[str, list[FlightRecord]] = {}
    seen: set[tuple[str, str]] = set()
    for r in rows:
        if (r["vehicle"], r["log_sha256"]) in seen:  # same log judged by another model/profile: latest wins
            continue
        seen.add((r["vehicle"], r["log_sha256"]))
        out.setdefault(r["vehicle"], []).append(FlightRecord(
            id=r["id"], log_path=r["log_path"], log_sha256=r["log_sha256"],
            flight_start_utc=r["flight_start_utc"], airborne_s=r["airborne_s"], status=r["status"],
            motor=r["motor"], confidence=r["confidence"], reason=r["reason"] or "",
            diagnosed_at=r["diagnosed_at"], vehicle_source=r["vehicle_source"], motors=figs.get(r["id"], {})))
    return out
