"""Where pulled logs go: a folder per vehicle, names that recognise a log pulled before, atomic files.

A log on the vehicle is recognised by a fingerprint of its listed size and its last bytes (one
``LOG_DATA`` packet, fetched before deciding to download): the log ids cannot serve (ArduPilot's
count from the oldest log still on the card and shift when old logs are erased; PX4's follow its
folder scan) and ``time_utc`` is 0 without a GPS clock. A log's end holds its latest timestamps, so
two different logs practically never share size and tail. The file is named
``YYYY-MM-DD_HH-MM-SS_<fingerprint>.ulg`` (UTC, when the vehicle had a clock) or
``nodate_<fingerprint>.bin``, extension from the content (ULog or DataFlash).

A download is written to a hidden ``.<name>.part`` file whose first bytes stay zero until the
last byte arrived (so nothing that sniffs logs by content, like ``fdlog diagnose FOLDER`` or a
folder watcher, takes it for a log), then renamed into place in one step; a failed download
removes it.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import os
import re
from pathlib import Path
from typing import Optional

from ..logs.sniff import DATAFLASH_HEAD, ULOG_MAGIC
from .transfer import LOG_DATA_LEN, LogEntry

#: Bytes at the end of a log that enter its fingerprint: one LOG_DATA packet, one round trip.
TAIL_BYTES = LOG_DATA_LEN
#: Hex digits of the fingerprint kept in the name (40 bits: a clash among a vehicle's logs of the
#: same size is a one-in-10^12 event).
FINGERPRINT_HEX = 10
#: time_utc before 2000-01-01 is not a clock: PX4's stand-ins for sessNNN/logNNN count days and
#: minutes from 1970, a FAT card without a clock stamps 1980-01-01.
CLOCK_VALID_AFTER = 946684800
#: Bytes of the partial file kept zero until the download completes (>= the 7-byte ULog magic and
#: the 3-byte DataFlash header the readers sniff).
HIDDEN_HEAD_BYTES = 16

_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def fingerprint(size: int, tail: bytes) -> str:
    """The log's identity from its size and its last ``min(size, TAIL_BYTES)`` bytes."""
    return hashlib.sha256(f"{size}:".encode() + bytes(tail)).hexdigest()[:FINGERPRINT_HEX]


def stamp(entry: LogEntry) -> str:
    """``YYYY-MM-DD_HH-MM-SS`` (UTC) of the log, or ``nodate`` when the vehicle had no clock."""
    if entry.time_utc < CLOCK_VALID_AFTER:
        return "nodate"
    return _dt.datetime.fromtimestamp(entry.time_utc, _dt.timezone.utc).strftime("%Y-%m-%d_%H-%M-%S")


def extension(head: bytes) -> str:
    """``.ulg`` for a ULog, ``.bin`` for a DataFlash log, ``.log`` for anything else."""
    if head.startswith(ULOG_MAGIC[:4]):
        return ".ulg"
    if head[:2] == DATAFLASH_HEAD:
        return ".bin"
    return ".log"


def vehicle_folder(root: Path, vehicle_key: str) -> Path:
    """``root/<vehicle key>`` (the key made safe as a folder name)."""
    return Path(root) / (_SAFE.sub("_", vehicle_key).strip("._") or "vehicle")


def find_pulled(folder: Path, fp: str, size: int) -> Optional[Path]:
    """The file pulled before with this fingerprint and size, if any."""
    if not folder.is_dir():
        return None
    for p in sorted(folder.glob(f"*_{fp}*")):
        if not p.name.startswith(".") and p.is_file() and p.stat().st_size == size:
            return p
    return None


class PartialLog:
    """A log being downloaded into ``folder``: ``write_at`` any order, then :meth:`commit` or
    :meth:`abort` (a context manager aborts unless committed)."""

    def __init__(self, folder: Path, fp: str, size: int):
        self.folder = Path(folder)
        self.fp = fp
        self.size = size
        self.head = bytearray(min(size, HIDDEN_HEAD_BYTES))
        self.folder.mkdir(parents=True, exist_ok=True)
        self.tmp = self.folder / f".{fp}.part"
        self._f = open(self.tmp, "w+b")
        self._f.truncate(size)
        self.path: Optional[Path] = None

    def __enter__(self) -> "PartialLog":
        return self

    def __exit__(self, *exc) -> None:
        if self.path is None:
            self.abort()

    def write_at(self, offset: int, data: bytes) -> None:
        n_head = max(0, min(len(data), len(self.head) - offset))
        if n_head:
            self.head[offset:offset + n_head] = data[:n_head]
            data, offset = data[n_head:], offset + n_head
        if data:
            self._f.seek(offset)
            self._f.write(data)

    def tail(self) -> bytes:
        """The last ``min(size, TAIL_BYTES)`` bytes as written."""
        n = min(self.size, TAIL_BYTES)
        self._f.flush()
        self._f.seek(self.size - n)
        data = bytearray(self._f.read(n))
        lead = len(self.head) - (self.size - n)  # tail bytes that live in the held-back head
        if lead > 0:
            data[:lead] = self.head[self.size - n:]
        return bytes(data)

    def commit(self, entry: LogEntry) -> Path:
        """Write the head, sync, and rename to the log's final name (never over an existing file)."""
        name = f"{stamp(entry)}_{self.fp}{extension(bytes(self.head))}"
        final = self.folder / name
        self._f.seek(0)
        self._f.write(self.head)
        self._f.flush()
        os.fsync(self._f.fileno())
        self._f.close()
        n = 1
        while final.exists():
            if final.stat().st_size == self.size:  # the same log, pulled meanwhile
                self.abort()
                self.path = final
                return final
            n += 1
            final = self.folder / f"{stamp(entry)}_{self.fp}-{n}{extension(bytes(self.head))}"
        os.replace(self.tmp, final)
        self.path = final
        return final

    def abort(self) -> None:
        if not self._f.closed:
            self._f.close()
        try:
            self.tmp.unlink()
        except FileNotFoundError:
            pass
