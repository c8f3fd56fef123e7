"""flightlog-fd: offline propeller-fault diagnosis for multirotor flight logs.

Data flows one way (:mod:`flightlog_fd.diagnose` runs it): log file -> :func:`load_flight` ->
:class:`Flight` -> NIF/CF windows (:mod:`flightlog_fd.windows`) -> ONNX model
(:mod:`flightlog_fd.model`) -> the windows' timeline and onset (:mod:`flightlog_fd.timeline`) ->
per-motor findings of each evidence source (:mod:`flightlog_fd.analyzers`) -> the verdict
(:mod:`flightlog_fd.decision`, also for stopped motors and flights that cannot be judged) ->
report (:mod:`flightlog_fd.report`).
"""
__version__ = "0.1.0"

from .flight import Flight, Frame, Rotor, Series  # noqa: E402,F401
from .errors import FlightLogError  # noqa: E402,F401


def load_flight(path):
    """Read a PX4 ULog or ArduPilot DataFlash log (chosen by content) into a :class:`Flight`."""
    from .logs import load_flight as _load

    return _load(path)
