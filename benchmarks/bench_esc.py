"""ESC analyzer on simulated flights: does it name the damaged motor, and stay quiet on healthy ones?

Flights (60 s waypoint missions, random airframes 30 g-5 kg with realistic imbalance and motor KV
spread, ESC telemetry at 10 Hz (ArduPilot logging profile) and 50 Hz (PX4 default profile)):

- damaged: η ∈ {0.6, 0.7, 0.8, 0.9} from take-off, a random motor, η_torque = η^k with k ~ U(1.0, 1.6)
  (sim/damage.py TORQUE_EXPONENT_RANGE), airframes that can fly that η; scored without a profile
  and against an EscBaseline fitted on a healthy flight of the same airframe, motors and ESCs;
- healthy;
- trim-changed pairs: a calibration flight, then the same airframe, motors and ESCs with the centre
  of mass moved (up to 10 % of the arm) or the motors' yaw trim changed (tilt ±1°): scored without
  a profile and against an EscBaseline fitted on the calibration flight.

Prints: share of damaged flights where :meth:`EscAnalysis.motor_named` is the damaged motor (no
profile; target >= 95 % for η <= 0.9), false alarms on healthy and trim-changed flights (target 0).
``--measure`` also prints what sets the analyzer's constants (healthy spread of the offsets,
largest healthy llr, damage direction), on seeds of its own. Bounded: ~2-4 min on one core
(``--per-cell`` flights per (η, rate) cell, default 12).

``--verdicts`` also prints the fused verdict of `diagnose_flight` (shipped model, no profile) on
the same damaged and healthy flights, with their ESC telemetry and without it: what a pilot would
read, all analyzers together (results/no_profile_simulated_healthy.md: ``--verdicts --seed 4242
--per-cell 10 --verdict-healthy 100``).

``--causes`` (instead of the above) measures how well the cause of a rotor's lost thrust is told
apart (:mod:`flightlog_fd.cause`): damaged propellers (η_torque = η^k as above) and weak motors /
ESCs (sim/damage.py cause "motor") at η 0.6-0.9, ESC telemetry at 10, 50 and 100 Hz (the logging
profiles ardupilot, px4_default and ardupilot: RCOU 10 Hz with ESC at 100 Hz is ArduCopter's with
ESC telemetry), random airframes 30 g-5 kg with realistic imbalance and KV spread; per cell the ESC
analyzer's cause LLR on the true rotor (right / wrong / undecided at cause.CAUSE_LLR) and the fused
verdict (diagnose_flight, shipped model, no profile): right rotor named, with the right cause /
the wrong one / none; the same flights without ESC telemetry (the cause must stay unknown); healthy
flights (no cause may be given); and a sweep of the cause threshold.

    python benchmarks/bench_esc.py [--per-cell N] [--seed S] [--measure] [--verdicts [--verdict-healthy N]]
    python benchmarks/bench_esc.py --causes [--per-cell N] [--seed S]
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from flightlog_fd.analyzers.esc import DECISION_LLR, analyze_esc, fit_esc_baseline, measure_esc
from flightlog_fd.sim.airframe import random_airframes
from flightlog_fd.sim.api import simulate_flights
from flightlog_fd.sim.damage import TORQUE_EXPONENT_RANGE, Damage, min_feasible_eta
from flightlog_fd.sim.esc import random_esc_params
from flightlog_fd.sim.imbalance import random_imbalances

ETAS = (0.6, 0.7, 0.8, 0.9)
RATES = {10.0: "ardupilot", 50.0: "px4_default"}
DURATION_S = 60.0
#: CoG moves / yaw-trim changes applied after calibration (fraction of arm / degrees of tilt).
COG_CHANGE = (0.04, 0.10)
TILT_CHANGE_DEG = (0.5, 1.0)


def airframes_for(n: int, eta: float, rng: np.random.Generator):
    out = []
    while len(out) < n:
        out += [af for af in random_airframes(4 * n, rng) if min_feasible_eta(af) <= eta]
    return out[:n]


def fly(afs, damages, rate, seed, imbalances=None, escs=None):
    return simulate_flights(len(afs), airframes=afs, damages=damages, duration_s=DURATION_S,
                            profile=RATES[rate], seed=seed, esc=escs if escs is not None else rate,
                            imbalance=imbalances if imbalances is not None else "random",
                            healthy_fraction=0.0)


def damaged_set(eta: float, rate: float, n: int, seed: int):
    """(healthy calibration flight, damaged flight) of the same airframe, motors and ESCs."""
    rng = np.random.default_rng([seed, int(eta * 100), int(rate)])
    afs = airframes_for(n, eta, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate) for af in afs]
    dmg = [Damage(int(rng.integers(1, 5)), eta, None, float(eta ** rng.uniform(*TORQUE_EXPONENT_RANGE)))
           for _ in afs]
    s = seed + int(eta * 100) + int(rate)
    return list(zip(fly(afs, [Damage()] * n, rate, s + 5, imbs, escs), fly(afs, dmg, rate, s, imbs, escs)))


def healthy_set(rate: float, n: int, seed: int):
    rng = np.random.default_rng([seed, 1, int(rate)])
    afs = random_airframes(n, rng)
    return fly(afs, [Damage()] * n, rate, seed + 1 + int(rate))


def trim_pairs(rate: float, n: int, seed: int):
    """(calibration flight, changed flight, what changed) for n airframes, half CoG, half yaw trim."""
    rng = np.random.default_rng([seed, 2, int(rate)])
    afs = random_airframes(n, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate) for af in afs]
    changed, what = [], []
    for i, imb in enumerate(imbs):
        if i % 2 == 0:
            ang = rng.uniform(-np.pi, np.pi)
            c = rng.uniform(*COG_CHANGE)
            changed.append(replace(imb, cog_offset=(imb.cog_offset[0] + c * np.cos(ang),
                                                    imb.cog_offset[1] + c * np.sin(ang))))
            what.append(f"CoG moved {c:.0%} of arm")
        else:
            d = np.radians(rng.uniform(*TILT_CHANGE_DEG)) * rng.choice([-1, 1])
            changed.append(replace(imb, motor_tilt_rad=tuple(t + d for t in imb.motor_tilt_rad)))
            what.append(f"yaw trim: tilt {np.degrees(d):+.1f} deg")
    calib = fly(afs, [Damage()] * n, rate, seed + 3, imbs, escs)
    after = fly(afs, [Damage()] * n, rate, seed + 4, changed, escs)
    return list(zip(calib, after, what))


def run(per_cell: int, seed: int, measure: bool, verdicts: bool = False, verdict_healthy: int = 0) -> None:
    t0 = time.time()
    print(f"ESC analyzer, simulated flights ({DURATION_S:.0f} s waypoints, random airframes, realistic "
          f"imbalance); decision llr > {DECISION_LLR:g} nats, no profile unless said")
    print(f"{'eta':>5} {'ESC Hz':>7} {'right motor':>12} {'wrong motor':>12} {'nothing':>8} {'abstained':>9}"
          f"   {'with profile: right':>20}")
    damaged_llr_ratio, total_ok, total_n, profile_ok = [], 0, 0, {}
    sweep_damaged: dict[float, list[float]] = {}  # per eta: the right motor's llr when it is the largest, else 0
    for eta in ETAS:
        for rate in RATES:
            pairs = damaged_set(eta, rate, per_cell, seed)
            fl = [f for _, f in pairs]
            right = wrong = none = abst = right_p = 0
            for calib, f in pairs:
                right_p += analyze_esc(f, fit_esc_baseline([calib])).motor_named() == f.truth["motor"]
                a = analyze_esc(f)
                if a.abstain:
                    abst += 1
                    continue
                k = f.truth["motor"]
                sweep_damaged.setdefault(eta, []).append(a.llr[k] if max(a.llr, key=a.llr.get) == k else 0.0)
                named = a.motor_named()
                k = f.truth["motor"]
                if named == k:
                    right += 1
                elif named is None:
                    none += 1
                else:
                    wrong += 1
                if measure:
                    m, _ = measure_esc(f)
                    damaged_llr_ratio.append((m.r[k - 1, 0], m.r[k - 1, 1], eta, f.truth["eta_torque"]))
            total_ok += right
            total_n += len(fl)
            profile_ok[eta] = profile_ok.get(eta, 0) + right_p
            print(f"{eta:5.2f} {rate:7.0f} {right / len(fl):11.0%} {wrong:12d} {none:8d} {abst:9d}"
                  f"   {right_p / len(fl):20.0%}")
    print(f"damaged flights, right motor named without a profile: {total_ok}/{total_n} = {total_ok / total_n:.1%}")
    print("with a profile fitted on one healthy flight of the same airframe: "
          + ", ".join(f"eta {e:g} {profile_ok[e] / (len(RATES) * per_cell):.0%}" for e in ETAS))

    healthy_llr, offsets = [], []
    fa_h = n_h = 0
    for rate in RATES:
        for f in healthy_set(rate, 2 * per_cell, seed):
            a = analyze_esc(f)
            if a.abstain:
                continue
            n_h += 1
            fa_h += a.motor_named() is not None
            healthy_llr.append(max(a.llr.values()))
            if measure:
                m, _ = measure_esc(f)
                offsets.append(m.r)
    fa_t = fa_tp = n_t = 0
    trim_llr, trim_llr_p, trim_dev = [], [], []
    for rate in RATES:
        for calib, after, what in trim_pairs(rate, per_cell, seed):
            a = analyze_esc(after)
            try:
                base = fit_esc_baseline([calib])
            except ValueError:
                continue
            ap = analyze_esc(after, base)
            if a.abstain or ap.abstain:
                continue
            n_t += 1
            fa_t += a.motor_named() is not None
            fa_tp += ap.motor_named() is not None
            trim_llr.append(max(a.llr.values()))
            trim_llr_p.append(max(ap.llr.values()))
            if measure:
                mc, _ = measure_esc(calib)
                ma, _ = measure_esc(after)
                trim_dev.append(ma.r - mc.r)
    print(f"healthy flights, false alarms: {fa_h}/{n_h} (largest llr {max(healthy_llr):.1f} nats)")
    print(f"trim changed after calibration (CoG / yaw trim), false alarms without profile: {fa_t}/{n_t} "
          f"(largest llr {max(trim_llr):.1f}), against the calibration flight's baseline: {fa_tp}/{n_t} "
          f"(largest llr {max(trim_llr_p):.1f})")
    thresholds = (4.0, 6.0, 8.0, 10.0, 12.0, 15.0)
    print("\nllr threshold sweep (no profile): right motor named per eta / false alarms on healthy + trim-changed")
    print(f"{'llr >':>6} " + " ".join(f"{'eta ' + format(e, 'g'):>8}" for e in ETAS) + f" {'false alarms':>13}")
    quiet = np.array(healthy_llr + trim_llr)
    for th in thresholds:
        print(f"{th:6.1f} " + " ".join(f"{np.mean(np.array(sweep_damaged[e]) > th):8.0%}" for e in ETAS)
              + f" {int(np.sum(quiet > th)):6d}/{quiet.size}")
    if measure:
        o = np.concatenate(offsets)  # (flights*motors, 2)
        print("\n--measure: healthy offsets against the other motors (natural log):")
        print(f"  std a {o[:, 0].std():.4f}  d {o[:, 1].std():.4f}  corr {np.corrcoef(o.T)[0, 1]:+.2f}  "
              f"(n = {o.shape[0]} motors)")
        dv = np.concatenate(trim_dev)
        print(f"  same airframe, trim changed: flight-to-flight std a {dv[:, 0].std():.4f}  d {dv[:, 1].std():.4f}")
        d = np.array(damaged_llr_ratio)
        loss = -np.log(d[:, 3])
        print(f"  damaged motor: a / torque loss median {np.median(d[:, 0] / loss):.3f}, "
              f"d / torque loss median {np.median(d[:, 1] / loss):.3f}")
        print(f"  largest healthy llr {max(healthy_llr + trim_llr):.2f} nats; p99 "
              f"{np.percentile(healthy_llr + trim_llr, 99):.2f}")
        mo = []
        for eta in ETAS:
            for rate in RATES:
                for f in cause_set("motor", eta, rate, max(2, per_cell // 2), seed + 7):
                    m, _ = measure_esc(f)
                    if m is not None:
                        k = f.truth["motor"]
                        mo.append(m.r[k - 1] / -np.log(eta))
        mo = np.array(mo)
        print(f"  weak motor / ESC (MOTOR_DIRECTION): a / loss median {np.median(mo[:, 0]):.3f} "
              f"(10-90 % {np.percentile(mo[:, 0], 10):.3f}..{np.percentile(mo[:, 0], 90):.3f}), d / loss median "
              f"{np.nanmedian(mo[:, 1]):.3f}, {len(mo)} flights")
    if verdicts:
        fused_verdicts(per_cell, seed, verdict_healthy or 2 * per_cell)
    print(f"({time.time() - t0:.0f} s)")


def fused_verdicts(per_cell: int, seed: int, healthy_per_rate: int) -> None:
    """The flight verdicts (no profile) on this run's damaged flights and ``healthy_per_rate``
    healthy flights per ESC rate, each with its ESC telemetry and again without it (most logs
    have none)."""
    from collections import Counter

    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    model = resolve_model()

    def verdict(f, with_esc: bool):
        return diagnose_flight(f if with_esc else replace(f, esc=None), model, keep_flight=False).verdict
    print("\nfused verdict (diagnose_flight, shipped model, no profile): right / wrong motor / uncertain / healthy")
    for eta in ETAS:
        c = {True: Counter(), False: Counter()}
        for rate in RATES:
            for _, f in damaged_set(eta, rate, per_cell, seed):
                for with_esc in (True, False):
                    v = verdict(f, with_esc)
                    c[with_esc]["right" if v.status == "damaged" and v.motor == f.truth["motor"]
                                else "wrong" if v.status == "damaged" else v.status] += 1
        print("  " + "   ".join(f"eta {eta:g} {'with' if w else 'without'} ESC: {c[w]['right']} / {c[w]['wrong']} / "
                                f"{c[w]['uncertain']} / {c[w]['healthy']}" for w in (True, False)))
    c = {True: Counter(), False: Counter()}
    for rate in RATES:
        for f in healthy_set(rate, healthy_per_rate, seed):
            for with_esc in (True, False):
                c[with_esc][verdict(f, with_esc).status] += 1
    for w in (True, False):
        print(f"  healthy {'with' if w else 'without'} ESC: damaged {c[w]['damaged']} / uncertain {c[w]['uncertain']} "
              f"/ healthy {c[w]['healthy']}")


#: ESC telemetry rate (Hz) -> logging profile, for --causes.
CAUSE_RATES = {10.0: "ardupilot", 50.0: "px4_default", 100.0: "ardupilot"}


def cause_set(cause: str, eta: float, rate: float, n: int, seed: int, profile: str | None = None):
    """n flights of random airframes that fly ``eta``, rotor k's thrust lost to ``cause``
    ("propeller": η_torque = η^k, k ~ TORQUE_EXPONENT_RANGE; "motor": a weak motor or ESC)."""
    rng = np.random.default_rng([seed, int(eta * 100), int(rate), 0 if cause == "propeller" else 1])
    afs = airframes_for(n, eta, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate) for af in afs]
    dmg = [Damage(int(rng.integers(1, 5)), eta, None,
                  float(eta ** rng.uniform(*TORQUE_EXPONENT_RANGE)) if cause == "propeller" else None, cause=cause)
           for _ in afs]
    return simulate_flights(n, airframes=afs, damages=dmg, duration_s=DURATION_S,
                            profile=profile or CAUSE_RATES.get(rate, "ardupilot"),
                            seed=seed + int(eta * 100) + int(rate) + (0 if cause == "propeller" else 500),
                            esc=escs, imbalance=imbs, healthy_fraction=0.0)


def run_causes(per_cell: int, seed: int) -> None:
    """--causes: how well the cause of a rotor's lost thrust is told apart (module docstring)."""
    from collections import Counter

    from flightlog_fd.cause import CAUSE_LLR
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    t0 = time.time()
    model = resolve_model()
    truth_word = {"propeller": "propeller", "motor": "motor_or_esc"}
    print(f"Cause of a rotor's lost thrust (propeller or motor / ESC), simulated {DURATION_S:.0f} s flights, "
          f"random airframes, {per_cell} per cell, seed {seed}; cause stated at |LLR| >= {CAUSE_LLR:g} nats")
    print(f"{'cause':>10} {'eta':>5} {'ESC Hz':>6} | {'ESC alone: right':>16} {'wrong':>5} {'none':>4} | "
          f"{'verdict: rotor named':>20} {'right cause':>11} {'wrong':>5} {'none':>4} | {'no ESC: cause':>13}")
    llrs: dict[str, list[float]] = {"propeller": [], "motor": []}
    totals = Counter()
    for cause in ("propeller", "motor"):
        for eta in ETAS:
            for rate in CAUSE_RATES:
                c = Counter()
                for f in cause_set(cause, eta, rate, per_cell, seed):
                    k, want = f.truth["motor"], truth_word[cause]
                    a = analyze_esc(f)
                    llr = a.cause_llr.get(k) if not a.abstain else None
                    if llr is not None:
                        llrs[cause].append(llr if cause == "motor" else -llr)  # positive: toward the truth
                        said = "motor_or_esc" if llr >= CAUSE_LLR else "propeller" if llr <= -CAUSE_LLR else None
                        c["esc " + ("right" if said == want else "none" if said is None else "wrong")] += 1
                    else:
                        c["esc none"] += 1
                    v = diagnose_flight(f, model, keep_flight=False).verdict
                    named = v.cause_evidence is not None and v.cause_evidence["motor"] == k
                    c["named"] += named
                    if named:
                        c["v " + ("right" if v.cause == want else "none" if v.cause is None else "wrong")] += 1
                    nv = diagnose_flight(replace(f, esc=None), model, keep_flight=False).verdict
                    c["no esc cause"] += nv.cause is not None
                totals.update({f"{cause} {key}": val for key, val in c.items()})
                totals[f"{cause} n"] += per_cell
                print(f"{cause:>10} {eta:5.2f} {rate:6.0f} | {c['esc right']:16d} {c['esc wrong']:5d} {c['esc none']:4d} | "
                      f"{c['named']:20d} {c['v right']:11d} {c['v wrong']:5d} {c['v none']:4d} | "
                      f"{c['no esc cause']:13d}", flush=True)
    for cause in ("propeller", "motor"):
        n = totals[f"{cause} n"]
        print(f"{cause}: ESC alone right {totals[cause + ' esc right']}/{n}, wrong {totals[cause + ' esc wrong']}; "
              f"verdict named the rotor {totals[cause + ' named']}/{n}, right cause {totals[cause + ' v right']}, "
              f"wrong {totals[cause + ' v wrong']}, none {totals[cause + ' v none']}; without ESC a cause was given "
              f"{totals[cause + ' no esc cause']} times")
    h = Counter()
    for rate in CAUSE_RATES:
        for f in fly_healthy(rate, 2 * per_cell, seed):
            v = diagnose_flight(f, model, keep_flight=False).verdict
            h[v.status] += 1
            h["cause"] += v.cause is not None
    print(f"healthy flights: {dict((k, v) for k, v in h.items() if k != 'cause')}, a cause given on {h['cause']}")
    print("\ncause threshold sweep (ESC alone, true rotor): right / wrong, per cause")
    for th in (1.0, 2.0, 3.0, 4.0, 6.0, 10.0):
        cells = []
        for cause in ("propeller", "motor"):
            x = np.array(llrs[cause])
            cells.append(f"{cause} {np.mean(x >= th):5.0%} / {int(np.sum(x <= -th))}")
        print(f"  |llr| >= {th:4.1f}: " + "   ".join(cells))
    worst = {c: (min(v) if v else float("nan")) for c, v in llrs.items()}
    print(f"lowest cause LLR toward the truth: propeller {worst['propeller']:+.1f}, motor {worst['motor']:+.1f} nats")
    print(f"({time.time() - t0:.0f} s)")


def fly_healthy(rate: float, n: int, seed: int):
    """n healthy flights of random airframes with ESC telemetry at ``rate`` (CAUSE_RATES' profile)."""
    rng = np.random.default_rng([seed, 3, int(rate)])
    afs = random_airframes(n, rng)
    return simulate_flights(n, airframes=afs, damages=[Damage()] * n, duration_s=DURATION_S,
                            profile=CAUSE_RATES[rate], seed=seed + 3 + int(rate), esc=rate, imbalance="random",
                            healthy_fraction=0.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cell", type=int, default=12)
    ap.add_argument("--seed", type=int, default=1700)
    ap.add_argument("--measure", action="store_true")
    ap.add_argument("--verdicts", action="store_true", help="also the fused verdicts of diagnose_flight")
    ap.add_argument("--verdict-healthy", type=int, default=0,
                    help="healthy flights per ESC rate for --verdicts (default 2 x --per-cell)")
    ap.add_argument("--causes", action="store_true", help="how well the cause (propeller or motor / ESC) is told apart")
    args = ap.parse_args()
    if args.causes:
        run_causes(args.per_cell, args.seed)
    else:
        run(args.per_cell, args.seed, args.measure, args.verdicts, args.verdict_healthy)


if __name__ == "__main__":
    main()
