"""Build the shipped default model: simulated flights only, randomised airframes, no real data.

    python -m flightlog_fd.training.build_default --flights 2400 --test-flights 240 --epochs 50   # ~20 min, 2 cores

Steps: simulate ``--flights`` flights over random airframes (30 g to 5 kg, quad-X and quad-+,
waypoint and pilot-style missions, small random motor imbalance, PX4 high-rate, PX4 default
(10 Hz motors) and ArduPilot logging) -> NIF windows through the same `make_windows` as
diagnosis -> per-channel statistics -> DCNN (no adaptation: there is no target airframe) ->
ONNX with the feature spec in its metadata, plus the torch weights (``default.pt``) that
`fdlog calibrate` fine-tunes. It then measures window accuracy on held-out simulated flights
(other seeds) and, where ``../shared`` is present, on the labelled target sets, and writes the
figures into ``models/default.json`` for the model card.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from flightlog_fd.features import FeatureSpec

#: Logging profiles mixed into the shipped model's training data, batch by batch: real logs
#: come at 250 Hz (PX4 high-rate), with 10 Hz motors (PX4 default) or from ArduPilot.
TRAIN_PROFILES = ("training", "px4_default", "ardupilot", "ardupilot_slow")
#: Without calibration the model cannot tell a weak propeller from an airframe's own imbalance,
#: so it is trained to call healthy what real healthy quads show (per-motor speed ratios within
#: about ±5 %: CrazyPAD E9 [1, 1.053, 0.934, 0.974], an Erle-Copter [1, 0.965, 1.095, 1.044]) and
#: damaged only what exceeds it. Milder damage needs `fdlog calibrate`.
RHO_SIGMA_MAX = 0.05
RHO_CLIP = 0.12
ETA_RANGE = (0.55, 0.85)


def random_imbalance(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 4) unbalance ratios: each flight's spread drawn from U(0, RHO_SIGMA_MAX), motor 1 = 1."""
    sigma = rng.uniform(0.0, RHO_SIGMA_MAX, size=(n, 1))
    rho = 1.0 + np.clip(rng.normal(0.0, 1.0, size=(n, 4)) * sigma, -RHO_CLIP, RHO_CLIP)
    return rho / rho[:, :1]
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "models" / "default.onnx"


def evaluate_targets(model, spec: FeatureSpec) -> dict:
    """Window accuracy and per-flight majority on the labelled ../shared sets (skipped if absent)."""
    from flightlog_fd.training.data import flight_windows
    from flightlog_fd.training.targets import available, crazypad_logs, sih_logs
    from flightlog_fd.training.train import predict_proba

    out = {}
    for name, loader in (("px4_sih_dev", sih_logs), ("crazypad_e9", crazypad_logs)):
        if not available()[name]:
            continue
        logs = loader()
        ws = flight_windows([lg.load() for lg in logs], spec, labels=[lg.truth for lg in logs],
                            names=[lg.name for lg in logs])
        P = predict_proba(model, spec.normalise(ws.X))
        pred = P.argmax(1)
        out[name] = {
            "window_accuracy": float((pred == ws.y).mean()),
            "healthy_window_accuracy": float((pred[ws.y == 0] == 0).mean()) if (ws.y == 0).any() else None,
            "damaged_window_accuracy": float((pred[ws.y > 0] == ws.y[ws.y > 0]).mean()) if (ws.y > 0).any() else None,
            "n_windows": int(len(ws.y)),
            "n_flights": len(logs),
        }
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights", type=int, default=2400)
    ap.add_argument("--test-flights", type=int, default=240)
    ap.add_argument("--epochs", type=int, default=50)
    ap.add_argument("--duration", type=float, default=50.0, help="planned seconds per simulated flight")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--cache", type=Path, default=None, help="npz cache of the simulated training windows")
    args = ap.parse_args(argv)

    from flightlog_fd.training.data import WindowSet, simulate_windows
    from flightlog_fd.training.dcnn import DCNNConfig
    from flightlog_fd.training.export import export_onnx
    from flightlog_fd.training.train import evaluate, train_dcnn
    import torch

    spec = FeatureSpec()
    t0 = time.time()
    if args.cache is not None and args.cache.exists():
        train = WindowSet.load(args.cache)
    else:
        rho = random_imbalance(args.flights, np.random.default_rng([args.seed, 11]))
        train = simulate_windows(args.flights, spec, seed=args.seed, profiles=TRAIN_PROFILES, rho=rho,
                                 eta_range=ETA_RANGE, duration_s=args.duration,
                                 progress=lambda d, n: print(f"simulated {d}/{n} flights ({time.time() - t0:.0f} s)",
                                                             flush=True))
        if args.cache is not None:
            train.save(args.cache)
    test = simulate_windows(args.test_flights, spec, seed=args.seed + 1000, profiles=TRAIN_PROFILES,
                            rho=random_imbalance(args.test_flights, np.random.default_rng([args.seed, 12])),
                            eta_range=ETA_RANGE, duration_s=args.duration)
    print(f"windows: train {len(train)} {np.bincount(train.y, minlength=5).tolist()}, test {len(test)}", flush=True)
    spec.fit(train.X)
    t1 = time.time()
    res = train_dcnn(spec.normalise(train.X), train.y, None, config=DCNNConfig(in_channels=len(spec.channels)),
                     max_epochs=args.epochs, seed=args.seed,
                     progress=lambda e: print(f"epoch {e.epoch} loss {e.loss:.4f} ({time.time() - t1:.0f} s)",
                                              flush=True))
    sim_acc, sim_conf = evaluate(res.model, spec.normalise(test.X), test.y)
    targets = evaluate_targets(res.model, spec)
    summary = {
        "data": f"{args.flights} simulated flights (random airframes 30 g-5 kg, quad-X and quad-+, waypoint and "
                f"pilot-style missions, motor imbalance rho ~ 1 + N(0, s), s ~ U(0, {RHO_SIGMA_MAX}), damage eta in {ETA_RANGE}, "
                f"logging {list(TRAIN_PROFILES)}), "
                f"{len(train)} NIF windows; no real data",
        "class_counts": np.bincount(train.y, minlength=5).tolist(),
        "epochs": len(res.history), "best_epoch": res.best_epoch, "best_loss": res.best_loss,
        "seed": args.seed, "lam": 0.0, "domain_adaptation": False,
        "sim_test": {"flights": args.test_flights, "windows": len(test), "window_accuracy": sim_acc,
                     "confusion": np.asarray(sim_conf).tolist()},
        "targets": targets,
        "command": "python -m flightlog_fd.training.build_default " + " ".join(
            f"--{k.replace('_', '-')} {v}" for k, v in vars(args).items() if k not in ("out", "cache")),
        "train_seconds": round(time.time() - t0, 1),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    export_onnx(res.model, args.out, metadata={"feature_spec": spec.to_dict(), "training": summary,
                                                "version": "default-1"})
    torch.save(res.model.state_dict(), args.out.with_suffix(".pt"))
    args.out.with_suffix(".json").write_text(json.dumps(summary, indent=2))
    print(json.dumps({k: summary[k] for k in ("sim_test", "targets")}, indent=2))


if __name__ == "__main__":
    main()
