"""Loads an airframe carries: a point mass fixed on the frame, a payload swinging on a line, a
battery moved along the body (:class:`Load`), and their mass bookkeeping for the dynamics.

Positions are body FRD metres from the frame centre (the airframe's nominal centre of mass):
x forward, y right, z down. ``toward_motor=k`` with ``arm_fraction=f`` places the load on the
way from the centre to rotor k (autopilot numbering), ``f = 1`` on the rotor itself.

- ``"point"``: a mass fixed to the frame. Mass, centre of mass and inertia change together: the
  total mass grows, the CoM moves to the mass-weighted mean, the inertia about the new CoM is
  the airframe's (diagonal, about its own CoM) plus the point's, both moved there with the
  parallel-axis theorem (:func:`mass_properties`; off-diagonal products included).
- ``"battery"``: mass already in the airframe (``mass_fraction`` of the airframe's mass,
  default :data:`BATTERY_MASS_FRACTION`) moved by ``position`` (a displacement): the total mass
  is unchanged, the CoM moves by ``m_batt/M · d``, the inertia changes by the same theorem.
- ``"line"``: a payload of ``mass`` hanging on a line of ``length_m`` from ``position`` (the
  attachment point): a spherical pendulum coupled to the body (dynamics.py): the line tension
  acts on the body at the attachment point (force and moment), the payload feels gravity and
  the attachment point's acceleration, the swing is lightly damped
  (:data:`LINE_DAMPING_RATIO`). On the ground the payload rests (no tension); its weight comes
  on over the last :data:`LINE_LIFT_RAMP_M` of climb once the line is taut.

``mass_kg`` or ``mass_fraction`` gives the mass: a fraction is of the take-off mass of the
airframe with this load (``m = f / (1 - f) · m_airframe``; a battery's fraction is of the
airframe's own mass).

The controller is never told (as on a real aircraft): its mixer and thrust model keep the
nominal airframe, its rate integrators absorb the moment of the moved CoM and its vertical
velocity integrator the extra weight, so the hover command rises.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from flightlog_fd.sim.airframe import GRAVITY, Airframe

KINDS = ("point", "line", "battery")
#: A battery's share of the airframe's mass when not given: a 4S 5000 mAh pack is ~0.5 kg of a
#: 2 kg X500, a Crazyflie's 250 mAh pack 7 g of 27 g: 25-26 %.
BATTERY_MASS_FRACTION = 0.25
#: Damping ratio of a payload's swing (line friction, the payload's air drag): a choice, light (a
#: swing decays over tens of periods); not measured: the real string flights of
#: ../shared/crazypad_e9_load last 8-9 s, five periods, too short to fit it.
LINE_DAMPING_RATIO = 0.03
#: A payload on the ground takes its weight over this much climb once the line is taut (a line
#: stretches): no step in the vertical force at the payload's lift-off.
LINE_LIFT_RAMP_M = 0.15
#: Input bound: the largest mass fraction of the take-off mass a load may be given (the hover
#: check below refuses most loads well before it).
MAX_MASS_FRACTION = 0.6
#: Input bound: a load sits within this many arm lengths of the centre (else it is not on the frame).
MAX_POSITION_ARMS = 2.0
LINE_LENGTH_RANGE_M = (0.05, 20.0)
#: Static hover commands a loaded airframe may need (of full thrust); the simulator refuses
#: loads beyond. Measured (results/sim_loads.md): an X500 with a central mass raising its hover
#: command to 0.8 / 0.9 / 0.95 has a motor at full output 0.2 / 1.4 / 12.8 % of a waypoint flight
#: (manual: 5 / 8 / 12 %) and at 0.95 the mission takes 1.7x as long (it cannot climb at speed).
#: Below the lower bound a motor idles and cannot take torque away.
MAX_LOADED_HOVER_COMMAND = 0.9
MIN_LOADED_HOVER_COMMAND = 0.05
#: Largest lift-off tilt estimate (:func:`liftoff_tilt_deg`) a load may cause. Measured
#: (results/sim_loads.md): a SITL-like 3 kg quad and an X500 flown with growing offsets reach at
#: most 24-27 deg in flight up to an estimate of 20.6, 50 deg at 25.1 and flip from 26.
MAX_LIFTOFF_TILT_DEG = 22.0
#: ... or at most this much more than the airframe without the load (a damaged airframe at the
#: edge of damage.py's own lift-off limit still carries a light load near the centre).
LIFTOFF_TILT_MARGIN_DEG = 2.0


@dataclass(frozen=True)
class Load:
    """One load (see the module docstring). Give ``mass_kg`` or ``mass_fraction`` (a battery:
    ``mass_fraction`` of the airframe's mass, default BATTERY_MASS_FRACTION), and ``position``
    (metres, FRD; a battery's displacement) or ``toward_motor`` (1-based) with ``arm_fraction``."""

    kind: str = "point"
    mass_kg: Optional[float] = None
    mass_fraction: Optional[float] = None
    position: Optional[tuple[float, float, float]] = None
    toward_motor: Optional[int] = None
    arm_fraction: float = 1.0
    length_m: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"load kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if self.position is not None:
            p = tuple(float(v) for v in self.position)
            if len(p) == 2:
                p = p + (0.0,)
            if len(p) != 3 or not np.all(np.isfinite(p)):
                raise ValueError(f"load position needs x,y[,z] metres, got {self.position!r}")
            object.__setattr__(self, "position", p)
        if (self.position is None) == (self.toward_motor is None):
            raise ValueError("a load needs a position x,y[,z] or toward_motor (one of the two)")
        if self.kind == "battery" and self.toward_motor is not None:
            raise ValueError("a battery is moved by a displacement dx,dy[,dz], not toward a motor")
        if not 0.0 <= self.arm_fraction <= MAX_POSITION_ARMS:
            raise ValueError(f"arm fraction must be 0..{MAX_POSITION_ARMS:g}, got {self.arm_fraction:g}")
        if self.mass_kg is not None and self.mass_fraction is not None:
            raise ValueError("give a load's mass in kg or as a fraction, not both")
        if self.kind != "battery" and self.mass_kg is None and self.mass_fraction is None:
            raise ValueError(f"a {self.kind} load needs a mass")
        if self.mass_kg is not None and not (np.isfinite(self.mass_kg) and self.mass_kg > 0.0):
            raise ValueError(f"load mass must be > 0 kg, got {self.mass_kg:g}")
        if self.mass_fraction is not None and not 0.0 < self.mass_fraction <= MAX_MASS_FRACTION:
            raise ValueError(f"load mass fraction must be in (0, {MAX_MASS_FRACTION:g}], got {self.mass_fraction:g}")
        if self.kind == "line":
            lo, hi = LINE_LENGTH_RANGE_M
            if not lo <= self.length_m <= hi:
                raise ValueError(f"line length must be {lo:g}..{hi:g} m, got {self.length_m:g}")
        elif self.length_m:
            raise ValueError(f"only a line load has a length (got {self.length_m:g} m on a {self.kind})")

    def mass_on(self, af: Airframe) -> float:
        """This load's mass in kg on ``af`` (a battery: the moved battery's mass)."""
        if self.mass_kg is not None:
            return float(self.mass_kg)
        if self.kind == "battery":
            return float((BATTERY_MASS_FRACTION if self.mass_fraction is None else self.mass_fraction) * af.mass)
        f = float(self.mass_fraction)
        return f / (1.0 - f) * af.mass

    def position_on(self, af: Airframe) -> np.ndarray:
        """(3,) body FRD metres from the frame centre (a battery: its displacement)."""
        if self.position is not None:
            return np.array(self.position, dtype=np.float64)
        rotors = af.geometry().rotors
        if not 1 <= self.toward_motor <= len(rotors):
            raise ValueError(f"load toward motor {self.toward_motor}: the {af.frame} airframe has motors 1..{len(rotors)}")
        r = rotors[self.toward_motor - 1]
        return np.array([r.x, r.y, 0.0]) * self.arm_fraction

    def check(self, af: Airframe) -> None:
        """ValueError when this load cannot sit on ``af`` (too far from the centre)."""
        p = self.position_on(af)
        if np.linalg.norm(p) > MAX_POSITION_ARMS * af.arm + 1e-9:
            raise ValueError(f"a load {np.linalg.norm(p):.2f} m from the centre is not on this frame "
                             f"(arm {af.arm:.2f} m; at most {MAX_POSITION_ARMS:g} arms)")

    def to_dict(self, af: Airframe) -> dict:
        """Truth of this load on ``af``: kind, mass kg, its fraction of the take-off mass, position."""
        m = self.mass_on(af)
        d = {"kind": self.kind, "mass_kg": round(m, 6), "position_m": [round(float(v), 6) for v in self.position_on(af)],
             "toward_motor": self.toward_motor, "arm_fraction": self.arm_fraction if self.toward_motor else None}
        if self.kind == "battery":
            d["mass_fraction"] = round(m / af.mass, 6)
        else:
            d["mass_fraction"] = round(m / (af.mass + m), 6)
        if self.kind == "line":
            d["length_m"] = self.length_m
        return d


LoadSpec = Union[None, Load, Sequence[Load]]


def as_loads(spec: LoadSpec) -> tuple[Load, ...]:
    """One vehicle's loads as a tuple (None: none)."""
    if spec is None:
        return ()
    if isinstance(spec, Load):
        return (spec,)
    out = tuple(spec)
    if not all(isinstance(x, Load) for x in out):
        raise ValueError("loads must be Load objects")
    if sum(x.kind == "line" for x in out) > 1:
        raise ValueError("one vehicle carries at most one payload on a line")
    return out


@dataclass(frozen=True)
class MassProperties:
    """A loaded airframe's rigid body (the line's payload excluded) and its line payload.

    ``com`` (3,) m from the frame centre; ``inertia`` (3, 3) kg·m² about ``com``; ``take_off_mass``
    includes the line's payload; ``line_attach`` (3,) from the frame centre."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    take_off_mass: float
    line_mass: float = 0.0
    line_attach: Optional[np.ndarray] = None
    line_length: float = 0.0

    def to_dict(self) -> dict:
        return {"body_mass_kg": round(self.mass, 6), "take_off_mass_kg": round(self.take_off_mass, 6),
                "com_m": [round(float(v), 6) for v in self.com],
                "inertia_kgm2": [[round(float(v), 8) for v in row] for row in self.inertia]}


def _point_inertia(m: float, r: np.ndarray) -> np.ndarray:
    """Inertia (3, 3) of a point mass ``m`` at ``r`` about the origin."""
    return m * (float(r @ r) * np.eye(3) - np.outer(r, r))


def mass_properties(af: Airframe, loads: LoadSpec, cog_xy: Sequence[float] = (0.0, 0.0)) -> MassProperties:
    """Mass, centre of mass and inertia of ``af`` carrying ``loads`` (parallel-axis theorem, module
    docstring). ``cog_xy``: the bare airframe's own CoM (m; imbalance.py's offset × arm)."""
    loads = as_loads(loads)
    c0 = np.array([float(cog_xy[0]), float(cog_xy[1]), 0.0])
    m_tot = float(af.mass)
    first = af.mass * c0
    inertia_o = np.diag(np.array(af.inertia, dtype=np.float64)) + _point_inertia(af.mass, c0)
    line = None
    for ld in loads:
        ld.check(af)
        m, p = ld.mass_on(af), ld.position_on(af)
        if ld.kind == "point":
            m_tot += m
            first = first + m * p
            inertia_o = inertia_o + _point_inertia(m, p)
        elif ld.kind == "battery":  # the battery (at the frame centre as built) moved by p
            first = first + m * p
            inertia_o = inertia_o + _point_inertia(m, p)
        else:
            line = (m, p, ld.length_m)
    com = first / m_tot
    inertia = inertia_o - _point_inertia(m_tot, com)
    if line is None:
        return MassProperties(m_tot, com, inertia, m_tot)
    return MassProperties(m_tot, com, inertia, m_tot + line[0], line[0], line[1], float(line[2]))


def static_hover(af: Airframe, loads: LoadSpec, eta: Optional[Sequence[float]] = None,
                 cog_xy: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """(R,) steady-hover thrust setpoints of ``af`` carrying ``loads`` (a line's payload hanging
    still below its attachment point), rotor k giving ``eta[k]`` of its thrust: the static
    force and moment balance about the loaded CoM (least squares for R != 4 rotors, as the
    simulator's allocation). What the flown hover converges to once the integrators settle."""
    mp = mass_properties(af, loads, cog_xy)
    frame = af.geometry()
    x = np.array([r.x for r in frame.rotors]) - mp.com[0]
    y = np.array([r.y for r in frame.rotors]) - mp.com[1]
    spin = np.array([r.spin for r in frame.rotors], dtype=float)
    e = np.ones(len(x)) if eta is None else np.asarray(eta, dtype=float)
    a = np.stack([e, -y * e, x * e, spin * af.torque_ratio * e])
    rhs = np.array([mp.take_off_mass * GRAVITY, 0.0, 0.0, 0.0]) / af.thrust_max
    if mp.line_mass:
        ra = mp.line_attach - mp.com
        # Weight W down (+z) at ra: torque ra × (0, 0, W) = (ra_y W, −ra_x W, 0); rotors cancel it.
        w = mp.line_mass * GRAVITY / af.thrust_max
        rhs[1] -= ra[1] * w
        rhs[2] += ra[0] * w
    return np.linalg.solve(a, rhs) if a.shape[1] == 4 else np.linalg.pinv(a) @ rhs


def check_flyable(af: Airframe, loads: LoadSpec, damage=None, imbalance=None) -> None:
    """ValueError naming the motor when ``af`` with ``loads`` (and ``damage``, ``imbalance``: its
    CoM offset) cannot hover with control left: a static hover command above
    MAX_LOADED_HOVER_COMMAND or below MIN_LOADED_HOVER_COMMAND, or a moment that tips it over at
    lift-off (:func:`liftoff_tilt_deg` above MAX_LIFTOFF_TILT_DEG)."""
    loads = as_loads(loads)
    if not loads:
        return
    eta = np.ones(af.rotor_count)
    if damage is not None:
        for p in damage.parts:
            eta[p.motor - 1] = p.eta
    cog = (0.0, 0.0) if imbalance is None else tuple(c * af.arm for c in imbalance.cog_offset)
    u = static_hover(af, loads, eta, cog)
    k = int(np.argmax(u))
    if u[k] > MAX_LOADED_HOVER_COMMAND:
        raise ValueError(f"the {af.name} airframe cannot carry this load: motor {k + 1} would need {u[k]:.2f} of its "
                         f"full thrust to hover (at most {MAX_LOADED_HOVER_COMMAND:g})")
    k = int(np.argmin(u))
    if u[k] < MIN_LOADED_HOVER_COMMAND:
        raise ValueError(f"the {af.name} airframe cannot balance this load: motor {k + 1} would need {u[k]:.2f} of its "
                         f"full thrust to hover (at least {MIN_LOADED_HOVER_COMMAND:g})")
    tilt = liftoff_tilt_deg(af, loads, eta, cog)
    # An airframe that flies without the load (its damage and imbalance alone may exceed the
    # limit: damage.py accepts them by its own measure) may take a load adding a little.
    limit = max(MAX_LIFTOFF_TILT_DEG, liftoff_tilt_deg(af, (), eta, cog) + LIFTOFF_TILT_MARGIN_DEG)
    if tilt > limit:
        raise ValueError(f"the {af.name} airframe tips over at lift-off with this load: its moment tilts it "
                         f"{tilt:.0f} deg before the rate integrator holds it (at most {limit:.0f})")


def liftoff_tilt_deg(af: Airframe, loads: LoadSpec, eta: Optional[Sequence[float]] = None,
                     cog_xy: Sequence[float] = (0.0, 0.0)) -> float:
    """Tilt (degrees) at which the controller's P loops alone hold the moment of ``loads`` (and a
    rotor giving ``eta`` of its thrust) at lift-off, equal commands on every motor and the rate
    integrator still at zero (it is reset on the ground): ``α / (rate_kp · att_p)`` per axis,
    as damage.py's lift-off check for a damaged propeller. An upper estimate: the integrator
    catches up before the P-only equilibrium is reached."""
    mp = mass_properties(af, loads, cog_xy)
    frame = af.geometry()
    x = np.array([r.x for r in frame.rotors]) - mp.com[0]
    y = np.array([r.y for r in frame.rotors]) - mp.com[1]
    e = np.ones(len(x)) if eta is None else np.asarray(eta, dtype=float)
    f = e * mp.take_off_mass * GRAVITY / len(x)
    torque = np.array([-(y * f).sum(), (x * f).sum()])
    if mp.line_mass:
        ra = mp.line_attach - mp.com
        w = mp.line_mass * GRAVITY
        torque += np.array([ra[1] * w, -ra[0] * w])
    alpha = np.abs(torque) / np.array([mp.inertia[0, 0], mp.inertia[1, 1]])
    g = af.gains
    return float(np.degrees(alpha.max() / (g.rate_kp[0] * g.att_p[0])))


#: Random loads (:func:`random_load`): the issue's fixed loads, 5-30 % of the take-off mass from
#: the centre to a rotor (half toward a rotor, half in a random direction; 2 cm above to 8 cm
#: below the frame); lines of 0.3-1.5 m attached within 0.6 arm, 2-8 cm below; a battery moved
#: 10-50 % of the arm along x (either way) and up to ±10 % along y.
RANDOM_MASS_FRACTION_RANGE = (0.05, 0.30)
RANDOM_Z_RANGE_M = (-0.02, 0.08)
RANDOM_LINE_LENGTH_RANGE_M = (0.3, 1.5)
RANDOM_LINE_RADIUS_ARM = 0.6
RANDOM_BATTERY_X_RANGE_ARM = (0.1, 0.5)
RANDOM_BATTERY_Y_ARM = 0.1
#: Shrinking an unflyable draw (:func:`make_flyable`): radius × RADIUS_SHRINK and mass × MASS_SHRINK,
#: alternately, at most MAX_SHRINKS times, then the lightest load at the centre.
RADIUS_SHRINK, MASS_SHRINK, MAX_SHRINKS = 0.7, 0.8, 16


def random_load(af: Airframe, rng: np.random.Generator, kind: str = "point") -> Load:
    """One random load of ``kind`` on ``af`` (ranges above; not yet checked for flyability)."""
    if kind == "battery":
        dx = float(rng.choice([-1.0, 1.0]) * rng.uniform(*RANDOM_BATTERY_X_RANGE_ARM) * af.arm)
        dy = float(rng.uniform(-RANDOM_BATTERY_Y_ARM, RANDOM_BATTERY_Y_ARM) * af.arm)
        return Load("battery", position=(dx, dy, 0.0))
    frac = float(rng.uniform(*RANDOM_MASS_FRACTION_RANGE))
    if kind == "line":
        radius, ang = float(rng.uniform(0.0, RANDOM_LINE_RADIUS_ARM)), float(rng.uniform(-np.pi, np.pi))
        pos = (af.arm * radius * np.cos(ang), af.arm * radius * np.sin(ang), float(rng.uniform(0.02, 0.08)))
        return Load("line", mass_fraction=frac, position=pos,
                    length_m=float(rng.uniform(*RANDOM_LINE_LENGTH_RANGE_M)))
    if kind != "point":
        raise ValueError(f"load kind must be one of {', '.join(KINDS)}, got {kind!r}")
    radius, z = float(rng.uniform(0.0, 1.0)), float(rng.uniform(*RANDOM_Z_RANGE_M))
    if rng.uniform() < 0.5:
        r = af.geometry().rotors[int(rng.integers(af.rotor_count))]
        pos = (r.x * radius, r.y * radius, z)
    else:
        ang = float(rng.uniform(-np.pi, np.pi))
        pos = (af.arm * radius * np.cos(ang), af.arm * radius * np.sin(ang), z)
    return Load("point", mass_fraction=frac, position=pos)


def make_flyable(af: Airframe, load: Load, damage=None, imbalance=None) -> Load:
    """``load`` moved toward the centre and lightened (never below 5 %), alternately, until ``af``
    hovers with it (:func:`check_flyable`, with ``damage`` and ``imbalance``); at last the
    lightest load at the centre (ValueError if even that cannot fly)."""
    from dataclasses import replace

    for i in range(MAX_SHRINKS):
        try:
            check_flyable(af, load, damage, imbalance)
            return load
        except ValueError:
            pass
        if load.position is None:
            load = replace(load, position=tuple(load.position_on(af)), toward_motor=None, arm_fraction=1.0)
        if i % 2 == 0 or load.mass_fraction is None or load.kind == "battery":
            load = replace(load, position=tuple(v * RADIUS_SHRINK for v in load.position[:2]) + (load.position[2],))
        else:
            load = replace(load, mass_fraction=max(RANDOM_MASS_FRACTION_RANGE[0], load.mass_fraction * MASS_SHRINK))
    try:
        check_flyable(af, load, damage, imbalance)
        return load
    except ValueError:
        load = replace(load, position=(0.0, 0.0, load.position[2]),
                       mass_fraction=None if load.kind == "battery" else RANDOM_MASS_FRACTION_RANGE[0],
                       mass_kg=None)
        check_flyable(af, load, damage, imbalance)
        return load


def random_loads(airframes: Sequence[Airframe], rng: np.random.Generator, *, kinds: Sequence[str] = KINDS,
                 weights: Optional[Sequence[float]] = None, loaded_fraction: float = 1.0, damages=None,
                 imbalances=None) -> list[tuple[Load, ...]]:
    """One random flyable load per airframe (``kinds`` drawn with ``weights``; with probability
    1 − ``loaded_fraction`` none), made flyable with its damage and imbalance (lists of n or None):
    training sets and benchmarks draw here. Pass the result as ``simulate_flights(loads=...)``."""
    out = []
    p = None if weights is None else np.asarray(weights, dtype=float) / float(np.sum(weights))
    for i, af in enumerate(airframes):
        if rng.uniform() >= loaded_fraction:
            out.append(())
            continue
        kind = str(kinds[int(rng.choice(len(kinds), p=p))])
        ld = make_flyable(af, random_load(af, rng, kind), None if damages is None else damages[i],
                          None if imbalances is None else imbalances[i])
        out.append((ld,))
    return out


@dataclass
class LoadArrays:
    """Loads of N vehicles for the dynamics, component-major: rigid-body mass (N,), the CoM's
    shift by the loads (3, N) m (from the as-built CoM), inertia (3, 3, N) about the loaded CoM,
    the line's payload mass (N,) (0: none), attachment point from the loaded CoM (3, N), length (N,)."""

    mass: np.ndarray
    shift: np.ndarray
    inertia: np.ndarray
    line_mass: np.ndarray
    line_attach: np.ndarray
    line_length: np.ndarray
    props: list

    @classmethod
    def build(cls, loads: Sequence[tuple[Load, ...]], airframes: Sequence[Airframe],
              cog_xy: Optional[np.ndarray] = None) -> "LoadArrays":
        """``cog_xy`` (2, N) m: each bare airframe's own CoM offset (imbalance), else 0."""
        n = len(airframes)
        props = []
        mass, inertia = np.empty(n), np.empty((3, 3, n))
        shift, attach = np.zeros((3, n)), np.zeros((3, n))
        lm, ll = np.zeros(n), np.ones(n)
        for i, (af, ld) in enumerate(zip(airframes, loads)):
            c0 = (0.0, 0.0) if cog_xy is None else (float(cog_xy[0, i]), float(cog_xy[1, i]))
            mp = mass_properties(af, ld, c0)
            props.append(mp)
            mass[i] = mp.mass
            inertia[:, :, i] = mp.inertia
            shift[:, i] = mp.com - np.array([c0[0], c0[1], 0.0])
            if mp.line_mass:
                lm[i], ll[i] = mp.line_mass, mp.line_length
                attach[:, i] = mp.line_attach - mp.com
        return cls(mass, shift, inertia, lm, attach, ll, props)


def resolve_loads(spec, n: int) -> Optional[list[tuple[Load, ...]]]:
    """None (no loads: the flights are exactly as without this module); one Load, or a tuple of
    Loads, carried by every vehicle; or a list of n, one entry per vehicle (None, a Load or a
    tuple of Loads)."""
    if spec is None:
        return None
    if isinstance(spec, (Load, tuple)):
        return [as_loads(spec)] * n
    out = [as_loads(x) for x in spec]
    if len(out) != n:
        raise ValueError(f"got {len(out)} load entries for {n} vehicles (a list gives one per vehicle; "
                         "a tuple of Loads is carried by every vehicle)")
    return out


def parse_load(text: str) -> Load:
    """One ``--load`` value as a Load; ValueError with the expected forms otherwise.

    ``point:MASS@WHERE``, ``line:MASS@WHERE:LENGTH_M``, ``battery:DX[,DY[,DZ]][@MASS]``;
    MASS is kg (``0.3``) or a percentage of the take-off mass (``15%``; a battery's of the
    airframe's mass); WHERE is ``X,Y[,Z]`` metres (body x forward, y right, z down) or
    ``motorK[,F]`` (on the way to rotor K, F of the arm, default 1: on the rotor)."""
    forms = ("point:MASS@X,Y[,Z] | point:MASS@motorK[,F] | line:MASS@WHERE:LENGTH_M | battery:DX[,DY[,DZ]][@MASS] "
             "(MASS in kg or as a percentage of the take-off mass, e.g. 15%)")
    try:
        kind, rest = text.split(":", 1)
        kind = kind.strip().lower()
        if kind == "battery":
            disp, _, mass = rest.partition("@")
            mkg, mfrac = _mass(mass) if mass else (None, None)
            d = tuple(float(v) for v in disp.split(","))
            if not 1 <= len(d) <= 3:
                raise ValueError("a battery's displacement is dx[,dy[,dz]] metres")
            return Load("battery", mass_kg=mkg, mass_fraction=mfrac, position=(d + (0.0, 0.0))[:3])
        if kind not in ("point", "line"):
            raise ValueError
        mass, where = rest.split("@", 1)
        length = 0.0
        if kind == "line":
            where, length_text = where.rsplit(":", 1)
            length = float(length_text)
        mkg, mfrac = _mass(mass)
        if where.strip().lower().startswith("motor"):
            parts = where.strip()[5:].split(",")
            if len(parts) > 2:
                raise ValueError
            k = int(parts[0])
            f = float(parts[1]) if len(parts) == 2 else 1.0
            return Load(kind, mass_kg=mkg, mass_fraction=mfrac, toward_motor=k, arm_fraction=f, length_m=length)
        return Load(kind, mass_kg=mkg, mass_fraction=mfrac, position=_floats(where), length_m=length)
    except ValueError as e:
        msg = str(e)
        if msg and not msg.startswith(("could not convert", "invalid literal", "not enough values")):
            raise ValueError(f"--load {text!r}: {msg}") from None
        raise ValueError(f"--load {text!r} must be {forms}") from None


def _mass(text: str) -> tuple[Optional[float], Optional[float]]:
    t = text.strip()
    if t.endswith("%"):
        return None, float(t[:-1]) / 100.0
    return float(t), None


def _floats(text: str) -> tuple[float, ...]:
    vals = tuple(float(v) for v in text.split(","))
    if not 2 <= len(vals) <= 3:
        raise ValueError("a position needs x,y or x,y,z metres")
    return vals
