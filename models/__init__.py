"""The shipped default ONNX model (installed as package ``flightlog_fd.models``)."""
from pathlib import Path

DEFAULT_MODEL = Path(__file__).with_name("default.onnx")
