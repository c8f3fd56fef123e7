"""MkDocs hooks: the guide's reference pages come from the code, and its results pages from
``results/``, so nothing is written twice.

- ``reference/cli.md``: every command's ``fdlog CMD --help`` as the installed CLI prints it (run in
  a subprocess at a fixed width), under the command's first help line; ``tests/test_docs.py``
  checks the built page against ``fdlog --help`` run by the test itself.
- ``reference/json.md``: the JSON report's annotated layout (``flightlog_fd.report.json_report``'s
  docstring) and its JSON Schema's fields.
- ``reference/profile.md``: the calibration profile's docstring and keys (``flightlog_fd.profile``).
- ``results/``: every ``results/*.md`` with its images, and an index of them.

Needs the package importable (the docs build runs in the project's venv).
"""
from __future__ import annotations

import inspect
import json
import os
import re
import subprocess
import sys
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent
#: Terminal width the help texts are rendered at (the reference's code blocks).
HELP_COLUMNS = 100


def _fdlog() -> list[str]:
    exe = Path(sys.executable).with_name("fdlog")
    return [str(exe)] if exe.exists() else [sys.executable, "-c", "from flightlog_fd.cli import main; main()"]


def help_text(*command: str) -> str:
    """What ``fdlog COMMAND... --help`` prints, plain, at ``HELP_COLUMNS`` wide (each line's trailing
    blanks and the blank lines around it dropped, as a code block keeps it)."""
    env = dict(os.environ, COLUMNS=str(HELP_COLUMNS), NO_COLOR="1", TERM="dumb", _TYPER_FORCE_DISABLE_TERMINAL="1")
    out = subprocess.run([*_fdlog(), *command, "--help"], capture_output=True, text=True, env=env, check=True)
    return "\n".join(line.rstrip() for line in out.stdout.splitlines()).strip("\n") + "\n"


def commands() -> list[tuple[str, str]]:
    """(name, first help line) of every ``fdlog`` command, in the order ``fdlog --help`` lists them."""
    import typer

    from flightlog_fd.cli import app

    group = typer.main.get_command(app)
    out = []
    for name in group.list_commands(None):
        cmd = group.get_command(None, name)
        if cmd is None or cmd.hidden:
            continue
        first = (cmd.help or "").strip().split("\n\n")[0].replace("\n", " ")
        out.append((name, first))
    return out


def cli_reference() -> str:
    """The command-line reference page (markdown)."""
    parts = ["# Command line reference\n",
             "Generated from the code when the guide is built: each block is exactly what the "
             "command prints for `--help`.\n",
             "Exit codes, for every command that judges a log: **0** healthy, **1** damaged, a motor "
             "stopped or uncertain, **2** invalid input or not diagnosable.\n",
             "## fdlog\n", "```text\n" + help_text() + "```\n"]
    for name, first in commands():
        parts += [f"## fdlog {name}\n", f"{first}\n" if first else "", "```text\n" + help_text(name) + "```\n"]
    return "\n".join(parts)


def _code_block(doc: str) -> str:
    """The first ``.. code-block::`` of a reST docstring, dedented."""
    m = re.search(r"\.\. code-block:: \w+\n\n((?:    .*\n|\n)+)", doc)
    if not m:
        return ""
    return "\n".join(line[4:] for line in m.group(1).rstrip().split("\n"))


def _rst_to_md(text: str) -> str:
    """Docstring prose as markdown: ``x`` -> `x`, :func:`a.b` -> `a.b`."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


def _schema_rows(schema: dict, prefix: str = "", depth: int = 0) -> list[str]:
    rows = []
    req = set(schema.get("required", []))
    for key, sub in (schema.get("properties") or {}).items():
        if sub is schema:  # "flights": items are this schema again
            rows.append(f"| `{prefix}{key}` | array of this object | |")
            continue
        typ = sub.get("type", "const" if "const" in sub else ("enum" if "enum" in sub else "any"))
        typ = " or ".join(typ) if isinstance(typ, list) else typ
        if "enum" in sub:
            typ += ": " + ", ".join(f"`{v}`" for v in sub["enum"])
        if "const" in sub:
            typ = f"`{sub['const']}`"
        note = "; ".join(x for x in ("required" if key in req else "", sub.get("description", "")) if x)
        rows.append(f"| `{prefix}{key}` | {typ} | {note} |")
        if depth < 2 and isinstance(sub, dict):
            if sub.get("properties"):
                rows += _schema_rows(sub, f"{prefix}{key}.", depth + 1)
            items = sub.get("items")
            if isinstance(items, dict) and items.get("properties") and items is not schema:
                rows += _schema_rows(items, f"{prefix}{key}[].", depth + 1)
    return rows


def json_reference() -> str:
    """The JSON report reference page (markdown)."""
    from flightlog_fd.report import json_report as jr

    doc = inspect.getdoc(jr) or ""
    prose = doc.split(".. code-block::")[0].strip()
    after = doc.split("\n\n")
    tail = "\n\n".join(p for p in after if not p.startswith(("    ", ".. code-block")) and p.strip()
                       and p.strip() not in prose)
    return "\n".join([
        f"# JSON report (schema {jr.SCHEMA_VERSION})\n",
        "`fdlog diagnose --json` (and `fdlog pull --json`) print this; the store and the web page keep "
        "the same document. Generated from `flightlog_fd/report/json_report.py`.\n",
        _rst_to_md(prose) + "\n",
        "```text\n" + _code_block(doc) + "\n```\n",
        _rst_to_md(tail) + "\n",
        "## Fields and types (from the JSON Schema the tests validate every report against)\n",
        "| field | type | |", "|---|---|---|", *_schema_rows(jr.JSON_SCHEMA), "",
        "The whole JSON Schema (draft 2020-12):\n",
        "```json\n" + json.dumps(_printable(jr.JSON_SCHEMA), indent=1) + "\n```\n"])


def _printable(schema, seen=None):
    """The schema with its self-reference ("flights" items) written as a note."""
    seen = seen or set()
    if isinstance(schema, dict):
        if id(schema) in seen:
            return {"$ref": "#"}
        seen = seen | {id(schema)}
        return {k: _printable(v, seen) for k, v in schema.items()}
    if isinstance(schema, list):
        return [_printable(v, seen) for v in schema]
    return schema


def constant_comment(module, name: str) -> str:
    """The ``#:`` comment lines right above ``NAME =`` in ``module``'s source, joined."""
    lines = inspect.getsource(module).split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith(f"{name} =") or line.startswith(f"{name}:"))
    block = []
    for line in reversed(lines[:at]):
        if not line.startswith("#:"):
            break
        block.insert(0, line[2:].strip())
    return " ".join(block)


def profile_reference() -> str:
    """The calibration profile reference page (markdown)."""
    from flightlog_fd import profile as pr

    doc = inspect.getdoc(pr) or ""
    keys = [f"- `{k}` (required)" for k in pr._REQUIRED_KEYS] + [f"- `{k}`" for k in pr._OPTIONAL_KEYS]
    schema_note = _rst_to_md(constant_comment(pr, "PROFILE_SCHEMA"))
    return "\n".join([
        f"# Calibration profile (schema {pr.PROFILE_SCHEMA})\n",
        "What `fdlog calibrate` writes. Generated from `flightlog_fd/profile.py`.\n",
        _rst_to_md(doc) + "\n",
        f"Readable schemas: {', '.join(map(str, pr.READABLE_SCHEMAS))} (an older profile is read; "
        "`fdlog calibrate` writes the newest).\n", schema_note,
        "## Keys\n", *keys, ""])


def results_pages() -> dict[str, bytes]:
    """``results/<name>`` -> content: every results page and image, and an index page."""
    folder = ROOT / "results"
    out: dict[str, bytes] = {}
    rows = []
    for p in sorted(folder.iterdir()):
        if p.suffix.lower() in (".md", ".png", ".svg", ".jpg"):
            out[f"results/{p.name}"] = p.read_bytes()
        if p.suffix.lower() == ".md":
            first = next((line.lstrip("# ").strip() for line in p.read_text().splitlines() if line.startswith("#")),
                         p.stem)
            rows.append(f"- [{first}]({p.name})")
    out["results/index.md"] = "\n".join(
        ["# Measured results\n",
         "Every page here is a file in the repository's `results/` folder, written by the benchmark it names "
         "(`benchmarks/`), with the command that made it and the date it was measured.\n", *rows, ""]).encode()
    return out


def on_files(files, config):
    """Add the generated pages (mkdocs hook)."""
    generated = {"reference/cli.md": cli_reference(), "reference/json.md": json_reference(),
                 "reference/profile.md": profile_reference()}
    for uri, text in generated.items():
        files.append(File.generated(config, uri, content=text))
    card = ROOT / "models" / "MODEL_CARD.md"
    files.append(File.generated(config, "model-card.md", content=card.read_text()))
    for uri, data in results_pages().items():
        files.append(File.generated(config, uri, content=data))
    return files
