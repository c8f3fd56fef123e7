"""The decision model: mixer physics and severity, each source's LLR, and every verdict branch's
reason, and the confidence (decision.decide)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from flightlog_fd import decision as D
from flightlog_fd.analyzers import AnalyzerResult, Context, Finding, run_analyzers
from flightlog_fd.analyzers import command_shares as CS
from flightlog_fd.analyzers.effectiveness import effectiveness_llr
from flightlog_fd.analyzers.model_votes import model_llr
from flightlog_fd.analyzers.share_fit import Baseline, ShareFit, MotorShares
from flightlog_fd.flight import Frame
from flightlog_fd.timeline import DamageRun, Timeline


def window_probs(motor: int, p_motor: float, n: int = 60) -> np.ndarray:
    """n windows giving ``p_motor`` to class ``motor`` and the rest to healthy."""
    p = np.full((n, 5), 0.01)
    p[:, motor] = p_motor
    if motor != 0:
        p[:, 0] = 1.0 - p[:, 1:].sum(axis=1)
    return p / p.sum(axis=1, keepdims=True)


def damaged_shares(base, motor, eta, m=1.0, frame=None):
    frame = frame or Frame.quad_x()
    rows = CS._mixer_rows(frame, 4)
    u = CS.predicted_commands(np.asarray(base, float), rows, motor, eta, m)
    return u / u.mean(), u.mean() / np.mean(base)


@pytest.mark.parametrize("motor", [1, 2, 3, 4])
def test_one_weak_rotor_closed_loop_pattern(motor):
    """Quad X, even trim: the diagonal partner (same spin) needs eta times the weak rotor's command
    (equal thrusts on a diagonal hold roll and pitch); with m = 1 the other pair matches it too."""
    s, thr = damaged_shares(np.ones(4), motor, 0.7)
    partner = {1: 2, 2: 1, 3: 4, 4: 3}[motor]
    assert s[partner - 1] / s[motor - 1] == pytest.approx(0.7, abs=1e-9)
    assert np.argmax(s) == motor - 1 and thr > 1.0  # the lost thrust is made up: the throttle rises
    s2, _ = damaged_shares(np.ones(4), motor, 0.7, m=0.4)
    others = [k for k in range(4) if k not in (motor - 1, partner - 1)]
    assert s2[others[0]] > s[others[0]]  # less torque loss: the other pair stays closer to the weak rotor


@pytest.mark.parametrize("frame", [Frame.quad_x(), Frame.quad_plus()])
@pytest.mark.parametrize("eta", [0.6, 0.75, 0.9])
def test_severity_fit_recovers_eta_against_an_uneven_baseline(frame, eta):
    base = np.array([0.95, 1.08, 0.92, 1.05])
    s, thr = damaged_shares(base, 3, eta, m=1.25, frame=frame)
    chi_h, fits = CS.severity_fit(s, base, np.full(4, CS.DEFAULT_DRIFT_SIGMA), frame, thr)
    assert fits[2].eta_hat == pytest.approx(eta, abs=0.02)
    assert fits[2].eta_ci[0] <= eta <= fits[2].eta_ci[1]
    assert fits[2].llr == max(f.llr for f in fits)
    healthy_chi, healthy_fits = CS.severity_fit(base / base.mean(), base, np.full(4, 0.03), frame, 1.0)
    assert healthy_chi == pytest.approx(0.0, abs=1e-9) and all(f.llr < 0 for f in healthy_fits)
    assert all(f.eta_hat >= 0.97 for f in healthy_fits)


def test_model_llr_counts_correlated_windows_once_per_decorrelation_time():
    damaged = window_probs(2, 0.8)
    long = model_llr(damaged, covered_s=600.0)
    short = model_llr(damaged, covered_s=20.0)
    assert np.argmax(long) == 1 and long[1] > 0
    # 600 s of the same votes is NOT 30 times the evidence of 20 s: the between-flight spread caps it
    assert long[1] < 3 * max(short[1], 0.1)
    healthy = model_llr(window_probs(0, 0.9), covered_s=60.0)
    assert np.all(healthy < 0)


def test_effectiveness_llr_only_when_informative_and_sane():
    def est(values, informative=True, width=0.05):
        v = np.asarray(values, float)
        return SimpleNamespace(values=v, ci=np.stack([v - width, v + width], axis=1), informative=informative,
                               motors=list(range(4)))
    llr = effectiveness_llr(est([0.7, 1.0, 1.0, 1.0]))
    assert llr[0] > 2 and np.all(llr[1:] < 0)
    assert effectiveness_llr(est([0.7, 1.0, 1.0, 1.0], informative=False)) is None
    assert effectiveness_llr(est([-1.0, 1.0, 1.0, 1.0])) is None  # inconsistent fit: never used


def test_pooled_drift_sigma():
    assert CS.pooled_sigma(None, 1, 0.03) == 0.03
    assert CS.pooled_sigma(0.005, 2, 0.03) == pytest.approx(np.sqrt((3 * 0.03 ** 2 + 0.005 ** 2) / 4))
    assert CS.share_sigma("neighbours", None, 4)[0] == CS.NEIGHBOUR_SHARE_SIGMA
    assert CS.share_sigma("before onset", None, 4)[0] == CS.ONSET_BASELINE_SIGMA
    assert CS.share_sigma("profile", [0.01] * 4, 4, n_flights=4)[0] < CS.DEFAULT_DRIFT_SIGMA


BASE = np.array([0.95, 1.08, 0.92, 1.05])


def decide(probs, shares, base=BASE, kind="profile", ratio=1.0, first_seen=None, agree=None):
    """The decision from synthetic window probabilities and command shares, through the registered
    analyzers (the flight's throttle is ``ratio`` times the profile's); ``agree`` = (motor, nats): a
    source that does not read the command pattern (an effectiveness-like result) for that motor."""
    shares = np.asarray(shares, float)
    b = None if base is None else base / base.mean()
    motors = [MotorShares(k + 1, Frame.quad_x().position(k + 1), float(shares[k]),
                            None if b is None else float(b[k]), 0.0, None, None, 0.0) for k in range(4)]
    baseline = None if b is None else Baseline(share=b, slope=np.zeros(4), throttle_ref=0.5)
    ev = ShareFit(motors=motors, baseline=kind, throttle=0.5 * ratio, baseline_=baseline)
    ctx = Context(flight=SimpleNamespace(motors=[1]), frame=Frame.quad_x(), n_motors=4, probs=probs,
                  covered_s=60.0, share_fit=ev)
    tl = Timeline(n_windows=len(probs), covered_s=60.0, t_first=0.0)
    if first_seen is not None:  # a confirmed run after healthy flight: a mid-flight onset
        tl.run = DamageRun(motor=1, start_index=10, n_windows=len(probs) - 10, t_start=first_seen - 1.0,
                           covered_s=50.0, share=1.0, agreement=1.0, log_likelihood_ratio=10.0,
                           first_seen=first_seen, confirmed=True)
    results = run_analyzers(ctx)
    if agree is not None:
        results.append(AnalyzerResult("effectiveness", [Finding("effectiveness", k + 1, "f", 0.0,
                                                                llr=agree[1] if k + 1 == agree[0] else -1.0)
                                                        for k in range(4)]))
    v, d = D.decide(4, Frame.quad_x(), timeline=tl, results=results)
    return SimpleNamespace(**{**vars(v), "motors": d.motors, "named": v.motors}, pairs=d.pairs,
                           airframe_changed=d.airframe_changed, results=d.results)


def test_branch_damaged_names_the_rotor_how_much_since_when_and_what_to_do():
    s, thr = damaged_shares(BASE, 3, 0.75, m=0.5)
    d = decide(window_probs(3, 0.7), s, ratio=thr, first_seen=12.0, agree=(3, 3.5))
    assert d.status == "damaged" and d.motor == 3
    assert d.headline == "Rotor 3 (front-left) lost ~26 % thrust since t=12.0 s: inspect propeller 3"
    assert len(d.headline) <= D.HEADLINE_MAX
    assert "about 74 % of its normal thrust" in d.reason or "about 75 % of its normal thrust" in d.reason
    assert d.thrust[0]["motor"] == 3 and d.thrust[0]["eta_hat"] == pytest.approx(0.75, abs=0.03)
    assert d.airframe_changed is None and d.motors[2].weight > 0.9 and d.confidence == pytest.approx(d.motors[2].weight)
    assert d.cause is None and "cannot tell" in d.reason  # no source that sees why: the cause stays unknown


def test_branch_uncertain_names_the_rotor_when_inspecting_is_worth_it_but_damage_is_not_likelier():
    s, thr = damaged_shares(BASE, 2, 0.90)
    d = decide(window_probs(2, 0.5), s, ratio=thr)
    assert d.status == "uncertain" and d.motor == 2 and d.position == "rear-left", d.reason
    assert D.inspect_bar() <= d.p_damage < 0.5 and d.confidence == pytest.approx(d.motors[1].weight)
    assert d.headline.startswith("Uncertain: rotor 2 (rear-left) may have lost ~10 % thrust: inspect propeller 2")


def test_damage_two_rotors_share_is_named_as_either():
    """Strong evidence that splits evenly over two rotors (a source that sees one rotor at a time):
    damage is certain, the rotor is not: damaged, no one motor, both to inspect."""
    llrs = [7.0, -2.0, -2.0, 7.0]
    pairs = {(a, b): max(llrs[a - 1], llrs[b - 1]) for a in range(1, 5) for b in range(a + 1, 5)}
    r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=v) for k, v in enumerate(llrs)], pair_llrs=pairs)
    v, d = D.decide(4, Frame.quad_x(), timeline=Timeline(60, 60.0, 0.0), results=[r])
    assert v.status == "damaged" and v.motor is None and set(v.inspect) == {1, 4}, v.reason
    assert "Rotor 1 or 4 lost thrust" in v.headline and "cannot tell them apart" in v.reason


def test_airframe_changed_is_said_beside_a_healthy_verdict():
    retrim = BASE * np.array([1.10, 1.10, 0.90, 0.90])  # a yaw re-trim: no rotor and no load makes it
    d = decide(window_probs(0, 0.9), retrim / retrim.mean(), ratio=1.0)
    assert d.status == "healthy" and d.airframe_changed and "re-calibrate" in d.reason
    # a throttle rise with one rotor's pattern is what a weak rotor does: not an airframe change
    s, thr = damaged_shares(BASE, 4, 0.7)
    d = decide(window_probs(4, 0.7), s, ratio=thr, agree=(4, 3.5))
    assert d.airframe_changed is None and d.status == "damaged" and d.motor == 4
    # the model's windows all confidently healthy weigh against the commands (each source is capped)
    assert decide(window_probs(0, 0.95), s, ratio=thr).p_damage < d.p_damage


def test_moved_load_is_healthy_with_cause_load_and_a_weak_rotor_is_not_a_load():
    """A centre of mass moved toward motor 1 raises it and lowers motor 2 (its diagonal), no yaw
    part: propellers healthy, the load named toward motor 1, even with the model voting for motor 1
    (its windows read the same commands). Motor 1 at eta 0.7 (m = 1) carries the yaw part a load
    has not: damaged, not a load."""
    moved = BASE * np.array([1.2, 0.8, 1.0, 1.0])
    d = decide(window_probs(1, 0.6), moved / moved.mean(), ratio=1.0)
    assert d.status == "healthy" and d.cause == "load" and d.load["motor"] == 1, d.reason
    assert "the load sits toward motor 1" in d.reason and d.load["size"] == pytest.approx(0.2, abs=0.03)
    assert d.headline.startswith("Healthy propellers; the load sits toward motor 1 (front-right)")
    forward = BASE * np.array([1.1, 0.9, 1.1, 0.9])  # toward the front, between motors 1 and 3
    d = decide(window_probs(0, 0.9), forward / forward.mean(), ratio=1.0)
    assert d.status == "healthy"
    s, thr = damaged_shares(BASE, 1, 0.7)
    d = decide(window_probs(1, 0.7), s, ratio=thr, agree=(1, 3.5))
    assert d.status == "damaged" and d.motor == 1 and d.cause != "load" and d.load is None
    cmd = next(r for r in d.results if r.analyzer == "commands")
    assert cmd.rotor_vs_load[0] > 2.0  # its yaw part: a rotor, not a load


def test_branch_healthy_says_the_strongest_case():
    d = decide(window_probs(0, 0.9), BASE / BASE.mean())
    assert d.status == "healthy" and "no rotor lost thrust" in d.reason and "nats" in d.reason
    assert d.headline == "Healthy: no rotor lost thrust" and d.seen is True


def test_without_a_profile_a_trim_is_not_damage_but_a_large_one_motor_loss_is():
    trim = np.array([1.08, 0.92, 1.08, 0.92])  # centre of mass forward: healthy airframes show this
    d = decide(window_probs(1, 0.4), trim, base=None, kind="neighbours")
    assert d.status == "healthy", d.reason
    s, _ = damaged_shares(np.ones(4), 2, 0.65)
    d = decide(window_probs(2, 0.7), s, base=None, kind="neighbours", agree=(2, 3.5))
    assert d.status == "damaged" and d.motor == 2


def test_confidence_is_the_posterior_of_the_statement_under_the_stated_prior():
    """Healthy: P(no rotor lost thrust); damaged: P(the named rotor lost thrust); every verdict
    states the prior it was decided under, and a fleet's own prior moves the verdict."""
    def verdict(llrs, prior=D.PRIOR_DAMAGE):
        n = len(llrs)
        pairs = {(a, b): max(llrs[a - 1], llrs[b - 1]) for a in range(1, n + 1) for b in range(a + 1, n + 1)}
        r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=float(v)) for k, v in enumerate(llrs)],
                           pair_llrs=pairs)
        return D.decide(n, None, timeline=Timeline(60, 60.0, 0.0), results=[r], prior=prior)

    v, d = verdict([-2.0] * 8)
    assert v.status == "healthy" and v.confidence == pytest.approx(1 - d.p_damage) and v.seen is True
    v, d = verdict([7.0, -2.0, -2.0, -2.0])
    assert v.status == "damaged" and v.motor == 1 and v.confidence == pytest.approx(d.motors[0].weight)
    assert v.confidence > 0.9
    assert v.prior_damage == D.PRIOR_DAMAGE and v.as_dict()["prior_damage"] == D.PRIOR_DAMAGE
    assert sum(d.posterior.values()) == pytest.approx(1.0)
    # the bars in nats follow from the prior and the miss cost: one rotor at the damaged bar is even odds
    unc, dmg = D.evidence_bars(4)
    assert verdict([dmg + 0.2, -9, -9, -9])[0].status == "damaged"
    assert verdict([dmg - 0.3, -9, -9, -9])[0].status == "uncertain"
    assert verdict([unc - 0.3, -9, -9, -9])[0].status == "healthy"
    # a fleet that sees damage more often reads the same log as more likely damaged
    assert verdict([dmg - 0.3, -9, -9, -9], prior=0.3)[0].status == "damaged"


def test_the_cost_of_a_miss_sets_where_healthy_ends():
    """Healthy only while P(damage) stays below 1 / (1 + MISS_COST); a log that says nothing either
    way keeps the prior: healthy (a miss costs MISS_COST inspections, P(damage) is the prior 0.1),
    but not seen."""
    assert D.inspect_bar() == pytest.approx(1 / (1 + D.MISS_COST))
    r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=0.0) for k in range(4)])
    v, d = D.decide(4, Frame.quad_x(), timeline=Timeline(60, 60.0, 0.0), results=[r])
    assert v.status == "healthy" and v.seen is False and d.p_damage == pytest.approx(D.PRIOR_DAMAGE, abs=0.02)
    assert "could not show damage" in v.reason


def test_stopped_outranks_and_not_diagnosable_passes_through():
    stop = SimpleNamespace(motor=2, t_start=12.5, duration_s=8.0, evidence="output at its minimum")
    v, d = D.decide(4, Frame.quad_x(), stopped=[stop], not_diagnosable_reason="too slow")
    assert v.status == "stopped" and v.motor == 2 and v.confidence == 1.0 and d is None
    assert "propeller diagnosis alone" not in v.reason  # no window was judged
    assert v.headline.startswith("Motor 2 (rear-left) stopped at t=12.5 s")
    v, d = D.decide(4, Frame.quad_x(), timeline=Timeline(3, 1.5, 0.0, shortfall="only 3 windows"),
                    stopped=[stop])
    assert v.status == "stopped" and "alone said not_diagnosable" in v.reason
    v, d = D.decide(4, Frame.quad_x(), not_diagnosable_reason="too slow")
    assert v.status == "not_diagnosable" and v.reason == "too slow" and v.confidence == 0.0 and d is None
    assert v.headline == "Not diagnosable: too slow"


@pytest.mark.parametrize("frame", [Frame.quad_x(), Frame.quad_plus()])
def test_batched_prediction_table_equals_one_solve_at_a_time(frame):
    rows = CS._mixer_rows(frame, 4)
    base = np.array([0.95, 1.08, 0.92, 1.05])
    table = CS._pred_table(base, rows, 3)
    for a in (0, len(CS.ETA_GRID) // 2, len(CS.ETA_GRID) - 1):
        for b in range(len(CS.M_GRID)):
            one = CS.predicted_commands(base, rows, 3, float(CS.ETA_GRID[a]), float(CS.M_GRID[b]))
            assert np.allclose(table[a, b], one, atol=1e-12)


def test_the_commands_alone_against_a_profile_say_which_rotor_lost_how_much_not_why():
    """A one-rotor pattern against a profile with only the sources that read the commands: the log
    shows that rotor 4 lost about a quarter of its thrust, decisively; it cannot show why (a damaged
    propeller, a weak motor and a weight in its wash need the same command), so the cause stays
    unknown and the advice starts at the propeller."""
    s, thr = damaged_shares(BASE, 4, 0.75)
    d = decide(window_probs(4, 0.5), s, ratio=thr)
    assert d.status == "damaged" and d.motor == 4 and d.cause is None, d.reason
    assert d.headline == "Rotor 4 (rear-right) lost ~25 % thrust since take-off: inspect propeller 4"
    assert "fdlog calibrate --add" in d.reason  # a one-session profile: what would make it stronger


def test_more_load_on_every_motor_is_not_evidence():
    for ratio in (1.15, 1.4, 0.8):
        d = decide(window_probs(0, 0.5), BASE / BASE.mean(), ratio=ratio)
        assert d.status == "healthy", (ratio, d.reason)
        thr = next(r for r in d.results if r.analyzer == "throttle")
        assert all(f.llr <= 1e-9 for f in thr.findings)


def test_severity_interval_never_collapses_at_the_grid_edge():
    base = np.ones(4)
    s, thr = damaged_shares(base, 2, 0.30)  # below the grid's 0.40
    _, fits = CS.severity_fit(s, base, np.full(4, 0.01), Frame.quad_x(), thr)
    lo, hi = fits[1].eta_ci
    assert lo == 0.0 and hi > CS.ETA_GRID[0]
    s, thr = damaged_shares(base, 2, 0.70)
    _, fits = CS.severity_fit(s, base, np.full(4, 0.001), Frame.quad_x(), thr)
    lo, hi = fits[1].eta_ci
    assert lo < 0.70 < hi  # a sharp fit still spans a grid step each side


def test_share_noise_adds_how_well_the_flights_pin_the_shares():
    plain = CS.share_sigma("profile", None, 4)
    pinned = CS.share_sigma("profile", None, 4, pins=([0.04] * 4, None, [0.03] * 4))
    assert pinned[0] == pytest.approx(np.sqrt(CS.DEFAULT_DRIFT_SIGMA ** 2 + 0.04 ** 2 + 0.03 ** 2))
    assert plain[0] == CS.DEFAULT_DRIFT_SIGMA
    assert CS.share_sigma("neighbours", None, 4, pins=([0.5] * 4,))[0] == CS.NEIGHBOUR_SHARE_SIGMA


def test_a_throttle_that_fell_weighs_against_a_lost_rotor():
    """A rotor that lost thrust makes the throttle rise with the same load: a throttle well below
    calibration lowers the probability of the rotor against the same pattern with the throttle up."""
    s, thr = damaged_shares(BASE, 3, 0.7)
    up = decide(window_probs(3, 0.8), s, ratio=thr)
    down = decide(window_probs(3, 0.8), s, ratio=0.75)
    assert up.status == "damaged" and down.motors[2].llr < up.motors[2].llr


def test_a_weight_in_a_rotors_wash_is_its_lost_thrust_with_no_cause_claimed():
    """A weight in rotor 2's wash takes its thrust as a damaged propeller does (crazypad_e9_load W3):
    "rotor 2 lost thrust" is what the log shows, with or without a profile, and no source that sees
    why says "propeller", so the cause is unknown and the reason says what could tell."""
    for base, kind in ((BASE, "profile"), (None, "neighbours")):
        s, thr = damaged_shares(np.ones(4) if base is None else base, 2, 0.65)
        d = decide(window_probs(2, 0.8), s, base=base, kind=kind, ratio=thr)
        assert (d.status, d.motor) == ("damaged", 2), d.reason
        assert d.cause is None and "propeller" not in d.headline.split(":")[0]
