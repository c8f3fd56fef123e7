"""A vehicle double for `fdlog pull`: a pymavlink endpoint on the loopback that answers the MAVLink
log protocol as PX4 or as ArduPilot do, serving given log files, over a link that can lose,
duplicate, reorder and stall.

What it copies from the autopilots' sources (read with the project's search tool):

- PX4 ``src/modules/mavlink/mavlink_log_handler.cpp`` (MavlinkLogHandler): logs numbered 0..n-1 in
  the order the log folders are scanned (not necessarily by time); ``LOG_REQUEST_LIST`` builds the
  list (start 0) or re-sends a part of it; ``LOG_REQUEST_DATA`` is ignored before a list was
  requested, after ``LOG_REQUEST_END`` and for an unknown id, and otherwise replaces the current
  stream; a stream ends with a packet shorter than 90 bytes or when the count is sent; an empty
  card answers one ``LOG_ENTRY`` of id 0 and ``num_logs`` 0; ``LOG_ERASE`` deletes every log.
- ArduPilot ``libraries/AP_Logger/AP_Logger_MAVLinkLogTransfer.cpp``: logs numbered 1..n from the
  oldest; ``time_utc`` 0 when the vehicle had no GPS clock; no log message is answered while armed
  (STATUSTEXT "Disarm for log download"); a list or data request that arrives while a list or a
  stream is going is dropped ("Log download in progress" for a list); an invalid id ends the
  transfer; ``LOG_DATA`` flows only while the ground station's last heartbeat is under 3 s old.
- Both: system id 1, component 1 (MAV_COMP_ID_AUTOPILOT1), MAVLink 2, a 1 Hz HEARTBEAT naming the
  autopilot (PX4 = 12, ArduPilot = 3) and a quadrotor, attitude telemetry at 10 Hz, an
  ``AUTOPILOT_VERSION`` (board uid, firmware, the FTP capability bit) on MAV_CMD_REQUEST_MESSAGE or
  MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES; beside them a companion computer's heartbeat (component
  191, MAV_AUTOPILOT_INVALID) that a ground station must not take for the autopilot.

The link: each packet either way is lost with probability ``loss``; each LOG_DATA is sent twice with
probability ``duplicate`` and held back behind the next one with probability ``reorder``; LOG_DATA
goes out at ``rate`` bytes of log per second; after ``stall_after`` bytes of LOG_DATA the link goes
silent both ways for ``stall_for`` seconds (forever when None).

Run as a script (tests start it as a subprocess, it prints ``ready`` once listening)::

    python tests/vehicle_double.py --flavour px4 --connect udpout:127.0.0.1:14550 --loss 0.05 LOG...

then ``fdlog pull udp:127.0.0.1:14550``. Logs are given oldest first.
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import time
from pathlib import Path
from typing import Optional

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

mavlink = mavutil.mavlink

AUTOPILOT_IDS = {"px4": mavlink.MAV_AUTOPILOT_PX4, "ardupilot": mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA}
#: A board's uid2 as each autopilot fills it: PX4 its 18-byte GUID, ArduPilot the MCU's 12-byte id.
UID2 = {"px4": bytes.fromhex("000600000000343434333631510a0014002f"),
        "ardupilot": bytes.fromhex("3a0025000d51373033383739") + bytes(6)}
FIRMWARE = {"px4": (1, 15, 4), "ardupilot": (4, 5, 7)}
LOG_DATA_LEN = 90
#: ArduPilot stops log streaming when the ground station's heartbeat is older than this.
ARDUPILOT_GCS_HEARTBEAT_S = 3.0
#: A first log time for the double's logs that have a clock (2024-05-01 10:00:00 UTC), one flight an hour.
FIRST_LOG_TIME, LOG_TIME_STEP = 1714557600, 3600


class VehicleDouble:
    """The double's state and event loop (see the module docstring)."""

    def __init__(self, logs: list[bytes], *, flavour: str = "px4", connect: str, times: Optional[list[int]] = None,
                 loss: float = 0.0, duplicate: float = 0.0, reorder: float = 0.0, rate: float = 1e6,
                 stall_after: Optional[int] = None, stall_for: Optional[float] = None, armed: bool = False,
                 scan_reversed: bool = False, listed_extra: int = 0, seed: int = 0):
        if flavour not in AUTOPILOT_IDS:
            raise ValueError(f"flavour must be px4 or ardupilot, got {flavour!r}")
        self.flavour = flavour
        self.logs = list(logs)
        self.times = list(times) if times is not None else [FIRST_LOG_TIME + LOG_TIME_STEP * k for k in range(len(logs))]
        self.loss, self.duplicate, self.reorder = loss, duplicate, reorder
        self.rate = rate
        self.stall_after, self.stall_for = stall_after, stall_for
        self.armed = armed
        self.scan_reversed = scan_reversed
        self.listed_extra = listed_extra  # LOG_ENTRY sizes this much larger than the files (a lying card)
        self.rng = random.Random(seed)
        self.conn = mavutil.mavlink_connection(connect, source_system=1, source_component=1)
        self.mav = self.conn.mav
        self.companion = mavlink.MAVLink(self.conn, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
        # protocol state
        self.state = "inactive" if flavour == "px4" else "idle"  # PX4: inactive | idle | listing | sending
        self.order: list[int] = []  # PX4: list position -> index into self.logs
        self.next_entry = self.last_entry = 0
        self.cur_id: Optional[int] = None
        self.ofs = self.remaining = 0
        self.last_gcs_heartbeat = 0.0
        self.warned_armed = False
        self.held: Optional[bytes] = None
        self.data_bytes_sent = 0
        self.stalled_since: Optional[float] = None

    # -- the link ---------------------------------------------------------------------------------
    def _write(self, buf: bytes, is_data: bool = False) -> None:
        if self.rng.random() < self.loss:
            return
        if is_data and self.held is None and self.rng.random() < self.reorder:
            self.held = buf
            return
        self.conn.write(buf)
        if is_data and self.rng.random() < self.duplicate:
            self.conn.write(buf)
        if self.held is not None:
            held, self.held = self.held, None
            self.conn.write(held)

    def _send(self, msg, mav=None, is_data: bool = False) -> None:
        mav = mav or self.mav
        buf = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        self._write(buf, is_data)

    def _stalled(self, now: float) -> bool:
        if self.stall_after is None or self.data_bytes_sent < self.stall_after:
            return False
        if self.stalled_since is None:
            self.stalled_since = now
        if self.stall_for is not None and now - self.stalled_since >= self.stall_for:
            self.stall_after = None  # the link is back
            return False
        return True

    # -- what the vehicle says by itself --------------------------------------------------------------
    def _heartbeat(self) -> None:
        base_mode = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
        self._send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, AUTOPILOT_IDS[self.flavour], base_mode, 0,
                                             mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY))
        self._send(self.companion.heartbeat_encode(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID,
                                                   0, 0, mavlink.MAV_STATE_ACTIVE), mav=self.companion)

    def _autopilot_version(self) -> None:
        major, minor, patch = FIRMWARE[self.flavour]
        sw = (major << 24) | (minor << 16) | (patch << 8) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
        caps = (mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_FTP | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2)
        uid2 = UID2[self.flavour]
        uid = int.from_bytes(uid2[:8], "little") if self.flavour == "ardupilot" else int.from_bytes(uid2[10:18], "little")
        self._send(self.mav.autopilot_version_encode(caps, sw, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0x26AC, 0x0011,
                                                     uid, list(uid2)))

    def _status(self, text: str) -> None:
        self._send(self.mav.statustext_encode(mavlink.MAV_SEVERITY_INFO, text.encode()))

    # -- the log protocol -----------------------------------------------------------------------------
    def _count(self) -> int:
        return len(self.logs)

    def _entry(self, log_id: int) -> tuple[int, int, int]:
        """(index into self.logs, size, time_utc) of a protocol id, or (-1, 0, 0)."""
        if self.flavour == "px4":
            if not 0 <= log_id < len(self.order):
                return -1, 0, 0
            k = self.order[log_id]
        else:
            if not 1 <= log_id <= self._count():
                return -1, 0, 0
            k = log_id - 1
        return k, len(self.logs[k]), self.times[k]

    def _handle(self, m, now: float) -> None:
        kind = m.get_type()
        if kind == "HEARTBEAT" and m.type == mavlink.MAV_TYPE_GCS:
            self.last_gcs_heartbeat = now
            return
        if kind == "COMMAND_LONG" and m.target_system == 1:
            wants_version = (m.command == mavlink.MAV_CMD_REQUEST_MESSAGE and int(m.param1) == 148) or \
                m.command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
            if wants_version:
                self._send(self.mav.command_ack_encode(m.command, mavlink.MAV_RESULT_ACCEPTED))
                self._autopilot_version()
            return
        if not kind.startswith("LOG_") or getattr(m, "target_system", 1) != 1:
            return
        if self.flavour == "ardupilot" and self.armed:
            if not self.warned_armed:
                self._status("Disarm for log download")
                self.warned_armed = True
            return
        (self._handle_px4 if self.flavour == "px4" else self._handle_ardupilot)(m, kind)

    def _handle_px4(self, m, kind: str) -> None:
        if kind == "LOG_REQUEST_LIST":
            if self.state != "inactive":
                self.state = "inactive" if m.start == 0 else "idle"
            if self.state == "inactive":
                self.order = list(range(self._count()))[::-1] if self.scan_reversed else list(range(self._count()))
                self.next_entry = self.last_entry = 0
                self.cur_id = None
                self.state = "idle"
            n = len(self.order)
            if n:
                self.next_entry = m.start if m.start < n else n - 1
                self.last_entry = m.end if m.end < n else n - 1
            self.state = "listing"
        elif kind == "LOG_REQUEST_DATA":
            if self.state == "inactive" or m.id >= len(self.order):
                return
            self.state = "idle"
            self.cur_id = m.id
            size = self._entry(m.id)[1] + self.listed_extra
            self.ofs = m.ofs
            self.remaining = min(max(0, size - m.ofs), m.count)
            self.state = "sending"
        elif kind == "LOG_REQUEST_END":
            self.state = "inactive"
        elif kind == "LOG_ERASE":
            self.state = "inactive"
            self.logs, self.times, self.order = [], [], []

    def _handle_ardupilot(self, m, kind: str) -> None:
        if kind == "LOG_REQUEST_LIST":
            if self.state != "idle":
                self._status("Log download in progress")
                return
            n = self._count()
            if n == 0:
                self.next_entry = self.last_entry = 0
            else:
                self.next_entry, self.last_entry = max(1, m.start), min(m.end, n)
            self.state = "listing"
        elif kind == "LOG_REQUEST_DATA":
            if self.state != "idle":
                return  # "some GCS stream request_data while filling gaps": dropped, same channel
            k, size, _ = self._entry(m.id)
            if k < 0:
                return
            size += self.listed_extra
            self.cur_id = m.id
            self.ofs = m.ofs
            self.remaining = min(max(0, size - m.ofs), m.count)
            self.state = "sending"
        elif kind == "LOG_REQUEST_END":
            self.state = "idle"
        elif kind == "LOG_ERASE":
            self.logs, self.times = [], []

    def _send_entry(self) -> None:
        if self.flavour == "px4":
            n = len(self.order)
            _, size, t = self._entry(self.next_entry) if n else (-1, 0, 0)
        else:
            n = self._count()
            _, size, t = self._entry(self.next_entry) if self.next_entry else (-1, 0, 0)
        self._send(self.mav.log_entry_encode(self.next_entry, n, self.last_entry, t, size + self.listed_extra * (size > 0)))
        if self.next_entry == self.last_entry:
            self.state = "idle"
        else:
            self.next_entry += 1

    def _send_data(self) -> None:
        k, size, _ = self._entry(self.cur_id)
        n = min(self.remaining, LOG_DATA_LEN)
        chunk = self.logs[k][self.ofs:self.ofs + n] if k >= 0 else b""
        data = list(chunk) + [0] * (LOG_DATA_LEN - len(chunk))
        self._send(self.mav.log_data_encode(self.cur_id, self.ofs, len(chunk), data), is_data=True)
        self.data_bytes_sent += len(chunk)
        self.ofs += len(chunk)
        self.remaining -= len(chunk)
        if len(chunk) < LOG_DATA_LEN or self.remaining == 0:
            self.state = "idle"

    # -- the loop -------------------------------------------------------------------------------------
    def run(self, duration: Optional[float] = None) -> None:
        start = last_hb = last_att = last_tick = time.monotonic()
        budget = 0.0
        last_hb -= 1.0
        while duration is None or time.monotonic() - start < duration:
            now = time.monotonic()
            if self._stalled(now):
                while self.conn.recv_msg() is not None:  # a dead link: nothing in, nothing out
                    pass
                time.sleep(0.005)
                last_tick = now
                continue
            while True:
                m = self.conn.recv_msg()
                if m is None:
                    break
                if m.get_type() == "BAD_DATA" or self.rng.random() < self.loss:
                    continue
                self._handle(m, now)
            if now - last_hb >= 1.0:
                last_hb = now
                self._heartbeat()
            if now - last_att >= 0.1:
                last_att = now
                self._send(self.mav.attitude_encode(int((now - start) * 1000), 0.01, -0.02, 1.5, 0.0, 0.0, 0.0))
            budget = min(budget + (now - last_tick) * self.rate / LOG_DATA_LEN, 64.0)
            last_tick = now
            streaming = not (self.flavour == "ardupilot" and now - self.last_gcs_heartbeat > ARDUPILOT_GCS_HEARTBEAT_S)
            while budget >= 1.0 and self.state in ("listing", "sending") and streaming:
                budget -= 1.0
                if self.state == "listing":
                    self._send_entry()
                else:
                    self._send_data()
            if self.state not in ("listing", "sending"):
                budget = min(budget, 1.0)
            self.conn.select(0.0005 if self.state in ("listing", "sending") else 0.01)


def main(argv: Optional[list[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="*", type=Path, help="log files to serve, oldest first")
    ap.add_argument("--flavour", choices=sorted(AUTOPILOT_IDS), default="px4")
    ap.add_argument("--connect", required=True, help="mavutil string, e.g. udpout:127.0.0.1:14550 or tcpin:127.0.0.1:5760")
    ap.add_argument("--no-clock", action="store_true", help="time_utc 0 for every log (no GPS clock)")
    ap.add_argument("--loss", type=float, default=0.0)
    ap.add_argument("--duplicate", type=float, default=0.0)
    ap.add_argument("--reorder", type=float, default=0.0)
    ap.add_argument("--rate", type=float, default=1e6, help="LOG_DATA bytes of log per second")
    ap.add_argument("--stall-after", type=int, default=None, help="go silent after this many LOG_DATA bytes")
    ap.add_argument("--stall-for", type=float, default=None, help="... for this many seconds (default: forever)")
    ap.add_argument("--armed", action="store_true")
    ap.add_argument("--scan-reversed", action="store_true", help="PX4: list the newest log first (folder scan order)")
    ap.add_argument("--listed-extra", type=int, default=0, help="list every log this many bytes larger than it is")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    a = ap.parse_args(argv)
    logs = [p.read_bytes() for p in a.logs]
    times = [0] * len(logs) if a.no_clock else None
    double = VehicleDouble(logs, flavour=a.flavour, connect=a.connect, times=times, loss=a.loss,
                           duplicate=a.duplicate, reorder=a.reorder, rate=a.rate, stall_after=a.stall_after,
                           stall_for=a.stall_for, armed=a.armed, scan_reversed=a.scan_reversed,
                           listed_extra=a.listed_extra, seed=a.seed)
    print("ready", flush=True)
    try:
        double.run(a.duration)
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    sys.exit(main())
