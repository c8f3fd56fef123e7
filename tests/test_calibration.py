"""One calibration: `fdlog calibrate --no-adapt`, the web page's calibration job and the library
function write the same profile from the same flights."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app

SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"


def _comparable(path: Path) -> dict:
    """The profile file without its creation time (the only field that may differ)."""
    d = json.loads(Path(path).read_text())
    d.pop("created")
    for s in d.get("sessions_") or []:
        s.pop("created")
    return d


@pytest.mark.parametrize("log", ["px4_healthy.ulg", "px4_octo_healthy.ulg"])
def test_serve_job_and_cli_write_the_same_profile(tmp_path, log):
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.serve.worker import calibrate_task

    cli_out = tmp_path / "cli.json"
    r = CliRunner().invoke(app, ["calibrate", "--no-adapt", str(SAMPLES / log), "-o", str(cli_out)])
    assert r.exit_code == 0, r.output
    calibrate_task([str(SAMPLES / log)], str(tmp_path / "serve.json"), adapt=False)
    lib = calibrate([SAMPLES / log])
    cli = _comparable(cli_out)
    assert cli["analyzers"], "the analyzers' baselines are part of the profile"
    assert _comparable(tmp_path / "serve.json") == cli
    lib_d = json.loads(json.dumps(lib.to_dict()))
    lib_d.pop("created")
    for s in lib_d["sessions_"]:
        s.pop("created")
    assert lib_d == cli


def test_calibrate_refuses_to_overwrite_and_adapt_needs_a_path(tmp_path):
    from flightlog_fd.calibration import calibrate
    from flightlog_fd.errors import ProfileError

    out = tmp_path / "p.json"
    out.write_text("{}")
    with pytest.raises(ProfileError, match="already exists"):
        calibrate([SAMPLES / "px4_healthy.ulg"], output=out)
    with pytest.raises(ValueError, match="output"):
        calibrate([SAMPLES / "px4_healthy.ulg"], adapt=True)
