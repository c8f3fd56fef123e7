"""JSON report, schema version 8 (``fdlog diagnose --json``).

One log gives one object; several logs give an array of such objects (in the order given).
Times are seconds on the log's own clock; probabilities are 0..1 rounded to 4 decimals; n is the
frame's rotor count (4, 6, 8, ...; motors in the autopilot's own numbering, class k = motor k).

.. code-block:: text

    {
      "schema": 8,
      "tool": {"name": "flightlog-fd", "version": "0.1.0"},
      "log": "flight.ulg",                       # the path as given
      "autopilot": "px4" | "ardupilot" | "sim" | null,   # null when the file could not be read
      "firmware": "v1.14.0" | null,
      "vehicle_type": "quadrotor" | ... | null,
      "frame": "quad_x" | "quad_plus" | "hexa_x" | "octo_x" | ... | null,
      "duration_s": 123.4 | null, "airborne_s": 98.0 | null,
      "model": {"path": str|null, "version": str, "sha256": str, "calibrated": bool} | null,
      "profile": {"path": str|null, "model_path": str|null, "model_sha256": str|null,
                  "sessions": int,                   # its calibration sessions (schema 6)
                  "configuration": {"name": str, "of": int,     # optional: the load configuration the
                                    "load": {"motor": 1-n, "direction_deg": float, "size": float} | null}
                                    | null} | null,  #   commands were weighed against (null: one configuration)
      "verdict": {"status": "healthy" | "damaged" | "stopped" | "uncertain" | "not_diagnosable",
                                                     #   damaged: a rotor lost thrust (why: "cause")
                  "headline": "Rotor 2 (rear-left) lost ~30 % thrust since take-off: inspect propeller 2",
                                                     # the first line every report prints, at most 100
                                                     #   characters: the status, the rotor, how much, what to do
                  "motor": 1-n | null,               # the rotor that lost thrust (stopped), the first of two, or
                                                     #   the one an uncertain verdict asks to inspect first
                  "motors": [1-n],                   # every rotor it names: damaged, stopped, an uncertain
                                                     #   pair's two, or the one to inspect; [] when none
                  "positions": [str|null],           # the frame's words for each of "motors"
                  "pair": bool,                      # two rotors lost thrust together
                  "position": "front-right" | ... | null,   # the frame's words for "motor"
                  "thrust": [{"motor": 1-n,          # per named rotor, how much of its normal thrust it
                              "eta_hat": 0-1 | null, #   gives (1 = healthy; the joint evidence's peak)
                              "eta_ci": [lo, hi] | null}],  #   90 % interval (null: a pair's fit gives none)
                  "confidence": 0-1,        # the probability that this verdict is right, given the stated
                                             #   prior of damage, measured on real and simulated flights
                                             #   (0 for not_diagnosable: no verdict)
                  "p_damage": 0-1 | null,    # P(some rotor lost thrust) after the log (null: not weighed)
                  "prior_damage": 0-1,       # the prior of damage it was decided under (--prior-damage)
                  "seen": bool | null,       # healthy: true when the evidence saw the flight, false when
                                             #   this log could not show damage (not a clearance); else null
                  "first_seen": seconds | null,   # start of the first window of the damaged run
                  "reason": "rotor 2 gives about 70 % of its normal thrust [61-79 %]; ...",
                                             # the evidence, clauses joined by "; "
                  "cause": "propeller" | "motor_or_esc" | "wash" | "load" | null,
                                             # why the named rotor lost thrust, as far as the log shows:
                                             #   "wash": something in its wash or under it; "load": the
                                             #   propellers are healthy, a moved load explains the commands;
                                             #   null: the log cannot tell, or no rotor is named
                  "cause_probability": 0-1 | null,   # P(cause | the rotor lost thrust); null: none stated
                  "cause_evidence": {"motor": 1-n,                # null when no rotor is named
                                     "llr": nats | null,          # motor / ESC against propeller; null: no ESC rpm
                                     "rpm_per_command": % | null, "current_per_rpm2": % | null,
                                     "reason": str} | null,       # why that cause, or why none
                  "load": {"motor": 1-n,                          # cause "load": the motor nearest the load
                           "position": str | null, "side": str,   # that motor's and the load's side in words
                           "direction_deg": deg,                   # body frame: 0 forward, +90 right
                           "size": share,                          # share change of a motor straight toward it
                           "llr": nats,                            # the load against healthy, on the shares
                           "words": str} | null,
                  "advice": [{"kind": "inspect" | "add_session" | "calibrate" | "without_payload" |
                                      "logging" | "esc_telemetry" | "manoeuvre",
                              "text": str,              # what to do, in words, in the order to do it
                              "motors": [1-n],          # inspect: the rotors; without_payload: the load's motor
                              "command": str | null,    # add_session / calibrate: the fdlog command
                              "setting": str | null}]}, # logging / esc_telemetry: the autopilot parameter
      "evidence": {"n_windows": int, "covered_s": float,
                   "share": [healthy, m1, ..., mn],   # smoothed votes, 0..1
                   "abstained": 0-1} | null,
      "motor_columns": [{"key": "commands.share",       # "<analyzer>.<finding>", or the analyzer
                         "analyzer": str, "name": str,  # id alone ("name" "") when it abstained
                         "label": "share", "description": str,
                         "abstained": str | null}],     # why its cells are dashes
      "motors": [{"motor": 1-n, "position": str|null, "class": "motor k",
                  "model_vote": 0-1,                      # mean model probability "this propeller damaged"
                  "command_share": float,                 # mean thrust command / mean of all motors (1 = even)
                  "command_share_baseline": float|null,   # the profile's (or pre-onset) healthy share
                  "command_change": float,                # share - baseline, or - mean of the others
                  "eta_hat": float|null, "eta_ci": [lo, hi]|null,   # thrust efficiency (1 = healthy), 90 %
                  "effectiveness": float|null,            # relative to the others (1 = as they), null
                  "effectiveness_ci": [lo, hi]|null,      #   when the analyzer called it uninformative
                  "throttle": float|null,                 # the flight's throttle / calibration's
                  "weight": 0-1|null,                     # the decision's P("this rotor lost thrust")
                  "llr": float|null,                      # total log-likelihood ratio, nats
                  "llr_by_source": {analyzer id: nats}|null,
                  "cells": {column key: text},            # the per-motor table as every report draws it
                  "unavailable": {figure: reason}}],      # why an estimate above is null
      "motor_evidence": {"baseline": "profile" | "before onset" | "neighbours",
                         "throttle": float,
                         "effectiveness": {"informative": bool, "reason": str, "seconds": float,
                                           "motor_lag_s": float, "r2": [roll, pitch, yaw]} | null,
                         "airframe_changed": str | null,
                         "decision": {"sources": [str], "healthy_chi2": float|null,
                                      "share_sigma": float|null,
                                      "weights": {analyzer id: {"cell": str,   # its reliability-table cell
                                                  "trust": "trusted" | "corroborating" | "discounted" | null,
                                                  "cap": float}},  # the most nats it could give
                                      "posterior": {hypothesis: probability},  # "healthy", "load",
                                                  # "rotor k", "rotors j+k": the one posterior the verdict
                                                  # is read from (decision.hypotheses), under the prior
                                      "load_llr": float | null,  # a moved load's evidence, nats
                                      "pair": {"motors": [a, b], "llr": float,     # the most likely pair of
                                               "llr_by_source": {id: nats},       # rotors and its excess over
                                               "eta_hat": [ea, eb]|null,          # the best single rotor
                                               "excess": float} | null} | null} | null,
      "windows": [{"t_start": s, "t_end": s,
                   "class": 0-n,                  # the model's most probable class
                   "probabilities": [p0, p1, ..., pn],   # healthy, then motor 1..n
                   "phase": "hover" | "climb" | "descent" | "manoeuvre" | "unknown",
                   "smoothed_class": -1..n}],     # the verdict's label: -1 uncertain
      "analyzers": [{"analyzer": "model" | "commands" | "throttle" | "effectiveness" | "esc" | ...,
                     "abstained": str | null,            # why it had nothing to say
                     "notes": [str],
                     "findings": [{"motor": 0-n, "name": str,   # 0: about the flight (vibration level) "value": float|null, "unit": str,
                                   "interval": [lo, hi]|null, "baseline": float|null,
                                   "direction": "up" | "down" | "",   # which way damage moves it
                                   "llr": float|null,                 # its weight in the decision, nats
                                   "text": str, "analyzer": str}]}],
      "stopped_motors": [{"motor": 1-n, "t_start": s, "t_end": s,   # "motor k stopped" while airborne,
                          "evidence": str, "source": str}],        # any frame (status "stopped")
      "warnings": [str],
      "exit_code": 0 | 1 | 2,
      "part": "flight 2 of 2, 376.8-464.9 s" | null,   # which flight of the log this object is
      "flights": [object, ...]   # a log holding several flights: one object of this schema per
    }                            # take-off to landing ("part" set); no flight is worse than its log

``motors`` is the one per-motor shape (:mod:`flightlog_fd.report.motor_view`, which every report
draws); ``analyzers`` is each analyzer's own record (what the results store keeps per finding).
:data:`JSON_SCHEMA` is the same as a JSON Schema (draft 2020-12) dict; :func:`validate` checks a
document against it without needing the ``jsonschema`` package (it implements exactly the
keywords the schema uses). Adding a field is a compatible change; renaming or removing one, or
changing what one means, bumps ``schema``. Schema 2 added ``motors`` and ``motor_evidence``;
schema 3 added each motor's severity, decision weight and log-likelihood ratios; schema 4 (this
one) makes ``motors`` the per-motor view (``class``, ``throttle``, ``cells``, ``unavailable`` and
``motor_columns`` added; ``effectiveness`` null when its analyzer did not weigh it; any rotor
count), drops ``motor_evidence``'s ``top_motor``, ``single_motor_gap`` and ``notes`` (the
analyzers' results carry the notes) and makes ``confidence`` and ``weight`` the probability of
what they state; schema 5 adds ``part`` and ``flights`` (each take-off to landing of a log with its
own verdict: judged from vibration alone, the log's verdict is its worst flight's; with motor outputs,
the whole log's, each flight judged from the log's windows and never worse than it) and
flight-level findings (``motor`` 0: the vibration level); schema 6 adds the verdict's ``advice`` (what would
resolve it: the propellers to inspect, the command that adds the flight to the profile, the logging
settings that let a source decide next time), each source's reliability ``weights`` in
``motor_evidence.decision``, ``profile.sessions`` (how many calibration sessions the profile holds),
``verdict.motor`` for an ``uncertain`` verdict naming one propeller to inspect (it was null for
every uncertain verdict), ``verdict.motors``, ``verdict.positions`` and ``verdict.pair`` (two
propellers named together; ``motor`` stays the first of a damaged pair, null for an uncertain one)
and ``motor_evidence.decision.pair`` (the most likely pair hypothesis), and ``verdict.cause`` and
``verdict.cause_evidence`` (:mod:`flightlog_fd.cause`: with ESC telemetry, whether the named rotor's
propeller or its motor / ESC lost the thrust; null and the reason when the log cannot tell, and
null for a pair); schema 7 gives ``confidence`` one meaning: the probability that this verdict is
right, measured on real and simulated flights (never below 0.5 for a stated verdict; an uncertain
verdict's is the probability that one of the propellers it names lost thrust, at most 0.8;
``benchmarks/bench_confidence.py``, ``results/confidence.md``), and adds ``verdict.seen``, ``"load"`` in ``verdict.cause`` (healthy propellers, a moved or added
load explains the command pattern) and ``verdict.load`` (where the load sits and how much more the
motor toward it carries; null otherwise); within schema 7, the optional ``profile.configuration``: the
profile's load configuration the commands were weighed against (the nearest of two or more; null
for a profile of one configuration). Schema 8 decides from one posterior under a stated prior:
``confidence`` is the probability that this verdict is right, given the stated prior of damage,
measured on real and simulated flights; ``damaged`` now means "a rotor lost thrust" (why is
``cause``, a judgement of its own, with
``cause_probability``; ``"wash"`` added: something in the rotor's wash or under it), and adds
``verdict.headline`` (the first line every report prints), ``verdict.thrust`` (how much thrust each
named rotor gives, with its interval), ``verdict.p_damage`` and ``verdict.prior_damage``; the
``inspect`` advice now lists propeller, motor and ESC, and what sits under the rotor, one item each
in the order the cause makes likely.
:func:`flightlog_fd.report.motor_view.MotorView.from_doc` reads schema 3 and 4 documents too.
"""
from __future__ import annotations

import json
from typing import Any, Optional, Sequence, Union

import numpy as np

from .. import __version__
from ..advice import ADVICE_KINDS
from ..decision import CONFIDENCE_MEANING, HEADLINE_MAX, headline
from ..diagnose import Diagnosis
from .motor_view import MotorView

SCHEMA_VERSION = 8
#: The most rotors a frame the readers place can have (ArduPilot dodecahexa: 12).
MAX_ROTORS = 12
#: Decimals kept for probabilities and confidences (more is noise), and for times (1 ms).
PROB_DECIMALS = 4
TIME_DECIMALS = 3

_NUM = {"type": "number"}
_STR_OR_NULL = {"type": ["string", "null"]}
_NUM_OR_NULL = {"type": ["number", "null"]}
_PROB = {"type": "number", "minimum": 0, "maximum": 1}
_PAIR_OR_NULL = {"type": ["array", "null"], "items": _NUM_OR_NULL, "minItems": 2, "maxItems": 2}

JSON_SCHEMA: dict = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "fdlog diagnose report",
    "type": "object",
    "required": ["schema", "log", "autopilot", "frame", "model", "profile", "verdict", "motors",
                 "motor_columns", "motor_evidence", "windows", "warnings", "exit_code"],
    "properties": {
        "schema": {"const": SCHEMA_VERSION},
        "tool": {"type": "object", "required": ["name", "version"],
                 "properties": {"name": {"type": "string"}, "version": {"type": "string"}}},
        "log": {"type": "string"},
        "autopilot": _STR_OR_NULL,
        "firmware": _STR_OR_NULL,
        "vehicle_type": _STR_OR_NULL,
        "frame": _STR_OR_NULL,
        "duration_s": _NUM_OR_NULL,
        "airborne_s": _NUM_OR_NULL,
        "model": {"type": ["object", "null"], "required": ["path", "version", "sha256", "calibrated"],
                  "properties": {"path": _STR_OR_NULL, "version": {"type": "string"},
                                 "sha256": {"type": "string"}, "calibrated": {"type": "boolean"}}},
        "profile": {"type": ["object", "null"], "required": ["path", "model_path", "model_sha256", "sessions"],
                    "properties": {"path": _STR_OR_NULL, "model_path": _STR_OR_NULL,
                                   "model_sha256": _STR_OR_NULL, "sessions": {"type": "integer", "minimum": 1},
                                   "configuration": {
                                       "type": ["object", "null"], "required": ["name", "of", "load"],
                                       "properties": {"name": {"type": "string"}, "of": {"type": "integer", "minimum": 2},
                                                      "load": {"type": ["object", "null"],
                                                               "required": ["motor", "direction_deg", "size"],
                                                               "properties": {"motor": {"type": "integer", "minimum": 1,
                                                                                        "maximum": MAX_ROTORS},
                                                                              "direction_deg": {"type": "number"},
                                                                              "size": {"type": "number"}}}}}}},
        "verdict": {
            "type": "object",
            "required": ["status", "headline", "motor", "motors", "positions", "pair", "position", "thrust",
                         "confidence", "p_damage", "prior_damage", "first_seen", "reason", "advice", "cause",
                         "cause_probability", "cause_evidence", "seen", "load"],
            "properties": {
                "status": {"enum": ["healthy", "damaged", "stopped", "uncertain", "not_diagnosable"]},
                "headline": {"type": "string", "maxLength": HEADLINE_MAX},
                "thrust": {"type": "array", "maxItems": MAX_ROTORS, "items": {
                    "type": "object", "required": ["motor", "eta_hat", "eta_ci"],
                    "properties": {"motor": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS},
                                   "eta_hat": {"type": ["number", "null"], "minimum": 0},
                                   "eta_ci": {"type": ["array", "null"], "items": _PROB, "minItems": 2,
                                              "maxItems": 2}}}},
                "p_damage": {"type": ["number", "null"], "minimum": 0, "maximum": 1},
                "prior_damage": {"type": "number", "minimum": 0, "maximum": 1},
                "cause_probability": {"type": ["number", "null"], "minimum": 0, "maximum": 1},
                "motor": {"type": ["integer", "null"], "minimum": 1, "maximum": MAX_ROTORS},
                "motors": {"type": "array", "maxItems": MAX_ROTORS,
                           "items": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS}},
                "positions": {"type": "array", "maxItems": MAX_ROTORS, "items": _STR_OR_NULL},
                "pair": {"type": "boolean"},
                "position": _STR_OR_NULL,
                "confidence": {**_PROB, "description": CONFIDENCE_MEANING},
                "seen": {"type": ["boolean", "null"]},
                "first_seen": _NUM_OR_NULL,
                "reason": {"type": "string"},
                "cause": {"enum": ["propeller", "motor_or_esc", "wash", "load", None]},
                "load": {"type": ["object", "null"],
                         "required": ["motor", "position", "side", "direction_deg", "size", "llr", "words"],
                         "properties": {"motor": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS},
                                        "position": _STR_OR_NULL, "side": {"type": "string"},
                                        "direction_deg": _NUM, "size": _NUM, "llr": _NUM,
                                        "words": {"type": "string"}}},
                "cause_evidence": {"type": ["object", "null"],
                                   "required": ["motor", "llr", "rpm_per_command", "current_per_rpm2", "reason"],
                                   "properties": {"motor": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS},
                                                  "llr": _NUM_OR_NULL, "rpm_per_command": _NUM_OR_NULL,
                                                  "current_per_rpm2": _NUM_OR_NULL, "reason": {"type": "string"}}},
                "advice": {"type": "array", "items": {
                    "type": "object", "required": ["kind", "text", "motors", "command", "setting"],
                    "properties": {"kind": {"enum": list(ADVICE_KINDS)}, "text": {"type": "string"},
                                   "motors": {"type": "array", "items": {"type": "integer", "minimum": 1,
                                                                         "maximum": MAX_ROTORS}},
                                   "command": _STR_OR_NULL, "setting": _STR_OR_NULL}}},
            },
        },
        "evidence": {"type": ["object", "null"], "required": ["n_windows", "covered_s", "share", "abstained"],
                     "properties": {"n_windows": {"type": "integer", "minimum": 0}, "covered_s": _NUM,
                                    "share": {"type": "array", "items": _PROB, "minItems": 2,
                                              "maxItems": MAX_ROTORS + 1},
                                    "abstained": _PROB}},
        "motor_columns": {
            "type": "array",
            "items": {"type": "object", "required": ["key", "analyzer", "name", "label", "description", "abstained"],
                      "properties": {"key": {"type": "string"}, "analyzer": {"type": "string"},
                                     "name": {"type": "string"}, "label": {"type": "string"},
                                     "description": {"type": "string"}, "abstained": _STR_OR_NULL}},
        },
        "motors": {
            "type": "array", "maxItems": MAX_ROTORS,
            "items": {
                "type": "object",
                "required": ["motor", "position", "class", "model_vote", "command_share", "command_share_baseline",
                             "command_change", "eta_hat", "eta_ci", "effectiveness", "effectiveness_ci", "throttle",
                             "weight", "llr", "llr_by_source", "cells", "unavailable"],
                "properties": {
                    "motor": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS},
                    "position": _STR_OR_NULL,
                    "class": {"type": "string"},
                    "model_vote": {"type": ["number", "null"], "minimum": 0, "maximum": 1},
                    "command_share": _NUM_OR_NULL,
                    "command_share_baseline": _NUM_OR_NULL,
                    "command_change": _NUM_OR_NULL,
                    "eta_hat": _NUM_OR_NULL,
                    "eta_ci": _PAIR_OR_NULL,
                    "effectiveness": _NUM_OR_NULL,
                    "effectiveness_ci": _PAIR_OR_NULL,
                    "throttle": _NUM_OR_NULL,
                    "weight": {"type": ["number", "null"], "minimum": 0, "maximum": 1},
                    "llr": _NUM_OR_NULL,
                    "llr_by_source": {"type": ["object", "null"]},
                    "cells": {"type": "object"},
                    "unavailable": {"type": "object"},
                },
            },
        },
        "motor_evidence": {
            "type": ["object", "null"],
            "required": ["baseline", "throttle", "effectiveness", "airframe_changed"],
            "properties": {
                "baseline": {"enum": ["profile", "before onset", "neighbours"]},
                "throttle": _NUM_OR_NULL,
                "effectiveness": {"type": ["object", "null"],
                                  "required": ["informative", "reason", "seconds", "motor_lag_s", "r2"],
                                  "properties": {"informative": {"type": "boolean"}, "reason": {"type": "string"},
                                                 "seconds": _NUM, "motor_lag_s": _NUM,
                                                 "r2": {"type": "array", "items": _NUM, "minItems": 3, "maxItems": 3}}},
                "airframe_changed": _STR_OR_NULL,
                "decision": {"type": ["object", "null"],
                             "required": ["sources", "healthy_chi2", "share_sigma", "weights"],
                             "properties": {"sources": {"type": "array", "items": {"type": "string"}},
                                            "healthy_chi2": _NUM_OR_NULL, "share_sigma": _NUM_OR_NULL,
                                            "weights": {"type": "object"},
                                            "posterior": {"type": "object"}, "load_llr": _NUM_OR_NULL,
                                            "pair": {"type": ["object", "null"],
                                                     "required": ["motors", "llr", "llr_by_source", "eta_hat",
                                                                  "excess"],
                                                     "properties": {
                                                         "motors": {"type": "array", "minItems": 2, "maxItems": 2,
                                                                    "items": {"type": "integer", "minimum": 1,
                                                                              "maximum": MAX_ROTORS}},
                                                         "llr": _NUM_OR_NULL, "llr_by_source": {"type": "object"},
                                                         "eta_hat": _PAIR_OR_NULL, "excess": _NUM_OR_NULL}}}},
            },
        },
        "windows": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["t_start", "t_end", "class", "probabilities", "phase"],
                "properties": {
                    "t_start": _NUM,
                    "t_end": _NUM,
                    "class": {"type": "integer", "minimum": 0, "maximum": MAX_ROTORS},
                    "probabilities": {"type": "array", "items": _PROB, "minItems": 2, "maxItems": MAX_ROTORS + 1},
                    "phase": {"enum": ["hover", "climb", "descent", "manoeuvre", "unknown"]},
                    "smoothed_class": {"type": "integer", "minimum": -1, "maximum": MAX_ROTORS},
                },
            },
        },
        "analyzers": {
            "type": "array",
            "items": {"type": "object", "required": ["analyzer", "abstained", "notes", "findings"],
                      "properties": {
                          "analyzer": {"type": "string"}, "abstained": _STR_OR_NULL,
                          "notes": {"type": "array", "items": {"type": "string"}},
                          "findings": {"type": "array", "items": {
                              "type": "object",
                              "required": ["analyzer", "motor", "name", "value", "unit", "interval", "baseline",
                                           "direction", "llr", "text"],
                              "properties": {
                                  "analyzer": {"type": "string"},
                                  "motor": {"type": "integer", "minimum": 0, "maximum": MAX_ROTORS},
                                  "name": {"type": "string"}, "value": _NUM_OR_NULL, "unit": {"type": "string"},
                                  "interval": {"type": ["array", "null"], "items": _NUM_OR_NULL,
                                               "minItems": 2, "maxItems": 2},
                                  "baseline": _NUM_OR_NULL, "direction": {"enum": ["up", "down", ""]},
                                  "llr": _NUM_OR_NULL, "text": {"type": "string"}}}}}},
        },
        "stopped_motors": {
            "type": "array",
            "items": {"type": "object", "required": ["motor", "t_start", "t_end", "evidence", "source"],
                      "properties": {"motor": {"type": "integer", "minimum": 1, "maximum": MAX_ROTORS},
                                     "t_start": _NUM, "t_end": _NUM, "evidence": {"type": "string"},
                                     "source": {"type": "string"}}},
        },
        "warnings": {"type": "array", "items": {"type": "string"}},
        "exit_code": {"enum": [0, 1, 2]},
        "part": _STR_OR_NULL,
        "flights": {"type": "array"},  # items: this schema (set below)
    },
}
JSON_SCHEMA["properties"]["flights"]["items"] = JSON_SCHEMA


def _motor_evidence(d: Diagnosis) -> Optional[dict]:
    fit = d.share_fit
    if fit is None:
        return None
    return {"baseline": fit.baseline, "throttle": None if not np.isfinite(fit.throttle) else round(float(fit.throttle), 4),
            "effectiveness": None if fit.effectiveness is None else fit.effectiveness.as_dict(),
            "airframe_changed": None if d.decision is None else d.decision.airframe_changed,
            "decision": None if d.decision is None else {
                "sources": list(d.decision.sources),
                "healthy_chi2": None if d.decision.healthy_chi2 is None else round(float(d.decision.healthy_chi2), 3),
                "share_sigma": None if d.decision.share_sigma is None else round(float(d.decision.share_sigma), 4),
                "weights": {k: w.as_dict() for k, w in d.decision.weights.items()},
                "posterior": {h: round(float(x), 4) for h, x in d.decision.posterior.items()},
                "load_llr": None if d.decision.load_llr is None else round(float(d.decision.load_llr), 3),
                "pair": d.decision.pairs[0].as_dict() if d.decision.pairs else None}}


def _configuration(d: Diagnosis) -> Optional[dict]:
    """``profile.configuration``: the load configuration the commands were weighed against, or None."""
    c = getattr(d.share_fit, "configuration", None) if d.share_fit is not None else None
    if not c:
        return None
    load = c.get("load")
    return {"name": c["name"], "of": int(c["of"]),
            "load": None if not load else {"motor": int(load["motor"]), "direction_deg": float(load["direction_deg"]),
                                           "size": float(load["size"])}}


def to_dict(d: Diagnosis) -> dict:
    """The schema-8 object for one diagnosis (and, in ``flights``, each flight of its log)."""
    f, m, p, v = d.facts, d.model, d.profile, d.verdict
    ev = d.timeline if d.timeline is not None and d.timeline.shortfall is None else None
    return {
        "schema": SCHEMA_VERSION,
        "tool": {"name": "flightlog-fd", "version": __version__},
        "log": d.log,
        "autopilot": f.autopilot if f else None,
        "firmware": (f.firmware or None) if f else None,
        "vehicle_type": f.vehicle_type if f else None,
        "frame": f.frame if f else None,
        "duration_s": round(f.duration_s, TIME_DECIMALS) if f else None,
        "airborne_s": round(f.airborne_s, TIME_DECIMALS) if f else None,
        "model": None if m is None else {"path": m.path, "version": m.version, "sha256": m.sha256,
                                         "calibrated": m.calibrated},
        "profile": None if p is None else {"path": p.path, "model_path": p.model_path,
                                           "model_sha256": p.model_sha256, "sessions": p.sessions,
                                           "configuration": _configuration(d)},
        "verdict": {**v.as_dict(), "headline": v.headline or headline(v)},  # (a verdict made without one)
        "evidence": None if ev is None or ev.n_windows == 0 else {
            "n_windows": ev.n_windows, "covered_s": round(ev.covered_s, TIME_DECIMALS),
            "share": [round(x, PROB_DECIMALS) for x in ev.smoothed_share],
            "abstained": round(ev.abstained_share, PROB_DECIMALS)},
        **MotorView.of(d).to_json(),
        "motor_evidence": _motor_evidence(d),
        "windows": [{"t_start": round(w.t_start, TIME_DECIMALS), "t_end": round(w.t_end, TIME_DECIMALS),
                     "class": w.cls, "probabilities": [round(x, PROB_DECIMALS) for x in w.probabilities],
                     "phase": w.phase, "smoothed_class": w.label} for w in d.windows],
        "analyzers": [r.as_dict() for r in (d.decision.results if d.decision is not None else [])],
        "stopped_motors": [{"motor": int(x.motor), "t_start": round(float(x.t_start), TIME_DECIMALS),
                            "t_end": round(float(x.t_end), TIME_DECIMALS), "evidence": x.evidence,
                            "source": x.source} for x in d.stopped],
        "warnings": list(d.warnings),
        "exit_code": d.exit_code,
        "part": d.part or None,
        "flights": [to_dict(x) for x in d.flights],
    }


def render_json(diagnoses: Union[Diagnosis, Sequence[Diagnosis]], *, indent: int | None = 2) -> str:
    """One object for one diagnosis, an array for a sequence of them."""
    if isinstance(diagnoses, Diagnosis):
        doc: Any = to_dict(diagnoses)
    else:
        doc = [to_dict(d) for d in diagnoses]
    return json.dumps(doc, indent=indent, ensure_ascii=False)


_TYPES = {"object": dict, "array": list, "string": str, "boolean": bool, "null": type(None)}


def _type_ok(value: Any, name: str) -> bool:
    if name == "integer":
        return isinstance(value, int) and not isinstance(value, bool)
    if name == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    return isinstance(value, _TYPES[name])


def validate(doc: Any, schema: dict = JSON_SCHEMA, where: str = "$") -> list[str]:
    """Errors of ``doc`` against ``schema`` (empty when valid). Supports the keywords used in
    :data:`JSON_SCHEMA`: type, const, enum, required, properties, items, minItems, maxItems,
    minimum, maximum, maxLength."""
    errors: list[str] = []
    if "const" in schema and doc != schema["const"]:
        errors.append(f"{where}: expected {schema['const']!r}, got {doc!r}")
    if "enum" in schema and doc not in schema["enum"]:
        errors.append(f"{where}: {doc!r} not one of {schema['enum']}")
    if "type" in schema:
        names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(_type_ok(doc, n) for n in names):
            return errors + [f"{where}: expected {'/'.join(names)}, got {type(doc).__name__}"]
    if isinstance(doc, (int, float)) and not isinstance(doc, bool):
        if "minimum" in schema and doc < schema["minimum"]:
            errors.append(f"{where}: {doc} < minimum {schema['minimum']}")
        if "maximum" in schema and doc > schema["maximum"]:
            errors.append(f"{where}: {doc} > maximum {schema['maximum']}")
    if isinstance(doc, str) and "maxLength" in schema and len(doc) > schema["maxLength"]:
        errors.append(f"{where}: {len(doc)} characters > maxLength {schema['maxLength']}")
    if isinstance(doc, dict):
        errors += [f"{where}: missing {k!r}" for k in schema.get("required", []) if k not in doc]
        for k, sub in schema.get("properties", {}).items():
            if k in doc:
                errors += validate(doc[k], sub, f"{where}.{k}")
    if isinstance(doc, list):
        if "minItems" in schema and len(doc) < schema["minItems"]:
            errors.append(f"{where}: {len(doc)} items < {schema['minItems']}")
        if "maxItems" in schema and len(doc) > schema["maxItems"]:
            errors.append(f"{where}: {len(doc)} items > {schema['maxItems']}")
        if "items" in schema:
            for i, item in enumerate(doc):
                errors += validate(item, schema["items"], f"{where}[{i}]")
    return errors
