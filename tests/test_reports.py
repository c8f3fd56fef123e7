"""Reports: JSON against its schema, CSV columns, HTML structure and escaping, terminal words."""
from __future__ import annotations

import csv
import dataclasses
import io
import json
from html.parser import HTMLParser

import numpy as np
import pytest
from rich.console import Console

from flightlog_fd.diagnose import Diagnosis, FlightFacts, ModelInfo, WindowResult
from flightlog_fd.flight import Flight, Frame, Series
from flightlog_fd.report.csv_report import csv_columns, render_csv, write_csv
from flightlog_fd.report.html_report import decimate, nice_ticks, render_html, write_html
from flightlog_fd.report.json_report import JSON_SCHEMA, render_json, to_dict, validate
from flightlog_fd.report.terminal import render, summary_table, timeline_strip, verdict_sentence
from flightlog_fd.decision import CONFIDENCE_MEANING, HEADLINE_MAX, Verdict, headline, not_diagnosable
from flightlog_fd.timeline import build as build_timeline

HOSTILE = '<script>alert("x")</script>'


def make_diagnosis(onset_s=34.5, motor=3, path="flight.ulg", firmware="v1.14.0") -> Diagnosis:
    """A 100 s flight, windows 1.6 s every 0.8 s from t=10 s; motor damaged from ``onset_s``."""
    rng = np.random.default_rng(0)
    ts = np.arange(10.0, 98.0, 0.8)
    te = ts + 1.58
    probs = np.full((ts.size, 5), 0.03)
    cls = np.where(ts >= onset_s, motor, 0) if onset_s is not None else np.zeros(ts.size, int)
    probs[np.arange(ts.size), cls] = 0.88
    probs += rng.uniform(0, 0.01, probs.shape)
    probs /= probs.sum(axis=1, keepdims=True)
    frame = Frame.quad_x()
    timeline = build_timeline(ts, te, probs)
    run = timeline.run if timeline.run is not None and timeline.run.confirmed else None
    verdict = (Verdict("damaged", run.motor, frame.position(run.motor), 0.91, run.first_seen,
                       f"rotor {run.motor} gives about 70 % of its normal thrust [60-80 %]; evidence for rotor "
                       f"{run.motor} (nats): model +4.0, commands +3.1; P(damage) 0.97 with a prior of 0.10",
                       thrust=[{"motor": run.motor, "eta_hat": 0.7, "eta_ci": (0.6, 0.8)}], p_damage=0.97)
               if run else Verdict("healthy", confidence=0.88, reason="no rotor lost thrust", p_damage=0.12))
    verdict.headline = headline(verdict, f"since t={run.first_seen:.1f} s" if run else "", frame)
    t = np.arange(0.0, 100.0, 0.02)
    flight = Flight(path=path, autopilot="px4", firmware=firmware, vehicle_type="quadrotor", frame=frame,
                    rates=Series(t, 0.1 * np.sin(np.outer(t, [1.0, 1.3, 0.7])), "rates"),
                    motors=Series(t, np.full((t.size, 4), 0.5), "motors"),
                    airborne=[(8.0, 99.0)], t_start=0.0, t_end=100.0)
    windows = [WindowResult(float(a), float(b), int(c), [float(x) for x in p], "hover", int(lab))
               for a, b, c, p, lab in zip(ts, te, probs.argmax(axis=1), probs, timeline.labels)]
    return Diagnosis(log=path, verdict=verdict, facts=FlightFacts.from_flight(flight),
                     model=ModelInfo("/m/default.onnx", "1.0.0", "cd" * 32, list("hABCD"), False),
                     profile=None, windows=windows, warnings=["no calibration profile"], flight=flight,
                     timeline=timeline)


def bad_file_diagnosis() -> Diagnosis:
    return Diagnosis(log="notes.txt", verdict=not_diagnosable("not a PX4 ULog or ArduPilot DataFlash log"))


# ---------------------------------------------------------------- JSON

def test_json_validates_and_holds_the_verdict():
    d = make_diagnosis()
    doc = json.loads(render_json(d))
    assert validate(doc) == []
    assert doc["schema"] == 8 and doc["log"] == "flight.ulg" and doc["frame"] == "quad_x"
    assert doc["verdict"]["status"] == "damaged" and doc["verdict"]["motor"] == 3
    assert doc["verdict"]["headline"].startswith("Rotor 3 (front-left) lost ~30 % thrust since t=34.")
    assert doc["verdict"]["thrust"] == [{"motor": 3, "eta_hat": 0.7, "eta_ci": [0.6, 0.8]}]
    assert doc["verdict"]["p_damage"] == 0.97 and doc["verdict"]["prior_damage"] == 0.1
    assert doc["verdict"]["position"] == "front-left"
    assert abs(doc["verdict"]["first_seen"] - 34.8) < 1.0
    assert doc["exit_code"] == 1
    assert len(doc["windows"]) == len(d.windows)
    w0 = doc["windows"][0]
    assert w0["class"] == 0 and len(w0["probabilities"]) == 5 and abs(sum(w0["probabilities"]) - 1) < 1e-3
    assert doc["model"]["sha256"] == "cd" * 32 and doc["profile"] is None


def test_json_for_a_bad_file_and_for_many_logs():
    many = json.loads(render_json([make_diagnosis(), bad_file_diagnosis()]))
    assert isinstance(many, list) and len(many) == 2
    for doc in many:
        assert validate(doc) == []
    bad = many[1]
    assert bad["verdict"]["status"] == "not_diagnosable" and bad["exit_code"] == 2
    assert bad["autopilot"] is None and bad["windows"] == [] and bad["verdict"]["confidence"] == 0


def test_validator_catches_schema_violations():
    doc = to_dict(make_diagnosis())
    doc["verdict"]["status"] = "broken"
    doc["windows"][0]["probabilities"] = [1.0]  # no motor class
    doc["verdict"]["headline"] = "x" * (HEADLINE_MAX + 1)  # longer than a glance
    doc["verdict"]["cause"] = "gremlins"
    del doc["warnings"]
    errors = validate(doc)
    assert any("verdict.status" in e for e in errors)
    assert any("verdict.headline" in e for e in errors) and any("verdict.cause" in e for e in errors)
    assert any("windows[0].probabilities" in e for e in errors)
    assert any("missing 'warnings'" in e for e in errors)
    assert JSON_SCHEMA["properties"]["schema"]["const"] == 8


# ---------------------------------------------------------------- CSV

def test_csv_columns_and_rows(tmp_path):
    d = make_diagnosis()
    rows = list(csv.DictReader(io.StringIO(render_csv([d, bad_file_diagnosis()]))))
    assert tuple(rows[0].keys()) == csv_columns(d)
    assert tuple(rows[0].keys())[:9] == ("log", "t_start", "t_end", "class", "p_healthy", "p_motor1", "p_motor2",
                                         "p_motor3", "p_motor4")
    assert len(rows) == len(d.windows)  # the bad file adds no rows
    first, last = rows[0], rows[-1]
    assert first["class"] == "0" and last["class"] == "3" and last["smoothed_class"] == "3"
    assert {r["verdict_headline"] for r in rows} == {d.verdict.headline}
    assert float(first["t_start"]) == pytest.approx(10.0)
    assert float(first["p_healthy"]) > 0.8 and last["verdict"] == "damaged"
    out = tmp_path / "w.csv"
    write_csv(d, out)
    assert out.read_text(encoding="utf-8").splitlines()[0] == ",".join(csv_columns(d))


# ---------------------------------------------------------------- HTML

class PageParser(HTMLParser):
    """Collects tags, text, and any <script> element (there must be none)."""

    def __init__(self):
        super().__init__()
        self.tags: list[str] = []
        self.text: list[str] = []
        self.attrs: list[tuple[str, str]] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attrs += [(k, v or "") for k, v in attrs]

    def handle_data(self, data):
        self.text.append(data)


def parse(page: str) -> PageParser:
    p = PageParser()
    p.feed(page)
    p.close()
    return p


def test_html_has_verdict_plots_and_no_scripts(tmp_path):
    d = make_diagnosis()
    out = tmp_path / "r.html"
    write_html(d, out)
    page = out.read_text(encoding="utf-8")
    p = parse(page)
    text = " ".join(p.text)
    first = page[page.index("<body>"):]
    assert first.startswith(f"<body><h1 class=\"verdict\"") and verdict_sentence(d) in first[:400]  # the headline first
    assert "Propeller 3 (front-left) damaged" not in text  # no source but the commands and the model
    assert text.count(CONFIDENCE_MEANING) == 1  # its meaning once, in the legend
    assert "rotor 3 gives about 70 % of its normal thrust [60-80 %]" in text
    assert p.tags.count("svg") == 3  # rates, motor commands, class probabilities
    assert p.tags.count("polyline") == 3 + 4 + 5
    assert "rect" in p.tags  # window shading
    assert "script" not in p.tags
    assert not any(v.startswith("http") and k in ("src", "href") for k, v in p.attrs)  # nothing fetched


def test_html_escapes_hostile_text_from_the_log():
    d = make_diagnosis(path=f"{HOSTILE}.ulg", firmware=HOSTILE)
    d.warnings.append(HOSTILE)
    page = render_html([d, bad_file_diagnosis()])
    assert HOSTILE not in page
    assert "<script" not in page.lower()
    p = parse(page)
    assert "script" not in p.tags
    assert HOSTILE in " ".join(p.text)  # shown to the reader as text, escaped in the source
    assert "Summary" in " ".join(p.text)


def test_html_helpers():
    assert nice_ticks(0.0, 100.0, 5) == [0, 20, 40, 60, 80, 100]
    t = np.arange(10000.0)
    y = np.zeros(10000)
    y[5000] = 9.0  # a spike must survive decimation
    td, yd = decimate(t, y, 200)
    assert td.size <= 200 and yd.max() == 9.0 and np.all(np.diff(td) > 0)


# ---------------------------------------------------------------- terminal

def test_terminal_words_timeline_and_summary():
    d = make_diagnosis()
    assert verdict_sentence(d) == d.verdict.headline
    assert verdict_sentence(d).startswith("Rotor 3 (front-left) lost ~30 % thrust since t=34.")
    assert verdict_sentence(d).endswith(": inspect propeller 3")
    strip = timeline_strip(d, width=40).plain
    body = strip.split(" ")[2]  # "t=10.0 s <strip> t=... s"
    assert len(body) == 40 and body.startswith("....") and body.endswith("3333")
    healthy = make_diagnosis(onset_s=None)
    assert verdict_sentence(healthy) == "Healthy: no rotor lost thrust"
    unseen = make_diagnosis(onset_s=None)
    unseen.verdict = dataclasses.replace(unseen.verdict, seen=False)
    unseen.verdict.headline = headline(unseen.verdict)
    assert verdict_sentence(unseen).startswith("Healthy as far as this log shows") and "not a clearance" in \
        verdict_sentence(unseen)
    assert verdict_sentence(bad_file_diagnosis()).startswith("Not diagnosable: not a PX4 ULog")

    console = Console(record=True, width=120, color_system=None)
    render(d, console, show_windows=True)
    console.print(summary_table([d, healthy, bad_file_diagnosis()]))
    out = console.export_text()
    lines = out.splitlines()
    assert lines[0] == d.verdict.headline  # the first line
    assert lines[1] == "  damaged, confidence 0.91 | flight.ulg"
    assert "  - rotor 3 gives about 70 % of its normal thrust [60-80 %]" in lines  # a clause a line
    assert "warning: no calibration profile" in out
    assert "Windows" in out and "hover" in out
    assert "not_diagnosable" in out and "damaged 3 FL" in out
    assert " ".join(out.split()).count(CONFIDENCE_MEANING) == 1  # said once, in the legend
    assert "P(damage) 0.97 with a prior of 0.10" in out


def test_the_reason_is_said_once_and_the_cause_line_apart():
    """The reason's clauses, one a line (a bracket's ";" is no split), the cause clause on the
    cause line only; an analyzer's note already among them is not repeated under the table."""
    from flightlog_fd.report.words import cause_line, evidence_clauses, split_clauses

    assert split_clauses("a (x; y); b;c; ") == ["a (x; y)", "b;c"]
    v = Verdict("uncertain", 2, "rear-left", 0.4, reason="rotor 2 gives about 70 % of its normal thrust; cause: "
                "the log has no ESC telemetry, so (a; b); P(damage) 0.4 with a prior of 0.10; vibration low",
                cause_evidence={"motor": 2, "llr": None, "rpm_per_command": None, "current_per_rpm2": None,
                                "reason": "the log has no ESC telemetry, so (a; b)"})
    assert evidence_clauses(v) == ["rotor 2 gives about 70 % of its normal thrust",
                                   "P(damage) 0.4 with a prior of 0.10", "vibration low"]
    assert cause_line(v) == "cause: unknown: the log has no ESC telemetry, so (a; b)"
    v.cause, v.cause_probability = "motor_or_esc", 0.97
    v.cause_evidence = dict(v.cause_evidence, reason="the motor or its ESC is weak, not the propeller: 25 % slower")
    assert cause_line(v) == "cause (probability 0.97): the motor or its ESC is weak, not the propeller: 25 % slower"
    assert cause_line(Verdict("healthy", reason="x")) == "" and evidence_clauses(not_diagnosable("no log")) == []
    d = make_diagnosis()
    d.verdict.reason += "; vibration: a note an analyzer also made"
    from flightlog_fd.report.motor_view import MotorView
    view = MotorView(rows=[], columns=[], n_motors=4, notes=["vibration: vibration: a note an analyzer also made",
                                                             "esc: no ESC telemetry in this log"])
    assert view.notes_beside(evidence_clauses(d.verdict)) == ["esc: no ESC telemetry in this log"]


def test_decimate_keeps_each_buckets_first_minimum_and_maximum():
    """decimate (all buckets at once) against its definition, one bucket at a time: NaN ignored,
    infinities kept as values, buckets without a finite value dropped, the first of ties."""
    rng = np.random.default_rng(5)

    def one_at_a_time(t, y, max_points):
        if t.shape[0] <= max_points:
            return t, y
        edges = np.linspace(0, t.shape[0], max_points // 2 + 1).astype(int)
        keep = []
        for a, b in zip(edges[:-1], edges[1:]):
            seg = y[a:b]
            if b > a and np.isfinite(seg).any():
                keep.extend(sorted({a + int(np.nanargmin(seg)), a + int(np.nanargmax(seg))}))
        idx = np.asarray(keep, dtype=int)
        return t[idx], y[idx]

    for _ in range(500):
        n, max_points = int(rng.integers(1, 3000)), int(rng.integers(2, 300))
        y = np.round(rng.normal(size=n), int(rng.integers(0, 3)))
        y[rng.random(n) < rng.random() * 0.5] = np.nan
        y[rng.random(n) < 0.02] = np.inf
        y[rng.random(n) < 0.02] = -np.inf
        t = np.arange(n) * 0.01
        got, want = decimate(t, y, max_points), one_at_a_time(t, y, max_points)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1], equal_nan=True)


def test_confidence_has_one_meaning_in_the_reference_the_guide_and_the_reports():
    """The one sentence (decision.CONFIDENCE_MEANING) word for word in the JSON reference (docstring
    and JSON Schema), the guide and the report line."""
    from pathlib import Path

    from flightlog_fd.report import json_report

    flat = lambda text: " ".join(text.split())  # noqa: E731
    assert CONFIDENCE_MEANING in flat(json_report.__doc__)
    assert JSON_SCHEMA["properties"]["verdict"]["properties"]["confidence"]["description"] == CONFIDENCE_MEANING
    guide = Path(__file__).resolve().parent.parent / "docs" / "verdicts.md"
    assert f"**Confidence**: {CONFIDENCE_MEANING}." in flat(guide.read_text())
    console = Console(record=True, width=80, color_system=None)
    render(make_diagnosis(), console)  # the report's legend, not every line
    assert flat(console.export_text()).count(CONFIDENCE_MEANING) == 1
    assert CONFIDENCE_MEANING not in verdict_sentence(make_diagnosis())
