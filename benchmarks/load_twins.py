"""Simulated load twins of the damaged cases the decision scores: log files and a manifest.

    python benchmarks/load_twins.py OUT_DIR [--quick] [--per-cell 1] [--seed 9300] [--duration 50]
                                    [--frames quad_x,hexa_x,octo_x] [--profiles px4_high,...] [--esc] [--force]

The cases are :mod:`bench_reliability`'s simulated ones (random airframes of 30 g to 5 kg with
realistic imbalance and real-log noise, one rotor damaged from take-off at eta 0.6-0.9, waypoint
and manual missions, every logging profile but ``training``), each airframe flown six times in
one batch (the same airframe, imbalance and, with ``--esc``, motors and ESCs):

==============  ==========================================================================
role            flight
==============  ==========================================================================
``twin``        healthy, no load: the flight a ``--no-adapt`` profile is calibrated on
``healthy``     healthy, no load
``damaged``     rotor k damaged (eta), no load
``load``        healthy propellers, a fixed point mass of 5-30 % of the take-off mass
                anywhere from the centre to a rotor (half the draws toward a rotor, half in
                a random direction; up to 8 cm below or 2 cm above the frame)
``load2``       healthy propellers, a payload swinging on a line (0.3-1.5 m, 5-30 %) or the
                battery moved (25 % of the mass, 10-50 % of the arm along x, ±10 % along y),
                alternating airframe by airframe
``damaged_load`` the ``damaged`` flight's damage and one load drawn as above (fixed, line or
                battery 2:1:1)
==============  ==========================================================================

Loads are drawn by sim/loads.py (``random_load``, its ranges); one the airframe cannot hover with
(``check_flyable``, with its damage and imbalance) is moved toward the centre and lightened
(never below 5 %), alternately, until it can (``make_flyable``); the manifest holds what was
flown. Logs: PX4 profiles as ULog (``.ulg``, the truth also under
``fdlog_truth``), ArduPilot ones as DataFlash (``.bin``). ``manifest.csv``: one row per file
with the truth (role, damaged motor and eta, each load's kind, mass, mass fraction of the
take-off mass, position, line length, the loaded CoM and take-off mass, the twin's file).
Deterministic for ``--seed``. The default set is 3 frames x 6 profiles x 1 airframe x 6 flights
= 108 flights of 50 s (a few minutes on one core); ``--quick`` 12 flights of 30 s (quad, two
profiles). Scoring is not done here: the manifest is what a scorer reads (:func:`read_manifest`).
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

#: Seed of the load-twin set: apart from bench_reliability's (9100, 12100) and training's.
LOAD_TWIN_SEED = 9300
LOG_PROFILES = ("px4_high", "px4_default", "ardupilot_fast", "ardupilot", "ardupilot_slow", "ardupilot_rcou")
FRAMES = ("quad_x", "hexa_x", "octo_x")
ETAS = (0.6, 0.7, 0.8, 0.9)
ROLES = ("twin", "healthy", "damaged", "load", "load2", "damaged_load")
QUICK = dict(frames=("quad_x",), profiles=("px4_high", "ardupilot"), duration_s=30.0)

MANIFEST_FIELDS = ["file", "role", "frame", "rotor_count", "log_profile", "airframe", "airframe_mass_kg",
                   "mission", "damaged_motor", "eta", "cause", "load_kind", "load_mass_kg", "load_mass_fraction",
                   "load_x_m", "load_y_m", "load_z_m", "load_toward_motor", "load_arm_fraction", "line_length_m",
                   "loads", "com_x_m", "com_y_m", "com_z_m", "take_off_mass_kg", "twin_file", "seed", "duration_s",
                   "airborne_s"]


def _cell(frame: str, profile: str, per_cell: int, seed: int, duration_s: float, esc: bool, cell: int = 0):
    """The flights of one frame and logging profile: (flights, roles, airframe index, damage)."""
    from flightlog_fd.sim.airframe import random_airframes
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage, min_feasible_eta
    from flightlog_fd.sim.imbalance import random_imbalances
    from flightlog_fd.sim.loads import make_flyable, random_load

    rng = np.random.default_rng(seed)
    afs = random_airframes(per_cell, rng, frames=(frame,))
    imbs = random_imbalances(afs, rng)
    vehicles = []  # (airframe index, role, damage, loads, mission)
    for i, (af, imb) in enumerate(zip(afs, imbs)):
        nrot = af.rotor_count
        eta = max(ETAS[(seed + i) % len(ETAS)], round(float(min_feasible_eta(af)) + 0.005, 2))
        dmg = Damage(int(rng.integers(1, nrot + 1)), eta, rotors=nrot)
        healthy = Damage(0, 1.0, rotors=nrot)
        mission = "waypoints" if (cell + i) % 2 == 0 else "manual"
        second = random_load(af, rng, "line" if (seed + i) % 2 == 0 else "battery")
        pick = rng.uniform()
        with_damage = random_load(af, rng, "point" if pick < 0.5 else "line" if pick < 0.75 else "battery")
        plan = {"twin": (healthy, ()), "healthy": (healthy, ()), "damaged": (dmg, ()),
                "load": (healthy, (make_flyable(af, random_load(af, rng, "point"), healthy, imb),)),
                "load2": (healthy, (make_flyable(af, second, healthy, imb),)),
                "damaged_load": (dmg, (make_flyable(af, with_damage, dmg, imb),))}
        for role in ROLES:
            vehicles.append((i, role, plan[role][0], plan[role][1], mission))
    esc_spec = None
    if esc:
        from flightlog_fd.sim.esc import random_esc_params

        per_af = [random_esc_params(af, np.random.default_rng([seed, 7, i])) for i, af in enumerate(afs)]
        esc_spec = [per_af[v[0]] for v in vehicles]
    flights = simulate_flights(len(vehicles), airframes=[afs[v[0]] for v in vehicles],
                               imbalance=[imbs[v[0]] for v in vehicles], damages=[v[2] for v in vehicles],
                               loads=[v[3] for v in vehicles], mission=[v[4] for v in vehicles],
                               duration_s=duration_s, profile=profile, noise="real_logs", midflight_fraction=0.0,
                               esc=esc_spec, seed=seed,
                               # every airframe shakes as a real one does (its intact propellers' residual
                               # imbalance and broadband floor, sim/prop_vibration.py): without it a raw
                               # accelerometer level is the manoeuvres' alone, and two healthy flights of
                               # one airframe differed 7.6x (ardupilot_fast, seed 9300)
                               prop_imbalance="residual")
    return flights, vehicles, afs


def make_load_twins(out: Path, *, frames: Sequence[str] = FRAMES, profiles: Sequence[str] = LOG_PROFILES,
                    per_cell: int = 1, seed: int = LOAD_TWIN_SEED, duration_s: float = 50.0, esc: bool = False,
                    force: bool = False, log=None) -> list[dict]:
    """Write the load-twin flights into ``out`` (module docstring) and return the manifest rows
    (also written to ``out/manifest.csv``). ``log``: a callable taking progress lines."""
    from flightlog_fd.logs.dataflash_writer import write_dataflash
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.sim.files import load_text

    out = Path(out)
    manifest = out / "manifest.csv"
    if manifest.exists() and not force:
        raise FileExistsError(f"{manifest} already exists (use --force to overwrite)")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for fi, frame in enumerate(frames):
        for pi, profile in enumerate(profiles):
            t0 = time.perf_counter()
            s = seed + 1000 * fi + 97 * pi
            flights, vehicles, afs = _cell(frame, profile, per_cell, s, duration_s, esc, cell=fi + pi)
            ext = ".ulg" if profile.startswith("px4") else ".bin"
            names = [f"{frame}_{profile}_{v[0]:02d}_{v[1]}{ext}" for v in vehicles]
            for fl, v, name in zip(flights, vehicles, names):
                i, role, dmg, loads, mission = v
                fl.path = str(out / name)
                fl.vehicle_id = f"loadtwin-{frame}-{profile}-{i}"
                (write_ulog if ext == ".ulg" else write_dataflash)(fl, out / name)
                t = fl.truth
                lt = t.get("loads") or []
                first = lt[0] if lt else {}
                lm = t.get("load_mass") or {}
                com = lm.get("com_m") or [0.0, 0.0, 0.0]
                pos = first.get("position_m") or ["", "", ""]
                rows.append({
                    "file": name, "role": role, "frame": frame, "rotor_count": afs[i].rotor_count,
                    "log_profile": profile, "airframe": i, "airframe_mass_kg": round(afs[i].mass, 4),
                    "mission": mission, "damaged_motor": int(dmg.motor), "eta": dmg.eta if dmg.motor else "",
                    "cause": dmg.cause if dmg.motor else "", "load_kind": first.get("kind", ""),
                    "load_mass_kg": first.get("mass_kg", ""), "load_mass_fraction": first.get("mass_fraction", ""),
                    "load_x_m": pos[0], "load_y_m": pos[1], "load_z_m": pos[2],
                    "load_toward_motor": "", "load_arm_fraction": "",
                    "line_length_m": first.get("length_m", ""), "loads": ";".join(load_text(x) for x in lt),
                    "com_x_m": com[0], "com_y_m": com[1], "com_z_m": com[2],
                    "take_off_mass_kg": lm.get("take_off_mass_kg", round(afs[i].mass, 6)),
                    "twin_file": f"{frame}_{profile}_{i:02d}_twin{ext}",
                    "seed": s, "duration_s": duration_s, "airborne_s": _airborne(t)})
                rows[-1].update(_toward(afs[i], first))
            if log:
                log(f"  {frame} {profile}: {len(flights)} flights ({time.perf_counter() - t0:.0f} s)")
    with open(manifest, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=MANIFEST_FIELDS)
        w.writeheader()
        w.writerows(rows)
    return rows


def _airborne(truth: dict):
    """Lift-off to touchdown, s ("" when the flight never took off or never landed)."""
    a, b = truth.get("takeoff_s"), truth.get("touchdown_s")
    return round(b - a, 2) if a is not None and b is not None else ""


def _toward(af, load: dict) -> dict:
    """The rotor a fixed or line load sits nearest in direction, and its radius over the arm."""
    if not load or load.get("kind") == "battery":
        return {}
    x, y = load["position_m"][:2]
    r = float(np.hypot(x, y))
    if r < 1e-9:
        return {"load_toward_motor": 0, "load_arm_fraction": 0.0}
    rotors = af.geometry().rotors
    cos = [(x * q.x + y * q.y) / (r * np.hypot(q.x, q.y)) for q in rotors]
    return {"load_toward_motor": int(np.argmax(cos)) + 1, "load_arm_fraction": round(r / af.arm, 4)}


def read_manifest(folder: Path) -> list[dict]:
    """The manifest rows of a load-twin folder (strings as written; numbers where written)."""
    with open(Path(folder) / "manifest.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def count_table(rows: list[dict]) -> str:
    """Flights per frame and logging profile by role, and per load kind."""
    roles = Counter((r["frame"], r["log_profile"], r["role"]) for r in rows)
    cells = sorted({(r["frame"], r["log_profile"]) for r in rows})
    lines = ["| frame | profile | " + " | ".join(ROLES) + " |", "|---|---|" + "---|" * len(ROLES)]
    for c in cells:
        lines.append(f"| {c[0]} | {c[1]} | " + " | ".join(str(roles[c + (k,)]) for k in ROLES) + " |")
    kinds = Counter((r["load_kind"] or "none", r["role"]) for r in rows)
    lines.append("")
    lines.append("| load kind | " + " | ".join(ROLES) + " | total |")
    lines.append("|---|" + "---|" * (len(ROLES) + 1))
    for k in sorted({x[0] for x in kinds}):
        n = [kinds[(k, role)] for role in ROLES]
        lines.append(f"| {k} | " + " | ".join(map(str, n)) + f" | {sum(n)} |")
    fr = [float(r["load_mass_fraction"]) for r in rows if r["load_kind"] in ("point", "line")]
    if fr:
        lines.append(f"\nfixed and line loads: mass fraction {min(fr):.2f}-{max(fr):.2f} of the take-off mass "
                     f"(median {np.median(fr):.2f}); {len(rows)} flights")
    return "\n".join(lines)


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="folder for the logs and manifest.csv")
    ap.add_argument("--quick", action="store_true", help="12 flights of 30 s (quad, px4_high and ardupilot)")
    ap.add_argument("--frames", default=None, help="comma-separated (default quad_x,hexa_x,octo_x)")
    ap.add_argument("--profiles", default=None, help="comma-separated logging profiles (default all but training)")
    ap.add_argument("--per-cell", type=int, default=1, help="airframes per frame and profile (6 flights each)")
    ap.add_argument("--seed", type=int, default=LOAD_TWIN_SEED)
    ap.add_argument("--duration", type=float, default=None, help="planned flight time, s (default 50; quick 30)")
    ap.add_argument("--esc", action="store_true", help="add ESC telemetry (the same motors and ESCs per airframe)")
    ap.add_argument("--force", action="store_true", help="overwrite an existing manifest")
    a = ap.parse_args(argv)
    kw = dict(QUICK) if a.quick else {}
    if a.frames:
        kw["frames"] = tuple(a.frames.split(","))
    if a.profiles:
        kw["profiles"] = tuple(a.profiles.split(","))
    if a.duration:
        kw["duration_s"] = a.duration
    t0 = time.perf_counter()
    try:
        rows = make_load_twins(a.out, per_cell=a.per_cell, seed=a.seed, esc=a.esc, force=a.force,
                               log=lambda s: print(s, file=sys.stderr, flush=True), **kw)
    except (FileExistsError, ValueError) as e:
        print(f"load_twins: {e}", file=sys.stderr)
        return 2
    print(count_table(rows))
    print(f"\nwrote {len(rows)} flights and {a.out / 'manifest.csv'} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
