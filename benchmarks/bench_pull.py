"""Time `fdlog pull` of a ~30 MB log over the loopback vehicle double (tests/vehicle_double.py).

Makes the logs with the simulator in a temporary folder (a long flight with 1 kHz raw IMU and
100 Hz ESC telemetry: ULog for the PX4 double, DataFlash for the ArduPilot double; nothing is kept),
then pulls the log from each double over UDP at a fixed link rate, without loss and with 5 % of the
packets lost each way (plus 2 % duplicated and 2 % reordered LOG_DATA), and once over TCP with the
double unthrottled (the client's own ceiling: TCP has flow control, so nothing is dropped).

Prints, per run: seconds, MB/s of log, LOG_DATA packets per second received (chunk rate), requests
(the first one and the re-requests of gaps), duplicates, the measured round trip, the client's CPU
time per packet received (the double runs in its own process), and whether the file is
byte-identical. Usage::

    nice -n 5 .venv/bin/python benchmarks/bench_pull.py [--mb 30] [--rate 1e6] [--flavour px4 ardupilot]
"""
from __future__ import annotations

import argparse
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOUBLE = ROOT / "tests" / "vehicle_double.py"
#: Simulated log bytes per second of flight with 1 kHz IMU and 100 Hz ESC telemetry (measured on a
#: 60 s flight: ULog 9.07 MB, DataFlash 7.81 MB).
BYTES_PER_S = {"ulog": 151_000, "dataflash": 130_000}


def _free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def make_log(folder: Path, fmt: str, mb: float) -> Path:
    out = folder / ("long.ulg" if fmt == "ulog" else "long.bin")
    duration = mb * 1e6 / BYTES_PER_S[fmt]
    subprocess.run([str(ROOT / ".venv" / "bin" / "fdlog") if (ROOT / ".venv").exists() else "fdlog",
                    "simulate", "-o", str(out), "--format", fmt, "--duration", f"{duration:.0f}",
                    "--imu-rate", "1000", "--esc-rate", "100", "--force"], check=True, stdout=subprocess.DEVNULL)
    return out


def run_once(flavour: str, log: Path, out: Path, *, rate: float, loss: float, tcp: bool) -> dict:
    from flightlog_fd.vehicle.link import VehicleLink
    from flightlog_fd.vehicle.ports import parse_connection
    from flightlog_fd.vehicle.pull import pull_logs

    port = _free_port(socket.SOCK_STREAM if tcp else socket.SOCK_DGRAM)
    link = f"tcpin:127.0.0.1:{port}" if tcp else f"udpout:127.0.0.1:{port}"
    args = [sys.executable, str(DOUBLE), "--flavour", flavour, "--connect", link, str(log), "--rate", str(rate)]
    if loss:
        args += ["--loss", str(loss), "--duplicate", "0.02", "--reorder", "0.02"]
    if flavour == "ardupilot":
        args.append("--no-clock")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        shutil.rmtree(out, ignore_errors=True)
        conn = parse_connection(f"tcp:127.0.0.1:{port}" if tcp else f"udp:127.0.0.1:{port}")
        with VehicleLink(conn) as vl:
            t0, cpu0 = time.monotonic(), time.process_time()
            report = pull_logs(vl, out, stall_timeout=20)
            seconds, cpu = time.monotonic() - t0, time.process_time() - cpu0
        pulled = report.logs[0]
        s = pulled.stats
        return {"seconds": seconds, "mb_s": s.bytes / 1e6 / s.seconds, "chunks_s": s.packets / s.seconds,
                "requests": s.requests, "re_requests": s.re_requests, "duplicates": s.duplicates,
                "packets": s.packets, "rtt_ms": s.rtt_s * 1e3, "cpu_us": cpu / max(1, s.packets) * 1e6,
                "identical": pulled.path.read_bytes() == log.read_bytes()}
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=30.0, help="log size to simulate, MB")
    ap.add_argument("--rate", type=float, default=1e6, help="the double's UDP link rate, bytes of log per second")
    ap.add_argument("--flavour", nargs="+", default=["px4", "ardupilot"], choices=["px4", "ardupilot"])
    a = ap.parse_args()
    os.environ.setdefault("MAVLINK20", "1")
    print(f"load average {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores; link rate {a.rate / 1e6:g} MB/s (UDP)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for flavour in a.flavour:
            t = time.monotonic()
            log = make_log(folder, "ulog" if flavour == "px4" else "dataflash", a.mb)
            print(f"\n{flavour}: {log.name} {log.stat().st_size / 1e6:.1f} MB (simulated in {time.monotonic() - t:.0f} s)")
            print(f"{'run':<28}{'s':>7}{'MB/s':>7}{'chunks/s':>10}{'requests':>10}{'dups':>7}{'rtt ms':>8}{'cpu us/chunk':>13}  identical")
            for name, kw in ((f"udp {a.rate / 1e6:g} MB/s, no loss", dict(rate=a.rate, loss=0.0, tcp=False)),
                             (f"udp {a.rate / 1e6:g} MB/s, 5 % loss", dict(rate=a.rate, loss=0.05, tcp=False)),
                             ("tcp unthrottled, no loss", dict(rate=1e9, loss=0.0, tcp=True))):
                r = run_once(flavour, log, folder / "out", **kw)
                print(f"{name:<28}{r['seconds']:>7.1f}{r['mb_s']:>7.2f}{r['chunks_s']:>10.0f}"
                      f"{r['requests']:>10}{r['duplicates']:>7}{r['rtt_ms']:>8.2f}{r['cpu_us']:>13.0f}  {r['identical']}", flush=True)
            log.unlink()


if __name__ == "__main__":
    main()
