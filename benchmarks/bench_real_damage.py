"""One table: how the verdict does on real damaged and healthy airframes, and eta-hat in simulation.

    python benchmarks/bench_real_damage.py [--profiles DIR] [--sim-per-eta 6] [--skip-sim]

Real part (each set skips when ../shared lacks it): rrc_straight calibrated on good 1, on goods
1+2, and without a profile; crazypad_e9 calibrated on normal log00, and on its three normal
flights (the profile then measures the airframe's flight-to-flight drift); the real healthy flights
without a profile; px4_sih_dev calibrated on sih_004 and without a profile. Rows per set: the
adapted (or shipped) model alone (majority of its windows' argmax), the fused verdict
(`fdlog diagnose`), and the motor-balance rule (training/peer_rule.py, offsets from the
calibration flight). Cells count healthy / uncertain / damaged (motor named) per group; the
side-by-side table counts a damaged flight named right by a damaged verdict naming its motor and
by an uncertain one naming it (``verdict.motor``) apart.
``--profiles DIR`` reuses the profiles calibrated there before (rrc_g1.json, rrc_g12.json,
cp00.json, sih004.json) and writes there the ones it has to calibrate (about a minute each).

Simulated part: random airframes with realistic imbalance, a healthy flight and a damaged flight
(eta in 0.6-0.9) of each, at the px4_high, ardupilot and px4_default (10 Hz motor) logging
profiles; calibrated (measure only, no adaptation) on the healthy one; prints how often eta-hat of
the damaged motor is within +-0.05 of eta, the mean error, and how often the verdict names it.
Also prints the spread figures decision.py's constants cite. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
RRC = SHARED / "real_damaged" / "rrc_straight"


def _group_rrc(name: str) -> str:
    return "good" if name.startswith("good") else name.split("_cut")[0].replace("_", " ")


def _cell(results: list[tuple[str, int]]) -> str:
    c = Counter(s for s, _ in results)
    motors = Counter(m for s, m in results if s == "damaged")
    named = "/".join(f"m{m}x{k}" for m, k in sorted(motors.items()))
    return f"{c['healthy']}h {c['uncertain']}u {c['damaged']}d" + (f" ({named})" if named else "")


def _model_alone(d) -> tuple[str, int]:
    labels = np.array([w.cls for w in d.windows])
    if labels.size == 0:
        return ("n/a", 0)
    k = int(np.bincount(labels, minlength=5).argmax())
    return ("healthy", 0) if k == 0 else ("damaged", k)


def _peer(flight, offsets) -> tuple[str, int]:
    from flightlog_fd.training.peer_rule import THRESHOLD, steady_means

    means, _, _ = steady_means(flight)
    excess = np.array([means[i] - np.delete(means, i).mean() for i in range(4)]) - offsets
    k = int(np.argmax(excess))
    return ("damaged", k + 1) if excess[k] > THRESHOLD else ("healthy", 0)


def _offsets(flights) -> np.ndarray:
    from flightlog_fd.training.peer_rule import steady_means

    ex = []
    for fl in flights:
        means, _, _ = steady_means(fl)
        ex.append([means[i] - np.delete(means, i).mean() for i in range(4)])
    return np.mean(ex, axis=0)


def _profile(name: str, logs: list[Path], profiles: Path | None, tmp: Path):
    from flightlog_fd.profile import Profile
    from flightlog_fd.calibration import calibrate

    if profiles is not None and (profiles / f"{name}.json").exists():
        return Profile.load(profiles / f"{name}.json")
    out = (profiles if profiles is not None else tmp) / f"{name}.json"
    t0 = time.perf_counter()
    calibrate(logs, adapt=True, output=out)
    print(f"  calibrated {name} on {', '.join(p.name for p in logs)} in {time.perf_counter() - t0:.0f} s", flush=True)
    return Profile.load(out)


def real_part(args) -> None:
    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.training.targets import crazypad_logs, real_healthy_logs, sih_logs

    shipped = resolve_model()
    tmp = Path(tempfile.mkdtemp(prefix="bench_real_damage_"))
    cases = []  # (set label, profile name or None, calibration paths, [(name, group, path, truth motor)])
    if RRC.is_dir():
        rrc = [(p.stem, _group_rrc(p.stem), p, None) for p in sorted(RRC.glob("*.BIN"))]
        g1, g2 = RRC / "good_prop_straight_line_1.BIN", RRC / "good_prop_straight_line_2.BIN"
        cases.append(("rrc_straight, profile good 1", "rrc_g1", [g1], [r for r in rrc if r[2] != g1]))
        cases.append(("rrc_straight, profile goods 1+2", "rrc_g12", [g1, g2], [r for r in rrc if r[2] not in (g1, g2)]))
        cases.append(("rrc_straight, no profile", None, [], rrc))
    if (SHARED / "crazypad_e9").is_dir():
        cp = crazypad_logs(SHARED)
        cal = next(lg for lg in cp if lg.name == "normal_flight__E9_log00")
        cases.append(("crazypad_e9, profile normal log00", "cp00", [cal.path],
                      [(lg.name, "healthy" if lg.healthy else f"motor {lg.truth['motor']}", lg.path, lg.truth["motor"])
                       for lg in cp if lg.name != cal.name]))
        normals = [lg for lg in cp if lg.healthy]
        cases.append(("crazypad_e9, profile normal logs 00-02 (measured drift)", "cp012", [lg.path for lg in normals],
                      [(lg.name, f"motor {lg.truth['motor']}", lg.path, lg.truth["motor"]) for lg in cp if not lg.healthy]))
        cases.append(("crazypad_e9, no profile", None, [],
                      [(lg.name, "healthy" if lg.healthy else f"motor {lg.truth['motor']}", lg.path, lg.truth["motor"])
                       for lg in cp]))
    if (SHARED / "real_healthy").is_dir():
        cases.append(("real healthy (+Erle), no profile", None, [],
                      [(lg.name, "healthy", lg.path, 0) for lg in real_healthy_logs(SHARED)]))
    if (SHARED / "px4_sih_dev").is_dir():
        sih = sih_logs(SHARED)
        cal = next(lg for lg in sih if lg.name == "sih_004")

        def grp(lg):
            return "healthy" if lg.healthy else ("eta<=0.8" if lg.truth["eta"] <= 0.8 else "eta 0.9")
        cases.append(("px4_sih_dev, profile sih_004", "sih004", [cal.path],
                      [(lg.name, grp(lg), lg.path, lg.truth["motor"]) for lg in sih if lg.name != cal.name]))
        cases.append(("px4_sih_dev, no profile", None, [],
                      [(lg.name, grp(lg), lg.path, lg.truth["motor"]) for lg in sih]))

    model_stats: dict[str, list] = defaultdict(list)
    summary = []  # (set, damaged n, verdict named, uncertain naming it, model named, healthy n, FA verdict, FA model)
    print("\n== real flights: cells = healthy / uncertain / damaged (motors named) per group ==")
    if args.profiled_only:
        cases = [c for c in cases if c[1] is not None]
    for label, pname, cal_paths, flights in cases:
        profile = _profile(pname, cal_paths, args.profiles, tmp) if pname else None
        model = resolve_model(None, profile) if profile is not None else shipped
        offsets = _offsets([load_flight(p) for p in cal_paths]) if cal_paths else np.zeros(4)
        rows: dict[str, dict[str, list]] = {"model alone": defaultdict(list), "fused verdict": defaultdict(list),
                                            "motor-balance rule": defaultdict(list)}
        right = Counter()
        side = Counter()
        detail = []
        for name, group, path, truth in flights:
            fl = load_flight(path)
            d = diagnose_flight(fl, model, profile)
            v = d.verdict
            alone = _model_alone(d)
            rows["model alone"][group].append(alone)
            rows["fused verdict"][group].append((v.status, v.motor or 0))
            rows["motor-balance rule"][group].append(_peer(fl, offsets))
            if truth:
                right["model alone"] += alone == ("damaged", truth)
                right["fused verdict"] += (v.status, v.motor) == ("damaged", truth)
                side["damaged"] += 1
                side["uncertain naming it"] += v.status == "uncertain" and v.motor == truth
            elif group in ("healthy", "good"):
                side["healthy"] += 1
                side["verdict FA"] += v.status == "damaged"
                side["model FA"] += alone[0] == "damaged"
            eta = ""
            if d.decision is not None and v.motor:
                m = d.decision.motors[v.motor - 1]
                eta = f" eta-hat {m.eta_hat:.2f} [{m.eta_ci[0]:.2f}-{m.eta_ci[1]:.2f}]"
            detail.append(f"    {name}: {v.status}{' motor ' + str(v.motor) if v.motor else ''}{eta}")
            if pname is None and d.windows:
                from flightlog_fd.timeline import PROB_FLOOR_MIX

                pr = np.array([w.probabilities for w in d.windows])
                q = (1 - PROB_FLOOR_MIX) * pr + PROB_FLOOR_MIX / pr.shape[1]
                lr = np.log(q[:, 1:]) - np.log(q[:, :1])
                model_stats[label].append((truth if group == "eta<=0.8" else 0, lr.mean(axis=0), float(np.median((lr - lr.mean(axis=0)).std(axis=0)))))
        groups = list(dict.fromkeys(g for _, g, _, _ in flights))
        print(f"\n{label}")
        print("  " + f"{'':20s}" + "".join(f"{g:>30s}" for g in groups) + ("   right motor" if right else ""))
        for row, cells in rows.items():
            extra = f"   {right[row]}" if right and row in right else ("   -" if right else "")
            print("  " + f"{row:20s}" + "".join(f"{_cell(cells[g]):>30s}" for g in groups) + extra)
        if args.verbose:
            print("\n".join(detail))
        summary.append((label, side["damaged"], right["fused verdict"], side["uncertain naming it"],
                        right["model alone"], side["healthy"], side["verdict FA"], side["model FA"]))
    print("\n== side by side: the verdict and the model's window majority alone ==")
    print("  damaged flights: the verdict 'damaged' naming the motor, 'uncertain' naming it (verdict.motor), both, and the "
          "model's window majority naming it; healthy flights called damaged by the verdict / by the model alone")
    print(f"  {'set':58s} {'damaged':>8s} {'uncertain':>10s} {'named':>6s} {'model':>6s} {'of':>4s}   "
          f"{'healthy called damaged':>24s}")
    for label, nd, vr, vu, mr, nh, vfa, mfa in summary:
        dmg = f"{vr:8d} {vu:10d} {vr + vu:6d} {mr:6d} {nd:4d}" if nd else f"{'-':>8s} {'-':>10s} {'-':>6s} {'-':>6s} {'-':>4s}"
        print(f"  {label:58s} {dmg}   {f'{vfa} / {mfa} of {nh}' if nh else '-':>24s}")
    print("\n== the shipped model's flight-mean window log ratios (decision.MODEL_* constants) ==")
    for label, rows in model_stats.items():
        if label.startswith("real healthy"):
            allm = np.concatenate([m for _, m, _ in rows])
            print(f"  {label}: all motors mean {allm.mean():+.2f}, sd {allm.std(ddof=1):.2f}; within-flight window "
                  f"sd median {np.median([w for _, _, w in rows]):.2f}; most-voted motor per flight "
                  f"{min(m.max() for _, m, _ in rows):+.2f} .. {max(m.max() for _, m, _ in rows):+.2f}")
        if label.startswith("px4_sih_dev, no profile"):
            dm = np.array([m[t - 1] for t, m, _ in rows if t])
            print(f"  {label}, the damaged motor of the eta <= 0.8 flights (mid-flight onsets included): median {np.median(dm):+.2f}, sd {dm.std(ddof=1):.2f}")


def spread_figures() -> None:
    """The measurements decision.py's constants cite."""
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.share_fit import airborne_thrust, shares_of
    from flightlog_fd.training.targets import crazypad_logs, real_healthy_logs

    def shares(path):
        return shares_of(airborne_thrust([load_flight(path)]))

    print("\n== spreads behind decision.py's constants ==")
    if (SHARED / "real_healthy").is_dir():
        s = np.array([shares(lg.path)[0] for lg in real_healthy_logs(SHARED)])
        print(f"  real healthy airframes ({len(s)} flights): RMS share deviation from 1 = "
              f"{np.sqrt(np.mean((s - 1) ** 2)):.3f} (NEIGHBOUR_SHARE_SIGMA)")
    for label, paths in (("rrc_straight goods 1-3", sorted(RRC.glob("good_prop_*.BIN"))),
                         ("CrazyPAD E9 normal 00-02", [lg.path for lg in crazypad_logs(SHARED)
                                                       if lg.name.startswith("normal")] if (SHARED / "crazypad_e9").is_dir() else [])):
        if len(paths) < 2:
            continue
        each = [shares(p) for p in paths]
        sh = np.array([e[0] for e in each])
        thr = np.array([e[1] for e in each])
        sd = sh.std(axis=0, ddof=1)
        print(f"  {label}: per-motor share sd {np.round(sd, 3).tolist()} (RMS {np.sqrt(np.mean(sd ** 2)):.3f}); "
              f"throttle {np.round(thr, 3).tolist()} (relative sd {thr.std(ddof=1) / thr.mean():.3f})")


def sim_part(args) -> None:
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.calibration import calibrate_profile
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage
    from flightlog_fd.sim.imbalance import random_imbalances

    model = resolve_model()
    etas = (0.6, 0.7, 0.8, 0.9)
    print("\n== simulated severity: profile from a healthy flight of the same airframe (no adaptation) ==")
    print(f"  {'profile':12s} {'eta':>4s} {'n':>3s} {'|err|<=0.05':>12s} {'mean err':>9s} {'named':>6s} {'healthy ok':>10s}")
    for prof in ("px4_high", "ardupilot", "px4_default"):
        rng = np.random.default_rng(args.seed)
        n = args.sim_per_eta * len(etas)
        afs = random_airframes(n, rng)
        imbs = random_imbalances(afs, rng)
        truth = [(int(rng.integers(1, 5)), etas[i % len(etas)]) for i in range(n)]
        t0 = time.perf_counter()
        flights = simulate_flights(2 * n, airframes=afs + afs, imbalance=imbs + imbs,
                                   damages=[Damage(0, 1.0)] * n + [Damage(k, e) for k, e in truth],
                                   duration_s=args.duration, profile=prof, seed=args.seed, midflight_fraction=0.0)
        by_eta: dict[float, list] = defaultdict(list)
        healthy_ok = 0
        for i, (k, eta) in enumerate(truth):
            profile = calibrate_profile([flights[i]])
            dh = diagnose_flight(flights[i], model, profile, keep_flight=False)
            healthy_ok += dh.verdict.status == "healthy"
            d = diagnose_flight(flights[n + i], model, profile, keep_flight=False)
            if d.decision is None:
                by_eta[eta].append((np.nan, False))
                continue
            by_eta[eta].append((d.decision.motors[k - 1].eta_hat - eta, d.verdict.motor == k))
        for eta in etas:
            r = by_eta[eta]
            err = np.array([e for e, _ in r], float)
            ok = np.mean(np.abs(err) <= 0.05) if len(err) else float("nan")
            print(f"  {prof:12s} {eta:4.1f} {len(r):3d} {100 * ok:11.0f}% {np.nanmean(err):+9.3f} "
                  f"{sum(nm for _, nm in r):6d}")
        print(f"  {prof:12s} healthy flights of the same airframes (re-diagnosed with their own profile): "
              f"{healthy_ok}/{n} healthy   ({time.perf_counter() - t0:.0f} s)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profiles", type=Path, default=None)
    ap.add_argument("--profiled-only", action="store_true",
                    help="only the sets diagnosed with a profile (e.g. to compare two folders of profiles)")
    ap.add_argument("--sim-per-eta", type=int, default=6)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--skip-sim", action="store_true")
    ap.add_argument("--skip-real", action="store_true")
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per real flight")
    args = ap.parse_args()
    if not args.skip_real:
        if not SHARED.is_dir():
            print("skipped real part: ../shared is not present")
        else:
            spread_figures()
            real_part(args)
    if not args.skip_sim:
        sim_part(args)


if __name__ == "__main__":
    main()
