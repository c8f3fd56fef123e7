"""The fast ULog reader against pyulog: same values on every ULog we have, explicit fallbacks.

- Every field of every topic instance (exact equality, NaN == NaN), in pyulog's ``data_list``
  order, plus info, multi-info, initial / default / changed parameters, logged messages,
  dropouts, start / last timestamp, corruption flag and pyulog's printed warnings: on
  ``sample_logs/*.ulg`` (every topic) and on every ULog in ``../shared`` (every topic for files up
  to ``FULL_COMPARE_MAX_BYTES``, fdlog's ``ULOG_TOPICS`` for the bigger ones, to keep the run short).
- ``read_ulog`` gives the same Flight with either reader.
- What the fast reader refuses goes to pyulog, and ``Flight.reader`` / ``fdlog info`` say so.
- Damaged files (cuts, corrupt sizes, random byte changes): the fast reader either gives pyulog's
  values or refuses (FastULogUnsupported / FlightLogError), never another exception.
"""
from __future__ import annotations

import contextlib
import io
import json
import struct
from pathlib import Path

import numpy as np
import pytest

from flightlog_fd.errors import CorruptLogError, FlightLogError
from flightlog_fd.logs import ulog as ulog_module
from flightlog_fd.logs.ulog import READER_FAST, ULOG_TOPICS, _ends_cut, read_ulog
from flightlog_fd.logs.ulog_fast import FastULogUnsupported, read_ulog_bytes, read_ulog_fast

from conftest import ROOT, SHARED

SAMPLE_ULOGS = sorted((ROOT / "sample_logs").glob("*.ulg"))
#: Bigger shared logs are compared on fdlog's topics only (every topic of all of them takes ~60 s).
FULL_COMPARE_MAX_BYTES = 3_000_000


def _shared_ulogs() -> list[Path]:
    found = []
    for folder in ("real_logs/px4", "px4_sih_dev/logs", "crazypad_e9/ulog"):
        base = SHARED / folder
        if base.is_dir():
            found += sorted(base.rglob("*.ulg"))
    return found


def _pyulog(data: bytes, topics):
    from pyulog import ULog

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        ulog = ULog(io.BytesIO(data), message_name_filter_list=topics, disable_str_exceptions=True)
    return ulog, printed.getvalue().strip().splitlines()


def _messages(items):
    return [(m.log_level, m.timestamp, m.message) for m in items]


def assert_same_as_pyulog(data: bytes, topics, fast=None) -> None:
    """Everything the fast reader returns equals pyulog's reading of the same bytes."""
    fast = read_ulog_bytes(data, topics) if fast is None else fast
    ref, printed = _pyulog(data, topics)
    assert [(d.name, d.multi_id, d.msg_id) for d in fast.data_list] == \
        [(d.name, d.multi_id, d.msg_id) for d in ref.data_list]
    for mine, theirs in zip(fast.data_list, ref.data_list):
        assert list(mine.data) == list(theirs.data), mine.name
        assert [(f.field_name, f.type_str) for f in theirs.field_data] == mine.field_data
        for name, expected in theirs.data.items():
            got = mine.data[name]
            assert got.dtype == expected.dtype, f"{mine.name}.{name}"
            assert np.array_equal(got, expected, equal_nan=expected.dtype.kind == "f"), f"{mine.name}.{name}"
    assert fast.msg_info_dict == ref.msg_info_dict
    assert fast.msg_info_multiple_dict == ref.msg_info_multiple_dict
    assert fast.initial_parameters == ref.initial_parameters
    assert fast.default_parameters == ref._default_parameters
    assert fast.changed_parameters == ref.changed_parameters
    assert [(d.timestamp, d.duration) for d in fast.dropouts] == [(d.timestamp, d.duration) for d in ref.dropouts]
    assert _messages(fast.logged_messages) == _messages(ref.logged_messages)
    assert {k: _messages(v) for k, v in fast.logged_messages_tagged.items()} == \
        {k: _messages(v) for k, v in ref.logged_messages_tagged.items()}
    assert {k: f.fields for k, f in fast.message_formats.items()} == \
        {k: f.fields for k, f in ref.message_formats.items()}
    assert (fast.start_timestamp, fast.last_timestamp) == (ref.start_timestamp, ref.last_timestamp)
    assert fast.file_corruption == ref.file_corruption
    assert fast.printed == printed
    if not fast.has_data_appended:  # with appended data the fast walk follows pyulog's segments
        assert fast.truncated == _ends_cut(data)


# ---------------------------------------------------------------- identical values


@pytest.mark.parametrize("path", SAMPLE_ULOGS, ids=lambda p: p.name)
def test_sample_logs_every_topic_equals_pyulog(path):
    data = path.read_bytes()
    assert_same_as_pyulog(data, None)
    assert_same_as_pyulog(data, ULOG_TOPICS)


@pytest.mark.shared
def test_shared_ulogs_equal_pyulog():
    paths = _shared_ulogs()
    if not paths:
        pytest.skip("../shared not available")
    assert len(paths) > 40  # px4 real logs, rflymad, SIH, crazypad: all present
    for path in paths:
        data = path.read_bytes()
        topics = None if len(data) <= FULL_COMPARE_MAX_BYTES else ULOG_TOPICS
        try:
            assert_same_as_pyulog(data, topics)
        except AssertionError as e:
            raise AssertionError(f"{path}: {e}") from None


@pytest.mark.parametrize("path", SAMPLE_ULOGS[:2], ids=lambda p: p.name)
def test_read_ulog_same_flight_with_either_reader(path):
    fast, slow = read_ulog(path), read_ulog(path, reader="pyulog")
    assert fast.reader == READER_FAST and slow.reader == "pyulog"
    for name in ("rates", "attitude", "motors", "esc_rpm", "velocity"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert (a is None) == (b is None), name
        if a is not None:
            assert a.source == b.source
            np.testing.assert_array_equal(a.t, b.t)
            np.testing.assert_array_equal(a.values, b.values)
    for name in ("armed", "airborne", "airborne_source", "t_start", "t_end", "params", "warnings", "frame",
                 "firmware", "vehicle_type", "motor_kind", "thrust_curve"):
        assert getattr(fast, name) == getattr(slow, name), name


@pytest.mark.shared
def test_every_shared_ulog_uses_the_fast_reader(shared):
    """No silent fallback on real logs: a fallback there would hide a gap in the fast reader."""
    for path in [shared("real_logs", "px4", "sample_appended_multiple.ulg"),
                 shared("real_logs", "px4", "sample_logging_tagged_and_default_params.ulg"),
                 shared("real_logs", "px4", "sample_px4_events.ulg")]:
        assert read_ulog(path).reader == READER_FAST


# ---------------------------------------------------------------- explicit fallback


def _offsets(data: bytes) -> list[int]:
    out, pos = [], 16
    while pos + 3 <= len(data):
        out.append(pos)
        pos += 3 + struct.unpack_from("<H", data, pos)[0]
    return out


def _insert_after_first_data(data: bytes, message: bytes) -> bytes:
    """``message`` (header included) placed right after the first 'D' message."""
    for pos in _offsets(data):
        if data[pos + 2] == ord("D"):
            end = pos + 3 + struct.unpack_from("<H", data, pos)[0]
            return data[:end] + message + data[end:]
    raise AssertionError("no data message")


def _message(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


SMALL = ROOT / "sample_logs" / "px4_motor4_damaged.ulg"


@pytest.mark.parametrize("bad,why", [
    (struct.pack("<HB", 0, 0) + b"\x00" * 20, "corrupt message"),  # type 0: pyulog re-synchronises
    (_message("O", b"\x01\x02\x03"), "unparsable 'O'"),  # dropout of 3 bytes: pyulog stops reading
    (_message("A", b"\x00\x63\x00no_such_format"), "undefined format"),
    (_message("R", b"\x05" + b"\x2F\x73\x13\x20\x25\x0C\xBB\x12"), "sync marker"),
])
def test_fallback_to_pyulog_is_explicit(tmp_path, bad, why):
    data = _insert_after_first_data(SMALL.read_bytes(), bad)
    with pytest.raises(FastULogUnsupported, match=why):
        read_ulog_bytes(data, ULOG_TOPICS)
    path = tmp_path / "odd.ulg"
    path.write_bytes(data)
    flight, slow = read_ulog(path), read_ulog(path, reader="pyulog")
    assert flight.reader.startswith("pyulog (fallback: ") and why in flight.reader
    # what pyulog makes of it (it stops reading at the short dropout, so no motors there)
    assert flight.warnings == slow.warnings and flight.t_end == slow.t_end
    assert (flight.motors is None) == (why == "unparsable 'O'")


def test_fallback_when_the_fast_reader_breaks(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise ZeroDivisionError("bug")

    monkeypatch.setattr(ulog_module, "read_ulog_bytes", broken)
    flight = read_ulog(SMALL)
    assert flight.reader == "pyulog (fallback: fast reader failed (ZeroDivisionError: bug))"
    assert flight.motors is not None


def test_info_says_which_reader(tmp_path):
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    res = CliRunner().invoke(app, ["info", "--json", str(SMALL)])
    assert json.loads(res.stdout)["reader"] == READER_FAST
    odd = tmp_path / "odd.ulg"
    odd.write_bytes(_insert_after_first_data(SMALL.read_bytes(), _message("O", b"\x01\x02\x03")))
    res = CliRunner().invoke(app, ["info", str(odd)])
    assert "reader     pyulog (fallback: unparsable 'O' message" in res.stdout


def test_skipped_records_and_unknown_ids_match_pyulog():
    """A record of the wrong size and one of an unsubscribed msg_id: corrupt, skipped, same warning."""
    data = SMALL.read_bytes()
    first_d = next(p for p in _offsets(data) if data[p + 2] == ord("D"))
    msg_id = data[first_d + 3:first_d + 5]
    data = _insert_after_first_data(data, _message("D", msg_id + b"\x00" * 7) + _message("D", b"\xee\x02" + b"\x01" * 9))
    fast = read_ulog_bytes(data, None)
    assert fast.file_corruption
    assert fast.printed == ["Warning: no subscription found for message id 750. Continuing, but file is most "
                            "likely corrupt"]
    assert_same_as_pyulog(data, None, fast)


# ---------------------------------------------------------------- damaged files


def test_cut_anywhere_matches_pyulog_or_refuses():
    data = SMALL.read_bytes()
    offsets = _offsets(data)
    first_a = next(p for p in offsets if data[p + 2] == ord("A"))
    cuts = [17, 40, first_a - 1, first_a + 2] + list(np.linspace(first_a + 5, len(data) - 1, 12).astype(int))
    for cut in cuts:
        piece = data[:cut]
        try:
            fast = read_ulog_bytes(piece, ULOG_TOPICS)
        except FastULogUnsupported:
            assert cut < first_a + 3  # only a cut inside the definitions is refused
            continue
        assert fast.truncated
        assert_same_as_pyulog(piece, ULOG_TOPICS, fast)


def test_random_damage_matches_pyulog_or_refuses():
    """Bytes overwritten at random places (sizes, types, ids, payloads): pyulog's values or a refusal."""
    clean = SMALL.read_bytes()
    offsets = np.array(_offsets(clean))
    rng = np.random.default_rng(7)
    outcomes = {"same": 0, "refused": 0}
    for trial in range(40):
        data = bytearray(clean)
        for pos in rng.choice(offsets[10:], size=3, replace=False):
            pos = int(pos) + int(rng.integers(0, 6))  # header bytes or the msg_id / first payload bytes
            data[pos] = int(rng.integers(0, 256))
        data = bytes(data)
        try:
            fast = read_ulog_bytes(data, ULOG_TOPICS)
        except (FastULogUnsupported, FlightLogError):
            outcomes["refused"] += 1
            continue
        assert_same_as_pyulog(data, ULOG_TOPICS, fast)
        outcomes["same"] += 1
    assert outcomes["same"] >= 5 and outcomes["refused"] >= 5, outcomes  # both paths were exercised


@pytest.mark.parametrize("fields,error", [
    (b"loop:loop inner;uint64_t timestamp;", "nests more than"),
    (b"huge:uint64_t timestamp;double[60000] a;", "larger than any ULog message"),
])
def test_impossible_formats_raise_corrupt(tmp_path, fields, error):
    """Formats no ULog message can hold are refused with one clear line, not handed to pyulog
    (which would recurse without end or build hundreds of thousands of fields)."""
    name = fields.split(b":")[0]
    data = SMALL.read_bytes()
    first_a = next(p for p in _offsets(data) if data[p + 2] == ord("A"))
    data = data[:first_a] + _message("F", fields) + _message("A", b"\x00\x90\x01" + name) + data[first_a:]
    with pytest.raises(CorruptLogError, match=error):
        read_ulog_bytes(data, ULOG_TOPICS)
    path = tmp_path / "bad.ulg"
    path.write_bytes(data)
    with pytest.raises(CorruptLogError, match=error):
        read_ulog(path)


def test_header_only_and_garbage_never_leak():
    head = SMALL.read_bytes()[:16]
    for data in (head, head + b"\xff\xff", head + bytes(range(256)) * 40, b"ULog", head + b"D" * 100_000,
                 head + bytes(30_000), head + b"\x02\x00D\x01\x00" * 10_000):
        try:
            fast = read_ulog_bytes(data, ULOG_TOPICS)
        except (FastULogUnsupported, FlightLogError):
            continue
        assert fast.data_list == []


@pytest.mark.shared
def test_cut_appended_data_log_matches_pyulog(shared):
    """Appended-data offsets past the end of a cut file: pyulog reads to the end, so do we."""
    data = shared("real_logs", "px4", "sample_appended_multiple.ulg").read_bytes()
    fast = read_ulog_bytes(data, None)
    assert fast.has_data_appended and fast.appended_offsets
    for cut in (fast.appended_offsets[0] - 7, fast.appended_offsets[-1] + 1001, len(data) - 5):
        assert_same_as_pyulog(data[:cut], None)


def test_read_ulog_fast_from_path_matches_bytes():
    a, b = read_ulog_fast(SMALL, ULOG_TOPICS), read_ulog_bytes(SMALL.read_bytes(), ULOG_TOPICS)
    assert [d.name for d in a.data_list] == [d.name for d in b.data_list]
    assert a.last_timestamp == b.last_timestamp
