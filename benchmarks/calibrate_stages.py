"""Where an adapted calibration spends its time: wall and CPU seconds per progress stage.

    python benchmarks/calibrate_stages.py [LOG] [--seed 0]

Runs `flightlog_fd.calibration.calibrate(adapt=True)` of LOG (default the 45 s ArduPilot sample)
in this process and splits the time at the stages its progress callback reports (whatever stages
the checkout has: an older one reports only "simulating" and "training"); "start" is everything
before the first report (loading the log, imports), "end" everything after the last stage began.
Run it with each checkout's Python to compare them (the code is the one that Python imports); the CPU seconds (this process's) are less
disturbed by the machine's other load than the wall seconds. Prints one JSON line; asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", nargs="?", type=Path, default=ROOT / "sample_logs" / "ardupilot_healthy.bin")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    load = os.getloadavg()[0]
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.training.adapt import AdaptSettings

    marks: list[tuple[str, float, float]] = [("start", t_wall, t_cpu)]

    def progress(stage: str, frac: float) -> None:
        if marks[-1][0] != stage:
            marks.append((stage, time.perf_counter(), time.process_time()))

    with tempfile.TemporaryDirectory() as tmp:
        profile = calibrate([args.log], adapt=True, output=Path(tmp) / "p.json", settings=AdaptSettings(seed=args.seed),
                            progress=progress)
    marks.append(("done", time.perf_counter(), time.process_time()))
    stages = {}
    for (name, w0, c0), (_, w1, c1) in zip(marks, marks[1:]):
        prev = stages.get(name, (0.0, 0.0))
        stages[name] = (round(prev[0] + w1 - w0, 2), round(prev[1] + c1 - c0, 2))
    ad = (profile.extra or {}).get("adaptation") or {}
    import flightlog_fd

    print(json.dumps({"checkout": str(Path(flightlog_fd.__file__).parent.parent), "load": round(load, 2),
                      "wall_s": round(marks[-1][1] - t_wall, 2), "cpu_s": round(marks[-1][2] - t_cpu, 2),
                      "stages_wall_cpu_s": stages, "epochs": ad.get("epochs"), "stop_reason": ad.get("stop_reason"),
                      "data": (ad.get("data") or "")[:90]}))


if __name__ == "__main__":
    main()
