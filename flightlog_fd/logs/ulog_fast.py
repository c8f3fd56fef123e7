"""Fast PX4 ULog reader: the topics asked for, decoded straight into numpy, same values as pyulog.

Input: the bytes of a ULog file (``read_ulog_bytes``) or its path (``read_ulog_fast``), and the
topic names to decode (``None``: every subscribed topic). Output: a :class:`FastULog` whose
attributes carry pyulog's names and values (``data_list`` of per topic-instance field arrays,
``msg_info_dict``, ``msg_info_multiple_dict``, ``initial_parameters``, ``changed_parameters``,
``get_default_parameters``, ``logged_messages``, ``logged_messages_tagged``, ``dropouts``,
``start_timestamp``, ``last_timestamp``, ``file_corruption``, ``message_formats``) plus
``truncated`` (the last message is cut) and ``printed`` (the lines pyulog would have printed).

How: one walk over the 3-byte message headers (``msg_size`` u16, ``msg_type`` u8) that records
message offsets only. It does not step through the 'D' messages one at a time: numpy finds
candidate 'D' headers first (type byte 'D', the next message starting with a known type byte,
pointed at by one of the candidates just before), chains them into runs (candidate ``i``'s next message is
candidate ``i + 1``), and the walk takes a whole run in one step whenever it stands on the
run's first message; other messages (and runs broken by false candidates) are stepped in Python.
The walk only ever enters a run from a position it reached itself, so the result is exactly the
message chain pyulog reads, whatever the candidates. On the 67 MB log below the walk is ~1000
Python steps instead of 900k. Types, sizes and ``msg_id`` of every message are then gathered
with numpy. The definitions ('B' flag bits with appended-data offsets, 'F' formats, 'I'/'M'
info, 'P' initial and 'Q' default parameters) and the rare data-section messages ('A'
subscriptions, 'P' changed parameters, 'I'/'M', 'L'/'C' logging and tagged logging, 'O'
dropouts, 'S' sync) are parsed in Python. The 'D' records of each wanted subscription are
copied in one numpy gather (the file viewed as overlapping ``V<size>`` items, one per byte
offset, indexed by the record offsets) and viewed as a structured dtype built from the format:
nested types and arrays flattened with pyulog's names (``control[0]``, ``esc[2].esc_rpm``),
trailing ``_padding*`` fields dropped, ``bool``/``char`` as int8, packed little-endian.

pyulog's semantics are kept where they decide values: a 'D' record counts only when its
subscription came first in the same data segment and its size equals the format's; records of
other sizes and 'D' messages of unknown ``msg_id`` mark the file corrupt (with pyulog's
warning line); ``last_timestamp`` and the dropout / changed-parameter timestamps are the
running maximum of the decoded records' timestamps; appended data (flag bit 0 with offsets)
is read segment by segment and each segment's subscriptions end with it; ``data_list`` is in
pyulog's order (per segment, last subscription first, then stably sorted by name and
instance); a cut last message is dropped and reported as ``truncated``.

What it refuses (raises :class:`FastULogUnsupported`; :func:`~flightlog_fd.logs.ulog.read_ulog`
then falls back to pyulog and says so): anything pyulog handles by re-synchronising or by
stopping early, i.e. a corrupt message of unknown type (type 0, size 0 or > 10000 bytes:
pyulog skips one byte and searches the next sync marker), an unknown message whose payload
holds the sync marker, a message that does not parse (short info/parameter/dropout/logging
payloads, malformed format strings, subscriptions to undefined formats, duplicate field names),
a 'D' record shorter than its ``msg_id``, a ``msg_id`` subscribed twice in one segment, a
subscription whose format has no 8-byte ``timestamp`` where pyulog reads it, a 'B' message that
is not the first message or is shorter than 40 bytes, unknown incompatible flags, appended
offsets that go backwards or into the definitions, and a file cut inside its
definitions. A format whose flattened size exceeds the largest possible record (65533 bytes) or
nests deeper than ``MAX_NESTING`` raises :class:`~flightlog_fd.errors.CorruptLogError`
instead (pyulog would recurse or build millions of fields). Every allocation is bounded by the
file size: offsets are 8 bytes per message of at least 3 bytes, run candidates 8 bytes per 'D'
type byte (none when those are denser than one per ``MAX_CANDIDATE_DENSITY`` bytes: the walk
then steps every message), decoded rows are copies of file bytes. The worst case for time is a
file of tiny messages (e.g. zero bytes: 3-byte messages), ~0.3 s per MB.

Measured (``python benchmarks/bench_load.py --ulog-only [--all-shared]``, 2-core machine shared
with other jobs, load average 4-6, so figures vary by about 30 % between runs): on the 600 s /
67 MB synthetic log (900k messages) pyulog's full parse ``ULog(path)`` takes 3.5-3.8 s, this
reader 0.5-0.8 s (4.6-6.7x on fdlog's topics, 5.4-8x on every topic; 0.49 s best of 7 on every
topic when run alone); ``read_ulog`` as a whole (with the Flight assembly) 1.2 s, 3x. On the 76
ULogs of ``sample_logs/`` and ``../shared``: 4-15x for the 1-10 MB flight logs; 2x on the small
logs with ~100 topics (0.4-0.5 MB), where parsing hundreds of definitions in Python is most of
the time. Values equal pyulog's (``tests/test_ulog_fast.py``: every field of every topic
instance, parameters, info, logged messages, dropouts, on ``sample_logs/`` and the ULogs in
``../shared``; a differential test on damaged files: pyulog's values or a refusal).
"""
from __future__ import annotations

import struct
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from ..errors import CorruptLogError, NotALogError

ULOG_MAGIC = b"ULog\x01\x12\x35"
SYNC_BYTES = b"\x2F\x73\x13\x20\x25\x0C\xBB\x12"
HEADER_BYTES = 16
MSG_HEADER_BYTES = 3
#: A 'D' record's payload: msg_id (2 bytes) then the fields; the largest ULog message is 65535.
MAX_RECORD_BYTES = 0xFFFF - 2
#: Deepest nesting of formats accepted (PX4 nests two levels: esc_status -> esc_report).
MAX_NESTING = 16
#: pyulog treats a message of unknown type as corrupt when its size is 0 or above this.
PYULOG_CORRUPT_SIZE = 10000
#: A 'D' candidate is kept when one of this many candidates before it points at it (3: on the
#: 67 MB benchmark log 125 run breaks are left of 900k messages; 1: 47k).
POINTED_LOOKBACK = 3
#: Above one 'D' type byte per this many bytes the file is not a real log (those have one per
#: 30-80 bytes, random bytes one per 256): no run finding then, the walk steps every message.
MAX_CANDIDATE_DENSITY = 8
#: Up to this many wanted subscriptions, each one's records are found by one comparison pass.
FEW_SUBSCRIPTIONS = 24
#: 'B' payload: 8 compat + 8 incompat flag bytes + 3 appended-data offsets (u64).
FLAG_BITS_BYTES = 40

MSG_FORMAT, MSG_DATA, MSG_INFO, MSG_INFO_MULTIPLE = ord("F"), ord("D"), ord("I"), ord("M")
MSG_PARAMETER, MSG_PARAMETER_DEFAULT, MSG_ADD_LOGGED = ord("P"), ord("Q"), ord("A")
MSG_REMOVE_LOGGED, MSG_SYNC, MSG_DROPOUT = ord("R"), ord("S"), ord("O")
MSG_LOGGING, MSG_LOGGING_TAGGED, MSG_FLAG_BITS = ord("L"), ord("C"), ord("B")
#: Types pyulog's data-section loop knows; any other type is "unknown" there.
#: Stored alike wherever they appear (_add_info_like).
INFO_LIKE_TYPES = (MSG_INFO, MSG_INFO_MULTIPLE, MSG_PARAMETER_DEFAULT)
DATA_SECTION_TYPES = INFO_LIKE_TYPES + (MSG_PARAMETER, MSG_ADD_LOGGED, MSG_LOGGING, MSG_LOGGING_TAGGED, MSG_DATA,
                                        MSG_DROPOUT, MSG_SYNC)
DEFINITION_TYPES = INFO_LIKE_TYPES + (MSG_FORMAT, MSG_PARAMETER, MSG_FLAG_BITS)
#: The first message of one of these types ends the definitions section (as in pyulog).
DATA_SECTION_START_TYPES = (MSG_ADD_LOGGED, MSG_LOGGING, MSG_LOGGING_TAGGED)

#: ULog basic type -> (struct code, size, numpy type), as pyulog decodes them.
BASIC_TYPES = {
    "int8_t": ("b", 1, np.int8), "uint8_t": ("B", 1, np.uint8), "int16_t": ("h", 2, np.int16),
    "uint16_t": ("H", 2, np.uint16), "int32_t": ("i", 4, np.int32), "uint32_t": ("I", 4, np.uint32),
    "int64_t": ("q", 8, np.int64), "uint64_t": ("Q", 8, np.uint64), "float": ("f", 4, np.float32),
    "double": ("d", 8, np.float64), "bool": ("?", 1, np.int8), "char": ("c", 1, np.int8),
}
_U16 = struct.Struct("<H")
_U64 = struct.Struct("<Q")
_FLAG_BITS = struct.Struct("<8B8B3Q")
_LOGGING = struct.Struct("<BQ")
_LOGGING_TAGGED = struct.Struct("<BHQ")
NO_SUBSCRIPTION_WARNING = ("Warning: no subscription found for message id {:}. Continuing, but file is most "
                           "likely corrupt")


class FastULogUnsupported(Exception):
    """The file holds something the fast reader does not reproduce exactly: use pyulog."""


# ---------------------------------------------------------------- result types (pyulog's names)


@dataclass
class MessageFormat:
    """One 'F' definition: ``fields`` is a list of (type, array_size, name), array_size 0 = scalar."""

    name: str
    fields: list


@dataclass
class TopicData:
    """One subscribed topic instance: ``data`` maps each flattened field name to its array."""

    name: str
    multi_id: int
    msg_id: int
    field_data: list  # (flattened name, basic type) in record order
    data: dict


@dataclass
class Dropout:
    timestamp: int
    duration: int  # ms


@dataclass
class LoggedMessage:
    log_level: int
    timestamp: int
    message: str
    tag: Optional[int] = None  # tagged logging ('C') only


@dataclass
class FastULog:
    """What the fast reader found; attribute names follow pyulog's ``ULog``."""

    start_timestamp: int = 0
    last_timestamp: int = 0
    file_version: int = 0
    compat_flags: list = field(default_factory=lambda: [0] * 8)
    incompat_flags: list = field(default_factory=lambda: [0] * 8)
    appended_offsets: list = field(default_factory=list)
    message_formats: dict = field(default_factory=dict)
    msg_info_dict: dict = field(default_factory=dict)
    msg_info_dict_types: dict = field(default_factory=dict)
    msg_info_multiple_dict: dict = field(default_factory=dict)
    initial_parameters: dict = field(default_factory=dict)
    default_parameters: dict = field(default_factory=dict)  # default type bit -> {name: value}
    changed_parameters: list = field(default_factory=list)  # (timestamp, name, value)
    logged_messages: list = field(default_factory=list)
    logged_messages_tagged: dict = field(default_factory=dict)  # tag -> [LoggedMessage]
    dropouts: list = field(default_factory=list)
    data_list: list = field(default_factory=list)
    sync_count: int = 0
    file_corruption: bool = False
    truncated: bool = False  # the file ends inside its last message (dropped, as pyulog does)
    printed: list = field(default_factory=list)  # lines pyulog prints for the same file

    def get_default_parameters(self, default_type: int) -> dict:
        return self.default_parameters.get(default_type, {})

    @property
    def has_data_appended(self) -> bool:
        return bool(self.incompat_flags[0] & 1)


# ---------------------------------------------------------------- message payload parsers


def _string(raw: bytes) -> str:
    return str(raw, "utf-8", "ignore")  # pyulog's disable_str_exceptions=True


def _info(payload: bytes) -> tuple[str, str, object]:
    """'I'/'P' payload -> (type, key, value), as pyulog's _MessageInfo."""
    key_len = payload[0]
    type_key = _string(payload[1:1 + key_len]).split(" ")
    vtype, key = type_key[0], type_key[1]
    raw = payload[1 + key_len:]
    if vtype.startswith("char["):
        return vtype, key, _string(raw)
    if vtype in BASIC_TYPES:
        return vtype, key, struct.unpack("<" + BASIC_TYPES[vtype][0], raw)[0]
    return vtype, key, raw


def _format(payload: bytes) -> MessageFormat:
    parts = _string(payload).split(":")
    fields = []
    for item in parts[1].split(";"):
        if not item:
            continue
        words = item.split(" ")
        type_str, name = words[0], words[1]
        a = type_str.find("[")
        if a == -1:
            fields.append((type_str, 0, name))
            continue
        size = int(type_str[a + 1:type_str.find("]")])
        if size < 0 or size > 0xFFFF:
            raise ValueError(f"invalid array size {size}")
        fields.append((type_str[:a], size, name))
    return MessageFormat(parts[0], fields)


def _flatten(name: str, formats: dict, path) -> list[tuple[str, str]]:
    """A topic's fields flattened the way pyulog names them, trailing ``_padding*`` removed."""
    out: list[tuple[str, str]] = []
    size = [0]

    def walk(prefix: str, type_name: str, depth: int) -> None:
        if depth > MAX_NESTING:
            raise CorruptLogError(path, f"ULog format {name!r} nests more than {MAX_NESTING} levels")
        if type_name not in formats:
            raise FastULogUnsupported(f"subscription {name!r} uses undefined format {type_name!r}")
        for ftype, count, fname in formats[type_name].fields:
            if ftype in BASIC_TYPES:
                size[0] += BASIC_TYPES[ftype][1] * max(count, 1)
                if size[0] > MAX_RECORD_BYTES:
                    raise CorruptLogError(path, f"ULog format {name!r} is larger than any ULog message")
                if count > 0:
                    out.extend((f"{prefix}{fname}[{i}]", ftype) for i in range(count))
                else:
                    out.append((prefix + fname, ftype))
            elif count > 0:
                for i in range(count):
                    walk(f"{prefix}{fname}[{i}].", ftype, depth + 1)
            else:
                walk(f"{prefix}{fname}.", ftype, depth + 1)

    walk("", name, 0)
    while out and out[-1][0].startswith("_padding"):
        out.pop()
    return out


@dataclass
class _Subscription:
    name: str
    multi_id: int
    msg_id: int
    index: int  # message index of its 'A' (records before it are not its own)
    fields: list
    dtype: np.dtype
    timestamp_offset: int

    @property
    def timestamp_is_field(self) -> bool:
        return "timestamp" in self.dtype.names and self.dtype.fields["timestamp"][0] == np.dtype("<u8") \
            and self.dtype.fields["timestamp"][1] == self.timestamp_offset


def _subscription(payload: bytes, index: int, formats: dict, cache: dict, path) -> _Subscription:
    multi_id, msg_id = payload[0], _U16.unpack_from(payload, 1)[0]
    name = _string(payload[3:])
    if name not in cache:
        fields = _flatten(name, formats, path)
        try:
            dtype = np.dtype([(n, BASIC_TYPES[t][2]) for n, t in fields]).newbyteorder("<")
        except (ValueError, TypeError) as e:  # duplicate or empty field names
            raise FastULogUnsupported(f"format {name!r} gives no numpy dtype ({e})") from None
        t_off = 0
        for n, t in fields:
            if n == "timestamp":
                break
            t_off += BASIC_TYPES[t][1]
        cache[name] = (fields, dtype, t_off)
    fields, dtype, t_off = cache[name]
    return _Subscription(name, multi_id, msg_id, index, fields, dtype, t_off)


# ---------------------------------------------------------------- the header walk


class _DataRuns:
    """Runs of chained 'D' messages found with numpy, for :func:`_walk` to jump over.

    Candidates are the positions whose would-be type byte is 'D', whose ``next = pos + 3 + size``
    holds a known type byte, and that one of the ``POINTED_LOOKBACK`` candidates before it points
    at (a true 'D' message is pointed at by its predecessor unless that one is of another type;
    false candidates inside payloads rarely are). In candidate order, ``nxt[i] == pos[i + 1]`` links a
    candidate to the next one; ``run_last[i]`` is the last candidate of the linked run through ``i``. Nothing here is trusted
    by itself: the walk enters a run only from a position it reached by walking, so every
    candidate it takes is the true next message. Memory: a few arrays of 8 bytes per candidate
    (at most one per ``MAX_CANDIDATE_DENSITY`` bytes of file).
    """

    def __init__(self, data: bytes):
        n = len(data)
        buf = np.frombuffer(data, dtype=np.uint8)
        is_d = buf[2:] == MSG_DATA if n >= MSG_HEADER_BYTES + 2 else np.zeros(0, dtype=bool)
        if np.count_nonzero(is_d) > n // MAX_CANDIDATE_DENSITY:  # garbage: not worth 16 bytes a byte
            pos = nxt = np.zeros(0, np.int64)
        else:
            pos = np.flatnonzero(is_d)
            del is_d
            nxt = pos + MSG_HEADER_BYTES + _u16_view(data)[pos]
            # the next message of a 'D' starts with a known type byte; the file's last message, cut
            # or corrupt 'D' messages fail this and end a run: the walk steps them itself
            inside = nxt + 2 < n
            keep = inside & _KNOWN_TYPE[buf[np.where(inside, nxt + 2, 0)]]
            pos, nxt = pos[keep], nxt[keep]
            # a true 'D' after a 'D' is pointed at by its predecessor, which is one of the few
            # candidates just before it (false ones between two true ones are rare by now)
            pointed = np.zeros(len(pos), dtype=bool)
            for back in range(1, POINTED_LOOKBACK + 1):
                pointed[back:] |= nxt[:-back] == pos[back:]
            pos, nxt = pos[pointed], nxt[pointed]
        self.pos, self.nxt = pos, nxt
        self.count = len(pos)
        linked = np.zeros(self.count, dtype=bool)
        linked[:-1] = nxt[:-1] == pos[1:]
        ends = np.flatnonzero(~linked)
        self.run_last = np.repeat(ends, np.diff(ends, prepend=-1))

    def first_at_or_after(self, p: int) -> tuple[int, int]:
        i = int(np.searchsorted(self.pos, p))
        return i, (int(self.pos[i]) if i < self.count else -1)


_KNOWN_TYPE = np.zeros(256, dtype=bool)
_KNOWN_TYPE[list(DATA_SECTION_TYPES + DEFINITION_TYPES + (MSG_REMOVE_LOGGED,))] = True


def _walk(data: bytes, runs: _DataRuns, pos: int, limit: int, chunks: list) -> int:
    """Append (as int64 arrays, in file order) the offset of every whole message from ``pos`` that
    ends at or before ``limit``; return where the walk stopped (the first message not taken).

    Messages are stepped one by one in Python except where ``pos`` is the start of a run of
    linked 'D' candidates: the whole run is taken in one step (a real log is mostly such runs)."""
    singles = array("q")
    append = singles.append
    last = len(data) - MSG_HEADER_BYTES
    i, next_run = runs.first_at_or_after(pos)
    while pos <= last:
        if pos == next_run:
            j = int(runs.run_last[i])
            if int(runs.nxt[j]) > limit:  # the run crosses the segment's end: take what fits
                j = i + int(np.searchsorted(runs.nxt[i:j + 1], limit, "right")) - 1
            if j < i:
                break
            if singles:
                chunks.append(np.frombuffer(singles, dtype=np.int64))
                singles = array("q")
                append = singles.append
            chunks.append(runs.pos[i:j + 1])
            pos = int(runs.nxt[j])
            i, next_run = runs.first_at_or_after(pos)
            continue
        end = pos + MSG_HEADER_BYTES + (data[pos] | data[pos + 1] << 8)
        if end > limit:
            break
        append(pos)
        pos = end
        if pos > next_run >= 0:
            i, next_run = runs.first_at_or_after(pos)
    if singles:
        chunks.append(np.frombuffer(singles, dtype=np.int64))
    return pos


def _u16_view(data: bytes) -> np.ndarray:
    """Little-endian u16 starting at every byte offset (an unaligned strided view, no copy)."""
    return np.ndarray(shape=(max(len(data) - 1, 0),), dtype="<u2", buffer=data, strides=(1,))


# ---------------------------------------------------------------- entry points


def read_ulog_fast(path, topics: Optional[Iterable[str]] = None) -> FastULog:
    """Read the file at ``path`` (see :func:`read_ulog_bytes`)."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise NotALogError(path, f"cannot read: {e.strerror or e}") from None
    return read_ulog_bytes(data, topics, path=path)


def read_ulog_bytes(data: bytes, topics: Optional[Iterable[str]] = None, path=None) -> FastULog:
    """Decode ``topics`` (None: all) of a ULog held in ``data``.

    Raises :class:`FastULogUnsupported` for what only pyulog reproduces (module docstring) and
    :class:`CorruptLogError` for formats no ULog can hold."""
    wanted = None if topics is None else set(topics)
    n = len(data)
    if n < HEADER_BYTES or data[:7] != ULOG_MAGIC:
        raise FastULogUnsupported("no complete ULog file header")
    out = FastULog(file_version=data[7], start_timestamp=_U64.unpack_from(data, 8)[0])
    if out.file_version > 1:
        out.printed.append("Warning: unknown file version. Will attempt to read it anyway")

    # 'B' flag bits: only as the first message (pyulog complains about it anywhere else)
    pos = HEADER_BYTES
    if n >= pos + MSG_HEADER_BYTES and data[pos + 2] == MSG_FLAG_BITS:
        size = data[pos] | data[pos + 1] << 8
        if size < FLAG_BITS_BYTES or pos + MSG_HEADER_BYTES + size > n:
            raise FastULogUnsupported("flag bits message too short or cut")
        if size > FLAG_BITS_BYTES:
            out.printed.append("Warning: Flags Bit message is longer than expected")
        vals = _FLAG_BITS.unpack_from(data, pos + MSG_HEADER_BYTES)
        out.compat_flags, out.incompat_flags = list(vals[:8]), list(vals[8:16])
        offsets = list(vals[16:])
        while offsets and offsets[-1] == 0:
            offsets.pop()
        out.appended_offsets = offsets
        if out.incompat_flags[0] & ~1 or any(out.incompat_flags[1:]):
            raise FastULogUnsupported("unknown incompatible flag set")
    segment_starts = out.appended_offsets if (out.has_data_appended and out.appended_offsets) else []
    if any(b < a for a, b in zip(segment_starts, segment_starts[1:])):
        raise FastULogUnsupported("appended-data offsets out of order")
    limits = segment_starts + [n]  # an offset past the end (a cut file): pyulog reads to the end

    # ---- walk: segment 0 from the header, then each appended segment from its offset
    buf = np.frombuffer(data, dtype=np.uint8)
    u16 = _u16_view(data)
    runs = _DataRuns(data)
    chunks: list = []
    stop = _walk(data, runs, HEADER_BYTES, min(limits[0], n), chunks)
    out.truncated = limits[0] >= n and stop != n
    seg_bounds = [0]
    for start, limit in zip(segment_starts, limits[1:]):
        seg_bounds.append(sum(len(c) for c in chunks))
        if start >= n:
            continue
        if start < stop:
            raise FastULogUnsupported("appended-data offset inside data already read")
        stop = _walk(data, runs, start, min(limit, n), chunks)
        out.truncated = limit >= n and stop != n
    seg_bounds.append(sum(len(c) for c in chunks))
    del runs

    msg_pos = np.concatenate(chunks) if chunks else np.zeros(0, np.int64)
    msg_type = buf[msg_pos + 2]
    msg_size = u16[msg_pos].astype(np.int64)

    # ---- definitions: up to the first 'A', 'L' or 'C' of segment 0
    starts_data = np.flatnonzero(np.isin(msg_type[:seg_bounds[1]], DATA_SECTION_START_TYPES))
    def_end = int(starts_data[0]) if len(starts_data) else seg_bounds[1]
    # a cut message pyulog still sees the header of: its definitions loop parses the partial
    # payload unless the type ends the definitions (then its data loop drops the cut message)
    cut_ends_definitions = stop + MSG_HEADER_BYTES <= n and data[stop + 2] in DATA_SECTION_START_TYPES
    if not len(starts_data) and (segment_starts or (out.truncated and not cut_ends_definitions)):
        raise FastULogUnsupported("file ends (or data is appended) inside the definitions section")
    def_types = msg_type[:def_end]
    bad = ~np.isin(def_types, DEFINITION_TYPES) & ((def_types == 0) | (msg_size[:def_end] == 0)
                                                    | (msg_size[:def_end] > PYULOG_CORRUPT_SIZE))
    if bad.any():
        raise FastULogUnsupported(f"corrupt message in the definitions at byte {int(msg_pos[np.argmax(bad)])}")
    for k in np.flatnonzero(np.isin(def_types, DEFINITION_TYPES)).tolist():
        p, t = int(msg_pos[k]), int(def_types[k])
        payload = data[p + MSG_HEADER_BYTES:p + MSG_HEADER_BYTES + int(msg_size[k])]
        try:
            if t == MSG_FORMAT:
                fmt = _format(payload)
                out.message_formats[fmt.name] = fmt
            elif t in INFO_LIKE_TYPES:
                _add_info_like(out, t, payload)
            elif t == MSG_PARAMETER:
                _, key, value = _info(payload)
                out.initial_parameters[key] = value
            elif t == MSG_FLAG_BITS and p != HEADER_BYTES:
                raise FastULogUnsupported("flag bits message that is not the first message")
        except (IndexError, ValueError, KeyError, OverflowError, struct.error) as e:
            raise FastULogUnsupported(f"unparsable {chr(t)!r} definition at byte {p} ({_why(e)})") from None

    # ---- data section, segment by segment
    sub_cache: dict = {}
    filtered_at = np.full(0x10000, np.iinfo(np.int64).max, dtype=np.int64)  # first 'A' filtering a msg_id
    warned: set = set()
    record_ts = np.zeros(len(msg_pos), dtype=np.uint64)  # timestamp of each decoded record, else 0
    pending_ts: list = []  # (message index, setter) of dropouts / changed parameters
    for seg in range(len(seg_bounds) - 1):
        lo = def_end if seg == 0 else seg_bounds[seg]
        hi = seg_bounds[seg + 1]
        if hi <= lo:
            continue
        types = msg_type[lo:hi]
        sizes = msg_size[lo:hi]
        known = np.isin(types, DATA_SECTION_TYPES)
        bad = ~known & ((types == 0) | (sizes == 0) | (sizes > PYULOG_CORRUPT_SIZE))
        if bad.any():
            raise FastULogUnsupported(f"corrupt message (unknown type {int(types[np.argmax(bad)])}) at byte "
                                      f"{int(msg_pos[lo + np.argmax(bad)])}: pyulog re-synchronises")
        is_data = types == MSG_DATA
        subs: dict[int, _Subscription] = {}
        for j in np.flatnonzero(~is_data).tolist():
            k = lo + j
            p, t, size = int(msg_pos[k]), int(types[j]), int(sizes[j])
            payload = data[p + MSG_HEADER_BYTES:p + MSG_HEADER_BYTES + size]
            try:
                if t == MSG_ADD_LOGGED:
                    sub = _subscription(payload, k, out.message_formats, sub_cache, path)
                    if wanted is None or sub.name in wanted:
                        if sub.msg_id in subs:
                            raise FastULogUnsupported(f"msg_id {sub.msg_id} subscribed twice")
                        subs[sub.msg_id] = sub
                    else:
                        filtered_at[sub.msg_id] = min(filtered_at[sub.msg_id], k)
                elif t == MSG_PARAMETER:
                    _, key, value = _info(payload)
                    out.changed_parameters.append([0, key, value])
                    pending_ts.append((k, out.changed_parameters[-1]))
                elif t == MSG_DROPOUT:
                    (duration,) = _U16.unpack(payload)
                    out.dropouts.append(Dropout(0, duration))
                    pending_ts.append((k, out.dropouts[-1]))
                elif t in INFO_LIKE_TYPES:
                    _add_info_like(out, t, payload)
                elif t == MSG_LOGGING:
                    level, ts = _LOGGING.unpack(payload[:9])
                    out.logged_messages.append(LoggedMessage(level, ts, _string(payload[9:])))
                elif t == MSG_LOGGING_TAGGED:
                    level, tag, ts = _LOGGING_TAGGED.unpack(payload[:11])
                    out.logged_messages_tagged.setdefault(tag, []).append(
                        LoggedMessage(level, ts, _string(payload[11:]), tag))
                elif t == MSG_SYNC:
                    out.sync_count += 1
                elif SYNC_BYTES in payload:  # unknown type: pyulog looks for a sync marker inside
                    raise FastULogUnsupported(f"sync marker inside an unknown message at byte {p}")
            except (IndexError, ValueError, KeyError, OverflowError, struct.error) as e:
                raise FastULogUnsupported(f"unparsable {chr(t)!r} message at byte {p} ({_why(e)})") from None

        # 'D' records: msg_id, then one gather per wanted subscription
        d_idx = np.flatnonzero(is_data)
        d_size = sizes[d_idx]
        if (d_size < 2).any():
            raise FastULogUnsupported("data message shorter than its msg_id")
        d_pos = msg_pos[lo + d_idx]
        d_id = u16[d_pos + MSG_HEADER_BYTES]  # uint16: the stable argsort below is a radix sort
        d_k = lo + d_idx
        sub_at = np.full(0x10000, np.iinfo(np.int64).max, dtype=np.int64)
        for sub in subs.values():
            sub_at[sub.msg_id] = sub.index
        ours = sub_at[d_id] < d_k
        missing = ~ours & ~(filtered_at[d_id] < d_k)
        if missing.any():
            out.file_corruption = True
            ids, first = np.unique(d_id[missing], return_index=True)
            for mid in ids[np.argsort(first)].tolist():
                if mid not in warned:
                    warned.add(mid)
                    out.printed.append(NO_SUBSCRIPTION_WARNING.format(mid))
        decoded: dict[int, np.ndarray] = {}
        if len(subs) > FEW_SUBSCRIPTIONS:  # group the records by msg_id once (radix sort of uint16)
            sel = np.flatnonzero(ours)
            by_id = sel[np.argsort(d_id[sel], kind="stable")]  # file order within each msg_id
            sorted_ids = d_id[by_id]
        for sub in subs.values():
            if len(subs) > FEW_SUBSCRIPTIONS:
                a, b = np.searchsorted(sorted_ids, np.array([sub.msg_id, sub.msg_id + 1]))
                mine = by_id[a:b]
            else:
                mine = np.flatnonzero(ours & (d_id == sub.msg_id))
            if not len(mine):
                continue
            right = mine[d_size[mine] - 2 == sub.dtype.itemsize]
            if len(right) != len(mine):
                out.file_corruption = True  # pyulog skips records of another size silently
            if not len(right):
                continue
            if sub.timestamp_offset + 8 > sub.dtype.itemsize:  # pyulog stops reading the file there
                raise FastULogUnsupported(f"topic {sub.name!r} has no 8-byte timestamp where pyulog reads it")
            # the file seen as overlapping records of this size, one per byte offset: indexing
            # it with the record offsets copies exactly the records (memcpy per row)
            size = sub.dtype.itemsize
            records = np.ndarray(shape=(n - size + 1,), dtype=f"V{size}", buffer=data, strides=(1,))
            rows = records[d_pos[right] + MSG_HEADER_BYTES + 2]
            table = rows.view(sub.dtype)
            if sub.timestamp_is_field:
                record_ts[d_k[right]] = table["timestamp"]
            else:  # pyulog reads 8 bytes at the offset whatever the field's type
                raw = rows.view(np.uint8).reshape(-1, size)
                stamps = np.ascontiguousarray(raw[:, sub.timestamp_offset:sub.timestamp_offset + 8])
                record_ts[d_k[right]] = stamps.view("<u8").reshape(-1)
            decoded[sub.msg_id] = table
        # pyulog pops its subscriptions (last added first) into data_list, then sorts stably
        for msg_id in reversed(list(subs)):
            if msg_id in decoded:
                sub, table = subs[msg_id], decoded[msg_id]
                out.data_list.append(TopicData(sub.name, sub.multi_id, sub.msg_id, sub.fields,
                                               {name: table[name] for name in table.dtype.names}))
        out.data_list.sort(key=lambda d: (d.name, d.multi_id))

    # ---- last_timestamp: running maximum of the decoded records' timestamps (pyulog's rule);
    # a dropout or changed parameter gets the value reached before its own message
    running = np.maximum.accumulate(record_ts) if len(record_ts) else record_ts
    out.last_timestamp = max(out.start_timestamp, int(running[-1])) if len(running) else out.start_timestamp
    for k, item in pending_ts:
        value = max(out.start_timestamp, int(running[k - 1])) if k else out.start_timestamp
        if isinstance(item, Dropout):
            item.timestamp = value
        else:
            item[0] = value
    out.changed_parameters = [tuple(c) for c in out.changed_parameters]
    return out


def _why(e: Exception) -> str:
    return str(e) or type(e).__name__


def _add_info_like(out: FastULog, t: int, payload: bytes) -> None:
    """Store a message of ``INFO_LIKE_TYPES``: the definitions and the data section carry them alike."""
    if t == MSG_INFO:
        vtype, key, value = _info(payload)
        out.msg_info_dict[key] = value
        out.msg_info_dict_types[key] = vtype
    elif t == MSG_INFO_MULTIPLE:
        _add_info_multiple(out, payload)
    else:
        _add_default(out, payload)


def _add_info_multiple(out: FastULog, payload: bytes) -> None:
    continued = payload[0]
    vtype, key, value = _info(payload[1:])
    if key in out.msg_info_multiple_dict:
        if continued:
            out.msg_info_multiple_dict[key][-1].append(value)
        else:
            out.msg_info_multiple_dict[key].append([value])
    else:
        out.msg_info_multiple_dict[key] = [[value]]


def _add_default(out: FastULog, payload: bytes) -> None:
    bits = payload[0]
    _, key, value = _info(payload[1:])
    for bit in range(8):
        if bits & (1 << bit):  # pyulog's key is the bit's value minus one (bits 0, 1 -> 0, 1; bit 2 -> 3)
            out.default_parameters.setdefault((1 << bit) - 1, {})[key] = value


__all__ = ["read_ulog_fast", "read_ulog_bytes", "FastULog", "FastULogUnsupported", "TopicData"]
