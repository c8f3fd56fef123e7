"""What to do after a verdict: what to inspect, in the order the cause makes likely, the command
that adds this flight to the airframe's profile as a session when the propellers are sound, and the
logging settings that would let a source that could not weigh in decide next time.

:func:`advise` turns a verdict, the kind of log (:class:`~flightlog_fd.analyzers.reliability.LogKind`)
and the analyzers' abstentions into a list of :class:`Advice` (the JSON report's
``verdict.advice``; every report prints it under the cause and the evidence):

- ``damaged`` or ``uncertain`` naming rotor k: inspect propeller k, then motor k and its ESC, then
  what sits under rotor k (in its wash), in the order the cause (:mod:`flightlog_fd.cause`) makes
  likely: a motor or ESC cause puts the motor first, something in the wash what sits under it
  first; a propeller cause or none keeps that order. Two rotors: both, in the same order; no rotor
  named: every propeller. A damaged verdict whose cause is unknown asks for ESC telemetry (it tells
  a propeller from a motor or ESC next time);
- ``uncertain``: then what resolves it (add the flight as a session, or calibrate on it, when
  the propellers are sound; the logging settings a source lacked);
- ``healthy`` naming a moved load (cause ``load``): re-balance it, or re-calibrate with it;
- ``healthy`` resting on thin evidence (a mostly uncertain timeline, a log that could not show
  damage: ``Verdict.seen`` False, or a source held back by the log's rates): what to inspect and
  what to log;
- ``stopped`` and ``not_diagnosable``: nothing here (the headline says what to check; the
  reason why the log cannot be judged).

Settings named (the autopilots' own parameters):
- PX4: ``SDLOG_PROFILE`` bit 4 "high rate" (value 16; 17 = the default set plus high rate) logs
  ``actuator_motors`` and the angular rates at up to 250 Hz instead of 10 / 50 Hz; ESC telemetry
  (``esc_status``) with DShot telemetry (``DSHOT_TEL_CFG``) or bidirectional DShot
  (``DSHOT_BIDIR_EN``);
- ArduPilot: ``LOG_BITMASK`` bits ATTITUDE_FAST (1) and IMU (128) log ``RATE`` (with the motor
  mixer's outputs) and ``IMU`` at the loop rate, RCOUT (1024) the outputs; ESC telemetry (``ESC``
  messages) with bidirectional DShot (``SERVO_BLH_BDMASK``) or BLHeli telemetry (``SERVO_BLH_TRATE``).
"""
from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

from .analyzers.reliability import FULL_RATE_HZ, LogKind
from .decision import HEADLINE_ROTORS_NAMED, THIN_TIMELINE_SHARE

#: Every kind of advice, in the order a pilot acts on them.
#: ``without_payload``: re-balance a moved load a healthy verdict names.
ADVICE_KINDS = ("inspect", "add_session", "calibrate", "without_payload", "logging", "esc_telemetry", "manoeuvre")

LOGGING = {
    "px4": ("SDLOG_PROFILE", "set SDLOG_PROFILE to include its high-rate bit (16; e.g. 17 = the default set "
                             "plus high rate) so the motor outputs and the angular rates are logged at up to "
                             "250 Hz"),
    "ardupilot": ("LOG_BITMASK", "add ATTITUDE_FAST (1), IMU (128) and RCOUT (1024) to LOG_BITMASK so the RATE "
                                 "message (with the motor mixer's outputs) and the IMU are logged at the loop rate"),
}
ESC_TELEMETRY = {
    "px4": ("DSHOT_TEL_CFG", "enable ESC telemetry (DShot telemetry, DSHOT_TEL_CFG, or bidirectional DShot, "
                             "DSHOT_BIDIR_EN) so esc_status logs each motor's rpm: a damaged propeller turns "
                             "faster per command, a weak motor slower"),
    "ardupilot": ("SERVO_BLH_BDMASK", "enable ESC telemetry (bidirectional DShot, SERVO_BLH_BDMASK, or BLHeli "
                                      "telemetry, SERVO_BLH_TRATE) so the ESC message logs each motor's rpm: a "
                                      "damaged propeller turns faster per command, a weak motor slower"),
}


#: What to look at on each part that can take a rotor's thrust; {r} "propeller 2 (rear-left)" or
#: "propellers 1 (front-right) and 4 (rear-right)", {m} "motor 2" / "motors 1 and 4", {u} "rotor 2".
PARTS = {
    "propeller": "{r}: chips, cracks (flex each blade), a cut or worn tip, a bent blade, a loose hub or nut",
    "motor": "{m} and {its} ESC{s}: spin by hand (roughness, play, heat after flight), wires, connectors, "
             "solder joints",
    "wash": "what sits under {u}: a camera, a leg, a cable, tape or a payload in {its} wash",
}
#: The order the parts are inspected in, per cause (``Verdict.cause``; None: unknown): the likely
#: part first, the propeller next (the commonest and cheapest to check), what sits under it last.
INSPECT_ORDER = {
    None: ("propeller", "motor", "wash"),
    "propeller": ("propeller", "motor", "wash"),
    "motor_or_esc": ("motor", "propeller", "wash"),
    "wash": ("wash", "propeller", "motor"),
}


@dataclass(frozen=True)
class Advice:
    """One thing to do: ``kind`` (:data:`ADVICE_KINDS`), the words, and where it applies the motors,
    the command or the autopilot setting."""

    kind: str
    text: str
    motors: tuple[int, ...] = ()
    command: Optional[str] = None
    setting: Optional[str] = None

    def as_dict(self) -> dict:
        return {"kind": self.kind, "text": self.text, "motors": list(self.motors), "command": self.command,
                "setting": self.setting}


@dataclass
class Situation:
    """What :func:`advise` reads about one diagnosis."""

    status: str
    inspect: Sequence[int] = ()  # the rotors the verdict names to inspect, first first
    kind: Optional[LogKind] = None
    autopilot: str = ""
    log: Optional[str] = None
    profile: Optional[str] = None
    has_esc: bool = False
    little_manoeuvring: bool = False  # the effectiveness fit said the flight did not manoeuvre enough
    timeline_uncertain: float = 0.0  # share of '?' windows
    positions: dict = field(default_factory=dict)  # motor -> position words
    cause: Optional[str] = None  # the named rotor's likely cause (flightlog_fd.cause), or "load"
    pair: bool = False  # the verdict is that two rotors lost thrust together (``inspect`` holds both)
    seen: Optional[bool] = None  # a healthy verdict: False when this log could not show damage
    load: Optional[dict] = None  # a healthy verdict naming a moved load: ``Verdict.load``


def advice_line(a: Advice) -> str:
    """One advice item as a report prints it: its words, then the command to run or the setting."""
    if a.command:
        return f"{a.text}: {a.command}"
    return a.text


def _quote(p: Optional[str], fallback: str) -> str:
    return shlex.quote(str(p)) if p else fallback


def _profile_for(log: Optional[str]) -> str:
    """A profile file name beside the log for a first calibration (never an existing file's name)."""
    if not log:
        return "airframe.json"
    p = Path(log)
    return str(p.with_name(p.stem + ".profile.json"))


def _calibrate(s: Situation, text: str) -> Advice:
    """The first calibration on this flight (``--no-adapt`` for a frame the adaptation is not for)."""
    no_adapt = " --no-adapt" if s.kind is not None and s.kind.n_motors != 4 else ""
    return Advice("calibrate", text, command=f"fdlog calibrate{no_adapt} {_quote(s.log, 'LOG')} -o "
                                             f"{shlex.quote(_profile_for(s.log))}")


def _and(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + f" and {items[-1]}"


def inspect_steps(motors: Sequence[int], cause: Optional[str], positions: dict) -> list[Advice]:
    """The "inspect" advice for the named rotors: propeller, motor and ESC, what sits under it, one
    item each in the order the cause makes likely (:data:`INSPECT_ORDER`); every propeller when
    none is named, or as many as the headline names none of (``HEADLINE_ROTORS_NAMED``)."""
    motors = tuple(int(m) for m in motors)
    if not motors or len(motors) >= HEADLINE_ROTORS_NAMED:  # as many as the headline names none of
        return [Advice("inspect", "inspect every propeller: " + PARTS["propeller"].split(": ", 1)[1]),
                Advice("inspect", "then every motor and its ESC: " + PARTS["motor"].split(": ", 1)[1])]
    many = len(motors) > 1
    named = _and([f"{k} ({positions[k]})" if positions.get(k) else f"{k}" for k in motors])
    ks = _and([str(k) for k in motors])
    words = {"r": f"propeller{'s' if many else ''} {named}", "m": f"motor{'s' if many else ''} {ks}",
             "u": f"rotor{'s' if many else ''} {ks}", "its": "their" if many else "its", "s": "s" if many else ""}
    order = INSPECT_ORDER.get(cause, INSPECT_ORDER[None])
    return [Advice("inspect", ("inspect " if i == 0 else "then ") + PARTS[part].format(**words), motors)
            for i, part in enumerate(order)]


def _resolve(s: Situation, found: str) -> Optional[Advice]:
    """The profile step when the inspection finds nothing: add the flight as a session, or calibrate."""
    if s.profile:
        return Advice("add_session", f"{found}, add this flight to the airframe's profile as a session, so its "
                                     f"normal spread is known next time",
                      command=f"fdlog calibrate --add {_quote(s.profile, 'PROFILE')} {_quote(s.log, 'LOG')}")
    return _calibrate(s, f"{found}, calibrate this airframe on this flight and diagnose the next flights with "
                         f"the profile (--profile)")


def advise(s: Situation) -> list[Advice]:
    """The advice for one verdict (module docstring); [] when there is nothing to do."""
    thin = s.status == "healthy" and (s.timeline_uncertain >= THIN_TIMELINE_SHARE or s.seen is False)
    load = s.status == "healthy" and s.cause == "load" and bool(s.load)
    if s.status not in ("uncertain", "damaged") and not thin and not load:
        return []
    out: list[Advice] = []
    autopilot = s.autopilot if s.autopilot in LOGGING else ""
    if s.status in ("uncertain", "damaged"):
        out += inspect_steps(s.inspect, s.cause if len(s.inspect) == 1 else None, s.positions)
    if s.status == "damaged":
        if s.cause is None and len(s.inspect) == 1 and not s.has_esc and autopilot:
            setting, text = ESC_TELEMETRY[autopilot]
            out.append(Advice("esc_telemetry", text, setting=setting))
        return out
    if s.status == "uncertain":
        out.append(_resolve(s, "if nothing is found"))
    elif load:
        k = int(s.load["motor"])
        where = f"motor {k}" + (f" ({s.positions[k]})" if s.positions.get(k) else "")
        out.append(Advice("without_payload", f"re-balance: the load sits toward {where}; move the battery, camera "
                                             f"or payload back toward the centre", (k,)))
        out.append(_resolve(s, "or, if the aircraft flies with this load from now on"))
    elif not s.profile:
        # The command calibrates on this very flight, which may carry damage the model could not
        # see: so the advice asks for the inspection first (a profile made on a damaged propeller
        # would call that damage normal).
        why = ("this log could not show damage" if s.seen is False
               else "the model could not tell this flight's propellers apart")
        out.append(_calibrate(s, f"{why}: inspect the propellers, and if they are sound, calibrate this airframe on "
                                 f"this flight so its command pattern weighs in fully next time (--profile)"))
    kind = s.kind
    slow = kind is not None and kind.stream_hz < FULL_RATE_HZ
    if slow and autopilot:
        setting, text = LOGGING[autopilot]
        out.append(Advice("logging", f"the motor outputs and rates were logged at {kind.motors_hz:.0f} / "
                                     f"{kind.rates_hz:.0f} Hz, too slow for the model's windows to count fully: "
                                     f"{text}", setting=setting))
    if s.little_manoeuvring and not slow:
        out.append(Advice("manoeuvre", "the flight held too steady for the effectiveness fit: a few deliberate "
                                       "roll and pitch moves in the next flight let it weigh each motor"))
    if s.status == "uncertain" and not s.has_esc and autopilot:
        setting, text = ESC_TELEMETRY[autopilot]
        out.append(Advice("esc_telemetry", text, setting=setting))
    return out


def situation(diagnosis: Any, flight: Any) -> Situation:
    """The :class:`Situation` of a :class:`~flightlog_fd.diagnose.Diagnosis` of ``flight``."""
    from .analyzers.effectiveness_fit import LITTLE_MANOEUVRING

    f = diagnosis.facts
    eff = getattr(diagnosis.share_fit, "effectiveness", None) if diagnosis.share_fit is not None else None
    frame = getattr(flight, "frame", None)
    tl = diagnosis.timeline
    v = diagnosis.verdict
    return Situation(
        status=v.status, inspect=tuple(v.inspect) or tuple(v.motors), kind=diagnosis.log_kind,
        autopilot=f.autopilot if f else "", log=diagnosis.log,
        profile=diagnosis.profile.path if diagnosis.profile is not None else None,
        has_esc=getattr(flight, "esc", None) is not None,
        little_manoeuvring=bool(eff is not None and (eff.reason or "").startswith(LITTLE_MANOEUVRING)),
        timeline_uncertain=float(tl.abstained_share) if tl is not None and tl.n_windows else 0.0,
        positions={k: frame.position(k) for k in range(1, frame.rotor_count + 1)} if frame is not None else {},
        cause=v.cause, pair=bool(getattr(v, "pair", False)), seen=getattr(v, "seen", None),
        load=getattr(v, "load", None))
