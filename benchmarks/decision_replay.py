"""Replay the decision on captured inputs: every flight of sample_logs/ and ../shared with its truth,
without and with the golden file's profiles, decided in seconds by the code as it stands.

    python benchmarks/decision_replay.py capture DIR [--profiles DIR]   # diagnose once, keep DecisionInputs
    python benchmarks/decision_replay.py score DIR [-v] [--out RECORDS.json]

``capture`` diagnoses each case of :func:`golden_verdicts.cases` (no profile on every log; the
``--no-adapt`` and adapted profiles of the golden file, made once into ``--profiles``) in process,
recording every :class:`~flightlog_fd.decision.DecisionInputs` the pipeline passes to
``decide_flight`` (pickled per profile). ``score`` decides every captured flight again with the
installed decision (the whole log first; a flight of several is then capped by the new whole-log
verdict) and prints the targets of issue 37 (``TARGETS``) and, per set and profile kind, the verdicts,
the share uncertain and "stated >= 0.9 right". The analyzers are not re-run: a change to an analyzer
needs a new capture. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import csv
import json
import pickle
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_confidence as bc  # noqa: E402
import golden_verdicts as gv  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"


# ----------------------------------------------------------------------------- truth

#: The truth of CrazyPAD's heavy weight taped near PX4 motor 2: right when healthy, or when rotor 2
#: is named with a cause other than the propeller.
WASH = "wash:2"

def truth_table() -> dict[str, object]:
    """{resolved path: truth}: None healthy, a tuple of damaged motors (() = damaged, rotor not stated),
    "load" for sound propellers carrying a load, "stopped" for a motor stopped mid-flight."""
    out: dict[str, object] = {}
    for rows in bc.real_sets().values():
        for p, t in rows:
            out[str(p.resolve())] = t
    for name in ("crazypad_e9_load", "px4_sih_dev_load"):
        for p in sorted((SHARED / name).rglob("*.ulg")):
            # the heavy taped weight sits in PX4 motor 2's wash and takes its thrust (README): "rotor 2
            # lost thrust" is true of it, a propeller cause is not
            out[str(p.resolve())] = WASH if p.name.startswith("add_weight_W3") else "load"
    for p, t in bc.sim_sets(ROOT / "build" / "no_sim").get("sample_logs", []):
        out[str(p.resolve())] = t
    for p in sorted((SHARED / "ardupilot_sitl_quad").glob("*.BIN")):
        out[str(p.resolve())] = None if "healthy" in p.name else (1,)
    for p in sorted((SHARED / "ardupilot_sitl_hexa").glob("*.bin")):
        out[str(p.resolve())] = "stopped"
    for name, rows in bc.sim_sets(SIM_FOLDER).items():
        if name.startswith("sim "):
            for p, t in rows:
                out[str(p.resolve())] = t
    for r in twin_rows():  # sound propellers with or without a load are "load"; damage names its rotor
        out[str((TWINS_FOLDER / r["file"]).resolve())] = (
            (int(r["damaged_motor"]),) if int(r["damaged_motor"] or 0) else ("load" if r["load_kind"] else None))
    return out


def set_of(path: str) -> str:
    p = Path(path)
    if TWINS_FOLDER.resolve() in p.parents:
        row = next((r for r in twin_rows() if r["file"] == p.name), None)
        return f"twins {row['role'] if row else '?'}"
    if SIM_FOLDER.resolve() in p.parents:
        return next((name for name, *_ in sorted(bc.SIM_SETS, key=lambda x: -len(x[0]))
                     if p.name.startswith(name.replace(" ", "_") + "_")), "sim")
    try:
        rel = p.relative_to(SHARED.resolve())
        return rel.parts[0] if rel.parts[0] not in ("real_damaged", "real_vibration") else rel.parts[1]
    except ValueError:
        return "sample_logs"


# ----------------------------------------------------------------------------- capture

def cases() -> list[tuple[str, list[Path], bool, list[Path]]]:
    """The golden file's cases, and the load sets against their airframes' profiles (CrazyPAD's
    normal log00, px4_sih_dev's sih_004), named ``<profile>+load``: (name, calibration logs, adapt?,
    logs)."""
    out = gv.cases(adapted=True)
    extra = []
    for name, cal, adapt, _ in out:
        if name.split("_")[0] in ("cp00", "sih004") and name.endswith(("_noadapt", "_adapted")):
            load = SHARED / ("crazypad_e9_load" if name.startswith("cp00") else "px4_sih_dev_load")
            logs = sorted(load.rglob("*.ulg"))
            if logs:
                extra.append((name, cal, adapt, logs))
    return out + [(n, c, a, ls) for n, c, a, ls in extra]


#: Load twins with ESC telemetry (benchmarks/load_twins.py --frames quad_x --per-cell 2 --esc, written
#: there once): per airframe and logging profile a healthy twin, a healthy flight, a damaged rotor, a
#: fixed load, a line or a moved battery, and damage under a load; weighed without a profile and
#: against the twin's --no-adapt profile.
TWINS_FOLDER = ROOT / "build" / "load_twins_esc"


def twin_rows() -> list[dict]:
    if not (TWINS_FOLDER / "manifest.csv").exists():
        return []
    with open(TWINS_FOLDER / "manifest.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def twin_cases() -> list[tuple[str, list[Path], bool, list[Path]]]:
    """The load twins without a profile, and each airframe's flights against its twin's profile."""
    rows = twin_rows()
    if not rows:
        return []
    out = [("", [], False, [TWINS_FOLDER / r["file"] for r in rows])]
    by_twin: dict[str, list[Path]] = {}
    for r in rows:
        if r["role"] != "twin":
            by_twin.setdefault(r["twin_file"], []).append(TWINS_FOLDER / r["file"])
    for twin, logs in sorted(by_twin.items()):
        out.append((f"twin_{Path(twin).stem}_noadapt", [TWINS_FOLDER / twin], False, logs))
    return out


#: The simulated batch of benchmarks/bench_confidence.py (random quads at three logging profiles,
#: random hexas, a preset x500 with a profile of its first healthy flight), written once here.
SIM_FOLDER = ROOT / "build" / "confidence_sim2"


def sim_cases() -> list[tuple[str, list[Path], bool, list[Path]]]:
    """The simulated batch without a profile, and the x500 set against its healthy flight's profile."""
    bc.make_sim(SIM_FOLDER)
    sets = bc.sim_sets(SIM_FOLDER)
    out = []
    logs = [p for name, rows in sets.items() if name.startswith("sim ") for p, _ in rows]
    out.append(("", [], False, logs))
    for name, rows in sets.items():
        if not name.startswith("sim "):
            continue
        for pname, cal, prows in bc.profile_groups(name, rows):
            out.append((f"{pname}_noadapt", [cal], False, [p for p, _ in prows]))
    return out

def capture(folder: Path, profiles: Path) -> None:
    from flightlog_fd import diagnose as dg
    from flightlog_fd.profile import Profile

    folder.mkdir(parents=True, exist_ok=True)
    profiles.mkdir(parents=True, exist_ok=True)
    real_decide = dg.decide_flight
    calls: list = []

    def hooked(inputs):
        calls.append(inputs)
        return real_decide(inputs)

    dg.decide_flight = hooked
    t0 = time.perf_counter()
    todo = cases() + sim_cases() + twin_cases()
    for i, (name, cal, adapt, logs) in enumerate(todo, 1):
        tag = "+load" if logs and "_load" in logs[0].parent.as_posix().split("shared/")[-1] else ""
        tag = "+sim" if logs and SIM_FOLDER.resolve() in logs[0].resolve().parents else tag
        tag = "+twins" if logs and TWINS_FOLDER.resolve() in logs[0].resolve().parents else tag
        out = folder / f"{name or 'no_profile'}{tag}.pkl"
        if out.exists():
            continue
        prof = None
        if name:
            path, refusal = gv._profile(name, cal, profiles, adapt)
            if path is None:
                print(f"[{i}/{len(todo)}] {name}: calibration refused: {refusal}", flush=True)
                continue
            prof = Profile.load(path)
        by_log = {}
        cal_set = {str(c.resolve()) for c in cal}
        for log in logs:
            calls.clear()
            model = dg.resolve_model(None, prof)
            d = dg.diagnose_path(log, model, prof, keep_flight=False)
            by_log[str(log.resolve())] = {"calls": list(calls), "status": d.verdict.status,
                                          "calibration_flight": str(log.resolve()) in cal_set}
        out.write_bytes(pickle.dumps({"profile": name, "adapted": adapt, "logs": by_log}))
        print(f"[{i}/{len(todo)}] {name or 'no profile'}: {len(by_log)} logs ({time.perf_counter() - t0:.0f} s)",
              flush=True)


# ----------------------------------------------------------------------------- score

def replay(calls: list, prior: float | None = None):
    """The log's final verdict decided again from its captured inputs (the whole log first), under
    ``prior`` (the decision's default when None)."""
    from dataclasses import replace

    from flightlog_fd.decision import decide_flight, decide_log

    if not calls:
        return None
    whole = None
    parts = []
    for inputs in calls:
        if prior is not None:
            inputs = replace(inputs, prior=prior)
        if inputs.log is not None and whole is not None:
            inputs = replace(inputs, log=whole)
        v, d = decide_flight(inputs)
        if inputs.log is None and whole is None:
            whole = (v, d)
        elif inputs.log is not None:
            parts.append(v)
    verdict = whole[0] if whole is not None else v
    if parts:
        verdict = decide_log([(f"flight {i + 1}", p) for i, p in enumerate(parts)], whole=verdict)
    return verdict


def right(status: str, named: list, truth, cause=None) -> bool:
    if truth == WASH:
        return status == "healthy" or (status in ("damaged", "uncertain") and named == [2] and cause != "propeller")
    if truth is None or truth == "load":
        return status == "healthy"
    if truth == "stopped":
        return status == "stopped"
    if status not in ("damaged", "uncertain", "stopped"):
        return False
    return not truth or not named or bool(set(named) & set(truth))


def records(folder: Path, prior: float | None = None) -> list[dict]:
    truth = truth_table()
    out = []
    for f in sorted(folder.glob("*.pkl")):
        doc = pickle.loads(f.read_bytes())
        for log, case in doc["logs"].items():
            if case["calibration_flight"]:
                continue
            v = replay(case["calls"], prior)
            if v is None:
                continue
            named = list(v.motors) or list(v.inspect)
            t = truth.get(log, "?")
            out.append({"profile": doc["profile"] or "none", "adapted": doc["adapted"], "log": log,
                        "set": set_of(log), "name": Path(log).name, "truth": t, "status": v.status,
                        "motor": v.motor, "named": named, "confidence": float(v.confidence), "cause": v.cause,
                        "headline": getattr(v, "headline", ""), "reason": v.reason,
                        "right": None if t == "?" else right(v.status, named, t, v.cause)})
    return out


def _pick(recs, profile=None, set_=None, prefix=None, adapted=None):
    out = []
    for r in recs:
        if profile is not None and not (r["profile"] == profile if isinstance(profile, str) else r["profile"] in profile):
            continue
        if set_ is not None and r["set"] != set_:
            continue
        if prefix is not None and not any(r["name"].startswith(p) for p in ([prefix] if isinstance(prefix, str) else prefix)):
            continue
        if adapted is not None and r["adapted"] != adapted:
            continue
        out.append(r)
    return out


def _counts(rs) -> str:
    c = Counter(r["status"] for r in rs)
    return "/".join(str(c[s]) for s in ("healthy", "uncertain", "damaged", "stopped", "not_diagnosable"))


def _damaged_right(rs) -> int:
    return sum(r["status"] == "damaged" and r["truth"] not in (None, "load", "stopped", "?", WASH)
               and (not r["truth"] or set(r["named"]) & set(r["truth"])) for r in rs)


def targets(recs: list[dict]) -> list[tuple[str, str, str]]:
    """(target, measured, goal) for each line of issue 37's "done when" (and 38's that the decision sees)."""
    out = []
    sih_truth = {}
    man = SHARED / "px4_sih_dev" / "manifest.csv"
    if man.exists():
        sih_truth = {f"{r['name']}.ulg": int(r["faulty_motor"]) for r in csv.DictReader(man.open())}
    # make demo
    s = _pick(recs, "none", "sample_logs")
    dmg = [r for r in s if r["truth"] not in (None,)]
    octo = _pick(recs, "sample_px4_octo_healthy_noadapt", "sample_logs", "px4_octo_motor2")
    ok = sum(r["status"] == "damaged" and r["motor"] == (r["truth"] or (None,))[0] for r in dmg + octo)
    hok = sum(r["status"] == "healthy" for r in s if r["truth"] is None)
    out.append(("make demo: damaged samples damaged naming their rotor (octo with profile incl.)",
                f"{ok}/{len(dmg) + len(octo)}; healthy {hok}/{sum(r['truth'] is None for r in s)}", "all"))
    for prof, label in (("sih004_noadapt", "no-adapt"), ("sih004_adapted", "adapted")):
        rs = _pick(recs, prof, "px4_sih_dev")
        f = [r for r in rs if sih_truth.get(r["name"])]
        h = [r for r in rs if r["name"] in sih_truth and not sih_truth[r["name"]]]
        okf = sum(r["status"] == "damaged" and r["motor"] == sih_truth[r["name"]] for r in f)
        out.append((f"px4_sih_dev, {label} profile sih_004: weak motors damaged naming it; healthy healthy",
                    f"{okf}/{len(f)}; {sum(r['status'] == 'healthy' for r in h)}/{len(h)} ({_counts(rs)})", "15/15; 3/3"))
    rs = _pick(recs, "none", "px4_sih_dev")
    f = [r for r in rs if sih_truth.get(r["name"])]
    out.append(("px4_sih_dev, no profile: right motor damaged", f"{sum(r['status'] == 'damaged' and r['motor'] == sih_truth[r['name']] for r in f)}/{len(f)} ({_counts(rs)})", ">= 12"))
    for adapted in (False, True):
        profs = ("rrc_g1_noadapt", "rrc_g2_noadapt", "rrc_g3_noadapt") if not adapted else ("rrc_g1_adapted",)
        rs = _pick(recs, profs, "rrc_straight")
        c25 = _pick(rs, prefix="25_mm")
        c20 = _pick(rs, prefix="20_mm")
        good = _pick(rs, prefix="good")
        out.append((f"rrc_straight, profile from each good flight ({'adapted g1' if adapted else 'no-adapt'}): 25 mm damaged; 20 mm flagged; good healthy",
                    f"{sum(r['status'] == 'damaged' for r in c25)}/{len(c25)}; "
                    f"{sum(r['status'] in ('damaged', 'uncertain') for r in c20)}/{len(c20)}; "
                    f"{sum(r['status'] == 'healthy' for r in good)}/{len(good)}", "9/9; 9/9; 6/6"))
    for prof in ("cp00_noadapt", "cp00_adapted", "none"):
        rs = _pick(recs, prof, "crazypad_e9")
        singles = [r for r in rs if isinstance(r["truth"], tuple) and len(r["truth"]) == 1]
        okc = sum(r["status"] == "damaged" and r["motor"] == r["truth"][0] for r in singles)
        h = [r for r in rs if r["truth"] is None]
        out.append((f"crazypad_e9 single propellers, profile {prof}: damaged naming the motor; normals healthy",
                    f"{okc}/{len(singles)}; {sum(r['status'] == 'healthy' for r in h)}/{len(h)} ({_counts(rs)})", ">= 8/39; 2/2"))
    u = _pick(recs, "none", "quad_udesa")
    out.append(("quad_udesa: damaged, cause propeller, rotor 1",
                "; ".join(f"{r['status']} {r['motor']} {r['cause']}" for r in u), "damaged 1 propeller"))
    for prof in ("none", "cp00_noadapt", "cp00_adapted"):
        rs = _pick(recs, prof, "crazypad_e9_load")
        light = [r for r in rs if not r["name"].startswith("add_weight_W3")]
        out.append((f"crazypad_e9_load ({prof}): cause propeller never; W1/W2/string healthy",
                    f"{sum(r['cause'] == 'propeller' for r in rs)}; {sum(r['status'] == 'healthy' for r in light)}/{len(light)} ({_counts(rs)})",
                    "0; 9/9"))
    for prof in ("none", "sih004_noadapt", "sih004_adapted"):
        rs = _pick(recs, prof, "px4_sih_dev_load")
        out.append((f"px4_sih_dev_load ({prof}): healthy naming the load",
                    f"{sum(r['status'] == 'healthy' and r['cause'] == 'load' for r in rs)}/{len(rs)} ({_counts(rs)})", "4/4"))
    rh = _pick(recs, "none", "real_healthy") + [r for r in _pick(recs, "none", "real_logs") if r["truth"] is None]
    out.append(("real_healthy, no profile: healthy; damaged", f"{sum(r['status'] == 'healthy' for r in rh)}/{len(rh)}; "
                f"{sum(r['status'] == 'damaged' for r in rh)}", ">= 17/18; 0"))
    known = [r for r in recs if r["truth"] != "?" and r["status"] != "not_diagnosable"]
    unc = sum(r["status"] == "uncertain" for r in known)
    out.append(("every shared log with truth: uncertain", f"{unc}/{len(known)} ({100 * unc / max(len(known), 1):.0f} %)", "<= 10 %"))
    return out


def reweighted(rs: list[dict], prior: float) -> float | None:
    """The share right among ``rs`` with each flight weighed so the set's damaged flights hold
    ``prior`` of the weight and its healthy ones (sound propellers, loads) the rest: what the
    stated confidence means on a fleet with that base rate. None when ``rs`` is empty."""
    dmg = [r for r in rs if r["truth"] not in (None, "load", WASH)]
    ok = [r for r in rs if r["truth"] in (None, "load", WASH)]
    if not rs:
        return None
    w_d = prior / len(dmg) if dmg and ok else (1.0 / len(dmg) if dmg else 0.0)
    w_h = (1 - prior) / len(ok) if dmg and ok else (1.0 / len(ok) if ok else 0.0)
    tot = sum(w_d if r in dmg else w_h for r in rs)
    return sum((w_d if r in dmg else w_h) * bool(r["right"]) for r in rs) / tot


def per_set(recs: list[dict], prior: float) -> None:
    keyed = defaultdict(list)
    for r in recs:
        kind = "none" if r["profile"] == "none" else ("adapted" if r["adapted"] else "no-adapt")
        keyed[(r["set"], kind)].append(r)
    print(f"\nstated >= 0.9: right / stated, and the share right with the set reweighted to a prior of {prior:.2f}")
    print("\n| set | profile | h/u/d/s/nd | right | uncertain | stated >= 0.9 right | reweighted |")
    print("|---|---|---|---|---|---|---|")
    for (s, kind), rs in sorted(keyed.items()):
        known = [r for r in rs if r["right"] is not None and r["truth"] != "stopped"]
        hi = [r for r in known if r["confidence"] >= 0.9 and r["status"] != "not_diagnosable"]
        ok = sum(r["right"] for r in hi)
        rw = reweighted(hi, prior)
        print(f"| {s} | {kind} | {_counts(rs)} | {sum(r['right'] for r in known)}/{len(known)} | "
              f"{sum(r['status'] == 'uncertain' for r in rs)} | {ok}/{len(hi)} | "
              f"{'-' if rw is None else f'{100 * rw:.0f} %'}{' !' if rw is not None and rw < 0.9 else ''} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("capture")
    c.add_argument("folder", type=Path)
    c.add_argument("--profiles", type=Path, default=ROOT / "build" / "golden_profiles")
    s = sub.add_parser("score")
    s.add_argument("folder", type=Path)
    s.add_argument("-v", action="store_true", help="one line per flight")
    s.add_argument("--out", type=Path, help="write the records (JSON)")
    s.add_argument("--prior", type=float, help="decide under this prior of damage (default: the decision's)")
    args = ap.parse_args()
    if args.cmd == "capture":
        capture(args.folder, args.profiles)
        return
    recs = records(args.folder, args.prior)
    if args.out:
        args.out.write_text(json.dumps(recs, indent=0, default=str))
    print("| target | measured | goal |\n|---|---|---|")
    for t, m, g in targets(recs):
        print(f"| {t} | {m} | {g} |")
    import flightlog_fd.decision as decision

    # a decision older than the stated prior is reweighted to today's, so the two compare
    per_set(recs, args.prior if args.prior is not None else getattr(decision, "PRIOR_DAMAGE", 0.10))
    if args.v:
        for r in recs:
            print(f"{r['profile']:>32} {r['set']:>18} {r['name'][:40]:40} truth={str(r['truth']):8} "
                  f"{r['status']:>9} {str(r['named']):8} {r['confidence']:.2f} {r['cause']}")


if __name__ == "__main__":
    main()
