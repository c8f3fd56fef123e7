"""Idle CPU and detection delay of the ways to watch a folder: watchdog (inotify), watchfiles
(Rust notify), and polling, raw and as `fdlog watch` uses them (flightlog_fd.watch.FolderWatch).

    python benchmarks/bench_watch.py [--files 2000] [--dirs 20] [--idle-s 60] [--ways all]

Each way runs in a subprocess of its own over the same tree of ``--files`` small files in
``--dirs`` folders (a fleet share after a season), idle for ``--idle-s`` seconds; printed: its CPU
time while idle (user + system, all threads) as seconds and as % of one core, its memory (max
RSS), and then the delay from a new file being written (closed) to the way noticing it
(FolderWatch: to handing it over, minus its settle time). Polling scans every ``--poll-s``
(flightlog_fd.watch.POLL_S). Compare figures from one run; the machine is shared.

Figures and the choice made from them: results/watch.md.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WAYS = ("watchdog", "watchfiles", "poll", "fdlog-events", "fdlog-poll")

CHILD = r'''
import os, sys, threading, time, resource
way, tree, idle_s, poll_s = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
seen = threading.Event()
stop = threading.Event()
new = None  # the file whose arrival is awaited
if way == "watchdog":
    from watchdog.observers import Observer
    from watchdog.events import FileSystemEventHandler
    class H(FileSystemEventHandler):
        def on_any_event(self, e):
            if new in (os.fsdecode(e.src_path), os.fsdecode(getattr(e, "dest_path", "") or "")):
                seen.set()
    obs = Observer(); obs.schedule(H(), tree, recursive=True); obs.start()
elif way == "watchfiles":
    import watchfiles
    def run():
        for changes in watchfiles.watch(tree, stop_event=stop, debounce=50, step=50):
            if any(p == new for _, p in changes):
                seen.set()
    threading.Thread(target=run, daemon=True).start()
elif way == "poll":
    def run():
        known = None
        while not stop.is_set():
            cur = {}
            for root, dirs, files in os.walk(tree):
                for n in files:
                    p = os.path.join(root, n)
                    try:
                        st = os.stat(p)
                    except OSError:
                        continue  # removed or renamed since the listing
                    cur[p] = (st.st_size, st.st_mtime_ns)
            if known is not None and new in cur and new not in known:
                seen.set()
            elif known is not None and new in cur and new in known and not seen.is_set():
                seen.set()  # written between two scans that both saw it: noticed now
            known = cur
            stop.wait(poll_s)
    threading.Thread(target=run, daemon=True).start()
else:
    from flightlog_fd.store import Store
    from flightlog_fd.watch import FolderWatch
    import tempfile
    store = Store(os.path.join(tempfile.mkdtemp(), "s.sqlite"))
    def sink(found):
        if found.path == new:
            seen.set()
        return "skip", ""
    w = FolderWatch([tree], store, sink, settle_s=1e-6, poll_s=poll_s if way == "fdlog-poll" else None)
    threading.Thread(target=w.run, daemon=True).start()
    time.sleep(1.0)
    while w._seen:  # the first pass over the tree (each file sniffed once) is not idle time
        time.sleep(0.2)
time.sleep(3.0)  # set-up (first scan, watches) is not idle time
t0, r0 = time.monotonic(), os.times()
time.sleep(idle_s)
r1 = os.times()
cpu = (r1.user - r0.user) + (r1.system - r0.system)
import random
delays = []
for k in range(5):  # at random moments: a polling way's delay depends on where in its period the file lands
    time.sleep(random.uniform(0.1, poll_s + 0.1))
    new = os.path.join(tree, "d0", f"new_file_{k}.ulg")
    seen.clear()
    t_write = time.monotonic()
    with open(new + ".tmp", "wb") as fh:
        fh.write(b"ULog" + b"x" * 1000)
    os.replace(new + ".tmp", new)
    delays.append(time.monotonic() - t_write if seen.wait(30) else float("nan"))
delay = sum(delays) / len(delays)
print(f"{cpu:.3f} {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} {delay:.3f} {max(delays):.3f}", flush=True)
stop.set()
os._exit(0)
'''


def make_tree(root: Path, n_files: int, n_dirs: int) -> None:
    for d in range(n_dirs):
        (root / f"d{d}").mkdir(parents=True, exist_ok=True)
    for i in range(n_files):
        (root / f"d{i % n_dirs}" / f"notes_{i}.dat").write_bytes(os.urandom(64))  # passed over after one look


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", type=int, default=2000)
    ap.add_argument("--dirs", type=int, default=20)
    ap.add_argument("--idle-s", type=float, default=60.0)
    ap.add_argument("--poll-s", type=float, default=2.0)
    ap.add_argument("--ways", default="all", help=f"comma-separated among {', '.join(WAYS)}")
    a = ap.parse_args()
    ways = WAYS if a.ways == "all" else tuple(a.ways.split(","))
    tmp = Path(tempfile.mkdtemp(prefix="fdlog-bench-watch-"))
    try:
        tree = tmp / "tree"
        make_tree(tree, a.files, a.dirs)
        print(f"load average {os.getloadavg()[0]:.2f}; {a.files} files in {a.dirs} folders; idle {a.idle_s:.0f} s; "
              f"polling every {a.poll_s:g} s")
        print(f"{'way':<14} {'idle CPU s':>10} {'% of a core':>11} {'max RSS MB':>10} {'noticed after s (mean of 5)':>28}")
        for way in ways:
            out = subprocess.run([sys.executable, "-c", CHILD, way, str(tree), str(a.idle_s), str(a.poll_s)],
                                 capture_output=True, text=True, timeout=a.idle_s + 120, cwd=str(tmp))
            if out.returncode != 0 or not out.stdout.strip():
                print(f"{way:<14} failed: {out.stderr.strip()[-300:]}")
                continue
            cpu, rss, delay, worst = out.stdout.split()
            print(f"{way:<14} {float(cpu):>10.3f} {100 * float(cpu) / a.idle_s:>10.3f}% {float(rss):>10.0f} "
                  f"{float(delay):>11.3f} (max {float(worst):.3f})")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
