"""Profiles that know the airframe's loads (issue 32 item 4): `fdlog calibrate --add` turns a
healthy flight carrying another load into a load configuration of the profile (its own
command-share baseline), diagnose weighs each flight against the nearest configuration and names
it (reason, JSON ``profile.configuration``), a flight that fits a weak rotor is not turned into a
configuration, and a profile older than schema 7 is one configuration."""
from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from conftest import shared_path
from flightlog_fd.cli import app
from flightlog_fd.errors import ProfileError
from flightlog_fd.profile import AS_CALIBRATED, Profile

runner = CliRunner()


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    """A --no-adapt profile of px4_sih_dev's healthy sih_004 (``base``) and the same profile with
    px4_sih_dev_load's centre of mass moved 3 cm toward motor 1 added (``prof``)."""
    d = tmp_path_factory.mktemp("configs")
    base, prof = d / "base.json", d / "sih.json"
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(shared_path("px4_sih_dev", "logs", "sih_004.ulg")),
                              "-o", str(base)])
    assert res.exit_code == 0, res.output
    shutil.copy(base, prof)
    res = runner.invoke(app, ["calibrate", "--add", str(prof), str(shared_path("px4_sih_dev_load", "A_default_com_m1.ulg"))])
    return base, prof, res


def test_a_loaded_flight_becomes_a_configuration_not_a_session(loaded):
    base, prof, res = loaded
    assert res.exit_code == 0, res.output
    assert "added load configuration 'load toward motor 1 +2" in res.output, res.output
    d, b = json.loads(prof.read_text()), json.loads(base.read_text())
    assert d["schema"] == 7 and len(d["configurations_"]) == 1
    # the 'as calibrated' sessions, baseline and drift are unchanged
    assert d["sessions_"] == b["sessions_"] and d["baseline_"] == b["baseline_"]
    c = d["configurations_"][0]
    assert c["load"]["motor"] == 1 and 0.1 < c["load"]["size"] < 0.4 and abs(c["load"]["direction_deg"] - 45) < 20
    assert c["baseline_"]["share"][0] > 1.1 and c["baseline_"]["share"][1] < 0.9  # motor 1 up, its opposite down
    assert [e["name"] for s in c["sessions_"] for e in s["logs"]] == ["A_default_com_m1.ulg"]
    assert "model" in c["analyzers"]  # the model's own reading of this trim
    p = Profile.load(prof)
    assert p.configuration_names() == [AS_CALIBRATED, c["name"]] and len(p.baselines()) == 2


def test_the_same_load_is_weighed_against_its_configuration_and_named(loaded):
    """The same centre of mass on the default logging profile (motors at 10 Hz): against the
    configuration it is healthy, and the JSON (valid) and the reason name the configuration; a
    weak motor 1 (eta 0.7) is still damaged and named against 'as calibrated'."""
    from flightlog_fd.report.json_report import validate

    _, prof, _ = loaded
    res = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof),
                              str(shared_path("px4_sih_dev_load", "A_default_com_m1_p1.ulg"))])
    doc = json.loads(res.stdout)
    assert validate(doc) == []
    cfg = doc["profile"]["configuration"]
    assert cfg["name"].startswith("load toward motor 1") and cfg["of"] == 2 and cfg["load"]["motor"] == 1
    assert doc["verdict"]["status"] == "healthy", doc["verdict"]["reason"]
    assert f"against configuration '{cfg['name']}' (load toward motor 1" in doc["verdict"]["reason"]
    res = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof),
                              str(shared_path("px4_sih_dev", "logs", "sih_051.ulg"))])
    doc = json.loads(res.stdout)
    # the weak motor is still named against the healthy configuration (uncertain since only the
    # sources that read the command pattern point at it: a rotor, or a load at its corner)
    assert doc["verdict"]["status"] in ("damaged", "uncertain") and doc["verdict"]["motor"] == 1, doc["verdict"]["reason"]
    assert doc["profile"]["configuration"]["name"] == AS_CALIBRATED and validate(doc) == []


def test_a_weak_motor_is_not_turned_into_a_configuration(loaded, tmp_path):
    """sih_051 (motor 1 at 70 %) added, by itself or named as a configuration: refused with one
    line, the profile untouched."""
    _, prof, _ = loaded
    p = tmp_path / "p.json"
    shutil.copy(prof, p)
    before = p.read_bytes()
    weak = str(shared_path("px4_sih_dev", "logs", "sih_051.ulg"))
    for extra in ([], ["--name", "camera"]):
        res = runner.invoke(app, ["calibrate", "--add", str(p), weak, *extra])
        assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
        assert "looks damaged against" in res.output and "motor 1 lost thrust" in res.output
        assert p.read_bytes() == before


def test_an_old_profile_is_one_configuration_and_bad_configurations_are_refused(loaded, tmp_path):
    base, prof, _ = loaded
    d = json.loads(base.read_text())
    old = {k: v for k, v in d.items() if k != "configurations_"} | {"schema": 6}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    p = Profile.load(path)
    assert p.configurations_ == [] and p.configuration_names() == [AS_CALIBRATED] and len(p.baselines()) == 1
    assert p.to_dict()["schema"] == 7
    good = json.loads(prof.read_text())
    c = good["configurations_"][0]
    for bad, words in ((c | {"name": AS_CALIBRATED}, "used twice"), (c | {"name": ""}, "name"),
                       (c | {"sessions_": []}, "sessions_"), (c | {"load": {"motor": 9}}, "load"),
                       (c | {"baseline_": {**c["baseline_"], "share": [1.0, 1.0]}}, "baseline_.share")):
        path.write_text(json.dumps(good | {"configurations_": [bad]}))
        with pytest.raises(ProfileError, match=words):
            Profile.load(path)


def test_a_named_payload_the_decision_calls_damaged_is_taken_when_its_pattern_is_a_loads(tmp_path):
    """A simulated x500 with 15 % of its mass toward motor 2 (model and effectiveness read it as
    motor 2): without --name it is refused or, once the decision names the load, a configuration;
    with --name the pattern (a load fits the shares better than any rotor) makes it one."""
    logs = {}
    for name, extra in (("healthy.ulg", ["--seed", "1"]), ("load.ulg", ["--seed", "2", "--load", "point:15%@motor2"])):
        r = runner.invoke(app, ["simulate", "-o", str(tmp_path / name), "--duration", "40", *extra])
        assert r.exit_code == 0, r.output
        logs[name] = str(tmp_path / name)
    prof = tmp_path / "x500.json"
    assert runner.invoke(app, ["calibrate", "--no-adapt", logs["healthy.ulg"], "-o", str(prof)]).exit_code == 0
    before = prof.read_bytes()
    r = runner.invoke(app, ["calibrate", "--add", str(prof), logs["load.ulg"]])
    if r.exit_code == 2:
        assert "add it as a load configuration (--name NAME)" in r.output and prof.read_bytes() == before
    else:
        assert r.exit_code == 0 and "added load configuration 'load toward motor 2" in r.output, r.output
        prof.write_bytes(before)
    r = runner.invoke(app, ["calibrate", "--add", str(prof), logs["load.ulg"], "--name", "camera"])
    assert r.exit_code == 0 and "added load configuration 'camera'" in r.output, r.output
    d = json.loads(prof.read_text())
    assert [c["name"] for c in d["configurations_"]] == ["camera"] and d["configurations_"][0]["load"]["motor"] == 2
    assert d["sessions_"] == json.loads(before)["sessions_"]


def test_a_flight_nearest_a_configuration_joins_it_and_a_healthy_one_joins_as_calibrated(loaded, tmp_path):
    """The same load (10 Hz logging) added: a second session of its configuration; a healthy flight
    of another day: a session of 'as calibrated', whose drift then comes from healthy flights only."""
    _, prof, _ = loaded
    p = tmp_path / "p.json"
    shutil.copy(prof, p)
    res = runner.invoke(app, ["calibrate", "--add", str(p), str(shared_path("px4_sih_dev_load", "A_default_com_m1_p1.ulg"))])
    assert res.exit_code == 0 and "added 1 session to load configuration 'load toward motor 1" in res.output, res.output
    res = runner.invoke(app, ["calibrate", "--add", str(p), str(shared_path("px4_sih_dev", "logs", "sih_039.ulg"))])
    assert res.exit_code == 0 and "added session 2: sih_039.ulg" in res.output, res.output
    d = json.loads(p.read_text())
    assert len(d["sessions_"]) == 2 and [len(c["sessions_"]) for c in d["configurations_"]] == [2]
    assert d["baseline_"]["spread"] is not None and max(d["baseline_"]["spread"]) < 0.05  # not the load's 0.2
