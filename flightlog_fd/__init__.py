"""flightlog-fd: offline propeller-fault diagnosis for multirotor flight logs.

Data flows one way (:mod:`flightlog_fd.diagnose` runs it): log file -> :func:`load_flight` ->
:class:`Flight` -> NIF/CF windows (:mod:`flightlog_fd.windows`) -> ONNX model
(:mod:`flightlog_fd.model`) -> the windows' timeline and onset (:mod:`flightlog_fd.timeline`) ->
per-motor findings of each evidence source (:mod:`flightlog_fd.analyzers`) -> the verdict
(:mod:`flightlog_fd.decision`, also for stopped motors and flights that cannot be judged) ->
report (:mod:`flightlog_fd.report`).

Importing the package loads nothing else: ``Flight``, ``Frame``, ``Rotor``, ``Series`` (and
NumPy with them) load on first use, so `fdlog --help` does not pay for them.
"""
__version__ = "0.1.0"

from .errors import FlightLogError  # noqa: E402,F401

_FLIGHT_NAMES = ("Flight", "Frame", "Rotor", "Series")
__all__ = ["FlightLogError", "load_flight", "__version__", *_FLIGHT_NAMES]


def __getattr__(name):
    """The Flight types, imported on first use (PEP 562)."""
    if name in _FLIGHT_NAMES:
        from . import flight

        return getattr(flight, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def load_flight(path):
    """Read a PX4 ULog or ArduPilot DataFlash log (chosen by content) into a :class:`Flight`."""
    from .logs import load_flight as _load

    return _load(path)
