"""Corrupted logs: every damaged file ends quickly in a verdict or one clear line, never a crash.

Seeded mutations (truncation, single bit flips, zeroed blocks, duplicated blocks) of the sample
logs and of a few small real logs from ../shared (skipped when absent) go through the public
loader and the diagnosis in-process (``diagnose_path`` with the shipped model loaded once), and a
handful through the CLI. Each case must end with a status in healthy / damaged / uncertain /
not_diagnosable (exit code 0/1/2), without an uncaught exception, in under ``CASE_LIMIT_S``.
Half of the offsets fall in the first ``HEAD_BYTES`` of the file (header, format definitions,
parameters), where one flipped bit does the most damage. Every failure names the case
(file, mutation, offset, argument) and the seed, so it reproduces with ``mutate()``.

The checks are reader-agnostic: only ``flightlog_fd.load_flight`` / ``diagnose_path`` and the CLI
are called, so whatever reader ``read_ulog`` switches on is exercised too.

A valid start of a log followed by random bytes (a ULog file header or part of its definitions,
a DataFlash FMT message or part of its FMT table; several seeds and sizes) goes through the real
`fdlog diagnose` in a subprocess with a timeout: every file must end in one error line, exit 2.
A differential test holds :func:`~flightlog_fd.logs.ulog.pyulog_definitions_stall` to pyulog's
own behaviour on such files (it used to spin for ever on most ULog ones).

Two regression cases are built deterministically from sample logs: a flipped high bit in a
DataFlash ``TimeUS`` (which made `fdlog diagnose` ask for petabytes and die with a traceback) and
a flipped bit in a ULog header timestamp of a log that ends airborne (which took minutes).
Typical figures: ``python benchmarks/bench_fuzz.py``.
"""
from __future__ import annotations

import random
import signal
import struct
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from flightlog_fd import load_flight
from flightlog_fd.cli import app
from flightlog_fd.diagnose import diagnose_path

from conftest import ROOT, shared_path

SEED = 20240610
SAMPLES = ROOT / "sample_logs"
#: The issue's requirement for one corrupted file (load + diagnose); cases take ~0.1 s here.
CASE_LIMIT_S = 10.0
#: A case still running after this is reported as hung (SIGALRM) instead of stalling the suite.
HANG_LIMIT_S = 60
#: Bytes at the start of a file that hold the header, format definitions and parameters.
HEAD_BYTES = 4096
STATUSES = {"healthy", "damaged", "uncertain", "not_diagnosable"}
MUTATIONS = ("truncate", "flip", "flip", "flip", "zero", "dup")

#: (file, random cases, timestamp cases): the small sample logs of both formats (~0.1 s a case).
SAMPLE_CASES = [
    ("px4_motor2_damaged.ulg", 30, 12),
    ("px4_motor4_damaged.ulg", 30, 12),
    ("ardupilot_healthy.bin", 30, 12),
    ("ardupilot_motor2_damaged.bin", 30, 12),
    ("ardupilot_plus_motor4_damaged.bin", 30, 0),
]
#: Small real logs from ../shared (their path under it, random cases, timestamp cases).
SHARED_CASES = [
    (("real_logs", "px4", "robologs_f450_ground.ulg"), 12, 4),
    (("real_logs", "px4", "sample_appended_multiple.ulg"), 12, 4),
    (("real_logs", "px4", "sample_px4_events.ulg"), 12, 4),
    (("real_logs", "ardupilot", "arducopter46_truncated_80k.bin"), 12, 4),
    (("real_logs", "ardupilot", "erle_copter34_7.BIN"), 12, 4),
]


@dataclass(frozen=True)
class Case:
    """One mutation of one file: ``arg`` is the bit (flip) or block length (zero, dup); ``cut``
    (when non-zero) truncates the file there first, so that the log ends in flight."""

    file: str
    mutation: str
    offset: int
    arg: int
    cut: int = 0

    def __str__(self) -> str:
        cut = f" after a cut at {self.cut}" if self.cut else ""
        return f"{self.file} {self.mutation} offset={self.offset} arg={self.arg}{cut} (seed {SEED})"


def mutate(data: bytes, case: Case) -> bytes:
    """The damaged bytes for ``case``."""
    b = bytearray(data[:case.cut] if case.cut else data)
    off = case.offset
    if case.mutation == "truncate":
        return bytes(b[:off])
    if case.mutation == "flip":
        b[off] ^= 1 << case.arg
        return bytes(b)
    if case.mutation == "zero":
        end = min(len(b), off + case.arg)
        b[off:end] = bytes(end - off)
        return bytes(b)
    if case.mutation == "dup":
        return bytes(b[:off + case.arg] + b[off:off + case.arg] + b[off + case.arg:])
    raise ValueError(case.mutation)


def make_cases(name: str, size: int, count: int) -> list[Case]:
    """``count`` seeded cases for a file of ``size`` bytes (same list on every run)."""
    rng = random.Random(f"{SEED}:{name}")
    cases = []
    for _ in range(count):
        mutation = rng.choice(MUTATIONS)
        span = min(size, HEAD_BYTES) if rng.random() < 0.5 else size
        offset = rng.randrange(1, span) if mutation == "truncate" else rng.randrange(span)
        arg = rng.randrange(8) if mutation == "flip" else rng.choice((8, 64, 512, 4096))
        cases.append(Case(name, mutation, offset, arg))
    return cases


def ulog_data_messages(data: bytes):
    """Offsets of the ULog data ('D') messages: walked by their (size, type) headers."""
    pos = 16
    while pos + 3 <= len(data):
        size, kind = struct.unpack_from("<HB", data, pos)
        if kind == ord("D"):
            yield pos
        pos += 3 + size


def timestamp_cases(name: str, data: bytes, count: int) -> list[Case]:
    """Flipped high bits (24..63, i.e. 17 s to 292 000 years in microseconds) in the timestamps of
    seeded data messages of a log cut at 60 % (so it ends in flight): the class of damage that
    once made a diagnosis allocate petabytes or run for minutes."""
    rng = random.Random(f"{SEED}:timestamps:{name}")
    cut = int(len(data) * 0.6)
    head = data[:cut]
    if name.lower().endswith(".ulg"):
        # size, type, msg_id, then the uint64 timestamp: flip in its bytes 3..7
        stamps = [(pos + 5, 3, 8) for pos in ulog_data_messages(head)]
    else:
        # TimeUS (uint64): bytes 3..7; TimeMS (uint32, before ArduCopter 3.4): bytes 1..3
        widths = {"TimeUS": (3, 8), "TimeMS": (1, 4)}
        stamps = [(pos + 3, *widths[cols[0]]) for pos, _, cols in dataflash_messages(head)
                  if cols and cols[0] in widths]
    stamps = [s for s in stamps if s[0] + s[2] <= cut]
    if not stamps:
        return []
    cases = []
    for _ in range(count):
        start, first_byte, width = rng.choice(stamps)
        cases.append(Case(name, "flip", start + rng.randrange(first_byte, width), rng.randrange(8), cut))
    return cases


class _Hung(Exception):
    pass


def _on_alarm(signum, frame):
    raise _Hung()


def run_case(path: Path, model) -> tuple[str, float]:
    """(outcome, seconds): outcome is the verdict status or "EXCEPTION ..." / "HUNG"."""
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(HANG_LIMIT_S)
    t0 = time.perf_counter()
    try:
        d = diagnose_path(path, model, keep_flight=False)
        outcome = d.verdict.status
        if d.exit_code not in (0, 1, 2):
            outcome = f"exit code {d.exit_code} for status {outcome}"
    except _Hung:
        outcome = f"HUNG (> {HANG_LIMIT_S} s)"
    except Exception as e:  # the point of the test: report which case, not just that one failed
        where = traceback.extract_tb(e.__traceback__)[-1]
        outcome = f"EXCEPTION {type(e).__name__}: {str(e)[:200]} at {Path(where.filename).name}:{where.lineno}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return outcome, time.perf_counter() - t0


@pytest.fixture(scope="module")
def model():
    from flightlog_fd.model import FaultModel, default_model_path

    model = FaultModel(default_model_path())
    # one clean run first, so that no case is timed with the one-off imports (scipy.signal: seconds)
    assert diagnose_path(SAMPLES / "px4_motor4_damaged.ulg", model, keep_flight=False).verdict.status in STATUSES
    return model


def fuzz_file(source: Path, count: int, stamp_count: int, model, tmp_path: Path) -> None:
    data = source.read_bytes()
    failures = []
    cases = make_cases(source.name, len(data), count) + timestamp_cases(source.name, data, stamp_count)
    for case in cases:
        damaged = tmp_path / f"damaged{source.suffix}"
        damaged.write_bytes(mutate(data, case))
        outcome, seconds = run_case(damaged, model)
        if outcome not in STATUSES:
            failures.append(f"{case}: {outcome}")
        elif seconds > CASE_LIMIT_S:
            failures.append(f"{case}: took {seconds:.1f} s (limit {CASE_LIMIT_S:.0f} s)")
    assert not failures, f"{len(failures)} of {len(cases)} corrupted cases failed:\n" + "\n".join(failures)


@pytest.mark.parametrize("name,count,stamp_count", SAMPLE_CASES)
def test_corrupted_sample_logs(name, count, stamp_count, model, tmp_path):
    fuzz_file(SAMPLES / name, count, stamp_count, model, tmp_path)


@pytest.mark.shared
@pytest.mark.parametrize("parts,count,stamp_count", SHARED_CASES, ids=[p[-1] for p, _, _ in SHARED_CASES])
def test_corrupted_real_logs(parts, count, stamp_count, model, tmp_path):
    fuzz_file(shared_path(*parts), count, stamp_count, model, tmp_path)


# ----------------------------------------------------------------------------- the CLI

CLI_CASES = [
    Case("px4_motor2_damaged.ulg", "truncate", 2000, 0),  # cut inside the definitions
    Case("px4_motor2_damaged.ulg", "zero", 0, 64),  # magic bytes gone
    Case("px4_motor2_damaged.ulg", "flip", 100, 1),  # a format definition
    Case("ardupilot_healthy.bin", "zero", 0, 4096),  # FMT table gone
    Case("ardupilot_healthy.bin", "truncate", 500, 0),  # cut inside the FMT table
    Case("ardupilot_healthy.bin", "dup", 100_000, 4096),  # a replayed block
]


@pytest.mark.parametrize("case", CLI_CASES, ids=str)
def test_corrupted_logs_through_the_cli(case, tmp_path):
    damaged = tmp_path / f"damaged{Path(case.file).suffix}"
    damaged.write_bytes(mutate((SAMPLES / case.file).read_bytes(), case))
    res = CliRunner().invoke(app, ["diagnose", str(damaged)])
    assert res.exit_code in (0, 1, 2), f"{case}: exit code {res.exit_code}\n{res.output}"
    assert res.exception is None or isinstance(res.exception, SystemExit), f"{case}: {res.exception!r}"
    assert "Traceback" not in res.output, f"{case}:\n{res.output}"
    if res.exit_code == 2:
        errors = [ln for ln in res.output.splitlines() if ln.startswith("fdlog: ")]
        assert errors and all(str(damaged) in ln for ln in errors), f"{case}: no one-line error\n{res.output}"


# ----------------------------------------------------------------------------- regressions

def dataflash_messages(data: bytes):
    """(offset, type name, column names) of every message, walked with the file's own FMT table."""
    formats = {0x80: (89, "FMT", ["Type", "Length", "Name", "Format", "Columns"])}
    pos = 0
    while pos + 3 <= len(data):
        if data[pos] != 0xA3 or data[pos + 1] != 0x95 or data[pos + 2] not in formats:
            pos += 1
            continue
        length, name, columns = formats[data[pos + 2]]
        if name == "FMT" and pos + 89 <= len(data):
            type_id, msg_len = data[pos + 3], data[pos + 4]
            formats[type_id] = (msg_len, data[pos + 5:pos + 9].rstrip(b"\0").decode(),
                                data[pos + 25:pos + 89].rstrip(b"\0").decode().split(","))
        yield pos, name, columns
        pos += length


def test_flipped_dataflash_timestamp_is_dropped_with_a_warning(model, tmp_path):
    """Bit 60 of one CTUN.TimeUS in a log that ends airborne: the flight used to stretch to
    2^60 us and the resampler to ask for petabytes (MemoryError traceback)."""
    data = bytearray((SAMPLES / "ardupilot_motor2_damaged.bin").read_bytes()[:200_000])  # cut in flight
    ctun = [pos for pos, name, cols in dataflash_messages(bytes(data)) if name == "CTUN" and cols[0] == "TimeUS"]
    pos = ctun[len(ctun) // 2]
    (before,) = struct.unpack_from("<Q", data, pos + 3)
    data[pos + 3 + 7] ^= 1 << 4  # bit 60 of the little-endian uint64 TimeUS
    assert struct.unpack_from("<Q", data, pos + 3)[0] == before ^ (1 << 60)
    damaged = tmp_path / "flipped_timeus.bin"
    damaged.write_bytes(bytes(data))

    flight = load_flight(damaged)
    assert flight.t_end - flight.t_start < 3600, (flight.t_start, flight.t_end)
    assert all(b < flight.t_end + 1e-9 for _, b in flight.airborne)
    assert any(w.startswith("CTUN messages: dropped 1 sample with an implausible timestamp") for w in flight.warnings), \
        flight.warnings
    d = diagnose_path(damaged, model, keep_flight=False)
    assert d.verdict.status in STATUSES
    assert any("CTUN messages: dropped 1 sample" in w for w in d.warnings)
    res = CliRunner().invoke(app, ["diagnose", str(damaged)])
    assert res.exit_code in (0, 1, 2), res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output


def test_flipped_ulog_header_timestamp_finishes_quickly(model, tmp_path):
    """Bit 43 of the ULog header's start time in a log cut while airborne: the airborne interval
    used to run to the bogus start time (8.8e6 s) and the diagnosis took minutes."""
    data = bytearray((SAMPLES / "px4_motor2_damaged.ulg").read_bytes()[:200_000])  # cut in flight
    data[8 + 43 // 8] ^= 1 << (43 % 8)
    damaged = tmp_path / "flipped_header.ulg"
    damaged.write_bytes(bytes(data))

    outcome, seconds = run_case(damaged, model)
    assert outcome in STATUSES, outcome
    assert seconds < CASE_LIMIT_S, f"took {seconds:.1f} s"
    flight = load_flight(damaged)
    assert flight.t_end - flight.t_start < 3600, (flight.t_start, flight.t_end)
    assert any("header start time" in w and "implausible" in w for w in flight.warnings), flight.warnings


def test_resampler_grid_is_bounded_by_the_data_not_the_airborne_span():
    """Shared code, whatever reader made the Flight: an airborne interval reaching 10^12 s
    builds grid points only where the streams have samples."""
    from flightlog_fd.prepared import resample
    from flightlog_fd.flight import Flight, Frame, Series

    t = np.arange(0.0, 30.0, 0.004)
    rng = np.random.default_rng(SEED)
    rates = Series(t, rng.normal(0, 0.05, (t.size, 3)), "test rates")
    motors = Series(t[::25], np.full((t[::25].size, 4), 0.5), "test motors")
    flight = Flight(path="synthetic", autopilot="sim", vehicle_type="quadrotor", frame=Frame.quad_x(),
                    rates=rates, motors=motors, airborne=[(2.0, 1e12)], t_start=0.0, t_end=1e12)
    t0 = time.perf_counter()
    segments = resample(flight)
    assert time.perf_counter() - t0 < CASE_LIMIT_S
    assert len(segments) == 1
    assert segments[0].t[0] >= 3.0 and segments[0].t[-1] <= t[-1] + 1e-9


def test_sanitise_flight_drops_spikes_and_clips_intervals():
    from flightlog_fd.flight import Flight, Frame, Series, implausible_times, sanitise_flight

    t = np.arange(0.0, 20.0, 0.01)
    spiky = t.copy()
    spiky[500] += 2.0 ** 40 / 1e6  # a flipped bit 40 in microseconds
    spiky[900] -= 5.0  # a sample that steps back
    bad = implausible_times(spiky)
    assert np.flatnonzero(bad).tolist() == [500, 900]
    assert not implausible_times(np.concatenate([t, t[-1] + 3000 + t])).any()  # a logging pause is kept

    order = np.argsort(spiky)
    flight = Flight(path="synthetic", autopilot="sim", frame=Frame.quad_x(),
                    rates=Series(spiky[order], np.zeros((t.size, 3)), "r"),
                    motors=Series(t, np.zeros((t.size, 4)), "m"),
                    airborne=[(1.0, 2.0 ** 40 / 1e6)], armed=[(0.0, 2.0 ** 40 / 1e6)],
                    t_start=0.0, t_end=2.0 ** 40 / 1e6)
    sanitise_flight(flight)
    assert flight.rates.t.max() < 20.0
    assert flight.t_end == pytest.approx(t[-1])
    assert flight.airborne == [(1.0, pytest.approx(t[-1]))]
    assert any(w.startswith("rates (r): dropped 1 sample") for w in flight.warnings), flight.warnings
    assert any("log end time" in w for w in flight.warnings), flight.warnings


def test_running_median_is_scipys_median_filter():
    """The timestamp check's NumPy running median gives scipy.ndimage.median_filter's numbers
    (mode "mirror"), so the samples it drops are the same; short lines go to scipy itself."""
    from scipy.ndimage import median_filter

    from flightlog_fd.flight import TIME_SPIKE_NEIGHBOURS, _running_median

    rng = np.random.default_rng(7)
    for n in list(range(2, 60)) + [257, 4000]:
        for _ in range(20):
            t = np.cumsum(rng.random(n))
            t[rng.integers(n)] += 1e3 * rng.random()  # a spike
            if rng.random() < 0.3:
                t = np.round(t, 1)  # ties
            want = median_filter(t, size=TIME_SPIKE_NEIGHBOURS, mode="mirror")
            assert np.array_equal(_running_median(t, TIME_SPIKE_NEIGHBOURS), want), n


def test_short_streams_skip_the_median_only_where_it_cannot_matter():
    """A stream of fewer samples than the median's neighbourhood is judged without the median
    when its span is within the end limit; the result is the full check's."""
    from flightlog_fd import flight as F

    rng = np.random.default_rng(3)
    for n in range(2, F.TIME_SPIKE_NEIGHBOURS):
        for span in (5.0, 500.0, 5000.0):
            t = np.sort(rng.random(n)) * span
            t[rng.integers(n)] += rng.choice([0.0, 30.0, 2.0 ** 31 / 1e6])
            fast = F.implausible_times(t)
            thr = F._spike_threshold(t[np.isfinite(t)])
            med = F._running_median(t, F.TIME_SPIKE_NEIGHBOURS)
            spike = np.abs(t - med) > max(thr, F.MAX_SAMPLE_GAP_S)
            kept = t[~spike]
            back = kept < np.maximum.accumulate(kept) - thr
            keep = ~spike
            keep[np.flatnonzero(keep)[back]] = False
            if np.diff(t).min() >= -thr and np.diff(t).max() <= thr:
                keep[:] = True
            assert np.array_equal(fast, ~keep), (n, span, t)


# ----------------------------------------------------------------------------- header + random bytes

#: Random tails after a valid header (bytes), every one with each seed: below and above pyulog's
#: corrupt-message size (10000 B) and the largest message (65535 B), up to a 1 MB "log".
RANDOM_TAIL_SIZES = (100, 3_000, 30_000, 300_000, 1_000_000)
RANDOM_TAIL_SEEDS = (1, 2, 3)
#: One `fdlog diagnose` of all the files of one shape must end within this (a subprocess, so that
#: a reader spinning in a loop no signal reaches fails the test instead of stalling the suite).
#: Each file took < 1 s (60 files, load 7); before the definitions check pyulog spun for ever on
#: most of the ULog ones.
RANDOM_TAIL_TIMEOUT_S = 60


def _ulog_definitions_end(data: bytes) -> int:
    """Offset of the first subscription/logging message: where a ULog's definitions end."""
    pos = 16
    while pos + 3 <= len(data):
        size, kind = struct.unpack_from("<HB", data, pos)
        if kind in b"ALC":
            return pos
        pos += 3 + size
    return pos


def _dataflash_fmt_end(data: bytes) -> int:
    """Offset after the leading run of FMT messages (89 bytes each) of a DataFlash log."""
    pos = 0
    while data[pos:pos + 3] == b"\xa3\x95\x80":
        pos += 89
    return pos


RANDOM_TAIL_SHAPES = ("ulog_header", "ulog_definitions", "dataflash_fmt", "dataflash_fmt_table")


def random_tail_file(shape: str, seed: int, size: int) -> tuple[bytes, str]:
    """(file bytes, suffix): the valid start of a sample log followed by ``size`` seeded random
    bytes. Shapes: ``ulog_header`` (the 16-byte ULog file header), ``ulog_definitions`` (the ULog
    cut at a seeded byte of its definitions), ``dataflash_fmt`` (the first FMT message),
    ``dataflash_fmt_table`` (the DataFlash log cut at a seeded byte of its FMT table)."""
    rng = random.Random(f"{SEED}:{shape}:{seed}:{size}")
    if shape.startswith("ulog"):
        data = (SAMPLES / "px4_motor2_damaged.ulg").read_bytes()
        head = data[:16] if shape == "ulog_header" else data[:rng.randrange(16, _ulog_definitions_end(data))]
        return head + rng.randbytes(size), ".ulg"
    data = (SAMPLES / "ardupilot_healthy.bin").read_bytes()
    head = data[:89] if shape == "dataflash_fmt" else data[:rng.randrange(3, _dataflash_fmt_end(data))]
    return head + rng.randbytes(size), ".bin"


@pytest.mark.parametrize("shape", RANDOM_TAIL_SHAPES)
def test_header_then_random_bytes_is_one_line_and_exit_2(shape, tmp_path):
    """A valid start followed by random bytes, several seeds and sizes, through the real `fdlog`
    in a subprocess: every file ends in one ``fdlog: <file>: ...`` line (exit 2), no traceback,
    within ``RANDOM_TAIL_TIMEOUT_S`` for them all. A ULog header + random bytes used to make
    pyulog's definitions walk spin for ever (the watcher and the server killed it after 10 min)."""
    import os
    import subprocess
    import sys

    files = []
    for seed in RANDOM_TAIL_SEEDS:
        for size in RANDOM_TAIL_SIZES:
            data, suffix = random_tail_file(shape, seed, size)
            path = tmp_path / f"{shape}_seed{seed}_{size}{suffix}"
            path.write_bytes(data)
            files.append(path)
    cmd = [sys.executable, "-c", "from flightlog_fd.cli import main; main()", "diagnose", *map(str, files)]
    t0 = time.perf_counter()
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=RANDOM_TAIL_TIMEOUT_S, cwd=ROOT,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})  # what finished shows on a timeout
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        pytest.fail(f"{shape}: still running after {RANDOM_TAIL_TIMEOUT_S} s; output so far:\n{out[-2000:]}")
    seconds = time.perf_counter() - t0
    assert res.returncode == 2, f"{shape}: exit code {res.returncode}\n{res.stdout}\n{res.stderr}"
    assert "Traceback" not in res.stdout + res.stderr, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.strip()]
    for f in files:
        named = [ln for ln in errors if ln.startswith(f"fdlog: {f}: ")]
        assert len(named) == 1, f"{f.name}: expected one error line naming it, got {named}\n{res.stderr}"
    assert len(errors) == len(files), res.stderr
    print(f"{shape}: {len(files)} files in {seconds:.1f} s")


def test_pyulog_definitions_stall_finds_the_backward_step():
    """The message whose declared size runs past the end of the file is found; a complete
    definitions section, a cut one, and one that ends at a subscription pass."""
    from flightlog_fd.logs.ulog import pyulog_definitions_stall

    header = (SAMPLES / "px4_motor2_damaged.ulg").read_bytes()[:16]
    bogus = struct.pack("<HB", 20_000, 0xAB) + bytes(100)  # unknown type, > 10000 bytes, cut
    assert pyulog_definitions_stall(header + bogus) == (16, 0xAB, 20_000)
    fmt = b"x:uint64_t timestamp;"
    ok = struct.pack("<HB", len(fmt), ord("F")) + fmt
    assert pyulog_definitions_stall(header + ok + bogus) == (16 + 3 + len(fmt), 0xAB, 20_000)
    # a complete corrupt message is stepped over one byte at a time, as pyulog does
    assert pyulog_definitions_stall(header + struct.pack("<HB", 12_000, 0) + bytes(12_000)) is None
    # zero-filled bytes are jumped over to 2 bytes before the next non-zero one, as pyulog steps:
    # there [0, 0, "F"] is a format of size 0 (skipped whole), so the bogus message after it is hit
    assert pyulog_definitions_stall(header + bytes(50) + b"F" + bogus) == (16 + 50 + 1, 0xAB, 20_000)
    # a subscription ends the section before the bogus message is reached
    assert pyulog_definitions_stall(header + ok + struct.pack("<HB", 0, ord("A")) + bogus) is None
    for log in sorted(SAMPLES.glob("*.ulg")):
        data = log.read_bytes()
        assert pyulog_definitions_stall(data) is None, log.name
        assert pyulog_definitions_stall(data[:_ulog_definitions_end(data) // 2]) is None, log.name


def test_pyulog_definitions_stall_agrees_with_pyulog():
    """Differential check against pyulog itself (its reads counted, so a spin ends the run): on
    seeded ULog header + random byte files shorter than the magic read as a message, a file is
    flagged exactly when pyulog spins on it. (In longer files a backward step can lead pyulog on
    to an end after re-reading bytes it already walked; the check refuses those too.)"""
    import contextlib
    import io

    from pyulog import ULog

    from flightlog_fd.logs.ulog import pyulog_definitions_stall

    class _Spinning(Exception):
        pass

    class CountedReads(io.BytesIO):
        def __init__(self, data: bytes):
            super().__init__(data)
            self.reads_left = 3 * len(data) + 1000  # a walk that advances reads each byte at most ~once

        def read(self, size=-1):
            self.reads_left -= 1
            if self.reads_left < 0:
                raise _Spinning()
            return super().read(size)

    header = (SAMPLES / "px4_motor2_damaged.ulg").read_bytes()[:16]
    spins = 0
    for seed in range(100):
        rng = random.Random(f"{SEED}:pyulog-stall:{seed}")
        data = header + rng.randbytes(rng.choice((10, 300, 3_000, 8_000)))
        if seed % 2:  # a zero-filled block inside (the check jumps over zero runs)
            at = rng.randrange(16, len(data))
            data = data[:at] + bytes(rng.choice((3, 50, 1_000))) + data[at:]
        stall = pyulog_definitions_stall(data)
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                ULog(CountedReads(data), disable_str_exceptions=True)
        except _Spinning:
            spun = True
        except Exception:
            spun = False  # pyulog's own error (e.g. unknown incompatible flags): one line from the CLI
        else:
            spun = False
        # below 19544 bytes every backward step lands on byte 0, where the magic's "UL" + "o" read
        # as a corrupt message of 19541 bytes that runs past the end again: flagged <=> spins
        assert spun == (stall is not None), f"seed {seed}: pyulog spins {spun}, check says {stall}"
        spins += spun
    assert spins > 0, "no file made pyulog spin: the test checks nothing"
