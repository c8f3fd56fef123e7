"""`fdlog serve`: the HTTP API (upload with a token, 401, 413, the diagnosis under `diagnosis`),
content-hash storage, escaping of hostile names and log metadata on every page, CSRF on forms,
paths that cannot leave the data folder, airframes of logs without an id. Skips without the
[serve] extra."""
from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("jinja2")
pytest.importorskip("multipart")

from serve_helpers import AUTH, SAMPLES, TOKEN, serve_client, upload, wait_done  # noqa: E402

from flightlog_fd.report.json_report import validate  # noqa: E402

HOSTILE_NAME = "<img src=x onerror=alert('name')>.ulg"
HOSTILE_FW = "<script>alert('fw')</script> v1.2.3"
HOSTILE_ID = "<svg onload=alert('id')>&\"'"


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    """One server with one worker process for the tests that need diagnoses."""
    with serve_client(tmp_path_factory.mktemp("serve"), workers=1) as c:
        yield c


def test_upload_needs_a_token(live):
    r = upload(live, SAMPLES / "px4_healthy.ulg", headers={})
    assert r.status_code == 401 and "token" in r.json()["error"]
    r = upload(live, SAMPLES / "px4_healthy.ulg", headers={"Authorization": "Bearer not-the-token-at-all"})
    assert r.status_code == 401 and r.json() == {"error": "invalid token"}
    r = upload(live, SAMPLES / "px4_healthy.ulg", headers={"Authorization": "Basic " + TOKEN})
    assert r.status_code == 401
    assert live.get("/api/logs").json()["logs"] == []  # nothing was stored


def test_upload_and_result_with_a_token(live):
    r = upload(live, SAMPLES / "px4_motor1_damaged.ulg", name="../../../etc/evil.ulg")
    assert r.status_code == 200, r.text
    body = r.json()
    fid, sha = body["id"], body["sha256"]
    j = wait_done(live, fid)
    assert j["state"] == "done"
    assert validate(j["diagnosis"]) == []  # the same schema as `fdlog diagnose --json`
    # rotor 1 lost thrust (issue 37: "damaged" says that, its cause apart)
    assert (j["diagnosis"]["verdict"]["status"], j["diagnosis"]["verdict"]["motor"]) == ("damaged", 1)
    assert j["diagnosis"]["verdict"]["headline"].startswith("Rotor 1 (front-right) lost")
    assert j["name"] == "evil.ulg"  # the last part of the client's name, for display only
    # stored by content hash, never under the client's name
    data = Path(live.app_.state.data.root)
    stored = data / "logs" / sha[:2] / f"{sha}.ulg"
    assert stored.read_bytes() == (SAMPLES / "px4_motor1_damaged.ulg").read_bytes()
    assert not any("evil" in p.name for p in data.rglob("*"))
    # every analyzer's findings are rows of the store
    n_findings = sum(len(a["findings"]) for a in j["diagnosis"].get("analyzers") or [])
    rows = live.app_.state.store.db.query("SELECT * FROM finding WHERE flight_id = ?", (fid,))
    assert len(rows) == n_findings > 0
    # the same bytes again are the same flight: no new row, no new job
    again = upload(live, SAMPLES / "px4_motor1_damaged.ulg", name="copy.ulg").json()
    assert again["id"] == fid and again["created"] is False
    assert [f["sha256"] for f in live.get("/api/logs").json()["logs"]].count(sha) == 1
    # the reports
    assert json.loads(live.get(f"/flights/{fid}/report.json").text) == j["diagnosis"]
    csv = live.get(f"/flights/{fid}/report.csv")
    assert csv.status_code == 200 and csv.text.startswith("log,t_start")
    rep = live.get(f"/flights/{fid}/report.html")
    assert rep.status_code == 200 and "<svg" in rep.text and "script-src" not in rep.text
    assert "default-src 'none'" in rep.headers["content-security-policy"]


def test_pages_show_the_flight(live):
    fid = upload(live, SAMPLES / "px4_motor2_damaged.ulg").json()["id"]
    wait_done(live, fid)
    page = live.get(f"/flights/{fid}").text
    assert 'id="flightplot"' in page and "/static-plotly.min.js" in page
    assert "Per-motor evidence" in page and "motor 2" in page.lower()
    assert 'id="findings"' in page  # every analyzer's findings, as the report lists them
    plot = json.loads(re.search(r'<script type="application/json" id="plot-data">(.*?)</script>', page, re.S).group(1))
    assert len(plot["plot"]["rates"]) == 3 and len(plot["plot"]["motors"]) == 4 and plot["windows"]
    fleet = live.get("/").text
    assert "sim-13-0" in fleet and 'href="/flights/' in fleet
    af = live.get("/airframe", params={"key": "sim-13-0"})
    assert af.status_code == 200 and 'id="trend-data"' in af.text
    js = live.get("/static-plotly.min.js")
    assert js.status_code == 200 and len(js.content) > 1_000_000  # served from the plotly package, no CDN
    assert "cdn" not in (page + fleet + af.text).lower()
    # no inline script on any page, and the policy says scripts come from the app only
    for text in (page, fleet, af.text):
        for tag in re.findall(r"<script[^>]*>", text):
            assert "src=" in tag or 'type="application/json"' in tag, tag
    csp = live.get("/").headers["content-security-policy"]
    assert "script-src 'self';" in csp and "frame-ancestors 'none'" in csp


def test_a_damaged_flight_page_says_what_to_inspect(live):
    """The hexa sample without a profile: rotor 5 lost thrust, cause unknown; the page lists what to
    inspect, propeller first, and what would tell the cause (ESC telemetry)."""
    fid = upload(live, SAMPLES / "ardupilot_hexa_motor5_damaged.bin").json()["id"]
    wait_done(live, fid)
    page = live.get(f"/flights/{fid}").text
    advice = re.search(r'<div id="advice">(.*?)</div>', page, re.S).group(1)
    assert "inspect propeller 5" in advice and "then motor 5 and its ESC" in advice
    assert 'class="advice-esc_telemetry"' in advice


def test_logs_without_an_id_are_not_one_unknown_airframe(live):
    ids = [upload(live, SAMPLES / n).json()["id"] for n in ("ardupilot_healthy.bin", "ardupilot_motor3_damaged.bin")]
    keys = {wait_done(live, i)["airframe"] for i in ids}
    assert len(keys) == 2 and all(k.startswith("log:") for k in keys)
    assert "unknown" not in keys


def test_hostile_file_name_and_log_metadata_are_escaped_everywhere(live, tmp_path):
    from flightlog_fd import load_flight
    from flightlog_fd.logs.ulog_writer import write_ulog

    f = load_flight(SAMPLES / "px4_motor1_damaged.ulg")
    f.firmware, f.vehicle_id = HOSTILE_FW, HOSTILE_ID
    p = tmp_path / "hostile.ulg"
    write_ulog(f, p)
    fid = upload(live, p, name=HOSTILE_NAME).json()["id"]
    j = wait_done(live, fid)
    assert j["airframe"] == HOSTILE_ID and j["diagnosis"]["firmware"] == HOSTILE_FW
    pages = {"fleet": live.get("/").text, "flight": live.get(f"/flights/{fid}").text,
             "airframe": live.get("/airframe", params={"key": HOSTILE_ID}).text,
             "report": live.get(f"/flights/{fid}/report.html").text}
    for where, text in pages.items():
        for raw in (HOSTILE_NAME, HOSTILE_FW.split(" ")[0], "<svg onload", "<img src=x"):
            assert raw not in text, f"{raw!r} unescaped on the {where} page"
    assert html.escape(HOSTILE_NAME, quote=False) in pages["flight"] or "&lt;img src=x" in pages["flight"]
    assert "&lt;script&gt;" in pages["flight"] and "&lt;svg onload" in pages["airframe"]


def test_upload_over_the_limit_is_413(tmp_path):
    with serve_client(tmp_path, workers=0, max_upload_bytes=100_000) as c:
        r = upload(c, SAMPLES / "px4_healthy.ulg")  # ~1.9 MB, with Content-Length
        assert r.status_code == 413 and "limit is 100000 bytes" in r.json()["error"]
        # chunked (no Content-Length): counted as it streams
        body = (SAMPLES / "px4_healthy.ulg").read_bytes()
        boundary = "fdlogboundary"
        head = (f"--{boundary}\r\nContent-Disposition: form-data; name=\"log\"; filename=\"a.ulg\"\r\n"
                f"Content-Type: application/octet-stream\r\n\r\n").encode()
        tail = f"\r\n--{boundary}--\r\n".encode()

        def chunks():
            yield head
            for i in range(0, len(body), 65536):
                yield body[i:i + 65536]
            yield tail

        r = c.post("/api/logs", headers={**AUTH, "Content-Type": f"multipart/form-data; boundary={boundary}"},
                   content=chunks())
        assert r.status_code == 413, r.text
        assert c.get("/api/logs").json()["logs"] == []
        assert list((Path(c.app_.state.data.root) / "tmp").iterdir()) == []  # nothing left behind
        # under the limit: accepted
        small = tmp_path / "small.bin"
        small.write_bytes((SAMPLES / "ardupilot_healthy.bin").read_bytes()[:50_000])
        assert upload(c, small).status_code == 200


def test_bad_uploads_get_one_clear_line(tmp_path):
    with serve_client(tmp_path, workers=0) as c:
        txt = tmp_path / "notes.txt"
        txt.write_text("hello\n")
        r = upload(c, txt)
        assert r.status_code == 400 and r.json()["error"].startswith("not a flight log")
        empty = tmp_path / "empty.ulg"
        empty.write_bytes(b"")
        assert upload(c, empty).json() == {"error": "empty file: not a flight log"}
        r = c.post("/api/logs", headers=AUTH, data={"other": "x"})
        assert r.status_code == 400 and "multipart field 'log'" in r.json()["error"]
        assert c.get("/api/logs/999").status_code == 404
        assert c.get("/api/logs/abc").json()["error"].startswith("bad request")
        for r in (txt,):
            assert "Traceback" not in upload(c, r).text


def test_paths_cannot_leave_the_data_folder(tmp_path):
    with serve_client(tmp_path, workers=0) as c:
        for url in ("/static/../app.py", "/static/%2e%2e/app.py", "/static/..%2fapp.py",
                    "/flights/..%2f..%2fetc%2fpasswd/report.html", "/flights/1/../../../etc/passwd",
                    "/static/%2e%2e/%2e%2e/database.py"):
            r = c.get(url)
            assert r.status_code in (400, 404), (url, r.status_code)
            assert "def create_app" not in r.text and "root:" not in r.text and "import" not in r.text


def test_forms_need_a_session_and_its_csrf_token(tmp_path):
    with serve_client(tmp_path, workers=0, view="token") as c:
        # viewing is token-gated: pages send to the sign-in form, the API answers 401
        r = c.get("/", follow_redirects=False)
        assert r.status_code == 303 and r.headers["location"].startswith("/login")
        assert c.get("/api/logs").status_code == 401
        assert c.get("/api/logs", headers=AUTH).status_code == 200
        # a form post without any sign-in
        assert c.post("/airframe/rename", data={"key": "k", "name": "n"}).status_code == 401
        # wrong token at sign-in
        assert c.post("/login", data={"token": "nope-nope-nope-nope"}).status_code == 401
        r = c.post("/login", data={"token": TOKEN, "next": "/"}, follow_redirects=False)
        assert r.status_code == 303
        cookie = r.headers["set-cookie"].lower()
        assert "httponly" in cookie and "samesite=strict" in cookie and TOKEN.lower() not in cookie
        page = c.get("/").text
        csrf = re.search(r'name="csrf" value="([0-9a-f]+)"', page).group(1)
        # signed in, but no / a wrong CSRF token: refused
        assert c.post("/airframe/rename", data={"key": "k", "name": "n"}).status_code == 403
        assert c.post("/airframe/rename", data={"key": "k", "name": "n", "csrf": "0" * 64}).status_code == 403
        # upload from the browser session: the CSRF header is required too
        with open(SAMPLES / "ardupilot_healthy.bin", "rb") as fh:
            assert c.post("/api/logs", files={"log": ("a.bin", fh)}).status_code == 403
        with open(SAMPLES / "ardupilot_healthy.bin", "rb") as fh:
            r = c.post("/api/logs", files={"log": ("a.bin", fh)}, headers={"X-CSRF-Token": csrf})
        assert r.status_code == 200
        # with it: the form works (no such airframe yet -> 404, not 403)
        assert c.post("/airframe/rename", data={"key": "k", "name": "n", "csrf": csrf}).status_code == 404


def test_token_file_keeps_hashes_only(tmp_path):
    from flightlog_fd.errors import FlightLogError
    from flightlog_fd.serve.security import TokenSet

    f = tmp_path / "tokens"
    f.write_text("# fleet tokens\n" + TOKEN + "\n\nsecond-token-abcdefghijkl\n")
    ts = TokenSet.from_file(f)
    assert len(ts) == 2 and ts.check(TOKEN) and ts.check("second-token-abcdefghijkl")
    assert not ts.check(TOKEN[:-1]) and not ts.check("") and not ts.check(None)
    assert TOKEN not in repr(vars(ts))
    f.write_text("short\n")
    with pytest.raises(FlightLogError, match="shorter than"):
        TokenSet.from_file(f)


def test_fleet_page_filters_and_sorts(live):
    for n in ("px4_healthy.ulg", "px4_motor4_damaged.ulg"):
        wait_done(live, upload(live, SAMPLES / n).json()["id"])

    def rows(**params):
        text = live.get("/", params=params).text
        body = text[text.index('<table class="fleet"'):text.index("</table>", text.index('<table class="fleet"'))]
        return re.findall(r'<a href="/airframe\?key=([^"]+)">', body)

    assert "sim-11-0" in rows(status="healthy") and "sim-15-0" not in rows(status="healthy")
    # px4_motor4_damaged: rotor 4 lost thrust
    assert "sim-15-0" in rows(status="damaged") and "sim-11-0" not in rows(status="damaged")
    assert rows(q="sim-15") == ["sim-15-0"]
    assert rows(q="px4_healthy") == ["sim-11-0"]  # a file name finds its airframe
    by_name = rows(sort="name")
    assert by_name == sorted(by_name, key=str.lower) and len(by_name) >= 2
    attention = rows()
    assert attention.index("sim-15-0") < attention.index("sim-11-0")  # uncertain before healthy
    assert rows(status="drift") == []


def test_airframe_page_explains_a_drift_where_it_fires(tmp_path):
    with serve_client(tmp_path, workers=0) as c:
        store = c.app_.state.store
        for i, share2 in enumerate((1.00, 1.02, 1.05, 1.09, 1.14)):  # motor 2 needs more command each flight
            fid, _ = store.add_upload(f"{i:064x}", f"flight{i}.ulg", 1, "ulog")
            job = store.claim_job("test")
            shares = [1.0, share2, 1.0 - 0.001 * i, 1.0 + 0.001 * i]
            doc = {"verdict": {"status": "healthy", "motor": None, "confidence": 0.9, "reason": "r"},
                   "motors": [{"motor": k + 1, "command_share": s, "model_vote": 0.1} for k, s in enumerate(shares)]}
            assert store.complete_diagnosis(job, "test", {"sha256": f"{i:064x}", "diagnosis": doc,
                                                          "vehicle": "quad-7", "vehicle_source": "sys_uuid"})
        page = c.get("/airframe", params={"key": "quad-7"}).text
        assert "Drift flagged" in page and "motor 2 command share drifts from the others" in page
        assert "least-squares line of z" in page  # the rule, explained
        fleet = c.get("/", params={"status": "drift"}).text
        assert "quad-7" in fleet


def test_serve_command_bad_input_is_one_line_and_exit_2(tmp_path):
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    runner = CliRunner()
    cases = [(["serve", "--view", "everyone", "--data", str(tmp_path / "d")], "--view must be open or token"),
             (["serve", "--db", str(tmp_path / "missing" / "x.sqlite"), "--data", str(tmp_path / "d")],
              "its folder does not exist"),
             (["serve", "--token-file", str(tmp_path / "nope"), "--data", str(tmp_path / "d")],
              "cannot read the token file")]
    for argv, msg in cases:
        res = runner.invoke(app, argv)
        assert res.exit_code == 2, (argv, res.output)
        assert msg in res.output and "Traceback" not in res.output


def test_internal_errors_are_one_line_with_the_security_headers(tmp_path):
    """An unhandled error is answered outside Starlette's middleware: the handler adds the
    headers itself, and falls back to a plain line when the error page cannot be drawn either."""
    from flightlog_fd.serve.app import SECURITY_HEADERS

    def boom(*a, **k):
        raise RuntimeError("store down")

    with serve_client(tmp_path, workers=0, view="open") as c:
        store = c.app_.state.store
        store.fleet = boom  # the fleet page fails; the error page still renders
        r = c.get("/")
        assert r.status_code == 500 and "internal error: RuntimeError" in r.text
        assert "store down" not in r.text  # no internals to the browser
        for k, v in SECURITY_HEADERS.items():
            assert r.headers.get(k) == v
        store.job_counts = boom  # now the error page itself fails
        r = c.get("/")
        assert r.status_code == 500 and r.text == "internal error: RuntimeError"
        for k, v in SECURITY_HEADERS.items():
            assert r.headers.get(k) == v
