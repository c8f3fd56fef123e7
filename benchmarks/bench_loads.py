"""A load is not a propeller: the figures of issue 32's "done when", in one run.

    python benchmarks/bench_loads.py --profiles /work/golden/profiles [--only SETS] [-v]

Profiles are read from ``--profiles`` (the golden file's: cp00_noadapt.json, cp00_adapted.json
(+ .onnx), sih004_noadapt.json, sih004_adapted.json, rrc_g{1,2,3}_noadapt.json); a missing one is
calibrated there with ``--no-adapt`` (adapted ones are skipped). Each set skips when ../shared
lacks it. Printed per set: healthy / uncertain / damaged counts, the flights whose verdict names
the right motor (damaged, or uncertain with ``verdict.motor``) against the model's window
majority alone (the before-stop hook's rule: the most-voted damaged class when at least half the
windows vote damage), and for the load sets how many verdicts give ``cause`` = ``load`` and name
the load toward the motor it sits near. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import Counter
from pathlib import Path

SHARED = Path(__file__).resolve().parents[1].parent / "shared"


def majority(d) -> int:
    votes = [w.cls for w in d.windows]
    dmg = [c for c in votes if c > 0]
    if not votes or len(dmg) < 0.5 * len(votes):
        return 0
    return Counter(dmg).most_common(1)[0][0]


def profile_of(name: str, folder: Path, calib: Path | None):
    from flightlog_fd.profile import Profile

    p = folder / f"{name}.json"
    if not p.exists():
        if calib is None or "adapted" in name:
            return None
        from flightlog_fd.calibration import calibrate

        calibrate([calib], adapt=False, output=p)
    return Profile.load(p)


def run(label, logs, prof, verbose, near=None):
    """logs: [(name, path, truth motor or 0, group)]; prints one line per group and returns counts."""
    from flightlog_fd.diagnose import diagnose_path, resolve_model

    model = resolve_model(None, prof)
    rows = []
    for name, path, truth, group in logs:
        d = diagnose_path(path, model, prof)
        v = d.verdict
        load = getattr(v, "load", None) or {}
        rows.append((name, group, truth, v.status, v.motor, v.cause, load.get("motor"), majority(d)))
        if verbose:
            cmd = next((r for r in (d.decision.results if d.decision else []) if r.analyzer == "commands"), None)
            fit = getattr(cmd, "load", None)
            lf = (f"load llr {fit.llr:+.1f} m{fit.motor} a{fit.size:.2f} rvl "
                  + ",".join(f"{x:+.1f}" for x in cmd.rotor_vs_load)) if fit is not None else "no load fit"
            tot = ",".join(f"{m.llr:+.1f}" for m in d.decision.motors) if d.decision else ""
            print(f"    {name[:44]:44s} {v.status:9s} m{v.motor} cause {v.cause} model {majority(d)} | {lf} | "
                  f"tot {tot} | {v.reason[:110]}", flush=True)
    print(f"\n{label}")
    for g in dict.fromkeys(r[1] for r in rows):
        rs = [r for r in rows if r[1] == g]
        c = Counter(r[3] for r in rs)
        named = sum(1 for r in rs if r[2] and r[3] in ("damaged", "uncertain") and r[4] == r[2])
        damaged_right = sum(1 for r in rs if r[2] and r[3] == "damaged" and r[4] == r[2])
        model = sum(1 for r in rs if r[2] and r[7] == r[2])
        loads = sum(1 for r in rs if r[5] == "load")
        toward = sum(1 for r in rs if r[5] == "load" and near and r[6] == near)
        txt = f"  {g:34s} n={len(rs):2d}  {c['healthy']}h {c['uncertain']}u {c['damaged']}d"
        if any(r[2] for r in rs):
            txt += f" | named {named} (damaged {damaged_right}), model majority {model}"
        txt += f" | cause load {loads}" + (f", toward motor {near} {toward}" if near else "")
        print(txt, flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--profiles", type=Path, default=Path("build/golden_profiles"))
    ap.add_argument("--only", default="", help="comma list: e9load,sihload,sih,e9,rrc,healthy,apsitl")
    ap.add_argument("-v", "--verbose", action="store_true")
    a = ap.parse_args()
    a.profiles.mkdir(parents=True, exist_ok=True)
    only = set(filter(None, a.only.split(",")))

    def want(s):
        return not only or s in only

    t0 = time.time()
    cp = SHARED / "crazypad_e9"
    cp00 = cp / "ulog" / "normal_flight__E9_log00.ulg"
    if want("e9load") and (SHARED / "crazypad_e9_load").is_dir():
        logs = [(r["file"], SHARED / "crazypad_e9_load" / "ulog" / r["file"], 0, r["condition"])
                for r in csv.DictReader(open(SHARED / "crazypad_e9_load" / "manifest.csv"))]
        for pn in (None, "cp00_noadapt", "cp00_adapted"):
            prof = profile_of(pn, a.profiles, cp00) if pn else None
            if pn and prof is None:
                continue
            run(f"crazypad_e9_load, profile {pn}", logs, prof, a.verbose, near=2)
    sih = SHARED / "px4_sih_dev"
    if want("sihload") and (SHARED / "px4_sih_dev_load").is_dir():
        near = {"A_default_com_m1": 1, "A_default_com_m3": 3, "A_default_com_m1_p1": 1}
        logs = [(p.stem, p, 0, p.stem) for p in sorted((SHARED / "px4_sih_dev_load").glob("*.ulg"))]
        for pn in (None, "sih004_noadapt", "sih004_adapted"):
            prof = profile_of(pn, a.profiles, sih / "logs" / "sih_004.ulg") if pn else None
            if pn and prof is None:
                continue
            rows = run(f"px4_sih_dev_load, profile {pn}", logs, prof, a.verbose)
            print("  load named toward the right motor: "
                  + ", ".join(f"{r[0]} {r[6]}" for r in rows if r[5] == "load" and r[0] in near))
    if want("sih") and sih.is_dir():
        logs = []
        for r in csv.DictReader(open(sih / "manifest.csv")):
            m = int(r["faulty_motor"])
            logs.append((r["name"], sih / "logs" / f"{r['name']}.ulg", m, "healthy" if not m else "weak motor"))
        for pn in (None, "sih004_noadapt", "sih004_adapted"):
            prof = profile_of(pn, a.profiles, sih / "logs" / "sih_004.ulg") if pn else None
            if pn and prof is None:
                continue
            run(f"px4_sih_dev, profile {pn}", [x for x in logs if not (pn and x[0] == "sih_004")], prof, a.verbose)
    if want("e9") and cp.is_dir():
        logs = []
        for r in csv.DictReader(open(cp / "manifest.csv")):
            m = int(r["damaged_px4_motors"]) if r["damaged_px4_motors"].strip() else 0
            logs.append((r["file"], cp / "ulog" / r["file"], m, "normal" if not m else "single propeller"))
        for pn in (None, "cp00_noadapt", "cp00_adapted"):
            prof = profile_of(pn, a.profiles, cp00) if pn else None
            if pn and prof is None:
                continue
            run(f"crazypad_e9, profile {pn}", [x for x in logs if not (pn and x[1] == cp00)], prof, a.verbose)
    rrc = SHARED / "real_damaged" / "rrc_straight"
    if want("rrc") and rrc.is_dir():
        for g in (1, 2, 3):
            good = rrc / f"good_prop_straight_line_{g}.BIN"
            prof = profile_of(f"rrc_g{g}_noadapt", a.profiles, good)
            logs = [(p.stem, p, 1 if "cut" in p.stem else 0, p.stem.split("_straight")[0].rsplit("_", 1)[0]
                     if "cut" in p.stem else "good") for p in sorted(rrc.glob("*.BIN")) if p != good]
            run(f"rrc_straight, profile good {g} (--no-adapt)", logs, prof, a.verbose)
        logs = [(p.stem, p, 1 if "cut" in p.stem else 0, p.stem.split("_straight")[0].rsplit("_", 1)[0]
                 if "cut" in p.stem else "good") for p in sorted(rrc.glob("*.BIN"))]
        run("rrc_straight, no profile", logs, None, a.verbose)
    if want("healthy") and (SHARED / "real_healthy").is_dir():
        paths = sorted((SHARED / "real_healthy" / "logs").glob("*")) + sorted(
            (SHARED / "real_logs" / "ardupilot").glob("erle_copter*.BIN"))
        run("real healthy (+Erle), no profile", [(p.stem, p, 0, "healthy") for p in paths], None, a.verbose)
    aq = SHARED / "ardupilot_sitl_quad"
    if want("apsitl") and aq.is_dir():
        run("ardupilot_sitl_quad, no profile", [(p.stem, p, 1 if "motor1" in p.stem else 0, p.stem)
                                                 for p in sorted(aq.glob("*.BIN"))], None, True)
    print(f"\n({time.time() - t0:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
