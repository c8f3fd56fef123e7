"""Every sample log (quad X and +, hexa, octo, ESC, damaged and healthy) through every output:
the terminal with and without --windows, JSON (validated), CSV (header as wide as every row),
HTML, the `--db` store and `fdlog history`, and a `fdlog serve` upload that ends `done` with its
flight page. Each sample is diagnosed once for the reports (module fixture); the CLI and the
server diagnose again in their own way, as a user's run would."""
from __future__ import annotations

import csv
import io
import json
import re
from pathlib import Path

import pytest
from rich.console import Console
from typer.testing import CliRunner

from flightlog_fd.cli import app
from flightlog_fd.batch import diagnose_one
from flightlog_fd.decision import HEADLINE_MAX
from flightlog_fd.diagnose import resolve_model
from flightlog_fd.report import terminal
from flightlog_fd.report.csv_report import render_csv
from flightlog_fd.report.html_report import render_html
from flightlog_fd.report.json_report import render_json, validate
from flightlog_fd.report.motor_view import DASH, MotorView

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
SAMPLE_FILES = sorted(p for p in SAMPLES.iterdir() if p.suffix in (".ulg", ".bin"))
runner = CliRunner()


@pytest.fixture(scope="module")
def results():
    """Log name -> LogResult (the CLI's path, with the flight for the plots), each sample diagnosed once."""
    model = resolve_model()
    return {p.name: diagnose_one(0, p, model, keep_flight=True) for p in SAMPLE_FILES}


@pytest.fixture(scope="module")
def diagnoses(results):
    """Log name -> Diagnosis (with its flight, for the HTML plots)."""
    return {name: r.diagnosis for name, r in results.items()}


def test_every_output_of_every_sample_says_the_same_verdict(results, tmp_path):
    """tests/output_checks.py on the samples' one diagnosis each: the terminal with --windows, JSON,
    CSV, HTML, the store and the flight page agree with it (status, motor, the cause's words);
    the test_outputs_* files do the same for every log of ../shared."""
    pytest.importorskip("fastapi", reason="the serve extra is not installed")
    from output_checks import OutputRun

    run = OutputRun(tmp_path)
    try:
        problems = {name: run.problems(r, SAMPLES / name) for name, r in results.items()}
    finally:
        run.close()
    assert {k: v for k, v in problems.items() if v} == {}


def test_the_samples_cover_every_frame_and_kind(diagnoses):
    frames = {d.facts.frame for d in diagnoses.values()}
    assert {"quad_x", "quad_plus", "hexa", "octo"} <= {f.split("_")[0] if f.startswith(("hexa", "octo")) else f
                                                         for f in frames}, frames
    statuses = {d.verdict.status for d in diagnoses.values()}
    assert "healthy" in statuses and "damaged" in statuses
    assert any(d.flight.esc is not None for d in diagnoses.values())


def _rotors(d) -> int:
    return d.flight.frame.rotor_count


@pytest.mark.parametrize("name", [p.name for p in SAMPLE_FILES])
def test_every_output_of_a_sample(name, diagnoses):
    d = diagnoses[name]
    n = _rotors(d)
    assert d.verdict.status != "not_diagnosable", d.verdict.reason
    view = MotorView.of(d)
    assert [r.motor for r in view.rows] == list(range(1, n + 1))
    assert all(r.position for r in view.rows)  # every rotor of every frame has a position name

    # terminal, with and without --windows: fits 80 columns, one table row per motor
    for windows in (False, True):
        console = Console(file=io.StringIO(), width=80, color_system=None)
        terminal.render(d, console, show_windows=windows)
        text = console.file.getvalue()
        assert "per-motor findings" in text
        lines = text.splitlines()
        head = next(i for i, ln in enumerate(lines) if ln.startswith("# pos"))
        assert [ln.split()[0] for ln in lines[head + 1:head + 1 + n]] == [str(k) for k in range(1, n + 1)]
        if windows:
            assert re.search(rf"\bp{n}\b", text) and not re.search(rf"\bp{n + 1}\b", text)
            assert "…" not in text  # no column cut short
        assert max(len(ln) for ln in lines) <= 80

    # JSON: valid, one motor object per rotor, and a dash wherever an analyzer said nothing
    doc = json.loads(render_json(d))
    assert validate(doc) == []
    assert [m["motor"] for m in doc["motors"]] == list(range(1, n + 1))
    assert all(len(w["probabilities"]) == n + 1 for w in doc["windows"])
    abstained = {a["analyzer"]: a["abstained"] for a in doc["analyzers"]}
    for c in doc["motor_columns"]:
        if c["abstained"]:
            assert all(m["cells"][c["key"]] == DASH for m in doc["motors"])
    if abstained.get("effectiveness"):
        assert all(m["effectiveness"] is None and m["effectiveness_ci"] is None for m in doc["motors"])
        assert all(m["unavailable"]["effectiveness"] == abstained["effectiveness"] for m in doc["motors"])
    if abstained.get("commands"):
        assert all(m["eta_hat"] is None and "eta_hat" in m["unavailable"] for m in doc["motors"])
    # the web page's view of the stored document draws the same table
    assert MotorView.from_doc(doc).table() == view.table()

    # CSV: the header is as wide as every row, with a probability column per motor
    rows = list(csv.reader(io.StringIO(render_csv(d))))
    assert len(rows) == len(d.windows) + 1
    assert {len(r) for r in rows} == {len(rows[0])}
    assert f"p_motor{n}" in rows[0] and f"p_motor{n + 1}" not in rows[0] and f"weight_m{n}" in rows[0]

    # HTML: the per-motor table with one row per motor, the window table with n + 1 probabilities
    page = render_html(d)
    table = re.search(r'<table class="motor-panel">(.*?)</table>', page, re.S).group(1)
    assert table.count("<tr") == n + 1
    assert f"<th>p m{n}</th>" in page and f"<th>p m{n + 1}</th>" not in page


def test_every_headline_is_at_most_100_characters(diagnoses):
    """The first line a pilot reads (issue 37: the status, the rotor, how much and what to do, in
    five seconds), on every sample and each flight of a log holding several."""
    for name, d in diagnoses.items():
        for x in [d, *d.flights]:
            head = x.verdict.headline
            assert head and len(head) <= HEADLINE_MAX, (name, head)
            assert terminal.verdict_sentence(x) == head


def test_the_terminal_at_80_columns_starts_with_the_headline_and_has_no_longer_line(diagnoses):
    """Every sample at 80 columns (rich wraps it there): the headline first, no line over 80
    characters, and in the summary of them all every file name whole on one line."""
    flat = lambda t: " ".join(t.split())  # noqa: E731
    for name, d in diagnoses.items():
        console = Console(file=io.StringIO(), width=80, color_system=None)
        terminal.render(d, console)
        text = console.file.getvalue()
        assert flat(text).startswith(flat(d.verdict.headline)), name
        assert max(len(ln) for ln in text.splitlines()) <= 80, name
        assert text.count("confidence: the probability") == 1  # the legend, once
    console = Console(file=io.StringIO(), width=80, color_system=None)
    console.print(terminal.summary_table(list(diagnoses.values())))
    text = console.file.getvalue()
    assert max(len(ln) for ln in text.splitlines()) <= 80
    for name in diagnoses:
        assert re.search(rf"^ ?{re.escape(name)} ", text, re.M), name  # not folded onto two lines


def test_one_csv_of_every_rotor_count_keeps_its_width(diagnoses):
    rows = list(csv.reader(io.StringIO(render_csv(list(diagnoses.values())))))
    assert {len(r) for r in rows} == {len(rows[0])}
    assert "p_motor8" in rows[0] and "weight_m8" in rows[0]


def test_the_cli_renders_every_sample_then_the_store_and_history(tmp_path):
    db, csv_out, html_out = tmp_path / "r.sqlite", tmp_path / "r.csv", tmp_path / "r.html"
    res = runner.invoke(app, ["diagnose", str(SAMPLES), "--windows", "--db", str(db), "--csv", str(csv_out),
                              "--html", str(html_out)])
    assert res.exit_code == 1, res.output  # damage found; no traceback, no bad input
    assert "Traceback" not in res.output and "not diagnosable" not in res.output
    rows = list(csv.reader(csv_out.open(encoding="utf-8")))
    assert {len(r) for r in rows} == {len(rows[0])}
    assert html_out.read_text(encoding="utf-8").count('class="motor-panel"') == len(SAMPLE_FILES)
    res = runner.invoke(app, ["diagnose", "--json", *map(str, SAMPLE_FILES)])
    docs = json.loads(res.stdout)
    assert len(docs) == len(SAMPLE_FILES) and all(validate(doc) == [] for doc in docs)

    res = runner.invoke(app, ["history", "--db", str(db)])
    assert res.exit_code in (0, 1), res.output
    for p in SAMPLE_FILES:
        assert p.name in res.stdout
    res = runner.invoke(app, ["history", "--db", str(db), "--json"])
    hist = json.loads(res.stdout)
    flights = {Path(f["log"]).name: f for v in hist["vehicles"] for f in v["flights"]}
    assert set(flights) == {p.name for p in SAMPLE_FILES}
    rotors = {doc["log"]: len(doc["motors"]) for doc in docs}
    for p in SAMPLE_FILES:
        assert len(flights[p.name]["motors"]) == rotors[str(p)], p.name


def test_serve_upload_of_every_sample_ends_done_with_its_flight_page(tmp_path):
    pytest.importorskip("fastapi", reason="the serve extra is not installed")
    pytest.importorskip("jinja2", reason="the serve extra is not installed")
    pytest.importorskip("multipart", reason="the serve extra is not installed")
    from serve_helpers import serve_client, upload, wait_done

    with serve_client(tmp_path / "serve", workers=1) as c:
        fids = {}
        for p in SAMPLE_FILES:
            r = upload(c, p)
            assert r.status_code == 200, r.text
            fids[p.name] = r.json()["id"]
        for name, fid in fids.items():
            j = wait_done(c, fid)
            assert j["state"] == "done", (name, j.get("error"))
            doc = j["diagnosis"]
            assert validate(doc) == [] and not any("could not be drawn" in w for w in doc["warnings"]), name
            page = c.get(f"/flights/{fid}").text
            table = re.search(r'<table id="motors">(.*?)</table>', page, re.S).group(1)
            assert table.count("<tr") == len(doc["motors"]) + 1, name
            assert c.get(f"/flights/{fid}/report.html").status_code == 200
            assert c.get(f"/flights/{fid}/report.csv").status_code == 200
        airframes = {j["airframe"] for j in c.get("/api/logs").json()["logs"]}
        for key in airframes:
            assert c.get("/airframe", params={"key": key}).status_code == 200


def test_a_stored_schema_3_report_is_drawn_alike_without_its_uninformative_numbers(diagnoses):
    """The web pages draw reports stored by the previous release (schema 3) with the same table."""
    d = diagnoses["px4_motor2_damaged.ulg"]
    doc = json.loads(render_json(d))
    abstained = {a["analyzer"]: a["abstained"] for a in doc["analyzers"]}
    assert abstained["effectiveness"]  # this sample's effectiveness fit is uninformative
    old = {k: v for k, v in doc.items() if k != "motor_columns"}
    old["schema"] = 3
    old["motors"] = [{k: v for k, v in m.items() if k not in ("class", "throttle", "cells", "unavailable")}
                     for m in doc["motors"]]
    for m in old["motors"]:  # schema 3 carried the fit's numbers even when the analyzer abstained
        m["effectiveness"], m["effectiveness_ci"] = -1.007, [-1.533, -0.848]
    view = MotorView.from_doc(old)
    assert view.table() == MotorView.of(d).table()
    assert all(r.effectiveness is None and r.unavailable["effectiveness"] == abstained["effectiveness"]
               for r in view.rows)
