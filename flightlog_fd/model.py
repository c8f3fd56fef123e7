"""A trained fault classifier in an ONNX file, run with onnxruntime (no torch needed).

The file (written by ``training/export.py``) holds one graph:

    input  "windows"        (N, C, T) float32, ALREADY standardised per channel
    output "probabilities"  (N, n+1)  float32, softmax over the classes (healthy, motor 1..n), rows sum to 1

and one ONNX metadata_props entry, key METADATA_KEY ("flightlog_fd"), whose value is a JSON
object:

    version       str   who/what made the model, e.g. "default-1"
    feature_spec  dict  FeatureSpec.to_dict() of flightlog_fd.windows: features (nif|cf),
                        rate_hz, window, stride, channels (C names, in input order),
                        transform, ..., and the per-channel standardisation "mean"/"std"
    classes       list  ["healthy", "motor1", "motor2", "motor3", "motor4"] (output order; an
                        n-rotor model lists healthy, motor1 .. motorn)
    rotor_count   int   optional: the rotor count the model diagnoses (n-rotor models carry it,
                        with "frames", the simulator frames it was trained on); else the
                        feature spec's n_motors, else 4
    training      dict  free-form summary (data, epochs, seed, lam, accuracy...)
    created       str   ISO-8601 UTC time of export
    temperature   float optional, > 0: confidence calibration of the shipped model (temperature
                        scaling fitted on held-out simulated flights, training/build_default.py):
                        probabilities become p_k^(1/T) / sum, i.e. softmax(logits / T); 1 if absent.
    logit_bias    list  optional, one number per class: decision offsets added to the log
                        probabilities before renormalising (p_k * exp(b_k) / sum). `fdlog
                        calibrate` sets them from the calibration flight's healthy windows so
                        that this airframe's own healthy flight is called healthy (see
                        training/adapt.py); absent or zero for the shipped model.

:class:`FaultModel` loads such a file, checks that the metadata is complete and agrees with the
graph's input/output shapes (ModelError otherwise, naming the file), standardises raw windows
with the stored mean/std and returns class probabilities, ``INFERENCE_BATCH`` windows per run.
onnxruntime runs on the CPU provider with at most ``INTRA_OP_THREADS`` threads (the tool may run
several diagnoses in parallel processes).

:func:`model_for_flight` swaps the shipped quad model for the shipped model of the flight's
rotor count (``flightlog_fd.models.MODEL_FILES``: 6 hexa, 8 octo); any other model is kept.

Limits: only the CPU execution provider; the batch axis must be dynamic (fixed-batch files are
refused); this module must not import torch (``fdlog diagnose`` installs without it).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Optional

import numpy as np

from .errors import ModelError
from .util import file_sha256  # noqa: F401  (re-exported: tests and callers use model.file_sha256)

METADATA_KEY = "flightlog_fd"
CLASSES = ("healthy", "motor1", "motor2", "motor3", "motor4")
INPUT_NAME = "windows"
OUTPUT_NAME = "probabilities"
INTRA_OP_THREADS = 1  # per session; parallelism comes from diagnosing logs in separate processes
INFERENCE_BATCH = 1024  # windows per onnxruntime run: bounds memory for long logs
REQUIRED_METADATA = ("version", "feature_spec", "classes", "training", "created")


def _finite_numbers(values: Any, n: int) -> Optional[np.ndarray]:
    """``values`` as a float64 array of length n if it is a list of n finite numbers, else None."""
    if not isinstance(values, (list, tuple)) or len(values) != n:
        return None
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return None
    arr = np.asarray(values, dtype=np.float64)
    return arr if np.all(np.isfinite(arr)) else None


def validate_metadata(meta: Any, path: Any = None) -> dict:
    """Check a decoded metadata object; return it, or raise ModelError saying what is wrong.

    Shared by the exporter (so a bad file is never written) and the loader.
    """
    if not isinstance(meta, dict):
        raise ModelError(path, f"model metadata must be a JSON object, not {type(meta).__name__}")
    missing = [k for k in REQUIRED_METADATA if k not in meta]
    if missing:
        raise ModelError(path, f"model metadata lacks {', '.join(missing)}")
    if not isinstance(meta["version"], str) or not meta["version"]:
        raise ModelError(path, "model metadata 'version' must be a non-empty string")
    if not isinstance(meta["training"], dict):
        raise ModelError(path, "model metadata 'training' must be an object")
    classes = meta["classes"]
    if not isinstance(classes, list) or not classes or not all(isinstance(c, str) for c in classes):
        raise ModelError(path, "model metadata 'classes' must be a list of names")
    spec = meta["feature_spec"]
    if not isinstance(spec, dict):
        raise ModelError(path, "model metadata 'feature_spec' must be an object")
    channels = spec.get("channels")
    if not isinstance(channels, list) or not channels or not all(isinstance(c, str) for c in channels):
        raise ModelError(path, "feature_spec 'channels' must be a non-empty list of names")
    window = spec.get("window")
    if not isinstance(window, int) or isinstance(window, bool) or window < 1:
        raise ModelError(path, "feature_spec 'window' must be a positive integer")
    rate = spec.get("rate_hz")
    if not isinstance(rate, (int, float)) or isinstance(rate, bool) or not rate > 0:
        raise ModelError(path, "feature_spec 'rate_hz' must be a positive number")
    mean = _finite_numbers(spec.get("mean"), len(channels))
    std = _finite_numbers(spec.get("std"), len(channels))
    if mean is None or std is None:
        raise ModelError(path, f"feature_spec needs 'mean' and 'std' as {len(channels)} finite numbers each")
    if np.any(std <= 0):
        raise ModelError(path, "feature_spec 'std' must be positive")
    if "temperature" in meta and not (isinstance(meta["temperature"], (int, float))
                                      and not isinstance(meta["temperature"], bool)
                                      and math.isfinite(meta["temperature"]) and meta["temperature"] > 0):
        raise ModelError(path, "model metadata 'temperature' must be a positive number")
    if "logit_bias" in meta and _finite_numbers(meta["logit_bias"], len(classes)) is None:
        raise ModelError(path, f"model metadata 'logit_bias' must be {len(classes)} finite numbers")
    return meta


def _dims(value_info) -> list:
    """Shape of an onnxruntime NodeArg: ints for fixed axes, str/None for dynamic ones."""
    return list(value_info.shape)


class FaultModel:
    """An ONNX fault classifier with its feature spec; see the module docstring."""

    def __init__(self, path):
        self._path = Path(path)
        if self._path.is_dir():
            raise ModelError(self._path, "is a folder, not a model file")
        if not self._path.is_file():
            raise ModelError(self._path, "model file not found")
        # Imported here so that `import flightlog_fd.model` stays cheap for commands not diagnosing.
        import onnxruntime as ort

        options = ort.SessionOptions()
        options.intra_op_num_threads = INTRA_OP_THREADS
        options.inter_op_num_threads = 1
        options.log_severity_level = 3  # errors only: no warnings on stderr for the user
        try:
            self._session = ort.InferenceSession(
                str(self._path), sess_options=options, providers=["CPUExecutionProvider"]
            )
        except Exception as e:  # onnxruntime raises its own Fail/InvalidProtobuf/... types
            first_line = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise ModelError(self._path, f"not a readable ONNX model ({first_line[:200]})") from None
        raw = self._session.get_modelmeta().custom_metadata_map.get(METADATA_KEY)
        if raw is None:
            raise ModelError(self._path, f"ONNX file has no '{METADATA_KEY}' metadata (not a flightlog-fd model)")
        try:
            meta = json.loads(raw)
        except json.JSONDecodeError as e:
            raise ModelError(self._path, f"'{METADATA_KEY}' metadata is not valid JSON ({e.msg})") from None
        self._metadata = validate_metadata(meta, self._path)
        spec = self._metadata["feature_spec"]
        self._mean = np.asarray(spec["mean"], dtype=np.float32)
        self._std = np.asarray(spec["std"], dtype=np.float32)
        self._check_graph()
        self._sha256 = file_sha256(self._path)

    def _check_graph(self) -> None:
        """The graph's input/output must be the documented ones and agree with the metadata."""
        inputs, outputs = self._session.get_inputs(), self._session.get_outputs()
        if len(inputs) != 1 or inputs[0].name != INPUT_NAME:
            raise ModelError(self._path, f"model must have one input named '{INPUT_NAME}'")
        if OUTPUT_NAME not in [o.name for o in outputs]:
            raise ModelError(self._path, f"model has no output named '{OUTPUT_NAME}'")
        in_dims = _dims(inputs[0])
        expected = [self.n_channels, self.window]
        if len(in_dims) != 3 or in_dims[1:] != expected:
            raise ModelError(
                self._path, f"model input is {in_dims}, metadata says (N, {expected[0]}, {expected[1]})"
            )
        if isinstance(in_dims[0], int) and in_dims[0] > 0:
            raise ModelError(self._path, f"model input has a fixed batch of {in_dims[0]}; it must be dynamic")
        out_dims = _dims(next(o for o in outputs if o.name == OUTPUT_NAME))
        if len(out_dims) != 2 or out_dims[1] != len(self.classes):
            raise ModelError(
                self._path, f"model output is {out_dims}, metadata lists {len(self.classes)} classes"
            )

    # --- metadata -------------------------------------------------------------------------
    @property
    def path(self) -> Path:
        return self._path

    @property
    def sha256(self) -> str:
        return self._sha256

    @property
    def metadata(self) -> dict:
        """The whole decoded metadata object (a copy: callers cannot alter the model)."""
        return json.loads(json.dumps(self._metadata))

    @property
    def feature_spec(self) -> dict:
        """FeatureSpec.to_dict() the windows must be built with (includes mean/std)."""
        return json.loads(json.dumps(self._metadata["feature_spec"]))

    @property
    def classes(self) -> list[str]:
        return list(self._metadata["classes"])

    @property
    def version(self) -> str:
        return self._metadata["version"]

    @property
    def training(self) -> dict:
        return json.loads(json.dumps(self._metadata["training"]))

    @property
    def created(self) -> str:
        return str(self._metadata["created"])

    @property
    def rotor_count(self) -> int:
        """Rotors the model diagnoses: metadata rotor_count, else the spec's n_motors, else 4."""
        return model_rotor_count(self._metadata)

    @property
    def n_channels(self) -> int:
        return len(self._metadata["feature_spec"]["channels"])

    @property
    def window(self) -> int:
        return int(self._metadata["feature_spec"]["window"])

    # --- inference ------------------------------------------------------------------------
    def _check_windows(self, X: np.ndarray) -> None:
        if X.ndim != 3 or X.shape[1:] != (self.n_channels, self.window):
            raise ModelError(
                self._path, f"model expects windows (N, {self.n_channels}, {self.window}), got {X.shape}"
            )

    def standardise(self, X: np.ndarray) -> np.ndarray:
        """Raw windows (N, C, T) -> (X - mean) / std per channel, float32, as the model was trained."""
        X = np.asarray(X, dtype=np.float32)
        self._check_windows(X)
        return (X - self._mean[None, :, None]) / self._std[None, :, None]

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """Standardised windows (N, C, T) -> probabilities (N, n_classes) float32; (0, n) for none."""
        X = np.ascontiguousarray(X, dtype=np.float32)
        if X.ndim == 3 and X.shape[0] == 0:
            return np.zeros((0, len(self.classes)), dtype=np.float32)
        self._check_windows(X)
        if not np.all(np.isfinite(X)):
            raise ModelError(self._path, "windows hold NaN or infinite values")
        parts = [
            self._session.run([OUTPUT_NAME], {INPUT_NAME: X[first : first + INFERENCE_BATCH]})[0]
            for first in range(0, len(X), INFERENCE_BATCH)
        ]
        probs = apply_temperature(np.concatenate(parts), self.temperature)
        return apply_logit_bias(probs, self.logit_bias).astype(np.float32, copy=False)

    @property
    def temperature(self) -> float:
        """Confidence-calibration temperature (1 when the model has none)."""
        return float(self._metadata.get("temperature", 1.0))

    @property
    def logit_bias(self) -> np.ndarray:
        """Decision offsets per class (zeros when the model has none)."""
        b = self._metadata.get("logit_bias")
        return np.zeros(len(self.classes)) if b is None else np.asarray(b, dtype=np.float64)

    def __repr__(self) -> str:
        return f"FaultModel({str(self._path)!r}, version={self.version!r}, classes={len(self.classes)})"


def apply_temperature(probs: np.ndarray, temperature: float) -> np.ndarray:
    """softmax(logits / T) from softmax(logits): p_k^(1/T), renormalised; unchanged for T = 1."""
    if temperature == 1.0:
        return probs
    logp = np.log(np.clip(np.asarray(probs, dtype=np.float64), 1e-30, None)) / temperature
    logp -= logp.max(axis=1, keepdims=True)
    q = np.exp(logp)
    return q / q.sum(axis=1, keepdims=True)


def apply_logit_bias(probs: np.ndarray, bias: Optional[np.ndarray]) -> np.ndarray:
    """p_k * exp(b_k), renormalised per row; unchanged when ``bias`` is None or all zero."""
    if bias is None or not np.any(bias):
        return probs
    q = np.asarray(probs, dtype=np.float64) * np.exp(np.asarray(bias, dtype=np.float64))[None, :]
    return q / q.sum(axis=1, keepdims=True)


def classes_for(n_motors: int) -> list[str]:
    """Output classes of an n-rotor model: healthy, motor1 .. motorn (CLASSES for 4)."""
    return ["healthy"] + [f"motor{k}" for k in range(1, n_motors + 1)]


def model_rotor_count(meta: dict) -> int:
    """Rotor count of a model's metadata (see the module docstring)."""
    n = meta.get("rotor_count")
    if isinstance(n, int) and not isinstance(n, bool) and n > 0:
        return n
    n = (meta.get("feature_spec") or {}).get("n_motors", 4)
    return int(n) if isinstance(n, int) and not isinstance(n, bool) and n > 0 else 4


def shipped_model_path(n_rotors: int = 4) -> Optional[Path]:
    """The shipped model file for ``n_rotors`` rotors, or None when none is shipped for that count."""
    try:
        import flightlog_fd.models as models
    except ImportError:
        return None
    if n_rotors == 4:
        return Path(models.DEFAULT_MODEL)
    name = getattr(models, "MODEL_FILES", {}).get(n_rotors)
    path = Path(models.DEFAULT_MODEL).with_name(name) if name else None
    return path if path is not None and path.is_file() else None


def shipped_model_paths() -> list[Path]:
    """Every shipped model file present (the quad model first)."""
    try:
        import flightlog_fd.models as models
    except ImportError:
        return []
    counts = [4] + sorted(n for n in getattr(models, "MODEL_FILES", {}) if n != 4)
    return [p for p in (shipped_model_path(n) for n in counts) if p is not None and p.is_file()]


_SHIPPED: dict[Path, "FaultModel"] = {}


def model_for_flight(model: Any, flight: Any) -> Any:
    """The model to diagnose ``flight`` with: the shipped model of the flight's rotor count when
    ``model`` is the shipped quad model and the flight's placed frame has another rotor count with
    a shipped model; else ``model`` itself (a user's or a profile's model is never swapped)."""
    frame = getattr(flight, "frame", None)
    n = getattr(frame, "rotor_count", 0) if frame is not None else 0
    if not n or n == 4 or getattr(frame, "unplaced", "") or getattr(model, "rotor_count", 4) == n:
        return model
    try:
        if Path(getattr(model, "path", "") or "").resolve() != Path(default_model_path()).resolve():
            return model
    except ModelError:
        return model
    path = shipped_model_path(n)
    if path is None:
        return model
    key = path.resolve()
    if key not in _SHIPPED:
        _SHIPPED[key] = FaultModel(path)
    return _SHIPPED[key]


def default_model_path() -> Path:
    """The shipped model (package ``flightlog_fd.models``); ModelError when it is not installed."""
    try:
        import flightlog_fd.models
    except ImportError:
        raise ModelError(None, "the shipped models package (flightlog_fd.models) is not installed") from None
    path = Path(flightlog_fd.models.DEFAULT_MODEL)
    if not path.is_file():
        raise ModelError(path, "the shipped default model is missing; build it with `python -m flightlog_fd.training.build_default`")
    return path

