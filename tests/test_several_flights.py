"""Several flights in one log (issue 23): each take-off to landing with its own verdict in the
JSON, CSV, store (``flight_part``, upgraded in place), `fdlog history` and the web flight page;
a flight never worse than its log with motor outputs (real healthy Erle 09-10-2014_31 flight 2
judged alone: damaged motor 2); `fdlog calibrate LOG --flight N`. Real-data tests skip when
../shared is absent."""
from __future__ import annotations

import csv
import io
import json
import sqlite3

import pytest
from typer.testing import CliRunner

from conftest import shared_path
from flightlog_fd.cli import app
from flightlog_fd.decision import Verdict, capped_by_log
from flightlog_fd.report.json_report import validate
from flightlog_fd.store import SCHEMA_VERSION, Store, load_history

runner = CliRunner()


def test_a_flight_is_never_worse_than_its_log():
    healthy = Verdict("healthy", confidence=0.8, reason="no rotor lost thrust")
    damaged2 = Verdict("damaged", motor=2, confidence=0.9, reason="motor 2 lost thrust")
    uncertain = Verdict("uncertain", confidence=0.6, reason="motor 4 may have lost thrust")
    capped = capped_by_log(damaged2, healthy, None)
    assert capped.status == "healthy" and capped.motor is None and capped.confidence == 0.8
    assert capped.reason.startswith("judged alone this flight would be damaged (motor 2): motor 2 lost thrust")
    assert capped_by_log(damaged2, uncertain, None).status == "uncertain"
    assert capped_by_log(damaged2, Verdict("damaged", motor=2), None) is damaged2
    other = capped_by_log(damaged2, Verdict("damaged", motor=3), None)  # another motor than the log's
    assert other.status == "uncertain" and other.motor == 2 and other.inspect == (2,)  # the one to inspect
    assert capped_by_log(healthy, damaged2, None) is healthy  # better than its log: its own
    nd = Verdict("not_diagnosable", reason="too short")
    assert capped_by_log(nd, damaged2, None) is nd


def test_erle_five_flights_each_with_its_verdict_and_no_false_alarm(tmp_path):
    log = shared_path("real_healthy", "logs", "erle_pxf_copter_09-10-2014_31.BIN")
    out_csv = tmp_path / "w.csv"
    db = tmp_path / "s.sqlite"
    res = runner.invoke(app, ["diagnose", "--json", "--csv", str(out_csv), "--db", str(db), str(log)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert validate(doc) == [] and doc["verdict"]["status"] == "healthy"
    flights = doc["flights"]
    assert [f["part"].split(",")[0] for f in flights] == [f"flight {i} of 5" for i in range(1, 6)]
    assert all(f["verdict"]["status"] == "healthy" for f in flights)
    # judged alone flight 2 points at motor 2 (the command pattern alone: uncertain, motor 2 or a load
    # at its corner); the whole log does not confirm it
    assert flights[1]["verdict"]["reason"].startswith("judged alone this flight would be uncertain (motor 2)")
    assert "flight 2 of 5: healthy" in doc["verdict"]["reason"]
    assert sum(len(f["windows"]) for f in flights) == len(doc["windows"])
    rows = list(csv.DictReader(io.StringIO(out_csv.read_text())))
    assert {r["flight"] for r in rows} == {f"flight {i} of 5" for i in range(1, 6)}
    assert {r["flight_verdict"] for r in rows} == {"healthy"}
    with Store(db) as store:
        (f,) = store.logs()
        parts = store.flight_parts(f["id"])
    assert [p["part"] for p in parts] == [1, 2, 3, 4, 5] and parts[1]["t_start_s"] == pytest.approx(234.8)
    assert [p["status"] for p in parts] == ["healthy"] * 5
    (records,) = load_history(db).values()
    assert len(records[0].parts) == 5
    text = runner.invoke(app, ["history", "--db", str(db)]).stdout
    assert "flight 2 of 5, 234.8-327.8 s" in text


def test_an_existing_store_gets_its_flight_rows_when_upgraded(tmp_path):
    """A store at migration 3 holding a diagnosis of a log with several flights: opening it runs
    migration 4, which fills flight_part from the stored report."""
    log = shared_path("real_vibration", "octo_air", "air_octo_03.BIN")
    db = tmp_path / "s.sqlite"
    assert runner.invoke(app, ["diagnose", "--db", str(db), str(log)]).exit_code == 1
    with sqlite3.connect(db) as c:  # back to what the release at migration 3 left
        c.execute("DROP TABLE flight_part")
        c.execute("DROP TABLE IF EXISTS watched_file")  # migration 5
        c.execute("DROP TABLE calibration_session")  # migration 6
        c.execute("ALTER TABLE flight DROP COLUMN cause")  # migration 7
        for column in ("verdict_motors", "pair"):  # migration 8's
            c.execute(f"ALTER TABLE flight DROP COLUMN {column}")
        for column in ("load_motor", "load_size", "load_direction_deg"):  # migration 9's
            c.execute(f"ALTER TABLE flight DROP COLUMN {column}")
        c.execute("DELETE FROM schema_migrations WHERE version >= 4")
        c.execute("PRAGMA user_version = 3")
    with Store(db) as store:
        assert store.db.schema_version() == SCHEMA_VERSION >= 4
        (f,) = store.logs()
        parts = store.flight_parts(f["id"])
    assert [(p["label"].split(",")[0], p["status"]) for p in parts] == [("flight 1 of 2", "healthy"),
                                                                      ("flight 2 of 2", "damaged")]


def test_the_web_flight_page_lists_each_flight(tmp_path):
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client

    log = shared_path("real_vibration", "octo_air", "air_octo_03.BIN")
    data = tmp_path / "data"
    data.mkdir()
    assert runner.invoke(app, ["diagnose", "--db", str(data / "fdlog.sqlite"), str(log)]).exit_code == 1
    with serve_client(data, workers=0) as c:
        fid = c.get("/api/logs").json()["logs"][0]["id"]
        page = c.get(f"/flights/{fid}").text
    assert 'id="parts"' in page and "flight 1 of 2, 57.0-137.0 s" in page and "flight 2 of 2, 376.8-464.9 s" in page
    parts = page[page.index('id="parts"'):page.index("</table>", page.index('id="parts"'))]
    assert parts.index("healthy") < parts.index("damaged", parts.index("flight 2 of 2"))
    assert "Healthy" in parts and ("lost" in parts or "Damage" in parts or "damaged" in parts)  # each flight's headline


def test_calibrate_on_one_flight_of_a_log(tmp_path):
    octo = shared_path("real_vibration", "octo_air")
    prof = tmp_path / "p.json"
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(octo / "air_octo_03.BIN"), "--flight", "1", "-o", str(prof)])
    assert res.exit_code == 0, res.output
    assert "calibrated on flight 1 of 2, 57.0-137.0 s" in res.output
    p = json.loads(prof.read_text())
    assert p["extra"]["flight"].startswith("flight 1 of 2") and p["analyzers"]["vibration"]["level"] == pytest.approx(5.95, abs=0.01)
    res = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof), str(octo / "air_octo_03.BIN"),
                              str(octo / "air_octo_14.BIN")])
    d03, d14 = json.loads(res.stdout)
    assert [f["verdict"]["status"] for f in d03["flights"]] == ["healthy", "damaged"]
    assert d14["verdict"]["status"] == "healthy"
    # the whole log's second flight (15 mm cut) is not a healthy calibration: a different profile
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(octo / "air_octo_03.BIN"), "--flight", "2", "-o",
                              str(tmp_path / "p2.json")])
    assert res.exit_code == 0 and json.loads((tmp_path / "p2.json").read_text())["analyzers"]["vibration"]["level"] > 20
    for args in (["--flight", "3", str(octo / "air_octo_03.BIN")],
                 ["--flight", "1", str(octo / "air_octo_03.BIN"), str(octo / "air_octo_14.BIN")]):
        res = runner.invoke(app, ["calibrate", "--no-adapt", *args, "-o", str(tmp_path / "x.json")])
        assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output
        assert not (tmp_path / "x.json").exists()
