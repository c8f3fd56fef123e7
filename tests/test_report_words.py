"""Legends and labels in the words of the verdict's cause (report/words.py), and the one line that
says which streams a log's plots lack (report/panels.py), in every format: the terminal, the HTML
report, the CSV, the fleet page's flight page and the history flag."""
from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from flightlog_fd.cause import VERDICT_CAUSES as CAUSES
from flightlog_fd.diagnose import diagnose_path, resolve_model
from flightlog_fd.flight import Series
from flightlog_fd.report import terminal
from flightlog_fd.report.csv_report import render_csv
from flightlog_fd.report.html_report import render_html
from flightlog_fd.report.json_report import JSON_SCHEMA
from flightlog_fd.report.vibration_view import _raw_series
from flightlog_fd.report.words import CAUSE_WORDS, UNKNOWN_CAUSE, cause_words

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
PROPELLER = "propeller damaged"
UNKNOWN = "rotor lost thrust (propeller, motor or ESC, or something in its wash)"
WEAK = "motor or ESC weak"


@pytest.fixture(scope="module")
def model():
    return resolve_model()


def _terminal(d) -> str:
    con = Console(file=io.StringIO(), width=80, color_system=None)
    terminal.render(d, con)
    return con.file.getvalue()


def _legend(text: str) -> str:
    """The timeline legend, its wrapped lines joined."""
    lines = text.splitlines()
    i = next(i for i, ln in enumerate(lines) if ln.startswith("  . healthy"))
    return " ".join(ln.strip() for ln in lines[i:i + 2] if ln.startswith("  ") and not ln.startswith("  *"))


def test_every_cause_a_verdict_can_state_has_its_words():
    """A cause added to cause.VERDICT_CAUSES (or the JSON schema) without words fails here: one entry
    in CAUSE_WORDS is all a new cause needs."""
    assert set(CAUSES) <= set(CAUSE_WORDS)
    schema_causes = set(JSON_SCHEMA["properties"]["verdict"]["properties"]["cause"]["enum"]) - {None}
    assert schema_causes == set(CAUSE_WORDS) and "wash" in schema_causes
    assert cause_words(None) is UNKNOWN_CAUSE and cause_words("a cause from a newer version") is UNKNOWN_CAUSE
    for c in (None, *CAUSE_WORDS):  # no cause known: honest words, never "propeller damaged"
        w = cause_words(c)
        assert ("propeller damaged" in w.lost) == (c == "propeller")
        assert str(7) in w.named(7)
    assert cause_words("motor_or_esc").named(1) == "motor 1 or its ESC weak"
    assert cause_words(None).named(2) == "rotor 2 lost thrust (propeller, motor or ESC, or something in its wash)"
    assert cause_words("wash").likely == "something in its wash or under it"


def test_legends_without_a_known_cause_do_not_say_propeller(model):
    """No ESC telemetry: the windows see rotor 1 lose thrust, not which part lost it; the headline
    asks to inspect the propeller first but never calls it damaged."""
    d = diagnose_path(SAMPLES / "px4_motor1_damaged.ulg", model)
    assert d.verdict.status in ("damaged", "uncertain") and d.verdict.motor == 1 and d.verdict.cause is None
    assert "damaged" not in d.verdict.headline.lower() and d.verdict.headline.endswith("inspect propeller 1")
    text = _terminal(d)
    assert _legend(text).split("1-4 ")[1].startswith(UNKNOWN)
    assert "cause: unknown: the log cannot tell a propeller from a motor" in " ".join(text.split())
    assert [a.kind for a in d.verdict.advice][:3] == ["inspect"] * 3  # propeller, motor and ESC, under it
    assert [a.text.split(":")[0] for a in d.verdict.advice[:3]] == [
        "inspect propeller 1 (front-right)", "then motor 1 and its ESC", "then what sits under rotor 1"]
    page = render_html(d)
    assert f"red {UNKNOWN}," in page and f"red {PROPELLER}" not in page
    rows = list(csv.DictReader(io.StringIO(render_csv(d))))
    assert {r["verdict_cause"] for r in rows} == {""}


def test_legends_of_a_propeller_cause_say_propeller(model):
    d = diagnose_path(SAMPLES / "px4_esc_motor2_damaged.ulg", model)
    assert d.verdict.cause == "propeller"
    assert _legend(_terminal(d)).endswith(f"1-4 {PROPELLER}")
    assert f"red {PROPELLER}," in render_html(d)
    assert {r["verdict_cause"] for r in csv.DictReader(io.StringIO(render_csv(d)))} == {"propeller"}


def test_the_weak_motor_log_names_the_motor_or_esc_in_every_legend(model, shared, tmp_path):
    """ArduCopter SITL, motor 1 weakened, ESC telemetry: the issue's case (the legends read
    "propeller damaged")."""
    pytest.importorskip("fastapi", reason="the serve extra is not installed")
    from output_checks import FlightPages

    from flightlog_fd.batch import diagnose_one

    path = shared("ardupilot_sitl_quad", "motor1_weak_esc.BIN")
    res = diagnose_one(0, path, model, keep_flight=True)
    d = res.diagnosis
    assert (d.verdict.status, d.verdict.motor, d.verdict.cause) == ("damaged", 1, "motor_or_esc")
    legend = _legend(_terminal(d))
    assert f"1-4 {WEAK}" in legend and "propeller" not in legend
    # the motor and its ESC first, then the propeller, then what sits under it
    assert [a.text.split(":")[0] for a in d.verdict.advice if a.kind == "inspect"] == [
        "inspect motor 1 and its ESC", "then propeller 1 (right)", "then what sits under rotor 1"]
    assert "inspect motor 1 and its ESC" in d.verdict.headline
    con = Console(file=io.StringIO(), width=80, color_system=None)
    con.print(terminal.summary_table([d, d]))  # several logs: the summary's cause cell tags the cause
    assert re.search(r"damaged 1 right +motor or ESC", con.file.getvalue())
    assert "propeller" not in con.file.getvalue()
    page = render_html(d)
    assert f"red {WEAK}," in page and PROPELLER not in page
    assert '<p class="cause">cause' in page and "the motor or its ESC is weak" in page
    assert {r["verdict_cause"] for r in csv.DictReader(io.StringIO(render_csv(d)))} == {"motor_or_esc"}
    pages = FlightPages(tmp_path / "serve")
    try:
        assert pages.problems(res, path) == []
        fid = pages.store.logs()[-1]["id"]
        web = pages.client.get(f"/flights/{fid}").text
        assert f"red {WEAK}," in web and PROPELLER not in web
        assert re.search(r'"rotor_word": "motor/ESC"', web)  # the class traces: P(motor/ESC k)
        assert re.search(r'<p id="cause">cause[^<]*: the motor or its ESC is weak', web)
    finally:
        pages.close()


def test_the_history_flag_follows_the_cause():
    from flightlog_fd.history import _latest_words

    assert _latest_words({"motor": 3, "cause": "motor_or_esc"}) == "motor 3 or its ESC weak"
    assert _latest_words({"motor": 3, "cause": "propeller"}) == "propeller 3 damaged"
    assert _latest_words({"motor": 3, "cause": None}) == UNKNOWN.replace("rotor", "rotor 3", 1)
    assert _latest_words({"motors": [1, 4], "cause": None}) == "rotors 1 and 4 lost thrust"


# ----------------------------------------------------------------------------- missing streams

def test_a_log_without_rates_draws_the_other_panels_and_says_so_in_one_line(model):
    d = diagnose_path(SAMPLES / "px4_motor1_damaged.ulg", model)
    assert "Angular rates" in render_html(d)
    d.flight.rates = None
    page = render_html(d)
    lines = re.findall(r'<p class="muted missing">(.*?)</p>', page)
    assert len(lines) == 1 and "angular rates (not logged)" in lines[0]
    assert "vibration (" in lines[0] and "ESC telemetry" in lines[0]  # this simulated log has neither
    assert "Angular rates" not in page and "Motor commands" in page and "Class probabilities" in page


def test_crazypad_e9_draws_its_timeline_and_motors_and_says_vibration_is_missing(model, shared):
    """Every crazypad_e9 HTML report failed ("max() arg is an empty sequence"): its accelerometer's
    horizontal axes are all NaN, which left a vibration panel with nothing finite to draw."""
    d = diagnose_path(shared("crazypad_e9", "ulog", "cut_m3_2mm_2mm__E9_log00.ulg"), model)
    assert not np.isfinite(d.flight.vibration.imus[0].accel.values[:, :2]).any()
    page = render_html(d)
    assert "Motor commands" in page and "Angular rates" in page and "Class probabilities" in page
    assert "Vibration level" not in page
    line = re.findall(r'<p class="muted missing">(.*?)</p>', page)
    assert len(line) == 1 and "accelerometer&#x27;s horizontal axes hold no samples" in line[0]


def test_one_missing_accelerometer_sample_costs_its_blocks_not_the_series():
    fs, n = 200.0, 2000
    t = np.arange(n) / fs
    rng = np.random.default_rng(0)
    x = np.c_[rng.normal(0, 1, n), rng.normal(0, 1, n), np.full(n, -9.8)]
    x[1000, 0] = np.nan
    name, tb, level = _raw_series(Series(t, x, "test"), "IMU 0")
    assert np.isfinite(level).all() and level.size >= 7  # 10 blocks of 1 s, the NaN's dropped
    assert not ((tb > 4.5) & (tb < 5.5)).any()  # the block holding the NaN is not drawn
    assert (tb < 4.5).sum() >= 3 and (tb > 5.5).sum() >= 3
    assert np.all((level > 1.0) & (level < 2.0))  # sqrt(2) for two unit-variance axes
