"""Model variants against the shipped recipe at reduced scale: same data, same seed, one table.

    python -m flightlog_fd.training.variants simulate --flights 1600 --test-flights 320 --out build/variants
    python -m flightlog_fd.training.variants train base --epochs 20 --out build/variants
    python -m flightlog_fd.training.variants import-build candidate --build build/candidate/default.onnx --out build/variants
    python -m flightlog_fd.training.variants table --out build/variants

``simulate`` flies ``--flights`` training quads (seed 0) and ``--test-flights`` held-out ones (seed
1000) with the shipped model's distribution (``build_default.sim_kwargs``), in batches of 40 / 32 so
that every mission x logging-profile pair is flown, and windows the same flights twice: the
shipped 80-sample windows and 160-sample ones (3.2 s, a longer receptive field). ``train NAME``
trains one variant (:data:`VARIANTS`) with ``build_default``'s optimiser (Adam 5e-4, batch 128,
cross-entropy, lowest training loss kept), one torch thread, and writes its held-out figures
(window accuracy, healthy windows called healthy, damaged windows right, the same without mild
damage eta >= 0.9, training loss and accuracy per epoch, to see whether they still move) to
``NAME.json``. ``table`` prints every variant measured. The paper's DCNN stays in
``training/experiment.py``; these variants are DCNNs (``DCNNConfig``). ``fdlog calibrate``
(``training/adapt.py``) builds the default DCNN shape for the model's window, so it adapts the
variants of the shipped shape (data, epochs, dropout, loads, the candidate) as they are; kernel7,
wide and win160 would need it to read the shape from the model's metadata."""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

#: name -> (window samples, DCNNConfig overrides, share of the training flights used; -1: all flights,
#: every second window)
VARIANTS = {
    "base": (80, {}, 0.5),  # the shipped recipe on the first half of the flights
    "quarter_data": (80, {}, 0.25),  # data volume: a quarter
    "double_data": (80, {}, 1.0),  # data volume: all the flights (run it with half the epochs: same compute)
    # twice the airframes, every second window of each (the base's window count and compute): windows of
    # one flight share its airframe, so airframes, not windows, may be what the model lacks
    "double_airframes": (80, {}, -1.0),
    "kernel7": (80, {"kernel": 7}, 0.5),  # longer receptive field inside the 1.6 s window
    "wide": (80, {"filters": 128, "dense": 256}, 0.5),  # capacity
    "dropout": (80, {"dropout": 0.3}, 0.5),  # regularisation against memorised airframes
    "win160": (160, {}, 0.5),  # 3.2 s windows (flight context by length)
    "loads": ("80_loads", {}, 1.0),  # the base's 800 flights' worth, half of them carrying random loads
}


def _paths(out: Path, window) -> tuple[Path, Path]:
    return out / f"train_w{window}.npz", out / f"test_w{window}.npz"


def simulate(out: Path, flights: int, test_flights: int) -> None:
    from flightlog_fd.training.build_default import sim_kwargs
    from flightlog_fd.training.data import simulate_window_sets
    from flightlog_fd.windows import FeatureSpec

    out.mkdir(parents=True, exist_ok=True)
    specs = [FeatureSpec(window=80), FeatureSpec(window=160)]
    t0 = time.time()
    for n, seed, batch, which in ((flights, 0, 40, 0), (test_flights, 1000, 32, 1)):
        sets = simulate_window_sets(n, specs, seed=seed, batch=batch, duration_s=50.0, **sim_kwargs(),
                                    progress=lambda d, m: print(f"seed {seed}: {d}/{m} flights ({time.time() - t0:.0f} s)",
                                                                flush=True))
        for spec, ws in zip(specs, sets):
            ws.save(_paths(out, spec.window)[which])
            print(f"window {spec.window}: {len(ws)} windows", flush=True)


#: Share of the flights that carry a random load (sim/loads.py random_loads: fixed point loads, a
#: moved battery, a swinging payload) in the ``--loads`` sets.
LOADED_FRACTION = 0.5


def simulate_loads(out: Path, flights: int, test_flights: int) -> None:
    """Training (seed 0) and held-out (seed 1000) 80-sample windows like :func:`simulate`, with
    LOADED_FRACTION of the airframes carrying a random flyable load (drawn with the airframe's
    damage and imbalance, so that it can hover): ``train_w80_loads.npz`` / ``test_w80_loads.npz``."""
    from flightlog_fd.prepared import PreparedFlight
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import random_damages
    from flightlog_fd.sim.imbalance import random_imbalances
    from flightlog_fd.sim.loads import random_loads
    from flightlog_fd.training.build_default import (ETA_RANGE, HEALTHY_FRACTION, MILD_FRACTION, NOISE,
                                                     TORQUE_EXPONENT_RANGE, TRAIN_PROFILES)
    from flightlog_fd.training.data import DEFAULT_MISSIONS, WindowSet, flight_windows
    from flightlog_fd.windows import FeatureSpec

    spec = FeatureSpec()
    t0 = time.time()
    for n_all, seed, batch, name in ((flights, 0, 40, "train"), (test_flights, 1000, 32, "test")):
        sets, done, b, refused = [], 0, 0, 0
        while done < n_all:
            n = min(batch, n_all - done)
            mission = DEFAULT_MISSIONS[b % len(DEFAULT_MISSIONS)]
            profile = TRAIN_PROFILES[(b // len(DEFAULT_MISSIONS)) % len(TRAIN_PROFILES)]
            afs = random_airframes(n, np.random.default_rng([seed, b, 11]))
            imbs = random_imbalances(afs, np.random.default_rng([seed, b, 12]))
            dmgs = random_damages(afs, np.full(n, 50.0), np.random.default_rng([seed, b, 13]),
                                  healthy_fraction=HEALTHY_FRACTION, eta_range=ETA_RANGE, mild_fraction=MILD_FRACTION,
                                  torque_exponent_range=TORQUE_EXPONENT_RANGE)
            loads = random_loads(afs, np.random.default_rng([seed, b, 14]), loaded_fraction=LOADED_FRACTION,
                                 damages=dmgs, imbalances=imbs)
            kw = dict(airframes=afs, damages=dmgs, imbalance=imbs, mission=mission, duration_s=50.0, profile=profile,
                      seed=int(np.random.default_rng([seed, b]).integers(2**31)), noise=NOISE, accelerometer=False)
            refused_now = False
            try:
                fls = simulate_flights(n, loads=loads, **kw)
            except ValueError as e:  # a load the flown damage cannot carry: this batch flies without
                refused += 1
                refused_now = True
                print(f"batch {b}: {e}; flown without loads", flush=True)
                fls = simulate_flights(n, **kw)
            fls = [PreparedFlight(f) for f in fls]
            loaded = [bool(ld) and not refused_now for ld in loads]  # names end -L (loaded) / -N
            sets.append(flight_windows(fls, spec, names=[f"{name}{seed}-{b}-{i}-{'L' if loaded[i] else 'N'}"
                                                         for i in range(n)]))
            done += n
            b += 1
            print(f"{name} with loads: {done}/{n_all} flights ({time.time() - t0:.0f} s)", flush=True)
        ws = WindowSet.concat(sets)
        ws.save(out / f"{name}_w80_loads.npz")
        print(f"{name}: {len(ws)} windows, {refused} batches flown without loads", flush=True)


def train(name: str, out: Path, epochs: int, seed: int = 0, tag: str = "") -> dict:
    import torch

    from flightlog_fd.training.data import WindowSet
    from flightlog_fd.training.dcnn import DCNNConfig, count_parameters
    from flightlog_fd.training.train import predict_proba, train_dcnn
    from flightlog_fd.windows import FeatureSpec

    window, overrides, share = VARIANTS[name]
    tr_path, te_path = _paths(out, window)
    window = int(str(window).split("_")[0])
    train_ws, test_ws = WindowSet.load(tr_path), WindowSet.load(te_path)
    if share < 0:  # every flight, every second window
        keep = np.zeros(len(train_ws), bool)
        keep[::2] = True
    elif share < 1.0:
        keep = np.isin(train_ws.flight, np.unique(train_ws.flight)[: int(share * (train_ws.flight.max() + 1))])
    if share != 1.0:
        train_ws = WindowSet(train_ws.X[keep], train_ws.y[keep], train_ws.flight[keep], train_ws.t_start[keep],
                             train_ws.t_end[keep], train_ws.eta[keep], train_ws.names)
    spec = FeatureSpec(window=window).fit(train_ws.X)
    Xtr, Xte, y = spec.normalise(train_ws.X), spec.normalise(test_ws.X), test_ws.y
    mild = (y > 0) & (test_ws.eta >= 0.9)
    cfg = DCNNConfig(in_channels=7, window=window, **overrides)
    per_epoch = []

    def progress(e):
        print(f"{name} epoch {e.epoch} loss {e.loss:.4f} train acc {e.accuracy:.3f} ({e.seconds:.0f} s)", flush=True)
        per_epoch.append({"epoch": e.epoch, "loss": round(e.loss, 4), "train_acc": round(e.accuracy, 4),
                          "seconds": round(e.seconds, 1)})

    t0 = time.time()
    res = train_dcnn(Xtr, train_ws.y, None, config=cfg, max_epochs=epochs, patience=epochs, seed=seed,
                     progress=progress)
    P = predict_proba(res.model, Xte)
    pred = P.argmax(1)
    d = y > 0
    out_d = {
        "name": name + tag, "window": window, "config": cfg.to_dict(), "parameters": count_parameters(res.model),
        "train_windows": int(len(train_ws)), "train_flights": int(len(np.unique(train_ws.flight))),
        "test_windows": int(len(y)), "epochs": epochs, "best_epoch": res.best_epoch, "seed": seed,
        "train_seconds": round(time.time() - t0, 1),
        "window_accuracy": float((pred == y).mean()),
        "healthy_called_healthy": float((pred[y == 0] == 0).mean()),
        "damaged_right": float((pred[d] == y[d]).mean()),
        "accuracy_without_mild": float((pred[~mild] == y[~mild]).mean()),
        "damaged_right_without_mild": float((pred[d & ~mild] == y[d & ~mild]).mean()),
        "history": per_epoch,
    }
    torch.save({"state": res.model.state_dict(), "config": cfg.to_dict(), "spec": spec.to_dict()}, out / f"{name}{tag}.pt")
    out_d["targets"] = targets(res.model, spec)
    out_d["loads_test"] = loaded_test(res.model, spec, out)
    (out / f"{name}{tag}.json").write_text(json.dumps(out_d, indent=1))
    print(json.dumps({k: v for k, v in out_d.items() if k != "history"}), flush=True)
    return out_d


def targets(model, spec) -> dict:
    """Window accuracy without calibration on the labelled real-format sets (build_default's)."""
    from flightlog_fd.training.build_default import evaluate_targets

    return evaluate_targets(model, spec)


def loaded_test(model, spec, out: Path) -> dict:
    """Held-out figures on the loads set (``simulate-loads``), when it exists: all windows, and the
    healthy windows of loaded and unloaded airframes apart."""
    from flightlog_fd.training.data import WindowSet
    from flightlog_fd.training.train import predict_proba

    path = out / "test_w80_loads.npz"
    if spec.window != 80 or not path.exists():
        return {}
    ws = WindowSet.load(path)
    pred = predict_proba(model, spec.normalise(ws.X)).argmax(1)
    y = ws.y
    loaded = np.array([ws.names[f].endswith("-L") for f in ws.flight])
    d = y > 0
    r = {"window_accuracy": float((pred == y).mean()), "damaged_right": float((pred[d] == y[d]).mean()),
         "windows": int(len(y))}
    for tag, m in (("loaded", loaded), ("unloaded", ~loaded)):
        h = m & (y == 0)
        r[f"healthy_called_healthy_{tag}"] = float((pred[h] == 0).mean()) if h.any() else None
        r[f"damaged_right_{tag}"] = float((pred[m & d] == y[m & d]).mean()) if (m & d).any() else None
    return r


def plain_test(model, spec, out: Path) -> dict:
    """The held-out figures on the plain 80-sample test set (``test_w80.npz``)."""
    from flightlog_fd.training.data import WindowSet
    from flightlog_fd.training.train import predict_proba

    te = WindowSet.load(_paths(out, 80)[1])
    p = predict_proba(model, spec.normalise(te.X)).argmax(1)
    y, d = te.y, te.y > 0
    mild = d & (te.eta >= 0.9)
    return {"window_accuracy": float((p == y).mean()), "healthy_called_healthy": float((p[y == 0] == 0).mean()),
            "damaged_right": float((p[d] == y[d]).mean()), "accuracy_without_mild": float((p[~mild] == y[~mild]).mean())}


def import_build(onnx_path: Path, name: str, out: Path) -> None:
    """A model ``build_default`` wrote (its .onnx, .pt and .json) as variant ``name``, then measured
    like the others (the table's ``candidate``)."""
    import torch

    from flightlog_fd.model import FaultModel
    from flightlog_fd.training.dcnn import DCNNConfig

    meta = FaultModel(onnx_path).metadata
    torch.save({"state": torch.load(onnx_path.with_suffix(".pt")), "config": DCNNConfig().to_dict(),
                "spec": meta["feature_spec"]}, out / f"{name}.pt")
    t = meta["training"]
    (out / f"{name}.json").write_text(json.dumps({
        "name": name, "window": 80, "parameters": 96709, "train_windows": int(sum(t["class_counts"])),
        "train_flights": int(t["data"].split()[0]), "epochs": t["epochs"], "train_seconds": t["train_seconds"],
        "history": [{"loss": t["best_loss"], "train_acc": float("nan")}], "targets": t["targets"]}))
    evaluate_saved(name, out)


def evaluate_saved(name: str, out: Path) -> None:
    """Add the real-format sets' figures to a variant trained before they were measured."""
    import torch

    from flightlog_fd.training.dcnn import DCNN, DCNNConfig
    from flightlog_fd.windows import FeatureSpec

    saved = torch.load(out / f"{name}.pt")
    model = DCNN(DCNNConfig.from_dict(saved["config"]))
    model.load_state_dict(saved["state"])
    model.eval()
    r = json.loads((out / f"{name}.json").read_text())
    spec = FeatureSpec.from_dict(saved["spec"])
    if "targets" not in r:
        r["targets"] = targets(model, spec)
    r["loads_test"] = loaded_test(model, spec, out)
    if VARIANTS.get(name.split("_s")[0], (80,))[0] != 80 or "window_accuracy" not in r:
        r["plain_test"] = plain_test(model, spec, out)  # trained (or first measured) on another set
    (out / f"{name}.json").write_text(json.dumps(r, indent=1))
    print(json.dumps({k: r[k] for k in ("targets", "loads_test")}))


def evaluate_shipped(out: Path) -> None:
    """The shipped quad model (``models/default.pt``, 2400 flights, 20 epochs) on the same sets, as
    the table's reference row ``shipped``."""
    import torch

    from flightlog_fd.model import FaultModel, default_model_path
    from flightlog_fd.training.data import WindowSet
    from flightlog_fd.training.dcnn import DCNN, DCNNConfig, count_parameters
    from flightlog_fd.training.train import predict_proba
    from flightlog_fd.windows import FeatureSpec

    onnx = FaultModel(default_model_path())
    spec = FeatureSpec.from_dict(onnx.feature_spec)
    model = DCNN(DCNNConfig())
    model.load_state_dict(torch.load(default_model_path().with_suffix(".pt")))
    model.eval()
    test = WindowSet.load(_paths(out, 80)[1])
    pred = predict_proba(model, spec.normalise(test.X)).argmax(1)
    y, d = test.y, test.y > 0
    mild = d & (test.eta >= 0.9)
    t = onnx.training
    r = {"name": "shipped", "window": 80, "parameters": count_parameters(model),
         "train_windows": int(sum(t["class_counts"])),
         "train_flights": int(t["data"].split()[0]), "epochs": t["epochs"], "train_seconds": t["train_seconds"],
         "window_accuracy": float((pred == y).mean()), "healthy_called_healthy": float((pred[y == 0] == 0).mean()),
         "damaged_right": float((pred[d] == y[d]).mean()),
         "accuracy_without_mild": float((pred[~mild] == y[~mild]).mean()),
         "history": [{"loss": t["best_loss"], "train_acc": float("nan")}],
         "targets": targets(model, spec), "loads_test": loaded_test(model, spec, out)}
    (out / "shipped.json").write_text(json.dumps(r, indent=1))
    print(json.dumps({k: v for k, v in r.items() if k != "history"}))


def table(out: Path) -> None:
    print("| variant | window | parameters | train flights / windows | epochs | train s | held-out window acc | "
          "healthy->healthy | damaged right | acc without eta>=0.9 | final train loss / acc | px4_sih_dev | crazypad_e9 | "
          "loads set: acc / loaded healthy->healthy / unloaded healthy->healthy |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for p in sorted(out.glob("*.json")):
        r = json.loads(p.read_text())
        r.update(r.get("plain_test", {}))  # a variant trained on another set, measured on the plain held-out one
        h = r["history"][-1]
        print(f"| {r['name']} | {r['window']} | {r['parameters']} | {r['train_flights']} / {r['train_windows']} | "
              f"{r['epochs']} | {r['train_seconds']:.0f} | {100 * r['window_accuracy']:.1f} % | "
              f"{100 * r['healthy_called_healthy']:.1f} % | {100 * r['damaged_right']:.1f} % | "
              f"{100 * r['accuracy_without_mild']:.1f} % | {h['loss']:.3f} / {100 * h['train_acc']:.1f} % | "
              + " | ".join(f"{100 * t['window_accuracy']:.1f} %" if t else "-"
                           for t in (r.get("targets", {}).get(k) for k in ("px4_sih_dev", "crazypad_e9"))) + " | "
              + (" / ".join(f"{100 * x:.1f} %" for x in (lt["window_accuracy"], lt["healthy_called_healthy_loaded"],
                                                          lt["healthy_called_healthy_unloaded"]))
                 if (lt := r.get("loads_test")) else "-") + " |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cmd", choices=("simulate", "simulate-loads", "train", "table", "evaluate", "evaluate-shipped",
                                    "import-build"))
    ap.add_argument("--build", type=Path, default=None, help="import-build: the .onnx build_default wrote")
    ap.add_argument("name", nargs="?", default="base")
    ap.add_argument("--flights", type=int, default=1600)
    ap.add_argument("--test-flights", type=int, default=320)
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("build/variants"))
    ap.add_argument("--tag", default="", help="suffix of the result files (e.g. the epochs of a rerun)")
    a = ap.parse_args(argv)
    if a.cmd == "simulate":
        simulate(a.out, a.flights, a.test_flights)
    elif a.cmd == "train":
        train(a.name, a.out, a.epochs, a.seed, a.tag)
    elif a.cmd == "simulate-loads":
        simulate_loads(a.out, a.flights, a.test_flights)
    elif a.cmd == "import-build":
        import_build(a.build, a.name, a.out)
    elif a.cmd == "evaluate-shipped":
        evaluate_shipped(a.out)
    elif a.cmd == "evaluate":
        evaluate_saved(a.name, a.out)
    else:
        table(a.out)


if __name__ == "__main__":
    main()
