"""A logger that drops messages under load (ArduPilot fast logging) leaves holes of a few samples
in its fast streams: they must not split the airborne grid, a real data gap still must, and
`fdlog info` (checks.diagnosability) and `fdlog diagnose` agree on whether a log can be judged."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flightlog_fd.checks import diagnosability
from flightlog_fd.flight import Series
from flightlog_fd.prepared import resample
from flightlog_fd.streams import GAP_FACTOR


@pytest.fixture(scope="module")
def fast_flight():
    """A 45 s simulated ArduCopter flight logged at 400 Hz (IMU and RATE)."""
    from flightlog_fd.sim.api import simulate_flights

    return simulate_flights(1, duration_s=45, profile="ardupilot_fast", seed=11, damages=[None])[0]


def _drop(series: Series, keep: np.ndarray) -> Series:
    return replace(series, t=series.t[keep], values=series.values[keep])


def _bursts(n: int, rng: np.random.Generator, share: float, longest: int) -> np.ndarray:
    """Keep-mask of n samples losing ``share`` of them in bursts of 1..``longest`` samples."""
    keep = np.ones(n, dtype=bool)
    i = 0
    while i < n:
        i += int(rng.geometric(share * 2 / (longest + 1)))
        k = int(rng.integers(1, longest + 1))
        keep[i:i + k] = False
        i += k
    return keep


def _dropped(flight, rng, share, longest):
    """The flight with each fast stream losing its own bursts (the logger drops per message)."""
    rates = _drop(flight.rates, _bursts(len(flight.rates), rng, share, longest))
    motors = _drop(flight.motors, _bursts(len(flight.motors), rng, share, longest))
    return replace(flight, rates=rates, motors=motors, accel=None)


def test_dropped_bursts_do_not_split_the_grid(fast_flight):
    """ArduCopter 4.7 SITL healthy_fastlog.BIN lost 3 % of its 400 Hz IMU samples in holes of up to
    16 (40 ms); here 3 % in bursts of up to 16 samples: still one segment per airborne interval,
    as long as the whole flight's."""
    whole = resample(fast_flight)
    holed = _dropped(fast_flight, np.random.default_rng(1), 0.03, 16)
    dt = np.diff(holed.rates.t)
    assert np.sum(dt > GAP_FACTOR * np.median(dt)) > 50  # holes beyond the stream's own threshold
    segs = resample(holed)
    assert len(segs) == len(whole) == 1
    assert abs(segs[0].duration_s - whole[0].duration_s) < 0.1
    assert diagnosability(holed).ok


def test_a_real_gap_still_splits_and_info_agrees_with_diagnose(fast_flight):
    """Holes longer than a few grid steps are gaps: a log whose every 1.2 s loses 150 ms of rates
    holds no 1.6 s window; `fdlog info`'s check says so with the diagnosis's own reason."""
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    t = fast_flight.rates.t
    keep = ((t - t[0]) % 1.2) < 1.05
    holed = replace(fast_flight, rates=_drop(fast_flight.rates, keep), accel=None)
    check = diagnosability(holed)
    assert not check.ok and "the longest usable stretch is 1.0 s" in check.reason, check.reason
    d = diagnose_flight(holed, resolve_model(), keep_flight=False)
    assert d.verdict.status == "not_diagnosable" and "the longest usable stretch is 1.0 s" in d.verdict.reason
