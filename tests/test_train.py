"""Training loop: learns a toy problem, MMD adaptation aligns healthy features, early stopping,
best-model keeping, repeatability, weights and evaluation. Tiny data: seconds per test."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from flightlog_fd.training.dcnn import DCNNConfig
from flightlog_fd.training.mmd import mmd2
from flightlog_fd.training.train import evaluate, predict_proba, train_dcnn

# A shift of the healthy target that looks partly like damage on motor 1 (channel 3): the
# "simulation-to-reality gap" of this toy.
TARGET_SHIFT = np.array([0.3, -0.3, 0.2, 1.0, 0.2, 0.5, -0.2], dtype=np.float32)
# Fewer conv filters keep the tests fast (the conv stack is ~90 % of the compute); the dense
# layers keep the paper's 128 units so the MMD runs on features like the real ones. The paper's
# full network is checked in test_dcnn.py and trained in test_learns_with_the_paper_network.
TOY = DCNNConfig(filters=16)


def toy_windows(n: int, seed: int, shift: np.ndarray | None = None, channels: int = 7):
    """Separable 5-class toy windows (n, C, 80): class k > 0 lifts channel 2 + k and adds a
    20-sample sine to channel k % 3, like a damaged motor's offset and vibration."""
    rng = np.random.default_rng(seed)
    y = rng.integers(0, 5, n)
    X = rng.normal(0.0, 1.0, (n, channels, 80)).astype(np.float32)
    wave = np.sin(2 * np.pi * np.arange(80) / 20).astype(np.float32)
    for k in range(1, 5):
        X[y == k, 2 + k, :] += 1.5
        X[y == k, k % 3, :] += wave
    if shift is not None:
        X += shift[None, :, None]
    return X, y


@pytest.fixture(scope="module")
def source():
    return toy_windows(1500, seed=0)


@pytest.fixture(scope="module")
def held_out():
    return toy_windows(600, seed=1)


def healthy_feature_mmd(model, X_a, X_b) -> float:
    with torch.no_grad():
        return float(mmd2(model.features(torch.from_numpy(X_a)), model.features(torch.from_numpy(X_b))))


def test_learns_separable_toy_problem(source, held_out):
    X, y = source
    seen = []
    res = train_dcnn(X, y, config=TOY, max_epochs=6, seed=0, progress=seen.append)
    acc, confusion = evaluate(res.model, *held_out)
    assert acc > 0.95
    assert confusion.shape == (5, 5) and confusion.sum() == len(held_out[1])
    assert np.trace(confusion) / confusion.sum() == pytest.approx(acc)
    np.testing.assert_array_equal(confusion.sum(1), np.bincount(held_out[1], minlength=5))
    # the callback saw every epoch; the loss fell; no MMD without a target
    assert [s.epoch for s in seen] == list(range(1, len(res.history) + 1))
    assert res.history[-1].loss < res.history[0].loss
    assert all(s.mmd2 == 0.0 and s.loss == s.ce for s in res.history)
    assert res.settings["lam"] == 0.0 and res.settings["n_source_windows"] == 1500
    P = predict_proba(res.model, held_out[0])
    assert P.shape == (600, 5) and P.dtype == np.float32
    np.testing.assert_allclose(P.sum(1), 1.0, atol=1e-5)
    assert predict_proba(res.model, held_out[0][:0]).shape == (0, 5)


def test_mmd_adaptation_aligns_healthy_features_and_still_classifies(source, held_out):
    X, y = source
    X_tgt, y_tgt = toy_windows(1500, seed=2, shift=TARGET_SHIFT)
    X_tgt_test, y_tgt_test = toy_windows(600, seed=3, shift=TARGET_SHIFT)
    healthy_src_test = held_out[0][held_out[1] == 0]
    healthy_tgt_test = X_tgt_test[y_tgt_test == 0]
    common = dict(config=TOY, max_epochs=10, seed=0)
    plain = train_dcnn(X, y, None, **common)
    # the paper's lambda; 5 CE-only epochs of 12 steps stand in for the default 300 warm-up steps
    adapted = train_dcnn(X, y, X_tgt[y_tgt == 0], lam=1e4, warmup_steps=60, **common)
    assert adapted.settings["warmup_epochs"] == 5 and adapted.settings["lam"] == 1e4
    assert all(h.mmd2 != 0.0 for h in adapted.history)
    gap_plain = healthy_feature_mmd(plain.model, healthy_src_test, healthy_tgt_test)
    gap_adapted = healthy_feature_mmd(adapted.model, healthy_src_test, healthy_tgt_test)
    assert gap_adapted < 0.1 * gap_plain  # measured: 0.009 vs 0.86
    # The target (whose labels it never saw) gains: measured 0.74 -> 0.79. The source pays: this
    # toy's gap is a +1 offset on motor 1's channel, the only cue telling motor 1 from motor 4,
    # so becoming blind to it for healthy windows costs motor 1 (measured 1.00 -> 0.79 overall).
    # Training with lambda = 1e4 still classifies far above chance (0.2).
    acc_tgt_plain = evaluate(plain.model, X_tgt_test, y_tgt_test)[0]
    acc_tgt_adapted = evaluate(adapted.model, X_tgt_test, y_tgt_test)[0]
    assert acc_tgt_adapted > acc_tgt_plain + 0.03
    assert evaluate(adapted.model, *held_out)[0] > 0.7


def test_learns_with_the_paper_network(held_out):
    X, y = toy_windows(1000, seed=4)
    res = train_dcnn(X, y, max_epochs=4, seed=0)  # DCNNConfig() from the data: 7 x 80, 64 filters
    assert res.model.config == DCNNConfig()
    assert evaluate(res.model, *held_out)[0] > 0.9


def test_early_stopping_and_best_model_kept(source):
    X, y = source
    # A far too large learning rate makes the loss bounce: training stops on patience.
    kwargs = dict(config=TOY, lr=0.05, max_epochs=12, patience=2, seed=3)
    res = train_dcnn(X, y, **kwargs)
    losses = [h.loss for h in res.history]
    assert res.stop_reason == "patience"
    assert res.best_loss == min(losses) and losses[res.best_epoch - 1] == res.best_loss
    assert len(res.history) == res.best_epoch + 2
    # The returned weights are those of the best epoch: a run cut at that epoch (same seed, so
    # the same trajectory) ends with exactly the same weights.
    cut = train_dcnn(X, y, **{**kwargs, "max_epochs": res.best_epoch})
    assert [h.loss for h in cut.history] == losses[: res.best_epoch]
    for name, value in res.model.state_dict().items():
        torch.testing.assert_close(value, cut.model.state_dict()[name], rtol=0, atol=0)


def test_max_seconds_stops_after_one_epoch(source):
    X, y = source
    res = train_dcnn(X[:300], y[:300], config=TOY, max_epochs=5, max_seconds=0.0)
    assert res.stop_reason == "max_seconds" and len(res.history) == 1 and res.best_epoch == 1


def test_repeatable_with_seed_and_different_without(source):
    X, y = source[0][:400], source[1][:400]
    a = train_dcnn(X, y, config=TOY, max_epochs=2, seed=7)
    b = train_dcnn(X, y, config=TOY, max_epochs=2, seed=7)
    c = train_dcnn(X, y, config=TOY, max_epochs=2, seed=8)
    assert [h.loss for h in a.history] == [h.loss for h in b.history]
    assert [h.loss for h in a.history] != [h.loss for h in c.history]


def test_sample_weight_zero_removes_a_class(source, held_out):
    X, y = source
    weight = (y != 4).astype(np.float32)  # class 4 never counts
    res = train_dcnn(X, y, config=TOY, max_epochs=4, seed=0, sample_weight=weight)
    _, confusion = evaluate(res.model, *held_out)
    assert confusion[:, 4].sum() < 0.1 * confusion[4].sum()  # (almost) never predicted
    assert confusion[1, 1] > 0.9 * confusion[1].sum()  # the others are still learnt


def test_finetune_from_init_state(source, held_out):
    X, y = source
    base = train_dcnn(X, y, config=TOY, max_epochs=4, seed=0)
    tuned = train_dcnn(X[:256], y[:256], config=TOY, max_epochs=1, lr=1e-6, init_state=base.model.state_dict())
    assert tuned.settings["init"] == "given weights"
    assert evaluate(tuned.model, *held_out)[0] == pytest.approx(evaluate(base.model, *held_out)[0], abs=0.01)
    with pytest.raises(ValueError):
        train_dcnn(X[:, :5], y, config=DCNNConfig(in_channels=5, filters=16), max_epochs=1,
                   init_state=base.model.state_dict())


def test_bad_inputs(source):
    X, y = source
    with pytest.raises(ValueError):
        train_dcnn(X[:, :6], y, config=DCNNConfig(), max_epochs=1)
    with pytest.raises(ValueError):
        train_dcnn(X, y + 5, max_epochs=1)
    with pytest.raises(ValueError):
        train_dcnn(X, y, X[:1], max_epochs=1)  # one target window: no MMD possible
    bad = X.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError):
        train_dcnn(bad, y, max_epochs=1)


@pytest.fixture(scope="module")
def pretrained(source):
    """Toy weights trained on the source: what a calibration fine-tunes from."""
    X, y = source
    return train_dcnn(X, y, config=TOY, max_epochs=4, seed=0).model.state_dict()


def test_frozen_convolutions_stop_when_the_classes_have_converged(source, pretrained):
    """The adaptation's stop: frozen blocks stay as given, and training ends at the first epoch
    whose class changes on the monitor set are at most ``converged_change`` (none before it);
    judging the epochs does not change the training itself."""
    X, y = source
    X_tgt, y_tgt = toy_windows(400, seed=2, shift=TARGET_SHIFT)
    kw = dict(config=TOY, lam=1e4, seed=0, init_state=pretrained, frozen_blocks=4)
    res = train_dcnn(X, y, X_tgt[y_tgt == 0], max_epochs=40, converged_change=0.02, **kw)
    changed = [h.changed for h in res.history]
    assert res.stop_reason == "converged" and 1 < len(changed) < 40
    assert changed[-1] <= 0.02 and all(c > 0.02 for c in changed[:-1])
    assert res.best_epoch == len(res.history)  # the converged weights are the ones returned
    assert res.settings["trained"] == "dense layers (convolutions frozen)"
    for name, value in res.model.state_dict().items():
        if name.startswith("blocks."):
            torch.testing.assert_close(value, pretrained[name], rtol=0, atol=0)
    assert any(not torch.equal(v, pretrained[k]) for k, v in res.model.state_dict().items())
    # The same epochs without the monitor: the same losses as long as the learning rate has not
    # been halved (after the first epoch whose change is no new low), so judging draws nothing.
    same_lr = next((i + 1 for i in range(1, len(changed)) if changed[i] >= min(changed[:i])), len(changed))
    plain = train_dcnn(X, y, X_tgt[y_tgt == 0], max_epochs=len(changed), patience=len(changed), **kw)
    assert [h.loss for h in plain.history][:same_lr] == [h.loss for h in res.history][:same_lr]
    # A budget too small to converge stops on it.
    short = train_dcnn(X, y, X_tgt[y_tgt == 0], max_epochs=len(changed) - 1, converged_change=0.02, **kw)
    assert short.stop_reason in ("max_epochs", "patience") and len(short.history) == len(changed) - 1


def test_frozen_training_is_repeatable(source, pretrained):
    X, y = source
    X_tgt, y_tgt = toy_windows(300, seed=5, shift=TARGET_SHIFT)
    kw = dict(config=TOY, lam=1e4, max_epochs=3, seed=4, init_state=pretrained, frozen_blocks=4,
              converged_change=0.0)
    a, b = (train_dcnn(X[:600], y[:600], X_tgt[y_tgt == 0], **kw) for _ in range(2))
    assert [h.loss for h in a.history] == [h.loss for h in b.history]
    for name, value in a.model.state_dict().items():
        torch.testing.assert_close(value, b.model.state_dict()[name], rtol=0, atol=0)
