"""The `fdlog serve` web application (FastAPI + Jinja2 templates, run by uvicorn).

What: :func:`create_app` builds the ASGI app from a :class:`ServeConfig`: the store
(:class:`~flightlog_fd.store.Store`, SQLite or PostgreSQL), the data folder, the job
runner, the tokens. Pages: fleet (``/``), airframe (``/airframe?key=K``), flight
(``/flights/ID``) with its JSON / CSV / HTML reports; API: ``POST /api/logs`` (multipart field
``log``), ``GET /api/logs/ID``, ``GET /api/logs``, ``GET /api/jobs/ID``.

Limits and why: uploads and every state-changing request need a token (Bearer header, or a signed-in
browser session plus its CSRF token: :mod:`.security`); viewing is open or token-gated
(``view``). An upload is counted as it streams and refused with 413 past ``max_upload_bytes``; it
is stored as ``DATA/logs/<sha[:2]>/<sha256>.<ulg|bin>``, never under the client's name, and the
same bytes twice are one flight. Routes take integer ids or a key as a query value, never a path,
so no request reaches outside the data folder. Jinja2 autoescapes every value on every page; JSON
inlined in a page goes through ``tojson`` (which escapes ``<``, ``>``, ``&``, ``'``). Errors are
one line: JSON ``{"error": ...}`` under ``/api/``, a small page elsewhere, never a traceback.
While the store is unreachable every route that needs it answers 503 with one line saying so
(and ``Retry-After``); the error page and ``/api/health`` still show the workers' state, and the
server uses the store again as soon as it is back (:mod:`flightlog_fd.database`), no restart.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import uuid
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional
from urllib.parse import quote

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, PlainTextResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from jinja2 import Environment, FileSystemLoader
from starlette.exceptions import HTTPException as StarletteHTTPException

from .. import __version__
from ..drift import DRIFT_SLOPE_MIN, DRIFT_Z_MIN, FIGURE_FLOORS, MIN_FLIGHTS, verdict_words
from ..database import StoreUnavailable
from ..errors import FlightLogError
from ..report.motor_view import MotorView, summary_cell, summary_header
from ..report.panels import missing_line
from ..report.words import cause_line, cause_words, confidence_legend, evidence_clauses
from ..store import TREND_FIGURES, Store, parse_verdict_motors
from .security import SESSION_COOKIE, Sessions, TokenSet, bearer
from .worker import DataDir, JobRunner, diagnose_task

HERE = Path(__file__).resolve().parent
#: Default upload limit per file: the largest real log in ../shared is 67 MB.
DEFAULT_MAX_UPLOAD_MB = 256
#: Multipart framing allowed on top of the file itself (boundaries, headers, the CSRF field).
MULTIPART_SLACK_BYTES = 64 * 1024
#: Bytes read per chunk while hashing and copying an upload.
CHUNK = 1 << 20
#: Longest client file name kept for display (it is never used as a path).
MAX_NAME_CHARS = 200
#: Flights listed on the fleet page's "waiting / failed" table (the newest).
MAX_LISTED = 50
#: Jobs shown in the fleet page's "latest jobs" table.
MAX_JOBS_LISTED = 10
#: Fields a form may carry (ours carry at most five; more is not a browser of ours).
MAX_FORM_FIELDS = 20


def named_motors(row: dict) -> str:
    """What a stored verdict (a flight or flight_part row) names after its status: " · motor 3",
    " · motor 3 (motor or ESC)" (its cause the motor / ESC), " · motors 1 and 4" (a pair, damaged
    or uncertain); "" for none."""
    motors = row.get("verdict_motors")
    if isinstance(motors, str):
        motors = parse_verdict_motors(motors)
    words = verdict_words("x", row.get("motor"), list(motors or []), bool(row.get("pair")))
    if words == "x":
        return ""
    tag = cause_words(row.get("cause")).tag
    why = f" ({tag})" if tag and not (row.get("pair") and len(motors or []) > 1) else ""
    return f" \u00b7 {words[3:-1]}{why}"


#: Seconds a client is asked to wait before trying again while the store is unavailable (the
#: workers' first retries come as soon: database.STORE_RETRY_MIN_S doubling to STORE_RETRY_MAX_S).
RETRY_AFTER_S = 5
#: "attention" sort order of a latest verdict: what needs a look first.
STATUS_ORDER = {"damaged": 0, "stopped": 0, "uncertain": 1, "not_diagnosable": 2, "healthy": 3, None: 4}
SORTS = ("attention", "name", "flights", "latest")
#: Sent with every response. Scripts only from the app itself (no inline script, no CDN), so even
#: a text that escaped escaping could not run; plotly adds inline styles. No framing (clickjacking
#: of the forms), forms post to the app only.
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
                               "img-src 'self' data:; object-src 'none'; base-uri 'none'; form-action 'self'; "
                               "frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "same-origin",
}


@dataclass
class ServeConfig:
    """Everything `fdlog serve` decides at start."""

    data_dir: Path
    tokens: TokenSet
    db: Optional[str] = None  # SQLite path or postgresql:// URL; default DATA/fdlog.sqlite
    view: str = "open"  # "open": anyone who reaches the port may look; "token": pages need sign-in
    max_upload_bytes: int = DEFAULT_MAX_UPLOAD_MB * 1024 * 1024
    workers: int = 1
    scheduler: Optional[str] = None
    calibrate_adapt: bool = False  # calibration jobs also adapt the model (torch, minutes)
    diagnose_fn: Callable = diagnose_task
    job_timeout_s: Optional[float] = None
    secure_cookies: bool = False  # set the cookie's Secure flag (behind HTTPS)
    watch: list = field(default_factory=list)  # folders whose new logs are queued (`--watch`)
    watch_settle_s: Optional[float] = None  # None: flightlog_fd.watch.SETTLE_S
    watch_poll_s: Optional[float] = None  # None: events where delivered
    extra: dict = field(default_factory=dict)


class ApiError(Exception):
    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


class TooLarge(Exception):
    pass


def clean_name(name: Optional[str]) -> str:
    """The client's file name for display: last path part, no control characters, bounded."""
    base = re.split(r"[\\/]", name or "")[-1]
    base = "".join(ch for ch in base if ch.isprintable())[:MAX_NAME_CHARS].strip()
    return base or "upload"


def fmt_number(x: Any, decimals: int = 3) -> str:
    """A number with ``decimals`` decimals, "-" for anything else (a field a newer report lacks)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return "-"
    return f"{x:.{decimals}f}"


def _profile_logs(path: str) -> set:
    """The sha256 of every log a profile file lists (empty when it cannot be read)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    logs = list(d.get("source_logs") or []) + [e for s in (d.get("sessions_") or []) for e in (s.get("logs") or [])]
    return {e.get("sha256") for e in logs if isinstance(e, dict) and e.get("sha256")}


def ingest_file(store: Store, data: DataDir, path, sha256: Optional[str] = None, fmt: Optional[str] = None) -> tuple[int, bool]:
    """Queue a local log file as if uploaded (`fdlog serve LOGS`, `--watch`): copied by content
    hash (``sha256`` / ``fmt`` when already known). Raises FlightLogError for a file that is not a log."""
    import shutil

    from ..logs import sniff_format
    from ..util import file_sha256

    p = Path(path)
    fmt = fmt or sniff_format(p)
    sha = sha256 or file_sha256(p)
    dest = data.log_path(sha, fmt)
    if not dest.exists():
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = data.root / "tmp" / f"{uuid.uuid4().hex}.part"
        shutil.copyfile(p, tmp)
        os.replace(tmp, dest)
    return store.add_upload(sha, clean_name(p.name), p.stat().st_size, fmt)


def queue_sink(store: Store, data: DataDir, runner: JobRunner) -> Callable:
    """The sink of `fdlog serve --watch` (:class:`flightlog_fd.watch.FolderWatch`): each log found
    becomes an upload on the job queue (the same bytes twice are one flight)."""
    def sink(found) -> tuple[str, str]:
        if found.problem is not None:  # refused alike when uploaded: no flight row
            return "bad", f"not a flight log: {found.problem}"
        fid, created = ingest_file(store, data, found.path, sha256=found.sha256, fmt=found.fmt)
        if created:
            runner.wake()
            return "diagnosed", f"queued as flight {fid}"
        return "known", f"already flight {fid}"

    return sink


def create_app(cfg: ServeConfig):
    """The ASGI app; the job runner starts and stops with the app's lifespan."""
    data = DataDir(cfg.data_dir)
    store = Store(cfg.db or str(data.root / "fdlog.sqlite"))
    kw = {"job_timeout_s": cfg.job_timeout_s} if cfg.job_timeout_s else {}
    runner = JobRunner(store, data, workers=cfg.workers, scheduler=cfg.scheduler, diagnose_fn=cfg.diagnose_fn, **kw)
    sessions = Sessions()
    env = Environment(loader=FileSystemLoader(str(HERE / "templates")), autoescape=True)
    env.filters["fmt"] = fmt_number
    env.filters["q"] = lambda s: quote(str(s), safe="")
    env.globals.update(summary_header=summary_header, summary_cell=summary_cell)  # the per-motor summary names
    env.globals["named_motors"] = named_motors
    env.globals["cause_words"] = cause_words  # legends and labels in the verdict's cause's words
    # the verdict's lines in every report's order and words (report/words.py)
    env.globals.update(cause_line=cause_line, evidence_clauses=evidence_clauses, confidence_legend=confidence_legend)
    env.filters["capitalize_first"] = lambda s: s[:1].upper() + s[1:] if s else s
    env.globals["missing_line"] = missing_line  # the streams a flight's plots lack, in one line

    watcher = None
    if cfg.watch:
        import logging

        from ..watch import SETTLE_S, FolderWatch

        log = logging.getLogger("uvicorn.error")

        def report(kind: str, path: str, text: str) -> None:
            if kind != "known":
                log.warning("fdlog serve --watch: %s", f"{path}: {text}" if path else text)

        watcher = FolderWatch(cfg.watch, store, queue_sink(store, data, runner), report=report, poll_s=cfg.watch_poll_s,
                              settle_s=cfg.watch_settle_s if cfg.watch_settle_s is not None else SETTLE_S)

    @asynccontextmanager
    async def lifespan(app):
        import threading

        runner.start()
        thread = None
        if watcher is not None:
            thread = threading.Thread(target=watcher.run, name="fdlog-watch", daemon=True)
            thread.start()
        try:
            yield
        finally:
            if watcher is not None:
                watcher.stop()
                thread.join(10)
            runner.stop()
            store.close()

    app = FastAPI(title="fdlog serve", version=__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  openapi_url=None)
    app.state.store, app.state.runner, app.state.data, app.state.config = store, runner, data, cfg
    app.state.watcher = watcher
    app.mount("/static", StaticFiles(directory=str(HERE / "static")), name="static")

    @app.middleware("http")
    async def security_headers(request: Request, call_next):
        resp = await call_next(request)
        for k, v in SECURITY_HEADERS.items():
            resp.headers.setdefault(k, v)  # a report keeps its own stricter policy
        return resp

    # ------------------------------------------------------------------ auth helpers

    def session_id(request: Request) -> Optional[str]:
        sid = request.cookies.get(SESSION_COOKIE)
        return sid if sessions.valid(sid) else None

    def can_view(request: Request) -> bool:
        return cfg.view == "open" or cfg.tokens.check(bearer(request.headers.get("authorization"))) \
            or session_id(request) is not None

    def require_view(request: Request) -> None:
        if not can_view(request):
            raise ApiError(401, "sign in with a token to view this server")

    def require_write(request: Request, csrf: Optional[str] = None) -> None:
        auth = request.headers.get("authorization")
        if auth is not None:
            if cfg.tokens.check(bearer(auth)):
                return
            raise ApiError(401, "invalid token")
        sid = session_id(request)
        if sid is None:
            raise ApiError(401, "a token is needed: Authorization: Bearer TOKEN, or sign in")
        if not sessions.csrf_ok(sid, csrf or request.headers.get("x-csrf-token")):
            raise ApiError(403, "missing or wrong CSRF token: reload the page and try again")

    def page(request: Request, template: str, http_status: int = 200, **ctx) -> HTMLResponse:
        sid = session_id(request)
        try:
            counts = store.job_counts()
        except StoreUnavailable:
            if http_status < 500:
                raise
            counts = None  # the error page of an outage: no counts to show
        ctx.update(signed_in=sid is not None, csrf=sessions.csrf(sid) if sid else "", version=__version__,
                   view=cfg.view, counts=counts, workers=runner.status(), outage=store.db.outage())
        return HTMLResponse(env.get_template(template).render(**ctx), status_code=http_status)

    # ------------------------------------------------------------------ errors: one line

    def error_response(request: Request, status: int, message: str):
        if request.url.path.startswith("/api/"):
            return JSONResponse({"error": message}, status_code=status)
        if status == 401 and request.method == "GET":
            return RedirectResponse("/login?next=" + quote(str(request.url.path), safe=""), status_code=303)
        return page(request, "error.html", http_status=status, status_code=status, message=message)

    @app.exception_handler(ApiError)
    async def _api_error(request: Request, exc: ApiError):
        return error_response(request, exc.status, exc.message)

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException):
        msg = {404: "not found", 405: "method not allowed"}.get(exc.status_code, str(exc.detail))
        return error_response(request, exc.status_code, msg)

    @app.exception_handler(RequestValidationError)
    async def _bad_request(request: Request, exc: RequestValidationError):
        errs = exc.errors()
        first = errs[0] if errs else {}
        where = ".".join(str(x) for x in first.get("loc", ()) if x not in ("body", "query", "path"))
        return error_response(request, 400, f"bad request: {where or 'input'}: {first.get('msg', 'invalid')}")

    def error_or_plain(request: Request, status: int, message: str):
        """The error page, or one plain line when the page itself cannot be made (it asks the
        store for the job counts, which may be what failed)."""
        try:
            return error_response(request, status, message)
        except Exception:
            return PlainTextResponse(message, status_code=status)

    @app.exception_handler(StoreUnavailable)
    async def _store_down(request: Request, exc: StoreUnavailable):
        message = f"{exc.message} ({store.db.where}); the server reconnects by itself: try again in a few seconds"
        resp = error_or_plain(request, 503, message)
        resp.headers["Retry-After"] = str(RETRY_AFTER_S)
        return resp

    @app.exception_handler(FlightLogError)
    async def _store_error(request: Request, exc: FlightLogError):
        return error_response(request, 400, exc.message)

    @app.exception_handler(Exception)
    async def _internal(request: Request, exc: Exception):
        # Starlette answers unhandled errors outside the middleware stack: the security headers
        # are added here.
        resp = error_or_plain(request, 500, f"internal error: {type(exc).__name__}")
        for k, v in SECURITY_HEADERS.items():
            resp.headers.setdefault(k, v)
        return resp

    # ------------------------------------------------------------------ upload

    async def receive_upload(request: Request) -> dict:
        """Stream one multipart upload into the data folder by content hash (module docstring)."""
        from starlette.requests import Request as StarletteRequest

        from ..errors import NotALogError
        from ..logs import sniff_format

        auth = request.headers.get("authorization")
        if auth is not None and not cfg.tokens.check(bearer(auth)):
            raise ApiError(401, "invalid token")
        if auth is None and session_id(request) is None:
            raise ApiError(401, "a token is needed: Authorization: Bearer TOKEN, or sign in")
        limit = cfg.max_upload_bytes + MULTIPART_SLACK_BYTES
        length = request.headers.get("content-length")
        if length is not None and length.isdigit() and int(length) > limit:
            raise ApiError(413, f"upload too large: the limit is {cfg.max_upload_bytes} bytes per log")
        seen = 0
        inner = request.receive

        async def counted():
            nonlocal seen
            msg = await inner()
            if msg.get("type") == "http.request":
                seen += len(msg.get("body", b""))
                if seen > limit:
                    raise TooLarge()
            return msg

        try:
            form = await StarletteRequest(request.scope, counted).form(max_files=1, max_fields=MAX_FORM_FIELDS)
        except TooLarge:
            raise ApiError(413, f"upload too large: the limit is {cfg.max_upload_bytes} bytes per log") from None
        except Exception as e:  # malformed multipart, too many files
            raise ApiError(400, f"bad upload: {str(e).splitlines()[0][:200] if str(e) else type(e).__name__}") from None
        try:
            if auth is None:  # a browser session: its CSRF token (form field or header)
                require_write(request, form.get("csrf") if isinstance(form.get("csrf"), str) else None)
            up = form.get("log")
            if up is None or isinstance(up, str):
                raise ApiError(400, "no file: send the log as multipart field 'log' (curl -F log=@flight.ulg)")
            tmp = data.root / "tmp" / f"{uuid.uuid4().hex}.part"
            h = hashlib.sha256()
            size = 0
            try:
                with open(tmp, "wb") as out:
                    while True:
                        chunk = await up.read(CHUNK)
                        if not chunk:
                            break
                        size += len(chunk)
                        if size > cfg.max_upload_bytes:
                            raise ApiError(413, f"upload too large: the limit is {cfg.max_upload_bytes} bytes per log")
                        h.update(chunk)
                        out.write(chunk)
                if size == 0:
                    raise ApiError(400, "empty file: not a flight log")
                try:
                    fmt = sniff_format(tmp)
                except NotALogError as e:
                    raise ApiError(400, f"not a flight log (PX4 ULog or ArduPilot DataFlash): {e.message}") from None
                sha = h.hexdigest()
                dest = data.log_path(sha, fmt)
                dest.parent.mkdir(parents=True, exist_ok=True)
                if dest.exists():
                    tmp.unlink()
                else:
                    os.replace(tmp, dest)
            finally:
                if tmp.exists():
                    tmp.unlink()
            fid, created = store.add_upload(sha, clean_name(up.filename), size, fmt)
        finally:
            await form.close()
        if created:
            runner.wake()
        return {"id": fid, "sha256": sha, "created": created, "state": store.flight(fid)["state"],
                "url": f"/flights/{fid}", "api": f"/api/logs/{fid}"}

    def flight_json(f: dict) -> dict:
        out = {"id": int(f["id"]), "name": f["name"], "sha256": f["sha256"], "size_bytes": int(f["size_bytes"]),
               "format": f["format"], "uploaded_at": f["uploaded_at"], "state": f["state"],
               "airframe": store.resolve(f["airframe"]) if f["airframe"] else None, "healthy_mark": bool(f["healthy_mark"]),
               "url": f"/flights/{f['id']}"}
        if f["state"] in ("done", "error"):
            out["diagnosis"] = json.loads(f["diagnosis_json"]) if f["diagnosis_json"] else None
            out["diagnosed_at"] = f["diagnosed_at"]
        if f["state"] == "error":
            out["error"] = f["error"]
        return out

    def get_flight(fid: int) -> dict:
        f = store.flight(fid)
        if f is None:
            raise ApiError(404, f"no flight {fid}")
        return f

    # ------------------------------------------------------------------ API

    @app.post("/api/logs")
    async def api_upload(request: Request):
        return JSONResponse(await receive_upload(request))

    @app.get("/api/logs/{fid}")
    def api_log(fid: int, request: Request):
        require_view(request)
        return JSONResponse(flight_json(get_flight(fid)))

    @app.get("/api/logs")
    def api_logs(request: Request):
        require_view(request)
        return JSONResponse({"logs": store.logs(), "jobs": store.job_counts()})

    @app.get("/api/jobs/{jid}")
    def api_job(jid: int, request: Request):
        require_view(request)
        j = store.job(jid)
        if j is None:
            raise ApiError(404, f"no job {jid}")
        return JSONResponse({k: j[k] for k in ("id", "kind", "flight_id", "airframe", "state", "attempts", "error",
                                               "created_at", "started_at", "finished_at")})

    @app.get("/api/health")
    def api_health():
        """200 with the job counts while the store answers; 503 with the outage while it does not;
        both with each worker slot's state."""
        try:
            jobs = store.job_counts()
        except StoreUnavailable as e:
            return JSONResponse({"ok": False, "version": __version__, "database": store.dialect,
                                 "error": e.message, "outage": store.db.outage(), "workers": runner.status()},
                                status_code=503, headers={"Retry-After": str(RETRY_AFTER_S)})
        return JSONResponse({"ok": True, "version": __version__, "jobs": jobs, "database": store.dialect,
                             "workers": runner.status()})

    # ------------------------------------------------------------------ sign-in

    @app.get("/login", response_class=HTMLResponse)
    def login_page(request: Request, next: str = "/"):
        return page(request, "login.html", next=next if next.startswith("/") and not next.startswith("//") else "/")

    @app.post("/login")
    async def login(request: Request):
        form = await request.form(max_files=0, max_fields=MAX_FORM_FIELDS)
        token, nxt = str(form.get("token") or ""), str(form.get("next") or "/")
        if not cfg.tokens.check(token.strip()):
            return page(request, "login.html", http_status=401, next=nxt, message="wrong token")
        if not nxt.startswith("/") or nxt.startswith("//"):
            nxt = "/"
        resp = RedirectResponse(nxt, status_code=303)
        resp.set_cookie(SESSION_COOKIE, sessions.create(), httponly=True, samesite="strict",
                        secure=cfg.secure_cookies, path="/")
        return resp

    @app.post("/logout")
    async def logout(request: Request):
        form = await request.form(max_files=0, max_fields=MAX_FORM_FIELDS)
        sid = session_id(request)
        if sid and sessions.csrf_ok(sid, str(form.get("csrf") or "")):
            sessions.drop(sid)
        resp = RedirectResponse("/", status_code=303)
        resp.delete_cookie(SESSION_COOKIE, path="/")
        return resp

    # ------------------------------------------------------------------ pages

    @app.get("/", response_class=HTMLResponse)
    def fleet_page(request: Request, q: str = "", status: str = "", sort: str = "attention"):
        require_view(request)
        fleet = store.fleet()
        if q:
            ql = q.lower()
            fleet = [a for a in fleet if ql in a["name"].lower() or ql in a["key"].lower()
                     or any(ql in f["name"].lower() for f in a["flights"])]
        if status == "drift":
            fleet = [a for a in fleet if a["drift"]]
        elif status:
            fleet = [a for a in fleet if a["latest"] and a["latest"]["status"] == status]
        sort = sort if sort in SORTS else "attention"
        keyf = {"attention": lambda a: (not a["drift"], STATUS_ORDER.get(a["latest"]["status"] if a["latest"] else None, 4), a["name"]),
                "name": lambda a: a["name"].lower(), "flights": lambda a: -len(a["flights"]),
                "latest": lambda a: "" if not a["latest"] else (a["latest"]["flight_start_utc"] or a["latest"]["uploaded_at"])}[sort]
        fleet.sort(key=keyf, reverse=(sort == "latest"))
        pending = store.pending()[-MAX_LISTED:]
        return page(request, "fleet.html", fleet=fleet, q=q, status=status, sort=sort, sorts=SORTS,
                    pending=pending, jobs=store.jobs(MAX_JOBS_LISTED),
                    max_upload=cfg.max_upload_bytes)

    @app.get("/airframe", response_class=HTMLResponse)
    def airframe_page(request: Request, key: str):
        require_view(request)
        a = store.airframe_view(key)
        if a is None:
            target = store.resolve(key)
            if target != key and store.airframe_view(target) is not None:
                return RedirectResponse("/airframe?key=" + quote(target, safe=""), status_code=303)
            raise ApiError(404, "no such airframe")
        trend = {"flights": [], "figures": []}
        for i, f in enumerate(a["flights"], 1):
            trend["flights"].append({"n": i, "id": int(f["id"]), "name": f["name"], "status": f["status"] or f["state"]})
        n_motors = max([4] + [int(k) for f in a["flights"] for k in f["motors"]])  # hexa, octo: more
        for fig, title in TREND_FIGURES:
            lines = []
            for k in range(1, n_motors + 1):
                ys = [(f["motors"].get(k) or {}).get(fig) for f in a["flights"]]
                lines.append({"motor": k, "y": ys})
            if any(v is not None for ln in lines for v in ln["y"]):
                trend["figures"].append({"field": fig, "title": title, "lines": lines})
        profile = None
        if a["profile_path"]:
            try:
                profile = json.loads(Path(a["profile_path"]).read_text(encoding="utf-8"))
            except (OSError, ValueError):
                profile = {"error": "the profile file cannot be read"}
        others = [o for o in store.fleet() if o["key"] != key]
        cal_jobs = store.calibration_jobs(key)
        sessions = store.calibration_sessions(key)
        rule = {"min_flights": MIN_FLIGHTS, "slope": DRIFT_SLOPE_MIN, "z": DRIFT_Z_MIN, "floors": FIGURE_FLOORS}
        return page(request, "airframe.html", a=a, trend=trend, n_motors=n_motors, profile=profile, others=others, rule=rule,
                    cal_jobs=cal_jobs, adapt=cfg.calibrate_adapt, sessions=sessions)

    @app.get("/flights/{fid}", response_class=HTMLResponse)
    def flight_page(request: Request, fid: int):
        require_view(request)
        f = get_flight(fid)
        doc = json.loads(f["diagnosis_json"]) if f["diagnosis_json"] else None
        plot = json.loads(f["plot_json"]) if f["plot_json"] else None
        mview = MotorView.from_doc(doc or {})
        mheader, mrows = mview.table()
        windows = [{"t0": w.get("t_start"), "t1": w.get("t_end"), "p": w.get("probabilities") or [],
                    "label": w.get("smoothed_class")} for w in (doc or {}).get("windows") or []
                   if isinstance(w, dict) and w.get("t_start") is not None]
        airframe = store.resolve(f["airframe"]) if f["airframe"] else None
        return page(request, "flight.html", f=f, doc=doc, mview=mview, mheader=mheader, mrows=mrows,
                    plotdata={"plot": plot, "windows": windows,
                              "rotor_word": cause_words(((doc or {}).get("verdict") or {}).get("cause")).short},
                    airframe=airframe, parts=store.flight_parts(fid),
                    part_headlines=[((x.get("verdict") or {}).get("headline") if isinstance(x, dict) else None)
                                    for x in (doc or {}).get("flights") or []],
                    has_html=data.report_path(f["sha256"], "html").exists(),
                    has_csv=data.report_path(f["sha256"], "csv").exists())

    @app.get("/flights/{fid}/report.json")
    def flight_report_json(request: Request, fid: int):
        require_view(request)
        f = get_flight(fid)
        if not f["diagnosis_json"]:
            raise ApiError(404, "not diagnosed yet")
        return Response(f["diagnosis_json"], media_type="application/json")

    def report_file(request: Request, fid: int, ext: str, media: str):
        require_view(request)
        f = get_flight(fid)
        p = data.report_path(f["sha256"], ext)
        if not p.is_file():
            raise ApiError(404, "no report for this flight yet")
        headers = {"Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; img-src data:",
                   "X-Content-Type-Options": "nosniff"}
        if ext == "csv":
            headers["Content-Disposition"] = f'attachment; filename="flight-{fid}.csv"'
        return FileResponse(p, media_type=media, headers=headers)

    @app.get("/flights/{fid}/report.html")
    def flight_report_html(request: Request, fid: int):
        return report_file(request, fid, "html", "text/html; charset=utf-8")

    @app.get("/flights/{fid}/report.csv")
    def flight_report_csv(request: Request, fid: int):
        return report_file(request, fid, "csv", "text/csv; charset=utf-8")

    # ------------------------------------------------------------------ forms (token + CSRF)

    async def form_of(request: Request) -> Any:
        form = await request.form(max_files=0, max_fields=MAX_FORM_FIELDS)
        require_write(request, str(form.get("csrf") or ""))
        return form

    def back(key: Optional[str] = None, fid: Optional[int] = None):
        url = f"/flights/{fid}" if fid is not None else ("/airframe?key=" + quote(key, safe="") if key else "/")
        return RedirectResponse(url, status_code=303)

    @app.post("/flights/{fid}/healthy")
    async def mark_healthy(request: Request, fid: int):
        form = await form_of(request)
        get_flight(fid)
        store.set_healthy_mark(fid, str(form.get("healthy") or "") == "1")
        nxt = str(form.get("next") or "")
        return RedirectResponse(nxt if nxt.startswith("/") and not nxt.startswith("//") else f"/flights/{fid}",
                                status_code=303)

    @app.post("/airframe/calibrate")
    async def calibrate(request: Request):
        form = await form_of(request)
        key = str(form.get("key") or "")
        a = store.airframe_view(key)
        if a is None:
            raise ApiError(404, "no such airframe")
        ids = [int(f["id"]) for f in a["flights"] if f["healthy_mark"] and f["state"] == "done"]
        if not ids:
            raise ApiError(400, "mark at least one diagnosed flight of this airframe as healthy first")
        add_to = a["profile_path"] if str(form.get("mode") or "") == "add" else None
        if add_to:  # the marked flights the profile does not hold yet become its next sessions
            held = {int(s["flight_id"]) for s in store.calibration_sessions(key)} | _profile_logs(add_to)
            by_sha = {int(f["id"]): f["sha256"] for f in a["flights"]}
            ids = [i for i in ids if i not in held and by_sha.get(i) not in held]
            if not ids:
                raise ApiError(400, "every flight marked healthy is already a session of the profile: mark another "
                                    "healthy flight (another day or battery) first")
        store.enqueue_calibration(key, ids, cfg.calibrate_adapt and not add_to, add_to=add_to)
        runner.wake()
        return back(key)

    @app.post("/airframe/rename")
    async def rename(request: Request):
        form = await form_of(request)
        key = str(form.get("key") or "")
        name = "".join(ch for ch in str(form.get("name") or "") if ch.isprintable())[:MAX_NAME_CHARS].strip()
        if not store.rename_airframe(key, name):
            raise ApiError(404, "no such airframe")
        return back(key)

    @app.post("/airframe/merge")
    async def merge(request: Request):
        form = await form_of(request)
        key, into = str(form.get("key") or ""), str(form.get("into") or "")
        store.merge_airframe(key, into)
        return back(store.resolve(into))

    @app.get("/static-plotly.min.js")
    def plotly_js():
        import plotly

        p = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
        if not p.is_file():
            raise ApiError(404, "plotly.min.js is not in the installed plotly package")
        return FileResponse(p, media_type="text/javascript", headers={"Cache-Control": "public, max-age=86400"})

    return app
