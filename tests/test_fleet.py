"""Fleet batches and the results store: the batch engines (serial, process pool, Dask LocalCluster)
give results in input order with one error row per bad log; `--db` writes SQLite rows that
`fdlog history` reads back with its drift flags; concurrent writers do not corrupt the store;
`diagnose` without `--scheduler` never imports dask; logs carry a vehicle identity.
"""
from __future__ import annotations

import json
import multiprocessing
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd import batch as batch_mod
from flightlog_fd.batch import LogResult, run_batch
from flightlog_fd.cli import app
from flightlog_fd.diagnose import Diagnosis, WindowResult
from flightlog_fd.drift import DRIFT_SLOPE_MIN
from flightlog_fd.store import SCHEMA_VERSION, RunInfo, Store, load_history, motor_rows
from flightlog_fd.decision import Verdict

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
runner = CliRunner()


def _sample_files() -> list[Path]:
    """Every sample log: quads, hexa and octo."""
    return sorted(p for p in SAMPLES.iterdir() if p.suffix in (".ulg", ".bin"))


def _corrupt(tmp_path: Path) -> Path:
    """A ULog cut inside its definitions (deterministic: pyulog can spin forever on some random bytes)."""
    bad = tmp_path / "corrupt.ulg"
    bad.write_bytes((SAMPLES / "px4_healthy.ulg").read_bytes()[:400])
    return bad


@pytest.fixture(scope="module")
def model():
    from flightlog_fd.diagnose import resolve_model

    return resolve_model()


# ----------------------------------------------------------------------------- engines

def test_dask_local_cluster_keeps_order_and_turns_a_corrupt_log_into_one_row(tmp_path, model):
    pytest.importorskip("dask.distributed")
    files = _sample_files()
    files.insert(3, _corrupt(tmp_path))
    seen = []
    results = run_batch(files, model, None, jobs=2, scheduler="local", processes=False,
                        on_result=lambda r: seen.append(r.index))
    assert [r.path for r in results] == [str(f) for f in files]
    assert sorted(seen) == list(range(len(files)))  # every log reported once as it finished
    bad = results[3]
    assert bad.diagnosis.verdict.status == "not_diagnosable" and bad.diagnosis.exit_code == 2
    assert bad.diagnosis.verdict.reason and "\n" not in bad.diagnosis.verdict.reason
    good = [r for i, r in enumerate(results) if i != 3]
    assert all(r.diagnosis.verdict.status in ("healthy", "damaged", "uncertain") for r in good)  # hexa: uncertain
    # same verdicts as the in-process engine
    serial = run_batch(files, model, None)
    assert [(r.diagnosis.verdict.status, r.diagnosis.verdict.motor) for r in serial] == \
           [(r.diagnosis.verdict.status, r.diagnosis.verdict.motor) for r in results]
    assert results[0].diagnosis.model.path == str(model.path)  # the user's model, not a worker copy


def test_a_worker_that_cannot_see_the_model_file_builds_it_from_the_scattered_bytes(model, monkeypatch):
    monkeypatch.setattr(batch_mod, "_MODEL_CACHE", {})
    payload = batch_mod.ModelPayload(Path(model.path).read_bytes(), model.sha256, "/elsewhere/model.onnx", None)
    m = batch_mod._cached_model(payload)
    assert m.sha256 == model.sha256 and str(m.path) == "/elsewhere/model.onnx"
    assert batch_mod._cached_model(payload) is m  # one session per worker and model
    r = batch_mod._dask_task(0, str(SAMPLES / "px4_healthy.ulg"), payload, False)
    assert r.diagnosis.verdict.status == "healthy" and r.diagnosis.model.path == "/elsewhere/model.onnx"


@pytest.mark.skipif(multiprocessing.get_start_method() != "fork", reason="needs fork to patch the workers")
def test_a_dying_pool_worker_costs_one_row_not_the_batch():
    # In a fresh interpreter: forking this test process after a Dask cluster ran in it is unsafe.
    code = r"""
import json, os, sys
from pathlib import Path
from flightlog_fd import batch
from flightlog_fd.diagnose import resolve_model
real = batch.diagnose_one
def exit_on_motor2(index, path, model, profile=None, keep_flight=False, **kw):  # runs in a forked pool worker
    if "motor2" in str(path):
        os._exit(3)
    return real(index, path, model, profile, keep_flight, **kw)
batch.diagnose_one = exit_on_motor2
files = sys.argv[1:]
results = batch.run_batch(files, resolve_model(), None, jobs=2)
print(json.dumps([[r.path, r.diagnosis.verdict.status, r.diagnosis.verdict.reason] for r in results]))
"""
    files = [str(SAMPLES / f"ardupilot_{n}.bin") for n in ("healthy", "motor1_damaged", "motor2_damaged",
                                                           "motor3_damaged")]
    res = subprocess.run([sys.executable, "-c", code, *files], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    rows = json.loads(res.stdout)
    assert [r[0] for r in rows] == files
    assert [r[1] for r in rows] == ["healthy", "damaged", "not_diagnosable", "damaged"]
    assert "died" in rows[2][2]


def test_a_dying_dask_worker_costs_one_row_not_the_batch(monkeypatch, model):
    pytest.importorskip("dask.distributed")
    import dask

    def exit_on_motor2(index, path, payload, keep_flight):  # local: cloudpickle sends it by value
        import os

        from flightlog_fd.batch import _dask_task  # in the worker process: the real one

        if "motor2" in path:
            os._exit(3)
        return _dask_task(index, path, payload, keep_flight)

    monkeypatch.setattr(batch_mod, "_dask_task", exit_on_motor2)
    files = [SAMPLES / f"ardupilot_{n}.bin" for n in ("healthy", "motor1_damaged", "motor2_damaged", "motor3_damaged")]
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        results = run_batch(files, model, None, jobs=2, scheduler="local", processes=True)
    assert [r.diagnosis.verdict.status for r in results] == ["healthy", "damaged", "not_diagnosable", "damaged"]
    assert "Dask worker failed" in results[2].diagnosis.verdict.reason


def test_diagnose_without_scheduler_never_imports_dask(tmp_path):
    code = r"""
import sys
class BlockDask:
    def find_spec(self, name, path=None, target=None):
        if name == "dask" or name.startswith(("dask.", "distributed")):
            raise ImportError("dask blocked by the test")
sys.meta_path.insert(0, BlockDask())
from flightlog_fd.cli import main
sys.argv = ["fdlog", "diagnose", sys.argv[1], sys.argv[2], "--jobs", "2", "--db", sys.argv[3]]
try:
    main()
except SystemExit as e:
    assert not any(m == "dask" or m.startswith(("dask.", "distributed")) for m in sys.modules)
    raise
"""
    files = [str(SAMPLES / "px4_healthy.ulg"), str(SAMPLES / "ardupilot_healthy.bin")]
    res = subprocess.run([sys.executable, "-c", code, *files, str(tmp_path / "r.sqlite")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "healthy" in res.stdout


# ----------------------------------------------------------------------------- CLI + store

def test_cli_scheduler_local_with_db_then_history(tmp_path, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(batch_mod, "LOCAL_CLUSTER_PROCESSES", False)  # threads start faster in a test
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("px4_healthy.ulg", "px4_motor1_damaged.ulg", "ardupilot_healthy.bin"):
        (logs / name).write_bytes((SAMPLES / name).read_bytes())
    _corrupt(logs)
    db = tmp_path / "r.sqlite"
    res = runner.invoke(app, ["diagnose", str(logs), "--scheduler", "local", "--jobs", "2", "--db", str(db)])
    assert res.exit_code == 2, res.output  # the corrupt log
    assert "corrupt.ulg" in res.stderr
    with sqlite3.connect(db) as c:
        rows = c.execute("SELECT flight.name, flight.airframe, airframe.source, flight.status, flight.motor FROM flight "
                         "JOIN airframe ON airframe.key = flight.airframe ORDER BY flight.name").fetchall()
        n_motor_rows = c.execute("SELECT COUNT(*) FROM motor_figure").fetchone()[0]
        assert c.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
        # every analyzer's findings came back from the Dask workers with the diagnosis
        analyzers_stored = {r[0] for r in c.execute("SELECT DISTINCT analyzer FROM finding")}
        assert {"model", "commands"} <= analyzers_stored
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    by_name = {Path(r[0]).name: r for r in rows}
    assert set(by_name) == {"px4_healthy.ulg", "px4_motor1_damaged.ulg", "ardupilot_healthy.bin", "corrupt.ulg"}
    assert by_name["px4_healthy.ulg"][1:4] == ("sim-11-0", "sys_uuid", "healthy")
    assert by_name["px4_motor1_damaged.ulg"][3:] == ("damaged", 1)  # rotor 1 lost thrust
    assert by_name["corrupt.ulg"][3] == "not_diagnosable"
    assert n_motor_rows == 12  # 4 per diagnosed log, none for the corrupt one

    # the same logs again (now serial): no duplicates
    res = runner.invoke(app, ["diagnose", str(logs), "--db", str(db)])
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT COUNT(*) FROM flight").fetchone()[0] == 4
        assert c.execute("SELECT COUNT(*) FROM motor_figure").fetchone()[0] == 12

    res = runner.invoke(app, ["history", "--db", str(db)])
    # sim-12-0's latest (only) flight: rotor 1 lost thrust, its cause unknown (no ESC rpm): history
    # flags it as diagnose's exit 1 does, never calling it a damaged propeller
    assert res.exit_code == 1, res.output
    assert "sim-12-0" in res.stdout and "damaged m1" in res.stdout
    assert "FLAG: latest flight: rotor 1 lost thrust (propeller, motor or ESC, or something in its wash) " \
           "(px4_motor1_damaged.ulg)" in res.stdout
    res = runner.invoke(app, ["history", "--db", str(db), "--vehicle", "sim-11-0", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert [v["vehicle"] for v in out["vehicles"]] == ["sim-11-0"] and not out["flagged"]
    motors = out["vehicles"][0]["flights"][0]["motors"]
    assert [m["motor"] for m in motors] == [1, 2, 3, 4]
    assert abs(sum(m["command_share"] for m in motors) - 4.0) < 1e-3  # shares of the mean (1 = even)


def _result(path: str, sha: str, vote: list[float], share: list[float], status="healthy", motor=None,
            vehicle="A1", utc=None) -> LogResult:
    windows = [WindowResult(10.0 * i, 10.0 * i + 5, 0, [max(0.0, 1 - sum(vote))] + list(vote), "hover", 0)
               for i in range(3)]
    d = Diagnosis(log=path, verdict=Verdict(status=status, motor=motor, confidence=0.9, reason="test"),
                  windows=windows)
    return LogResult(0, path, d, log_sha256=sha, vehicle_id=vehicle, vehicle_id_source="sys_uuid",
                     utc_start=utc, command_share=share)


RUN = RunInfo(model_sha256="m" * 64, model_version="test-1", tool_version="0.1.0")


def _drifting_db(db: Path, n: int = 5) -> None:
    """Airframe A1: motor 2's command share grows 1 % a flight; airframe B2 stays even."""
    with Store(db) as store:
        for i in range(n):
            extra = 0.01 * i
            share = [0.25 - extra / 3, 0.25 + extra, 0.25 - extra / 3, 0.25 - extra / 3]
            store.add_result(_result(f"a{i}.ulg", f"a{i:063d}", [0.0] * 4, share, utc=1.7e9 + 86400 * i), RUN)
            store.add_result(_result(f"b{i}.ulg", f"b{i:063d}", [0.0] * 4, [0.25, 0.251, 0.249, 0.25],
                              vehicle="B2", utc=1.7e9 + 86400 * i), RUN)


def test_history_flags_a_drifting_motor_and_writes_html(tmp_path):
    db = tmp_path / "r.sqlite"
    _drifting_db(db)
    page = tmp_path / "h.html"
    res = runner.invoke(app, ["history", "--db", str(db), "--html", str(page), "--json"])
    assert res.exit_code == 1, res.output
    out = json.loads(res.stdout)
    by_vehicle = {v["vehicle"]: v for v in out["vehicles"]}
    drift = by_vehicle["A1"]["drift"]
    assert [(d["motor"], d["figure"]) for d in drift] == [(2, "command_share")]
    assert drift[0]["slope_z_per_flight"] >= DRIFT_SLOPE_MIN
    assert by_vehicle["B2"]["drift"] == []
    assert [f["log"] for f in by_vehicle["A1"]["flights"]] == [f"a{i}.ulg" for i in range(5)]
    text = page.read_text()
    assert text.count("<svg") >= 2 and "<script" not in text and "A1" in text
    res = runner.invoke(app, ["history", "--db", str(db), "--vehicle", "B2"])
    assert res.exit_code == 0 and "FLAG" not in res.stdout


def test_history_needs_three_flights_and_ignores_a_steady_offset(tmp_path):
    db = tmp_path / "r.sqlite"
    with Store(db) as store:
        for i in range(2):  # strong drift but only two flights
            store.add_result(_result(f"a{i}.ulg", f"a{i:063d}", [0.0] * 4, [0.24, 0.25 + 0.05 * i, 0.24, 0.24]), RUN)
        for i in range(6):  # motor 3 always needs 3 % more: an offset, not a drift
            store.add_result(_result(f"c{i}.ulg", f"c{i:063d}", [0.0] * 4, [0.24, 0.24, 0.27, 0.25], vehicle="C3"), RUN)
    res = runner.invoke(app, ["history", "--db", str(db), "--json"])
    assert res.exit_code == 0, res.output
    assert not json.loads(res.stdout)["flagged"]


@pytest.mark.parametrize("kind", ["missing", "text", "other_sqlite"])
def test_history_bad_db_is_one_line_and_exit_2(tmp_path, kind):
    db = tmp_path / "r.sqlite"
    if kind == "text":
        db.write_text("not a database at all, just some text\n" * 20)
    elif kind == "other_sqlite":
        with sqlite3.connect(db) as c:
            c.execute("CREATE TABLE t (x)")
    res = runner.invoke(app, ["history", "--db", str(db)])
    assert res.exit_code == 2
    assert res.stderr.count("\n") == 1 and str(db) in res.stderr and "Traceback" not in res.output


def test_diagnose_refuses_a_db_that_is_not_ours(tmp_path):
    db = tmp_path / "r.sqlite"
    with sqlite3.connect(db) as c:
        c.execute("CREATE TABLE t (x)")
    res = runner.invoke(app, ["diagnose", str(SAMPLES / "px4_healthy.ulg"), "--db", str(db)])
    assert res.exit_code == 2 and "not an fdlog store" in res.stderr


def _write_many(args) -> None:
    db, worker, n = args
    with Store(db) as store:
        for i in range(n):
            store.add_result(_result(f"w{worker}_{i}.ulg", f"{worker:032d}{i:032d}", [0.1, 0.0, 0.0, 0.0],
                              [0.25] * 4, vehicle=f"V{worker}"), RUN)
            if i % 10 == 0:  # re-write an earlier log: an upsert, never a second row
                store.add_result(_result(f"w{worker}_0.ulg", f"{worker:032d}{0:032d}", [0.2, 0.0, 0.0, 0.0],
                                  [0.25] * 4, vehicle=f"V{worker}"), RUN)


def test_concurrent_writers_do_not_corrupt_the_store(tmp_path):
    db = tmp_path / "r.sqlite"
    n_procs, n_rows = 4, 60
    ctx = multiprocessing.get_context("spawn" if sys.platform != "linux" else "fork")
    with ctx.Pool(n_procs) as pool:
        pool.map(_write_many, [(str(db), w, n_rows) for w in range(n_procs)])
    with sqlite3.connect(db) as c:
        assert c.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert c.execute("SELECT COUNT(*) FROM flight").fetchone()[0] == n_procs * n_rows
        assert c.execute("SELECT COUNT(DISTINCT sha256) FROM flight").fetchone()[0] == n_procs * n_rows
        assert c.execute("SELECT COUNT(*) FROM motor_figure").fetchone()[0] == 4 * n_procs * n_rows
        assert c.execute("SELECT COUNT(*) FROM flight d JOIN motor_figure m ON m.flight_id = d.id "
                         "WHERE d.name = 'w0_0.ulg' AND m.motor = 1 AND m.model_vote > 0.15").fetchone()[0] == 1
    assert {v: len(f) for v, f in load_history(db).items()} == {f"V{w}": n_rows for w in range(n_procs)}


# ----------------------------------------------------------------------------- figures and identity

def test_motor_rows_prefer_the_report_motors_else_the_windows_and_batch_shares():
    from flightlog_fd.report.json_report import to_dict

    doc = to_dict(_result("a.ulg", "a" * 64, [0.4, 0.0, 0.0, 0.0], [1.2, 0.92, 0.92, 0.96]).diagnosis)
    own = motor_rows(doc, [1.2, 0.92, 0.92, 0.96])
    assert [round(m["model_vote"], 6) for m in own] == [0.4, 0.0, 0.0, 0.0]
    assert own[0]["command_share"] == 1.2 and own[0]["effectiveness"] is None
    assert abs(own[0]["command_change"] - (1.2 - (0.92 + 0.92 + 0.96) / 3)) < 1e-12
    doc["motors"] = [{"motor": k, "position": "front", "command_share": 1.0, "command_share_baseline": 1.0,
                      "command_change": 0.0, "effectiveness": 0.9, "effectiveness_ci": [0.8, 1.0], "model_vote": 0.1,
                      "eta_hat": 0.95, "eta_ci": [0.9, 1.0], "weight": 0.01, "llr": -3.0} for k in range(1, 5)]
    ev = motor_rows(doc, [1.2, 0.92, 0.92, 0.96])
    assert ev[0]["effectiveness"] == 0.9 and ev[0]["effectiveness_ci_lo"] == 0.8 and ev[0]["command_share"] == 1.0
    assert (ev[0]["eta_hat"], ev[0]["eta_ci_hi"], ev[0]["weight"], ev[0]["llr"]) == (0.95, 1.0, 0.01, -3.0)


def test_simulated_logs_carry_a_vehicle_identity(tmp_path):
    from flightlog_fd import load_flight
    from flightlog_fd.logs.dataflash_writer import sim_board_uid
    from flightlog_fd.logs.ulog import read_ulog

    px4 = read_ulog(SAMPLES / "px4_healthy.ulg")
    assert (px4.vehicle_id, px4.vehicle_id_source) == ("sim-11-0", "sys_uuid")
    from flightlog_fd.logs.dataflash_writer import write_dataflash
    from test_dataflash_writer import synthetic_flight

    fl = synthetic_flight(duration=5.0)
    fl.vehicle_id = "sim-5-0"  # as the simulator names its airframes
    out = tmp_path / "ap.bin"
    write_dataflash(fl, out)
    ap = load_flight(out)
    assert ap.vehicle_id_source == "board_uid" and ap.vehicle_id == sim_board_uid("sim-5-0")
    assert ap.vehicle_id.startswith("FDLOG_SIM ") and ap.utc_start is None


@pytest.mark.shared
def test_real_logs_vehicle_identity_and_utc(shared):
    from flightlog_fd import load_flight

    ap = load_flight(shared("real_logs", "ardupilot", "arducopter46_truncated_80k.bin"))
    assert ap.vehicle_id_source == "board_uid" and ap.utc_start is not None
    px4 = load_flight(shared("real_logs", "px4", "sample_log_small.ulg"))
    assert px4.vehicle_id_source == "sys_uuid"
    # GPS time_utc_usec of that log: 2021-04-21 (a plausible date, not the 1970 of a zero field)
    assert 1.6e9 < px4.utc_start < 1.7e9
    erle = load_flight(shared("real_logs", "ardupilot", "erle_copter34_22.BIN"))
    assert (erle.vehicle_id, erle.vehicle_id_source) == ("SYSID_THISMAV 1", "SYSID_THISMAV")
