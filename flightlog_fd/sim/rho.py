"""The paper's "adjusted simulation model": per-motor unbalance ratios ρ (sim/rho.py; the realistic
airframe imbalance of healthy training airframes is sim/imbalance.py).

A real quadrotor is never balanced: centre of mass off-centre, motors and propellers that differ.
In a steady hover its healthy motors run at different speeds; the paper measures
``ρ_i = mean(w_i) / mean(w_1)`` in hover of one healthy real flight and re-simulates with it, so
that simulated training data looks like that airframe. Two ways to apply ρ (``rho_mode``):

- ``"physical"`` (default): rotor i's thrust AND drag torque are scaled by ``1/ρ_i²``. A balanced
  steady hover needs equal rotor thrusts, so ``k_f/ρ_i² · w_i²`` is the same for every rotor and
  ``w_i ∝ ρ_i``: in the logs, mean(w_com_i)/mean(w_com_1) ≈ ρ_i/ρ_1 (= ρ_i with ρ_1 = 1), i.e. the
  thrust setpoints differ by ρ_i², exactly how an unbalanced real quad looks in its logs.
- ``"paper"``: the paper's literal formula on the motor speed, ``ρ_i(w_i) = (w_i / max w_i) · ρ_i``
  and ``w_i,a = ρ_i(w_i) · w_i``, where ``max w_i`` is motor i's maximum speed (``omega_max``):
  the rotor turns at ``ρ_i · w_i² / omega_max`` instead of ``w_i``. This also reshapes the thrust
  curve (thrust ∝ u² instead of u), so hover commands rise; it is kept to reproduce the paper.

These ρ modes are the paper's experiment and ``fdlog calibrate``'s model of an airframe; the
realistic imbalance of healthy airframes for the shipped model (CoG offset, motor tilt,
coefficient spread) is imbalance.py. ``rho=None`` means balanced (all ones); ``"random"`` draws ρ_1 = 1 and ρ_2..4 = 1 + N(0, 0.03)
clipped to ±0.08 per vehicle.
"""
from __future__ import annotations

from typing import Union

import numpy as np

RHO_MODES = ("physical", "paper")
RANDOM_RHO_STD = 0.03
RANDOM_RHO_CLIP = 0.08

RhoSpec = Union[None, str, np.ndarray, list, tuple]


def resolve_rho(rho: RhoSpec, n: int, rng: np.random.Generator, n_rotors: int = 4) -> np.ndarray:
    """(n, R) unbalance ratios from None / "random" / (R,) / (n, R); R = ``n_rotors`` (4: a quad)."""
    r = n_rotors
    if rho is None:
        return np.ones((n, r))
    if isinstance(rho, str):
        if rho != "random":
            raise ValueError(f"rho must be None, 'random' or an array, got {rho!r}")
        dev = np.clip(rng.normal(0.0, RANDOM_RHO_STD, size=(n, r)), -RANDOM_RHO_CLIP, RANDOM_RHO_CLIP)
        dev[:, 0] = 0.0
        return 1.0 + dev
    arr = np.asarray(rho, dtype=np.float64)
    if arr.shape == (r,):
        arr = np.tile(arr, (n, 1))
    if arr.shape != (n, r):
        raise ValueError(f"rho must have shape ({r},) or ({n}, {r}), got {arr.shape}")
    if np.any(arr <= 0):
        raise ValueError("rho must be positive")
    return arr


def physical_effectiveness(rho: np.ndarray) -> np.ndarray:
    """Thrust/torque scale of each rotor in ``"physical"`` mode: 1/ρ²."""
    return 1.0 / (rho * rho)


def paper_speed_gain(rho: np.ndarray, w: np.ndarray, omega_max: np.ndarray) -> np.ndarray:
    """Speed multiplier of ``"paper"`` mode, ρ_i(w_i) = (w_i / omega_max) · ρ_i (so w_a = gain · w).
    ``rho``, ``w`` (rotors, vehicles); ``omega_max`` (vehicles,): each vehicle's own speed scale."""
    return rho * w / omega_max[None, :]


def check_mode(rho_mode: str) -> str:
    if rho_mode not in RHO_MODES:
        raise ValueError(f"rho_mode must be one of {RHO_MODES}, got {rho_mode!r}")
    return rho_mode
