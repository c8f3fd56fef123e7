"""Corrupted logs: time to load + diagnose each damaged file (goal: every case < 10 s).

    python benchmarks/bench_fuzz.py [--cases 40] [--stamps 12] [FILE...]

Uses the seeded mutations of ``tests/test_fuzz.py`` (truncations, single bit flips, zeroed and
duplicated blocks, and high-bit flips in data-message timestamps of a log cut in flight) on the
given logs, default every ``sample_logs/*.ulg`` / ``*.bin`` and the logs in
``../shared/real_logs`` (skipped when absent); then the test's "valid start + random bytes"
files (a ULog header or cut definitions, a DataFlash FMT message or cut FMT table, each with
``RANDOM_TAIL_SEEDS`` x ``RANDOM_TAIL_SIZES`` tails), where only exit 2 (not_diagnosable) is right. Runs ``diagnose_path`` in-process with the shipped
model loaded once (and one clean diagnosis first, so no case pays for imports); prints, per file,
the number of cases, the outcomes, the mean and the worst time with its case. Prints figures
only; the machine is shared, so read them as orders of magnitude.

Measured with ``nice -n 10 .venv/bin/python benchmarks/bench_fuzz.py`` (defaults: 40 random +
12 timestamp cases per file, the 10 sample logs and the 14 logs in ../shared/real_logs, 1248
cases) on the shared 2-core machine: 0 failed; mean per file 0.025-0.43 s (the 1.9-2.1 MB sample
ULogs are the slowest); worst case 0.83 s (px4_motor1_damaged.ulg flip offset=827 arg=7).
Before the timestamp checks, 7 of the 12 timestamp cases of px4_motor2_damaged.ulg ended in
MemoryError (1.64 TiB ... 3.28 PiB grids) or ran past 60 s, and damaged format definitions gave
KeyError tracebacks.
"""
from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", type=Path, nargs="*")
    ap.add_argument("--cases", type=int, default=40, help="random mutations per file")
    ap.add_argument("--stamps", type=int, default=12, help="timestamp bit flips per file")
    args = ap.parse_args()

    import tempfile

    import test_fuzz as fuzz
    from flightlog_fd.diagnose import diagnose_path
    from flightlog_fd.model import FaultModel, default_model_path

    files = args.files or sorted((ROOT / "sample_logs").glob("*.ulg")) + sorted((ROOT / "sample_logs").glob("*.bin"))
    shared = ROOT.parent / "shared" / "real_logs"
    if not args.files and shared.is_dir():
        files += sorted(p for p in shared.rglob("*") if p.suffix.lower() in (".ulg", ".bin"))
    elif not args.files:
        print("../shared/real_logs absent: sample logs only")

    model = FaultModel(default_model_path())
    diagnose_path(ROOT / "sample_logs" / "px4_motor4_damaged.ulg", model, keep_flight=False)
    worst_all = (0.0, "")
    total_cases, failed = 0, 0
    with tempfile.TemporaryDirectory() as tmp:
        for src in files:
            data = src.read_bytes()
            cases = fuzz.make_cases(src.name, len(data), args.cases) + fuzz.timestamp_cases(src.name, data, args.stamps)
            outcomes: Counter = Counter()
            times = []
            worst = (0.0, "")
            for case in cases:
                damaged = Path(tmp) / f"damaged{src.suffix}"
                damaged.write_bytes(fuzz.mutate(data, case))
                outcome, seconds = fuzz.run_case(damaged, model)
                outcomes[outcome if outcome in fuzz.STATUSES else "FAILED"] += 1
                if outcome not in fuzz.STATUSES:
                    failed += 1
                    print(f"  FAILED {case}: {outcome}")
                times.append(seconds)
                worst = max(worst, (seconds, str(case)))
            total_cases += len(cases)
            worst_all = max(worst_all, worst)
            summary = ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()))
            print(f"{src.name}: {len(cases)} cases ({summary}); mean {sum(times) / len(times):.3f} s, "
                  f"worst {worst[0]:.2f} s ({worst[1]})", flush=True)
        print("valid start + random bytes (tests/test_fuzz.py shapes; seeds x sizes):")
        for shape in fuzz.RANDOM_TAIL_SHAPES:
            outcomes = Counter()
            times = []
            worst = (0.0, "")
            for seed in fuzz.RANDOM_TAIL_SEEDS:
                for size in fuzz.RANDOM_TAIL_SIZES:
                    data, suffix = fuzz.random_tail_file(shape, seed, size)
                    damaged = Path(tmp) / f"random_tail{suffix}"
                    damaged.write_bytes(data)
                    outcome, seconds = fuzz.run_case(damaged, model)
                    outcomes[outcome] += 1
                    if outcome != "not_diagnosable":  # exit 2 is the only right answer here
                        failed += 1
                        print(f"  FAILED {shape} seed {seed} size {size}: {outcome}")
                    times.append(seconds)
                    worst = max(worst, (seconds, f"seed {seed} size {size}"))
            total_cases += len(times)
            worst_all = max(worst_all, (worst[0], f"{shape} {worst[1]}"))
            summary = ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()))
            print(f"{shape}: {len(times)} files ({summary}); mean {sum(times) / len(times):.3f} s, "
                  f"worst {worst[0]:.2f} s ({worst[1]})", flush=True)
    print(f"all: {total_cases} cases, {failed} failed, worst {worst_all[0]:.2f} s ({worst_all[1]})")


if __name__ == "__main__":
    main()
