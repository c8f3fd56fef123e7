"""Each evidence source's measured reliability by kind of log: the table the decision weighs with.

    python benchmarks/bench_reliability.py collect [--sets real,sim,nrotor] [--sim-airframes 12]
    python benchmarks/bench_reliability.py table [--write results/reliability.md]
    python benchmarks/bench_reliability.py replay            # today's decision on the cached cases

``collect`` diagnoses (in-process, shipped or the profile's model) every case below and caches,
per case, the log's kind (:class:`flightlog_fd.analyzers.reliability.LogKind`: motor-output and
rate-stream rates, airborne time, manoeuvre share, profile kind), each analyzer's LLR per motor as
it computed it (no cap), the verdict, the model's window classes, and the decision's inputs
(pickled) so that ``replay`` can re-decide without diagnosing again. Cases:

- real (``../shared``, each set skipped when absent): the real healthy ArduCopter flights and
  rrc_straight, CrazyPAD E9, px4_sih_dev without a profile; each airframe's other flights against
  a one-flight ``--no-adapt`` profile of each of its healthy flights (Erle board groups, rrc goods,
  E9 normals, SIH healthy); adapted profiles where ``--profiles`` holds them (``rrc_g1_adapted``,
  ``cp00``, ``sih004``... as ``bench_real_damage.py`` and ``golden_verdicts.py`` name them);
- sim: random quad airframes with realistic imbalance and real-log noise (seeds 9100+, neither
  training's nor the other benchmarks'), each flown healthy, damaged (one rotor, eta 0.6-0.9 from
  take-off) and healthy again (the twin a ``--no-adapt`` profile is calibrated on), logged at every
  logging profile of :data:`flightlog_fd.sim.logger.PROFILES` but ``training``; diagnosed without
  and with the twin's profile;
- nrotor: the same for hexa-X and octo-X airframes (their shipped models).

``table`` prints, per source and per cell of the reliability table (the source's own keys), the
healthy flights' leading LLR (largest over motors) and the damaged flights' LLR of the damaged
motor (raw, before any cap): count, median, 90th percentile / 10th percentile, largest / smallest,
the false-alarm rate (healthy lead >= ``FIRE_LLR``) and detection rate (damaged motor's LLR >=
``FIRE_LLR`` and the largest), and the cap that rate pair supports. ``--write`` also writes it as
markdown. Figures only; nothing is asserted.
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
GOLDEN_PROFILES = Path("/work/golden/profiles")
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
        normals = [(lg.name, lg.path) for lg in cp if lg.healthy]
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
    # adapted profiles made by the other benchmarks, where present
    adapted = {"rrc_g1_adapted": "rrc_straight", "rrc_g1": "rrc_straight", "cp00": "crazypad_e9",
               "sih004": "px4_sih_dev"}
    done = set()
    for pname, af in adapted.items():
        profile = find_profile(pname)
        if profile is None or not profile.model or af in done:
            continue
        done.add(af)
        healthy, damaged = next(((h, d) for a, h, d in airframes if a == af), ([], []))
        cal = {s["name"] for s in (profile.source_logs or [])}
        others = [(n, p, 0, "healthy", None) for n, p in healthy if p.name not in cal]
        run(af, others + list(damaged), profile, f"{pname} (adapted)")
    return out


# ------------------------------------------------------------------------------------ simulated
def sim_cases(n_airframes: int, frames: tuple[str, ...] = ("quad_x",), log_profiles=SIM_LOG_PROFILES,
              seed: int = SIM_SEED) -> list[dict]:
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
            common = dict(duration_s=60.0, profile=lp, noise="real_logs", midflight_fraction=0.0)
            res = []
            for mission, sub in (("waypoints", 0), ("manual", 1)):
                idx = [i for i in range(n_airframes) if i % 2 == sub]
                if not idx:
                    continue
                a = [afs[i] for i in idx]
                im = [imbs[i] for i in idx]
                k = len(idx)
                fl = simulate_flights(3 * k, airframes=a * 3, imbalance=im * 3, mission=mission,
                                      damages=[Damage(0, 1.0, rotors=nrot)] * k + [Damage(*truth[i], rotors=nrot) for i in idx]
                                      + [Damage(0, 1.0, rotors=nrot)] * k,
                                      seed=s + 13 * sub, **common)
                for j, i in enumerate(idx):
                    res.append((i, mission, fl[j], fl[k + j], fl[2 * k + j]))
            for i, mission, healthy, damaged, twin in sorted(res, key=lambda r: r[0]):
                motor, eta = truth[i]
                profile = calibrate([twin])  # as `fdlog calibrate --no-adapt`
                tag = f"sim {frame} {lp}"
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
def load_cases(which=("real", "sim", "nrotor")) -> list[dict]:
    out = []
    for w in which:
        p = CACHE / f"{w}.pkl"
        if p.exists():
            out += pickle.loads(p.read_bytes())
    return out


def collect(args) -> None:
    CACHE.mkdir(parents=True, exist_ok=True)
    sets = args.sets.split(",")
    dirs = [Path(d) for d in args.profiles] + [GOLDEN_PROFILES, ROOT / "build" / "bench_profiles"]
    if "real" in sets and SHARED.is_dir():
        (CACHE / "real.pkl").write_bytes(pickle.dumps(real_cases(dirs)))
    if "sim" in sets:
        (CACHE / "sim.pkl").write_bytes(pickle.dumps(sim_cases(args.sim_airframes)))
    if "nrotor" in sets:
        (CACHE / "nrotor.pkl").write_bytes(pickle.dumps(
            sim_cases(args.sim_airframes, frames=("hexa_x", "octo_x"), log_profiles=("px4_high", "ardupilot", "px4_default"))))


# ------------------------------------------------------------------------------------ table
def _lead(raw: list[float]) -> float:
    return float(np.max(raw))


def table(cases: list[dict], out_md: Path | None = None) -> str:
    from flightlog_fd.analyzers import REGISTRY
    from flightlog_fd.analyzers.reliability import FIRE_LLR, LogKind, cell_of, supported_cap

    lines = []
    cells: dict[tuple, dict] = defaultdict(lambda: {"h": [], "d": [], "d_lead": [], "sets": Counter()})
    for c in cases:
        if c["kind"] is None:
            continue
        kind = LogKind.from_dict(c["kind"])
        for a in REGISTRY:
            raw = c["raw"].get(a.id)
            if raw is None:
                continue
            key = (a.id, cell_of(a, kind))
            e = cells[key]
            e["sets"][c["set"].split(" | ")[0].split(" #")[0]] += 1
            if c["truth"] == 0:
                e["h"].append(_lead(raw))
            elif c["truth"] > 0 and c["truth"] <= len(raw):
                e["d"].append(raw[c["truth"] - 1])
                e["d_lead"].append(int(np.argmax(raw)) + 1 == c["truth"])
    hdr = (f"| source | cell | healthy n | lead median / p90 / max | FA | damaged n | damaged motor p10 / median "
           f"| detected | supported cap | sets |")
    lines += [hdr, "|" + "---|" * 10]
    for (src, cell), e in sorted(cells.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        h, dd = np.array(e["h"]), np.array(e["d"])
        fa = int(np.sum(h >= FIRE_LLR)) if len(h) else 0
        det = int(np.sum((dd >= FIRE_LLR) & np.array(e["d_lead"], bool))) if len(dd) else 0
        hs = f"{np.median(h):+.1f} / {np.percentile(h, 90):+.1f} / {h.max():+.1f}" if len(h) else "-"
        ds = f"{np.percentile(dd, 10):+.1f} / {np.median(dd):+.1f}" if len(dd) else "-"
        cap = supported_cap(fa, len(h), det, len(dd))
        sets = ", ".join(f"{k} {v}" for k, v in e["sets"].most_common(4))
        lines.append(f"| {src} | {cell} | {len(h)} | {hs} | {fa} | {len(dd)} | {ds} | {det} | {cap:.1f} | {sets} |")
    text = "\n".join(lines)
    print(text)
    if out_md is not None:
        out_md.write_text(text + "\n")
    return text


def replay(cases: list[dict]) -> None:
    """Today's decision on the cached cases: per set, verdict against the model's window majority."""
    from flightlog_fd.decision import decide

    rows = defaultdict(lambda: Counter())
    for c in cases:
        if c["replay"] is None:
            continue
        n, frame, tl, results, stopped, kind = pickle.loads(c["replay"])
        v, _ = decide(n, frame, timeline=tl, results=results, stopped=stopped, kind=kind)
        key = (c["set"].split(" | ")[0] + (" | profile" if " | " in c["set"] else ""), c["group"])
        r = rows[key]
        r["n"] += 1
        t = c["truth"]
        r["verdict healthy"] += v.status == "healthy"
        r["verdict uncertain"] += v.status == "uncertain"
        r["verdict damaged"] += v.status == "damaged"
        if t > 0:
            r["verdict right"] += v.status == "damaged" and v.motor == t
            r["model right"] += c["model_alone"] == ("damaged", t)
        elif t == 0:
            r["model healthy"] += c["model_alone"][0] == "healthy"
    for (s, g), r in sorted(rows.items()):
        print(f"{s:45s} {g:12s} n={r['n']:3d} h/u/d {r['verdict healthy']}/{r['verdict uncertain']}/"
              f"{r['verdict damaged']}" + (f"  right: verdict {r['verdict right']} model {r['model right']}"
                                            if 'verdict right' in r or 'model right' in r else
                                            f"  model healthy {r['model healthy']}"))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("collect", "table", "replay"))
    ap.add_argument("--sets", default="real,sim,nrotor")
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
