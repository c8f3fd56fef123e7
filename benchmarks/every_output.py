"""Every output on every log: finds the logs a report cannot draw, or draws differently.

What: each log under the folders given (default: ``sample_logs/`` and every dataset of
``../shared``) is diagnosed ONCE through the library (``batch.diagnose_one``, the CLI's path), then
drawn by every report from that one result: the terminal with ``--windows``, JSON (validated),
CSV, HTML, the ``--db`` store, and the fleet page's flight page (the checks of
``tests/output_checks.py``, which the test_outputs_* files run). Prints each log's verdict, CPU
seconds and every problem found; a count per dataset. ``--cli`` also runs ``fdlog diagnose`` once
per dataset folder with every output at once and checks its exit code and that no traceback shows.

Run it nice'd: ``nice -n 10 .venv/bin/python benchmarks/every_output.py [FOLDER...] [--cli]``.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from output_checks import SAMPLES, FlightPages, log_files, output_problems, shared_datasets  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="*", type=Path)
    ap.add_argument("--cli", action="store_true", help="also fdlog diagnose once per folder, every output")
    args = ap.parse_args(argv)

    from flightlog_fd.batch import diagnose_one
    from flightlog_fd.diagnose import resolve_model
    from flightlog_fd.store import RunInfo, Store

    model = resolve_model()
    folders = args.folders or [SAMPLES, *shared_datasets()]
    failures: list[str] = []
    counts: dict[str, list] = {}
    with tempfile.TemporaryDirectory() as tmp:
        store, run = Store(Path(tmp) / "cli.sqlite"), RunInfo.for_batch(model)
        pages = FlightPages(Path(tmp) / "serve")
        for folder in folders:
            files = log_files(folder)
            counts[folder.name] = [len(files), 0, 0.0]
            for i, p in enumerate(files):
                t0 = time.process_time()
                res = diagnose_one(i, p, model, keep_flight=True)
                t1 = time.process_time()
                bad = output_problems(res, store, run) + pages.problems(res, p)
                cpu = time.process_time() - t0
                counts[folder.name][1] += bool(bad)
                counts[folder.name][2] += cpu
                v = res.diagnosis.verdict
                print(f"{folder.name}/{p.relative_to(folder)}: {v.status} {v.motor or ''} {v.cause or ''} exit "
                      f"{res.diagnosis.exit_code} ({t1 - t0:.1f} s diagnose, {cpu:.1f} s CPU)"
                      + "".join(f"\n    {b}" for b in bad), flush=True)
                failures += [f"{p}: {b}" for b in bad]
        pages.close()
        store.close()
    if args.cli:
        for folder in folders:
            with tempfile.TemporaryDirectory() as t:
                cmd = [str(Path(sys.executable).parent / "fdlog"), "diagnose", str(folder), "--windows", "--json",
                       "--csv", f"{t}/r.csv", "--html", f"{t}/r.html", "--db", f"{t}/r.sqlite"]
                r = subprocess.run(cmd, capture_output=True, text=True)
                tb = "Traceback" in r.stdout + r.stderr
                try:  # the folder's exit code: 2 if any log is not diagnosable, else the worst of 0 / 1
                    codes = [{"healthy": 0, "damaged": 1, "uncertain": 1, "stopped": 1}.get(x["verdict"]["status"], 2)
                             for x in json.loads(r.stdout)]
                    want = 2 if 2 in codes else max(codes)
                except (ValueError, KeyError, TypeError):
                    want = None
                print(f"CLI {folder.name}: exit {r.returncode} (documented {want}){' TRACEBACK' if tb else ''}",
                      flush=True)
                if tb or r.returncode != want:
                    failures.append(f"CLI {folder.name}: exit {r.returncode} {(r.stderr or '')[-300:]}")
    print("\nper dataset (logs, logs with a problem, CPU s):")
    for k, (n, f, cpu) in counts.items():
        print(f"  {k}: {n} logs, {f} with a problem, {cpu:.1f} s")
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
