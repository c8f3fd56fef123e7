"""Test-only: a diagnosis that takes long enough to be interrupted.

`tests/test_watch.py` puts this folder on ``PYTHONPATH`` of the `fdlog watch` it starts, with
``FDLOG_TEST_SLOW_NAME`` set; every Python process of that watcher (its spawned worker too) then
sleeps ``FDLOG_TEST_SLOW_S`` seconds before diagnosing a file whose name starts with it. The test
kills the watcher in that sleep, so "killed mid-diagnosis" does not depend on how fast the machine
diagnoses (the sample's diagnosis alone can end between two polls of the store).
"""
import os

_PREFIX = os.environ.get("FDLOG_TEST_SLOW_NAME")

if _PREFIX:
    import functools
    import time

    import flightlog_fd.batch as _batch

    _diagnose_one = _batch.diagnose_one

    @functools.wraps(_diagnose_one)
    def _slow_diagnose_one(index, path, *args, **kwargs):
        if os.path.basename(str(path)).startswith(_PREFIX):
            time.sleep(float(os.environ.get("FDLOG_TEST_SLOW_S", "30")))
        return _diagnose_one(index, path, *args, **kwargs)

    _batch.diagnose_one = _slow_diagnose_one
