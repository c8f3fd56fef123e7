"""Simulated flights written as real log files (`fdlog simulate`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence, Union

from ..errors import FlightLogError

FORMATS = {"ulog": ".ulg", "dataflash": ".bin"}
#: eta_torque = eta ** this for simulated flights with ESC telemetry (see simulate_to_files).
ESC_SAMPLE_TORQUE_EXPONENT = 1.3


def simulate_to_files(out: Path, *, count: int = 1, fmt: str = "ulog", airframe: str = "x500",
                      frame: Optional[str] = None, motor: Union[int, Sequence[int]] = 0,
                      eta: Union[float, Sequence[float]] = 0.8,
                      onset: Union[None, float, Sequence[Optional[float]]] = None,
                      duration: float = 60.0, mission: str = "waypoints", log_profile: Optional[str] = None,
                      rho: Optional[list[float]] = None, seed: int = 0, force: bool = False,
                      esc_rate: Optional[float] = None, vehicle_id: Optional[str] = None,
                      imbalance: Optional[list[str]] = None, imu_rate: Optional[float] = None,
                      cause: str = "propeller", loads: Optional[list[str]] = None,
                      esc_curve: Optional[float] = None) -> list[tuple[Path, dict]]:
    """Simulate flights and write them as real log files; returns [(path, truth)].

    ``imbalance``: ["MOTOR:G_MM"] propeller mass imbalance m·r in g·mm on that motor, or
    ["MOTOR:aero=FRACTION"] a blade thrust difference (sim/prop_vibration.py); with it (or with
    ``imu_rate``) every propeller also keeps its healthy residual imbalance, and the logs carry
    VIBE / vehicle_imu_status; ``imu_rate`` (Hz) adds raw IMU samples (ACC/GYR, sensor_accel/gyro).

    ``esc_rate`` (Hz): add ESC telemetry (rpm, current, voltage, temperature per motor) at that
    rate (PX4 ``esc_status``, ArduPilot ``ESC`` with RawRPM); the damaged propeller then also
    loses torque: ``eta_torque = eta ** 1.3`` (blade-element cut, sim/damage.py). ``esc_curve``: the
    rotors turn as omega_max·u^(b/2) for thrust command u (sim/esc.py speed law; default 1, the
    autopilot's thrust model fits the rotor; ArduCopter 4.7 SITL measures 1.33).

    ``motor``: one damaged propeller (0: healthy) or several (e.g. [1, 4]), each with its own
    ``eta`` (one value for all, or one per motor) and ``onset`` (seconds after arming; None or 0:
    from take-off; one value for all, or one per motor).

    ``cause``: what lost the thrust of each ``motor``: ``"propeller"`` (damaged) or ``"motor"``
    (the motor or its ESC is weak: the rotor turns at sqrt(eta) of its commanded speed, the
    propeller is sound; sim/damage.py).

    ``loads``: ``--load`` values (sim/loads.py :func:`~flightlog_fd.sim.loads.parse_load`):
    ``point:MASS@X,Y[,Z]`` or ``point:MASS@motorK[,F]`` (a mass fixed on the frame),
    ``line:MASS@WHERE:LENGTH_M`` (a payload swinging on a line), ``battery:DX[,DY[,DZ]][@MASS]``
    (the battery moved); MASS in kg or ``15%`` of the take-off mass. The truth carries them
    (ULog ``fdlog_truth``; ``truth.csv`` with ``--count``).

    ``count == 1`` writes the file ``out``; more write ``out/sim_000.ulg``... and ``out/truth.csv``.
    Existing files are never overwritten unless ``force``.
    """
    from ..logs.dataflash_writer import write_dataflash
    from ..logs.ulog_writer import write_ulog
    from .airframe import N_ROTOR_FRAMES, SIM_FRAMES, preset
    from .api import simulate_flights
    from .damage import CAUSES, Damage

    if cause not in CAUSES:
        raise FlightLogError(out, f"--cause must be one of {', '.join(CAUSES)}, got {cause!r}")
    if fmt not in FORMATS:
        raise FlightLogError(out, f"unknown format {fmt!r}: use ulog or dataflash")
    if frame is not None and frame not in SIM_FRAMES:
        raise FlightLogError(out, f"--frame must be one of {', '.join(SIM_FRAMES)}, got {frame!r}")
    rotors = 4 if frame is None or frame not in N_ROTOR_FRAMES else preset("x500", frame).rotor_count
    motors, etas, onsets = _damaged(out, motor, eta, onset, rotors)
    if rho is not None and len(rho) != rotors:
        raise FlightLogError(out, f"--rho needs {rotors} values (one per rotor), got {len(rho)}")
    profile_name = log_profile or ("px4_high" if fmt == "ulog" else "ardupilot_fast")
    want_autopilot = "px4" if fmt == "ulog" else "ardupilot"
    if not profile_name.startswith(want_autopilot) and profile_name != "training":
        raise FlightLogError(out, f"logging profile {profile_name!r} does not match format {fmt!r}")
    if count == 1:
        paths = [out]
    else:
        paths = [out / f"sim_{i:03d}{FORMATS[fmt]}" for i in range(count)]
    for p in paths + ([out / "truth.csv"] if count > 1 else []):
        if p.exists() and not force:
            raise FlightLogError(p, "already exists (use --force to overwrite)")
    try:
        if airframe != "random":
            af = [preset(airframe, frame)] * count
        elif frame is not None:  # random airframes flown as this frame (without --frame: random quads)
            import numpy as np

            from .airframe import random_airframes

            af = random_airframes(count, np.random.default_rng([seed, 3]), frames=(frame,))
        else:
            af = None
    except ValueError as e:
        raise FlightLogError(None, str(e)) from None
    if esc_rate is not None and not 10.0 <= esc_rate <= 100.0:
        raise FlightLogError(out, f"--esc-rate must be 10..100 Hz, got {esc_rate:g}")
    if esc_curve is not None:
        from .esc import SPEED_EXPONENT_RANGE

        if esc_rate is None:
            raise FlightLogError(out, "--esc-curve needs --esc-rate (it shapes the ESC telemetry's motors)")
        if not SPEED_EXPONENT_RANGE[0] <= esc_curve <= SPEED_EXPONENT_RANGE[1]:
            raise FlightLogError(out, f"--esc-curve must be {SPEED_EXPONENT_RANGE[0]:g}..{SPEED_EXPONENT_RANGE[1]:g}, "
                                      f"got {esc_curve:g}")
    # With ESC telemetry the torque loss shows in the motor current: a cut propeller loses more
    # torque than thrust (R^5 vs R^4: eta_torque = eta^1.25); 1.3 is inside damage.py's 1.0-1.6.
    torque_exp = ESC_SAMPLE_TORQUE_EXPONENT if (esc_rate and cause == "propeller") else None
    damage = Damage.several(*(Damage(k, e, o, e ** torque_exp if torque_exp else None, rotors=rotors, cause=cause)
                              for k, e, o in zip(motors, etas, onsets))) if motors else Damage()
    props = parse_imbalance(out, imbalance, rotors, imu_rate) if (imbalance or imu_rate) else None
    load_list = parse_loads(out, loads, af[0] if af else None, damage) if loads else None
    try:
        flights = simulate_flights(count, airframes=af, damages=[damage] * count, mission=mission,
                                   duration_s=duration, profile=profile_name, rho=rho, seed=seed,
                                   esc=esc_rate if esc_curve is None else (esc_rate, esc_curve),
                                   imbalance="random" if esc_rate else None,
                                   prop_imbalance=props, imu_rate_hz=imu_rate,
                                   loads=None if load_list is None else tuple(load_list))
    except ValueError as e:
        if load_list is None:
            raise
        raise FlightLogError(out, f"--load: {e}") from None
    if count > 1:
        out.mkdir(parents=True, exist_ok=True)
    written = []
    for i, (p, fl) in enumerate(zip(paths, flights)):
        p.parent.mkdir(parents=True, exist_ok=True)
        fl.path = str(p)
        if vehicle_id:  # one simulated vehicle flown several times (a calibration flight and others)
            fl.vehicle_id = vehicle_id if count == 1 else f"{vehicle_id}-{i}"
        (write_ulog if fmt == "ulog" else write_dataflash)(fl, p)
        written.append((p, fl.truth or {}))
    if count > 1:
        import csv

        with open(out / "truth.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["file", "label", "motor", "eta", "cause", "onset_s", "airframe", "mission", "seed",
                        "motors", "etas", "loads"])
            for p, t in written:
                w.writerow([p.name, t.get("label"), t.get("motor"), t.get("eta"), t.get("cause"), t.get("onset_s"),
                            (t.get("airframe") or {}).get("name"), t.get("mission"), t.get("seed"),
                            ";".join(str(k) for k in t.get("motors") or []),
                            ";".join(f"{e:g}" for e in t.get("etas") or []),
                            ";".join(load_text(x) for x in t.get("loads") or [])])
    return written


def load_text(d: dict) -> str:
    """A load's truth (sim/loads.py ``Load.to_dict``) as one compact field:
    ``point 0.300kg 15.0% @+0.120,+0.120,+0.000`` (a line adds ``L1.00m``)."""
    text = "{} {:.3f}kg {:.1f}% @{:+.3f},{:+.3f},{:+.3f}".format(d["kind"], d["mass_kg"], 100 * d["mass_fraction"],
                                                             *d["position_m"])
    return text + (f" L{d['length_m']:.2f}m" if d.get("length_m") else "")


def parse_loads(out: Path, items: list[str], af, damage) -> list:
    """``--load`` values as Loads; FlightLogError naming ``out`` for a value that does not parse,
    does not fit the airframe ``af`` (None: random airframes, checked as they are drawn), or
    that it cannot hover with (with ``damage``)."""
    from .loads import as_loads, check_flyable, parse_load

    try:
        loads = as_loads([parse_load(x) for x in items])
        if af is not None:
            for ld in loads:
                ld.check(af)
            check_flyable(af, loads, damage)
    except ValueError as e:
        raise FlightLogError(out, str(e) if str(e).startswith("--load") else f"--load: {e}") from None
    return list(loads)


def _damaged(out: Path, motor, eta, onset, rotors: int) -> tuple[list[int], list[float], list[Optional[float]]]:
    """(motors, etas, onsets) of the damaged propellers asked for, one each; FlightLogError for
    bad values (a motor out of range or twice, an eta outside (0, 1), lists of other lengths)."""
    motors = [int(m) for m in (motor if isinstance(motor, (list, tuple)) else [motor])]
    motors = [] if motors in ([], [0]) else motors
    for m in motors:
        if not 1 <= m <= rotors:
            raise FlightLogError(out, f"--motor must be 0 (healthy) or 1..{rotors}, got {m}")
    if len(set(motors)) != len(motors):
        raise FlightLogError(out, f"--motor names each damaged propeller once, got {motors}")

    def per_motor(values, name):
        vals = list(values) if isinstance(values, (list, tuple)) else [values]
        if len(vals) == 1:
            return vals * len(motors)
        if len(vals) != len(motors):
            raise FlightLogError(out, f"--{name} needs one value, or one per --motor ({len(motors)}), got {len(vals)}")
        return vals

    etas = [float(e) for e in per_motor(eta, "eta")] if motors else []
    for e in etas:
        if not 0.0 < e < 1.0:
            raise FlightLogError(out, f"--eta must be between 0 and 1 for a damaged propeller or weak motor, got {e}")
    raw = per_motor(onset if onset is not None else [None], "onset") if motors else []
    onsets = [None if o is None or float(o) == 0.0 else float(o) for o in raw]
    if any(o is not None and o < 0 for o in onsets):
        raise FlightLogError(out, f"--onset must be >= 0 seconds after arming, got {onset}")
    return motors, etas, onsets


def parse_imbalance(out: Path, items: Optional[list[str]], rotors: int, imu_rate: Optional[float]):
    """``--imbalance`` values ("MOTOR:G_MM" or "MOTOR:aero=FRACTION", repeatable) as a PropImbalance."""
    from .prop_vibration import IMU_RATES_HZ, PropImbalance

    if imu_rate is not None and imu_rate not in IMU_RATES_HZ:
        raise FlightLogError(out, f"--imu-rate must be one of {', '.join(f'{r:g}' for r in IMU_RATES_HZ)} Hz, "
                                  f"got {imu_rate:g}")
    mass, aero = [0.0] * rotors, [0.0] * rotors
    for item in items or []:
        try:
            k_text, size = item.split(":", 1)
            k = int(k_text)
            is_aero = size.startswith("aero=")
            value = float(size[5:] if is_aero else size)
        except ValueError:
            raise FlightLogError(out, f"--imbalance must be MOTOR:G_MM or MOTOR:aero=FRACTION, got {item!r}") from None
        if not 1 <= k <= rotors:
            raise FlightLogError(out, f"--imbalance motor must be 1..{rotors}, got {k}")
        if is_aero and not 0.0 <= value < 1.0 or not is_aero and not 0.0 <= value <= 10000.0:
            raise FlightLogError(out, f"--imbalance {item!r}: mass 0..10000 g·mm, aero 0..1")
        if is_aero:
            aero[k - 1] += value
        else:
            mass[k - 1] += value * 1e-6  # g·mm -> kg·m
    return PropImbalance(tuple(mass), tuple(aero))
