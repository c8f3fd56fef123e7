"""`fdlog calibrate` on one healthy flight, then `fdlog diagnose --profile` on the rest of the set.

    python benchmarks/bench_calibrate.py [--target px4_sih_dev|crazypad_e9] [--calib NAME] [--profile P.json]

Prints the calibration time (goal: under 3 minutes on this 2-core CPU), then for every other
flight of the labelled set its verdict against the truth, the first-seen time against a
mid-flight onset, and the window accuracy (windows straddling an onset are not scored), with the
shipped model (no profile) beside it. Uses the library functions the CLI calls. Prints figures;
no asserts. ``--profile``: diagnose with a profile made before (e.g. by another checkout's
`fdlog calibrate` of the calibration flight, for a before/after pair diagnosed by the same code)
instead of calibrating.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

DEFAULT_CALIB = {"px4_sih_dev": "sih_004", "crazypad_e9": "normal_flight__E9_log00"}


def window_truth(lg, windows) -> np.ndarray:
    """Truth per diagnosed window (-1 for windows straddling a mid-flight onset)."""
    from flightlog_fd.windows import labels_for_spans

    return labels_for_spans(lg.truth, [w.t_start for w in windows], [w.t_end for w in windows])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--target", choices=sorted(DEFAULT_CALIB), default="px4_sih_dev")
    ap.add_argument("--calib", default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", type=Path, default=None, help="a profile of the calibration flight made before")
    args = ap.parse_args()

    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.profile import Profile
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.training.adapt import AdaptSettings
    from flightlog_fd.training.targets import crazypad_logs, sih_logs

    from flightlog_fd.training.targets import available

    if not available()[args.target]:
        print(f"skipped: ../shared/{args.target} is not present")
        return
    logs = {"px4_sih_dev": sih_logs, "crazypad_e9": crazypad_logs}[args.target]()
    calib = args.calib or DEFAULT_CALIB[args.target]
    cal = next(lg for lg in logs if lg.name == calib)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.profile or Path(tmp) / "profile.json"
        t0 = time.perf_counter()
        if args.profile is None:
            calibrate([cal.path], adapt=True, output=out, settings=AdaptSettings(seed=args.seed))
        t_cal = time.perf_counter() - t0
        profile = Profile.load(out)
        adapted = resolve_model(None, profile)
        shipped = resolve_model()
        ad = (profile.extra or {}).get("adaptation", {})
        made = f"profile {args.profile} given" if args.profile else f"{t_cal:.1f} s"
        print(f"calibrate {cal.name}: {made} (simulate {ad.get('simulate_seconds')} s, "
              f"{ad.get('epochs')} epochs), rho {np.round(profile.rho_, 4).tolist()}, "
              f"logit_bias {ad.get('logit_bias')}")
        rows, acc = [], {"calibrated": [], "shipped": []}
        ok = {"calibrated": 0, "shipped": 0}
        for lg in logs:
            if lg.name == calib:
                continue
            fl = lg.load()
            cells = []
            for name, model, prof in (("calibrated", adapted, profile), ("shipped", shipped, None)):
                d = diagnose_flight(fl, model, prof, keep_flight=False)
                v = d.verdict
                y = window_truth(lg, d.windows)
                pred = np.array([w.cls for w in d.windows])
                acc[name].append((pred[y >= 0] == y[y >= 0]))
                right = (v.status == "healthy" and lg.truth["label"] == 0) or (
                    v.status == "damaged" and v.motor == lg.truth["label"])
                ok[name] += right
                seen = ""
                if lg.truth.get("onset_s") is not None and v.first_seen is not None:
                    seen = f" first seen {v.first_seen - lg.truth['onset_s']:+.1f} s from onset"
                cells.append(f"{'OK ' if right else 'BAD'} {v.status}{' ' + str(v.motor) if v.motor else ''}"
                             f" ({v.confidence:.2f}){seen}")
            rows.append(f"{lg.name:44s} truth {lg.truth['label']}  | {cells[0]:40s} | {cells[1]}")
        print(f"{'flight':44s} {'':8s}  | {'calibrated profile':40s} | shipped model, no profile")
        print("\n".join(rows))
        n = len(rows)
        for name in ("calibrated", "shipped"):
            a = np.concatenate(acc[name])
            print(f"{name:10s}: verdicts right {ok[name]}/{n}, window accuracy {100 * a.mean():.1f} % "
                  f"({a.size} windows)")


if __name__ == "__main__":
    main()
