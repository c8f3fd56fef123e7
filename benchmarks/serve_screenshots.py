"""Screenshots of the three `fdlog serve` pages (fleet, airframe, flight) and of an HTML report into results/, by headless Chromium.

What: starts `fdlog serve` on loopback with the sample logs plus a small simulated history of one
airframe ("x500-demo": 5 flights of the same id, propeller 3 losing thrust a little more each
flight, eta 1.00 -> 0.80, so the airframe page has trends and, when the rule fires, a drift
flag), waits for every diagnosis, signs in and saves results/serve_fleet.png,
results/serve_airframe.png, results/serve_flight.png, then writes `fdlog diagnose --html` of
HTML_REPORT_LOG and saves results/html_report.png (the guide, docs/, shows them). Needs chromium + chromedriver (apt) and
the [serve] extra. About a minute on 2 cores.

    .venv/bin/python benchmarks/serve_screenshots.py [--out results]
"""
from __future__ import annotations

import argparse
import base64
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOKEN = "screenshot-token-0123456789"
#: The demo airframe's flights: propeller 3 efficiency per flight (1 = healthy).
DRIFT_ETAS = (1.0, 0.96, 0.92, 0.86, 0.80)
#: Tallest screenshot kept (px): whole pages, but bounded.
MAX_SHOT_PX = 3000
#: The sample log whose HTML report the guide shows (a damaged propeller: every part of the page drawn).
HTML_REPORT_LOG = ROOT / "sample_logs" / "px4_motor1_damaged.ulg"
FLIGHT_S = 30.0  # simulated flight length (s): short, still well over the 20 s a diagnosis needs


def demo_history(out: Path) -> list[Path]:
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    paths = []
    for i, eta in enumerate(DRIFT_ETAS):
        dmg = Damage(3, eta) if eta < 1 else Damage()
        fl = simulate_flights(1, airframes=[preset("x500", None)], damages=[dmg], duration_s=FLIGHT_S,
                              profile="px4_high", seed=100 + i)[0]
        fl.vehicle_id = "x500-demo"
        p = out / f"x500_demo_flight{i + 1}.ulg"
        fl.path = str(p)
        write_ulog(fl, p)
        paths.append(p)
    return paths


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def get_json(url: str) -> dict:
    import json

    return json.loads(urllib.request.urlopen(url, timeout=5).read())


def capture(drv, out: Path) -> None:
    """The whole page (at most MAX_SHOT_PX tall) as a PNG at ``out``."""
    h = int(drv.execute_script("return document.documentElement.scrollHeight"))
    shot = drv.execute_cdp_cmd("Page.captureScreenshot", {
        "format": "png", "captureBeyondViewport": True,
        "clip": {"x": 0, "y": 0, "width": 1360, "height": min(h, MAX_SHOT_PX), "scale": 1}})
    out.write_bytes(base64.b64decode(shot["data"]))
    print(f"wrote {out}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results")
    args = ap.parse_args()
    chromium, driver_bin = shutil.which("chromium"), shutil.which("chromedriver")
    if not (chromium and driver_bin):
        print("skipped: needs chromium and chromedriver (apt-get install chromium chromium-driver)")
        return
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    work = Path(tempfile.mkdtemp(prefix="fdlog-shots-"))
    logs = demo_history(work)
    n_samples = sum(1 for p in (ROOT / "sample_logs").iterdir() if p.suffix in (".ulg", ".bin"))
    (work / "tokens").write_text(TOKEN + "\n")
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    # the history first, in flight order, so it is uploaded (and listed) in time order
    server = subprocess.Popen([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "serve",
                               *map(str, logs), str(ROOT / "sample_logs"), "--data", str(work / "data"),
                               "--port", str(port), "--token-file", str(work / "tokens"), "--workers", "2"],
                              env={**os.environ, "OMP_NUM_THREADS": "1"}, stderr=subprocess.DEVNULL)
    profile = tempfile.mkdtemp(prefix="fdlog-chrome-")
    drv = None
    try:
        end = time.monotonic() + 300
        while time.monotonic() < end:
            try:
                jobs = get_json(base + "/api/health")["jobs"]
                if jobs["queued"] == 0 and jobs["running"] == 0 and jobs["done"] + jobs["error"] >= len(logs) + n_samples:
                    break
            except OSError:
                pass
            time.sleep(1)
        opts = Options()
        opts.binary_location = chromium
        for f in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars", "--window-size=1360,900", f"--user-data-dir={profile}"):
            opts.add_argument(f)
        drv = webdriver.Chrome(service=Service(executable_path=driver_bin), options=opts)
        drv.get(base + "/login")
        drv.find_element(By.ID, "token").send_keys(TOKEN)
        drv.find_element(By.ID, "signin").click()
        flights = get_json(base + "/api/logs")["logs"]
        last_demo = max(f["id"] for f in flights if f["name"].startswith("x500_demo"))
        args.out.mkdir(parents=True, exist_ok=True)
        for name, url in (("fleet", "/"), ("airframe", "/airframe?key=x500-demo"), ("flight", f"/flights/{last_demo}")):
            drv.get(base + url)
            time.sleep(2.5)  # plotly draws after load
            capture(drv, args.out / f"serve_{name}.png")
        report = work / "report.html"
        subprocess.run([sys.executable, "-c", "from flightlog_fd.cli import main; main()", "diagnose", "--html",
                        str(report), str(HTML_REPORT_LOG.relative_to(ROOT))], stdout=subprocess.DEVNULL, cwd=ROOT)
        drv.get(report.as_uri())
        time.sleep(1.0)
        capture(drv, args.out / "html_report.png")
    finally:
        if drv is not None:
            drv.quit()
        server.terminate()
        server.wait(30)
        shutil.rmtree(profile, ignore_errors=True)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
