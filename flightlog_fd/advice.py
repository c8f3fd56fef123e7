"""What would resolve a verdict: the propellers to inspect, the command that adds this flight to the
airframe's profile as a session when they are sound, and the logging settings that would let a
source that could not weigh in decide next time.

:func:`advise` turns a verdict, the kind of log (:class:`~flightlog_fd.analyzers.reliability.LogKind`)
and the analyzers' abstentions into a list of :class:`Advice` (the JSON report's
``verdict.advice``; every report prints it). Advice is given for an ``uncertain`` verdict, and for a
``healthy`` one resting on thin evidence (a mostly uncertain timeline, a log that could not show
damage: ``Verdict.seen`` False, or a source held back by the log's rates): what to inspect and what
to log. A ``damaged`` verdict names its propeller in its reason; a ``stopped`` one its motor.

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
from .decision import THIN_TIMELINE_SHARE

#: Every kind of advice, in the order a pilot acts on them.
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


@dataclass(frozen=True)
class Advice:
    """One thing to do: ``kind`` ("inspect", "add_session", "calibrate", "logging", "esc_telemetry",
    "manoeuvre"), the words, and where it applies the motors, the command or the autopilot setting."""

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
    inspect: Sequence[int] = ()  # the propellers the verdict names to inspect, first first
    kind: Optional[LogKind] = None
    autopilot: str = ""
    log: Optional[str] = None
    profile: Optional[str] = None
    has_esc: bool = False
    little_manoeuvring: bool = False  # the effectiveness fit said the flight did not manoeuvre enough
    timeline_uncertain: float = 0.0  # share of '?' windows
    positions: dict = field(default_factory=dict)  # motor -> position words
    cause: Optional[str] = None  # the named rotor's likely cause (flightlog_fd.cause): its motor / ESC first
    pair: bool = False  # the verdict is that two propellers lost thrust together (``inspect`` holds both)
    seen: Optional[bool] = None  # a healthy verdict: False when this log could not show damage
    #: The motor the command pattern alone points at (``Decision.pattern_held``: that rotor lost
    #: thrust, or a load sits at its corner); calibration refuses such a flight, so the advice is to
    #: fly once without the payload instead of calibrating on it.
    pattern_held: Optional[int] = None


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


def advise(s: Situation) -> list[Advice]:
    """The advice for one verdict (module docstring); [] when there is nothing to resolve."""
    thin = s.status == "healthy" and (s.timeline_uncertain >= THIN_TIMELINE_SHARE or s.seen is False)
    if s.status != "uncertain" and not thin:
        return []
    out: list[Advice] = []
    if s.status == "uncertain":
        motors = tuple(int(m) for m in s.inspect)
        if len(motors) == 1 and s.cause == "motor_or_esc":
            k = motors[0]
            name = f"{k}" + (f" ({s.positions[k]})" if s.positions.get(k) else "")
            out.append(Advice("inspect", f"inspect motor {name} and its ESC first (bearings, windings, wiring and "
                                         f"solder joints, the ESC): ESC rpm shows it turning slower for its command; "
                                         f"then propeller {k}", motors))
        elif len(motors) == 1 and s.cause == "wash":
            k = motors[0]
            name = f"{k}" + (f" ({s.positions[k]})" if s.positions.get(k) else "")
            out.append(Advice("inspect", f"inspect what sits under rotor {name} first (a payload, a strap, a guard, "
                                         f"anything in its wash): ESC rpm shows its propeller and motor turning as "
                                         f"sound ones do; then propeller {k} and motor {k}", motors))
        elif motors:
            names = " and ".join(f"{m}" + (f" ({s.positions[m]})" if s.positions.get(m) else "") for m in motors)
            if s.pair and len(motors) == 2:
                out.append(Advice("inspect", f"inspect both propellers, {names}: the evidence fits the two having "
                                             f"lost thrust together (cracks, chips, a loose or bent blade, their "
                                             f"motors turning freely)", motors))
            else:
                out.append(Advice("inspect", f"inspect propeller{'s' if len(motors) > 1 else ''} {names} first "
                                             f"(cracks, chips, a loose or bent blade, its motor turning freely)",
                                  motors))
        else:
            out.append(Advice("inspect", "inspect every propeller (cracks, chips, a loose or bent blade)"))
        log = _quote(s.log, "LOG")
        if s.pattern_held is not None:
            k = s.pattern_held
            out.append(Advice("without_payload", f"if propeller {k} is sound and the aircraft carried a payload, a "
                                                 f"camera or a weight near motor {k}, fly once without it and "
                                                 f"diagnose that flight: the two explanations then part (this "
                                                 f"flight cannot be a calibration: its commands look like rotor "
                                                 f"{k} lost thrust)", (k,)))
        elif s.profile:
            cmd = f"fdlog calibrate --add {_quote(s.profile, 'PROFILE')} {log}"
            out.append(Advice("add_session", "if the propellers are sound, add this flight to the airframe's "
                                             "profile as a session, so its normal spread is known next time",
                              command=cmd))
        else:
            out.append(_calibrate(s, "if the propellers are sound, calibrate this airframe on this flight and "
                                     "diagnose the next flights with the profile (--profile)"))
    elif not s.profile:
        # The command calibrates on this very flight, which may carry damage the model could not
        # see: so the advice asks for the inspection first (a profile made on a damaged propeller
        # would call that damage normal).
        why = ("this log could not show damage" if s.seen is False
               else "the model could not tell this flight's propellers apart")
        out.append(_calibrate(s, f"{why}: inspect the propellers, and if they are sound, calibrate this airframe on "
                                 f"this flight so its command pattern weighs in fully next time (--profile)"))
    kind = s.kind
    autopilot = s.autopilot if s.autopilot in LOGGING else ""
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
        status=v.status, inspect=tuple(v.inspect), kind=diagnosis.log_kind,
        autopilot=f.autopilot if f else "", log=diagnosis.log,
        profile=diagnosis.profile.path if diagnosis.profile is not None else None,
        has_esc=getattr(flight, "esc", None) is not None,
        little_manoeuvring=bool(eff is not None and (eff.reason or "").startswith(LITTLE_MANOEUVRING)),
        timeline_uncertain=float(tl.abstained_share) if tl is not None and tl.n_windows else 0.0,
        positions={k: frame.position(k) for k in range(1, frame.rotor_count + 1)} if frame is not None else {},
        cause=v.cause, pair=bool(getattr(v, "pair", False)), seen=getattr(v, "seen", None),
        pattern_held=getattr(diagnosis.decision, "pattern_held", None) if v.status == "uncertain" else None)
