"""Two damaged propellers: does the verdict name both, and does it keep one-propeller and healthy
flights what they are?

    python benchmarks/bench_two_props.py [--seeds 101 102] [--per-set 12] [--duration 60] [--real]
    python benchmarks/bench_two_props.py --measure          # the figures decision.py / model_votes.py cite
    python benchmarks/bench_two_props.py --esc --seeds 31   # with ESC telemetry (what esc.py's pair_keeps_order cites)

Simulated part: for each seed and logging profile (px4_high, ardupilot, px4_default: 10 Hz motor
outputs) and airframe set (random quads 30 g-5 kg, X and +, with realistic imbalance; and the
x500, f450 and sih presets with realistic imbalance), ``--per-set`` airframes, each flown three
times: healthy (the twin the profile is calibrated on, ``fdlog calibrate --no-adapt``), with two
damaged propellers (adjacent or opposite pair, each eta uniform in 0.6-0.85 where the airframe
flies on with both, sim.damage.random_pair_damages; in ``--onset-fraction`` of them the second
breaks 30-70 % into the flight) and with one (eta 0.6-0.85). Each is diagnosed without a profile
and with the twin's. Prints per condition: both propellers named (damaged naming both / uncertain
naming both), one of them named alone, another verdict; one-propeller flights named as a pair;
healthy flights not healthy. The model alone (majority of its windows' argmax) beside it.

``--real``: every real healthy flight in ../shared without a profile and with each one-flight
profile of its airframe's other flights (``--no-adapt``, the cross-session pairs), and the real
one-propeller damaged sets with their profiles: how many are named as pairs (must be 0 healthy
called damaged; pairs on one-propeller flights counted).

``--measure`` (seed 21, not a scoring seed): the model's votes on two-propeller flights
(model_votes.PAIR_VOTE_STATS) and the best pair's excess over the best single rotor on
one-propeller, healthy and two-propeller flights (decision.PAIR_EXCESS_LLR and _PROFILE_LLR).
Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
PROFILES = ("px4_high", "ardupilot", "px4_default")
AIRFRAME_SETS = ("random", "presets")
PRESETS = ("x500", "f450", "sih")


def _airframes(kind: str, n: int, rng):
    from flightlog_fd.sim.airframe import preset, random_airframes

    if kind == "random":
        return random_airframes(n, rng)
    return [preset(PRESETS[i % len(PRESETS)]) for i in range(n)]


def _pair_kind(af, motors) -> str:
    from flightlog_fd.sim.damage import rotor_pairs

    return "opposite" if tuple(sorted(motors)) in rotor_pairs(af, "opposite") else "adjacent"


def _model_alone(d) -> list[int]:
    labels = np.array([w.cls for w in d.windows])
    if labels.size == 0:
        return []
    k = int(np.bincount(labels, minlength=5).argmax())
    return [] if k == 0 else [k]


def _record(d, truth_motors, **extra) -> dict:
    from flightlog_fd.analyzers.model_votes import mean_log_ratio

    v = d.verdict
    dec = d.decision
    probs = np.array([w.probabilities for w in d.windows]) if d.windows else np.zeros((0, 5))
    top = dec.pairs[0] if dec is not None and dec.pairs else None
    true_pair = next((pd for pd in (dec.pairs if dec is not None else []) if sorted(pd.motors) == sorted(truth_motors)),
                     None)
    return dict(truth=list(truth_motors), status=v.status, motor=v.motor, motors=list(v.motors), pair=bool(v.pair),
                inspect=[int(k) for k in getattr(v, "inspect", ()) or ()],
                model_alone=_model_alone(d),
                single_best=None if dec is None or not dec.motors else max(m.llr for m in dec.motors),
                pair_best=None if top is None else top.llr, pair_motors=None if top is None else list(top.motors),
                pair_excess=None if top is None else top.excess,
                pair_sources=None if top is None else top.llr_by_source,
                true_pair_sources=None if true_pair is None else true_pair.llr_by_source,
                single_sources=None if dec is None else [m.llr_by_source for m in dec.motors],
                mlr=mean_log_ratio(probs).tolist() if len(probs) else None, **extra)


def simulate_set(seed: int, prof: str, kind: str, n: int, duration: float, onset_fraction: float):
    """Flights (healthy twins, two-propeller, one-propeller) of ``n`` airframes and their truths."""
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import PAIR_ETA_RANGE, Damage, min_feasible_eta, random_pair_damages
    from flightlog_fd.sim.imbalance import random_imbalances

    rng = np.random.default_rng([seed, AIRFRAME_SETS.index(kind)])
    afs = _airframes(kind, n, rng)
    imbs = random_imbalances(afs, rng)
    planned = np.full(n, duration)
    pairs = random_pair_damages(afs, rng, onset_fraction=onset_fraction, planned_s=planned)
    singles = []
    for af in afs:
        lo = min(max(PAIR_ETA_RANGE[0], min_feasible_eta(af)), PAIR_ETA_RANGE[1])
        singles.append(Damage(int(rng.integers(1, af.rotor_count + 1)), float(rng.uniform(lo, PAIR_ETA_RANGE[1]))))
    flights = simulate_flights(3 * n, airframes=afs * 3, imbalance=imbs * 3, damages=[Damage()] * n + pairs + singles,
                               duration_s=duration, profile=prof, seed=seed, midflight_fraction=0.0)
    return afs, flights[:n], flights[n:2 * n], flights[2 * n:]


def run_sim(seeds, per_set: int, duration: float, onset_fraction: float, cache: Path | None) -> list[dict]:
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    model = resolve_model()
    rows = []
    for seed in seeds:
        for prof in PROFILES:
            for kind in AIRFRAME_SETS:
                t0 = time.perf_counter()
                afs, healthy, pairs, singles = simulate_set(seed, prof, kind, per_set, duration, onset_fraction)
                for i, af in enumerate(afs):
                    try:
                        profile = calibrate([healthy[i]])
                    except Exception as e:  # noqa: BLE001  (a twin that cannot calibrate: no profile rows)
                        print(f"  {prof} {kind} #{i}: calibration refused: {e}")
                        profile = None
                    for what, fl in (("healthy", healthy[i]), ("pair", pairs[i]), ("single", singles[i])):
                        truth = fl.truth.get("motors") or []
                        if what == "pair" and len(truth) != 2:
                            continue  # an airframe too weak for two damaged propellers in the range
                        etas = fl.truth.get("etas") or []
                        onsets = fl.truth.get("onsets_s") or []
                        common = dict(seed=seed, log_profile=prof, airframes=kind, index=i, airframe=af.name,
                                      frame=af.frame,
                                      mass=round(af.mass, 3), flight=what, etas=etas,
                                      onset=any(o is not None for o in onsets),
                                      pair_kind=_pair_kind(af, truth) if len(truth) == 2 else "")
                        for pname, pr in (("no profile", None), ("profile", profile)):
                            if pname == "profile" and pr is None:
                                continue
                            d = diagnose_flight(fl, model, pr, keep_flight=False)
                            rows.append(_record(d, truth, profile=pname, **common))
                print(f"  seed {seed} {prof:11s} {kind:8s}: {len(afs)} airframes in {time.perf_counter() - t0:.0f} s",
                      flush=True)
    if cache is not None:
        cache.write_text(json.dumps(rows))
    return rows


def _both(r) -> bool:
    return sorted(r["motors"]) == sorted(r["truth"]) and r["pair"]


def _one_of(r) -> bool:
    """Not named as a pair, but a damaged or uncertain verdict naming (or sending the pilot to) one
    of the two damaged propellers."""
    named = set(r["motors"]) | set(r.get("inspect") or [])
    return r["status"] in ("damaged", "uncertain") and not r["pair"] and bool(named & set(r["truth"]))


def summary(rows: list[dict]) -> None:
    print("\n== two damaged propellers: both named (damaged / uncertain naming both) ==")
    print("  both: the verdict names both (dmg: damaged, unc: uncertain); one: it names one of them alone;\n"
          "  >=1: both or one; the model alone (its windows' majority) can name one at most")
    print(f"  {'condition':44s} {'n':>4s} {'both':>6s} {'dmg':>4s} {'unc':>4s} {'one':>4s} {'other':>5s} "
          f"{'>=1':>5s} {'model alone':>11s}")

    def line(label, rs):
        if not rs:
            return
        both = [r for r in rs if _both(r)]
        dmg = sum(r["status"] == "damaged" for r in both)
        one = sum(_one_of(r) for r in rs)
        alone = sum(bool(set(r["model_alone"]) & set(r["truth"])) for r in rs)
        print(f"  {label:44s} {len(rs):4d} {100 * len(both) / len(rs):5.0f}% {dmg:4d} {len(both) - dmg:4d} {one:4d} "
              f"{len(rs) - len(both) - one:5d} {len(both) + one:5d} {alone:11d}")

    pairs = [r for r in rows if r["flight"] == "pair"]
    for pname in ("no profile", "profile"):
        sel = [r for r in pairs if r["profile"] == pname]
        line(f"{pname}: all", sel)
        line(f"{pname}: both from take-off", [r for r in sel if not r["onset"]])
        for key, vals in (("log_profile", PROFILES), ("airframes", AIRFRAME_SETS), ("pair_kind", ("adjacent", "opposite"))):
            for v in vals:
                line(f"{pname}: {key} {v}", [r for r in sel if r[key] == v])
        line(f"{pname}: second propeller mid-flight", [r for r in sel if r["onset"]])
        line(f"{pname}: the weaker propeller eta < 0.7", [r for r in sel if min(r["etas"]) < 0.7])
        line(f"{pname}: the weaker propeller eta 0.7-0.8", [r for r in sel if 0.7 <= min(r["etas"]) < 0.8])
        line(f"{pname}: the weaker propeller eta >= 0.8", [r for r in sel if min(r["etas"]) >= 0.8])
        line(f"{pname}: the stronger propeller eta >= 0.8", [r for r in sel if max(r["etas"]) >= 0.8])
    print("\n== one damaged propeller: named as a pair / right motor / verdicts ==")
    for pname in ("no profile", "profile"):
        sel = [r for r in rows if r["flight"] == "single" and r["profile"] == pname]
        if not sel:
            continue
        as_pair = sum(r["pair"] for r in sel)
        right = sum(r["status"] == "damaged" and r["motor"] == r["truth"][0] and not r["pair"] for r in sel)
        c = Counter(r["status"] for r in sel)
        print(f"  {pname:11s}: {len(sel)} flights, named as a pair {as_pair} ({100 * as_pair / len(sel):.1f} %), "
              f"damaged naming the right motor alone {right}, verdicts {dict(c)}")
    print("\n== healthy twins ==")
    for pname in ("no profile", "profile"):
        sel = [r for r in rows if r["flight"] == "healthy" and r["profile"] == pname]
        if sel:
            c = Counter(r["status"] for r in sel)
            print(f"  {pname:11s}: {len(sel)} flights, {dict(c)}, named as a pair {sum(r['pair'] for r in sel)}")


def measure(args) -> None:
    """The figures the constants cite (seed 21)."""
    if args.summary and args.cache is not None and args.cache.exists():
        rows = json.loads(args.cache.read_text())
    else:
        rows = run_sim([21], args.per_set, args.duration, 0.0, args.cache)
    within = 0.9 / np.sqrt(args.duration / 3.6)  # model_votes.MODEL_WINDOW_SIGMA over the flight
    by = defaultdict(dict)
    for r in rows:
        by[(r["log_profile"], r["airframes"], r["index"], r["profile"])][r["flight"]] = r
    print("\n== the model's flight-mean window log ratio, no profile (model_votes.PAIR_VOTE_STATS) ==")
    stats = defaultdict(list)
    for key, d in by.items():
        if key[-1] != "no profile" or "healthy" not in d or not d["healthy"]["mlr"]:
            continue
        h = d["healthy"]["mlr"]
        stats["healthy, every motor"] += h
        if "single" in d and d["single"]["mlr"]:
            k = d["single"]["truth"][0] - 1
            stats["one propeller: the damaged motor"].append(d["single"]["mlr"][k])
            stats["one propeller: against its twin"].append(d["single"]["mlr"][k] - h[k])
        if "pair" in d and d["pair"]["mlr"]:
            m = d["pair"]["mlr"]
            a, b = (k - 1 for k in d["pair"]["truth"])
            hi, lo = (a, b) if m[a] - h[a] >= m[b] - h[b] else (b, a)
            stats["pair: more-voted member"].append(max(m[a], m[b]))
            stats["pair: other member"].append(min(m[a], m[b]))
            stats["pair: more-voted member against its twin"].append(m[hi] - h[hi])
            stats["pair: other member against its twin"].append(m[lo] - h[lo])
    for name, x in stats.items():
        x = np.array(x)
        sd = x.std(ddof=1)
        print(f"  {name:42s} n={len(x):3d} mean {x.mean():+.2f} sd {sd:.2f} (between flights "
              f"{np.sqrt(max(sd ** 2 - within ** 2, 0)):.2f})")
    print("\n== best pair's total minus the best single rotor's (decision.PAIR_EXCESS_LLR, _PROFILE_LLR) ==")
    for pname in ("no profile", "profile"):
        for what in ("healthy", "single", "pair"):
            x = np.array([r["pair_excess"] for r in rows if r["profile"] == pname and r["flight"] == what
                          and r["pair_excess"] is not None])
            if len(x):
                print(f"  {pname:11s} {what:8s} n={len(x):3d} pct 50/90/95/99/max "
                      f"{np.round(np.percentile(x, [50, 90, 95, 99, 100]), 2)}")


def run_real(args) -> None:
    """Real flights of ../shared (bench_cross_session.py's sets): every healthy flight without a
    profile and against each one-flight ``--no-adapt`` profile of its airframe's other healthy
    flights, and every one-propeller damaged flight without a profile and against each of those
    profiles: verdicts, pairs named, and the best pair's excess over the best single rotor."""
    import sys

    from flightlog_fd import load_flight
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    if not SHARED.is_dir():
        print("skipped --real: ../shared is not present")
        return
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_cross_session import airframes, no_profile_sets

    model = resolve_model()
    flights: dict = {}

    def flight(path):
        if path not in flights:
            flights[path] = load_flight(path)
        return flights[path]

    def diag(path, profile):
        return diagnose_flight(flight(path), model, profile, keep_flight=False)

    def report(label, ds):
        c = Counter(d.verdict.status for d in ds)
        pairs = sum(d.verdict.pair for d in ds)
        ex = [d.decision.pairs[0].excess for d in ds if d.decision is not None and d.decision.pairs]
        exs = f"max {max(ex):+.1f}, 95th pct {np.percentile(ex, 95):+.1f}" if ex else "-"
        print(f"  {label:46s} {len(ds):4d} flights {dict(c)}; named as a pair {pairs}; pair excess {exs}", flush=True)

    print("\n== real flights: verdicts, pairs named, the best pair's excess over the best single rotor ==")
    for name, cases in no_profile_sets():
        report(f"{name}, no profile: healthy", [diag(p, None) for p, t, _ in cases if t == -1])
        dmg = [diag(p, None) for p, t, _ in cases if t != -1]
        if dmg:
            report(f"{name}, no profile: one propeller", dmg)
    for af in airframes():
        healthy, damaged = [], []
        for cal in af.healthy:
            try:
                prof = calibrate([flight(cal)])
            except Exception as e:  # noqa: BLE001  (a refused calibration is no pair)
                print(f"  {af.name}: calibration on {cal.name} refused: {e}")
                continue
            healthy += [diag(p, prof) for p in af.healthy if p != cal]
            damaged += [diag(p, prof) for p, _, _ in af.damaged]
        report(f"{af.name}, one-flight profiles: healthy pairs", healthy)
        if damaged:
            report(f"{af.name}, one-flight profiles: one propeller", damaged)


ESC_RATES = (("px4_default", 50.0), ("ardupilot", 10.0), ("px4_high", 100.0))


def run_esc(seeds, per_set: int, duration: float) -> None:
    """``--esc``: random quads with ESC telemetry (50 / 10 / 100 Hz at the px4_default / ardupilot /
    px4_high logging profiles), ``per_set`` each, healthy, two propellers and one (eta 0.6-0.85,
    eta_torque = eta^k as sim/damage.py TORQUE_EXPONENT_RANGE), no profile: the ESC analyzer's
    per-motor LLRs before the cap (the second-largest on one-propeller and healthy flights, the
    weaker member's on two-propeller ones) and the verdicts."""
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import (PAIR_ETA_RANGE, TORQUE_EXPONENT_RANGE, Damage, min_feasible_eta,
                                         random_pair_damages)
    from flightlog_fd.sim.imbalance import random_imbalances

    model = resolve_model()
    rows = []
    for seed in seeds:
        for prof, rate in ESC_RATES:
            rng = np.random.default_rng([seed, int(rate)])
            afs = random_airframes(per_set, rng)
            imbs = random_imbalances(afs, rng)
            pairs = random_pair_damages(afs, rng, torque_exponent_range=TORQUE_EXPONENT_RANGE)
            singles = []
            for af in afs:
                lo = min(max(PAIR_ETA_RANGE[0], min_feasible_eta(af)), PAIR_ETA_RANGE[1])
                e = float(rng.uniform(lo, PAIR_ETA_RANGE[1]))
                singles.append(Damage(int(rng.integers(1, 5)), e, None, float(e ** rng.uniform(*TORQUE_EXPONENT_RANGE))))
            flights = simulate_flights(3 * per_set, airframes=afs * 3, imbalance=imbs * 3,
                                       damages=[Damage()] * per_set + pairs + singles, duration_s=duration,
                                       profile=prof, seed=seed, midflight_fraction=0.0, esc=rate)
            for i, fl in enumerate(flights):
                what = ("healthy", "pair", "single")[i // per_set]
                truth = fl.truth.get("motors") or []
                if what == "pair" and len(truth) != 2:
                    continue
                d = diagnose_flight(fl, model, None, keep_flight=False)
                esc = next((r for r in d.decision.results if r.analyzer == "esc"), None)
                raw = None if esc is None else esc.raw_llr(4)
                v = d.verdict
                rows.append(dict(what=what, truth=truth, raw=None if raw is None else raw.tolist(), status=v.status,
                                 motors=list(v.motors), pair=bool(v.pair),
                                 excess=d.decision.pairs[0].excess if d.decision.pairs else None))
            print(f"  seed {seed} {prof:11s} ESC {rate:3.0f} Hz: {per_set} airframes", flush=True)
    print("\n== with ESC telemetry, no profile ==")
    for what in ("healthy", "single", "pair"):
        rs = [r for r in rows if r["what"] == what and r["raw"] is not None]
        if not rs:
            continue
        second = [float(np.sort(r["raw"])[-2]) for r in rs]
        ex = [r["excess"] for r in rs if r["excess"] is not None]
        line = f"  {what:8s} {len(rs):3d} flights, verdicts {dict(Counter((r['status'], r['pair']) for r in rs))}"
        if ex:
            line += f"; best pair's excess max {max(ex):+.2f}"
        if what == "pair":
            weaker = [min(r["raw"][r["truth"][0] - 1], r["raw"][r["truth"][1] - 1]) for r in rs]
            both = sum(r["pair"] and sorted(r["motors"]) == sorted(r["truth"]) for r in rs)
            one = sum(not r["pair"] and r["status"] in ("damaged", "uncertain") and bool(set(r["motors"]) & set(r["truth"]))
                      for r in rs)
            line += (f"; both named {both} ({100 * both / len(rs):.0f} %), one {one}; the weaker member's ESC LLR "
                     f"10/50 % {np.percentile(weaker, 10):+.1f} / {np.percentile(weaker, 50):+.1f}")
        else:
            line += (f"; named as a pair {sum(r['pair'] for r in rs)}; second-largest ESC LLR 50/90 %/max "
                     f"{np.percentile(second, 50):+.1f} / {np.percentile(second, 90):+.1f} / {max(second):+.1f}")
        print(line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[101, 102])
    ap.add_argument("--per-set", type=int, default=12)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--onset-fraction", type=float, default=0.25)
    ap.add_argument("--measure", action="store_true")
    ap.add_argument("--real", action="store_true", help="also the real flights of ../shared")
    ap.add_argument("--skip-sim", action="store_true")
    ap.add_argument("--cache", type=Path, default=None, help="write (or with --summary read) the rows here")
    ap.add_argument("--summary", action="store_true", help="summarise --cache without simulating")
    ap.add_argument("--esc", action="store_true", help="instead: random quads with ESC telemetry, no profile")
    args = ap.parse_args()
    if args.esc:
        run_esc(args.seeds, args.per_set, args.duration)
        return
    if args.measure:
        measure(args)
        return
    if args.summary and args.cache is not None:
        summary(json.loads(args.cache.read_text()))
        return
    if not args.skip_sim:
        summary(run_sim(args.seeds, args.per_set, args.duration, args.onset_fraction, args.cache))
    if args.real:
        run_real(args)


if __name__ == "__main__":
    main()
