"""Today's verdicts on a load-twin folder (benchmarks/load_twins.py), as a baseline to hold the
load decision against: every flight but the twins diagnosed without a profile and with its twin's
``--no-adapt`` profile (as bench_reliability's simulated cases), counted per role.

    python benchmarks/load_twins_baseline.py FOLDER [--list]

Figures only; nothing is asserted. ``--list`` prints each flight's verdicts too.
"""
from __future__ import annotations

import argparse
import csv
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

ROLES = ("healthy", "damaged", "load", "load2", "damaged_load")


def score(folder: Path, listing: bool = False) -> str:
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.logs import load_flight

    rows = list(csv.DictReader(open(folder / "manifest.csv", newline="")))
    profiles: dict = {}
    status: Counter = Counter()
    named: Counter = Counter()
    for r in rows:
        if r["role"] == "twin":
            continue
        fl = load_flight(str(folder / r["file"]))
        if r["twin_file"] not in profiles:
            profiles[r["twin_file"]] = calibrate([str(folder / r["twin_file"])])  # as --no-adapt
        for tag, prof in (("no profile", None), ("twin profile", profiles[r["twin_file"]])):
            v = diagnose_flight(fl, resolve_model(None, prof, rotor_count=len(fl.frame.rotors)), prof,
                                keep_flight=False).verdict
            status[(r["role"], tag, v.status)] += 1
            if v.status == "damaged" and str(v.motor) == r["damaged_motor"] != "0":
                named[(r["role"], tag)] += 1
            if listing:
                print(f"{r['file']}\t{tag}\t{v.status}\t{v.motor}\t{r['load_kind']}\t{r['load_mass_fraction']}")
    out = ["| role | profile | damaged | uncertain | healthy | damaged, right motor |", "|---|---|---|---|---|---|"]
    for role in ROLES:
        for tag in ("no profile", "twin profile"):
            c = [status[(role, tag, s)] for s in ("damaged", "uncertain", "healthy")]
            out.append(f"| {role} | {tag} | {c[0]} | {c[1]} | {c[2]} | {named[(role, tag)]} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--list", action="store_true")
    a = ap.parse_args(argv)
    print(score(a.folder, a.list))
    return 0


if __name__ == "__main__":
    sys.exit(main())
