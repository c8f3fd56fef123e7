"""Per-motor evidence: command patterns, the profile baseline, airframe change, and the
effectiveness estimate on simulated flights with a known damaged rotor."""
from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from flightlog_fd.analyzers.share_fit import Baseline, fit_shares
from flightlog_fd.flight import Frame


def segments(shares, throttle=0.5, seconds=60.0, noise=0.01, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.02)
    w = throttle * np.asarray(shares, float)[None, :] * (1 + noise * rng.standard_normal((t.size, 4)))
    return [SimpleNamespace(t=t, w_sq=w, __len__=lambda: t.size)]


def probs_for(motor, n=50):
    p = np.full((n, 5), 0.02)
    p[:, motor] = 0.92
    return p


def test_figures_against_neighbours_and_against_a_profile():
    ev = fit_shares(segments([1.0, 1.4, 1.0, 1.0]), probs_for(2), Frame.quad_x())
    assert ev.baseline == "neighbours" and int(np.argmax([m.command_change for m in ev.motors])) == 1
    assert ev.motors[1].model_vote > 0.9 and ev.motors[1].position == "rear-left"
    assert ev.throttle_ratio is None
    base = Baseline(share=np.array([0.95, 1.08, 0.92, 1.05]), slope=np.zeros(4), throttle_ref=0.5)
    same = fit_shares(segments(base.share), probs_for(0), Frame.quad_x(), baseline=base)
    assert same.baseline == "profile" and max(abs(m.command_change) for m in same.motors) < 0.01
    assert same.throttle_ratio == pytest.approx(1.0, abs=0.01)
    harder = base.share * np.array([1.0, 1.0, 1.1, 1.0])
    one = fit_shares(segments(harder), probs_for(3), Frame.quad_x(), baseline=base)
    assert one.motors[2].command_change > 0.05


def test_onset_uses_the_flight_before_it_as_baseline():
    segs = segments([0.95, 1.08, 0.92, 1.05])
    seg = segs[0]
    after = seg.t >= 30.0
    seg.w_sq[after, 2] *= 1.12
    ev = fit_shares(segs, probs_for(3), Frame.quad_x(), since=30.0)
    assert ev.baseline == "before onset"
    assert ev.motors[2].command_change == pytest.approx(0.12 * 0.92 / 1.0, abs=0.03)


@pytest.mark.parametrize("motor, eta", [(3, 0.7), (1, 0.8)])
def test_effectiveness_recovers_a_damaged_rotor_in_simulation(motor, eta):
    """Measured by benchmarks/bench_effectiveness.py: rmse ~0.05 at the high-rate profile; here a
    tolerance of 0.1 and the damaged rotor must be the weakest."""
    from flightlog_fd.analyzers.effectiveness_fit import estimate_effectiveness
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    fl = simulate_flights(1, damages=[Damage(motor, eta)], duration_s=45, profile="px4_high", seed=7)[0]
    est = estimate_effectiveness(fl)
    assert est.weakest() == motor
    assert est.values[motor - 1] == pytest.approx(eta, abs=0.1)
    lo, hi = est.motors[motor - 1].ci
    assert lo <= est.values[motor - 1] <= hi


def test_effectiveness_says_when_there_is_too_little_data():
    from flightlog_fd.analyzers.effectiveness_fit import estimate_effectiveness
    from flightlog_fd.sim.api import simulate_flights

    fl = simulate_flights(1, duration_s=12, profile="px4_high", seed=3)[0]
    (a, _), = fl.airborne
    est = estimate_effectiveness(dataclasses.replace(fl, airborne=[(a, a + 14.0)]))  # 8 s after the edge trims
    assert not est.informative and "only 8 s" in est.reason


@pytest.mark.parametrize("motor, eta", [(2, 0.7), (4, 0.9)])
def test_effectiveness_is_exact_without_disturbances(motor, eta):
    """Noiseless simulation (no turbulence, noise or wind): with the ground seconds out, the motor
    lag found and the body-rate torques fitted, the estimate is η (before those fixes η 0.7 read
    0.60 and 0.9 read 0.83 on such flights; the SIH airframe now reads 0.713 and 0.908)."""
    from flightlog_fd.analyzers.effectiveness_fit import estimate_effectiveness
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    fl = simulate_flights(1, damages=[Damage(motor, eta)], duration_s=45, profile="px4_high", seed=7,
                          airframes="sih", realism=False)[0]
    est = estimate_effectiveness(fl)
    assert est.values[motor - 1] == pytest.approx(eta, abs=0.03)
    others = np.delete(est.values, motor - 1)
    assert np.all(np.abs(others - 1.0) < 0.03)


def test_accelerometer_round_trip(tmp_path):
    """The simulator's accelerometer reads about -g along body z in flight and survives both log
    writers and readers."""
    from flightlog_fd.logs import load_flight
    from flightlog_fd.logs.dataflash_writer import write_dataflash
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    for profile, write, name in (("px4_high", write_ulog, "a.ulg"), ("ardupilot", write_dataflash, "a.bin")):
        fl = simulate_flights(1, damages=[Damage(3, 0.8)], duration_s=30, profile=profile, seed=5)[0]
        acc = fl.accel
        (a, b), = fl.airborne
        air = (acc.t > a + 3) & (acc.t < b - 3)
        assert np.median(acc.values[air, 2]) == pytest.approx(-9.8, abs=1.0)
        back = load_flight(write(fl, tmp_path / name))
        assert back.accel is not None and len(back.accel) == len(acc)
        np.testing.assert_allclose(back.accel.values, acc.values, atol=1e-4)


def test_lag_search_subset_spreads_its_chunks_and_keeps_short_flights_whole():
    from flightlog_fd.analyzers.effectiveness_fit import _lag_search_segments
    from flightlog_fd.streams import Segment

    def seg(t0, seconds, hz=50.0):
        t = t0 + np.arange(int(seconds * hz)) / hz
        z = np.zeros((t.size, 4))
        return Segment(t=t, rates=z[:, :3], attitude=z[:, :2], motors=z, w_sq=z, ang_acc=z[:, :3])

    short = [seg(0.0, 50.0), seg(60.0, 40.0)]
    assert _lag_search_segments(short, max_s=120.0, chunk_s=15.0) is short
    long = [seg(0.0, 300.0), seg(400.0, 200.0)]
    chunks = _lag_search_segments(long, max_s=120.0, chunk_s=15.0)
    assert len(chunks) == 8
    assert sum(c.duration_s for c in chunks) <= 120.0
    for c in chunks:  # each inside one segment
        assert any(s.t[0] <= c.t[0] and c.t[-1] <= s.t[-1] for s in long)
    starts = [c.t[0] for c in chunks]
    assert starts == sorted(starts) and starts[0] < 40.0 and starts[-1] > 540.0  # the whole flight


def test_lag_from_the_subset_matches_the_whole_flight(monkeypatch):
    """A 200 s flight (over LAG_SEARCH_MAX_S): the lag found on the chunks is the whole flight's
    within 6 ms and the values within 0.02 (the shared logs moved by at most 0.010)."""
    import flightlog_fd.analyzers.effectiveness_fit as E
    from flightlog_fd.sim.api import simulate_flights
    from flightlog_fd.sim.damage import Damage

    fl = simulate_flights(1, damages=[Damage(2, 0.75)], duration_s=200, profile="px4_high", seed=11)[0]
    sub = E.estimate_effectiveness(fl)
    assert sub.seconds > E.LAG_SEARCH_MAX_S
    monkeypatch.setattr(E, "LAG_SEARCH_MAX_S", float("inf"))
    whole = E.estimate_effectiveness(fl)
    assert abs(sub.motor_lag_s - whole.motor_lag_s) <= 0.006
    assert np.max(np.abs(sub.values - whole.values)) < 0.02
    assert sub.weakest() == whole.weakest() == 2


def test_diagnose_runs_blas_single_threaded(monkeypatch):
    """diagnose_flight limits BLAS to DIAGNOSE_BLAS_THREADS while it runs, and restores it after."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    import flightlog_fd.diagnose as D

    seen = []
    real = D._diagnose_flight

    def spy(*a, **k):
        seen.append({i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"})
        return real(*a, **k)

    monkeypatch.setattr(D, "_diagnose_flight", spy)
    from flightlog_fd.sim.api import simulate_flights

    fl = simulate_flights(1, duration_s=20, profile="px4_high", seed=2)[0]
    before = {i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"}
    D.diagnose_flight(fl, D.resolve_model(), keep_flight=False)
    assert seen == [{D.DIAGNOSE_BLAS_THREADS}]
    assert {i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"} == before


def test_lag_search_on_many_short_segments():
    """A long flight cut into 0.2 s pieces (gaps): the search's stretches, clipped by their piece,
    are filtered like any segment, and the estimate still comes out."""
    import flightlog_fd.analyzers.effectiveness_fit as E
    from flightlog_fd.prepared import resample
    from flightlog_fd.prepared import PreparedFlight
    from flightlog_fd.sim.api import simulate_flights

    fl = simulate_flights(1, duration_s=200, profile="px4_high", seed=3)[0]
    prep = PreparedFlight(fl)
    pieces = [E._slice_segment(s, slice(a, a + 10)) for s in resample(prep) for a in range(0, len(s) - 10, 11)]
    est = E.estimate_effectiveness(prep, segments=pieces)
    assert est.seconds > E.LAG_SEARCH_MAX_S and est.motor_lag_s is not None and len(est.motors) == 4


def test_pin_spread_sees_a_flight_whose_shares_wander():
    from flightlog_fd.analyzers.share_fit import pin_spread

    rng = np.random.default_rng(3)
    steady = 0.5 + 0.01 * rng.standard_normal((3000, 4))
    assert np.all(pin_spread([steady]) < 0.01)
    wander = steady.copy()
    wander[:, 0] *= np.linspace(0.8, 1.2, len(wander))  # motor 1 works ever harder
    p = pin_spread([wander])
    assert p[0] > 0.05 and p[0] == max(p)
    assert pin_spread([steady[:100]]) is None  # 2 s: nothing to compare


def test_baseline_slope_is_not_extrapolated_beyond_the_calibrated_throttle():
    b = Baseline(share=np.ones(4), slope=np.array([1.0, -1.0, 0.0, 0.0]), throttle_ref=0.5,
                 throttle_range=(0.45, 0.55))
    assert np.allclose(b.share_at(1.5), b.share_at(0.55))
    assert not np.allclose(b.share_at(0.5), b.share_at(0.55))


def test_profile_records_how_well_its_flights_pin_the_shares(tmp_path):
    from pathlib import Path

    from flightlog_fd.calibration import calibrate_profile
    from flightlog_fd.profile import Profile

    sample = Path(__file__).resolve().parents[1] / "sample_logs" / "px4_healthy.ulg"
    prof = calibrate_profile([sample])
    pin = prof.baseline_["pin"]
    assert pin is not None and len(pin) == 4 and all(0 <= x < 0.2 for x in pin)
    prof.save(tmp_path / "p.json")
    assert np.allclose(Profile.load(tmp_path / "p.json").baseline().pin, pin)
