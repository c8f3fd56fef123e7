"""The results store: every diagnosis appended to one SQLite file, and per-airframe history.

``fdlog diagnose LOGS --db results.sqlite`` calls :meth:`ResultStore.add` for each log as its
result arrives (in the client process, also for Dask batches); ``fdlog history --db`` reads it
back (:func:`load_history`, :func:`find_drift`, :func:`render_html`). Standard library ``sqlite3``.

Schema (``SCHEMA_VERSION`` 1; kept in ``PRAGMA user_version`` and in the ``schema_version``
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

**Drift rule** (:func:`find_drift`), per airframe and figure, over its flights in time order (UTC
start; flights without GPS time follow, ordered by file name; one row per log, the latest
diagnosis): for each flight where all four motors have the figure, motor k's robust z-score
against the other three is ``z = (x_k - median(others)) / max(1.4826 * MAD(others), FLOOR)``.
A least-squares line of z over the flight index (0, 1, 2...) flags motor k when, with at least
``MIN_FLIGHTS`` flights, its slope in the figure's damage direction (model vote up, command share
up: a worn propeller needs more command, effectiveness down) is at least ``DRIFT_SLOPE_MIN`` z
per flight **and** the latest flight's z in that direction is at least ``DRIFT_Z_MIN``. A steady
offset (a motor that always needs 2 % more) has no slope and is not flagged. The ``unknown``
group (logs without identity) is not one airframe: no drift rule there. The floors keep three
nearly equal neighbours from turning noise into large z: ``FIGURE_FLOORS`` (command share 0.005,
i.e. half a percent of the total; model vote 0.05; effectiveness 0.02).
Not yet measured on a real fleet (no multi-flight airframe history in ../shared): the constants
are set from the simulator's spread and should be revisited on real data.
"""
from __future__ import annotations

import html
import json
import math
import random
import sqlite3
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable, Optional

from .errors import FlightLogError

SCHEMA_VERSION = 1
BUSY_TIMEOUT_S = 30.0
MAX_RETRIES = 10
RETRY_BASE_S = 0.05

UNKNOWN_VEHICLE = "unknown"
MIN_FLIGHTS = 3
DRIFT_SLOPE_MIN = 0.5  # robust z per flight, in the damage direction
DRIFT_Z_MIN = 2.0  # latest flight's robust z, in the damage direction
#: figure -> (damage direction, floor of the neighbours' spread)
FIGURE_FLOORS = {"model_vote": 0.05, "command_share": 0.005, "effectiveness": 0.02}
FIGURE_DIRECTION = {"model_vote": +1, "command_share": +1, "effectiveness": -1}
FIGURES = tuple(FIGURE_FLOORS)
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
        return [flight.frame.position(k) for k in range(1, 5)]
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
    out = []
    for k in range(1, 5):
        vote = None
        if windows:
            probs = [w.probabilities[k] for w in windows if len(w.probabilities) > k]
            vote = sum(probs) / len(probs) if probs else None
        out.append({"motor": k, "position": positions[k - 1],
                    "command_share": _num(command_share[k - 1]) if command_share else None,
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
            if version not in (0, SCHEMA_VERSION) or (version == 0 and tables and "schema_version" not in tables):
                raise StoreError(self.path, "not an fdlog results database (other tables or schema version "
                                            f"{version}; fdlog writes version {SCHEMA_VERSION})")
            for stmt in filter(str.strip, SCHEMA.split(";")):
                c.execute(stmt)
            if not c.execute("SELECT 1 FROM schema_version").fetchone():
                c.execute("INSERT INTO schema_version VALUES (?, ?)", (SCHEMA_VERSION, __version__))
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

        def write() -> int:
            c = self.conn
            c.execute("BEGIN IMMEDIATE")
            try:
                rid = c.execute(sql, row).fetchone()[0]
                c.execute("DELETE FROM motor_figure WHERE diagnosis_id = ?", (rid,))
                c.executemany(msql, [(rid, m["motor"], *(m.get(k) for k in MOTOR_FIELDS)) for m in motors])
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
    if version != SCHEMA_VERSION:
        raise StoreError(p, f"results database schema version {version}, this fdlog reads {SCHEMA_VERSION}")


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
        """The four motors' values of ``name``, or None unless all four are known."""
        vals = [self.motors.get(k, {}).get(name) for k in range(1, 5)]
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


def robust_z(values: list[float], k: int, floor: float) -> float:
    """Motor k's (0-based) z-score against the median and MAD of the other three."""
    others = sorted(v for i, v in enumerate(values) if i != k)
    med = others[len(others) // 2] if len(others) % 2 else 0.5 * (others[len(others) // 2 - 1] + others[len(others) // 2])
    dev = sorted(abs(v - med) for v in others)
    mad = dev[len(dev) // 2] if len(dev) % 2 else 0.5 * (dev[len(dev) // 2 - 1] + dev[len(dev) // 2])
    return (values[k] - med) / max(1.4826 * mad, floor)


def _slope(y: list[float]) -> float:
    n = len(y)
    xm = (n - 1) / 2.0
    ym = sum(y) / n
    sxx = sum((i - xm) ** 2 for i in range(n))
    return sum((i - xm) * (v - ym) for i, v in enumerate(y)) / sxx


@dataclass
class Drift:
    """A motor whose figure moves away from the other three across an airframe's flights."""

    vehicle: str
    motor: int
    figure: str
    slope: float  # robust z per flight, signed as the figure
    latest_z: float
    n_flights: int

    def describe(self) -> str:
        return (f"motor {self.motor} {self.figure.replace('_', ' ')} drifts from the other three: "
                f"z {self.slope:+.2f} per flight over {self.n_flights} flights, latest z {self.latest_z:+.1f}")


def find_drift(vehicle: str, flights: list[FlightRecord]) -> list[Drift]:
    """The motors flagged by the drift rule of the module docstring."""
    out = []
    for name in FIGURES:
        series = [f.figure(name) for f in flights]
        series = [s for s in series if s is not None]
        if len(series) < MIN_FLIGHTS:
            continue
        sign = FIGURE_DIRECTION[name]
        for k in range(4):
            z = [robust_z(s, k, FIGURE_FLOORS[name]) for s in series]
            slope = _slope(z)
            if sign * slope >= DRIFT_SLOPE_MIN and sign * z[-1] >= DRIFT_Z_MIN:
                out.append(Drift(vehicle, k + 1, name, slope, z[-1], len(series)))
    return out


def history_summary(history: dict[str, list[FlightRecord]]) -> dict:
    """JSON-ready: per vehicle its flights, drifts and whether its latest flight is damaged.

    ``unknown`` (logs with no identity, no profile) is not one airframe: no drift there, and any
    damaged flight in it counts as a latest flight."""
    vehicles = []
    for vehicle, flights in history.items():
        drifts = find_drift(vehicle, flights) if vehicle != UNKNOWN_VEHICLE else []
        latest = flights[-1] if flights else None
        if vehicle == UNKNOWN_VEHICLE:
            latest = next((f for f in reversed(flights) if f.status == "damaged"), latest)
        vehicles.append({
            "vehicle": vehicle,
            "vehicle_source": latest.vehicle_source if latest else None,
            "flights": [{"log": f.log_path, "log_sha256": f.log_sha256, "flight_start_utc": f.flight_start_utc,
                         "airborne_s": f.airborne_s, "status": f.status, "motor": f.motor,
                         "confidence": f.confidence, "reason": f.reason, "diagnosed_at": f.diagnosed_at,
                         "motors": [{"motor": k, **f.motors[k]} for k in sorted(f.motors)]} for f in flights],
            "drift": [{"motor": d.motor, "figure": d.figure, "slope_z_per_flight": d.slope,
                       "latest_z": d.latest_z, "n_flights": d.n_flights, "text": d.describe()} for d in drifts],
            "latest_damaged": bool(latest and latest.status == "damaged"),
            "latest": None if latest is None else {"log": latest.log_path, "motor": latest.motor},
        })
    flagged = any(v["drift"] or v["latest_damaged"] for v in vehicles)
    return {"schema": 1, "rule": {"min_flights": MIN_FLIGHTS, "drift_slope_min": DRIFT_SLOPE_MIN,
                                  "drift_z_min": DRIFT_Z_MIN, "floors": FIGURE_FLOORS},
            "vehicles": vehicles, "flagged": flagged}


# ----------------------------------------------------------------------------- html

MOTOR_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd")


def _svg_trend(flights: list[dict], figure: str, width: int = 560, height: int = 180) -> str:
    """Inline SVG: each motor's ``figure`` over the flights (x = flight index)."""
    pts = {k: [] for k in range(1, 5)}
    for i, f in enumerate(flights):
        for m in f["motors"]:
            v = m.get(figure)
            if v is not None:
                pts[m["motor"]].append((i, float(v)))
    vals = [v for p in pts.values() for _, v in p]
    if not vals:
        return ""
    lo, hi = min(vals), max(vals)
    if hi - lo < 1e-9:
        lo, hi = lo - 0.5 * max(abs(lo), 1e-3), hi + 0.5 * max(abs(hi), 1e-3)
    pad_l, pad_r, pad_t, pad_b = 50, 90, 10, 28
    n = max(len(flights) - 1, 1)

    def xy(i: int, v: float) -> tuple[float, float]:
        x = pad_l + (width - pad_l - pad_r) * i / n
        y = pad_t + (height - pad_t - pad_b) * (1 - (v - lo) / (hi - lo))
        return x, y

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" role="img" '
             f'aria-label="{html.escape(figure)} per motor over flights">',
             f'<rect x="{pad_l}" y="{pad_t}" width="{width - pad_l - pad_r}" height="{height - pad_t - pad_b}" '
             f'fill="none" stroke="#bbb"/>',
             f'<text x="4" y="{pad_t + 10}" font-size="10">{hi:.3g}</text>',
             f'<text x="4" y="{height - pad_b}" font-size="10">{lo:.3g}</text>',
             f'<text x="{pad_l}" y="{height - 8}" font-size="10">flight 1</text>',
             f'<text x="{width - pad_r - 40}" y="{height - 8}" font-size="10">flight {len(flights)}</text>']
    for k, p in pts.items():
        if not p:
            continue
        c = MOTOR_COLOURS[k - 1]
        coords = " ".join(f"{x:.1f},{y:.1f}" for x, y in (xy(i, v) for i, v in p))
        parts.append(f'<polyline points="{coords}" fill="none" stroke="{c}" stroke-width="1.5"/>')
        for i, v in p:
            x, y = xy(i, v)
            parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.5" fill="{c}"><title>motor {k}, flight {i + 1}: '
                         f'{v:.4g}</title></circle>')
        parts.append(f'<text x="{width - pad_r + 8}" y="{pad_t + 14 * k}" font-size="11" fill="{c}">motor {k}</text>')
    parts.append("</svg>")
    return "".join(parts)


def render_html(summary: dict) -> str:
    """A small self-contained page: per airframe its flights, flags and trend plots (inline SVG)."""
    e = html.escape
    out = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>fdlog fleet history</title>",
           "<style>body{font-family:sans-serif;margin:2em;max-width:1000px}table{border-collapse:collapse}"
           "td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}.flag{color:#b00;font-weight:bold}</style>",
           "</head><body><h1>fdlog fleet history</h1>",
           f"<p>Drift rule: at least {MIN_FLIGHTS} flights; robust z of a motor's figure against the other three, "
           f"least-squares slope &ge; {DRIFT_SLOPE_MIN} z per flight in the damage direction and latest z "
           f"&ge; {DRIFT_Z_MIN}.</p>"]
    for v in summary["vehicles"]:
        out.append(f"<h2>{e(v['vehicle'])} <small>({e(str(v['vehicle_source']))}, {len(v['flights'])} flights)</small></h2>")
        for d in v["drift"]:
            out.append(f"<p class='flag'>{e(d['text'])}</p>")
        if v["latest_damaged"]:
            f = v["latest"]
            out.append(f"<p class='flag'>latest flight: propeller {f['motor']} damaged ({e(f['log'])})</p>")
        out.append("<table><tr><th>#</th><th>start (UTC)</th><th>log</th><th>verdict</th><th>confidence</th>"
                   + "".join(f"<th>m{k} vote / share</th>" for k in range(1, 5)) + "</tr>")
        for i, f in enumerate(v["flights"], 1):
            verdict = f["status"] + (f" (motor {f['motor']})" if f["motor"] else "")
            cells = []
            by_motor = {m["motor"]: m for m in f["motors"]}
            for k in range(1, 5):
                m = by_motor.get(k, {})
                cells.append(f"<td>{_fmt(m.get('model_vote'))} / {_fmt(m.get('command_share'))}</td>")
            out.append(f"<tr><td>{i}</td><td>{e(f['flight_start_utc'] or '-')}</td><td>{e(Path(f['log']).name)}</td>"
                       f"<td>{e(verdict)}</td><td>{_fmt(f['confidence'])}</td>{''.join(cells)}</tr>")
        out.append("</table>")
        for figure in FIGURES:
            svg = _svg_trend(v["flights"], figure)
            if svg:
                out.append(f"<h3>{e(figure.replace('_', ' '))}</h3>{svg}")
    out.append("</body></html>")
    return "\n".join(out)


def _fmt(x: Optional[float]) -> str:
    return "-" if x is None else f"{x:.3f}"


def iter_text_lines(summary: dict) -> Iterable[str]:
    """Plain-text history: per airframe its flights and each motor's figures, then flags."""
    for v in summary["vehicles"]:
        yield f"{v['vehicle']}  ({v['vehicle_source']}, {len(v['flights'])} flights)"
        yield f"  {'#':>3} {'start (UTC)':<24} {'verdict':<18} {'conf':>5}  " + "  ".join(
            f"m{k} vote/share" for k in range(1, 5)) + "  log"
        for i, f in enumerate(v["flights"], 1):
            verdict = f["status"] + (f" m{f['motor']}" if f["motor"] else "")
            by_motor = {m["motor"]: m for m in f["motors"]}
            figs = "  ".join(f"{_fmt(by_motor.get(k, {}).get('model_vote'))}/{_fmt(by_motor.get(k, {}).get('command_share'))}"
                             for k in range(1, 5))
            yield (f"  {i:>3} {(f['flight_start_utc'] or '-'):<24} {verdict:<18} {_fmt(f['confidence']):>5}  "
                   f"{figs}  {Path(f['log']).name}")
        for d in v["drift"]:
            yield f"  FLAG: {d['text']}"
        if v["latest_damaged"]:
            f = v["latest"]
            yield f"  FLAG: latest flight has propeller {f['motor']} damaged ({Path(f['log']).name})"
        yield ""


def summary_json(summary: dict) -> str:
    return json.dumps(summary, indent=2)
