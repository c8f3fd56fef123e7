"""The calibration profile of one airframe: what it holds, its validation and its JSON file.

:class:`Profile` is a versioned JSON file (``"schema"``: ``PROFILE_SCHEMA``): airframe identity
(autopilot, frame name, firmware, vehicle_id, rotor count), the learned values (trailing
underscore: ``rho_``, ``rho_spread_``, ``hover_throttle_``, ``hover_s_``, ``n_hover_segments_``,
``n_windows_``, ``rho_source_``, the command-share baseline ``baseline_``, the calibration
sessions ``sessions_``, the load configurations ``configurations_``), each analyzer's
healthy baseline (``analyzers``), the streams' rates, the
:class:`~flightlog_fd.windows.FeatureSpec` with the per-channel statistics of the healthy
windows, the source logs (file name + sha256), creation time (UTC), tool version and an optional
``model`` entry (path of an ONNX file RELATIVE to the profile's folder + its sha256). Loading
validates everything and raises :class:`~flightlog_fd.errors.ProfileError` with a one-line message.

``rho_i = mean w_i / mean w_1`` is each motor's speed-proxy ratio to motor 1 in steady flight of
a HEALTHY flight (the paper's "adjusted simulation model"; a real quad never runs its motors
alike: CG offset, motor/ESC/propeller spread, yaw trim). Measuring it, and the rest of the
profile, is :mod:`flightlog_fd.calibration`'s work.

Load configurations: the payloads the airframe flies with. ``baseline_`` and ``sessions_`` are the
configuration it was first calibrated in (:data:`AS_CALIBRATED`); each ``configurations_`` entry
(``name``, ``load``: where it sits against AS_CALIBRATED, ``sessions_``, ``baseline_``, and its own
``analyzers`` baselines, e.g. the model votes') is a healthy flight with another payload added by
``fdlog calibrate --add`` (:func:`flightlog_fd.calibration.add_sessions`). The diagnosis weighs a
flight against the nearest one (:func:`flightlog_fd.analyzers.command_shares.nearest_configuration`),
with the airframe's drift from the AS_CALIBRATED sessions.

Limits: quadrotors, and hexa / octo frames laid out like the shipped n-rotor models' training
tables (rho and shares then have n entries; ``rotor_count`` in PROFILE_ROTOR_COUNTS); one
airframe per profile.
"""
from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePosixPath
from typing import Optional, Union

import numpy as np

from .errors import ProfileError
from .flight import Flight
from .util import file_sha256
from .windows import FeatureSpec

#: Profile file format version; :meth:`Profile.load` reads this one and the older ones in
#: ``READABLE_SCHEMAS`` (schema 1 has no ``baseline_``: it is derived from rho_; schema 2 has no
#: flight-to-flight ``baseline_.spread``: the decision model's default drift is used; schema 4 adds
#: ``lacks_`` and lets a profile from logs without motor outputs leave ``rho_``, ``rho_spread_``,
#: ``hover_throttle_`` and ``feature_spec`` null: it holds only the analyzers' baselines the logs
#: support, e.g. vibration; schema 5 adds ``baseline_.pin``: how well the calibration flights pin
#: each share, without it the diagnosed flight's own figure stands in; schema 6 adds ``sessions_``:
#: one entry per calibration session, without it the profile's flights are one session; schema 7 adds
#: ``configurations_``: the airframe's load configurations, without it the profile is one
#: configuration, "as calibrated").
PROFILE_SCHEMA = 7
READABLE_SCHEMAS = (1, 2, 3, 4, 5, 6, 7)
#: The name of the configuration the profile was first calibrated in (its ``baseline_`` and
#: ``sessions_``); the others are ``configurations_`` entries.
AS_CALIBRATED = "as calibrated"
#: Longest configuration name (it is shown in one-line reasons).
MAX_CONFIGURATION_NAME = 40
AUTOPILOTS = ("px4", "ardupilot", "sim")
#: Rotor counts a profile may describe: the quad and the frames with a shipped n-rotor model
#: (flightlog_fd.models.MODEL_FILES); an n-rotor frame must be laid out like a trained table
#: (checks.trained_layout).
PROFILE_ROTOR_COUNTS = (4, 6, 8)
#: Plausible range of a ratio: beyond it the motors are not running the same airframe's job.
RHO_MIN, RHO_MAX = 0.2, 5.0
_SHA256_RE = re.compile(r"^[0-9a-f]{64}$")
_REQUIRED_KEYS = ("schema", "autopilot", "frame", "rotor_count", "rho_", "rho_spread_", "hover_throttle_",
                  "feature_spec")
_OPTIONAL_KEYS = ("firmware", "vehicle_id", "hover_s_", "n_hover_segments_", "n_windows_", "stream_rates",
                  "source_logs", "created", "tool_version", "model", "extra", "rho_source_", "baseline_",
                  "analyzers", "lacks_", "sessions_", "configurations_", "prior_damage")

PathLike = Union[str, os.PathLike]


@dataclass
class Profile:
    """One airframe's calibration (see module docstring). Learned values end with ``_``."""

    autopilot: str
    frame: str
    rotor_count: int
    rho_: Optional[np.ndarray]  # None: the calibration logs had no motor outputs (``lacks_`` says so)
    rho_spread_: Optional[np.ndarray]
    hover_throttle_: Optional[float]
    feature_spec: Optional[dict]
    firmware: str = ""
    vehicle_id: Optional[str] = None
    hover_s_: float = 0.0
    n_hover_segments_: int = 0
    n_windows_: int = 0
    stream_rates: dict = field(default_factory=dict)
    source_logs: list = field(default_factory=list)
    created: str = ""
    tool_version: str = ""
    model: Optional[dict] = None
    extra: dict = field(default_factory=dict)
    rho_source_: str = "hover"
    baseline_: Optional[dict] = None
    #: Each analyzer's healthy baseline from the calibration flights ({analyzer id: dict}).
    analyzers: dict = field(default_factory=dict)
    #: What the calibration logs could not give, in plain words ([] for a full profile).
    lacks_: list = field(default_factory=list)
    #: One entry per calibration session (one flight, or flights the user grouped): its logs, its
    #: airborne-mean command shares, throttle, pinning and seconds (:func:`session_entry` in
    #: calibration). [] in a profile older than schema 6: its flights are one session.
    sessions_: list = field(default_factory=list)
    #: The airframe's other load configurations (a camera, a bigger battery, a payload): each
    #: ``{"name", "load", "created", "sessions_", "baseline_", "analyzers"}``, its own command-share
    #: baseline (and model-vote baseline, ``analyzers``) from its own sessions (:func:`~flightlog_fd.calibration.add_sessions` with a loaded flight).
    #: [] in a profile older than schema 7: one configuration, :data:`AS_CALIBRATED`.
    configurations_: list = field(default_factory=list)
    #: The fleet's own prior of damage for this airframe (P(a rotor lost thrust) per diagnosed
    #: flight, before its log is read), or None for the decision's (:data:`flightlog_fd.decision.PRIOR_DAMAGE`)
    prior_damage: Optional[float] = None
    schema: int = PROFILE_SCHEMA
    path: Optional[str] = field(default=None, repr=False, compare=False)  # where it was loaded/saved

    def __post_init__(self) -> None:
        if self.rho_ is not None:
            self.rho_ = np.asarray(self.rho_, dtype=np.float64).reshape(-1)
        if self.rho_spread_ is not None:
            self.rho_spread_ = np.asarray(self.rho_spread_, dtype=np.float64).reshape(-1)

    @property
    def measures_motors(self) -> bool:
        """False for a profile from logs without motor outputs (only analyzers' baselines such as
        vibration; no imbalance, command-share baseline, throttle or model statistics)."""
        return self.rho_ is not None
    # ------------------------------------------------------------------ conversion
    @property
    def spec(self) -> FeatureSpec:
        """The FeatureSpec (with the healthy windows' statistics)."""
        return FeatureSpec.from_dict(self.feature_spec)

    def to_dict(self) -> dict:
        return {
            "schema": self.schema,
            "autopilot": self.autopilot,
            "frame": self.frame,
            "rotor_count": int(self.rotor_count),
            "firmware": self.firmware,
            "vehicle_id": self.vehicle_id,
            "rho_": None if self.rho_ is None else [float(x) for x in self.rho_],
            "rho_spread_": None if self.rho_spread_ is None else [float(x) for x in self.rho_spread_],
            "hover_throttle_": None if self.hover_throttle_ is None else float(self.hover_throttle_),
            "hover_s_": float(self.hover_s_),
            "n_hover_segments_": int(self.n_hover_segments_),
            "n_windows_": int(self.n_windows_),
            "stream_rates": {k: float(v) for k, v in self.stream_rates.items()},
            "feature_spec": self.feature_spec,
            "source_logs": list(self.source_logs),
            "created": self.created,
            "tool_version": self.tool_version,
            "model": self.model,
            "extra": self.extra,
            "rho_source_": self.rho_source_,
            "baseline_": self.baseline_,
            "analyzers": self.analyzers,
            "lacks_": list(self.lacks_),
            "sessions_": list(self.sessions_),
            "configurations_": list(self.configurations_),
            "prior_damage": self.prior_damage,
        }

    def fit_analyzers(self, flights, model, sessions=None, adapted_on: bool = False) -> None:
        """Fit every registered analyzer's healthy baseline on the calibration ``flights`` with
        the profile's ``model`` (the adapted one, or the shipped one with --no-adapt); the model
        votes' per session (``sessions``: the flights' indices grouped as ``sessions_``; default
        one per flight; ``adapted_on``: the model was adapted on these flights)."""
        from .analyzers import REGISTRY, fit_baselines
        from .analyzers.model_votes import ModelVotes, combine_sessions

        votes = [a for a in REGISTRY if isinstance(a, ModelVotes)]
        self.analyzers = fit_baselines(flights, model, [a for a in REGISTRY if not isinstance(a, ModelVotes)])
        groups = sessions if sessions is not None else [[i] for i in range(len(flights))]
        for a in votes:
            each = [a.fit_baseline([flights[i] for i in g], model) for g in groups]
            combined = combine_sessions(each, [adapted_on] * len(each))
            if combined is not None:
                self.analyzers = {a.id: combined, **self.analyzers}

    @property
    def n_sessions(self) -> int:
        """Calibration sessions the profile holds (a profile older than schema 6 is one)."""
        return max(len(self.sessions_), 1)

    def session_figures(self):
        """The sessions' figures (:class:`~flightlog_fd.analyzers.session_drift.SessionFigures`) the
        airframe's own drift is learned from, or None with fewer than two sessions."""
        from .analyzers.session_drift import SessionFigures

        if len(self.sessions_) < 2:
            return None
        n = self.rotor_count
        pins = [s.get("pin") if s.get("pin") is not None else [float("nan")] * n for s in self.sessions_]
        return SessionFigures(shares=[s["share"] for s in self.sessions_],
                              throttles=[s["throttle"] for s in self.sessions_], pins=pins)

    def configuration_names(self) -> list[str]:
        """The airframe's configurations: :data:`AS_CALIBRATED` first, then the added ones."""
        return [AS_CALIBRATED] + [str(c["name"]) for c in self.configurations_]

    def configuration(self, name: str) -> Optional[dict]:
        """The ``configurations_`` entry called ``name`` (None for AS_CALIBRATED or an unknown name)."""
        return next((c for c in self.configurations_ if c.get("name") == name), None)

    def baselines(self) -> list[tuple[str, Optional[dict], object, dict]]:
        """(name, load or None, :class:`~flightlog_fd.analyzers.share_fit.Baseline`, analyzer
        baselines of its own ({} for AS_CALIBRATED, whose are ``analyzers``)) of every
        configuration, AS_CALIBRATED first; [] for a profile without motor figures. A load
        configuration's baseline is its own shares, throttle, slope and pinning, weighed with the
        airframe's drift (the AS_CALIBRATED sessions': how far a session moves is the airframe's,
        not the payload's)."""
        first = self.baseline()
        if first is None:
            return []
        out = [(AS_CALIBRATED, None, first, {})]
        for c in self.configurations_:
            b = c["baseline_"]
            out.append((str(c["name"]), c.get("load"), replace(
                first, share=np.asarray(b["share"], float), slope=np.asarray(b["slope"], float),
                throttle_ref=float(b["throttle_ref"]), source=f"configuration {c['name']!r}",
                pin=None if b.get("pin") is None else np.asarray(b["pin"], float),
                throttle_range=_range(b.get("throttle_range"))), dict(c.get("analyzers") or {})))
        return out

    def baseline(self):
        """The healthy command-share baseline of the configuration the profile was calibrated in
        (:class:`~flightlog_fd.analyzers.share_fit.Baseline`); a
        schema-1 profile has none recorded, so it is derived from rho_ at the hover throttle; None
        for a profile without motor figures."""
        from .analyzers.share_fit import Baseline

        b = self.baseline_
        if not b and self.rho_ is None:
            return None
        if b:
            spread = b.get("spread")
            return Baseline(share=np.asarray(b["share"], float), slope=np.asarray(b["slope"], float),
                            throttle_ref=float(b["throttle_ref"]), source=str(b.get("source", "")),
                            spread=None if spread is None else np.asarray(spread, float),
                            throttle_spread=b.get("throttle_spread"), n_flights=int(b.get("n_flights", 1)),
                            pin=None if b.get("pin") is None else np.asarray(b["pin"], float),
                            throttle_range=_range(b.get("throttle_range")),
                            sessions=self.session_figures(), n_sessions=len(self.sessions_))
        share = self.rho_ ** 2
        return Baseline(share=share / share.mean(), slope=np.zeros(len(share)), throttle_ref=float(self.hover_throttle_),
                        source="from rho_ (schema 1 profile)")

    @classmethod
    def from_dict(cls, d, path: Optional[PathLike] = None) -> "Profile":
        """Validate a parsed profile; raises ProfileError(path, one-line reason)."""
        def bad(msg: str) -> ProfileError:
            return ProfileError(path, f"invalid profile: {msg}")

        if not isinstance(d, dict):
            raise bad("the file does not hold a JSON object")
        if "schema" not in d:
            raise bad('not an fdlog profile (no "schema" key)')
        if d["schema"] not in READABLE_SCHEMAS:
            raise ProfileError(path, f"profile schema {d['schema']!r} is not supported (this fdlog reads schemas "
                                     f"{', '.join(map(str, READABLE_SCHEMAS))}); recalibrate with this version")
        missing = [k for k in _REQUIRED_KEYS if k not in d]
        if missing:
            raise bad(f"missing key(s) {', '.join(missing)}")
        unknown = sorted(set(d) - set(_REQUIRED_KEYS) - set(_OPTIONAL_KEYS))
        if unknown:
            raise bad(f"unknown key(s) {', '.join(unknown)}")
        if d["autopilot"] not in AUTOPILOTS:
            raise bad(f"autopilot must be one of {', '.join(AUTOPILOTS)}, not {d['autopilot']!r}")
        if not isinstance(d["frame"], str) or not d["frame"]:
            raise bad("frame must be a non-empty name such as 'quad_x'")
        n = d["rotor_count"]
        if not isinstance(n, int) or isinstance(n, bool) or n not in PROFILE_ROTOR_COUNTS:
            raise bad(f"rotor_count must be one of {', '.join(map(str, PROFILE_ROTOR_COUNTS))}, not {n!r}")
        lacks = d.get("lacks_", [])
        if not isinstance(lacks, list) or not all(isinstance(x, str) for x in lacks):
            raise bad("lacks_ must be a list of strings")
        prior = d.get("prior_damage")
        if prior is not None and (isinstance(prior, bool) or not isinstance(prior, (int, float))
                                  or not 0.0 < float(prior) < 1.0):
            raise bad(f"prior_damage must be null or a probability strictly between 0 and 1, not {prior!r}")
        motorless = [k for k in ("rho_", "rho_spread_", "hover_throttle_", "feature_spec") if d[k] is None]
        if motorless:
            if len(motorless) != 4 or not lacks or d.get("baseline_") is not None or d.get("model") is not None:
                raise bad("a profile without motor figures (rho_, rho_spread_, hover_throttle_, feature_spec "
                          "all null) must say what its logs lack (lacks_) and have no baseline_ or model")
            return cls._motorless(d, path, bad)
        rho = _number_list(d["rho_"], n, "rho_", bad)
        if not all(RHO_MIN <= x <= RHO_MAX for x in rho):
            raise bad(f"rho_ values must be within {RHO_MIN}..{RHO_MAX}, got {rho}")
        if abs(rho[0] - 1.0) > 1e-6:
            raise bad(f"rho_[0] must be 1 (motor 1 is the reference), got {rho[0]}")
        spread = _number_list(d["rho_spread_"], n, "rho_spread_", bad)
        if any(x < 0 for x in spread):
            raise bad("rho_spread_ values must be >= 0")
        thr = d["hover_throttle_"]
        if not _is_number(thr) or not 0.0 < thr <= 1.5:
            raise bad(f"hover_throttle_ must be a number in (0, 1.5], not {thr!r}")
        try:
            FeatureSpec.from_dict(d["feature_spec"])
        except ValueError as e:
            raise bad(f"feature_spec: {e}") from None
        model = d.get("model")
        if model is not None:
            if not isinstance(model, dict) or not isinstance(model.get("path"), str) or not model["path"]:
                raise bad('model must be null or {"path": ..., "sha256": ...}')
            mp = PurePosixPath(model["path"].replace("\\", "/"))
            if mp.is_absolute() or ".." in mp.parts or re.match(r"^[A-Za-z]:", model["path"]):
                raise bad(f"model path must be relative to the profile's folder, not {model['path']!r}")
            if not isinstance(model.get("sha256"), str) or not _SHA256_RE.match(model["sha256"]):
                raise bad("model sha256 must be 64 lowercase hex digits")
        logs = d.get("source_logs", [])
        if not isinstance(logs, list) or not all(isinstance(x, dict) and isinstance(x.get("name"), str)
                                                 for x in logs):
            raise bad('source_logs must be a list of {"name": ..., "sha256": ...}')
        rates = d.get("stream_rates", {})
        an = d.get("analyzers", {})
        if not isinstance(an, dict) or not all(isinstance(v, dict) for v in an.values()):
            raise bad("analyzers must map analyzer ids to objects")
        if not isinstance(rates, dict) or not all(_is_number(v) for v in rates.values()):
            raise bad("stream_rates must map stream names to rates in Hz")
        base = d.get("baseline_")
        if base is not None:
            if not isinstance(base, dict):
                raise bad("baseline_ must be null or an object")
            _check_baseline(base, n, "baseline_", bad)
        _check_sessions(d.get("sessions_"), n, bad)
        _check_configurations(d.get("configurations_"), n, bad)
        if "rho_source_" in d and d["rho_source_"] not in ("hover", "steady flight", "airborne mean"):
            raise bad(f"rho_source_ must be hover, steady flight or airborne mean, not {d['rho_source_']!r}")
        kw = {k: d[k] for k in _REQUIRED_KEYS + _OPTIONAL_KEYS if k in d}
        kw["schema"] = PROFILE_SCHEMA
        kw["hover_throttle_"] = float(thr)
        if kw.get("sessions_") is None:
            kw["sessions_"] = []
        if kw.get("configurations_") is None:
            kw["configurations_"] = []
        for k in ("hover_s_",):
            if k in kw and not _is_number(kw[k]):
                raise bad(f"{k} must be a number")
        for k in ("n_hover_segments_", "n_windows_"):
            if k in kw and (not isinstance(kw[k], int) or kw[k] < 0):
                raise bad(f"{k} must be a non-negative integer")
        if kw.get("extra") is None:
            kw["extra"] = {}
        if kw.get("stream_rates") is None:
            kw["stream_rates"] = {}
        if kw.get("source_logs") is None:
            kw["source_logs"] = []
        return cls(**kw, path=str(path) if path is not None else None)

    @classmethod
    def _motorless(cls, d: dict, path, bad) -> "Profile":
        """A validated profile from logs without motor outputs (only analyzers' baselines)."""
        an = d.get("analyzers", {})
        if not isinstance(an, dict) or not an or not all(isinstance(v, dict) for v in an.values()):
            raise bad("a profile without motor figures needs at least one analyzer baseline")
        kw = {k: d[k] for k in _REQUIRED_KEYS + _OPTIONAL_KEYS if k in d}
        kw["schema"] = PROFILE_SCHEMA
        if d.get("sessions_"):
            raise bad("a profile without motor figures has no command-share sessions (sessions_ must be [] or null)")
        if d.get("configurations_"):
            raise bad("a profile without motor figures has no load configurations (configurations_ must be [] or null)")
        for k, empty in (("extra", {}), ("stream_rates", {}), ("source_logs", []), ("sessions_", []),
                         ("configurations_", [])):
            if kw.get(k) is None:
                kw[k] = empty
        return cls(**kw, path=str(path) if path is not None else None)

    # ------------------------------------------------------------------ files
    def save(self, path: PathLike, overwrite: bool = False) -> Path:
        """Write the profile as JSON. Refuses to replace an existing file unless ``overwrite``."""
        p = Path(path)
        if p.exists() and not overwrite:
            raise ProfileError(p, "already exists; not overwriting it (use --force / overwrite=True to replace it)")
        if p.is_dir():
            raise ProfileError(p, "is a folder; give a file name such as profile.json")
        text = json.dumps(self.to_dict(), indent=2, sort_keys=False) + "\n"
        try:
            tmp = p.with_name(p.name + ".tmp")
            tmp.write_text(text, encoding="utf-8")
            os.replace(tmp, p)  # atomic: a crash never leaves half a profile
        except OSError as e:
            raise ProfileError(p, f"cannot write: {e.strerror or e}") from None
        self.path = str(p)
        return p

    @classmethod
    def load(cls, path: PathLike) -> "Profile":
        """Read and validate a profile file (ProfileError on any problem)."""
        p = Path(path)
        if not p.exists():
            raise ProfileError(p, "no such profile file")
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ProfileError(p, f"cannot read profile: {getattr(e, 'strerror', None) or e}") from None
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise ProfileError(p, f"not a JSON profile (line {e.lineno}: {e.msg})") from None
        return cls.from_dict(d, path=p)

    # ------------------------------------------------------------------ model entry
    def set_model(self, model_file: PathLike, profile_path: Optional[PathLike] = None) -> None:
        """Point ``model`` at ``model_file`` (must be in the profile's folder or below it)."""
        base = Path(profile_path or self.path or ".").resolve().parent
        mf = Path(model_file).resolve()
        try:
            rel = mf.relative_to(base)
        except ValueError:
            raise ProfileError(model_file, f"the model must be stored next to the profile (in {base})") from None
        self.model = {"path": rel.as_posix(), "sha256": file_sha256(mf)}

    def model_path(self, verify: bool = True) -> Optional[Path]:
        """Absolute path of the profile's model (None if it has none); checks the sha256."""
        if self.model is None:
            return None
        base = Path(self.path).resolve().parent if self.path else Path.cwd()
        mp = base / self.model["path"]
        if not mp.exists():
            raise ProfileError(self.path, f"its model file {self.model['path']} is missing (looked in {base})")
        if verify and file_sha256(mp) != self.model["sha256"]:
            raise ProfileError(self.path, f"its model file {self.model['path']} has changed since calibration "
                                          "(sha256 mismatch); recalibrate or restore the file")
        return mp

    # ------------------------------------------------------------------ checks
    def check_compatible(self, flight: Flight) -> list[str]:
        """Raise ProfileError if ``flight`` is from another kind of airframe; return warnings
        (a different vehicle id or firmware) for the user."""
        frame = flight.frame.name if flight.frame is not None else "unknown"
        rotors = flight.frame.rotor_count if flight.frame is not None else (
            flight.motors.values.shape[1] if flight.motors is not None else 0)
        if flight.autopilot != self.autopilot or frame != self.frame or (rotors and rotors != self.rotor_count):
            raise ProfileError(flight.path, f"profile was made for {self.autopilot} {self.frame}, this log is "
                                            f"{flight.autopilot} {frame}" + (f" ({rotors} rotors)" if rotors != 4 else ""))
        warnings = []
        if self.vehicle_id and flight.vehicle_id and flight.vehicle_id != self.vehicle_id:
            warnings.append(f"profile was made on vehicle {self.vehicle_id}, this log is from {flight.vehicle_id}")
        if self.firmware and flight.firmware and flight.firmware != self.firmware:
            warnings.append(f"profile was made with firmware {self.firmware}, this log has {flight.firmware}")
        return warnings


def _range(v) -> Optional[tuple[float, float]]:
    """A (lo, hi) throttle range from a profile entry, or None."""
    if isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_number(x) for x in v) and v[0] <= v[1]:
        return float(v[0]), float(v[1])
    return None


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _number_list(v, n: int, name: str, bad) -> list[float]:
    if not isinstance(v, list) or len(v) != n or not all(_is_number(x) for x in v):
        raise bad(f"{name} must be a list of {n} finite numbers")
    return [float(x) for x in v]


def _check_sessions(v, n: int, bad) -> None:
    """Validate ``sessions_`` (null, or a list of session objects for an n-rotor profile)."""
    if v is None:
        return
    if not isinstance(v, list):
        raise bad("sessions_ must be a list of session objects")
    for i, sess in enumerate(v, 1):
        where = f"sessions_[{i}]"
        if not isinstance(sess, dict):
            raise bad(f"{where} must be an object")
        share = _number_list(sess.get("share"), n, f"{where}.share", bad)
        if not all(0.0 < x < 4.0 for x in share):
            raise bad(f"{where}.share values must be within 0..4, got {share}")
        thr = sess.get("throttle")
        if not _is_number(thr) or not 0.0 < thr <= 1.5:
            raise bad(f"{where}.throttle must be a number in (0, 1.5]")
        if sess.get("pin") is not None and any(x < 0 for x in _number_list(sess["pin"], n, f"{where}.pin", bad)):
            raise bad(f"{where}.pin values must be >= 0")
        if not _is_number(sess.get("seconds", 0.0)) or sess.get("seconds", 0.0) < 0:
            raise bad(f"{where}.seconds must be a number >= 0")
        logs = sess.get("logs", [])
        if not isinstance(logs, list) or not all(isinstance(x, dict) and isinstance(x.get("name"), str) for x in logs):
            raise bad(f'{where}.logs must be a list of {{"name": ..., "sha256": ...}}')


def _check_baseline(base: dict, n: int, where: str, bad) -> None:
    """Validate a command-share baseline object (the profile's ``baseline_`` or a configuration's)
    of an n-rotor profile; ``where`` names it in the error."""
    share = _number_list(base.get("share"), n, f"{where}.share", bad)
    _number_list(base.get("slope"), n, f"{where}.slope", bad)
    if not all(0.0 < x < 4.0 for x in share):
        raise bad(f"{where}.share values must be within 0..4, got {share}")
    if not _is_number(base.get("throttle_ref")) or not 0.0 < base["throttle_ref"] <= 1.5:
        raise bad(f"{where}.throttle_ref must be a number in (0, 1.5]")
    for key in ("spread", "pin"):
        if base.get(key) is not None and any(x < 0 for x in _number_list(base[key], n, f"{where}.{key}", bad)):
            raise bad(f"{where}.{key} values must be >= 0")
    ts = base.get("throttle_spread")
    if ts is not None and (not _is_number(ts) or ts < 0):
        raise bad(f"{where}.throttle_spread must be null or a number >= 0")


def _check_configurations(v, n: int, bad) -> None:
    """Validate ``configurations_`` (null, or a list of load configurations of an n-rotor profile)."""
    if v is None:
        return
    if not isinstance(v, list):
        raise bad("configurations_ must be a list of configuration objects")
    names = {AS_CALIBRATED}
    for i, c in enumerate(v, 1):
        where = f"configurations_[{i}]"
        if not isinstance(c, dict):
            raise bad(f"{where} must be an object")
        name = c.get("name")
        if not isinstance(name, str) or not name.strip() or len(name) > MAX_CONFIGURATION_NAME:
            raise bad(f"{where}.name must be a non-empty name of at most {MAX_CONFIGURATION_NAME} characters")
        if name in names:
            raise bad(f"{where}.name {name!r} is used twice (or is the reserved {AS_CALIBRATED!r})")
        names.add(name)
        load = c.get("load")
        if load is not None:
            if not isinstance(load, dict) or not isinstance(load.get("motor"), int) or not 1 <= load["motor"] <= n \
                    or not _is_number(load.get("direction_deg")) or not _is_number(load.get("size")):
                raise bad(f"{where}.load must be null or {{\"motor\": 1..{n}, \"direction_deg\": ..., \"size\": ...}}")
        sessions = c.get("sessions_")
        if not isinstance(sessions, list) or not sessions:
            raise bad(f"{where}.sessions_ must list its calibration sessions (at least one)")
        _check_sessions(sessions, n, lambda m: bad(f"{where}.{m}"))
        an = c.get("analyzers", {})
        if not isinstance(an, dict) or not all(isinstance(x, dict) for x in an.values()):
            raise bad(f"{where}.analyzers must map analyzer ids to objects")
        base = c.get("baseline_")
        if not isinstance(base, dict):
            raise bad(f"{where}.baseline_ must be an object")
        _check_baseline(base, n, f"{where}.baseline_", bad)
