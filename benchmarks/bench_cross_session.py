"""Cross-session benchmark: a calibrated airframe's other healthy flights, and its damaged ones.

    python benchmarks/bench_cross_session.py [--profiles DIR] [--no-adapted] [--out RECORDS.json]
    python benchmarks/bench_cross_session.py --report RECORDS.json      # print again from saved records

Every real airframe in ``../shared`` with two or more healthy flights (the Erle board groups of
``real_healthy/manifest.csv`` column ``board_group``, the rrc_straight good flights, the CrazyPAD E9
normal flights, the px4_sih_dev healthy flights): each flight calibrates a one-flight profile
(``fdlog calibrate --no-adapt`` and, unless ``--no-adapted``, the default adapted ``fdlog calibrate``)
that diagnoses every other healthy flight of the airframe (every ordered pair); and, leaving one
flight out, a profile of all the airframe's other healthy flights, ONE SESSION EACH, diagnoses the
flight left out (``--no-adapt``: ``fdlog calibrate A B ...``, each log a session; adapted: the
first flight's adapted one-flight profile with the others added by ``fdlog calibrate --add``, as a
pilot adds sessions; ``--via-add`` builds the ``--no-adapt`` ones that way too). With two healthy
flights the leave-one-out profile is the one-flight one. The damage side on the same footing: every
one-flight and leave-one-out profile of an airframe with damaged flights (rrc_straight cuts 5-25
mm, CrazyPAD E9 cuts and tape, px4_sih_dev weakened motors) diagnoses all of them. Beside it,
without a profile: the real healthy flights, the rrc_straight set and the px4_sih_dev set.

Driven through the CLI only (``fdlog calibrate``, ``fdlog diagnose --json`` with all of a profile's
logs in one call), so it measures what a pilot gets. Profiles are made once into ``--profiles``
(default ``build/cross_session_profiles``) and reused; a refused calibration is a row of its own.

Prints per airframe and in total healthy / uncertain / damaged for the healthy pairs, every false
call (uncertain or damaged on a healthy flight) with its reason and confidence, the damage side
per cut length / eta, the cross-session drift (per pair: per-motor command-share change against
calibration and the throttle ratio), and a reliability table over every verdict: confidence bins
against the fraction right (the verdict's hypothesis: healthy, or motor k; an uncertain verdict is
scored on the hypothesis its confidence is for, the most probable one).
"""
from __future__ import annotations

import argparse
import csv
import itertools
import json
import os
import re
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
#: The fdlog to drive: the one beside this Python, or $FDLOG (e.g. another checkout's, for a
#: before/after pair on the very same profile files).
FDLOG = os.environ.get("FDLOG") or str(Path(sys.executable).with_name("fdlog"))
RRC = SHARED / "real_damaged" / "rrc_straight"
CP = SHARED / "crazypad_e9"
SIH = SHARED / "px4_sih_dev"
HEALTHY = SHARED / "real_healthy"
#: CrazyPAD sessions whose label the set's README says to score as detection only (labelled PX4
#: motor 4, moves like a motor-2 problem).
CP_DETECTION_ONLY = ("cut_M2_0.5mm_46.5mm",)
#: Confidence bins of the reliability table.
RELIABILITY_BINS = (0.0, 0.5, 0.7, 0.9, 0.95, 0.99, 1.0001)


# ---------------------------------------------------------------------------------------- sets
class Airframe:
    """One real airframe: its healthy flights and its damaged flights with truth (motor 0 = unknown)."""

    def __init__(self, name: str, healthy: list[Path], damaged: list[tuple[Path, int, str]] = ()):
        self.name, self.healthy, self.damaged = name, healthy, list(damaged)


def airframes() -> list[Airframe]:
    out: list[Airframe] = []
    man = HEALTHY / "manifest.csv"
    if man.exists():
        groups: dict[str, list[Path]] = defaultdict(list)
        for row in csv.DictReader(man.open()):
            if row.get("board_group"):
                groups[row["board_group"]].append(HEALTHY / "logs" / row["file"])
        for g, files in sorted(groups.items()):
            if len(files) >= 2:
                out.append(Airframe(f"erle_{g}", sorted(files)))
    if RRC.is_dir():
        goods = sorted(RRC.glob("good_prop_straight_line_*.BIN"))
        cuts = []
        for p in sorted(RRC.glob("*_mm_cut_straight_line_*.BIN")):
            mm = int(p.name.split("_")[0])
            cuts.append((p, 0, f"{mm} mm cut"))
        cuts.sort(key=lambda c: (int(c[2].split()[0]), c[0].name))
        out.append(Airframe("rrc_straight", goods, cuts))
    if (CP / "manifest.csv").exists():
        normals, dmg = [], []
        for row in csv.DictReader((CP / "manifest.csv").open()):
            p = CP / "ulog" / row["file"]
            if row["damage_kind"] == "none":
                normals.append(p)
            elif row["condition"] in CP_DETECTION_ONLY:
                dmg.append((p, 0, f"{row['damage_kind']} m{row['damaged_px4_motors']} (detection)"))
            else:
                dmg.append((p, int(row["damaged_px4_motors"].split(";")[0]), f"{row['damage_kind']} m{row['damaged_px4_motors']}"))
        out.append(Airframe("crazypad_e9", sorted(normals), dmg))
    if (SIH / "manifest.csv").exists():
        h, dmg = [], []
        for row in csv.DictReader((SIH / "manifest.csv").open()):
            p = SIH / "logs" / f"{row['name']}.ulg"
            if row["label"] == "healthy":
                h.append(p)
            else:
                dmg.append((p, int(row["faulty_motor"]), f"eta {float(row['eta']):.1f}"))
        out.append(Airframe("px4_sih_dev", sorted(h), dmg))
    return out


def no_profile_sets() -> list[tuple[str, list[tuple[Path, int, str]]]]:
    """(set name, [(log, truth motor (-1 healthy, 0 damaged motor unknown), group)])."""
    real = sorted((HEALTHY / "logs").glob("*")) + sorted((SHARED / "real_logs" / "ardupilot").glob("erle_copter*.BIN"))
    out = [("real healthy", [(p, -1, "healthy") for p in real])]
    for af in airframes():
        if af.name in ("rrc_straight", "px4_sih_dev"):
            out.append((af.name, [(p, -1, "healthy") for p in af.healthy] + list(af.damaged)))
    return out


# ---------------------------------------------------------------------------------------- CLI
def calibrate(name: str, logs: list[Path], folder: Path, adapt: bool, base: Path | None = None) -> tuple[Path | None, str]:
    """The profile (made once), or None and the CLI's one-line refusal (also cached). ``base``: a
    profile to copy and add ``logs`` to as sessions (``fdlog calibrate --add``) instead."""
    out = folder / f"{name}.json"
    refused = folder / f"{name}.refused"
    if refused.exists():
        return None, refused.read_text().strip()
    if not out.exists():
        t0 = time.perf_counter()
        if base is not None:
            tmp = folder / f"{name}.partial.json"
            tmp.write_text(base.read_text())  # its model path stays relative: the same folder
            cmd = [FDLOG, "calibrate", "--add", str(tmp), *map(str, logs)]
        else:
            tmp = None
            cmd = [FDLOG, "calibrate", *([] if adapt else ["--no-adapt"]), *map(str, logs), "-o", str(out)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            why = ((r.stderr.strip() or r.stdout.strip()).splitlines() or ["(no message)"])[-1][:400]
            refused.write_text(why + "\n")
            return None, why
        if tmp is not None:
            tmp.replace(out)
        print(f"  calibrated {name} in {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return out, ""


def diagnose(logs: list[Path], profile: Path | None, jobs: int) -> dict[str, dict]:
    """``fdlog diagnose --json`` on many logs in one call: {log path: JSON object}."""
    if not logs:
        return {}
    cmd = [FDLOG, "diagnose", "--json", *(["--jobs", str(jobs)] if jobs > 1 else []),
           *(["--profile", str(profile)] if profile else []), *map(str, logs)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if not r.stdout.strip():
        raise SystemExit(f"fdlog diagnose printed nothing (exit {r.returncode}): {r.stderr[-2000:]}")
    docs = json.loads(r.stdout)
    docs = docs if isinstance(docs, list) else [docs]
    return {str(Path(d["log"])): d for d in docs}


def _finding(doc: dict, analyzer: str, name: str, motor: int):
    for a in doc.get("analyzers") or []:
        if a.get("analyzer") == analyzer:
            for f in a.get("findings") or []:
                if f.get("name") == name and f.get("motor") == motor:
                    return f
    return None


def record(doc: dict, **meta) -> dict:
    """The figures this benchmark keeps from one diagnosis."""
    v = doc.get("verdict") or {}
    motors = doc.get("motors") or []
    thr = _finding(doc, "throttle", "throttle", 1)
    weights = [m.get("weight") for m in motors]
    return {**meta, "log": Path(doc["log"]).name, "status": v.get("status"), "motor": v.get("motor"),
            "confidence": v.get("confidence"), "reason": v.get("reason"),
            "share": [m.get("command_share") for m in motors],
            "baseline": [m.get("command_share_baseline") for m in motors],
            "throttle_ratio": None if thr is None else thr.get("value"),
            "throttle": (doc.get("motor_evidence") or {}).get("throttle"),
            "eta_hat": [m.get("eta_hat") for m in motors], "eta_ci": [m.get("eta_ci") for m in motors],
            "llr": [m.get("llr") for m in motors], "llr_by_source": [m.get("llr_by_source") for m in motors],
            "weight": weights}


def run(args) -> list[dict]:
    folder = Path(args.profiles)
    folder.mkdir(parents=True, exist_ok=True)
    recs: list[dict] = []
    paths = ([] if args.adapted_only else ["noadapt"]) + ([] if args.no_adapted else ["adapted"])
    t0 = time.perf_counter()
    for af in airframes():
        if args.only and af.name not in args.only.split(","):
            continue
        n = len(af.healthy)
        cal_sets = [(i,) for i in range(n)] + ([tuple(j for j in range(n) if j != i) for i in range(n)] if n >= 3 else [])
        for path in paths:
            for cal in cal_sets:
                name = f"{af.name}_{''.join(str(i + 1) for i in cal)}_{path}"
                rest = [p for i, p in enumerate(af.healthy) if i not in cal]
                damaged = [] if (args.quick and len(cal) >= 2) else af.damaged
                if not rest and not damaged:
                    continue
                base, logs = None, [af.healthy[i] for i in cal]
                if len(cal) >= 2 and (path == "adapted" or args.via_add):
                    # the first flight that calibrates alone, the others added to it as sessions
                    for i in cal:
                        base, why = calibrate(f"{af.name}_{i + 1}_{path}", [af.healthy[i]], folder, path == "adapted")
                        if base is not None:
                            logs = [af.healthy[j] for j in cal if j != i]
                            break
                    if base is None:
                        recs.append({"airframe": af.name, "path": path, "profile": name, "n_cal": len(cal),
                                     "cal": [af.healthy[i].name for i in cal], "kind": "refused", "log": None,
                                     "reason": f"its first flight's profile was refused: {why}", "status": "refused"})
                        continue
                prof, why = calibrate(name, logs, folder, path == "adapted", base=base)
                meta = {"airframe": af.name, "path": path, "profile": name, "n_cal": len(cal),
                        "cal": [af.healthy[i].name for i in cal]}
                if args.calibrate_only:
                    continue
                if prof is None:
                    recs.append({**meta, "kind": "refused", "reason": why, "log": None, "status": "refused"})
                    print(f"{name}: calibration refused: {why}", file=sys.stderr, flush=True)
                    continue
                docs = diagnose(rest + [d[0] for d in damaged], prof, args.jobs)
                for p in rest:
                    recs.append(record(docs[str(p)], **meta, kind="healthy pair", truth=-1, group="healthy"))
                for p, motor, group in damaged:
                    recs.append(record(docs[str(p)], **meta, kind="damage", truth=motor, group=group))
                print(f"{name}: {len(rest)} healthy + {len(damaged)} damaged ({time.perf_counter() - t0:.0f} s)",
                      file=sys.stderr, flush=True)
    for set_name, items in ([] if args.calibrate_only or args.only else no_profile_sets()):
        docs = diagnose([p for p, _, _ in items], None, args.jobs)
        for p, motor, group in items:
            recs.append(record(docs[str(p)], airframe=set_name, path="none", profile="", n_cal=0, cal=[],
                               kind="no profile", truth=motor, group=group))
        print(f"no profile, {set_name}: {len(items)} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    return recs


# ---------------------------------------------------------------------------------------- scoring
def hypothesis(r: dict) -> int:
    """The hypothesis the verdict's confidence is for: 0 healthy, k motor k (uncertain: the most
    probable one of {healthy, motor 1..n}, from the weights)."""
    if r["status"] == "healthy":
        return 0
    if r["status"] in ("damaged", "stopped") and r.get("motor"):
        return int(r["motor"])
    w = [x or 0.0 for x in r.get("weight") or []]
    if not w:
        return 0
    w0 = 1.0 - sum(w)
    return 0 if w0 >= max(w) else int(np.argmax(w)) + 1


def right(r: dict) -> bool:
    """The verdict's hypothesis matches the truth (-1 healthy; 0 damaged, motor unknown; k)."""
    h = hypothesis(r)
    if r["truth"] == -1:
        return h == 0
    return h != 0 and (r["truth"] == 0 or h == r["truth"])


def _count(rs: list[dict]) -> str:
    c = defaultdict(int)
    for r in rs:
        c[r["status"]] += 1
    return f"{c['healthy']}h {c['uncertain']}u {c['damaged']}d" + (f" {c['not_diagnosable']}nd" if c["not_diagnosable"] else "")


def _motors(rs: list[dict], status: str) -> str:
    m = defaultdict(int)
    for r in rs:
        if r["status"] == status:
            k = r["motor"] if status == "damaged" else hypothesis(r)
            m[k] += 1
    return ", ".join(f"m{k}x{v}" for k, v in sorted(m.items()))


def _short_reason(text: str, width: int = 230) -> str:
    t = re.sub(r"\s+", " ", text or "")
    return t if len(t) <= width else t[:width - 3] + "..."


def report(recs: list[dict], verbose: bool = True) -> None:
    if not recs:
        return
    pairs = [r for r in recs if r["kind"] == "healthy pair"]
    refused = [r for r in recs if r["kind"] == "refused"]
    print("## Healthy flights against a profile of the same airframe (healthy / uncertain / damaged)\n")
    print("| airframe | calibrate | one-flight profile (ordered pairs) | all the other flights, one session each (leave-one-out) |")
    print("|---|---|---|---|")
    for path in ("noadapt", "adapted"):
        rows = [r for r in pairs if r["path"] == path]
        if not rows:
            continue
        for af in sorted({r["airframe"] for r in rows}):
            one = [r for r in rows if r["airframe"] == af and r["n_cal"] == 1]
            two = [r for r in rows if r["airframe"] == af and r["n_cal"] >= 2]
            print(f"| {af} | {path} | {_count(one)} | {_count(two) if two else '-'} |")
        one = [r for r in rows if r["n_cal"] == 1]
        two = [r for r in rows if r["n_cal"] >= 2]
        h1 = sum(r["status"] == "healthy" for r in one)
        h2 = sum(r["status"] == "healthy" for r in two)
        print(f"| **all** | {path} | **{_count(one)}** ({100 * h1 / max(len(one), 1):.0f} % healthy) | "
              f"**{_count(two)}** ({100 * h2 / max(len(two), 1):.0f} % healthy) |")
    for path in ("noadapt", "adapted"):
        loo = [r for r in pairs if r["path"] == path and r["airframe"] != "px4_sih_dev" and r["n_cal"] >= 2]
        if not loo:
            continue
        two_flight = [r for r in pairs if r["path"] == path and r["n_cal"] == 1 and r["airframe"] != "px4_sih_dev"
                      and len({x["log"] for x in pairs if x["airframe"] == r["airframe"]}) == 2]
        for label, rs in (("groups of three flights", loo), ("with the two-flight group's pairs", loo + two_flight)):
            h = sum(r["status"] == "healthy" for r in rs)
            print(f"\nLeave-one-out on the real airframes ({path}, {label}): {_count(rs)}, "
                  f"{h}/{len(rs)} healthy ({100 * h / max(len(rs), 1):.0f} %)")
    if refused:
        print("\nRefused calibrations: " + "; ".join(f"{r['profile']} ({_short_reason(r['reason'], 120)})" for r in refused))
    false = [r for r in pairs if r["status"] != "healthy"]
    print(f"\n### False calls on healthy flights ({len(false)})\n")
    for r in sorted(false, key=lambda r: (r["status"] != "damaged", r["path"], r["profile"], r["log"])):
        print(f"- **{r['status']}** {r['confidence']:.2f}, {r['profile']} -> {r['log']}: {_short_reason(r['reason'])}")

    print("\n## Damaged flights against a profile of the same airframe\n")
    dmg = [r for r in recs if r["kind"] == "damage"]
    print("| airframe | calibrate | profile flights | group | verdicts | damaged motors | uncertain leans |")
    print("|---|---|---|---|---|---|---|")
    for (af, path, n_cal, group), rs in sorted(_groupby(dmg, ("airframe", "path", "n_cal", "group")).items(),
                                               key=lambda kv: (kv[0][0], kv[0][1], kv[0][2], _group_key(kv[0][3]))):
        print(f"| {af} | {path} | {n_cal} | {group} | {_count(rs)} | {_motors(rs, 'damaged')} | {_motors(rs, 'uncertain')} |")
    rrc = [r for r in dmg if r["airframe"] == "rrc_straight"]
    if rrc:
        print("\nrrc_straight, per profile (one-flight: 25 mm damaged naming motor 1, 20 mm at least uncertain naming "
              "motor 1; two good flights, one session each: still flagged):\n")
        for (path, prof), rs in sorted(_groupby(rrc, ("path", "profile")).items()):
            cells = []
            for mm in (5, 10, 20, 25):
                g = [r for r in rs if r["group"] == f"{mm} mm cut"]
                cells.append(f"{mm} mm " + " ".join(_mark(r) for r in g))
            print(f"- {prof}: " + "; ".join(cells))

    print("\n## Without a profile\n")
    nop = [r for r in recs if r["kind"] == "no profile"]
    for (af, group), rs in sorted(_groupby(nop, ("airframe", "group")).items(), key=lambda kv: (kv[0][0], _group_key(kv[0][1]))):
        right_n = sum(right(r) for r in rs)
        print(f"- {af}, {group}: {_count(rs)} (right {right_n}/{len(rs)}; damaged motors: {_motors(rs, 'damaged') or '-'})")

    drift_report(pairs)
    reliability(recs)


def _mark(r: dict) -> str:
    s = {"healthy": "h", "uncertain": "u", "damaged": "D"}.get(r["status"], "?")
    k = r["motor"] if r["status"] == "damaged" else (hypothesis(r) if r["status"] == "uncertain" else "")
    return f"{s}{k or ''}"


def _group_key(g: str):
    m = re.match(r"([\d.]+)", g.split()[-1] if g.startswith("eta") else g)
    return (g.split()[0], float(m.group(1)) if m else 0.0, g)


def _groupby(rs, keys):
    out = defaultdict(list)
    for r in rs:
        out[tuple(r[k] for k in keys)].append(r)
    return out


def drift_figures(r: dict) -> dict | None:
    """One pair's drift: per-motor share change against calibration (absolute and relative to the
    baseline share), and the throttle ratio."""
    s, b = r.get("share"), r.get("baseline")
    if not s or not b or any(x is None for x in s + b):
        return None
    s, b = np.array(s, float), np.array(b, float)
    d = s - b
    return {"change": d, "rel": d / b, "max_abs": float(np.max(np.abs(d))), "max_rel_up": float(np.max(d / b)),
            "throttle_ratio": r.get("throttle_ratio")}


def drift_report(pairs: list[dict]) -> None:
    rows = [(r, drift_figures(r)) for r in pairs if r["path"] == "noadapt"]
    rows = [(r, f) for r, f in rows if f is not None]
    if not rows:
        return
    print("\n## Cross-session drift (healthy pairs, --no-adapt profiles)\n")
    print("Per pair: each motor's command-share change against calibration (share - baseline), the "
          "largest relative rise, and the throttle against calibration.\n")
    print("| airframe | profile flights | pairs | RMS share change | largest abs change | largest rise (rel.) | throttle ratio range |")
    print("|---|---|---|---|---|---|---|")
    for (af, n_cal), rs in sorted(_groupby([r for r, _ in rows], ("airframe", "n_cal")).items()):
        fs = [drift_figures(r) for r in rs]
        ch = np.concatenate([f["change"] for f in fs])
        thr = [f["throttle_ratio"] for f in fs if f["throttle_ratio"] is not None]
        print(f"| {af} | {n_cal} | {len(rs)} | {np.sqrt(np.mean(ch ** 2)):.3f} | {max(f['max_abs'] for f in fs):.3f} | "
              f"{max(f['max_rel_up'] for f in fs):+.2f} | "
              f"{(f'{min(thr):.2f}-{max(thr):.2f}' if thr else '-')} |")
    one = [f for r, f in rows if r["n_cal"] == 1]
    ch = np.concatenate([f["change"] for f in one])
    z = ch / np.sqrt(np.mean(ch ** 2))
    qs = np.quantile(np.abs(ch), [0.5, 0.9, 0.95, 0.99, 1.0])
    kurt = float(np.mean(z ** 4))
    print(f"\nAll one-flight pairs ({len(one)} pairs, {len(ch)} motor changes): |change| quantiles 50/90/95/99/100 %: "
          + "/".join(f"{q:.3f}" for q in qs) + f"; RMS {np.sqrt(np.mean(ch ** 2)):.3f}; kurtosis {kurt:.1f} (normal: 3)")
    per_af_rms = {af: float(np.sqrt(np.mean(np.concatenate([f['change'] for r, f in rows if r['airframe'] == af and r['n_cal'] == 1]) ** 2)))
                  for af in sorted({r['airframe'] for r, _ in rows})}
    print("Per airframe RMS (one-flight pairs): " + ", ".join(f"{k} {v:.3f}" for k, v in per_af_rms.items()))
    thr = np.array([f["throttle_ratio"] for f in one if f["throttle_ratio"] is not None])
    if len(thr):
        print(f"Throttle ratio (one-flight pairs): |log| quantiles 50/90/100 %: "
              + "/".join(f"{q:.3f}" for q in np.quantile(np.abs(np.log(thr)), [0.5, 0.9, 1.0])))


def reliability(recs: list[dict]) -> None:
    rs = [r for r in recs if r.get("status") in ("healthy", "uncertain", "damaged") and r.get("confidence") is not None]
    print("\n## Reliability: stated confidence against the fraction right (every verdict above)\n")
    print("| confidence | verdicts | right | fraction right | of which damaged (right) | uncertain (right) | healthy (right) |")
    print("|---|---|---|---|---|---|---|")
    edges = RELIABILITY_BINS
    for lo, hi in zip(edges[:-1], edges[1:]):
        b = [r for r in rs if lo <= r["confidence"] < hi]
        if not b:
            continue
        ok = sum(right(r) for r in b)

        def part(st):
            x = [r for r in b if r["status"] == st]
            return f"{len(x)} ({sum(right(r) for r in x)})"
        print(f"| {lo:.2f}-{min(hi, 1.0):.2f} | {len(b)} | {ok} | {ok / len(b):.2f} | {part('damaged')} | "
              f"{part('uncertain')} | {part('healthy')} |")
    hi = [r for r in rs if r["confidence"] >= 0.9]
    if hi:
        ok = sum(right(r) for r in hi)
        print(f"\nStated at 0.9 or more: {ok}/{len(hi)} right ({100 * ok / len(hi):.1f} %); "
              f"damaged verdicts at 0.9 or more: "
              f"{sum(right(r) for r in hi if r['status'] == 'damaged')}/{sum(r['status'] == 'damaged' for r in hi)} right")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profiles", default=str(ROOT / "build" / "cross_session_profiles"),
                    help="folder of the profiles (made once, reused)")
    ap.add_argument("--no-adapted", action="store_true", help="skip the adapted (default `fdlog calibrate`) profiles")
    ap.add_argument("--quick", action="store_true", help="leave-one-out profiles only on the healthy flights")
    ap.add_argument("--via-add", action="store_true",
                    help="make the --no-adapt leave-one-out profiles with `fdlog calibrate --add` too")
    ap.add_argument("--adapted-only", action="store_true", help="only the adapted (default `fdlog calibrate`) profiles")
    ap.add_argument("--only", help="only these airframes (comma-separated names, e.g. rrc_straight,erle_A)")
    ap.add_argument("--calibrate-only", action="store_true", help="only make the profiles (for a later run)")
    ap.add_argument("--jobs", type=int, default=1, help="fdlog diagnose --jobs")
    ap.add_argument("--out", help="write the records (JSON) here")
    ap.add_argument("--report", help="print the report from saved records instead of running")
    args = ap.parse_args()
    if args.report:
        recs = json.loads(Path(args.report).read_text())
    else:
        if not SHARED.is_dir():
            raise SystemExit(f"{SHARED}: not found (the benchmark needs ../shared)")
        recs = run(args)
        if args.out:
            Path(args.out).write_text(json.dumps(recs, indent=0, default=float))
    report(recs)


if __name__ == "__main__":
    main()
