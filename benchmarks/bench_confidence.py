"""Is the stated confidence the probability that the verdict is right? Measured per set.

    python benchmarks/bench_confidence.py [--out RECORDS.json] [--profiles DIR] [--sim DIR] [--only SET,...]
    python benchmarks/bench_confidence.py --report RECORDS.json     # print again from saved records

Drives the installed ``fdlog`` (``fdlog diagnose --json``, all of a set's logs in one call) on each
set, without a profile and, where the set has a healthy flight of one airframe, with a one-flight
``fdlog calibrate --no-adapt`` profile of its first healthy flight (that flight left out of the
scoring). Sets, with their truth:

- real: ``real healthy`` (``../shared/real_healthy`` + the Erle copter logs of ``real_logs/ardupilot``,
  all healthy; profiles per Erle board group), ``rrc_straight`` (good / 5-25 mm cuts, rotor not
  stated), ``crazypad_e9`` (manifest: normal / cut or tape on the PX4 motors listed),
  ``crazypad_e9_load`` (added weights: the propellers are sound), ``px4_sih_dev`` (manifest: healthy
  / faulty motor), ``px4_sih_dev_load`` (a shifted centre of mass: sound), ``real_vibration``
  (air_octo 03 and 10, udesa: a cut propeller, rotor not stated; air_octo 14: healthy);
- simulated: ``sample_logs`` (named by their truth), ``ardupilot_sitl`` (ArduPilot's own SITL:
  healthy, a weak motor 1, hexa motors stopped) and ``sim batch``: flights ``fdlog simulate`` writes
  into ``--sim`` (random quads at three logging profiles and random hexas at PX4 high rate, healthy
  and one damaged propeller at eta 0.6-0.95; a preset x500 set with a healthy flight for the profile).

Right: ``healthy`` iff the truth is healthy; ``damaged``, ``uncertain`` and ``stopped`` iff the truth
is damaged and a propeller the verdict names (``verdict.motors``, else its ``inspect`` advice,
else all) is a damaged one (any named one when the set does not say which rotor). Prints per set and
profile: verdicts, how many stated below 0.5, the stated-confidence bins against the fraction
right, and "stated >= 0.9: right k/n".
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
FDLOG = str(Path(sys.executable).with_name("fdlog"))
#: Confidence bins of the table.
BINS = (0.0, 0.5, 0.7, 0.8, 0.9, 0.95, 1.0001)
#: Truth: None healthy; a tuple of damaged motors (() = damaged, rotor not stated).
HEALTHY = None


def _glob(folder: Path, *patterns: str) -> list[Path]:
    return sorted(p for pat in patterns for p in folder.glob(pat)) if folder.is_dir() else []


def real_sets() -> dict[str, list[tuple[Path, object]]]:
    out: dict[str, list[tuple[Path, object]]] = {}
    real = _glob(SHARED / "real_healthy" / "logs", "*") + _glob(SHARED / "real_logs" / "ardupilot", "erle_copter*.BIN")
    out["real healthy"] = [(p, HEALTHY) for p in real]
    rrc = SHARED / "real_damaged" / "rrc_straight"
    out["rrc_straight"] = [(p, HEALTHY if p.name.startswith("good") else ()) for p in _glob(rrc, "*.BIN")]
    for name in ("crazypad_e9", "crazypad_e9_load"):
        man = SHARED / name / "manifest.csv"
        if man.exists():
            rows = []
            for row in csv.DictReader(man.open()):
                p = SHARED / name / "ulog" / row["file"]
                kind = row["damage_kind"]
                if kind in ("none", "load"):
                    rows.append((p, HEALTHY))
                else:
                    rows.append((p, tuple(int(k) for k in row["damaged_px4_motors"].split(";") if k)))
            out[name] = sorted(rows)
    man = SHARED / "px4_sih_dev" / "manifest.csv"
    if man.exists():
        out["px4_sih_dev"] = [(SHARED / "px4_sih_dev" / "logs" / f"{r['name']}.ulg",
                               HEALTHY if r["label"] == "healthy" else (int(r["faulty_motor"]),))
                              for r in csv.DictReader(man.open())]
    out["px4_sih_dev_load"] = [(p, HEALTHY) for p in _glob(SHARED / "px4_sih_dev_load", "*.ulg")]
    vib = SHARED / "real_vibration"
    out["real_vibration"] = [(p, HEALTHY if "octo_14" in p.name else ()) for p in
                             _glob(vib / "octo_air", "*.BIN") + _glob(vib / "quad_udesa", "*.ulg")]
    return {k: v for k, v in out.items() if v}


def _sample_truth(p: Path):
    if "healthy" in p.name:
        return HEALTHY
    for tok in p.stem.split("_"):
        if tok.startswith("motor") and tok[5:].isdigit():
            return (int(tok[5:]),)
    return ()


def sim_sets(folder: Path) -> dict[str, list[tuple[Path, object]]]:
    out: dict[str, list[tuple[Path, object]]] = {}
    out["sample_logs"] = [(p, _sample_truth(p)) for p in _glob(ROOT / "sample_logs", "*.ulg", "*.bin")]
    sitl = SHARED / "ardupilot_sitl_quad"
    out["ardupilot_sitl"] = ([(p, HEALTHY if "healthy" in p.name else (1,)) for p in _glob(sitl, "*.BIN")]
                             + [(p, (int(p.stem[-1]),)) for p in _glob(SHARED / "ardupilot_sitl_hexa", "*.bin")])
    made = folder / "truth.json"
    if made.exists():
        truth = json.loads(made.read_text())
        for set_name, rows in truth.items():
            out[set_name] = [(folder / f, None if t is None else tuple(t)) for f, t in rows]
    return {k: v for k, v in out.items() if v}


#: The simulated batch: (set, log profile, format, airframe, frame); each gets SIM_HEALTHY healthy
#: flights and one damaged propeller at each of SIM_ETAS, on motors 1..n in turn.
SIM_SETS = (("sim px4_high", "px4_high", "ulog", "random", None),
            ("sim px4_default", "px4_default", "ulog", "random", None),
            ("sim ardupilot", "ardupilot", "dataflash", "random", None),
            ("sim x500 px4_default", "px4_default", "ulog", "x500", None),
            ("sim hexa px4_high", "px4_high", "ulog", "random", "hexa_x"))
SIM_HEALTHY, SIM_ETAS = 6, (0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95)


def make_sim(folder: Path) -> None:
    """Write the simulated batch into ``folder`` once (``fdlog simulate``), with truth.json."""
    made = folder / "truth.json"
    if made.exists():
        return
    folder.mkdir(parents=True, exist_ok=True)
    truth: dict[str, list] = {}
    seed = 7300
    for set_name, prof, fmt, airframe, frame in SIM_SETS:
        ext = ".ulg" if fmt == "ulog" else ".bin"
        rows = []
        n = {"hexa_x": 6, "octo_x": 8}.get(frame or "", 4)
        jobs = [(0, 1.0)] * SIM_HEALTHY + [((i % n) + 1, eta) for i, eta in enumerate(SIM_ETAS)]
        for i, (motor, eta) in enumerate(jobs):
            seed += 1
            name = f"{set_name.replace(' ', '_')}_{i:02d}_{'healthy' if motor == 0 else f'm{motor}_eta{eta:.1f}'}{ext}"
            cmd = [FDLOG, "simulate", "-o", str(folder / name), "-f", fmt, "--airframe", airframe,
                   "--log-profile", prof, "--seed", str(seed), "--motor", str(motor), "--force",
                   *(["--eta", str(eta)] if motor else []), *(["--frame", frame] if frame else [])]
            if airframe != "random":
                cmd += ["--vehicle-id", set_name.replace(" ", "_")]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                print(f"  simulate failed: {' '.join(cmd)}: {r.stderr.strip()[-300:]}", file=sys.stderr)
                continue
            rows.append((name, None if motor == 0 else [motor]))
        truth[set_name] = rows
        print(f"  simulated {set_name}: {len(rows)} flights", file=sys.stderr, flush=True)
    made.write_text(json.dumps(truth, indent=1))


def profile_groups(set_name: str, rows: list[tuple[Path, object]]) -> list[tuple[str, Path, list]]:
    """(profile name, its one healthy calibration flight, the rows it diagnoses): one airframe each."""
    healthy = [p for p, t in rows if t is HEALTHY]
    if set_name == "real healthy":
        man = SHARED / "real_healthy" / "manifest.csv"
        groups: dict[str, list[Path]] = defaultdict(list)
        for row in csv.DictReader(man.open()):
            if row.get("board_group"):
                groups[row["board_group"]].append(SHARED / "real_healthy" / "logs" / row["file"])
        out = []
        for g, files in sorted(groups.items()):
            files = sorted(files)
            if len(files) >= 2:
                out.append((f"board_{g}", files[0], [(p, HEALTHY) for p in files]))
        return out
    if set_name in ("real_vibration", "ardupilot_sitl") or set_name.startswith("sim ") and "x500" not in set_name:
        return []  # different airframes (or no healthy flight of the damaged ones' airframe)
    if set_name == "sample_logs":
        px4_quad = [(p, t) for p, t in rows if p.suffix == ".ulg" and "octo" not in p.name]
        return [("sample_px4", ROOT / "sample_logs" / "px4_healthy.ulg", px4_quad)]
    if set_name == "px4_sih_dev_load":
        return [("sih004", SHARED / "px4_sih_dev" / "logs" / "sih_004.ulg", rows)]
    if set_name == "crazypad_e9_load":
        cp = sorted(_glob(SHARED / "crazypad_e9" / "ulog", "normal*.ulg"))
        return [("cp_normal0", cp[0], rows)] if cp else []
    if set_name == "px4_sih_dev":
        return [("sih004", SHARED / "px4_sih_dev" / "logs" / "sih_004.ulg", rows)]
    return [(f"{set_name.replace(' ', '_')}_h0", healthy[0], rows)] if healthy else []


def calibrate(name: str, log: Path, folder: Path) -> Path | None:
    out = folder / f"{name}_noadapt.json"
    if not out.exists():
        r = subprocess.run([FDLOG, "calibrate", "--no-adapt", str(log), "-o", str(out)], capture_output=True, text=True)
        if r.returncode != 0:
            print(f"  calibration {name} refused: {(r.stderr or r.stdout).strip()[-300:]}", file=sys.stderr)
            return None
    return out


def diagnose(logs: list[Path], profile: Path | None) -> dict[str, dict]:
    cmd = [FDLOG, "diagnose", "--json", *(["--profile", str(profile)] if profile else []), *map(str, logs)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if not r.stdout.strip():
        raise SystemExit(f"fdlog diagnose printed nothing (exit {r.returncode}): {r.stderr[-2000:]}")
    docs = json.loads(r.stdout)
    return {str(Path(d["log"])): d for d in (docs if isinstance(docs, list) else [docs])}


def record(doc: dict, **meta) -> dict:
    v = doc.get("verdict") or {}
    inspect = next((a.get("motors") for a in v.get("advice") or [] if a.get("kind") == "inspect" and a.get("motors")), [])
    ev = doc.get("evidence") or {}
    return {**meta, "log": Path(doc["log"]).name, "status": v.get("status"), "motor": v.get("motor"),
            "motors": v.get("motors") or [], "inspect": inspect or [], "confidence": v.get("confidence"),
            "seen": v.get("seen"), "reason": v.get("reason"), "exit_code": doc.get("exit_code"),
            "weights": [m.get("weight") for m in doc.get("motors") or []],
            "llr": [m.get("llr") for m in doc.get("motors") or []],
            "abstained": ev.get("abstained"), "covered_s": ev.get("covered_s"), "n_windows": ev.get("n_windows")}


def right(r: dict) -> bool:
    truth = r["truth"]
    if r["status"] == "healthy":
        return truth is None
    if truth is None:
        return False
    named = r["motors"] or r["inspect"]
    return not truth or not named or bool(set(named) & set(truth))


def run(args) -> list[dict]:
    profiles = Path(args.profiles)
    profiles.mkdir(parents=True, exist_ok=True)
    sim = Path(args.sim)
    make_sim(sim)
    sets = {**{k: ("real", v) for k, v in real_sets().items()}, **{k: ("simulated", v) for k, v in sim_sets(sim).items()}}
    recs: list[dict] = []
    t0 = time.perf_counter()
    for set_name, (group, rows) in sets.items():
        if args.only and set_name not in args.only.split(","):
            continue
        truth = {str(p): t for p, t in rows}
        docs = diagnose([p for p, _ in rows], None)
        recs += [record(d, set=set_name, group=group, profile="none", truth=truth[log]) for log, d in docs.items()]
        for name, cal, prows in profile_groups(set_name, rows):
            prof = calibrate(name, cal, profiles)
            if prof is None:
                continue
            logs = [p for p, _ in prows if p.resolve() != cal.resolve()]
            ptruth = {str(p): t for p, t in prows}
            docs = diagnose(logs, prof)
            recs += [record(d, set=set_name, group=group, profile=name, truth=ptruth[log]) for log, d in docs.items()]
        print(f"{set_name}: done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    return recs


def report(recs: list[dict]) -> None:
    rs = [r for r in recs if r["status"] in ("healthy", "uncertain", "damaged", "stopped")]
    nd = len(recs) - len(rs)
    print(f"# Stated confidence against the fraction right ({len(rs)} verdicts; {nd} not diagnosable left out)\n")
    print("Cells: right / verdicts stated in that confidence bin. healthy seen / not seen: healthy verdicts whose "
          "evidence saw the flight, and those whose log could not show damage (right in brackets).\n")
    print("| group | set | profile | verdicts h/u/d/s | healthy seen (right) / not seen (right) | below 0.5 | "
          + " | ".join(f"{lo:.2f}-{min(hi, 1):.2f}" for lo, hi in zip(BINS[:-1], BINS[1:])) + " | stated >= 0.9 right |")
    print("|---|---|---|---|---|---|" + "---|" * (len(BINS) - 1) + "---|")
    keyed: dict[tuple, list[dict]] = defaultdict(list)
    for r in rs:
        keyed[(r["group"], r["set"], "none" if r["profile"] == "none" else "one flight")].append(r)
    worst = []
    for (group, set_name, prof), b in sorted(keyed.items()):
        c = defaultdict(int)
        for r in b:
            c[r["status"]] += 1
        cells = []
        for lo, hi in zip(BINS[:-1], BINS[1:]):
            x = [r for r in b if lo <= r["confidence"] < hi]
            cells.append(f"{sum(map(right, x))}/{len(x)}" if x else "")
        hi9 = [r for r in b if r["confidence"] >= 0.9]
        ok9 = sum(map(right, hi9))
        frac = f"{ok9}/{len(hi9)} ({100 * ok9 / len(hi9):.0f} %)" if hi9 else "-"
        if hi9 and ok9 < 0.9 * len(hi9):
            worst.append((group, set_name, prof))
        below = sum(r["confidence"] < 0.5 for r in b)
        seen = [r for r in b if r["status"] == "healthy" and r.get("seen") is not False]
        unseen = [r for r in b if r["status"] == "healthy" and r.get("seen") is False]
        print(f"| {group} | {set_name} | {prof} | {c['healthy']}/{c['uncertain']}/{c['damaged']}/{c['stopped']} | "
              f"{len(seen)} ({sum(map(right, seen))}) / {len(unseen)} ({sum(map(right, unseen))}) | "
              f"{below} | " + " | ".join(cells) + f" | {frac} |")
    for group in ("real", "simulated"):
        g = [r for r in rs if r["group"] == group]
        hi9 = [r for r in g if r["confidence"] >= 0.9]
        if hi9:
            print(f"\n{group}: stated >= 0.9 right {sum(map(right, hi9))}/{len(hi9)}; "
                  f"below 0.5: {sum(r['confidence'] < 0.5 for r in g)} of {len(g)}")
        by = {st: [r for r in g if r["status"] == st] for st in ("healthy", "uncertain", "damaged", "stopped")}
        print(f"{group}, right per verdict (mean stated): " + "; ".join(
            f"{st} {sum(map(right, x))}/{len(x)} ({sum(r['confidence'] for r in x) / len(x):.2f})"
            for st, x in by.items() if x))
    print(f"\nSets where stated >= 0.9 is right less than 90 % of the time: {worst or 'none'}")
    below = [r for r in rs if r["confidence"] < 0.5]
    for r in below[:40]:
        print(f"  below 0.5: {r['set']} | {r['profile']} | {r['log']}: {r['status']} {r['motors']} "
              f"{r['confidence']:.2f} (truth {r['truth']})")
    wrong = [r for r in rs if r["confidence"] >= 0.9 and not right(r)]
    for r in wrong[:60]:
        print(f"  wrong at >= 0.9: {r['set']} | {r['profile']} | {r['log']}: {r['status']} {r['motors'] or r['inspect']} "
              f"{r['confidence']:.2f} (truth {r['truth']})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profiles", default=str(ROOT / "build" / "confidence_profiles"))
    ap.add_argument("--sim", default=str(ROOT / "build" / "confidence_sim2"), help="folder of the simulated batch")
    ap.add_argument("--only", help="only these sets (comma-separated)")
    ap.add_argument("--out", help="write the records (JSON) here")
    ap.add_argument("--report", help="print the report from saved records instead of running")
    args = ap.parse_args()
    if args.report:
        recs = json.loads(Path(args.report).read_text())
    else:
        recs = run(args)
        if args.out:
            Path(args.out).write_text(json.dumps(recs, indent=0))
    report(recs)


if __name__ == "__main__":
    main()
