"""Adapt the model to one airframe: the paper's adjusted simulation model + MMD domain adaptation.

Inputs: a calibration :class:`~flightlog_fd.profile.Profile` (ρ, hover throttle, frame, stream
rates, from :func:`~flightlog_fd.calibration.calibrate_profile`) and the HEALTHY flights it came
from. No damaged real flight is ever needed. :func:`flightlog_fd.calibration.calibrate` with
``adapt=True`` (`fdlog calibrate`) runs it.

1. **Adjusted simulation model.** Simulate a family of airframes like this one: random airframes
   (mass, inertia, motor lag, gains...) whose thrust is rescaled so that they hover at the
   logged hover throttle, flown as this frame, with this airframe's unbalance ratios ρ
   (``rho_mode="physical"``: in steady hover motor i is commanded ρ_i times motor 1, as in the
   log), logged like the log (10 Hz motors when the log has them). Damage: one propeller with
   η in ``ETA_RANGE``, from take-off or mid-flight. Of ``ADAPT_FLIGHTS`` simulated flights,
   those whose attitude time constant is within ``TAU_BAND`` of the log's are kept. They fly
   in one vectorised batch per logging profile, the missions mixed inside it: a batch costs
   mostly its per-step overhead, so one batch of 320 costs about what one of 128 did.
2. **Domain adaptation.** Fine-tune the shipped model's weights (``models/default.pt``; from
   scratch when absent) on those windows with loss CE + λ·MMD, the MMD on the first dense
   layer between healthy simulated windows and the log's own (healthy) windows, λ = 1e4. The
   shipped convolution blocks are kept (``ADAPT_FROZEN_BLOCKS``): their outputs are computed
   once per window and only the dense layers, where the MMD is taken, are trained: a step costs
   about a third of a full one (18 vs 57 ms CPU per batch of 128 measured). Training stops when
   it has converged: when the classes the model gives a fixed monitor set (the target windows and 2048 source windows) change from one epoch to
   the next on at most ``ADAPT_CONVERGED_CHANGE`` of it, the learning rate being halved
   whenever that share stops falling (:func:`flightlog_fd.training.train.train_dcnn`); at most
   ``ADAPT_EPOCHS`` epochs of at least ``ADAPT_MIN_EPOCH_STEPS`` steps.
3. **Decision offsets from the healthy flight.** The calibration flight is healthy by definition,
   so the adapted model must call its windows healthy. Per damage class k, the offset b_k is
   chosen so that healthy is at least ``HEALTHY_MARGIN`` times as likely as class k on
   ``HEALTHY_QUANTILE`` of the calibration windows (b_k = 0 when it already is); the runtime
   applies them as p_k·exp(b_k) (:func:`flightlog_fd.model.apply_logit_bias`). This sets the
   false-alarm rate on real healthy data of this airframe, using no damaged data; its cost is
   sensitivity to damage that looks like this airframe's own healthy flight.
4. **Export** the adapted model as ONNX (feature spec and statistics in its metadata) next to the
   profile by putting its weights into the shipped model's graph
   (:func:`flightlog_fd.training.export.export_onnx_like`: milliseconds, where a torch export
   took seconds), and record it in the profile (path + sha256).

Deterministic: the same flights and ``AdaptSettings.seed`` give the same model on the same
machine; nothing depends on the wall clock (``max_seconds`` is off unless asked for).

Time (`results/calibrate_speed.md`): the 45 s ArduPilot sample calibrates in about 18 s of CPU,
a quarter of what 192 x 2.5 flights in batches of 128 and full fine-tuning took even when a
100 s wall-clock cap cut that training to 4 of its 12 epochs; simulating is two thirds of what
is left, training a quarter.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from flightlog_fd.errors import NotDiagnosableError
from flightlog_fd.windows import FeatureSpec, make_windows
from flightlog_fd.flight import Flight
from flightlog_fd.profile import Profile

#: Simulated flights (one batch per logging profile). The filter kept 215 of 320 for the
#: ArduPilot sample, 98-146 for Erle board A's flights, 50-53 for the Crazyflie E9, 184 for the
#: SIH quad, 7-93 for the rrc quad (its good flights 1-3; the old 480 kept 6-160 of them):
#: results/calibrate_speed.md, whose adapted profiles come from these numbers.
ADAPT_FLIGHTS = 320
ADAPT_DURATION_S = 60.0
#: Most epochs; training stops earlier once converged (3-15 epochs on the measured airframes).
ADAPT_EPOCHS = 30
#: Converged: at most 1 % of the monitor windows change class in an epoch. With the shipped
#: convolutions kept and the learning rate fixed, the change settles at 1-4 % epoch to epoch
#: (Erle board A and B flights, step noise); halving the rate then brings it under 1 %.
ADAPT_CONVERGED_CHANGE = 0.01
#: Convolution blocks kept as shipped (all 4: only the dense layers adapt).
ADAPT_FROZEN_BLOCKS = 4
#: Steps per epoch at least (a small source set, e.g. 7 kept flights, is passed over several
#: times), so that the class change between two epochs measures the same amount of training.
ADAPT_MIN_EPOCH_STEPS = 100
#: Damage severities simulated for an adapted model: mild damage matters most to a pilot.
ETA_RANGE = (0.6, 0.97)
LAMBDA_MMD = 1e4
#: Decision offsets: healthy must beat each damage class by this factor on this share of the
#: calibration flight's windows.
HEALTHY_MARGIN = 2.0
HEALTHY_QUANTILE = 0.95
TARGET_STRIDE_DIV = 8
#: Dynamics matching: simulated flights are kept when their attitude time constant (robust scale
#: of the roll/pitch rates over that of their angular accelerations) is within this factor of
#: the calibration log's. A 30 g Crazyflie (~0.05 s) and a 2 kg quad (~0.13 s) differ by 2.5x.
TAU_BAND = 1.35
#: A log whose motors are slower than this is simulated with PX4's default 10 Hz motor logging.
SLOW_MOTORS_HZ = 30.0


@dataclass
class AdaptSettings:
    """How a calibration adapts the model (defaults: the module constants)."""

    n_flights: int = ADAPT_FLIGHTS  # simulated; those like this airframe are kept
    duration_s: float = ADAPT_DURATION_S
    max_epochs: int = ADAPT_EPOCHS
    converged_change: Optional[float] = ADAPT_CONVERGED_CHANGE
    frozen_blocks: int = ADAPT_FROZEN_BLOCKS  # leading conv blocks kept as shipped
    max_seconds: Optional[float] = None  # a wall-clock cap makes the result depend on the machine's load
    lam: float = LAMBDA_MMD
    eta_range: tuple[float, float] = ETA_RANGE
    seed: int = 0
    finetune: bool = True  # start from the shipped model's weights


@dataclass
class AdaptResult:
    onnx_path: Path
    summary: dict


def airframe_family(frame: str, hover_throttle: float):
    """A callable ``(n, rng) -> [Airframe]``: random airframes flown as ``frame`` whose thrust is
    rescaled so that a balanced hover needs ``hover_throttle`` (thrust setpoint, 0..1)."""
    from flightlog_fd.sim.airframe import random_airframes

    hover = float(np.clip(hover_throttle, 0.15, 0.75))

    def draw(n: int, rng: np.random.Generator):
        out = []
        for af in random_airframes(n, rng):
            scale = af.hover_command / hover  # k_f factor that moves the hover command to `hover`
            out.append(replace(af, frame=frame, k_f=af.k_f * scale, k_tau=af.k_tau * scale, gains=None,
                               name=f"{af.name}-like"))
        return out

    return draw


def logging_profiles_for(profile: Profile) -> tuple[str, ...]:
    """The simulator's logging profiles to train with, given how the calibration log was written.

    A PX4 airframe calibrated on a high-rate log will also be diagnosed from default-profile
    logs (10 Hz motors), so both are simulated; a 10 Hz calibration log gets 10 Hz only.
    """
    motors_hz = float(profile.stream_rates.get("motors", 100.0))
    if profile.autopilot == "ardupilot":
        return ("ardupilot",)
    return ("px4_default",) if motors_hz < SLOW_MOTORS_HZ else ("training", "px4_default")


def healthy_decision_offsets(probs: np.ndarray, margin: float = HEALTHY_MARGIN,
                             quantile: float = HEALTHY_QUANTILE) -> np.ndarray:
    """(5,) log-probability offsets so that healthy windows ``probs`` (N, 5) are called healthy.

    b_0 = 0; b_k = -max(0, q(log p_k - log p_0) + log(margin)) with q the ``quantile`` over windows.
    """
    logp = np.log(np.clip(np.asarray(probs, dtype=np.float64), 1e-12, 1.0))
    bias = np.zeros(logp.shape[1])
    if len(logp) == 0:
        return bias
    for k in range(1, logp.shape[1]):
        need = float(np.quantile(logp[:, k] - logp[:, 0], quantile)) + np.log(margin)
        bias[k] = -max(0.0, need)
    return bias


def attitude_time_constant(flight: Flight, rate_hz: float = 50.0) -> float:
    """Robust scale of roll/pitch rates over that of roll/pitch angular accelerations, seconds.

    A size-free signature of how fast the airframe's attitude moves (small quads are fast)."""
    from flightlog_fd.prepared import resample

    segs = resample(flight, rate_hz)
    if not segs:
        return float("nan")
    r = np.concatenate([s.rates[:, :2] for s in segs])
    a = np.concatenate([s.ang_acc[:, :2] for s in segs])
    mad = lambda x: np.median(np.abs(x - np.median(x, axis=0)), axis=0)  # noqa: E731
    return float(np.median(mad(r) / np.maximum(mad(a), 1e-9)))


def target_windows(healthy_flights: Sequence[Flight], spec: FeatureSpec) -> np.ndarray:
    """Raw (unstandardised) healthy target windows for the MMD and the decision offsets.

    They overlap more than diagnosis windows (stride window / TARGET_STRIDE_DIV), so that a short
    calibration flight (a Crazyflie hop is ~16 s airborne) still gives enough of them."""
    dense = FeatureSpec.from_dict({**spec.to_dict(), "stride": max(1, spec.window // TARGET_STRIDE_DIV)})
    return np.concatenate([make_windows(fl, dense).X for fl in healthy_flights])


def dynamics_filter(reference_flights: Sequence[Flight], rate_hz: float):
    """(tau, filter): the reference flights' attitude time constant and a ``flight -> bool`` that
    keeps simulated flights within TAU_BAND of it (None when tau cannot be measured)."""
    tau = float(np.nanmedian([attitude_time_constant(fl, rate_hz) for fl in reference_flights]))
    if not np.isfinite(tau):
        return tau, None

    def like_this_airframe(fl: Flight) -> bool:
        t = attitude_time_constant(fl, rate_hz)
        return bool(np.isfinite(t) and abs(np.log(t / tau)) <= np.log(TAU_BAND))

    return tau, like_this_airframe


def base_model_files(model_path: Optional[Path] = None) -> tuple[Path, Optional[Path]]:
    """The ONNX model to adapt and its torch weights (``.pt`` beside it) when present."""
    from flightlog_fd.model import default_model_path

    onnx_path = Path(model_path) if model_path is not None else Path(default_model_path())
    pt = onnx_path.with_suffix(".pt")
    return onnx_path, (pt if pt.exists() else None)


def adapt_model(profile: Profile, healthy_flights: Sequence[Flight], out_onnx: Path, *,
                settings: AdaptSettings = AdaptSettings(), base_model: Optional[Path] = None,
                progress: Optional[Callable[[str, float], None]] = None) -> AdaptResult:
    """Simulate this airframe, train NIF + DA against its healthy windows, export ONNX to ``out_onnx``.

    ``progress(stage, fraction)`` is called as work advances, stage by stage ("matching the
    dynamics", "simulating", "training", "exporting"). Deterministic for ``settings.seed`` (no
    stage depends on the wall clock unless ``settings.max_seconds`` is set).
    """
    import torch

    from flightlog_fd.model import FaultModel
    from flightlog_fd.training.data import simulate_windows
    from flightlog_fd.training.dcnn import DCNNConfig
    from flightlog_fd.training.export import export_onnx_like
    from flightlog_fd.training.train import predict_proba

    t0 = time.perf_counter()
    report = (lambda stage, frac: progress(stage, frac)) if progress else (lambda stage, frac: None)
    base_onnx, base_pt = base_model_files(base_model)
    base = FaultModel(base_onnx)
    spec = FeatureSpec.from_dict(base.feature_spec)  # same channels, rate, window and statistics
    report("matching the dynamics", 0.0)
    target = target_windows(healthy_flights, spec)
    log_profiles = logging_profiles_for(profile)
    tau, like_this_airframe = dynamics_filter(healthy_flights, spec.rate_hz)
    report("matching the dynamics", 1.0)

    # One vectorised batch per logging profile, the missions mixed inside it.
    batch = -(-settings.n_flights // len(log_profiles))
    report("simulating", 0.0)  # the bar shows the stage as it starts (the first batch takes most of it)
    src = simulate_windows(settings.n_flights, spec, seed=settings.seed, batch=batch, mixed_missions=True,
                           flight_filter=like_this_airframe,
                           airframes=airframe_family(profile.frame, profile.hover_throttle_),
                           rho=np.asarray(profile.rho_, float), rho_mode="physical",
                           duration_s=settings.duration_s, profiles=log_profiles, eta_range=settings.eta_range,
                           progress=lambda d, n: report("simulating", d / n))
    n_kept = len(set(src.names))
    t_sim = time.perf_counter() - t0
    if len(src) == 0 or not (src.y == 0).any():
        raise NotDiagnosableError(healthy_flights[0].path if len(healthy_flights) == 1 else None,
                                  f"none of {settings.n_flights} simulated airframes flies like this one (attitude "
                                  f"time constant {tau:.3f} s): the model cannot be adapted to it; use --no-adapt")
    init = None
    if settings.finetune and base_pt is not None:
        init = torch.load(base_pt, map_location="cpu", weights_only=True)
    report("training", 0.0)
    res = fine_tune(spec.normalise(src.X), src.y, spec.normalise(target), settings, init,
                    DCNNConfig(in_channels=len(spec.channels), window=spec.window),
                    progress=lambda e: report("training", e.epoch / settings.max_epochs))
    report("training", 1.0)
    bias = healthy_decision_offsets(predict_proba(res.model, spec.normalise(target)))
    t_train = time.perf_counter() - t0 - t_sim
    summary = {
        "kind": "calibrated (adjusted simulation model + MMD domain adaptation + healthy decision offsets)",
        "logit_bias": np.round(bias, 4).tolist(),
        "base_model": {"path": str(base_onnx), "sha256": base.sha256, "finetuned": init is not None},
        "data": f"{n_kept} of {settings.n_flights} simulated flights like this airframe (attitude time constant "
                f"{tau:.3f} s +/- x{TAU_BAND}, frame {profile.frame}, hover throttle "
                f"{profile.hover_throttle_:.3f}, rho {np.round(profile.rho_, 4).tolist()}, logging {list(log_profiles)}, "
                f"eta {settings.eta_range}); {len(src)} windows; target: {len(target)} healthy windows from "
                f"{len(healthy_flights)} log(s)",
        "class_counts": np.bincount(src.y, minlength=5).tolist(),
        "trained": res.settings["trained"],
        "epochs": len(res.history), "best_epoch": res.best_epoch, "best_loss": res.best_loss,
        "stop_reason": res.stop_reason, "changed": [round(h.changed, 4) for h in res.history if h.changed is not None],
        "lam": settings.lam, "seed": settings.seed, "domain_adaptation": True,
        "simulate_seconds": round(t_sim, 1), "train_seconds": round(t_train, 1),
    }
    report("exporting", 0.0)
    out_onnx = Path(out_onnx)
    meta = {"feature_spec": spec.to_dict(), "training": summary, "version": f"calibrated-{base.version}",
            "logit_bias": [float(b) for b in bias]}
    summary["total_seconds"] = round(time.perf_counter() - t0, 1)
    export_onnx_like(res.model, base_onnx, out_onnx, metadata=meta)
    report("exporting", 1.0)
    return AdaptResult(out_onnx, summary)


def fine_tune(X_src: np.ndarray, y_src: np.ndarray, X_target: np.ndarray, settings: AdaptSettings,
              init_state: Optional[dict], config, progress=None):
    """The adaptation's training (:func:`flightlog_fd.training.train.train_dcnn`) with ``settings``:
    standardised source windows and labels, standardised healthy target windows, the weights to
    start from (None: from the seed). What `fdlog calibrate` and the experiment's "ours" row run."""
    from flightlog_fd.training.train import train_dcnn

    return train_dcnn(X_src, y_src, X_target, config=config, lam=settings.lam, max_epochs=settings.max_epochs,
                      patience=settings.max_epochs, seed=settings.seed, max_seconds=settings.max_seconds,
                      init_state=init_state, frozen_blocks=settings.frozen_blocks if init_state is not None else 0,
                      converged_change=settings.converged_change, min_epoch_steps=ADAPT_MIN_EPOCH_STEPS,
                      progress=progress)
