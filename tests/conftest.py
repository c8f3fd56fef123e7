"""Shared test fixtures. Tests that read ../shared skip cleanly when it is absent."""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"


def shared_path(*parts: str) -> Path:
    """Path inside ../shared; skips the calling test when it does not exist."""
    p = SHARED.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"../shared not available ({p})")
    return p


@pytest.fixture
def shared():
    """Callable fixture: ``shared('real_logs', 'px4', 'sample.ulg')``."""
    return shared_path


@pytest.fixture(scope="module")
def postgres():
    """A throw-away PostgreSQL server for one test module (serve_helpers.Postgres); skips without
    psycopg or a server binary."""
    pytest.importorskip("psycopg")
    from serve_helpers import Postgres

    try:
        pg = Postgres()
    except (FileNotFoundError, RuntimeError) as e:
        pytest.skip(f"no PostgreSQL server: {e}")
    yield pg
    pg.stop()


@pytest.fixture
def runlog(tmp_path, monkeypatch):
    """A file every counting diagnosis appends its log to (serve_helpers.counting_diagnose), for
    checking that each log was diagnosed once; the variable is inherited by spawned workers."""
    from serve_helpers import RUNLOG_ENV

    p = tmp_path / "runs.txt"
    p.write_text("")
    monkeypatch.setenv(RUNLOG_ENV, str(p))
    return p


@pytest.fixture(scope="module")
def every_output(tmp_path_factory):
    """output_checks.OutputRun, one per test file: ``every_output.check(path)`` diagnoses the log
    once and returns the problems of every output drawn from that result (terminal, JSON, CSV,
    HTML, the store and the flight page); ``history_problems(logs)`` those of `fdlog history` and
    the fleet pages over the stores they filled."""
    from output_checks import OutputRun

    run = OutputRun(tmp_path_factory.mktemp("every_output"))
    yield run
    run.close()
