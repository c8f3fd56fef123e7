"""How far an adapted model's votes move between sessions of one airframe, healthy and damaged.

    python benchmarks/adapted_vote_drift.py [--profiles DIR] [--only erle_A,erle_B,rrc_straight] [--out J]

For each one-flight ADAPTED profile ``bench_cross_session.py`` made in ``--profiles`` (default
``build/cross_session_profiles``; named ``AIRFRAME_I_adapted.json``), every other healthy flight of
the airframe and its damaged flights are diagnosed with it (``fdlog diagnose --json``); per flight
and motor, the flight mean of the windows' log(q_k / q_0) (floored, as the model-vote analyzer
takes it) minus the profile's vote baseline (measured on the flight the model was adapted on).
Prints, per rate class of the airframe (low: 10 Hz RCOU and slower; full), the healthy flights'
shifts (all motors: mean, standard deviation, max) and the damaged motor's shift per group, and
the verdict of each pair: the figures ``model_votes.ADAPTED_LOW_RATE_SESSION_OFFSET`` and
``ADAPTED_LOW_RATE_SESSION_SIGMA`` cite. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_cross_session as B  # noqa: E402

from flightlog_fd.timeline import floored  # noqa: E402

#: The airframes whose motor outputs are logged below reliability.LOW_RATE_HZ.
LOW_RATE = ("erle_A", "erle_B", "erle_day-2014-09-07", "rrc_straight")


def shifts(profiles: Path, only: list[str] | None) -> list[dict]:
    recs = []
    for af in B.airframes():
        if only and af.name not in only:
            continue
        for i in range(len(af.healthy)):
            prof = profiles / f"{af.name}_{i + 1}_adapted.json"
            if not prof.exists():
                continue
            base = (json.loads(prof.read_text()).get("analyzers") or {}).get("model")
            if not base:
                continue
            rest = [(p, -1, "healthy") for j, p in enumerate(af.healthy) if j != i] + list(af.damaged)
            docs = B.diagnose([p for p, _, _ in rest], prof, 1)
            for p, truth, group in rest:
                d = docs[str(p)]
                w = d.get("windows") or []
                if not w:
                    continue
                q = floored(np.array([x["probabilities"] for x in w]))
                m = (np.log(q[:, 1:]) - np.log(q[:, :1])).mean(axis=0)
                v = d["verdict"]
                recs.append(dict(airframe=af.name, profile=prof.stem, log=p.name, truth=truth, group=group,
                                 shift=(m - np.array(base["healthy_mean"])).tolist(), status=v["status"],
                                 motor=v["motor"]))
            print(f"{prof.stem}: {len(rest)} flights", file=sys.stderr, flush=True)
    return recs


def report(recs: list[dict]) -> None:
    for rate, sel in (("low rate", [r for r in recs if r["airframe"] in LOW_RATE]),
                      ("full rate", [r for r in recs if r["airframe"] not in LOW_RATE])):
        h = [r for r in sel if r["group"] == "healthy"]
        if h:
            s = np.array([r["shift"] for r in h])
            print(f"{rate}: {len(h)} healthy cross-session pairs, all motors' shift mean {s.mean():+.2f}, "
                  f"sd {s.std(ddof=1):.2f}, max {s.max():+.2f}")
            for af in sorted({r["airframe"] for r in h}):
                a = np.array([r["shift"] for r in h if r["airframe"] == af])
                print(f"  {af}: {len(a)} pairs, mean {a.mean():+.2f}, sd {a.std(ddof=1) if a.size > 1 else 0:.2f}, "
                      f"max {a.max():+.2f}")
        groups = defaultdict(list)
        for r in sel:
            if r["group"] != "healthy":
                # the stated motor's shift; where the set states none (rrc cuts), the largest
                k = r["truth"] - 1 if r["truth"] and r["truth"] > 0 else int(np.argmax(r["shift"]))
                groups[r["group"]].append(r["shift"][k])
        for g, v in sorted(groups.items()):
            print(f"  damaged {g}: stated (else leading) motor's shift {np.round(v, 2).tolist()}")
        verdicts = defaultdict(list)
        for r in sel:
            verdicts[(r["profile"], r["group"])].append(f"{r['status'][0]}{r['motor'] or ''}")
        for (p, g), v in sorted(verdicts.items()):
            print(f"  {p} {g}: {' '.join(v)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profiles", type=Path, default=B.ROOT / "build" / "cross_session_profiles")
    ap.add_argument("--only", help="comma-separated airframe names")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    recs = shifts(args.profiles, args.only.split(",") if args.only else None)
    if args.out:
        args.out.write_text(json.dumps(recs))
    report(recs)


if __name__ == "__main__":
    main()
