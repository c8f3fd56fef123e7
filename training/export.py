"""Export a trained DCNN to a single self-describing ONNX file for flightlog_fd.model.FaultModel.

Input: a DCNN (training/dcnn.py) and a metadata dict with at least ``feature_spec``
(FeatureSpec.to_dict(), including the per-channel "mean"/"std" the training windows were
standardised with) and ``training`` (a JSON-able summary); optional ``version`` (default
"flightlog_fd <package version>"), ``classes`` (default CLASSES) and ``created`` (default: now,
UTC).

Output file: graph input "windows" (N, C, T) float32, already standardised, with a dynamic batch
axis N; output "probabilities" (N, n_classes): the softmax is inside the graph, so onnxruntime
gives probabilities directly. Weights are stored inside the file (no external data): ~0.4 MB for
the paper's NIF network. The metadata goes into one metadata_props entry "flightlog_fd" as JSON
and is validated with the same function the loader uses; the model with onnx.checker.

Exporter: torch.onnx's dynamo (torch.export) path first; if it fails, the TorchScript exporter
(``dynamo=False``). ExportResult.exporter says which one wrote the file.

Limits: CPU float32 only; opset chosen by torch's exporter (>= 17, read by onnxruntime >= 1.17).
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import io
import json
import logging
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import onnx
import torch
from torch import nn

import flightlog_fd
from flightlog_fd.model import CLASSES, INPUT_NAME, METADATA_KEY, OUTPUT_NAME, validate_metadata
from flightlog_fd.training.dcnn import DCNN

EXAMPLE_BATCH = 4  # trace batch; > 1 so torch.export does not specialise the batch axis to 1
BATCH_AXIS_NAME = "batch"


@dataclass
class ExportResult:
    path: Path
    exporter: str  # "dynamo" | "torchscript"
    opset: int
    size_bytes: int
    metadata: dict


class ProbabilityHead(nn.Module):
    """DCNN followed by softmax: the graph that gets exported."""

    def __init__(self, model: DCNN):
        super().__init__()
        self.model = model

    def forward(self, windows: torch.Tensor) -> torch.Tensor:
        return torch.softmax(self.model(windows), dim=1)  # (N, C, T) -> (N, n_classes)


def build_metadata(metadata: dict, n_classes: int) -> dict:
    """The full metadata object: caller's fields plus defaults for version, classes, created."""
    meta = dict(metadata)
    meta.setdefault("version", f"flightlog_fd {flightlog_fd.__version__}")
    meta.setdefault("classes", list(CLASSES))
    meta.setdefault("training", {})
    meta.setdefault("created", _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    meta["classes"] = list(meta["classes"])
    if len(meta["classes"]) != n_classes:
        raise ValueError(f"metadata lists {len(meta['classes'])} classes, the model has {n_classes}")
    # Round-trip through JSON so numpy scalars/arrays fail here, not in the user's hands.
    meta = json.loads(json.dumps(meta, default=_json_default))
    validate_metadata(meta, None)
    return meta


def _json_default(obj):
    """numpy scalars and arrays -> plain Python (summaries often hold np.float64 / arrays)."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _export_dynamo(head: nn.Module, example: torch.Tensor) -> onnx.ModelProto:
    batch = torch.export.Dim(BATCH_AXIS_NAME)
    # The exporter prints progress lines and logs warnings about optional packages (torchvision);
    # the model is the product, not the chatter.
    onnx_logger = logging.getLogger("torch.onnx")
    previous_level = onnx_logger.level
    onnx_logger.setLevel(logging.ERROR)
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            program = torch.onnx.export(
                head,
                (example,),
                dynamo=True,
                input_names=[INPUT_NAME],
                output_names=[OUTPUT_NAME],
                dynamic_shapes={INPUT_NAME: {0: batch}},
                external_data=False,
                verbose=False,
            )
        finally:
            onnx_logger.setLevel(previous_level)
    return program.model_proto


def _export_torchscript(head: nn.Module, example: torch.Tensor) -> onnx.ModelProto:
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            head,
            (example,),
            buffer,
            dynamo=False,
            input_names=[INPUT_NAME],
            output_names=[OUTPUT_NAME],
            dynamic_axes={INPUT_NAME: {0: BATCH_AXIS_NAME}, OUTPUT_NAME: {0: BATCH_AXIS_NAME}},
            opset_version=17,
        )
    return onnx.load_from_string(buffer.getvalue())


def _check_spec(model: DCNN, meta: dict) -> None:
    spec = meta["feature_spec"]
    if len(spec["channels"]) != model.config.in_channels or spec["window"] != model.config.window:
        raise ValueError(
            f"feature_spec says ({len(spec['channels'])} channels, window {spec['window']}), "
            f"the model takes ({model.config.in_channels}, {model.config.window})"
        )


def export_onnx(model: DCNN, path, metadata: dict, *, prefer_dynamo: bool = True) -> ExportResult:
    """Write ``model`` + softmax as one ONNX file at ``path`` with validated metadata."""
    path = Path(path)
    meta = build_metadata(metadata, model.config.n_classes)
    _check_spec(model, meta)
    was_training = model.training
    model.eval()  # dropout off in the exported graph
    head = ProbabilityHead(model).eval()
    example = torch.zeros(EXAMPLE_BATCH, model.config.in_channels, model.config.window)
    proto, exporter, dynamo_error = None, None, None
    try:
        if prefer_dynamo:
            try:
                proto, exporter = _export_dynamo(head, example), "dynamo"
            except Exception as e:  # any failure of the newer path: fall back, keep the reason
                dynamo_error = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
        if proto is None:
            proto, exporter = _export_torchscript(head, example), "torchscript"
    finally:
        model.train(was_training)
    if dynamo_error is not None:
        meta["exporter_note"] = f"dynamo export failed ({dynamo_error[:200]}); used torchscript"
    meta["exporter"] = exporter
    return _write(proto, path, meta, exporter)


def export_onnx_like(model: DCNN, base_onnx, path, metadata: dict) -> ExportResult:
    """Write ``model`` as ONNX by putting its weights into the graph of ``base_onnx``, a model
    this module exported from a DCNN of the same configuration (e.g. the shipped model a
    calibration fine-tunes): the same graph, new weights and metadata, in milliseconds instead
    of the seconds a torch export takes. ValueError when the graph does not hold exactly the
    model's weights with the same shapes (use :func:`export_onnx` then)."""
    from onnx import numpy_helper

    path = Path(path)
    meta = build_metadata(metadata, model.config.n_classes)
    _check_spec(model, meta)
    proto = onnx.load(str(base_onnx))
    inits = {i.name: i for i in proto.graph.initializer}
    state = {f"model.{k}": v.detach().cpu().numpy() for k, v in model.state_dict().items()}  # ProbabilityHead names
    for name, value in state.items():
        init = inits.get(name)
        if init is None or tuple(init.dims) != value.shape:
            raise ValueError(f"{base_onnx}: no initializer {name} of shape {value.shape}: not a graph of this model")
        init.CopyFrom(numpy_helper.from_array(value.astype(numpy_helper.to_array(init).dtype), name))
    base_meta = json.loads(next((e.value for e in proto.metadata_props if e.key == METADATA_KEY), "{}"))
    exporter = f"weights into the graph of {Path(base_onnx).name} ({base_meta.get('exporter', 'unknown')} export)"
    meta["exporter"] = exporter
    return _write(proto, path, meta, exporter)


def _write(proto: onnx.ModelProto, path: Path, meta: dict, exporter: str) -> ExportResult:
    """Metadata into ``proto``, check it, write it atomically to ``path``."""
    del proto.metadata_props[:]
    entry = proto.metadata_props.add()
    entry.key, entry.value = METADATA_KEY, json.dumps(meta, sort_keys=True)
    proto.producer_name = "flightlog_fd"
    proto.doc_string = "flightlog-fd propeller fault classifier: windows (N,C,T) standardised -> probabilities (N,5)"
    onnx.checker.check_model(proto, full_check=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Write beside the target and rename, so a crash never leaves a half-written model.
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(proto.SerializeToString())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    opset = next((o.version for o in proto.opset_import if o.domain in ("", "ai.onnx")), 0)
    return ExportResult(path, exporter, opset, path.stat().st_size, meta)
