"""The paper's experiment, one command: DCNN+CF, DCNN+NIF, DCNN+NIF+DA on a simulated set S and a
labelled real-format target set T, with the calibration protocol a pilot would follow.

    python -m flightlog_fd.training.experiment --target px4_sih_dev --runs 10
    python -m flightlog_fd.training.experiment --target crazypad_e9 --runs 10

Protocol (no labelled target data is used for training or model selection):
1. Calibrate on ONE healthy target flight (``--calib``): ρ from its hover, hover throttle, stream
   rates (:func:`flightlog_fd.calibration.calibrate_profile`).
2. S: simulated flights of the adjusted model for that airframe (:mod:`flightlog_fd.training.adapt`: random
   airframes rescaled to its hover throttle, its frame and ρ, its logging), split by flight into
   S-train and S-test; the same flights give NIF and CF windows.
3. Train ``--runs`` times (seeds 0..runs-1) each of CF, NIF (CE only) and NIF+DA (CE + λ·MMD,
   target = the calibration flight's healthy NIF windows), Adam 5e-4, batch 128, at most
   ``--epochs`` epochs, patience ``--patience``, lowest-training-loss model kept.
4. Test on S-test and on every OTHER target flight: window accuracy mean ± std over runs, a
   per-class confusion matrix (summed over runs), the windows' flight call (:mod:`flightlog_fd.timeline`: a confirmed damage run names its motor, else healthy)
   of every test flight, first-seen time for mid-flight onsets, and the peer rule
   (:mod:`flightlog_fd.training.peer_rule`) on the same flights.
5. A t-SNE figure of first-dense-layer features of S-test and T, NIF vs NIF+DA (PNG).

Results go to ``results/<target>.md`` (+ ``results/<target>_tsne.png`` and a JSON with every
number), with the command that made them.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flightlog_fd.windows import FeatureSpec
from flightlog_fd.calibration import calibrate_profile
from flightlog_fd.timeline import build as build_timeline

RESULTS = Path(__file__).resolve().parents[1] / "results"
CLASS_NAMES = ["healthy", "motor 1", "motor 2", "motor 3", "motor 4"]
DEFAULT_CALIB = {"px4_sih_dev": "sih_004", "crazypad_e9": "normal_flight__E9_log00"}
METHODS = ("CF", "NIF", "NIF+DA")
#: Our addition, not the paper's: exactly what `fdlog calibrate` ships (training/adapt.py: its
#: fine_tune with the default AdaptSettings), trained on this experiment's S, then decision
#: offsets set on the calibration flight's healthy windows.
OFFSETS = "NIF+DA, fine-tuned + offsets"
TSNE_POINTS = 1200  # per domain
#: Flights simulated per training flight asked for (``--flights``): the airframe filter keeps
#: about 1 in 2 for the SIH and 1 in 7 for the Crazyflie.
TAU_OVERSAMPLE = 2.5


@dataclass
class MethodResult:
    s_acc: list = field(default_factory=list)
    t_acc: list = field(default_factory=list)
    t_healthy_acc: list = field(default_factory=list)
    t_damaged_acc: list = field(default_factory=list)
    confusion: np.ndarray = field(default_factory=lambda: np.zeros((5, 5), int))
    verdict_ok: list = field(default_factory=list)  # per run: share of test flights with the right verdict
    verdicts: list = field(default_factory=list)  # run 0: per-flight verdict dicts
    seconds: list = field(default_factory=list)


def _ms(x) -> str:
    x = np.asarray(x, float) * 100
    return f"{x.mean():.1f} ± {x.std():.1f}" if len(x) else "n/a"


def flight_verdicts(probs: np.ndarray, ws, logs) -> list[dict]:
    """Verdict of every test flight from its windows' probabilities."""
    out = []
    for i, lg in enumerate(logs):
        m = ws.flight == i
        if not m.any():
            out.append({"name": lg.name, "truth": lg.truth["label"], "status": "not_diagnosable", "motor": None,
                        "ok": False, "first_seen": None, "onset": lg.truth.get("onset_s")})
            continue
        tl = build_timeline(ws.t_start[m], ws.t_end[m], probs[m])
        run = tl.run if tl.run is not None and tl.run.confirmed else None
        status = "not_diagnosable" if tl.shortfall else ("damaged" if run else "healthy")
        motor = run.motor if run else None
        # the mean window probability of the class named, over the windows the call rests on
        p = probs[m][np.argsort(ws.t_start[m], kind="stable")]
        conf = float(np.mean(p[run.start_index:, run.motor])) if run else float(np.mean(p[:, 0]))
        truth = lg.truth["label"]
        ok = (status == "healthy" and truth == 0) or (status == "damaged" and motor == truth)
        out.append({"name": lg.name, "truth": truth, "status": status, "motor": motor, "ok": bool(ok),
                    "confidence": round(conf, 3), "first_seen": run.first_seen if run else None,
                    "onset": lg.truth.get("onset_s"), "detail": lg.detail})
    return out


def run(target: str, calib: str | None, runs: int, flights: int, epochs: int, patience: int, seed: int,
        out_dir: Path, log=print) -> dict:
    import torch

    from flightlog_fd.training.adapt import (ETA_RANGE, TAU_BAND, airframe_family, dynamics_filter,
                                logging_profiles_for, target_windows)
    from flightlog_fd.training.data import flight_windows, simulate_window_sets
    from flightlog_fd.training.dcnn import DCNNConfig
    from flightlog_fd.training.peer_rule import healthy_offsets, peer_rule
    from flightlog_fd.training.targets import crazypad_logs, sih_logs
    from flightlog_fd.training.train import predict_proba, train_dcnn

    t0 = time.time()
    logs = {"px4_sih_dev": sih_logs, "crazypad_e9": crazypad_logs}[target]()
    calib = calib or DEFAULT_CALIB[target]
    cal = [lg for lg in logs if lg.name == calib]
    if not cal or not cal[0].healthy:
        raise SystemExit(f"calibration flight {calib!r} is not a healthy flight of {target}")
    cal = cal[0]
    tests = [lg for lg in logs if lg.name != calib]
    nif = FeatureSpec(features="nif")
    cf = FeatureSpec(features="cf")
    profile = calibrate_profile([cal.load()], spec=nif)
    log(f"calibrated on {calib}: rho {np.round(profile.rho_, 4).tolist()}, hover throttle "
        f"{profile.hover_throttle_:.3f}, {profile.hover_s_:.0f} s hover")

    family = airframe_family(profile.frame, profile.hover_throttle_)
    # The same airframe matching as `fdlog calibrate` (training/adapt.py): keep simulated flights
    # whose attitude time constant is within TAU_BAND of the calibration flight's.
    tau, like_this_airframe = dynamics_filter([cal.load()], nif.rate_hz)
    sim_kw = dict(airframes=family, rho=np.asarray(profile.rho_), rho_mode="physical",
                  profiles=logging_profiles_for(profile), seed=seed, eta_range=ETA_RANGE,
                  flight_filter=like_this_airframe)
    log(f"attitude time constant of {calib}: {tau:.3f} s; simulated flights kept within x{TAU_BAND}")
    n_test = max(32, flights // 4)
    # One simulation gives both the NIF and the CF windows of the same flights.
    trains = simulate_window_sets(int(round(flights * TAU_OVERSAMPLE)), [nif, cf], **sim_kw)
    tests_s = simulate_window_sets(int(round(n_test * TAU_OVERSAMPLE)), [nif, cf], **{**sim_kw, "seed": seed + 1000})
    S = {}
    for name, spec, tr, te in (("nif", nif, trains[0], tests_s[0]), ("cf", cf, trains[1], tests_s[1])):
        spec.fit(tr.X)
        S[name] = (tr, te)
        log(f"S {name}: train {len(tr)} windows from {len(tr.names)} flights, test {len(te)} from "
            f"{len(te.names)} ({time.time() - t0:.0f} s)")
    # T keeps the windows that straddle a mid-flight onset (label -1) for the verdicts; accuracies skip them.
    T = {name: flight_windows([lg.load() for lg in tests], spec, labels=[lg.truth for lg in tests],
                              names=[lg.name for lg in tests], keep_ambiguous=True)
         for name, spec in (("nif", nif), ("cf", cf))}
    from flightlog_fd.model import FaultModel
    from flightlog_fd.training.adapt import AdaptSettings, base_model_files, fine_tune

    base_onnx, base_pt = base_model_files()
    base_spec = FeatureSpec.from_dict(FaultModel(base_onnx).feature_spec)
    init = torch.load(base_pt, map_location="cpu", weights_only=True)

    target_raw = target_windows([cal.load()], nif)
    target_healthy = nif.normalise(target_raw)
    target_base = base_spec.normalise(target_raw)
    log(f"T: {len(T['nif'])} windows from {len(tests)} flights; DA target: {len(target_healthy)} healthy windows")

    from flightlog_fd.model import apply_logit_bias
    from flightlog_fd.training.adapt import healthy_decision_offsets

    results = {m: MethodResult() for m in METHODS + (OFFSETS,)}
    models0 = {}

    def record(method, model, seconds, ps, P, te, tw, r, epochs):
        """Score one trained model (S-test predictions ``ps``, T probabilities ``P``)."""
        R = results[method]
        R.seconds.append(seconds)
        pt = P.argmax(1)
        known = tw.y >= 0
        R.s_acc.append(float((ps == te.y).mean()))
        R.t_acc.append(float((pt[known] == tw.y[known]).mean()))
        R.t_healthy_acc.append(float((pt[tw.y == 0] == 0).mean()) if (tw.y == 0).any() else float("nan"))
        R.t_damaged_acc.append(float((pt[tw.y > 0] == tw.y[tw.y > 0]).mean()) if (tw.y > 0).any() else float("nan"))
        np.add.at(R.confusion, (tw.y[known], pt[known]), 1)
        v = flight_verdicts(P, tw, tests)
        R.verdict_ok.append(float(np.mean([x["ok"] for x in v])))
        if r == 0:
            R.verdicts = v
            models0[method] = model
        log(f"run {r} {method:14s}: S {R.s_acc[-1]:.3f}  T {R.t_acc[-1]:.3f}  verdicts "
            f"{sum(x['ok'] for x in v)}/{len(v)}  ({seconds:.0f} s, {epochs} epochs)")

    for r in range(runs):
        for method in METHODS:
            key = "cf" if method == "CF" else "nif"
            spec = cf if key == "cf" else nif
            tr, te = S[key]
            tw = T[key]
            t1 = time.time()
            res = train_dcnn(spec.normalise(tr.X), tr.y, target_healthy if method == "NIF+DA" else None,
                             config=DCNNConfig(in_channels=len(spec.channels), window=spec.window),
                             lam=1e4 if method == "NIF+DA" else 0.0, max_epochs=epochs, patience=patience,
                             seed=seed + r)
            seconds = time.time() - t1
            ps_raw = predict_proba(res.model, spec.normalise(te.X))
            P_raw = predict_proba(res.model, spec.normalise(tw.X))
            record(method, res.model, seconds, ps_raw.argmax(1), P_raw, te, tw, r, len(res.history))
        # `fdlog calibrate`'s model: fine-tune the shipped weights with the shipped statistics.
        tr, te = S["nif"]
        tw = T["nif"]
        t1 = time.time()
        res = fine_tune(base_spec.normalise(tr.X), tr.y, target_base, AdaptSettings(seed=seed + r), init,
                        DCNNConfig(in_channels=len(base_spec.channels), window=base_spec.window))
        bias = healthy_decision_offsets(predict_proba(res.model, target_base))
        ps = apply_logit_bias(predict_proba(res.model, base_spec.normalise(te.X)), bias).argmax(1)
        P = apply_logit_bias(predict_proba(res.model, base_spec.normalise(tw.X)), bias)
        record(OFFSETS, res.model, time.time() - t1, ps, P, te, tw, r, len(res.history))

    # Peer rule on the same test flights, offsets from the calibration flight.
    offsets = healthy_offsets(cal.load())
    peer = []
    for lg in tests:
        pr = peer_rule(lg.load(), offsets)
        peer.append({"name": lg.name, "truth": lg.truth["label"], "motor": pr.motor,
                     "ok": pr.motor == lg.truth["label"], "excess": np.round(pr.excess, 4).tolist(),
                     "source": pr.source})
    fig = out_dir / f"{target}_tsne.png"
    tsne_figure(models0, S["nif"][1], T["nif"], nif, fig, seed)
    summary = {
        "target": target, "calibration_flight": calib, "runs": runs, "flights": flights, "epochs": epochs,
        "patience": patience, "seed": seed,
        "profile": {"rho": profile.rho_.tolist(), "hover_throttle": profile.hover_throttle_,
                    "hover_s": profile.hover_s_},
        "tau": tau, "flights_kept": {"S_train": len(S["nif"][0].names), "S_test": len(S["nif"][1].names)},
        "n_windows": {"S_train": len(S["nif"][0]), "S_test": len(S["nif"][1]), "T": int((T["nif"].y >= 0).sum()),
                      "T_healthy": int((T["nif"].y == 0).sum()), "DA_target": int(len(target_healthy))},
        "methods": {m: {"S_acc": R.s_acc, "T_acc": R.t_acc, "T_healthy_acc": R.t_healthy_acc,
                        "T_damaged_acc": R.t_damaged_acc, "confusion": R.confusion.tolist(),
                        "verdict_ok": R.verdict_ok, "verdicts_run0": R.verdicts, "seconds": R.seconds}
                    for m, R in results.items()},
        "peer_rule": peer,
        "command": "python -m flightlog_fd.training.experiment " + " ".join(sys.argv[1:]),
        "code": _code_version(),
        "seconds": round(time.time() - t0, 1),
    }
    return summary


def tsne_figure(models: dict, s_test, t_set, spec: FeatureSpec, path: Path, seed: int) -> None:
    """First-dense-layer features of S-test and T under NIF and NIF+DA, embedded with t-SNE."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import torch
    from sklearn.manifold import TSNE

    rng = np.random.default_rng(seed)
    si = rng.choice(len(s_test), min(TSNE_POINTS, len(s_test)), replace=False)
    ti = rng.choice(len(t_set), min(TSNE_POINTS, len(t_set)), replace=False)
    X = np.concatenate([spec.normalise(s_test.X[si]), spec.normalise(t_set.X[ti])])
    y = np.concatenate([s_test.y[si], t_set.y[ti]])
    dom = np.r_[np.zeros(len(si)), np.ones(len(ti))]
    names = [m for m in ("NIF", "NIF+DA") if m in models]
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 5.2))
    axes = np.atleast_1d(axes)
    colors = plt.cm.tab10(np.arange(5))
    for ax, name in zip(axes, names):
        with torch.no_grad():
            f = models[name].features(torch.from_numpy(X.astype(np.float32))).numpy()
        Z = TSNE(n_components=2, random_state=seed, init="pca", perplexity=30).fit_transform(f)
        for k in range(5):
            for d, marker in ((0, "o"), (1, "x")):
                m = (y == k) & (dom == d)
                if m.any():
                    ax.scatter(Z[m, 0], Z[m, 1], s=6 if d == 0 else 14, marker=marker, color=colors[k],
                               alpha=0.5 if d == 0 else 0.9,
                               label=f"{'S' if d == 0 else 'T'} {CLASS_NAMES[k]}")
        ax.set_title(f"DCNN+{name}: first dense layer (t-SNE)")
        ax.set_xticks([])
        ax.set_yticks([])
    axes[-1].legend(fontsize=7, markerscale=2, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _code_version() -> str:
    """The commit of the simulator and training code that made the table (or 'unknown')."""
    import subprocess

    try:
        out = subprocess.run(["git", "-C", str(Path(__file__).resolve().parent), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, timeout=10)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def write_markdown(summary: dict, path: Path) -> None:
    t = summary["target"]
    M = summary["methods"]
    L = [f"# The paper's experiment on `{t}`", "",
         f"Made by `{summary['command']}` ({summary['seconds'] / 60:.0f} min on a 2-core CPU) with the "
         f"simulator and training code of commit `{summary.get('code', 'unknown')}` (regenerated after the simulator "
         f"learned realistic airframe imbalance and torque-losing damage, and the shipped model was retrained on it; "
         f"the paper's adjusted simulation itself is unchanged: ρ applied as weak motors, balanced otherwise).", "",
         f"Calibration: ONE healthy flight, `{summary['calibration_flight']}` (ρ = "
         f"{[round(x, 4) for x in summary['profile']['rho']]}, hover throttle "
         f"{summary['profile']['hover_throttle']:.3f}, {summary['profile']['hover_s']:.0f} s of hover). "
         f"S = simulated flights of the adjusted model for this airframe "
         f"({summary['n_windows']['S_train']} training windows from {summary['flights_kept']['S_train']} flights, "
         f"{summary['n_windows']['S_test']} test windows from {summary['flights_kept']['S_test']} other flights; "
         f"kept: attitude time constant within x1.35 of the calibration flight's {summary['tau']:.3f} s); "
         f"T = every other flight of the set "
         f"({summary['n_windows']['T']} windows, {summary['n_windows']['T_healthy']} healthy). DA target: the "
         f"calibration flight's {summary['n_windows']['DA_target']} healthy windows. No labelled target data is "
         f"used for training or model selection. {summary['runs']} runs per method (seeds 0..{summary['runs'] - 1}), "
         f"at most {summary['epochs']} epochs, patience {summary['patience']}.", "",
         "| method | accuracy on S (%) | accuracy on T (%) | T healthy windows (%) | T damaged windows (%) | flight verdicts right (%) |",
         "|---|---|---|---|---|---|"]
    for m, R in M.items():
        label = f"DCNN+{m}" + (" (ours: what `fdlog calibrate` ships)" if m == OFFSETS else "")
        L.append(f"| {label} | {_ms(R['S_acc'])} | {_ms(R['T_acc'])} | {_ms(R['T_healthy_acc'])} | "
                 f"{_ms(R['T_damaged_acc'])} | {_ms(R['verdict_ok'])} |")
    peer = summary["peer_rule"]
    L += ["", f"Peer rule (a motor whose mean steady-flight command exceeds the others' by > 0.05 after "
              f"subtracting the calibration flight's offsets): {sum(p['ok'] for p in peer)}/{len(peer)} flights right "
              f"({100 * np.mean([p['ok'] for p in peer]):.1f} %); healthy flights right: "
              f"{sum(p['ok'] for p in peer if p['truth'] == 0)}/{sum(p['truth'] == 0 for p in peer)}.", ""]
    for m in M:
        conf = np.asarray(M[m]["confusion"])
        L += [f"Confusion on T, DCNN+{m} (rows truth, columns predicted, windows summed over runs):", "",
              "| truth \\ predicted | " + " | ".join(CLASS_NAMES) + " |", "|---" * 6 + "|"]
        for k in range(5):
            if conf[k].sum():
                L.append(f"| {CLASS_NAMES[k]} | " + " | ".join(str(x) for x in conf[k]) + " |")
        L.append("")
    L += ["Per-flight verdicts (run 0) for DCNN+NIF+DA, for what `fdlog calibrate` ships (NIF+DA fine-tuned from "
          "the shipped model, with decision offsets from the calibration flight), and the peer rule:", "",
          "| flight | truth | DCNN+NIF+DA verdict | confidence | first seen (onset) | fdlog calibrate | peer rule |",
          "|---|---|---|---|---|---|---|"]
    pr = {p["name"]: p for p in peer}
    off = {v["name"]: v for v in M[OFFSETS]["verdicts_run0"]}
    for v in M["NIF+DA"]["verdicts_run0"]:
        verdict = v["status"] + (f" motor {v['motor']}" if v.get("motor") else "")
        onset = ""
        if v.get("onset") is not None:
            fs = v.get("first_seen")
            onset = f"{fs:.1f} s ({v['onset']:.1f} s)" if fs is not None else f"- ({v['onset']:.1f} s)"
        p = pr.get(v["name"], {})
        o = off.get(v["name"], {})
        o_verdict = o.get("status", "") + (f" motor {o['motor']}" if o.get("motor") else "")
        L.append(f"| {v['name']} | {CLASS_NAMES[v['truth']]} | {'✔' if v['ok'] else '✘'} {verdict} | "
                 f"{v.get('confidence', '')} | {onset} | {'✔' if o.get('ok') else '✘'} {o_verdict} | "
                 f"{'✔' if p.get('ok') else '✘'} "
                 f"{'healthy' if not p.get('motor') else 'motor ' + str(p.get('motor'))} |")
    L += ["", f"![t-SNE of first-dense-layer features]({t}_tsne.png)", ""]
    path.write_text("\n".join(L))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description="The paper's experiment (CF / NIF / NIF+DA) on a labelled target set.")
    ap.add_argument("--target", choices=sorted(DEFAULT_CALIB), default="px4_sih_dev")
    ap.add_argument("--calib", default=None, help="healthy flight to calibrate on (default per target)")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--flights", type=int, default=192, help="simulated training flights")
    ap.add_argument("--epochs", type=int, default=50)
    ap.add_argument("--patience", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    summary = run(args.target, args.calib, args.runs, args.flights, args.epochs, args.patience, args.seed, args.out,
                  log=lambda s: print(s, flush=True))
    (args.out / f"{args.target}.json").write_text(json.dumps(summary, indent=1, default=float))
    write_markdown(summary, args.out / f"{args.target}.md")
    print((args.out / f"{args.target}.md").read_text())


if __name__ == "__main__":
    main()
