"""Two damaged propellers: the simulator's two-propeller flights, each source's pair evidence, the
decision's pair step, and the pair in every report, the store, `fdlog history` and the web pages."""
from __future__ import annotations

import csv
import io
import json
import sqlite3
from types import SimpleNamespace

import numpy as np
import pytest
from typer.testing import CliRunner

from flightlog_fd import decision as D
from flightlog_fd.analyzers import AnalyzerResult, Context, Finding, run_analyzers
from flightlog_fd.analyzers import command_shares as CS
from flightlog_fd.analyzers.effectiveness import effectiveness_pair_llrs
from flightlog_fd.analyzers.effectiveness_fit import EffectivenessEstimate, MotorEffectiveness, relative_to_others
from flightlog_fd.analyzers.model_votes import model_llr, model_pair_llrs
from flightlog_fd.analyzers.share_fit import Baseline, MotorShares, ShareFit
from flightlog_fd.cli import app
from flightlog_fd.flight import Frame
from flightlog_fd.sim.airframe import preset
from flightlog_fd.sim.api import simulate_flights
from flightlog_fd.sim.damage import (Damage, DamageArrays, feasible, hover_commands, random_pair_damages,
                                     rotor_pairs)
from flightlog_fd.timeline import Timeline

from conftest import shared_path
from test_decision import window_probs  # noqa: E402  n windows voting for one class

runner = CliRunner()
X500 = preset("x500")


# ----------------------------------------------------------------------------- the simulator

def test_damage_several_lists_each_propeller_and_refuses_nonsense():
    d = Damage.several(Damage(1, 0.7), Damage(4, 0.8, onset_s=20.0, eta_torque=0.7))
    assert d.motors == [1, 4] and d.motor == 1 and d.eta == 0.7 and d.label == 1
    assert [(p.motor, p.eta, p.onset_s, p.torque_eta) for p in d.parts] == [(1, 0.7, None, 0.7), (4, 0.8, 20.0, 0.7)]
    assert Damage().parts == [] and Damage.several() == Damage()
    with pytest.raises(ValueError, match="another motor"):
        Damage.several(Damage(2, 0.7), Damage(2, 0.8))
    with pytest.raises(ValueError, match="healthy"):
        Damage(0, 1.0, also=(Damage(2, 0.8),))
    with pytest.raises(ValueError, match="same 4-rotor"):
        Damage.several(Damage(1, 0.7), Damage(2, 0.8, rotors=6))
    arr = DamageArrays.build([d, Damage(3, 0.6), Damage()], np.random.default_rng(0))
    assert arr.onset.shape == (3, 4) and arr.onset[0].tolist() == [0.0, 0.0, 0.0, 20.0]
    assert arr.eta_at(10.0)[0].tolist() == [0.7, 1.0, 1.0, 1.0]
    assert arr.eta_at(25.0)[0].tolist() == [0.7, 1.0, 1.0, 0.8] and arr.eta_at(25.0)[1].tolist() == [1, 1, 0.6, 1]
    with pytest.raises(ValueError, match="damaged motor 5"):
        DamageArrays.build([Damage.several(Damage(1, 0.7, rotors=6), Damage(5, 0.8, rotors=6))],
                           np.random.default_rng(0))


def test_two_propellers_each_from_its_own_onset_in_the_commands():
    """Noise-free hover: propeller 1 at 0.75 from take-off, propeller 4 at 0.8 from 25 s after
    arming. With drag torque lost as thrust (m = 1) each weak rotor needs 1/eta of the others'
    command: before the onset only motor 1 does, after it motor 4 too; the truth lists both."""
    f = simulate_flights(1, airframes="x500", damages=[Damage.several(Damage(1, 0.75), Damage(4, 0.8, onset_s=25.0))],
                         mission="hover", duration_s=50.0, profile="training", seed=3, realism=False)[0]
    t0 = f.truth["log_start_boot_s"]
    assert f.truth["motors"] == [1, 4] and f.truth["etas"] == [0.75, 0.8] and f.truth["motor"] == 1
    assert f.truth["onsets_s"][0] is None and f.truth["onsets_s"][1] == pytest.approx(25.0 + t0)
    assert f.truth["onset_s"] is None  # the first propeller's: from take-off
    before = f.motors.between(f.airborne[0][0] + 8.0, t0 + 24.0).values
    after = f.motors.between(t0 + 32.0, t0 + 45.0).values
    healthy_before = before[:, [1, 2]].mean()
    assert before[:, 0].mean() / healthy_before == pytest.approx(1 / 0.75, rel=0.03)
    assert before[:, 3].mean() / healthy_before == pytest.approx(1.0, abs=0.03)
    healthy_after = after[:, [1, 2]].mean()
    assert after[:, 0].mean() / healthy_after == pytest.approx(1 / 0.75, rel=0.03)
    assert after[:, 3].mean() / healthy_after == pytest.approx(1 / 0.8, rel=0.03)


def test_pairs_of_a_frame_and_which_two_propeller_damages_fly():
    assert rotor_pairs(X500, "opposite") == [(1, 2), (3, 4)]  # PX4 quad X: the diagonals
    assert rotor_pairs(X500, "adjacent") == [(1, 3), (1, 4), (2, 3), (2, 4)]
    assert rotor_pairs(preset("x500", "hexa_x"), "opposite") == [(1, 2), (3, 4), (5, 6)]
    with pytest.raises(ValueError):
        rotor_pairs(X500, "diagonal")
    u = hover_commands(X500, Damage.several(Damage(1, 0.7), Damage(4, 0.7)))
    assert u[[0, 3]] == pytest.approx(X500.hover_command / 0.7) and u[[1, 2]] == pytest.approx(X500.hover_command)
    assert feasible(X500, Damage(1, 0.7)) and not feasible(X500, Damage.several(Damage(1, 0.6), Damage(4, 0.6)))
    rng = np.random.default_rng(4)
    afs = [X500] * 6 + [preset("sih")] * 6
    for kind in ("adjacent", "opposite"):
        for af, d in zip(afs, random_pair_damages(afs, rng, kinds=(kind,))):
            assert len(d.motors) == 2 and tuple(sorted(d.motors)) in rotor_pairs(af, kind)
            assert all(0.6 <= p.eta <= 0.85 for p in d.parts) and feasible(af, d)
    # an airframe that cannot fly on with two weak propellers in the range gets none
    assert random_pair_damages([X500], rng, eta_range=(0.5, 0.55)) == [Damage()]


def test_simulate_two_propellers_on_the_command_line(tmp_path):
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "p.ulg"), "--motor", "1", "--motor", "4", "--eta", "0.7",
                              "--eta", "0.8", "--onset", "0", "--onset", "20", "--duration", "30"])
    assert res.exit_code == 0, res.output
    assert "propellers 1 and 4 damaged (eta 0.70, 0.80)" in res.output
    res = runner.invoke(app, ["simulate", "-o", str(tmp_path / "many"), "--count", "2", "--motor", "2", "--motor", "3",
                              "--eta", "0.75", "--duration", "25", "-f", "dataflash"])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader(open(tmp_path / "many" / "truth.csv")))
    assert [(r["motor"], r["motors"], r["etas"]) for r in rows] == [("2", "2;3", "0.75;0.75")] * 2
    for args, words in (([ "--motor", "1", "--motor", "1"], "each damaged propeller once"),
                        (["--motor", "1", "--motor", "2", "--eta", "0.7", "--eta", "0.8", "--eta", "0.9"],
                         "one per --motor"),
                        (["--motor", "1", "--motor", "5"], "1..4"),
                        (["--motor", "1", "--onset", "-3"], ">= 0")):
        bad = runner.invoke(app, ["simulate", "-o", str(tmp_path / "bad.ulg"), *args])
        assert bad.exit_code == 2 and words in bad.output and "Traceback" not in bad.output
        assert not (tmp_path / "bad.ulg").exists()


# ----------------------------------------------------------------------------- each source's pair evidence

def pair_shares(base, a, b, eta_a, eta_b, m=1.0, frame=None):
    """Closed-loop shares and throttle ratio with rotors a and b weak (the analyzer's own physics)."""
    rows = CS._mixer_rows(frame or Frame.quad_x(), 4)
    table = CS._pair_pred_table(np.asarray(base, float), rows, a, b)
    i, j = (int(np.argmin(np.abs(CS.PAIR_ETA_GRID - e))) for e in (eta_a, eta_b))
    u = table[i, j, int(np.argmin(np.abs(CS.M_GRID - m)))]
    return u / u.mean(), u.mean() / np.mean(base)


@pytest.mark.parametrize("frame", [Frame.quad_x(), Frame.quad_plus()])
@pytest.mark.parametrize("a,b", [(1, 4), (1, 2), (2, 3)])
def test_pair_fit_finds_both_weak_rotors_and_their_thrust(frame, a, b):
    base = np.array([0.95, 1.08, 0.92, 1.05])
    s, thr = pair_shares(base, a, b, 0.7, 0.76, m=0.5, frame=frame)
    fits = CS.pair_fit(s, base, np.full(4, CS.DEFAULT_DRIFT_SIGMA), frame, thr, move=True)
    top = max(fits, key=lambda f: f.llr)
    assert top.motors == (a, b) and top.eta_hat == pytest.approx((0.7, 0.76), abs=0.03)
    _, singles = CS.severity_fit(s, base, np.full(4, CS.DEFAULT_DRIFT_SIGMA), frame, thr, move=True)
    assert top.llr > max(f.llr for f in singles) + 3  # no single rotor explains two


def test_pair_fit_pays_for_its_second_efficiency_on_one_weak_rotor():
    s, thr = pair_shares(np.ones(4), 1, 2, 0.7, 0.98)  # one weak rotor (the other at the grid's top)
    _, singles = CS.severity_fit(s, np.ones(4), np.full(4, 0.03), Frame.quad_x(), thr, move=True)
    fits = CS.pair_fit(s, np.ones(4), np.full(4, 0.03), Frame.quad_x(), thr, move=True)
    assert max(f.llr for f in fits) < singles[0].llr  # the Occam factor of the wider prior
    healthy = CS.pair_fit(np.ones(4), np.ones(4), np.full(4, 0.03), Frame.quad_x(), 1.0, move=True)
    assert all(f.llr < 0 for f in healthy)


def _eff(values, width=0.04):
    v = np.asarray(values, float)
    return EffectivenessEstimate(motors=[MotorEffectiveness(k + 1, float(x), (float(x - width), float(x + width)))
                                         for k, x in enumerate(v)], informative=True)


def test_effectiveness_pair_evidence_follows_the_estimators_normalisation():
    x_values = relative_to_others(np.array([0.7, 1.0, 1.0, 0.75]), Frame.quad_x())
    assert x_values == pytest.approx([0.7, 1 / 0.75, 1 / 0.75, 0.75])
    llr = effectiveness_pair_llrs(_eff(x_values), Frame.quad_x())
    assert max(llr, key=llr.get) == (1, 4) and llr[(1, 4)] > 5
    assert all(v < 0 for v in effectiveness_pair_llrs(_eff([1.0] * 4), Frame.quad_x()).values())
    # quad +: two weak rotors on one axis read as a weaker axis (every value 1): only the wider
    # prior's Occam factor weighs against them (equal efficiencies are a thin slice of it), where
    # rotors on both axes are ruled out
    plus = effectiveness_pair_llrs(_eff(relative_to_others(np.array([0.7, 0.7, 1, 1]), Frame.quad_plus())),
                                   Frame.quad_plus())
    assert -2.5 < plus[(1, 2)] < 0 and plus[(3, 4)] == pytest.approx(plus[(1, 2)]) and plus[(1, 3)] < plus[(1, 2)] - 2
    assert effectiveness_pair_llrs(EffectivenessEstimate(informative=False), Frame.quad_x()) == {}


def test_model_sees_at_most_one_member_of_a_pair():
    one = window_probs(1, 0.6)
    single, pairs = model_llr(one, 60.0), model_pair_llrs(one, 60.0)
    assert pairs[(1, 4)] < single[0] and pairs[(1, 4)] > pairs[(2, 3)]  # a pair with the voted rotor fits better
    healthy = model_pair_llrs(window_probs(0, 0.95), 60.0)
    assert all(v < 0 for v in healthy.values())
    # monotone: the more healthy the votes, the less a pair (no wide-spread tail turning it round)
    levels = [model_pair_llrs(window_probs(0, q), 60.0)[(1, 2)] for q in (0.5, 0.8, 0.95, 0.99)]
    assert levels == sorted(levels, reverse=True)
    assert model_pair_llrs(np.zeros((0, 5)), 0.0) == {}


def test_pair_llr_sums_independent_sources_and_keeps_the_cap():
    r = AnalyzerResult("vibration", [Finding("vibration", k + 1, "line", 0.0, llr=v)
                                     for k, v in enumerate([3.0, -1.0, 0.5, 6.0])])
    pairs = r.pair_llr(4)
    assert pairs[(1, 4)] == pytest.approx(8.0) and pairs[(1, 2)] == pytest.approx(2.0)  # 9 clipped to the cap 8
    ordered = AnalyzerResult("c", pair_llrs={(1, 2): 20.0, (1, 3): 10.0}, llr_cap=8.0, cap_keeps_order=True)
    assert ordered.pair_llr(4) == {(1, 2): 8.0, (1, 3): -2.0}
    # the command shares' cap keeps its order between one rotor and two: every rotor and pair
    # lowered together by the top one's excess (the pair step's comparison), not each set alone
    both = AnalyzerResult("c", [Finding("c", k + 1, "share", 0.0, llr=v) for k, v in enumerate([12.0, 0, 0, 0])],
                          pair_llrs={(1, 2): 20.0, (1, 3): 9.0}, llr_cap=8.0, cap_keeps_order=True)
    assert both.llr(4).tolist() == [8.0, -4.0, -4.0, -4.0]  # the single-rotor verdict's view: unchanged
    assert both.llr(4, with_pairs=True).tolist() == [0.0, -8.0, -8.0, -8.0]
    assert both.pair_llr(4) == {(1, 2): 8.0, (1, 3): -3.0}
    assert r.pair_llr(6) is None  # pairs are weighed on quads only (PAIR_ROTOR_COUNTS)
    assert AnalyzerResult("none").pair_llr(4) is None


# ----------------------------------------------------------------------------- the decision's pair step

BASE = np.array([0.95, 1.08, 0.92, 1.05])


def decide(shares, ratio, probs, kind="profile", eff=None):
    """The decision through the registered analyzers from synthetic command shares (against
    BASE, or an even split for ``kind="neighbours"``), the throttle ratio, window votes and an
    optional effectiveness estimate."""
    b = BASE / BASE.mean() if kind == "profile" else None
    motors = [MotorShares(k + 1, Frame.quad_x().position(k + 1), float(shares[k]), None if b is None else float(b[k]),
                          0.0, None, None, 0.0) for k in range(4)]
    baseline = None if b is None else Baseline(share=b, slope=np.zeros(4), throttle_ref=0.5)
    fit = ShareFit(motors=motors, baseline=kind, throttle=0.5 * ratio, baseline_=baseline, effectiveness=eff)
    ctx = Context(flight=SimpleNamespace(motors=[1], rates=[1]), frame=Frame.quad_x(), n_motors=4, probs=probs,
                  covered_s=60.0, share_fit=fit)
    return D.decide(4, Frame.quad_x(), timeline=Timeline(n_windows=len(probs), covered_s=60.0, t_first=0.0),
                    results=run_analyzers(ctx))


def test_two_weak_rotors_named_together_when_a_trim_free_source_agrees():
    s, thr = pair_shares(BASE, 1, 4, 0.72, 0.78, m=0.75)
    eff = _eff(relative_to_others(np.array([0.74, 1, 1, 0.8]), Frame.quad_x()))
    v, d = decide(s, thr, window_probs(1, 0.3), eff=eff)
    assert (v.status, v.motor, v.motors, v.pair) == ("damaged", 1, [1, 4], True)
    assert v.positions == ["front-right", "rear-right"]
    assert v.headline == ("Rotors 1 (front-right) and 4 (rear-right) lost thrust since take-off: inspect "
                          "propellers 1 and 4")
    assert "two rotors explain the evidence" in v.reason
    top = d.pairs[0]
    assert top.motors == (1, 4) and top.excess >= -D.PAIR_LOG_PRIOR_ODDS["profile"]
    assert top.eta_hat == pytest.approx((0.72, 0.78), abs=0.05)
    # the confidence is that pair's probability; both rotors' weights count it
    assert v.confidence > 0.9 and d.motors[0].weight > 0.9 and d.motors[3].weight > 0.9 and d.motors[1].weight < 0.1
    assert v.as_dict()["motors"] == [1, 4] and v.as_dict()["pair"] is True
    assert v.status_words() == "damaged (motors 1 and 4)" and v.propellers() == (
        "propellers 1 (front-right) and 4 (rear-right)")


def test_commands_alone_a_pair_pattern_is_not_two_rotors_against_a_profile():
    """A centre of mass moved to the right side makes the pattern of propellers 1 and 4 weak: with
    the model leaning to propeller 1 only a little, two rotors do not earn their prior odds against a
    load or a healthy airframe, so the propellers are healthy (with the effectiveness agreeing on
    the pair it is named: test_two_weak_rotors_named_together_when_a_trim_free_source_agrees)."""
    s, thr = pair_shares(BASE, 1, 4, 0.72, 0.78, m=0.75)
    v, d = decide(s, thr, window_probs(1, 0.3))
    assert v.status == "healthy" and not v.pair, v.reason
    assert d.posterior["healthy"] + d.posterior["load"] > 0.9


def test_without_a_profile_a_trim_pattern_is_not_a_pair():
    """Against an even split a pair's pattern is also a healthy airframe's trim (real Erle
    6-3-2014_6: shares 1.04 / 0.67 / 0.86 / 1.43): the commands alone never name a pair."""
    s = np.array([1.043, 0.671, 0.859, 1.427])
    v, d = decide(s / s.mean(), 1.0, window_probs(0, 0.6), kind="neighbours")
    assert not v.pair and v.status == "healthy"
    top = d.pairs[0]
    assert top.motors == (1, 4) and top.llr_by_source["commands"] > 5  # what the commands alone said
    assert top.llr_by_source["model"] < 0  # and the model, which the pair's pattern would move, did not


def test_one_weak_rotor_stays_one():
    rows = CS._mixer_rows(Frame.quad_x(), 4)
    u = CS.predicted_commands(BASE, rows, 3, 0.72, 0.75)
    eff = _eff(relative_to_others(np.array([1, 1, 0.74, 1]), Frame.quad_x()))
    v, d = decide(u / u.mean(), u.mean() / BASE.mean(), window_probs(3, 0.6), eff=eff)
    assert (v.status, v.motor, v.motors, v.pair) == ("damaged", 3, [3], False)
    assert d.pairs[0].excess < -D.PAIR_LOG_PRIOR_ODDS["profile"]
    v, d = decide(BASE / BASE.mean(), 1.0, window_probs(0, 0.9), eff=_eff([1.0] * 4))
    assert v.status == "healthy" and v.motors == [] and not v.pair


def test_a_pair_needs_more_command_together_not_each():
    """Propellers 1 (0.65) and 4 (0.85) weak, drag exponent 1.6: the mixer moves the yaw load so
    that propeller 4's share falls below its baseline while the two together rise (the two-rotor
    fit's physics); the pair is named damaged, not held for propeller 4's share."""
    s, thr = pair_shares(BASE, 1, 4, 0.65, 0.85, m=1.6)
    b = BASE / BASE.mean()
    assert s[3] < b[3] and s[0] + s[3] > b[0] + b[3]
    eff = _eff(relative_to_others(np.array([0.65, 1, 1, 0.85]), Frame.quad_x()))
    v, d = decide(s, thr, window_probs(1, 0.3), eff=eff)
    assert (v.status, v.motors, v.pair) == ("damaged", [1, 4], True), v.reason


def test_esc_far_above_its_cap_on_two_motors_says_two_not_one():
    """ESC telemetry reads each motor against the others: two damaged propellers both far above
    the cap (12) keep "two rather than one" in the pair step; one damaged propeller with healthy
    neighbours (negative) keeps one; the single-rotor view is clipped motor by motor."""
    def esc(values):
        r = AnalyzerResult("esc", [Finding("esc", k + 1, "esc_damage", 0.0, llr=v) for k, v in enumerate(values)],
                           llr_cap=12.0, pair_keeps_order=True)
        return r

    two = esc([40.0, 2.0, 3.0, 35.0])
    assert two.llr(4).tolist() == [12.0, 2.0, 3.0, 12.0]  # what the single-rotor decision reads
    assert two.pair_llr(4)[(1, 4)] == 12.0 and two.llr(4, with_pairs=True).max() == -12.0
    one = esc([40.0, -1.0, -0.8, -1.1])
    assert one.llr(4, with_pairs=True)[0] == 12.0 and max(one.pair_llr(4).values()) == pytest.approx(11.2)


def test_an_uncertain_pairs_advice_is_to_inspect_both():
    from flightlog_fd.advice import Situation, advise

    where = {1: "front-right", 4: "rear-right"}
    (first, *_) = advise(Situation("uncertain", inspect=(1, 4), pair=True, positions=where, profile="p.json"))
    assert first.kind == "inspect" and first.motors == (1, 4)
    assert first.text.startswith("inspect propellers 1 (front-right) and 4 (rear-right):")
    (two, *_) = advise(Situation("uncertain", inspect=(1, 4), positions=where))  # two it cannot tell apart
    assert two.text.startswith("inspect propellers 1 (front-right) and 4 (rear-right):") and two.motors == (1, 4)


def test_no_pair_on_other_rotor_counts():
    r = AnalyzerResult("esc", [Finding("esc", k + 1, "rpm", 0.0, llr=5.0 if k in (0, 3) else -2.0) for k in range(6)])
    v, d = D.decide(6, None, timeline=Timeline(60, 60.0, 0.0), results=[r])
    assert d.pairs == [] and not v.pair


# ----------------------------------------------------------------------------- every report, the store, the web

@pytest.fixture(scope="module")
def pair_run(tmp_path_factory):
    """A healthy x500 flight and one with propellers 1 and 4 weak (0.7, 0.75), one airframe; the
    profile from the healthy one (--no-adapt); the pair diagnosed into every report and a store."""
    d = tmp_path_factory.mktemp("pair")
    sim = ["--seed", "3", "--vehicle-id", "quadA", "--duration", "60"]
    assert runner.invoke(app, ["simulate", "-o", str(d / "h.ulg"), *sim]).exit_code == 0
    assert runner.invoke(app, ["simulate", "-o", str(d / "p14.ulg"), *sim, "--motor", "1", "--motor", "4",
                               "--eta", "0.7", "--eta", "0.75"]).exit_code == 0
    res = runner.invoke(app, ["calibrate", "--no-adapt", str(d / "h.ulg"), "-o", str(d / "prof.json")])
    assert res.exit_code == 0, res.output
    db = d / "data" / "fdlog.sqlite"
    db.parent.mkdir()
    res = runner.invoke(app, ["diagnose", "--profile", str(d / "prof.json"), str(d / "p14.ulg"), "--json",
                              "--csv", str(d / "w.csv"), "--db", str(db)])
    assert res.exit_code == 1, res.output
    page = runner.invoke(app, ["diagnose", "--profile", str(d / "prof.json"), str(d / "p14.ulg"), str(d / "h.ulg"),
                               "--html", str(d / "r.html")])
    assert page.exit_code == 1, page.output
    text = runner.invoke(app, ["diagnose", "--profile", str(d / "prof.json"), str(d / "p14.ulg"), str(d / "h.ulg")],
                         terminal_width=100)
    return SimpleNamespace(dir=d, db=db, doc=json.loads(res.stdout), text=text.output)


def test_terminal_and_json_name_both(pair_run):
    from flightlog_fd.report.json_report import validate

    flat = " ".join(pair_run.text.split())
    assert "Rotors 1 (front-right) and 4 (rear-right) lost thrust since take-off: inspect propellers 1 and 4" in flat
    assert "damaged 1 FR+4 RR" in pair_run.text  # the summary table
    doc = pair_run.doc
    assert validate(doc) == [] and doc["schema"] == 8
    assert doc["verdict"]["headline"].startswith("Rotors 1 (front-right) and 4 (rear-right) lost thrust")
    v = doc["verdict"]
    assert (v["status"], v["motor"], v["motors"], v["pair"]) == ("damaged", 1, [1, 4], True)
    assert v["positions"] == ["front-right", "rear-right"]
    pair = doc["motor_evidence"]["decision"]["pair"]
    assert pair["motors"] == [1, 4] and pair["excess"] >= 4.0 and pair["eta_hat"][0] == pytest.approx(0.7, abs=0.1)


def test_csv_and_html_name_both(pair_run):
    rows = list(csv.DictReader(io.StringIO((pair_run.dir / "w.csv").read_text())))
    assert rows and {r["verdict_motors"] for r in rows} == {"1;4"} and {r["verdict"] for r in rows} == {"damaged"}
    page = (pair_run.dir / "r.html").read_text()
    assert "Rotors 1 (front-right) and 4 (rear-right) lost thrust" in page
    assert "Rotors 1 (front-right) and 4 (rear-right)" in page.split("<h2>Summary</h2>")[1]
    assert page.count('<tr class="top">') >= 2  # both rows of the per-motor table highlighted


def test_store_history_and_web_pages_name_both(pair_run, tmp_path):
    from flightlog_fd.store import Store, load_history

    with Store(pair_run.db) as store:
        (f,) = store.logs()
        row = store.flight(f["id"])
    assert (row["status"], row["motor"], row["verdict_motors"], row["pair"]) == ("damaged", 1, "1;4", 1)
    (records,) = load_history(pair_run.db).values()
    assert records[-1].verdict_motors == [1, 4] and records[-1].pair
    text = runner.invoke(app, ["history", "--db", str(pair_run.db)])
    assert text.exit_code == 1 and "damaged m1+m4" in text.output
    assert "FLAG: latest flight: rotors 1 and 4 lost thrust" in text.output
    out = json.loads(runner.invoke(app, ["history", "--db", str(pair_run.db), "--json"]).stdout)
    (veh,) = out["vehicles"]
    assert veh["latest"]["motors"] == [1, 4] and veh["flights"][-1]["verdict_motors"] == [1, 4]
    res = runner.invoke(app, ["history", "--db", str(pair_run.db), "--html", str(tmp_path / "h.html")])
    page = (tmp_path / "h.html").read_text()
    assert res.exit_code == 1 and "damaged (motors 1 and 4)" in page and "rotors 1 and 4 lost thrust" in page
    pytest.importorskip("fastapi")
    from serve_helpers import serve_client

    with serve_client(pair_run.db.parent, workers=0) as c:
        fid = c.get("/api/logs").json()["logs"][0]["id"]
        fleet, flight = c.get("/").text, c.get(f"/flights/{fid}").text
        airframe = c.get("/airframe", params={"key": row["airframe"]}).text
    assert "motors 1 and 4" in fleet and "motors 1 and 4" in airframe
    assert "Rotors 1 (front-right) and 4 (rear-right) lost thrust" in flight  # the headline
    assert flight.count('class="top"') >= 2


def test_an_existing_store_gets_the_named_propellers_when_upgraded(pair_run, tmp_path):
    """A store at migration 7 (before verdict_motors and pair): opening it runs migration 8, which
    fills them from each stored report."""
    import shutil

    from flightlog_fd.store import SCHEMA_VERSION, Store

    db = tmp_path / "old.sqlite"
    shutil.copy(pair_run.db, db)
    with sqlite3.connect(db) as c:
        for table in ("flight", "flight_part"):
            c.execute(f"ALTER TABLE {table} DROP COLUMN verdict_motors")
            c.execute(f"ALTER TABLE {table} DROP COLUMN pair")
        c.execute("DELETE FROM schema_migrations WHERE version = 8")
        c.execute("PRAGMA user_version = 7")
    with Store(db) as store:
        assert store.db.schema_version() == SCHEMA_VERSION >= 8
        (f,) = store.logs()
        row = store.flight(f["id"])
    assert (row["verdict_motors"], row["pair"]) == ("1;4", 1)


def test_a_weak_motor_or_esc_is_not_made_a_pair_by_its_neighbours_esc_offsets():
    """ArduCopter SITL, motor 1 weakened as a motor or ESC fault (slower per command): the ESC
    evidence is for motor 1 alone (each ESC against a robust level of the others, so motor 1 does
    not lift its neighbours), a pair with a healthy member is less likely than motor 1 alone, and
    the verdict names motor 1 alone, with its cause (a pair's cause would be null)."""
    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    log = shared_path("ardupilot_sitl_quad", "motor1_weak_esc.BIN")
    d = diagnose_flight(load_flight(log), resolve_model(), None, keep_flight=False)
    assert not d.verdict.pair and (d.verdict.motors or list(d.verdict.inspect)) == [1]
    assert d.verdict.cause == "motor_or_esc"
    esc = next(r for r in d.decision.results if r.analyzer == "esc")
    per = esc.llr(4)
    assert per[0] > 0 > max(per[1:])
    singles = esc.llr(4, with_pairs=True)  # the pair step's view: a healthy member lowers a pair
    assert all(esc.pair_llr(4)[(1, k)] < singles[0] for k in (2, 3, 4))


def test_several_flights_and_stopped_motors_keep_every_named_motor():
    from flightlog_fd.decision import capped_by_log

    pair = D.Verdict("damaged", motor=1, motors=[1, 4], pair=True, positions=["front-right", "rear-right"],
                     confidence=0.9, reason="two")
    one = D.Verdict("damaged", motor=1, confidence=0.9, reason="one")
    assert one.motors == [1] and one.status_words() == "damaged (motor 1)"
    # a flight naming a pair where its log names one rotor: not confirmed, so uncertain
    capped = capped_by_log(pair, one, None)
    assert capped.status == "uncertain" and "damaged (motors 1 and 4)" in capped.reason and not capped.pair
    assert capped_by_log(pair, pair, None) is pair
    log = D.log_verdict([("flight 1 of 2", D.Verdict("healthy", confidence=0.8)), ("flight 2 of 2", pair)])
    assert (log.motor, log.motors, log.pair, log.positions) == (1, [1, 4], True, ["front-right", "rear-right"])
    stops = [SimpleNamespace(motor=3, t_start=10.0, duration_s=5.0, evidence="output at its minimum"),
             SimpleNamespace(motor=2, t_start=12.0, duration_s=5.0, evidence="output at its minimum")]
    v, _ = D.decide(4, Frame.quad_x(), stopped=stops, not_diagnosable_reason="too slow")
    assert (v.status, v.motor, v.motors, v.positions) == ("stopped", 3, [3, 2], ["front-left", "rear-left"])
