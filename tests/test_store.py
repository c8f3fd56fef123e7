"""The one store: stores written by fdlog 0.1 (the `--db` results store at schema 2 and 1, the serve
store at migration 2; SQL dumps in tests/data made by that release's own code) are upgraded in place
and keep reading; `fdlog diagnose --db`, `fdlog history` and the web pages read the same rows, named
as the JSON report names its per-motor fields; the same on PostgreSQL (skipped without a server)."""
from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd.cli import app
from flightlog_fd.store import MOTOR_COLUMNS, SCHEMA_VERSION, RunInfo, Store, load_history

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
DATA = Path(__file__).resolve().parent / "data"
TABLES = {"schema_migrations", "airframe", "flight", "motor_figure", "finding", "job", "flight_part", "watched_file",
          "calibration_session"}
runner = CliRunner()


def _from_dump(path: Path, dump: str) -> Path:
    with sqlite3.connect(path) as c:
        c.executescript((DATA / dump).read_text())
    return path


def _tables(db: Path) -> set[str]:
    with sqlite3.connect(db) as c:
        return {r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


@pytest.mark.parametrize("version", [2, 1])
def test_a_results_store_of_the_current_release_is_upgraded_in_place(tmp_path, version):
    db = _from_dump(tmp_path / "r.sqlite", "old_results_store_v2.sql")
    if version == 1:  # what fdlog wrote before findings were stored
        with sqlite3.connect(db) as c:
            c.execute("DROP TABLE finding")
            c.execute("UPDATE schema_version SET version = 1")
            c.execute("PRAGMA user_version = 1")
    hist = load_history(db)
    assert _tables(db) == TABLES
    with sqlite3.connect(db) as c:
        assert c.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert set(hist) == {"sim-12-0", "unknown"}
    (damaged,) = hist["sim-12-0"]
    assert (damaged.status, damaged.motor, damaged.vehicle_source) == ("damaged", 1, "sys_uuid")
    assert Path(damaged.log_path).name == "px4_motor1_damaged.ulg"
    m1 = damaged.motors[1]
    assert m1["position"] == "front-right"
    assert [round(m1[k], 4) for k in ("model_vote", "command_share", "effectiveness")] == [0.6305, 1.2842, 0.7861]
    others = [damaged.motors[k]["command_share"] for k in (2, 3, 4)]
    assert abs(m1["command_change"] - (m1["command_share"] - sum(others) / 3)) < 1e-9  # no baseline: the others
    assert m1["eta_hat"] is None  # not stored by that release
    with Store(db) as store:
        finds = store.findings(damaged.id)
        assert bool(finds) == (version == 2)
        if finds:
            assert {"model", "commands"} <= {f["analyzer"] for f in finds}
            assert all(f["direction"] in ("up", "down", "") for f in finds)
        assert {a["key"] for a in store.fleet()} == {"sim-12-0", "unknown"}  # the web fleet page reads it too
    res = runner.invoke(app, ["history", "--db", str(db)])
    assert res.exit_code == 1 and "rotor 1 lost thrust (propeller, motor or ESC, or something in its wash)" in \
        res.stdout  # no ESC rpm: no cause
    # the new code writes into it: the same log again replaces its diagnosis, now with every figure
    res = runner.invoke(app, ["diagnose", str(SAMPLES / "px4_motor1_damaged.ulg"), "--db", str(db)])
    assert res.exit_code == 1, res.output
    (again,) = load_history(db)["sim-12-0"]
    assert again.id == damaged.id and again.motors[1]["eta_hat"] is not None
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT COUNT(*) FROM flight").fetchone()[0] == 2


def test_a_serve_store_of_the_current_release_is_upgraded_in_place(tmp_path):
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client

    data = tmp_path / "data"
    data.mkdir()
    db = _from_dump(data / "fdlog.sqlite", "old_serve_store_m2.sql")
    with Store(db) as store:
        assert store.db.schema_version() == SCHEMA_VERSION
        fleet = {a["key"]: a for a in store.fleet()}
        named = [a for a in fleet.values() if a["name"] == "X500 #3"]
        assert len(named) == 1  # the operator's name kept
        fid = next(int(f["id"]) for a in fleet.values() for f in a["flights"] if f["status"] == "damaged")
        m1 = {m["motor"]: m for m in store.flight_motors(fid)}[1]
        doc = json.loads(store.flight(fid)["diagnosis_json"])
        j1 = doc["motors"][0]
        # the rows now carry every per-motor field of the stored report, under its names
        assert m1["eta_hat"] == j1["eta_hat"] and m1["weight"] == j1["weight"] and m1["llr"] == j1["llr"]
        assert [m1["eta_ci_lo"], m1["eta_ci_hi"]] == j1["eta_ci"]
        assert store.flight(fid)["model_sha256"] == doc["model"]["sha256"]
        finds = store.findings(fid)
        assert finds and {f["direction"] for f in finds} <= {"up", "down", ""} and any(f["direction"] for f in finds)
        hist = store.history()
    assert sorted(f.status for fl in hist.values() for f in fl) == ["damaged", "healthy"]
    with serve_client(data, workers=0) as c:
        key = named[0]["key"]
        page = c.get("/airframe", params={"key": key})
        assert page.status_code == 200 and "X500 #3" in page.text
        assert c.get(f"/flights/{fid}").status_code == 200
        assert len(c.get("/api/logs").json()["logs"]) == 2
    res = runner.invoke(app, ["history", "--db", str(db), "--json"])
    assert res.exit_code == 1, res.output  # the damaged flight is its airframe's latest


def test_history_and_the_web_pages_show_the_report_figures_under_its_names(tmp_path):
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client

    data = tmp_path / "data"
    data.mkdir()
    db = data / "fdlog.sqlite"
    log = SAMPLES / "px4_motor1_damaged.ulg"
    res = runner.invoke(app, ["diagnose", str(log), "--json", "--db", str(db)])
    assert res.exit_code == 1, res.output
    report = json.loads(res.stdout)
    res = runner.invoke(app, ["history", "--db", str(db), "--json"])
    (flight,) = json.loads(res.stdout)["vehicles"][0]["flights"]
    assert [set(m) for m in flight["motors"]] == [{"motor", *MOTOR_COLUMNS}] * 4
    for stored, m in zip(flight["motors"], report["motors"]):
        for name in ("model_vote", "command_share", "command_change", "effectiveness", "eta_hat", "weight", "llr"):
            assert stored[name] == m[name], name
        assert [stored["eta_ci_lo"], stored["eta_ci_hi"]] == m["eta_ci"]
    text = runner.invoke(app, ["history", "--db", str(db)]).stdout
    m1 = report["motors"][0]
    assert "m1 vote/change" in text and f"{m1['model_vote']:.2f}/{m1['command_change']:.3f}" in text
    with serve_client(data, workers=0) as c:  # the server reads the same store
        page = c.get("/airframe", params={"key": "sim-12-0"}).text
    assert "m1 vote / change" in page and f"{m1['model_vote']:.2f} / {m1['command_change']:.3f}" in page


def test_a_store_that_is_not_ours_or_is_newer_is_refused_in_one_line(tmp_path):
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as c:
        c.execute("CREATE TABLE diagnosis (x)")
    newer = _from_dump(tmp_path / "newer.sqlite", "old_results_store_v2.sql")
    with sqlite3.connect(newer) as c:
        c.execute("PRAGMA user_version = 7")
    for db, words in ((other, "not an fdlog store"), (newer, "schema version 7"),
                      (tmp_path / "missing.sqlite", "no such database")):
        res = runner.invoke(app, ["history", "--db", str(db)])
        assert res.exit_code == 2 and words in res.stderr and res.stderr.count("\n") == 1, res.stderr
    assert not (tmp_path / "missing.sqlite").exists()


def test_diagnose_db_and_history_on_postgresql(postgres):
    url = postgres.url()
    # the mid-flight sample stays damaged (px4_motor1_damaged is uncertain: the command pattern alone)
    logs = [str(SAMPLES / n) for n in ("px4_healthy.ulg", "px4_motor3_midflight.ulg")]
    res = runner.invoke(app, ["diagnose", *logs, "--db", url])
    assert res.exit_code == 1, res.output
    res = runner.invoke(app, ["diagnose", logs[1], "--db", url])  # again: replaced, not added
    res = runner.invoke(app, ["history", "--db", url, "--json"])
    assert res.exit_code == 1, res.output
    out = {v["vehicle"]: v for v in json.loads(res.stdout)["vehicles"]}
    assert len(out) == 2 and "sim-11-0" in out
    dmg = next(k for k in out if k != "sim-11-0")
    assert out[dmg]["latest_damaged"] and not out["sim-11-0"]["latest_damaged"]
    assert len(out[dmg]["flights"]) == 1 and out[dmg]["flights"][0]["motors"][2]["eta_hat"] is not None
    with Store(url) as store:
        assert store.dialect == "postgres" and store.db.schema_version() == SCHEMA_VERSION
        fid = out[dmg]["flights"][0]
        assert store.findings(store.db.one("SELECT id FROM flight WHERE sha256 = ?", (fid["log_sha256"],))["id"])


def test_run_info_names_the_vehicle_of_a_log_without_id_after_the_profile(tmp_path):
    from flightlog_fd.store import vehicle_identity

    run = RunInfo(model_sha256="m", profile_name="x500")
    assert vehicle_identity(None, None, run) == ("profile:x500", "profile")
    assert vehicle_identity("sim-1-0", "sys_uuid", run) == ("sim-1-0", "sys_uuid")
    assert vehicle_identity(None, None, RunInfo(model_sha256="m")) == ("unknown", "unknown")


def test_history_flags_a_latest_flight_that_asks_to_inspect_a_propeller(tmp_path):
    """A latest flight that is uncertain naming a propeller (the hexa sample without a profile, for a
    fleet whose prior of damage is 0.05: rotor 5 at P 0.35) is flagged as diagnose's exit 1 is:
    'inspect propeller 5', exit 1; a healthy latest flight is not."""
    db = str(tmp_path / "h.sqlite")
    hexa = "ardupilot_hexa_motor5_damaged.bin"
    res = runner.invoke(app, ["diagnose", "--prior-damage", "0.05", str(SAMPLES / hexa), str(SAMPLES / "px4_healthy.ulg"),
                              "--db", db])
    assert res.exit_code == 1, res.output
    res = runner.invoke(app, ["history", "--db", db, "--json"])
    assert res.exit_code == 1, res.output
    out = {Path(v["latest"]["log"]).name: v for v in json.loads(res.stdout)["vehicles"]}
    dmg, ok = out[hexa], out["px4_healthy.ulg"]
    assert not ok["latest_inspect"] and not ok["latest_damaged"]
    assert dmg["latest_inspect"] and not dmg["latest_damaged"] and dmg["latest"]["motors"] == [5], dmg
    text = runner.invoke(app, ["history", "--db", db]).stdout
    assert f"FLAG: latest flight uncertain: inspect propeller 5 ({hexa})" in text
