"""No false alarm on real healthy airframes: the shipped model, no profile, every real healthy
quadrotor flight in ../shared (skips when it is absent). The figure pilots judge the tool by:
not one `damaged`, and at least 80 % `healthy` (benchmarks/bench_real_airframes.py prints the
same with the motor-balance rule beside it)."""
from __future__ import annotations

import pytest

from flightlog_fd.diagnose import diagnose_path, resolve_model
from flightlog_fd.training.targets import real_healthy_logs


@pytest.mark.shared
def test_no_damaged_verdict_on_real_healthy_flights():
    logs = [lg.path for lg in real_healthy_logs()]
    if not logs:
        pytest.skip("../shared/real_healthy is absent")
    model = resolve_model()
    verdicts = {}
    for path in logs:
        d = diagnose_path(path, model, keep_flight=False)
        verdicts[path.name] = (d.verdict.status, d.verdict.reason)
    judged = {k: v for k, v in verdicts.items() if v[0] != "not_diagnosable"}
    damaged = {k: v[1] for k, v in judged.items() if v[0] == "damaged"}
    assert not damaged, f"false alarms on real healthy flights: {damaged}"
    healthy = sum(v[0] == "healthy" for v in judged.values())
    assert len(judged) >= 15 and healthy >= 0.8 * len(judged), verdicts
