"""How long `fdlog calibrate` (the default, adapted) takes, against another checkout's, in one run.

    python benchmarks/bench_calibrate_speed.py [--before /path/to/other/.venv/bin/fdlog] [--repeat 2]
                                               [--log sample_logs/ardupilot_healthy.bin]

Runs ``fdlog calibrate LOG -o ...`` alternately with this checkout's fdlog (the one beside this
Python) and, when given, ``--before`` (e.g. main's), ``--repeat`` times each, each in a fresh
process, and prints per run the wall time, the CPU time of the process (user + sys, which the
machine's other load disturbs less than the wall time), the load average when it started, and the
profile's adaptation summary (stage wall times inside the adaptation, simulated flights kept,
epochs, why training stopped); then the
median of each and the after/before ratios. Figures only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FDLOG = str(Path(sys.executable).with_name("fdlog"))


def one_run(fdlog: str, log: Path, out: Path) -> dict:
    """Wall and CPU seconds of one ``fdlog calibrate`` in a child process, and its summary."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run([fdlog, "calibrate", str(log), "-o", str(out), "--force"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit(f"{fdlog} calibrate failed (exit {r.returncode}): {r.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    ad = (json.loads(out.read_text()).get("extra") or {}).get("adaptation") or {}
    return {"wall": wall, "cpu": cpu, "load": load, "epochs": ad.get("epochs"), "stop": ad.get("stop_reason", "-"),
            "stages": {k.replace("_seconds", ""): ad.get(k) for k in ("simulate_seconds", "train_seconds", "total_seconds")
                       if ad.get(k) is not None},
            "data": (ad.get("data") or "").split(" like this airframe")[0]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", help="another checkout's fdlog (e.g. main's .venv/bin/fdlog)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--log", type=Path, default=ROOT / "sample_logs" / "ardupilot_healthy.bin")
    args = ap.parse_args()
    runs = [("after", FDLOG)] + ([("before", args.before)] if args.before else [])
    results: dict[str, list[dict]] = {name: [] for name, _ in runs}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeat):
            for name, fdlog in (runs if i % 2 == 0 else runs[::-1]):  # alternate who goes first
                res = one_run(fdlog, args.log, Path(tmp) / f"{name}.json")
                results[name].append(res)
                print(f"{name:6s} run {i + 1}: wall {res['wall']:6.1f} s  cpu {res['cpu']:6.1f} s  load {res['load']:5.2f}  "
                      f"epochs {res['epochs']} ({res['stop']}); stages (wall s, inside adapt) {res['stages']}; {res['data']}",
                      flush=True)
    print(f"\n{args.log.name}: median over {args.repeat} run(s) each")
    med = {name: {k: statistics.median(r[k] for r in rs) for k in ("wall", "cpu", "load")} for name, rs in results.items()}
    for name, m in med.items():
        print(f"  {name:6s}: wall {m['wall']:6.1f} s, cpu (user+sys) {m['cpu']:6.1f} s, load average {m['load']:.2f}")
    if "before" in med:
        print(f"  after/before: wall {med['after']['wall'] / med['before']['wall']:.3f}, "
              f"cpu {med['after']['cpu'] / med['before']['cpu']:.3f}")


if __name__ == "__main__":
    main()
