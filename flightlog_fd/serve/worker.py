"""Background jobs of `fdlog serve`: diagnose uploaded logs and calibrate airframes, from the store's queue.

What: :class:`JobRunner` runs ``workers`` slots (threads of the server). Each slot claims one job
at a time from the store (:meth:`~flightlog_fd.store.Store.claim_job`, atomic) and runs it in a worker process
of its own (a one-process ``ProcessPoolExecutor``, started with ``spawn``: never a fork of the
threaded web server), or on a Dask cluster with ``scheduler`` (``"local"`` or ``tcp://HOST:8786``,
as ``fdlog diagnose --scheduler``; its workers must see the data folder). The worker process
reads the stored log, diagnoses it (the airframe's profile when it has one), and writes the HTML
and CSV reports under ``DATA/reports``; the slot writes the result to the store, in the
transaction that marks the job done.

Failures: a log that cannot be read is a ``not_diagnosable`` flight like in ``fdlog diagnose``. A
worker process that dies on a log (segfault, ``os._exit``, out of memory) is known at once, since
the slot's process ran only that log: the job becomes an error row with that reason, and the slot
starts a fresh process. A job running longer than ``JOB_TIMEOUT_S`` (pyulog can spin on some
corrupt files) has its process killed and becomes an error row. Leases are renewed every
``LEASE_S / 3`` and expired ones recovered (:meth:`~flightlog_fd.store.Store.recover`), so a server that stops
leaves no stuck job for the next one; a server on this machine whose process is gone has its jobs
requeued at once (:func:`holder_is_dead`), without waiting for the lease.

The store going away (PostgreSQL restarted, the SQLite file unreachable) is not the log's fault:
a slot that meets :class:`~flightlog_fd.database.StoreUnavailable` waits with a bounded backoff
(:func:`~flightlog_fd.database.retry_while_unavailable`) and goes on where it was: a diagnosis
already made is kept in memory and written when the store is back, and no job is marked failed
for an outage. :meth:`JobRunner.status` tells each slot's state (idle, running a job, waiting for
the store since when and why) for the web page.
"""
from __future__ import annotations

import json
import os
import shutil
import socket
import threading
import time
import uuid
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any, Callable, Optional

from ..database import StoreUnavailable, retry_while_unavailable
from ..store import LEASE_S, Store, holder_is_dead

#: Seconds between queue polls of an idle slot (a new upload also wakes the slots at once).
POLL_S = 1.0
#: Longest one diagnosis may run before its process is killed (the 67 MB real log takes ~20 s).
JOB_TIMEOUT_S = 600.0
#: Longest a fresh worker process may take to start and load the model before its first job.
WARMUP_TIMEOUT_S = 300.0
#: Longest one calibration may run (adapting the model trains on ~192 simulated flights).
CALIBRATE_TIMEOUT_S = 3600.0
#: Points kept per plotted line on the flight page (min/max per bucket keeps spikes).
PLOT_POINTS = 1500
#: Decimals kept for plotted values and times (finer is invisible at page resolution).
PLOT_DECIMALS = 4
RAD_TO_DEG = 57.29577951308232

_CHILD_MODELS: dict[str, Any] = {}  # in a worker process: model path -> FaultModel


# ----------------------------------------------------------------------------- in the worker process

def _model_for(profile: Any):
    from ..diagnose import resolve_model
    from ..model import default_model_path

    key = str(profile.path) if profile is not None else str(default_model_path())
    if key not in _CHILD_MODELS:
        _CHILD_MODELS[key] = resolve_model(None, profile)
    return _CHILD_MODELS[key]


def _line(name: str, t, y) -> dict:
    import numpy as np

    from ..report.html_report import decimate

    ok = np.isfinite(y)
    tt, yy = decimate(np.asarray(t)[ok], np.asarray(y)[ok], PLOT_POINTS)
    return {"name": name, "t": [round(float(x), 3) for x in tt], "y": [round(float(v), PLOT_DECIMALS) for v in yy]}


def plot_series(flight, diagnosis: Any = None) -> dict:
    """Decimated angular rates (deg/s) and motor commands (0..1) of a flight, and its vibration
    (:func:`flightlog_fd.report.vibration_view.vibration_and_gaps`, with the diagnosis's
    reference), for the flight page; ``missing``: the streams not drawn and why
    (:func:`flightlog_fd.report.panels.missing_panels`)."""
    from ..report.panels import missing_panels
    from ..report.vibration_view import vibration_and_gaps

    out: dict[str, Any] = {"rates": [], "motors": [], "motor_kind": getattr(flight, "motor_kind", ""),
                           "vibration": None, "missing": []}
    if flight is None:
        return out
    vp, gaps = vibration_and_gaps(flight, diagnosis)
    if diagnosis is not None and getattr(diagnosis, "flight", None) is flight:
        out["missing"] = missing_panels(diagnosis, gaps)
    if vp is not None:
        out["vibration"] = vp.to_json(_line)
    if flight.rates is not None and len(flight.rates):
        for k, n in enumerate(("p (roll)", "q (pitch)", "r (yaw)")[: flight.rates.values.shape[1]]):
            out["rates"].append(_line(n, flight.rates.t, flight.rates.values[:, k] * RAD_TO_DEG))
    if flight.motors is not None and len(flight.motors):
        for k in range(flight.motors.values.shape[1]):
            pos = flight.frame.position(k + 1) if flight.frame is not None else None
            out["motors"].append(_line(f"motor {k + 1}" + (f" {pos}" if pos else ""), flight.motors.t,
                                       flight.motors.values[:, k]))
    return out


def diagnose_task(log_path: str, sha256: str, name: str, reports_dir: str, profiles: dict[str, str]) -> dict:
    """Diagnose one stored log (in a worker process); returns what the store keeps.

    ``name``: the client's file name, used as the report's ``log``; ``profiles``: airframe key ->
    profile path (the log's own id picks one). Writes ``reports_dir/<sha>.html`` and ``.csv``."""
    from .. import load_flight
    from ..diagnose import Diagnosis, diagnose_flight
    from ..errors import FlightLogError
    from ..profile import Profile
    from ..util import file_sha256
    from ..decision import not_diagnosable

    flight = None
    prof_sha = ""
    try:
        flight = load_flight(log_path)
        flight.path = name
        ppath = profiles.get(flight.vehicle_id) if flight.vehicle_id else None
        prof = Profile.load(ppath) if ppath else None
        prof_sha = file_sha256(ppath) if ppath else ""
        d = diagnose_flight(flight, _model_for(prof), prof, keep_flight=True)
    except FlightLogError as e:
        d = Diagnosis(log=name, verdict=not_diagnosable(e.message))
    return task_result(d, flight, sha256, name, reports_dir, prof_sha)


def task_result(d: Any, flight: Any, sha256: str, name: str, reports_dir: str, prof_sha: str = "") -> dict:
    """What the store keeps of one diagnosis ``d`` of ``flight`` (None when it could not be read),
    named ``name``: writes ``reports_dir/<sha>.html`` and ``.csv``; a report that cannot be drawn
    costs that file and a warning on the flight's page, never the diagnosis. The tests feed it a
    diagnosis made once (every log of ../shared through the flight page)."""
    from ..report.csv_report import render_csv
    from ..report.html_report import render_html
    from ..report.json_report import to_dict
    from ..report.terminal import verdict_sentence
    from ..store import utc_iso

    d.log = name
    if d.facts is not None:
        d.facts.path = name
    rd = Path(reports_dir)
    rd.mkdir(parents=True, exist_ok=True)
    for ext, render in (("html", render_html), ("csv", render_csv)):
        try:
            text = render(d)
        except Exception as e:  # a report's bug costs that file, said on the flight's page, not the diagnosis
            first = (str(e).strip().splitlines() or [""])[0][:200]
            d.warnings.append(f"the {ext.upper()} report could not be drawn ({type(e).__name__}: {first})")
            continue
        tmp = rd / f"{sha256}.{ext}.{os.getpid()}.part"
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, rd / f"{sha256}.{ext}")
    return {"sha256": sha256, "diagnosis": to_dict(d), "sentence": verdict_sentence(d),
            "vehicle": flight.vehicle_id if flight is not None else None,
            "vehicle_source": (flight.vehicle_id_source or "log") if flight is not None else None,
            "flight_start_utc": utc_iso(flight.utc_start) if flight is not None else None,
            "log_t_start_s": flight.t_start if flight is not None else None,
            "profile_sha256": prof_sha, "plot": plot_series(flight, d)}


def calibrate_task(log_paths: list[str], out_path: str, adapt: bool, add_to: Optional[str] = None) -> str:
    """Calibrate a profile from healthy logs, one session each (in a worker process); returns its
    sha256. ``adapt`` also adapts the model (needs torch, minutes); else only measures
    (``--no-adapt``). ``add_to``: an existing profile the logs are added to as new sessions
    (:func:`flightlog_fd.calibration.add_sessions`, its model kept); ``out_path`` is then a copy of
    it with the sessions added, in the same folder (the earlier file stays as it was)."""
    from ..calibration import add_sessions, calibrate
    from ..util import file_sha256

    if add_to:
        src, out = Path(add_to), Path(out_path)
        if src.resolve().parent != out.resolve().parent:
            raise ValueError("a profile with sessions added is written beside the one it extends")
        tmp = out.with_name(out.name + ".part")
        shutil.copyfile(src, tmp)
        try:
            add_sessions(tmp, [Path(p) for p in log_paths], keep_previous=False)
            os.replace(tmp, out)
        finally:
            tmp.unlink(missing_ok=True)
    else:
        calibrate([Path(p) for p in log_paths], adapt=adapt, output=Path(out_path), overwrite=True)
    return file_sha256(out_path)


def warm_child() -> bool:
    """Run first in a fresh worker process: imports and the shipped model load here, so that a
    job's time limit measures the job, not the process start (seconds on a busy machine)."""
    try:
        _model_for(None)
    except Exception:
        pass  # the job itself reports a missing or broken model
    return True


def _init_child() -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        import torch  # noqa: F401  (only when installed; calibration trains with one thread)

        torch.set_num_threads(1)
    except Exception:
        pass


# ----------------------------------------------------------------------------- in the server

class DataDir:
    """The server's data folder: logs by content hash, reports, profiles, temporary uploads."""

    def __init__(self, root):
        self.root = Path(root).resolve()
        for sub in ("logs", "reports", "profiles", "tmp"):
            (self.root / sub).mkdir(parents=True, exist_ok=True)

    def log_path(self, sha256: str, fmt: str) -> Path:
        return self.root / "logs" / sha256[:2] / f"{sha256}{'.ulg' if fmt == 'ulog' else '.bin'}"

    def report_path(self, sha256: str, ext: str) -> Path:
        return self.root / "reports" / f"{sha256}.{ext}"


def _error_doc(name: str, reason: str) -> str:
    from ..batch import error_result
    from ..report.json_report import to_dict

    return json.dumps(to_dict(error_result(0, name, reason).diagnosis))


class JobRunner:
    """Runs the store's queued jobs in ``workers`` slots until :meth:`stop` (module docstring)."""

    def __init__(self, store: Store, data: DataDir, *, workers: int = 1, scheduler: Optional[str] = None,
                 diagnose_fn: Callable = diagnose_task, calibrate_fn: Callable = calibrate_task,
                 poll_s: float = POLL_S, job_timeout_s: float = JOB_TIMEOUT_S, name: Optional[str] = None):
        self.store, self.data = store, data
        self.workers = max(0, int(workers))
        self.scheduler = scheduler
        self.diagnose_fn, self.calibrate_fn = diagnose_fn, calibrate_fn
        self.poll_s, self.job_timeout_s = poll_s, job_timeout_s
        self.worker_id = name or f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._threads: list[threading.Thread] = []
        self._running: set[int] = set()
        self._busy_slots: set[int] = set()
        self._lock = threading.Lock()
        self._pools: dict[int, Optional[ProcessPoolExecutor]] = {}
        self._client = self._cluster = None
        self._states: dict[int, dict] = {}

    # ------------------------------------------------------------------ state

    def _set_state(self, i: int, state: str, **kw) -> None:
        with self._lock:
            self._states[i] = {"slot": i, "state": state, "since": time.time(), **kw}

    def status(self) -> list[dict]:
        """Each slot's state now: ``state`` idle | running | waiting for the store | stopped, with
        ``job`` / ``name`` while running, ``reason`` and ``retry_s`` while waiting, ``for_s``."""
        now = time.time()
        with self._lock:
            out = [dict(v) for _, v in sorted(self._states.items())]
        for v in out:
            v["for_s"] = round(now - v.pop("since"), 1)
        return out

    def _store(self, i: int, fn: Callable[[], Any], job: Optional[dict] = None) -> Any:
        """``fn()`` (a store call), waiting while the store is unavailable; the slot's state says
        so meanwhile. Raises StoreUnavailable only when the runner is stopping."""
        held = self._states.get(i)

        def waiting(e: StoreUnavailable, delay: float) -> None:
            extra = {"job": int(job["id"])} if job else {}
            self._set_state(i, "waiting for the store", reason=e.message, retry_s=delay, **extra)

        out = retry_while_unavailable(fn, self._stop, waiting)
        if held is not None and self._states.get(i, {}).get("state") == "waiting for the store":
            with self._lock:
                self._states[i] = held
        return out

    # ------------------------------------------------------------------ control

    def start(self) -> "JobRunner":
        self.store.recover(is_dead=holder_is_dead)
        if self.scheduler and self.workers:
            from ..batch import _dask_client

            self._client, self._cluster = _dask_client(self.scheduler, self.workers if self.scheduler == "local" else None,
                                                       True)
        for i in range(self.workers):
            self._set_state(i, "idle")
            t = threading.Thread(target=self._slot, args=(i,), name=f"fdlog-job-{i}", daemon=True)
            t.start()
            self._threads.append(t)
        t = threading.Thread(target=self._lease_loop, name="fdlog-leases", daemon=True)
        t.start()
        self._threads.append(t)
        return self

    def wake(self) -> None:
        """A job was queued: idle slots look now instead of at their next poll."""
        self._wake.set()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop claiming; kill the worker processes that are busy (their jobs go back to the
        queue) and shut the idle ones down cleanly; join the threads."""
        self._stop.set()
        self._wake.set()
        with self._lock:
            busy = set(self._busy_slots)
        for i, pool in list(self._pools.items()):
            if pool is None:
                continue
            if i in busy:
                _kill(pool)
            else:
                pool.shutdown(wait=True, cancel_futures=True)
        for t in self._threads:
            t.join(timeout)
        try:
            self.store.release_jobs(self.worker_id)
        except Exception:
            pass  # their leases run out instead
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()

    def busy(self) -> int:
        with self._lock:
            return len(self._running)

    # ------------------------------------------------------------------ threads

    def _lease_loop(self) -> None:
        while not self._stop.wait(LEASE_S / 3):
            try:
                with self._lock:
                    ids = list(self._running)
                self.store.renew_leases(self.worker_id, ids)
                self.store.recover(is_dead=holder_is_dead)  # another server sharing the store may have stopped
            except Exception:
                pass  # the next round tries again; a lost lease only means another server may take the job

    def _slot(self, i: int) -> None:
        while not self._stop.is_set():
            try:
                job = self._store(i, lambda: self.store.claim_job(self.worker_id))
            except StoreUnavailable:
                break  # stopping while the store is away
            except Exception:
                job = None
            if job is None:
                self._set_state(i, "idle")
                self._wake.wait(self.poll_s)
                self._wake.clear()
                continue
            with self._lock:
                self._running.add(int(job["id"]))
                self._busy_slots.add(i)
            self._set_state(i, "running", job=int(job["id"]), kind=job["kind"])
            try:
                self._run(i, job)
            except StoreUnavailable:
                pass  # stopping while the store is away: the job's lease runs out, another server takes it
            finally:
                with self._lock:
                    self._running.discard(int(job["id"]))
                    self._busy_slots.discard(i)
        self._set_state(i, "stopped")

    def _submit(self, i: int, fn: Callable, *args):
        if self._client is not None:
            return self._client.submit(fn, *args, pure=False)
        pool = self._pools.get(i)
        if pool is None:
            import multiprocessing

            pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"),
                                       initializer=_init_child)
            self._pools[i] = pool
            try:
                pool.submit(warm_child).result(timeout=WARMUP_TIMEOUT_S)
            except Exception as e:  # not this log's fault: say so rather than blame it
                _kill(pool)
                self._pools[i] = None
                raise RuntimeError(f"could not start a worker process ({type(e).__name__})") from None
        return pool.submit(fn, *args)

    def _run(self, i: int, job: dict) -> None:
        """Run one claimed job. Every store call waits out an outage (:meth:`_store`): a result
        is never thrown away and a job never failed because the store was away."""
        if self._stop.is_set():
            return
        kind = job["kind"]
        name = f"job {job['id']}"
        store = self.store

        def fail(reason: str, doc: Optional[str] = None) -> None:
            self._store(i, lambda: store.fail_job(job, self.worker_id, reason, doc), job)

        try:
            if kind == "diagnose":
                f = self._store(i, lambda: store.flight(int(job["flight_id"])), job)
                profiles = self._store(i, store.profiles, job)
                name = f["name"]
                self._set_state(i, "running", job=int(job["id"]), kind=kind, name=name)
                fut = self._submit(i, self.diagnose_fn, str(self.data.log_path(f["sha256"], f["format"])),
                                   f["sha256"], f["name"], str(self.data.root / "reports"), profiles)
                res = fut.result(timeout=self.job_timeout_s)
                self._store(i, lambda: store.complete_diagnosis(job, self.worker_id, res), job)
            elif kind == "calibrate":
                args = json.loads(job["args"] or "{}")
                paths = []
                for fid in args.get("flights", []):
                    f = self._store(i, lambda: store.flight(int(fid)), job)
                    if f is not None:
                        paths.append(str(self.data.log_path(f["sha256"], f["format"])))
                out = self.data.root / "profiles" / f"profile-{int(job['id'])}.json"
                fut = self._submit(i, self.calibrate_fn, paths, str(out), bool(args.get("adapt")), args.get("add_to"))
                sha = fut.result(timeout=max(self.job_timeout_s, CALIBRATE_TIMEOUT_S))
                self._store(i, lambda: store.complete_calibration(job, self.worker_id, str(out), sha), job)
            else:
                fail(f"unknown job kind {kind!r}")
        except StoreUnavailable:
            raise
        except BrokenProcessPool:
            self._pools[i] = None
            if not self._stop.is_set():  # stopping kills the processes: those jobs go back to the queue
                fail("the worker process died while working on this log",
                     _error_doc(name, "the worker process died while diagnosing this log") if kind == "diagnose" else None)
        except FutureTimeout:
            pool = self._pools.pop(i, None)
            if pool is not None:
                _kill(pool)
            reason = f"took longer than {self.job_timeout_s:.0f} s: the worker was stopped"
            fail(reason, _error_doc(name, reason) if kind == "diagnose" else None)
        except Exception as e:
            if self._stop.is_set():
                return
            first = (str(e).strip().splitlines() or [""])[0][:200]
            reason = f"{'calibration' if kind == 'calibrate' else 'diagnosis'} failed: {type(e).__name__}: {first}"
            fail(reason, _error_doc(name, reason) if kind == "diagnose" else None)


def _kill(pool: ProcessPoolExecutor) -> None:
    """Kill a pool's worker process(es) now and let the pool go."""
    for p in list(getattr(pool, "_processes", {}).values()):
        try:
            p.kill()
        except Exception:
            pass
    try:
        pool.shutdown(wait=False, cancel_futures=True)
    except Exception:
        pass


def wait_idle(store: Store, timeout: float = 120.0, poll: float = 0.2) -> bool:
    """True once no job is queued or running (tests, the benchmark, `fdlog serve --exit-when-done`)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        c = store.job_counts()
        if c["queued"] == 0 and c["running"] == 0:
            return True
        time.sleep(poll)
    return False
