"""Vibration: readers, the analyzer's level and rotor line, vibration-only verdicts, several
flights in one log. Real-data tests skip when ../shared is absent."""
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from flightlog_fd.analyzers.vibration import (ANALYZER_ID, HEALTHY_LEVEL_REF, VibrationBaseline, VibrationResult,
                                              analyze_vibration, fit_vibration_baseline, result_from, tie_motor)
from flightlog_fd.decision import decide, evidence_bars

#: the nats one rotor's evidence needs for a damaged verdict on a quad under the stated prior
DAMAGED_LLR = evidence_bars(4)[1]
from flightlog_fd.flight import Flight, Frame, ImuStream, Series, Vibration
from flightlog_fd.flights import split_flights

SHARED = Path(__file__).resolve().parents[2] / "shared"
if not SHARED.exists():
    SHARED = Path("/work/shared")
OCTO = SHARED / "real_vibration" / "octo_air"
UDESA = SHARED / "real_vibration" / "quad_udesa" / "udesa_f450_prop13.ulg"
needs_shared = pytest.mark.skipif(not OCTO.exists(), reason="../shared/real_vibration absent")


def _synthetic(level=4.0, line_motor=None, rate=400.0, seconds=60.0, seed=0, flights=1):
    """A quad-X Flight with VIBE at ``level`` (horizontal) and a gyro at ``rate`` Hz carrying, when
    ``line_motor`` is set, a once-per-revolution line at that rotor's speed (f = 90 Hz·sqrt(u/0.4))."""
    rng = np.random.default_rng(seed)
    spans = [(10.0 + i * (seconds + 40.0), 10.0 + i * (seconds + 40.0) + seconds) for i in range(flights)]
    t_end = spans[-1][1] + 10.0
    t = np.arange(0.0, t_end, 1.0 / rate)
    tm = np.arange(0.0, t_end, 0.01)
    u = 0.4 + 0.08 * np.column_stack([np.sin(2 * np.pi * 0.3 * tm + k * 1.7) for k in range(4)])
    g = 0.01 * rng.standard_normal((t.size, 3))
    if line_motor is not None:
        f = 90.0 * np.sqrt(np.interp(t, tm, u[:, line_motor - 1]) / 0.4)
        ph = 2 * np.pi * np.cumsum(f) / rate
        g[:, 0] += 0.2 * np.sin(ph)
        g[:, 1] += 0.2 * np.cos(ph)
    tv = np.arange(0.0, t_end, 0.1)
    vibe = np.column_stack([np.full(tv.size, level / np.sqrt(2))] * 2 + [np.full(tv.size, level)])
    vib = Vibration("ardupilot_vibe", {0: Series(tv, vibe, "VIBE[0]")}, {},
                    [ImuStream(0, "IMU[0]", None, Series(t, g, "GYR[0]"))])
    return Flight(path="synthetic", autopilot="ardupilot", vehicle_type="quadrotor", frame=Frame.quad_x(),
                  motors=Series(tm, u, "RCOU"), motor_kind="thrust", thrust_curve=0.0,
                  armed=[(a - 3, b + 3) for a, b in spans], airborne=spans, t_start=0.0, t_end=t_end,
                  vibration=vib)


def test_level_against_reference_and_profile():
    quiet, shaky = _synthetic(HEALTHY_LEVEL_REF), _synthetic(6 * HEALTHY_LEVEL_REF)
    a, b = analyze_vibration(quiet), analyze_vibration(shaky)
    # no profile: the level alone is bounded by the spread of healthy airframes (NO_PROFILE_LLR_CAP)
    from flightlog_fd.analyzers.vibration import NO_PROFILE_LLR_CAP

    assert a.flight_llr < 0 < b.flight_llr <= NO_PROFILE_LLR_CAP
    base = fit_vibration_baseline([quiet])
    assert analyze_vibration(shaky, base).flight_llr > DAMAGED_LLR
    assert analyze_vibration(_synthetic(1.2 * HEALTHY_LEVEL_REF, seed=3), base).flight_llr < 0


@pytest.mark.parametrize("motor", [1, 3])
def test_line_tied_to_the_rotor_whose_speed_it_follows(motor):
    a = analyze_vibration(_synthetic(line_motor=motor))
    assert a.line is not None and 80.0 < a.line.freq_hz < 100.0  # the sweep of 90 Hz·sqrt(u/0.4)
    assert tie_motor(a.line) == motor and a.line.tie_probs[motor - 1] > 0.9 and a.line.tie_source == "command"
    assert any("once-per-revolution" in n for n in a.notes)


def test_no_line_without_one_and_too_slow_a_gyro():
    assert analyze_vibration(_synthetic()).line is None
    assert analyze_vibration(_synthetic(line_motor=2, rate=80.0)).line is None


NO_OUTPUTS = "no per-motor outputs in the log (actuator_motors / actuator_outputs / RCOU)"


def vibration_only_verdict(flight, profile=None):
    """(Verdict, Decision) of decision.decide from vibration alone, as diagnose gives a log without motor outputs."""
    b = (getattr(profile, "analyzers", None) or {}).get(ANALYZER_ID) if profile is not None else None
    n = flight.frame.rotor_count if flight.frame is not None else 4
    r = result_from(analyze_vibration(flight, VibrationBaseline.from_dict(b) if b else None), n)
    return decide(n, flight.frame, results=[r], not_diagnosable_reason=NO_OUTPUTS)


def test_split_flights_and_vibration_only_verdict():
    f = _synthetic(flights=2)
    parts = split_flights(f)
    assert [p.part.split(",")[0] for p in parts] == ["flight 1 of 2", "flight 2 of 2"]
    assert all(len(p.airborne) == 1 and p.vibration is not None for p in parts)
    f.motors = None
    for p in parts:
        v, d = vibration_only_verdict(p)
        assert v.status == "healthy" and d.results[0].analyzer == ANALYZER_ID and "only vibration" in v.reason


@needs_shared
def test_octo_air_with_and_without_profile():
    from flightlog_fd import load_flight

    healthy = load_flight(OCTO / "air_octo_14.BIN")
    b = fit_vibration_baseline(split_flights(healthy))
    profile = SimpleNamespace(analyzers={ANALYZER_ID: b.to_dict()})
    two = split_flights(load_flight(OCTO / "air_octo_03.BIN"))
    ten = load_flight(OCTO / "air_octo_10.BIN")
    assert len(two) == 2
    with_p = [vibration_only_verdict(f, profile)[0] for f in (two[0], two[1], ten, healthy)]
    assert [v.status for v in with_p] == ["healthy", "damaged", "damaged", "healthy"]
    assert all(v.motor is None for v in with_p)
    assert with_p[1].headline.endswith("inspect every propeller") and "no per-motor outputs" in with_p[1].reason
    without = [vibration_only_verdict(f)[0].status for f in (two[0], two[1], ten, healthy)]
    assert without[0] == without[3] == "healthy" and without[1] in ("uncertain", "damaged") \
        and without[2] in ("uncertain", "damaged")


@needs_shared
def test_octo_air_diagnose_exit_codes():
    from flightlog_fd.diagnose import diagnose_path
    from flightlog_fd.model import FaultModel, default_model_path

    m = FaultModel(default_model_path())
    d03 = diagnose_path(OCTO / "air_octo_03.BIN", m)
    assert d03.exit_code == 1 and "flight 2 of 2" in d03.verdict.reason and "flight 1 of 2" in d03.verdict.reason
    assert diagnose_path(OCTO / "air_octo_14.BIN", m).exit_code == 0


@pytest.mark.skipif(not UDESA.exists(), reason="../shared/real_vibration absent")
def test_udesa_line_near_87_hz():
    from flightlog_fd import load_flight

    f = load_flight(UDESA)
    assert f.motors is not None and f.motors.source.startswith("actuator_controls_0")
    a = analyze_vibration(f)
    assert a.line is not None and 84.0 < a.line.freq_hz < 90.0 and tie_motor(a.line) == 1
    assert any("once-per-revolution" in n and "Hz" in n for n in a.notes)
    from flightlog_fd.diagnose import diagnose_flight, resolve_model

    v = diagnose_flight(f, resolve_model(), keep_flight=False).verdict
    assert v.status == "damaged" and "85." in v.reason and "motor 1" in v.reason
    assert v.motor == 1 or (v.inspect and v.inspect[0] == 1)


def test_tied_line_keeps_the_flight_level_finding():
    from flightlog_fd.analyzers.vibration import result_from

    a = analyze_vibration(_synthetic(5 * HEALTHY_LEVEL_REF, line_motor=2))
    r = result_from(a, 4)
    assert isinstance(r, VibrationResult) and tie_motor(a.line) == 2 and r.line_motor == 2
    assert r.flight_llr == a.flight_llr > 3.5


HEALTHY = sorted((SHARED / "real_healthy" / "logs").glob("*.BIN")) + \
    sorted((SHARED / "real_damaged" / "rrc_straight").glob("good_prop*.BIN")) + \
    sorted((SHARED / "crazypad_e9" / "ulog").glob("normal_flight*.ulg")) + \
    [p for p in (SHARED / "real_logs" / "ardupilot").glob("erle_copter34_*.BIN")]


@pytest.mark.skipif(not HEALTHY, reason="../shared absent")
def test_no_false_alarm_on_real_healthy_flights():
    from flightlog_fd import load_flight

    for p in HEALTHY:
        for f in split_flights(load_flight(p)):
            a = analyze_vibration(f)
            assert a.flight_llr is None or a.flight_llr < DAMAGED_LLR, (p.name, f.part, a.flight_llr)
            if a.line is not None and tie_motor(a.line) is not None:
                pytest.fail(f"{p.name}: a rotor line on a healthy flight ({a.notes})")


@needs_shared
def test_calibrate_and_diagnose_through_the_cli_without_motor_outputs(tmp_path):
    """Done-when of issue 23 through the CLI: a profile from air_octo_14 (no motor outputs; with and
    without --no-adapt), then air_octo_03 (flight 1 healthy, flight 2 damaged) and air_octo_10
    damaged, no rotor named."""
    import json

    from typer.testing import CliRunner

    from flightlog_fd.cli import app
    from flightlog_fd.report.json_report import validate

    runner = CliRunner()
    for extra in ([], ["--no-adapt"]):
        prof = tmp_path / f"p{len(extra)}.json"
        res = runner.invoke(app, ["calibrate", str(OCTO / "air_octo_14.BIN"), "-o", str(prof), *extra])
        assert res.exit_code == 0, res.output
        p = json.loads(prof.read_text())
        assert p["rho_"] is None and p["lacks_"] and p["analyzers"]["vibration"]["kind"] == "vibe"
        res = runner.invoke(app, ["diagnose", "--json", "--profile", str(prof), str(OCTO / "air_octo_03.BIN"),
                                  str(OCTO / "air_octo_10.BIN"), str(OCTO / "air_octo_14.BIN")])
        assert res.exit_code == 1, res.output
        d03, d10, d14 = json.loads(res.output)
        assert all(validate(d) == [] for d in (d03, d10, d14)) and d03["schema"] == 8
        assert [f["part"].split(",")[0] for f in d03["flights"]] == ["flight 1 of 2", "flight 2 of 2"]
        assert [f["verdict"]["status"] for f in d03["flights"]] == ["healthy", "damaged"]
        assert d03["verdict"]["status"] == d10["verdict"]["status"] == "damaged"
        assert d03["verdict"]["motor"] is None and d10["verdict"]["motor"] is None
        assert d14["verdict"]["status"] == "healthy"


def test_raw_level_against_a_profile_only_from_a_fast_stream_at_its_rate():
    from flightlog_fd.analyzers.vibration import RAW_PROFILE_MIN_HZ, Level, VibrationBaseline

    base = VibrationBaseline(0.6, "raw", "IMU[0].AccX/Y/Z", rate_hz=400.0)
    same = Level(2.6, "IMU[0].AccX/Y/Z", "raw", rate_hz=410.0)
    assert base.measures(same)
    assert not base.measures(Level(2.6, "IMU[0].AccX/Y/Z", "raw", rate_hz=250.0))   # another band
    assert not base.measures(Level(2.6, "IMU[1].AccX/Y/Z", "raw", rate_hz=400.0))   # another stream
    slow = VibrationBaseline(0.6, "raw", "IMU[0].AccX/Y/Z", rate_hz=50.0)
    assert RAW_PROFILE_MIN_HZ > 50.0
    assert not slow.measures(Level(2.6, "IMU[0].AccX/Y/Z", "raw", rate_hz=50.0))    # the filtered stream
    assert VibrationBaseline(5.0, "vibe", "VIBE").measures(Level(6.0, "VIBE", "vibe"))
    assert VibrationBaseline.from_dict(base.to_dict()).rate_hz == 400.0


def test_healthy_pair_with_slow_raw_accel_is_not_damaged_by_vibration(shared):
    """A real healthy board calibrated on one flight: its next flight's filtered 50 Hz accelerometer
    reads 4x the calibration's; that must not make vibration evidence against the profile."""
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.vibration import analyze_vibration, fit_vibration_baseline

    logs = shared("real_healthy", "logs")
    cal = load_flight(logs / "erle_Erle-Brain2_Debian-first-flight-with-case.BIN")
    other = load_flight(logs / "erle_pxf_copter_6-3-2014_6.BIN")
    a = analyze_vibration(other, fit_vibration_baseline([cal]))
    assert a.against == "healthy airframes"
    assert a.flight_llr is not None and a.flight_llr < 3.5


def test_batched_periodograms_are_one_window_at_a_time():
    """_psds (one FFT call per batch of windows) gives each window's periodogram bit for bit."""
    import numpy as np

    from flightlog_fd.analyzers.vibration import PSD_BATCH, _psds

    rng = np.random.default_rng(4)
    x = np.cumsum(rng.normal(size=(5000, 2)), axis=0)
    for nper, pad in ((400, 400), (100, 800), (16, 16)):
        starts = np.arange(0, x.shape[0] - nper + 1, nper // 2)[:PSD_BATCH + 7]
        w = np.hanning(nper)
        for i, s in enumerate(starts):
            seg = x[s:s + nper] - x[s:s + nper].mean(axis=0)
            one = (np.abs(np.fft.rfft(seg * w[:, None], n=pad, axis=0)) ** 2).sum(axis=1)
            assert np.array_equal(_psds(x, nper, pad, starts)[i], one) if i % 50 == 0 else True
        batch = _psds(x, nper, pad, starts)
        assert batch.shape == (starts.size, pad // 2 + 1)
        assert np.array_equal(batch[-1], _psds(x, nper, pad, starts[-1:])[0])


# ----------------------------------------------------------------------------- issue 38: lines tied to a rotor


def _lined(rate=250.0, line_hz=90.0, motor=3, equal=False, esc=False, seconds=60.0, seed=1, accel=2.0):
    """A quad-X Flight whose IMU (gyro and accelerometer at ``rate``) carries a line at ``line_hz``
    x its rotor's speed (folded when above rate/2), following ``motor``; ``equal``: every rotor at
    one speed; ``esc``: ESC rpm logged (the line at once per revolution)."""
    from flightlog_fd.flight import EscChannel, EscTelemetry

    rng = np.random.default_rng(seed)
    t_end = seconds + 20.0
    t = np.arange(0.0, t_end, 1.0 / rate)
    tm = np.arange(0.0, t_end, 0.02)
    swing = 0.0 if equal else 0.08
    u = 0.4 + np.column_stack([swing * np.sin(2 * np.pi * 0.2 * tm + k * 1.9) + 0.02 * np.sin(2 * np.pi * 0.05 * tm)
                               for k in range(4)])
    speed = np.sqrt(u / 0.4)  # the line's multiple of line_hz
    f = line_hz * np.interp(t, tm, speed[:, motor - 1])
    ph = 2 * np.pi * np.cumsum(f) / rate
    g = 0.01 * rng.standard_normal((t.size, 3))
    a = 0.3 * rng.standard_normal((t.size, 3)) + np.array([0.0, 0.0, -9.8])
    g[:, 0] += 0.2 * np.sin(ph)
    g[:, 1] += 0.2 * np.cos(ph)
    a[:, 0] += accel * np.sqrt(2) * np.sin(ph)
    a[:, 1] += accel * np.sqrt(2) * np.cos(ph)
    vib = Vibration("", {}, {}, [ImuStream(0, "sensor_combined", Series(t, a, "acc"), Series(t, g, "gyr"))])
    fl = Flight(path="synthetic", autopilot="px4", vehicle_type="quadrotor", frame=Frame.quad_x(),
                motors=Series(tm, u, "actuator_motors"), motor_kind="thrust", thrust_curve=0.0,
                armed=[(5.0, t_end - 5.0)], airborne=[(10.0, 10.0 + seconds)], t_start=0.0, t_end=t_end,
                vibration=vib)
    if esc:
        rpm = line_hz * 60.0 * speed
        fl.esc = EscTelemetry([EscChannel(k + 1, tm, rpm[:, k], online=np.ones(tm.size, bool)) for k in range(4)],
                              "esc_status", {})
    return fl


def test_a_folded_line_is_tied_to_its_rotor():
    from flightlog_fd.analyzers.rotor_lines import fold

    assert fold(160.0, 250.0) == pytest.approx(90.0) and fold(260.0, 250.0) == pytest.approx(10.0)
    a = analyze_vibration(_lined(rate=250.0, line_hz=160.0, motor=3))
    assert a.line is not None and 70.0 < a.line.freq_hz < 110.0  # seen folded: 144-176 Hz at 250 Hz
    assert tie_motor(a.line) == 3 and a.line.follows
    # by the commands alone the fold stays open (the map's exponent is free: 410 Hz moving as s^0.4
    # folds the same); ESC rpm pins it at once per revolution
    e = analyze_vibration(_lined(rate=250.0, line_hz=160.0, motor=3, esc=True))
    assert tie_motor(e.line) == 3 and e.line.folded and e.line.rotor_hz == pytest.approx(160.0, rel=0.05)
    assert "folded from" in e.notes[0]


def test_esc_rpm_tie_at_once_per_revolution():
    a = analyze_vibration(_lined(line_hz=95.0, motor=2, esc=True))
    assert a.line.tie_source == "esc_rpm" and tie_motor(a.line) == 2
    r = result_from(a, 4)
    assert r.tie_source == "esc_rpm" and r.line_motor == 2 and r.tie_trusted


def test_rotors_at_one_speed_name_no_rotor_and_say_why():
    a = analyze_vibration(_lined(motor=4, equal=True))
    r = result_from(a, 4)
    assert r.line_motor is None and not r.tie_trusted
    assert r.tie_probs == pytest.approx([0.25] * 4, abs=0.05)
    assert "turned within" in r.why_untied and "Hz of each other" in r.why_untied
    assert all(f.llr is None for f in r.findings if f.name == "rotor_line")


def test_the_interface_the_decision_reads():
    a = analyze_vibration(_lined(motor=1, accel=8.0))
    r = result_from(a, 4)
    assert r.line_motor == 1 and r.tie_trusted and r.why_untied == ""
    assert len(r.tie_probs) == 4 and sum(r.tie_probs) == pytest.approx(1.0)
    assert r.flight_llr == pytest.approx(r.line_llr + max(r.level_llr, 0.0))
    assert r.line_llr > 0 and r.line_hz is not None
    by = {f.motor: f.llr for f in r.findings if f.name == "rotor_line"}
    assert by[1] == pytest.approx(r.flight_llr + np.log(4 * r.tie_probs[0]))
    from flightlog_fd.analyzers.vibration import TIE_P_FLOOR
    assert min(by.values()) >= r.flight_llr + np.log(4 * TIE_P_FLOOR) - 1e-9
    assert by[1] > max(by[k] for k in (2, 3, 4))


def test_a_fixed_frequency_is_not_a_rotor_line():
    """A line that does not move with the rotors (a mount resonance) carries no evidence and names no rotor."""
    f = _lined(motor=2, accel=8.0)
    f.motors = Series(f.motors.t, np.full_like(f.motors.values, 0.4) + 0.05 * np.sin(f.motors.t)[:, None]
                      * np.array([1.0, -1.0, 1.0, -1.0]), "actuator_motors")
    imu = f.vibration.imus[0]
    t = imu.gyro.t
    ph = 2 * np.pi * 90.0 * t
    imu.gyro.values[:, 0] = 0.01 * np.random.default_rng(2).standard_normal(t.size) + 0.2 * np.sin(ph)
    imu.accel.values[:, 0] = 0.3 * np.random.default_rng(3).standard_normal(t.size) + 8.0 * np.sin(ph)
    imu.accel.values[:, 1] = 0.3 * np.random.default_rng(4).standard_normal(t.size)
    a = analyze_vibration(f)
    assert a.line is not None and not a.line.follows and a.line_llr == 0.0 and tie_motor(a.line) is None
    assert "does not follow" in a.line.why_untied


def test_level_against_the_profile_at_matching_rotor_speed():
    """A payload turns the rotors faster: the level expected there is the profile's x speed^2."""
    from flightlog_fd.analyzers.vibration import SPEED_EXPONENT, Level

    base = VibrationBaseline(5.0, "vibe", "VIBE", sessions=[{"level": 5.0, "speed": 1.0, "flight": "a"}],
                             speed_source="command")
    ln, sd, ratio = base.expected(1.18, "command")
    assert np.exp(ln) == pytest.approx(5.0 * 1.18 ** SPEED_EXPONENT, rel=1e-3) and ratio == pytest.approx(1.18)
    assert sd > base.spread_log  # the exponent's spread widens the comparison away from the sessions
    assert base.expected(1.18, "esc_rpm")[0] == pytest.approx(np.log(5.0))  # another speed: the level itself
    two = VibrationBaseline(5.0, "vibe", "VIBE", sessions=[{"level": 5.0, "speed": 1.0, "flight": "a"},
                                                           {"level": 5.0 * 1.2 ** 1.0, "speed": 1.2, "flight": "b"}],
                            speed_source="command")
    assert np.exp(two.expected(1.2, "command")[0]) < 5.0 * 1.2 ** SPEED_EXPONENT  # sessions pull the exponent
    assert VibrationBaseline.from_dict(two.to_dict()).sessions == two.sessions
    assert base.measures(Level(6.0, "VIBE", "vibe"))


def test_add_sessions_keeps_older_profiles_and_adds_speeds():
    from flightlog_fd.analyzers.vibration import add_sessions

    old = {"analyzer": ANALYZER_ID, "level": 4.0, "kind": "vibe", "source": "VIBE", "flights": ["x"]}
    f = _synthetic(5.0)
    new = add_sessions(old, [f])
    b = VibrationBaseline.from_dict(new)
    assert len(b.sessions) == 2 and b.sessions[0]["speed"] is None  # an older profile's level: speed unknown
    assert b.level == pytest.approx(np.sqrt(4.0 * 5.0), rel=1e-6)
    assert add_sessions(old, []) == old


@needs_shared
def test_octo_air_03_flight_2_against_the_logs_first_flight():
    """Without a profile, a flight of a log is also weighed against the log's quietest other flight."""
    from flightlog_fd import load_flight
    from flightlog_fd.analyzers.vibration import log_reference

    parts = split_flights(load_flight(OCTO / "air_octo_03.BIN"))
    a1 = analyze_vibration(parts[0], None, log_reference(parts, 0))
    a2 = analyze_vibration(parts[1], None, log_reference(parts, 1))
    assert a1.against == "healthy airframes" and a1.flight_llr < 0
    assert a2.against.startswith("log:flight 1") and a2.flight_llr > DAMAGED_LLR and a2.ratio > 4


@pytest.mark.skipif(not UDESA.exists(), reason="../shared/real_vibration absent")
def test_udesa_tied_to_rotor_1_strongly():
    from flightlog_fd import load_flight

    r = result_from(analyze_vibration(load_flight(UDESA)), 4)
    assert r.flight_llr > DAMAGED_LLR and r.line_motor == 1 and r.tie_source == "command"
    assert r.tie_probs[0] > 0.99 and 84.0 < r.line_hz < 90.0


@pytest.mark.skipif(not UDESA.exists(), reason="../shared/real_vibration absent")
def test_a_log_of_sensor_combined_alone_is_judged_from_vibration(tmp_path):
    """The udesa log cut down to sensor_combined (pyulog's writer, into tmp): airborne time from the
    IMU, judged from vibration alone, the words saying what could not be judged."""
    from pyulog import ULog

    from flightlog_fd import load_flight
    from flightlog_fd.diagnose import diagnose_path
    from flightlog_fd.model import FaultModel, default_model_path

    out = tmp_path / "sensor_combined_only.ulg"
    ULog(str(UDESA), message_name_filter_list=["sensor_combined"]).write_ulog(str(out))
    f = load_flight(out)
    assert f.motors is None and f.airborne_source.startswith("IMU")
    assert 60.0 < f.airborne_s < 78.0  # the throttle's 70 s in the full log
    d = diagnose_path(out, FaultModel(default_model_path()))
    assert d.verdict.status in ("uncertain", "damaged") and d.exit_code == 1
    assert "only vibration was judged" in d.verdict.reason and "no motor outputs" in d.verdict.reason
    assert "cannot be tied to a rotor" in d.verdict.reason


def test_calibrate_add_gives_the_vibration_baseline_a_session_at_the_payloads_rotor_speed(tmp_path):
    """`fdlog calibrate --add` with a flight carrying a payload: the vibration baseline gains a
    session at that flight's (faster) rotor speed, and the payload flight is not damaged by vibration."""
    from flightlog_fd import load_flight
    from flightlog_fd.calibration import add_sessions, calibrate
    from flightlog_fd.sim.files import simulate_to_files

    base, loaded = tmp_path / "base.ulg", tmp_path / "loaded.ulg"
    simulate_to_files(base, airframe="f450", imbalance=["1:0"], seed=7, duration=45.0, vehicle_id="v")
    simulate_to_files(loaded, airframe="f450", imbalance=["1:0"], seed=8, duration=45.0, vehicle_id="v",
                      loads=["point:30%@0,0,0.03"])
    prof = tmp_path / "p.json"
    calibrate([base], output=prof)
    b0 = VibrationBaseline.from_dict(__import__("json").loads(prof.read_text())["analyzers"][ANALYZER_ID])
    assert len(b0.sessions) == 1 and b0.speed_source == "command" and b0.sessions[0]["speed"] > 0
    f = load_flight(loaded)
    a = analyze_vibration(f, b0)
    assert a.speed_ratio is not None and a.speed_ratio > 1.05  # the payload turns the rotors faster
    assert a.flight_llr < DAMAGED_LLR
    res = add_sessions(prof, [loaded], name="payload")
    b1 = VibrationBaseline.from_dict(res.profile.analyzers[ANALYZER_ID])
    assert len(b1.sessions) == 2 and b1.sessions[1]["speed"] > b1.sessions[0]["speed"]
    assert any("vibration:" in c for c in res.changes)



def test_a_fixed_line_at_the_band_edge_is_said_to_be_the_edge():
    """The strongest power at the band's lower edge that follows nothing is the skirt of motion or
    a frame mode below it (3 simulated twins, RflyMAD SIL TestCase_1), not "a mount resonance"; a
    fixed line inside the band still reads as a resonance. The edge stays a candidate line: a
    rotor's line folded just below it shows there (results/vibration.md)."""
    from flightlog_fd.analyzers.rotor_lines import LINE_MIN_HZ, RotorLine, why_untied

    edge = RotorLine(LINE_MIN_HZ, 45.0, "sensor_combined", "gyro", 250.0)
    edge.tie_source, edge.follows, edge.follows_llr, edge.tie_probs = "command", False, -25.3, [0.25] * 4
    words = why_untied(edge, 4)
    assert "lower edge" in words and "resonance" not in words
    inside = RotorLine(90.0, 45.0, "sensor_combined", "gyro", 250.0)
    inside.tie_source, inside.follows, inside.follows_llr, inside.tie_probs = "command", False, -25.3, [0.25] * 4
    assert "frame or mount resonance" in why_untied(inside, 4)


def test_the_band_edge_of_rflymad_testcase_1_is_said_to_be_the_edge():
    """RflyMAD's SIL log TestCase_1 (PX4 firmware): its strongest gyro power sits at the band's edge
    and follows nothing; the words say so and the line carries no evidence."""
    log = SHARED / "real_logs" / "px4" / "rflymad_sil" / "TestCase_1_1000000000.ulg"
    if not log.is_file():
        pytest.skip("../shared/real_logs TestCase_1 not available")
    from flightlog_fd import load_flight

    a = analyze_vibration(load_flight(log))
    assert a.line is not None and not a.line.follows and a.line_llr == 0.0
    assert "lower edge" in a.line.why_untied
    from flightlog_fd.analyzers.vibration import line_words

    assert line_words(a.line).startswith("the gyro spectrum's strongest power, at 20.")
