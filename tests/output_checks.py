"""Every output of one diagnosed log, checked: the helpers of the test_outputs_* files (one per
dataset of ../shared) and of ``benchmarks/every_output.py``.

A log is diagnosed ONCE (``batch.diagnose_one``, the CLI's own path, keeping the flight for the
plots); :func:`output_problems` draws every report from that one result: the terminal with
``--windows``, JSON (validated), CSV, HTML and the ``--db`` store; :class:`FlightPages` stores it
as the fleet page's finished job (the server's own :func:`~flightlog_fd.serve.worker.task_result`)
and fetches its flight page through the app, one store for all the logs of a test file. Each
returns the problems it found (a traceback's last frame, or two outputs that say different
things), [] when every output agrees with the diagnosis. Importable without pytest state.
"""
from __future__ import annotations

import csv
import dataclasses
import html
import io
import json
import re
import tempfile
import traceback
from pathlib import Path
from typing import Any, Callable, Optional

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
SAMPLES = ROOT / "sample_logs"
LOG_SUFFIXES = (".ulg", ".bin")


def log_files(folder: Path) -> list[Path]:
    """Every log under ``folder`` (ULog or DataFlash by suffix, any case), sorted."""
    return sorted(p for p in Path(folder).rglob("*") if p.is_file() and p.suffix.lower() in LOG_SUFFIXES)


def shared_datasets() -> list[Path]:
    """Every folder of ../shared holding logs ([] without ../shared)."""
    if not SHARED.is_dir():
        return []
    return sorted(p for p in SHARED.iterdir() if p.is_dir() and log_files(p))


def _attempt(bad: list[str], what: str, fn: Callable[[], Any]) -> Any:
    try:
        return fn()
    except Exception as e:  # the problem found, with where it was raised
        tb = traceback.extract_tb(e.__traceback__)[-1]
        bad.append(f"{what}: {type(e).__name__}: {str(e)[:160]} ({Path(tb.filename).name}:{tb.lineno})")
        return None


def output_problems(res: Any, store: Any = None, run: Any = None) -> list[str]:
    """What is wrong with the outputs of one ``LogResult`` (module docstring); ``store`` and
    ``run``: a :class:`~flightlog_fd.store.Store` and its RunInfo to write the result to."""
    from rich.console import Console

    from flightlog_fd.report import terminal
    from flightlog_fd.report.csv_report import render_csv
    from flightlog_fd.report.html_report import render_html
    from flightlog_fd.report.json_report import render_json, validate
    from flightlog_fd.decision import CONFIDENCE_MEANING, HEADLINE_MAX
    from flightlog_fd.report.words import cause_words, evidence_clauses

    d = res.diagnosis
    v = d.verdict
    bad: list[str] = []
    if "internal error" in (v.reason or ""):
        bad.append(f"diagnose: {v.reason}")
    want = (v.status, v.motor)
    lost = cause_words(v.cause).lost

    def term() -> str:
        con = Console(file=io.StringIO(), width=80, color_system=None)
        terminal.render(d, con, show_windows=True)
        return con.file.getvalue()

    head = terminal.verdict_sentence(d)
    flat = lambda t: " ".join(t.split())  # noqa: E731  (the words, whatever the wrapping)
    if not head or len(head) > HEADLINE_MAX:
        bad.append(f"headline: {len(head)} characters (at most {HEADLINE_MAX}): {head!r}")
    text = _attempt(bad, "terminal", term)
    if text is not None:
        lines = text.splitlines()
        if not flat("\n".join(lines[:2])).startswith(flat(head)):
            bad.append("terminal: the first line is not the headline")
        if max(len(ln) for ln in lines) > 80:
            bad.append("terminal: a line over 80 columns")
        if d.windows and f"1-{terminal.LABEL_CHARS[len(d.windows[0].probabilities) - 1]} {lost}" not in flat(text):
            bad.append(f"terminal: the timeline legend does not say {lost!r} (cause {v.cause})")
        paragraphs = [flat(c) for c in evidence_clauses(v) if len(c) > 40]
        if any(flat(text).count(c) > 1 for c in paragraphs):
            bad.append("terminal: an evidence clause said twice")
    doc = _attempt(bad, "json", lambda: json.loads(render_json(d)))
    if doc is not None:
        errs = validate(doc)
        if errs:
            bad.append(f"json: invalid: {errs[:2]}")
        jv = doc["verdict"]
        if (jv["status"], jv["motor"], jv["cause"], jv["headline"]) != (*want, v.cause, head):
            bad.append(f"json: verdict {jv['status']} {jv['motor']} {jv['cause']} != {want} {v.cause}")
    rows = _attempt(bad, "csv", lambda: list(csv.reader(io.StringIO(render_csv(d)))))
    if rows:
        if {len(r) for r in rows} != {len(rows[0])}:
            bad.append("csv: rows of different widths")
        h = rows[0]
        got = {(r[h.index("verdict")], r[h.index("verdict_motor")], r[h.index("verdict_cause")],
                r[h.index("verdict_headline")]) for r in rows[1:]}
        if len(rows) != len(d.windows) + 1 or (got and got != {(v.status, str(v.motor or ""), v.cause or "", head)}):
            bad.append(f"csv: {len(rows) - 1} rows for {len(d.windows)} windows, verdict {got} != {want} {v.cause}")
    page = _attempt(bad, "html", lambda: render_html(d))
    if page is not None:
        body = page[page.index("<body>"):]
        first = re.search(r"<h1[^>]*>(.*?)</h1>", body, re.S)
        if first is None or html.unescape(first.group(1)) != head:
            bad.append("html: the first line is not the headline")
        if v.status != "not_diagnosable" and body.count(html.escape(CONFIDENCE_MEANING, quote=True)) != 1:
            bad.append("html: the confidence legend not said once")
        if d.windows and f"red {html.escape(lost, quote=True)}," not in page:
            bad.append(f"html: the background legend does not say {lost!r}")
        fl = d.flight
        for what, series, title in (("motor commands", fl and fl.motors, "Motor commands"),
                                    ("angular rates", fl and fl.rates, "Angular rates")):
            if series is not None and len(series) and f'aria-label="{title}' not in page:
                bad.append(f"html: no {what} panel")  # the panels the log can draw are drawn
        if d.windows and 'aria-label="Class probabilities per window"' not in page:
            bad.append("html: no class probabilities panel")
    if store is not None and res.log_sha256:
        fid = _attempt(bad, "store", lambda: store.add_result(res, run))
        if fid is not None:
            row = store.flight(fid)
            if (row["status"], row["motor"], row["cause"]) != (*want, v.cause):
                bad.append(f"store: verdict {row['status']} {row['motor']} {row['cause']} != {want} {v.cause}")
    return bad


class FlightPages:
    """The fleet page (``fdlog serve``'s app, no job workers) over one store in a temporary
    folder: :meth:`problems` stores a diagnosis as its finished job and reads its flight page."""

    def __init__(self, root: Optional[Path] = None):
        from fastapi.testclient import TestClient

        from flightlog_fd.serve.app import ServeConfig, create_app
        from flightlog_fd.serve.security import TokenSet
        from flightlog_fd.store import Store

        self._tmp = None if root is not None else tempfile.TemporaryDirectory(prefix="fdlog-pages-")
        self.root = Path(root if root is not None else self._tmp.name)
        app = create_app(ServeConfig(data_dir=self.root, tokens=TokenSet(["t" * 24]), workers=0))
        self.client = TestClient(app, raise_server_exceptions=False).__enter__()
        self.store = Store(self.root / "fdlog.sqlite")
        self.n = 0

    def close(self) -> None:
        self.client.__exit__(None, None, None)
        self.store.close()
        if self._tmp is not None:
            self._tmp.cleanup()

    def problems(self, res: Any, path: Path) -> list[str]:
        """What is wrong with the flight page of ``res`` (a LogResult of ``path``)."""
        from flightlog_fd.report import terminal
        from flightlog_fd.report.words import cause_words
        from flightlog_fd.serve.worker import task_result

        bad: list[str] = []
        d, v = res.diagnosis, res.diagnosis.verdict
        self.n += 1
        sha = res.log_sha256 or f"{self.n:064x}"
        # the worker names the report after the upload: a copy, so the caller's diagnosis stays as it was
        mine = dataclasses.replace(d, warnings=list(d.warnings),
                                   facts=dataclasses.replace(d.facts) if d.facts is not None else None)
        out = _attempt(bad, "flight page (worker)",
                       lambda: task_result(mine, d.flight, sha, path.name, str(self.root / "reports")))
        if out is None:
            return bad
        bad += [f"flight page: {w}" for w in out["diagnosis"]["warnings"] if "could not be drawn" in w]
        fid, _ = self.store.add_upload(sha, path.name, path.stat().st_size,
                                       "ulog" if path.suffix.lower() == ".ulg" else "dataflash")
        job = self.store.claim_job("tests")
        self.store.complete_diagnosis(job, "tests", out)
        r = self.client.get(f"/flights/{fid}")
        if r.status_code != 200:
            return bad + [f"flight page: HTTP {r.status_code}"]
        m = re.search(r'data-status="([^"]*)"', r.text)
        if m is None or m.group(1) != v.status:
            bad.append(f"flight page: status {m.group(1) if m else None} != {v.status}")
        first = re.search(r"<h1[^>]*>(.*?)</h1>", r.text, re.S)
        if first is None or html.unescape(first.group(1)) != (v.headline or terminal.verdict_sentence(d)):
            bad.append("flight page: the first line is not the headline")
        row = self.store.flight(fid)
        if (row["status"], row["motor"]) != (v.status, v.motor):
            bad.append(f"flight page store: {row['status']} {row['motor']} != {v.status} {v.motor}")
        lost = html.escape(cause_words(v.cause).lost, quote=True)
        if d.windows and f"red {lost}," not in r.text:
            bad.append(f"flight page: the plot legend does not say {cause_words(v.cause).lost!r}")
        if d.flight is not None and out["plot"].get("missing") and 'id="missing"' not in r.text:
            bad.append("flight page: the missing streams are not said")
        fl = d.flight
        for key, series in (("motors", fl and fl.motors), ("rates", fl and fl.rates)):
            if series is not None and len(series) and not out["plot"][key]:
                bad.append(f"flight page: no {key} lines")
        if d.windows and 'id="flightplot"' not in r.text:
            bad.append("flight page: no timeline plot")
        if v.status != "not_diagnosable":
            for ext in ("html", "csv"):
                if self.client.get(f"/flights/{fid}/report.{ext}").status_code != 200:
                    bad.append(f"flight page: no {ext.upper()} report")
        return bad


class OutputRun:
    """One test file's run: the shipped model, a ``--db`` store and the fleet page, shared by its
    logs; :meth:`check` diagnoses one log once and returns every output's problems."""

    def __init__(self, root: Path):
        from flightlog_fd.diagnose import resolve_model
        from flightlog_fd.store import RunInfo, Store

        self.model = resolve_model()
        self.store, self.run = Store(Path(root) / "cli.sqlite"), RunInfo.for_batch(self.model)
        self.pages = FlightPages(Path(root) / "serve")

    def check(self, path: Path) -> list[str]:
        from flightlog_fd.batch import diagnose_one

        return self.problems(diagnose_one(0, path, self.model, keep_flight=True), path)

    def problems(self, res: Any, path: Path) -> list[str]:
        """Every output's problems for a result made already (a LogResult of ``path``)."""
        return output_problems(res, self.store, self.run) + self.pages.problems(res, path)

    def history_problems(self, logs: list[Path]) -> list[str]:
        """`fdlog history` over the store the checked logs went to (text, JSON and HTML, as its
        command draws them) and the fleet and airframe pages over the flight pages' store: every
        log listed, nothing raised."""
        from flightlog_fd.history import history_summary, iter_text_lines, render_html, summary_json

        bad: list[str] = []
        summary = _attempt(bad, "history", lambda: history_summary(self.store.history()))
        if summary is not None:
            text = "\n".join(_attempt(bad, "history text", lambda: list(iter_text_lines(summary))) or [])
            _attempt(bad, "history json", lambda: json.loads(summary_json(summary)))
            _attempt(bad, "history html", lambda: render_html(summary))
            missing = [p.name for p in logs if p.name not in text]
            if missing:
                bad.append(f"history: {len(missing)} stored logs not listed, e.g. {missing[:3]}")
        r = self.pages.client.get("/")
        if r.status_code != 200:
            bad.append(f"fleet page: HTTP {r.status_code}")
        for key in {row["airframe"] for row in self.pages.client.get("/api/logs").json()["logs"]}:
            if self.pages.client.get("/airframe", params={"key": key}).status_code != 200:
                bad.append(f"airframe page {key}: not drawn")
        return bad

    def close(self) -> None:
        self.pages.close()
        self.store.close()


def shared_log_params(*datasets: str) -> list:
    """pytest params: every log of these ../shared datasets (id: dataset/relative path), or one
    skipped param saying why when ../shared or a dataset is absent."""
    import pytest

    out = []
    for ds in datasets:
        folder = SHARED / ds
        files = log_files(folder) if folder.is_dir() else []
        if not files:
            out.append(pytest.param(None, id=ds, marks=pytest.mark.skip(reason=f"../shared/{ds} not available")))
        out += [pytest.param(p, id=f"{ds}/{p.relative_to(folder)}") for p in files]
    return out


def cli_exit_problems(path: Path, tmp: Path) -> list[str]:
    """``fdlog diagnose LOG --windows --json --csv --html --db`` as a user runs it (the installed
    command, a process of its own): no traceback, and the exit code the documented one for the
    verdict its JSON states (0 healthy, 1 damaged / uncertain / stopped, 2 not diagnosable)."""
    import subprocess
    import sys

    fdlog = Path(sys.executable).parent / "fdlog"
    r = subprocess.run([str(fdlog), "diagnose", str(path), "--windows", "--json", "--csv", str(tmp / "r.csv"),
                        "--html", str(tmp / "r.html"), "--db", str(tmp / "r.sqlite")],
                       capture_output=True, text=True, timeout=300)
    bad = [f"CLI: traceback: {r.stderr[-300:]}"] if "Traceback" in r.stdout + r.stderr else []
    try:
        status = json.loads(r.stdout)["verdict"]["status"]
    except (ValueError, KeyError, TypeError):
        return bad + [f"CLI: no JSON on stdout (exit {r.returncode}): {r.stderr[-300:]}"]
    want = {"healthy": 0, "damaged": 1, "uncertain": 1, "stopped": 1}.get(status, 2)
    if r.returncode != want:
        bad.append(f"CLI: exit {r.returncode} for {status} (documented: {want})")
    if want != 2 and not (tmp / "r.html").is_file():
        bad.append("CLI: no HTML report written")
    return bad


def dataset_tests(datasets: tuple[str, ...], cli_logs: tuple[str, ...]) -> tuple[Callable, Callable, Callable]:
    """The three tests a ``tests/test_outputs_*.py`` file runs over its ../shared datasets, made once
    here (the files exist only so ``pytest -n 2 --dist loadfile`` spreads the datasets over both
    processes): every output of each log, then `fdlog history` and the fleet pages over the store
    those logs filled (same file, same ``every_output`` fixture), and ``fdlog diagnose`` as a
    process on ``cli_logs`` (paths under ../shared) for its exit code."""
    import pytest

    @pytest.mark.parametrize("path", shared_log_params(*datasets))
    def test_every_output_of_the_log(path, every_output):
        assert every_output.check(path) == []

    def test_history_and_the_fleet_pages_of_those_logs(every_output):
        logs = [p.values[0] for p in shared_log_params(*datasets) if p.values[0] is not None]
        if not logs:
            pytest.skip("../shared not available")
        assert every_output.history_problems(logs) == []

    @pytest.mark.parametrize("rel", cli_logs)
    def test_the_cli_exit_code(rel, tmp_path):
        path = SHARED / rel
        if not path.is_file():
            pytest.skip(f"../shared/{rel} not available")
        assert cli_exit_problems(path, tmp_path) == []

    return test_every_output_of_the_log, test_history_and_the_fleet_pages_of_those_logs, test_the_cli_exit_code
