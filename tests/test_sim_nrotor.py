"""The simulator flies hexa- and octocopters (X, +, coaxial octaquad) with the quad's damage and
imbalance models; their flights read back and window like real n-rotor logs."""
from __future__ import annotations

import numpy as np
import pytest

from flightlog_fd.windows import FeatureSpec, labels_for_spans, make_windows
from flightlog_fd.frames import ardupilot_frame
from flightlog_fd.sim.airframe import N_ROTOR_FRAMES, preset, random_airframes
from flightlog_fd.sim.api import simulate_flights
from flightlog_fd.sim.damage import Damage, random_damages


def nif_windows(f, n_motors: int):
    """NIF windows with n motor channels ."""
    return make_windows(f, FeatureSpec(n_motors=n_motors))


def _airborne_mean(f, margin_s=3.0):
    m = np.zeros(len(f.motors), bool)
    for a, b in f.airborne:
        m |= (f.motors.t > a + margin_s) & (f.motors.t < b - margin_s)
    return f.motors.values[m].mean(axis=0)


@pytest.mark.parametrize("frame", ["hexa_x", "hexa_plus", "octo_x", "octaquad_x"])
def test_n_rotor_airframe_flies_and_the_damaged_motor_works_hardest(frame):
    af = preset("x500", frame)
    n = af.rotor_count
    assert n == len(ardupilot_frame(*N_ROTOR_FRAMES[frame]).rotors)
    assert af.hover_command == pytest.approx(preset("x500").hover_command)  # same thrust-to-weight
    dmg = [Damage(), Damage(2, 0.7, rotors=n), Damage(n, 0.6, rotors=n)]
    fls = simulate_flights(3, airframes=af, damages=dmg, duration_s=30.0, seed=4)
    for f, d in zip(fls, dmg):
        assert f.airborne_s > 25.0 and f.motors.values.shape[1] == n
        assert f.frame.layout == ardupilot_frame(*N_ROTOR_FRAMES[frame]).layout
        assert f.vehicle_type == {6: "hexarotor", 8: "octorotor"}[n] and f.truth["rotor_count"] == n
        mean = _airborne_mean(f)
        if d.motor == 0:
            assert mean.max() - mean.min() < 0.02
        else:
            assert int(np.argmax(mean)) + 1 == d.motor and mean.max() - np.median(mean) > 0.04
        w = make_windows(f, FeatureSpec(features="nif", n_motors=n))
        assert w.X.shape[1] == 3 + n and len(w) > 20
        labels = labels_for_spans(f.truth, w.t_start, w.t_end)
        assert set(labels.tolist()) == {d.motor}


def test_random_n_rotor_airframes_with_realistic_imbalance_fly():
    rng = np.random.default_rng(3)
    frames = ("hexa_x", "hexa_plus")
    afs = random_airframes(4, rng, frames=frames)
    assert {a.frame for a in afs} <= set(frames) and all(a.rotor_count == 6 for a in afs)
    assert all(1.6 <= a.thrust_to_weight <= 3.5 for a in afs)
    dmg = random_damages(afs, np.full(4, 30.0), np.random.default_rng(4), healthy_fraction=0.0)
    assert all(1 <= d.motor <= 6 and d.rotors == 6 for d in dmg)
    fls = simulate_flights(4, airframes=afs, damages=dmg, duration_s=30.0, seed=5, rho="random", imbalance="random")
    assert all(f.airborne_s > 20.0 and f.motors.values.shape[1] == 6 for f in fls)
    assert all(len(f.truth["imbalance"]["thrust_scale"]) == 6 for f in fls)
    with pytest.raises(ValueError, match="one rotor count"):
        simulate_flights(2, airframes=[preset("x500"), preset("x500", "hexa_x")], duration_s=10.0)
    with pytest.raises(ValueError, match="frames must be"):
        random_airframes(2, rng, frames=("hexa_v",))
    with pytest.raises(ValueError, match="1..4"):
        Damage(5, 0.8)


def test_simulated_hexa_written_as_ulog_reads_back(tmp_path):
    from flightlog_fd.logs.ulog import read_ulog
    from flightlog_fd.logs.ulog_writer import write_ulog

    f = simulate_flights(1, airframes=preset("f450", "hexa_x"), damages=[Damage(3, 0.7, rotors=6)],
                         duration_s=20.0, seed=2)[0]
    back = read_ulog(write_ulog(f, tmp_path / "hexa.ulg"))
    assert back.frame.name == "hexa" and back.vehicle_type == "hexarotor" and back.motors.values.shape[1] == 6
    assert [back.frame.position(k) for k in range(1, 7)] == [f.frame.position(k) for k in range(1, 7)]
    assert len(make_windows(back, FeatureSpec(features="nif", n_motors=6))) > 5


def test_cli_simulates_a_hexa_and_refuses_what_it_cannot_write(tmp_path):
    from typer.testing import CliRunner

    from flightlog_fd.cli import app

    run = CliRunner()
    out = tmp_path / "h.ulg"
    res = run.invoke(app, ["simulate", "-o", str(out), "--frame", "hexa_x", "--motor", "5", "--eta", "0.7",
                           "--duration", "20", "--seed", "3"])
    assert res.exit_code == 0, res.output
    res = run.invoke(app, ["info", "--json", str(out)])
    assert '"name": "hexa"' in res.stdout and '"layout": "PX4 control allocation"' in res.stdout
    rnd = tmp_path / "r.bin"  # a random airframe flown as an octaquad, written as DataFlash
    res = run.invoke(app, ["simulate", "-o", str(rnd), "-f", "dataflash", "--airframe", "random", "--frame",
                           "octaquad_x", "--duration", "15", "--seed", "3"])
    assert res.exit_code == 0, res.output
    res = run.invoke(app, ["info", "--json", str(rnd)])
    assert '"layout": "ArduPilot OCTAQUAD/X"' in res.stdout
    for args, words in ((["--frame", "octo_x", "--motor", "9"], "1..8"),
                        (["--frame", "hexa_x", "--rho", "1,1,1,1"], "needs 6 values"),
                        (["--frame", "hexa_v"], "--frame must be one of")):
        res = run.invoke(app, ["simulate", "-o", str(tmp_path / "x.bin" if "dataflash" in args else tmp_path / "x.ulg"),
                               *args])
        assert res.exit_code == 2 and words in res.output, (args, res.output)
