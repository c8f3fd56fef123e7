"""The paper's deep convolutional network (DCNN) for propeller-fault classification.

Input: a batch of windows ``x`` of shape (N, C, T), float32, already standardised per channel
(mean 0, std 1 from the training set). C = 7 for the NIF features (p_dot, q_dot, r_dot in
rad/s^2 and w1^2..w4^2 in (rad/s)^2, before standardisation) or 9 for the CF baseline (roll,
pitch, p, q, r, w1..w4); T = 80 samples.

Architecture (Zhang, Tong, Liao, Zhang, "Simulation-to-reality UAV fault diagnosis with deep
learning"):

    4 x [Conv1d(kernel 3, 64 filters, padding 1) -> ReLU -> MaxPool1d(2)]   (N, 64, T / 16)
    flatten                                                                  (N, 64 * T/16)
    dense 128 -> ReLU            <- "features": the MMD is measured here      (N, 128)
    dropout 0.1 -> dense 128 -> ReLU -> dropout 0.1                           (N, 128)
    dense n+1 -> logits (softmax is applied by the loss / the exported graph) (N, n+1)

Classes, in order: 0 healthy, k propeller of motor k damaged (k = 1..n; n = 4 for the default quad).

Limits: the window must survive ``n_blocks`` halvings (T >= 2**n_blocks, i.e. T >= 16 for the
default 4 blocks); pooling floors odd lengths, as MaxPool1d does.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn

NIF_CHANNELS = 7  # p_dot, q_dot, r_dot, w1^2, w2^2, w3^2, w4^2 (a quad)
CF_CHANNELS = 9  # roll, pitch, p, q, r, w1, w2, w3, w4 (a quad)
POOL = 2  # every block halves the time axis


@dataclass
class DCNNConfig:
    """Shape of the network; the defaults are the paper's NIF model for a quad (written once, here)."""

    in_channels: int = NIF_CHANNELS
    window: int = 80  # T in the paper
    n_classes: int = 5  # healthy + one class per damaged propeller (n + 1 for n rotors)
    filters: int = 64
    kernel: int = 3
    n_blocks: int = 4
    dense: int = 128
    dropout: float = 0.1

    def __post_init__(self) -> None:
        if self.kernel % 2 != 1:
            # "same" padding (kernel // 2) keeps the length only for odd kernels.
            raise ValueError(f"kernel must be odd, got {self.kernel}")
        if self.pooled_length() < 1:
            raise ValueError(
                f"window {self.window} is too short for {self.n_blocks} pooling blocks"
            )

    def pooled_length(self) -> int:
        """Time-axis length after the conv blocks (each MaxPool1d(2) floors)."""
        length = self.window
        for _ in range(self.n_blocks):
            length //= POOL
        return length

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "DCNNConfig":
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


class ConvBlock(nn.Module):
    """Conv1d (same length) -> ReLU -> MaxPool1d(2)."""

    def __init__(self, in_channels: int, filters: int, kernel: int):
        super().__init__()
        self.conv = nn.Conv1d(in_channels, filters, kernel, padding=kernel // 2)
        self.act = nn.ReLU()
        self.pool = nn.MaxPool1d(POOL)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.conv(x)  # (N, C_in, L) -> (N, F, L)
        x = self.act(x)  # (N, F, L)
        return self.pool(x)  # (N, F, L // 2)


class DCNN(nn.Module):
    """The paper's DCNN. ``forward`` gives logits; ``features`` the first dense layer's output."""

    def __init__(self, config: DCNNConfig | None = None):
        super().__init__()
        self.config = config or DCNNConfig()
        cfg = self.config
        blocks = []
        channels = cfg.in_channels
        for _ in range(cfg.n_blocks):
            blocks.append(ConvBlock(channels, cfg.filters, cfg.kernel))
            channels = cfg.filters
        self.blocks = nn.Sequential(*blocks)
        flat = cfg.filters * cfg.pooled_length()  # 64 * 5 = 320 for T = 80
        self.dense1 = nn.Linear(flat, cfg.dense)
        self.dense2 = nn.Linear(cfg.dense, cfg.dense)
        self.head = nn.Linear(cfg.dense, cfg.n_classes)
        self.act = nn.ReLU()
        self.dropout = nn.Dropout(cfg.dropout)

    def conv_features(self, x: torch.Tensor) -> torch.Tensor:
        """The convolution blocks' output, flattened (N, 64 * T // 16): what the dense layers read."""
        return self.blocks(x).flatten(1)  # (N, C, T) -> (N, 64, T // 16) -> (N, 64 * T // 16)

    def dense_features(self, z: torch.Tensor) -> torch.Tensor:
        """First dense layer's activations from :meth:`conv_features` output."""
        return self.act(self.dense1(z))  # (N, 128)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """First dense layer's activations (after ReLU, before dropout): where the MMD is taken."""
        return self.dense_features(self.conv_features(x))  # (N, 128)

    def classify(self, feats: torch.Tensor) -> torch.Tensor:
        """Logits from first-dense features (the rest of the network)."""
        x = self.dropout(feats)  # (N, 128)
        x = self.act(self.dense2(x))  # (N, 128)
        x = self.dropout(x)  # (N, 128)
        return self.head(x)  # (N, n_classes)

    def forward_with_features(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(logits, features) from one pass, so training gets the MMD features for free."""
        feats = self.features(x)  # (N, 128)
        return self.classify(feats), feats  # (N, n_classes), (N, 128)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.classify(self.features(x))  # (N, C, T) -> (N, n_classes)


def count_parameters(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)
