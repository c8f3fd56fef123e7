"""An uncertain verdict naming one propeller to inspect carries it as ``verdict.motor`` (and its
position) in every report and the store, as a damaged verdict does."""
from __future__ import annotations

import csv
import io

from rich.console import Console

from flightlog_fd.batch import LogResult
from flightlog_fd.decision import Verdict
from flightlog_fd.diagnose import Diagnosis, WindowResult
from flightlog_fd.history import history_summary, iter_text_lines
from flightlog_fd.report.csv_report import render_csv
from flightlog_fd.report.html_report import render_html
from flightlog_fd.report.json_report import to_dict, validate
from flightlog_fd.report.terminal import summary_table
from flightlog_fd.store import RunInfo, Store, load_history


def _diagnosis(path: str, verdict: Verdict) -> Diagnosis:
    windows = [WindowResult(10.0 * i, 10.0 * i + 1.6, 2, [0.4, 0.05, 0.45, 0.05, 0.05], "hover", -1)
               for i in range(3)]
    return Diagnosis(log=path, verdict=verdict, windows=windows)


UNCERTAIN = Verdict("uncertain", motor=2, position="rear-left", confidence=0.6, inspect=(2,),
                    reason="motor 2 (rear-left) may have lost thrust, but the evidence is too weak to call")
TWO = Verdict("uncertain", confidence=0.5, inspect=(1, 4),
              reason="the evidence points at motor 1 or motor 4 and cannot tell them apart")


def test_every_report_names_the_propeller_an_uncertain_verdict_asks_to_inspect():
    one, two = _diagnosis("a.ulg", UNCERTAIN), _diagnosis("b.ulg", TWO)
    doc = to_dict(one)
    assert validate(doc) == [] and (doc["verdict"]["motor"], doc["verdict"]["position"]) == (2, "rear-left")
    assert to_dict(two)["verdict"]["motor"] is None
    rows = list(csv.DictReader(io.StringIO(render_csv([one, two]))))
    assert {r["log"]: r["verdict_motor"] for r in rows} == {"a.ulg": "2", "b.ulg": ""}
    assert all(r["verdict"] == "uncertain" for r in rows)
    console = Console(record=True, width=120, color_system=None)
    console.print(summary_table([one, two]))
    line = next(x for x in console.export_text().splitlines() if x.strip().startswith("a.ulg"))
    assert "uncertain 2 RL" in line
    assert "<td>Uncertain: rotor 2 (rear-left) may have lost thrust: inspect propeller 2</td>" in render_html([one, two])


def test_the_store_and_history_keep_it(tmp_path):
    db = tmp_path / "r.sqlite"
    run = RunInfo(model_sha256="m" * 64, model_version="test-1", tool_version="0.1.0")
    with Store(db) as store:
        store.add_result(LogResult(0, "a.ulg", _diagnosis("a.ulg", UNCERTAIN), log_sha256="a" * 64,
                                   vehicle_id="A1", vehicle_id_source="sys_uuid", command_share=[0.25] * 4), run)
    (flight,) = load_history(db)["A1"]
    assert (flight.status, flight.motor) == ("uncertain", 2)
    text = "\n".join(iter_text_lines(history_summary(load_history(db))))
    assert "uncertain m2" in text
