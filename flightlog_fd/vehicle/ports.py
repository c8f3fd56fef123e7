"""Where the autopilot is: a connection string as `mavutil` spells it, or the one USB autopilot.

Pure functions (no I/O but :func:`list_serial_ports`): :func:`parse_connection` checks a string the
user typed, :func:`pick_usb_autopilot` chooses among the serial ports the system lists.

USB ids: the boards' vendor / product ids as QGroundControl's auto-connect table lists them
(``src/comm/USBBoardInfo.json``: PX4 FMU boards under 3D Robotics' vendor id 0x26AC and the newer
PX4-branded ids, ArduPilot's ChibiOS ids 0x1209:0x5740/0x5741 and 0x0483:0x5740, CubePilot and
Holybro by vendor), plus its fall-backs on the USB manufacturer / product strings. Telemetry radios
(SiK, FTDI) and GPS receivers are not autopilots and are never picked by themselves.
"""
from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

from ..errors import VehicleLinkError

#: USB CDC ignores the baud rate; mavutil needs one for a serial port all the same.
DEFAULT_BAUD = 115200

#: (vendor id, product id or None for every product of that vendor, board name).
AUTOPILOT_USB_IDS: tuple[tuple[int, Optional[int], str], ...] = (
    (0x26AC, None, "PX4 FMU (3D Robotics ids)"),
    (0x3185, 0x0033, "PX4 FMU v5X"),
    (0x3185, 0x0035, "PX4 FMU v6X"),
    (0x3185, 0x0038, "PX4 FMU v6C"),
    (0x3185, 0x0039, "ARK FMU v6X"),
    (0x3185, 0x003B, "ARK FPV"),
    (0x1B8C, 0x0036, "PX4 FMU v6U"),
    (0x3643, 0x001D, "PX4 FMU v6X-RT"),
    (0x1FC9, 0x001C, "PX4 FMUK66"),
    (0x0483, 0xA32F, "ModalAI FCv1"),
    (0x0483, 0xA330, "ModalAI FCv2"),
    (0x0483, 0x0037, "SmartAP AIRLink"),
    (0x1008, 0x0001, "UVify Core"),
    (0x3163, 0x004C, "CUAV"),
    (0x3162, None, "Holybro"),
    (0x2DAE, None, "CubePilot"),
    (0x35A7, 0x0001, "ThePeach FCC-K1"),
    (0x35A7, 0x0002, "ThePeach FCC-R1"),
    (0x1209, 0x5740, "ArduPilot ChibiOS"),
    (0x1209, 0x5741, "ArduPilot ChibiOS"),
    (0x0483, 0x5740, "ArduPilot ChibiOS (STM32 virtual COM port)"),
)
#: Products that share an autopilot vendor id but are not autopilots.
NOT_AUTOPILOT_USB_IDS = {(0x26AC, 0x0015): "PX4 Flow"}
#: USB manufacturer / product strings of autopilots whose ids are not in the table above.
AUTOPILOT_MANUFACTURERS = re.compile(r"^(ArduPilot|Hex/ProfiCNC|Holybro|mRo|CubePilot)$")
AUTOPILOT_PRODUCTS = re.compile(r"^(PX4 (FMU|Crazyflie|OmnibusF4SD)|ARK (BL )?FMU|fmuv[2-6]|mRoControlZeroF7)")

#: The prefixes `fdlog pull` accepts, as mavutil spells them (``udp:`` listens like ``udpin:``).
NETWORK_PREFIXES = ("udp:", "udpin:", "udpout:", "tcp:", "tcpin:")


@dataclass(frozen=True)
class Connection:
    """A link to open: ``device`` is what mavutil is given; ``baud`` only for serial ports."""
    device: str
    baud: int = DEFAULT_BAUD
    serial: bool = False
    description: str = ""

    def __str__(self) -> str:
        return self.device if not self.serial or self.baud == DEFAULT_BAUD else f"{self.device},{self.baud}"


@dataclass(frozen=True)
class SerialPort:
    """One serial port as the system lists it (pyserial's ListPortInfo, reduced)."""
    device: str
    vid: Optional[int] = None
    pid: Optional[int] = None
    serial_number: Optional[str] = None
    manufacturer: Optional[str] = None
    product: Optional[str] = None
    interface: Optional[str] = None

    def label(self) -> str:
        ids = f"{self.vid:04x}:{self.pid:04x}" if self.vid is not None and self.pid is not None else "no USB id"
        name = " ".join(x for x in (self.manufacturer, self.product) if x)
        return f"{self.device} ({ids}{', ' + name if name else ''})"


def autopilot_name(port: SerialPort) -> Optional[str]:
    """The board name when ``port`` is an autopilot's USB port, else None."""
    if port.vid is not None and port.pid is not None:
        if (port.vid, port.pid) in NOT_AUTOPILOT_USB_IDS:
            return None
        for vid, pid, name in AUTOPILOT_USB_IDS:
            if port.vid == vid and (pid is None or port.pid == pid):
                return name
    if port.manufacturer and AUTOPILOT_MANUFACTURERS.match(port.manufacturer):
        return port.manufacturer
    if port.product and AUTOPILOT_PRODUCTS.match(port.product):
        return port.product
    return None


def pick_usb_autopilot(ports: Sequence[SerialPort]) -> Connection:
    """The one autopilot among ``ports``, else VehicleLinkError with one line listing what was found.

    A board that shows several serial interfaces under one USB serial number (ArduPilot's dual-CDC
    boards: MAVLink on the first, SLCAN on the second) is one autopilot, reached on its first
    interface (the lowest device name)."""
    boards: dict[tuple, list[SerialPort]] = {}
    for p in ports:
        if autopilot_name(p) is not None:
            key = (p.vid, p.pid, p.serial_number) if p.serial_number else (p.device,)
            boards.setdefault(key, []).append(p)
    if len(boards) == 1:
        port = sorted(next(iter(boards.values())), key=lambda p: (p.interface or "", p.device))[0]
        return Connection(port.device, DEFAULT_BAUD, serial=True, description=autopilot_name(port) or "")
    if not boards:
        seen = "; ".join(p.label() for p in ports) or "no serial ports at all"
        raise VehicleLinkError("usb", f"no autopilot found on USB (serial ports: {seen}); plug one in, or give "
                               "a connection such as udp:127.0.0.1:14550, tcp:HOST:5760 or /dev/ttyUSB0,57600")
    found = "; ".join(f"{sorted(b, key=lambda p: p.device)[0].label()}" for b in boards.values())
    raise VehicleLinkError("usb", f"{len(boards)} autopilots on USB ({found}): name one, e.g. fdlog pull "
                           f"{sorted(boards.values(), key=lambda b: b[0].device)[0][0].device}")


def list_serial_ports() -> list[SerialPort]:
    """The system's serial ports (pyserial), reduced to :class:`SerialPort`."""
    try:
        from serial.tools import list_ports
    except ImportError:  # pragma: no cover - pyserial is a dependency
        raise VehicleLinkError("usb", "finding the autopilot on USB needs pyserial: pip install pyserial") from None
    return [SerialPort(p.device, p.vid, p.pid, p.serial_number, p.manufacturer, p.product,
                       getattr(p, "interface", None)) for p in list_ports.comports()]


def _host_port(text: str, where: str) -> None:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise VehicleLinkError(where, "expected HOST:PORT after the prefix, e.g. udp:127.0.0.1:14550")


def parse_connection(text: Optional[str], ports: Optional[Iterable[SerialPort]] = None) -> Connection:
    """Check what the user typed and turn it into a :class:`Connection`.

    ``None``: the one USB autopilot among ``ports`` (default: the system's). ``udp:HOST:PORT`` (listen,
    as mavutil's ``udp:``), ``udpin:``, ``udpout:``, ``tcp:HOST:PORT``, ``tcpin:``; else a serial device
    ``DEVICE[,BAUD]`` that must exist and not be a regular file (mavutil would read a log file as a
    recorded link). Anything else: VehicleLinkError naming the string.
    """
    if text is None or not text.strip():
        return pick_usb_autopilot(list(ports) if ports is not None else list_serial_ports())
    text = text.strip()
    if text.startswith(NETWORK_PREFIXES):
        prefix, _, rest = text.partition(":")
        _host_port(rest, text)
        return Connection(text, description=f"{prefix} link")
    device, baud = text, DEFAULT_BAUD
    head, sep, tail = text.rpartition(",")
    if sep:
        if not tail.isdigit() or int(tail) <= 0:
            raise VehicleLinkError(text, "the baud rate after ',' must be a positive number, e.g. /dev/ttyUSB0,57600")
        device, baud = head, int(tail)
    if re.fullmatch(r"COM\d+", device, flags=re.IGNORECASE):  # Windows serial ports are names, not paths
        return Connection(device, baud, serial=True, description="serial port")
    if ":" in device and not os.path.exists(device):
        raise VehicleLinkError(text, "not a connection fdlog knows: use udp:HOST:PORT, udpin:, udpout:, "
                               "tcp:HOST:PORT, tcpin:, or a serial device DEVICE[,BAUD]")
    try:
        mode = os.stat(device).st_mode
    except OSError:
        raise VehicleLinkError(text, "no such serial port (and not a connection such as udp:127.0.0.1:14550)") from None
    if stat.S_ISREG(mode):
        raise VehicleLinkError(text, "is a file, not a serial port (to diagnose a log file: fdlog diagnose FILE)")
    if stat.S_ISDIR(mode):
        raise VehicleLinkError(text, "is a folder, not a serial port")
    return Connection(device, baud, serial=True, description="serial port")
