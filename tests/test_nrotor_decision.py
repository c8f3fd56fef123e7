"""The decision on hexa and octo frames: the command source's order-keeping cap (coaxial partners),
the n-rotor models' own vote statistics, and `fdlog calibrate --no-adapt` on an n-rotor log."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from flightlog_fd import decision as D
from flightlog_fd.analyzers import REGISTRY, AnalyzerResult, Context, Finding, run_analyzers
from flightlog_fd.analyzers import command_shares as CS
from flightlog_fd.analyzers import model_votes as MV
from flightlog_fd.analyzers.share_fit import Baseline, ShareFit, MotorShares
from flightlog_fd.frames import ardupilot_frame
from flightlog_fd.timeline import Timeline

OCTAQUAD = ardupilot_frame(4, 1)  # motors 1-4 on top, 5-8 below: 1/6, 2/5, 3/8, 4/7 share an arm
COAX_PARTNER = {1: 6, 6: 1, 2: 5, 5: 2, 3: 8, 8: 3, 4: 7, 7: 4}


def _result(llrs, keeps_order: bool, cap: float = 8.0) -> AnalyzerResult:
    r = AnalyzerResult("x", [Finding("x", k + 1, "f", 0.0, llr=float(v)) for k, v in enumerate(llrs)])
    r.llr_cap, r.cap_keeps_order = cap, keeps_order
    return r


def test_cap_keeps_the_order_only_where_the_analyzer_asks():
    llrs = [20.0, 12.0, 9.0, 14.0]
    assert np.allclose(_result(llrs, False).llr(4), [8, 8, 8, 8])  # each motor alone: all tie at the cap
    assert np.allclose(_result(llrs, True).llr(4), [8, 0, -3, 2])  # lowered by the top's excess of 12
    assert np.allclose(_result([20.0, -30.0], True).llr(2), [8, -8])  # still clipped at -cap
    assert np.allclose(_result([5.0, -2.0], True).llr(2), [5, -2])  # under the cap: untouched
    flags = {a.id: a.cap_keeps_order for a in REGISTRY}
    assert flags["commands"] and not flags["model"]  # mixer physics, not a classifier's leaning


def _octaquad_decision(motor: int, eta: float, probs: np.ndarray):
    base = 1.0 + 0.04 * np.sin(np.arange(8) * 1.7)  # an uneven healthy trim
    base = base / base.mean()
    rows = CS._mixer_rows(OCTAQUAD, 8)
    u = CS.predicted_commands(base, rows, motor, eta, 1.0)
    shares = u / u.mean()
    motors = [MotorShares(k + 1, OCTAQUAD.position(k + 1), float(shares[k]), float(base[k]), 0.0, None, None, 0.0)
              for k in range(8)]
    ev = ShareFit(motors=motors, baseline="profile", throttle=0.5 * u.mean() / base.mean(),
                        baseline_=Baseline(share=base, slope=np.zeros(8), throttle_ref=0.5))
    ctx = Context(flight=SimpleNamespace(motors=[1]), frame=OCTAQUAD, n_motors=8, probs=probs, covered_s=40.0,
                  share_fit=ev)
    results = run_analyzers(ctx)
    v, d = D.decide(8, OCTAQUAD, timeline=Timeline(n_windows=len(probs), covered_s=40.0, t_first=0.0), results=results)
    return SimpleNamespace(**{**vars(v), "motors": d.motors, "named": v.motors}), results


@pytest.mark.parametrize("motor", [1, 2, 6, 7])
def test_octaquad_weak_rotor_is_told_from_its_coaxial_partner(motor):
    """Same arm, opposite spin: the partners differ only in the yaw pattern. The command fit tells
    them apart by far more than the cap; clipping each motor alone tied them at 8 nats, the tempered
    profile keeps them apart."""
    probs = np.full((50, 9), 0.4 / 8)
    probs[:, 0] = 0.6  # a model that leans to healthy, as it does on a trim it has not seen
    d, results = _octaquad_decision(motor, 0.65, probs)
    cmd = next(r for r in results if r.analyzer == "commands")
    raw = np.array([f.llr for f in cmd.findings if f.name == "share"])
    partner = COAX_PARTNER[motor]
    assert raw[motor - 1] - raw[partner - 1] > 4.0
    # the commands against a profile name the weak rotor, not its partner, even with the model
    # leaning to healthy; the cause stays unknown (nothing that sees it)
    assert (d.status, d.motor, d.cause) == ("damaged", motor, None), d.reason
    assert d.motors[motor - 1].weight > 0.9 > 0.1 > d.motors[partner - 1].weight
    lean = np.full((50, 9), 0.03)
    lean[:, motor] = 0.75
    lean[:, 0] = 1 - lean[:, 1:].sum(axis=1)
    d2, _ = _octaquad_decision(motor, 0.65, lean / lean.sum(axis=1, keepdims=True))
    assert (d2.status, d2.motor) == ("damaged", motor), d2.reason


CS_CAP = CS.CommandShares.llr_cap


def test_n_rotor_models_are_weighed_with_their_own_vote_statistics():
    assert MV.vote_stats(4) == MV.QUAD_VOTE_STATS and MV.vote_stats(5) == MV.QUAD_VOTE_STATS
    assert set(MV.NROTOR_VOTE_STATS) == {6, 8}
    quad = np.full((60, 5), 0.1)
    quad[:, 0] = 0.6
    # the quad's LLR is the one it always was
    explicit = MV.model_llr(quad, 60.0, stats=MV.VoteStats(MV.MODEL_HEALTHY_MEAN, MV.MODEL_HEALTHY_SIGMA,
                                                            MV.MODEL_DAMAGED_MEAN, MV.MODEL_DAMAGED_SIGMA,
                                                            MV.MODEL_DAMAGE_SHIFT, MV.MODEL_DAMAGED_SIGMA))
    assert np.array_equal(MV.model_llr(quad, 60.0), explicit)
    # an octo model that leaves the damaged motor's vote at its measured damaged level: no longer
    # several nats against it (the quad's figures expect +0.8)
    st = MV.NROTOR_VOTE_STATS[8]
    p = np.full((60, 9), 1.0)
    p[:, 0] = np.exp(-st.damaged_mean)  # log(q_k / q_0) = damaged_mean for every motor
    llr8 = MV.model_llr(p / p.sum(1, keepdims=True), 60.0)
    as_quad = MV.model_llr(p / p.sum(1, keepdims=True), 60.0, stats=MV.QUAD_VOTE_STATS)
    assert np.all(llr8 > 0) and np.all(as_quad < -1)
    # with a profile: the airframe's own healthy level, the octo model's measured shift
    own = MV.model_llr(p / p.sum(1, keepdims=True), 60.0, healthy_mean=np.full(8, st.damaged_mean - st.damage_shift),
                       healthy_sigma=MV.MODEL_MIN_HEALTHY_SIGMA)
    assert np.all(own > 0)


def test_calibrate_no_adapt_on_a_hexa_fits_the_hexa_models_baseline(tmp_path):
    import json

    from typer.testing import CliRunner

    from flightlog_fd.cli import app
    from flightlog_fd.logs.ulog_writer import write_ulog
    from flightlog_fd.model import FaultModel, shipped_model_path
    from flightlog_fd.sim.airframe import preset
    from flightlog_fd.sim.api import simulate_flights

    f = simulate_flights(1, airframes=preset("x500", "hexa_x"), healthy_fraction=1.0, profile="px4_default",
                         duration_s=25.0, seed=3, imbalance="random")[0]
    log = write_ulog(f, tmp_path / "h.ulg")
    res = CliRunner().invoke(app, ["calibrate", "--no-adapt", str(log), "-o", str(tmp_path / "h.json")])
    assert res.exit_code == 0, res.output  # was refused: the votes' baseline was fitted with the quad model
    base = json.loads((tmp_path / "h.json").read_text())["analyzers"]["model"]
    assert base["model_sha256"] == FaultModel(shipped_model_path(6)).sha256 and len(base["healthy_mean"]) == 6
