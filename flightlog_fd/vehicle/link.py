"""One MAVLink connection to one autopilot, as a ground station holds it (pymavlink's mavutil).

:class:`VehicleLink` opens the connection, waits for the autopilot's heartbeat (the first
component whose heartbeat names an autopilot: companion computers, cameras and gimbals send
``MAV_AUTOPILOT_INVALID``), asks for ``AUTOPILOT_VERSION`` (board uid, firmware, capabilities) and
then sends and receives the log protocol's messages, filtered to that autopilot. It sends the
ground station's own heartbeat once a second throughout: ArduPilot stops streaming ``LOG_DATA``
when the ground station's last heartbeat is more than 3 s old
(``AP_Logger_MAVLinkLogTransfer.cpp``, ``handle_log_send_data``).

pymavlink is imported when a link opens (never at the package's import), with MAVLink 2 chosen
(``MAVLINK20``): ``AUTOPILOT_VERSION.uid2`` is a MAVLink 2 extension field.
"""
from __future__ import annotations

import os
import time
from typing import Any, Optional, Sequence

from ..errors import VehicleLinkError
from .ports import Connection

#: The ground station's ids by convention (QGroundControl and Mission Planner use 255 /
#: MAV_COMP_ID_MISSIONPLANNER = 190); autopilots answer any GCS id.
GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190
#: MAVLink's heartbeat rate, and well inside ArduPilot's 3 s cut-off for log streaming.
HEARTBEAT_PERIOD_S = 1.0
#: PX4 and ArduPilot send their heartbeat at 1 Hz on every link: 5 missed beats means no
#: autopilot is there (or it is still booting).
CONNECT_TIMEOUT_S = 5.0
#: AUTOPILOT_VERSION is answered within one scheduler loop; 3 tries of 1 s each, then the vehicle
#: is named by its system id only.
IDENTIFY_TRIES, IDENTIFY_TIMEOUT_S = 3, 1.0

MAV_AUTOPILOT_ARDUPILOTMEGA, MAV_AUTOPILOT_INVALID, MAV_AUTOPILOT_PX4 = 3, 8, 12
MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_TYPE_GCS = 6
MAV_CMD_REQUEST_MESSAGE, MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES = 512, 520
MAVLINK_MSG_ID_AUTOPILOT_VERSION = 148

AUTOPILOT_KINDS = {MAV_AUTOPILOT_PX4: "px4", MAV_AUTOPILOT_ARDUPILOTMEGA: "ardupilot"}
AUTOPILOT_NAMES = {"px4": "PX4", "ardupilot": "ArduPilot"}


def firmware_version(flight_sw_version: int) -> str:
    """``AUTOPILOT_VERSION.flight_sw_version`` (major << 24 | minor << 16 | patch << 8 | type) as text."""
    if not flight_sw_version:
        return ""
    v = flight_sw_version
    return f"{(v >> 24) & 0xFF}.{(v >> 16) & 0xFF}.{(v >> 8) & 0xFF}"


def board_uid(uid: int, uid2: Sequence[int]) -> str:
    """The board's unique id as hex: ``uid2`` (PX4's 18-byte GUID, ArduPilot's MCU id) when set,
    else the 64-bit ``uid``; empty when the autopilot gives neither."""
    raw = bytes(uid2 or b"").rstrip(b"\0")
    if raw:
        return raw.hex()
    return f"{uid:016x}" if uid else ""


class VehicleLink:
    """A ground station's link to one autopilot (context manager: opens, identifies, closes).

    After :meth:`open`: ``kind`` ("px4", "ardupilot" or "mavN"), ``system_id`` / ``component_id`` of the
    autopilot, ``uid`` / ``firmware`` / ``capabilities`` from AUTOPILOT_VERSION (empty / 0 when it did
    not answer), ``status_texts`` the vehicle's STATUSTEXT lines seen while receiving."""

    def __init__(self, connection: Connection, *, connect_timeout: float = CONNECT_TIMEOUT_S):
        self.connection = connection
        self.connect_timeout = connect_timeout
        self.mav: Any = None
        self.kind = ""
        self.system_id = self.component_id = 0
        self.uid = self.firmware = ""
        self.capabilities = 0
        self.status_texts: list[str] = []
        self._last_heartbeat_sent = 0.0

    # -- opening --------------------------------------------------------------------------------
    def __enter__(self) -> "VehicleLink":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def fail(self, message: str) -> VehicleLinkError:
        """The one-line error for this link, with the vehicle's last status text when it said why."""
        if self.status_texts:
            message += f" (the vehicle said: {self.status_texts[-1]})"
        return VehicleLinkError(str(self.connection), message)

    def open(self) -> None:
        """Open the connection, wait for the autopilot's heartbeat, ask who it is."""
        os.environ.setdefault("MAVLINK20", "1")
        from pymavlink import mavutil

        try:
            self.mav = mavutil.mavlink_connection(self.connection.device, baud=self.connection.baud,
                                                  source_system=GCS_SYSTEM_ID, source_component=GCS_COMPONENT_ID,
                                                  autoreconnect=False, retries=0)
        except Exception as e:  # socket, serial and mavutil's own errors: one line
            raise VehicleLinkError(str(self.connection), f"cannot open the link: {e}") from None
        self._wait_autopilot()
        self._identify()

    def close(self) -> None:
        if self.mav is not None:
            try:
                self.mav.close()
            except Exception:
                pass
            self.mav = None

    def _wait_autopilot(self) -> None:
        deadline = time.monotonic() + self.connect_timeout
        while time.monotonic() < deadline:
            self.tick()
            m = self.mav.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2)
            if m is None or m.autopilot == MAV_AUTOPILOT_INVALID or m.type == MAV_TYPE_GCS:
                continue
            self.system_id, self.component_id = m.get_srcSystem(), m.get_srcComponent()
            self.kind = AUTOPILOT_KINDS.get(m.autopilot, f"mav{m.autopilot}")
            if m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED:
                raise VehicleLinkError(str(self.connection), f"the vehicle (system {self.system_id}) is armed: "
                                       "disarm it first (ArduPilot refuses log download while armed, and PX4 "
                                       "is still writing the flight's log)")
            return
        raise VehicleLinkError(str(self.connection), f"no heartbeat from an autopilot in {self.connect_timeout:g} s "
                               "(is the vehicle powered, and is this its link?)")

    def _identify(self) -> None:
        for attempt in range(IDENTIFY_TRIES):
            self.send_command(MAV_CMD_REQUEST_MESSAGE, attempt, MAVLINK_MSG_ID_AUTOPILOT_VERSION)
            self.send_command(MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, attempt, 1)  # firmware before 2020
            m = self.recv(("AUTOPILOT_VERSION",), IDENTIFY_TIMEOUT_S)
            if m is not None:
                self.uid = board_uid(m.uid, getattr(m, "uid2", ()))
                self.firmware = firmware_version(m.flight_sw_version)
                self.capabilities = m.capabilities
                return

    # -- what the rest of the package uses ------------------------------------------------------
    @property
    def autopilot_name(self) -> str:
        return AUTOPILOT_NAMES.get(self.kind, self.kind)

    @property
    def vehicle_key(self) -> str:
        """A folder name for this vehicle: autopilot and board uid (``px4-00040000...``), else its
        system id (``ardupilot-sys1``) when the autopilot did not say its uid."""
        return f"{self.kind}-{self.uid}" if self.uid else f"{self.kind}-sys{self.system_id}"

    def describe(self) -> str:
        fw = f" {self.firmware}" if self.firmware else ""
        return f"{self.autopilot_name}{fw} (system {self.system_id}, {self.vehicle_key}) on {self.connection}"

    def tick(self) -> None:
        """Send the ground station's heartbeat when one is due."""
        now = time.monotonic()
        if now - self._last_heartbeat_sent >= HEARTBEAT_PERIOD_S:
            self._last_heartbeat_sent = now
            self.mav.mav.heartbeat_send(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def send_command(self, command: int, confirmation: int, *params: float) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.mav.command_long_send(self.system_id, self.component_id, command, confirmation, *p)

    def send_log_request_list(self, start: int, end: int) -> None:
        self.mav.mav.log_request_list_send(self.system_id, self.component_id, start, end)

    def send_log_request_data(self, log_id: int, offset: int, count: int) -> None:
        self.mav.mav.log_request_data_send(self.system_id, self.component_id, log_id, offset, count)

    def send_log_request_end(self) -> None:
        self.mav.mav.log_request_end_send(self.system_id, self.component_id)

    def send_log_erase(self) -> None:
        self.mav.mav.log_erase_send(self.system_id, self.component_id)

    def recv(self, types: Sequence[str], timeout: float) -> Optional[Any]:
        """The next message of one of ``types`` from the autopilot, or None after ``timeout`` seconds.
        Keeps the heartbeat going and remembers the vehicle's STATUSTEXT lines."""
        wanted = list(types) + ["STATUSTEXT"]
        deadline = time.monotonic() + timeout
        while True:
            self.tick()
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            m = self.mav.recv_match(type=wanted, blocking=True, timeout=min(left, HEARTBEAT_PERIOD_S / 2))
            if m is None or m.get_srcSystem() != self.system_id or m.get_srcComponent() != self.component_id:
                continue
            if m.get_type() == "STATUSTEXT" and "STATUSTEXT" not in types:
                self.status_texts.append(str(m.text).strip())
                continue
            return m
