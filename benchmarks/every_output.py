"""Every output on every log: finds the logs a report cannot draw, or draws differently.

What: each log under the folders given (default: ``sample_logs/`` and every dataset of
``../shared``) is diagnosed ONCE through the library (``batch.diagnose_one``, the CLI's path), then
drawn by every report from that one result: the terminal with ``--windows``, JSON (validated),
CSV, HTML, the ``--db`` store (``Store.add_result``) and the fleet page's flight page (the server's
own worker result, :func:`flightlog_fd.serve.worker.task_result`, stored as a finished job and
fetched through the app). Prints one line per failure (a traceback's last line, or two outputs
saying different things) and a count per dataset. ``--cli`` also runs ``fdlog diagnose`` once per
dataset folder with every output at once and checks its exit code.

Run it nice'd: ``nice -n 10 .venv/bin/python benchmarks/every_output.py [FOLDER...] [--cli]``.
About 2-4 s of CPU per log (the diagnosis), 140+ logs.
"""
from __future__ import annotations

import argparse
import csv
import io
import json
import re
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
LOG_SUFFIXES = (".ulg", ".bin")


def log_files(folder: Path) -> list[Path]:
    """Every log under ``folder`` (ULog or DataFlash by suffix, any case), sorted."""
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in LOG_SUFFIXES)


def datasets() -> list[Path]:
    out = [ROOT / "sample_logs"]
    if SHARED.is_dir():
        out += sorted(p for p in SHARED.iterdir() if p.is_dir() and log_files(p))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="*", type=Path)
    ap.add_argument("--cli", action="store_true", help="also fdlog diagnose once per folder, every output")
    args = ap.parse_args(argv)

    from fastapi.testclient import TestClient
    from rich.console import Console

    from flightlog_fd.batch import diagnose_one
    from flightlog_fd.diagnose import resolve_model
    from flightlog_fd.report import terminal
    from flightlog_fd.report.csv_report import render_csv
    from flightlog_fd.report.html_report import render_html
    from flightlog_fd.report.json_report import render_json, validate
    from flightlog_fd.serve.app import ServeConfig, create_app
    from flightlog_fd.serve.security import TokenSet
    from flightlog_fd.serve.worker import task_result
    from flightlog_fd.store import RunInfo, Store

    model = resolve_model()
    folders = args.folders or datasets()
    tmp = Path(tempfile.mkdtemp(prefix="every_output_"))
    db = Store(tmp / "cli.sqlite")
    run = RunInfo.for_batch(model)
    app = create_app(ServeConfig(data_dir=tmp / "serve", tokens=TokenSet(["x" * 24]), workers=0))
    failures: list[str] = []
    counts: dict[str, list[int]] = {}
    with TestClient(app, raise_server_exceptions=False) as client:
        web = Store(tmp / "serve" / "fdlog.sqlite")
        for folder in folders:
            files = log_files(folder)
            counts[folder.name] = [len(files), 0]
            for i, p in enumerate(files):
                name = f"{folder.name}/{p.relative_to(folder)}"
                bad: list[str] = []

                def attempt(what, fn):
                    try:
                        return fn()
                    except Exception as e:
                        tb = traceback.extract_tb(e.__traceback__)[-1]
                        bad.append(f"{what}: {type(e).__name__}: {str(e)[:120]} ({Path(tb.filename).name}:{tb.lineno})")
                        return None

                t0 = time.process_time()
                res = diagnose_one(i, p, model, keep_flight=True)
                d = res.diagnosis
                v = d.verdict
                if "internal error" in (v.reason or ""):
                    bad.append(f"diagnose: {v.reason}")
                want = (v.status, v.motor)

                def term():
                    con = Console(file=io.StringIO(), width=80, color_system=None)
                    terminal.render(d, con, show_windows=True)
                    return con.file.getvalue()

                text = attempt("terminal", term)
                doc = attempt("json", lambda: json.loads(render_json(d)))
                if doc is not None:
                    errs = validate(doc)
                    if errs:
                        bad.append(f"json: invalid: {errs[:2]}")
                    if (doc["verdict"]["status"], doc["verdict"]["motor"]) != want:
                        bad.append(f"json: verdict {doc['verdict']['status']} {doc['verdict']['motor']} != {want}")
                rows = attempt("csv", lambda: list(csv.reader(io.StringIO(render_csv(d)))))
                if rows:
                    if {len(r) for r in rows} != {len(rows[0])}:
                        bad.append("csv: rows of different widths")
                    h = rows[0]
                    got = {(r[h.index("verdict")], r[h.index("verdict_motor")]) for r in rows[1:]}
                    if got and got != {(v.status, str(v.motor or ""))}:
                        bad.append(f"csv: verdict {got} != {want}")
                page = attempt("html", lambda: render_html(d))
                if page is not None and text is not None:
                    sentence = terminal.verdict_sentence(d)
                    import html as _html
                    if _html.escape(sentence, quote=True) not in page:
                        bad.append("html: the verdict sentence is not the terminal's")
                fid = attempt("store", lambda: db.add_result(res, run))
                if fid is not None:
                    row = db.flight(fid)
                    if (row["status"], row["motor"]) != want:
                        bad.append(f"store: verdict {row['status']} {row['motor']} != {want}")

                def flight_page():
                    sha = res.log_sha256 or f"{i:064d}"
                    out = task_result(d, d.flight, sha, p.name, str(tmp / "serve" / "reports"))
                    fid2, _ = web.add_upload(sha + "", p.name, p.stat().st_size, "ulog" if p.suffix.lower() == ".ulg" else "bin")
                    job = web.claim_job("survey")
                    web.complete_diagnosis(job, "survey", out)
                    for w in out["diagnosis"]["warnings"]:
                        if "could not be drawn" in w:
                            bad.append(f"flight page: {w}")
                    r = client.get(f"/flights/{fid2}")
                    if r.status_code != 200:
                        bad.append(f"flight page: HTTP {r.status_code}")
                        return
                    m = re.search(r'data-status="([^"]*)"', r.text)
                    if m is None or m.group(1) != v.status:
                        bad.append(f"flight page: status {m.group(1) if m else None} != {v.status}")
                    for ext in ("html", "csv"):
                        if v.status != "not_diagnosable" and client.get(f"/flights/{fid2}/report.{ext}").status_code != 200:
                            bad.append(f"flight page: no {ext} report")

                attempt("flight page", flight_page)
                cpu = time.process_time() - t0
                counts[folder.name][1] += bool(bad)
                line = f"{name}: {v.status} {v.motor or ''} exit {d.exit_code} ({cpu:.1f} s CPU)"
                print(line + ("" if not bad else "\n    " + "\n    ".join(bad)), flush=True)
                failures += [f"{name}: {b}" for b in bad]
        web.close()
    db.close()
    if args.cli:
        for folder in folders:
            with tempfile.TemporaryDirectory() as t:
                cmd = [str(Path(sys.executable).parent / "fdlog"), "diagnose", str(folder), "--windows",
                       "--csv", f"{t}/r.csv", "--html", f"{t}/r.html", "--db", f"{t}/r.sqlite"]
                r = subprocess.run(cmd, capture_output=True, text=True)
                tb = "Traceback" in r.stdout + r.stderr
                print(f"CLI {folder.name}: exit {r.returncode}{' TRACEBACK' if tb else ''}", flush=True)
                if tb or r.returncode not in (0, 1, 2):
                    failures.append(f"CLI {folder.name}: exit {r.returncode} {(r.stderr or '')[-300:]}")
    print("\nper dataset (logs, logs with a failure):")
    for k, (n, f) in counts.items():
        print(f"  {k}: {n} logs, {f} failing")
    print(f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
