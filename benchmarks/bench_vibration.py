"""Vibration evidence (issue 38): how often it speaks and how strongly, on every real log in
../shared and on simulated twins, one of each logging profile and frame.

``--real``: every real log of ../shared (each take-off to landing its own flight), without a
profile: the level against the healthy airframes, the rotor line (its stream, prominence,
accelerometer amplitude, whether it follows the rotors' speed, the tie and its probability), the
two parts of ``flight_llr``; octo_air against a profile from air_octo_14; the verdict of
``fdlog diagnose`` and whether vibration made it (its reason is the vibration's); the udesa log
cut down to ``sensor_combined`` alone (written into a temporary folder, never kept); the airborne
time the IMU alone finds against each log's own land detector.

``--sim`` (default): simulated twins written and read back as log files (`fdlog simulate`):
per (logging profile, frame) ``--airframes`` random airframes (``random_airframes``; quad only on
DataFlash, the writer's limit), each flown four times on the same mission and seed: healthy
(``--imbalance 1:0``, the residuals only), one propeller out of balance (``--imbalance K:G_MM``
sized so its hover line is 4-20 m/s/s, log-uniform: octo_air's real cuts raised VIBE by 24-26,
udesa's line is >= 18 m/s/s), the healthy twin carrying a payload (``--load point:P%@0,0,0.03``,
P 10-40 %), and the unbalanced twin with the payload. Each is judged by the analyzer without a
profile and against a profile from the healthy twin without the payload (``fit_vibration_baseline``,
what ``fdlog calibrate`` stores), and with ``--verdicts`` by ``diagnose_flight`` (shipped model,
profile from ``calibrate(adapt=False)``).

Printed per (profile, frame): the line shows (the fastest IMU stream >= 100 Hz), flagged
(``flight_llr`` at the posterior's uncertain bar for an untied line) without a profile, damaged (at its damaged bar) against the
profile; the rotor named right / wrong / none, and whether the rotors' speeds parted (the
analyzer's measure: the rotors' predicted lines further apart than twice the track's scatter);
healthy twins damaged; payload twins damaged; unbalanced payload twins found. Then the tie's
reliability: stated P(rotor k) against the fraction right, over every rotor of every tied flight.

    python benchmarks/bench_vibration.py [--sim] [--real] [--airframes N] [--seed S] [--verdicts] [--quick]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from flightlog_fd import load_flight
from flightlog_fd.analyzers.rotor_lines import rotors_parted
from flightlog_fd.analyzers.vibration import analyze_vibration, fit_vibration_baseline, log_reference, result_from
from flightlog_fd.decision import hypotheses, inspect_bar


def _untied_bars(n: int = 4) -> tuple[float, float]:
    """(uncertain, damaged): the flight_llr at which an untied line alone (no other source) makes
    the posterior's verdict uncertain (P(damage) at the inspection bar) and damaged (even odds)
    under the decision's stated prior, on an n-rotor: the bars the "flagged" and "damaged" counts
    below use, found by bisection on the decision itself."""
    from flightlog_fd.analyzers.vibration import VibrationResult

    def p_damage(f: float) -> float:
        r = VibrationResult("vibration", flight_llr=f, tie_probs=[1.0 / n] * n)
        return hypotheses([r], n, None).p_damage

    def solve(target: float) -> float:
        lo, hi = -10.0, 40.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if p_damage(mid) < target else (lo, mid)
        return round(hi, 2)
    return solve(inspect_bar()), solve(0.5)


UNCERTAIN_LLR, DAMAGED_LLR = _untied_bars()
from flightlog_fd.flights import imu_airborne, split_flights

ROOT = Path(__file__).resolve().parents[1]
SHARED = next((p for p in (ROOT.parent / "shared", Path("/work/shared")) if p.exists()), ROOT.parent / "shared")

#: (format, logging profile, frames, ESC rate): PX4 writes every frame; the DataFlash writer quads only.
N_FRAMES = ("quad_x", "quad_plus", "hexa_x", "hexa_plus", "octo_x", "octo_plus", "octaquad_x")
CONFIGS = ([("ulog", "px4_high", f, None) for f in N_FRAMES] + [("ulog", "px4_default", f, None) for f in N_FRAMES]
           + [("dataflash", p, f, None) for p in ("ardupilot_fast", "ardupilot") for f in ("quad_x", "quad_plus")]
           + [("ulog", "px4_high", f, 50.0) for f in ("quad_x", "hexa_x", "octo_x")])
QUICK = [("ulog", "px4_high", "quad_x", None), ("ulog", "px4_high", "octo_x", None),
         ("ulog", "px4_default", "hexa_x", None), ("dataflash", "ardupilot_fast", "quad_x", None),
         ("ulog", "px4_high", "quad_x", 50.0)]
LINE_MS2 = (4.0, 20.0)
PAYLOAD = (0.10, 0.40)
DURATION_S = 60.0


# ----------------------------------------------------------------------------- simulation


def _airframe(seed: int, frame: str):
    """The random airframe `fdlog simulate --airframe random --frame F --seed S` flies."""
    from flightlog_fd.sim.airframe import random_airframes

    return random_airframes(1, np.random.default_rng([seed, 3]), frames=(frame,))[0]


def _fly(path: Path, fmt: str, prof: str, frame: str, seed: int, imbalance: str, load, esc):
    from flightlog_fd.sim.files import simulate_to_files

    simulate_to_files(path, fmt=fmt, airframe="random", frame=frame, seed=seed, imbalance=[imbalance],
                      log_profile=prof, duration=DURATION_S, force=True, esc_rate=esc, loads=load,
                      vehicle_id=f"bench-{seed}")
    return load_flight(path)


def _judge(f, base):
    n = f.frame.rotor_count
    a0, a1 = analyze_vibration(f), analyze_vibration(f, base)
    return a0, a1, result_from(a0, n), result_from(a1, n)


#: The logged IMU shows the line when, at its folded hover frequency (±SHOW_BAND), the unbalanced
#: twin's spectrum carries SHOW_RATIO times the healthy twin's power in the gyro or the accelerometer.
SHOW_BAND = 0.08
SHOW_RATIO = 10.0


def _shows(fh, fu, f_hover: float) -> bool:
    """Truth, not the analyzer: does the logged IMU carry the line (folded or not)?"""
    from flightlog_fd.analyzers.rotor_lines import MIN_SPECTRUM_HZ, fold
    from flightlog_fd.analyzers.vibration import _intervals, spectrum

    for kind in ("gyro", "accel"):
        sh, su = (f.vibration.fastest(kind, batch=False) if f.vibration else None for f in (fh, fu))
        if sh is None or su is None or getattr(sh, kind).rate_hz < MIN_SPECTRUM_HZ:
            continue
        fs = getattr(su, kind).rate_hz
        fr = fold(f_hover, fs)
        pw = []
        for f, s in ((fh, sh), (fu, su)):
            x, p = spectrum(getattr(s, kind), _intervals(f))
            m = (x >= fr - SHOW_BAND * f_hover) & (x <= fr + SHOW_BAND * f_hover)
            pw.append(float(p[m].sum()) if m.any() else 0.0)
        if pw[0] > 0 and pw[1] / pw[0] >= SHOW_RATIO:
            return True
    return False


def run_sim(configs, n_air: int, seed: int, verdicts: bool) -> None:
    t0 = time.time()
    model = None
    if verdicts:
        from flightlog_fd.diagnose import resolve_model

        model = resolve_model()
    rng = np.random.default_rng(seed)
    print(f"Simulated twins: {n_air} random airframes per (profile, frame), {DURATION_S:.0f} s waypoints; "
          f"imbalance line at hover {LINE_MS2[0]:g}-{LINE_MS2[1]:g} m/s/s, payload +{100 * PAYLOAD[0]:.0f}-"
          f"{100 * PAYLOAD[1]:.0f} %; flagged: flight_llr >= {UNCERTAIN_LLR:g}, damaged >= {DAMAGED_LLR:g}")
    head = (f"{'format/profile/frame':<34} {'shows':>5} {'flag dmg|p':>10} | {'unbalanced: flag dmg|prof':>26} | {'named rgt wrg no':>16} | "
            f"{'parted':>6} {'named':>5} | {'healthy dmg':>11} | {'payload dmg':>11} | {'pay+unb found':>13}"
            + (" | verdicts H/U/D unb(prof) hlt(prof) pay(prof)" if verdicts else ""))
    print(head)
    ties = []  # (stated p_k, is the truth)
    tot = Counter()
    with tempfile.TemporaryDirectory(prefix="bench_vib_") as tmp:
        tmp = Path(tmp)
        for fmt, prof, frame, esc in configs:
            c = Counter()
            vc = defaultdict(Counter)
            for i in range(n_air):
                s = int(rng.integers(1, 10 ** 6))
                af = _airframe(s, frame)
                n = af.rotor_count
                k = int(rng.integers(1, n + 1))
                a = float(np.exp(rng.uniform(*np.log(LINE_MS2))))
                w_hover = af.omega_max * np.sqrt(af.hover_command)
                gmm = a * af.mass / w_hover ** 2 * 1e6
                pay = float(rng.uniform(*PAYLOAD))
                load = [f"point:{100 * pay:.0f}%@0,0,0.03"]
                ext = ".ulg" if fmt == "ulog" else ".bin"
                fl = {tag: _fly(tmp / f"{tag}{ext}", fmt, prof, frame, s, imb, ld, esc)
                      for tag, imb, ld in (("h", "1:0", None), ("u", f"{k}:{gmm:.3f}", None),
                                           ("p", "1:0", load), ("pu", f"{k}:{gmm:.3f}", load))}
                base = fit_vibration_baseline(split_flights(fl["h"]))
                shows = _shows(fl["h"], fl["u"], w_hover / (2 * np.pi))
                res = {tag: _judge(f, base) for tag, f in fl.items()}
                a0, a1, r0, r1 = res["u"]
                c["unb"] += 1
                c["shows"] += shows
                c["shows_flag"] += shows and (a0.flight_llr or -9) >= UNCERTAIN_LLR
                c["shows_dmg"] += shows and (a1.flight_llr or -9) >= DAMAGED_LLR
                c["flag"] += (a0.flight_llr or -9) >= UNCERTAIN_LLR
                c["dmg_np"] += (a0.flight_llr or -9) >= DAMAGED_LLR
                c["dmg_p"] += (a1.flight_llr or -9) >= DAMAGED_LLR
                named = r1.line_motor
                c["named_" + ("no" if named is None else "right" if named == k else "wrong")] += 1
                par = rotors_parted(a1.line)
                c["parted"] += par
                c["parted_named"] += par and named == k
                if a1.line is not None and a1.line.tie_source and a1.line.follows:
                    ties.extend((p, j + 1 == k) for j, p in enumerate(a1.line.tie_probs))
                for tag in ("h", "p"):
                    a0, a1, _, _ = res[tag]
                    c[tag + "_dmg"] += max(a0.flight_llr or -9, a1.flight_llr or -9) >= DAMAGED_LLR
                    c[tag + "_unc_np"] += (a0.flight_llr or -9) >= UNCERTAIN_LLR
                c["pu_found"] += (res["pu"][1].flight_llr or -9) >= DAMAGED_LLR
                if verdicts:
                    from flightlog_fd.calibration import calibrate
                    from flightlog_fd.diagnose import diagnose_flight

                    try:
                        prof_h = calibrate([fl["h"]])
                    except Exception as e:  # a flight calibrate refuses: counted, not hidden
                        prof_h = None
                        vc["calibrate_refused"][type(e).__name__] += 1
                    for tag in ("u", "h", "p"):
                        for pr, lab in ((None, "np"), (prof_h, "p")):
                            if lab == "p" and pr is None:
                                continue
                            v = diagnose_flight(fl[tag], model, pr, keep_flight=False).verdict
                            st = v.status
                            if tag == "u" and st == "damaged":
                                # right: rotor k named; wrong: another rotor named; every: no rotor
                                # named, every propeller (or a list holding k) to inspect; missed: a
                                # list that leaves k out
                                st += "+" + ("right" if v.motor == k else "wrong" if v.motor is not None else
                                             "every" if not v.inspect or k in v.inspect else "missed")
                            vc[f"{tag}_{lab}"][st] += 1
            for key in c:
                tot[key] += c[key]
            label = f"{fmt[:2]}/{prof}/{frame}" + (f"/esc{esc:g}" if esc else "")
            row = (f"{label:<34} {c['shows']:>5} {c['shows_flag']:>4} {c['shows_dmg']:>5} | {c['flag']:>4}/{c['unb']:<2} {c['dmg_np']:>3} {c['dmg_p']:>4}/{c['unb']:<2}"
                   f"      | {c['named_right']:>6} {c['named_wrong']:>3} {c['named_no']:>3} | {c['parted']:>6} "
                   f"{c['parted_named']:>5} | {c['h_dmg']:>5}/{n_air:<5} | {c['p_dmg']:>5}/{n_air:<5} | "
                   f"{c['pu_found']:>7}/{n_air:<5}")
            if verdicts:
                row += " | " + " ".join(f"{t}:{dict(vc[t])}" for t in sorted(vc))
            print(row, flush=True)
    print(f"the logged IMU shows the line in {tot['shows']} of {tot['unb']} unbalanced flights: flagged without a "
          f"profile {tot['shows_flag']}, damaged against the healthy twin's profile {tot['shows_dmg']}")
    print(f"all: unbalanced {tot['unb']}: flagged without a profile {tot['flag']}, damaged against the healthy "
          f"twin's profile {tot['dmg_p']}; rotor named right {tot['named_right']}, wrong {tot['named_wrong']}, "
          f"none {tot['named_no']}; the rotors' speeds parted in {tot['parted']} ({tot['parted_named']} of them "
          f"named); healthy twins damaged {tot['h_dmg']}, payload twins damaged {tot['p_dmg']}, unbalanced "
          f"payload twins found {tot['pu_found']}")
    _tie_reliability(ties)
    print(f"({time.time() - t0:.0f} s)")


def _tie_reliability(ties) -> None:
    if not ties:
        return
    p = np.array([t[0] for t in ties])
    y = np.array([t[1] for t in ties], dtype=float)
    print("tie reliability (every rotor of every flight whose line follows the rotors): stated P -> fraction right")
    for lo, hi in ((0.0, 0.05), (0.05, 0.2), (0.2, 0.5), (0.5, 0.8), (0.8, 0.9), (0.9, 0.99), (0.99, 1.01)):
        m = (p >= lo) & (p < hi)
        if m.any():
            print(f"  P {lo:.2f}-{min(hi, 1):.2f}: {int(m.sum()):4d} stated, mean {p[m].mean():.3f}, right {y[m].mean():.3f}")


# ----------------------------------------------------------------------------- real logs

REAL = {
    "real_vibration": "damaged (octo_air 03 flight 2, 10; udesa) / healthy (octo_air 03 flight 1, 14)",
    "real_healthy/logs": "healthy", "real_logs/ardupilot": "healthy", "real_logs/px4": "healthy (samples)",
    "real_damaged/rrc_straight": "rrc: good props healthy, symmetric cuts (no imbalance)",
    "crazypad_e9/ulog": "CrazyPAD: normals healthy, cuts / tape on motor 2 or 4",
    "px4_sih_dev/logs": "PX4 SIH (simulator): healthy and damaged, by its manifest",
}
DAMAGED_FLIGHTS = {("air_octo_03.BIN", 2), ("air_octo_10.BIN", 1), ("udesa_f450_prop13.ulg", 1)}


def _group(sub: str, name: str, flight: int) -> str:
    """The truth of one real flight: an out-of-balance propeller, healthy, or other damage."""
    if (name, flight) in DAMAGED_FLIGHTS:
        return "damaged (imbalance)"
    if sub.startswith("px4_sih_dev"):
        return "healthy" if _sih_labels().get(name.rsplit(".", 1)[0]) == "healthy" else \
            "other damage (rrc symmetric cuts, CrazyPAD cuts and tape, SIH thrust loss)"
    if REAL[sub].startswith("healthy") or "good_prop" in name or "normal_flight" in name or \
            name == "air_octo_14.BIN" or (name == "air_octo_03.BIN" and flight == 1):
        return "healthy"
    return "other damage (rrc symmetric cuts, CrazyPAD cuts and tape, SIH thrust loss)"


def _sih_labels() -> dict:
    import csv

    m = SHARED / "px4_sih_dev" / "manifest.csv"
    return {r["name"]: r["label"] for r in csv.DictReader(m.open())} if m.exists() else {}


def _files():
    for sub in REAL:
        d = SHARED / sub
        for p in sorted(d.rglob("*")):
            if p.is_file() and p.suffix.lower() in (".ulg", ".bin"):
                yield sub, p


def _vibration_made(v) -> bool:
    """True when the verdict's statement is the vibration's (raised by it, or judged from it alone)."""
    r = v.reason or ""
    return v.status in ("damaged", "uncertain") and (" propeller is likely damaged: vibration" in r or
                                                     "may be out of balance: vibration" in r or
                                                     "possibly out of balance: vibration" in r or
                                                     r.startswith("a propeller is") or "only vibration was judged" in r)


def run_real(verdicts: bool) -> None:
    from flightlog_fd.diagnose import diagnose_path, resolve_model

    t0 = time.time()
    model = resolve_model() if verdicts else None
    print(f"Real logs in {SHARED} (no profile): per flight, the level's and the line's evidence (nats)")
    print(f"{'log':<46} {'flight':<7} {'level':>14} {'lvl':>5} | {'line':<34} {'line':>5} | {'flight_llr':>10} | verdict")
    stats = defaultdict(list)
    for sub, p in _files():
        try:
            fl = load_flight(p)
        except Exception as e:
            print(f"{p.name[:46]:<46} unreadable: {e}")
            continue
        parts = split_flights(fl)
        verdict = None
        if verdicts:
            d = diagnose_path(p, model, keep_flight=False)
            verdict = d.verdict
        for i, part in enumerate(parts):
            ref = log_reference(parts, i) if fl.motors is None and len(parts) > 1 else None
            a = analyze_vibration(part, None, ref)
            r = result_from(a, part.frame.rotor_count if part.frame else 4)
            lv = "-" if a.level is None else f"{a.level.value:.2f} {a.level.kind}"
            ln = a.line
            line = "-" if ln is None else (f"{ln.freq_hz:.0f}Hz {ln.prominence:.0f}x {ln.kind} "
                                           + (f"{ln.amplitude:.2g}m/s2 " if ln.amplitude else "")
                                           + (f"m{r.line_motor} {max(r.tie_probs):.2f}" if r.line_motor else
                                              ("follows" if ln.follows else "fixed")))
            group = _group(sub, p.name, i + 1)
            if a.flight_llr is not None:
                stats[group].append(a.flight_llr)
            else:
                stats[group + " silent"].append(0)
            vtxt = ""
            if verdict is not None:
                vv = d.flights[i].verdict if d.flights and len(d.flights) == len(parts) else verdict
                vtxt = vv.status + (" (vibration)" if _vibration_made(vv) else "")
                stats[group + " verdict"].append(vtxt)
            fl_llr = "-" if a.flight_llr is None else f"{a.flight_llr:+.2f}"
            lvl_llr = "-" if a.level_llr is None else f"{a.level_llr:+.1f}"
            print(f"{(sub.split('/')[0][:12] + '/' + p.name)[:46]:<46} {i + 1}/{len(parts):<5} {lv:>14} {lvl_llr:>5} | "
                  f"{line[:34]:<34} {a.line_llr:5.1f} | {fl_llr:>10} | {vtxt}", flush=True)
    print("summary (flights):")
    for g in sorted(stats):
        v = stats[g]
        if g.endswith("verdict"):
            print(f"  {g}: {dict(Counter(v))}")
        elif g.endswith("silent"):
            print(f"  {g}: {len(v)} flights without a vibration figure")
        else:
            x = np.array(v)
            print(f"  {g}: {len(x)} flights with a figure; flight_llr min {x.min():+.2f} median {np.median(x):+.2f} "
                  f"max {x.max():+.2f}; >= {UNCERTAIN_LLR:g}: {int((x >= UNCERTAIN_LLR).sum())}, >= {DAMAGED_LLR:g}: "
                  f"{int((x >= DAMAGED_LLR).sum())}")
    _octo_with_profile()
    _imu_only(verdicts, model)
    _airborne_from_imu()
    print(f"({time.time() - t0:.0f} s)")


def _octo_with_profile() -> None:
    octo = SHARED / "real_vibration" / "octo_air"
    if not octo.exists():
        return
    base = fit_vibration_baseline(split_flights(load_flight(octo / "air_octo_14.BIN")))
    print("octo_air against a profile from air_octo_14:")
    for name in ("air_octo_03.BIN", "air_octo_10.BIN", "air_octo_14.BIN"):
        for i, part in enumerate(split_flights(load_flight(octo / name))):
            a = analyze_vibration(part, base)
            print(f"  {name} flight {i + 1}: {a.ratio:.2f}x, flight_llr {a.flight_llr:+.1f}")


def _imu_only(verdicts: bool, model) -> None:
    """The udesa log cut down to sensor_combined (pyulog's writer), judged from vibration alone."""
    src = SHARED / "real_vibration" / "quad_udesa" / "udesa_f450_prop13.ulg"
    if not src.exists():
        return
    from pyulog import ULog

    with tempfile.TemporaryDirectory(prefix="bench_vib_imu_") as tmp:
        out = Path(tmp) / "sensor_combined_only.ulg"
        ULog(str(src), message_name_filter_list=["sensor_combined"]).write_ulog(str(out))
        fl = load_flight(out)
        a = analyze_vibration(fl)
        print(f"udesa cut to sensor_combined: airborne {fl.airborne_s:.0f} s ({fl.airborne_source}); level "
              f"{a.level.value:.1f} ({a.level.kind}), line {a.line.freq_hz:.1f} Hz, flight_llr {a.flight_llr:+.2f}")
        if verdicts:
            from flightlog_fd.diagnose import diagnose_path

            v = diagnose_path(out, model, keep_flight=False).verdict
            print(f"  verdict: {v.status}: {v.reason[:160]}")


def _airborne_from_imu() -> None:
    """The IMU's airborne time against each log's own (land detector / throttle)."""
    rows = []
    for sub, p in _files():
        if "px4_sih" in sub and not p.name.startswith("sih_00"):
            continue
        try:
            fl = load_flight(p)
        except Exception:
            continue
        ref = fl.airborne
        if not ref:
            continue
        est = imu_airborne(fl)
        inter = sum(max(0.0, min(b, d) - max(a, c)) for a, b in est for c, d in ref)
        rows.append((p.name, sum(b - a for a, b in ref), sum(b - a for a, b in est), inter))
    if not rows:
        return
    rec = np.array([r[3] / r[1] for r in rows])
    prec = np.array([r[3] / r[2] if r[2] > 0 else 0.0 for r in rows])
    print(f"airborne from the IMU alone against the log's own, {len(rows)} logs: recall median {np.median(rec):.2f} "
          f"(>= 0.9 in {int((rec >= 0.9).sum())}), precision median {np.median(prec):.2f} (>= 0.9 in "
          f"{int((prec >= 0.9).sum())}); worst: " + ", ".join(
              f"{r[0][:28]} {r[3] / r[1]:.2f}/{(r[3] / r[2] if r[2] else 0):.2f}"
              for r in sorted(rows, key=lambda r: min(r[3] / r[1], r[3] / r[2] if r[2] else 0))[:5]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim", action="store_true")
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--airframes", type=int, default=3)
    ap.add_argument("--seed", type=int, default=3800)
    ap.add_argument("--verdicts", action="store_true", help="also diagnose_flight / diagnose_path verdicts")
    ap.add_argument("--quick", action="store_true", help=f"only {len(QUICK)} configurations")
    args = ap.parse_args()
    if args.real:
        run_real(args.verdicts)
    if args.sim or not args.real:
        run_sim(QUICK if args.quick else CONFIGS, args.airframes, args.seed, args.verdicts)


if __name__ == "__main__":
    main()
