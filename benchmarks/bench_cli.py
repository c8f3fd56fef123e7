"""What a person waits for at the prompt: `fdlog --help`, `fdlog info LOG`, `fdlog diagnose LOG`.

    python benchmarks/bench_cli.py [--repeat 7] [--before REV] [--log FILE ...]

Each command runs as a fresh process (``python -c "from flightlog_fd.cli import main; main()"``,
what the ``fdlog`` script does); its wall time and its CPU time (user + system, from the
children's rusage: the figure a loaded machine disturbs least) are the median of ``--repeat``
runs. For ``diagnose`` it also prints the log's load time (``load_flight`` in this process, wall and
CPU, best of ``--repeat``) and the cold diagnose minus that load (issue 29's goal: at most 0.5 s).

``--before REV`` also runs the tree of git revision REV (extracted to a temporary folder, run
with the same interpreter and packages), alternating before / after run by run, and prints
after/before ratios: compare ratios from one run, never figures from different times. Prints the
load average, since the machine is shared. Figures: results/cli_speed.md.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Issue 29's goals.
GOAL_HELP_S = 0.3
GOAL_DIAGNOSE_OVER_LOAD_S = 0.5

_MAIN = "import sys; sys.argv = ['fdlog'] + sys.argv[1:]; from flightlog_fd.cli import main; main()"


def run_once(tree: Path | None, args: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one ``fdlog ARGS`` process running the package in ``tree`` (None: the
    installed one)."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", _MAIN, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=env, cwd=tempfile.gettempdir(), check=False)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def extract(rev: str, into: Path) -> Path:
    """The package tree of git revision ``rev`` (flightlog_fd, training, models) under ``into``."""
    archive = into / "tree.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(archive), rev, "flightlog_fd", "training", "models"],
                   check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into / "tree")
    return into / "tree"


def load_seconds(path: Path, repeat: int) -> tuple[float, float]:
    """(wall s, CPU s) of ``load_flight(path)`` in this process, each the best of ``repeat``."""
    from flightlog_fd import load_flight

    wall = cpu = float("inf")
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        load_flight(path)
        wall, cpu = min(wall, time.perf_counter() - t), min(cpu, time.process_time() - c)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--before", help="also time this git revision's tree, alternating with this one")
    ap.add_argument("--log", type=Path, nargs="*", default=[ROOT / "sample_logs" / "px4_healthy.ulg",
                                                           ROOT / "sample_logs" / "ardupilot_healthy.bin"])
    args = ap.parse_args()

    cases = [["--help"], ["diagnose", "--help"]]
    for log in args.log:
        cases += [["info", str(log.resolve())], ["diagnose", str(log.resolve())]]
    with tempfile.TemporaryDirectory() as tmp:
        trees: dict[str, Path | None] = {"after": None}
        if args.before:
            trees = {"before": extract(args.before, Path(tmp)), "after": None}
        print(f"load average at start: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")
        for name, tree in trees.items():  # compile each tree's .pyc first: not what a user waits for twice
            run_once(tree, ["--help"])
        times: dict[tuple[str, int], list[tuple[float, float]]] = {}
        for _ in range(args.repeat):
            for i, case in enumerate(cases):
                for name, tree in trees.items():
                    times.setdefault((name, i), []).append(run_once(tree, case))
        loads = {str(log.resolve()): load_seconds(log, args.repeat) for log in args.log}
        print(f"load average at end: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")

    cols = "".join(f" {n + ' wall':>12s} {n + ' cpu':>11s}" for n in trees)
    print(f"{'command':52s}{cols}" + (f" {'wall ratio':>10s} {'cpu ratio':>9s}" if len(trees) > 1 else ""))
    for i, case in enumerate(cases):
        label = "fdlog " + " ".join(Path(a).name if "/" in a else a for a in case)
        med = {n: (statistics.median(w for w, _ in times[(n, i)]), statistics.median(c for _, c in times[(n, i)]))
               for n in trees}
        row = "".join(f" {med[n][0]:12.3f} {med[n][1]:11.3f}" for n in trees)
        if len(trees) > 1:
            row += f" {med['after'][0] / med['before'][0]:9.2f}x {med['after'][1] / med['before'][1]:8.2f}x"
        note = ""
        if case == ["--help"]:
            note = f"  goal <= {GOAL_HELP_S} s"
        elif case[0] == "diagnose" and case[1] != "--help":
            load_wall, load_cpu = loads[case[1]]
            note = (f"  load {load_wall:.3f} s wall, {load_cpu:.3f} s cpu; after - load: wall "
                    f"{med['after'][0] - load_wall:.3f} s, cpu {med['after'][1] - load_cpu:.3f} s "
                    f"(goal <= {GOAL_DIAGNOSE_OVER_LOAD_S} s)")
        print(f"{label:52s}{row}{note}")


if __name__ == "__main__":
    main()
