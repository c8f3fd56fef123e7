"""ONNX export and the torch-free FaultModel: equality with torch, metadata round trip, errors."""
from __future__ import annotations

import datetime as dt
import hashlib
import json
import subprocess
import sys

import numpy as np
import onnx
import pytest
import torch

import flightlog_fd.models
from flightlog_fd.errors import ModelError
from flightlog_fd.windows import FeatureSpec
from flightlog_fd.model import CLASSES, INFERENCE_BATCH, METADATA_KEY, FaultModel, default_model_path
from flightlog_fd.training.dcnn import DCNN, DCNNConfig
from flightlog_fd.training.export import export_onnx, export_onnx_like
from flightlog_fd.training.train import predict_proba, train_dcnn


def raw_windows(n: int, seed: int, channels: int = 7) -> np.ndarray:
    """Unstandardised windows with per-channel offsets/scales, so standardising matters."""
    rng = np.random.default_rng(seed)
    offset = np.linspace(-3, 5, channels)[None, :, None]
    scale = np.linspace(0.5, 4, channels)[None, :, None]
    return (offset + scale * rng.normal(size=(n, channels, 80))).astype(np.float32)


def labelled_windows(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Raw windows where class k > 0 lifts channel 2 + k by two of its standard deviations."""
    X = raw_windows(n, seed)
    y = (np.arange(n) % 5).astype(np.int64)
    lift = 2.0 * np.linspace(0.5, 4, 7)
    for k in range(1, 5):
        X[y == k, 2 + k, :] += lift[2 + k]
    return X, y


@pytest.fixture(scope="module")
def trained():
    """A paper-sized DCNN trained briefly (peaked probabilities make the comparison meaningful)."""
    spec = FeatureSpec()  # NIF, 7 channels, window 80
    X, y = labelled_windows(1000, seed=0)
    spec.fit(X)
    res = train_dcnn(spec.normalise(X), y, config=DCNNConfig(), max_epochs=3, seed=0)
    return res.model, spec, res.summary()


@pytest.fixture(scope="module")
def exported(trained, tmp_path_factory):
    model, spec, summary = trained
    summary = {**summary, "note": np.float64(0.5), "confusion": np.eye(5, dtype=np.int64)}  # numpy survives
    path = tmp_path_factory.mktemp("onnx") / "model.onnx"
    result = export_onnx(model, path, {"feature_spec": spec.to_dict(), "training": summary, "version": "test-1"})
    return result


def test_import_does_not_pull_torch():
    code = "import flightlog_fd.model, sys; assert 'torch' not in sys.modules, 'torch imported'"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_single_small_file_with_dynamic_batch(exported):
    assert exported.exporter == "dynamo"
    assert exported.path.is_file() and exported.size_bytes < 1_000_000
    assert sorted(p.name for p in exported.path.parent.iterdir()) == ["model.onnx"]  # no external data
    proto = onnx.load(str(exported.path))
    onnx.checker.check_model(proto)
    assert [i.name for i in proto.graph.input] == ["windows"]
    assert [o.name for o in proto.graph.output] == ["probabilities"]
    batch_dim = proto.graph.input[0].type.tensor_type.shape.dim[0]
    assert batch_dim.dim_param and not batch_dim.HasField("dim_value")


@pytest.mark.parametrize("prefer_dynamo", [True, False])
def test_onnx_probabilities_equal_torch(trained, exported, tmp_path, prefer_dynamo):
    model, spec, summary = trained
    if prefer_dynamo:
        path = exported.path
    else:
        result = export_onnx(model, tmp_path / "ts.onnx", {"feature_spec": spec.to_dict(), "training": summary},
                             prefer_dynamo=False)
        assert result.exporter == "torchscript"
        path = result.path
    fm = FaultModel(path)
    X = fm.standardise(labelled_windows(INFERENCE_BATCH + 300, seed=1)[0])  # > one onnxruntime run
    p_onnx = fm.predict_proba(X)
    p_torch = predict_proba(model, X)
    assert p_onnx.shape == (INFERENCE_BATCH + 300, 5) and p_onnx.dtype == np.float32
    assert np.abs(p_onnx - p_torch).max() < 1e-5
    np.testing.assert_allclose(p_onnx.sum(1), 1.0, atol=1e-5)
    assert p_onnx.max() > 0.9  # a trained, confident model: the comparison is not between uniforms
    for n in (1, 3):  # any batch size
        np.testing.assert_allclose(fm.predict_proba(X[:n]), p_onnx[:n], atol=1e-6)
    assert fm.predict_proba(X[:0]).shape == (0, 5)


def test_weights_into_a_graph_equal_torch(trained, exported, tmp_path):
    """export_onnx_like (what a calibration uses: the shipped graph, new weights) gives torch's
    probabilities, keeps the graph, and refuses a graph of another network."""
    model, spec, summary = trained
    other = DCNN(DCNNConfig())
    torch.manual_seed(5)
    other.load_state_dict({k: v + 0.01 * torch.randn_like(v) for k, v in model.state_dict().items()})
    result = export_onnx_like(other, exported.path, tmp_path / "like.onnx",
                              {"feature_spec": spec.to_dict(), "training": {"note": "weights swapped"}})
    assert "weights into the graph of model.onnx (dynamo export)" == result.exporter
    fm = FaultModel(result.path)
    X = fm.standardise(labelled_windows(500, seed=2)[0])
    assert np.abs(fm.predict_proba(X) - predict_proba(other, X)).max() < 1e-5
    assert np.abs(fm.predict_proba(X) - FaultModel(exported.path).predict_proba(X)).max() > 1e-3  # new weights
    assert [n.op_type for n in onnx.load(str(result.path)).graph.node] == \
        [n.op_type for n in onnx.load(str(exported.path)).graph.node]
    assert fm.training == {"note": "weights swapped"}
    with pytest.raises(ValueError, match="not a graph of this model"):
        export_onnx_like(DCNN(DCNNConfig(filters=16)), exported.path, tmp_path / "x.onnx",
                         {"feature_spec": spec.to_dict()})


def test_metadata_round_trip(trained, exported):
    _, spec, summary = trained
    fm = FaultModel(exported.path)
    assert fm.feature_spec == spec.to_dict()
    assert FeatureSpec.from_dict(fm.feature_spec).to_dict() == spec.to_dict()
    assert fm.classes == list(CLASSES)
    assert fm.version == "test-1"
    assert fm.training["best_epoch"] == summary["best_epoch"]
    assert fm.training["note"] == 0.5 and fm.training["confusion"] == np.eye(5, dtype=int).tolist()
    assert dt.datetime.fromisoformat(fm.metadata["created"]).tzinfo is not None
    assert fm.metadata["exporter"] == "dynamo"
    assert fm.path == exported.path
    assert fm.sha256 == hashlib.sha256(exported.path.read_bytes()).hexdigest()
    # the metadata is one JSON entry under one key
    props = {p.key: p.value for p in onnx.load(str(exported.path)).metadata_props}
    assert list(props) == [METADATA_KEY]
    assert json.loads(props[METADATA_KEY])["feature_spec"]["mean"] == spec.to_dict()["mean"]
    # properties hand out copies
    fm.feature_spec["mean"][0] = 1e9
    assert fm.feature_spec == spec.to_dict()


def test_standardise_uses_the_stored_statistics(trained, exported):
    _, spec, _ = trained
    fm = FaultModel(exported.path)
    X = raw_windows(10, seed=2)
    np.testing.assert_allclose(fm.standardise(X), spec.normalise(X), rtol=1e-5, atol=1e-5)
    with pytest.raises(ModelError, match=r"\(N, 7, 80\)"):
        fm.standardise(X[:, :, :40])
    with pytest.raises(ModelError):
        fm.predict_proba(np.zeros((2, 9, 80), np.float32))


def _rewrite_metadata(src, dst, value):
    proto = onnx.load(str(src))
    del proto.metadata_props[:]
    if value is not None:
        entry = proto.metadata_props.add()
        entry.key, entry.value = METADATA_KEY, value
    onnx.save(proto, str(dst))
    return dst


def test_errors_name_the_file(exported, tmp_path):
    good = json.loads(json.dumps(FaultModel(exported.path).metadata))
    no_std = json.loads(json.dumps(good))
    del no_std["feature_spec"]["std"]
    short_mean = json.loads(json.dumps(good))
    short_mean["feature_spec"]["mean"] = [0.0, 1.0]
    three_classes = {**good, "classes": ["a", "b", "c"]}
    wrong_window = json.loads(json.dumps(good))
    wrong_window["feature_spec"]["window"] = 40
    text = tmp_path / "notes.onnx"
    text.write_text("this is not a model\n")
    empty = tmp_path / "empty.onnx"
    empty.write_bytes(b"")
    truncated = tmp_path / "truncated.onnx"
    truncated.write_bytes(exported.path.read_bytes()[:5000])
    cases = {
        tmp_path / "absent.onnx": "not found",
        text: "not a readable ONNX model",
        empty: "not a readable ONNX model",
        truncated: "not a readable ONNX model",
        _rewrite_metadata(exported.path, tmp_path / "bare.onnx", None): "no 'flightlog_fd' metadata",
        _rewrite_metadata(exported.path, tmp_path / "json.onnx", "{not json"): "not valid JSON",
        _rewrite_metadata(exported.path, tmp_path / "nostd.onnx", json.dumps(no_std)): "'mean' and 'std'",
        _rewrite_metadata(exported.path, tmp_path / "mean.onnx", json.dumps(short_mean)): "'mean' and 'std'",
        _rewrite_metadata(exported.path, tmp_path / "cls.onnx", json.dumps(three_classes)): "3 classes",
        _rewrite_metadata(exported.path, tmp_path / "win.onnx", json.dumps(wrong_window)): "metadata says",
        _rewrite_metadata(exported.path, tmp_path / "list.onnx", "[1, 2]"): "JSON object",
    }
    for path, message in cases.items():
        with pytest.raises(ModelError) as err:
            FaultModel(path)
        assert message in err.value.message, (path.name, err.value.message)
        assert err.value.path == str(path)
        assert "\n" not in str(err.value)


def test_export_refuses_inconsistent_metadata(trained, tmp_path):
    model, spec, _ = trained
    cf = FeatureSpec(features="cf")
    cf.fit(raw_windows(20, seed=3, channels=9))
    with pytest.raises(ValueError, match="9 channels"):
        export_onnx(model, tmp_path / "x.onnx", {"feature_spec": cf.to_dict()})
    unfitted = FeatureSpec().to_dict()  # no mean/std: the model file could not standardise
    with pytest.raises(ModelError, match="'mean' and 'std'"):
        export_onnx(model, tmp_path / "x.onnx", {"feature_spec": unfitted})
    with pytest.raises(ModelError, match="feature_spec"):
        export_onnx(model, tmp_path / "x.onnx", {"training": {}})
    assert not (tmp_path / "x.onnx").exists()


def test_cf_model_exports_too(tmp_path):
    torch.manual_seed(0)
    model = DCNN(DCNNConfig(in_channels=9))
    spec = FeatureSpec(features="cf")
    spec.fit(raw_windows(20, seed=4, channels=9))
    result = export_onnx(model, tmp_path / "cf.onnx", {"feature_spec": spec.to_dict()}, prefer_dynamo=False)
    fm = FaultModel(result.path)
    X = fm.standardise(raw_windows(5, seed=5, channels=9))
    assert np.abs(fm.predict_proba(X) - predict_proba(model, X)).max() < 1e-5
    assert fm.feature_spec["channels"] == list(spec.channels)


def test_default_model_path(monkeypatch, exported, tmp_path):
    monkeypatch.setattr(flightlog_fd.models, "DEFAULT_MODEL", tmp_path / "default.onnx")
    with pytest.raises(ModelError, match="missing"):
        default_model_path()
    monkeypatch.setattr(flightlog_fd.models, "DEFAULT_MODEL", exported.path)
    assert default_model_path() == exported.path
