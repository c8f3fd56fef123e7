"""Diagnose many logs: one pure-Python entry point, three engines.

:func:`run_batch` takes a list of log paths, the model and the optional calibration profile, and
returns one :class:`LogResult` per path **in input order**. Engines:

- ``serial`` (``jobs == 1``, no scheduler): in this process.
- ``processes`` (``jobs > 1``): a ``concurrent.futures.ProcessPoolExecutor`` whose initializer
  loads the model once per worker process (onnxruntime sessions cannot be pickled).
- ``dask`` (``scheduler`` given): ``"local"`` starts a ``LocalCluster`` here (``jobs`` workers,
  else the core count; processes, one thread each); any other value is the address of an existing
  scheduler (``tcp://HOST:8786``). The model file's bytes, its sha256 and the profile are
  scattered to every worker once (``broadcast=True``); each worker builds its onnxruntime session
  once per model sha256 and keeps it in :data:`_MODEL_CACHE`. Log paths are sent as absolute
  paths: the workers must see the same files (shared storage). ``dask`` is imported only here,
  only for this engine: ``fdlog diagnose`` without ``--scheduler`` never imports it.

Failure handling, the same in every engine: a log that cannot be read or diagnosed, an
unexpected exception in a parser, or a worker process that dies while diagnosing it becomes one
error row: a ``not_diagnosable`` Diagnosis with a one-line reason (exit code 2 for that log). The
rest of the batch goes on. A dead pool worker: the logs that were pending are retried, each in a
fresh one-process pool, so only the log that kills its worker is lost. A dead Dask worker: the
scheduler re-runs its tasks elsewhere and gives up on a task after
``distributed.scheduler.allowed-failures`` deaths (default 3), which becomes that log's error row.

``on_result(result)`` is called in this process as each log finishes (completion order): the CLI
moves its progress bar and writes the results store (:mod:`flightlog_fd.store`) from there, so
only the client ever writes the database, never a Dask worker.

Besides the Diagnosis, each worker returns what the results store needs from the Flight, which is
not sent back unless ``keep_flight``: the log's sha256, the vehicle identity, the UTC start time
and each motor's share of the summed thrust commands while airborne (:func:`airborne_shares`).

Measured (``benchmarks/bench_batch.py``, 94 diagnosable logs: sample_logs + ../shared, 2 shared
cores, load average ~4 from other users): ``--jobs 2`` 13.0 s = 7.3 logs/s; ``--scheduler local``
with 2 worker processes 19.6 s = 4.8 logs/s, of which ~1.7 s is starting the cluster; the rest is
Dask's per-task overhead and slower workers (summed per-log time 32.5 s against 25.5 s). On one
machine the process pool is faster; Dask is for spreading a fleet's logs over many machines.

Known limit: a per-log time limit is not enforced. pyulog 1.3.0 spins (minutes or more) on a
ULog whose header is followed by random bytes, and such a log holds its worker.
"""
from __future__ import annotations

import os
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

import numpy as np

from .diagnose import Diagnosis, diagnose_flight
from .errors import FlightLogError
from .decision import not_diagnosable

#: LocalCluster workers are processes (one thread each); tests may set False (threads start faster).
LOCAL_CLUSTER_PROCESSES = True


@dataclass
class LogResult:
    """One log's outcome: its Diagnosis plus the facts about the log the results store keeps.

    ``vehicle_id``/``vehicle_id_source`` come from the log (None when it carries none);
    ``utc_start`` is POSIX seconds at the log's ``t_start`` when the log has GPS time;
    ``command_share`` is each motor's mean share of the summed thrust commands while airborne
    (1.0 each when even: their mean is 1), None when the log has no usable motor outputs."""

    index: int
    path: str
    diagnosis: Diagnosis
    log_sha256: Optional[str] = None
    vehicle_id: Optional[str] = None
    vehicle_id_source: Optional[str] = None
    utc_start: Optional[float] = None
    command_share: Optional[list[float]] = None
    elapsed_s: float = 0.0


def _error_diagnosis(path: str, reason: str) -> Diagnosis:
    return Diagnosis(log=path, verdict=not_diagnosable(reason))


def error_result(index: int, path: str, reason: str) -> LogResult:
    """The error row of a log that could not be diagnosed at all (one line, exit code 2)."""
    return LogResult(index=index, path=path, diagnosis=_error_diagnosis(path, reason))


def airborne_shares(flight) -> Optional[list[float]]:
    """A quadrotor's airborne command shares for the results store when the diagnosis has none:
    each motor's mean thrust command (thrust proxy) while airborne over the mean of the four (1 =
    an even share, as :attr:`flightlog_fd.analyzers.share_fit.MotorShares.command_share`); None
    for other rotor counts or without usable motor outputs."""
    from .analyzers.share_fit import shares_of
    from .streams import flight_thrust_proxy

    m = flight.motors
    if m is None or m.values.shape[1] != 4 or len(m) == 0:
        return None
    try:
        thrust = flight_thrust_proxy(flight)
    except (FlightLogError, ValueError):
        return None
    mask = np.zeros(len(m), dtype=bool)
    for a, b in flight.airborne:
        mask |= (m.t >= a) & (m.t <= b)
    thrust = thrust[mask]
    thrust = thrust[np.all(np.isfinite(thrust), axis=1)]
    share, _ = shares_of([thrust])
    return [float(x) for x in share] if np.all(np.isfinite(share)) else None


#: Held while a Dask task reads a log: the ULog reader captures pyulog's prints with
#: ``contextlib.redirect_stdout``, which swaps the process-wide ``sys.stdout`` and is not
#: thread-safe (two threads interleaving it leave ``sys.stdout`` pointing at a dead buffer). Dask
#: workers may run several threads (``dask worker --nthreads N``, or ``processes=False``).
_READ_LOCK = threading.Lock()


def diagnose_one(index: int, path, model: Any, profile: Any = None, keep_flight: bool = False,
                 read_lock: Optional[Any] = None, prior: Optional[float] = None) -> LogResult:
    """Load and diagnose one log; never raises for a bad log (it becomes an error row).
    ``read_lock``: held while the log is read (threaded workers; see ``_READ_LOCK``); ``prior``: the
    prior of damage (None: the profile's or the decision's)."""
    import contextlib

    from . import load_flight
    from .util import file_sha256

    t0 = time.perf_counter()
    path = str(path)
    try:
        sha = file_sha256(path)
    except OSError:
        sha = None
    try:
        with read_lock if read_lock is not None else contextlib.nullcontext():
            flight = load_flight(path)
    except FlightLogError as e:
        return LogResult(index, path, _error_diagnosis(path, e.message), log_sha256=sha,
                         elapsed_s=time.perf_counter() - t0)
    except Exception as e:  # a parser bug must cost one row, not the batch
        return LogResult(index, path, _error_diagnosis(path, f"internal error reading the log: "
                                                             f"{type(e).__name__}: {str(e)[:200]}"),
                         log_sha256=sha, elapsed_s=time.perf_counter() - t0)
    try:
        d = diagnose_flight(flight, model, profile, keep_flight=keep_flight, prior=prior)
        # The per-motor evidence carries the command shares; measure them here only for a flight
        # that got none (not diagnosable), so the store still has a figure for it.
        share = None if d.motors else airborne_shares(flight)
    except Exception as e:
        d = _error_diagnosis(path, f"internal error diagnosing the log: {type(e).__name__}: {str(e)[:200]}")
        share = None
    return LogResult(index, path, d, log_sha256=sha, vehicle_id=flight.vehicle_id,
                     vehicle_id_source=getattr(flight, "vehicle_id_source", None) or None,
                     utc_start=getattr(flight, "utc_start", None), command_share=share,
                     elapsed_s=time.perf_counter() - t0)


# ----------------------------------------------------------------------------- process pool

_pool_state: dict = {}


def _init_pool_worker(model_path: str, profile: Any, prior: Optional[float] = None) -> None:
    """Pool initializer: build the onnxruntime session once per worker process."""
    from .model import FaultModel

    _pool_state.update(model=FaultModel(model_path), profile=profile, prior=prior)


def _pool_task(index: int, path: str, keep_flight: bool) -> LogResult:
    return diagnose_one(index, path, _pool_state["model"], _pool_state["profile"], keep_flight,
                        prior=_pool_state.get("prior"))


def _run_processes(files: list[str], model: Any, profile: Any, jobs: int, keep_flight: bool,
                   emit: Callable[[LogResult], None], prior: Optional[float] = None) -> None:
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    init = (str(model.path), profile, prior)
    broken: list[int] = []
    with ProcessPoolExecutor(max_workers=jobs, initializer=_init_pool_worker, initargs=init) as pool:
        futures = {pool.submit(_pool_task, i, f, keep_flight): i for i, f in enumerate(files)}
        for fut in as_completed(futures):
            i = futures[fut]
            try:
                emit(fut.result())
            except BrokenProcessPool:
                broken.append(i)
            except Exception as e:  # pickling trouble and the like: one row
                emit(error_result(i, files[i], f"worker failed: {type(e).__name__}: {str(e)[:200]}"))
    # A worker died: every pending log failed with it. Retry each alone, so only the culprit is lost.
    for i in sorted(broken):
        try:
            with ProcessPoolExecutor(max_workers=1, initializer=_init_pool_worker, initargs=init) as pool:
                emit(pool.submit(_pool_task, i, files[i], keep_flight).result())
        except BrokenProcessPool:
            emit(error_result(i, files[i], "the worker process died while diagnosing this log"))


# ----------------------------------------------------------------------------- dask

@dataclass
class ModelPayload:
    """What every Dask worker needs once: the model file's bytes and sha256, and the profile."""

    model_bytes: bytes
    model_sha256: str
    model_path: str
    profile: Any
    prior: Optional[float] = None


#: Per worker process: model sha256 -> FaultModel (one onnxruntime session per worker and model).
_MODEL_CACHE: dict[str, Any] = {}
_MODEL_CACHE_LOCK = threading.Lock()


def _cached_model(payload: ModelPayload):
    """The worker's FaultModel for this payload, built on first use. Uses the original file when
    this worker sees it with the same sha256, else writes the scattered bytes to a temp file."""
    from .model import FaultModel
    from .util import file_sha256

    with _MODEL_CACHE_LOCK:
        model = _MODEL_CACHE.get(payload.model_sha256)
        if model is not None:
            return model
        src = Path(payload.model_path)
        if not (src.is_file() and file_sha256(src) == payload.model_sha256):
            src = Path(tempfile.gettempdir()) / f"flightlog_fd-model-{payload.model_sha256}.onnx"
            if not (src.is_file() and file_sha256(src) == payload.model_sha256):
                tmp = src.with_suffix(f".{os.getpid()}.part")
                tmp.write_bytes(payload.model_bytes)
                os.replace(tmp, src)
        model = FaultModel(src)
        model._path = Path(payload.model_path)  # reports name the file the user chose, not the copy
        _MODEL_CACHE[payload.model_sha256] = model
        return model


def _dask_task(index: int, path: str, payload: ModelPayload, keep_flight: bool) -> LogResult:
    try:
        model = _cached_model(payload)
    except FlightLogError as e:
        return error_result(index, path, f"worker could not load the model: {e.message}")
    return diagnose_one(index, path, model, payload.profile, keep_flight, read_lock=_READ_LOCK,
                        prior=payload.prior)


def _dask_client(scheduler: str, jobs: Optional[int], processes: bool):
    """(client, cluster or None) for ``"local"`` or a scheduler address."""
    from dask.distributed import Client, LocalCluster

    if scheduler == "local":
        cluster = LocalCluster(n_workers=jobs or os.cpu_count() or 1, threads_per_worker=1,
                               processes=processes, dashboard_address=None)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout="10s"), None
    except (OSError, TimeoutError, ValueError) as e:
        raise FlightLogError(None, f"cannot reach the Dask scheduler at {scheduler}: {e}") from None


def _run_dask(files: list[str], model: Any, profile: Any, scheduler: str, jobs: Optional[int],
              keep_flight: bool, emit: Callable[[LogResult], None], processes: bool,
              prior: Optional[float] = None) -> None:
    import uuid

    from dask.distributed import as_completed

    client, cluster = _dask_client(scheduler, jobs, processes)
    try:
        payload = ModelPayload(Path(model.path).read_bytes(), str(model.sha256), str(model.path), profile, prior)
        scattered = client.scatter(payload, broadcast=True, hash=False)
        run = uuid.uuid4().hex[:8]
        futures = {client.submit(_dask_task, i, f, scattered, keep_flight, key=f"fdlog-{run}-{i}", pure=False): i
                   for i, f in enumerate(files)}
        failed: list[int] = []
        for fut in as_completed(list(futures)):
            i = futures[fut]
            try:
                emit(fut.result())
            except Exception:  # KilledWorker, lost connection...: which log did it is not known yet
                failed.append(i)
            fut.release()
        # A dying worker takes every task it held with it: retry those logs one at a time, so only
        # the log that kills its worker again becomes an error row (as the process pool does).
        for i in sorted(failed):
            payload_again = client.scatter(payload, broadcast=True, hash=False)
            fut = client.submit(_dask_task, i, files[i], payload_again, keep_flight, key=f"fdlog-{run}-{i}-retry",
                                pure=False)
            try:
                emit(fut.result())
            except Exception as e:
                first = (str(e).strip().splitlines() or [""])[0][:200]
                emit(error_result(i, files[i], f"Dask worker failed on this log: {type(e).__name__}: {first}"))
            fut.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ----------------------------------------------------------------------------- entry point

def engine_name(jobs: int, scheduler: Optional[str], n_files: int) -> str:
    if scheduler:
        return "dask"
    return "processes" if jobs > 1 and n_files > 1 else "serial"


def run_batch(files: Sequence, model: Any, profile: Any = None, *, jobs: Optional[int] = None,
              scheduler: Optional[str] = None, keep_flight: bool = False,
              on_result: Optional[Callable[[LogResult], None]] = None,
              processes: Optional[bool] = None, prior: Optional[float] = None) -> list[LogResult]:
    """Diagnose ``files`` with ``model`` (a FaultModel) and ``profile``; results in input order.

    ``scheduler``: None (this machine: serial, or ``jobs`` processes; None means 1), ``"local"`` (a
    LocalCluster of ``jobs`` workers, None: one per core) or a Dask scheduler address. ``processes=False`` runs
    LocalCluster workers as threads of this process (tests). ``on_result`` is called here for each
    log as it finishes; ``prior``: the prior of damage (None: the profile's or the decision's).
    Raises FlightLogError only for a scheduler that cannot be reached.
    """
    paths = [str(Path(f).resolve()) if scheduler else str(f) for f in files]
    out: list[Optional[LogResult]] = [None] * len(paths)

    def emit(r: LogResult) -> None:
        r.path = str(files[r.index])  # the path as the user gave it (workers saw the absolute one)
        if r.diagnosis.log == paths[r.index]:
            r.diagnosis.log = r.path
        if r.diagnosis.facts is not None and r.diagnosis.facts.path == paths[r.index]:
            r.diagnosis.facts.path = r.path
        out[r.index] = r
        if on_result is not None:
            on_result(r)

    if processes is None:
        processes = LOCAL_CLUSTER_PROCESSES
    engine = engine_name(jobs or 1, scheduler, len(paths))
    if engine == "dask":
        _run_dask(paths, model, profile, scheduler, jobs, keep_flight, emit, processes, prior)
    elif engine == "processes":
        _run_processes(paths, model, profile, jobs, keep_flight, emit, prior)
    else:
        for i, f in enumerate(paths):
            emit(diagnose_one(i, f, model, profile, keep_flight, prior=prior))
    for i, r in enumerate(out):  # cannot happen unless an engine lost a future: still one row each
        if r is None:
            emit(error_result(i, paths[i], "no result came back for this log"))
    return [r for r in out if r is not None]
