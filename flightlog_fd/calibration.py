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

Sessions: each log is one calibration session (``one_session`` groups them), a ``sessions_`` entry
(:func:`session_entry`: its shares, throttle, pinning); with two or more the command-share baseline
is their mean (:func:`baseline_of_sessions`) and the diagnosis weighs the commands against the
airframe's own session drift (:mod:`flightlog_fd.analyzers.session_drift`). Each session is first
diagnosed against the others (:func:`check_sessions`) and one that looks damaged is refused.
:func:`add_sessions` (``fdlog calibrate --add``, the web page's "add" job) adds sessions to an
existing profile, keeping the previous file.

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

from .analyzers.share_fit import airborne_thrust, estimate_baseline, pin_spread, shares_of
from .checks import trained_layout
from .errors import NotDiagnosableError, ProfileError, UnsupportedVehicleError
from .flight import Flight
from .hover import HOVER_MIN_DURATION_S, HoverSegment, hover_seconds, hover_segments
from .profile import AS_CALIBRATED, MAX_CONFIGURATION_NAME, PROFILE_ROTOR_COUNTS, Profile
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
              progress: Optional[Callable[[str, float], None]] = None, flight: Optional[int] = None,
              one_session: bool = False) -> Profile:
    """The calibration profile of one airframe from HEALTHY flights (paths or Flights).

    ``output``: the profile file to write (needed with ``adapt``: the adapted model goes beside it,
    ``<stem>.onnx``); refuses to replace an existing file unless ``overwrite``. ``settings``
    (:class:`flightlog_fd.training.adapt.AdaptSettings`), ``base_model`` and ``progress``
    (``progress(stage, fraction)``) are for ``adapt``. ``flight``: calibrate on that take-off to
    landing (1-based, :func:`flightlog_fd.flights.split_flights`) of the one log given (the profile's
    ``extra["flight"]`` names it). Each log is one calibration session unless ``one_session``
    groups them all into one; with two or more sessions each is first diagnosed against the others
    (:func:`check_sessions`: one that looks damaged is refused). Raises FlightLogError subclasses
    for bad input (one line each); ImportError when ``adapt`` is asked without torch.
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
    groups = [list(range(len(flights)))] if (one_session or part is not None) else [[i] for i in range(len(flights))]
    if flights and all(fl.motors is None for fl in flights):
        profile = _motorless(flights, adapt)
    elif not adapt:
        profile = calibrate_profile(flights, sessions=groups)
        if flights:
            check_sessions(flights, groups)
            profile.fit_analyzers(flights, model_for_flight(FaultModel(default_model_path()), flights[0]),
                                  sessions=groups)
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
        profile = calibrate_profile(flights, spec=FeatureSpec.from_dict({**spec.to_dict(), "mean": None, "std": None}),
                                    sessions=groups)
        check_sessions(flights, groups)
        if progress:
            progress("measuring hover", 1.0)
        out_onnx = out.with_suffix(".onnx")
        res = adapt_model(profile, flights, out_onnx, settings=settings or AdaptSettings(),
                          base_model=None if base_model is None else Path(base_model), progress=progress)
        profile.extra = {**(profile.extra or {}), "adaptation": res.summary}
        profile.set_model(out_onnx, profile_path=out)
        if progress:
            progress("fitting baselines", 0.0)
        profile.fit_analyzers(flights, FaultModel(out_onnx), sessions=groups, adapted_on=True)
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
    """A calibration log as the profile records it: its name, sha256 and, when the log has GPS/UTC
    time, when it flew (``utc_start``, POSIX s: a later flight of the same session is weighed
    against it with the session's own small drift, :func:`~flightlog_fd.analyzers.reliability.same_session`)."""
    utc = getattr(fl, "utc_start", None)
    when = {"utc_start": float(utc)} if utc is not None and np.isfinite(utc) else {}
    if fl.path and Path(fl.path).is_file():
        return {"name": Path(fl.path).name, "sha256": file_sha256(fl.path), **when}
    return {"name": Path(fl.path).name if fl.path else "<in-memory flight>", "sha256": None, **when}


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
                      min_hover_s: float = MIN_HOVER_S, sessions: Optional[Sequence[Sequence[int]]] = None) -> Profile:
    """A :class:`Profile` from HEALTHY flights of one airframe (paths are read with load_flight).

    ``sessions``: the flights' indices grouped into calibration sessions (default: each flight is
    one); with two or more the command-share baseline is their mean (:func:`baseline_of_sessions`).

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
    groups = [list(g) for g in sessions] if sessions is not None else [[i] for i in range(len(flights))]
    entries = [session_entry([flights[i] for i in g], [per_flight[i] for i in g]) for g in groups]
    baseline = baseline_of_sessions(estimate_baseline(flights, thrust_blocks, per_flight), entries)

    return Profile(
        autopilot=first.autopilot, frame=first.frame.name, rotor_count=first.frame.rotor_count,
        firmware=first.firmware, vehicle_id=first.vehicle_id,
        rho_=imbalance.rho, rho_spread_=imbalance.rho_spread, hover_throttle_=imbalance.hover_throttle,
        rho_source_=imbalance.source, baseline_=baseline,
        hover_s_=imbalance.hover_s, n_hover_segments_=imbalance.n_segments, n_windows_=int(len(X)),
        stream_rates=_stream_rates(flights),
        feature_spec=fitted.to_dict(), source_logs=[_source_entry(fl) for fl in flights],
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"), tool_version=__version__,
        sessions_=entries)


# ----------------------------------------------------------------------------- sessions

#: Least airborne time (s) of a calibration session: its shares' pinning is measured from its
#: thirds (share_fit.pin_spread needs 3 s); a shorter flight joins a session with others.
MIN_SESSION_S = 3.0


def session_entry(flights: Sequence[Flight], blocks: Optional[Sequence[Sequence[np.ndarray]]] = None) -> dict:
    """One calibration session (``Profile.sessions_`` entry) from its HEALTHY flights: their logs,
    airborne-mean command shares (mean 1), mean thrust command, pinning (:func:`pin_spread`) and
    airborne seconds. ``blocks``: each flight's :func:`airborne_thrust` when the caller has it.
    ProfileError when the flights hold less than ``MIN_SESSION_S`` of airborne commands."""
    per_flight = list(blocks) if blocks is not None else [airborne_thrust([fl]) for fl in flights]
    u = [b for pf in per_flight for b in pf]
    seconds = sum(len(b) for b in u) / DEFAULT_RATE_HZ
    share, throttle = shares_of(u)
    if seconds < MIN_SESSION_S or not np.all(np.isfinite(share)) or not throttle > 0:
        names = ", ".join(Path(f.path).name if f.path else "<in-memory flight>" for f in flights)
        raise ProfileError(flights[0].path if len(flights) == 1 else None,
                           f"{names}: {seconds:.1f} s of airborne motor commands, a calibration session needs "
                           f"{MIN_SESSION_S:g} s: group it with other flights of the same day (--one-session)")
    pin = pin_spread(u)
    return {"logs": [_source_entry(fl) for fl in flights], "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "seconds": round(float(seconds), 1), "share": [float(x) for x in share], "throttle": float(throttle),
            "pin": None if pin is None else [float(x) for x in pin]}


def baseline_of_sessions(base: dict, sessions: Sequence[dict]) -> dict:
    """The command-share baseline (``baseline_``) of a profile holding ``sessions``: with one, ``base``
    as measured on its flights; with two or more, their equal-weight mean shares and geometric-mean
    throttle (each session one draw of the airframe's session drift), the session-to-session
    spreads, the mean's pinning (root-mean-square of the sessions' over sqrt(S)) and the throttle
    range widened to the sessions'; ``base``'s slope is kept."""
    if len(sessions) < 2:
        # flights grouped as one session: their spread is within a session, not between sessions
        grouped = {"spread": None, "throttle_spread": None} if sessions and len(sessions[0].get("logs") or []) > 1 else {}
        return dict(base, n_sessions=max(len(sessions), 1), **grouped)
    shares = np.array([s["share"] for s in sessions], float)
    share = shares.mean(axis=0)
    share = share / share.mean()
    log_thr = np.log([s["throttle"] for s in sessions])
    thr = float(np.exp(log_thr.mean()))
    pins = [s["pin"] for s in sessions if s.get("pin") is not None]
    pin = (np.sqrt(np.mean(np.square(pins), axis=0)) / np.sqrt(len(sessions))) if pins else None
    lo, hi = base.get("throttle_range") or (thr, thr)
    return {**base, "share": [float(x) for x in share], "throttle_ref": thr,
            "throttle_range": [float(min(lo, np.exp(log_thr.min()))), float(max(hi, np.exp(log_thr.max())))],
            "seconds": round(float(sum(s.get("seconds", 0.0) for s in sessions)), 1),
            "source": f"mean of {len(sessions)} calibration sessions' airborne-mean thrust-command shares",
            "n_flights": int(sum(len(s.get("logs") or [None]) for s in sessions)), "n_sessions": len(sessions),
            "spread": [float(x) for x in shares.std(axis=0, ddof=1)],
            "throttle_spread": float(np.std(log_thr, ddof=1)),
            "pin": None if pin is None else [float(x) for x in pin]}


def check_sessions(flights: Sequence[Flight], groups: Sequence[Sequence[int]]) -> None:
    """Diagnose each calibration session against a ``--no-adapt`` profile of the others (two or more
    sessions); ProfileError (one line) for the first that looks damaged or stopped against them, so
    damage is never calibrated away. A session whose others cannot make a profile is not checked."""
    from .errors import FlightLogError
    from .model import FaultModel, default_model_path, model_for_flight

    if len(groups) < 2:
        return
    model = model_for_flight(FaultModel(default_model_path()), flights[0])
    for j, g in enumerate(groups):
        others = [i for k, h in enumerate(groups) if k != j for i in h]
        regroup = [[others.index(i) for i in h] for k, h in enumerate(groups) if k != j]
        try:
            ref = calibrate_profile([flights[i] for i in others], sessions=regroup)
        except FlightLogError:
            continue
        ref.fit_analyzers([flights[i] for i in others], model, sessions=regroup)
        _refuse_if_damaged([flights[i] for i in g], ref, model,
                           f"the other {len(groups) - 1} calibration session{'s' if len(groups) > 2 else ''}")


#: A flight named as a load configuration (``calibrate --add --name``) that the decision calls
#: damaged is taken as the payload the pilot says it carries only when its command shares fit a
#: load toward some direction better than any single rotor's loss by this many nats
#: (``CommandSharesResult.rotor_vs_load`` below minus this for every rotor). Measured against
#: --no-adapt profiles of the healthy flight (benchmarks/bench_load_configurations.py,
#: results/load_configurations.md): px4_sih_dev's 15 weak motors +4.3..+7.9 (the rotor fits
#: better), px4_sih_dev_load's four moved centres of mass -5.6..-0.3, a simulated x500 with 15 %
#: of its mass toward motor 2 -3.1 (called damaged: model and effectiveness read the load as motor 2).
CONFIGURATION_LOAD_OVER_ROTOR = 0.0


def _load_like(d) -> bool:
    """The diagnosis's command shares fit a load better than any one rotor's loss
    (``CONFIGURATION_LOAD_OVER_ROTOR``)."""
    cmd = next((r for r in (d.decision.results if d.decision is not None else []) if r.analyzer == "commands"), None)
    r = list(getattr(cmd, "rotor_vs_load", None) or [])
    return bool(r) and getattr(cmd, "load", None) is not None and max(r) < -CONFIGURATION_LOAD_OVER_ROTOR


def _refuse_if_damaged(flights: Sequence[Flight], profile: Profile, model, against: str,
                       outcome: str = "not calibrated on", named: bool = False) -> list:
    """ProfileError when one of ``flights`` is diagnosed damaged (a rotor lost thrust, whatever the
    cause: calibrating on it would take the loss for the airframe's trim) or stopped against
    ``profile`` with ``model``; else their diagnoses (a moved load is healthy, ``cause`` = ``load``).
    ``named``: the flights are a load configuration the pilot named, so a damaged or held verdict
    whose command shares fit a load better than a rotor (:func:`_load_like`) is taken as that load."""
    from .diagnose import diagnose_flight

    diagnoses = []
    for fl in flights:
        d = diagnose_flight(fl, model, profile, keep_flight=False)
        v = d.verdict
        diagnoses.append(d)
        if v.status in ("damaged", "uncertain") and named and _load_like(d):
            continue
        if v.status in ("damaged", "stopped"):
            what = (f"motor {v.motor} " + ("stopped" if v.status == "stopped" else "lost thrust")) if v.motor else "damaged"
            hint = ("; if it carries a payload and the propellers are sound, add it as a load configuration "
                    "(--name NAME): its commands fit a load better than a rotor"
                    if v.status == "damaged" and outcome.startswith("not added") and _load_like(d) else "")
            raise ProfileError(fl.path, f"looks damaged against {against}: {what} (confidence {v.confidence:.2f}); "
                                        f"{outcome}: inspect the propellers, and calibrate only on healthy flights"
                                        f"{hint}")
    return diagnoses


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


# ----------------------------------------------------------------------------- adding sessions

@dataclass
class AddedSessions:
    """What :func:`add_sessions` did: the new profile, where it was written, where the previous one
    was kept, and what changed in plain words (one line each)."""

    profile: Profile
    path: Path
    previous: Optional[Path]
    changes: list[str]


def add_sessions(profile_path: PathLike, flights_or_paths: Iterable[Union[PathLike, Flight]], *,
                 one_session: bool = False, keep_previous: bool = True, name: Optional[str] = None) -> AddedSessions:
    """Add HEALTHY flights to a profile as new calibration sessions (each log one session unless
    ``one_session``), in place: the previous file is kept beside it (``<stem>.sessions-<N>.json``,
    N its session count, never overwritten; ``keep_previous=False`` when the caller keeps it) and
    the new one replaces it atomically.

    Load configurations: a flight the diagnosis finds carrying another load (``cause`` = ``load``)
    becomes a load configuration of the profile (``configurations_``, its own command-share
    baseline, named by the load, e.g. "load toward motor 1 +22 %") instead of widening the
    airframe's session drift; ``name`` puts all the flights in the configuration of that name (a new
    one, or more sessions of an existing one; :data:`~flightlog_fd.profile.AS_CALIBRATED` for the
    profile's own). A flight that fits the profile's nearest configuration is a session of it. A
    flight whose commands fit a weak rotor better than a load (damaged, stopped, or uncertain
    naming a rotor without the load) is refused as a configuration; a named one the decision calls
    damaged is taken when its command shares fit a load better than any rotor (:func:`_load_like`:
    the model and the vibration cannot tell a payload from a weak rotor, the command pattern can).

    Each new session is first diagnosed against the profile with its own model; one that looks
    damaged (or a stopped motor) is refused (ProfileError, one line) and nothing is written, so
    damage is never calibrated away. Updated: ``sessions_``, the command-share baseline
    (:func:`baseline_of_sessions`; its slope kept), the model-vote baseline (the new sessions'
    means with the profile's model), ``source_logs``. Kept from the earlier sessions: the imbalance
    (rho), the window statistics, the adapted model and the other analyzers' baselines.
    Limits: a profile with motor figures (not one from logs without motor outputs); a profile
    older than schema 6 counts as one session (its flights were pooled)."""
    from . import load_flight
    from .analyzers.model_votes import ModelVotes, combine_sessions
    from .model import FaultModel, default_model_path, model_for_flight

    src = Path(profile_path)
    profile = Profile.load(src)
    if not profile.measures_motors:
        raise ProfileError(src, "holds no command-share baseline (calibrated on logs without motor outputs): "
                                "sessions can only be added to a profile with motor figures; calibrate anew")
    if profile.baseline_ is None:
        raise ProfileError(src, "is a schema-1 profile without a recorded command-share baseline: calibrate anew")
    flights = [x if isinstance(x, Flight) else load_flight(x) for x in flights_or_paths]
    if not flights:
        raise ProfileError(src, "no log to add")
    known = {e.get("sha256") for e in profile.source_logs if e.get("sha256")}
    for fl in flights:
        _check_not_labelled_damaged(fl)
        profile.check_compatible(fl)
        if fl.motors is None:
            raise ProfileError(fl.path, "has no per-motor outputs: it cannot be a command-share session")
        entry = _source_entry(fl)
        if entry["sha256"] and entry["sha256"] in known:
            raise ProfileError(fl.path, f"is already one of {src.name}'s calibration logs")
    model = (FaultModel(profile.model_path(verify=True)) if profile.model
             else model_for_flight(FaultModel(default_model_path()), flights[0]))
    if name is not None:
        name = " ".join(str(name).split())
        if not name or len(name) > MAX_CONFIGURATION_NAME:
            raise ProfileError(src, f"a configuration name needs 1 to {MAX_CONFIGURATION_NAME} characters, not {name!r}")
    n_before = profile.n_sessions
    diagnoses = _refuse_if_damaged(flights, profile, model,
                                   f"the {n_before} session{'s' if n_before != 1 else ''} of {src.name}",
                                   "not added, the profile is unchanged", named=name not in (None, AS_CALIBRATED))
    targets = [_target_configuration(profile, fl, d, name) for fl, d in zip(flights, diagnoses)]
    configured = [(fl, t) for fl, t in zip(flights, targets) if t != AS_CALIBRATED]
    config_changes = _add_configurations(profile, configured, one_session, model)
    config_changes += _add_vibration_sessions(profile, flights)
    flights = [fl for fl, t in zip(flights, targets) if t == AS_CALIBRATED]
    if not flights:
        previous = _keep_previous(src, n_before) if keep_previous else None
        profile.save(src, overwrite=True)
        changes = config_changes + ([f"the previous profile is kept as {previous.name}"] if previous else [])
        return AddedSessions(profile=profile, path=src, previous=previous, changes=changes)

    groups = [flights] if one_session else [[fl] for fl in flights]
    new = [session_entry(g) for g in groups]
    old_sessions = list(profile.sessions_) or [_implicit_session(profile)]
    old_base = dict(profile.baseline_)
    sessions = old_sessions + new
    profile.sessions_ = sessions
    profile.baseline_ = baseline_of_sessions(old_base, sessions)
    profile.source_logs = list(profile.source_logs) + [e for s in new for e in s["logs"]]
    votes = profile.analyzers.get("model")
    sha = str(getattr(model, "sha256", ""))
    if votes and votes.get("model_sha256") == sha:
        earlier = [{"model_sha256": sha, "healthy_mean": m} for m in (votes.get("sessions") or [votes["healthy_mean"]])]
        seen = list(votes.get("sessions_seen") or [bool(profile.model)] * len(earlier))
        added = [ModelVotes().fit_baseline(g, model) for g in groups]
        profile.analyzers = {**profile.analyzers, "model": combine_sessions(earlier + added,
                                                                            seen + [False] * len(added))}
    changes = _session_changes(old_base, profile.baseline_, new, votes, profile.analyzers.get("model"), sessions,
                               n_before)
    changes = config_changes + changes
    previous = _keep_previous(src, n_before) if keep_previous else None
    profile.save(src, overwrite=True)
    if previous is not None:
        changes.append(f"the previous profile is kept as {previous.name}")
    return AddedSessions(profile=profile, path=src, previous=previous, changes=changes)


def _add_vibration_sessions(profile: Profile, flights: Sequence[Flight]) -> list[str]:
    """Every added flight (a session or a load configuration alike) becomes a session of the
    profile's vibration baseline at its rotor speed (:func:`~flightlog_fd.analyzers.vibration.add_sessions`:
    a payload turns the rotors faster and shakes more, and diagnose compares at matching speed).
    Returns what changed, in plain words."""
    from .analyzers.vibration import ANALYZER_ID, add_sessions as add_vibration
    from .flights import split_flights

    old = profile.analyzers.get(ANALYZER_ID)
    new = add_vibration(old, [part for fl in flights for part in split_flights(fl)])
    if new is None or new == old:
        return []
    profile.analyzers = {**profile.analyzers, ANALYZER_ID: new}
    n = len(new.get("sessions") or [])
    return [f"vibration: {n} session{'s' if n != 1 else ''} of the healthy level at its rotor speed "
            f"(level {new['level']:.2f}, {new.get('source', '')})"]


def _target_configuration(profile: Profile, fl: Flight, d, name: Optional[str]) -> str:
    """The configuration a flight added to ``profile`` belongs to (:func:`add_sessions`), from its
    diagnosis ``d`` against the profile; ProfileError for a flight whose commands fit a weak rotor
    rather than a load, when it would start or join a load configuration."""
    v = d.verdict
    nearest = ((getattr(d.share_fit, "configuration", None) or {}).get("name") if d.share_fit is not None
               else None) or AS_CALIBRATED
    if name is not None:
        target = name
    elif v.cause == "load" and v.load:
        target = _load_name(v.load)
    else:
        return nearest
    if target != AS_CALIBRATED and v.status == "uncertain" and v.cause != "load" and v.motor and not _load_like(d):
        raise ProfileError(fl.path, f"its commands fit motor {v.motor} losing thrust as well as a load (uncertain, "
                                    f"confidence {v.confidence:.2f}): not added as a load configuration, the profile "
                                    f"is unchanged; inspect propeller {v.motor} and fly once without the payload")
    return target


def _load_name(load: dict) -> str:
    """A configuration's name from its load, e.g. "load toward motor 1 +22 %"."""
    return f"load toward motor {int(load['motor'])} {100 * float(load['size']):+.0f} %"[:MAX_CONFIGURATION_NAME]


def _configuration_load(profile: Profile, share: Sequence[float], frame) -> dict:
    """The load that moves the profile's AS_CALIBRATED shares to a configuration's ``share``
    (:func:`~flightlog_fd.analyzers.command_shares.load_fit` at the one-flight drift), as stored."""
    from .analyzers.command_shares import DEFAULT_DRIFT_SIGMA, load_fit

    n = profile.rotor_count
    fit = load_fit(np.asarray(share, float), np.asarray(profile.baseline_["share"], float),
                   np.full(n, DEFAULT_DRIFT_SIGMA), frame)
    return {k: v for k, v in fit.as_dict().items() if k != "llr"}


def _add_configurations(profile: Profile, configured: Sequence[tuple[Flight, str]], one_session: bool,
                        model) -> list[str]:
    """Add each (flight, configuration name) to ``profile.configurations_``: a new configuration's
    command-share baseline is its flights' own (:func:`estimate_baseline`, :func:`baseline_of_sessions`),
    and so is its model-vote baseline (its sessions' means with the profile's ``model``, weighed with
    the AS_CALIBRATED sessions' spread: the model reads a load as a trim, the trim is the
    configuration's); an existing one gains sessions. Returns what changed, in plain words."""
    from .analyzers.model_votes import ModelVotes, combine_sessions

    votes = profile.analyzers.get("model")
    sha = str(getattr(model, "sha256", ""))
    lines = []
    for target in dict.fromkeys(t for _, t in configured):
        fls = [fl for fl, t in configured if t == target]
        groups = [fls] if one_session else [[fl] for fl in fls]
        entries = [session_entry(g) for g in groups]
        cfg = profile.configuration(target)
        if cfg is None:
            base = baseline_of_sessions(estimate_baseline(fls), entries)
            load = _configuration_load(profile, base["share"], fls[0].frame)
            cfg = {"name": target, "load": load, "created": entries[0]["created"], "sessions_": entries,
                   "baseline_": base}
            profile.configurations_ = list(profile.configurations_) + [cfg]
            what = "added load configuration"
        else:
            cfg["sessions_"] = list(cfg["sessions_"]) + entries
            cfg["baseline_"] = baseline_of_sessions(cfg["baseline_"], cfg["sessions_"])
            cfg["load"] = _configuration_load(profile, cfg["baseline_"]["share"], fls[0].frame)
            what = f"added {len(entries)} session{'s' if len(entries) != 1 else ''} to load configuration"
        if votes and votes.get("model_sha256") == sha:
            own = (cfg.get("analyzers") or {}).get("model")
            earlier = [{"model_sha256": sha, "healthy_mean": m} for m in ((own or {}).get("sessions") or [])]
            combined = combine_sessions(earlier + [ModelVotes().fit_baseline(g, model) for g in groups])
            if combined is not None:
                cfg["analyzers"] = {"model": {**combined, "spread": votes.get("spread"),
                                              "n_flights": int(votes.get("n_flights", 1))}}
        profile.source_logs = list(profile.source_logs) + [e for s in entries for e in s["logs"]]
        ld = cfg["load"]
        lines.append(f"{what} '{target}': {', '.join(e['name'] for s in entries for e in s['logs'])} "
                     f"(load toward motor {ld['motor']}, {100 * ld['size']:+.0f} % of its share; throttle "
                     f"{cfg['baseline_']['throttle_ref']:.3f}); its own command-share baseline: "
                     + ", ".join(f"motor {k + 1} {x:.3f}" for k, x in enumerate(cfg["baseline_"]["share"])))
    if lines:
        lines.append(f"the profile now holds {len(profile.configuration_names())} configurations "
                     f"({', '.join(repr(x) for x in profile.configuration_names())}); diagnose compares each "
                     f"flight with the nearest; the {AS_CALIBRATED!r} sessions and their drift are unchanged")
    return lines


def _implicit_session(profile: Profile) -> dict:
    """The one session of a profile older than schema 6: its pooled baseline and logs."""
    b = profile.baseline_
    return {"logs": list(profile.source_logs), "created": profile.created, "seconds": float(b.get("seconds", 0.0)),
            "share": [float(x) for x in b["share"]], "throttle": float(b["throttle_ref"]),
            "pin": None if b.get("pin") is None else [float(x) for x in b["pin"]]}


def _keep_previous(src: Path, n_sessions: int) -> Path:
    """Copy the profile file as it is to ``<stem>.sessions-<N>.json`` beside it (a free name: never
    replaces a file), so the profile before the change stays recoverable."""
    import shutil

    for k in range(1, 1000):
        dst = src.with_name(f"{src.stem}.sessions-{n_sessions}{'' if k == 1 else f'-{k}'}.json")
        if not dst.exists():
            try:
                shutil.copy2(src, dst)
            except OSError as e:
                raise ProfileError(dst, f"cannot keep the previous profile: {e.strerror or e}") from None
            return dst
    raise ProfileError(src, "cannot find a free name to keep the previous profile")


def _session_changes(old: dict, new: dict, added: list[dict], votes_old: Optional[dict], votes_new: Optional[dict],
                     sessions: Sequence[dict], n_before: int) -> list[str]:
    """What adding sessions changed, in plain words."""
    n_after = len(sessions)
    lines = [f"added session {n_before + i + 1}: {', '.join(e['name'] for e in s['logs'])} ({s['seconds']:.0f} s "
             f"airborne, throttle {s['throttle']:.3f})" for i, s in enumerate(added)]
    lines.append(f"the profile now holds {n_after} calibration sessions (was {n_before})")
    lines.append("command-share baseline: " + ", ".join(
        f"motor {k + 1} {a:.3f} -> {b:.3f}" for k, (a, b) in enumerate(zip(old["share"], new["share"])))
        + f"; throttle {old['throttle_ref']:.3f} -> {new['throttle_ref']:.3f}")
    lines.append(session_drift_words(sessions))
    if votes_old and votes_new and votes_new is not votes_old:
        lines.append("model-vote baseline (mean log ratio per motor): " + ", ".join(
            f"motor {k + 1} {a:+.2f} -> {b:+.2f}" for k, (a, b) in
            enumerate(zip(votes_old["healthy_mean"], votes_new["healthy_mean"]))))
    elif votes_old:
        lines.append("model-vote baseline kept: it was measured with another model than the profile's")
    lines.append("kept from the earlier sessions: the imbalance (rho), the window statistics, the model and the "
                 "other analyzers' baselines")
    return lines


def session_drift_words(sessions: Sequence[dict]) -> str:
    """How far the airframe's sessions move, in plain words (two or more sessions)."""
    from .analyzers.command_shares import DEFAULT_DRIFT_SIGMA, THROTTLE_DRIFT_SIGMA
    from .analyzers.session_drift import SessionDrift, SessionFigures

    if len(sessions) < 2:
        return "one session cannot show how the airframe's trim moves between sessions"
    n = len(sessions[0]["share"])
    figs = SessionFigures(shares=[s["share"] for s in sessions], throttles=[s["throttle"] for s in sessions],
                          pins=[s["pin"] if s.get("pin") is not None else [float("nan")] * n for s in sessions])
    drift = SessionDrift.fit(figs, DEFAULT_DRIFT_SIGMA, THROTTLE_DRIFT_SIGMA)
    tau = drift.tau_median()
    return (f"session-to-session drift of this airframe: {tau * DEFAULT_DRIFT_SIGMA:.3f} share per motor and "
            f"{100 * tau * THROTTLE_DRIFT_SIGMA:.1f} % throttle ({tau:.2f} x the population drift, from "
            f"{len(sessions)} sessions)")
