"""Small helpers shared by the readers, the model and the profile."""
from __future__ import annotations

import hashlib
import os
from typing import Union

PathLike = Union[str, "os.PathLike[str]"]


def file_sha256(path: PathLike) -> str:
    """Hex SHA-256 of a file's bytes (profiles pin their source logs and model with it)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def intersect_intervals(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The non-empty overlaps of two lists of (start, end) intervals, sorted."""
    out = []
    for a0, a1 in a:
        for b0, b1 in b:
            lo, hi = max(a0, b0), min(a1, b1)
            if hi > lo:
                out.append((lo, hi))
    return sorted(out)


_BLAS_CONTROLLER = None
_BLAS_MODULES_SEEN = -1  # len(sys.modules) when the controller was made


def blas_threads(n: int):
    """A context that runs NumPy's (and, once loaded, SciPy's) BLAS with at most ``n`` threads
    (threadpoolctl), or does nothing when threadpoolctl is not installed. A controller limits only
    the BLAS libraries loaded when it is made, so it is made on first use and again whenever
    modules were imported since (``scipy.linalg``, torch and scikit-learn bring their own BLAS: a
    server or a calibration that loads them after the first diagnosis would otherwise run them
    unlimited)."""
    global _BLAS_CONTROLLER, _BLAS_MODULES_SEEN
    import contextlib
    import sys

    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return contextlib.nullcontext()
    if _BLAS_CONTROLLER is None or len(sys.modules) != _BLAS_MODULES_SEEN:
        _BLAS_CONTROLLER, _BLAS_MODULES_SEEN = ThreadpoolController(), len(sys.modules)
    return _BLAS_CONTROLLER.limit(limits=n, user_api="blas")
