"""DCNN shapes and structure for NIF (7 channels) and CF (9 channels) inputs."""
from __future__ import annotations

import pytest
import torch

from flightlog_fd.training.dcnn import CF_CHANNELS, NIF_CHANNELS, DCNN, DCNNConfig, count_parameters


@pytest.mark.parametrize("channels", [NIF_CHANNELS, CF_CHANNELS])
def test_output_and_feature_shapes(channels):
    torch.manual_seed(0)
    model = DCNN(DCNNConfig(in_channels=channels)).eval()
    x = torch.randn(6, channels, 80)
    with torch.no_grad():
        logits = model(x)
        feats = model.features(x)
        logits2, feats2 = model.forward_with_features(x)
        rest = model.classify(feats)
    assert logits.shape == (6, 5)
    assert feats.shape == (6, 128)
    # features come after the ReLU of the first dense layer
    assert float(feats.min()) >= 0.0
    # forward is features followed by the rest of the network
    torch.testing.assert_close(rest, logits)
    torch.testing.assert_close(logits2, logits)
    torch.testing.assert_close(feats2, feats)


def test_paper_architecture():
    cfg = DCNNConfig()
    assert (cfg.in_channels, cfg.window, cfg.n_classes) == (7, 80, 5)
    assert cfg.pooled_length() == 5  # 80 -> 40 -> 20 -> 10 -> 5
    model = DCNN(cfg)
    convs = [m for m in model.modules() if isinstance(m, torch.nn.Conv1d)]
    pools = [m for m in model.modules() if isinstance(m, torch.nn.MaxPool1d)]
    assert len(convs) == 4 and len(pools) == 4
    assert all(c.out_channels == 64 and c.kernel_size == (3,) and c.padding == (1,) for c in convs)
    assert model.dense1.in_features == 64 * 5 and model.dense1.out_features == 128
    assert model.dense2.out_features == 128 and model.head.out_features == 5
    assert model.dropout.p == pytest.approx(0.1)
    # 4 conv layers + 3 dense layers, counted by hand
    expected = (7 * 3 * 64 + 64) + 3 * (64 * 3 * 64 + 64) + (320 * 128 + 128) + (128 * 128 + 128) + (128 * 5 + 5)
    assert count_parameters(model) == expected


def test_dropout_does_not_touch_features():
    torch.manual_seed(1)
    model = DCNN().train()
    x = torch.randn(4, 7, 80)
    torch.testing.assert_close(model.features(x), model.features(x))  # no dropout before features
    assert not torch.equal(model(x), model(x))  # dropout active afterwards in train mode


def test_config_round_trip_and_limits():
    cfg = DCNNConfig(in_channels=9)
    assert DCNNConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ValueError):
        DCNNConfig(window=8)  # cannot survive 4 halvings
    with pytest.raises(ValueError):
        DCNNConfig(kernel=4)
