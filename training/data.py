"""Windows for training and evaluation: simulated flights and labelled logs through ONE path.

Every window, simulated or parsed, comes out of :func:`flightlog_fd.windows.make_windows`; this
module only decides which flights to make and how to label them:

- :func:`simulate_windows` flies batches of simulated quads (``flightlog_fd.sim``) and windows
  them, labelled from ``Flight.truth`` (windows that straddle a mid-flight onset are dropped);
- :func:`flight_windows` windows any list of `Flight` objects with labels given per flight
  (e.g. a manifest's truth for the PX4 SITL or CrazyPAD logs), or with `truth` when present.

A :class:`WindowSet` holds unstandardised windows (N, C, T) float32 with labels and per-window
bookkeeping (flight index, η, start time) so experiments can split by flight, never by window.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

import numpy as np

from flightlog_fd.windows import FeatureSpec, make_windows, window_labels
from flightlog_fd.flight import Flight
from flightlog_fd.prepared import PreparedFlight

#: Missions mixed in simulated datasets: autonomous waypoints (like the PX4 SITL set) and
#: pilot-style stick flying (like the paper's real flights).
DEFAULT_MISSIONS = ("waypoints", "manual")
#: Vehicles flown together in one vectorised simulator batch.
SIM_BATCH = 128
AMBIGUOUS = -1


@dataclass
class WindowSet:
    """Windows with labels. ``X`` (N, C, T) float32 is NOT standardised."""

    X: np.ndarray
    y: np.ndarray  # (N,) int, 0 healthy, k = motor k damaged
    flight: np.ndarray  # (N,) int, index of the flight the window came from
    t_start: np.ndarray  # (N,) float, log clock seconds
    t_end: np.ndarray  # (N,) float, log clock seconds
    eta: np.ndarray  # (N,) float, efficiency of the damaged motor (1.0 when healthy / unknown)
    names: list[str] = field(default_factory=list)  # one per flight

    def __len__(self) -> int:
        return int(len(self.y))

    def healthy(self) -> np.ndarray:
        return self.X[self.y == 0]

    @staticmethod
    def concat(sets: Sequence["WindowSet"]) -> "WindowSet":
        sets = [s for s in sets if s is not None]
        names: list[str] = []
        parts_flight = []
        for s in sets:
            parts_flight.append(s.flight + len(names))
            names.extend(s.names)
        return WindowSet(
            np.concatenate([s.X for s in sets]) if sets else np.zeros((0, 7, 80), np.float32),
            np.concatenate([s.y for s in sets]) if sets else np.zeros(0, int),
            np.concatenate(parts_flight) if sets else np.zeros(0, int),
            np.concatenate([s.t_start for s in sets]) if sets else np.zeros(0),
            np.concatenate([s.t_end for s in sets]) if sets else np.zeros(0),
            np.concatenate([s.eta for s in sets]) if sets else np.zeros(0),
            names,
        )

    def save(self, path: Path) -> None:
        np.savez_compressed(path, X=self.X, y=self.y, flight=self.flight, t_start=self.t_start, t_end=self.t_end,
                            eta=self.eta,
                            names=np.array(self.names))

    @staticmethod
    def load(path: Path) -> "WindowSet":
        d = np.load(path)
        t_end = d["t_end"] if "t_end" in d else d["t_start"]
        return WindowSet(d["X"], d["y"], d["flight"], d["t_start"], t_end, d["eta"], [str(x) for x in d["names"]])


def flight_windows(flights: Sequence[Union[Flight, PreparedFlight]], spec: FeatureSpec,
                   labels: Optional[Sequence[dict]] = None, names: Optional[Sequence[str]] = None,
                   keep_ambiguous: bool = False) -> WindowSet:
    """Window flights (or prepared flights) with labels from ``labels[i]`` (a truth dict: label,
    motor, eta, onset_s) or from ``Flight.truth``; flights with neither get label 0 (use only for
    healthy targets)."""
    sets = []
    for i, item in enumerate(flights):
        w = make_windows(item, spec)  # a PreparedFlight shares its resampled segments
        fl = PreparedFlight.of(item).flight
        truth = (labels[i] if labels is not None else None) or fl.truth
        if truth is not None:
            y = window_labels(fl, w, truth)
            eta = float(truth.get("eta") or 1.0)
        else:
            y = np.zeros(len(w.X), int)
            eta = 1.0
        keep = np.ones(len(y), bool) if keep_ambiguous else (y != AMBIGUOUS)
        n = int(keep.sum())
        sets.append(WindowSet(
            w.X[keep].astype(np.float32), y[keep].astype(int), np.zeros(n, int), w.t_start[keep], w.t_end[keep],
            np.where(y[keep] > 0, eta, 1.0),
            [names[i] if names is not None else (fl.path or f"flight{i}")],
        ))
    return WindowSet.concat(sets)


def simulate_windows(n_flights: int, spec: FeatureSpec, *, seed: int = 0, batch: int = SIM_BATCH,
                     airframes=None, rho=None, rho_mode: str = "physical",
                     missions: Sequence[str] = DEFAULT_MISSIONS, duration_s: float = 60.0,
                     profile: str = "training", profiles: Optional[Sequence] = None,
                     healthy_fraction: Optional[float] = None,
                     eta_range: Optional[tuple[float, float]] = None,
                     imbalance=None, mild_fraction: Optional[float] = None,
                     torque_exponent_range: Optional[tuple[float, float]] = None, noise: Optional[str] = None,
                     flight_filter: Optional[Callable[[Flight], bool]] = None,
                     progress: Optional[Callable[[int, int], None]] = None,
                     mixed_missions: bool = False) -> WindowSet:
    """Fly ``n_flights`` simulated quads in batches and window them (labels from the truth).

    ``airframes`` / ``rho`` / ``rho_mode`` / ``eta_range`` / ``imbalance`` (None, ``"random"`` for
    realistic healthy-airframe imbalance drawn per flight, sim/imbalance.py) / ``mild_fraction`` /
    ``torque_exponent_range`` (damaged propellers' separate drag-torque loss, sim/damage.py) /
    ``noise`` ("real_logs": sensor noise spanning real logs, sim/sensors.py) are
    passed to :func:`flightlog_fd.sim.api.simulate_flights`; ``airframes`` may be a callable
    ``(n, rng) -> list[Airframe]`` to draw a family (e.g. airframes like a calibrated one).
    Missions (and ``profiles``, logging profiles, when given instead of ``profile``) alternate
    batch by batch; with ``mixed_missions`` every batch flies all the missions (vehicle i the
    i-th, cycling) and only the logging profiles alternate, so that one batch per logging
    profile gives every mission (a batch's cost is mostly its per-step overhead, whatever its
    size). ``flight_filter(flight) -> bool`` keeps only some of the simulated flights
    (``n_flights`` counts the simulated ones). Deterministic for a seed.
    """
    return simulate_window_sets(n_flights, [spec], seed=seed, batch=batch, airframes=airframes, rho=rho,
                                rho_mode=rho_mode, missions=missions, duration_s=duration_s, profile=profile,
                                profiles=profiles, healthy_fraction=healthy_fraction, eta_range=eta_range,
                                imbalance=imbalance, mild_fraction=mild_fraction,
                                torque_exponent_range=torque_exponent_range, noise=noise,
                                flight_filter=flight_filter, progress=progress, mixed_missions=mixed_missions)[0]


def simulate_window_sets(n_flights: int, specs: Sequence[FeatureSpec], *, seed: int = 0, batch: int = SIM_BATCH,
                         airframes=None, rho=None, rho_mode: str = "physical",
                         missions: Sequence[str] = DEFAULT_MISSIONS, duration_s: float = 60.0,
                         profile: str = "training", profiles: Optional[Sequence] = None,
                         healthy_fraction: Optional[float] = None,
                         eta_range: Optional[tuple[float, float]] = None,
                         imbalance=None, mild_fraction: Optional[float] = None,
                         torque_exponent_range: Optional[tuple[float, float]] = None, noise: Optional[str] = None,
                         flight_filter: Optional[Callable[[Flight], bool]] = None,
                         progress: Optional[Callable[[int, int], None]] = None,
                         mixed_missions: bool = False) -> list[WindowSet]:
    """:func:`simulate_windows` for several feature specs at once: one WindowSet per spec, all from
    the same simulated flights (so NIF and CF windows of an experiment describe the same data)."""
    from flightlog_fd.sim.api import simulate_flights

    kw = {}
    if healthy_fraction is not None:
        kw["healthy_fraction"] = healthy_fraction
    if eta_range is not None:
        kw["eta_range"] = eta_range
    if mild_fraction is not None:
        kw["mild_fraction"] = mild_fraction
    if torque_exponent_range is not None:
        kw["torque_exponent_range"] = torque_exponent_range
    if noise is not None:
        kw["noise"] = noise
    sets: list[list[WindowSet]] = [[] for _ in specs]
    log_profiles = list(profiles) if profiles else [profile]
    done = 0
    b = 0
    while done < n_flights:
        n = min(batch, n_flights - done)
        bseed = int(np.random.default_rng([seed, b]).integers(2**31))
        afs = airframes(n, np.random.default_rng([seed, b, 7])) if callable(airframes) else airframes
        r = rho
        if rho is not None and not isinstance(rho, str) and np.ndim(rho) == 2:
            r = np.asarray(rho)[done:done + n]
        if mixed_missions:
            mission = [missions[i % len(missions)] for i in range(n)]
            log_profile = log_profiles[b % len(log_profiles)]
        else:
            mission = missions[b % len(missions)]
            log_profile = log_profiles[(b // len(missions)) % len(log_profiles)]
        flights = simulate_flights(n, airframes=afs, mission=mission, duration_s=duration_s, profile=log_profile,
                                   rho=r, rho_mode=rho_mode, seed=bseed, imbalance=imbalance, accelerometer=False,
                                   **kw)
        names = [f"sim{seed}-{b}-{i}" for i in range(n)]
        # Prepared once: the filter (e.g. the attitude time constant) and the windows resample alike.
        flights = [PreparedFlight(fl) for fl in flights]
        if flight_filter is not None:
            keep = [i for i, fl in enumerate(flights) if flight_filter(fl)]
            flights, names = [flights[i] for i in keep], [names[i] for i in keep]
        if flights:
            for out, spec in zip(sets, specs):
                out.append(flight_windows(flights, spec, names=names))
        done += n
        b += 1
        if progress is not None:
            progress(done, n_flights)
    return [WindowSet.concat(parts) for parts in sets]
