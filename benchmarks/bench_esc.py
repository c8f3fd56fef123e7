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

``--causes`` also flies rotors that lost thrust in their wash (thrust η, the propeller's drag
torque and speed unchanged) and airframes whose rotors turn as command^(b/2) with b 1, 1.33
(ArduCopter SITL) and 1.8 (PX4 THR_MDL_FAC 0) in turn (sim/esc.py speed law), and judges the cause
with :func:`flightlog_fd.cause.judge_cause` (three causes, a probability bar; its sweep printed).

``--loads``: point loads (10-25 % of the take-off mass, 0.5-1 arm toward one rotor, shrunk until
the airframe hovers) at ESC 10 / 50 / 100 Hz (ArduPilot, PX4 default, PX4 high-rate logging) and
b 1 / 1.33 / 1.8, each with its no-load twin (same airframe, imbalance, motors and ESCs): the ESC
source alone (lost-rotor llr, a rotor named) before (main a2a0145, loaded beside this one from
git) and after, without and against the twin's profile; the cause judged on the loaded rotor; the
current decision's verdicts.

``--reliability``: the ESC and effectiveness sources alone per ESC rate (and its logging profile)
and profile kind, on healthy, loaded, damaged-propeller and weak-motor flights: how often each
reaches the decision's bars, how strong on the damaged rotor, and the level
``reliability.trust_level`` gives.

    python benchmarks/bench_esc.py [--per-cell N] [--seed S] [--measure] [--verdicts [--verdict-healthy N]]
    python benchmarks/bench_esc.py --causes [--per-cell N] [--seed S]
    python benchmarks/bench_esc.py --loads [--per-cell N] [--seed S]
    python benchmarks/bench_esc.py --reliability [--per-cell N] [--seed S]
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from typing import Sequence

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
    before, before_right, fa_h_before, fa_t_before = _before_module(), 0, 0, 0
    sweep_damaged: dict[float, list[float]] = {}  # per eta: the right motor's llr when it is the largest, else 0
    for eta in ETAS:
        for rate in RATES:
            pairs = damaged_set(eta, rate, per_cell, seed)
            fl = [f for _, f in pairs]
            right = wrong = none = abst = right_p = 0
            for calib, f in pairs:
                right_p += analyze_esc(f, fit_esc_baseline([calib])).motor_named() == f.truth["motor"]
                if before is not None:
                    before_right += before.analyze_esc(f).motor_named() == f.truth["motor"]
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
    print(f"damaged flights, right motor named without a profile: {total_ok}/{total_n} = {total_ok / total_n:.1%}"
          f" (before, main a2a0145: {before_right}/{total_n})")
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
            fa_h_before += before is not None and before.analyze_esc(f).motor_named() is not None
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
            fa_t_before += before is not None and before.analyze_esc(after).motor_named() is not None
            fa_tp += ap.motor_named() is not None
            trim_llr.append(max(a.llr.values()))
            trim_llr_p.append(max(ap.llr.values()))
            if measure:
                mc, _ = measure_esc(calib)
                ma, _ = measure_esc(after)
                trim_dev.append(ma.r - mc.r)
    print(f"healthy flights, false alarms: {fa_h}/{n_h} (largest llr {max(healthy_llr):.1f} nats; before {fa_h_before})")
    print(f"trim changed after calibration (CoG / yaw trim), false alarms without profile: {fa_t}/{n_t} "
          f"(before {fa_t_before}) "
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


def cause_set(cause: str, eta: float, rate: float, n: int, seed: int, profile: str | None = None,
              exponents: Sequence[float] = (1.0,)):
    """n flights of random airframes that fly ``eta``, rotor k's thrust lost to ``cause``
    ("propeller": η_torque = η^k, k ~ TORQUE_EXPONENT_RANGE; "motor": a weak motor or ESC; "wash":
    something in the rotor's wash: thrust η, its propeller's drag torque and speed unchanged), the
    airframes' rpm curves cycling through ``exponents``."""
    rng = np.random.default_rng([seed, int(eta * 100), int(rate), CAUSE_KINDS.index(cause)])
    afs = airframes_for(n, eta, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate, exponents[i % len(exponents)]) for i, af in enumerate(afs)]
    dmg = []
    for _ in afs:
        k = int(rng.integers(1, 5))
        if cause == "propeller":
            dmg.append(Damage(k, eta, None, float(eta ** rng.uniform(*TORQUE_EXPONENT_RANGE))))
        elif cause == "wash":
            dmg.append(Damage(k, eta, None, 1.0))
        else:
            dmg.append(Damage(k, eta, None, None, cause="motor"))
    return simulate_flights(n, airframes=afs, damages=dmg, duration_s=DURATION_S,
                            profile=profile or CAUSE_RATES.get(rate, "ardupilot"),
                            seed=seed + int(eta * 100) + int(rate) + 500 * CAUSE_KINDS.index(cause),
                            esc=escs, imbalance=imbs, healthy_fraction=0.0)


#: The simulated causes of --causes and the verdict's word for each.
CAUSE_KINDS = ("propeller", "motor", "wash")
TRUTH_WORD = {"propeller": "propeller", "motor": "motor_or_esc", "wash": "wash"}


def run_causes(per_cell: int, seed: int) -> None:
    """--causes: how well the cause of a rotor's lost thrust is told apart (module docstring)."""
    from collections import Counter

    from flightlog_fd.cause import CAUSE_PROBABILITY_BAR, judge_cause
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    t0 = time.time()
    model = resolve_model()
    print(f"Cause of a rotor's lost thrust (propeller, motor / ESC, something in its wash), simulated "
          f"{DURATION_S:.0f} s flights, random airframes with rpm curves b = {', '.join(map(str, SPEED_EXPONENTS))} "
          f"in turn, {per_cell} per cell, seed {seed}, no profile; cause stated at P >= {CAUSE_PROBABILITY_BAR:g}")
    print(f"{'cause':>10} {'eta':>5} {'ESC Hz':>6} | {'judged on the true rotor: right':>31} {'wrong':>5} {'none':>4} "
          f"{'P(true) median':>14} | {'verdict: rotor named':>20} {'right cause':>11} {'wrong':>5} {'none':>4} | "
          f"{'no ESC: cause':>13}")
    p_true: dict[str, list[float]] = {c: [] for c in CAUSE_KINDS}
    p_wrong: dict[str, list[float]] = {c: [] for c in CAUSE_KINDS}  # the largest P of a wrong cause
    totals = Counter()
    for cause in CAUSE_KINDS:
        for eta in ETAS:
            for rate in CAUSE_RATES:
                c = Counter()
                ps = []
                for f in cause_set(cause, eta, rate, per_cell, seed, exponents=SPEED_EXPONENTS):
                    k, want = f.truth["motor"], TRUTH_WORD[cause]
                    d = diagnose_flight(f, model, keep_flight=False)
                    cz = judge_cause(d.decision.results if d.decision else [], k)
                    ps.append(cz.probs.get(want, 0.0))
                    p_true[cause].append(cz.probs.get(want, 0.0))
                    p_wrong[cause].append(max(v for key, v in cz.probs.items() if key != want))
                    c["esc " + ("right" if cz.cause == want else "none" if cz.cause is None else "wrong")] += 1
                    v = d.verdict
                    named = v.cause_evidence is not None and v.cause_evidence["motor"] == k
                    c["named"] += named
                    if named:
                        c["v " + ("right" if v.cause == want else "none" if v.cause is None else "wrong")] += 1
                    nv = diagnose_flight(replace(f, esc=None), model, keep_flight=False).verdict
                    c["no esc cause"] += nv.cause is not None and nv.cause != "load"
                totals.update({f"{cause} {key}": val for key, val in c.items()})
                totals[f"{cause} n"] += per_cell
                print(f"{cause:>10} {eta:5.2f} {rate:6.0f} | {c['esc right']:31d} {c['esc wrong']:5d} {c['esc none']:4d} "
                      f"{np.median(ps):14.2f} | {c['named']:20d} {c['v right']:11d} {c['v wrong']:5d} {c['v none']:4d} | "
                      f"{c['no esc cause']:13d}", flush=True)
    for cause in CAUSE_KINDS:
        n = totals[f"{cause} n"]
        print(f"{cause}: judged on the true rotor right {totals[cause + ' esc right']}/{n}, wrong "
              f"{totals[cause + ' esc wrong']}; verdict named the rotor {totals[cause + ' named']}/{n}, right cause "
              f"{totals[cause + ' v right']}, wrong {totals[cause + ' v wrong']}, none {totals[cause + ' v none']}; "
              f"without ESC a cause was given {totals[cause + ' no esc cause']} times")
    h = Counter()
    for rate in CAUSE_RATES:
        for f in fly_healthy(rate, 2 * per_cell, seed):
            v = diagnose_flight(f, model, keep_flight=False).verdict
            h[v.status] += 1
            h["cause"] += v.cause is not None and v.cause != "load"
    print(f"healthy flights: {dict((k, v) for k, v in h.items() if k != 'cause')}, a cause given on {h['cause']}")
    print("\ncause bar sweep (judged on the true rotor): stated right / stated wrong, per cause")
    for bar in (0.6, 0.7, 0.8, 0.9, 0.95, 0.99):
        cells = []
        for cause in CAUSE_KINDS:
            pt, pw = np.array(p_true[cause]), np.array(p_wrong[cause])
            cells.append(f"{cause} {np.mean(pt >= bar):5.0%} / {int(np.sum(pw >= bar))}")
        print(f"  P >= {bar:4.2f}: " + "   ".join(cells))
    print(f"({time.time() - t0:.0f} s)")


def fly_healthy(rate: float, n: int, seed: int):
    """n healthy flights of random airframes with ESC telemetry at ``rate`` (CAUSE_RATES' profile)."""
    rng = np.random.default_rng([seed, 3, int(rate)])
    afs = random_airframes(n, rng)
    return simulate_flights(n, airframes=afs, damages=[Damage()] * n, duration_s=DURATION_S,
                            profile=CAUSE_RATES[rate], seed=seed + 3 + int(rate), esc=rate, imbalance="random",
                            healthy_fraction=0.0)


#: The rotors' rpm-versus-command exponent b of the simulated airframes for --loads and --causes
#: (sim/esc.py speed law): 1 (the autopilot's thrust model fits the rotor), 1.33 (ArduCopter 4.7
#: SITL, measured), 1.8 (PX4 THR_MDL_FAC 0 over a motor whose speed is linear in its signal).
SPEED_EXPONENTS = (1.0, 1.33, 1.8)
#: ESC rate (Hz) -> logging profile for --loads: ArduPilot's 10 Hz ESC log, PX4's default, PX4's
#: high-rate profile.
LOAD_RATES = {10.0: "ardupilot", 50.0: "px4_default", 100.0: "px4_high"}
#: Point loads of this share of the take-off mass, this share of the arm toward one rotor.
LOAD_FRACTION = (0.10, 0.25)
LOAD_ARM_FRACTION = (0.5, 1.0)
#: The ESC source "speaks" for a rotor at the decision's bars (nats): uncertain, damaged.
SPEAK_BARS = (3.5, 6.0)


def _before_module():
    """The ESC analyzer as it was on main at a2a0145 (b fixed at 1, against the other motors at
    their own commands), loaded beside this one for the before column; None without git."""
    import importlib.util
    import subprocess
    import tempfile
    from pathlib import Path

    try:
        src = subprocess.run(["git", "show", "a2a0145:flightlog_fd/analyzers/esc.py"], capture_output=True,
                             check=True, text=True, cwd=Path(__file__).resolve().parent).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    path = Path(tempfile.mkdtemp()) / "esc_before.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("flightlog_fd.analyzers._esc_before", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def nearest_motor(af, load) -> int:
    """The rotor (1-based) the load sits toward."""
    p = load.position_on(af)[:2]
    rot = af.geometry().rotors
    return 1 + int(np.argmax([p[0] * r.x + p[1] * r.y for r in rot]))


def load_pairs(rate: float, exponent: float, n: int, seed: int):
    """(twin without the load, the same airframe / imbalance / motors / ESCs with a point load toward
    one rotor, the rotor it sits toward, words) for n random airframes."""
    from flightlog_fd.sim.loads import Load, make_flyable

    rng = np.random.default_rng([seed, int(rate), int(exponent * 100), 7])
    afs = random_airframes(n, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate, exponent) for af in afs]
    loads = []
    for af, imb in zip(afs, imbs):
        ld = Load("point", mass_fraction=float(rng.uniform(*LOAD_FRACTION)), toward_motor=int(rng.integers(1, 5)),
                  arm_fraction=float(rng.uniform(*LOAD_ARM_FRACTION)))
        loads.append((make_flyable(af, ld, None, imb),))
    kw = dict(airframes=afs, damages=[Damage()] * n, duration_s=DURATION_S, profile=LOAD_RATES[rate], esc=escs,
              imbalance=imbs, healthy_fraction=0.0)
    s = seed + int(rate) + int(exponent * 100)
    twins = simulate_flights(n, seed=s + 1, **kw)
    loaded = simulate_flights(n, seed=s, loads=loads, **kw)
    out = []
    for af, tw, f, (ld,) in zip(afs, twins, loaded, loads):
        k = nearest_motor(af, ld)
        r = float(np.hypot(*ld.position_on(af)[:2]) / af.arm)
        out.append((tw, f, k, f"{ld.mass_fraction:.0%} at {r:.2f} arm toward motor {k}"))
    return out


def run_loads(per_cell: int, seed: int) -> None:
    """--loads: moved loads with ESC telemetry (module docstring of run_loads' section in
    results/cause.md): the ESC source alone and the cause, before (main a2a0145) and after."""
    from collections import Counter

    from flightlog_fd.calibration import calibrate
    from flightlog_fd.cause import judge_cause
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    t0 = time.time()
    before = _before_module()
    model = resolve_model()
    print(f"Moved loads with ESC telemetry: random airframes, {DURATION_S:.0f} s waypoints, point loads "
          f"{LOAD_FRACTION[0]:.0%}-{LOAD_FRACTION[1]:.0%} of the take-off mass at {LOAD_ARM_FRACTION[0]}-"
          f"{LOAD_ARM_FRACTION[1]} of the arm toward one rotor (shrunk until it hovers), {per_cell} per cell, "
          f"seed {seed}; profile = one flight of the no-load twin")
    print("ESC alone: lost-rotor llr (decision_llr) of the loaded rotor and the largest; named = GLR > "
          f"{DECISION_LLR:g}; before = main a2a0145 (b fixed at 1)")
    print(f"{'Hz':>4} {'b':>5} | {'before: max llr':>15} {'named':>5} | {'after: max llr':>14} {'named':>5} "
          f"{'>=3.5':>5} | {'profile: max':>12} {'named':>5} | {'cause P(prop) max':>17} {'stated':>14} | "
          f"{'verdict (no profile / profile)':>30}")
    totals = Counter()
    worst = {"before": [], "after": [], "profile": [], "p_prop": []}
    for rate in LOAD_RATES:
        for b in SPEED_EXPONENTS:
            c = Counter()
            mx = {"before": [], "after": [], "profile": [], "p_prop": []}
            verdicts = Counter()
            for twin, f, k, what in load_pairs(rate, b, per_cell, seed):
                if before is not None:
                    ab = before.analyze_esc(f)
                    if not ab.abstain:
                        mx["before"].append(max(ab.decision_llr.values()))
                        c["before named"] += ab.motor_named() is not None
                a = analyze_esc(f)
                if a.abstain:
                    c["abstained"] += 1
                    continue
                mx["after"].append(max(a.decision_llr.values()))
                c["after named"] += a.motor_named() is not None
                c["after speaks"] += max(a.decision_llr.values()) >= SPEAK_BARS[0]
                try:
                    ap = analyze_esc(f, fit_esc_baseline([twin]))
                    mx["profile"].append(max(ap.decision_llr.values()))
                    c["profile named"] += ap.motor_named() is not None
                except ValueError:
                    pass
                prof = calibrate([twin])
                for tag, p in (("no profile", None), ("profile", prof)):
                    d = diagnose_flight(f, model, p, keep_flight=False)
                    v = d.verdict
                    results = d.decision.results if d.decision is not None else []
                    cz = judge_cause(results, k)
                    mx["p_prop"].append(cz.probs.get("propeller", 0.0))
                    c[f"cause {cz.cause}"] += 1
                    c["verdict propeller"] += v.cause == "propeller"
                    verdicts[f"{tag} {v.status}"] += 1
            for key in mx:
                worst[key] += mx[key]
            totals.update(c)
            totals.update(verdicts)
            stated = "/".join(str(c[f"cause {x}"]) for x in ("propeller", "motor_or_esc", "wash"))
            vwords = (f"{verdicts['no profile damaged']}d {verdicts['no profile uncertain']}u / "
                      f"{verdicts['profile damaged']}d {verdicts['profile uncertain']}u")
            print(f"{rate:4.0f} {b:5.2f} | {max(mx['before'], default=float('nan')):15.1f} {c['before named']:5d} | "
                  f"{max(mx['after'], default=float('nan')):14.1f} {c['after named']:5d} {c['after speaks']:5d} | "
                  f"{max(mx['profile'], default=float('nan')):12.1f} {c['profile named']:5d} | "
                  f"{max(mx['p_prop'], default=float('nan')):17.2f} {stated:>14} | {vwords:>30}", flush=True)
    n = len(worst["after"])
    print(f"loaded flights {n}: ESC named a rotor before {totals['before named']}, after {totals['after named']} "
          f"(profile {totals['profile named']}); largest lost-rotor llr before {max(worst['before'], default=0):.1f}, "
          f"after {max(worst['after'], default=0):.1f}, with profile {max(worst['profile'], default=0):.1f}")
    print(f"cause on the loaded rotor (no profile and profile, {2 * n}): propeller {totals['cause propeller']}, "
          f"motor_or_esc {totals['cause motor_or_esc']}, wash {totals['cause wash']}, unknown {totals['cause None']}; "
          f"largest P(propeller) {max(worst['p_prop'], default=0):.2f}; verdicts with cause propeller "
          f"{totals['verdict propeller']}")
    print(f"verdicts (current decision): " + ", ".join(f"{k} {v}" for k, v in sorted(totals.items())
                                                      if k.startswith(("no profile ", "profile ")) and "named" not in k))
    print(f"({time.time() - t0:.0f} s)")


def reliability_set(rate: float, n: int, seed: int):
    """Per airframe (n random ones, rpm curves cycling through SPEED_EXPONENTS, the same motors,
    ESCs and imbalance on every flight): the twin a profile is calibrated on, a second healthy
    flight, a point load toward one rotor (LOAD_FRACTION at LOAD_ARM_FRACTION), a damaged propeller
    and a weak motor (η 0.6-0.9, each its rotor). Returns dicts with the flight, its role, the
    rotor concerned (0 healthy) and the twin."""
    from flightlog_fd.sim.loads import Load, make_flyable

    rng = np.random.default_rng([seed, int(rate), 11])
    afs = airframes_for(n, 0.6, rng)
    imbs = random_imbalances(afs, rng)
    escs = [random_esc_params(af, rng, rate, SPEED_EXPONENTS[i % len(SPEED_EXPONENTS)]) for i, af in enumerate(afs)]
    roles = ("twin", "healthy", "load", "propeller", "motor")
    fly_afs, fly_imbs, fly_escs, dmg, loads, meta = [], [], [], [], [], []
    for af, imb, esc in zip(afs, imbs, escs):
        for role in roles:
            k = int(rng.integers(1, 5))
            eta = float(rng.uniform(0.6, 0.9))
            ld = ()
            if role == "load":
                ld = (make_flyable(af, Load("point", mass_fraction=float(rng.uniform(*LOAD_FRACTION)), toward_motor=k,
                                            arm_fraction=float(rng.uniform(*LOAD_ARM_FRACTION))), None, imb),)
                k = nearest_motor(af, ld[0])
            d = (Damage(k, eta, None, float(eta ** rng.uniform(*TORQUE_EXPONENT_RANGE))) if role == "propeller"
                 else Damage(k, eta, None, None, cause="motor") if role == "motor" else Damage())
            fly_afs.append(af)
            fly_imbs.append(imb)
            fly_escs.append(esc)
            dmg.append(d)
            loads.append(ld)
            meta.append((role, k if role in ("load", "propeller", "motor") else 0, esc.speed_exponent))
    flights = simulate_flights(len(fly_afs), airframes=fly_afs, damages=dmg, duration_s=DURATION_S,
                               profile=LOAD_RATES[rate], seed=seed + int(rate), esc=fly_escs, imbalance=fly_imbs,
                               loads=loads, healthy_fraction=0.0)
    out = []
    for i in range(0, len(flights), len(roles)):
        twin = flights[i]
        for j in range(1, len(roles)):
            role, k, b = meta[i + j]
            out.append({"flight": flights[i + j], "role": role, "motor": k, "b": b, "twin": twin})
    return out


def run_reliability(per_cell: int, seed: int) -> None:
    """--reliability: the ESC and effectiveness sources alone, per ESC rate (and its logging profile)
    and profile kind: how often each speaks on healthy and loaded flights, how strong it is on a
    damaged propeller's and a weak motor's rotor; the level reliability.trust_level gives."""
    from collections import defaultdict

    from flightlog_fd.analyzers.reliability import trust_level
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    t0 = time.time()
    model = resolve_model()
    rows = defaultdict(list)  # (source, Hz, profile kind, role) -> [(leading llr, true rotor's llr)]
    for rate in LOAD_RATES:
        for case in reliability_set(rate, per_cell, seed):
            f, role, k = case["flight"], case["role"], case["motor"]
            for tag, prof in (("no profile", None), ("profile", calibrate([case["twin"]]))):
                d = diagnose_flight(f, model, prof, keep_flight=False)
                for r in (d.decision.results if d.decision else []):
                    if r.analyzer not in ("esc", "effectiveness") or r.abstained:
                        continue
                    raw = r.raw_llr(4)
                    if raw is None:
                        continue
                    rows[(r.analyzer, rate, tag, role)].append((float(raw.max()), float(raw[k - 1]) if k else np.nan))
    print(f"ESC and effectiveness as sources of their own: simulated {DURATION_S:.0f} s waypoint flights, "
          f"{per_cell} random airframes per ESC rate (rpm curves b {', '.join(map(str, SPEED_EXPONENTS))} in turn), "
          f"seed {seed}; LLR per motor before any cap; bars {SPEAK_BARS[0]:g} / {SPEAK_BARS[1]:g} nats")
    print(f"{'source':>13} {'ESC Hz':>6} {'log':>11} {'profile':>10} | {'healthy: lead med/max':>21} {'>=3.5':>5} "
          f"{'>=6':>3} | {'loaded: lead max':>16} {'>=3.5':>5} {'>=6':>3} | {'prop: rotor p10/med':>19} {'>=6':>4} | "
          f"{'motor: rotor p10/med':>20} {'>=6':>4} | {'level':>13}")
    for src in ("esc", "effectiveness"):
        for rate in LOAD_RATES:
            for tag in ("no profile", "profile"):
                h = np.array([x[0] for x in rows[(src, rate, tag, "healthy")]])
                ld = np.array([x[0] for x in rows[(src, rate, tag, "load")]])
                pr = np.array([x[1] for x in rows[(src, rate, tag, "propeller")]])
                mo = np.array([x[1] for x in rows[(src, rate, tag, "motor")]])
                quiet = np.concatenate([h, ld])
                if not quiet.size:
                    continue
                level = trust_level(quiet.size, int(np.sum(quiet >= SPEAK_BARS[0])), int(np.sum(quiet >= SPEAK_BARS[1])))

                def pm(x):
                    return f"{np.percentile(x, 10):+.1f}/{np.median(x):+.1f}" if x.size else "-"
                print(f"{src:>13} {rate:6.0f} {LOAD_RATES[rate]:>11} {tag:>10} | "
                      f"{np.median(h) if h.size else np.nan:+10.1f}/{h.max() if h.size else np.nan:+10.1f} "
                      f"{int(np.sum(h >= SPEAK_BARS[0])):5d} {int(np.sum(h >= SPEAK_BARS[1])):3d} | "
                      f"{ld.max() if ld.size else np.nan:+16.1f} {int(np.sum(ld >= SPEAK_BARS[0])):5d} "
                      f"{int(np.sum(ld >= SPEAK_BARS[1])):3d} | {pm(pr):>19} {int(np.sum(pr >= SPEAK_BARS[1])):4d} | "
                      f"{pm(mo):>20} {int(np.sum(mo >= SPEAK_BARS[1])):4d} | {str(level):>13}", flush=True)
    print(f"({time.time() - t0:.0f} s; n per row: {per_cell} healthy, {per_cell} loaded, {per_cell} each damaged; "
          f"level: reliability.trust_level on the healthy and loaded flights, None below "
          f"reliability.MIN_MEASURED)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cell", type=int, default=12)
    ap.add_argument("--seed", type=int, default=1700)
    ap.add_argument("--measure", action="store_true")
    ap.add_argument("--verdicts", action="store_true", help="also the fused verdicts of diagnose_flight")
    ap.add_argument("--verdict-healthy", type=int, default=0,
                    help="healthy flights per ESC rate for --verdicts (default 2 x --per-cell)")
    ap.add_argument("--causes", action="store_true", help="how well the cause (propeller or motor / ESC) is told apart")
    ap.add_argument("--loads", action="store_true", help="moved loads with ESC telemetry: the ESC source and the cause")
    ap.add_argument("--reliability", action="store_true",
                    help="ESC and effectiveness as sources of their own, per ESC rate and profile kind")
    args = ap.parse_args()
    if args.reliability:
        run_reliability(args.per_cell, args.seed)
    elif args.loads:
        run_loads(args.per_cell, args.seed)
    elif args.causes:
        run_causes(args.per_cell, args.seed)
    else:
        run(args.per_cell, args.seed, args.measure, args.verdicts, args.verdict_healthy)


if __name__ == "__main__":
    main()
