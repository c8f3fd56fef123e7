"""Where an adapted calibration spends its time: wall and CPU seconds per stage.

    python benchmarks/calibrate_stages.py [LOG] [--seed 0]

Runs `flightlog_fd.calibration.calibrate(adapt=True)` of LOG (default the 45 s ArduPilot sample)
in this process, timing the calls the adaptation makes (simulating and windowing the airframes,
the training, the ONNX export, the fitting of the profile's analyzers) by wrapping those library
functions, whichever of them the checkout has (an older one exports with ``export_onnx``, a newer
one with ``export_onnx_like``); "other" is the rest (loading the log, measuring the hover, the
dynamics filter of the target, imports). Run it with each checkout's Python to compare them (the
code is the one that Python imports); the CPU seconds (this process's) are less disturbed by the
machine's other load than the wall seconds. Prints one JSON line; asserts nothing.
"""
from __future__ import annotations

import argparse
import importlib
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

    timed: dict[str, list[float]] = {}

    def wrap(module: str, name: str, stage: str) -> None:
        mod = importlib.import_module(module)
        fn = getattr(mod, name, None)
        if fn is not None:
            setattr(mod, name, lambda *a, **k: _timed_call(timed, stage, fn, *a, **k))

    wrap("flightlog_fd.training.data", "simulate_windows", "simulate + window")
    wrap("flightlog_fd.training.train", "train_dcnn", "train")
    wrap("flightlog_fd.training.export", "export_onnx", "export")
    wrap("flightlog_fd.training.export", "export_onnx_like", "export")
    from flightlog_fd.profile import Profile

    fit = Profile.fit_analyzers
    Profile.fit_analyzers = lambda self, *a, **k: _timed_call(timed, "fit analyzers", fit, self, *a, **k)
    with tempfile.TemporaryDirectory() as tmp:
        profile = calibrate([args.log], adapt=True, output=Path(tmp) / "p.json", settings=AdaptSettings(seed=args.seed))
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    stages = {k: [round(w, 2), round(c, 2)] for k, (w, c) in timed.items()}
    stages["other"] = [round(wall - sum(w for w, _ in timed.values()), 2), round(cpu - sum(c for _, c in timed.values()), 2)]
    ad = (profile.extra or {}).get("adaptation") or {}
    import flightlog_fd

    print(json.dumps({"checkout": str(Path(flightlog_fd.__file__).parent.parent), "load": round(load, 2),
                      "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
                      "stages_wall_cpu_s": stages, "epochs": ad.get("epochs"), "stop_reason": ad.get("stop_reason"),
                      "data": (ad.get("data") or "")[:90]}))


def _timed_call(timed: dict, stage: str, fn, *a, **k):
    """fn(*a, **k), its wall and CPU seconds added to timed[stage]."""
    w0, c0 = time.perf_counter(), time.process_time()
    try:
        return fn(*a, **k)
    finally:
        acc = timed.setdefault(stage, [0.0, 0.0])
        acc[0] += time.perf_counter() - w0
        acc[1] += time.process_time() - c0


if __name__ == "__main__":
    main()
