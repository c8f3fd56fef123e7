"""The shipped model on real airframes, no profile: false alarms on real healthy flights, right
motors on the PX4 SITL set, beside the motor-balance rule - the figure pilots judge the tool by.

    python benchmarks/bench_real_airframes.py [--model A.onnx --model B.onnx ...] [--sets real_logs,real_healthy,px4_sih_dev]

For every diagnosable flight of ``../shared/real_logs`` (the Erle ArduCopter flights; the PX4 files
there are bench, VTOL or SIL logs and are skipped or reported not diagnosable), ``../shared/
real_healthy`` and ``../shared/px4_sih_dev`` it runs each model given (default: the shipped one)
WITHOUT a profile and prints per set:

- healthy flights: healthy / uncertain / damaged verdicts,
- damaged flights (SITL): right motor / wrong motor / uncertain / healthy, and how many of those
  with η ≤ 0.8 name the right motor,
- window accuracy (the model's argmax against the truth; healthy flights: share of windows called
  healthy),

twice per model: ``model only`` (the window probabilities alone: a confirmed damage run in the
timeline names its motor, else healthy; never uncertain) and ``model + evidence`` (what ``fdlog diagnose`` prints
now), and once for the motor-balance rule (``training/peer_rule.py``: a motor whose mean command
in steady flight exceeds the others' by 0.05 of full scale). Figures only; nothing is asserted.
Give the previous model with ``--model`` to get before/after figures from one run.
"""
from __future__ import annotations

from types import SimpleNamespace

import argparse
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
SETS = ("real_logs", "real_healthy", "px4_sih_dev")


def labelled_flights(sets):
    """(set, path, motor, eta) of every flight with known truth (real logs: healthy)."""
    from flightlog_fd.training.targets import real_healthy_logs, sih_logs

    out = []
    for lg in real_healthy_logs(SHARED):
        set_name = "real_logs" if lg.path.parent.parent.name == "real_logs" else "real_healthy"
        if set_name in sets:
            out.append((set_name, lg.path, 0, 1.0))
    if "px4_sih_dev" in sets and (SHARED / "px4_sih_dev" / "manifest.csv").exists():
        out += [("px4_sih_dev", lg.path, lg.truth["motor"], lg.truth["eta"]) for lg in sih_logs(SHARED)]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, action="append", default=None, help="ONNX model (repeat for several)")
    ap.add_argument("--sets", default=",".join(SETS))
    ap.add_argument("--verbose", action="store_true", help="one line per flight")
    args = ap.parse_args()

    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight
    from flightlog_fd.errors import FlightLogError
    from flightlog_fd.model import FaultModel, default_model_path
    from flightlog_fd.training.peer_rule import peer_rule
    from flightlog_fd.timeline import build as build_timeline

    if not SHARED.exists():
        print(f"{SHARED} is absent: nothing to measure")
        return
    models = [FaultModel(p) for p in (args.model or [default_model_path()])]
    flights = labelled_flights(args.sets.split(","))
    loaded = []
    t0 = time.perf_counter()
    for set_name, path, motor, eta in flights:
        try:
            loaded.append((set_name, path, motor, eta, load_flight(path)))
        except FlightLogError as e:
            print(f"skip {path.name}: {e.message}")
    print(f"{len(loaded)} flights loaded in {time.perf_counter() - t0:.0f} s")

    # tally[(variant, set)] -> Counter of outcomes; windows[(variant, set)] -> [right, total]
    tally: dict = defaultdict(Counter)
    windows: dict = defaultdict(lambda: [0, 0])
    variants = []
    for mi, model in enumerate(models):
        name = f"{Path(model.path).name}#{mi}" if len(models) > 1 else Path(model.path).name
        variants += [f"{name} model only", f"{name} model + evidence"]
        for set_name, path, motor, eta, fl in loaded:
            d = diagnose_flight(fl, model, keep_flight=False)
            if d.verdict.status == "not_diagnosable":
                for v in variants[-2:]:
                    tally[(v, set_name)]["not diagnosable"] += 1
                continue
            t_s = np.array([w.t_start for w in d.windows])
            t_e = np.array([w.t_end for w in d.windows])
            probs = np.array([w.probabilities for w in d.windows])
            tl = build_timeline(t_s, t_e, probs)  # the model alone: a confirmed damage run names its motor
            run = tl.run if tl.run is not None and tl.run.confirmed else None
            model_only = SimpleNamespace(status="damaged" if run else "healthy", motor=run.motor if run else None)
            for v, verdict in ((variants[-2], model_only), (variants[-1], d.verdict)):
                tally[(v, set_name)][outcome(verdict.status, verdict.motor, motor, eta)] += 1
                if args.verbose:
                    print(f"  {v:40s} {path.name[:36]:36s} truth {motor} -> {verdict.status} {verdict.motor or ''}")
            cls = probs.argmax(axis=1)
            w = windows[(variants[-1], set_name)]
            w[0] += int(np.sum(cls == motor))
            w[1] += int(cls.size)
            windows[(variants[-2], set_name)] = w
    rule = "motor-balance rule (peer_rule, 0.05)"
    variants.append(rule)
    for set_name, path, motor, eta, fl in loaded:
        try:
            r = peer_rule(fl)
        except FlightLogError:
            tally[(rule, set_name)]["not diagnosable"] += 1
            continue
        tally[(rule, set_name)][outcome("damaged" if r.motor else "healthy", r.motor or None, motor, eta)] += 1

    for set_name in args.sets.split(","):
        print(f"\n== {set_name}")
        print(f"{'':44s} {'healthy flights: H / U / D':28s} {'damaged: right / wrong / U / H  (eta<=0.8 right)':52s} window acc")
        for v in variants:
            c = tally[(v, set_name)]
            if not c:
                continue
            healthy = f"{c['H|0']} / {c['U|0']} / {c['D|0']}"
            dmg = (f"{c['right'] + c['right08']} / {c['wrong'] + c['wrong08']} / {c['U|k'] + c['U|k08']} / "
                   f"{c['H|k'] + c['H|k08']}  ({c['right08']} of {c['right08'] + c['wrong08'] + c['U|k08'] + c['H|k08']})")
            w = windows.get((v, set_name))
            acc = f"{100 * w[0] / w[1]:.1f} % of {w[1]}" if w and w[1] else "-"
            nd = f"  ({c['not diagnosable']} not diagnosable)" if c["not diagnosable"] else ""
            print(f"{v:44s} {healthy:28s} {dmg:52s} {acc}{nd}")


def outcome(status: str, named, truth: int, eta: float) -> str:
    """H|0 U|0 D|0 for healthy truth; right / wrong / U|k / H|k (suffix 08 when eta <= 0.8)."""
    if truth == 0:
        return {"healthy": "H|0", "uncertain": "U|0", "damaged": "D|0"}[status]
    suffix = "08" if eta <= 0.8 + 1e-9 else ""
    if status == "damaged":
        return ("right" if named == truth else "wrong") + suffix
    return ("U|k" if status == "uncertain" else "H|k") + suffix


if __name__ == "__main__":
    main()
