"""Calibration: one airframe's profile from its healthy flights, the same whoever asks.

`fdlog calibrate` (with and without ``--no-adapt``), the web page's calibration job and the
benchmarks all call :func:`calibrate`, so the same flights give the same profile.

What it does: reads the logs, measures the profile (:func:`flightlog_fd.profile.calibrate_profile`:
imbalance rho, the command-share baseline, the healthy windows' statistics), then

- without ``adapt``: fits every analyzer's healthy baseline with the shipped model the diagnosis
  will use for this frame (:func:`flightlog_fd.model.model_for_flight`: hexa and octo have their own);
- with ``adapt``: adapts the model to the airframe (:func:`flightlog_fd.training.adapt.adapt_model`,
  needs torch, quadrotors only), stores it beside the profile and fits the analyzers' baselines
  with it.

Logs without per-motor outputs (e.g. ArduPilot logs without RCOU) give a profile of what they
support: the vibration baseline, with ``lacks_`` naming the rest (no imbalance, command shares,
throttle, model statistics or adapted model), with and without ``adapt``.

Limits: adapting needs the training extra (``pip install 'flightlog-fd[train]'``); one airframe
per profile (:func:`~flightlog_fd.profile.calibrate_profile` refuses mixed logs).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Iterable, Optional, Union

from .errors import ProfileError, UnsupportedVehicleError
from .flight import Flight
from .profile import Profile, calibrate_profile, motorless_profile
from .windows import FeatureSpec

PathLike = Union[str, os.PathLike]


def calibrate(flights_or_paths: Iterable[Union[PathLike, Flight]], *, adapt: bool = False,
              output: Optional[PathLike] = None, overwrite: bool = False, settings=None,
              base_model: Optional[PathLike] = None,
              progress: Optional[Callable[[str, float], None]] = None, flight: Optional[int] = None) -> Profile:
    """The calibration profile of one airframe from HEALTHY flights (paths or Flights).

    ``output``: the profile file to write (needed with ``adapt``: the adapted model goes beside it,
    ``<stem>.onnx``); refuses to replace an existing file unless ``overwrite``. ``settings``
    (:class:`flightlog_fd.training.adapt.AdaptSettings`), ``base_model`` and ``progress``
    (``progress(stage, fraction)``) are for ``adapt``. ``flight``: calibrate on that take-off to
    landing (1-based, :func:`flightlog_fd.flights.split_flights`) of the one log given (the profile's
    ``extra["flight"]`` names it). Raises FlightLogError subclasses for bad input (one line each);
    ImportError when ``adapt`` is asked without torch.
    """
    from . import load_flight
    from .model import FaultModel, default_model_path, model_for_flight

    if adapt and output is None:
        raise ValueError("calibrate(adapt=True) needs an output path: the adapted model is stored beside the profile")
    out = Path(output) if output is not None else None
    if out is not None:
        for p in ([out, out.with_suffix(".onnx")] if adapt else [out]):
            if p.exists() and not overwrite:
                raise ProfileError(p, "already exists (use --force to overwrite)")
    flights = [x if isinstance(x, Flight) else load_flight(x) for x in flights_or_paths]
    part = None
    if flight is not None:
        flights, part = _one_flight(flights, flight)
    if flights and all(fl.motors is None for fl in flights):
        profile = _motorless(flights, adapt)
    elif not adapt:
        profile = calibrate_profile(flights)
        if flights:
            profile.fit_analyzers(flights, model_for_flight(FaultModel(default_model_path()), flights[0]))
    else:
        from .training.adapt import AdaptSettings, adapt_model, base_model_files

        for fl in flights:  # the adjusted simulation and the base weights are the quad's
            if fl.frame is not None and fl.frame.rotor_count not in (0, 4):
                raise UnsupportedVehicleError(fl.path, f"adapting the model is for quadrotors so far; this is a "
                                                       f"{fl.frame.rotor_count}-rotor {fl.frame.name}: use --no-adapt "
                                                       f"to measure its profile (imbalance and command shares)")
        if progress:
            progress("measuring hover", 0.0)
        base_onnx, _ = base_model_files(None if base_model is None else Path(base_model))
        spec = FeatureSpec.from_dict(FaultModel(base_onnx).feature_spec)
        profile = calibrate_profile(flights, spec=FeatureSpec.from_dict({**spec.to_dict(), "mean": None, "std": None}))
        out_onnx = out.with_suffix(".onnx")
        res = adapt_model(profile, flights, out_onnx, settings=settings or AdaptSettings(),
                          base_model=None if base_model is None else Path(base_model), progress=progress)
        profile.extra = {**(profile.extra or {}), "adaptation": res.summary}
        profile.set_model(out_onnx, profile_path=out)
        profile.fit_analyzers(flights, FaultModel(out_onnx))
    if part is not None:
        profile.extra = {**(profile.extra or {}), "flight": part}
    if out is not None:
        profile.save(out, overwrite=overwrite)
    return profile


def _one_flight(flights: list[Flight], n: int) -> tuple[list[Flight], str]:
    """[flight n of the only log] and its label; ProfileError for several logs or no such flight."""
    from .flights import split_flights

    if len(flights) != 1:
        raise ProfileError(None, f"choosing a flight needs exactly one log ({len(flights)} given)")
    parts = split_flights(flights[0])
    if not 1 <= n <= len(parts):
        raise ProfileError(flights[0].path, f"has {len(parts)} flight{'s' if len(parts) != 1 else ''}: "
                                            f"there is no flight {n}")
    if len(parts) == 1:
        return parts, f"flight 1 of 1, {parts[0].t_start:.1f}-{parts[0].t_end:.1f} s"
    return [parts[n - 1]], parts[n - 1].part


def _motorless(flights: list[Flight], adapt: bool) -> Profile:
    """The profile of logs without per-motor outputs: only the baselines of the analyzers that need
    none (vibration), ``lacks_`` saying what is missing (with ``adapt``: that no model was adapted)."""
    from .analyzers import REGISTRY, fit_baselines

    profile = motorless_profile(flights, fit_baselines(flights, None, [a for a in REGISTRY
                                                                       if not a.needs_motor_outputs]))
    if adapt:
        profile.lacks_.append("the model was not adapted: adapting needs motor outputs")
    return profile
