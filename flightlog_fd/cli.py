"""`fdlog`: the command line. Thin: parse arguments, call the library, print.

Every command catches :class:`~flightlog_fd.errors.FlightLogError` and prints one line
``fdlog: <file>: <problem>`` with exit code 2, never a traceback. Heavy imports (torch, the
simulator) happen inside the commands that need them, so `fdlog diagnose` runs without torch.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console

from .errors import FlightLogError, NotALogError

app = typer.Typer(
    help="Offline propeller-fault diagnosis for multirotor flight logs (PX4 ULog, ArduPilot DataFlash).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

EXIT_OK, EXIT_DAMAGE, EXIT_INVALID = 0, 1, 2


@app.callback()
def _root() -> None:
    """Offline propeller-fault diagnosis for multirotor flight logs (PX4 ULog, ArduPilot DataFlash).

    Exit codes: 0 healthy, 1 damage found or uncertain, 2 invalid input or not diagnosable.
    """


def _console(stderr: bool = False) -> Console:
    return Console(stderr=stderr, highlight=False, soft_wrap=True)


def _fail(err: FlightLogError | str) -> None:
    """Print one error line to stderr."""
    _console(stderr=True).print(f"fdlog: {err}", markup=False)


@app.command()
def info(
    logs: List[Path] = typer.Argument(..., help="Log files (.ulg / .bin) or folders of them."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON for machines instead of text."),
) -> None:
    """Describe logs: autopilot, vehicle, frame, streams and rates, airborne time, and whether they can be diagnosed."""
    from . import load_flight
    from .checks import describe_flight
    from .logs import collect_logs
    from .report.info_text import print_info

    files, errors = collect_logs(logs)
    for e in errors:
        _fail(e)
    out = []
    code = EXIT_INVALID if errors else EXIT_OK
    console = _console()
    for f in files:
        try:
            flight = load_flight(f)
        except FlightLogError as e:
            _fail(e)
            code = EXIT_INVALID
            if as_json:
                out.append({"log": str(f), "error": e.message})
            continue
        d = describe_flight(flight)
        if not d["diagnosable"]:
            code = EXIT_INVALID
        if as_json:
            out.append(d)
        else:
            print_info(console, d)
    if as_json:
        typer.echo(json.dumps(out if len(out) != 1 else out[0], indent=2))
    if not files and not errors:
        _fail("no log files found")
        code = EXIT_INVALID
    raise typer.Exit(code)


def _progress(console: Console, total: int, label: str):
    """A rich progress bar on stderr (hidden when not a terminal or for a single item)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    return Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                    console=console, transient=True, disable=total <= 1)


@app.command()
def diagnose(
    logs: List[Path] = typer.Argument(..., help="Log files (.ulg / .bin) or folders of them."),
    profile: Optional[Path] = typer.Option(None, "--profile", "-p", help="Calibration profile from `fdlog calibrate` (its adapted model is used)."),
    model: Optional[Path] = typer.Option(None, "--model", "-m", help="ONNX model to use instead of the profile's or the shipped one."),
    as_json: bool = typer.Option(False, "--json", help="Print the versioned JSON report (its schema: flightlog_fd/report/json_report.py) instead of text."),
    csv_out: Optional[Path] = typer.Option(None, "--csv", help="Write the per-window timeline of every log to this CSV file."),
    html_out: Optional[Path] = typer.Option(None, "--html", help="Write a self-contained HTML report to this file."),
    windows: bool = typer.Option(False, "--windows", help="Also print the table of windows."),
    jobs: Optional[int] = typer.Option(None, "--jobs", "-j", min=1, help="Diagnose several logs in parallel processes (with --scheduler local: the number of Dask workers, default one per core)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Run the batch on Dask: 'local' (a LocalCluster here) or a scheduler address tcp://HOST:8786 (needs flightlog-fd[fleet])."),
    db: Optional[str] = typer.Option(None, "--db", help="Write every diagnosis to this store: a SQLite file or a postgresql:// URL (see `fdlog history`, `fdlog serve --db`)."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing --csv / --html files."),
) -> None:
    """Diagnose logs: per-window timeline, flight verdict (healthy / propeller k damaged / uncertain) and reports.

    Exit code: 0 every log healthy, 1 damage found or uncertain, 2 invalid input or not diagnosable.
    """
    from .batch import run_batch
    from .diagnose import resolve_model
    from .profile import Profile
    from .report import terminal

    for out in (csv_out, html_out):
        if out is not None and out.exists() and not force:
            _fail(f"{out}: already exists (use --force to overwrite)")
            raise typer.Exit(EXIT_INVALID)
    from .logs import collect_logs

    files, errors = collect_logs(logs)
    for e in errors:
        _fail(e)
    if not files:
        if not errors:
            _fail("no log files found in " + ", ".join(str(p) for p in logs))
        raise typer.Exit(EXIT_INVALID)
    try:
        prof = Profile.load(profile) if profile is not None else None
        fault_model = resolve_model(model, prof)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)

    if scheduler is not None:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            _fail("--scheduler needs Dask: pip install 'flightlog-fd[fleet]'")
            raise typer.Exit(EXIT_INVALID)
    store = run_info = None
    if db is not None:
        from .store import RunInfo, Store

        try:
            store = Store(db)
        except FlightLogError as e:
            _fail(e)
            raise typer.Exit(EXIT_INVALID)
        run_info = RunInfo.for_batch(fault_model, prof)

    console = _console()
    err_console = _console(stderr=True)
    keep = html_out is not None
    store_errors: list[str] = []
    with _progress(err_console, len(files), "diagnosing") as bar:
        task = bar.add_task("diagnosing", total=len(files))

        def on_result(r) -> None:
            # Runs in this process as each log finishes: the client writes the store, never a worker.
            if store is not None:
                try:
                    store.add_result(r, run_info)
                except FlightLogError as e:
                    store_errors.append(str(e))
            bar.advance(task)

        try:
            batch = run_batch(files, fault_model, prof, jobs=jobs, scheduler=scheduler, keep_flight=keep,
                              on_result=on_result)
        except FlightLogError as e:
            _fail(e)
            raise typer.Exit(EXIT_INVALID)
        finally:
            if store is not None:
                store.close()
    results = [r.diagnosis for r in batch]
    for e in dict.fromkeys(store_errors):  # a store that fails, fails alike for every log: say it once
        _fail(e)

    if as_json:
        from .report.json_report import render_json

        typer.echo(render_json(results[0] if len(results) == 1 else results))
    else:
        for d in results:
            terminal.render(d, console, show_windows=windows)
            console.print()
        if len(results) > 1:
            console.print(terminal.summary_table(results))
    for d in results:
        if d.verdict.status == "not_diagnosable":
            _fail(f"{d.log}: not diagnosable: {d.verdict.reason}")
    if csv_out is not None:
        from .report.csv_report import write_csv

        write_csv(results, csv_out)
    if html_out is not None:
        from .report.html_report import write_html

        write_html(results if len(results) > 1 else results[0], html_out)
    codes = [d.exit_code for d in results]
    raise typer.Exit(EXIT_INVALID if errors or store_errors or EXIT_INVALID in codes else max(codes))


@app.command()
def history(
    db: str = typer.Option(..., "--db", help="The store written by `fdlog diagnose --db` or `fdlog serve` (SQLite file or postgresql:// URL)."),
    vehicle: Optional[str] = typer.Option(None, "--vehicle", help="Only this airframe (as history lists it)."),
    html_out: Optional[Path] = typer.Option(None, "--html", help="Also write a self-contained HTML page with a trend plot per airframe."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON for machines instead of text."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing --html file."),
) -> None:
    """Per airframe: its flights in time order with verdicts and each motor's figures; flags a motor drifting away from the others.

    Exit code: 0 nothing flagged, 1 a drifting motor or a damaged verdict in an airframe's latest flight, 2 bad input.
    """
    from .history import history_summary, iter_text_lines, render_html, summary_json
    from .store import load_history

    if html_out is not None and html_out.exists() and not force:
        _fail(f"{html_out}: already exists (use --force to overwrite)")
        raise typer.Exit(EXIT_INVALID)
    try:
        hist = load_history(db, vehicle)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    if vehicle is not None and not hist:
        _fail(f"{db}: no flights of vehicle {vehicle!r}")
        raise typer.Exit(EXIT_INVALID)
    summary = history_summary(hist)
    if as_json:
        typer.echo(summary_json(summary))
    else:
        console = _console()
        if not hist:
            console.print(f"{db}: no diagnoses yet", markup=False)
        for line in iter_text_lines(summary):
            console.print(line, markup=False)
    if html_out is not None:
        html_out.write_text(render_html(summary), encoding="utf-8")
    raise typer.Exit(EXIT_DAMAGE if summary["flagged"] else EXIT_OK)


@app.command()
def calibrate(
    logs: List[Path] = typer.Argument(..., help="One or more logs of HEALTHY flights of one airframe."),
    output: Path = typer.Option(..., "--output", "-o", help="Profile to write (JSON); the adapted model goes beside it (.onnx)."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing profile and model."),
    no_adapt: bool = typer.Option(False, "--no-adapt", help="Only measure the imbalance and statistics; keep the shipped model."),
    flights: Optional[int] = typer.Option(None, min=1, help="Airframes to simulate (those that fly like this one are adapted on); default: the calibration's own."),
    epochs: Optional[int] = typer.Option(None, min=1, help="At most this many training epochs (training stops earlier once it has converged); default: the calibration's own."),
    seed: int = typer.Option(0, help="Random seed (simulation and training)."),
    flight: Optional[int] = typer.Option(None, "--flight", help="Calibrate on this take-off to landing (1, 2, ...) of the one log given (a log holding several flights; `fdlog diagnose` lists them)."),
) -> None:
    """Calibrate one airframe from healthy flights: motor imbalance from hover, then adapt the model to it.

    Needs the training extra (torch): pip install 'flightlog-fd[train]'.
    """
    from .logs import collect_logs

    files, errors = collect_logs(logs)
    for e in errors:
        _fail(e)
    if errors or not files:
        if not files and not errors:
            _fail("no log files found")
        raise typer.Exit(EXIT_INVALID)
    if not no_adapt:
        try:
            import torch  # noqa: F401
            from flightlog_fd.training.adapt import AdaptSettings
        except ImportError:
            _fail("calibration adapts the model and needs torch: pip install 'flightlog-fd[train]' "
                  "(or use --no-adapt to measure the imbalance only)")
            raise typer.Exit(EXIT_INVALID)
    from .calibration import calibrate as run_calibration

    console = _console()
    err_console = _console(stderr=True)
    try:
        if no_adapt:
            profile = run_calibration(files, output=output, overwrite=force, flight=flight)
        else:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            with Progress(TextColumn("{task.description:<22}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                          TimeElapsedColumn(), console=err_console, transient=True) as bar:
                tasks: dict[str, int] = {}

                def progress(stage: str, frac: float) -> None:
                    if stage not in tasks:
                        tasks[stage] = bar.add_task(stage, total=1.0)
                    bar.update(tasks[stage], completed=min(1.0, frac))

                given = {"n_flights": flights, "max_epochs": epochs}
                settings = AdaptSettings(seed=seed, **{k: v for k, v in given.items() if v is not None})
                profile = run_calibration(files, adapt=True, output=output, overwrite=force, settings=settings,
                                          progress=progress, flight=flight)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    if profile.measures_motors:
        rho = ", ".join(f"{x:.3f}" for x in profile.rho_)
        console.print(f"wrote {output}: {profile.autopilot} {profile.frame}, rho = [{rho}], "
                      f"throttle {profile.hover_throttle_:.3f} from {profile.hover_s_:.0f} s of {profile.rho_source_} "
                      f"({profile.n_hover_segments_} segment(s))", markup=False)
    else:
        vib = profile.analyzers.get("vibration") or {}
        level = f", vibration {vib['level']:.2f} ({vib.get('source', '')})" if "level" in vib else ""
        console.print(f"wrote {output}: {profile.autopilot} {profile.frame}{level}", markup=False)
    if (profile.extra or {}).get("flight"):
        console.print(f"calibrated on {profile.extra['flight']} of {files[0]}", markup=False)
    for lack in profile.lacks_:
        console.print(f"note: {lack}", markup=False)
    if profile.model:
        ad = (profile.extra or {}).get("adaptation", {})
        console.print(f"adapted model: {output.with_suffix('.onnx')} ({ad.get('epochs', '?')} epochs, "
                      f"{ad.get('total_seconds', '?')} s)", markup=False)
    console.print(f"use it with: fdlog diagnose --profile {output} LOG", markup=False)


@app.command()
def serve(
    logs: Optional[List[Path]] = typer.Argument(None, help="Logs or folders to queue at start (e.g. sample_logs/)."),
    data: Path = typer.Option(Path("fdlog-data"), "--data", help="Data folder: uploaded logs (by content hash), reports, profiles, the default SQLite store."),
    db: Optional[str] = typer.Option(None, "--db", help="Store: a SQLite file (default DATA/fdlog.sqlite) or postgresql://USER@HOST:PORT/DB."),
    host: str = typer.Option("127.0.0.1", help="Address to listen on (loopback by default; use HTTPS in front of anything else)."),
    port: int = typer.Option(8000, min=1, max=65535, help="Port to listen on."),
    token_file: Optional[Path] = typer.Option(None, "--token-file", help="Accepted tokens, one per line (only their hashes are kept). Without it a random token is made and printed once."),
    view: str = typer.Option("open", "--view", help="open: anyone who reaches the port may look; token: pages need a token too."),
    max_upload_mb: float = typer.Option(256.0, "--max-upload-mb", min=0.001, help="Largest accepted log (MB); larger uploads get HTTP 413."),
    workers: int = typer.Option(1, "--workers", "-j", min=0, help="Logs diagnosed at once (worker processes; 0: only queue)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Run jobs on Dask: 'local' or tcp://HOST:8786 (workers must see --data)."),
    adapt: bool = typer.Option(False, "--adapt/--no-adapt", help="Calibration jobs also adapt the model (needs torch, minutes); default: measure only."),
) -> None:
    """Serve the fleet's web page: upload logs, background diagnosis, per-airframe history and drift, calibration.

    Pages at http://HOST:PORT/; API: POST /api/logs (multipart field 'log', Authorization: Bearer TOKEN), GET /api/logs/ID.
    """
    try:
        import fastapi  # noqa: F401
        import uvicorn
    except ImportError:
        _fail("fdlog serve needs the serve extra: pip install 'flightlog-fd[serve]'")
        raise typer.Exit(EXIT_INVALID)
    import secrets

    from .serve.app import ServeConfig, create_app, ingest_file
    from .serve.security import TokenSet

    if view not in ("open", "token"):
        _fail(f"--view must be open or token, got {view!r}")
        raise typer.Exit(EXIT_INVALID)
    err = _console(stderr=True)
    from .logs import collect_logs

    files, errors = collect_logs(list(logs or []))
    for e in errors:
        _fail(e)
    try:
        if token_file is not None:
            tokens = TokenSet.from_file(token_file)
        else:
            made = secrets.token_urlsafe(24)
            tokens = TokenSet([made])
        cfg = ServeConfig(data_dir=data, tokens=tokens, db=db, view=view, max_upload_bytes=int(max_upload_mb * 1024 * 1024),
                          workers=workers, scheduler=scheduler, calibrate_adapt=adapt)
        web = create_app(cfg)
        if token_file is None:
            err.print(f"fdlog serve: upload token (shown once, not stored; use --token-file to choose your own): {made}",
                      markup=False)
        for f in files:
            try:
                fid, created = ingest_file(web.state.store, web.state.data, f)
            except NotALogError as e:  # one line for it; the others are still served
                _fail(e)
                continue
            err.print(f"fdlog serve: {f} -> flight {fid}{'' if created else ' (already stored)'}", markup=False)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    if host not in ("127.0.0.1", "localhost", "::1"):
        err.print(f"fdlog serve: listening on {host}: tokens and logs travel in clear unless HTTPS is in front", markup=False)
    err.print(f"fdlog serve: http://{host}:{port}/  (data {data}, store {web.state.store.db.where})", markup=False)
    try:
        uvicorn.run(web, host=host, port=port, log_level="warning")
    except (OSError, SystemExit) as e:
        _fail(f"cannot serve on {host}:{port}: {e}")
        raise typer.Exit(EXIT_INVALID)


@app.command()
def simulate(
    out: Path = typer.Option(..., "--output", "-o", help="Output log file (or folder when --count > 1)."),
    fmt: str = typer.Option("ulog", "--format", "-f", help="ulog (PX4) or dataflash (ArduPilot)."),
    airframe: str = typer.Option("x500", help="Airframe preset (x500, f450, crazyflie, sih, heavy) or 'random'."),
    frame: Optional[str] = typer.Option(None, help="Fly the preset as quad_x, quad_plus, hexa_x, hexa_plus, octo_x, "
                                                   "octo_plus or octaquad_x."),
    motor: int = typer.Option(0, help="Damaged propeller 1..n (4 on a quad), or 0 for a healthy flight."),
    eta: float = typer.Option(0.8, help="Efficiency of the damaged propeller (thrust and torque factor)."),
    onset: Optional[float] = typer.Option(None, help="Damage starts this many seconds after arming (default: from take-off)."),
    duration: float = typer.Option(60.0, help="Planned flight time, seconds."),
    mission: str = typer.Option("waypoints", help="waypoints, manual (pilot sticks) or hover."),
    log_profile: Optional[str] = typer.Option(None, "--log-profile", help="px4_high, px4_default, ardupilot, ardupilot_fast."),
    rho: Optional[str] = typer.Option(None, help="Unbalance ratios rho1..rho4, comma-separated (e.g. 1,1.05,1,1)."),
    count: int = typer.Option(1, min=1, help="Number of flights (written into the --output folder)."),
    seed: int = typer.Option(0, help="Random seed: the same seed gives the same flight."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing files."),
    esc_rate: Optional[float] = typer.Option(None, "--esc-rate", help="Add ESC telemetry (rpm, current, voltage, "
                                             "temperature per motor) at this rate, 10-100 Hz, on a realistically "
                                             "unbalanced airframe."),
    vehicle_id: Optional[str] = typer.Option(None, "--vehicle-id", help="The vehicle id written into the log "
                                             "(default sim-SEED-i): give two flights of one simulated airframe the "
                                             "same id, as a real vehicle's logs have."),
    imbalance: Optional[list[str]] = typer.Option(None, "--imbalance", help="Propeller imbalance MOTOR:G_MM (mass "
                                                  "imbalance m·r in g·mm, e.g. 2:30) or MOTOR:aero=FRACTION (blade "
                                                  "thrust difference); repeatable. Adds a once-per-revolution "
                                                  "vibration and the logs' vibration metrics (VIBE, vehicle_imu_status)."),
    imu_rate: Optional[float] = typer.Option(None, "--imu-rate", help="Also log raw IMU samples at this rate (Hz, "
                                             "100-1000: ArduPilot ACC/GYR, PX4 sensor_accel/sensor_gyro)."),
) -> None:
    """Simulate multirotor flights (quad; hexa and octo as ULog), healthy or with a damaged propeller, and write them as ULog or DataFlash logs."""
    rho_list = None
    if rho:
        try:
            rho_list = [float(x) for x in rho.split(",")]
        except ValueError:
            rho_list = []
        if len(rho_list) < 3 or min(rho_list) <= 0:
            _fail(f"--rho must be one positive number per rotor (four on a quad), got {rho!r}")
            raise typer.Exit(EXIT_INVALID)
    from .sim.files import simulate_to_files

    try:
        written = simulate_to_files(out, count=count, fmt=fmt, airframe=airframe, frame=frame, motor=motor, eta=eta,
                                    onset=onset, duration=duration, mission=mission, log_profile=log_profile,
                                    rho=rho_list, seed=seed, force=force, esc_rate=esc_rate, vehicle_id=vehicle_id,
                                    imbalance=imbalance, imu_rate=imu_rate)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    except ValueError as e:
        _fail(str(e))
        raise typer.Exit(EXIT_INVALID)
    console = _console()
    for p, t in written:
        what = "healthy" if not t.get("motor") else f"propeller {t['motor']} damaged (eta {t['eta']:.2f})"
        added = (t.get("prop_imbalance") or {})
        unbalanced = [f"{k + 1}: {m * 1e6:g} g·mm" for k, m in enumerate(added.get("added_mass_kgm", [])) if m > 0]
        unbalanced += [f"{k + 1}: aero {a:g}" for k, a in enumerate(added.get("added_aero", [])) if a > 0]
        if unbalanced:
            what += "; propeller imbalance " + ", ".join(unbalanced)
        console.print(f"wrote {p}: {what}", markup=False)


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except FlightLogError as e:  # a command that forgot to catch: still one line, exit 2
        _fail(e)
        sys.exit(EXIT_INVALID)
    except KeyboardInterrupt:
        _fail("interrupted")
        sys.exit(130)


if __name__ == "__main__":
    main()
