"""The shipped model file: loads without torch, carries its feature spec, and its metadata says
how it was trained (what models/MODEL_CARD.md quotes)."""
from __future__ import annotations

import json

import numpy as np

from flightlog_fd.windows import FeatureSpec
from flightlog_fd.model import FaultModel, default_model_path

from conftest import ROOT


def test_default_model_loads_with_complete_metadata():
    m = FaultModel(default_model_path())
    spec = FeatureSpec.from_dict(m.feature_spec)
    assert spec.features == "nif" and spec.window == 80 and len(spec.channels) == 7
    assert m.classes == ["healthy", "motor1", "motor2", "motor3", "motor4"]
    assert not np.any(m.logit_bias)  # the shipped model has no airframe-specific offsets
    t = m.training
    assert t["domain_adaptation"] is False
    assert 0.5 < t["sim_test"]["window_accuracy"] <= 1.0
    X = np.zeros((3, 7, 80), np.float32)
    p = m.predict_proba(X)
    assert p.shape == (3, 5) and np.allclose(p.sum(1), 1, atol=1e-5)


def test_model_card_quotes_the_model_files_figures():
    meta = json.loads((ROOT / "models" / "default.json").read_text())
    card = (ROOT / "models" / "MODEL_CARD.md").read_text()
    assert f"{100 * meta['sim_test']['window_accuracy']:.1f} %" in card
    assert (ROOT / "models" / "default.pt").exists()  # the weights `fdlog calibrate` fine-tunes
