"""Profiles that know the airframe's loads (issue 32 item 4): the figures, in one run.

    python benchmarks/bench_load_configurations.py [--only sih,sim,crazypad] [-v]

Per set: a profile is calibrated (``--no-adapt``) on the set's healthy flight, a loaded healthy
flight is added with ``calibrate --add`` (:func:`flightlog_fd.calibration.add_sessions`: it becomes a
load configuration), then the set's other loaded flights and damaged flights are diagnosed against
it and against the profile without the configuration. Printed per flight: the truth, the verdict
(status, motor, cause) with and without the configuration, the configuration chosen and each
configuration's evidence; per set, the counts. Sets (each skips when ../shared lacks it):

- ``sih``: px4_sih_dev sih_004, + px4_sih_dev_load A_default_com_m1; the other 3 moved centres of
  mass and the 15 weak-motor flights of px4_sih_dev.
- ``sim``: simulated x500 (``fdlog simulate``): a healthy flight, + (``--name``: the verdict calls it damaged) a flight with a point mass of
  15 % toward motor 2; the same load on another seed, a weak motor 2 / motor 4 (eta 0.75) with and
  without the load.
- ``crazypad``: crazypad_e9 normal log00, + one crazypad_e9_load W1 flight (``--name "W1 near M3"``:
  the verdict does not name its load, so it would be an ordinary session); the other load
  flights and crazypad_e9's single-propeller cuts; ``crazypad_w3``: the same with the heavier taped
  weight's first flight (W3 log01) as the configuration.
Figures only; nothing is asserted (results/load_configurations.md).
"""
from __future__ import annotations

import argparse
import csv
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
FDLOG = Path(sys.executable).with_name("fdlog")


def diagnose(paths, prof_path):
    from flightlog_fd.diagnose import diagnose_path, resolve_model
    from flightlog_fd.profile import Profile

    prof = Profile.load(prof_path)
    model = resolve_model(None, prof)
    out = {}
    for p in paths:
        d = diagnose_path(p, model, prof)
        v = d.verdict
        cfg = getattr(d.share_fit, "configuration", None) if d.share_fit is not None else None
        out[p] = (v.status, v.motor, v.cause, None if not cfg else cfg["name"], None if not cfg else cfg["evidence"],
                  v.reason)
    return out


def gap(evidence: dict) -> float:
    """The best load configuration's evidence over 'as calibrated' (nats)."""
    own = evidence["as calibrated"]
    return max(v for k, v in evidence.items() if k != "as calibrated") - own


def run_set(label, calib, added, flights, tmp, verbose, name=None, start=None):
    """flights: [(name, path, truth motor (0 healthy), kind)] -> prints and returns rows. ``start``:
    an existing profile of ``calib`` (its .onnx beside it) instead of a --no-adapt calibration."""
    from flightlog_fd.calibration import add_sessions, calibrate

    base = tmp / f"{label}_base.json"
    if start is None:
        calibrate([calib], adapt=False, output=base, overwrite=True)
    else:  # the profile's model is named relative to its folder: it goes beside both copies
        shutil.copy(start, base)
        model = __import__("json").loads(Path(start).read_text()).get("model")
        if model:
            shutil.copy(Path(start).parent / model["path"], tmp / model["path"])
    prof = tmp / f"{label}_cfg.json"
    shutil.copy(base, prof)
    from flightlog_fd.errors import ProfileError

    try:
        res = add_sessions(prof, [added], name=name, keep_previous=False)
    except ProfileError as e:
        print(f"== {label}: calibrated on {Path(calib).name}; adding {Path(added).name} refused: {e}")
        return []
    print(f"== {label}: calibrated on {Path(calib).name}, added {Path(added).name}")
    for line in res.changes:
        print(f"   {line}")
    paths = [p for _, p, _, _ in flights]
    without, with_cfg = diagnose(paths, base), diagnose(paths, prof)
    rows = []
    for nm, p, truth, kind in flights:
        a, b = without[p], with_cfg[p]
        rows.append((nm, truth, kind, a, b))
        print(f"  {nm:34s} truth {truth} {kind:8s} | without: {a[0]:9s} m{a[1]} {a[2] or '-':9s} | with: "
              f"{b[0]:9s} m{b[1]} {b[2] or '-':9s} against {b[3]!r}" + (f" (load configuration {gap(b[4]):+.2f} nats)"
                                                                         if b[4] else ""))
        if verbose:
            print(f"      evidence {b[4]}\n      reason: {b[5]}")
    for kind in dict.fromkeys(k for _, _, k, _, _ in rows):
        sub = [r for r in rows if r[2] == kind]
        for which, i in (("without", 3), ("with", 4)):
            c = Counter(r[i][0] for r in sub)
            named = sum(1 for r in sub if r[1] and r[i][0] in ("damaged", "uncertain") and r[i][1] == r[1])
            print(f"  {kind:8s} {which:7s} the configuration: {len(sub)} flights: " +
                  ", ".join(f"{k} {v}" for k, v in sorted(c.items())) +
                  (f"; right motor named {named}/{len(sub)}" if any(r[1] for r in sub) else ""))
        gaps = [gap(r[4][4]) for r in sub if r[4][4]]
        if gaps:
            print(f"  {kind:8s} load configuration over 'as calibrated': {min(gaps):+.2f} .. {max(gaps):+.2f} nats")
        chosen = Counter(r[4][3] for r in sub)
        print(f"  {kind:8s} compared with: " + ", ".join(f"{k!r} {v}" for k, v in chosen.items()))
    return rows


def sih(tmp, verbose, start=None):
    dev, load = SHARED / "px4_sih_dev", SHARED / "px4_sih_dev_load"
    if not (dev.exists() and load.exists()):
        print("sih: skipped (no px4_sih_dev / px4_sih_dev_load)")
        return
    flights = [(f.stem, str(f), 0, "load") for f in sorted(load.glob("*.ulg")) if f.name != "A_default_com_m1.ulg"]
    with open(dev / "manifest.csv") as fh:
        for r in csv.DictReader(fh):
            if r["label"] == "faulty":
                flights.append((r["name"], str(dev / "logs" / f"{r['name']}.ulg"), int(r["faulty_motor"]), "weak"))
            elif r["name"] != "sih_004":
                flights.append((r["name"], str(dev / "logs" / f"{r['name']}.ulg"), 0, "healthy"))
    run_set("sih", dev / "logs" / "sih_004.ulg", load / "A_default_com_m1.ulg", flights, tmp, verbose, start=start)


def sim(tmp, verbose, start=None):
    def simulate(out, *args):
        subprocess.run([str(FDLOG), "simulate", "--airframe", "x500", "--output", str(out), *args], check=True,
                       capture_output=True)
        return str(out)

    healthy = simulate(tmp / "sim_healthy.ulg", "--seed", "1")
    added = simulate(tmp / "sim_load_a.ulg", "--seed", "2", "--load", "point:15%@motor2")
    flights = [("load 15% @motor2 seed 3", simulate(tmp / "sim_load_b.ulg", "--seed", "3", "--load", "point:15%@motor2"), 0, "load"),
               ("load 10% @motor2 seed 4", simulate(tmp / "sim_load_c.ulg", "--seed", "4", "--load", "point:10%@motor2"), 0, "load"),
               ("healthy seed 5", simulate(tmp / "sim_healthy_b.ulg", "--seed", "5"), 0, "healthy")]
    for motor in (1, 4):
        for with_load in (False, True):
            extra = ["--load", "point:15%@motor2"] if with_load else []
            nm = f"weak m{motor} eta 0.75" + (" + load" if with_load else "")
            flights.append((nm, simulate(tmp / f"sim_weak{motor}_{int(with_load)}.ulg", "--seed", str(10 + motor),
                                         "--motor", str(motor), "--eta", "0.75", "--cause", "motor", *extra), motor, "weak+load" if with_load else "weak"))
    run_set("sim", healthy, added, flights, tmp, verbose, name="15 % at motor 2")


def crazypad(tmp, verbose, start=None, added_kind="W1", name="W1 near M3"):
    e9, load = SHARED / "crazypad_e9", SHARED / "crazypad_e9_load"
    if not (e9.exists() and load.exists()):
        print("crazypad: skipped")
        return
    rows = list(csv.DictReader(open(e9 / "manifest.csv")))
    normals = [r for r in rows if r["damage_kind"] == "none"]
    cuts = [(r["file"].split("__")[0] + " " + r["file"][-9:-4], str(e9 / "ulog" / r["file"]), int(r["damaged_px4_motors"]),
             "cut") for r in rows if r["damage_kind"] in ("cut", "tape") and r["damaged_px4_motors"].isdigit()]
    loads = [(r["file"][:-4], str(load / "ulog" / r["file"]), 0, "load")
             for r in csv.DictReader(open(load / "manifest.csv"))]
    added = next(p for nm, p, _, _ in loads if added_kind in nm)
    log00 = next(str(e9 / "ulog" / r["file"]) for r in normals if r["file"].endswith("log00.ulg"))
    flights = ([x for x in loads if x[1] != added] + [(r["file"][:-4], str(e9 / "ulog" / r["file"]), 0, "healthy")
                                                      for r in normals if not r["file"].endswith("log00.ulg")] + cuts)
    run_set("crazypad", log00, added, flights, tmp, verbose, name=name)


def crazypad_w3(tmp, verbose, start=None):
    """As ``crazypad``, the configuration from the heavier taped weight's first flight (W3 log01)."""
    crazypad(tmp, verbose, start, added_kind="add_weight_W3", name="W3 taped near M3")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="sih,sim,crazypad")
    ap.add_argument("-v", "--verbose", action="store_true")
    ap.add_argument("--start", default=None, help="start from this profile of the set's healthy flight (e.g. "
                    "/work/golden/profiles/sih004_adapted.json, its .onnx beside it) instead of a --no-adapt one")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for s in a.only.split(","):
            {"sih": sih, "sim": sim, "crazypad": crazypad, "crazypad_w3": crazypad_w3}[s](Path(d), a.verbose, a.start)


if __name__ == "__main__":
    main()
