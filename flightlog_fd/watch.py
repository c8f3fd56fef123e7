"""Watch folders and diagnose every log that appears in them, once, into the store.

What: :class:`FolderWatch` finds the files in some folders (a ground station's download folder, a
fleet share), waits until each stops changing, and hands each log to a sink exactly once per
content: :class:`DiagnoseSink` diagnoses it here into the store (`fdlog watch DIR --db STORE`),
``serve.app.QueueSink`` queues it on the server's job queue (`fdlog serve --watch DIR`). The
store keys a log by its content hash (``flight.sha256``), so a log copied twice, renamed, or
seen again after a restart is one flight; the watcher remembers each file's size, modification
time and hash in the store (``watched_file``), so a restart does not read every file again.

Finding files: filesystem events (``watchdog``: inotify, FSEvents, ReadDirectoryChangesW) where
the folder is on a local disk and watchdog is installed, else polling every ``poll_s``; network
file systems (:data:`NETWORK_FS`: NFS, SMB/CIFS, sshfs...) deliver no events for changes made by
other machines, so they are always polled. In event mode the tree is still rescanned every
``RESCAN_S`` (an event queue that overflowed loses events). Idle CPU of each way:
results/watch.md (``benchmarks/bench_watch.py``).

When a file is ready: its size and modification time unchanged for ``settle_s`` of this
machine's clock (a download or copy in progress keeps changing them); files named like a
download in progress (:data:`PARTIAL_SUFFIXES`) or hidden are never read; a file that changed
while it was being hashed waits again. A writer that pauses longer than ``settle_s`` makes the
part written so far look complete: set ``settle_s`` above the longest pause of the writer.

Exactly once, several watchers, restarts: :meth:`~flightlog_fd.store.Store.claim_watched` makes a
new flight and a ``watch`` job held by this watcher in one transaction (leases as the server's
jobs: :mod:`flightlog_fd.store`); a watcher that stops mid-diagnosis leaves a lease that runs out
(at once when its process is gone from this machine) and the next watcher to see the file takes
the job again. A bad file (not decodable, not a flight) is one row with verdict
``not_diagnosable`` and its reason, as ``fdlog diagnose --db`` writes it; the watch goes on. A log
is diagnosed in a worker process with a time limit (``JOB_TIMEOUT_S``), so a file that hangs or
kills the reader costs its own row only. The store going away (PostgreSQL restarted, the SQLite
file unreachable) is waited out with a bounded backoff; a diagnosis made meanwhile is kept and
written when the store is back.
"""
from __future__ import annotations

import os
import socket
import stat as stat_mode
import threading
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from .database import StoreUnavailable, retry_while_unavailable
from .errors import FlightLogError, NotALogError
from .store import LEASE_S, RunInfo, Store, holder_is_dead

#: Seconds a file's size and modification time must stay unchanged before it is read. A ground
#: station writes a MAVLink log download as the chunks arrive and a copy to a share writes
#: continuously; 5 s covers a short stall of either and delays a verdict by as little.
SETTLE_S = 5.0
#: Seconds between scans where events are not delivered (network shares, no watchdog).
POLL_S = 2.0
#: Seconds between full rescans in event mode: a safety net for lost events (an inotify queue
#: that overflowed). One rescan of 20,000 files costs ~0.17 s of CPU here (results/watch.md), so
#: every 5 min is 0.06 % of a core, and a log whose event was lost waits at most that long.
RESCAN_S = 300.0
#: Longest one diagnosis may run before its worker process is killed and the log is an error
#: row: as the server's (serve.worker.JOB_TIMEOUT_S; the 67 MB real log takes ~20 s).
JOB_TIMEOUT_S = 600.0
#: Names of files still being downloaded or copied (browsers, rsync's temporary names are
#: hidden, ground stations and `fdlog pull` write NAME.part then rename).
PARTIAL_SUFFIXES = (".part", ".partial", ".tmp", ".temp", ".crdownload", ".download", ".swp", "~")
#: Extensions of flight logs: such a file that is not a log is a bad file (an error row); any
#: other file that is not a log (a README, a CSV) is passed over in silence.
LOG_SUFFIXES = (".ulg", ".bin", ".log", ".px4log")
#: File system types on which inotify sees no change made by another machine: polled.
NETWORK_FS = frozenset({"nfs", "nfs4", "cifs", "smb3", "smbfs", "9p", "afs", "ncpfs", "davfs", "fuse.sshfs",
                        "fuse.rclone", "fuse.s3fs", "fuse.gvfsd-fuse", "vboxsf", "glusterfs", "ceph", "fuse.ceph",
                        "lustre", "gpfs", "beegfs"})


@dataclass
class Found:
    """A log ready to be taken: where, its content hash and format, and what the watcher saw."""

    path: str
    sha256: str
    fmt: str  # ulog | dataflash | "" (a log-named file that is not a log)
    size: int
    mtime_ns: int
    problem: Optional[str] = None  # why it is not a log (then fmt is "")


def filesystem_type(folder: Path) -> Optional[str]:
    """The file system type of ``folder`` from /proc/self/mounts (Linux; None elsewhere)."""
    try:
        mounts = Path("/proc/self/mounts").read_text().splitlines()
    except OSError:
        return None
    real = str(Path(folder).resolve())
    best, kind = "", None
    for line in mounts:
        parts = line.split()
        if len(parts) < 3:
            continue
        mnt = parts[1].replace("\\040", " ")
        if (real == mnt or real.startswith(mnt.rstrip("/") + "/")) and len(mnt) >= len(best):
            best, kind = mnt, parts[2]
    return kind


def choose_mode(folder: Path, poll: bool = False) -> tuple[str, str]:
    """("events" | "poll", why) for one folder (module docstring)."""
    if poll:
        return "poll", "polling asked for"
    fs = filesystem_type(folder)
    if fs in NETWORK_FS:
        return "poll", f"a {fs} network share: no events for other machines' changes"
    try:
        import watchdog.observers  # noqa: F401
    except ImportError:
        return "poll", "watchdog is not installed (pip install 'flightlog-fd[watch]')"
    return "events", f"filesystem events ({fs or 'local'})"


def _candidate(name: str) -> bool:
    low = name.lower()
    return not name.startswith(".") and not low.endswith(PARTIAL_SUFFIXES)


class FolderWatch:
    """Find files in ``folders``, wait for each to settle, hand each content once to ``sink``.

    ``sink(found) -> (kind, text)``: what happened, for ``report(kind, path, text)`` (kind:
    "diagnosed", "known", "busy", "bad", "skip", "info", "waiting"). ``store``: where the
    files' hashes are remembered. Thread-safe :meth:`stop`."""

    def __init__(self, folders: Sequence, store: Store, sink: Callable[[Found], tuple[str, str]], *,
                 settle_s: float = SETTLE_S, poll_s: Optional[float] = None, rescan_s: float = RESCAN_S,
                 report: Optional[Callable[[str, str, str], None]] = None):
        self.folders = [Path(f).resolve() for f in folders]
        for f in self.folders:
            if not f.is_dir():
                raise FlightLogError(f, "no such folder")
        self.store, self.sink = store, sink
        self.settle_s, self.rescan_s = float(settle_s), float(rescan_s)
        self.modes = {f: choose_mode(f, poll=poll_s is not None) for f in self.folders}
        self.poll_s = float(poll_s) if poll_s is not None else POLL_S
        self.report = report or (lambda kind, path, text: None)
        self.host = socket.gethostname()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._dirty: set[str] = set()
        self._dirty_lock = threading.Lock()
        self._rescan_all = True
        self._observer = None
        self._seen: dict[str, tuple[int, int, float]] = {}  # path -> (size, mtime_ns, when it last changed)
        self._taken: dict[str, tuple[int, int]] = {}  # path -> (size, mtime_ns) handed over (or passed over)
        self._busy: dict[str, float] = {}  # path -> when to look again (another watcher holds it)
        self.counts = {"diagnosed": 0, "known": 0, "bad": 0}

    # ------------------------------------------------------------------ control

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()

    @property
    def stopping(self) -> threading.Event:
        return self._stop

    def _hidden(self, path: str) -> bool:
        """Inside a hidden folder of a watched folder (the scan skips those too)."""
        for f in self.folders:
            rel = os.path.relpath(path, f)
            if not rel.startswith(".."):
                return any(part.startswith(".") for part in Path(rel).parts[:-1])
        return False

    def _notify(self, path: str) -> None:
        if self._hidden(path):
            return
        with self._dirty_lock:
            self._dirty.add(path)
        self._wake.set()

    def _start_events(self) -> None:
        event_folders = [f for f, (m, _) in self.modes.items() if m == "events"]
        if not event_folders:
            return
        from watchdog.events import FileSystemEventHandler
        from watchdog.observers import Observer

        watch = self

        class Handler(FileSystemEventHandler):
            def on_any_event(self, event):
                if event.event_type in ("opened", "closed_no_write"):
                    return  # reads (our own hashing among them) change nothing
                if event.is_directory:
                    watch._rescan_all = True  # a folder moved in arrives as one event: look inside
                    watch._wake.set()
                    return
                for p in (event.src_path, getattr(event, "dest_path", "")):
                    if p:
                        watch._notify(os.fsdecode(p))

        observer = Observer()
        observer.daemon = True
        try:
            for f in event_folders:
                observer.schedule(Handler(), str(f), recursive=True)
            observer.start()
        except OSError as e:  # e.g. the inotify watch limit (fs.inotify.max_user_watches) reached
            for f in event_folders:
                self.modes[f] = ("poll", f"filesystem events failed ({e.strerror or e}): polling")
                self.report("info", str(f), self.modes[f][1])
            return
        self._observer = observer

    # ------------------------------------------------------------------ finding files

    def _scan(self) -> dict[str, tuple[int, int]]:
        out = {}
        for folder in self.folders:
            for root, dirs, files in os.walk(folder):
                dirs[:] = [d for d in dirs if not d.startswith(".")]
                for name in files:
                    if not _candidate(name):
                        continue
                    p = os.path.join(root, name)
                    st = self._stat(p)
                    if st is not None:
                        out[p] = st
        return out

    def _observe(self, path: str, stat: Optional[tuple[int, int]], now: float) -> None:
        if stat is None:
            self._seen.pop(path, None)
            self._taken.pop(path, None)
            return
        if self._taken.get(path) == stat:
            return
        prev = self._seen.get(path)
        if prev is None or prev[:2] != stat:
            self._seen[path] = (stat[0], stat[1], now)

    def _stat(self, path: str) -> Optional[tuple[int, int]]:
        if not _candidate(os.path.basename(path)):
            return None
        try:
            st = os.stat(path)
        except OSError:
            return None
        if not stat_mode.S_ISREG(st.st_mode):
            return None
        return (st.st_size, st.st_mtime_ns)

    def _ready(self, now: float) -> list[str]:
        return sorted(p for p, (size, _, changed) in self._seen.items()
                      if size > 0 and now - changed >= self.settle_s)

    # ------------------------------------------------------------------ taking a file

    def _store_call(self, fn: Callable[[], Any]) -> Any:
        def waiting(e: StoreUnavailable, delay: float) -> None:
            self.report("waiting", "", f"{e.message}; next try in {delay:.1f} s")

        return retry_while_unavailable(fn, self._stop, waiting)

    def _take(self, path: str) -> None:
        """Hash a settled file and hand it to the sink (or pass over it)."""
        from .logs import sniff_format
        from .util import file_sha256

        before = self._stat(path)
        if before is None:
            self._seen.pop(path, None)
            return
        size, mtime_ns = before
        try:
            fmt, problem = sniff_format(path), None
        except NotALogError as e:
            fmt, problem = "", e.message
        except OSError as e:
            self.report("skip", path, f"cannot read it: {e.strerror or e}")
            self._seen.pop(path, None)
            self._taken[path] = before
            return
        if problem is not None and not path.lower().endswith(LOG_SUFFIXES):
            self._seen.pop(path, None)  # a README or a CSV beside the logs: not ours
            self._taken[path] = before
            return
        sha = self._store_call(lambda: self.store.watched_sha(self.host, path, size, mtime_ns))
        if sha is None:
            try:
                sha = file_sha256(path)
            except OSError as e:
                self.report("skip", path, f"cannot read it: {e.strerror or e}")
                self._seen.pop(path, None)
                return
            if self._stat(path) != before:  # still being written after all: wait again
                self._seen[path] = (*(self._stat(path) or before), time.monotonic())
                return
        found = Found(path, sha, fmt, size, mtime_ns, problem)
        kind, text = self._store_call(lambda: self.sink(found))
        self._seen.pop(path, None)
        if kind == "busy":
            self._busy[path] = time.monotonic() + LEASE_S / 3
            self.report(kind, path, text)
            return
        self._store_call(lambda: self.store.remember_watched(self.host, path, size, mtime_ns, sha))
        self._taken[path] = before
        self._busy.pop(path, None)
        if kind in self.counts:
            self.counts[kind] += 1
        self.report(kind, path, text)

    # ------------------------------------------------------------------ the loop

    def run(self, once: bool = False) -> None:
        """Watch until :meth:`stop` (or, with ``once``, until every file found at start was taken)."""
        for f, (mode, why) in self.modes.items():
            self.report("info", str(f), f"watching ({why})")
        if not once:
            self._start_events()
        polled = any(m == "poll" for m, _ in self.modes.values())  # after _start_events: it may fall back
        next_scan = 0.0
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                if self._rescan_all or now >= next_scan:
                    self._rescan_all = False
                    found = self._scan()
                    for p in set(self._seen) | set(self._taken):
                        if p not in found:
                            self._observe(p, None, now)
                    for p, stat in found.items():
                        self._observe(p, stat, now)
                    next_scan = now + (self.poll_s if polled else self.rescan_s)
                with self._dirty_lock:
                    dirty, self._dirty = self._dirty, set()
                for p in dirty | set(self._seen):  # files in progress are looked at each round
                    self._observe(p, self._stat(p), now)
                for p, when in list(self._busy.items()):
                    if now >= when:
                        del self._busy[p]
                        self._taken.pop(p, None)
                        self._observe(p, self._stat(p), now - self.settle_s)
                for p in self._ready(time.monotonic()):
                    if self._stop.is_set():
                        break
                    self._take(p)
                if once and not self._seen:
                    return
                waits = [next_scan - time.monotonic()]
                if self._seen:
                    waits.append(min(c for _, _, c in self._seen.values()) + self.settle_s - time.monotonic())
                    waits.append(min(1.0, self.settle_s / 4))  # re-stat files in progress
                if self._busy:
                    waits.append(min(self._busy.values()) - time.monotonic())
                self._wake.wait(max(0.05, min(waits)))
                self._wake.clear()
        except StoreUnavailable:
            if not self._stop.is_set():
                raise
        finally:
            if self._observer is not None:
                self._observer.stop()
                self._observer.join(5)


class DiagnoseSink:
    """Diagnose each log here (in a worker process) into the store: `fdlog watch`.

    ``model`` / ``profile`` as ``fdlog diagnose``; ``stop``: an event that ends a wait for the
    store. Call :meth:`close` at the end (kills the worker process, hands a held job back)."""

    def __init__(self, store: Store, model: Any, profile: Any = None, *, job_timeout_s: float = JOB_TIMEOUT_S,
                 stop: Optional[threading.Event] = None):
        self.store, self.model, self.profile = store, model, profile
        self.run_info = RunInfo.for_batch(model, profile)
        self.job_timeout_s = job_timeout_s
        self.worker_id = f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self.stop = stop or threading.Event()
        self._pool = None
        self._held: Optional[int] = None
        self.exit_codes: list[int] = []  # of every log this sink diagnosed
        self._lease_stop = threading.Event()
        self._lease_thread = threading.Thread(target=self._lease_loop, name="fdlog-watch-leases", daemon=True)
        self._wait(lambda: store.recover(is_dead=holder_is_dead))
        self._lease_thread.start()

    def _wait(self, fn: Callable[[], Any]) -> Any:
        return retry_while_unavailable(fn, self.stop)

    def _lease_loop(self) -> None:
        while not self._lease_stop.wait(LEASE_S / 3):
            try:
                if self._held is not None:
                    self.store.renew_leases(self.worker_id, [self._held])
                self.store.recover(is_dead=holder_is_dead)  # a watcher or server that stopped
            except Exception:
                pass  # the next round tries again

    def _diagnose(self, path: str):
        """A LogResult for ``path`` from the worker process; an error row when the process dies
        or runs past the time limit."""
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures import TimeoutError as FutureTimeout
        from concurrent.futures.process import BrokenProcessPool

        from .batch import _init_pool_worker, _pool_task, error_result

        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"),
                                             initializer=_init_pool_worker,
                                             initargs=(str(self.model.path), self.profile))
        try:
            return self._pool.submit(_pool_task, 0, path, False).result(timeout=self.job_timeout_s)
        except FutureTimeout:
            self._kill()
            return error_result(0, path, f"took longer than {self.job_timeout_s:.0f} s: the diagnosis was stopped")
        except BrokenProcessPool:
            self._pool = None
            return error_result(0, path, "the worker process died while diagnosing this log")

    def _kill(self) -> None:
        pool, self._pool = self._pool, None
        if pool is None:
            return
        for p in list(getattr(pool, "_processes", {}).values()):
            try:
                p.kill()
            except Exception:
                pass
        pool.shutdown(wait=False, cancel_futures=True)

    def __call__(self, found: Found) -> tuple[str, str]:
        from .batch import error_result
        from .report.terminal import verdict_sentence

        size = found.size
        state, job = self._wait(lambda: self.store.claim_watched(found.sha256, found.path, size, found.fmt,
                                                                 self.worker_id))
        if state == "stored":
            return "known", "already in the store (the same bytes were diagnosed or uploaded before)"
        if state == "busy":
            return "busy", "another watcher is diagnosing the same bytes"
        self._held = int(job["id"])
        try:
            if found.problem is not None:
                result = error_result(0, found.path, found.problem)
                result.log_sha256 = found.sha256
            else:
                result = self._diagnose(found.path)
                result.log_sha256 = found.sha256  # the bytes that were claimed, hashed before reading
            stored = self._wait(lambda: self.store.complete_watched(job, self.worker_id, result, self.run_info))
        finally:
            self._held = None
        if not stored:  # our lease ran out during a long store outage and the job went back to the queue
            return "busy", "the job went back to the queue while the store was away: taking it again"
        d = result.diagnosis
        self.exit_codes.append(d.exit_code)
        if d.verdict.status == "not_diagnosable":
            return "bad", f"not diagnosable: {d.verdict.reason}"
        return "diagnosed", verdict_sentence(d)

    def close(self) -> None:
        self._lease_stop.set()
        self._kill()
        try:
            self.store.release_jobs(self.worker_id)
        except Exception:
            pass  # the lease runs out instead


__all__ = ["FolderWatch", "DiagnoseSink", "Found", "choose_mode", "filesystem_type", "SETTLE_S", "POLL_S",
           "RESCAN_S", "PARTIAL_SUFFIXES", "LOG_SUFFIXES", "NETWORK_FS"]
