"""Log readers: one module per format; :func:`load_flight` picks one by the file's content.

The extension is never trusted: a ULog starts with the magic bytes ``ULog\\x01\\x12\\x35``; a
DataFlash binary log starts with a message header ``0xA3 0x95`` followed by the ``FMT`` message
id 128 (0x80).
"""
from __future__ import annotations

from pathlib import Path

from ..errors import CorruptLogError, FlightLogError, NotALogError
from ..flight import Flight, sanitise_flight

ULOG_MAGIC = b"ULog\x01\x12\x35"
DATAFLASH_HEAD = b"\xa3\x95"
DATAFLASH_FMT_ID = 0x80


def read_head(path, n: int = 16) -> bytes:
    """The first ``n`` bytes of a log file; NotALogError (one line) for a missing path, a folder,
    an unreadable or an empty file. Every reader starts here."""
    p = Path(path)
    if not p.exists():
        raise NotALogError(path, "no such file")
    if p.is_dir():
        raise NotALogError(path, "is a folder, not a log file")
    try:
        with open(p, "rb") as f:
            head = f.read(n)
    except OSError as e:
        raise NotALogError(path, f"cannot read: {e.strerror or e}") from None
    if not head:
        raise NotALogError(path, "empty file (0 bytes)")
    return head


def sniff_format(path) -> str:
    """Return ``"ulog"`` or ``"dataflash"`` from the file's first bytes, else raise NotALogError."""
    head = read_head(path)
    if head.startswith(ULOG_MAGIC):
        return "ulog"
    if len(head) >= 3 and head[:2] == DATAFLASH_HEAD and head[2] == DATAFLASH_FMT_ID:
        return "dataflash"
    if head.startswith(b"ULog"):
        return "ulog"  # unknown ULog version: let the reader say what is wrong
    raise NotALogError(path, "not a PX4 ULog or ArduPilot DataFlash log (unrecognised header)")


def load_flight(path) -> Flight:
    """Read a log into a :class:`Flight`, choosing the parser by content, not extension.

    Whatever reader made it, the Flight then passes the timestamp checks of
    :func:`flightlog_fd.flight.sanitise_flight` (implausible samples dropped, with a warning)."""
    kind = sniff_format(path)
    if kind == "ulog":
        from .ulog import read_ulog as reader
    else:
        from .dataflash import read_dataflash as reader
    try:
        return sanitise_flight(reader(path))
    except FlightLogError:
        raise
    except MemoryError:
        raise CorruptLogError(path, "damaged log: decoding it ran out of memory") from None
    except Exception as e:
        # Last line of defence for damage no check foresaw (tests/test_fuzz.py hunts these and
        # each one found gets its own check): one line naming the file, never a traceback.
        raise CorruptLogError(path, f"damaged log: cannot decode it ({type(e).__name__}: {e})") from None
