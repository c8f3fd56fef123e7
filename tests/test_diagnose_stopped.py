"""`fdlog diagnose` reports "motor k stopped" (status ``stopped``, exit 1) on any frame, from
stopped.diagnose_stopped: the ArduPilot SITL hexa flights in ../shared, each with one motor stopped
mid-flight, and no such finding on the quad samples."""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app
from flightlog_fd.report.json_report import validate

HEXA = Path(__file__).resolve().parents[1].parent / "shared" / "ardupilot_sitl_hexa"
SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"
runner = CliRunner()


@pytest.mark.shared
@pytest.mark.skipif(not HEXA.is_dir(), reason="../shared/ardupilot_sitl_hexa is not present")
@pytest.mark.parametrize("motor", [1, 2, 3, 4, 5, 6])
def test_sitl_hexa_motor_stopped_is_reported_with_its_time(motor):
    res = runner.invoke(app, ["diagnose", "--json", str(HEXA / f"hexa_cwx_m{motor}.bin")])
    assert res.exit_code == 1, res.output
    doc = json.loads(res.stdout)
    assert validate(doc) == []
    v = doc["verdict"]
    assert v["status"] == "stopped" and v["motor"] == motor
    assert [s["motor"] for s in doc["stopped_motors"]] == [motor]
    # the README's stop time: the first RCOU sample of that output at 1000 us
    row = re.search(rf"\| hexa_cwx_m{motor}\.bin \| {motor} \| ([0-9.]+) \|", (HEXA / "README.md").read_text())
    assert row, "the README's table changed"
    assert abs(v["first_seen"] - float(row.group(1))) <= 2.0
    assert f"motor {motor} stopped" in v["reason"] and "damaged" not in v["reason"].split(";")[0]


def test_quad_samples_have_no_stopped_motor():
    for log in ("px4_motor1_damaged.ulg", "ardupilot_healthy.bin"):
        res = runner.invoke(app, ["diagnose", "--json", str(SAMPLES / log)])
        doc = json.loads(res.stdout)
        assert doc["stopped_motors"] == [] and doc["verdict"]["status"] != "stopped"
