"""One database layer for SQLite and PostgreSQL: connections, transactions, numbered migrations.

What: :func:`open_database` takes a SQLite path (the default kind) or a PostgreSQL URL
(``postgresql://user@host:port/db``) and returns a :class:`Database`. Callers write SQL once, in
the common subset of both dialects, with ``?`` placeholders; :meth:`Database.sql` turns ``?`` into
``%s`` for PostgreSQL and fills the few DDL words that differ (:data:`DDL_WORDS`: ``{pk}`` the
auto-numbered primary key, ``{real}`` a double). Rows come back as dicts.

Transactions: :meth:`Database.transaction` runs a function inside one transaction and retries it
with backoff when SQLite says ``database is locked`` or PostgreSQL reports a serialization failure
or deadlock (``MAX_RETRIES``). SQLite transactions start with ``BEGIN IMMEDIATE`` (the write lock
is taken at once, so a read-then-write inside one transaction is atomic); PostgreSQL ones are
READ COMMITTED, so code that must not race uses ``SELECT ... FOR UPDATE SKIP LOCKED`` or a
conditional ``UPDATE ... WHERE state = ...``.

Migrations: :meth:`Database.migrate` applies a list of ``(version, name, step)`` in order (``step``
is SQL, or a function of the Database for what SQL alone cannot say), in one transaction that
records each in ``schema_migrations``; concurrent processes starting at once take a lock first
(SQLite's write lock; ``pg_advisory_xact_lock`` on PostgreSQL), so each migration runs once. A
SQLite file also carries the version in ``PRAGMA user_version``. A database whose newest migration
is unknown to this code is refused (made by a newer fdlog). Connections are per thread (web server
threads and job threads each get their own).

Outages: when the store goes away (PostgreSQL stopped or restarted, the network cut, the SQLite
file moved away, its disk gone, or locked past every retry) a statement raises
:class:`StoreUnavailable`, never a raw driver error, and the thread's connection is dropped: the
next call opens a fresh one, so the store is used again as soon as it is back, without a restart.
A connection found dead when a statement or transaction starts (the server restarted while it was
idle) is replaced at once and the statement run on the new one; a connection lost inside a
transaction is not retried here (its COMMIT may or may not have landed): the caller decides, with
:func:`retry_while_unavailable` (bounded backoff). A SQLite connection is checked against the file
at its path on every use: a file moved away is an outage, a file replaced by another (a restored
backup) gets new connections, and a reconnect never creates an empty database where the file was.
:meth:`Database.outage` says whether the store is down now, since when and why.

Limits: SQLite needs a local file system (WAL); PostgreSQL needs ``psycopg`` (the ``[serve]``
extra) and is imported only when a URL is given.
"""
from __future__ import annotations

import os
import random
import re
import sqlite3
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Iterable, Optional, Sequence
from urllib.parse import quote

from .errors import FlightLogError

#: Seconds a SQLite connection waits for another writer's lock before reporting "locked".
BUSY_TIMEOUT_S = 30.0
#: Retries of one transaction on a lock / serialization failure, with backoff RETRY_BASE_S x 2^k.
MAX_RETRIES = 10
RETRY_BASE_S = 0.05
#: Key of the PostgreSQL advisory lock held while migrating (any fixed 64-bit number).
PG_MIGRATION_LOCK = 0x66646C6F67  # "fdlog"
#: Seconds after a failed PostgreSQL connection attempt during which other threads are told
#: "unavailable" at once instead of each trying again (a request during an outage answers at once,
#: not after ``connect_timeout``); shorter than the smallest retry delay, so no retry waits on it.
#: (SQLite needs none: the file's stat is the probe.)
RECONNECT_GAP_S = 0.25
#: Backoff of a caller waiting for the store to come back (:func:`retry_while_unavailable`): the
#: first retry after STORE_RETRY_MIN_S, doubling up to STORE_RETRY_MAX_S. The cap bounds how long a
#: worker may sleep after the store is back; 5 s is a small share of a PostgreSQL restart plus a
#: diagnosis (results/store_outage.md), and one connection attempt per worker every 5 s is no load.
STORE_RETRY_MIN_S = 0.5
STORE_RETRY_MAX_S = 5.0
#: SQLite errors that mean "the file cannot be reached now", not "this statement is wrong".
SQLITE_OUTAGE_WORDS = ("unable to open database file", "disk i/o error", "database is locked", "database is busy",
                       "readonly database")
#: PostgreSQL SQLSTATEs of a server going away: class 08 (connection exception), 57P01 admin
#: shutdown, 57P02 crash shutdown, 57P03 cannot connect now (starting up or shutting down).
PG_OUTAGE_STATES = ("57P01", "57P02", "57P03")
#: DDL words that differ between the dialects: {name: (sqlite, postgresql)}.
DDL_WORDS = {
    "pk": ("INTEGER PRIMARY KEY", "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY"),
    "real": ("REAL", "DOUBLE PRECISION"),
}


class DatabaseError(FlightLogError):
    """The database cannot be opened, is not ours, or a statement failed (one line)."""


class StoreUnavailable(DatabaseError):
    """The store cannot be reached now (server down, connection lost, file gone or locked): wait
    and try again; nothing about the data or the request is wrong."""


def retry_while_unavailable(fn: Callable[[], Any], stop: Optional[threading.Event] = None,
                            on_wait: Optional[Callable[[StoreUnavailable, float], None]] = None,
                            min_s: float = STORE_RETRY_MIN_S, max_s: float = STORE_RETRY_MAX_S) -> Any:
    """``fn()``, called again after a bounded, doubling delay for as long as it raises
    :class:`StoreUnavailable`. ``on_wait(error, delay)`` is told before each wait; a set ``stop``
    event ends the wait by raising the last StoreUnavailable."""
    delay = min_s
    while True:
        try:
            return fn()
        except StoreUnavailable as e:
            if stop is not None and stop.is_set():
                raise
            if on_wait is not None:
                on_wait(e, delay)
            if stop is not None:
                if stop.wait(delay):
                    raise
            else:
                time.sleep(delay)
            delay = min(max_s, delay * 2)


def utc_now() -> str:
    """ISO-8601 UTC with a Z, to the millisecond (sorts as text)."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def is_postgres_url(target: Any) -> bool:
    return isinstance(target, str) and re.match(r"^postgres(ql)?://", target) is not None


class Database:
    """A SQLite file or a PostgreSQL database behind one small API (see the module docstring)."""

    def __init__(self, target):
        self.target = str(target)
        self.dialect = "postgres" if is_postgres_url(target) else "sqlite"
        self._local = threading.local()
        self._all: list[Any] = []
        self._all_lock = threading.Lock()
        self._file_id: Optional[tuple[int, int]] = None  # SQLite: (device, inode) of the store file
        self._down: Optional[dict] = None  # the outage in progress: since, reason, last connect attempt
        if self.dialect == "postgres":
            try:
                import psycopg  # noqa: F401
            except ImportError:
                raise DatabaseError(None, "a PostgreSQL store needs psycopg: pip install 'flightlog-fd[serve]'") from None
        else:
            p = Path(self.target)
            if p.is_dir():
                raise DatabaseError(p, "is a folder, not a database file")
            if not p.parent.exists():
                raise DatabaseError(p, "its folder does not exist")
        self.conn()  # fail now, with one line, if it cannot be opened

    # -------------------------------------------------------------------- connections

    @property
    def where(self) -> str:
        """The target for messages, without a password."""
        return re.sub(r"://([^:@/]+):[^@/]*@", r"://\1:***@", self.target)

    def conn(self):
        """This thread's connection (opened on first use, replaced when found dead or, for
        SQLite, when the file at the path is not the one it was opened on). Raises
        :class:`StoreUnavailable` when the store cannot be reached."""
        c = getattr(self._local, "conn", None)
        if c is not None and getattr(self._local, "in_tx", False):
            return c  # a transaction ends on the connection it began on (its COMMIT decides)
        if self.dialect == "sqlite":
            fid = self._sqlite_file_id()
            if c is not None and getattr(self._local, "file_id", None) != fid:
                self._drop(c)  # the file was replaced: never write into the one moved away
                c = None
        if c is not None:
            if self.dialect == "postgres" and (c.closed or c.broken):
                self._drop(c)
            else:
                return c
        down = self._down
        if self.dialect == "postgres" and down is not None and time.monotonic() - down["tried"] < RECONNECT_GAP_S:
            raise StoreUnavailable(self.where, f"the store is unavailable: {down['reason']}")
        try:
            if self.dialect == "postgres":
                import psycopg
                from psycopg.rows import dict_row

                c = psycopg.connect(self.target, autocommit=True, row_factory=dict_row, connect_timeout=10)
            else:
                first = self._file_id is None
                # After the first open, never create: a missing file is an outage, not a new store.
                where = self.target if first else "file:" + quote(str(Path(self.target).resolve())) + "?mode=rw"
                c = sqlite3.connect(where, timeout=BUSY_TIMEOUT_S, isolation_level=None, check_same_thread=False,
                                    uri=not first)
                c.row_factory = sqlite3.Row
                c.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
                c.execute("PRAGMA foreign_keys = ON")
                mode = c.execute("PRAGMA journal_mode = WAL").fetchone()[0]
                if str(mode).lower() != "wal":
                    raise DatabaseError(self.where, f"cannot switch the database to WAL journal mode (got {mode})")
                fid = self._sqlite_file_id()
                self._file_id = fid
                self._local.file_id = fid
        except DatabaseError:
            raise
        except Exception as e:  # sqlite3.Error, psycopg.Error: one line, never a traceback
            if self._file_id is not None or self.dialect == "postgres" and self._ever_connected:
                raise self._outage(e) from None
            raise DatabaseError(self.where, f"cannot open the database: {_first_line(e)}") from None
        self._ever_connected = True
        self._local.conn = c
        with self._all_lock:
            self._all.append(c)
        return c

    _ever_connected = False

    def _sqlite_file_id(self) -> Optional[tuple[int, int]]:
        """(device, inode) of the file at the store's path; StoreUnavailable once the store was
        opened and the file is gone (moved away, its disk unmounted)."""
        try:
            st = os.stat(self.target)
        except OSError as e:
            if self._file_id is None:
                return None  # not created yet: the first open makes it
            self._note_down(f"the database file cannot be reached ({e.strerror or e})")
            raise StoreUnavailable(self.where, f"the store is unavailable: {self._down['reason']}") from None
        return (st.st_dev, st.st_ino)

    def _drop(self, c) -> None:
        """Forget (and close) this thread's connection ``c``."""
        if getattr(self._local, "conn", None) is c:
            self._local.conn = None
            self._local.file_id = None
        with self._all_lock:
            if c in self._all:
                self._all.remove(c)
        try:
            c.close()
        except Exception:
            pass

    def _note_down(self, reason: str) -> None:
        now = time.monotonic()
        if self._down is None:
            self._down = {"since": now, "since_utc": utc_now(), "reason": reason, "tried": now}
        else:
            self._down.update(reason=reason, tried=now)

    def _outage(self, e: BaseException) -> StoreUnavailable:
        self._note_down(_first_line(e))
        return StoreUnavailable(self.where, f"the store is unavailable: {self._down['reason']}")

    def _up(self) -> None:
        if self._down is not None:
            self._down = None

    def outage(self) -> Optional[dict]:
        """None while the store answers; else {"since_utc", "down_s", "reason"} of the outage."""
        d = self._down
        if d is None:
            return None
        return {"since_utc": d["since_utc"], "down_s": round(time.monotonic() - d["since"], 1), "reason": d["reason"]}

    def is_outage(self, e: BaseException, c: Any = None) -> bool:
        """Does the driver error ``e`` (on connection ``c``) mean the store cannot be reached?"""
        if isinstance(e, StoreUnavailable):
            return True
        if isinstance(e, sqlite3.Error):
            msg = str(e).lower()
            return isinstance(e, sqlite3.OperationalError) and any(w in msg for w in SQLITE_OUTAGE_WORDS)
        if self.dialect != "postgres":
            return False
        import psycopg

        if not isinstance(e, (psycopg.OperationalError, psycopg.InterfaceError)):
            return False
        state = getattr(e, "sqlstate", None) or ""
        return (c is None or c.closed or c.broken or state.startswith("08") or state in PG_OUTAGE_STATES
                or getattr(e, "sqlstate", None) is None)

    def close(self) -> None:
        """Close every thread's connection."""
        with self._all_lock:
            for c in self._all:
                try:
                    c.close()
                except Exception:
                    pass
            self._all.clear()
        self._local = threading.local()

    # -------------------------------------------------------------------- statements

    def sql(self, text: str) -> str:
        """``text`` in this dialect: DDL words filled, ``?`` -> ``%s`` for PostgreSQL."""
        i = 0 if self.dialect == "sqlite" else 1
        for k, v in DDL_WORDS.items():
            text = text.replace("{" + k + "}", v[i])
        if self.dialect == "postgres":
            text = text.replace("%", "%%").replace("?", "%s")
        return text

    def _statement(self, fn: Callable[[Any], Any]) -> Any:
        """``fn(connection)`` for one statement. Outside a transaction, a connection found dead
        is replaced and the statement run once more on the new one; an outage raises
        :class:`StoreUnavailable`."""
        if getattr(self._local, "in_tx", False):
            return fn(self.conn())  # errors go to transaction(), which knows what was done
        for attempt in (0, 1):
            c = self.conn()
            try:
                out = fn(c)
            except Exception as e:
                if self._is_db_error(e) and self.is_outage(e, c):
                    stale = "locked" not in str(e) and "busy" not in str(e)
                    self._drop(c)
                    if attempt == 0 and stale:
                        continue
                    raise self._outage(e) from None
                raise
            self._up()
            return out

    def query(self, text: str, params: Sequence = ()) -> list[dict]:
        """Rows of one statement as dicts."""
        def go(c):
            cur = c.execute(self.sql(text), tuple(params))
            if cur.description is None:
                return []
            return [dict(r) for r in cur.fetchall()]

        return self._statement(go)

    def one(self, text: str, params: Sequence = ()) -> Optional[dict]:
        rows = self.query(text, params)
        return rows[0] if rows else None

    def run(self, text: str, params: Sequence = ()) -> int:
        """Execute one statement; returns the number of rows it changed."""
        return self._statement(lambda c: c.execute(self.sql(text), tuple(params)).rowcount)

    def run_many(self, text: str, rows: Iterable[Sequence]) -> None:
        rows = [tuple(r) for r in rows]

        def go(c):
            if self.dialect == "postgres":
                with c.cursor() as cur:
                    cur.executemany(self.sql(text), rows)
            else:
                c.executemany(self.sql(text), rows)

        self._statement(go)

    # -------------------------------------------------------------------- transactions

    def _retryable(self, e: Exception) -> bool:
        if self.dialect == "sqlite":
            msg = str(e).lower()
            return isinstance(e, sqlite3.OperationalError) and ("locked" in msg or "busy" in msg)
        import psycopg

        return isinstance(e, (psycopg.errors.SerializationFailure, psycopg.errors.DeadlockDetected))

    def _begin(self):
        """This thread's connection with a transaction begun on it. A connection that turns out
        dead at BEGIN (nothing done yet) is replaced once."""
        for attempt in (0, 1):
            c = self.conn()
            try:
                c.execute("BEGIN IMMEDIATE" if self.dialect == "sqlite" else "BEGIN")
                return c
            except Exception as e:
                if self._is_db_error(e) and self.is_outage(e, c) and "locked" not in str(e) and "busy" not in str(e):
                    self._drop(c)
                    if attempt == 0:
                        continue
                    raise self._outage(e) from None
                raise

    def transaction(self, fn: Callable[[], Any], what: str = "write the store") -> Any:
        """Run ``fn()`` in one transaction (retried on lock conflicts); returns what it returns.
        Raises :class:`StoreUnavailable` when the store goes away (module docstring)."""
        for attempt in range(MAX_RETRIES + 1):
            c = None
            try:
                c = self._begin()
                self._local.in_tx = True
                try:
                    out = fn()
                    c.execute("COMMIT")
                except BaseException:
                    try:
                        c.execute("ROLLBACK")
                    except Exception:
                        pass  # a lost connection has rolled back by itself
                    raise
                finally:
                    self._local.in_tx = False
                self._up()
                return out
            except FlightLogError:
                raise
            except Exception as e:
                if self._is_db_error(e) and self._retryable(e) and attempt < MAX_RETRIES:
                    time.sleep(RETRY_BASE_S * (2 ** attempt) * (0.5 + random.random()))
                    continue
                if self._is_db_error(e) and self.is_outage(e, c):
                    if c is not None and not ("locked" in str(e) or "busy" in str(e)):
                        self._drop(c)
                    self._note_down(_first_line(e))
                    raise StoreUnavailable(self.where, f"cannot {what}: the store is unavailable: "
                                                       f"{self._down['reason']}") from None
                if self._is_db_error(e):
                    raise DatabaseError(self.where, f"cannot {what}: {_first_line(e)}") from None
                raise

    def _is_db_error(self, e: Exception) -> bool:
        if isinstance(e, sqlite3.Error):
            return True
        if self.dialect == "postgres":
            import psycopg

            return isinstance(e, psycopg.Error)
        return False

    # -------------------------------------------------------------------- migrations

    def migrate(self, migrations: Sequence[tuple[int, str, Any]],
                adopt: Optional[Callable[[set], Optional[Callable[[], None]]]] = None) -> list[int]:
        """Apply the migrations not yet applied (in version order); returns their versions.

        ``adopt(tables)`` is asked about a SQLite file that holds tables but no migrations (one
        written before them): it may move its tables aside and return a function run after the
        migrations (to copy them in), or return None to refuse the file."""
        known = max(v for v, _, _ in migrations)

        def apply() -> list[int]:
            finish = None
            if self.dialect == "postgres":
                self.run("SELECT pg_advisory_xact_lock(?)", (PG_MIGRATION_LOCK,))
            else:
                tables = {r["name"] for r in self.query("SELECT name FROM sqlite_master WHERE type = 'table'")}
                if tables and "schema_migrations" not in tables:
                    finish = adopt(tables) if adopt is not None else None
                    if finish is None:
                        raise DatabaseError(self.where, "not an fdlog store (it holds other tables)")
            self.run("CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, "
                     "name TEXT NOT NULL, applied_at TEXT NOT NULL)")
            done = {int(r["version"]) for r in self.query("SELECT version FROM schema_migrations")}
            if done and max(done) > known:
                raise DatabaseError(self.where, f"store schema version {max(done)} is newer than this fdlog "
                                                f"({known}): upgrade fdlog")
            applied = []
            for version, name, text in sorted(migrations):
                if version in done:
                    continue
                if callable(text):
                    text(self)
                else:
                    for stmt in filter(str.strip, text.split(";")):
                        self.run(stmt)
                self.run("INSERT INTO schema_migrations (version, name, applied_at) VALUES (?, ?, ?)",
                         (version, name, utc_now()))
                applied.append(version)
            if finish is not None:
                finish()
            if applied and self.dialect == "sqlite":
                self.run(f"PRAGMA user_version = {int(max(applied))}")
            return applied

        return self.transaction(apply, "migrate the store's schema")

    def schema_version(self) -> int:
        row = self.one("SELECT MAX(version) AS v FROM schema_migrations")
        return int(row["v"] or 0) if row else 0


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0][:300]


def open_database(target) -> Database:
    """A :class:`Database` for a SQLite path or a ``postgresql://`` URL."""
    return Database(target)
