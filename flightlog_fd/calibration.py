"""Calibration: one airframe's profile from its healthy flights, the same whoever asks.

`fdlog calibrate` (with and without ``--no-adapt``), the web page's calibration job and the
benchmarks all call :func:`calibrate`, so the same flights give the same profile.

What it does: reads the logs, measures the profile (:func:`calibrate_profile`: imbalance rho, the
command-share baseline, the healthy windows' statistics), then

- without ``adapt``: fits every analyzer's healthy baseline with the shipped model the diagnosis
  will use for this frame (:func:`flightlog_fd.model.model_for_flight`: hexa and octo have their own);
- with ``adapt``: adapts the model to the airframe (:func:`flightlog_fd.training.adapt.adapt_model`,
  needs torch, quadrotors only), stores it beside the profile and fits the analyzers' baselines
  with it.

Logs without per-motor outputs (e.g. ArduPilot logs without RCOU) give a profile of what they
support: the vibration baseline, with ``lacks_`` naming the rest (no imbalance, command shares,
throttle, model statistics or adapted model), with and without ``adapt``.

Imbalance rho (:func:`estimate_imbalance`, flights -> :class:`ImbalanceEstimate`): ``w`` is the
motor SPEED proxy, ``sqrt`` of the thrust proxy of :func:`flightlog_fd.streams.thrust_proxy`
(thrust ~ w^2), averaged over the steady-hover segments of :func:`flightlog_fd.hover.hover_segments`
with their durations as weights. It uses, in this order, what the flights have: at least
``MIN_HOVER_S`` (4 s) of steady hover; else as much of steady flight of any kind (hover, cruise,
gentle climbs and descents: ``STEADY_*`` thresholds, speed free); else the whole airborne time,
which is steady on average (over a flight the mean angular acceleration is ~0, so the mean
commands satisfy the trim moment balance; rho_i is then sqrt(share_i / share_1) of the
airborne-mean thrust shares), provided there are ``MIN_AIRBORNE_S`` of it. ``rho_spread`` is the
standard deviation of the per-segment ratios (0 with a single segment). Motor 1 is the reference
(rho_1 = 1). ``source`` records which. Measured: the project's own healthy sample logs (constant
manoeuvring missions) hold 0 s of hover and 1.8-2.3 s of steady flight, 40-47 s airborne; the
Erle-Copter 34_7 holds 30 s of hover. The command-share baseline (``baseline_``) is the
command-share analyzer's fit (:func:`flightlog_fd.analyzers.share_fit.estimate_baseline`).

Limits: adapting needs the training extra (``pip install 'flightlog-fd[train]'``); one airframe
per profile (:func:`calibrate_profile` refuses mixed logs); battery sag and payload changes move
the hover throttle, not rho.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Iterable, Optional, Sequence, Union

import numpy as np

from .analyzers.share_fit import airborne_thrust, estimate_baseline
from .checks import trained_layout
from .errors import NotDiagnosableError, ProfileError, UnsupportedVehicleError
from .flight import Flight
from .hover import HOVER_MIN_DURATION_S, HoverSegment, hover_seconds, hover_segments
from .profile import PROFILE_ROTOR_COUNTS, Profile
from .streams import DEFAULT_RATE_HZ
from .util import file_sha256
from .windows import FeatureSpec, make_windows

#: Steady flight of any kind (for rho when there is too little hover): rates, tilt and duration
#: relaxed, speed free. A cruise at constant speed and a gentle climb are balanced flight too.
STEADY_MAX_RATE_RMS = 0.5  # rad/s
STEADY_MAX_TILT_RAD = 0.35  # rad (20 deg)
STEADY_MIN_DURATION_S = 1.0
#: Least usable airborne time (s) for the whole-flight fallback.
MIN_AIRBORNE_S = 20.0
#: Least total steady hover (s) for rho: 2 segments of the 2 s minimum, or one of 4 s. At 4 s a
#: 100 Hz log has 400 samples per motor; the ratios then repeat within ~1 % across flights.
MIN_HOVER_S = 4.0

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
        if progress:
            progress("fitting baselines", 0.0)
        profile.fit_analyzers(flights, FaultModel(out_onnx))
        if progress:
            progress("fitting baselines", 1.0)
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


@dataclass
class ImbalanceEstimate:
    """rho (n,) = mean w_i / mean w_1 over hover; rho_spread (n,) = std of per-segment ratios."""

    rho: np.ndarray
    rho_spread: np.ndarray
    hover_s: float
    n_segments: int
    hover_throttle: float
    segments: list[HoverSegment] = field(default_factory=list)
    source: str = "hover"  # "hover" | "steady flight" | "airborne mean"


def estimate_imbalance(flights: Iterable[Flight], min_hover_s: float = MIN_HOVER_S,
                       min_segment_s: float = HOVER_MIN_DURATION_S,
                       thrust_blocks: Optional[list[np.ndarray]] = None) -> ImbalanceEstimate:
    """Motor-imbalance ratios from the steadiest flight the healthy logs hold (module docstring).

    Raises NotDiagnosableError (naming the logs, what was found and what would do) when the
    flights hold neither ``min_hover_s`` of steady flight nor ``MIN_AIRBORNE_S`` of airborne data.
    ``thrust_blocks``: :func:`~flightlog_fd.analyzers.share_fit.airborne_thrust` of the flights when the caller has it already.
    """
    flights = list(flights)
    if not flights:
        raise ValueError("estimate_imbalance needs at least one flight")
    hover: list[HoverSegment] = []
    for fl in flights:
        hover += hover_segments(fl, min_duration_s=min_segment_s)
    source, segments = "hover", hover
    if hover_seconds(hover) < min_hover_s:
        steady: list[HoverSegment] = []
        for fl in flights:
            steady += hover_segments(fl, min_duration_s=STEADY_MIN_DURATION_S, max_rate_rms=STEADY_MAX_RATE_RMS,
                                     max_tilt_rad=STEADY_MAX_TILT_RAD, max_speed_m_s=float("inf"))
        source, segments = "steady flight", steady
    if hover_seconds(segments) >= min_hover_s:
        weights = np.array([s.duration_s for s in segments])
        speeds = np.array([s.mean_speed for s in segments])  # (S, n)
        pooled = np.average(speeds, axis=0, weights=weights)
        rho = pooled / pooled[0]
        per_segment = speeds / speeds[:, :1]
        spread = per_segment.std(axis=0, ddof=1) if len(segments) > 1 else np.zeros(rho.shape)
        throttle = float(np.average([s.throttle for s in segments], weights=weights))
        return ImbalanceEstimate(rho=rho, rho_spread=spread, hover_s=hover_seconds(segments),
                                 n_segments=len(segments), hover_throttle=throttle, segments=segments, source=source)
    # Whole airborne time: steady on average (module docstring).
    chunks = thrust_blocks if thrust_blocks is not None else airborne_thrust(flights)
    airborne_s = sum(len(c) for c in chunks) / DEFAULT_RATE_HZ
    if airborne_s < MIN_AIRBORNE_S:
        names = ", ".join(Path(f.path).name if f.path else "<in-memory flight>" for f in flights)
        where = flights[0].path if len(flights) == 1 else None
        raise NotDiagnosableError(
            where, f"found {hover_seconds(hover):.1f} s of steady hover, {hover_seconds(segments):.1f} s of steady "
                   f"flight and {airborne_s:.0f} s of usable airborne data in {len(flights)} log(s) [{names}]; "
                   f"calibration needs {min_hover_s:g} s of steady flight (hover, cruise or a gentle climb: rates "
                   f"< {math.degrees(STEADY_MAX_RATE_RMS):.0f} deg/s, tilt < {math.degrees(STEADY_MAX_TILT_RAD):.0f} deg) "
                   f"or {MIN_AIRBORNE_S:.0f} s of airborne flight: give a longer healthy flight or several")
    u = np.vstack(chunks)
    mean_thrust = u.mean(axis=0)
    speed = np.sqrt(np.clip(mean_thrust, 0.0, None))
    rho = speed / speed[0]
    per_chunk = np.array([np.sqrt(np.clip(c.mean(axis=0), 0.0, None)) for c in chunks if len(c)])
    per_chunk = per_chunk / per_chunk[:, :1]
    spread = per_chunk.std(axis=0, ddof=1) if len(per_chunk) > 1 else np.zeros(rho.shape)
    return ImbalanceEstimate(rho=rho, rho_spread=spread, hover_s=float(airborne_s), n_segments=len(chunks),
                             hover_throttle=float(mean_thrust.mean()), segments=[], source="airborne mean")



def _source_entry(fl: Flight) -> dict:
    if fl.path and Path(fl.path).is_file():
        return {"name": Path(fl.path).name, "sha256": file_sha256(fl.path)}
    return {"name": Path(fl.path).name if fl.path else "<in-memory flight>", "sha256": None}


def _stream_rates(flights: Sequence[Flight]) -> dict[str, float]:
    """Each stream's median rate (Hz) over the calibration flights."""
    rates: dict[str, list[float]] = {}
    for fl in flights:
        for s in fl.streams():
            rates.setdefault(s.name, []).append(s.rate_hz)
    return {k: float(np.median(v)) for k, v in rates.items()}


def _check_not_labelled_damaged(fl: Flight) -> None:
    if fl.truth and int(fl.truth.get("label", 0) or 0) != 0:
        raise ProfileError(fl.path, "calibration logs must be healthy flights; this one is labelled damaged")


def calibrate_profile(paths_or_flights: Iterable[Union[PathLike, Flight]], spec: Optional[FeatureSpec] = None,
                      min_hover_s: float = MIN_HOVER_S) -> Profile:
    """A :class:`Profile` from HEALTHY flights of one airframe (paths are read with load_flight).

    Raises UnsupportedVehicleError for a frame no shipped model is for (quad, hexa-X/+,
    octo-X/+/octaquad-X), ProfileError when the logs mix autopilots or
    frames or one is labelled damaged, NotDiagnosableError when hover or windows are too few.
    """
    from . import __version__, load_flight

    flights = [x if isinstance(x, Flight) else load_flight(x) for x in paths_or_flights]
    if not flights:
        raise ValueError("calibrate_profile needs at least one log")
    first = flights[0]
    for fl in flights:
        if fl.frame is None or not (fl.frame.is_quad or (fl.frame.rotor_count in PROFILE_ROTOR_COUNTS
                                                          and not fl.frame.unplaced and trained_layout(fl.frame))):
            what = fl.frame.name if fl.frame is not None else fl.vehicle_type
            raise UnsupportedVehicleError(fl.path, f"calibration needs a quadrotor, hexa-X/+ or octo-X/+/octaquad-X "
                                                   f"log; this one is {what}")
        if (fl.autopilot, fl.frame.name, fl.frame.rotor_count) != (first.autopilot, first.frame.name,
                                                                   first.frame.rotor_count):
            raise ProfileError(fl.path, f"all calibration logs must come from one airframe: this log is "
                                        f"{fl.autopilot} {fl.frame.name}, {Path(first.path or '').name or 'the first'} "
                                        f"is {first.autopilot} {first.frame.name}")
        _check_not_labelled_damaged(fl)
    per_flight = [airborne_thrust([fl]) for fl in flights]
    thrust_blocks = [b for pf in per_flight for b in pf]
    imbalance = estimate_imbalance(flights, min_hover_s=min_hover_s, thrust_blocks=thrust_blocks)

    base = spec or FeatureSpec(n_motors=first.frame.rotor_count)
    if base.n_motors != first.frame.rotor_count:
        raise ProfileError(first.path, f"the model takes {base.n_motors} motors, this frame has "
                                       f"{first.frame.rotor_count}")
    unfitted = FeatureSpec.from_dict({**base.to_dict(), "mean": None, "std": None})
    X = np.concatenate([make_windows(fl, unfitted).X for fl in flights])
    if len(X) == 0:
        raise NotDiagnosableError(first.path if len(flights) == 1 else None,
                                  "the calibration logs yield no input window (too little airborne time without gaps)")
    fitted = unfitted.fit(X)

    return Profile(
        autopilot=first.autopilot, frame=first.frame.name, rotor_count=first.frame.rotor_count,
        firmware=first.firmware, vehicle_id=first.vehicle_id,
        rho_=imbalance.rho, rho_spread_=imbalance.rho_spread, hover_throttle_=imbalance.hover_throttle,
        rho_source_=imbalance.source, baseline_=estimate_baseline(flights, thrust_blocks, per_flight),
        hover_s_=imbalance.hover_s, n_hover_segments_=imbalance.n_segments, n_windows_=int(len(X)),
        stream_rates=_stream_rates(flights),
        feature_spec=fitted.to_dict(), source_logs=[_source_entry(fl) for fl in flights],
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"), tool_version=__version__)


#: What a profile from logs without motor outputs cannot hold (its ``lacks_``).
MOTORLESS_LACKS = ("no per-motor outputs in the calibration log(s): no motor imbalance (rho), command-share "
                   "baseline, hover throttle, model statistics or adapted model; only the baselines of "
                   "analyzers that need no motor outputs (vibration)")


def motorless_profile(flights: list[Flight], analyzers: dict) -> Profile:
    """A profile from HEALTHY flights without motor outputs: their identity and the analyzers'
    ``analyzers`` baselines (e.g. vibration), ``lacks_`` saying what is missing. ProfileError
    when the logs mix airframes or no analyzer could fit a baseline."""
    from . import __version__

    first = flights[0]
    name = lambda fl: fl.frame.name if fl.frame is not None else "unknown"  # noqa: E731
    for fl in flights:
        if (fl.autopilot, name(fl)) != (first.autopilot, name(first)):
            raise ProfileError(fl.path, f"all calibration logs must come from one airframe: this log is "
                                        f"{fl.autopilot} {name(fl)}, the first is {first.autopilot} {name(first)}")
        _check_not_labelled_damaged(fl)
    if first.frame is None or first.frame.rotor_count not in PROFILE_ROTOR_COUNTS:
        raise UnsupportedVehicleError(first.path, f"calibration needs a quadrotor, hexa or octo log; this one is "
                                                  f"{name(first)}")
    if not analyzers:
        raise NotDiagnosableError(first.path if len(flights) == 1 else None,
                                  "no motor outputs and no vibration data in the calibration log(s): nothing to "
                                  "calibrate")
    return Profile(autopilot=first.autopilot, frame=first.frame.name, rotor_count=first.frame.rotor_count,
                   firmware=first.firmware, vehicle_id=first.vehicle_id, rho_=None, rho_spread_=None,
                   hover_throttle_=None, feature_spec=None, rho_source_="",
                   stream_rates=_stream_rates(flights),
                   source_logs=[_source_entry(fl) for fl in flights], analyzers=dict(analyzers),
                   lacks_=[MOTORLESS_LACKS], created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                   tool_version=__version__)
