"""Each evidence source's measured reliability by kind of log: the table the decision weighs with.

    python benchmarks/bench_reliability.py collect [--sets real,sim,nrotor,esc] [--sim-airframes 30]
    python benchmarks/bench_reliability.py table [--write results/reliability.md]   # between its markers
    python benchmarks/bench_reliability.py replay            # the decision now, on the cached cases

``collect`` diagnoses (in-process, shipped or the profile's model) every case below and caches
(build/reliability/*.pkl), per case, the log's kind (:class:`flightlog_fd.analyzers.reliability.LogKind`:
motor-output and rate-stream rates, covered time, manoeuvre share, profile kind, rotor count), each
analyzer's LLR per motor as it computed it (no cap), the verdict, the model's window classes and
flight-mean log ratios, the command shares, and the decision's inputs (pickled) so that ``replay``
re-decides without diagnosing again. Cases:

- real (``../shared``, each set skipped when absent): the real healthy ArduCopter flights,
  rrc_straight, CrazyPAD E9 and px4_sih_dev without a profile; each airframe's other flights
  (healthy and damaged) against a one-flight ``--no-adapt`` profile of each of its healthy flights
  (Erle board groups, rrc goods, E9 normals, SIH healthy), and against a one-flight adapted profile
  where build/cross_session_profiles holds one (``<airframe>_<i>_adapted.json``, as
  ``bench_cross_session.py --calibrate-only`` names them);
- sim: random quad airframes with realistic imbalance and real-log noise (seeds 9100+, neither
  training's nor the other benchmarks'), each flown healthy, damaged (one rotor, eta 0.6-0.9 from
  take-off) and healthy again (the twin a ``--no-adapt`` profile is calibrated on), waypoint and
  manual missions, logged at every logging profile of :data:`flightlog_fd.sim.logger.PROFILES`
  but ``training``; diagnosed without and with the twin's profile;
- esc: the same with simulated ESC telemetry (the twin flies the same motors and ESCs);
- nrotor: hexa-X and octo-X airframes (their shipped models).

``table`` prints, per source and cell of the reliability table (the analyzer's own
``reliability_keys``) and per origin (real, simulated): the healthy flights' leading LLR (largest
over the motors, before any cap), how many reach the decision's uncertain and damaged bars, the damaged flights' LLR of the damaged motor and how often it alone
names it at the damaged bar; the level ``reliability.trust_level`` gives each origin, the cell's
level (``reliability.cell_trust``) and the level the code holds, flagging a difference; then the
rule's table as the code holds it. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import csv
import pickle
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
CACHE = ROOT / "build" / "reliability"
SIM_SEED = 9100
SIM_LOG_PROFILES = ("px4_high", "ardupilot_fast", "ardupilot", "ardupilot_slow", "px4_default", "ardupilot_rcou")
SIM_ETAS = (0.6, 0.7, 0.8, 0.9)


# ------------------------------------------------------------------------------------ one case
def _model_alone(probs_cls: list[int], n: int) -> tuple[str, int]:
    """The model's window majority (plurality of the windows' argmax; bench_real_damage's rule)."""
    if not probs_cls:
        return ("n/a", 0)
    k = int(np.bincount(np.asarray(probs_cls), minlength=n + 1).argmax())
    return ("healthy", 0) if k == 0 else ("damaged", k)


def case(d, *, set_name: str, name: str, truth: int, group: str, profile_kind: str, eta=None) -> dict:
    """The cached figures of one diagnosis ``d`` (truth: 0 healthy, k motor k, -1 damaged motor unknown)."""
    from flightlog_fd.analyzers.reliability import log_kind

    dec = d.decision
    n = len(dec.motors) if dec is not None else (d.facts and 4)
    results = dec.results if dec is not None else []
    kind = d.log_kind if getattr(d, "log_kind", None) is not None else None
    raw, abst = {}, {}
    for r in results:
        v = r.raw_llr(n)
        raw[r.analyzer] = None if v is None else [float(x) for x in v]
        if r.abstained:
            abst[r.analyzer] = r.abstained
    cls = [w.cls for w in d.windows]
    from flightlog_fd.analyzers.model_votes import mean_log_ratio

    mlr = [float(x) for x in mean_log_ratio(np.array([w.probabilities for w in d.windows]))] if d.windows else None
    return {"set": set_name, "name": name, "truth": truth, "group": group, "eta": eta, "profile_kind": profile_kind,
            "n": n, "kind": None if kind is None else kind.as_dict(), "raw": raw, "mlr": mlr,
            "shares": None if d.share_fit is None else [float(m.command_share) for m in d.share_fit.motors], "abstained": abst,
            "status": d.verdict.status, "motor": d.verdict.motor, "confidence": d.verdict.confidence,
            "reason": d.verdict.reason, "model_alone": _model_alone(cls, n),
            "damaged_windows": sum(c > 0 for c in cls), "windows": len(cls),
            "replay": pickle.dumps((n, d.flight.frame if d.flight is not None else None, d.timeline, results,
                                    d.stopped, kind)) if dec is not None else None}


# ------------------------------------------------------------------------------------ real sets
def _profile_kind(profile) -> str:
    return "none" if profile is None else ("adapted" if getattr(profile, "model", None) else "profile")


def real_cases(profiles_dirs: list[Path]) -> list[dict]:
    from flightlog_fd import load_flight
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.errors import FlightLogError
    from flightlog_fd.profile import Profile
    from flightlog_fd.training.targets import crazypad_logs, real_healthy_logs, sih_logs

    shipped = resolve_model()
    out: list[dict] = []
    flights: dict[Path, object] = {}

    def fl(p: Path):
        if p not in flights:
            flights[p] = load_flight(p)
        return flights[p]

    def run(set_name, items, profile=None, profile_name=""):
        model = resolve_model(None, profile) if profile is not None else shipped
        kind = _profile_kind(profile)
        t0 = time.perf_counter()
        for name, path, truth, group, eta in items:
            d = diagnose_flight(fl(path), model, profile)
            out.append(case(d, set_name=set_name + (f" | {profile_name}" if profile_name else ""), name=name,
                            truth=truth, group=group, profile_kind=kind, eta=eta))
        print(f"  {set_name} {profile_name or 'no profile'}: {len(items)} flights "
              f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    def find_profile(name: str):
        for d in profiles_dirs:
            p = d / f"{name}.json"
            if p.exists():
                return Profile.load(p)
        return None

    airframes = []  # (airframe, [(name, path)] healthy, [(name, path, truth, group, eta)] damaged)
    if (SHARED / "real_healthy").is_dir():
        rh = [(lg.name, lg.path, 0, "healthy", None) for lg in real_healthy_logs(SHARED)]
        run("real healthy", rh)
        groups = defaultdict(list)
        for row in csv.DictReader((SHARED / "real_healthy" / "manifest.csv").open()):
            if row.get("board_group"):
                groups[row["board_group"]].append(SHARED / "real_healthy" / "logs" / row["file"])
        for g, files in sorted(groups.items()):
            if len(files) >= 2:
                airframes.append((f"erle_{g}", [(p.stem, p) for p in sorted(files)], []))
    rrc = SHARED / "real_damaged" / "rrc_straight"
    if rrc.is_dir():
        goods = [(p.stem, p) for p in sorted(rrc.glob("good_prop_*.BIN"))]
        cuts = [(p.stem, p, -1, p.stem.split("_cut")[0].replace("_", " "), None)
                for p in sorted(rrc.glob("*_mm_cut_*.BIN"))]
        run("rrc_straight", [(n, p, 0, "good", None) for n, p in goods] + cuts)
        airframes.append(("rrc_straight", goods, cuts))
    if (SHARED / "crazypad_e9").is_dir():
        cp = crazypad_logs(SHARED)
        normals = sorted((lg.name, lg.path) for lg in cp if lg.healthy)
        dmg = [(lg.name, lg.path, lg.truth["motor"] if not lg.name.startswith("cut_M2_0.5mm") else -1,
                f"motor {lg.truth['motor']}", None) for lg in cp if not lg.healthy]
        run("crazypad_e9", [(n, p, 0, "healthy", None) for n, p in normals] + dmg)
        airframes.append(("crazypad_e9", normals, dmg))
    if (SHARED / "px4_sih_dev").is_dir():
        sih = sih_logs(SHARED)
        h = [(lg.name, lg.path) for lg in sih if lg.healthy]
        dmg = [(lg.name, lg.path, lg.truth["motor"], f"eta {lg.truth['eta']:.1f}", lg.truth["eta"])
               for lg in sih if not lg.healthy]
        run("px4_sih_dev", [(n, p, 0, "healthy", None) for n, p in h] + dmg)
        airframes.append(("px4_sih_dev", h, dmg))
    # one-flight --no-adapt profiles on each healthy flight of each airframe
    for af, healthy, damaged in airframes:
        for cal_name, cal_path in healthy:
            try:
                profile = calibrate([fl(cal_path)])  # as `fdlog calibrate --no-adapt`
            except FlightLogError as e:  # refused, as `fdlog calibrate` refuses it
                print(f"  {af} {cal_name}: calibration refused ({e.message[:80]})", file=sys.stderr)
                continue
            others = [(n, p, 0, "healthy", None) for n, p in healthy if p != cal_path]
            run(af, others + list(damaged), profile, f"{cal_name} no-adapt")
    # one-flight adapted profiles (the default `fdlog calibrate`) made by bench_cross_session.py
    # (--quick --calibrate-only), where present: named <airframe>_<i>_adapted
    for af, healthy, damaged in airframes:
        for i, (cal_name, cal_path) in enumerate(healthy):
            profile = find_profile(f"{af}_{i + 1}_adapted")
            if profile is None or not profile.model:
                continue
            others = [(n, p, 0, "healthy", None) for n, p in healthy if p != cal_path]
            run(af, others + list(damaged), profile, f"{cal_name} adapted")
    return out


# ------------------------------------------------------------------------------------ simulated
def sim_cases(n_airframes: int, frames: tuple[str, ...] = ("quad_x",), log_profiles=SIM_LOG_PROFILES,
              seed: int = SIM_SEED, esc=None) -> list[dict]:
    """Healthy / damaged / healthy-twin flights of ``n_airframes`` random airframes per frame and
    logging profile, diagnosed without a profile and with the twin's ``--no-adapt`` profile."""
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage
    from flightlog_fd.sim.imbalance import random_imbalances

    model = resolve_model()
    out = []
    for frame in frames:
        for li, lp in enumerate(log_profiles):
            s = seed + 97 * li + 1000 * frames.index(frame)
            rng = np.random.default_rng(s)
            afs = random_airframes(n_airframes, rng, frames=None if frame == "quad_x" else (frame,))
            imbs = random_imbalances(afs, rng)
            nrot = afs[0].rotor_count
            truth = [(int(rng.integers(1, nrot + 1)), SIM_ETAS[i % len(SIM_ETAS)]) for i in range(n_airframes)]
            t0 = time.perf_counter()
            common = dict(duration_s=60.0, profile=lp, noise="real_logs", midflight_fraction=0.0, esc=esc)
            res = []
            for mission, sub in (("waypoints", 0), ("manual", 1)):
                idx = [i for i in range(n_airframes) if i % 2 == sub]
                if not idx:
                    continue
                a = [afs[i] for i in idx]
                im = [imbs[i] for i in idx]
                k = len(idx)
                if esc == "random":  # the same motors and ESCs on the healthy, damaged and twin flights
                    from flightlog_fd.sim.esc import random_esc_params

                    e = [random_esc_params(x, np.random.default_rng([s, sub, j])) for j, x in enumerate(a)]
                    common["esc"] = e * 3
                fl = simulate_flights(3 * k, airframes=a * 3, imbalance=im * 3, mission=mission,
                                      damages=[Damage(0, 1.0, rotors=nrot)] * k + [Damage(*truth[i], rotors=nrot) for i in idx]
                                      + [Damage(0, 1.0, rotors=nrot)] * k,
                                      seed=s + 13 * sub, **common)
                for j, i in enumerate(idx):
                    res.append((i, mission, fl[j], fl[k + j], fl[2 * k + j]))
            for i, mission, healthy, damaged, twin in sorted(res, key=lambda r: r[0]):
                motor, eta = truth[i]
                profile = calibrate([twin])  # as `fdlog calibrate --no-adapt`
                tag = f"sim {frame} {lp}" + (" esc" if esc else "")
                for prof in (None, profile):
                    for f, t, g in ((healthy, 0, "healthy"), (damaged, motor, f"eta {eta:.1f}")):
                        d = diagnose_flight(f, model, prof, keep_flight=True)
                        c = case(d, set_name=tag + ("" if prof is None else " | twin no-adapt"), name=f"{tag} #{i} {mission}",
                                 truth=t, group=g, profile_kind=_profile_kind(prof), eta=eta if t else None)
                        c["flight"] = None
                        out.append(c)
            print(f"  {frame} {lp}: {n_airframes} airframes ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    return out


# ------------------------------------------------------------------------------------ cache
def load_cases(which=("real", "sim", "nrotor", "esc")) -> list[dict]:
    out = []
    for w in which:
        p = CACHE / f"{w}.pkl"
        if p.exists():
            out += pickle.loads(p.read_bytes())
    return out


def collect(args) -> None:
    CACHE.mkdir(parents=True, exist_ok=True)
    sets = args.sets.split(",")
    dirs = [Path(d) for d in args.profiles] + [ROOT / "build" / "cross_session_profiles"]
    if "real" in sets and SHARED.is_dir():
        (CACHE / "real.pkl").write_bytes(pickle.dumps(real_cases(dirs)))
    if "sim" in sets:
        (CACHE / "sim.pkl").write_bytes(pickle.dumps(sim_cases(args.sim_airframes)))
    if "esc" in sets:
        (CACHE / "esc.pkl").write_bytes(pickle.dumps(
            sim_cases(args.sim_airframes, log_profiles=("px4_high", "ardupilot", "px4_default"), seed=SIM_SEED + 500,
                      esc="random")))
    if "nrotor" in sets:
        (CACHE / "nrotor.pkl").write_bytes(pickle.dumps(
            sim_cases(args.sim_airframes, frames=("hexa_x", "octo_x"), log_profiles=("px4_high", "ardupilot", "px4_default"))))


# ------------------------------------------------------------------------------------ table
def measure(cases: list[dict]) -> dict:
    """{(source, cell): {"real"|"sim": {"h": [healthy leads], "d": [(damaged motor's LLR, led)]}}}."""
    from flightlog_fd.analyzers import REGISTRY
    from flightlog_fd.analyzers.reliability import LogKind, cell_of

    keys = {a.id: a.reliability_keys for a in REGISTRY if a.reliability_keys}
    out: dict = defaultdict(lambda: {"real": {"h": [], "d": []}, "sim": {"h": [], "d": []}})
    for c in cases:
        if c["kind"] is None:
            continue
        kind = LogKind.from_dict(c["kind"])
        origin = "sim" if c["set"].startswith("sim") else "real"
        for src, raw in c["raw"].items():
            if raw is None or src not in keys:
                continue
            e = out[(src, cell_of(keys[src], kind))][origin]
            if c["truth"] == 0:
                e["h"].append(float(np.max(raw)))
            elif 0 < c["truth"] <= len(raw):
                e["d"].append((raw[c["truth"] - 1], int(np.argmax(raw)) + 1 == c["truth"]))
    return out


def table(cases: list[dict], out_md: Path | None = None) -> str:
    """The measured table (module docstring), the level the rule gives each cell, and the level
    the code holds (flightlog_fd/analyzers/reliability.RELIABILITY), flagging any difference."""
    from flightlog_fd.analyzers.reliability import EXCEPTIONS, cell_trust, trust_level, trust_of
    from flightlog_fd.decision import DAMAGED_LLR, UNCERTAIN_LLR

    from flightlog_fd.analyzers import REGISTRY

    learned = {a.id: a.learned for a in REGISTRY}
    lines = [f"| source | cell | origin | healthy n | leading LLR median / max | reaching "
             f"{UNCERTAIN_LLR:g} / {DAMAGED_LLR:g} "
             f"| damaged n | damaged motor's LLR p10 / median | named at >= {DAMAGED_LLR:g} | level | cell level "
             f"| in code |", "|" + "---|" * 12]
    for (src, cell), origins in sorted(measure(cases).items()):
        levels = {}
        rows = []
        for origin in ("real", "sim"):
            h = np.array(origins[origin]["h"])
            d = origins[origin]["d"]
            if not len(h) and not d:
                continue
            fa_u, fa_d = int(np.sum(h >= UNCERTAIN_LLR)), int(np.sum(h >= DAMAGED_LLR))
            levels[origin] = trust_level(len(h), fa_u, fa_d)
            dv = np.array([x for x, _ in d])
            named = sum(1 for x, led in d if led and x >= DAMAGED_LLR)
            rows.append([src, cell, origin, str(len(h)),
                         f"{np.median(h):+.1f} / {h.max():+.1f}" if len(h) else "-",
                         f"{fa_u} / {fa_d}" if len(h) else "-",
                         str(len(dv)), f"{np.percentile(dv, 10):+.1f} / {np.median(dv):+.1f}" if len(dv) else "-",
                         str(named) if len(dv) else "-", levels[origin] or "too few"])
        level = cell_trust(levels.get("real"), levels.get("sim"), learned[src])
        code = trust_of(src, cell) or "-"
        if (src, cell) in EXCEPTIONS:
            code += " (exception)"
        for i, r in enumerate(rows):
            lines.append("| " + " | ".join(r + ([level, code + (" (differs)" if not code.startswith(level) else "")] if i == 0
                                                else ["", ""])) + " |")
    text = "\n".join(lines)
    print(text)
    print("\n# the rule's table, as flightlog_fd/analyzers/reliability.RELIABILITY holds it")
    by_src: dict = defaultdict(dict)
    for line in lines[2:]:
        cols = [c.strip() for c in line.strip("|").split("|")]
        if cols[10]:
            by_src[cols[0]][cols[1]] = cols[10]
    print("RELIABILITY = {\n" + "".join(
        f"    {src!r}: {{\n" + "".join(f"        {c!r}: {lv!r},\n" for c, lv in cells.items()) + "    },\n"
        for src, cells in by_src.items()) + "}")
    for (src, cell), (level, why) in EXCEPTIONS.items():
        print(f"\nexception: {src}, {cell}: {level}: {why}")
    if out_md is not None:  # the table between its markers; the words around it are kept
        start, end = "<!-- table: bench_reliability.py table --write -->", "<!-- /table -->"
        doc = out_md.read_text() if out_md.exists() else f"{start}\n{end}\n"
        a, b = doc.index(start) + len(start), doc.index(end)
        out_md.write_text(doc[:a] + "\n" + text + "\n" + doc[b:])
    return text


def replay(cases: list[dict]) -> None:
    """The decision as the code makes it now, on the cached cases, beside the decision with one cap
    per source (no reliability table, the command pattern abstaining on an n-rotor without a
    profile: main before issue 28) and the model's window majority: per set (profiles pooled) and
    group, healthy / uncertain / damaged, and for a known damaged motor how often it was named."""
    from flightlog_fd.analyzers import REGISTRY
    from flightlog_fd.decision import decide

    keys = {a.id: tuple(a.reliability_keys) for a in REGISTRY}
    rows: dict = defaultdict(Counter)
    for c in cases:
        if c["replay"] is None:
            continue
        n, frame, tl, results, stopped, kind = pickle.loads(c["replay"])
        for r in results:  # the analyzers' keys as the code names them now
            r.reliability_keys = keys.get(r.analyzer, ())
        v, _ = decide(n, frame, timeline=tl, results=results, stopped=stopped, kind=kind)
        n_rotor_bare = n != 4 and kind is not None and kind.profile == "none"
        before, _ = decide(n, frame, timeline=tl, stopped=stopped, kind=None,
                           results=[r for r in results if not (n_rotor_bare and r.analyzer == "commands")])
        prof = c["set"].split(" | ")[1].split(" ")[-1] if " | " in c["set"] else "none"
        grp = c["group"] if c["truth"] <= 0 else ("damaged" if not c["set"].startswith("sim") else c["group"])
        r = rows[(c["set"].split(" | ")[0], prof, grp)]
        r["n"] += 1
        for tag, st, m in (("was", before.status, before.motor), ("now", v.status, v.motor)):
            r[f"{tag} {st[0]}"] += 1
            if c["truth"] > 0:
                r[f"{tag} right"] += st == "damaged" and m == c["truth"]
        if c["truth"] > 0:
            r["model right"] += c["model_alone"] == ("damaged", c["truth"])
        elif c["truth"] == 0:
            r["model FA"] += c["model_alone"][0] == "damaged"

    def cell(r, tag):
        return f"{r[tag + ' h']}h {r[tag + ' u']}u {r[tag + ' d']}d" + (f" ({r[tag + ' right']} right)"
                                                                       if (tag + " right") in r else "")
    print(f"{'set':34s} {'profile':9s} {'group':10s} {'n':>4s}  {'before':>20s}  {'now':>20s}  model alone")
    for (st, prof, grp), r in sorted(rows.items()):
        model = f"{r['model right']} right" if "model right" in r else f"{r['model FA']} called damaged"
        mark = " *" if cell(r, "was") != cell(r, "now") else ""
        print(f"{st[:34]:34s} {prof:9s} {grp[:10]:10s} {r['n']:4d}  {cell(r, 'was'):>20s}  {cell(r, 'now'):>20s}  "
              f"{model}{mark}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("collect", "table", "replay"))
    ap.add_argument("--sets", default="real,sim,nrotor,esc")
    ap.add_argument("--sim-airframes", type=int, default=12)
    ap.add_argument("--profiles", action="append", default=[], help="folders holding adapted profiles")
    ap.add_argument("--write", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.what == "collect":
        collect(args)
    elif args.what == "table":
        table(load_cases(args.sets.split(",")), args.write)
    else:
        replay(load_cases(args.sets.split(",")))


if __name__ == "__main__":
    main()
