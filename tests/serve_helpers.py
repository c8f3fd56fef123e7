"""Helpers of the `fdlog serve` tests: a server in this process, a PostgreSQL server started from the
system's packages, and diagnose functions the job runner's worker processes import by name
(spawned workers import this module: keep it importable, without pytest state)."""
from __future__ import annotations

import contextlib
import glob
import os
import pwd
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
import uuid
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_logs"
TOKEN = "test-token-0123456789abcdef"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
#: Env var naming a file where counting_diagnose appends one line per diagnosis it runs.
RUNLOG_ENV = "FDLOG_TEST_RUNLOG"


# ----------------------------------------------------------------------------- in worker processes

def counting_diagnose(log_path, sha256, name, reports_dir, profiles):
    """The real diagnose task, plus one line ``sha256`` per run in $FDLOG_TEST_RUNLOG."""
    from flightlog_fd.serve.worker import diagnose_task

    out = diagnose_task(log_path, sha256, name, reports_dir, profiles)
    with open(os.environ[RUNLOG_ENV], "a") as fh:
        fh.write(sha256 + "\n")
    return out


def dying_diagnose(log_path, sha256, name, reports_dir, profiles):
    """Kills its own worker process on a log whose name contains 'kill-me' (a crashing parser)."""
    if "kill-me" in name:
        os._exit(9)
    return counting_diagnose(log_path, sha256, name, reports_dir, profiles)


# ----------------------------------------------------------------------------- in the test process

def upload(client, path, name=None, headers=AUTH):
    with open(path, "rb") as fh:
        return client.post("/api/logs", headers=headers, files={"log": (name or Path(path).name, fh)})


def wait_done(client, fid, timeout=120.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        j = client.get(f"/api/logs/{fid}", headers=AUTH).json()
        if j["state"] in ("done", "error"):
            return j
        time.sleep(0.3)
    raise AssertionError(f"flight {fid} not diagnosed in {timeout} s: {j}")


@contextlib.contextmanager
def serve_client(data_dir, db=None, **kw):
    """A TestClient on a fresh app (its lifespan starts and stops the job runner)."""
    from fastapi.testclient import TestClient

    from flightlog_fd.serve.app import ServeConfig, create_app
    from flightlog_fd.serve.security import TokenSet

    cfg = ServeConfig(data_dir=Path(data_dir), tokens=TokenSet([TOKEN]), db=db, **kw)
    app = create_app(cfg)
    with TestClient(app, raise_server_exceptions=False) as c:
        c.app_ = app
        yield c


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(data: Path, port: int, *logs: Path, workers: int = 1) -> subprocess.Popen:
    """`fdlog serve` in a subprocess on loopback; returns once /api/health answers."""
    tokens = data.parent / "tokens"
    tokens.write_text(TOKEN + "\n")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    log = open(data.parent / f"serve-{port}.log", "wb")  # a file, not a pipe nobody reads
    proc = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "serve",
                             *map(str, logs), "--data", str(data), "--port", str(port), "--token-file", str(tokens),
                             "--workers", str(workers)], env=env, stdout=subprocess.DEVNULL, stderr=log,
                            start_new_session=True)  # its own process group: a test can kill it with its workers
    log.close()
    end = time.monotonic() + 60
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise RuntimeError(f"fdlog serve exited: {(data.parent / f'serve-{port}.log').read_text()[-500:]}")
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=2).read()
            return proc
        except OSError:
            time.sleep(0.3)
    proc.kill()
    raise RuntimeError("fdlog serve did not answer in 60 s")


class Postgres:
    """A throw-away PostgreSQL server from /usr/lib/postgresql/*/bin on a loopback port (as the
    ``postgres`` user when run as root: postgres refuses root). ``url()`` makes a fresh database."""

    def __init__(self):
        bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
        if not bins:
            raise FileNotFoundError("PostgreSQL server binaries not found (apt-get install postgresql)")
        self.bin = Path(bins[-1]).parent
        self.dir = Path(tempfile.mkdtemp(prefix="fdlog-pg-"))
        self.as_user = None
        if os.geteuid() == 0:
            try:
                pw = pwd.getpwnam("postgres")
            except KeyError:
                raise FileNotFoundError("running as root and there is no 'postgres' user to run the server") from None
            os.chown(self.dir, pw.pw_uid, pw.pw_gid)
            self.as_user = "postgres"
        self.port = free_port()
        self._run(["initdb", "-D", str(self.dir / "data"), "-U", "fdlog", "--auth=trust", "-E", "UTF8", "--no-sync"])
        self._run(["pg_ctl", "-D", str(self.dir / "data"), "-l", str(self.dir / "log"), "-w", "-t", "60", "-o",
                   f"-p {self.port} -k {self.dir} -c listen_addresses=127.0.0.1 -c fsync=off "
                   f"-c synchronous_commit=off -c full_page_writes=off", "start"])

    def _run(self, argv):
        cmd = [str(self.bin / argv[0]), *argv[1:]]
        if self.as_user:
            cmd = ["runuser", "-u", self.as_user, "--", *cmd]
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        if res.returncode != 0:
            raise RuntimeError(f"{argv[0]} failed: {res.stderr.strip()[-500:]}")

    def url(self) -> str:
        import psycopg

        name = "t_" + uuid.uuid4().hex[:12]
        with psycopg.connect(f"postgresql://fdlog@127.0.0.1:{self.port}/postgres", autocommit=True) as c:
            c.execute(f"CREATE DATABASE {name}")
        return f"postgresql://fdlog@127.0.0.1:{self.port}/{name}"

    def stop(self):
        try:
            self._run(["pg_ctl", "-D", str(self.dir / "data"), "-m", "immediate", "stop"])
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)


def sleeping_diagnose(log_path, sha256, name, reports_dir, profiles):
    """Hangs on a log whose name contains 'hang' (pyulog spinning on a corrupt file)."""
    if "hang" in name:
        time.sleep(600)
    return counting_diagnose(log_path, sha256, name, reports_dir, profiles)


def pg_halt(pg: "Postgres") -> None:
    """Stop the PostgreSQL server, keeping its data (``pg_ctl stop -m fast``: clients are cut off)."""
    pg._run(["pg_ctl", "-D", str(pg.dir / "data"), "-m", "fast", "-w", "stop"])


def pg_resume(pg: "Postgres") -> None:
    """Start a server stopped by :func:`pg_halt` again, on the same port."""
    pg._run(["pg_ctl", "-D", str(pg.dir / "data"), "-l", str(pg.dir / "log"), "-w", "-t", "60", "-o",
             f"-p {pg.port} -k {pg.dir} -c listen_addresses=127.0.0.1 -c fsync=off "
             f"-c synchronous_commit=off -c full_page_writes=off", "start"])
