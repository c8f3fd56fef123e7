"""`fdlog pull` without the printing: choose logs on the vehicle, download the ones not here yet.

:func:`pull_logs` lists the vehicle's logs, picks the newest (default), one id, every log not
pulled before (``since_last``) or all, recognises each one already in the vehicle's folder by its
fingerprint (folder.py), downloads the others atomically and ends the transfer session
(``LOG_REQUEST_END``, which PX4 needs to free its list and ArduPilot to resume logging).
:func:`erase_all` erases the vehicle's logs and checks that it lists none afterwards.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from .folder import TAIL_BYTES, PartialLog, find_pulled, fingerprint, vehicle_folder
from .link import VehicleLink
from .transfer import (STALL_TIMEOUT_S, LogEntry, MemorySink, TransferStats, download, list_logs,
                       newest_entry)

MODES = ("newest", "id", "since_last", "all")
#: LOG_ERASE has no acknowledgement: it is sent again when the list still shows logs, at most
#: this many times (a lossy link can drop it); each erase gets this long before the re-list
#: (PX4 deletes in its MAVLink receive thread, ArduPilot in its logger thread: well under a second
#: for a card of logs).
ERASE_TRIES, ERASE_SETTLE_S = 3, 1.0


@dataclass
class PulledLog:
    """One chosen log: where it is here, and whether this run downloaded it (with its figures)."""
    entry: LogEntry
    path: Path
    downloaded: bool
    stats: Optional[TransferStats] = None


@dataclass
class PullReport:
    """What a pull found and did. ``every_log_here``: each log on the vehicle was looked at and is
    in ``folder`` (the precondition of :func:`erase_all`)."""
    vehicle: str
    folder: Path
    entries: list[LogEntry]
    logs: list[PulledLog] = field(default_factory=list)
    empty: list[LogEntry] = field(default_factory=list)
    every_log_here: bool = False

    @property
    def downloaded(self) -> list[PulledLog]:
        return [p for p in self.logs if p.downloaded]


def choose(entries: list[LogEntry], kind: str, mode: str, log_id: Optional[int] = None) -> list[LogEntry]:
    """The entries a pull looks at, oldest first. ``mode``: newest | id | since_last | all."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if not entries:
        return []
    if mode == "newest":
        return [newest_entry(entries, kind)]
    if mode == "id":
        return [e for e in entries if e.id == log_id]
    if kind == "ardupilot":
        return sorted(entries, key=lambda e: e.id)
    return sorted(entries, key=lambda e: (e.time_utc, e.id))


def pull_logs(link: VehicleLink, root: Path, *, mode: str = "newest", log_id: Optional[int] = None,
              stall_timeout: float = STALL_TIMEOUT_S,
              on_start: Optional[Callable[[LogEntry], Callable[[int, int], None]]] = None,
              on_log: Optional[Callable[[PulledLog], None]] = None) -> PullReport:
    """Pull logs from the vehicle on ``link`` into ``root/<vehicle>/``.

    ``on_start(entry)`` is called before a download and returns its progress callback
    ``(bytes done, bytes total)``; ``on_log`` after each chosen log (downloaded or found here).
    A log already here is not downloaded again; with ``since_last`` it is left out of the report.
    Raises VehicleLinkError (one line) when the link fails; a failed download leaves no file."""
    entries = list_logs(link)
    folder = vehicle_folder(root, link.vehicle_key)
    report = PullReport(link.describe(), folder, entries)
    chosen = choose(entries, link.kind, mode, log_id)
    if mode == "id" and entries and not chosen:
        ids = ", ".join(str(e.id) for e in entries[:20]) + (" ..." if len(entries) > 20 else "")
        raise link.fail(f"no log {log_id} on the vehicle (its logs: {ids})")
    all_here = mode in ("all", "since_last")
    try:
        for entry in chosen:
            if entry.size == 0:
                report.empty.append(entry)
                continue
            tail = MemorySink(entry.size - min(entry.size, TAIL_BYTES), entry.size)
            download(link, entry, tail, start=tail.start, stall_timeout=stall_timeout)
            fp = fingerprint(entry.size, tail.data)
            here = find_pulled(folder, fp, entry.size)
            if here is not None:
                if mode != "since_last":
                    report.logs.append(PulledLog(entry, here, False))
                    if on_log:
                        on_log(report.logs[-1])
                continue
            progress = on_start(entry) if on_start else None
            with PartialLog(folder, fp, entry.size) as part:
                stats = download(link, entry, part, stall_timeout=stall_timeout, progress=progress)
                if part.tail() != bytes(tail.data):
                    raise link.fail(f"log {entry.id} changed on the vehicle while it was downloaded "
                                    "(is it still being written?)")
                path = part.commit(entry)
            report.logs.append(PulledLog(entry, path, True, stats))
            if on_log:
                on_log(report.logs[-1])
    finally:
        try:
            link.send_log_request_end()
        except Exception:  # the link is already gone: nothing to end
            pass
    report.every_log_here = all_here  # an empty (0-byte) log holds nothing to keep
    return report


def erase_all(link: VehicleLink) -> None:
    """Erase every log on the vehicle (LOG_ERASE), then list again until it shows none."""
    left: list[LogEntry] = []
    for _ in range(ERASE_TRIES):
        link.send_log_erase()
        time.sleep(ERASE_SETTLE_S)
        left = list_logs(link)
        if not left:
            link.send_log_request_end()
            return
    link.send_log_request_end()
    raise link.fail(f"the vehicle still lists {len(left)} logs after {ERASE_TRIES} LOG_ERASE requests")
