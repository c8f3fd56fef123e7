"""ESC analyzer on simulated flights: damaged motor named, healthy and trim-changed flights quiet,
abstention when the telemetry cannot say, and the same findings after a ULog / DataFlash round trip."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flightlog_fd.analyzers.esc import (DECISION_LLR, EscBaseline, analyze_esc, fit_esc_baseline,
                                        measure_esc)
from flightlog_fd.flight import EscChannel, EscTelemetry
from flightlog_fd.logs import load_flight
from flightlog_fd.logs.dataflash_writer import write_dataflash
from flightlog_fd.logs.ulog_writer import write_ulog
from flightlog_fd.sim.airframe import preset
from flightlog_fd.sim.api import simulate_flights
from flightlog_fd.sim.damage import Damage
from flightlog_fd.sim.esc import random_esc_params
from flightlog_fd.sim.imbalance import AirframeImbalance


@pytest.fixture(scope="module")
def same_airframe():
    """One x500 with its own imbalance, motors and ESCs flown three times: healthy, healthy with
    the CoG moved 8 % of the arm and a yaw trim (tilt +0.8 deg), and with propeller 3 at eta 0.75."""
    af = preset("x500")
    rng = np.random.default_rng(5)
    esc = random_esc_params(af, rng, 20.0)
    imb = AirframeImbalance(cog_offset=(0.03, -0.02), motor_tilt_rad=tuple(np.radians([0.3, -0.2, 0.1, 0.4])),
                            thrust_scale=(1.02, 0.98, 1.01, 0.99), torque_scale=(0.98, 1.02, 1.0, 1.01))
    moved = replace(imb, cog_offset=(0.09, 0.03), motor_tilt_rad=tuple(t + np.radians(0.8) for t in imb.motor_tilt_rad))
    kw = dict(airframes=[af] * 3, duration_s=45.0, profile="px4_default", esc=[esc] * 3, healthy_fraction=0.0)
    return simulate_flights(3, damages=[Damage(), Damage(), Damage(3, 0.75, None, 0.75 ** 1.3)],
                            imbalance=[imb, moved, imb], seed=41, **kw)


def test_damaged_motor_named_with_its_signature(same_airframe):
    healthy, trimmed, damaged = same_airframe
    a = analyze_esc(damaged)
    assert a.abstain is None and a.bins >= 30
    assert a.motor_named() == 3
    by = {(f.motor, f.name): f for f in a.findings}
    assert by[(3, "rpm_per_command")].value > 0.5 and by[(3, "rpm_per_command")].direction == "up"
    assert by[(3, "current_per_rpm2")].value < -15 and by[(3, "current_per_rpm2")].direction == "down"
    lo, hi = by[(3, "current_per_rpm2")].interval
    assert lo < by[(3, "current_per_rpm2")].value < hi
    assert a.llr[3] > DECISION_LLR and max(v for k, v in a.llr.items() if k != 3) < 1.0
    # torque loss estimated near 1 - 0.75**1.3 = 31 %
    assert 20 < by[(3, "esc_damage")].value < 45


def test_healthy_and_trim_changed_flights_stay_quiet(same_airframe):
    healthy, trimmed, damaged = same_airframe
    for f in (healthy, trimmed):
        a = analyze_esc(f)
        assert a.abstain is None and a.motor_named() is None and max(a.llr.values()) < DECISION_LLR / 2
    base = fit_esc_baseline([healthy])
    at = analyze_esc(trimmed, base)
    assert at.against == "profile" and at.motor_named() is None
    # the trim change moved the command shares but not the ESC relations
    mh, mt = measure_esc(healthy)[0], measure_esc(trimmed)[0]
    share = lambda f: f.motors.between(*f.airborne[0]).values.mean(axis=0)
    assert np.max(np.abs(share(trimmed) / share(healthy) - 1)) > 0.04
    # each motor's rpm level moves only within what the fitted exponents' uncertainty allows at the
    # distance its command moved from the others' (its lever); current per rpm² barely at all
    slope_room = 2 * np.hypot(mh.slope_sd[0], mt.slope_sd[0]) * np.abs(mt.lever[:, 0] - mh.lever[:, 0])
    assert np.all(np.abs(mt.r[:, 0] - mh.r[:, 0]) < 0.012 + slope_room)
    assert np.max(np.abs(mt.r[:, 1] - mh.r[:, 1])) < 0.015
    ad = analyze_esc(damaged, base)
    assert ad.motor_named() == 3 and ad.llr[3] > analyze_esc(damaged).llr[3]
    assert EscBaseline.from_dict(base.to_dict()) == base
    assert base.slopes is not None and len(base.levers) == 4
    # a profile from before the rpm curve (offsets at b = 1, no slopes) is not used, and says so
    old = EscBaseline(base.offsets, base.cov, base.flights, base.has_current)
    ao = analyze_esc(damaged, EscBaseline.from_dict({k: v for k, v in old.to_dict().items()
                                                     if k not in ("slopes", "levers")}))
    assert ao.against.startswith("other motors (the profile's ESC baseline predates") and ao.motor_named() == 3


@pytest.mark.parametrize("fmt", ["ulog", "dataflash"])
def test_same_findings_after_writing_and_reading(same_airframe, tmp_path, fmt):
    damaged = same_airframe[2]
    p = tmp_path / ("d.ulg" if fmt == "ulog" else "d.bin")
    (write_ulog if fmt == "ulog" else write_dataflash)(damaged, p)
    g = load_flight(p)
    a, b = analyze_esc(damaged), analyze_esc(g)
    assert b.motor_named() == 3
    for fa, fb in zip(a.findings, b.findings):
        assert (fa.motor, fa.name) == (fb.motor, fb.name)
        # the reader's airborne time may differ by a few bins, which moves the rpm curve's fitted
        # exponent within its uncertainty: figures agree within their own 90 % half-interval
        lo, hi = fa.interval
        room = 1.0 if not np.isfinite(hi - lo) else max(0.15, 0.5 * (hi - lo))  # esc_damage: shown to 1 %
        assert abs(fb.value - fa.value) <= room, (fa, fb)


def _with_esc(flight, channels):
    return replace(flight, esc=EscTelemetry(channels, flight.esc.source, flight.esc.units))


def test_abstains_and_says_why(same_airframe):
    f = same_airframe[0]
    assert "no ESC telemetry in this log" == analyze_esc(replace(f, esc=None)).abstain
    a = analyze_esc(_with_esc(f, f.esc.channels[:3]))
    assert "motor(s) 4" in a.abstain and a.motor_named() is None and all(x.abstain for x in a.findings)
    slow = [EscChannel(c.motor, c.t[::25], c.rpm[::25], c.current[::25], esc_index=c.esc_index) for c in f.esc.channels]
    assert "too slow" in analyze_esc(_with_esc(f, slow)).abstain
    # ESC 2 offline for all but 10 s of the flight: too few bins with every ESC reporting
    c2 = f.esc.channel(2)
    on = (c2.t > f.airborne[0][0] + 5) & (c2.t < f.airborne[0][0] + 15)
    chans = [c if c.motor != 2 else replace(c, online=on) for c in f.esc.channels]
    assert "every ESC reporting" in analyze_esc(_with_esc(f, chans)).abstain


def test_rpm_only_telemetry_still_scores(same_airframe):
    damaged = same_airframe[2]
    chans = [replace(c, current=None) for c in damaged.esc.channels]
    a = analyze_esc(_with_esc(damaged, chans))
    assert a.abstain is None and "log_rpm_per_log_sqrt_command" in a.slopes and "log_current_per_log_rpm2" not in a.slopes
    cur = [x for x in a.findings if x.name == "current_per_rpm2"]
    assert all(np.isnan(x.value) and x.abstain == "no current telemetry" for x in cur)
    # the rpm lift alone (about 2 % here) is weak evidence, and on this short flight whose commands
    # barely vary the rotors' curve is uncertain (exponent ± 0.26) where rotor 3's command sits 18 %
    # above the others': it names nothing, and it does not mistake rotor 3 for a weak motor or ESC
    assert a.motor_named() is None
    assert a.cause_ll[3]["motor_or_esc"] < 0 and a.cause_ll[3]["propeller"] > a.cause_ll[3]["motor_or_esc"]


@pytest.mark.parametrize("name,motor", [("px4_esc_motor2_damaged.ulg", 2), ("ardupilot_esc_motor3_damaged.bin", 3)])
def test_sample_logs_with_esc_telemetry(name, motor):
    from pathlib import Path

    f = load_flight(Path(__file__).resolve().parents[1] / "sample_logs" / name)
    assert f.esc is not None and f.esc.motors == [1, 2, 3, 4] and set(f.esc.quantities()) == {
        "rpm", "current", "voltage", "temperature"}
    a = analyze_esc(f)
    assert a.motor_named() == motor, a.llr
    # the decision's figure: strong for the damaged motor, negative (clearing) for the others
    assert a.decision_llr[motor] > 6.0
    assert all(v < 0.0 for k, v in a.decision_llr.items() if k != motor), a.decision_llr


def test_decision_llr_is_a_bayes_factor_over_the_damage_prior():
    """Exactly healthy relations give about -3.2 nats for a propeller (the prior's share of
    invisible losses); the further along the damage direction, the larger; always below the
    maximised GLR. The lost-rotor figure the decision sums weighs the three causes by their prior,
    so it never falls below log P(wash): the ESC cannot clear a loss it cannot see."""
    from flightlog_fd.analyzers.esc import (DAMAGE_DIRECTION, HEALTHY_SPREAD_COV, _glr, _log_bayes_factor,
                                            damage_prior_losses)

    losses, cov, mu = damage_prior_losses(), np.array(HEALTHY_SPREAD_COV), np.array(DAMAGE_DIRECTION)
    assert losses.min() > 0 and losses.max() < 1.6
    values = [_log_bayes_factor(l * mu, cov, mu, losses) for l in (0.0, 0.05, 0.1, 0.2, 0.4)]
    assert -3.5 < values[0] < -2.5
    assert values == sorted(values) and values[-1] > 50
    for l, v in zip((0.0, 0.05, 0.1, 0.2, 0.4), values):
        assert v <= _glr(l * mu, cov, mu)[0]
    assert _log_bayes_factor(-0.1 * mu, cov, mu, losses) < values[0]  # opposite to damage: clears more
    from flightlog_fd.analyzers.base import CAUSE_PRIOR
    from flightlog_fd.analyzers.esc import _log_mean_exp, _mixture, cause_log_ratios

    by = cause_log_ratios(np.zeros(2), cov, [0, 1])
    assert set(by) == {"propeller", "motor_or_esc", "wash"} and np.all(by["wash"] == 0)
    healthy = float(_log_mean_exp(_mixture(by)))
    assert np.log(CAUSE_PRIOR["wash"]) < healthy < 0


@pytest.fixture(scope="module")
def moved_load():
    """An x500 whose rotors turn as command^(1.33/2) (ArduCopter SITL's measured curve, sim/esc.py
    speed law), flown without and with 20 % of its take-off mass toward rotor 1."""
    from flightlog_fd.sim.loads import Load, make_flyable

    af = preset("x500")
    rng = np.random.default_rng(11)
    esc = random_esc_params(af, rng, 50.0, speed_exponent=1.33)
    load = make_flyable(af, Load("point", mass_fraction=0.2, toward_motor=1, arm_fraction=0.9))
    kw = dict(airframes=[af], duration_s=45.0, profile="px4_default", esc=[esc], healthy_fraction=0.0,
              imbalance=[AirframeImbalance()], damages=[Damage()])
    return simulate_flights(1, seed=12, **kw)[0], simulate_flights(1, seed=13, loads=[(load,)], **kw)[0]


def test_a_moved_load_moves_command_and_rpm_along_the_curve(moved_load):
    """The load raises rotor 1's command and its rpm together, along the rotors' curve: the ESC
    names no rotor and its lost-rotor evidence stays low, without and with a profile; against the
    other motors at a fixed exponent of 1 (main before the curve) rotor 1 read as turning faster
    for its command, a cut propeller's sign."""
    from flightlog_fd.cause import judge_cause

    twin, loaded = moved_load
    m = measure_esc(loaded)[0]
    b = m.slopes["log_rpm_per_log_sqrt_command"]
    assert abs(b - 1.33) < 0.15, m.slopes
    assert m.lever[0, 0] > 0.05  # rotor 1 runs well above the others' command
    assert m.r[0, 0] - (1.0 - b) * m.lever[0, 0] > 0.02  # at b = 1 it would read 2 % or more faster
    for against in (None, fit_esc_baseline([twin])):
        a = analyze_esc(loaded, against)
        assert a.motor_named() is None and max(a.decision_llr.values()) < 2.0, (a.decision_llr, a.against)
        assert abs(next(f.value for f in a.findings if f.motor == 1 and f.name == "rpm_per_command")) < 3.0
    esc = __import__("flightlog_fd.analyzers.esc", fromlist=["Esc"]).Esc()
    from flightlog_fd.analyzers.base import Context

    res = esc.analyze(Context(loaded, loaded.frame, 4, np.zeros((0, 5)), 0.0))
    assert judge_cause([res], 1).cause != "propeller"
