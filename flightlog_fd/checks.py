"""Can this log be diagnosed? One plain verdict with the reasons when not.

Inputs: a :class:`~flightlog_fd.flight.Flight` and optionally the model's feature spec (its rate
and window length decide how much airborne time is needed).

Rules (each failing rule adds one reason, in the order a pilot would fix them):
- the vehicle is a quadrotor with a known 4-rotor layout, or an n-rotor frame laid out like one
  the n-rotor model was trained on (:data:`TRAINED_LAYOUTS`) when a model for its rotor count
  exists (the spec's ``n_motors``; without a spec, a shipped model). Fixed-wing and VTOL are
  named; another n-rotor frame is told that only stopped-motor detection
  (:func:`flightlog_fd.stopped.diagnose_stopped`) is available; a frame whose rotors cannot be
  placed gets the reason from :mod:`flightlog_fd.frames`;
- per-motor commands for every motor and body angular rates are present;
- the rate streams are fast enough: angular rates >= ``MIN_RATES_HZ`` (the angular acceleration is a
  derivative of them), motor commands >= ``MIN_MOTORS_HZ`` (PX4's default 10 Hz logging passes);
- the log has at least ``MIN_AIRBORNE_S`` of airborne time and enough for ``MIN_WINDOWS`` windows;
- its airborne stretches between data gaps (:mod:`flightlog_fd.streams`, the very segments the
  diagnosis cuts its windows from) hold a window and enough windows to judge
  (``timeline.shortfall``): so `fdlog info` and `fdlog diagnose` agree on every log.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .errors import FlightLogError
from .flight import Flight
from .prepared import PreparedFlight, segment_times
from .stopped import diagnose_stopped

#: Below this the derivative of the gyro no longer resolves a quad's attitude dynamics (a few Hz).
MIN_RATES_HZ = 15.0
#: PX4's default logging profile writes actuator_motors at 10 Hz and ArduCopter RCOU at 10 Hz: both pass.
MIN_MOTORS_HZ = 5.0
#: A verdict from less than this is too easily swayed by one manoeuvre.
MIN_AIRBORNE_S = 8.0
# The verdict needs several windows to smooth over: use its own minimum so that both agree.
from .timeline import MIN_WINDOWS  # noqa: E402

#: ArduPilot quad layouts diagnosed as quads: motors 1-4 where quad-X's (X, V, H) or quad-+'s sit. The
#: other quad tables (BF_X, DJI_X, CW_X, V-/A-tail, Y4...) are placed for `fdlog info` and the
#: stopped-motor finding only.
ARDUPILOT_QUAD_LAYOUTS = ("ArduPilot QUAD/X", "ArduPilot QUAD/PLUS", "ArduPilot QUAD/V", "ArduPilot QUAD/H")
#: Vehicle types whose placed n-rotor frame gets the stopped-motor-only message (readers' vehicle_type).
MULTIROTOR_TYPES = ("quadrotor", "unknown", "multirotor", "hexarotor", "octorotor", "dodecarotor", "decarotor")

#: ArduPilot (FRAME_CLASS, FRAME_TYPE) tables whose motor numbering the shipped n-rotor models'
#: classes follow: the frames they were trained on (training/build_default.py FRAMES_BY_ROTORS,
#: sim/airframe.py N_ROTOR_FRAMES: hexa X/+, octo X/+, octaquad X). PX4 frames match by geometry.
TRAINED_LAYOUTS = {6: ((2, 1), (2, 0)), 8: ((3, 1), (3, 0), (4, 1))}
#: A log's motor k matches a trained table's motor k when its bearing from the centre is within
#: this many degrees and it spins the same way (tables differ by >= 30 deg or in spin where they differ).
FRAME_MATCH_DEG = 10.0

DEFAULT_RATE_HZ = 50.0
DEFAULT_WINDOW = 80


@dataclass
class Diagnosability:
    ok: bool
    reasons: list[str] = field(default_factory=list)
    facts: dict = field(default_factory=dict)

    @property
    def reason(self) -> str:
        return "; ".join(self.reasons)


def describe_vehicle(flight: Flight) -> str:
    """Plain words for the vehicle: "quadrotor (quad_x)", "VTOL", "hexarotor"..."""
    vt = (flight.vehicle_type or "unknown").replace("_", " ")
    f = flight.frame
    if f is not None and f.rotor_count:
        return f"{vt} ({f.name}, {f.rotor_count} rotors)" if f.name != vt else f"{vt} ({f.rotor_count} rotors)"
    return vt


def trained_layout(frame) -> str:
    """The trained table (e.g. "ArduPilot HEXA/X") whose numbering ``frame`` follows, else ""."""
    import math

    from .frames import ardupilot_frame

    def bearing(r) -> float:
        return math.degrees(math.atan2(r.y, r.x))

    for cls, typ in TRAINED_LAYOUTS.get(frame.rotor_count, ()):
        ref = ardupilot_frame(cls, typ)
        if all(abs((bearing(a) - bearing(b) + 180.0) % 360.0 - 180.0) <= FRAME_MATCH_DEG
               and math.copysign(1.0, a.spin) == math.copysign(1.0, b.spin)
               for a, b in zip(frame.rotors, ref.rotors)):
            return ref.layout
    return ""


def _n_rotor_reason(frame, spec_n) -> str:
    """Why a placed n-rotor frame (n != 4) cannot get a propeller diagnosis; "" when it can."""
    from .model import shipped_model_path

    n = frame.rotor_count
    has_model = (spec_n == n) if spec_n is not None else shipped_model_path(n) is not None
    if not has_model:
        if spec_n is not None and shipped_model_path(n) is not None:
            return (f"{n}-rotor frame ({frame.name}): the model diagnoses {spec_n} rotors; use the shipped "
                    f"{n}-rotor model (leave out --model)")
        return (f"{n}-rotor frame ({frame.name}): fdlog has no {n}-rotor propeller-damage model yet; "
                f"only stopped-motor detection is available for it")
    if not trained_layout(frame):
        trained = ", ".join(f"{c}/{t}" for c, t in TRAINED_LAYOUTS.get(n, ()))
        return (f"{n}-rotor frame {frame.layout or frame.name}: its motor numbering is not that of the frames the "
                f"{n}-rotor model was trained on (ArduPilot FRAME_CLASS/TYPE {trained}); only stopped-motor "
                f"detection is available for it")
    return ""


def _stretch_reason(prep: PreparedFlight, spec: dict | None, n_motors: int) -> str | None:
    """Why the flight's gap-free airborne stretches (the diagnosis's own segments for ``spec``)
    hold too few windows to judge, or None."""
    from .timeline import covered_seconds, shortfall
    from .windows import FeatureSpec, no_window_reason, window_spans

    try:
        fs = FeatureSpec.from_dict(spec) if spec else FeatureSpec(n_motors=n_motors)
        times = segment_times(prep, fs.rate_hz, fs.max_gap_s, fs.trim_s, fs.savgol_window_s,
                              need_attitude=fs.features == "cf", speed_source=fs.speed_source, n_motors=fs.n_motors)
    except FlightLogError as e:
        return e.message
    except ValueError:  # a malformed spec is the model's problem, reported where the model is read
        return None
    t0, t1 = window_spans(times, fs)
    if t0.size == 0:
        return no_window_reason(prep.flight, times, fs)
    return shortfall(int(t0.size), covered_seconds(t0, t1))


def diagnosability(flight, spec: dict | None = None) -> Diagnosability:
    """Check everything the diagnosis needs; never raises for a loaded Flight (or a
    :class:`~flightlog_fd.prepared.PreparedFlight`, whose segments the diagnosis then reuses)."""
    prep = PreparedFlight.of(flight)
    flight = prep.flight
    spec_n = int(spec.get("n_motors", 4)) if spec else None
    spec = spec or {}
    rate_hz = float(spec.get("rate_hz", DEFAULT_RATE_HZ))
    window = int(spec.get("window", DEFAULT_WINDOW))
    reasons: list[str] = []
    frame = flight.frame
    is_quad = frame is not None and frame.is_quad
    vtype = (flight.vehicle_type or "unknown").lower()
    if vtype not in ("quadrotor", "unknown", "multirotor") or not is_quad:
        n = frame.rotor_count if frame is not None else 0
        if vtype in MULTIROTOR_TYPES and frame is not None and n and n != 4 and not frame.unplaced:
            why = _n_rotor_reason(frame, spec_n)
            if why:
                reasons.append(why)
        elif vtype in MULTIROTOR_TYPES and frame is not None and frame.unplaced:
            reasons.append(f"cannot place the rotors of this {frame.name} frame: {frame.unplaced}")
        elif vtype not in ("quadrotor", "unknown", "multirotor"):
            reasons.append(f"not a quadrotor: this log is from a {describe_vehicle(flight).replace('vtol', 'VTOL')}; "
                           f"fdlog diagnoses quadrotors only")
        elif frame is None:
            reasons.append("unknown frame: the log has no rotor geometry or frame parameters")
        else:
            reasons.append(f"unsupported frame {frame.name!r}; fdlog diagnoses quad-X and quad-+ frames")
    elif frame.layout.startswith("ArduPilot QUAD/") and frame.layout not in ARDUPILOT_QUAD_LAYOUTS:
        reasons.append(f"unsupported frame {frame.layout}: its motor numbering is not quad-X / quad-+ (the model's "
                       f"motor classes follow quad-X numbering); fdlog diagnoses quad-X and quad-+ frames")
    need_motors = frame.rotor_count if frame is not None and frame.rotor_count > 4 else 4
    if flight.motors is None:
        reasons.append("no per-motor outputs in the log (actuator_motors / actuator_outputs / RCOU)")
    elif flight.motors.values.shape[1] < need_motors:
        reasons.append(f"only {flight.motors.values.shape[1]} motor outputs in the log, need {need_motors}")
    elif flight.motors.rate_hz < MIN_MOTORS_HZ:
        reasons.append(f"motor outputs logged at {flight.motors.rate_hz:.1f} Hz, need >= {MIN_MOTORS_HZ:.0f} Hz")
    if flight.rates is None:
        reasons.append("no angular rates in the log (gyro / vehicle_angular_velocity / RATE)")
    elif flight.rates.rate_hz < MIN_RATES_HZ:
        reasons.append(f"angular rates logged at {flight.rates.rate_hz:.1f} Hz, need >= {MIN_RATES_HZ:.0f} Hz")
    need_s = max(MIN_AIRBORNE_S, (window + (MIN_WINDOWS - 1) * window / 2) / rate_hz)
    airborne = flight.airborne_s
    if not flight.airborne:
        reasons.append("the vehicle never flew in this log (no airborne time)")
    elif airborne < need_s:
        reasons.append(f"only {airborne:.1f} s airborne, need at least {need_s:.0f} s")
    if not reasons:
        why = _stretch_reason(prep, spec, need_motors)
        if why:
            reasons.append(why)
    facts = {
        "vehicle": describe_vehicle(flight),
        "airborne_s": round(airborne, 2),
        "needed_airborne_s": round(need_s, 1),
        "rates_hz": round(flight.rates.rate_hz, 1) if flight.rates is not None else None,
        "motors_hz": round(flight.motors.rate_hz, 1) if flight.motors is not None else None,
    }
    return Diagnosability(not reasons, reasons, facts)


def describe_flight(flight: Flight, spec: dict | None = None) -> dict:
    """Everything `fdlog info` shows, as a JSON-safe dict."""
    d = diagnosability(flight, spec)
    frame = flight.frame
    return {
        "log": flight.path,
        "autopilot": flight.autopilot,
        "firmware": flight.firmware,
        "reader": flight.reader,
        "vehicle_type": flight.vehicle_type,
        "vehicle_id": flight.vehicle_id,
        "frame": None if frame is None else {
            "name": frame.name,
            "rotor_count": frame.rotor_count,
            "source": frame.source,
            "layout": frame.layout,
            "unplaced": frame.unplaced or None,
            "motors": [
                {"motor": i + 1, "position": frame.position(i + 1), "x": r.x, "y": r.y,
                 "spin": "CCW" if r.spin > 0 else ("CW" if r.spin < 0 else "none"),
                 "axis": list(r.axis),
                 "output": frame.outputs[i] if i < len(frame.outputs) else None}
                for i, r in enumerate(frame.rotors)
            ],
        },
        "t_start": round(flight.t_start, 6),
        "t_end": round(flight.t_end, 6),
        "duration_s": round(flight.duration_s, 3),
        "armed": [[round(a, 3), round(b, 3)] for a, b in flight.armed],
        "airborne": [[round(a, 3), round(b, 3)] for a, b in flight.airborne],
        "airborne_s": round(flight.airborne_s, 3),
        "airborne_source": flight.airborne_source,
        "motor_kind": flight.motor_kind,
        "thrust_curve": flight.thrust_curve,
        "streams": [
            {"name": s.name, "source": s.source, "rate_hz": round(s.rate_hz, 2), "samples": s.samples}
            for s in flight.streams()
        ],
        "stopped_motors": [
            {"motor": f.motor, "t_start": round(f.t_start, 3), "t_end": round(f.t_end, 3), "evidence": f.evidence,
             "source": f.source}
            for f in diagnose_stopped(flight)
        ],
        # ESC gaps counted within the armed time (telemetry before arming is not expected)
        "esc": None if flight.esc is None else flight.esc.describe(
            *((flight.armed[0][0], flight.armed[-1][1]) if flight.armed else (None, None))),
        "diagnosable": d.ok,
        "reasons": d.reasons,
        "warnings": list(flight.warnings),
    }
