"""The diagnose pipeline: a Flight (or a log path) and a model -> a :class:`Diagnosis`.

Steps (pure: nothing is printed, nothing imports torch):

0. Did a motor stop in the air? (:func:`flightlog_fd.stopped.diagnose_stopped`, any frame: a
   "motor k stopped" finding outranks every propeller verdict, and is given even where no
   damage model exists for the frame.)
1. Is the log diagnosable? (:func:`flightlog_fd.checks.diagnosability` with the model's feature
   spec: a placed frame the model is for, its motor outputs, fast enough rates, enough airborne time.)
2. Is the calibration profile, if any, made for this airframe? (``profile.check_compatible``.)
3. Windows with the model's own feature spec (:func:`flightlog_fd.windows.make_windows`),
   standardised with the model's statistics, then class probabilities from the ONNX model.
4. A flight phase per window (:mod:`flightlog_fd.phases`) and the model's timeline: smoothed
   labels and a confirmed mid-flight damage onset (:mod:`flightlog_fd.timeline`).
5. The share fit (:mod:`flightlog_fd.analyzers.share_fit`: command shares against the
   profile's baseline, the flight before an onset or an even split;
   :mod:`flightlog_fd.analyzers.effectiveness_fit`) from
   the same resampled segments as the windows, and every registered analyzer's findings
   (:mod:`flightlog_fd.analyzers`).
6. The verdict, from :func:`flightlog_fd.decision.decide_flight` alone, called once per flight
   with its :class:`~flightlog_fd.decision.DecisionInputs` (stopped motors, the reason a flight
   cannot be judged, the timeline, the analyzers' results, the profile configuration's words and,
   for one flight of several, the whole log's verdict it is capped by); a log of several flights
   gets its verdict from :func:`flightlog_fd.decision.decide_log`.

Anything wrong with the input (a :class:`~flightlog_fd.errors.FlightLogError`) becomes a
``not_diagnosable`` Diagnosis with the one-line reason and exit code 2, so a batch of logs
never stops on one bad file. Exit codes: 0 healthy, 1 damaged, stopped or uncertain, 2 not
diagnosable or invalid input.

Limits: windows come from airborne time only (streams.py decides); a model whose class list
is not healthy + the flight's motors is refused (:class:`~flightlog_fd.errors.ModelError`).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Optional

import numpy as np

from .advice import advise, situation
from .analyzers import REGISTRY, Context, run_analyzers
from .analyzers.effectiveness_fit import estimate_effectiveness
from .analyzers.reliability import log_kind
from .analyzers.command_shares import nearest_configuration
from .analyzers.share_fit import fit_shares
from .checks import diagnosability
from .analyzers.vibration import LOG_REFERENCE_KEY, log_reference, vibration_can_judge
from .decision import PRIOR_DAMAGE, Decision, DecisionInputs, Verdict, decide_flight, decide_log, worst_flight
from .errors import FlightLogError, ModelError
from .flight import Flight
from .flights import split_flights
from .phases import window_phases
from .prepared import PreparedFlight
from .stopped import diagnose_stopped
from .timeline import Timeline, build as build_timeline, covered_seconds
from .util import blas_threads
from .windows import FeatureSpec, make_windows

EXIT_HEALTHY = 0
EXIT_DAMAGED_OR_UNCERTAIN = 1
EXIT_NOT_DIAGNOSABLE = 2

NO_PROFILE_WARNING = ("no calibration profile: using the shipped model; a profile made with "
                      "`fdlog calibrate` on a healthy flight of this airframe is more accurate")
#: The same advice when the user chose a model file of their own.
NO_PROFILE_OWN_MODEL_WARNING = ("no calibration profile: a profile made with `fdlog calibrate` on a "
                                "healthy flight of this airframe makes the diagnosis more accurate")
#: If more than this share of windows are manoeuvres, say so: the model is most reliable in
#: steady flight, and a verdict resting on manoeuvres deserves a second look.
MANOEUVRE_WARNING_SHARE = 0.5
#: BLAS threads while diagnosing one flight. Its matrices are tall and thin (30 000 x 4-24 for a
#: 600 s flight), where a second thread gains little and, on a busy machine, waits for the core
#: another process holds: the 600 s benchmark logs (benchmarks/bench_diagnose.py) took 146 / 185 ms
#: (ULog / DataFlash) with one thread against 187 / 224 ms with two, best of 6 in one run on the
#: shared 2-core box (2026-11-24, one core busy elsewhere). Parallel work comes from diagnosing logs in
#: separate processes (batch, serve), as for onnxruntime (model.INTRA_OP_THREADS).
DIAGNOSE_BLAS_THREADS = 1


@dataclass
class FlightFacts:
    """What the report says about the log itself (times in seconds on the log's clock)."""

    path: Optional[str]
    autopilot: str
    firmware: str
    vehicle_type: str
    frame: Optional[str]
    frame_source: str
    duration_s: float
    airborne_s: float
    t_start: float
    t_end: float
    airborne: list[tuple[float, float]] = field(default_factory=list)

    @staticmethod
    def from_flight(flight: Flight) -> "FlightFacts":
        return FlightFacts(
            path=flight.path, autopilot=flight.autopilot, firmware=flight.firmware or "",
            vehicle_type=flight.vehicle_type, frame=flight.frame.name if flight.frame else None,
            frame_source=flight.frame.source if flight.frame else "",
            duration_s=flight.duration_s, airborne_s=flight.airborne_s,
            t_start=flight.t_start, t_end=flight.t_end,
            airborne=[(float(a), float(b)) for a, b in flight.airborne])


@dataclass
class ModelInfo:
    """Which model judged the flight; ``calibrated`` when it is the profile's own model."""

    path: Optional[str]
    version: str
    sha256: str
    classes: list[str]
    calibrated: bool


@dataclass
class ProfileInfo:
    """Which calibration profile was used (None in the Diagnosis when there was none)."""

    path: Optional[str]
    model_path: Optional[str]
    model_sha256: Optional[str]
    sessions: int = 1  # calibration sessions the profile holds


@dataclass
class WindowResult:
    """One window: its bounds (s), the model's class (argmax), probabilities, phase, and the
    smoothed label the verdict used (-1 uncertain, 0 healthy, k motor k)."""

    t_start: float
    t_end: float
    cls: int
    probabilities: list[float]
    phase: str
    label: int


@dataclass
class Diagnosis:
    """Everything a report needs about one log. ``flight`` is kept for plots (never serialised)."""

    log: str
    verdict: Verdict
    facts: Optional[FlightFacts] = None
    model: Optional[ModelInfo] = None
    profile: Optional[ProfileInfo] = None
    windows: list[WindowResult] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    diagnosability_facts: dict = field(default_factory=dict)
    flight: Optional[Flight] = field(default=None, repr=False)
    #: The per-motor share fit (:class:`flightlog_fd.analyzers.share_fit.ShareFit`); None when not diagnosable.
    share_fit: Any = None
    #: Why the analyzers' evidence gave its verdict (per-motor severity, LLR by source, weight); None when it
    #: was not weighed.
    decision: Optional[Decision] = None
    #: The model's windows over time (smoothed labels, onset); None when no window was judged.
    timeline: Optional[Timeline] = None
    #: "motor k stopped" findings (:class:`flightlog_fd.stopped.StoppedMotor`), on any frame.
    stopped: list = field(default_factory=list)
    #: Which flight of the log this is ("flight 2 of 2, 376.8-464.9 s"), "" for a log's only one.
    part: str = ""
    #: Each take-off to landing of a log holding several, diagnosed on its own (the log's verdict
    #: is the worst of theirs); [] for a log with one flight.
    flights: list = field(default_factory=list)
    #: What kind of log the sources were weighed for (:class:`flightlog_fd.analyzers.reliability.LogKind`);
    #: None when the analyzers did not run.
    log_kind: Any = None

    @property
    def motors(self) -> list:
        """Per-motor figures (:class:`flightlog_fd.analyzers.share_fit.MotorShares`), [] without a share fit."""
        return list(self.share_fit.motors) if self.share_fit is not None else []

    @property
    def exit_code(self) -> int:
        status = self.verdict.status
        if status == "healthy":
            return EXIT_HEALTHY
        if status in ("damaged", "uncertain", "stopped"):
            return EXIT_DAMAGED_OR_UNCERTAIN
        return EXIT_NOT_DIAGNOSABLE


def _profile_file(profile: Any) -> Optional[Path]:
    p = getattr(profile, "path", None)
    return Path(p) if p else None


def profile_info(profile: Any) -> Optional[ProfileInfo]:
    """The profile's path and the model it names (path resolved against the profile's folder)."""
    if profile is None:
        return None
    pfile = _profile_file(profile)
    ref = getattr(profile, "model", None) or {}
    model_path = ref.get("path")
    if model_path and pfile is not None and not Path(model_path).is_absolute():
        model_path = str(pfile.parent / model_path)
    return ProfileInfo(path=str(pfile) if pfile else None, model_path=model_path,
                       model_sha256=ref.get("sha256"), sessions=int(getattr(profile, "n_sessions", 1) or 1))


def model_info(model: Any, profile: Any = None) -> ModelInfo:
    """Describe ``model``; it is "calibrated" when the profile names a model with its sha256."""
    info = profile_info(profile)
    sha = str(getattr(model, "sha256", "") or "")
    calibrated = bool(info and info.model_sha256 and sha and info.model_sha256 == sha)
    path = getattr(model, "path", None)
    return ModelInfo(path=str(path) if path else None, version=str(getattr(model, "version", "") or ""),
                     sha256=sha, classes=[str(c) for c in getattr(model, "classes", [])], calibrated=calibrated)


def resolve_model(model_path=None, profile: Any = None, rotor_count: int = 4):
    """The model to use: an explicit ``--model`` path, else the profile's model, else the shipped one
    for ``rotor_count`` rotors (diagnose_flight swaps the shipped quad model for the shipped model of
    the flight's own rotor count, :func:`flightlog_fd.model.model_for_flight`).

    A profile's model path is relative to the profile file; a file whose sha256 differs from the
    one the profile recorded is refused (ProfileError: the profile was calibrated for another model).
    """
    from .model import FaultModel, default_model_path, shipped_model_path

    if model_path is not None:
        return FaultModel(model_path)
    if profile is not None and getattr(profile, "model", None):
        # Profile.model_path() resolves against the profile's folder and raises ProfileError
        # when the file is missing or its sha256 differs from the one recorded at calibration.
        return FaultModel(profile.model_path(verify=True))
    path = shipped_model_path(rotor_count) if rotor_count != 4 else None
    if rotor_count != 4 and path is None:
        raise ModelError(None, f"no shipped model for {rotor_count} rotors")
    return FaultModel(path or default_model_path())


def is_shipped_model(model: Any) -> bool:
    """True when ``model`` is a file shipped with the package, for any rotor count."""
    from .model import shipped_model_paths

    path = getattr(model, "path", None)
    return bool(path) and Path(path).resolve() in [p.resolve() for p in shipped_model_paths()]


def _check_model_classes(model: Any, n_motors: int) -> None:
    classes = list(getattr(model, "classes", []))
    if classes and len(classes) != n_motors + 1:
        raise ModelError(getattr(model, "path", None),
                         f"model has {len(classes)} classes, this {n_motors}-rotor flight needs {n_motors + 1} "
                         f"(healthy + {n_motors} motors)")


def diagnose_flight(flight: Flight, model: Any, profile: Any = None, *, keep_flight: bool = True,
                    prior: Optional[float] = None) -> Diagnosis:
    """Diagnose one loaded flight with ``model`` (a FaultModel or any object with the same
    ``feature_spec``, ``standardise`` and ``predict_proba``) and an optional calibration profile.

    ``keep_flight=False`` leaves ``Diagnosis.flight`` empty (no plots, but a small object to
    send back from a worker process when many logs are diagnosed in parallel).
    Runs with at most ``DIAGNOSE_BLAS_THREADS`` BLAS threads."""
    with blas_threads(DIAGNOSE_BLAS_THREADS):
        d = _diagnose_flight(flight, model, profile, keep_flight=keep_flight, prior=prior_damage(profile, prior))
    for x in [d, *d.flights]:  # what would resolve each verdict (the flight's streams decide the settings)
        x.verdict.advice = advise(situation(x, flight))
    return d


#: A log with motor outputs holding several flights is judged once as a whole (its verdict is the
#: log's), and each flight gets its own verdict from the same windows with the whole log as its
#: context: no mid-flight onset is searched inside a flight (its own first minutes are no healthy
#: reference: judged alone, real healthy Erle 09-10-2014_31 flight 2 of 5 became "damaged, motor 2",
#: model +5.0, commands +2.3 nats against its first 30 s); only the whole log's onset, when it lies
#: in that flight, splits its shares. A flight too short to judge alone (CrazyPAD's 8.6 s first hop:
#: 7 windows) is reported as such and judged with the log. A flight is never worse than the whole
#: log (decision.capped_by_log): uncapped, Erle 09-10-2014_31 flight 2 stays "damaged, motor 2" (model
#: +5.0, commands +1.0 nats on its 77 windows) and Erle 6-3-2014_6 flight 2 "uncertain" (commands
#: +8.0) on real healthy logs whose whole verdicts are healthy (benchmarks/bench_several_flights.py).
SEVERAL_FLIGHTS_NOTE = "each flight judged with the whole log as its context"


def _diagnose_flight(flight: Flight, model: Any, profile: Any, *, keep_flight: bool, prior: float) -> Diagnosis:
    """A log holding several take-offs to landings (:func:`flightlog_fd.flights.split_flights`):
    each flight gets its own Diagnosis (``Diagnosis.flights``). A log with what the full diagnosis
    needs is judged as one and each flight from the same windows (``SEVERAL_FLIGHTS_NOTE``; the
    log keeps the whole log's verdict and no flight is worse than it, see :func:`_per_flight`); a log judged from
    vibration alone (no motor outputs) has each flight judged on its own, the log's verdict being
    its worst flight's."""
    from .model import model_for_flight

    parts = split_flights(flight)
    if len(parts) == 1:
        return _diagnose_one(flight, model, profile, keep_flight=keep_flight, prior=prior)
    spec = model_for_flight(model, flight).feature_spec
    prepared = PreparedFlight(flight)  # the check's segments are the diagnosis's
    if diagnosability(prepared, spec).ok:
        return _diagnose_one(flight, model, profile, keep_flight=keep_flight, parts=parts, prepared=prepared,
                             prior=prior)
    # judged each on its own from vibration: without a profile, each against the log's quietest other flight too
    refs = [None] * len(parts) if profile is not None else [log_reference(parts, i) for i in range(len(parts))]
    subs = [_diagnose_one(p, model, profile, keep_flight=keep_flight, prior=prior,
                          vibration_reference=None if r is None else r.to_dict()) for p, r in zip(parts, refs)]
    for p, d in zip(parts, subs):
        d.part = p.part
    w = subs[worst_flight([d.verdict for d in subs])]
    verdict = decide_log([(d.part, d.verdict) for d in subs])
    return replace(w, verdict=verdict, facts=FlightFacts.from_flight(flight), part="", flights=subs,
                   flight=flight if keep_flight else None, warnings=list(flight.warnings) + [
                       x for d in subs for x in d.warnings if x not in flight.warnings])


def _diagnose_one(flight: Flight, model: Any, profile: Any, *, keep_flight: bool,
                  parts: Optional[list] = None, prepared: Optional[PreparedFlight] = None,
                  prior: float = PRIOR_DAMAGE, vibration_reference: Optional[dict] = None) -> Diagnosis:
    from .model import model_for_flight

    model = model_for_flight(model, flight)  # the shipped quad model -> the one for the flight's rotor count
    log = str(flight.path) if flight.path else "<flight>"
    facts = FlightFacts.from_flight(flight)
    warnings = list(flight.warnings)
    common = dict(facts=facts, model=model_info(model, profile), profile=profile_info(profile),
                  warnings=warnings, flight=flight if keep_flight else None)

    stops = diagnose_stopped(flight)
    n_motors = flight.frame.rotor_count if flight.frame is not None else 4
    # built once: the check, the windows, phases and share fit use it
    prepared = prepared if prepared is not None else PreparedFlight(flight)
    check = diagnosability(prepared, model.feature_spec)
    facts_kw = dict(stopped=stops, diagnosability_facts=dict(check.facts), **common)

    def cannot_judge(reason: str) -> Diagnosis:
        verdict, _ = decide_flight(DecisionInputs(n_motors, flight.frame, stopped=stops,
                                                  not_diagnosable_reason=reason, prior=prior))
        return Diagnosis(log=log, verdict=verdict, **facts_kw)

    if not check.ok:
        reason = check.reason
        if flight.frame is not None and flight.frame.rotor_count > 4 and not flight.frame.unplaced:
            reason += "; no motor stopped while airborne"
        if flight.vibration is not None and flight.airborne and vibration_can_judge(check.reasons):
            return _vibration_only(flight, profile, n_motors, reason, log, facts_kw, keep_flight, prior,
                                   vibration_reference)
        return cannot_judge(reason)
    if profile is None:  # only worth saying when a verdict follows
        warnings.append(NO_PROFILE_WARNING if is_shipped_model(model) else NO_PROFILE_OWN_MODEL_WARNING)
    try:
        _check_model_classes(model, n_motors)
        if profile is not None:
            # Raises ProfileError for another airframe; returns softer mismatches (vehicle id, firmware).
            warnings.extend(profile.check_compatible(flight) or [])
        try:
            spec = FeatureSpec.from_dict(model.feature_spec)
        except ValueError as e:
            raise ModelError(getattr(model, "path", None), f"bad feature spec in the model: {e}") from None
        win = make_windows(prepared, spec)
        if len(win.t_start) == 0:
            return cannot_judge(win.reason or "no complete window of airborne data")
        # The model (onnxruntime, which releases the GIL) runs beside the effectiveness fit, which
        # does not need its answer: on two free cores the two take the time of the longer one.
        with ThreadPoolExecutor(max_workers=1) as pool:
            model_run = pool.submit(lambda: model.predict_proba(model.standardise(win.X)))
            try:
                eff = estimate_effectiveness(prepared, rate_hz=spec.rate_hz, savgol_window_s=spec.savgol_window_s,
                                             segments=win.segments)
            finally:
                probs = np.asarray(model_run.result(), dtype=np.float64)
    except FlightLogError as e:
        return cannot_judge(e.message)

    t_start = np.asarray(win.t_start, dtype=np.float64)
    t_end = np.asarray(win.t_end, dtype=np.float64)
    phases = window_phases(prepared, t_start, t_end)
    timeline = build_timeline(t_start, t_end, probs)
    onset = timeline.onset
    share_fit = _share_fit(win.segments, probs, flight.frame, eff, profile, onset.t_start if onset else None)
    results = []
    kind = None
    if timeline.shortfall is None:
        ctx = _analyzer_context(flight, t_start, t_end, probs, onset, share_fit, profile, win.segments,
                                str(getattr(model, "sha256", "") or ""))
        results = run_analyzers(ctx)
        kind = log_kind(flight, phases, ctx.covered_s, profile, common["model"].calibrated, probs.shape[1] - 1)
    verdict, decision = decide_flight(DecisionInputs(
        probs.shape[1] - 1, flight.frame, timeline=timeline, results=results, stopped=stops, kind=kind,
        configuration_words=_configuration_words(share_fit), prior=prior))
    order = np.argsort(t_start, kind="stable")
    # one conversion to Python numbers per array (not per window: 740 windows of a 600 s flight)
    starts, ends, probs_l = t_start[order].tolist(), t_end[order].tolist(), probs[order].tolist()
    classes, labels = np.argmax(probs, axis=1)[order].tolist(), np.asarray(timeline.labels)[order].tolist()
    windows = [WindowResult(starts[j], ends[j], int(classes[j]), probs_l[j], phases[i], int(labels[j]))
               for j, i in enumerate(order.tolist())]
    manoeuvre_share = sum(ph == "manoeuvre" for ph in phases) / len(phases)
    if manoeuvre_share > MANOEUVRE_WARNING_SHARE:
        warnings.append(f"{100 * manoeuvre_share:.0f} % of windows are manoeuvres: the model is most "
                        f"reliable in steady flight, so treat this verdict with care")
    whole = Diagnosis(log=log, verdict=verdict, windows=windows, share_fit=share_fit, decision=decision,
                      timeline=timeline, log_kind=kind, **facts_kw)
    if parts:
        whole = _per_flight(whole, parts, prepared, win, probs, timeline, profile, model, keep_flight, prior)
    return whole


def _share_fit(segments, probs: np.ndarray, frame: Any, eff: Any, profile: Any, since: Optional[float]) -> Any:
    """The flight's share fit against the profile's nearest load configuration
    (:func:`~flightlog_fd.analyzers.command_shares.nearest_configuration`), or without a profile."""
    return nearest_configuration(profile, lambda b: fit_shares(segments, probs, frame, eff, b, since=since),
                                 frame)[0]


def _configuration_words(share_fit: Any) -> Optional[str]:
    """The profile's load configuration the commands were weighed against, in words (a profile of
    two or more configurations), else None."""
    return share_fit.configuration_words() if share_fit is not None else None


def _per_flight(whole: Diagnosis, parts: list, prepared: PreparedFlight, win: Any, probs: np.ndarray,
                timeline: Timeline, profile: Any, model: Any, keep_flight: bool, prior: float) -> Diagnosis:
    """Each flight of a log with motor outputs judged from the whole log's windows
    (``SEVERAL_FLIGHTS_NOTE``): its windows, its segments' command shares (split only at the whole
    log's onset when it lies in this flight), the analyzers on this flight; each flight's verdict no
    worse than the whole log's (:func:`flightlog_fd.decision.capped_by_log`, behind
    ``decide_flight``). The log keeps the whole log's verdict, its
    reason listing the flights'."""
    t_start = np.asarray(win.t_start, dtype=np.float64)
    t_end = np.asarray(win.t_end, dtype=np.float64)
    onset = timeline.onset
    sha = str(getattr(model, "sha256", "") or "")
    subs = []
    for part in parts:
        a, b = part.t_start, part.t_end
        m = (t_start >= a - 1e-6) & (t_end <= b + 1e-6)
        segs = [s for s in win.segments if len(s.t) and s.t[0] >= a - 1e-6 and s.t[-1] <= b + 1e-6]
        stops = [s for s in whole.stopped if a <= s.t_start <= b]
        facts_kw = dict(facts=FlightFacts.from_flight(part), model=whole.model, profile=whole.profile,
                        warnings=[], flight=part if keep_flight else None, stopped=stops,
                        diagnosability_facts=dict(whole.diagnosability_facts))
        tl = build_timeline(t_start[m], t_end[m], probs[m])
        if tl.shortfall is not None:
            reason = f"too short to judge alone ({tl.shortfall}): judged with the whole log"
            v, _ = decide_flight(DecisionInputs(probs.shape[1] - 1, part.frame, stopped=stops,
                                                not_diagnosable_reason=reason, log=(whole.verdict, whole.decision),
                                                prior=prior))
            subs.append(Diagnosis(log=whole.log, verdict=v, timeline=tl, part=part.part, **facts_kw))
            continue
        here = onset if (onset is not None and a <= onset.t_start <= b) else None
        if here is None and tl.onset is not None:  # no onset searched inside one flight
            tl.run = replace(tl.run, confirmed=False)
        spec = FeatureSpec.from_dict(model.feature_spec)
        eff = estimate_effectiveness(prepared, rate_hz=spec.rate_hz, savgol_window_s=spec.savgol_window_s,
                                     segments=segs)
        ev = _share_fit(segs, probs[m], part.frame, eff, profile, here.t_start if here else None)
        pm = probs[m]
        ctx = _analyzer_context(part, t_start[m], t_end[m], pm, here, ev, profile, segs, sha)
        kind = replace(whole.log_kind, covered_s=ctx.covered_s) if whole.log_kind is not None else None
        v, dec = decide_flight(DecisionInputs(
            pm.shape[1] - 1, part.frame, timeline=tl, results=run_analyzers(ctx), stopped=stops, kind=kind,
            configuration_words=_configuration_words(ev), log=(whole.verdict, whole.decision), prior=prior))
        sub_windows = [w for w in whole.windows if a - 1e-6 <= w.t_start and w.t_end <= b + 1e-6]
        subs.append(Diagnosis(log=whole.log, verdict=v, windows=sub_windows, share_fit=ev, decision=dec,
                              timeline=tl, part=part.part, log_kind=kind, **facts_kw))
    listing = ", ".join(p.part.split(", ", 1)[1] for p in parts)
    whole.warnings.append(f"this log holds {len(parts)} flights ({listing}): {SEVERAL_FLIGHTS_NOTE}")
    whole.flights = subs
    whole.verdict = decide_log([(d.part.split(',')[0], d.verdict) for d in subs], whole=whole.verdict)
    return whole


def _vibration_only(flight: Flight, profile: Any, n_motors: int, reason: str, log: str, facts_kw: dict,
                    keep_flight: bool, prior: float, vibration_reference: Optional[dict] = None) -> Diagnosis:
    """A flight the full diagnosis cannot take (no motor outputs, no damage model), judged by
    :func:`~flightlog_fd.decision.decide_flight` from the analyzers that need no motor outputs
    (vibration); ``vibration_reference``: one of several flights of a log without a profile, the
    log's quietest other flight (:func:`~flightlog_fd.analyzers.vibration.log_reference`)."""
    if profile is not None:
        try:  # another airframe's baseline would judge nothing; softer mismatches are warnings
            facts_kw["warnings"].extend(profile.check_compatible(flight) or [])
        except FlightLogError as e:
            verdict, _ = decide_flight(DecisionInputs(n_motors, flight.frame, stopped=facts_kw["stopped"],
                                                      not_diagnosable_reason=e.message, prior=prior))
            return Diagnosis(log=log, verdict=verdict, **facts_kw)
    ctx = Context(flight=flight, frame=flight.frame, n_motors=n_motors, probs=np.zeros((0, n_motors + 1)),
                  covered_s=0.0, profile=profile,
                  memo={LOG_REFERENCE_KEY: vibration_reference} if vibration_reference else {})
    results = run_analyzers(ctx, [a for a in REGISTRY if not a.needs_motor_outputs])
    verdict, decision = decide_flight(DecisionInputs(n_motors, flight.frame, results=results,
                                                     stopped=facts_kw["stopped"], not_diagnosable_reason=reason,
                                                     prior=prior))
    return Diagnosis(log=log, verdict=verdict, decision=decision, part=flight.part, **facts_kw)


def _analyzer_context(flight: Flight, t_start: np.ndarray, t_end: np.ndarray, probs: np.ndarray, onset: Any,
                      share_fit: Any, profile: Any, segments, model_sha256: str) -> Context:
    """What the analyzers read (one flight, or one flight of a log with the whole log's onset when it
    lies in it). After a mid-flight onset the model's votes are weighed from the
    onset on (the windows before it are the healthy airframe, and the shares are taken against
    them), unless the commands show a drift: the onset run is the stretch the model itself picked
    as most damaged, so without a step in the commands its votes alone would count the selection
    as evidence (real healthy Erle 11-2-2015_112 was called damaged that way)."""
    order = np.argsort(t_start, kind="stable")
    if onset is not None and share_fit.drifting() is None:
        order = order[int(np.searchsorted(t_start[order], onset.t_start)):]
    return Context(flight=flight, frame=flight.frame, n_motors=probs.shape[1] - 1, probs=probs[order],
                   covered_s=covered_seconds(t_start[order], t_end[order]), segments=segments, share_fit=share_fit,
                   profile=profile, model_sha256=model_sha256)


def prior_damage(profile: Any = None, prior: Optional[float] = None) -> float:
    """The prior of damage a diagnosis decides under: ``prior`` (``fdlog diagnose --prior-damage``),
    else the profile's own (a fleet's, ``fdlog calibrate --prior-damage``), else
    :data:`~flightlog_fd.decision.PRIOR_DAMAGE`."""
    if prior is not None:
        return float(prior)
    own = getattr(profile, "prior_damage", None) if profile is not None else None
    return float(own) if own is not None else PRIOR_DAMAGE


def diagnose_path(path, model: Any, profile: Any = None, *, keep_flight: bool = True,
                  prior: Optional[float] = None) -> Diagnosis:
    """Load ``path`` and diagnose it; a bad file gives a not_diagnosable Diagnosis (exit 2)."""
    from . import load_flight

    try:
        flight = load_flight(path)
    except FlightLogError as e:
        return Diagnosis(log=str(path), verdict=decide_flight(DecisionInputs(0, not_diagnosable_reason=e.message))[0])
    return diagnose_flight(flight, model, profile, keep_flight=keep_flight, prior=prior)
