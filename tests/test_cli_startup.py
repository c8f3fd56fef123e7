"""`fdlog` starts without what it does not use (issue 29): nothing is timed here, the modules a
process loaded are counted (`sys.modules` of a fresh interpreter). The speed-ups must not change
what the user sees: help and parameter values are compared with typer's own.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"

#: Modules that cost 0.05-0.3 s CPU each to import and that `fdlog --help` never needs.
HEAVY = ("numpy", "scipy", "pandas", "onnxruntime", "plotly", "pydantic", "torch", "rich.traceback",
         "rich.markdown", "pygments", "matplotlib", "sklearn", "dask", "fastapi", "jinja2")
#: What no diagnosis or `info` needs, whatever the log.
NEVER_FOR_A_LOG = ("pandas", "plotly", "pydantic", "torch", "rich.traceback", "rich.markdown", "matplotlib",
                   "sklearn", "dask", "fastapi")

_RUN = """
import atexit, json, sys
atexit.register(lambda: sys.__stderr__.write("\\nMODULES " + json.dumps(sorted(sys.modules)) + "\\n"))
sys.argv = ["fdlog"] + sys.argv[1:]
from flightlog_fd.cli import main
main()
"""


def _modules_after(*args: str) -> tuple[set[str], subprocess.CompletedProcess]:
    env = {**os.environ, "COLUMNS": "100"}
    res = subprocess.run([sys.executable, "-c", _RUN, *args], capture_output=True, text=True, env=env, cwd=ROOT)
    line = [ln for ln in res.stderr.splitlines() if ln.startswith("MODULES ")][-1]
    return set(json.loads(line[len("MODULES "):])), res


def _loaded(modules: set[str], names) -> list[str]:
    return [m for m in names if m in modules]


def test_importing_the_cli_loads_nothing_heavy():
    code = "import sys, json, flightlog_fd.cli; print(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert _loaded(set(json.loads(out.stdout)), HEAVY) == []


@pytest.mark.parametrize("args", [(), ("--help",), ("info", "--help"), ("diagnose", "--help"),
                                  ("calibrate", "--help"), ("serve", "--help"), ("pull", "--help")])
def test_help_loads_nothing_heavy(args):
    modules, res = _modules_after(*args)
    assert "Usage" in res.stdout + res.stderr
    assert _loaded(modules, HEAVY) == []


@pytest.mark.parametrize("log", ["px4_healthy.ulg", "ardupilot_healthy.bin"])
def test_info_loads_only_the_reader(log):
    modules, res = _modules_after("info", str(SAMPLES / log))
    assert res.returncode == 0, res.stderr
    assert _loaded(modules, NEVER_FOR_A_LOG + ("onnxruntime", "scipy")) == []


@pytest.mark.parametrize("log", ["px4_healthy.ulg", "ardupilot_healthy.bin"])
def test_diagnose_loads_no_scipy_plotting_training_or_pydantic(log):
    modules, res = _modules_after("diagnose", str(SAMPLES / log))
    assert res.returncode == 0, res.stderr
    assert "onnxruntime" in modules  # the model ran
    assert _loaded(modules, NEVER_FOR_A_LOG + ("scipy",)) == []


_TYPER_HELP = """
import sys
import typer.rich_utils  # typer's help renderer imported whole, as typer itself does
import flightlog_fd.cli as cli
cli._use_plain_coercion = lambda params: None  # typer's own coercion
sys.argv = ["fdlog"] + sys.argv[1:]
cli.main()
"""


@pytest.mark.parametrize("args", [(), ("--help",), ("info", "--help"), ("diagnose", "--help"),
                                  ("history", "--help"), ("calibrate", "--help"), ("serve", "--help"),
                                  ("simulate", "--help"), ("diagnose", "--jobs", "0", "x"), ("diagnose", "--nope")])
def test_help_and_errors_are_typers_own(args):
    """The fast start prints byte for byte what typer prints (colours on)."""
    env = {**os.environ, "COLUMNS": "100", "FORCE_COLOR": "1"}
    fast = subprocess.run([sys.executable, "-c", _RUN, *args], capture_output=True, text=True, env=env, cwd=ROOT)
    plain = subprocess.run([sys.executable, "-c", _TYPER_HELP, *args], capture_output=True, text=True, env=env,
                           cwd=ROOT)
    strip = lambda s: s.split("\nMODULES ")[0]  # noqa: E731
    assert (fast.returncode, fast.stdout, strip(fast.stderr)) == (plain.returncode, plain.stdout, strip(plain.stderr))
    assert "\x1b[" in fast.stdout + fast.stderr  # the comparison saw the colours


def _typer_params():
    import typer.main

    from flightlog_fd.cli import app

    group = typer.main.get_command(app)
    for name, command in group.commands.items():
        for p in command.params:
            yield name, p


#: Values as a shell hands them over (and typed defaults), valid and not.
_SAMPLES = {
    int: ["0", "1", "2", "-3", "65535", "70000", "007", "+5", " 5", "1.5", "abc", "", 4, 0, True],
    float: ["0", "0.5", "1e-3", ".5", "5.", "-2.5E+2", "inf", "nan", "1_0", "abc", "", 3, 0.7, True],
    str: ["x", "", "tcp://h:8786", "1,1.05,1,1"],
    Path: ["a.ulg", "sample_logs", "", "-", Path("x.bin"), "/nonexistent/dir/f.json"],
}


def _app():
    from flightlog_fd.cli import app

    return app


def _coerce(param, value):
    """(result, type) or the error text of a coercion."""
    import typer

    try:
        ctx = typer.Context(typer.main.get_command(_app()))
        out = param.get_runtime_param()._coerce_value(value, param=param, ctx=ctx)
        return ("ok", out, type(out).__name__)
    except Exception as e:  # noqa: BLE001 - comparing the failure itself
        return ("error", type(e).__name__, str(e))


def test_plain_coercion_gives_typers_values_and_messages():
    from typing import get_args, get_origin

    from typer._coercion import build_runtime_param

    from flightlog_fd import cli

    checked = 0
    for name, p in _typer_params():
        ann = p.type_descriptor.annotation
        leaf = get_args(ann)[0] if get_origin(ann) is list else ann
        values = _SAMPLES.get(leaf)
        if values is None:
            continue
        if get_origin(ann) is list:
            values = [[v] for v in values if isinstance(v, str)] + [[values[0], values[1]]]
        for v in values:
            p._runtime_param = None
            typers = _coerce(p, v)
            p._runtime_param = None
            cli._use_plain_coercion([p])
            assert type(p._runtime_param).__name__ == "PlainRuntimeParam"
            ours = _coerce(p, v)
            assert repr(ours) == repr(typers), (name, p.name, v)  # repr: nan == nan
            checked += 1
        p._runtime_param = build_runtime_param(p.type_descriptor)
    assert checked > 200
