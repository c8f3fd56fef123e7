"""Make an adapted profile around an adapted model made before (e.g. by an older `fdlog calibrate`).

    python benchmarks/profile_with_model.py OUT.json MODEL.onnx LOG [LOG ...]

Runs what `flightlog_fd.calibration.calibrate(adapt=True)` runs after the adaptation (the
measured profile, one session per log, the model's analyzer baselines fitted with the model
marked as adapted on them) with ``MODEL.onnx`` in place of a fresh adaptation, and copies the
model beside OUT. So two adapted models, e.g. an old calibration's and a new one's, can be
compared on profiles that differ in nothing else (results/calibrate_speed.md). The model must be
an adapted model of these logs' airframe; nothing checks that.
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path


def main() -> None:
    if len(sys.argv) < 4:
        raise SystemExit(__doc__.split("\n\n")[1])
    out, model, logs = Path(sys.argv[1]), Path(sys.argv[2]), [Path(p) for p in sys.argv[3:]]
    from flightlog_fd.calibration import calibrate_profile, check_sessions
    from flightlog_fd.logs import load_flight
    from flightlog_fd.model import FaultModel
    from flightlog_fd.windows import FeatureSpec

    flights = [load_flight(p) for p in logs]
    groups = [[i] for i in range(len(flights))]
    fm = FaultModel(model)
    spec = FeatureSpec.from_dict(fm.feature_spec)
    profile = calibrate_profile(flights, spec=FeatureSpec.from_dict({**spec.to_dict(), "mean": None, "std": None}),
                                sessions=groups)
    check_sessions(flights, groups)
    onnx_out = out.with_suffix(".onnx")
    shutil.copyfile(model, onnx_out)
    profile.extra = {**(profile.extra or {}), "adaptation": fm.training,
                     "model_from": f"{model} (an adaptation made before)"}
    profile.set_model(onnx_out, profile_path=out)
    profile.fit_analyzers(flights, FaultModel(onnx_out), sessions=groups, adapted_on=True)
    profile.save(out, overwrite=True)
    print(json.dumps({"wrote": str(out), "model": str(onnx_out)}))


if __name__ == "__main__":
    main()
