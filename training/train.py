"""Training loop for the DCNN, with optional MMD domain adaptation to healthy real flights.

Inputs (plain numpy, so this module does not depend on how windows are made):
  X_src (N, C, T) float32, standardised source (simulated) windows; y_src (N,) int class labels
  0 healthy, 1..4 propeller 1..4 damaged; optional X_tgt_healthy (M, C, T) float32 healthy
  real windows, standardised with the SAME mean/std as the source (no labels needed: they are
  all healthy); optional sample_weight (N,) >= 0 weights for the source cross-entropy.

Loss per step (the paper's): CE(source batch) + lam * MMD^2(f(healthy source), f(healthy target))
where f is the first dense layer (DCNN.features) and MMD^2 the multi-bandwidth Gaussian estimate
of training/mmd.py (median-heuristic bandwidth from the pooled batch, detached). Every step draws,
besides the shuffled source batch of ``batch`` windows, a separate mini-batch of ``mmd_batch``
healthy source windows and ``mmd_batch`` healthy target windows (cycling through their own
shuffles), so the MMD never runs on the handful of healthy windows a random batch happens to hold.
The three go through the network in one forward pass (features are taken before dropout, so the
extra rows do not change the result).

Two choices the paper leaves open, made so that lam = 1e4 trains (measured on toy data, see
tests/test_train.py): (1) the UNBIASED MMD^2 estimator: the biased one has a positive floor
(1 - mean within-set kernel) / batch that lam = 1e4 turns into a force of ~150x the CE which
collapses all features to a point (CE stuck at chance); the unbiased one has no such floor.
(2) a warm-up: the first WARMUP_STEPS = 300 steps (rounded up to whole epochs; 2 epochs for 20k
windows; none when fine-tuning given weights) optimise the CE alone, because an MMD term that
large on untrained features drowns the CE gradient and the network learns slowly or not at all
(toy, 10k windows, 10 epochs: 75 % source accuracy without warm-up, 99 % with one epoch). The reported loss of every epoch,
including warm-up ones, is the full CE + lam * MMD^2, so early stopping and model keeping watch
the paper's objective. Being unbiased, the per-epoch MMD^2 mean can be slightly negative; with
lam = 1e4 its noise (~1e-3) moves the loss by ~10, far more than the CE changes late in training.

Optimisation (the paper's): Adam, lr 5e-4, batch 128, at most 50 epochs; the training loss of an
epoch is the mean of the step losses (CE + lam * MMD^2); training stops after ``patience`` epochs
without a lower training loss (or when ``max_seconds`` of wall time are used up, checked after
every epoch) and the weights of the epoch with the lowest training loss are restored. No model
selection ever uses labelled target data.

Repeatability: one ``seed`` sets torch's generator (weights, dropout) and a numpy Generator
(shuffles); same inputs and seed give the same model on the same machine. CPU only; torch runs
on ``threads`` (default TORCH_THREADS = 1, see there why) threads while training and predicting,
restored afterwards.
"""
from __future__ import annotations

import contextlib
import copy
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
import torch
import torch.nn.functional as F

from flightlog_fd.training.dcnn import DCNN, DCNNConfig
from flightlog_fd.training.mmd import mmd2

LAMBDA_MMD = 1e4  # paper's weight of the MMD term
LEARNING_RATE = 5e-4
BATCH_SIZE = 128
MAX_EPOCHS = 50
PATIENCE = 10  # epochs without a lower training loss before stopping
MMD_BATCH = 64  # healthy source + healthy target windows per step for the MMD
WARMUP_STEPS = 300  # CE-only optimiser steps (rounded up to whole epochs) before the MMD joins
HEALTHY = 0  # class index of healthy windows
# One thread: the network's ops are small, and on the 2-core machines this runs on (shared with
# other processes) 2 OpenMP threads measured 10-25x SLOWER per step (186 vs 7 ms for the
# 16-filter test network, 540 vs 28 ms for the paper's) because the threads spin-wait for
# cores that are busy.
TORCH_THREADS = 1
PREDICT_BATCH = 4096  # windows per forward pass at inference
#: Source windows in the convergence monitor set (with every target window): enough that a
#: 1 % change is ~20 windows, few enough that judging an epoch costs a small part of it.
MONITOR_SOURCE_WINDOWS = 2048
#: With a convergence stop: epochs without a new least class change before the learning rate is
#: multiplied by CONVERGE_LR_FACTOR. Measured on the adaptation of the Erle board-A flight
#: 09-10-2014_25 (frozen convolutions, lr 5e-4): the change stays at 1.1-4 % from epoch 5 to 60.
CONVERGE_PLATEAU_EPOCHS = 1
CONVERGE_LR_FACTOR = 0.5


@dataclass
class EpochStats:
    """One epoch's means over its steps."""

    epoch: int  # 1-based
    loss: float  # CE + lam * MMD^2, the quantity early stopping watches
    ce: float
    mmd2: float  # unbiased estimate, may be slightly negative; 0.0 when no target data
    accuracy: float  # on the (dropout-perturbed) training batches
    seconds: float
    #: share of the monitor set whose class changed since the previous epoch (None unless
    #: ``converged_change`` is given)
    changed: Optional[float] = None


@dataclass
class TrainResult:
    """The best model (lowest training loss, already in eval mode) and how it got there."""

    model: DCNN
    history: list[EpochStats]
    best_epoch: int
    best_loss: float
    stop_reason: str  # "max_epochs" | "patience" | "max_seconds" | "converged"
    seconds: float
    settings: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """JSON-ready summary for the model file's metadata."""
        best = self.history[self.best_epoch - 1]
        return {
            **self.settings,
            "epochs_run": len(self.history),
            "best_epoch": self.best_epoch,
            "best_loss": self.best_loss,
            "best_ce": best.ce,
            "best_mmd2": best.mmd2,
            "stop_reason": self.stop_reason,
            "seconds": round(self.seconds, 2),
            "model_config": self.model.config.to_dict(),
        }


@contextlib.contextmanager
def limited_threads(threads: int):
    """Run torch on ``threads`` intra-op threads inside the block, restoring the previous count."""
    previous = torch.get_num_threads()
    torch.set_num_threads(max(1, threads))
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def _check_windows(name: str, X: np.ndarray, config: DCNNConfig) -> None:
    if X.ndim != 3 or X.shape[1] != config.in_channels or X.shape[2] != config.window:
        raise ValueError(
            f"{name} must be (N, {config.in_channels}, {config.window}), got {X.shape}"
        )
    if not np.isfinite(X).all():
        raise ValueError(f"{name} holds NaN or infinite values")


def _frozen_outputs(blocks: torch.nn.Module, X: torch.Tensor) -> torch.Tensor:
    """The output of the frozen leading conv ``blocks`` for windows ``X`` (N, C, T), in batches."""
    with torch.no_grad():
        return torch.cat([blocks(X[i : i + PREDICT_BATCH]) for i in range(0, len(X), PREDICT_BATCH)])


def _classes(model: DCNN, features: Callable, X: torch.Tensor) -> torch.Tensor:
    """Most probable class (N,) of inputs ``X`` (windows, or conv outputs with frozen blocks), eval mode."""
    was_training = model.training
    model.eval()
    with torch.no_grad():
        out = torch.cat([model.classify(features(X[i : i + PREDICT_BATCH])).argmax(1)
                         for i in range(0, len(X), PREDICT_BATCH)])
    model.train(was_training)
    return out


def _cycle_batches(indices: np.ndarray, size: int, rng: np.random.Generator):
    """Endless mini-batches of ``size`` drawn without replacement from reshuffled ``indices``."""
    size = min(size, len(indices))
    order = rng.permutation(indices)
    pos = 0
    while True:
        if pos + size > len(order):
            order = rng.permutation(indices)
            pos = 0
        yield order[pos : pos + size]
        pos += size


def train_dcnn(
    X_src: np.ndarray,
    y_src: np.ndarray,
    X_tgt_healthy: Optional[np.ndarray] = None,
    *,
    config: DCNNConfig | None = None,
    lam: float = LAMBDA_MMD,
    lr: float = LEARNING_RATE,
    batch: int = BATCH_SIZE,
    max_epochs: int = MAX_EPOCHS,
    patience: int = PATIENCE,
    seed: int = 0,
    progress: Optional[Callable[[EpochStats], None]] = None,
    max_seconds: Optional[float] = None,
    sample_weight: Optional[np.ndarray] = None,
    mmd_batch: int = MMD_BATCH,
    mmd_bandwidth: float | None = None,
    warmup_steps: Optional[int] = None,
    init_state: Optional[dict] = None,
    threads: int = TORCH_THREADS,
    frozen_blocks: int = 0,
    converged_change: Optional[float] = None,
    monitor_windows: int = MONITOR_SOURCE_WINDOWS,
    min_epoch_steps: int = 1,
) -> TrainResult:
    """Train a DCNN on source windows, aligning healthy features with ``X_tgt_healthy`` if given.

    ``init_state`` (a DCNN state dict with the same config) starts from trained weights, e.g. to
    fine-tune the shipped model with domain adaptation; otherwise the weights start from ``seed``.
    ``warmup_steps`` CE-only steps (rounded up to whole epochs) come before the MMD joins the
    optimised loss; default WARMUP_STEPS from random weights, 0 when fine-tuning ``init_state``
    (its features are already trained). ``progress(stats)`` is called after every epoch;
    ``sample_weight`` weights the source CE.

    ``frozen_blocks``: keep the first this many convolution blocks as given (``init_state``) and
    train the rest; their outputs are then computed once for every window instead of every
    step (the first blocks, on the longest sequences, cost the most). ``converged_change``:
    stop once the classes the model gives a fixed monitor set (every target window and up to
    ``monitor_windows`` source windows) change, from one epoch to the next, on at most this
    share of it (after the warm-up; the first epoch compares with the
    starting weights): the adaptation has converged. The weights kept are then that epoch's.
    Meanwhile the learning rate is halved whenever that share has not reached a new low for
    CONVERGE_PLATEAU_EPOCHS epochs (the changes left are then the steps' noise).
    ``min_epoch_steps``: an epoch passes over a small source several times, so that it holds at
    least this many steps (the epochs between two judgements then move the weights alike).
    """
    config = config or DCNNConfig(in_channels=X_src.shape[1], window=X_src.shape[2])
    X_src = np.ascontiguousarray(X_src, dtype=np.float32)
    y_src = np.asarray(y_src, dtype=np.int64)
    _check_windows("X_src", X_src, config)
    if y_src.shape != (len(X_src),):
        raise ValueError(f"y_src must be ({len(X_src)},), got {y_src.shape}")
    if len(X_src) == 0:
        raise ValueError("no source windows to train on")
    if y_src.min() < 0 or y_src.max() >= config.n_classes:
        raise ValueError(f"labels must be in 0..{config.n_classes - 1}")
    weights = None
    if sample_weight is not None:
        weights = np.asarray(sample_weight, dtype=np.float32)
        if weights.shape != y_src.shape or (weights < 0).any() or not np.isfinite(weights).all():
            raise ValueError("sample_weight must be (N,) finite and >= 0")
        weights = torch.from_numpy(weights)
    use_mmd = X_tgt_healthy is not None and lam > 0
    healthy_src = np.flatnonzero(y_src == HEALTHY)
    if use_mmd:
        X_tgt_healthy = np.ascontiguousarray(X_tgt_healthy, dtype=np.float32)
        _check_windows("X_tgt_healthy", X_tgt_healthy, config)
        # The MMD needs >= 2 rows per side to have a median distance between distinct points.
        if len(X_tgt_healthy) < 2 or len(healthy_src) < 2:
            raise ValueError("domain adaptation needs >= 2 healthy source and >= 2 target windows")

    with limited_threads(threads):
        torch.manual_seed(seed)
        rng = np.random.default_rng(seed)
        model = DCNN(config)
        if init_state is not None:
            try:
                model.load_state_dict(init_state)
            except (RuntimeError, KeyError) as e:
                raise ValueError(f"init_state does not fit a DCNN with {config}: {e}") from None
        X_src_t = torch.from_numpy(X_src)  # (N, C, T), shares memory
        y_src_t = torch.from_numpy(y_src)  # (N,)
        X_tgt_t = torch.from_numpy(X_tgt_healthy) if use_mmd else None  # (M, C, T)
        if not 0 <= frozen_blocks <= len(model.blocks):
            raise ValueError(f"frozen_blocks must be 0..{len(model.blocks)}, got {frozen_blocks}")
        if frozen_blocks:
            # Frozen blocks never change: their outputs are the inputs of what is trained.
            frozen, trained = model.blocks[:frozen_blocks], model.blocks[frozen_blocks:]
            for p in frozen.parameters():
                p.requires_grad_(False)
            X_src_t = _frozen_outputs(frozen, X_src_t)  # (N, 64, T // 2**frozen_blocks)
            X_tgt_t = _frozen_outputs(frozen, X_tgt_t) if use_mmd else None

            def features(z: torch.Tensor) -> torch.Tensor:
                return model.dense_features(trained(z).flatten(1))  # (N, 128)
        else:
            features = model.features
        optimiser = torch.optim.Adam([p for p in model.parameters() if p.requires_grad], lr=lr)
        if use_mmd:
            src_healthy_batches = _cycle_batches(healthy_src, mmd_batch, rng)
            tgt_batches = _cycle_batches(np.arange(len(X_tgt_healthy)), mmd_batch, rng)
        monitor = None
        if converged_change is not None:
            # A fixed subsample of the source (drawn from its own generator so that the training
            # draws are those of a run without it) and every target window.
            pick = np.sort(np.random.default_rng([seed, 1]).permutation(len(X_src))[:monitor_windows])
            monitor = X_src_t[torch.from_numpy(pick)]
            if use_mmd:
                monitor = torch.cat([monitor, X_tgt_t])
            previous = _classes(model, features, monitor)
            least_change, since_least = float("inf"), 0

        # An epoch is one pass over the source, or as many passes as make min_epoch_steps steps.
        passes = max(1, -(-min_epoch_steps // -(-len(X_src) // batch)))
        steps_per_epoch = -(-len(X_src) * passes // batch)
        warmup_epochs = 0
        if use_mmd and warmup_steps is None:
            # The default: WARMUP_STEPS from random weights, but at most a fifth of the epochs so
            # that a small source set still leaves room for the MMD; none when fine-tuning.
            warmup_epochs = 0 if init_state is not None else min(-(-WARMUP_STEPS // steps_per_epoch),
                                                                 max(1, max_epochs // 5))
        elif use_mmd:
            warmup_epochs = -(-warmup_steps // steps_per_epoch)

        history: list[EpochStats] = []
        best_loss, best_epoch, best_state = float("inf"), 0, None
        stop_reason = "max_epochs"
        start = time.perf_counter()
        for epoch in range(1, max_epochs + 1):
            epoch_start = time.perf_counter()
            model.train()
            order = torch.from_numpy(np.concatenate([rng.permutation(len(X_src)) for _ in range(passes)]))
            sums = {"loss": 0.0, "ce": 0.0, "mmd2": 0.0, "correct": 0}
            n_steps = 0
            for first in range(0, len(order), batch):
                idx = order[first : first + batch]
                xb = X_src_t[idx]  # (B, C, T)
                yb = y_src_t[idx]  # (B,)
                if use_mmd:
                    xs = X_src_t[torch.from_numpy(next(src_healthy_batches))]  # (Bm, C, T)
                    xt = X_tgt_t[torch.from_numpy(next(tgt_batches))]  # (Bm', C, T)
                    feats = features(torch.cat([xb, xs, xt]))  # (B + Bm + Bm', 128)
                    logits = model.classify(feats[: len(xb)])  # (B, 5)
                    f_src, f_tgt = feats[len(xb) : len(xb) + len(xs)], feats[len(xb) + len(xs) :]
                    mmd_term = mmd2(f_src, f_tgt, bandwidth=mmd_bandwidth, unbiased=True)  # scalar
                else:
                    logits = model.classify(features(xb))  # (B, 5)
                    mmd_term = torch.zeros(())
                if weights is None:
                    ce = F.cross_entropy(logits, yb)
                else:
                    wb = weights[idx]  # (B,)
                    ce = (F.cross_entropy(logits, yb, reduction="none") * wb).sum() / wb.sum().clamp_min(1e-12)
                # Reported (and early-stopping) loss always uses the full lam; the optimised one
                # leaves the MMD out during the warm-up epochs (see the module docstring).
                full_loss = ce + lam * mmd_term if use_mmd else ce
                loss = full_loss if epoch > warmup_epochs else ce
                optimiser.zero_grad(set_to_none=True)
                loss.backward()
                optimiser.step()
                sums["loss"] += full_loss.item()
                sums["ce"] += ce.item()
                sums["mmd2"] += mmd_term.item()
                sums["correct"] += int((logits.argmax(1) == yb).sum())
                n_steps += 1
            stats = EpochStats(
                epoch=epoch,
                loss=sums["loss"] / n_steps,
                ce=sums["ce"] / n_steps,
                mmd2=sums["mmd2"] / n_steps,
                accuracy=sums["correct"] / len(order),
                seconds=time.perf_counter() - epoch_start,
            )
            if monitor is not None:
                classes = _classes(model, features, monitor)
                stats.changed = float((classes != previous).float().mean())
                previous = classes
                # At a fixed step size the classes keep changing at the level of the gradient
                # noise; when that level stops falling, halve the step size, so it falls again.
                if stats.changed < least_change:
                    least_change, since_least = stats.changed, 0
                else:
                    since_least += 1
                if since_least >= CONVERGE_PLATEAU_EPOCHS:
                    for group in optimiser.param_groups:
                        group["lr"] *= CONVERGE_LR_FACTOR
                    least_change, since_least = float("inf"), 0
            history.append(stats)
            if progress is not None:
                progress(stats)
            # Warm-up epochs optimise CE alone, so their full loss (with the un-optimised MMD) is
            # no measure of the model: they are never kept as best and do not use up patience.
            if epoch <= warmup_epochs:
                pass
            elif monitor is not None and stats.changed <= converged_change:
                best_loss, best_epoch = stats.loss, epoch
                best_state = copy.deepcopy(model.state_dict())
                stop_reason = "converged"
                break
            elif stats.loss < best_loss:
                best_loss, best_epoch = stats.loss, epoch
                best_state = copy.deepcopy(model.state_dict())
            elif epoch - max(best_epoch, warmup_epochs) >= patience:
                stop_reason = "patience"
                break
            if max_seconds is not None and time.perf_counter() - start >= max_seconds:
                stop_reason = "max_seconds"
                break
        seconds = time.perf_counter() - start
        if best_state is None:
            # Only if every epoch's loss was NaN: keep the last weights rather than none.
            best_state, best_epoch, best_loss = model.state_dict(), len(history), float("nan")
        model.load_state_dict(best_state)
        model.eval()

    settings = {
        "n_source_windows": int(len(X_src)),
        "n_source_per_class": np.bincount(y_src, minlength=config.n_classes).tolist(),
        "n_target_healthy_windows": int(len(X_tgt_healthy)) if use_mmd else 0,
        "lam": float(lam) if use_mmd else 0.0,
        "lr": lr,
        "batch": batch,
        "mmd_batch": mmd_batch if use_mmd else 0,
        "mmd_estimator": "unbiased, median-heuristic multi-bandwidth Gaussian" if use_mmd else None,
        "warmup_epochs": warmup_epochs,
        "max_epochs": max_epochs,
        "patience": patience,
        "seed": seed,
        "weighted": weights is not None,
        "init": "given weights" if init_state is not None else f"random (seed {seed})",
        "trained": ("all layers" if not frozen_blocks else f"all but the first {frozen_blocks} convolution blocks"
                    if frozen_blocks < config.n_blocks else "dense layers (convolutions frozen)"),
        "converged_change": converged_change,
        "passes_per_epoch": passes,
    }
    return TrainResult(model, history, best_epoch, best_loss, stop_reason, seconds, settings)


def predict_proba(
    model: DCNN, X: np.ndarray, batch: int = PREDICT_BATCH, threads: int = TORCH_THREADS
) -> np.ndarray:
    """Class probabilities (N, n_classes) float32 for standardised windows X (N, C, T)."""
    X = np.ascontiguousarray(X, dtype=np.float32)
    n_classes = model.config.n_classes
    if len(X) == 0:
        return np.zeros((0, n_classes), dtype=np.float32)
    was_training = model.training
    model.eval()
    out = []
    with torch.no_grad(), limited_threads(threads):
        for first in range(0, len(X), batch):
            logits = model(torch.from_numpy(X[first : first + batch]))  # (b, 5)
            out.append(torch.softmax(logits, 1).numpy())
    model.train(was_training)
    return np.concatenate(out)


def evaluate(model: DCNN, X: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """(accuracy, confusion) on labelled windows; confusion[true, predicted] counts (5 x 5)."""
    y = np.asarray(y, dtype=np.int64)
    n_classes = model.config.n_classes
    predicted = predict_proba(model, X).argmax(1)
    confusion = np.zeros((n_classes, n_classes), dtype=np.int64)
    np.add.at(confusion, (y, predicted), 1)
    accuracy = float((predicted == y).mean()) if len(y) else float("nan")
    return accuracy, confusion
