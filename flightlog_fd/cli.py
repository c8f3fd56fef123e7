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


def collect_logs(paths: List[Path]) -> tuple[list[Path], list[str]]:
    """Expand folders into the log files they hold (by content, not extension).

    Returns (files, errors): a path that does not exist is an error; inside a folder, files that
    are not logs (READMEs, CSVs...) are skipped silently.
    """
    from .logs import sniff_format

    files: list[Path] = []
    errors: list[str] = []
    for p in paths:
        if p.is_dir():
            for f in sorted(x for x in p.rglob("*") if x.is_file()):
                try:
                    sniff_format(f)
                except NotALogError:
                    continue
                files.append(f)
            continue
        if not p.exists():
            errors.append(f"{p}: no such file")
            continue
        files.append(p)
    return files, errors


@app.command()
def info(
    logs: List[Path] = typer.Argument(..., help="Log files (.ulg / .bin) or folders of them."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON for machines instead of text."),
) -> None:
    """Describe logs: autopilot, vehicle, frame, streams and rates, airborne time, and whether they can be diagnosed."""
    from . import load_flight
    from .checks import describe_flight
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
