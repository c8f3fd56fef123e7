"""A stopped motor: "motor k stopped" with its time, a finding of its own, on every frame.

What: a motor whose output sits at its minimum while the vehicle is airborne and the other
motors carry it, or whose ESC reports its rotor (nearly) still while the others turn, for at
least ``STOP_MIN_S``. That is not a damaged propeller (the motor still turns and the controller
asks it for more): a stopped motor gets no command or no current at all (an ESC or motor
failure, a cut wire, an output re-assigned in flight).

Inputs: a :class:`~flightlog_fd.flight.Flight`. The output actually sent is preferred to the
controller's request: ArduPilot ``RCOU`` (``alt_motors["RCOU"]`` when the reader rebuilt the
motors from ``RATE``, whose mixer cannot know an output was cut), PX4 ``actuator_outputs``,
else the Flight's own motor stream. Values are the readers' 0..1 normalisation (0 = the
output's minimum: ArduPilot ``MOT_PWM_MIN``, PX4 ``PWM_MIN`` / disarmed value clipped to 0).

Limits: PX4 normalises its armed idle and its disarmed value both to 0, so on PX4 only the
duration separates a motor stopped from one the controller holds at idle; a motor stopped for
less than ``STOP_MIN_S``, or outside the airborne time, is not reported. ESC telemetry that reads
0 on every motor (ArduPilot SITL) says nothing and is ignored.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .flight import Flight, Series

#: A motor output at or below this fraction of its range is at its minimum (stopped). Measured:
#: the lowest airborne RCOU of every real ArduCopter quad in ../shared (real_healthy/logs,
#: real_logs/ardupilot, real_damaged/rrc_straight) is 0.068 (ArduCopter 3.3 erle_copter33_73 and
#: erle_pxf_25-9-2014_3; 4.x flies at MOT_SPIN_MIN >= 0.15), the stopped motor of every
#: ardupilot_sitl_hexa log sits at 0.000 (1000 us).
STOP_LEVEL = 0.03
#: ...for at least this long (s) while airborne. Measured: the longest airborne stretch at or
#: below 0.05 of any motor on the real and SITL healthy quads in ../shared is 0.5 s (PX4 RflyMAD
#: SIL actuator_outputs, a quad held at idle through a manoeuvre; ArduPilot never below 0.068);
#: a simulated octaquad with a damaged rotor (bench_nrotor.py) holds a coaxial partner at its
#: minimum for up to 1.3 s; the SITL hexa motors stay stopped 16-18 s. Twice that 1.3 s, rounded up.
STOP_MIN_S = 3.0
#: The other motors' median output must be at least this (they carry the vehicle); below it the
#: whole vehicle is spooled down (a landing flare, a throttle cut) and nothing is singled out.
#: Measured: the other five motors of the ardupilot_sitl_hexa logs run at 0.55-0.95 after the stop;
#: a hovering multirotor's outputs sit at 0.3-0.7 (every real log in ../shared, hover throttle
#: MOT_THST_HOVER 0.2-0.5 before the thrust curve).
OTHERS_MIN_LEVEL = 0.2
#: An ESC reading below this fraction of the other motors' median rpm means its rotor stopped.
#: Measured: the lowest airborne ratio in the only real ESC-rpm log in ../shared
#: (sample_px4_events.ulg, PX4 SITL esc_status) is 0.82, at touchdown.
STOP_RPM_RATIO = 0.25
#: Telemetry whose other motors' median is below this (rpm) carries no information (the
#: ardupilot_sitl_hexa logs report 0 rpm on every motor throughout).
MIN_TELEMETRY_RPM = 100.0
#: Stopped stretches of one motor closer than this (s) are one stop (a stray sample between).
MERGE_GAP_S = 0.5


@dataclass(frozen=True)
class StoppedMotor:
    """``motor`` (1-based, the autopilot's numbering) stopped from ``t_start`` to ``t_end`` (s,
    log clock); ``evidence``: one sentence with the numbers; ``source``: the stream it came from."""

    motor: int
    t_start: float
    t_end: float
    evidence: str
    source: str

    @property
    def duration_s(self) -> float:
        return float(self.t_end - self.t_start)


def _output_stream(flight: Flight) -> Optional[Series]:
    """The output sent to the motors where the log has it, else the Flight's motor stream."""
    if flight.motors is not None and flight.motor_kind == "signal":
        return flight.motors
    for key in ("RCOU", "actuator_outputs"):
        if key in flight.alt_motors:
            return flight.alt_motors[key]
    if flight.autopilot == "ardupilot":
        return None  # a RATE-mixer rebuild is the controller's request: it cannot show a cut output
    if flight.motors is not None and flight.motors.source.startswith("actuator_controls_0"):
        return None  # likewise PX4 control demands through the mixer
    return flight.motors


def _airborne_mask(flight: Flight, t: np.ndarray) -> np.ndarray:
    m = np.zeros(t.shape, dtype=bool)
    for a, b in flight.airborne:
        m |= (t >= a) & (t <= b)
    return m


def _runs(t: np.ndarray, flag: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) sample index of each stretch where ``flag`` holds, stretches with gaps of at
    most MERGE_GAP_S merged."""
    edges = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    out: list[tuple[int, int]] = []
    for s, e in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1):
        if out and t[s] - t[out[-1][1]] <= MERGE_GAP_S:
            out[-1] = (out[-1][0], int(e))
        else:
            out.append((int(s), int(e)))
    return out


def _others_median(v: np.ndarray, k: int) -> np.ndarray:
    return np.median(np.delete(v, k, axis=1), axis=1)


def _segments(flight: Flight, s: Series) -> list[np.ndarray]:
    """Index arrays of the stream's samples inside each airborne interval (runs never cross one)."""
    order = np.argsort(s.t, kind="stable")
    t = s.t[order]
    return [order[(t >= a) & (t <= b)] for a, b in flight.airborne]


def _stretches(flight: Flight, s: Series, stopped) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """(motor k 0-based, times, its values, the others' median) of every airborne run where
    ``stopped(values_k, others_median)`` holds, per airborne interval."""
    out = []
    if s.values.shape[1] < 2:
        return out
    for idx in _segments(flight, s):
        if idx.size < 2:
            continue
        t, v = s.t[idx], np.nan_to_num(s.values[idx], nan=0.0)
        for k in range(v.shape[1]):
            others = _others_median(v, k)
            for a, b in _runs(t, stopped(v[:, k], others)):
                out.append((k, t[a:b + 1], v[a:b + 1, k], others[a:b + 1]))
    return out


def _from_outputs(flight: Flight, s: Series) -> list[StoppedMotor]:
    runs = [(k, float(t[0]), float(t[-1]), float(np.max(vk)), float(np.median(oth)))  # k, t0, t1, highest, others
            for k, t, vk, oth in _stretches(flight, s, lambda vk, oth: (vk <= STOP_LEVEL) & (oth >= OTHERS_MIN_LEVEL))]
    # a motor that never left its minimum between two stretches (the vehicle landed or hit the
    # ground in between, ending an airborne interval) stopped once
    order = np.argsort(s.t, kind="stable")
    st, sv = s.t[order], np.nan_to_num(s.values[order], nan=0.0)
    merged: list[list] = []
    for k, t0, t1, hi, oth in sorted(runs):
        prev = merged[-1] if merged and merged[-1][0] == k else None
        between = sv[(st > (prev[2] if prev else t0)) & (st < t0), k] if prev else None
        if prev is not None and (between.size == 0 or np.all(between <= STOP_LEVEL)):
            prev[2], prev[3], prev[4] = t1, max(prev[3], hi), min(prev[4], oth)
        else:
            merged.append([k, t0, t1, hi, oth])
    return [StoppedMotor(
        k + 1, t0, t1,
        f"output at {hi:.0%} of its range or less (stopped: <= {STOP_LEVEL:.0%}) for {t1 - t0:.1f} s from "
        f"t={t0:.2f} s while airborne, the other motors at a median {oth:.0%}", s.source)
        for k, t0, t1, hi, oth in merged if t1 - t0 >= STOP_MIN_S]


def _from_rpm(flight: Flight, s: Series) -> list[StoppedMotor]:
    return [StoppedMotor(
        k + 1, float(t[0]), float(t[-1]),
        f"ESC reports {np.median(vk):.0f} rpm against a median {np.median(oth):.0f} rpm on the other motors "
        f"(stopped: < {STOP_RPM_RATIO:.0%}) for {t[-1] - t[0]:.1f} s from t={t[0]:.2f} s while airborne", s.source)
        for k, t, vk, oth in _stretches(flight, s, lambda vk, oth: (oth >= MIN_TELEMETRY_RPM) & (vk < STOP_RPM_RATIO * oth))
        if t[-1] - t[0] >= STOP_MIN_S]


def _merge(findings: list[StoppedMotor]) -> list[StoppedMotor]:
    """One finding per motor and overlapping time: the outputs' and the ESC's evidence joined."""
    findings = sorted(findings, key=lambda f: (f.motor, f.t_start))
    out: list[StoppedMotor] = []
    for f in findings:
        prev = out[-1] if out else None
        if prev is not None and prev.motor == f.motor and f.t_start <= prev.t_end + MERGE_GAP_S:
            out[-1] = StoppedMotor(f.motor, min(prev.t_start, f.t_start), max(prev.t_end, f.t_end),
                                   f"{prev.evidence}; {f.evidence}", f"{prev.source} + {f.source}")
        else:
            out.append(f)
    return sorted(out, key=lambda f: (f.t_start, f.motor))


def diagnose_stopped(flight: Flight) -> list[StoppedMotor]:
    """Every "motor k stopped" finding of the flight, earliest first (empty when none). Pure:
    reads the Flight only. Works for any rotor count; needs airborne intervals."""
    if not flight.airborne:
        return []
    found: list[StoppedMotor] = []
    s = _output_stream(flight)
    if s is not None and len(s):
        found += _from_outputs(flight, s)
    if flight.esc_rpm is not None and len(flight.esc_rpm):
        found += _from_rpm(flight, flight.esc_rpm)
    findings = _merge(found)
    out = []
    for f in findings:
        position = flight.frame.position(f.motor) if flight.frame is not None else f"motor {f.motor}"
        notes = [w for w in flight.warnings if f"(motor {f.motor})" in w]
        evidence = f"motor {f.motor} ({position}): {f.evidence}" + (f"; the log says: {notes[0]}" if notes else "")
        out.append(StoppedMotor(f.motor, f.t_start, f.t_end, evidence, f.source))
    return out


def describe(finding: StoppedMotor) -> str:
    """One line: "motor 3 stopped at t=73.87 s (for 18.1 s): <evidence>"."""
    return (f"motor {finding.motor} stopped at t={finding.t_start:.2f} s (for {finding.duration_s:.1f} s): "
            f"{finding.evidence}")


__all__ = ["StoppedMotor", "diagnose_stopped", "describe", "STOP_LEVEL", "STOP_MIN_S", "OTHERS_MIN_LEVEL",
           "STOP_RPM_RATIO", "MIN_TELEMETRY_RPM", "MERGE_GAP_S"]
