"""The shipped hexa and octo models' window votes on simulated flights: the figures behind
``flightlog_fd.analyzers.model_votes.NROTOR_VOTE_STATS``.

    python benchmarks/nrotor_vote_stats.py [--flights 96] [--seeds 7000 8000]

Flights as ``bench_nrotor.py`` (random airframes with realistic imbalance, damaged η uniform in
0.55-0.8 from take-off, PX4 default and ArduPilot logging, each with a healthy twin of the same
airframe), on seeds that neither the benchmark (5000) nor training (0, 1000) use. Per rotor count,
of each flight's mean window log ratio log(q_k / q_0) (``model_votes.mean_log_ratio``):

- healthy flights, every motor: mean and standard deviation (no profile: the healthy level);
- damaged flights, the damaged motor: mean and standard deviation (no profile);
- the damaged motor against its healthy twin's value (a profile: the shift damage makes), and
  every motor of a healthy flight against its twin (a healthy re-flight);

each standard deviation also with the within-flight term at the median covered time removed
(``model_votes`` adds it back per flight: ``MODEL_WINDOW_SIGMA / sqrt(covered / MODEL_DECORRELATION_S)``).
Figures only; re-run after retraining a model and update the constants.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights", type=int, default=96, help="flights per frame and seed (about half healthy)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[7000, 8000])
    args = ap.parse_args(argv)

    from bench_nrotor import FRAMES, PROFILES, simulate

    from flightlog_fd.analyzers.model_votes import MODEL_DECORRELATION_S, MODEL_WINDOW_SIGMA, mean_log_ratio
    from flightlog_fd.windows import FeatureSpec, make_windows
    from flightlog_fd.model import FaultModel, shipped_model_path
    from flightlog_fd.timeline import covered_seconds

    models = {6: FaultModel(shipped_model_path(6)), 8: FaultModel(shipped_model_path(8))}

    def votes(fl, model):
        w = make_windows(fl, FeatureSpec.from_dict(model.feature_spec))
        if not len(w.t_start):
            return None, 0.0
        p = model.predict_proba(model.standardise(w.X))
        return mean_log_ratio(p), covered_seconds(np.asarray(w.t_start), np.asarray(w.t_end))

    rows = []
    for seed in args.seeds:
        for fi, frame in enumerate(FRAMES):
            for pi, prof in enumerate(PROFILES):
                flights, twins = simulate(frame, args.flights // len(PROFILES), seed + 10 * fi + pi, prof, twins=True)
                for fl, tw in zip(flights, twins):
                    n = fl.frame.rotor_count
                    x, cov = votes(fl, models[n])
                    xt, _ = votes(tw, models[n])
                    if x is not None and xt is not None:
                        rows.append((n, frame, int(fl.truth["motor"]), x, xt, cov))
    print(f"models: 6 -> {models[6].path.name} ({models[6].version}), 8 -> {models[8].path.name} "
          f"({models[8].version}); seeds {args.seeds}, {args.flights} flights per frame and seed")
    for n in (6, 8):
        sel = [r for r in rows if r[0] == n]
        within = MODEL_WINDOW_SIGMA / np.sqrt(max(np.median([r[5] for r in sel]) / MODEL_DECORRELATION_S, 1.0))

        def line(name, v):
            v = np.asarray(v, float)
            between = float(np.sqrt(max(v.var() - within ** 2, 0.0)))
            print(f"  {name:<38} n={len(v):4d}  mean {v.mean():+.2f}  sd {v.std():.2f}  "
                  f"(between flights {between:.2f})  p05/p50/p95 {np.percentile(v, 5):+.2f} "
                  f"{np.median(v):+.2f} {np.percentile(v, 95):+.2f}")

        print(f"{n} rotors: {sum(r[2] == 0 for r in sel)} healthy, {sum(r[2] != 0 for r in sel)} damaged flights; "
              f"within-flight sd at the median covered time {within:.2f}")
        line("healthy, every motor", np.concatenate([r[3] for r in sel if r[2] == 0]))
        line("damaged, the damaged motor", [r[3][r[2] - 1] for r in sel if r[2]])
        line("healthy, every motor - twin", np.concatenate([r[3] - r[4] for r in sel if r[2] == 0]))
        line("damaged, the damaged motor - twin", [r[3][r[2] - 1] - r[4][r[2] - 1] for r in sel if r[2]])
        for frame in FRAMES:
            d = [r[3][r[2] - 1] - r[4][r[2] - 1] for r in sel if r[2] and r[1] == frame]
            if d:
                line(f"  {frame}: damaged motor - twin", d)


if __name__ == "__main__":
    main()
