"""Simulated flights written as real log files (`fdlog simulate`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from ..errors import FlightLogError

FORMATS = {"ulog": ".ulg", "dataflash": ".bin"}
#: eta_torque = eta ** this for simulated flights with ESC telemetry (see simulate_to_files).
ESC_SAMPLE_TORQUE_EXPONENT = 1.3


def simulate_to_files(out: Path, *, count: int = 1, fmt: str = "ulog", airframe: str = "x500",
                      frame: Optional[str] = None, motor: int = 0, eta: float = 0.8, onset: Optional[float] = None,
                      duration: float = 60.0, mission: str = "waypoints", log_profile: Optional[str] = None,
                      rho: Optional[list[float]] = None, seed: int = 0, force: bool = False,
                      esc_rate: Optional[float] = None, vehicle_id: Optional[str] = None) -> list[tuple[Path, dict]]:
    """Simulate flights and write them as real log files; returns [(path, truth)].

    ``esc_rate`` (Hz): add ESC telemetry (rpm, current, voltage, temperature per motor) at that
    rate (PX4 ``esc_status``, ArduPilot ``ESC`` with RawRPM); the damaged propeller then also
    loses torque: ``eta_torque = eta ** 1.3`` (blade-element cut, sim/damage.py).

    ``count == 1`` writes the file ``out``; more write ``out/sim_000.ulg``... and ``out/truth.csv``.
    Existing files are never overwritten unless ``force``.
    """
    from ..logs.dataflash_writer import write_dataflash
    from ..logs.ulog_writer import write_ulog
    from .airframe import N_ROTOR_FRAMES, SIM_FRAMES, preset
    from .api import simulate_flights
    from .damage import Damage

    if fmt not in FORMATS:
        raise FlightLogError(out, f"unknown format {fmt!r}: use ulog or dataflash")
    if frame is not None and frame not in SIM_FRAMES:
        raise FlightLogError(out, f"--frame must be one of {', '.join(SIM_FRAMES)}, got {frame!r}")
    rotors = 4 if frame is None or frame not in N_ROTOR_FRAMES else preset("x500", frame).rotor_count
    if not 0 <= motor <= rotors:
        raise FlightLogError(out, f"--motor must be 0 (healthy) or 1..{rotors}, got {motor}")
    if rho is not None and len(rho) != rotors:
        raise FlightLogError(out, f"--rho needs {rotors} values (one per rotor), got {len(rho)}")
    if motor and not 0.0 < eta < 1.0:
        raise FlightLogError(out, f"--eta must be between 0 and 1 for a damaged propeller, got {eta}")
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
    # With ESC telemetry the torque loss shows in the motor current: a cut propeller loses more
    # torque than thrust (R^5 vs R^4: eta_torque = eta^1.25); 1.3 is inside damage.py's 1.0-1.6.
    eta_torque = eta ** ESC_SAMPLE_TORQUE_EXPONENT if (motor and esc_rate) else None
    damage = Damage(motor, eta if motor else 1.0, onset, eta_torque, rotors=rotors) if motor else Damage()
    flights = simulate_flights(count, airframes=af, damages=[damage] * count, mission=mission,
                               duration_s=duration, profile=profile_name, rho=rho, seed=seed,
                               esc=esc_rate, imbalance="random" if esc_rate else None)
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
            w.writerow(["file", "label", "motor", "eta", "onset_s", "airframe", "mission", "seed"])
            for p, t in written:
                w.writerow([p.name, t.get("label"), t.get("motor"), t.get("eta"), t.get("onset_s"),
                            (t.get("airframe") or {}).get("name"), t.get("mission"), t.get("seed")])
    return written
