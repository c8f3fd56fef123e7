"""Load against damage: the airborne-mean command pattern of each flight, as modes.

    python benchmarks/load_physics.py

For each set in ../shared it prints each flight's thrust-command shares (mean 1) against the
healthy reference of its airframe (the normal flights' mean; px4_sih_dev: the healthy flights'),
split into the quad's modes (mixer rows): roll (-y), pitch (x), yaw (spin) moments of the share
change, the throttle against the reference, and the fitted "rotor k" and "load toward d" patterns:
a rotor that gives less thrust raises its own command (yaw part = spin_k * its roll/pitch size),
a point mass moves roll/pitch only (yaw part 0). Figures only (results/load_vs_damage.md).
"""
from __future__ import annotations

import csv
from collections import defaultdict
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[1].parent / "shared"


def shares_throttle(path):
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.share_fit import airborne_thrust, shares_of

    fl = load_flight(path)
    s, thr = shares_of(airborne_thrust([fl]))
    return fl, s, thr


def modes(d, frame):
    """(roll, pitch, yaw) moments of a share change d (n,), rotors at unit arm."""
    xs = np.array([r.x for r in frame.rotors]); ys = np.array([r.y for r in frame.rotors])
    arm = np.sqrt(xs ** 2 + ys ** 2); xs, ys = xs / arm, ys / arm
    sp = np.array([r.spin for r in frame.rotors], float)
    return float(-ys @ d), float(xs @ d), float(sp @ d)


def describe(name, d, thr_ratio, frame):
    r, p, y = modes(d, frame)
    rp = np.hypot(r, p)
    ang = np.degrees(np.arctan2(-r, p))  # direction of the heavier side (x forward, y right)
    return (f"  {name:48s} " + " ".join(f"{v:+.3f}" for v in d) +
            f"  | roll {r:+.3f} pitch {p:+.3f} yaw {y:+.3f} | yaw/rp {y / rp if rp > 1e-9 else float('nan'):+.2f}"
            f" dir {ang:+5.0f} deg | thr {thr_ratio:.3f}")


def run_set(title, items, ref_names):
    """items: [(name, path, group)]."""
    data = {}
    frame = None
    for name, path, group in items:
        try:
            fl, s, thr = shares_throttle(path)
        except Exception as e:  # noqa: BLE001 - figures only
            print(f"  {name}: {e}")
            continue
        frame = frame or fl.frame
        data[name] = (group, s, thr)
    ref = np.mean([data[n][1] for n in ref_names if n in data], axis=0)
    thr_ref = np.mean([data[n][2] for n in ref_names if n in data])
    print(f"\n== {title}: share change against the mean of {len(ref_names)} reference flights "
          f"(motors 1..n), modes, heavier-side direction (0 = forward, +90 = right), throttle ratio ==")
    groups = defaultdict(list)
    for name, (group, s, thr) in data.items():
        d = s - ref
        print(describe(name, d, thr / thr_ref, frame))
        groups[group].append((d, thr / thr_ref))
    print("  -- group means --")
    for g, rows in groups.items():
        d = np.mean([r[0] for r in rows], axis=0)
        print(describe(f"{g} (n={len(rows)})", d, float(np.mean([r[1] for r in rows])), frame))


def main():
    # crazypad e9 + load
    cp = SHARED / "crazypad_e9"
    items = []
    for row in csv.DictReader(open(cp / "manifest.csv")):
        g = "normal" if row["condition"] == "normal_flight" else f"{row['condition']} m{row['damaged_px4_motors']}"
        items.append((row["file"].replace("__E9", ""), cp / "ulog" / row["file"], g))
    for row in csv.DictReader(open(SHARED / "crazypad_e9_load" / "manifest.csv")):
        items.append((row["file"].replace("__E9", ""), SHARED / "crazypad_e9_load" / "ulog" / row["file"], row["condition"]))
    run_set("CrazyPAD E9 (cuts, tape, loads)", items, [n for n, _, g in items if g == "normal"])
    # px4 sih
    sih = SHARED / "px4_sih_dev"
    items = []
    for row in csv.DictReader(open(sih / "manifest.csv")):
        p = sih / "logs" / f"{row['name']}.ulg"
        if p.exists():
            g = "healthy" if row["label"] == "healthy" else f"m{row['faulty_motor']} eta {row['eta']} {row['fault_class']}"
            items.append((row["name"], p, g))
    for p in sorted((SHARED / "px4_sih_dev_load").glob("*.ulg")):
        items.append((p.stem, p, p.stem))
    run_set("px4_sih_dev (weak motors) and px4_sih_dev_load (CoM moved)", items, [n for n, _, g in items if g == "healthy"])
    # ardupilot sitl quad
    aq = SHARED / "ardupilot_sitl_quad"
    if aq.is_dir():
        items = [(p.stem, p, p.stem) for p in sorted(aq.rglob("*.BIN"))]
        if items:
            run_set("ardupilot_sitl_quad", items, [items[0][0]])
    rrc = SHARED / "real_damaged" / "rrc_straight"
    items = [(p.stem, p, "good" if p.stem.startswith("good") else p.stem.split("_cut")[0]) for p in sorted(rrc.glob("*.BIN"))]
    run_set("rrc_straight (real cuts on motor 1)", items, [n for n, _, g in items if g == "good"])


if __name__ == "__main__":
    main()
