"""`fdlog`: the command line. Thin: parse arguments, call the library, print.

Every command catches :class:`~flightlog_fd.errors.FlightLogError` and prints one line
``fdlog: <file>: <problem>`` with exit code 2, never a traceback. Heavy imports (torch, the
simulator) happen inside the commands that need them, so `fdlog diagnose` runs without torch.
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from typer.core import TyperGroup

from .errors import FlightLogError, NotALogError

#: typer.rich_utils imports these at its top but uses them only for markdown help text and
#: pretty tracebacks, neither of which fdlog uses; with pygments and markdown_it they were 0.05 s
#: of the 0.17 s CPU of `fdlog --help` (python -X importtime and process CPU, 2026-11-26).
_TYPER_HELP_UNUSED = (("rich.markdown", "Markdown"), ("rich.traceback", "Traceback"))
#: The command-line values typer would hand to pydantic that Python's own int()/float() read to
#: the same number (pydantic is 0.1 s CPU of every command's start); anything else goes to typer.
_PLAIN_INT = re.compile(r"-?(0|[1-9][0-9]*)")
_PLAIN_FLOAT = re.compile(r"-?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?")
_NOT_PLAIN = object()


def _deferred_class(module: str, name: str) -> type:
    """A stand-in for class ``module.name`` that imports the real module when it is called or
    an attribute of it is read, and returns the real class's objects."""
    import importlib

    def real():
        return getattr(importlib.import_module(module), name)

    class _Deferred(type):
        def __getattr__(cls, attr):
            return getattr(real(), attr)

    return _Deferred(name, (), {"__new__": lambda cls, *a, **k: real()(*a, **k)})


def _import_typer_help() -> None:
    """Import typer's help renderer (typer.rich_utils) without the modules it does not use for
    fdlog's help (:data:`_TYPER_HELP_UNUSED`): while it imports, those are stand-in modules whose
    classes load the real ones on first use; they leave ``sys.modules`` right after, so a later
    ``import rich.traceback`` gets the real module. A typer that needs more from them is imported
    whole."""
    import types

    if "typer.rich_utils" in sys.modules:
        return
    placed = {}
    for module, name in _TYPER_HELP_UNUSED:
        if module not in sys.modules:
            stand_in = types.ModuleType(module)
            setattr(stand_in, name, _deferred_class(module, name))
            sys.modules[module] = placed[module] = stand_in
    try:
        import typer.rich_utils  # noqa: F401
    except ImportError:
        sys.modules.pop("typer.rich_utils", None)
    finally:
        for module, stand_in in placed.items():
            if sys.modules.get(module) is stand_in:
                del sys.modules[module]
    import typer.rich_utils  # noqa: F401,F811  (a no-op unless the import above failed)


def _plain_value(annotation, info, value, param, ctx):
    """``value`` coerced as typer would for the plain types fdlog's options use (str, int, float,
    Path, lists of them), or :data:`_NOT_PLAIN` for anything else (typer then does it, with its
    own messages)."""
    if getattr(annotation, "__origin__", None) is list and isinstance(value, (list, tuple)):
        (item,) = annotation.__args__
        out = [_plain_value(item, info, v, param, ctx) for v in value]
        return _NOT_PLAIN if any(v is _NOT_PLAIN for v in out) else out
    if info.parser is not None or getattr(info, "clamp", False):
        return _NOT_PLAIN
    if annotation in (str, bool):
        return value if type(value) is annotation else _NOT_PLAIN
    if annotation is Path and info.path_type is None:
        if not isinstance(value, (str, Path)) or value == "":
            return _NOT_PLAIN
        from typer._param_types import coerce_cli_path

        return coerce_cli_path(Path(value), info, path_type=Path, param=param, ctx=ctx)
    if annotation in (int, float):
        if isinstance(value, str):
            if not (_PLAIN_INT if annotation is int else _PLAIN_FLOAT).fullmatch(value):
                return _NOT_PLAIN
            number = annotation(value)
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and (annotation is float or isinstance(value, int)):
            number = annotation(value)
        else:
            return _NOT_PLAIN
        if (info.min is not None and number < info.min) or (info.max is not None and number > info.max):
            return _NOT_PLAIN  # out of range: typer says so
        return number
    return _NOT_PLAIN


def _use_plain_coercion(params) -> None:
    """Give each of a command's ``params`` a coercion that reads plain values without importing
    pydantic (typer >= 0.2x builds a pydantic TypeAdapter for every parameter of the command that
    runs); any other value is passed to typer's own coercion, so results and messages are
    typer's. Does nothing on a typer without this machinery."""
    try:
        from dataclasses import dataclass

        from typer._coercion import RuntimeParam, build_runtime_param
    except ImportError:  # pragma: no cover - another typer
        return

    @dataclass(frozen=True)
    class PlainRuntimeParam(RuntimeParam):
        descriptor: object = None

        def _coerce_value(self, value, param, ctx):
            out = _plain_value(self.annotation, self.parameter_info, value, param, ctx)
            if out is _NOT_PLAIN:
                out = build_runtime_param(self.descriptor)._coerce_value(value, param=param, ctx=ctx)
            return out

    for p in params:
        descriptor = getattr(p, "type_descriptor", None)
        if descriptor is not None and getattr(p, "_runtime_param", 0) is None and descriptor.file_annotation is None:
            p._runtime_param = PlainRuntimeParam(parameter_info=descriptor.parameter_info,
                                                 annotation=descriptor.annotation, descriptor=descriptor)


class _FdlogGroup(TyperGroup):
    """typer's group, starting faster: help without typer's unused imports, commands without
    pydantic (see :func:`_import_typer_help`, :func:`_use_plain_coercion`)."""

    def parse_args(self, ctx, args):
        if not args or set(args) & set(ctx.help_option_names):
            _import_typer_help()
        _use_plain_coercion(self.get_params(ctx))
        return super().parse_args(ctx, args)

    def resolve_command(self, ctx, args):
        name, command, rest = super().resolve_command(ctx, args)
        if command is not None:
            _use_plain_coercion(command.get_params(ctx))
        return name, command, rest


app = typer.Typer(
    cls=_FdlogGroup,
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
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Run the batch on Dask: 'local' (a LocalCluster here) or a scheduler address tcp://HOST:8786 (needs flightlog-fd\\[fleet])."),
    db: Optional[str] = typer.Option(None, "--db", help="Write every diagnosis to this store: a SQLite file or a postgresql:// URL (see `fdlog history`, `fdlog serve --db`)."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing --csv / --html files."),
    prior_damage: Optional[float] = typer.Option(None, "--prior-damage", min=0.001, max=0.999, help="Your fleet's probability that a diagnosed flight has a rotor that lost thrust, before its log is read (default: the profile's, else 0.10); every verdict and confidence is decided under it."),
) -> None:
    """Diagnose logs: per-window timeline, flight verdict (healthy / rotor k lost thrust / uncertain) and reports.

    Exit code: 0 every log healthy, 1 damage found or uncertain, 2 invalid input or not diagnosable.
    """
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
    raise typer.Exit(_diagnose_files(files, bool(errors), profile=profile, model=model, as_json=as_json,
                                     csv_out=csv_out, html_out=html_out, windows=windows, jobs=jobs,
                                     scheduler=scheduler, db=db, prior=prior_damage))


def _diagnose_files(files: list, had_errors: bool, *, profile: Optional[Path], model: Optional[Path] = None,
                    as_json: bool = False, csv_out: Optional[Path] = None, html_out: Optional[Path] = None,
                    windows: bool = False, jobs: Optional[int] = None, scheduler: Optional[str] = None,
                    db: Optional[str] = None, prior: Optional[float] = None) -> int:
    """Diagnose ``files`` and print / write the reports: `fdlog diagnose`'s work after it found the
    logs, shared with `fdlog pull`. Returns the exit code (``had_errors``: some input already failed)."""
    from .batch import run_batch
    from .diagnose import resolve_model
    from .profile import Profile
    from .report import terminal

    try:
        prof = Profile.load(profile) if profile is not None else None
        fault_model = resolve_model(model, prof)
    except FlightLogError as e:
        _fail(e)
        return EXIT_INVALID

    if scheduler is not None:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            _fail("--scheduler needs Dask: pip install 'flightlog-fd[fleet]'")
            return EXIT_INVALID
    store = run_info = None
    if db is not None:
        from .store import RunInfo, Store

        try:
            store = Store(db)
        except FlightLogError as e:
            _fail(e)
            return EXIT_INVALID
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
            batch = run_batch(files, fault_model, prof, jobs=jobs, scheduler=scheduler, keep_flight=keep, prior=prior,
                              on_result=on_result)
        except FlightLogError as e:
            _fail(e)
            return EXIT_INVALID
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
        for d in results:  # several logs: the confidence legend once, under their summary
            terminal.render(d, console, show_windows=windows, with_legend=len(results) == 1)
            console.print()
        if len(results) > 1:
            console.print(terminal.summary_table(results))
            console.print(terminal.legend())
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
    return EXIT_INVALID if had_errors or store_errors or EXIT_INVALID in codes else max(codes)



@app.command()
def pull(
    connection: Optional[str] = typer.Argument(None, help="The autopilot's link as mavutil spells it: udp:HOST:PORT (listen), udpin:, udpout:, tcp:HOST:PORT, tcpin:, or a serial DEVICE[,BAUD]. Default: the one autopilot plugged in over USB."),
    output: Path = typer.Option(Path("fdlog-logs"), "--output", "-o", help="Folder for pulled logs: one subfolder per vehicle (autopilot and board id)."),
    log_id: Optional[int] = typer.Option(None, "--id", min=0, help="Pull this log (its id in --list) instead of the newest."),
    since: Optional[str] = typer.Option(None, "--since", metavar="LAST", help="'last': pull every log not yet pulled from this vehicle into --output."),
    all_logs: bool = typer.Option(False, "--all", help="Pull every log on the vehicle (those already here are not downloaded again)."),
    list_only: bool = typer.Option(False, "--list", help="Only list the logs on the vehicle (id, size, time) and exit."),
    no_diagnose: bool = typer.Option(False, "--no-diagnose", help="Only download; do not diagnose."),
    profile: Optional[Path] = typer.Option(None, "--profile", "-p", help="Calibration profile from `fdlog calibrate`, as in `fdlog diagnose`."),
    db: Optional[str] = typer.Option(None, "--db", help="Also write the diagnoses to this store (SQLite file or postgresql:// URL), as in `fdlog diagnose`."),
    as_json: bool = typer.Option(False, "--json", help="Print the diagnosis as `fdlog diagnose --json` does (pull messages go to stderr)."),
    windows: bool = typer.Option(False, "--windows", help="Also print the table of windows."),
    erase: bool = typer.Option(False, "--erase", help="After pulling with --all or --since last, erase every log on the vehicle (asks to confirm; only when each one is in --output)."),
    timeout: float = typer.Option(10.0, "--timeout", min=0.5, help="Seconds without data from the vehicle before giving up (a lost link)."),
) -> None:
    """Pull logs from the aircraft over MAVLink (PX4 or ArduPilot), then diagnose them.

    Downloads the newest log (or --id N, --since last, --all) with the MAVLink log protocol into OUTPUT/<vehicle>/, skipping logs pulled before, and prints the same verdict as `fdlog diagnose`. A partial download never stays behind. Logs on the vehicle are never erased without --erase and a confirmation.

    Exit code: as `fdlog diagnose` (0 healthy, 1 damage found or uncertain), 2 when the link fails or nothing could be pulled or diagnosed.
    """
    from .errors import VehicleLinkError
    from .vehicle.link import CONNECT_TIMEOUT_S, VehicleLink
    from .vehicle.ports import parse_connection
    from .vehicle.pull import erase_all, pull_logs

    chosen = [name for name, on in (("--id", log_id is not None), ("--since", since is not None),
                                    ("--all", all_logs)) if on]
    if len(chosen) > 1:
        _fail(f"{' and '.join(chosen)} cannot be combined: choose one")
        raise typer.Exit(EXIT_INVALID)
    if since is not None and since.strip().lower() != "last":
        _fail(f"--since takes 'last' (the logs not yet pulled from this vehicle), got {since!r}")
        raise typer.Exit(EXIT_INVALID)
    if erase and not (all_logs or since is not None):
        _fail("--erase needs --all or --since last, so that every log on the vehicle is pulled before it is erased")
        raise typer.Exit(EXIT_INVALID)
    mode = "id" if log_id is not None else "since_last" if since is not None else "all" if all_logs else "newest"
    err = _console(stderr=True)
    try:
        conn = parse_connection(connection)
        with VehicleLink(conn, connect_timeout=min(CONNECT_TIMEOUT_S, timeout)) as link:
            err.print(f"vehicle: {link.describe()}", markup=False)
            if list_only:
                from .vehicle.transfer import list_logs

                entries = list_logs(link)
                link.send_log_request_end()
                _print_log_list(entries)
                raise typer.Exit(EXIT_OK)
            with _download_bar(err) as bar:
                def on_start(entry):
                    task = bar.add_task(f"log {entry.id}", total=entry.size)
                    return lambda done, total: bar.update(task, completed=done)

                def on_log(p):
                    what = "pulled" if p.downloaded else "already pulled"
                    figures = (f" ({_size(p.entry.size)} in {p.stats.seconds:.1f} s, {_size(p.stats.rate)}/s, "
                               f"{p.stats.re_requests} re-requests)" if p.stats else "")
                    bar.console.print(f"{what} log {p.entry.id}: {p.path}{figures}", markup=False)

                report = pull_logs(link, output, mode=mode, log_id=log_id, stall_timeout=timeout,
                                   on_start=on_start, on_log=on_log)
            for e in report.empty:
                err.print(f"log {e.id} is empty on the vehicle (0 bytes): skipped", markup=False)
            if not report.entries:
                err.print("no logs on the vehicle", markup=False)
            elif mode == "since_last" and not report.downloaded:
                err.print(f"no new logs: all {len(report.entries)} on the vehicle are in {report.folder}", markup=False)
            if erase:
                if not report.every_log_here:
                    _fail("not erasing: not every log on the vehicle is pulled")
                    raise typer.Exit(EXIT_INVALID)
                if typer.confirm(f"Erase all {len(report.entries)} logs on the vehicle? Each one is in "
                                 f"{report.folder}", default=False, err=True):
                    erase_all(link)
                    err.print("erased every log on the vehicle", markup=False)
                else:
                    err.print("not erased", markup=False)
    except VehicleLinkError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    files = [p.path for p in report.logs]
    if no_diagnose:
        raise typer.Exit(EXIT_OK)
    if not files:
        raise typer.Exit(EXIT_OK if mode == "since_last" and report.entries else EXIT_INVALID)
    raise typer.Exit(_diagnose_files(files, False, profile=profile, as_json=as_json, windows=windows, db=db))


def _size(n: float) -> str:
    """Bytes as B / kB / MB (decimal units, as transfer rates are quoted)."""
    for unit, scale in (("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n:.0f} B"


def _download_bar(console: Console):
    """A rich progress bar per download on stderr: bytes, rate, time left (only on a terminal)."""
    from rich.progress import (BarColumn, DownloadColumn, Progress, TextColumn, TimeRemainingColumn,
                               TransferSpeedColumn)

    return Progress(TextColumn("{task.description}"), BarColumn(), DownloadColumn(), TransferSpeedColumn(),
                    TimeRemainingColumn(), console=console, transient=True, disable=not console.is_terminal)


def _print_log_list(entries) -> None:
    from .vehicle.folder import stamp

    console = _console()
    if not entries:
        console.print("no logs on the vehicle", markup=False)
    for e in entries:
        when = stamp(e).replace("_", " ", 1) if stamp(e) != "nodate" else "no date"
        console.print(f"{e.id:>5}  {_size(e.size):>10}  {when}", markup=False)


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
    logs: List[Path] = typer.Argument(..., help="One or more logs of HEALTHY flights of one airframe (each log is one calibration session)."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Profile to write (JSON); the adapted model goes beside it (.onnx)."),
    add: Optional[Path] = typer.Option(None, "--add", help="Add the logs as new sessions to this existing profile (in place; the previous file is kept beside it)."),
    one_session: bool = typer.Option(False, "--one-session", help="The logs given are one calibration session (e.g. several short flights on one battery)."),
    name: Optional[str] = typer.Option(None, "--name", help="With --add: the logs are a load configuration of this name (e.g. camera), a new one or more sessions of it; default: a flight carrying another load becomes a configuration named by its load."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing profile and model."),
    prior_damage: Optional[float] = typer.Option(None, "--prior-damage", min=0.001, max=0.999, help="Store your fleet's prior of damage (P(a rotor lost thrust) per diagnosed flight) in the profile: diagnoses with it decide under it."),
    no_adapt: bool = typer.Option(False, "--no-adapt", help="Only measure the imbalance and statistics; keep the shipped model."),
    flights: Optional[int] = typer.Option(None, min=1, help="Airframes to simulate (those that fly like this one are adapted on); default: the calibration's own."),
    epochs: Optional[int] = typer.Option(None, min=1, help="At most this many training epochs (training stops earlier once it has converged); default: the calibration's own."),
    seed: int = typer.Option(0, help="Random seed (simulation and training)."),
    flight: Optional[int] = typer.Option(None, "--flight", help="Calibrate on this take-off to landing (1, 2, ...) of the one log given (a log holding several flights; `fdlog diagnose` lists them)."),
) -> None:
    """Calibrate one airframe from healthy flights: motor imbalance from hover, then adapt the model to it.

    Each log is one calibration session; from the second session on, the diagnosis weighs the
    commands against the airframe's own session-to-session drift. `--add PROFILE LOG` adds a
    healthy flight of another day or battery to an existing profile (no torch needed); a session
    that looks damaged against the others is refused. A healthy flight carrying another payload
    becomes a load configuration of the profile (`--name camera` names it); diagnose compares each
    flight with the nearest configuration. Adapting needs the training extra (torch):
    pip install 'flightlog-fd\\[train]'.
    """
    from .logs import collect_logs

    files, errors = collect_logs(logs)
    for e in errors:
        _fail(e)
    if errors or not files:
        if not files and not errors:
            _fail("no log files found")
        raise typer.Exit(EXIT_INVALID)
    if add is not None:
        if output is not None or flight is not None:
            _fail("--add updates the profile in place: give no --output or --flight with it")
            raise typer.Exit(EXIT_INVALID)
        _add_sessions(add, files, one_session, name)
        return
    if name is not None:
        _fail("--name names a load configuration added with --add PROFILE.json; the first calibration is 'as calibrated'")
        raise typer.Exit(EXIT_INVALID)
    if output is None:
        _fail("give the profile to write (--output PROFILE.json), or --add PROFILE.json to add sessions to one")
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
            profile = run_calibration(files, output=output, overwrite=force, flight=flight, one_session=one_session)
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
                                          progress=progress, flight=flight, one_session=one_session)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    if prior_damage is not None:
        profile.prior_damage = float(prior_damage)
        profile.save(output, overwrite=True)
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
    if profile.measures_motors:
        from .calibration import session_drift_words

        console.print(f"{profile.n_sessions} calibration session{'s' if profile.n_sessions != 1 else ''}: "
                      f"{session_drift_words(profile.sessions_)}", markup=False)
    for lack in profile.lacks_:
        console.print(f"note: {lack}", markup=False)
    if profile.model:
        ad = (profile.extra or {}).get("adaptation", {})
        console.print(f"adapted model: {output.with_suffix('.onnx')} ({ad.get('epochs', '?')} epochs, "
                      f"{ad.get('total_seconds', '?')} s)", markup=False)
    console.print(f"use it with: fdlog diagnose --profile {output} LOG", markup=False)


def _add_sessions(profile: Path, files: list, one_session: bool, name: Optional[str] = None) -> None:
    """`fdlog calibrate --add`: add the logs as sessions or load configurations, print what changed
    (exit 2 on refusal)."""
    from .calibration import add_sessions

    try:
        res = add_sessions(profile, files, one_session=one_session, name=name)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    console = _console()
    console.print(f"updated {res.path}:", markup=False)
    for line in res.changes:
        console.print(f"  {line}", markup=False)


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
    watch: Optional[List[Path]] = typer.Option(None, "--watch", help="Also queue every log that appears in this folder (repeatable), once each, as `fdlog watch` does."),
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
                          workers=workers, scheduler=scheduler, calibrate_adapt=adapt, watch=list(watch or []))
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
def watch(
    folders: List[Path] = typer.Argument(..., help="Folders to watch, with their subfolders: a ground station's download folder, a fleet share."),
    db: str = typer.Option(..., "--db", help="The store to write: a SQLite file or a postgresql:// URL (the one `fdlog history` and `fdlog serve --db` read)."),
    profile: Optional[Path] = typer.Option(None, "--profile", "-p", help="Calibration profile from `fdlog calibrate` (its adapted model is used)."),
    model: Optional[Path] = typer.Option(None, "--model", "-m", help="ONNX model to use instead of the profile's or the shipped one."),
    settle: Optional[float] = typer.Option(None, "--settle", min=0.05, help="Seconds a file must stay unchanged before it is read (default 5): longer than the longest pause of whatever writes the folder."),
    poll: Optional[float] = typer.Option(None, "--poll", min=0.05, help="Look every this many seconds instead of using filesystem events (network shares are always polled, every 2 s by default)."),
    once: bool = typer.Option(False, "--once", help="Diagnose what is in the folders now, then exit (exit code as `fdlog diagnose`)."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Also list the files already in the store."),
) -> None:
    """Diagnose every log that appears in folders, once each (by content), into the store; runs until Ctrl-C.

    A file is read once its size stops changing; a log copied twice, renamed or found again after a
    restart is one flight; a bad file is one row saying why, and the watch goes on.
    """
    import signal

    from .diagnose import resolve_model
    from .profile import Profile
    from .store import Store
    from .watch import SETTLE_S, DiagnoseSink, FolderWatch

    err = _console(stderr=True)
    out = _console()
    try:
        prof = Profile.load(profile) if profile is not None else None
        fault_model = resolve_model(model, prof)
        store = Store(db)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)

    def report(kind: str, path: str, text: str) -> None:
        if kind == "known" and not verbose:
            return
        line = f"{path}: {text}" if path else text
        if kind in ("bad", "skip"):
            _fail(line)
        elif kind in ("info", "waiting", "busy", "known"):
            err.print(f"fdlog watch: {line}", markup=False)
        else:
            out.print(line, markup=False)

    sink = watcher = None
    try:
        sink = DiagnoseSink(store, fault_model, prof)
        watcher = FolderWatch(folders, store, sink, settle_s=settle if settle is not None else SETTLE_S,
                              poll_s=poll, report=report)
        sink.stop = watcher.stopping
        signal.signal(signal.SIGTERM, lambda *_: watcher.stop())
        watcher.run(once=once)
    except KeyboardInterrupt:
        pass
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    finally:
        if watcher is not None:
            watcher.stop()
        if sink is not None:
            sink.close()
        store.close()
    if watcher is not None:
        c = watcher.counts
        err.print(f"fdlog watch: {c['diagnosed']} diagnosed, {c['bad']} not diagnosable, {c['known']} already in the store",
                  markup=False)
    codes = sink.exit_codes if sink is not None else []
    raise typer.Exit(max(codes) if once and codes else EXIT_OK)


@app.command()
def simulate(
    out: Path = typer.Option(..., "--output", "-o", help="Output log file (or folder when --count > 1)."),
    fmt: str = typer.Option("ulog", "--format", "-f", help="ulog (PX4) or dataflash (ArduPilot)."),
    airframe: str = typer.Option("x500", help="Airframe preset (x500, f450, crazyflie, sih, heavy) or 'random'."),
    frame: Optional[str] = typer.Option(None, help="Fly the preset as quad_x, quad_plus, hexa_x, hexa_plus, octo_x, "
                                                   "octo_plus or octaquad_x."),
    motor: Optional[list[int]] = typer.Option(None, help="Damaged propeller 1..n (4 on a quad), or 0 for a healthy "
                                              "flight (the default); repeat for two: --motor 1 --motor 4."),
    eta: Optional[list[float]] = typer.Option(None, help="Efficiency of the damaged propeller (thrust and torque "
                                              "factor), or of the weak motor with --cause motor (thrust per command), "
                                              "default 0.8; one value for all, or one per --motor."),
    cause: str = typer.Option("propeller", help="What lost the thrust of --motor: propeller (damaged) or motor (the "
                                                "motor or its ESC is weak: it turns slower for its command)."),
    onset: Optional[list[float]] = typer.Option(None, help="Damage starts this many seconds after arming (default "
                                                "or 0: from take-off); one value for all, or one per --motor."),
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
    esc_curve: Optional[float] = typer.Option(None, "--esc-curve", help="With --esc-rate: the rotors turn as "
                                              "command^(B/2) (default 1: the autopilot's thrust model fits them; "
                                              "ArduCopter SITL measures 1.33, PX4 THR_MDL_FAC 0 about 2)."),
    vehicle_id: Optional[str] = typer.Option(None, "--vehicle-id", help="The vehicle id written into the log "
                                             "(default sim-SEED-i): give two flights of one simulated airframe the "
                                             "same id, as a real vehicle's logs have."),
    imbalance: Optional[list[str]] = typer.Option(None, "--imbalance", help="Propeller imbalance MOTOR:G_MM (mass "
                                                  "imbalance m·r in g·mm, e.g. 2:30) or MOTOR:aero=FRACTION (blade "
                                                  "thrust difference); repeatable. Adds a once-per-revolution "
                                                  "vibration and the logs' vibration metrics (VIBE, vehicle_imu_status)."),
    imu_rate: Optional[float] = typer.Option(None, "--imu-rate", help="Also log raw IMU samples at this rate (Hz, "
                                             "100-1000: ArduPilot ACC/GYR, PX4 sensor_accel/sensor_gyro)."),
    load: Optional[list[str]] = typer.Option(None, "--load", help="A load the aircraft carries (the autopilot is not "
                                             "told); repeatable. point:MASS@X,Y[,Z] a mass fixed on the frame (metres, "
                                             "x forward, y right, z down), point:MASS@motorK[,F] on the way to rotor K "
                                             "(F of the arm, default 1), line:MASS@WHERE:LENGTH_M a payload swinging on "
                                             "a line, battery:DX[,DY[,DZ]][@MASS] the battery moved; MASS in kg or as "
                                             "a percentage of the take-off mass (15%)."),
) -> None:
    """Simulate multirotor flights (quad; hexa and octo as ULog), healthy, with one or two damaged propellers or with a weak motor (--cause motor), carrying loads (--load), and write them as ULog or DataFlash logs."""
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
        written = simulate_to_files(out, count=count, fmt=fmt, airframe=airframe, frame=frame, motor=motor or 0,
                                    eta=eta or 0.8, onset=onset or None, duration=duration, mission=mission, log_profile=log_profile,
                                    rho=rho_list, seed=seed, force=force, esc_rate=esc_rate, vehicle_id=vehicle_id,
                                    imbalance=imbalance, imu_rate=imu_rate, cause=cause, loads=load,
                                    esc_curve=esc_curve)
    except FlightLogError as e:
        _fail(e)
        raise typer.Exit(EXIT_INVALID)
    except ValueError as e:
        _fail(str(e))
        raise typer.Exit(EXIT_INVALID)
    console = _console()
    for p, t in written:
        motors, etas = t.get("motors") or ([t["motor"]] if t.get("motor") else []), t.get("etas") or [t.get("eta")]
        part = "motor" if t.get("cause") == "motor" else "propeller"
        if not motors:
            what = "healthy"
        elif len(motors) == 1:
            what = (f"motor {motors[0]} or its ESC weak (eta {etas[0]:.2f})" if part == "motor"
                    else f"propeller {motors[0]} damaged (eta {etas[0]:.2f})")
        else:
            what = (f"{part}s {', '.join(map(str, motors[:-1]))} and {motors[-1]} "
                    f"{'weak' if part == 'motor' else 'damaged'} (eta {', '.join(f'{e:.2f}' for e in etas)})")
        added = (t.get("prop_imbalance") or {})
        unbalanced = [f"{k + 1}: {m * 1e6:g} g·mm" for k, m in enumerate(added.get("added_mass_kgm", [])) if m > 0]
        unbalanced += [f"{k + 1}: aero {a:g}" for k, a in enumerate(added.get("added_aero", [])) if a > 0]
        if unbalanced:
            what += "; propeller imbalance " + ", ".join(unbalanced)
        if t.get("loads"):
            from .sim.files import load_text

            what += "; carrying " + ", ".join(load_text(x) for x in t["loads"])
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
