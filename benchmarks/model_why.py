"""Why the per-window model is right on two windows in three: its held-out accuracy broken down.

    python benchmarks/model_why.py simulate /tmp/why.npz --flights 320 --batch 32 --seed 1000
    python benchmarks/model_why.py report /tmp/why.npz [--model models/default.onnx]

``simulate`` flies held-out quads with the shipped model's training distribution
(``build_default.sim_kwargs``: realistic imbalance, strong and 25 % mild damage, 35 % healthy), in
small batches so that every mission x logging profile pair is flown (build_default's own test set,
240 flights in batches of 128, holds only the first logging profile), and stores the raw windows
with per-flight facts from the simulator's truth (logging profile, mission, eta, CoG offset,
coefficient spread, mass). ``report`` prints window accuracy by damage severity, logging profile,
airframe imbalance and manoeuvring, what healthy windows are mistaken for, and the reliability
diagram of the top class's probability (raw and at the model's temperature) and of the 4 s
smoothed probabilities the timeline labels. Seeds 1000+ are build_default's test seeds, never
training's (0).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def simulate(out: Path, flights: int, batch: int, seed: int, duration: float, rotors: int = 4) -> None:
    from flightlog_fd.prepared import PreparedFlight
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.training.build_default import airframes_for, sim_kwargs
    from flightlog_fd.training.data import DEFAULT_MISSIONS, WindowSet, flight_windows
    from flightlog_fd.windows import FeatureSpec

    kw = sim_kwargs()
    profiles = kw.pop("profiles")
    spec = FeatureSpec(n_motors=rotors)
    afs = airframes_for(rotors)
    sets, meta = [], []
    done, b, t0 = 0, 0, time.time()
    while done < flights:
        n = min(batch, flights - done)
        mission = DEFAULT_MISSIONS[b % len(DEFAULT_MISSIONS)]
        profile = profiles[(b // len(DEFAULT_MISSIONS)) % len(profiles)]
        bseed = int(np.random.default_rng([seed, b]).integers(2**31))
        fls = simulate_flights(n, airframes=afs(n, np.random.default_rng([seed, b, 7])) if afs else None,
                               mission=mission, duration_s=duration, profile=profile, seed=bseed,
                               accelerometer=False, **kw)
        fls = [PreparedFlight(f) for f in fls]
        names = [f"why{seed}-{b}-{i}" for i in range(n)]
        ws = flight_windows(fls, spec, names=names)
        sets.append(ws)
        for f in fls:
            tr = f.flight.truth
            imb = tr.get("imbalance") or {}
            af = tr.get("airframe") or {}
            meta.append({"profile": profile, "mission": mission, "label": int(tr["label"]),
                         "eta": float(tr.get("eta") or 1.0), "eta_torque": float(tr.get("eta_torque") or 1.0),
                         "onset_s": tr.get("onset_s"),
                         "cog_offset": float(np.hypot(*imb.get("cog_offset", (0.0, 0.0)))),
                         "cog_xy": list(imb.get("cog_offset", (0.0, 0.0))),
                         "thrust_scale": list(imb.get("thrust_scale", [1.0] * rotors)),
                         "torque_scale": list(imb.get("torque_scale", [1.0] * rotors)),
                         "motor_tilt": list(imb.get("motor_tilt_deg", [0.0] * rotors)),
                         "frame": str(af.get("frame", "")),
                         "arm": float(af.get("arm_length", af.get("arm", 0.0)) or 0.0),
                         "thrust_spread": float(np.ptp(imb.get("thrust_scale", [1.0]))),
                         "torque_spread": float(np.ptp(imb.get("torque_scale", [1.0]))),
                         "tilt_deg": float(np.max(np.abs(imb.get("motor_tilt_deg", [0.0])))),
                         "mass": float(af.get("mass", 0.0) or 0.0)})
        done += n
        b += 1
        print(f"simulated {done}/{flights} ({time.time() - t0:.0f} s)", flush=True)
    ws = WindowSet.concat(sets)
    ws.save(out)
    Path(str(out) + ".meta.json").write_text(json.dumps(meta))


def _bars(P, y, bins=(0, .3, .4, .5, .6, .7, .8, .9, 1.0001)):
    conf, pred = P.max(1), P.argmax(1)
    rows = []
    for a, b in zip(bins[:-1], bins[1:]):
        m = (conf >= a) & (conf < b)
        if m.any():
            rows.append(f"    [{a:.1f}, {min(b, 1):.1f}): {m.mean() * 100:5.1f} % of windows, right {100 * (pred[m] == y[m]).mean():5.1f} %")
    return "\n".join(rows)


def report(path: Path, model_path: Path) -> None:
    from flightlog_fd.model import FaultModel, apply_temperature
    from flightlog_fd.timeline import PROB_FLOOR_MIX, SMOOTH_SPAN_S, smooth_probabilities
    from flightlog_fd.training.data import WindowSet

    ws = WindowSet.load(path)
    meta = json.loads(Path(str(path) + ".meta.json").read_text())
    model = FaultModel(model_path)
    T = model.temperature
    P = model.predict_proba(model.standardise(ws.X)).astype(float)  # at the model's temperature
    raw = apply_temperature(P, 1.0 / T)  # back to softmax(logits)
    pred, y = P.argmax(1), ws.y
    fl = ws.flight
    print(f"{model_path.name} (T={T:.2f}): {len(y)} windows of {len(meta)} flights, accuracy {(pred == y).mean():.1%}, "
          f"healthy called healthy {(pred[y == 0] == 0).mean():.1%}, damaged right motor {(pred[y > 0] == y[y > 0]).mean():.1%}")

    def row(name, m):
        if not m.any():
            return
        h, d = m & (y == 0), m & (y > 0)
        print(f"  {name:28s} {m.sum():6d} win  acc {100 * (pred[m] == y[m]).mean():5.1f} %"
              + (f"  healthy->healthy {100 * (pred[h] == 0).mean():5.1f} %" if h.any() else " " * 26)
              + (f"  damaged right {100 * (pred[d] == y[d]).mean():5.1f} %  called healthy {100 * (pred[d] == 0).mean():5.1f} %"
                 if d.any() else ""))

    eta = ws.eta
    print("by damage severity (eta of the damaged propeller):")
    row("healthy", y == 0)
    for a, b in ((0.5, 0.65), (0.65, 0.75), (0.75, 0.85), (0.85, 0.9), (0.9, 0.97)):
        row(f"eta {a:.2f}-{b:.2f}", (y > 0) & (eta >= a) & (eta < b))
    mild = (y > 0) & (eta >= 0.9)
    wrong = pred != y
    print(f"  mild (eta >= 0.9) windows: {mild.mean():.1%} of all, {(wrong & mild).sum() / wrong.sum():.1%} of the errors; "
          f"accuracy without them {(pred[~mild] == y[~mild]).mean():.1%} "
          f"(healthy->healthy unchanged, damaged right {(pred[(y > 0) & ~mild] == y[(y > 0) & ~mild]).mean():.1%})")
    print("by logging profile:")
    prof = np.array([meta[f]["profile"] for f in fl])
    for p in sorted(set(prof)):
        row(p, prof == p)
        row(p + " (eta < 0.9)", (prof == p) & ~mild)
    print("by mission:")
    mis = np.array([meta[f]["mission"] for f in fl])
    for p in sorted(set(mis)):
        row(p, mis == p)
    print("by airframe imbalance (flight's CoG offset / arm, and thrust-coefficient spread), eta < 0.9:")
    cog = np.array([meta[f]["cog_offset"] for f in fl])  # already a fraction of the arm (sim/imbalance.py)
    q = np.quantile(cog[y == 0], [0, 1 / 3, 2 / 3, 1]) + [0, 0, 0, 1e-9]
    for a, b in zip(q[:-1], q[1:]):
        row(f"cog/arm {a:.3f}-{b:.3f}", (cog >= a) & (cog < b) & ~mild)
    # the steady imbalance the window itself shows: largest motor share offset (window mean)
    nm = ws.X.shape[1] - 3
    share = ws.X[:, 3:, :].mean(2)
    off = np.abs(share - 1).max(1)
    q = np.quantile(off[y == 0], [0, 0.5, 0.9, 1]) + [0, 0, 0, 1e-9]
    for a, b in zip(q[:-1], q[1:]):
        row(f"window max |share-1| {a:.3f}-{b:.3f}", (off >= a) & (off < b) & ~mild)
    print("by manoeuvring (window std of the motor shares over time, terciles of healthy windows), eta < 0.9:")
    act = ws.X[:, 3:, :].std(2).mean(1)
    q = np.quantile(act[y == 0], [0, 1 / 3, 2 / 3, 1]) + [0, 0, 0, 1e-9]
    for a, b in zip(q[:-1], q[1:]):
        row(f"activity {a:.3f}-{b:.3f}", (act >= a) & (act < b) & ~mild)
    print("healthy windows called a motor: is it the motor running highest?")
    h = (y == 0) & (pred > 0)
    hi = share.argmax(1) + 1
    lo = share.argmin(1) + 1
    print(f"  {h.sum()} windows; named motor = highest share {100 * (pred[h] == hi[h]).mean():.1f} %, "
          f"= lowest share {100 * (pred[h] == lo[h]).mean():.1f} % (chance 25 %); median max |share-1| "
          f"{np.median(off[h]):.3f} vs {np.median(off[(y == 0) & (pred == 0)]):.3f} on healthy windows called healthy")
    # damaged windows: is the damaged motor the highest share?
    d = (y > 0) & ~mild
    print(f"  damaged (eta<0.9) windows whose damaged motor runs the highest share: {100 * (hi[d] == y[d]).mean():.1f} %; "
          f"model right where it is {100 * (pred[d & (hi == y)] == y[d & (hi == y)]).mean():.1f} %, where not "
          f"{100 * (pred[d & (hi != y)] == y[d & (hi != y)]).mean():.1f} %")
    print("reliability of the top class (window's probability -> share right):")
    print("  raw softmax (T=1):")
    print(_bars(raw, y))
    print(f"  at the model's temperature T={T:.2f}:")
    print(_bars(P, y))
    for name, Q in (("raw", raw), (f"T={T:.2f}", P)):
        sm = np.empty_like(Q)
        for f in np.unique(fl):
            m = np.flatnonzero(fl == f)
            o = m[np.argsort(ws.t_start[m])]
            q_ = (1 - PROB_FLOOR_MIX) * Q[o] + PROB_FLOOR_MIX / Q.shape[1]
            c = 0.5 * (ws.t_start[o] + ws.t_end[o])
            sm[o] = smooth_probabilities(c, q_, SMOOTH_SPAN_S)
        print(f"  smoothed {SMOOTH_SPAN_S:g} s and floored ({name}), as the timeline labels:")
        print(_bars(sm, y))
        print(f"    share >= 0.5 (labelled today): {(sm.max(1) >= 0.5).mean():.1%}; healthy windows labelled "
              f"{(sm[y == 0].max(1) >= 0.5).mean():.1%}")
    print("  smoothed (model's temperature), by the class on top: share of windows right per bin, "
          "(in brackets with healthy and damaged windows equally common): what sets timeline.LABEL_BARS")
    conf, arg = sm.max(1), sm.argmax(1)
    # balanced: healthy and damaged windows weighed as equally common (the set's mix is its own choice)
    wt = np.where(y == 0, 0.5 / np.mean(y == 0), 0.5 / np.mean(y > 0))
    edges = [0, .15, .2, .25, .3, .35, .4, .45, .5, .6, .7, 1.01]
    for kind, m0 in (("healthy on top", arg == 0), ("a motor on top", arg > 0)):
        cells = []
        for a, b in zip(edges[:-1], edges[1:]):
            m = m0 & (conf >= a) & (conf < b)
            if m.sum() >= 20:
                bal = np.sum(wt[m] * (arg[m] == y[m])) / np.sum(wt[m])
                cells.append(f"[{a:.2f},{b:.2f}) {m.sum()}: {100 * (arg[m] == y[m]).mean():.0f} % ({100 * bal:.0f})")
        print(f"    {kind}: " + "; ".join(cells))
    from flightlog_fd.timeline import label_bars
    hb, mb = label_bars(sm.shape[1])
    lab = np.where(conf >= np.where(arg == 0, hb, mb), arg, -1)
    ok = lab >= 0
    print(f"  labels with the bars (healthy {hb:.2f}, motor {mb:.2f}): {ok.mean():.1%} of windows labelled, right "
          f"{100 * (lab[ok] == y[ok]).mean():.1f} %, abstained windows right {100 * (arg[~ok] == y[~ok]).mean():.1f} % "
          f"as argmax; healthy windows labelled healthy {100 * (lab[y == 0] == 0).mean():.1f} %, '?' "
          f"{100 * (lab[y == 0] == -1).mean():.1f} %")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("simulate")
    s.add_argument("out", type=Path)
    s.add_argument("--flights", type=int, default=320)
    s.add_argument("--batch", type=int, default=32)
    s.add_argument("--seed", type=int, default=1000)
    s.add_argument("--duration", type=float, default=50.0)
    s.add_argument("--rotors", type=int, default=4, choices=(4, 6, 8))
    r = sub.add_parser("report")
    r.add_argument("data", type=Path)
    r.add_argument("--model", type=Path, default=Path(__file__).resolve().parents[1] / "models" / "default.onnx")
    a = ap.parse_args(argv)
    if a.cmd == "simulate":
        simulate(a.out, a.flights, a.batch, a.seed, a.duration, a.rotors)
    else:
        report(a.data, a.model)


if __name__ == "__main__":
    main()
