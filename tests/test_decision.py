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


def test_branch_damaged_names_the_motor_its_severity_and_inspection():
    s, thr = damaged_shares(BASE, 3, 0.75, m=0.5)
    d = decide(window_probs(3, 0.7), s, ratio=thr, first_seen=12.0, agree=(3, 3.5))
    assert d.status == "damaged" and d.motor == 3
    assert "motor 3 (front-left) lost thrust from t=12.0 s" in d.reason
    assert "about 75 % of its normal thrust" in d.reason and "inspect propeller 3" in d.reason
    assert "re-calibrate" not in d.reason and d.airframe_changed is None
    assert d.motors[2].weight > 0.9 and d.motors[2].eta_hat == pytest.approx(0.75, abs=0.03)


def test_branch_uncertain_weak_names_the_motor_to_inspect():
    s, thr = damaged_shares(BASE, 2, 0.90)
    d = decide(window_probs(2, 0.5), s, ratio=thr)
    assert d.status == "uncertain" and d.motor == 2 and d.position == "rear-left", d.reason
    assert "motor 2 (rear-left) may have lost thrust" in d.reason and "inspect propeller 2" in d.reason


def test_branch_uncertain_split_names_both_motors():
    p = np.tile([0.10, 0.42, 0.03, 0.03, 0.42], (60, 1))  # the windows split between motors 1 and 4
    both = BASE * np.array([1.06, 0.97, 0.97, 1.06])  # and both work a little harder
    d = decide(p, both / both.mean())
    assert d.status == "uncertain", d.reason
    assert "motor 1 (front-right)" in d.reason and "motor 4 (rear-right)" in d.reason
    assert "cannot tell them apart" in d.reason and "propellers" in d.reason
    assert d.motor is None and d.position is None and set(d.inspect) == {1, 4}  # two named: no one motor


def test_branch_airframe_changed_only_when_no_rotor_explains_it():
    retrim = BASE * np.array([1.10, 1.10, 0.90, 0.90])  # a yaw re-trim: no rotor and no load makes it
    d = decide(window_probs(0, 0.9), retrim / retrim.mean(), ratio=1.0)
    assert d.status == "uncertain" and d.airframe_changed and "re-calibrate" in d.reason
    assert "no rotor explains the change" in d.reason
    # a throttle rise alone with one rotor's pattern is what a weak rotor does: not an airframe change
    s, thr = damaged_shares(BASE, 4, 0.7)
    d = decide(window_probs(4, 0.7), s, ratio=thr, agree=(4, 3.5))
    assert d.airframe_changed is None and d.status == "damaged" and d.motor == 4
    # the model's windows all confidently healthy outweigh the commands (each source is capped)
    assert decide(window_probs(0, 0.95), s, ratio=thr).status != "damaged"


def test_moved_load_is_healthy_with_cause_load_and_a_weak_rotor_is_not_a_load():
    """A centre of mass moved toward motor 1 raises it and lowers motor 2 (its diagonal), no yaw
    part: propellers healthy, the load named toward motor 1, even with the model voting for motor 1
    (its windows read the same commands). Motor 1 at eta 0.7 (m = 1) carries the yaw part a load
    has not: damaged, not a load."""
    moved = BASE * np.array([1.12, 0.88, 1.0, 1.0])
    d = decide(window_probs(1, 0.6), moved / moved.mean(), ratio=1.0)
    assert d.status == "healthy" and d.cause == "load" and d.load["motor"] == 1
    assert "the load sits toward motor 1" in d.reason and d.load["size"] == pytest.approx(0.12, abs=0.03)
    forward = BASE * np.array([1.1, 0.9, 1.1, 0.9])  # toward the front, between motors 1 and 3
    d = decide(window_probs(0, 0.9), forward / forward.mean(), ratio=1.0)
    assert d.status == "healthy" and d.cause == "load" and d.load["side"] == "front"
    s, thr = damaged_shares(BASE, 1, 0.7)
    d = decide(window_probs(1, 0.7), s, ratio=thr, agree=(1, 3.5))
    assert d.status == "damaged" and d.motor == 1 and d.cause != "load" and d.load is None
    cmd = next(r for r in d.results if r.analyzer == "commands")
    assert cmd.rotor_vs_load[0] > D.LOAD_SEPARATION_LLR  # its yaw part: a rotor, not a load


def test_branch_healthy_says_the_strongest_case():
    d = decide(window_probs(0, 0.9), BASE / BASE.mean())
    assert d.status == "healthy" and "no rotor lost thrust" in d.reason and "nats" in d.reason


def test_without_a_profile_a_trim_is_not_damage_but_a_large_one_motor_loss_is():
    trim = np.array([1.08, 0.92, 1.08, 0.92])  # centre of mass forward: healthy airframes show this
    d = decide(window_probs(1, 0.4), trim, base=None, kind="neighbours")
    assert d.status == "healthy", d.reason
    s, _ = damaged_shares(np.ones(4), 2, 0.65)
    d = decide(window_probs(2, 0.7), s, base=None, kind="neighbours", agree=(2, 3.5))
    assert d.status == "damaged" and d.motor == 2


def test_branch_uncertain_when_the_commands_do_not_rise_for_the_named_motor():
    """Strong evidence for motor 1 from other sources may not name it when its command share fell:
    a rotor that lost thrust must need more."""
    def res(analyzer, name, llr, value=None, baseline=None, kind=AnalyzerResult):
        return kind(analyzer, [Finding(analyzer, k, name, value if k == 1 else 1.0, "", None, baseline,
                                       "up", llr if k == 1 else -3.0) for k in range(1, 5)])

    def verdict(results):
        return D.decide(4, Frame.quad_x(), timeline=Timeline(60, 60.0, 0.0), results=results)[0]
    shares = CS.CommandSharesResult
    results = [res("model", "vote", 5.0, 0.9), res("commands", "share", -0.5, 0.98, 1.0, shares),
               res("esc", "esc_damage", 4.0, 30.0)]
    v = verdict(results)
    assert v.status == "uncertain" and v.motor == 1, v.reason
    assert "did not rise" in v.reason and "inspect propeller 1" in v.reason
    results[1] = res("commands", "share", -0.5, 1.02, 1.0, shares)  # the same with its share up 2 %
    assert verdict(results).status == "damaged"


def test_confidence_is_the_probability_of_the_statement_whatever_the_rotor_count():
    """Healthy: P(no rotor lost thrust); the same per-motor LLRs read alike on a quad and an octo
    (the prior's damage half is not diluted by the rotor count), and never "healthy, 0.15"."""
    for n in (4, 6, 8):
        w = D.posterior(np.full(n, -1.0))
        assert w[0] == pytest.approx(1 / (1 + np.exp(-1.0)))  # 0.73 for every n
        assert w.sum() == pytest.approx(1.0)
    assert D.posterior(np.zeros(8))[0] == pytest.approx(1 - D.PRIOR_DAMAGED)

    def verdict(llrs, n):
        # a source that sees one rotor at a time: a pair is as likely as its likelier member, no more
        pairs = {(a, b): max(llrs[a - 1], llrs[b - 1]) for a in range(1, n + 1) for b in range(a + 1, n + 1)}
        r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=float(v)) for k, v in enumerate(llrs)],
                           pair_llrs=pairs)
        return D.decide(n, None, timeline=Timeline(60, 60.0, 0.0), results=[r])

    v, d = verdict([-1.0] * 8, 8)
    assert v.status == "healthy" and v.confidence > 0.7
    v, d = verdict([7.0, -2.0, -2.0, -2.0], 4)
    assert v.status == "damaged" and v.confidence == pytest.approx(d.motors[0].weight)
    # each motor's LLR is floored where damage too mild for any source to see cannot be ruled out
    assert v.confidence == pytest.approx(D.posterior(np.maximum([7.0, -2, -2, -2], D.MILD_DAMAGE_LLR_FLOOR))[1])
    v, d = verdict([-9.0] * 4, 4)  # every source clears every rotor: still not sure of "healthy"
    cap = (1 - D.PRIOR_DAMAGED) / (1 - D.PRIOR_DAMAGED + D.PRIOR_DAMAGED * np.exp(D.MILD_DAMAGE_LLR_FLOOR))
    assert v.status == "healthy" and v.confidence == pytest.approx(cap) and cap < 0.9
    v, d = verdict([4.0, 4.5, -2.0, -2.0, -2.0, -2.0], 6)  # two motors it cannot tell apart
    either = d.motors[0].weight + d.motors[1].weight
    assert v.status == "uncertain" and either > D.UNCERTAIN_CONFIDENCE_CAP
    assert v.confidence == pytest.approx(D.UNCERTAIN_CONFIDENCE_CAP)  # "too weak to call" is never stated surer


def test_no_verdict_is_stated_below_a_coin_toss():
    """P(healthy) below STATED_MIN_CONFIDENCE: uncertain naming the leading rotor (and why), its
    probability the stated one; spread over several rotors, it names them until they reach it.
    Above it the healthy verdict says whether the evidence saw the flight."""
    def verdict(llrs):
        r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=float(v)) for k, v in enumerate(llrs)])
        return D.decide(len(llrs), Frame.quad_x(), timeline=Timeline(60, 60.0, 0.0), results=[r])

    v, d = verdict([2.0, -2.0, -2.0, -2.0])  # below every bar: the bars alone say healthy
    w = D.posterior(np.maximum([2.0, -2.0, -2.0, -2.0], D.MILD_DAMAGE_LLR_FLOOR))
    assert w[0] < 0.5 and w[1] > 0.5
    assert v.status == "uncertain" and v.motor == 1 and v.inspect == (1,), v.reason
    assert v.confidence == pytest.approx(w[1]) and v.confidence >= D.STATED_MIN_CONFIDENCE
    assert f"P(healthy) only {w[0]:.2f}" in v.reason and "inspect propeller 1" in v.reason and v.seen is None
    v, d = verdict([1.2, 1.1, 1.0, -2.0])  # no rotor alone reaches 0.5: the leading ones together
    assert v.status == "uncertain" and v.motor is None and len(v.inspect) >= 2 and v.inspect[:2] == (1, 2)
    assert v.confidence >= D.STATED_MIN_CONFIDENCE
    assert v.confidence == pytest.approx(sum(d.motors[k - 1].weight for k in v.inspect))
    v, _ = verdict([-9.0] * 4)  # every rotor cleared: seen
    assert v.status == "healthy" and v.seen is True and v.confidence >= D.SEEN_HEALTHY_P
    v, _ = verdict([-0.2] * 4)  # the evidence barely moved the prior: not seen, still healthy
    assert v.status == "healthy" and v.seen is False and 0.5 <= v.confidence < D.SEEN_HEALTHY_P
    assert v.as_dict()["seen"] is False


def test_stopped_outranks_and_not_diagnosable_passes_through():
    stop = SimpleNamespace(motor=2, t_start=12.5, duration_s=8.0, evidence="output at its minimum")
    v, d = D.decide(4, Frame.quad_x(), stopped=[stop], not_diagnosable_reason="too slow")
    assert v.status == "stopped" and v.motor == 2 and v.confidence == 1.0 and d is None
    assert "propeller diagnosis alone" not in v.reason  # no window was judged
    v, d = D.decide(4, Frame.quad_x(), timeline=Timeline(3, 1.5, 0.0, shortfall="only 3 windows"),
                    stopped=[stop])
    assert v.status == "stopped" and "alone said not_diagnosable" in v.reason
    v, d = D.decide(4, Frame.quad_x(), not_diagnosable_reason="too slow")
    assert v.status == "not_diagnosable" and v.reason == "too slow" and v.confidence == 0.0 and d is None


@pytest.mark.parametrize("frame", [Frame.quad_x(), Frame.quad_plus()])
def test_batched_prediction_table_equals_one_solve_at_a_time(frame):
    rows = CS._mixer_rows(frame, 4)
    base = np.array([0.95, 1.08, 0.92, 1.05])
    table = CS._pred_table(base, rows, 3)
    for a in (0, len(CS.ETA_GRID) // 2, len(CS.ETA_GRID) - 1):
        for b in range(len(CS.M_GRID)):
            one = CS.predicted_commands(base, rows, 3, float(CS.ETA_GRID[a]), float(CS.M_GRID[b]))
            assert np.allclose(table[a, b], one, atol=1e-12)


def test_commands_alone_against_a_profile_reach_at_most_uncertain_with_advice():
    """A one-rotor pattern within what a moved load makes (CoM shift + battery), with no source that
    does not read the trim agreeing: uncertain, naming the propeller and when to re-calibrate."""
    s, thr = damaged_shares(BASE, 4, 0.75)
    d = decide(window_probs(4, 0.5), s, ratio=thr)  # the model leans to motor 4, too weakly to agree
    assert d.status == "uncertain" and d.motor == 4, d.reason
    assert "motor 4 (rear-right) needs" in d.reason and "more command than at calibration" in d.reason
    assert "inspect propeller 4" in d.reason and "the load moved" in d.reason and "re-calibrate" in d.reason
    assert "the profile holds one calibration session" in d.reason and "fdlog calibrate --add" in d.reason
    assert d.confidence < 0.9  # the moved-load explanation keeps the stated probability modest
    # the same pattern with the model's windows agreeing is still the command pattern alone (the
    # model reads the same commands): uncertain, a rotor or a load at its corner; a source that does
    # not read the commands agreeing makes it damage
    d = decide(window_probs(4, 0.7), s, ratio=thr)
    assert d.status == "uncertain" and d.motor == 4 and "or a load sits at its corner" in d.reason, d.reason
    assert decide(window_probs(4, 0.7), s, ratio=thr, agree=(4, 3.5)).status == "damaged"
    # beyond any moved load (a rise far past BEYOND_DRIFT_SHARE_RISE), the commands may call it alone
    s2, thr2 = damaged_shares(BASE, 4, 0.40)
    assert s2[3] - BASE[3] / BASE.mean() > D.BEYOND_DRIFT_SHARE_RISE
    d2 = decide(window_probs(4, 0.5), s2, ratio=thr2)
    assert d2.status == "damaged" and d2.motor == 4, d2.reason


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


def test_no_damage_against_a_profile_when_the_throttle_fell_below_its_drift():
    """A weak rotor makes the throttle rise with the same load; well below calibration the load or
    set-up changed, so the profile does not describe the flight: uncertain, re-calibrate."""
    s, thr = damaged_shares(BASE, 3, 0.7)
    assert decide(window_probs(3, 0.8), s, ratio=thr, agree=(3, 3.5)).status == "damaged"
    d = decide(window_probs(3, 0.8), s, ratio=0.75, agree=(3, 3.5))
    assert d.status == "uncertain" and "lower than at calibration" in d.reason, d.reason
    assert "inspect propeller 3" in d.reason and "re-calibrate" in d.reason


def test_the_command_pattern_alone_names_the_rotor_or_a_load_at_its_corner():
    """A weight in rotor 2's wash takes its thrust as a damaged propeller does (crazypad_e9_load W3):
    with only the commands, the throttle and the model (whose windows read the same commands)
    pointing at motor 2, with or without a profile, the verdict is uncertain naming motor 2 and the
    load, and what tells them apart; a source that does not read the commands agreeing (from
    TRIM_FREE_AGREE_LLR), a rise beyond any load, or a mid-flight onset keeps it damaged."""
    for base, kind in ((BASE, "profile"), (None, "neighbours")):
        s, thr = damaged_shares(np.ones(4) if base is None else base, 2, 0.65)
        d = decide(window_probs(2, 0.8), s, base=base, kind=kind, ratio=thr)
        assert (d.status, d.motor, d.inspect) == ("uncertain", 2, (2,)), d.reason
        assert "or a load sits at its corner" in d.reason and "inspect propeller 2" in d.reason
        assert "fly once without the payload" in d.reason and "ESC telemetry" in d.reason
        assert 0.5 <= d.confidence <= D.UNCERTAIN_CONFIDENCE_CAP
        just = decide(window_probs(2, 0.8), s, base=base, kind=kind, ratio=thr, agree=(2, D.TRIM_FREE_AGREE_LLR))
        assert (just.status, just.motor) == ("damaged", 2), just.reason
        short = decide(window_probs(2, 0.8), s, base=base, kind=kind, ratio=thr,
                       agree=(2, D.TRIM_FREE_AGREE_LLR - 0.5))
        assert short.status == "uncertain", short.reason
    s, thr = damaged_shares(BASE, 2, 0.40)  # a rise beyond any load
    assert s[1] - BASE[1] / BASE.mean() > D.BEYOND_DRIFT_SHARE_RISE
    assert decide(window_probs(2, 0.8), s, ratio=thr).status == "damaged"
