"""The `fdlog` command line, driven through typer's CliRunner (click underneath).

Every command must have help text; bad input gives one line naming the file and exit code 2;
`info`, `simulate`, `calibrate --no-adapt` work end to end on logs the tests write themselves.
"""
from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app

runner = CliRunner()


def _commands():
    import typer.main

    group = typer.main.get_command(app)
    return group, group.commands


def test_every_command_has_help_text():
    group, commands = _commands()
    assert {"info", "diagnose", "calibrate", "simulate"} <= set(commands)
    for name, cmd in commands.items():
        assert cmd.help and len(cmd.help.strip()) > 20, f"command {name} has no help text"
        for p in cmd.params:
            if p.param_type_name == "option" and p.name != "help":
                assert p.help, f"option --{p.name} of {name} has no help text"
        res = runner.invoke(app, [name, "--help"])
        assert res.exit_code == 0
        assert "Usage" in res.output


@pytest.mark.parametrize("command", ["info", "diagnose"])
def test_not_a_log_is_one_line_and_exit_2(tmp_path, command):
    bad = tmp_path / "notes.ulg"
    bad.write_text("this is not a flight log\n")
    res = runner.invoke(app, [command, str(bad)])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert any("notes.ulg" in ln and "not a PX4 ULog or ArduPilot DataFlash log" in ln for ln in lines)
    assert "Traceback" not in res.output


def test_missing_and_empty_files(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    res = runner.invoke(app, ["info", str(empty), str(tmp_path / "missing.ulg")])
    assert res.exit_code == 2
    assert "empty.bin: empty file" in res.output
    assert "missing.ulg: no such file" in res.output


@pytest.fixture(scope="module")
def sim_logs(tmp_path_factory):
    """A short healthy ULog and a damaged DataFlash log written by `fdlog simulate`."""
    d = tmp_path_factory.mktemp("sim")
    ulg = d / "healthy.ulg"
    bin_ = d / "m2.bin"
    r1 = runner.invoke(app, ["simulate", "-o", str(ulg), "--duration", "30", "--seed", "3", "--airframe", "f450"])
    r2 = runner.invoke(app, ["simulate", "-o", str(bin_), "--format", "dataflash", "--motor", "2", "--eta", "0.75",
                             "--duration", "30", "--seed", "4"])
    assert r1.exit_code == 0, r1.output
    assert r2.exit_code == 0, r2.output
    return ulg, bin_


def test_simulate_writes_logs_that_info_reads(sim_logs):
    ulg, bin_ = sim_logs
    res = runner.invoke(app, ["info", "--json", str(ulg)])
    assert res.exit_code == 0, res.output
    d = json.loads(res.output)
    assert d["autopilot"] == "px4" and d["frame"]["name"] == "quad_x" and d["diagnosable"]
    assert 20 < d["airborne_s"] < 40
    rates = {s["name"]: s["rate_hz"] for s in d["streams"]}
    assert rates["rates"] == pytest.approx(250, rel=0.05)
    res = runner.invoke(app, ["info", "--json", str(bin_)])
    d = json.loads(res.output)
    assert d["autopilot"] == "ardupilot" and d["frame"]["motors"][1]["position"] == "rear-left"


def test_simulate_refuses_to_overwrite(sim_logs):
    ulg, _ = sim_logs
    before = ulg.read_bytes()
    res = runner.invoke(app, ["simulate", "-o", str(ulg), "--duration", "20"])
    assert res.exit_code == 2
    assert "already exists" in res.output
    assert ulg.read_bytes() == before


def test_simulate_is_deterministic(tmp_path):
    a, b = tmp_path / "a.ulg", tmp_path / "b.ulg"
    for p in (a, b):
        assert runner.invoke(app, ["simulate", "-o", str(p), "--duration", "15", "--seed", "9",
                                   "--motor", "4"]).exit_code == 0
    assert a.read_bytes() == b.read_bytes()


def test_simulate_bad_arguments(tmp_path):
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "x.ulg"), "--motor", "7"])
    assert res.exit_code == 2 and "--motor" in res.output
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "x.ulg"), "--rho", "1,2"])
    assert res.exit_code == 2 and "--rho" in res.output
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "x.ulg"), "--airframe", "zeppelin"])
    assert res.exit_code == 2 and "zeppelin" in res.output


def test_calibrate_no_adapt_writes_profile_and_refuses_overwrite(sim_logs, tmp_path):
    ulg, _ = sim_logs
    out = tmp_path / "quad.json"
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(ulg), "-o", str(out)])
    assert res.exit_code == 0, res.output
    prof = json.loads(out.read_text())
    assert prof["schema"] == 7 and prof["autopilot"] == "px4"
    assert prof["rho_"] == pytest.approx([1, 1, 1, 1], abs=0.02)  # the simulated f450 is balanced
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(ulg), "-o", str(out)])
    assert res.exit_code == 2 and "already exists" in res.output


def test_profile_for_another_autopilot_is_refused(sim_logs, tmp_path):
    ulg, bin_ = sim_logs
    out = tmp_path / "px4.json"
    assert runner.invoke(app, ["calibrate", "--no-adapt", str(ulg), "-o", str(out)]).exit_code == 0
    res = runner.invoke(app, ["diagnose", "--profile", str(out), str(bin_)])
    assert res.exit_code == 2
    assert "px4" in res.output and "ardupilot" in res.output


def test_calibrate_adapts_the_model_and_diagnose_uses_it(sim_logs, tmp_path):
    """A tiny calibration (few simulated flights, one epoch): the profile records an adapted
    ONNX model beside it, with decision offsets, and `diagnose --profile` uses that model."""
    ulg, _ = sim_logs
    out = tmp_path / "f450.json"
    res = runner.invoke(app, ["calibrate", str(ulg), "-o", str(out), "--flights", "16", "--epochs", "1"])
    assert res.exit_code == 0, res.output
    prof = json.loads(out.read_text())
    assert prof["model"]["path"] == "f450.onnx"
    assert (tmp_path / "f450.onnx").exists()
    adaptation = prof["extra"]["adaptation"]
    assert adaptation["domain_adaptation"] is True and len(adaptation["logit_bias"]) == 5
    from flightlog_fd.model import FaultModel

    m = FaultModel(tmp_path / "f450.onnx")
    assert m.version.startswith("calibrated-") and m.logit_bias.shape == (5,)
    res = runner.invoke(app, ["diagnose", "--json", "--profile", str(out), str(ulg)])
    assert res.exit_code in (0, 1), res.output
    doc = json.loads(res.stdout)
    assert doc["model"]["calibrated"] is True
    assert doc["verdict"]["status"] in ("healthy", "uncertain")  # its own healthy flight is never "damaged"
    # A changed model file is refused (the profile pins its sha256).
    (tmp_path / "f450.onnx").write_bytes(b"tampered")
    res = runner.invoke(app, ["diagnose", "--profile", str(out), str(ulg)])
    assert res.exit_code == 2 and "changed since calibration" in res.output


# ---------------------------------------------------------------- per-motor evidence (issue 9)

SAMPLES = __import__("pathlib").Path(__file__).resolve().parents[1] / "sample_logs"


def test_diagnose_json_has_per_motor_evidence_valid_against_schema():
    from flightlog_fd.report.json_report import validate

    res = runner.invoke(app, ["diagnose", "--json", str(SAMPLES / "px4_motor2_damaged.ulg")])
    assert res.exit_code == 1, res.output
    doc = json.loads(res.stdout)
    assert validate(doc) == [] and doc["schema"] == 8
    motors = doc["motors"]
    assert [m["motor"] for m in motors] == [1, 2, 3, 4]
    assert motors[1]["position"] == "rear-left"
    # the damaged motor carries the command excess and the model's vote; the verdict cites it
    assert max(motors, key=lambda m: m["command_change"])["motor"] == 2
    assert motors[1]["command_change"] > 0.25 and motors[1]["model_vote"] > 0.5
    assert all(m["command_share_baseline"] is None for m in motors)  # no profile: against neighbours
    assert doc["motor_evidence"]["baseline"] == "neighbours"
    assert doc["verdict"]["motor"] == 2 and "command share" in doc["verdict"]["reason"]
    eff = motors[1]["effectiveness_ci"]
    assert eff is None or eff[0] <= eff[1]
    # a broken per-motor entry is caught by the validator
    doc["motors"][0]["model_vote"] = 3.0
    assert any("motors[0].model_vote" in e for e in validate(doc))


def test_diagnose_with_profile_compares_against_calibration_and_html_panel(tmp_path):
    prof = tmp_path / "x500.json"
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(SAMPLES / "px4_healthy.ulg"), "-o", str(prof)])
    assert res.exit_code == 0, res.output
    assert "airborne mean" in res.output or "steady flight" in res.output or "hover" in res.output
    p = json.loads(prof.read_text())
    assert p["schema"] == 7 and p["baseline_"]["seconds"] > 20 and len(p["baseline_"]["share"]) == 4
    html = tmp_path / "r.html"
    res = runner.invoke(app, ["diagnose", "--profile", str(prof), "--json", "--html", str(html),
                              str(SAMPLES / "px4_motor1_damaged.ulg")])
    assert res.exit_code == 1, res.output
    doc = json.loads(res.stdout)
    assert doc["motor_evidence"]["baseline"] == "profile"
    assert all(m["command_share_baseline"] is not None for m in doc["motors"])
    assert (doc["verdict"]["status"], doc["verdict"]["motor"]) == ("damaged", 1)  # rotor 1 lost thrust, cause unknown
    assert "against calibration" in doc["verdict"]["reason"]
    page = html.read_text(encoding="utf-8")
    assert "Per-motor evidence" in page and 'class="motor-panel"' in page
    assert page.count("<tr") >= 5 and 'tr class="top"' in page  # the named motor is highlighted
    assert "front-right" in page


def test_calibrate_sample_logs_without_hover(tmp_path):
    """Both healthy sample logs calibrate, though neither holds 4 s of steady hover."""
    for name in ("px4_healthy.ulg", "ardupilot_healthy.bin"):
        out = tmp_path / (name + ".json")
        res = runner.invoke(app, ["calibrate", "--no-adapt", str(SAMPLES / name), "-o", str(out)])
        assert res.exit_code == 0, res.output
        assert json.loads(out.read_text())["rho_source_"] in ("hover", "steady flight", "airborne mean")


def test_help_keeps_square_brackets():
    """typer renders help as rich markup: an unescaped "[train]" would vanish from the install hint."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    fdlog = str(Path(sys.executable).with_name("fdlog"))
    env = {**os.environ, "COLUMNS": "250"}
    calibrate = subprocess.run([fdlog, "calibrate", "--help"], capture_output=True, text=True, env=env).stdout
    diagnose = subprocess.run([fdlog, "diagnose", "--help"], capture_output=True, text=True, env=env).stdout
    assert "flightlog-fd[train]" in calibrate
    assert "flightlog-fd[fleet]" in diagnose
