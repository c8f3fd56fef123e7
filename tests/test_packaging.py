"""The installed distribution puts nothing at the top of site-packages except ``flightlog_fd``."""
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_wheel_has_only_flightlog_fd_at_top(tmp_path):
    # --no-build-isolation: the venv already has setuptools; no registry needed.
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                        "-q", "-w", str(tmp_path), str(ROOT)], capture_output=True, text=True)
    if r.returncode != 0 and "No module named" in r.stderr and "setuptools" in r.stderr:
        pytest.skip("setuptools is not installed in this environment")
    assert r.returncode == 0, r.stderr
    wheels = list(tmp_path.glob("flightlog_fd-*.whl"))
    assert len(wheels) == 1
    names = zipfile.ZipFile(wheels[0]).namelist()
    top = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert top == {"flightlog_fd"}
    # training and the shipped model travel inside the namespace
    assert "flightlog_fd/training/dcnn.py" in names
    assert "flightlog_fd/models/default.onnx" in names
    assert {"flightlog_fd/models/default_hexa.onnx", "flightlog_fd/models/default_octo.onnx"} <= set(names)
    # `fdlog serve`'s templates and static files are package data
    assert "flightlog_fd/serve/templates/flight.html" in names
    assert "flightlog_fd/serve/static/plots.js" in names
