"""Calibration sessions: the airframe's own session-to-session drift (analyzers/session_drift.py),
`fdlog calibrate` with one session per log, `fdlog calibrate --add` (adds, refuses a session that
looks damaged with one line and exit 2, keeps the previous profile), and the session count in the
reports."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from flightlog_fd.analyzers.session_drift import SessionDrift, SessionFigures, TAU2_GRID
from flightlog_fd.cli import app

SAMPLES = Path(__file__).resolve().parents[1] / "sample_logs"
runner = CliRunner()


# ---------------------------------------------------------------- the drift model

def test_without_pinning_the_posterior_is_the_conjugate_scaled_inverse_chi_square():
    """Sessions with no pinning noise: the grid posterior of tau^2 is the conjugate one, scaled
    inverse chi-square with nu0 + (S - 1) n degrees of freedom (n - 1 free shares and the
    throttle per session), so E[1 / tau^2] = dof / (nu0 tau0^2 + SS)."""
    rng = np.random.default_rng(1)
    n, s, tau = 4, 5, 2.0
    shares = 1.0 + tau * 0.03 * rng.standard_normal((s, n))
    shares -= shares.mean(axis=1, keepdims=True) - 1.0  # a flight's shares have mean 1
    thr = 0.5 * np.exp(tau * 0.05 * rng.standard_normal(s))
    d = SessionDrift.fit(SessionFigures(shares, thr, np.zeros((s, n))), 0.03, 0.05, prior_sessions=0.5)
    ss = float(((shares - shares.mean(axis=0)) ** 2).sum() / 0.03 ** 2
               + ((np.log(thr) - np.log(thr).mean()) ** 2).sum() / 0.05 ** 2)
    nu0 = 0.5 * n
    dof = nu0 + (s - 1) * n
    w = np.exp(d.log_w)
    assert float(w @ (1.0 / TAU2_GRID)) == pytest.approx(dof / (nu0 + ss), rel=0.02)


@pytest.mark.parametrize("tau", [0.3, 5.0])
def test_many_sessions_let_the_airframe_speak_for_itself(tau):
    """Forty sessions of a quiet (0.3) or a loud (5) airframe: the posterior median of tau comes
    back within 15 %, whatever the population prior says (it centres on 1)."""
    rng = np.random.default_rng(7)
    n, s = 4, 40
    shares = 1.0 + tau * 0.03 * rng.standard_normal((s, n))
    shares -= shares.mean(axis=1, keepdims=True) - 1.0
    thr = 0.5 * np.exp(tau * 0.05 * rng.standard_normal(s))
    pins = np.full((s, n), 0.002)
    d = SessionDrift.fit(SessionFigures(shares, thr, pins), 0.03, 0.05)
    assert d.tau_median() == pytest.approx(tau, rel=0.15)


def test_two_sessions_give_a_heavy_tailed_predictive():
    """Two close sessions: the flight's shares are predicted tight (near their pinning), but a far
    move costs much less than under a normal distribution of the same effective spread, and the
    chi-square equivalent of a move is below its plain chi-square at the posterior median scale."""
    shares = np.array([[1.02, 0.99, 1.01, 0.98], [1.01, 1.0, 1.0, 0.99]])
    d = SessionDrift.fit(SessionFigures(shares, [0.5, 0.505], np.full((2, 4), 0.005)), 0.03, 0.05)
    sig = d.share_sigma(np.full(4, 0.005))
    assert np.all(sig < 0.06)
    far = np.array([0.3, -0.1, -0.1, -0.1])
    gauss = -0.5 * np.sum((far / sig) ** 2 + np.log(2 * np.pi * sig ** 2))
    assert d.loglik(far, None, np.full(4, 0.005)) > gauss + 20
    med = d.tau_median() * 0.03
    plain = float(np.sum(far ** 2) / (med ** 2 + 0.005 ** 2))
    assert d.chi2_equivalent(far, None, np.full(4, 0.005)) < plain


def _commands_llr(shares, ratio, sessions=None):
    """The command-share analyzer's LLR per motor for a flight against a quad baseline BASE, with
    the profile's ``sessions`` (SessionFigures) or none (a one-session profile)."""
    from types import SimpleNamespace

    from flightlog_fd.analyzers import run_analyzers
    from flightlog_fd.analyzers.base import Context
    from flightlog_fd.analyzers.share_fit import Baseline, MotorShares, ShareFit
    from flightlog_fd.flight import Frame
    from test_decision import BASE, window_probs

    b = BASE / BASE.mean()
    motors = [MotorShares(k + 1, None, float(shares[k]), float(b[k]), 0.0, None, None, 0.0) for k in range(4)]
    base = Baseline(share=b, slope=np.zeros(4), throttle_ref=0.5, sessions=sessions,
                    n_sessions=0 if sessions is None else sessions.n_sessions)
    fit = ShareFit(motors=motors, baseline="profile", throttle=0.5 * ratio, baseline_=base, pin=np.full(4, 0.005))
    ctx = Context(flight=SimpleNamespace(motors=[1]), frame=Frame.quad_x(), n_motors=4, probs=window_probs(1, 0.3),
                  covered_s=60.0, share_fit=fit)
    res = {r.analyzer: r for r in run_analyzers(ctx)}
    return res["commands"].llr(4), res["commands"]


def test_the_airframes_own_sessions_set_how_much_the_commands_weigh():
    """The same motor-4 pattern (eta 0.8) against three quiet sessions (session moves of 0.005)
    weighs more than against a one-session profile, and against three loud sessions (moves of
    0.15, an Erle-board-like airframe) much less; a session-to-session profile carries no
    one-session note."""
    from test_decision import BASE, damaged_shares

    s, thr = damaged_shares(BASE, 4, 0.8)
    b = BASE / BASE.mean()
    rng = np.random.default_rng(3)

    def sessions(move):
        sh = b + move * rng.standard_normal((3, 4))
        return SessionFigures(sh / sh.mean(axis=1, keepdims=True), 0.5 * np.exp(move * rng.standard_normal(3)),
                              np.full((3, 4), 0.005))

    one, _ = _commands_llr(s, thr)
    quiet, res = _commands_llr(s, thr, sessions(0.005))
    loud, _ = _commands_llr(s, thr, sessions(0.15))
    assert int(np.argmax(quiet)) == 3 and quiet[3] >= one[3] and loud[3] < one[3] - 1.0, (one, quiet, loud)
    assert res.n_sessions == 3 and res.share_sigma < 0.03
    from flightlog_fd.decision import _one_flight_note

    assert _one_flight_note(res) is None


# ---------------------------------------------------------------- calibrate and --add

@pytest.fixture(scope="module")
def x500(tmp_path_factory):
    """Two more flights of the sample logs' x500 (PX4 high-rate): a healthy one and one with
    propeller 2 at 60 % thrust, written by `fdlog simulate`."""
    d = tmp_path_factory.mktemp("x500")
    out = {}
    for name, extra in (("healthy2.ulg", ["--seed", "5"]), ("m2.ulg", ["--seed", "6", "--motor", "2", "--eta", "0.6"])):
        r = runner.invoke(app, ["simulate", "-o", str(d / name), "--duration", "30", *extra])
        assert r.exit_code == 0, r.output
        out[name] = d / name
    return out


@pytest.fixture(scope="module")
def one_session(tmp_path_factory):
    """The bytes of a `--no-adapt` profile of the sample x500's healthy flight (one session)."""
    prof = tmp_path_factory.mktemp("one") / "x500.json"
    r = runner.invoke(app, ["calibrate", "--no-adapt", str(SAMPLES / "px4_healthy.ulg"), "-o", str(prof)])
    assert r.exit_code == 0, r.output
    assert "1 calibration session: one session cannot show" in r.output
    return prof.read_bytes()


def test_calibrate_add_adds_a_session_and_keeps_the_previous_profile(tmp_path, x500, one_session):
    prof = tmp_path / "x500.json"
    prof.write_bytes(one_session)
    before = prof.read_bytes()
    r = runner.invoke(app, ["calibrate", "--add", str(prof), str(x500["healthy2.ulg"])])
    assert r.exit_code == 0, r.output
    assert "added session 2: healthy2.ulg" in r.output and "now holds 2 calibration sessions (was 1)" in r.output
    assert "command-share baseline: motor 1" in r.output and "session-to-session drift" in r.output
    kept = tmp_path / "x500.sessions-1.json"
    assert kept.read_bytes() == before and "kept as x500.sessions-1.json" in r.output
    d = json.loads(prof.read_text())
    assert d["schema"] == 7 and len(d["sessions_"]) == 2 and d["baseline_"]["n_sessions"] == 2
    assert [e["name"] for e in d["source_logs"]] == ["px4_healthy.ulg", "healthy2.ulg"]
    assert [e["name"] for s in d["sessions_"] for e in s["logs"]] == ["px4_healthy.ulg", "healthy2.ulg"]
    assert len(d["analyzers"]["model"]["sessions"]) == 2 and d["analyzers"]["model"]["n_flights"] == 2
    assert d["analyzers"]["model"]["sessions_seen"] == [False, False]  # the shipped model saw neither
    assert np.allclose(d["baseline_"]["share"], np.mean([s["share"] for s in d["sessions_"]], axis=0), atol=1e-6)
    # the same log twice is refused, and nothing is written
    after = prof.read_bytes()
    r = runner.invoke(app, ["calibrate", "--add", str(prof), str(x500["healthy2.ulg"])])
    assert r.exit_code == 2 and "already one of x500.json's calibration logs" in r.output
    assert prof.read_bytes() == after and not (tmp_path / "x500.sessions-2.json").exists()
    # the reports say how many sessions the profile holds
    r = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof), str(SAMPLES / "px4_healthy.ulg")])
    doc = json.loads(r.output)
    assert doc["schema"] == 8 and doc["profile"]["sessions"] == 2
    r = runner.invoke(app, ["diagnose", "--profile", str(prof), str(SAMPLES / "px4_healthy.ulg")])
    assert "profile x500.json (2 calibration sessions)" in " ".join(r.output.split())
    html = tmp_path / "r.html"
    runner.invoke(app, ["diagnose", "--html", str(html), "--profile", str(prof), str(SAMPLES / "px4_healthy.ulg")])
    assert "2 calibration sessions" in html.read_text()


def test_calibrate_add_refuses_a_session_that_looks_damaged(tmp_path, x500, one_session):
    """A flight with propeller 2 at 60 % thrust added as a session: refused with one line and exit
    2, the profile untouched and no copy made, so the damage is not calibrated away."""
    prof = tmp_path / "x500.json"
    prof.write_bytes(one_session)
    before = prof.read_bytes()
    r = runner.invoke(app, ["calibrate", "--add", str(prof), str(x500["m2.ulg"])])
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fdlog: ") and "m2.ulg" in lines[0]
    assert "looks damaged against the 1 session of x500.json: motor 2 lost thrust" in lines[0]
    assert "not added, the profile is unchanged" in lines[0]
    assert prof.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["x500.json"]
    # and as a session of a new calibration: refused too, nothing written
    out = tmp_path / "two.json"
    r = runner.invoke(app, ["calibrate", "--no-adapt", str(SAMPLES / "px4_healthy.ulg"), str(x500["m2.ulg"]),
                            "-o", str(out)])
    assert r.exit_code == 2 and "looks damaged against the other 1 calibration session" in r.output
    assert not out.exists()


def test_each_log_is_a_session_unless_grouped_and_bad_arguments(tmp_path, x500, one_session):
    logs = [str(SAMPLES / "px4_healthy.ulg"), str(x500["healthy2.ulg"])]
    two, one = tmp_path / "two.json", tmp_path / "one.json"
    r = runner.invoke(app, ["calibrate", "--no-adapt", *logs, "-o", str(two)])
    assert r.exit_code == 0, r.output
    assert "2 calibration sessions: session-to-session drift of this airframe" in r.output
    assert len(json.loads(two.read_text())["sessions_"]) == 2
    # the same sessions by adding the second log later
    added = tmp_path / "added.json"
    added.write_bytes(one_session)
    assert runner.invoke(app, ["calibrate", "--add", str(added), logs[1]]).exit_code == 0
    a, b = json.loads(two.read_text()), json.loads(added.read_text())
    for key in ("share", "throttle", "pin", "seconds"):
        assert [x[key] for x in a["sessions_"]] == [x[key] for x in b["sessions_"]]
    for key in ("share", "throttle_ref", "spread", "pin", "n_sessions"):
        assert a["baseline_"][key] == pytest.approx(b["baseline_"][key], abs=1e-12)
    assert np.allclose(a["analyzers"]["model"]["sessions"], b["analyzers"]["model"]["sessions"], atol=1e-9)
    r = runner.invoke(app, ["calibrate", "--no-adapt", "--one-session", *logs, "-o", str(one)])
    assert r.exit_code == 0, r.output
    d = json.loads(one.read_text())
    assert len(d["sessions_"]) == 1 and len(d["sessions_"][0]["logs"]) == 2 and d["baseline_"]["n_flights"] == 2
    for args, words in ((["calibrate", "--no-adapt", logs[0]], "--output"),
                        (["calibrate", "--add", str(two), "-o", str(tmp_path / "x.json"), logs[0]], "in place"),
                        (["calibrate", "--add", str(tmp_path / "none.json"), logs[0]], "no such profile")):
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and words in r.output and len(r.output.strip().splitlines()) == 1, r.output


def test_a_schema_5_profile_is_one_session_and_takes_more(tmp_path, x500, one_session):
    prof = tmp_path / "old.json"
    d = json.loads(one_session)
    d.pop("sessions_")
    d["schema"] = 5
    prof.write_text(json.dumps(d))
    r = runner.invoke(app, ["calibrate", "--add", str(prof), str(x500["healthy2.ulg"])])
    assert r.exit_code == 0, r.output
    new = json.loads(prof.read_text())
    assert new["schema"] == 7 and len(new["sessions_"]) == 2
    assert new["sessions_"][0]["share"] == d["baseline_"]["share"]  # the old profile's pooled baseline
    assert json.loads((tmp_path / "old.sessions-1.json").read_text())["schema"] == 5


# ---------------------------------------------------------------- real airframes (../shared)

def test_real_airframes_other_flights_as_sessions_call_the_left_out_flight_healthy(tmp_path, shared):
    """Leave one out, the other healthy flights one session each (`calibrate A B`): board B's
    6-3-2014_6 ("the airframe itself changed", uncertain, against a pooled profile of the same
    flights) and rrc_straight good flight 3 are healthy; board A's 15-10-2014_42 (rotor 3 at +26 %
    against the other two, six days later) is named (results/verdict.md: its evidence is a 25 mm
    cut's); the rrc 25 mm cut is flagged naming motor 1."""
    erle = shared("real_healthy", "logs")
    rrc = shared("real_damaged", "rrc_straight")
    a25, a31, a42 = (erle / f"erle_pxf_copter_{x}.BIN" for x in ("09-10-2014_25", "09-10-2014_31", "15-10-2014_42"))
    # 15-10-2014_42 flew six days after the other two with rotor 3 needing +26 % more command: against
    # 09-10-2014_25's session it reads as rotor 3's lost thrust, so it is no calibration session
    r = runner.invoke(app, ["calibrate", "--no-adapt", str(a25), str(a42), "-o", str(tmp_path / "a.json")])
    assert r.exit_code == 2 and "motor 3 lost thrust" in r.output, r.output
    cases = [([a25, a31], a42, ("healthy", "uncertain", "damaged")),
             ([erle / "erle_Erle-Brain2_Debian-first-flight-with-case.BIN", erle / "erle_pxf_copter_22-12-2014_37.BIN"],
              erle / "erle_pxf_copter_6-3-2014_6.BIN", ("healthy",)),
             ([rrc / "good_prop_straight_line_1.BIN", rrc / "good_prop_straight_line_2.BIN"],
              rrc / "good_prop_straight_line_3.BIN", ("healthy",))]
    for k, (cal, left_out, want) in enumerate(cases):
        prof = tmp_path / f"p{k}.json"
        r = runner.invoke(app, ["calibrate", "--no-adapt", *map(str, cal), "-o", str(prof)])
        assert r.exit_code == 0, r.output
        r = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof), str(left_out)])
        doc = json.loads(r.output)
        assert doc["verdict"]["status"] in want and doc["profile"]["sessions"] == 2, (left_out.name, doc["verdict"])
    r = runner.invoke(app, ["diagnose", "--json", "--profile", str(tmp_path / "p2.json"),
                            str(rrc / "25_mm_cut_straight_line_1.BIN")])
    doc = json.loads(r.output)
    assert doc["verdict"]["status"] in ("uncertain", "damaged")
    llr = [m["llr"] for m in doc["motors"]]
    assert int(np.argmax(llr)) == 0 and doc["verdict"]["motor"] == 1
