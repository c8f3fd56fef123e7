"""The pilot's guide (docs/, MkDocs) builds with warnings as errors, and its generated command-line
reference is exactly what `fdlog ... --help` prints."""
from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None,
                                reason="mkdocs is not installed (the [dev] extra installs it)")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                        "-d", str(out)], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, f"mkdocs build --strict failed:\n{r.stderr[-4000:]}"
    assert "WARNING" not in r.stderr, r.stderr
    return out


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _code_blocks(page: Path) -> list[str]:
    text = page.read_text()
    return [html.unescape(re.sub(r"<[^>]+>", "", m)) for m in re.findall(r"<pre[^>]*><code[^>]*>(.*?)</code></pre>", text, re.S)]


def _help(*cmd: str) -> str:
    env = dict(os.environ, COLUMNS="100", NO_COLOR="1", TERM="dumb", _TYPER_FORCE_DISABLE_TERMINAL="1")
    exe = Path(sys.executable).with_name("fdlog")
    out = subprocess.run([str(exe), *cmd, "--help"], capture_output=True, text=True, env=env, check=True).stdout
    return _plain(out)


def _plain(text: str) -> str:
    return "\n".join(line.rstrip() for line in text.splitlines()).strip("\n")


def test_cli_reference_matches_help(site):
    blocks = [_plain(b) for b in _code_blocks(site / "reference" / "cli" / "index.html")]
    names = [n for n, _ in _hooks().commands()]
    assert {"diagnose", "calibrate", "info", "history", "serve", "simulate"} <= set(names)
    for cmd in [(), *[(n,) for n in names]]:
        assert _help(*cmd) in blocks, f"fdlog {' '.join(cmd)} --help is not in the guide's CLI reference"


def test_json_reference_names_every_field(site):
    from flightlog_fd.report.json_report import JSON_SCHEMA, SCHEMA_VERSION

    page = (site / "reference" / "json" / "index.html").read_text()
    assert f"schema {SCHEMA_VERSION}" in page
    for key in JSON_SCHEMA["properties"]:
        assert f"<code>{key}</code>" in page, key


def test_guide_pages_and_results(site):
    for page in ("index.html", "verdicts/index.html", "calibrate/index.html", "logging/index.html",
                 "pull-and-watch/index.html", "fleet/index.html", "method/index.html", "results/index.html",
                 "model-card/index.html"):
        assert (site / page).exists(), page
    for md in (ROOT / "results").glob("*.md"):
        assert (site / "results" / md.stem / "index.html").exists(), md.name
