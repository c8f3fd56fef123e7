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


def blas_threads(n: int):
    """A context that runs NumPy/SciPy's BLAS with at most ``n`` threads (threadpoolctl), or does
    nothing when threadpoolctl is not installed. The controller is made once per process, on
    first use, after loading scipy.linalg: it limits only the BLAS libraries loaded when it is
    made, and a first diagnosis that ends before scipy's BLAS loads (a log that cannot be judged)
    would otherwise leave that BLAS unlimited for the rest of the process."""
    global _BLAS_CONTROLLER
    import contextlib

    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return contextlib.nullcontext()
    if _BLAS_CONTROLLER is None:
        import scipy.linalg  # noqa: F401  (loads scipy's BLAS before the controller looks)

        _BLAS_CONTROLLER = ThreadpoolController()
    return _BLAS_CONTROLLER.limit(limits=n, user_api="blas")
