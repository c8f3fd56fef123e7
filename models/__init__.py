"""The shipped ONNX models (installed as package ``flightlog_fd.models``): one per rotor count."""
from pathlib import Path

DEFAULT_MODEL = Path(__file__).with_name("default.onnx")
#: Shipped model file per rotor count (quad: DEFAULT_MODEL; hexa and octo: training/build_default.py --rotors n).
MODEL_FILES = {4: "default.onnx", 6: "default_hexa.onnx", 8: "default_octo.onnx"}


def model_for_rotors(n: int) -> Path:
    """Path of the shipped model for ``n`` rotors (DEFAULT_MODEL for 4); KeyError if none is made for n."""
    return DEFAULT_MODEL if n == 4 else Path(__file__).with_name(MODEL_FILES[n])
