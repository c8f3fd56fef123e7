"""Errors the user sees as one line naming the file and the problem (exit code 2).

Every parser and check raises these instead of letting a library's exception escape; the CLI
catches :class:`FlightLogError` and prints ``fdlog: <file>: <message>``.
"""
from __future__ import annotations


class FlightLogError(Exception):
    """A problem with one input file: not a log, truncated, missing data, unsupported vehicle..."""

    exit_code = 2

    def __init__(self, path, message: str):
        self.path = str(path) if path is not None else None
        self.message = message
        super().__init__(f"{self.path}: {message}" if self.path else message)

    def __reduce__(self):  # picklable as raised (a worker process hands it back to the server)
        return (self.__class__, (self.path, self.message))


class NotALogError(FlightLogError):
    """The file is neither a ULog nor a DataFlash log (or it is empty)."""


class CorruptLogError(FlightLogError):
    """The file starts as a log but cannot be decoded."""


class UnsupportedVehicleError(FlightLogError):
    """The log is from a vehicle this tool cannot diagnose (fixed-wing, VTOL, a multirotor frame
    with no motor table or no shipped model...)."""


class MissingDataError(FlightLogError):
    """A stream the diagnosis needs (motor outputs, angular rates) is absent."""


class NotDiagnosableError(FlightLogError):
    """The log loads but cannot be diagnosed (never airborne, rates too low, too little hover...)."""


class ProfileError(FlightLogError):
    """A calibration profile is invalid or was made for another airframe."""


class ModelError(FlightLogError):
    """A model file is missing, unreadable, or lacks the metadata needed to build its input."""


class VehicleLinkError(FlightLogError):
    """The link to a vehicle (`fdlog pull`) failed: no autopilot found or answering, a stalled
    transfer, a log that does not match its listing. Named by the connection, not a file."""
