"""Golden file of verdicts and figures, for holding behaviour while code moves.

    python benchmarks/golden_verdicts.py write OUT.json [--profiles DIR] [--no-adapted]
    python benchmarks/golden_verdicts.py compare BEFORE.json AFTER.json
    python benchmarks/golden_verdicts.py moves BEFORE.json AFTER.json   # every status move, by truth

``write`` runs the installed ``fdlog`` (the CLI is the contract a move must keep) on every log in
``sample_logs/`` and in ``../shared`` without a profile, and on each calibration set with the
profiles the benchmarks build: ``--no-adapt`` profiles from one and from two healthy flights, and
(unless ``--no-adapted``) the adapted profiles ``bench_real_damage.py`` uses. Profiles are made once
into ``--profiles`` (default ``build/golden_profiles``) and reused, so a before/after pair compares
diagnoses under the very same profile files. Each case keeps the verdict (status, motor,
confidence, reason), the exit code, per motor the LLR (total and by source), eta-hat and its
interval, weight, command share and effectiveness, every analyzer finding's value and LLR, and the
windows' smoothed labels; numbers rounded to 6 decimals.

``compare`` prints every difference, case by case, and exits 1 when there is any. ``moves`` names
every status move against the flight's truth (benchmarks/decision_replay.py's table): per move,
set and profile, how many, on which truth (healthy, a load, damaged) and whether the rotor the new
verdict names is a damaged one; then each case.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
FDLOG = str(Path(sys.executable).with_name("fdlog"))
LOG_SUFFIXES = {".ulg", ".bin"}


def _logs(folder: Path) -> list[Path]:
    if not folder.exists():
        return []
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in LOG_SUFFIXES)


def _rel(p: Path) -> str:
    for base, name in ((SHARED, "shared"), (ROOT, "")):
        try:
            r = p.resolve().relative_to(base.resolve())
            return f"{name}/{r}" if name else str(r)
        except ValueError:
            pass
    return str(p)


def _round(x):
    if isinstance(x, float):
        return round(x, 6)
    if isinstance(x, list):
        return [_round(v) for v in x]
    if isinstance(x, dict):
        return {k: _round(v) for k, v in x.items()}
    return x


def _keep(doc: dict) -> dict:
    """The figures a move must keep, from one ``fdlog diagnose --json`` object."""
    v = doc.get("verdict") or {}
    out = {"status": v.get("status"), "motor": v.get("motor"), "confidence": v.get("confidence"),
           "reason": v.get("reason"), "exit_code": doc.get("exit_code"),
           "n_windows": (doc.get("evidence") or {}).get("n_windows"),
           "labels": "".join("u" if w.get("smoothed_class", 0) < 0 else str(w.get("smoothed_class"))
                             for w in doc.get("windows") or []),
           "warnings": doc.get("warnings")}
    out["motors"] = [{k: m.get(k) for k in ("motor", "llr", "llr_by_source", "eta_hat", "eta_ci", "weight",
                                             "command_share", "command_change", "effectiveness", "model_vote")}
                     for m in doc.get("motors") or []]
    out["findings"] = {a.get("analyzer"): {"abstained": a.get("abstained"),
                                           "findings": [[f.get("motor"), f.get("name"), f.get("value"), f.get("llr")]
                                                        for f in a.get("findings") or []]}
                       for a in doc.get("analyzers") or []}
    out["stopped"] = [[s.get("motor"), s.get("t_start")] for s in doc.get("stopped_motors") or []]
    return _round(out)


def _diagnose(logs: list[Path], profile: Path | None) -> dict[str, dict]:
    cmd = [FDLOG, "diagnose", "--json", *(["--profile", str(profile)] if profile else []), *map(str, logs)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if not r.stdout.strip():
        raise SystemExit(f"fdlog diagnose printed nothing (exit {r.returncode}): {r.stderr[-2000:]}")
    docs = json.loads(r.stdout)
    docs = docs if isinstance(docs, list) else [docs]
    return {_rel(Path(d["log"])): _keep(d) for d in docs}


def _profile(name: str, logs: list[Path], folder: Path, adapt: bool) -> tuple[Path | None, str]:
    """The profile file (made once), or None and the CLI's one-line refusal."""
    out = folder / f"{name}.json"
    if not out.exists():
        t0 = time.perf_counter()
        cmd = [FDLOG, "calibrate", *([] if adapt else ["--no-adapt"]), *map(str, logs), "-o", str(out)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            return None, (r.stderr.strip() or r.stdout.strip()).splitlines()[-1][:300]
        print(f"  calibrated {name} in {time.perf_counter() - t0:.0f} s", flush=True)
    return out, ""


def _healthy_groups() -> dict[str, list[Path]]:
    """Board groups of ../shared/real_healthy (manifest column board_group), two flights or more."""
    import csv

    man = SHARED / "real_healthy" / "manifest.csv"
    groups: dict[str, list[Path]] = {}
    if man.exists():
        for row in csv.DictReader(man.open()):
            if row.get("board_group"):
                groups.setdefault(row["board_group"], []).append(SHARED / "real_healthy" / "logs" / row["file"])
    return {g: sorted(v) for g, v in groups.items() if len(v) >= 2}


def cases(adapted: bool) -> list[tuple[str, list[Path], bool, list[Path]]]:
    """(profile name, calibration logs, adapt?, logs to diagnose); name '' = no profile."""
    samples = _logs(ROOT / "sample_logs")
    shared = _logs(SHARED)
    out: list[tuple[str, list[Path], bool, list[Path]]] = [("", [], False, samples + shared)]
    rrc = _logs(SHARED / "real_damaged" / "rrc_straight")
    goods = [p for p in rrc if p.name.startswith("good")]
    cp = _logs(SHARED / "crazypad_e9" / "ulog")
    cp_normal = [p for p in cp if p.name.startswith("normal")]
    sih = _logs(SHARED / "px4_sih_dev" / "logs")
    sih004 = [p for p in sih if p.name == "sih_004.ulg"]
    sets: list[tuple[str, list[Path], list[Path]]] = []
    for i, g in enumerate(goods, 1):
        sets.append((f"rrc_g{i}", [g], rrc))
    if len(goods) >= 2:
        sets.append(("rrc_g12", goods[:2], rrc))
    if cp_normal:
        sets.append(("cp00", cp_normal[:1], cp))
    if len(cp_normal) >= 3:
        sets.append(("cp012", cp_normal[:3], cp))
    if sih004:
        sets.append(("sih004", sih004, sih))
    for g, flights in _healthy_groups().items():
        for i, f in enumerate(flights):
            sets.append((f"board_{g}_{i}", [f], flights))
    for name in ("px4_healthy.ulg", "ardupilot_healthy.bin", "px4_octo_healthy.ulg"):
        s = [p for p in samples if p.name == name]
        if s:
            sets.append((f"sample_{s[0].stem}", s, samples))
    for name, cal, logs in sets:
        out.append((f"{name}_noadapt", cal, False, logs))
    if adapted:
        for name, cal, logs in sets:
            if name in ("rrc_g1", "rrc_g12", "cp00", "cp012", "sih004"):
                out.append((f"{name}_adapted", cal, True, logs))
    return out


def write(out: Path, profiles: Path, adapted: bool) -> None:
    profiles.mkdir(parents=True, exist_ok=True)
    golden: dict[str, dict] = {}
    t0 = time.perf_counter()
    todo = cases(adapted)
    for i, (name, cal, adapt, logs) in enumerate(todo, 1):
        prof, refusal = _profile(name, cal, profiles, adapt) if name else (None, "")
        if name and prof is None:
            golden[f"{name} | calibration"] = {"status": "calibration refused", "reason": refusal}
            print(f"[{i}/{len(todo)}] {name}: calibration refused: {refusal}", flush=True)
            continue
        res = _diagnose(logs, prof)
        for log, figs in res.items():
            golden[f"{name or 'no_profile'} | {log}"] = figs
        print(f"[{i}/{len(todo)}] {name or 'no profile'}: {len(res)} logs ({time.perf_counter() - t0:.0f} s)", flush=True)
    out.write_text(json.dumps(golden, indent=1, sort_keys=True))
    print(f"wrote {out}: {len(golden)} cases")


def _diff(a, b, path: str, out: list[str]) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            _diff(a.get(k), b.get(k), f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{path}[{i}]", out)
    elif a != b:
        out.append(f"{path}: {a!r} -> {b!r}")


def compare(before: Path, after: Path) -> int:
    a, b = json.loads(before.read_text()), json.loads(after.read_text())
    n_diff = 0
    status_moves: dict[str, int] = {}
    for key in sorted(set(a) | set(b)):
        out: list[str] = []
        _diff(a.get(key), b.get(key), "", out)
        if out:
            n_diff += 1
            print(f"== {key}")
            for line in out[:12]:
                print(f"   {line}")
            if len(out) > 12:
                print(f"   ... {len(out) - 12} more")
            sa, sb = (a.get(key) or {}).get("status"), (b.get(key) or {}).get("status")
            if sa != sb:
                status_moves[f"{sa} -> {sb}"] = status_moves.get(f"{sa} -> {sb}", 0) + 1
    print(f"\n{n_diff} of {len(set(a) | set(b))} cases differ; verdict moves: {status_moves or 'none'}")
    return 1 if n_diff else 0


def moves(before: Path, after: Path) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import decision_replay as dr

    truth = dr.truth_table()
    a, b = json.loads(before.read_text()), json.loads(after.read_text())
    groups: dict[tuple, list] = {}
    for key in sorted(set(a) & set(b)):
        sa, sb = a[key].get("status"), b[key].get("status")
        if sa == sb:
            continue
        prof, log = [x.strip() for x in key.split("|", 1)]
        path = str((SHARED / log[len("shared/"):]).resolve()) if log.startswith("shared/") else str((ROOT / log).resolve())
        t = truth.get(path, "?")
        kind = ("healthy" if t is None else "load" if t == "load" else "taped weight (wash)" if t == dr.WASH
                else "stopped" if t == "stopped" else "unknown" if t == "?" else "damaged")
        motor = b[key].get("motor")
        rotor = "" if kind != "damaged" or motor is None else (" right rotor" if (not t or motor in t) else " wrong rotor")
        where = "no profile" if prof == "no_profile" else "profile"
        groups.setdefault((f"{sa} -> {sb}", kind + rotor, where), []).append((prof, log, motor))
    print("| move | truth | profile | cases | sets |\n|---|---|---|---|---|")
    for (move, kind, where), rows in sorted(groups.items()):
        sets: dict[str, int] = {}
        for _, log, _ in rows:
            name = log.split("/")[1] if log.startswith("shared/") else "sample_logs"
            sets[name] = sets.get(name, 0) + 1
        print(f"| {move} | {kind} | {where} | {len(rows)} | " + ", ".join(f"{k} {v}" for k, v in sorted(sets.items())) + " |")
    print()
    for (move, kind, where), rows in sorted(groups.items()):
        for prof, log, motor in rows:
            print(f"{move:24s} {kind:22s} {prof:32s} {log} {'' if motor is None else motor}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("out", type=Path)
    w.add_argument("--profiles", type=Path, default=ROOT / "build" / "golden_profiles")
    w.add_argument("--no-adapted", action="store_true", help="skip the adapted (torch) profiles")
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    m = sub.add_parser("moves")
    m.add_argument("before", type=Path)
    m.add_argument("after", type=Path)
    args = ap.parse_args()
    if args.cmd == "write":
        write(args.out, args.profiles, not args.no_adapted)
    elif args.cmd == "moves":
        moves(args.before, args.after)
    else:
        sys.exit(compare(args.before, args.after))


if __name__ == "__main__":
    main()
