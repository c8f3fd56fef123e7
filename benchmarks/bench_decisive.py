"""Decisive, and a load at a rotor's corner (issue 32 item 5, the W3 flights): before and after, one run.

    python benchmarks/bench_decisive.py --profiles /work/golden/profiles [--only SETS] [-v]

Each flight is diagnosed once (in process, the golden file's profiles: ``cp00_noadapt``,
``cp00_adapted``, ``sih004_noadapt``, ``sih004_adapted``, ``rrc_g{1,2,3}_noadapt``; a missing
``--no-adapt`` one is calibrated there), then its verdict is decided twice from the same analyzer
results and timeline: "before" with :func:`flightlog_fd.decision._pattern_held` switched off (the
decision as it was), "after" as the code stands. Printed per set and group: healthy / uncertain /
damaged before -> after, the flights whose verdict names the right motor (damaged, or uncertain
naming it) and the damaged ones among them, against the model's window majority alone (the
before-stop hook's rule, :func:`bench_loads.majority`). ``-v``: one line per flight whose verdict
moved. Sets skip when ../shared lacks them. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_loads import SHARED, majority, profile_of  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def cases(profiles: Path, only: set):
    """[(set label, profile name or None, [(name, path, truth motor, group)])]"""
    def want(s):
        return not only or s in only

    out = []
    cp = SHARED / "crazypad_e9"
    cp00 = cp / "ulog" / "normal_flight__E9_log00.ulg"
    sih = SHARED / "px4_sih_dev"
    if want("e9load") and (SHARED / "crazypad_e9_load").is_dir():
        logs = [(r["file"], SHARED / "crazypad_e9_load" / "ulog" / r["file"], 0,
                 "W3 taped" if r["file"].startswith("add_weight_W3") else "other loads")
                for r in csv.DictReader(open(SHARED / "crazypad_e9_load" / "manifest.csv"))]
        for pn in (None, "cp00_noadapt", "cp00_adapted"):
            out.append(("crazypad_e9_load", pn, logs))
    if want("sihload") and (SHARED / "px4_sih_dev_load").is_dir():
        logs = [(p.stem, p, 0, "moved load") for p in sorted((SHARED / "px4_sih_dev_load").glob("*.ulg"))]
        for pn in (None, "sih004_noadapt", "sih004_adapted"):
            out.append(("px4_sih_dev_load", pn, logs))
    if want("sih") and sih.is_dir():
        logs = []
        for r in csv.DictReader(open(sih / "manifest.csv")):
            m = int(r["faulty_motor"])
            logs.append((r["name"], sih / "logs" / f"{r['name']}.ulg", m, "healthy" if not m else "weak motor"))
        out.append(("px4_sih_dev", None, logs))
        for pn in ("sih004_noadapt", "sih004_adapted"):
            out.append(("px4_sih_dev", pn, [x for x in logs if x[0] != "sih_004"]))
    if want("e9") and cp.is_dir():
        logs = []
        for r in csv.DictReader(open(cp / "manifest.csv")):
            m = int(r["damaged_px4_motors"]) if r["damaged_px4_motors"].strip() else 0
            logs.append((r["file"], cp / "ulog" / r["file"], m, "normal" if not m else "single propeller"))
        out.append(("crazypad_e9", None, logs))
        for pn in ("cp00_noadapt", "cp00_adapted"):
            out.append(("crazypad_e9", pn, [x for x in logs if x[1] != cp00]))
    rrc = SHARED / "real_damaged" / "rrc_straight"
    if want("rrc") and rrc.is_dir():
        def grp(p):
            return p.stem.split("_straight")[0].rsplit("_", 1)[0] if "cut" in p.stem else "good"
        for g in (1, 2, 3):
            good = rrc / f"good_prop_straight_line_{g}.BIN"
            out.append(("rrc_straight", f"rrc_g{g}_noadapt",
                        [(p.stem, p, 1 if "cut" in p.stem else 0, grp(p)) for p in sorted(rrc.glob("*.BIN")) if p != good]))
        out.append(("rrc_straight", None, [(p.stem, p, 1 if "cut" in p.stem else 0, grp(p))
                                           for p in sorted(rrc.glob("*.BIN"))]))
    if want("healthy") and (SHARED / "real_healthy").is_dir():
        paths = sorted((SHARED / "real_healthy" / "logs").glob("*")) + sorted(
            (SHARED / "real_logs" / "ardupilot").glob("erle_copter*.BIN"))
        out.append(("real healthy (+Erle)", None, [(p.stem, p, 0, "healthy") for p in paths]))
    aq = SHARED / "ardupilot_sitl_quad"
    if want("apsitl") and aq.is_dir():
        out.append(("ardupilot_sitl_quad", None, [(p.stem, p, 1 if "motor1" in p.stem else 0, p.stem)
                                                  for p in sorted(aq.glob("*.BIN"))]))
    if want("samples"):
        logs = []
        for p in sorted((ROOT / "sample_logs").glob("*")):
            if p.suffix.lower() not in (".ulg", ".bin"):
                continue
            m = next((int(t[5:]) for t in p.stem.split("_") if t.startswith("motor") and t[5:].isdigit()), 0)
            logs.append((p.stem, p, m, "damaged sample" if m else "healthy sample"))
        out.append(("sample_logs", None, logs))
    return out, cp00, sih / "logs" / "sih_004.ulg", rrc


def both(d):
    """(before, after) verdicts of one diagnosis, from its own results and timeline."""
    from flightlog_fd import decision

    if d.decision is None or d.timeline is None or d.stopped:
        return d.verdict, d.verdict
    n = len(d.decision.motors)
    frame = d.flight.frame if d.flight is not None else None
    after, dec = decision.decide(n, frame, timeline=d.timeline, results=d.decision.results, kind=d.log_kind)
    both.by_source = dict(dec.motors[after.motor - 1].llr_by_source) if dec is not None and after.motor else {}
    vib = decision._vibration(d.decision.results)
    both.vib = None if vib is None else decision._vibration_llr(vib)
    cmd = next((r for r in d.decision.results if r.analyzer == "commands"), None)
    both.load = None if cmd is None or cmd.load is None else (cmd.load.llr, list(cmd.rotor_vs_load))
    keep = decision._pattern_held
    decision._pattern_held = lambda *a, **k: None
    try:
        before, _ = decision.decide(n, frame, timeline=d.timeline, results=d.decision.results, kind=d.log_kind)
    finally:
        decision._pattern_held = keep
    return before, after


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--profiles", type=Path, default=Path("build/golden_profiles"))
    ap.add_argument("--only", default="", help="comma list: e9load,sihload,sih,e9,rrc,healthy,apsitl,samples")
    ap.add_argument("-v", "--verbose", action="count", default=0)
    a = ap.parse_args()
    a.profiles.mkdir(parents=True, exist_ok=True)
    from flightlog_fd.diagnose import diagnose_path, resolve_model

    t0 = time.time()
    sets, cp00, sih004, rrc = cases(a.profiles, set(filter(None, a.only.split(","))))
    calib = {"cp00": cp00, "sih004": sih004, **{f"rrc_g{g}": rrc / f"good_prop_straight_line_{g}.BIN" for g in (1, 2, 3)}}
    for label, pn, logs in sets:
        prof = profile_of(pn, a.profiles, calib[pn.rsplit("_", 1)[0]]) if pn else None
        if pn and prof is None:
            continue
        model = resolve_model(None, prof)
        rows = []
        for name, path, truth, group in logs:
            d = diagnose_path(path, model, prof)
            b, v = both(d)
            rows.append((group, truth, b, v, majority(d)))
            if a.verbose and a.verbose > 1:
                print(f"      {name[:40]:40s} {v.status} m{v.motor} vib {both.vib}", flush=True)
            if a.verbose and (b.status, b.motor, tuple(b.inspect)) != (v.status, v.motor, tuple(v.inspect)):
                print(f"    {label} {pn} {name[:40]:40s} {b.status} m{b.motor} -> {v.status} m{v.motor} "
                      f"{list(v.inspect)} | " + ", ".join(f"{k} {x:+.1f}" for k, x in both.by_source.items())
                      + (f", flight vibration {both.vib:+.1f}" if both.vib is not None else "")
                      + (f" | load {both.load[0]:+.1f} rotor-vs-load " + ",".join(f"{x:+.1f}" for x in both.load[1])
                         if both.load else ""), flush=True)
        print(f"\n{label}, profile {pn}")
        for g in dict.fromkeys(r[0] for r in rows):
            rs = [r for r in rows if r[0] == g]
            txt = f"  {g:30s} n={len(rs):2d}"
            for i in (2, 3):
                c = Counter(r[i].status for r in rs)
                txt += (" before " if i == 2 else " -> after ") + f"{c['healthy']}h {c['uncertain']}u {c['damaged']}d"
            if any(r[1] for r in rs):
                for i in (2, 3):
                    named = sum(1 for r in rs if r[1] and r[i].status in ("damaged", "uncertain") and r[i].motor == r[1])
                    dmg = sum(1 for r in rs if r[1] and r[i].status == "damaged" and r[i].motor == r[1])
                    txt += f" | {'before' if i == 2 else 'after'} named {named} ({dmg} d)"
                txt += f" | model majority {sum(1 for r in rs if r[1] and r[4] == r[1])}"
            print(txt, flush=True)
    print(f"\n({time.time() - t0:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
