"""Propeller or motor (flightlog_fd/cause.py): with ESC telemetry a rotor that lost thrust is named
with its likely cause in every report and the store; without it the cause is unknown and said so;
a healthy flight gets none. Simulated ArduPilot flights (fdlog simulate --cause, ESC at 50 Hz)."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest
from typer.testing import CliRunner

from flightlog_fd.cause import judge_cause
from flightlog_fd.cli import app

runner = CliRunner()
FLIGHTS = {"weak_motor2": ["--motor", "2", "--eta", "0.7", "--cause", "motor"],
           "propeller3": ["--motor", "3", "--eta", "0.7"],
           "healthy": []}


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("cause")
    out = {}
    for name, args in FLIGHTS.items():
        p = d / f"{name}.bin"
        res = runner.invoke(app, ["simulate", "-o", str(p), "-f", "dataflash", "--log-profile", "ardupilot",
                                  "--airframe", "f450", "--esc-rate", "50", "--duration", "60", "--seed", "3",
                                  *args])
        assert res.exit_code == 0, res.output
        out[name] = p
    return out


@pytest.fixture(scope="module")
def reports(logs):
    """name -> the JSON report of `fdlog diagnose --json`."""
    out = {}
    for name, p in logs.items():
        res = runner.invoke(app, ["diagnose", "--json", str(p)])
        out[name] = json.loads(res.stdout)
    return out


def test_weak_motor_is_named_with_its_motor_or_esc(logs, reports):
    from flightlog_fd.report.json_report import validate

    doc = reports["weak_motor2"]
    v = doc["verdict"]
    assert validate(doc) == [] and doc["schema"] == 8
    assert (v["status"], v["motor"], v["cause"]) == ("damaged", 2, "motor_or_esc"), v["reason"]
    ev = v["cause_evidence"]
    assert ev["motor"] == 2 and ev["llr"] > 20 and ev["rpm_per_command"] < -8
    assert v["headline"].endswith(": inspect motor 2 and its ESC")  # the motor first, then the propeller
    assert [a["text"].split(":")[0] for a in v["advice"] if a["kind"] == "inspect"][:2] == [
        "inspect motor 2 and its ESC", "then propeller 2 (rear-left)"]
    text = runner.invoke(app, ["diagnose", str(logs["weak_motor2"])]).stdout
    flat = " ".join(text.split())
    assert flat.startswith(v["headline"]) and "the motor or its ESC is weak" in flat and "cause (probability 1.00)" in flat


def test_damaged_propeller_is_named_with_its_propeller(reports):
    v = reports["propeller3"]["verdict"]
    assert (v["status"], v["motor"], v["cause"]) == ("damaged", 3, "propeller"), v["reason"]
    ev = v["cause_evidence"]
    assert ev["llr"] < -20 and ev["current_per_rpm2"] < -15  # a cut propeller draws less current per rpm²
    assert v["headline"].endswith("inspect propeller 3") and v["advice"][0]["text"].startswith("inspect propeller 3")
    assert ev["probs"]["propeller"] >= 0.9 and ev["sources"][0] == "esc"


def test_healthy_flight_gets_no_cause(reports):
    v = reports["healthy"]["verdict"]
    assert v["status"] == "healthy" and v["cause"] is None and v["cause_evidence"] is None


def test_without_esc_rpm_the_cause_is_unknown_and_said_so(logs):
    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    model = resolve_model()
    v = diagnose_flight(replace(load_flight(logs["weak_motor2"]), esc=None), model, keep_flight=False).verdict
    # the commands alone: rotor 2 lost thrust, why unknown
    assert v.motor == 2 and v.status in ("damaged", "uncertain"), v.reason
    assert v.cause is None and v.cause_evidence["llr"] is None
    assert "the log cannot tell a propeller from a motor or something in its wash: no ESC rpm" in \
        v.cause_evidence["reason"]
    assert [a.text.split(":")[0] for a in v.advice if a.kind == "inspect"] == [
        "inspect propeller 2 (rear-left)", "then motor 2 and its ESC", "then what sits under rotor 2"]
    # the damaged propeller (its rotor turns 5 % faster per command, which makes up part of the
    # lost thrust): whatever the commands alone say, no cause without ESC rpm
    v = diagnose_flight(replace(load_flight(logs["propeller3"]), esc=None), model, keep_flight=False).verdict
    assert v.cause is None


def _esc_result(k, by_cause, rpm=-1.0):
    """An ESC result whose motor ``k`` has these log Bayes factors against healthy, flat over eta."""
    import numpy as np

    from flightlog_fd.analyzers.base import Finding
    from flightlog_fd.analyzers.command_shares import ETA_GRID
    from flightlog_fd.analyzers.esc import EscResult

    eta = {c: np.full(len(ETA_GRID), float(v)) for c, v in by_cause.items()}
    return EscResult("esc", [Finding("esc", k, "rpm_per_command", rpm, "%")], cause_ll={k: dict(by_cause)},
                     cause_ll_eta={k: eta})


def test_the_cause_is_stated_only_past_its_bar():
    from flightlog_fd.analyzers.esc import EscResult
    from flightlog_fd.cause import CAUSE_PRIOR, CAUSE_PROBABILITY_BAR, judge_cause

    motor = judge_cause([_esc_result(1, {"propeller": -5, "motor_or_esc": 20, "wash": 0}, rpm=-20.0)], 1)
    assert motor.cause == "motor_or_esc" and motor.probs["motor_or_esc"] > 0.99 and motor.llr == 25
    assert "20 % slower" in motor.words and motor.advice.startswith("inspect motor 1 and ESC 1")
    wash = judge_cause([_esc_result(2, {"propeller": -8, "motor_or_esc": -8, "wash": 0}, rpm=0.3)], 2)
    assert wash.cause == "wash" and "something in its wash" in wash.words
    assert wash.advice.startswith("inspect what sits under rotor 2")
    # even evidence: the prior's probabilities, no cause, and the words say it is not clear
    mid = judge_cause([_esc_result(1, {"propeller": 0, "motor_or_esc": 0, "wash": 0})], 1)
    assert mid.cause is None and max(mid.probs.values()) < CAUSE_PROBABILITY_BAR
    assert mid.probs == pytest.approx(CAUSE_PRIOR) and "the cause is not clear" in mid.words
    assert mid.advice == "inspect propeller 1, then motor 1 and its ESC, then what sits under rotor 1"
    gone = judge_cause([EscResult("esc", abstained="ESC telemetry too slow (motor 1: 1.0 Hz < 2 Hz)")], 1)
    assert gone.cause is None and "no usable ESC rpm (ESC telemetry too slow" in gone.words
    assert gone.probs == pytest.approx(CAUSE_PRIOR) and gone.sources == ()
    ev = motor.evidence()
    assert set(ev["probs"]) == {"propeller", "motor_or_esc", "wash"} and ev["sources"] == ["esc"]


def test_a_vibration_line_tied_to_the_rotor_says_propeller_and_nothing_more():
    """A line certainly on rotor 1 is worth at most log(UNBALANCED_SHARE·n/INCIDENTAL_UNBALANCE)
    for its propeller; a line on another rotor, or no line, counts a little against it."""
    import numpy as np

    from flightlog_fd.analyzers.vibration import VibrationResult
    from flightlog_fd.cause import INCIDENTAL_UNBALANCE, UNBALANCED_SHARE, judge_cause

    def vib(tie, llr):
        r = VibrationResult("vibration", flight_llr=llr)
        r.tie_probs = tie  # the vibration branch's field (read with getattr)
        return r

    on1 = judge_cause([vib([0.97, 0.01, 0.01, 0.01], 30.0)], 1)
    assert on1.cause == "propeller" and on1.sources == ("vibration",)
    bound = np.log(UNBALANCED_SHARE * 4 / INCIDENTAL_UNBALANCE)
    odds = on1.probs["propeller"] / (1 - on1.probs["propeller"])
    assert np.log(odds) <= bound + 1e-6  # prior odds of the propeller against the rest: 0.5 / 0.5
    assert "follows rotor 1" in on1.words
    on3 = judge_cause([vib([0.01, 0.01, 0.97, 0.01], 30.0)], 1)
    assert on3.cause is None and on3.probs["propeller"] < 0.5
    quiet = judge_cause([vib([0.25] * 4, -5.0)], 1)
    assert quiet.probs["propeller"] < 0.5 and quiet.cause is None
    assert "no vibration line tied to it" in quiet.words


def test_html_store_history_and_web_page_carry_the_cause(logs, tmp_path):
    from flightlog_fd.store import load_history

    html = tmp_path / "r.html"
    data = tmp_path / "data"
    data.mkdir()
    db = data / "fdlog.sqlite"
    res = runner.invoke(app, ["diagnose", str(logs["weak_motor2"]), str(logs["healthy"]), "--html", str(html),
                              "--db", str(db)])
    assert res.exit_code == 1, res.output
    page = html.read_text()
    assert '<p class="cause">cause' in page and "the motor or its ESC is weak" in page
    ((key, records),) = load_history(db).items()
    assert {r.log_path.rsplit("/", 1)[-1]: r.cause for r in records} == {"weak_motor2.bin": "motor_or_esc",
                                                                         "healthy.bin": None}
    text = runner.invoke(app, ["history", "--db", str(db)]).stdout
    assert "damaged m2, motor or ESC" in text
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client

    fid = next(r.id for r in records if r.cause)
    with serve_client(data, workers=0) as c:
        flight_page = c.get(f"/flights/{fid}").text
        airframe_page = c.get("/airframe", params={"key": key}).text
    assert '<p id="cause">cause' in flight_page and "the motor or its ESC is weak" in flight_page
    assert "motor 2 (motor or ESC)" in airframe_page


def test_a_weak_motor_does_not_make_its_neighbours_look_like_damaged_propellers(logs):
    """rpm-only telemetry (bidirectional DShot): each motor is taken against a robust level of the
    others, so the weak motor's 15 % does not lift its neighbours' rpm per command by a third of
    it, which alone reads as a cut propeller (ArduCopter SITL against the mean: +9.5 %, +12 nats)."""
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.esc import analyze_esc
    from flightlog_fd.flight import EscTelemetry

    f = load_flight(logs["weak_motor2"])
    f = replace(f, esc=EscTelemetry([replace(c, current=None) for c in f.esc.channels], f.esc.source, f.esc.units))
    a = analyze_esc(f)
    rpm = {x.motor: x.value for x in a.findings if x.name == "rpm_per_command"}
    assert rpm[2] < -10 and a.cause_llr[2] > 20 and a.decision_llr[2] > 20
    for k in (1, 3, 4):
        assert abs(rpm[k]) < 3.0 and a.decision_llr[k] < 1.0, (k, rpm, a.decision_llr)


def test_simulate_refuses_an_unknown_cause_in_one_line(tmp_path):
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "x.ulg"), "--motor", "1", "--cause", "esc"])
    assert res.exit_code == 2 and "--cause must be one of propeller, motor" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "x.ulg").exists()


def test_a_store_at_migration_6_gets_the_cause_from_its_stored_reports(logs, tmp_path):
    """Migration 7 adds flight.cause and fills it from each stored report's verdict."""
    import sqlite3

    from flightlog_fd.store import SCHEMA_VERSION, Store

    db = tmp_path / "s.sqlite"
    assert runner.invoke(app, ["diagnose", "--db", str(db), str(logs["weak_motor2"])]).exit_code == 1
    with sqlite3.connect(db) as c:  # back to what the release at migration 6 left
        c.execute("ALTER TABLE flight DROP COLUMN cause")
        for table in ("flight", "flight_part"):  # migration 8's
            c.execute(f"ALTER TABLE {table} DROP COLUMN verdict_motors")
            c.execute(f"ALTER TABLE {table} DROP COLUMN pair")
        for column in ("load_motor", "load_size", "load_direction_deg"):  # migration 9's
            c.execute(f"ALTER TABLE flight DROP COLUMN {column}")
        c.execute("DELETE FROM schema_migrations WHERE version >= 7")
        c.execute("PRAGMA user_version = 6")
    with Store(db) as store:
        assert store.db.schema_version() == SCHEMA_VERSION >= 7
        (f,) = store.logs()
        assert store.flight(f["id"])["cause"] == "motor_or_esc"


def test_the_commands_eta_weighs_the_causes():
    """A propeller that lost 40 % of its thrust must show it in its current per rpm²: the same ESC
    relations (a propeller at eta 0.95 would explain them) read as the wash when the commands say
    eta 0.6, and stay open when they say nothing."""
    import numpy as np

    from flightlog_fd.analyzers.base import AnalyzerResult, Finding
    from flightlog_fd.analyzers.command_shares import ETA_GRID
    from flightlog_fd.analyzers.esc import EscResult, cause_log_ratios
    from flightlog_fd.cause import ETA_PRIOR_FLOOR, eta_weights

    by_eta = cause_log_ratios(np.array([0.004, -0.05]), np.diag([0.012, 0.033]) ** 2, [0, 1])
    esc = EscResult("esc", [Finding("esc", 1, "rpm_per_command", 0.4, "%")], cause_ll_eta={1: by_eta})
    cmds = AnalyzerResult("commands", [Finding("commands", 1, "thrust", 0.6, "of normal", (0.55, 0.66))])
    w = eta_weights([esc, cmds], 1)
    assert w.sum() == pytest.approx(1.0) and abs(float(w @ ETA_GRID) - 0.6) < 0.1
    assert w.min() == pytest.approx(ETA_PRIOR_FLOOR / len(ETA_GRID))
    told, open_ = judge_cause([esc, cmds], 1), judge_cause([esc], 1)
    assert told.probs["wash"] > open_.probs["wash"] and told.probs["propeller"] < open_.probs["propeller"]
    # a source's own eta_llr counts as well (the effectiveness fit gives one)
    eff = AnalyzerResult("effectiveness", eta_llrs={1: -0.5 * ((ETA_GRID - 0.6) / 0.05) ** 2})
    assert abs(float(eta_weights([eff], 1) @ ETA_GRID) - 0.6) < 0.1
