"""Log readers: one module per format; :func:`load_flight` picks one by the file's content.

The extension is never trusted: a ULog starts with the magic bytes ``ULog\\x01\\x12\\x35``; a
DataFlash binary log starts with a message header ``0xA3 0x95`` followed by the ``FMT`` message
id 128 (0x80).
"""
from __future__ import annotations

from ..errors import CorruptLogError, FlightLogError
from ..flight import Flight, sanitise_flight
from ..flights import with_imu_airborne
from .sniff import (DATAFLASH_FMT_ID, DATAFLASH_HEAD, ULOG_MAGIC, collect_logs, read_head,  # noqa: F401  (the package's API)
                    sniff_format)

def load_flight(path) -> Flight:
    """Read a log into a :class:`Flight`, choosing the parser by content, not extension.

    Whatever reader made it, the Flight then passes the timestamp checks of
    :func:`flightlog_fd.flight.sanitise_flight` (implausible samples dropped, with a warning); a
    log with no airborne time and nothing to find it from but its IMU (no land detector, arming
    state or motor outputs) gets it from the IMU (:func:`flightlog_fd.flights.with_imu_airborne`)."""
    kind = sniff_format(path)
    if kind == "ulog":
        from .ulog import read_ulog as reader
    else:
        from .dataflash import read_dataflash as reader
    try:
        return with_imu_airborne(sanitise_flight(reader(path)))
    except FlightLogError:
        raise
    except MemoryError:
        raise CorruptLogError(path, "damaged log: decoding it ran out of memory") from None
    except Exception as e:
        # Last line of defence for damage no check foresaw (tests/test_fuzz.py hunts these and
        # each one found gets its own check): one line naming the file, never a traceback.
        raise CorruptLogError(path, f"damaged log: cannot decode it ({type(e).__name__}: {e})") from None
