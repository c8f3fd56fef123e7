"""NIF / CF windows with n motor channels (hexa, octo); quad specs unchanged."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.errors import UnsupportedVehicleError
from flightlog_fd.windows import CF_CHANNELS, FeatureSpec, NIF_CHANNELS, cf_channels, labels_for_spans, make_windows, nif_channels


def test_channel_names_and_quad_spec_dict_unchanged():
    assert nif_channels(4) == NIF_CHANNELS and cf_channels(4) == CF_CHANNELS
    assert nif_channels(6)[-3:] == ("w4_sq", "w5_sq", "w6_sq") and len(cf_channels(8)) == 13
    assert "n_motors" not in FeatureSpec().to_dict()
    spec = FeatureSpec(features="cf", n_motors=8)
    back = FeatureSpec.from_dict(spec.to_dict())
    assert back.n_motors == 8 and back.channels == cf_channels(8) and back.n_channels == 13
    with pytest.raises(ValueError, match="n_motors"):
        FeatureSpec(n_motors=2)
    with pytest.raises(ValueError, match="channels"):
        FeatureSpec(n_motors=6, channels=NIF_CHANNELS)


def test_hexa_sitl_log_gives_six_motor_windows(shared):
    from flightlog_fd import load_flight

    f = load_flight(shared("ardupilot_sitl_hexa", "hexa_cwx_m3.bin"))
    with pytest.raises(UnsupportedVehicleError, match="hexa with 6 rotors"):
        make_windows(f, FeatureSpec(features="nif"))  # a quad spec still refuses it
    w = make_windows(f, FeatureSpec(features="nif", n_motors=6))
    assert w.X.shape[1:] == (9, 80) and len(w) > 10
    assert np.allclose(w.X[:, 3:9, :].mean(axis=(1, 2)), 1.0, atol=1e-5)  # scale-free shares
    # motor 3 stops at 73.87 s: its share in the windows after the stop is 0, before it about 1
    after, before = w.t_start > 75.0, w.t_end < 73.0
    assert after.any() and before.any()
    assert np.all(w.X[after, 5, :] < 0.05) and np.all(np.abs(w.X[before, 5, :].mean(axis=1) - 1.0) < 0.3)
    c = make_windows(f, FeatureSpec(features="cf", n_motors=6))
    assert c.X.shape[1] == 11


def test_n_motor_spec_refuses_a_quad(shared):
    from flightlog_fd import load_flight

    f = load_flight(shared("real_logs", "ardupilot", "erle_copter34_7.BIN"))
    with pytest.raises(UnsupportedVehicleError, match="6 rotors; this log is a quad_x with 4 rotors"):
        make_windows(f, FeatureSpec(features="nif", n_motors=6))


def test_labels_up_to_the_rotor_count():
    t0, t1 = np.array([0.0, 10.0]), np.array([2.0, 12.0])
    assert labels_for_spans({"label": 6, "rotor_count": 6, "onset_s": 5.0}, t0, t1).tolist() == [0, 6]
    with pytest.raises(ValueError, match="0..4"):
        labels_for_spans({"label": 5}, t0, t1)
