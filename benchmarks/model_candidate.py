"""Two quad models compared through the decision, as a pilot meets them (issue 37 item 6).

    python benchmarks/model_candidate.py run OUT.json --profiles DIR [--adapted]
    python benchmarks/model_candidate.py compare SHIPPED.json CANDIDATE.json [...]

``run`` drives the installed ``fdlog`` (``diagnose --json``, ``calibrate``) with the code as it is
checked out: its decision, its model-vote tables and its shipped model (``models/default.onnx``;
``fdlog calibrate`` has no ``--model``, so a model is compared by checking it out in place). Run it
once on each checkout to compare (e.g. main, and main with the candidate model and its re-measured
tables), each with its own ``--profiles`` folder (a profile's model-vote baseline is keyed to the
model it was made with). Cases, truth from the
manifests (``bench_confidence.real_sets`` / ``sim_sets``):

- ``real healthy`` (../shared/real_healthy + the Erle copters of real_logs/ardupilot), no profile,
  and each flight of each Erle board group against a ``--no-adapt`` profile of each other flight;
- ``px4_sih_dev``, ``px4_sih_dev_load``: no profile and a ``--no-adapt`` profile of sih_004;
- ``rrc_straight``: no profile and a ``--no-adapt`` profile of each good flight;
- ``crazypad_e9``, ``crazypad_e9_load``: no profile and a ``--no-adapt`` profile of normal log00;
- ``real_vibration``, ``ardupilot_sitl``, ``sample_logs`` and the simulated batch of
  ``bench_confidence`` (``--sim``; written once by ``fdlog simulate``, the same for every model):
  no profile; sample_logs' PX4 quads and the x500 batch also against their healthy flight;
- ``--adapted``: the default (adapted) ``fdlog calibrate`` of sih_004, rrc good 1 and CrazyPAD
  normal log00 too (torch; a few minutes each, made once into ``--profiles``).

``compare`` prints, per set, profile kind and group (rrc_straight by cut, px4_sih_dev by eta), the
verdicts healthy / uncertain / damaged of each run side by side, and for damaged truth how many
verdicts name a damaged motor (``damaged`` naming it + ``uncertain`` naming it); then the cases
whose verdict moved. Figures only.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_confidence as bc  # noqa: E402  (truth per set, the simulated batch, one record per verdict)
import golden_verdicts as gv  # noqa: E402  (profiles made once, the board groups)

ROOT = bc.ROOT
SHARED = bc.SHARED


def _calibrate(name: str, logs: list[Path], folder: Path, adapt: bool) -> Path | None:
    """The profile (made once into ``folder`` by golden_verdicts._profile), or None when the CLI refuses it."""
    out, why = gv._profile(f"{name}_{'adapted' if adapt else 'noadapt'}", logs, folder, adapt)
    if out is None:
        print(f"  calibration {name} refused: {why}", file=sys.stderr)
    return out


def _profiles(set_name: str, rows: list) -> list[tuple[str, list[Path], list]]:
    """(profile name, calibration logs, rows it diagnoses) of one set."""
    rrc = SHARED / "real_damaged" / "rrc_straight"
    cp = sorted(bc._glob(SHARED / "crazypad_e9" / "ulog", "normal*.ulg"))
    sih004 = SHARED / "px4_sih_dev" / "logs" / "sih_004.ulg"
    if set_name == "real healthy":
        return [(f"board_{g}_{i}", [f], [(p, bc.HEALTHY) for p in files])
                for g, files in gv._healthy_groups().items() for i, f in enumerate(files)]
    if set_name == "rrc_straight":
        return [(f"rrc_g{i}", [g], rows) for i, g in enumerate(sorted(rrc.glob("good_prop_*.BIN")), 1)]
    if set_name in ("crazypad_e9", "crazypad_e9_load") and cp:
        return [("cp00", cp[:1], rows)]
    if set_name in ("px4_sih_dev", "px4_sih_dev_load") and sih004.exists():
        return [("sih004", [sih004], rows)]
    if set_name == "sample_logs":
        px4_quad = [(p, t) for p, t in rows if p.suffix == ".ulg" and "octo" not in p.name]
        return [("sample_px4", [ROOT / "sample_logs" / "px4_healthy.ulg"], px4_quad)]
    if set_name == "sim x500 px4_default":
        healthy = [p for p, t in rows if t is bc.HEALTHY]
        return [("sim_x500", healthy[:1], rows)] if healthy else []
    return []


#: The profiles also made adapted with ``--adapted`` (the default ``fdlog calibrate``).
ADAPTED = ("sih004", "rrc_g1", "cp00")


def group_of(set_name: str, log: str) -> str:
    """A finer group than healthy / damaged where the set has one: rrc_straight's cut, the SIH eta."""
    if set_name == "rrc_straight":
        return "good" if log.startswith("good") else log.split("_cut")[0].replace("_", " ")
    if set_name == "px4_sih_dev":
        for r in csv.DictReader((SHARED / "px4_sih_dev" / "manifest.csv").open()):
            if f"{r['name']}.ulg" == log:
                return "healthy" if r["label"] == "healthy" else f"eta {float(r['eta']):.1f}"
    return ""


def record(doc: dict, **meta) -> dict:
    """bench_confidence's record of one verdict, with the model's part: its LLR per motor as the
    decision weighed it (``model_llr``) and the window majority (``model_alone``: 0 healthy, k motor k)."""
    r = bc.record(doc, **meta)
    r["model_llr"] = [((m.get("llr_by_source") or {}).get("model")) for m in doc.get("motors") or []]
    cls = [w.get("class", 0) for w in doc.get("windows") or []]
    r["model_alone"] = max(set(cls), key=cls.count) if cls else None
    return r


def run(args) -> list[dict]:
    profiles = Path(args.profiles)
    profiles.mkdir(parents=True, exist_ok=True)
    sim = Path(args.sim)
    bc.make_sim(sim)
    sets = {**bc.real_sets(), **bc.sim_sets(sim)}
    recs: list[dict] = []
    t0 = time.perf_counter()
    for set_name, rows in sets.items():
        if args.only and set_name not in args.only.split(","):
            continue
        truth = {str(p): t for p, t in rows}
        recs += [record(d, set=set_name, profile="none", truth=truth[log])
                 for log, d in bc.diagnose([p for p, _ in rows], None).items()]
        for name, cal, prows in _profiles(set_name, rows):
            for adapt in (False, True) if args.adapted and name in ADAPTED else (False,):
                prof = _calibrate(name, cal, profiles, adapt)
                if prof is None:
                    recs.append({"set": set_name, "profile": prof_name(name, adapt), "status": "calibration refused",
                                 "log": cal[0].name, "truth": None})
                    continue
                cal_r = {c.resolve() for c in cal}
                logs = [p for p, _ in prows if p.resolve() not in cal_r]
                ptruth = {str(p): t for p, t in prows}
                recs += [record(d, set=set_name, profile=prof_name(name, adapt), truth=ptruth[log])
                         for log, d in bc.diagnose(logs, prof).items()]
        print(f"{set_name}: done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    return recs


def prof_name(name: str, adapt: bool) -> str:
    return f"{name} {'adapted' if adapt else 'no-adapt'}"


def _kind(profile: str) -> str:
    return "none" if profile == "none" else ("adapted" if profile.endswith("adapted") and "no-adapt" not in profile
                                             else "no-adapt")


def _named_right(r: dict) -> bool:
    """A damaged or uncertain verdict that names a damaged motor (any named one when the set does not say)."""
    return r["status"] in ("damaged", "uncertain") and bool(r["truth"] is not None and bc.right(r))


def summary(recs: list[dict]) -> dict:
    """{(set, profile kind, group): Counter} of one run."""
    out: dict = defaultdict(Counter)
    for r in recs:
        if r["status"] == "calibration refused":
            out[(r["set"], _kind(r["profile"]), "calibration refused")]["n"] += 1
            continue
        g = group_of(r["set"], r["log"]) or ("healthy" if r["truth"] is None else "damaged")
        c = out[(r["set"], _kind(r["profile"]), g)]
        c["n"] += 1
        c[r["status"] if r["status"] in ("healthy", "uncertain", "damaged", "stopped") else "other"] += 1
        if r["truth"] is not None:
            c["d right"] += r["status"] in ("damaged", "stopped") and bc.right(r)
            c["u right"] += r["status"] == "uncertain" and bc.right(r)
        m = r.get("model_alone")
        if m is not None:  # the window majority: a motor on healthy truth, a damaged motor on damaged truth
            c["model"] += bool(m) and (r["truth"] is None or not r["truth"] or m in r["truth"])
    return out


def _cell(c: Counter, damaged_truth: bool) -> str:
    s = f"{c['healthy']}h {c['uncertain']}u {c['damaged'] + c['stopped']}d" + (f" {c['other']}x" if c["other"] else "")
    return s + (f" ({c['d right']}+{c['u right']} right)" if damaged_truth else "") + f"; model {c['model']}"


def compare(paths: list[Path]) -> None:
    runs = [json.loads(p.read_text()) for p in paths]
    sums = [summary(r) for r in runs]
    keys = sorted(set().union(*sums))
    names = [p.stem for p in paths]
    print("Verdicts healthy / uncertain / damaged (d includes stopped); for damaged truth (damaged naming a damaged "
          "motor + uncertain naming it) right; 'model': the model alone, flights whose window majority is a motor "
          "(healthy truth) or a damaged one (damaged truth). Profile kinds pooled over the set's profiles.\n")
    print("| set | profile | group | n | " + " | ".join(names) + " |")
    print("|---|---|---|---|" + "---|" * len(names))
    for k in keys:
        n = max(s[k]["n"] for s in sums)
        dt = k[2] not in ("healthy", "good", "calibration refused")
        cells = [_cell(s[k], dt) if s[k]["n"] else "-" for s in sums]
        mark = " *" if len(set(cells)) > 1 else ""
        print(f"| {k[0]} | {k[1]} | {k[2]} | {n} | " + " | ".join(cells) + f" |{mark}")
    for i in range(1, len(runs)):
        a = {(r["set"], r["profile"], r["log"]): r for r in runs[0]}
        b = {(r["set"], r["profile"], r["log"]): r for r in runs[i]}
        moved = [(k, a[k], b[k]) for k in sorted(set(a) & set(b))
                 if (a[k]["status"], a[k].get("motor")) != (b[k]["status"], b[k].get("motor"))]
        print(f"\n{len(moved)} verdicts moved {names[0]} -> {names[i]} (of {len(set(a) & set(b))}):")
        for (st, prof, log), x, y in moved:
            t = "healthy" if x["truth"] is None else (f"motor {','.join(map(str, x['truth']))}" if x["truth"] else "damaged")
            print(f"  {st} | {prof} | {log} (truth {t}): {x['status']} {x.get('motor') or ''} -> "
                  f"{y['status']} {y.get('motor') or ''}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    r.add_argument("--profiles", type=Path, required=True, help="profiles made once here (one folder per model)")
    r.add_argument("--adapted", action="store_true", help="also the adapted profiles of " + ", ".join(ADAPTED))
    r.add_argument("--sim", default=str(ROOT / "build" / "confidence_sim2"), help="folder of the simulated batch")
    r.add_argument("--only", help="only these sets (comma-separated)")
    c = sub.add_parser("compare")
    c.add_argument("runs", type=Path, nargs="+")
    args = ap.parse_args()
    if args.cmd == "run":
        recs = run(args)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(recs, indent=0))
        print(f"wrote {args.out}: {len(recs)} verdicts")
    else:
        compare(args.runs)


if __name__ == "__main__":
    main()
