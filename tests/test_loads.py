"""A load is not a propeller (issue 32): a moved centre of mass on genuine PX4 firmware is healthy
with the load named (JSON, CSV, terminal, the store at migration 9, history's drift rule), and a
weak motor on the same firmware is not read as a load."""
from __future__ import annotations

import csv
import io
import json
import sqlite3

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app

from conftest import shared_path

runner = CliRunner()


@pytest.fixture(scope="module")
def moved(tmp_path_factory):
    """The JSON report and the store of px4_sih_dev_load's centre of mass moved 3 cm toward motor 1,
    against a --no-adapt profile of the same airframe's healthy sih_004."""
    log = shared_path("px4_sih_dev_load", "A_default_com_m1.ulg")
    d = tmp_path_factory.mktemp("loads")
    prof, db = d / "sih004.json", d / "s.sqlite"
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(shared_path("px4_sih_dev", "logs", "sih_004.ulg")),
                              "-o", str(prof)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof), "--db", str(db), str(log)])
    return log, json.loads(res.stdout), res.exit_code, db, prof


def test_moved_centre_of_mass_is_healthy_with_the_load_named(moved):
    from flightlog_fd.report.json_report import validate

    log, doc, code, _, prof = moved
    v = doc["verdict"]
    assert validate(doc) == [] and doc["schema"] == 8 and code == 0
    assert (v["status"], v["cause"], v["load"]["motor"]) == ("healthy", "load", 1), v["reason"]
    assert v["reason"].startswith("propellers healthy: the load sits toward motor 1 (front-right)")
    assert 0.1 < v["load"]["size"] < 0.4 and abs(v["load"]["direction_deg"] - 45) < 20
    assert "more than at calibration" in v["reason"]
    text = runner.invoke(app, ["diagnose", "--profile", str(prof), str(log)]).stdout
    assert v["headline"] == "Healthy propellers; the load sits toward motor 1 (front-right): re-balance or re-calibrate"
    assert " ".join(text.split()).startswith(v["headline"])  # the first line (wrapped at 80 columns)
    assert [a["kind"] for a in v["advice"]][:2] == ["without_payload", "add_session"]


def test_csv_and_store_carry_the_load(moved, tmp_path):
    from flightlog_fd.store import SCHEMA_VERSION, Store

    log, _, _, db, prof = moved
    out = tmp_path / "w.csv"
    runner.invoke(app, ["diagnose", "--profile", str(prof), "--csv", str(out), str(log)])
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert rows and {(r["verdict_cause"], r["load_motor"]) for r in rows} == {("load", "1")}
    with Store(db) as store:
        (f,) = store.logs()
        row = store.flight(f["id"])
        assert (row["cause"], row["load_motor"]) == ("load", 1) and row["load_size"] > 0.1
    with sqlite3.connect(db) as c:  # back to what the release at migration 8 left
        for column in ("load_motor", "load_size", "load_direction_deg"):
            c.execute(f"ALTER TABLE flight DROP COLUMN {column}")
        c.execute("DELETE FROM schema_migrations WHERE version = 9")
        c.execute("PRAGMA user_version = 8")
    with Store(db) as store:  # migration 9 fills the columns from the stored report
        assert store.db.schema_version() == SCHEMA_VERSION >= 9
        (f,) = store.logs()
        assert store.flight(f["id"])["load_motor"] == 1


def test_weak_motor_is_not_a_load():
    """px4_sih_dev sih_051: motor 1 at 70 % thrust from take-off, no profile: its yaw part makes it
    a rotor, well beyond what a moved load explains. Only the command-pattern sources speak (no ESC,
    no vibration tie, no effectiveness): the log shows that rotor 1 lost thrust, not why, so the
    verdict is damaged, motor 1, its cause unknown."""
    from flightlog_fd.diagnose import diagnose_path, resolve_model

    d = diagnose_path(shared_path("px4_sih_dev", "logs", "sih_051.ulg"), resolve_model())
    cmd = next(r for r in d.decision.results if r.analyzer == "commands")
    assert (d.verdict.status, d.verdict.motor) == ("damaged", 1) and d.verdict.cause is None, d.verdict.reason
    assert d.verdict.load is None and cmd.rotor_vs_load[0] > 2.0
    assert d.verdict.headline.startswith("Rotor 1 (front-right) lost ~") and "inspect propeller 1" in d.verdict.headline


def test_drift_leaves_load_flights_out_of_the_command_pattern():
    """Motor 2's share rising flight after flight is a drift; the same rise on flights whose verdict
    names a load toward motor 2 (a payload carried on them) is not."""
    from flightlog_fd.drift import FlightRecord, find_drift

    def flight(i, share2, cause=None):
        shares = {1: 1.0, 2: share2, 3: 0.99, 4: 1.01}
        return FlightRecord(id=i, log_path=f"f{i}", log_sha256="", flight_start_utc=None, airborne_s=60.0,
                            status="healthy", motor=None, confidence=0.9, reason="", diagnosed_at="",
                            vehicle_source="", motors={k: {"command_share": v} for k, v in shares.items()},
                            cause=cause)
    rising = [flight(i, 1.0 + 0.04 * i) for i in range(5)]
    assert [d.motor for d in find_drift("v", rising) if d.figure == "command_share"] == [2]
    loaded = rising[:2] + [flight(i, 1.0 + 0.04 * i, "load") for i in range(2, 5)]
    assert not [d for d in find_drift("v", loaded) if d.figure == "command_share"]


def test_calibrate_add_takes_a_loaded_healthy_flight_and_says_so(moved, tmp_path):
    """Main refused it ("looks damaged against the 1 session ...: motor 1 lost thrust"): a flight
    whose only change is its load is added as a load configuration (its own baseline), the load
    named, the profile's sessions unchanged (tests/test_load_configurations.py for the rest)."""
    import shutil

    log, _, _, _, prof = moved
    p = tmp_path / "p.json"
    shutil.copy(prof, p)
    res = runner.invoke(app, ["calibrate", "--add", str(p), str(log)])
    assert res.exit_code == 0, res.output
    assert "added load configuration 'load toward motor 1" in res.output
    d = json.loads(p.read_text())
    assert len(d["sessions_"]) == 1 and len(d["configurations_"]) == 1


def test_a_weight_in_a_rotors_wash_is_not_called_a_damaged_propeller():
    """crazypad_e9_load W3: a heavier weight taped near PX4 motor 2, sound propellers. Its command
    pattern is a rotor-2 loss (the weight sits in its wash) and the 100 Hz log has no ESC telemetry,
    no usable vibration and no effectiveness fit: only the sources that read the commands speak.
    Rotor 2 lost thrust (true of a weight in its wash, issue 37), never called a damaged propeller:
    its cause is unknown, and the advice names what sits under rotor 2; exit 1."""
    res = runner.invoke(app, ["diagnose", "--json", str(shared_path("crazypad_e9_load", "ulog",
                                                                      "add_weight_W3_near_M3__E9_log01.ulg"))])
    assert res.exit_code == 1, res.output
    v = json.loads(res.stdout)["verdict"]
    assert (v["status"], v["motor"], v["motors"]) == ("damaged", 2, [2]), v["reason"]
    assert v["cause"] != "propeller" and "propeller 2 damaged" not in v["headline"].lower()
    assert not v["headline"].startswith("Propeller")
    inspect = [a["text"].split(":")[0] for a in v["advice"] if a["kind"] == "inspect"]
    assert "then what sits under rotor 2" in inspect or "inspect what sits under rotor 2" in inspect
