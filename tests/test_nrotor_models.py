"""The shipped hexa and octo models, the choice of model from the log's frame, and n-rotor profiles."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from flightlog_fd import load_flight
from flightlog_fd.errors import ModelError, ProfileError, UnsupportedVehicleError
from flightlog_fd.windows import FeatureSpec, make_windows, nif_channels
from flightlog_fd.model import FaultModel, classes_for, default_model_path, model_for_flight, shipped_model_path

SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"
N_ROTOR_SAMPLES = {"ardupilot_hexa_motor5_damaged.bin": 5, "px4_octo_motor2_damaged.ulg": 2}


@pytest.mark.parametrize("n", [6, 8])
def test_shipped_n_rotor_model(n, tmp_path):
    path = shipped_model_path(n)
    assert path is not None and path.is_file()
    copy = tmp_path / "alone.onnx"  # one self-contained file: no external weights beside it
    shutil.copy(path, copy)
    m = FaultModel(copy)
    assert m.rotor_count == n and m.classes == classes_for(n) and len(m.classes) == n + 1
    assert m.feature_spec["channels"] == list(nif_channels(n)) and m.n_channels == n + 3
    assert m.metadata["frames"] and m.temperature > 0
    probs = m.predict_proba(m.standardise(np.zeros((3, n + 3, m.window), np.float32)))
    assert probs.shape == (3, n + 1) and np.allclose(probs.sum(1), 1.0, atol=1e-5)


def test_quad_model_is_unchanged_and_counts_four_rotors():
    m = FaultModel(default_model_path())
    assert m.rotor_count == 4 and len(m.classes) == 5 and shipped_model_path(4) == default_model_path()
    assert shipped_model_path(5) is None


def test_model_chosen_from_the_frame():
    from flightlog_fd.diagnose import is_shipped_model, resolve_model

    quad = resolve_model()
    hexa = load_flight(SAMPLES / "ardupilot_hexa_motor5_damaged.bin")
    octo = load_flight(SAMPLES / "px4_octo_motor2_damaged.ulg")
    q = load_flight(SAMPLES / "px4_healthy.ulg")
    assert model_for_flight(quad, q) is quad
    assert model_for_flight(quad, hexa).rotor_count == 6 and model_for_flight(quad, octo).rotor_count == 8
    assert is_shipped_model(model_for_flight(quad, hexa))
    assert resolve_model(rotor_count=8).path == shipped_model_path(8)
    with pytest.raises(ModelError, match="5 rotors"):
        resolve_model(rotor_count=5)
    own = FaultModel(shipped_model_path(8))  # a model the user chose is never swapped
    assert model_for_flight(own, hexa) is own


@pytest.mark.parametrize("name", sorted(N_ROTOR_SAMPLES))
def test_n_rotor_model_names_the_damaged_sample_motor(name):
    fl = load_flight(SAMPLES / name)
    m = model_for_flight(FaultModel(default_model_path()), fl)
    w = make_windows(fl, FeatureSpec.from_dict(m.feature_spec))
    P = m.predict_proba(m.standardise(w.X)).astype(np.float64)
    assert len(P) >= 8
    # the model's vote per motor as the decision layer reads it: flight mean of log(p_k / p_0).
    # (On the octo sample the window majority is healthy, 39 of 49: the octo model alone does not
    # flag it; it does point at motor 2.)
    votes = np.log(np.clip(P[:, 1:], 1e-12, None) / np.clip(P[:, :1], 1e-12, None)).mean(axis=0)
    assert int(votes.argmax()) + 1 == N_ROTOR_SAMPLES[name]
    counts = np.bincount(P.argmax(1), minlength=m.rotor_count + 1)
    assert int(counts[1:].argmax()) + 1 == N_ROTOR_SAMPLES[name]


def test_n_rotor_sample_diagnosis():
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    res = CliRunner().invoke(app, ["diagnose", "--json", *(str(SAMPLES / n) for n in sorted(N_ROTOR_SAMPLES))])
    docs = {Path(d["log"]).name: d for d in json.loads(res.stdout)}
    hexa, octo = docs["ardupilot_hexa_motor5_damaged.bin"], docs["px4_octo_motor2_damaged.ulg"]
    assert hexa["model"]["path"].endswith("default_hexa.onnx") and octo["model"]["path"].endswith("default_octo.onnx")
    assert len(hexa["windows"][0]["probabilities"]) == 7 and len(octo["windows"][0]["probabilities"]) == 9
    # today's decision layer: the hexa sample's motor 5 is named (uncertain at +5 nats, the model's cap),
    # the octo sample is uncertain naming motor 2 (P(healthy) 0.28: no verdict is stated below 0.5);
    # neither names a wrong motor
    v = hexa["verdict"]
    assert (v["status"] == "damaged" and v["motor"] == 5) or (v["status"] == "uncertain"
                                                                and v["headline"].endswith("inspect propeller 5"))
    assert octo["verdict"]["status"] != "not_diagnosable" and octo["verdict"]["motor"] in (None, 2)


def test_n_rotor_profile(tmp_path):
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.calibration import calibrate_profile
    from flightlog_fd.profile import Profile
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.api import simulate_flights

    f = simulate_flights(1, airframes=preset("x500", "octaquad_x"), healthy_fraction=1.0, profile="px4_default",
                         duration_s=30.0, seed=5, imbalance="random")[0]
    fl = load_flight(write_ulog(f, tmp_path / "o.ulg"))
    p = calibrate_profile([fl])
    assert p.rotor_count == 8 and p.rho_.shape == (8,) and p.spec.n_motors == 8
    base = p.baseline()
    assert base.share.shape == (8,) and base.slope.shape == (8,) and abs(base.share.mean() - 1) < 1e-9
    d = json.loads(json.dumps(p.to_dict()))
    assert Profile.from_dict(d).check_compatible(fl) == []
    with pytest.raises(ProfileError, match="rotor_count"):
        Profile.from_dict({**d, "rotor_count": 5})
    with pytest.raises(ProfileError):
        Profile.from_dict({**d, "rho_": d["rho_"][:4]})
    from flightlog_fd.calibration import calibrate

    with pytest.raises(UnsupportedVehicleError, match="--no-adapt"):
        calibrate([tmp_path / "o.ulg"], adapt=True, output=tmp_path / "o.json")


def test_model_card_quotes_the_n_rotor_figures():
    root = Path(__file__).resolve().parents[1] / "models"
    card = (root / "MODEL_CARD.md").read_text()
    for stem in ("default_hexa", "default_octo"):
        sim = json.loads((root / f"{stem}.json").read_text())["sim_test"]
        assert f"{100 * sim['window_accuracy']:.1f} %" in card
        assert f"{sim['damaged_flights_majority_right']}/{sim['damaged_flights']}" in card
    from flightlog_fd.analyzers.model_votes import NROTOR_VOTE_STATS

    for st in NROTOR_VOTE_STATS.values():  # the vote statistics the decision uses are the card's
        assert f"{st.damaged_mean:+.2f} ± {st.damaged_sigma:.2f}" in card
        assert f"{st.damage_shift:+.2f} ± {st.shift_sigma:.2f}" in card
