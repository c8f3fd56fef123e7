"""Vibration drawn for people (issue 23): the HTML report and the web flight page show the level
over time per IMU with the healthy reference, and the gyro spectrum with the rotor rates marked,
for a simulated propeller imbalance (`fdlog simulate --imbalance`, 1 kHz IMU, ESC rpm) and for a
sample log."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from flightlog_fd import load_flight
from flightlog_fd.analyzers.vibration import LINE_MIN_HZ
from flightlog_fd.cli import app
from flightlog_fd.report.vibration_view import vibration_plot

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


@pytest.fixture(scope="module")
def imbalance_log(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("vib") / "imb.BIN"
    res = runner.invoke(app, ["simulate", "--airframe", "f450", "--format", "dataflash", "--imbalance", "1:40",
                              "--imu-rate", "1000", "--esc-rate", "50", "--seed", "3", "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_spectrum_peak_sits_on_the_unbalanced_rotor_mark(imbalance_log):
    vp = vibration_plot(load_flight(imbalance_log))
    assert vp is not None and vp.series and vp.unit == "m/s/s"
    assert [lab for _, lab in vp.marks] == [f"motor {k} rotor rate (ESC rpm)" for k in (1, 2, 3, 4)]
    band = vp.freq_hz >= LINE_MIN_HZ
    i = int(np.argmax(np.where(band, vp.power_db, -np.inf)))
    m1 = vp.marks[0][0]
    assert vp.power_db[i] > 10.0 and abs(vp.freq_hz[i] - m1) / m1 < 0.03  # once per revolution of motor 1


def _svgs_after(page: str, heading: str) -> list[str]:
    return re.findall(r"<svg.*?</svg>", page[page.index(heading):], re.S)


def test_html_report_draws_level_reference_and_spectrum(imbalance_log, tmp_path):
    out = tmp_path / "r.html"
    res = runner.invoke(app, ["diagnose", str(imbalance_log), "--html", str(out)])
    assert res.exit_code in (0, 1), res.output
    page = out.read_text()
    level, spec = _svgs_after(page, "<h3>Vibration</h3>")[:2]
    assert "Vibration level per IMU (m/s/s)" in level and "healthy reference" in level
    assert 'stroke-dasharray="5,3"' in level  # the reference is drawn dashed
    assert "Gyro spectrum (airborne)" in spec and ">Hz<" in spec and spec.count("stroke-dasharray") == 4
    assert "motor 1 rotor rate (ESC rpm)" in page and "<script" not in page


def test_sample_log_html_and_web_flight_page(tmp_path):
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client, upload, wait_done

    log = ROOT / "sample_logs" / "px4_octo_healthy.ulg"
    out = tmp_path / "s.html"
    assert runner.invoke(app, ["diagnose", str(log), "--html", str(out)]).exit_code in (0, 1)
    page = out.read_text()
    assert "Vibration level per IMU" in page and "Gyro spectrum (airborne)" in page
    data = tmp_path / "data"
    data.mkdir()
    with serve_client(data, workers=1) as c:
        fid = upload(c, log).json()["id"]
        wait_done(c, fid)
        html = c.get(f"/flights/{fid}").text
    assert 'id="vibplot"' in html and 'id="specplot"' in html and "plotly" in html
    plot = json.loads(re.search(r'<script type="application/json" id="plot-data">(.*?)</script>', html, re.S).group(1))
    vib = plot["plot"]["vibration"]
    assert vib["series"] and vib["series"][0]["t"] and vib["spectrum"]["f"] and len(vib["spectrum"]["f"]) == len(vib["spectrum"]["db"])
