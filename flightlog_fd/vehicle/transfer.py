"""The MAVLink log protocol, ground-station side: list the logs, fetch one, erase them all.

Messages (MAVLink common set): ``LOG_REQUEST_LIST`` -> one ``LOG_ENTRY`` per log (id, size,
time_utc); ``LOG_REQUEST_DATA`` (id, ofs, count) -> a stream of ``LOG_DATA`` (ofs, count <= 90 bytes);
``LOG_REQUEST_END``; ``LOG_ERASE`` (every log: the protocol has no per-log erase).

How the two autopilots answer, read from their sources, and what this client does about it:

- Numbering. PX4 (``src/modules/mavlink/mavlink_log_handler.cpp``, ``MavlinkLogHandler``) numbers
  logs 0..n-1 in the order it scans its log folders; ``time_utc`` is the file's mtime, or a stand-in
  counting days and minutes from 1970 for ``sessNNN/logNNN`` names. ArduPilot
  (``libraries/AP_Logger/AP_Logger_MAVLinkLogTransfer.cpp``, ``AP_Logger_File.cpp``) numbers them
  1..n from the oldest (list entry, not the file number: ``LASTLOG.TXT`` holds that, and the
  numbers wrap), ``time_utc`` 0 without a GPS clock, and answers an empty card with one
  ``LOG_ENTRY`` of id 0 and ``num_logs`` 0. So the newest is the highest id on ArduPilot, and the
  latest ``(time_utc, id)`` on PX4; ids are never used to recognise a log (see folder.py).
- PX4 ignores ``LOG_REQUEST_DATA`` until a list was requested and after ``LOG_REQUEST_END``: the
  client lists first and ends once, after the last log. A new request replaces the stream.
- ArduPilot drops a ``LOG_REQUEST_DATA`` that arrives while it is still streaming on that link,
  and streams only while the ground station's heartbeat is fresh: one request is outstanding at a
  time, and missing pieces are asked for after the stream went quiet.
- Both end a stream with a short packet (count < 90) or when the requested count is sent; a
  request at or past the end gets one packet of count 0.

Robustness: received byte ranges are tracked (:class:`Coverage`), so lost, duplicated and
reordered packets are harmless. Each next request is planned from the gaps after the previous one
(:meth:`Coverage.gap_run`), bridging gaps when re-sending the received bytes between them costs less
than one more request (costs measured on this link as the transfer goes: round trip, packet
interval, share of requests unanswered). A request unanswered within its timeout is sent again; no
new byte for ``stall_timeout`` seconds ends the transfer with one error. A log that turns out
shorter or longer than its ``LOG_ENTRY`` is an error, never a silently truncated file.
"""
from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass
from typing import Callable, Optional, Protocol

from ..errors import VehicleLinkError

#: Data bytes in one LOG_DATA (MAVLINK_MSG_LOG_DATA_FIELD_DATA_LEN).
LOG_DATA_LEN = 90
#: Before the link's round trip is measured, a request unanswered for 1 s is taken as lost and
#: sent again (10x a slow telemetry radio's round trip; PX4's mavlink thread and ArduPilot's logger
#: thread answer within milliseconds).
REQUEST_TIMEOUT_S = 1.0
#: Once measured: REQUEST_RTT_FACTOR x the worst of the last RTT_WINDOW round trips, never less than
#: REQUEST_TIMEOUT_MIN_S. On the loopback the round trip is ~0.1 ms but a loaded host pauses a
#: process for tens of ms (bench_pull at load 7-15: streams without loss were re-requested after
#: such pauses); a request re-sent too early costs little (PX4 restarts the same range, ArduPilot
#: drops a request while it streams), one waited for too long costs the whole wait: a 6 MB PX4 pull
#: with 5 % loss took 29.5 s with a 50 ms floor and 23.7 s with 20 ms (two runs at load 11-13).
REQUEST_RTT_FACTOR, RTT_WINDOW, REQUEST_TIMEOUT_MIN_S = 4.0, 16, 0.02
#: No new byte for this long despite re-requests: the link is lost (``--timeout``).
STALL_TIMEOUT_S = 10.0
#: A stream counts as over after this many packet intervals (measured) without a packet, plus two
#: round trips, within [STREAM_IDLE_MIN_S, the request timeout].
STREAM_IDLE_INTERVALS, STREAM_IDLE_MIN_S = 20, 0.02
#: The log list: PX4 scans its SD card's log folders before the first LOG_ENTRY (seconds with
#: hundreds of logs); each pass waits this long for the next entry, and the missing ids are
#: re-requested at most LIST_TRIES times.
LIST_REPLY_TIMEOUT_S, LIST_TRIES = 3.0, 4
#: A short packet that ends the log before its listed size, seen this many times at the same
#: offset, means the vehicle's file is shorter than its LOG_ENTRY said.
SHORT_EOF_CONFIRMATIONS = 2


@dataclass(frozen=True)
class LogEntry:
    """One log on the vehicle as LOG_ENTRY lists it: ``time_utc`` in seconds since 1970 (0 when the
    vehicle had no clock)."""
    id: int
    size: int
    time_utc: int


def newest_entry(entries: list[LogEntry], kind: str) -> LogEntry:
    """The most recent log: the highest id on ArduPilot (ids count from the oldest, whatever the
    clock said), the latest (time_utc, id) elsewhere (PX4's ids follow its folder scan)."""
    if kind == "ardupilot":
        return max(entries, key=lambda e: e.id)
    return max(entries, key=lambda e: (e.time_utc, e.id))


class LinkLike(Protocol):
    kind: str

    def send_log_request_list(self, start: int, end: int) -> None: ...
    def send_log_request_data(self, log_id: int, offset: int, count: int) -> None: ...
    def recv(self, types, timeout: float): ...
    def fail(self, message: str) -> VehicleLinkError: ...


class Coverage:
    """The byte ranges of ``[0, size)`` received so far (sorted, disjoint, touching ones merged)."""

    def __init__(self, size: int):
        self.size = size
        self.done = 0
        self._starts: list[int] = []
        self._ends: list[int] = []

    def add(self, start: int, end: int) -> int:
        """Mark ``[start, end)`` received (clipped to the file); return how many bytes were new."""
        start, end = max(0, start), min(self.size, end)
        if end <= start:
            return 0
        starts, ends = self._starts, self._ends
        if ends and ends[-1] == start:  # the common case: the stream goes on where it was
            ends[-1] = end
            self.done += end - start
            return end - start
        i = bisect.bisect_left(ends, start)  # first range ending at or after start
        j = bisect.bisect_right(starts, end)  # ranges i..j-1 touch or overlap [start, end)
        covered = sum(max(0, min(ends[k], end) - max(starts[k], start)) for k in range(i, j))
        if i < j:
            starts[i:j] = [min(start, starts[i])]
            ends[i:j] = [max(end, ends[j - 1])]
        else:
            starts.insert(i, start)
            ends.insert(i, end)
        added = (end - start) - covered
        self.done += added
        return added

    def covers(self, start: int, end: int) -> bool:
        """Whether every byte of ``[start, end)`` was received."""
        i = bisect.bisect_right(self._starts, start) - 1
        return i >= 0 and self._ends[i] >= min(end, self.size)

    def gap_run(self, cursor: int, bridge: int) -> Optional[tuple[int, int]]:
        """The first gap ending after ``cursor`` (else, wrapping round, the first gap), extended over
        the gaps that follow it across fewer than ``bridge`` received bytes; None when complete."""
        if self.complete:
            return None
        starts, ends, n = self._starts, self._ends, len(self._starts)

        def gap(i: int) -> tuple[int, int]:  # the gap before range i (i == n: after the last range)
            return (ends[i - 1] if i > 0 else 0, starts[i] if i < n else self.size)

        i = bisect.bisect_right(starts, cursor)
        while i <= n and (gap(i)[0] >= gap(i)[1] or gap(i)[1] <= cursor):
            i += 1
        if i > n:
            i = 0
            while gap(i)[0] >= gap(i)[1]:
                i += 1
        g_start, g_end = gap(i)
        while i < n:
            following = gap(i + 1)
            if following[0] >= following[1] or ends[i] - starts[i] >= bridge:
                break
            g_end = following[1]
            i += 1
        return g_start, g_end

    @property
    def complete(self) -> bool:
        return self.done >= self.size

    def missing(self) -> list[tuple[int, int]]:
        """The gaps, in order, as ``(start, end)``."""
        gaps, pos = [], 0
        for s, e in zip(self._starts, self._ends):
            if s > pos:
                gaps.append((pos, s))
            pos = e
        if pos < self.size:
            gaps.append((pos, self.size))
        return gaps


class Sink(Protocol):
    def write_at(self, offset: int, data: bytes) -> None: ...


class MemorySink:
    """Bytes of ``[start, end)`` of a log, kept in memory (the tail read for a fingerprint)."""

    def __init__(self, start: int, end: int):
        self.start = start
        self.data = bytearray(end - start)

    def write_at(self, offset: int, data: bytes) -> None:
        self.data[offset - self.start:offset - self.start + len(data)] = data


@dataclass
class TransferStats:
    """What one transfer took: unique bytes, LOG_DATA packets (and duplicates), requests (and
    re-requests of gaps or unanswered requests), seconds, measured round trip and packet interval."""
    bytes: int = 0
    packets: int = 0
    duplicates: int = 0
    requests: int = 0
    re_requests: int = 0
    seconds: float = 0.0
    rtt_s: float = 0.0
    interval_s: float = 0.0

    @property
    def rate(self) -> float:
        """Unique bytes per second."""
        return self.bytes / self.seconds if self.seconds > 0 else 0.0


class _LinkTiming:
    """What this link costs, measured as the transfer goes: round trips (request -> first packet),
    the packet interval within a stream, and the share of requests that got no answer."""

    def __init__(self) -> None:
        self.rtts: list[float] = []
        self.interval: Optional[float] = None
        self.requests = self.unanswered = 0

    @property
    def rtt(self) -> Optional[float]:
        return sum(self.rtts) / len(self.rtts) if self.rtts else None

    def add_rtt(self, x: float) -> None:
        self.rtts = (self.rtts + [x])[-RTT_WINDOW:]

    def add_interval(self, x: float) -> None:
        self.interval = x if self.interval is None else 0.95 * self.interval + 0.05 * x

    def request_timeout(self) -> float:
        if not self.rtts:
            return REQUEST_TIMEOUT_S
        return min(REQUEST_TIMEOUT_S, max(REQUEST_TIMEOUT_MIN_S, REQUEST_RTT_FACTOR * max(self.rtts)))

    def idle_timeout(self) -> float:
        if self.interval is None or not self.rtts:
            return self.request_timeout()
        return min(self.request_timeout(), max(STREAM_IDLE_MIN_S, STREAM_IDLE_INTERVALS * self.interval + 2 * self.rtt))

    def bridge_bytes(self) -> int:
        """Received bytes worth re-sending to save one request: a request costs a round trip plus,
        as often as requests go unanswered here, a timeout; re-sent bytes cost packet intervals."""
        if not self.interval or not self.rtts:
            return 0
        fail = self.unanswered / self.requests if self.requests else 0.0
        cost = self.rtt + fail * self.request_timeout()
        return int(math.ceil(cost / self.interval)) * LOG_DATA_LEN


def download(link: LinkLike, entry: LogEntry, sink: Sink, *, start: int = 0, end: Optional[int] = None,
             stall_timeout: float = STALL_TIMEOUT_S,
             progress: Optional[Callable[[int, int], None]] = None) -> TransferStats:
    """Fetch bytes ``[start, end)`` (default: the whole log) of ``entry`` into ``sink``.

    Returns the transfer's figures; raises VehicleLinkError (one line) when the link stalls for
    ``stall_timeout`` seconds or the vehicle's log does not match its listed size."""
    end = entry.size if end is None else end
    cov = Coverage(end)
    if start > 0:
        cov.add(0, start)
    base = cov.done
    stats = TransferStats()
    timing = _LinkTiming()
    t0 = last_new = time.monotonic()
    short_eof: dict[int, int] = {}
    last_report = 0.0
    first_request = True

    def report(force: bool = False) -> None:
        nonlocal last_report
        now = time.monotonic()
        if progress is not None and (force or now - last_report >= 0.1):
            last_report = now
            progress(cov.done - base, end - start)

    cursor = start
    while True:
        # One request at a time (ArduPilot drops a request while it streams, PX4 restarts on it),
        # planned from the gaps and the link's costs as measured so far.
        run = cov.gap_run(cursor, timing.bridge_bytes())
        if run is None:
            break
        r_start, r_end = run
        cursor = r_end
        link.send_log_request_data(entry.id, r_start, r_end - r_start)
        stats.requests += 1
        if not first_request:
            stats.re_requests += 1
        first_request = False
        sent = last_packet = time.monotonic()
        answered = False  # a packet of this request's range arrived
        reached = r_start  # how far this request's stream got
        timing.requests += 1
        while True:
            if not answered:
                wait = timing.request_timeout()
            elif r_end - reached <= 2 * LOG_DATA_LEN:
                wait = timing.idle_timeout()  # the stream's last packets are lost, or on their way
            else:
                wait = REQUEST_TIMEOUT_S  # a stream stopping short of its end is mostly a pause
            m = link.recv(("LOG_DATA",), wait)
            now = time.monotonic()
            if now - last_new > stall_timeout:
                raise link.fail(f"log {entry.id}: no data from the vehicle for {stall_timeout:g} s "
                                f"({cov.done} of {entry.size} bytes received): the link is lost")
            if m is None:
                timing.unanswered += not answered
                break  # stream over (or the request was lost): plan the next request from the gaps
            if m.id != entry.id:
                continue
            count = int(m.count)
            stats.packets += 1
            if m.ofs + count > entry.size:
                raise link.fail(f"log {entry.id}: the vehicle sent data past the listed size of {entry.size} "
                                "bytes (is it still writing this log?)")
            if count:
                if cov.add(m.ofs, m.ofs + count):
                    sink.write_at(m.ofs, bytes(m.data[:count]))
                    last_new = now
                else:
                    stats.duplicates += 1
            report()
            if not r_start <= m.ofs < r_end:
                continue  # a late packet of an earlier stream: kept, but it says nothing of this one
            if not answered:
                timing.add_rtt(now - sent)
                answered = True
            else:
                timing.add_interval(now - last_packet)
            last_packet = now
            reached = max(reached, m.ofs + count)
            if count < LOG_DATA_LEN and m.ofs + count < min(r_end, entry.size):
                short_eof[m.ofs + count] = short_eof.get(m.ofs + count, 0) + 1
                if short_eof[m.ofs + count] >= SHORT_EOF_CONFIRMATIONS:
                    raise link.fail(f"log {entry.id}: the vehicle's log ends at {m.ofs + count} bytes but its "
                                    f"LOG_ENTRY said {entry.size}")
                break
            if reached >= r_end or count < LOG_DATA_LEN:
                break
    stats.bytes = cov.done - base
    stats.seconds = time.monotonic() - t0
    stats.rtt_s = timing.rtt or 0.0
    stats.interval_s = timing.interval or 0.0
    report(force=True)
    return stats


def list_logs(link: LinkLike) -> list[LogEntry]:
    """The vehicle's logs, by id (LOG_REQUEST_LIST / LOG_ENTRY; lost entries re-requested)."""
    entries: dict[int, LogEntry] = {}
    num_logs: Optional[int] = None
    first_id = 1 if link.kind == "ardupilot" else 0
    link.send_log_request_list(0, 0xFFFF)
    tries = 1
    while True:
        m = link.recv(("LOG_ENTRY",), LIST_REPLY_TIMEOUT_S)
        if m is not None:
            if m.num_logs == 0:
                return []
            num_logs = int(m.num_logs)
            entries[int(m.id)] = LogEntry(int(m.id), int(m.size), int(m.time_utc))
            if len(entries) >= num_logs:
                break
            continue
        if tries >= LIST_TRIES:
            got = f"{len(entries)} of {num_logs}" if num_logs is not None else "no"
            raise link.fail(f"the vehicle did not list its logs ({got} LOG_ENTRY received after {tries} requests)")
        tries += 1
        if num_logs is None:
            link.send_log_request_list(0, 0xFFFF)
        else:
            missing = sorted(set(range(first_id, first_id + num_logs)) - set(entries)) or [first_id]
            link.send_log_request_list(missing[0], missing[-1])
    return [entries[k] for k in sorted(entries)]
