"""`fdlog pull`: the pure parts (connection strings, USB autopilot choice, byte coverage, names,
atomic files) and the whole command against the vehicle double (tests/vehicle_double.py) answering
as PX4 and as ArduPilot over a lossy, duplicating, reordering or stalling loopback link.

Every download must be byte-identical to the vehicle's file, or end in one error line with exit
code 2 and no file (not even a partial one) left in the output folder.
"""
from __future__ import annotations

import random
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app
from flightlog_fd.errors import VehicleLinkError
from flightlog_fd.vehicle.folder import PartialLog, find_pulled, fingerprint, stamp
from flightlog_fd.vehicle.ports import SerialPort, parse_connection, pick_usb_autopilot
from flightlog_fd.vehicle.pull import choose
from flightlog_fd.vehicle.transfer import Coverage, LogEntry, newest_entry

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
DOUBLE = Path(__file__).with_name("vehicle_double.py")
runner = CliRunner()

# Small sample logs (0.26-0.32 MB), oldest first; the newest is the damaged one.
PX4_LOGS = [SAMPLES / "px4_motor4_damaged.ulg", SAMPLES / "px4_motor2_damaged.ulg"]
ARDUPILOT_LOGS = [SAMPLES / "ardupilot_healthy.bin", SAMPLES / "ardupilot_motor2_damaged.bin"]
LOSSY = ["--loss", "0.05", "--duplicate", "0.02", "--reorder", "0.02"]


# -- pure parts ------------------------------------------------------------------------------------
def test_connection_strings(tmp_path):
    assert parse_connection("udp:127.0.0.1:14550").device == "udp:127.0.0.1:14550"
    for text in ("udpin:0.0.0.0:14550", "udpout:10.0.0.2:14550", "tcp:127.0.0.1:5760", "tcpin:0.0.0.0:5760"):
        assert parse_connection(text).device == text
    c = parse_connection("COM3,57600")
    assert (c.device, c.baud, c.serial) == ("COM3", 57600, True)
    assert parse_connection("/dev/null,921600").baud == 921600  # a character device stands in for a port
    log = tmp_path / "flight.ulg"
    log.write_bytes(b"ULog\x01\x12\x35")
    bad = {str(log): "is a file", str(tmp_path): "is a folder", "udp:127.0.0.1": "HOST:PORT",
           "udp:127.0.0.1:99999": "HOST:PORT", "/dev/null,fast": "baud", "/dev/nonexistent-port": "no such serial",
           "bluetooth:aa:bb": "not a connection"}
    for text, why in bad.items():
        with pytest.raises(VehicleLinkError, match=why) as e:
            parse_connection(text)
        assert "\n" not in str(e.value)


def test_usb_autopilot_is_found_when_exactly_one_is_plugged_in():
    radio = SerialPort("/dev/ttyUSB0", 0x0403, 0x6015, "A1", "FTDI", "FT231X USB UART")
    cube = [SerialPort("/dev/ttyACM0", 0x2DAE, 0x1016, "S1", "CubePilot", "CubeOrange", "00"),
            SerialPort("/dev/ttyACM1", 0x2DAE, 0x1016, "S1", "CubePilot", "CubeOrange", "02")]
    px4 = SerialPort("/dev/ttyACM2", 0x3185, 0x0035, "P1", "Auterion", "PX4 FMU v6X.x")
    flow = SerialPort("/dev/ttyACM3", 0x26AC, 0x0015, "F1", "3D Robotics", "PX4Flow")
    # a dual-CDC ArduPilot board is one autopilot, reached on its first interface
    assert pick_usb_autopilot([radio, *cube[::-1]]).device == "/dev/ttyACM0"
    assert pick_usb_autopilot([radio, px4, flow]).device == "/dev/ttyACM2"
    by_name = SerialPort("/dev/ttyACM4", 0x1234, 0x5678, "X", "ArduPilot", "MatekH743")
    assert pick_usb_autopilot([by_name]).device == "/dev/ttyACM4"
    with pytest.raises(VehicleLinkError, match=r"no autopilot found on USB \(serial ports: /dev/ttyUSB0 \(0403:6015"):
        pick_usb_autopilot([radio, flow])
    with pytest.raises(VehicleLinkError, match="2 autopilots on USB.*ttyACM0.*ttyACM2"):
        pick_usb_autopilot([*cube, px4])
    with pytest.raises(VehicleLinkError, match="no serial ports at all"):
        parse_connection(None, ports=[])


def test_coverage_matches_a_byte_map():
    rng = random.Random(3)
    for _ in range(200):
        n = rng.randint(1, 3000)
        cov, seen = Coverage(n), bytearray(n)
        for _ in range(rng.randint(0, 80)):
            s = rng.randint(-10, n)
            e = s + rng.randint(0, 400)
            before = sum(seen)
            for k in range(max(0, s), min(n, e)):
                seen[k] = 1
            assert cov.add(s, e) == sum(seen) - before
        assert cov.done == sum(seen) and cov.complete == (sum(seen) == n)
        assert {k for a, b in cov.missing() for k in range(a, b)} == {k for k in range(n) if not seen[k]}
        s = rng.randint(0, n - 1)
        e = rng.randint(s + 1, n)
        assert cov.covers(s, e) == all(seen[s:e])


def test_gap_run_starts_after_the_cursor_and_bridges_only_short_received_runs():
    cov = Coverage(2000)
    for s, e in ((90, 180), (270, 1000), (1090, 1900)):
        cov.add(s, e)
    assert cov.missing() == [(0, 90), (180, 270), (1000, 1090), (1900, 2000)]
    assert cov.gap_run(0, 0) == (0, 90)
    assert cov.gap_run(0, 100) == (0, 270)  # the 90 received bytes between are re-sent
    assert cov.gap_run(200, 100) == (180, 270)  # the gap around the cursor
    assert cov.gap_run(270, 10_000) == (1000, 2000)
    assert cov.gap_run(2000, 0) == (0, 90)  # past the last gap: round again
    rng = random.Random(5)
    for _ in range(500):  # against a plain reading of the gaps
        n = rng.randint(1, 2000)
        cov = Coverage(n)
        for _ in range(rng.randint(0, 30)):
            s = rng.randint(0, n)
            cov.add(s, s + rng.randint(0, 200))
        cursor, bridge = rng.randint(0, n), rng.choice([0, 50, 300, 5000])
        gaps = cov.missing()
        if not gaps:
            assert cov.gap_run(cursor, bridge) is None
            continue
        k = next((i for i, g in enumerate(gaps) if g[1] > cursor), 0)
        start, end = gaps[k]
        while k + 1 < len(gaps) and gaps[k + 1][0] - gaps[k][1] < bridge:
            end, k = gaps[k + 1][1], k + 1
        assert cov.gap_run(cursor, bridge) == (start, end)


def test_newest_log_per_autopilot():
    entries = [LogEntry(0, 10, 1714557600 + 3600), LogEntry(1, 10, 1714557600), LogEntry(2, 10, 0)]
    assert newest_entry(entries, "px4").id == 0  # PX4's ids follow its folder scan: the clock decides
    ardupilot = [LogEntry(1, 10, 0), LogEntry(2, 10, 0), LogEntry(3, 10, 0)]
    assert newest_entry(ardupilot, "ardupilot").id == 3  # ArduPilot counts from the oldest; no clock needed
    assert [e.id for e in choose(entries, "px4", "all")] == [2, 1, 0]
    assert choose(entries, "px4", "id", 5) == [] and choose([], "px4", "newest") == []


def test_partial_log_never_looks_like_a_log_until_committed(tmp_path):
    data = (SAMPLES / "px4_motor4_damaged.ulg").read_bytes()
    entry = LogEntry(3, len(data), 1714557600)
    fp = fingerprint(len(data), data[-90:])
    part = PartialLog(tmp_path, fp, len(data))
    for ofs in reversed(range(0, len(data), 90)):  # any order
        part.write_at(ofs, data[ofs:ofs + 90])
    assert part.tmp.name.startswith(".") and part.tmp.read_bytes()[:16] == bytes(16)
    assert part.tail() == data[-90:]
    path = part.commit(entry)
    assert path.name == f"2024-05-01_10-00-00_{fp}.ulg" and path.read_bytes() == data
    assert not part.tmp.exists()
    assert find_pulled(tmp_path, fp, len(data)) == path and find_pulled(tmp_path, fp, len(data) + 1) is None
    with PartialLog(tmp_path, "0123456789", 500) as aborted:
        aborted.write_at(0, b"\xa3\x95\x80" + bytes(87))
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # the aborted one left nothing
    assert stamp(LogEntry(1, 1, 0)) == stamp(LogEntry(1, 1, 86400 * 3 + 60)) == "nodate"


# -- the command against the vehicle double --------------------------------------------------------
def _free_port(kind=socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Double:
    """The vehicle double in a subprocess, sending to (udp) or listening on (tcp) a free port."""

    def __init__(self, flavour: str, logs, *args: str, tcp: bool = False):
        self.port = _free_port(socket.SOCK_STREAM if tcp else socket.SOCK_DGRAM)
        self.connection = f"tcp:127.0.0.1:{self.port}" if tcp else f"udp:127.0.0.1:{self.port}"
        link = f"tcpin:127.0.0.1:{self.port}" if tcp else f"udpout:127.0.0.1:{self.port}"
        self.proc = subprocess.Popen([sys.executable, str(DOUBLE), "--flavour", flavour, "--connect", link,
                                      *map(str, logs), *args], stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout.readline().strip() == "ready"

    def stop(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=10)


@pytest.fixture
def double():
    started = []

    def start(flavour, logs, *args, tcp=False):
        started.append(Double(flavour, logs, *args, tcp=tcp))
        return started[-1]

    yield start
    for d in started:
        d.stop()


def _pull(d: Double, out: Path, *args: str, input: str | None = None):
    return runner.invoke(app, ["pull", d.connection, "-o", str(out), *args], input=input)


def _files(out: Path) -> list[Path]:
    return sorted(p for p in out.rglob("*") if p.is_file())


@pytest.mark.parametrize("flavour,logs,extra", [("px4", PX4_LOGS, ["--scan-reversed"]),
                                                 ("ardupilot", ARDUPILOT_LOGS, ["--no-clock"])])
def test_pull_newest_over_a_lossy_link_is_byte_identical_and_diagnosed(double, tmp_path, flavour, logs, extra):
    d = double(flavour, logs, *LOSSY, *extra)
    res = _pull(d, tmp_path)
    files = _files(tmp_path)
    assert len(files) == 1, res.output
    assert files[0].read_bytes() == logs[-1].read_bytes()
    assert files[0].parent.name.startswith(f"{flavour}-")
    assert files[0].name.startswith("nodate_" if flavour == "ardupilot" else "2024-05-01_11-00-00_")
    expected = runner.invoke(app, ["diagnose", str(logs[-1])])
    assert res.exit_code == expected.exit_code == 1, res.output
    # the motor-2 samples: rotor 2 lost thrust, its headline the diagnosis' first line
    assert "Rotor 2 (rear-left) lost" in res.output and f"pulled log {2 if flavour == 'ardupilot' else 0}" in res.output


def test_since_last_pulls_only_new_logs_and_a_second_pull_is_recognised(double, tmp_path):
    d = double("ardupilot", ARDUPILOT_LOGS, "--no-clock", *LOSSY)
    first = _pull(d, tmp_path, "--no-diagnose")
    assert first.exit_code == 0, first.output
    [newest] = _files(tmp_path)
    mtime = newest.stat().st_mtime_ns
    again = _pull(d, tmp_path, "--no-diagnose")
    assert again.exit_code == 0 and "already pulled log 2" in again.output
    assert newest.stat().st_mtime_ns == mtime
    since = _pull(d, tmp_path, "--since", "last", "--no-diagnose")
    assert since.exit_code == 0 and "pulled log 1" in since.output and "log 2" not in since.output, since.output
    assert sorted(f.read_bytes() for f in _files(tmp_path)) == sorted(p.read_bytes() for p in ARDUPILOT_LOGS)
    nothing = _pull(d, tmp_path, "--since", "last")
    assert nothing.exit_code == 0 and "no new logs" in nothing.output, nothing.output
    # a new flight on the vehicle: only it is pulled
    d.stop()
    newer = SAMPLES / "ardupilot_plus_motor4_damaged.bin"
    d2 = double("ardupilot", [*ARDUPILOT_LOGS, newer], "--no-clock")
    res = _pull(d2, tmp_path, "--since", "last", "--no-diagnose")
    assert res.exit_code == 0 and res.output.count("pulled log") == 1 and "pulled log 3" in res.output, res.output
    assert len(_files(tmp_path)) == 3


def test_a_dead_link_is_one_line_exit_2_and_no_file(double, tmp_path):
    d = double("px4", PX4_LOGS, "--stall-after", "100000")
    res = _pull(d, tmp_path, "--timeout", "2")
    assert res.exit_code == 2
    errors = [line for line in res.output.splitlines() if line.startswith("fdlog:")]
    assert len(errors) == 1 and "link is lost" in errors[0] and "Traceback" not in res.output
    assert _files(tmp_path) == []


def test_a_link_that_stalls_and_comes_back_still_gives_the_whole_log(double, tmp_path):
    d = double("ardupilot", ARDUPILOT_LOGS, "--stall-after", "100000", "--stall-for", "1.5")
    res = _pull(d, tmp_path, "--timeout", "6", "--no-diagnose")
    assert res.exit_code == 0, res.output
    assert [f.read_bytes() for f in _files(tmp_path)] == [ARDUPILOT_LOGS[-1].read_bytes()]


def test_a_log_shorter_than_its_listing_is_an_error_not_a_truncated_file(double, tmp_path):
    d = double("px4", PX4_LOGS, "--listed-extra", "500")
    res = _pull(d, tmp_path, "--timeout", "3")
    assert res.exit_code == 2 and "LOG_ENTRY said" in res.output, res.output
    assert _files(tmp_path) == []


def test_no_vehicle_and_an_armed_vehicle_are_one_line_errors(double, tmp_path):
    res = runner.invoke(app, ["pull", f"udp:127.0.0.1:{_free_port()}", "-o", str(tmp_path), "--timeout", "1"])
    assert res.exit_code == 2 and "no heartbeat from an autopilot in 1 s" in res.output
    d = double("ardupilot", ARDUPILOT_LOGS, "--armed")
    res = _pull(d, tmp_path)
    assert res.exit_code == 2 and "is armed: disarm it first" in res.output
    assert _files(tmp_path) == []


def test_list_id_and_tcp(double, tmp_path):
    d = double("px4", PX4_LOGS, tcp=True)
    listed = _pull(d, tmp_path, "--list")
    assert listed.exit_code == 0
    assert "2024-05-01 10-00-00" in listed.output and "316.9 kB" in listed.output, listed.output
    res = _pull(d, tmp_path, "--id", "0", "--no-diagnose")
    assert res.exit_code == 0 and [f.read_bytes() for f in _files(tmp_path)] == [PX4_LOGS[0].read_bytes()]
    res = _pull(d, tmp_path, "--id", "7")
    assert res.exit_code == 2 and "no log 7 on the vehicle (its logs: 0, 1)" in res.output


def test_erase_needs_every_log_pulled_and_a_yes(double, tmp_path):
    res = runner.invoke(app, ["pull", "udp:127.0.0.1:9", "--erase"])
    assert res.exit_code == 2 and "--erase needs --all or --since last" in res.output
    for flavour, logs, extra in (("px4", PX4_LOGS, []), ("ardupilot", ARDUPILOT_LOGS, ["--no-clock"])):
        d = double(flavour, logs, *extra)
        out = tmp_path / flavour
        res = _pull(d, out, "--all", "--erase", "--no-diagnose", input="n\n")
        assert res.exit_code == 0 and "not erased" in res.output, res.output
        assert len(_files(out)) == 2
        res = _pull(d, out, "--since", "last", "--erase", "--no-diagnose", input="y\n")
        assert res.exit_code == 0 and "erased every log on the vehicle" in res.output, res.output
        assert "no logs on the vehicle" in _pull(d, out, "--list").output
        assert sorted(f.read_bytes() for f in _files(out)) == sorted(p.read_bytes() for p in logs)
