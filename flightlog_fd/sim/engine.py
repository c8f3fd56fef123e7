"""The time loop: N vehicles flown together (dynamics + controller + mission + damage + sensors).

One Python loop over time steps; every operation inside works on arrays of all vehicles (no
per-vehicle loop). Time is seconds since arming (t = 0 is the first logged instant). Each step:

1. every ``outer_every`` steps: estimator errors / gusts advance, the mission gives setpoints, the
   position/velocity loops update the desired attitude and thrust;
2. gyro (filtered, noisy, vibrating) and delayed attitude estimate;
3. attitude + rate loops + mixer → thrust setpoints u (0..1), ``w_com = omega_max·sqrt(u)``;
4. rotor effectiveness = damage η (after its onset) × unbalance (``"physical"`` ρ mode), or the
   paper's speed gain (``"paper"`` mode), plus the damaged rotor's separate drag-torque loss and a
   weak motor's lost speed (damage.py cause "motor");
   rigid-body step with the airframe as built (imbalance.py: CoG offset, motor tilt, per-rotor
   coefficient and lag spread) and loaded (loads.py: mass, CoM and inertia of fixed loads and a
   moved battery, a payload swinging on a line), while the controller uses the nominal airframe;
5. recording: stream ``s`` stores its quantities every ``decimation[s]`` steps.

Recordable streams (:data:`STREAM_FIELDS`): ``rates`` (filtered gyro, rad/s), ``attitude``
(estimated quaternion), ``motors`` (thrust setpoints u), ``velocity`` (estimated NED m/s),
``accel`` (accelerometer: body specific force + bias + noise, m/s² FRD), ``w_com`` (commanded rotor speed rad/s), ``w`` (actual rotor speed), ``pos`` (true NED m),
``thrust`` (per-rotor thrust N, of the step before), ``omega`` (true body rates rad/s), ``eta`` (rotor efficiency),
``torque`` (each propeller's drag torque N·m, what its motor delivers: ESC current, sim/esc.py);
``sforce`` (noise-free body specific force m/s², FRD), ``omega_fine`` and ``w_fine`` (true body rates
and rotor speeds, under names of their own so that sim/prop_vibration.py can record them at every
step without changing the decimation other users give ``omega`` / ``w``); ``swing`` (the direction
of a payload's line from its attachment point, NED unit vector; loads.py).

``motor_model`` (sim/esc.py ``MotorArrays``): rotor speeds follow the load-dependent motor model
(a lighter propeller spins faster at the same command) instead of reaching the commanded speed.

The loop stops when every vehicle has disarmed and ``tail_s`` more has passed, or at ``t_max``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from flightlog_fd.sim.airframe import Airframe
from flightlog_fd.sim.controller import CascadeController
from flightlog_fd.sim.damage import DamageArrays
from flightlog_fd.sim.imbalance import ImbalanceArrays
from flightlog_fd.sim.dynamics import QuadDynamics, RigidBodyState, VehicleParams, quat_yaw
from flightlog_fd.sim.missions import MissionPlan, MissionRunner
from flightlog_fd.sim.sensors import SensorParams, Sensors
from flightlog_fd.sim.rho import check_mode, paper_speed_gain, physical_effectiveness

STREAM_FIELDS = {"rates": 3, "attitude": 4, "motors": 4, "velocity": 3, "accel": 3, "w_com": 4, "w": 4,
                 "pos": 3, "thrust": 4, "omega": 3, "eta": 4, "torque": 4,
                 "sforce": 3, "omega_fine": 3, "w_fine": 4, "swing": 3}
#: Streams with one column per rotor (STREAM_FIELDS gives a quad's 4; a hexa records 6).
ROTOR_STREAMS = ("motors", "w_com", "w", "thrust", "eta", "torque", "w_fine")
#: Simulated time kept after the last disarm (covers the logger's tail after disarming).
DEFAULT_TAIL_S = 1.0


@dataclass
class BatchResult:
    """Recorded streams of a batch: ``times[s]`` (M,) s since arming, ``data[s]`` (M, N, k) float32."""

    times: dict[str, np.ndarray]
    data: dict[str, np.ndarray]
    t_takeoff_cmd: np.ndarray  # (N,) s, take-off leg start (thrust ramp), NaN if never
    t_takeoff: np.ndarray  # (N,) s, lift-off, NaN if never airborne
    t_touchdown: np.ndarray  # (N,) s, ground contact at landing, NaN if never landed again
    t_landed: np.ndarray  # (N,) s, land detector "landed" (motors stopped), NaN if never
    t_disarm: np.ndarray  # (N,) s, NaN if still armed at the end
    t_end: float  # last simulated time, s
    dt: float


def run_batch(airframes: Sequence[Airframe], plan: MissionPlan, damage: DamageArrays, rho: np.ndarray, rho_mode: str,
              sensor_params: SensorParams, dt: float, decimation: dict[str, int], t_max: float,
              rng: np.random.Generator, tail_s: float = DEFAULT_TAIL_S,
              imbalance: Optional[ImbalanceArrays] = None, motor_model=None, loads=None) -> BatchResult:
    """Fly the batch; see the module docstring. ``decimation`` maps stream name → record every k steps;
    ``imbalance`` the airframes as built (None: as designed); ``loads`` what they carry
    (:class:`~flightlog_fd.sim.loads.LoadArrays`, None: nothing; the controller is not told)."""
    check_mode(rho_mode)
    for name in decimation:
        if name not in STREAM_FIELDS:
            raise ValueError(f"unknown stream {name!r}; known: {sorted(STREAM_FIELDS)}")
    vp = VehicleParams.from_airframes(airframes)
    n, n_rot = vp.n, vp.n_rotors
    fields = {k: (n_rot if k in ROTOR_STREAMS else c) for k, c in STREAM_FIELDS.items()}
    vp_built = vp if imbalance is None else vp.with_imbalance(imbalance)
    dyn = QuadDynamics(vp_built if loads is None else vp_built.with_loads(loads), dt)
    if loads is not None:
        dyn.set_loads(loads)
    if "swing" in decimation and dyn.line_mass is None:
        raise ValueError("the 'swing' stream needs a payload on a line")
    dyn.track_specific_force = "accel" in decimation or "sforce" in decimation
    if motor_model is not None:
        dyn.set_motor_model(motor_model.a0, motor_model.kv_scale, motor_model.speed_exponent)
    ctrl = CascadeController(airframes, vp, dt)
    sens = Sensors(sensor_params, vp, dt, ctrl.dt_outer, rng)
    runner = MissionRunner(plan)
    state = RigidBodyState.on_ground(n, yaw=plan.home_yaw, n_rotors=n_rot)
    rho_t = rho.T.copy()
    unbalance = physical_effectiveness(rho_t) if rho_mode == "physical" else np.ones((n_rot, n))
    eta_full = damage.eta.T.copy()
    # Drag-torque efficiency relative to the thrust efficiency of each damaged rotor (None: equal).
    drag_full = None if damage.eta_torque is None else (damage.eta_torque / damage.eta).T.copy()
    drag_ratio = None
    # Fraction of the commanded speed each motor delivers (a weak motor or ESC; None: all 1).
    drive_full = None if damage.drive is None else damage.drive.T.copy()
    drive = None
    imbalance_base = damage.imbalance_base.T.copy()
    onset = damage.onset.T.copy()  # (R, N): each rotor's own onset
    omega_max = vp.omega_max

    n_max = int(np.ceil(t_max / dt))
    # Recording buffers sized for the longest possible run; pages never written are never
    # committed by the OS, so an early stop costs no memory.
    rec = {k: np.empty((n_max // d + 2, n, fields[k]), np.float32) for k, d in decimation.items()}
    rec_t = {k: np.empty(n_max // d + 2) for k, d in decimation.items()}
    count = dict.fromkeys(decimation, 0)
    t_all_done = None
    mode = np.zeros(n, dtype=np.int64)
    eta = np.ones((n_rot, n))
    eff = unbalance.copy()
    wind = sens.wind
    thrust = np.zeros((n_rot, n))
    t = 0.0
    for i in range(n_max + 1):
        t = i * dt
        if i % ctrl.outer_every == 0:
            # Damage onset, estimator errors, gusts, mission and position/velocity loops.
            eta = np.where(t >= onset, eta_full, 1.0)
            eff = eta * unbalance
            if drag_full is not None:
                drag_ratio = np.where(t >= onset, drag_full, 1.0)
            if drive_full is not None:
                drive = np.where(t >= onset, drive_full, 1.0)
            pos_est, vel_est, wind = sens.nav(state.pos, state.vel, state.w, imbalance_base + (1.0 - eta))
            sp = runner.update(t, ctrl.dt_outer, pos_est.T, quat_yaw(state.quat), state.landed)
            mode = sp.mode
            ctrl.outer(pos_est, vel_est, sp.pos.T, sp.vel_ff.T, sp.speed_lim, sp.yaw, sp.yaw_rate_ff, mode,
                       sp.man_acc_xy.T, sp.man_vz, state.landed, sp.thrust_ramp)
            if t_all_done is None and runner.all_done(t):
                t_all_done = t
        gyro, disturbance = sens.gyro_and_disturbance(state.omega)
        q_est = sens.attitude(state.quat)
        u = ctrl.inner(q_est, gyro, state.landed, mode)
        w_com = omega_max * np.sqrt(u)
        gain = None if rho_mode == "physical" else paper_speed_gain(rho_t, state.w, omega_max)
        for name, k in decimation.items():
            if i % k:
                continue
            if name == "rates":
                v = gyro
            elif name == "attitude":
                v = q_est
            elif name == "motors":
                v = u
            elif name == "velocity":
                v = state.vel + sens.vel_err
            elif name == "accel":  # specific force of the previous step, as the thrust below
                v = sens.accelerometer(dyn.specific_force)
            elif name == "w_com":
                v = w_com
            elif name == "w":
                v = state.w
            elif name == "pos":
                v = state.pos
            elif name in ("omega", "omega_fine"):
                v = state.omega
            elif name == "w_fine":
                v = state.w
            elif name == "swing":
                v = dyn.line_n
            elif name == "sforce":  # specific force of the previous step, noise-free
                v = dyn.specific_force
            elif name == "eta":
                v = eta
            elif name == "torque":
                v = dyn.rotor_drag_torque(state.w, eff, drag_ratio)
            else:  # thrust of the previous step (the rotor state lags anyway)
                v = thrust
            c = count[name]
            rec[name][c] = v.T
            rec_t[name][c] = t
            count[name] = c + 1
        thrust = dyn.step(state, w_com, eff, wind, disturbance, gain, drag_ratio, drive)
        if t_all_done is not None and t >= t_all_done + tail_s:
            break
    data = {k: v[:count[k]] for k, v in rec.items()}
    times = {k: v[:count[k]] for k, v in rec_t.items()}
    return BatchResult(times=times, data=data, t_takeoff_cmd=runner.t_takeoff_cmd, t_takeoff=runner.t_takeoff,
                       t_touchdown=runner.t_touchdown, t_landed=runner.t_landed, t_disarm=runner.t_disarm,
                       t_end=t, dt=dt)
