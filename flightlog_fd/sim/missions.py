"""Missions: per-vehicle leg lists planned up front, then run for N vehicles at once (vectorised).

Legs (``LEG_*``): pre-arm wait on the ground (armed, motors stopped, as the start of a PX4 log),
take-off (collective thrust ramped up over 1-2 s, then a vertical climb to 5-10 m at 1-2 m/s,
trapezoidal speed profile), hold (steady hover,
≥ ``MIN_CALIBRATION_HOVER_S`` after take-off so an unbalance calibration has steady hover),
go-to (straight line at 1-5 m/s, accel ≤ 1.5-3 m/s², yaw slewed to a new heading at 30-60 °/s),
yaw turn in place (90-360 °), manual flying (pilot sticks), land (descent at 1.2 m/s down to 3 m,
then 0.5-1 m/s until the ground is felt for a land-detector delay of 1-3 s: "landed", motors
stop), done (on the ground; disarmed ``DISARM_DELAY_S`` after "landed", as PX4's COM_DISARM_LAND).

Missions (:func:`plan_missions`):

- ``"waypoints"``: pre-arm, take-off, hover 4-8 s, random waypoints (|xy| ≤ 15 m, altitude 4-10 m,
  1-5 m/s) with heading changes, short holds and in-place yaw turns, return home, hover, land.
  The number of waypoints is chosen so that the estimated flight fits ``duration_s``; the hover
  at home lasts until the landing is due, so flights last about ``duration_s`` (longer when a
  vehicle falls behind its plan).
- ``"hover"``: pre-arm, take-off, hover for the rest of ``duration_s``, land.
- ``"manual"``: pre-arm, take-off to 1.5-4 m, then a pilot flying in an altitude-hold style
  mode: smooth random stick inputs (sum of 3 sinusoids of 0.05-0.5 Hz per stick, with calm
  periods) for tilt (5-25°), yaw rate (20-90 °/s) and climb rate (0.3-1.5 m/s); the pilot keeps
  the vehicle within 5-15 m of home and 1-12 m of altitude; then land.

Setpoints come out in NED metres / rad; position legs use a "carrot" moving along the leg (PX4's
trajectory generator does the same), so the controller gets a position and a feed-forward speed.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY
from flightlog_fd.sim.controller import MODE_MANUAL, MODE_OFF, MODE_POSITION

MISSIONS = ("waypoints", "hover", "manual")

LEG_PREARM, LEG_TAKEOFF, LEG_HOLD, LEG_GOTO, LEG_YAW, LEG_MANUAL, LEG_LAND, LEG_DONE = range(8)

MIN_CALIBRATION_HOVER_S = 4.0
WAYPOINT_RADIUS_M = 15.0
WAYPOINT_ALT_RANGE_M = (4.0, 10.0)
TAKEOFF_ALT_RANGE_M = (5.0, 10.0)
SPEED_RANGE_MS = (1.0, 5.0)
ACCEPTANCE_RADIUS_M = 1.0
GOTO_TIMEOUT_S = 15.0
LAND_DETECT_RANGE_S = (1.0, 3.0)
#: PX4 COM_DISARM_LAND-like: disarm this long after the land detector says "landed".
DISARM_DELAY_S = 2.0
#: PX4-like take-off thrust ramp (MPC_TKO_RAMP_T-like): the collective thrust rises from zero over this.
TAKEOFF_RAMP_RANGE_S = (1.0, 2.0)
#: PX4 AUTO.LAND-like descent: fast (MPC_Z_VEL_MAX_DN-like) down to LAND_SLOW_ALT_M, then the land speed.
LAND_FAST_SPEED_MS = 1.2
LAND_SLOW_ALT_M = 3.0
STICK_SINES = 3


@dataclass
class MissionPlan:
    """Legs for N vehicles, padded with LEG_DONE to the longest plan (arrays, leading axis vehicle)."""

    name: str
    missions: tuple  # (N,) each vehicle's mission name
    kind: np.ndarray  # (N, L) int
    target: np.ndarray  # (N, L, 3) NED m
    speed: np.ndarray  # (N, L) m/s
    dyaw: np.ndarray  # (N, L) rad (heading change during the leg)
    yaw_rate: np.ndarray  # (N, L) rad/s
    duration: np.ndarray  # (N, L) s (hold / pre-arm / manual / land-detect)
    until: np.ndarray  # (N, L) s since arming before which a hold / manual leg does not end
    accel: np.ndarray  # (N,) m/s²
    takeoff_ramp: np.ndarray  # (N,) s
    home_yaw: np.ndarray  # (N,) rad
    # Manual flying: sticks (fwd accel, right accel, yaw rate, climb rate) as sums of sines.
    stick_freq: np.ndarray  # (N, 4, K) Hz
    stick_amp: np.ndarray  # (N, 4, K)
    stick_phase: np.ndarray  # (N, 4, K)
    calm_freq: np.ndarray  # (N,) Hz of the calm/active envelope
    calm_phase: np.ndarray  # (N,)
    home_radius: np.ndarray  # (N,) m
    alt_range: np.ndarray  # (N, 2) m
    estimated_s: np.ndarray  # (N,) planned flight time, s

    @property
    def n(self) -> int:
        return int(self.kind.shape[0])


def _trapezoid_time(dist: float, speed: float, accel: float) -> float:
    t_a = speed / accel
    if accel * t_a * t_a > dist:
        return 2.0 * np.sqrt(dist / accel)
    return 2.0 * t_a + (dist - accel * t_a * t_a) / speed


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _plan_one(mission: str, duration_s: float, rng: np.random.Generator) -> tuple[list[tuple], float, float, dict]:
    """Legs (kind, target, speed, dyaw, yaw_rate, duration) for one vehicle."""
    legs: list[tuple] = []
    accel = rng.uniform(1.5, 3.0)
    ramp = rng.uniform(*TAKEOFF_RAMP_RANGE_S)
    yaw = rng.uniform(-np.pi, np.pi)
    home_yaw = yaw
    t_est = 0.0
    prearm = rng.uniform(1.5, 2.5)
    legs.append((LEG_PREARM, (0.0, 0.0, 0.0), 0.0, 0.0, 0.5, prearm))
    t_est += prearm
    alt_range = TAKEOFF_ALT_RANGE_M if mission != "manual" else (1.5, 4.0)
    alt = rng.uniform(*alt_range)
    climb = rng.uniform(1.0, 2.0)
    legs.append((LEG_TAKEOFF, (0.0, 0.0, -alt), climb, 0.0, 0.5, 0.0))
    t_est += _trapezoid_time(alt, climb, accel) + 1.0 + ramp
    land_speed = rng.uniform(0.5, 1.0)
    land_detect = rng.uniform(*LAND_DETECT_RANGE_S)
    manual = {}

    def land_time(a: float) -> float:
        fast = max(a - LAND_SLOW_ALT_M, 0.0)
        return fast / LAND_FAST_SPEED_MS + (a - fast) / land_speed + land_detect + 1.0

    if mission == "hover":
        hold = max(MIN_CALIBRATION_HOVER_S, duration_s - t_est - land_time(alt))
        legs.append((LEG_HOLD, (0.0, 0.0, -alt), 0.0, 0.0, 0.5, hold))
        t_est += hold
        pos, final_alt = np.array([0.0, 0.0, -alt]), alt
    elif mission == "manual":
        hold = rng.uniform(MIN_CALIBRATION_HOVER_S, 6.0)
        legs.append((LEG_HOLD, (0.0, 0.0, -alt), 0.0, 0.0, 0.5, hold))
        t_est += hold
        fly = max(5.0, duration_s - t_est - land_time(6.0))
        legs.append((LEG_MANUAL, (0.0, 0.0, -alt), 0.0, 0.0, 0.5, fly))
        t_est += fly
        pos, final_alt = np.array([0.0, 0.0, -alt]), 6.0
    else:
        hold = rng.uniform(MIN_CALIBRATION_HOVER_S, 8.0)
        legs.append((LEG_HOLD, (0.0, 0.0, -alt), 0.0, 0.0, 0.5, hold))
        t_est += hold
        pos = np.array([0.0, 0.0, -alt])
        while True:
            r = WAYPOINT_RADIUS_M * np.sqrt(rng.uniform(0.1, 1.0))
            ang = rng.uniform(-np.pi, np.pi)
            wp = np.array([r * np.cos(ang), r * np.sin(ang), -rng.uniform(*WAYPOINT_ALT_RANGE_M)])
            speed = rng.uniform(*SPEED_RANGE_MS)
            d = float(np.linalg.norm(wp - pos))
            ret = float(np.linalg.norm(wp[:2])) / 3.0 + land_time(-wp[2]) + 4.0
            leg_t = _trapezoid_time(d, speed, accel) + 2.0
            if t_est + leg_t + ret > duration_s and len(legs) > 3:
                break
            if t_est + leg_t + ret > duration_s + 30.0:
                break
            # Heading: face the direction of travel, keep it, or a random one.
            choice = rng.uniform()
            if choice < 0.5:
                new_yaw = np.arctan2(wp[1] - pos[1], wp[0] - pos[0])
            elif choice < 0.75:
                new_yaw = rng.uniform(-np.pi, np.pi)
            else:
                new_yaw = yaw
            dyaw = float(_wrap(new_yaw - yaw))
            yaw_rate = np.radians(rng.uniform(30.0, 60.0))
            legs.append((LEG_GOTO, tuple(wp), speed, dyaw, yaw_rate, 0.0))
            yaw += dyaw
            t_est += max(leg_t, abs(dyaw) / yaw_rate)
            pos = wp
            pause = rng.uniform(0.5, 3.0)
            legs.append((LEG_HOLD, tuple(wp), 0.0, 0.0, 0.5, pause))
            t_est += pause
            if rng.uniform() < 0.3:
                turn = float(rng.choice([-1.0, 1.0]) * np.radians(rng.uniform(90.0, 360.0)))
                rate = np.radians(rng.uniform(30.0, 60.0))
                legs.append((LEG_YAW, tuple(wp), 0.0, turn, rate, 0.0))
                yaw += turn
                t_est += abs(turn) / rate + 1.0
        home = np.array([0.0, 0.0, pos[2]])
        speed = rng.uniform(*SPEED_RANGE_MS)
        legs.append((LEG_GOTO, tuple(home), speed, 0.0, 0.5, 0.0))
        t_est += _trapezoid_time(float(np.linalg.norm(home - pos)), speed, accel) + 2.0
        legs.append((LEG_HOLD, tuple(home), 0.0, 0.0, 0.5, rng.uniform(1.0, 3.0)))
        final_alt = -pos[2]
        pos = home
    # The leg before landing lasts at least until the planned landing time, so that vehicles ahead
    # of their estimate hover (or keep flying manually) instead of idling on the ground.
    until = duration_s - land_time(final_alt)
    legs[-1] = legs[-1] + (until,)
    t_est = max(t_est, until)
    legs.append((LEG_LAND, tuple(pos), land_speed, 0.0, 0.5, land_detect))
    t_est += land_time(final_alt)
    legs.append((LEG_DONE, tuple(pos), 0.0, 0.0, 0.5, 0.0))

    # Pilot sticks for the manual leg: (fwd accel, right accel, yaw rate, climb rate).
    tilt = np.radians(rng.uniform(5.0, 25.0))
    amps = np.array([GRAVITY * np.tan(tilt), GRAVITY * np.tan(tilt), np.radians(rng.uniform(20.0, 90.0)),
                     rng.uniform(0.3, 1.5)])
    w = rng.uniform(0.3, 1.0, size=(4, STICK_SINES))
    manual = dict(
        stick_freq=rng.uniform(0.05, 0.5, size=(4, STICK_SINES)),
        stick_amp=amps[:, None] * w / w.sum(axis=1, keepdims=True),
        stick_phase=rng.uniform(0.0, 2 * np.pi, size=(4, STICK_SINES)),
        calm_freq=rng.uniform(0.02, 0.05), calm_phase=rng.uniform(0.0, 2 * np.pi),
        home_radius=rng.uniform(5.0, 15.0), alt_range=(1.0, rng.uniform(6.0, 12.0)),
    )
    return legs, accel, home_yaw, dict(manual, estimated_s=t_est + DISARM_DELAY_S, takeoff_ramp=ramp)


def plan_missions(n: int, mission: Union[str, Sequence[str]], duration_s: float,
                  rng: np.random.Generator) -> MissionPlan:
    """Plan ``mission`` for ``n`` vehicles, each aiming at about ``duration_s`` from arming to disarm.

    ``mission``: one name for every vehicle, or ``n`` names (one batch flies them together: the
    legs are per vehicle); the plan's ``name`` is then the names joined with "+" in first-seen order.
    """
    missions = [mission] * n if isinstance(mission, str) else list(mission)
    if len(missions) != n:
        raise ValueError(f"got {len(missions)} missions for {n} vehicles")
    bad = sorted({m for m in missions if m not in MISSIONS})
    if bad:
        raise ValueError(f"mission must be one of {MISSIONS}, got {bad[0]!r}")
    plans = [_plan_one(m, duration_s, rng) for m in missions]
    n_legs = max(len(p[0]) for p in plans)
    kind = np.full((n, n_legs), LEG_DONE, dtype=np.int64)
    target = np.zeros((n, n_legs, 3))
    speed = np.zeros((n, n_legs))
    dyaw = np.zeros((n, n_legs))
    yaw_rate = np.full((n, n_legs), 0.5)
    duration = np.zeros((n, n_legs))
    until = np.zeros((n, n_legs))
    for i, (legs, _, _, _) in enumerate(plans):
        for j, leg in enumerate(legs):
            kind[i, j], target[i, j], speed[i, j], dyaw[i, j], yaw_rate[i, j], duration[i, j] = leg[:6]
            until[i, j] = leg[6] if len(leg) > 6 else 0.0
        target[i, len(legs):] = legs[-1][1]
    m = [p[3] for p in plans]
    return MissionPlan(
        name="+".join(dict.fromkeys(missions)), missions=tuple(missions), kind=kind, target=target, speed=speed, dyaw=dyaw, yaw_rate=yaw_rate, duration=duration,
        until=until,
        accel=np.array([p[1] for p in plans]), takeoff_ramp=np.array([p[3]["takeoff_ramp"] for p in plans]),
        home_yaw=np.array([p[2] for p in plans]),
        stick_freq=np.array([x["stick_freq"] for x in m]), stick_amp=np.array([x["stick_amp"] for x in m]),
        stick_phase=np.array([x["stick_phase"] for x in m]), calm_freq=np.array([x["calm_freq"] for x in m]),
        calm_phase=np.array([x["calm_phase"] for x in m]), home_radius=np.array([x["home_radius"] for x in m]),
        alt_range=np.array([x["alt_range"] for x in m]), estimated_s=np.array([x["estimated_s"] for x in m]),
    )


@dataclass
class Setpoints:
    """What the mission asks of the controller this tick (arrays over vehicles)."""

    mode: np.ndarray  # (N,) MODE_*
    pos: np.ndarray  # (N, 3)
    vel_ff: np.ndarray  # (N, 3)
    speed_lim: np.ndarray  # (N,)
    yaw: np.ndarray  # (N,)
    yaw_rate_ff: np.ndarray  # (N,)
    man_acc_xy: np.ndarray  # (N, 2)
    man_vz: np.ndarray  # (N,)
    thrust_ramp: np.ndarray  # (N,) 0..1 factor on the collective thrust (take-off ramp)


class MissionRunner:
    """Steps the leg state machine of N vehicles; records take-off, touchdown and disarm times.

    Quantities that only change with the leg (its kind, target, trapezoid timing...) are cached and
    refreshed for the vehicles that change leg, so a tick costs a few dozen array operations.
    """

    def __init__(self, plan: MissionPlan):
        self.plan = plan
        n = plan.n
        self.idx = np.zeros(n, dtype=np.int64)
        self.t_leg0 = np.zeros(n)
        self.start_pos = np.zeros((n, 3))
        self.start_yaw = plan.home_yaw.copy()
        self.yaw_sp = plan.home_yaw.copy()
        self.landed_since = np.full(n, np.nan)
        self.t_takeoff_cmd = np.full(n, np.nan)  # take-off leg start (PX4's land detector flips here)
        self.t_takeoff = np.full(n, np.nan)  # lift-off (ground contact lost)
        self.t_touchdown = np.full(n, np.nan)  # ground contact again
        self.t_landed = np.full(n, np.nan)  # land detector: landed (motors stop)
        self.t_disarm = np.full(n, np.nan)
        self.kind = np.zeros(n, dtype=np.int64)
        self.target = np.zeros((n, 3))
        self.speed = np.zeros(n)
        self.dyaw = np.zeros(n)
        self.yaw_rate = np.ones(n)
        self.duration = np.zeros(n)
        self.until = np.zeros(n)
        self.direction = np.zeros((n, 3))
        self.dist = np.zeros(n)
        self.t_a = np.zeros(n)
        self.t_c = np.zeros(n)
        self.v_peak = np.zeros(n)
        self.t_total = np.zeros(n)
        self.turn_t = np.zeros(n)
        self._refresh(np.arange(n))

    def _refresh(self, ids: np.ndarray) -> None:
        """Load the current leg of vehicles ``ids`` and its trapezoidal speed profile."""
        p, j = self.plan, self.idx[ids]
        self.kind[ids] = p.kind[ids, j]
        target = p.target[ids, j]
        self.target[ids] = target
        speed = p.speed[ids, j]
        self.speed[ids] = speed
        dyaw, yaw_rate = p.dyaw[ids, j], p.yaw_rate[ids, j]
        self.dyaw[ids], self.yaw_rate[ids], self.duration[ids] = dyaw, yaw_rate, p.duration[ids, j]
        self.until[ids] = p.until[ids, j]
        self.turn_t[ids] = np.abs(dyaw) / yaw_rate
        delta = target - self.start_pos[ids]
        dist = np.linalg.norm(delta, axis=1)
        self.dist[ids] = dist
        self.direction[ids] = delta / np.maximum(dist, 1e-9)[:, None]
        a = p.accel[ids]
        v = np.maximum(speed, 0.1)
        tri = v * v / a > dist  # never reaches cruise speed: triangular profile
        v_peak = np.where(tri, np.sqrt(dist * a), v)
        t_a = v_peak / a
        t_c = np.where(tri, 0.0, (dist - a * t_a * t_a) / np.maximum(v_peak, 1e-9))
        self.v_peak[ids], self.t_a[ids], self.t_c[ids], self.t_total[ids] = v_peak, t_a, t_c, 2 * t_a + t_c

    def all_done(self, t: float) -> bool:
        """Every vehicle landed and disarmed by time ``t``."""
        return bool(np.all(self.kind == LEG_DONE) and np.all(self.t_disarm <= t))

    def update(self, t: float, dt: float, pos_est: np.ndarray, yaw_est: np.ndarray, landed: np.ndarray) -> Setpoints:
        """Setpoints at time ``t`` (s since arming); ``dt`` is the time since the previous call.

        ``pos_est`` (N, 3) NED m, ``yaw_est`` (N,) rad, ``landed`` (N,) ground contact.
        """
        p, n, kind = self.plan, self.plan.n, self.kind
        target, speed, duration = self.target, self.speed, self.duration
        tau = t - self.t_leg0

        # Take-off / touchdown events from the ground contact.
        airborne_leg = (kind != LEG_PREARM) & (kind != LEG_DONE)
        lifted = airborne_leg & ~landed & np.isnan(self.t_takeoff)
        self.t_takeoff[lifted] = t
        is_land = kind == LEG_LAND
        landing = is_land & landed
        self.landed_since = np.where(landing, np.fmin(self.landed_since, t), np.nan)
        self.t_touchdown[landing & np.isnan(self.t_touchdown)] = t

        # Carrot along the leg (take-off and go-to), trapezoidal speed profile.
        a, t_a, t_c, v_peak, t_total = p.accel, self.t_a, self.t_c, self.v_peak, self.t_total
        tc = np.clip(tau, 0.0, t_total)
        s = np.where(tc < t_a, 0.5 * a * tc * tc,
                     np.where(tc < t_a + t_c, 0.5 * a * t_a * t_a + v_peak * (tc - t_a),
                              self.dist - 0.5 * a * (t_total - tc) ** 2))
        sdot = np.where(tc < t_a, a * tc, np.where(tc < t_a + t_c, v_peak, a * (t_total - tc)))
        moving = ((kind == LEG_TAKEOFF) | (kind == LEG_GOTO)) & (tau < t_total)
        s_m = np.where(moving, s, np.where((kind == LEG_TAKEOFF) | (kind == LEG_GOTO), self.dist, 0.0))
        pos_sp = self.start_pos + self.direction * s_m[:, None]
        vel_ff = self.direction * (sdot * moving)[:, None]

        # Landing: the carrot descends fast down to LAND_SLOW_ALT_M, then at the land speed, until
        # 1 m below ground (the vehicle sits on the ground long before).
        t_fast = np.maximum(-LAND_SLOW_ALT_M - self.start_pos[:, 2], 0.0) / LAND_FAST_SPEED_MS
        land_z = np.minimum(self.start_pos[:, 2] + LAND_FAST_SPEED_MS * np.minimum(tau, t_fast)
                            + speed * np.maximum(tau - t_fast, 0.0), 1.0)
        pos_sp[:, 2] = np.where(is_land, land_z, pos_sp[:, 2])
        land_vz = np.where(tau < t_fast, LAND_FAST_SPEED_MS, speed) * (land_z < 1.0)
        vel_ff[:, 2] = np.where(is_land, land_vz, vel_ff[:, 2])

        # Heading: slew by dyaw at yaw_rate (go-to and yaw legs); the pilot's yaw rate in manual.
        turning = tau < self.turn_t
        sign = np.sign(self.dyaw)
        yaw_sp = self.start_yaw + sign * np.minimum(np.abs(self.dyaw), self.yaw_rate * np.maximum(tau, 0.0))
        yaw_rate_ff = sign * self.yaw_rate * turning

        # Manual: pilot sticks with a calm/active envelope and a pull back towards home / altitude band.
        is_manual = kind == LEG_MANUAL
        man_acc_xy = np.zeros((n, 2))
        man_vz = np.zeros(n)
        if is_manual.any():
            ph = 2 * np.pi * p.stick_freq * t + p.stick_phase
            sticks = (p.stick_amp * np.sin(ph)).sum(axis=2)  # (N, 4)
            env = np.clip(0.5 + 0.8 * np.sin(2 * np.pi * p.calm_freq * t + p.calm_phase), 0.0, 1.0)
            sticks *= env[:, None]
            c, sn = np.cos(yaw_est), np.sin(yaw_est)
            d_xy = pos_est[:, :2]
            d = np.linalg.norm(d_xy, axis=1)
            pull = 0.4 * np.maximum(d - p.home_radius, 0.0) / np.maximum(d, 1e-9)
            man_acc_xy[:, 0] = c * sticks[:, 0] - sn * sticks[:, 1] - pull * d_xy[:, 0]
            man_acc_xy[:, 1] = sn * sticks[:, 0] + c * sticks[:, 1] - pull * d_xy[:, 1]
            alt = -pos_est[:, 2]
            # Climb rate is NED down-positive: below the band push up (negative), above push down.
            man_vz = -sticks[:, 3] - 0.8 * np.maximum(p.alt_range[:, 0] - alt, 0.0) + 0.8 * np.maximum(
                alt - p.alt_range[:, 1], 0.0)
            yaw_sp = np.where(is_manual, self.yaw_sp + sticks[:, 2] * dt, yaw_sp)
            yaw_rate_ff = np.where(is_manual, sticks[:, 2], yaw_rate_ff)
            pos_sp = np.where(is_manual[:, None], pos_est, pos_sp)
        self.yaw_sp = yaw_sp

        off = (kind == LEG_PREARM) | (kind == LEG_DONE)
        mode = np.where(off, MODE_OFF, np.where(is_manual, MODE_MANUAL, MODE_POSITION))
        speed_lim = np.where(kind == LEG_GOTO, speed, 1.5)

        # Leg completion.
        waited = ((kind == LEG_PREARM) | (kind == LEG_HOLD) | is_manual) & (tau >= duration) & (t >= self.until)
        arrived = tau >= t_total
        err = pos_est - target
        close = (err * err).sum(axis=1) < ACCEPTANCE_RADIUS_M ** 2
        timeout = tau >= t_total + GOTO_TIMEOUT_S
        took_off = (kind == LEG_TAKEOFF) & ((arrived & close & (np.abs(err[:, 2]) < 0.5)) | timeout)
        went = (kind == LEG_GOTO) & ~turning & ((arrived & close) | timeout)
        turned = (kind == LEG_YAW) & (tau >= self.turn_t + 1.0)
        land_done = is_land & (t - self.landed_since >= duration)  # NaN (not landed) compares False
        done = waited | took_off | went | turned | land_done
        self.t_landed[land_done] = t
        self.t_disarm[land_done] = t + DISARM_DELAY_S
        if done.any():
            ids = np.flatnonzero(done)
            started = ids[self.kind[ids] == LEG_PREARM]
            self.t_takeoff_cmd[started] = t
            self.idx[ids] += 1
            self.t_leg0[ids] = t
            self.start_pos[ids] = np.where(is_land[ids, None], pos_est[ids], pos_sp[ids])
            self.start_yaw[ids] = yaw_sp[ids]
            self._refresh(ids)
        ramp = np.where(kind == LEG_TAKEOFF, np.minimum(tau / p.takeoff_ramp, 1.0), 1.0)
        return Setpoints(mode=mode, pos=pos_sp, vel_ff=vel_ff, speed_lim=speed_lim, yaw=yaw_sp,
                         yaw_rate_ff=yaw_rate_ff, man_acc_xy=man_acc_xy, man_vz=man_vz, thrust_ramp=ramp)
