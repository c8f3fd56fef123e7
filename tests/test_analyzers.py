"""The analyzer registry: a new analyzer is one file plus one registry line, and its findings reach
the decision, the JSON, the CSV, the HTML page and the results store without touching them."""
from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from flightlog_fd import analyzers
from flightlog_fd.analyzers import Analyzer, AnalyzerResult, Context, Finding
from flightlog_fd.cli import app
from flightlog_fd.report.json_report import validate
from flightlog_fd.store import Store

SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"
runner = CliRunner()


class ToyAnalyzer(Analyzer):
    """Says motor 3 runs 'hot' (a made-up figure) and weighs nothing."""

    id = "toy"
    description = "a made-up per-motor temperature"
    requires = ("motors",)

    def analyze(self, ctx: Context) -> AnalyzerResult:
        return AnalyzerResult(self.id, [Finding(self.id, k, "heat", 40.0 + k, "degC", (39.0 + k, 41.0 + k), 40.0,
                                                "up", None, f"{40 + k} degC") for k in range(1, ctx.n_motors + 1)])


class SilentAnalyzer(Analyzer):
    id = "silent"
    description = "needs a stream no log has"
    requires = ("no_such_stream",)

    def analyze(self, ctx: Context) -> AnalyzerResult:
        return AnalyzerResult(self.id, abstained=self.missing(ctx.flight))


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setattr(analyzers, "REGISTRY", analyzers.REGISTRY + [ToyAnalyzer(), SilentAnalyzer()])


def test_a_registered_analyzer_reaches_every_report_and_the_store(registered, tmp_path):
    csv, html, db = tmp_path / "w.csv", tmp_path / "r.html", tmp_path / "r.sqlite"
    res = runner.invoke(app, ["diagnose", "--json", "--csv", str(csv), "--html", str(html), "--db", str(db),
                              str(SAMPLES / "px4_motor1_damaged.ulg")])
    assert res.exit_code == 1, res.output
    doc = json.loads(res.stdout)
    assert validate(doc) == []
    toy = next(a for a in doc["analyzers"] if a["analyzer"] == "toy")
    assert [f["value"] for f in toy["findings"]] == [41.0, 42.0, 43.0, 44.0]
    assert toy["findings"][2]["interval"] == [42.0, 44.0] and toy["findings"][2]["unit"] == "degC"
    silent = next(a for a in doc["analyzers"] if a["analyzer"] == "silent")
    assert silent["abstained"] == "the log has no no_such_stream stream" and silent["findings"] == []
    # weighs nothing: the decision is the registry's without it
    assert (doc["verdict"]["status"], doc["verdict"]["motor"]) == ("damaged", 1)  # rotor 1 lost thrust
    assert "toy" not in doc["motors"][0]["llr_by_source"]
    header = csv.read_text().splitlines()[0].split(",")
    assert "toy_heat_m3" in header
    row = csv.read_text().splitlines()[1].split(",")
    assert float(row[header.index("toy_heat_m3")]) == 43.0
    page = html.read_text(encoding="utf-8")
    assert "<th>heat</th>" in page and "<td>43 degC</td>" in page and "no_such_stream" in page
    with sqlite3.connect(db) as conn:
        (rid,) = conn.execute("SELECT id FROM flight").fetchone()
    with Store(db, create=False) as store:
        stored = [f for f in store.findings(rid) if f["analyzer"] == "toy"]
    assert [(f["motor"], f["value"], f["interval_lo"], f["interval_hi"], f["unit"]) for f in stored] == [
        (k, 40.0 + k, 39.0 + k, 41.0 + k, "degC") for k in range(1, 5)]


def test_terminal_panel_shows_the_new_column(registered):
    res = runner.invoke(app, ["diagnose", str(SAMPLES / "px4_motor1_damaged.ulg")], env={"COLUMNS": "140"})
    assert "heat" in res.output and "43 degC" in res.output
    assert "silent: the log has no no_such_stream stream" in res.output


def test_a_failing_analyzer_abstains_instead_of_losing_the_diagnosis():
    class Broken(Analyzer):
        id = "broken"

        def analyze(self, ctx):
            raise ValueError("bad input")

    ctx = Context(flight=None, frame=None, n_motors=4, probs=[[1, 0, 0, 0, 0]], covered_s=1.0)
    (r,) = analyzers.run_analyzers(ctx, [Broken()])
    assert r.abstained == "failed: bad input" and r.findings == []
