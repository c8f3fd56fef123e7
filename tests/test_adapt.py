"""`fdlog calibrate`'s adaptation (training/adapt.py): the same flights and seed give the same
adapted model and profile, whatever the machine's load; the stages report their progress."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import numpy_helper

from flightlog_fd.calibration import calibrate
from flightlog_fd.training.adapt import AdaptSettings

SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"
#: A small calibration (few, short simulated flights) that still keeps some like the sample's airframe.
TINY = dict(n_flights=12, duration_s=30.0, max_epochs=3)


def _weights(onnx_path: Path) -> dict:
    return {i.name: numpy_helper.to_array(i) for i in onnx.load(str(onnx_path)).graph.initializer}


def _without_times(doc: dict) -> dict:
    """A profile without what differs between two runs by design: when (the profile and its
    sessions), where, how long."""
    doc = json.loads(json.dumps(doc))
    doc.pop("created", None)
    for session in doc.get("sessions_") or []:
        session.pop("created", None)
    ad = doc["extra"]["adaptation"]
    for k in ("simulate_seconds", "train_seconds", "total_seconds"):
        ad.pop(k)
    doc.pop("model")  # its file name, and its sha256: the ONNX metadata holds the timings too
    doc["analyzers"]["model"].pop("model_sha256")
    return doc


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("adapt")
    stages: list[str] = []

    def progress(stage: str, frac: float) -> None:
        if not stages or stages[-1] != stage:
            stages.append(stage)

    paths = {}
    for name, seed in (("a", 0), ("b", 0), ("c", 1)):
        paths[name] = out / f"{name}.json"
        calibrate([SAMPLES / "ardupilot_healthy.bin"], adapt=True, output=paths[name],
                  settings=AdaptSettings(seed=seed, **TINY), progress=progress if name == "a" else None)
    return paths, stages


def test_a_calibration_is_deterministic_for_a_seed(runs):
    paths, _ = runs
    a, b, c = (json.loads(paths[k].read_text()) for k in "abc")
    assert _without_times(a) == _without_times(b)
    wa, wb, wc = (_weights(paths[k].with_suffix(".onnx")) for k in "abc")
    assert wa.keys() == wb.keys()
    for name in wa:
        np.testing.assert_array_equal(wa[name], wb[name])
    # another seed simulates other airframes: another model
    assert any(not np.array_equal(wa[k], wc[k]) for k in wa)
    assert a["extra"]["adaptation"]["data"] != c["extra"]["adaptation"]["data"]


def test_the_progress_shows_every_stage(runs):
    _, stages = runs
    assert stages == ["measuring hover", "matching the dynamics", "simulating", "training", "exporting",
                      "fitting baselines"]
