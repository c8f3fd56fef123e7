"""Each evidence source's measured reliability by kind of log: the table the decision weighs with.

    python benchmarks/bench_reliability.py collect [--sets real,sim,nrotor,esc] [--sim-airframes 30]
    python benchmarks/bench_reliability.py table [--write results/reliability.md]   # between its markers
    python benchmarks/bench_reliability.py replay            # the decision now, on the cached cases
    python benchmarks/bench_reliability.py bars              # the uncertain bar per rate class, no profile

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
#: The damaged motors the vote statistics are fitted on: eta at most this (the "lost thrust" the
#: model is weighed for; milder damage is the decision's MILD_DAMAGE_LLR_FLOOR, invisible to every
#: source, as the flight-mean constants before were measured on SIH eta <= 0.8). CrazyPAD's cuts
#: (severity unknown, mild: a 3 mm cut moves the command share +0.16, eta ~0.86) are checked on, not fitted.
VOTE_FIT_ETA = 0.8
#: The seed of the simulated set the model's vote statistics per rate class are measured on
#: (``collect --sets simfit``; model_votes.QUAD_VOTE_SHARE_STATS), apart from the table's own (SIM_SEED).
SIM_FIT_SEED = 12100


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
    mctx = getattr(d, "_model_ctx", None)  # what the model analyzer read (recorded by _recording_contexts)
    return {"set": set_name, "name": name, "truth": truth, "group": group, "eta": eta, "profile_kind": profile_kind,
            "model_ctx": mctx,
            "n": n, "kind": None if kind is None else kind.as_dict(), "raw": raw, "mlr": mlr,
            "shares": None if d.share_fit is None else [float(m.command_share) for m in d.share_fit.motors], "abstained": abst,
            "status": d.verdict.status, "motor": d.verdict.motor, "confidence": d.verdict.confidence,
            "reason": d.verdict.reason, "model_alone": _model_alone(cls, n),
            "damaged_windows": sum(c > 0 for c in cls), "windows": len(cls),
            "replay": pickle.dumps((n, d.flight.frame if d.flight is not None else None, d.timeline, results,
                                    d.stopped, kind)) if dec is not None else None}


class _recording_contexts:
    """Within it, every diagnosis records what its (whole-log) model analyzer read: the windows'
    probabilities after the onset selection, the covered time, the profile's model-vote baseline
    and the judging model's sha256 (``d._model_ctx``), so ``replay`` can re-weigh the model's votes
    with the code as it is now."""

    def __enter__(self):
        import flightlog_fd.diagnose as dg

        self._dg, self._orig, self._diag = dg, dg.run_analyzers, dg.diagnose_flight
        self.seen: list = []

        def run(ctx, *a, **k):
            self.seen.append({"probs": np.asarray(ctx.probs, np.float32), "covered_s": float(ctx.covered_s),
                              "baseline": ctx.baseline_for("model"), "model_sha256": ctx.model_sha256})
            return self._orig(ctx, *a, **k)

        def diag(*a, **k):
            self.seen.clear()
            d = self._diag(*a, **k)
            d._model_ctx = self.seen[0] if self.seen else None
            return d

        dg.run_analyzers, dg.diagnose_flight = run, diag
        return self

    def __exit__(self, *exc):
        self._dg.run_analyzers, self._dg.diagnose_flight = self._orig, self._diag
        return False


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
def load_cases(which=("real", "sim", "nrotor", "esc"), reweigh: bool = True) -> list[dict]:
    """The cached cases of ``which``; ``reweigh``: the model's votes weighed again with the code
    as it is now (:func:`reweigh_model`), where the case recorded what the model read."""
    out = []
    for w in which:
        p = CACHE / f"{w}.pkl"
        if p.exists():
            out += pickle.loads(p.read_bytes())
    if reweigh:
        for c in out:
            reweigh_model(c)
    return out


def _model_context(c: dict):
    """A Context holding what the case's model analyzer read (None when it was not recorded)."""
    from types import SimpleNamespace

    from flightlog_fd.analyzers import Context

    m, k = c.get("model_ctx"), c.get("kind")
    if m is None or k is None or not len(m["probs"]):
        return None
    flight = SimpleNamespace(motors=SimpleNamespace(rate_hz=k["motors_hz"]), rates=SimpleNamespace(rate_hz=k["rates_hz"]))
    profile = SimpleNamespace(analyzers={"model": m["baseline"]}) if m["baseline"] else None
    return Context(flight=flight, frame=None, n_motors=m["probs"].shape[1] - 1, probs=np.asarray(m["probs"], float),
                   covered_s=m["covered_s"], profile=profile, model_sha256=m["model_sha256"])


def reweigh_model(c: dict) -> None:
    """Replace the case's model result (its raw LLR, and the result the replay re-decides with)
    by the current ModelVotes' on what the model read."""
    from flightlog_fd.analyzers import run_analyzers
    from flightlog_fd.analyzers.model_votes import ModelVotes

    ctx = _model_context(c)
    if ctx is None or c["replay"] is None:
        return
    (new,) = run_analyzers(ctx, [ModelVotes()])
    c.setdefault("replay_recorded", c["replay"])
    n, frame, tl, results, stopped, kind = pickle.loads(c["replay"])
    results = [new if r.analyzer == "model" else r for r in results]
    c["replay"] = pickle.dumps((n, frame, tl, results, stopped, kind))
    v = new.raw_llr(n)
    c["raw"]["model"] = None if v is None else [float(x) for x in v]


def collect(args) -> None:
    CACHE.mkdir(parents=True, exist_ok=True)
    sets = args.sets.split(",")
    dirs = [Path(d) for d in args.profiles] + [ROOT / "build" / "cross_session_profiles"]
    if "real" in sets and SHARED.is_dir():
        (CACHE / "real.pkl").write_bytes(pickle.dumps(real_cases(dirs)))
    if "sim" in sets:
        (CACHE / "sim.pkl").write_bytes(pickle.dumps(sim_cases(args.sim_airframes)))
    if "simfit" in sets:  # another seed: the set the model's vote statistics are measured on (model_votes)
        (CACHE / "simfit.pkl").write_bytes(pickle.dumps(sim_cases(args.sim_airframes, seed=SIM_FIT_SEED)))
    if "esc" in sets:
        (CACHE / "esc.pkl").write_bytes(pickle.dumps(
            sim_cases(args.sim_airframes, log_profiles=("px4_high", "ardupilot", "px4_default"), seed=SIM_SEED + 500,
                      esc="random")))
    if "nrotorfit" in sets:  # another seed: the n-rotor models' vote statistics (model_votes)
        (CACHE / "nrotorfit.pkl").write_bytes(pickle.dumps(
            sim_cases(args.sim_airframes, frames=("hexa_x", "octo_x"), log_profiles=("px4_high", "ardupilot", "px4_default"),
                      seed=SIM_FIT_SEED + 500)))
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
    from flightlog_fd.decision import evidence_bars

    UNCERTAIN_LLR, DAMAGED_LLR = evidence_bars(4)  # the quad's bars under the stated prior

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


def replay(cases: list[dict], listing: bool = False) -> None:
    """The decision as the code makes it now on the cached cases (the model's votes re-weighed),
    beside the verdict recorded when the cases were collected, and the model's window majority:
    per set (profiles pooled) and group, healthy / uncertain / damaged, and for a known damaged
    motor how often it was named (damaged naming it + uncertain naming it). ``listing``: every
    case whose verdict moved."""
    from flightlog_fd.analyzers import REGISTRY
    from flightlog_fd.decision import decide

    keys = {a.id: tuple(a.reliability_keys) for a in REGISTRY}
    rows: dict = defaultdict(Counter)
    moved = []
    for c in cases:
        if c["replay"] is None:
            continue
        n, frame, tl, results, stopped, kind = pickle.loads(c["replay"])
        for r in results:  # the analyzers' keys as the code names them now
            r.reliability_keys = keys.get(r.analyzer, ())
        v, dec = decide(n, frame, timeline=tl, results=results, stopped=stopped, kind=kind)
        # the recorded results re-decided (the collecting code's statuses; uncertain verdicts name their motor now)
        _, _, _, rec_results, _, _ = pickle.loads(c.get("replay_recorded", c["replay"]))
        for r in rec_results:
            r.reliability_keys = keys.get(r.analyzer, ())
        was, _ = decide(n, frame, timeline=tl, results=rec_results, stopped=stopped, kind=kind)
        prof = c["set"].split(" | ")[1].split(" ")[-1] if " | " in c["set"] else "none"
        grp = c["group"] if c["truth"] <= 0 else ("damaged" if not c["set"].startswith("sim") else c["group"])
        r = rows[(c["set"].split(" | ")[0], prof, grp)]
        r["n"] += 1
        for tag, st, m in (("was", was.status, was.motor), ("now", v.status, v.motor)):
            r[f"{tag} {st[0]}"] += 1
            if c["truth"] > 0:
                r[f"{tag} right d"] += st == "damaged" and m == c["truth"]
                r[f"{tag} right u"] += st == "uncertain" and m == c["truth"]
        if c["truth"] > 0:
            r["model right"] += c["model_alone"] == ("damaged", c["truth"])
        elif c["truth"] == 0:
            r["model FA"] += c["model_alone"][0] == "damaged"
        if (was.status, was.motor) != (v.status, v.motor):
            by = {m.motor: m.llr_by_source for m in dec.motors} if dec is not None else {}
            k = v.motor or was.motor or (int(np.argmax([m.llr for m in dec.motors])) + 1 if dec and dec.motors else None)
            moved.append(f"  {c['set']}: {c['name']} (truth {c['truth']}): {was.status} {was.motor or ''} -> "
                         f"{v.status} {v.motor or ''}; motor {k}: "
                         + ", ".join(f"{s_} {x:+.1f}" for s_, x in (by.get(k) or {}).items()))

    def cell(r, tag):
        right = (f" ({r[tag + ' right d']}+{r[tag + ' right u']} right)" if (tag + " right d") in r else "")
        return f"{r[tag + ' h']}h {r[tag + ' u']}u {r[tag + ' d']}d" + right
    print(f"{'set':34s} {'profile':9s} {'group':10s} {'n':>4s}  {'as recorded':>24s}  {'now':>24s}  model alone")
    for (st, prof, grp), r in sorted(rows.items()):
        model = f"{r['model right']} right" if "model right" in r else f"{r['model FA']} called damaged"
        mark = " *" if cell(r, "was") != cell(r, "now") else ""
        print(f"{st[:34]:34s} {prof:9s} {grp[:10]:10s} {r['n']:4d}  {cell(r, 'was'):>24s}  {cell(r, 'now'):>24s}  "
              f"{model}{mark}")
    print("(right: damaged naming the motor + uncertain naming it)")
    if listing:
        print(f"\n{len(moved)} verdicts moved:")
        print("\n".join(moved))


# ------------------------------------------------------------------------------------ bars
#: The share of a rate class's simulated healthy flights (realistic imbalance) an uncertain bar may
#: let through: the reliability rule's for a trusted source (reliability.trust_level, 5 %).
BAR_HEALTHY_SHARE = 0.05


def bars(cases: list[dict]) -> None:
    """The uncertain bar per rate class without a profile (decision.evidence_bars: one bar for every
    rate, from the prior and the miss cost): the decision as the code makes it now on the cached cases; per rotor count,
    rate class and origin, the healthy flights' leading total LLR (largest over the motors, every
    source capped as the decision caps it), how many reach each bar from 2.0 to 3.5 nats, and how
    many damaged flights (simulated: eta <= 0.8; real: every damaged flight whose motor is known)
    lead with their damaged motor at it; then the lowest bar, in tenths, that at most
    BAR_HEALTHY_SHARE of the simulated healthy flights and none of the real ones reach. Figures only."""
    from flightlog_fd.analyzers import REGISTRY
    from flightlog_fd.analyzers.reliability import rate_class
    from flightlog_fd.decision import decide, evidence_bars

    keys = {a.id: tuple(a.reliability_keys) for a in REGISTRY}
    healthy, damaged, code_bar = defaultdict(list), defaultdict(list), {}
    for c in cases:
        if c["replay"] is None or c["profile_kind"] != "none" or c["truth"] < 0:
            continue
        n, frame, tl, results, stopped, kind = pickle.loads(c["replay"])
        if kind is None:
            continue
        for r in results:
            r.reliability_keys = keys.get(r.analyzer, ())
        _, dec = decide(n, frame, timeline=tl, results=results, stopped=stopped, kind=kind)
        if dec is None or not dec.motors:
            continue
        total = np.array([m.llr for m in dec.motors])
        key = ("quad" if n == 4 else "n-rotor", rate_class(kind.stream_hz),
               "sim" if c["set"].startswith("sim") else "real")
        code_bar[key[:2]] = evidence_bars(n)[0]
        if c["truth"] == 0:
            healthy[key].append(float(total.max()))
        elif key[2] == "real" or (c["eta"] is not None and c["eta"] <= VOTE_FIT_ETA + 1e-9):
            k = c["truth"] - 1
            damaged[key].append(float(total[k]) if int(np.argmax(total)) == k else -np.inf)
    grid = np.round(np.arange(2.0, 3.51, 0.1), 1)
    print(f"healthy flights reaching each bar / damaged flights leading with their motor at it (no profile)")
    print(f"{'rotors':8s} {'rate':10s} {'origin':6s} {'healthy':>8s} {'max':>6s}  " + " ".join(f"{b:>7.1f}" for b in grid))
    for key in sorted(set(healthy) | set(damaged)):
        h, d = np.array(healthy.get(key, [])), np.array(damaged.get(key, []))
        cells = " ".join(f"{int(np.sum(h >= b)):>3d}/{int(np.sum(d >= b)):<3d}" for b in grid)
        print(f"{key[0]:8s} {key[1]:10s} {key[2]:6s} {len(h):4d}/{len(d):<3d} {h.max() if len(h) else float('nan'):+6.1f}  {cells}")
    print(f"\nthe lowest bar (tenths) that <= {100 * BAR_HEALTHY_SHARE:.0f} % of the simulated healthy flights and no real one reach:")
    for rk in sorted(code_bar):
        hs, hr = np.array(healthy.get(rk + ("sim",), [])), np.array(healthy.get(rk + ("real",), []))
        if not len(hs):
            print(f"  {rk[0]} {rk[1]}: no simulated healthy flights   (code: {code_bar[rk]:g})")
            continue
        ok = [b for b in np.round(np.arange(0.0, 10.01, 0.1), 1)
              if np.sum(hs >= b) <= BAR_HEALTHY_SHARE * len(hs) and not np.sum(hr >= b)]
        print(f"  {rk[0]} {rk[1]}: {ok[0] if ok else '-'} ({len(hs)} simulated, {len(hr)} real healthy)   "
              f"(code: {code_bar[rk]:g})")


# ------------------------------------------------------------------------------------ votes
def _vote_flights(cases: list[dict]) -> list[dict]:
    """The flights without a profile whose model context was recorded and whose truth is known:
    rotor count, rate class, origin, truth, eta, the windows' probabilities and covered time."""
    from flightlog_fd.analyzers.reliability import PROPERTIES, LogKind

    out = []
    for c in cases:
        m = c.get("model_ctx")
        if " | " in c["set"] or m is None or c["kind"] is None or c["truth"] < 0 or not len(m["probs"]):
            continue
        kind = LogKind.from_dict(c["kind"])
        out.append({"rotors": kind.n_motors, "rate": PROPERTIES["rate"](kind), "origin": "sim" if c["set"].startswith("sim") else "real",
                    "truth": c["truth"], "eta": c.get("eta"), "probs": np.asarray(m["probs"], float),
                    "covered_s": m["covered_s"], "name": c["name"], "set": c["set"]})
    return out


def _tau_int(indicators: list[np.ndarray], max_lag: int = 15, continuous: bool = False) -> float:
    """Integrated autocorrelation time (windows) of series pooled over flights (0/1 vote indicators,
    or ``continuous`` ones): 1 + 2 sum of the mean autocorrelation up to its first non-positive lag (Sokal)."""
    acc, cnt = np.zeros(max_lag + 1), np.zeros(max_lag + 1)
    for x in indicators:
        x = x - x.mean()
        var = float(np.mean(x * x))
        if var < 1e-12:
            continue
        for lag in range(min(max_lag, len(x) - 1) + 1):
            acc[lag] += np.mean(x[:len(x) - lag] * x[lag:]) / var
            cnt[lag] += 1
    rho = acc / np.maximum(cnt, 1)
    tau = 1.0
    for lag in range(1, max_lag + 1):
        if rho[lag] <= 0 or cnt[lag] == 0:
            break
        tau += 2 * rho[lag]
    return tau


def _fit_vote_shares(k: np.ndarray, n: np.ndarray, mixture: bool) -> tuple:
    """Maximum-likelihood Beta (a, b) or two-Beta mixture (a1, b1, a2, b2, w) of the vote share,
    from k votes of n effective windows per motor (beta-binomial); a and b kept in [0.02, 500]."""
    from scipy.optimize import minimize

    from flightlog_fd.analyzers.model_votes import _log_beta_binomial

    lo, hi = np.log(0.02), np.log(500.0)

    def unpack(x):
        ab = tuple(np.exp(np.clip(x[:4 if mixture else 2], lo, hi)))
        return ab + (1 / (1 + np.exp(-x[4])),) if mixture else ab

    def nll(x):
        return -float(np.sum(_log_beta_binomial(k, n, unpack(x))))
    starts = ([[np.log(0.1), np.log(2), np.log(2), np.log(1), -3], [np.log(0.2), np.log(10), np.log(0.5), np.log(0.7), -1]]
              if mixture else [[np.log(0.3), np.log(3)], [np.log(1), np.log(1)]])
    best = min((minimize(nll, x0, method="Nelder-Mead", options={"maxiter": 6000, "xatol": 1e-5, "fatol": 1e-7})
                for x0 in starts), key=lambda r: r.fun)
    return tuple(round(float(v), 4) for v in unpack(best.x))


def _share_tail(params: tuple, x: float) -> float:
    from scipy.stats import beta

    if len(params) == 2:
        return float(beta.sf(x, *params))
    a1, b1, a2, b2, w = params
    return float((1 - w) * beta.sf(x, a1, b1) + w * beta.sf(x, a2, b2))


def _fit_flight_means(x: np.ndarray, se: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood mean and between-flight standard deviation of flight means ``x`` whose
    own (within-flight) standard errors are ``se``: x ~ N(mu, sqrt(sigma^2 + se^2))."""
    from scipy.optimize import minimize

    def nll(v):
        sd = np.hypot(np.exp(v[1]), se)
        return float(np.sum(0.5 * ((x - v[0]) / sd) ** 2 + np.log(sd)))
    r = minimize(nll, [float(np.mean(x)), np.log(max(float(np.std(x)), 0.05))], method="Nelder-Mead")
    return round(float(r.x[0]), 3), round(float(np.exp(r.x[1])), 3)


def votes() -> None:
    """The model's window votes without a profile, per rotor count and rate class: the figures
    behind model_votes' VOTE_DECORRELATION_S and QUAD_VOTE_SHARE_STATS, and the re-measure of the
    flight mean's levels (QUAD_VOTE_STATS, MODEL_DECORRELATION_S, MODEL_WINDOW_SIGMA) per rate
    class. Measured: the decorrelation time of a motor's vote indicator and of its window log
    ratio, and the log ratio's within-flight spread, on real and simulated flights (the larger of
    the two is used); then, per hypothesis on the real flights where MIN_MEASURED of more than one
    airframe are there, else
    on the fit sets (simfit, nrotorfit) pooled with them (damaged: eta <= VOTE_FIT_ETA), the flight
    mean's Gaussian levels and the vote share's beta-binomial; then, on the check sets (the table's
    own simulated flights, seeds 9100+, and the real ones), what each statistic alone says: the
    healthy flights' leading LLR against the decision's bars, and the damaged motor's LLR
    (eta <= 0.8 and 0.9 apart) - for the flight mean with the code's levels and the fitted ones,
    and for the vote share with the code's and the fitted figures. Figures only."""
    from flightlog_fd.analyzers import model_votes as mv
    from flightlog_fd.analyzers.reliability import MIN_MEASURED
    from flightlog_fd.decision import evidence_bars

    UNCERTAIN_LLR, DAMAGED_LLR = evidence_bars(4)  # the quad's bars under the stated prior
    from flightlog_fd.timeline import floored

    def flights(which):
        out = []
        for w in which:
            for f in _vote_flights(load_cases((w,), reweigh=False)):
                f["src"] = w
                out.append(f)
        return out
    fit, check = flights(("simfit", "real", "nrotorfit")), flights(("sim", "real", "nrotor"))
    every = list({(f["src"], f["set"], f["name"]): f for f in fit + check}.values())
    rates = ("low rate", "mid rate", "full rate")

    def ratios(f):
        q = floored(f["probs"])
        return np.log(q[:, 1:]) - np.log(q[:, :1])
    print("== decorrelation (flights with >= 25 windows; windows every 0.8 s) and within-flight spread, quads")
    dec_vote, dec_lr, sd_lr = {}, {}, {}
    for rate in rates:
        line = []
        for origin in ("real", "sim"):
            fl = [f for f in every if f["rate"] == rate and f["origin"] == origin and f["rotors"] == 4]
            long = [f for f in fl if len(f["probs"]) >= 25]
            if not long:
                continue
            tv = 0.8 * _tau_int([(np.argmax(f["probs"], axis=1) == k + 1).astype(float) for f in long for k in range(4)])
            tl = 0.8 * _tau_int([ratios(f)[:, k] for f in long for k in range(4)], continuous=True)
            sd = float(np.median([np.median(ratios(f).std(axis=0)) for f in fl]))
            dec_vote[rate], dec_lr[rate] = max(dec_vote.get(rate, 0), tv), max(dec_lr.get(rate, 0), tl)
            sd_lr[rate] = max(sd_lr.get(rate, 0), sd)
            line.append(f"{origin} {len(long)} flights: votes {tv:.1f} s, log ratio {tl:.1f} s; window sd {sd:.2f} "
                        f"({len(fl)} flights)")
        code = (f"code: votes {mv.VOTE_DECORRELATION_S.get(rate, '-')} s, log ratio {mv.MODEL_DECORRELATION_S} s, "
                f"window sd {mv.MODEL_WINDOW_SIGMA}")
        print(f"  {rate}: " + "; ".join(line) + f"   ({code})")

    def damaged_fit(f):
        return f["truth"] > 0 and f["eta"] is not None and f["eta"] <= VOTE_FIT_ETA + 1e-9

    def real_first(fl, keep):
        """The flights of one hypothesis: the real ones alone where MIN_MEASURED of them are there
        from more than one airframe (real logs are what the tool is judged on, and the model reads
        them unlike its own simulated flights), else the real ones pooled with the simulated fit set:
        one airframe's flights (px4_sih_dev's, perfectly balanced, are the only real damaged ones at
        full rate) miss how the model reads airframes with realistic imbalance."""
        chosen = [f for f in fl if keep(f)]
        real = [f for f in chosen if f["origin"] == "real"]
        airframes = {f["set"] for f in real}
        return (real, "real") if len(real) >= MIN_MEASURED and len(airframes) > 1 else (chosen, "real + sim")
    means_fitted, shares_fitted = {}, {}
    print(f"\n== fitted, quads, per hypothesis on the real flights where {MIN_MEASURED} of more than one airframe are there, else on "
          f"simfit + real (damaged: eta <= {VOTE_FIT_ETA}; within-flight terms as measured above)")
    for rate in rates:
        every_rate = [f for f in fit if f["rotors"] == 4 and f["rate"] == rate]
        hf, h_from = real_first(every_rate, lambda f: f["truth"] == 0)
        df, d_from = real_first(every_rate, damaged_fit)
        fl = hf + df
        se = {id(f): sd_lr[rate] / np.sqrt(max(f["covered_s"] / dec_lr[rate], 1.0)) for f in fl}
        h = [(x, se[id(f)]) for f in hf for x in mv.mean_log_ratio(f["probs"])]
        d = [(mv.mean_log_ratio(f["probs"])[f["truth"] - 1], se[id(f)]) for f in df]
        n_real = sum(f["origin"] == "real" for f in fl)
        if len(h) < 40 or len(d) < 10:
            print(f"  {rate}: too few ({len(h) // 4} healthy, {len(d)} damaged flights)")
            continue
        hm, hs = _fit_flight_means(*map(np.array, zip(*h)))
        dm, ds = _fit_flight_means(*map(np.array, zip(*d)))
        means_fitted[rate] = mv.VoteStats(hm, hs, dm, ds, mv.QUAD_VOTE_STATS.damage_shift, mv.QUAD_VOTE_STATS.shift_sigma)
        neff = {id(f): max(f["covered_s"] / dec_vote[rate], 1.0) for f in fl}
        hv = np.array([(mv.vote_shares(f["probs"])[k], neff[id(f)]) for f in hf for k in range(4)])
        dv = np.array([(mv.vote_shares(f["probs"])[f["truth"] - 1], neff[id(f)]) for f in df])
        ph = _fit_vote_shares(hv[:, 0] * hv[:, 1], hv[:, 1], mixture=True)
        pd = _fit_vote_shares(dv[:, 0] * dv[:, 1], dv[:, 1], mixture=False)
        shares_fitted[rate] = mv.VoteShareStats(ph, pd)
        print(f"  {rate}: {len(h) // 4} healthy flights ({h_from}) and {len(d)} damaged ({d_from}); {n_real} real in all")
        print(f"      flight mean: healthy {hm:+.3f} +- {hs:.3f}, damaged {dm:+.3f} +- {ds:.3f}")
        print(f"      vote share:  healthy {ph}, damaged {pd}; healthy share >= 0.5: measured "
              f"{np.mean(hv[:, 0] >= 0.5):.3f}, fitted {_share_tail(ph, 0.5):.3f}; >= 0.9: {np.mean(hv[:, 0] >= 0.9):.3f}, "
              f"{_share_tail(ph, 0.9):.3f}; damaged median {np.median(dv[:, 0]):.2f}")

    def stat_llrs(f, how):
        rate = f["rate"]
        if how == "mean, code":  # the real flights' levels (Erle healthy, SIH damage) at every rate
            return mv.model_llr(f["probs"], f["covered_s"])
        if how == "mean, fitted":
            st = means_fitted.get(rate) if f["rotors"] == 4 else None
            if st is None:
                return None
            within = sd_lr[rate] / np.sqrt(max(f["covered_s"] / dec_lr[rate], 1.0))
            x = mv.mean_log_ratio(f["probs"])
            return np.array([mv._gauss_logpdf(v, st.damaged_mean, float(np.hypot(st.damaged_sigma, within)))
                             - mv._gauss_logpdf(v, st.healthy_mean, float(np.hypot(st.healthy_sigma, within))) for v in x])
        st = (mv.vote_share_stats(f["rotors"], rate) if how == "share, code"
              else shares_fitted.get(rate) if f["rotors"] == 4 else None)
        if st is None:
            return None
        n = max(f["covered_s"] / (mv.VOTE_DECORRELATION_S.get(rate) or dec_vote[rate]), 1.0)
        k = mv.vote_shares(f["probs"]) * n
        return mv._log_beta_binomial(k, n, st.damaged) - mv._log_beta_binomial(k, n, st.healthy)
    print(f"\n== each statistic alone on the check sets: healthy flights' leading LLR (median, max, reaching "
          f"{UNCERTAIN_LLR:g} / {DAMAGED_LLR:g}); the damaged motor's LLR (p10 / median, reaching {UNCERTAIN_LLR:g} and leading)")
    for rotors in sorted({f["rotors"] for f in check}):
        for rate in rates:
            for origin in ("real", "sim"):
                fl = [f for f in check if f["rotors"] == rotors and f["rate"] == rate and f["origin"] == origin]
                if not fl:
                    continue
                print(f"  {rotors} rotors, {rate}, {origin}:")
                for how in ("mean, code", "mean, fitted", "share, code", "share, fitted"):
                    if stat_llrs(fl[0], how) is None:
                        continue
                    hl, dl = [], {"eta<=0.8": [], "eta 0.9": []}
                    for f in fl:
                        x = stat_llrs(f, how)
                        if f["truth"] == 0:
                            hl.append(float(np.max(x)))
                        else:
                            g = "eta 0.9" if (f["eta"] or 0) > 0.85 else "eta<=0.8"
                            dl[g].append((float(x[f["truth"] - 1]), int(np.argmax(x)) + 1 == f["truth"]))
                    h = np.array(hl)
                    part = (f"healthy {len(h)}: {np.median(h):+.1f}, {h.max():+.1f}, "
                            f"{int(np.sum(h >= UNCERTAIN_LLR))} / {int(np.sum(h >= DAMAGED_LLR))}" if len(h) else "")
                    for g, v in dl.items():
                        if v:
                            a_ = np.array([x for x, _ in v])
                            part += (f"; damaged {g} {len(v)}: {np.percentile(a_, 10):+.1f} / {np.median(a_):+.1f}, "
                                     f"{sum(1 for x, led in v if led and x >= UNCERTAIN_LLR)}")
                    print(f"      {how:14s} {part}")
    print("\n# fitted")
    for rate, st in means_fitted.items():
        print(f"  flight mean {rate!r}: VoteStats({st.healthy_mean}, {st.healthy_sigma}, {st.damaged_mean}, "
              f"{st.damaged_sigma}, ...)")
    for rate, st in shares_fitted.items():
        print(f"  vote share {rate!r}: VoteShareStats(healthy={st.healthy}, damaged={st.damaged})")


def trims(cases: list[dict]) -> None:
    """How unbalanced the healthy airframes are, real and simulated (the reliability table's cases
    without a profile): per origin and logging profile, the command shares' RMS deviation from an
    even split, the leading motor's excess over the mean of the others, and how far the trim looks
    like one rotor's loss (the cosine between the share pattern's roll/pitch/yaw part and the nearest
    single-rotor pattern's: 1 = exactly one weak rotor, 0.58 = a pure yaw trim); percentiles
    10 / 50 / 90 / max. The simulated airframes' draws: flightlog_fd/sim/imbalance.py."""
    rows: dict = defaultdict(list)
    for c in cases:
        if " | " in c["set"] or c["truth"] != 0 or not c["shares"] or c["replay"] is None:
            continue
        n, frame, *_ = pickle.loads(c["replay"])
        if frame is None or n != 4 or c["set"] == "px4_sih_dev":  # SIH: a perfectly balanced simulated airframe
            continue
        x = np.array([r.x for r in frame.rotors])
        y = np.array([r.y for r in frame.rotors])
        spin = np.array([r.spin for r in frame.rotors], float)
        moments = np.stack([np.ones(4), -y / np.abs(y).max(), x / np.abs(x).max(), spin]).T  # (4 motors, 4)
        o = np.array(c["shares"]) - 1.0
        m = np.linalg.lstsq(moments, o, rcond=None)[0][1:]
        singles = [np.linalg.lstsq(moments, np.eye(4)[k] - 0.25, rcond=None)[0][1:] for k in range(4)]
        align = max(float(m @ sk / np.linalg.norm(m) / np.linalg.norm(sk)) for sk in singles) if np.linalg.norm(m) else 0.0
        lead = max(o[k] - np.delete(o, k).mean() for k in range(4))
        key = "real" if not c["set"].startswith("sim") else "sim " + c["set"].split()[2]
        rows[key].append((float(np.sqrt(np.mean(o ** 2))), float(lead), align))
    print(f"{'airframes':22s} {'n':>3s}  {'RMS share deviation':>26s}  {'leading excess':>26s}  {'one-rotor likeness':>26s}")
    for key in ["real"] + sorted(k for k in rows if k != "real"):
        a = np.array(rows[key])
        cols = ["/".join(f"{v:.2f}" for v in np.percentile(a[:, j], [10, 50, 90, 100])) for j in range(3)]
        print(f"{key:22s} {len(a):3d}  {cols[0]:>26s}  {cols[1]:>26s}  {cols[2]:>26s}")
    allsim = np.array([r for k, v in rows.items() if k != "real" for r in v])
    if len(allsim):
        cols = ["/".join(f"{v:.2f}" for v in np.percentile(allsim[:, j], [10, 50, 90, 100])) for j in range(3)]
        print(f"{'sim, all':22s} {len(allsim):3d}  {cols[0]:>26s}  {cols[1]:>26s}  {cols[2]:>26s}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("collect", "table", "replay", "votes", "trims", "bars"))
    ap.add_argument("--list", action="store_true", help="replay: list every verdict that moved")
    ap.add_argument("--sets", default="real,sim,nrotor,esc")
    ap.add_argument("--sim-airframes", type=int, default=12)
    ap.add_argument("--profiles", action="append", default=[], help="folders holding adapted profiles")
    ap.add_argument("--write", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.what == "collect":
        with _recording_contexts():
            collect(args)
    elif args.what == "table":
        table(load_cases(args.sets.split(",")), args.write)
    elif args.what == "replay":
        replay(load_cases(args.sets.split(",")), args.list)
    elif args.what == "votes":
        votes()
    elif args.what == "bars":
        bars(load_cases(args.sets.split(",")))
    else:
        trims(load_cases(("real", "sim"), reweigh=False))


if __name__ == "__main__":
    main()
