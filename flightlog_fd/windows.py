"""NIF / CF input windows of a flight - one code path for simulated flights and parsed logs.

Layer: above :mod:`flightlog_fd.prepared`; the windows are cut from the prepared flight's airborne
segments (:func:`flightlog_fd.prepared.resample`: grid, gaps, angular acceleration and thrust proxy
are documented in :mod:`flightlog_fd.streams`). Then:

1. **Scale-free transform** (``FeatureSpec.transform == "scale_free"``, the default) so that a
   30 g and a 5 kg quadrotor look alike: the motor channels are divided by the window's mean
   over all motors and all samples (each becomes a thrust share ~1; the damaged motor's
   share is > 1), and the angular accelerations (CF: the angular rates) by a per-flight robust
   scale, 1.4826 x MAD over all the flight's airborne grid samples of that axis, floored at
   ``ANG_ACC_SCALE_FLOOR`` (``RATE_SCALE_FLOOR``) so that a near-noiseless simulated hover does
   not blow up. Attitude angles are already scale-free. ``"raw"`` keeps the paper's units
   (rad/s^2, thrust 0..1). The per-channel standardisation (mean/std fitted on training windows)
   is applied afterwards by :meth:`FeatureSpec.normalise`.
2. :func:`make_windows` cuts each segment into windows of ``window`` samples (T = 80, 1.6 s at
   50 Hz) every ``stride`` samples (default 40) with ``numpy.lib.stride_tricks.sliding_window_view``.

Channel order: NIF ``p_dot, q_dot, r_dot, w1_sq, w2_sq, w3_sq, w4_sq``; CF ``roll, pitch, p, q,
r, w1, w2, w3, w4`` (w = sqrt of the thrust proxy). Motor k is column k-1 (autopilot numbering).
``FeatureSpec.n_motors`` (default 4) gives n motor channels, ``w1_sq .. wn_sq`` / ``w1 .. wn``, for
hexa- and octocopters: the paper's method is the same for n rotors. A quad spec (n = 4) builds
exactly the windows it always did and its dict carries no ``n_motors`` key.

Limits: the frame's rotor count must equal the spec's ``n_motors`` (a quad spec refuses a hexa). Windows carry no label; :func:`window_labels` gives them from ``Flight.truth``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .errors import NotDiagnosableError
from .flight import Flight
from .prepared import PreparedFlight, resample
from .streams import DEFAULT_MAX_GAP_S, DEFAULT_RATE_HZ, DEFAULT_SAVGOL_WINDOW_S, DEFAULT_TRIM_S, Segment

#: Version of the feature definition; bump when a change alters the numbers a model sees.
FEATURE_VERSION = 1

#: Window length (samples) and stride (samples) - the paper's T = 80 at DEFAULT_RATE_HZ.
DEFAULT_WINDOW = 80
DEFAULT_STRIDE = 40

#: Robust-scale floors (rad/s^2 and rad/s): a noiseless simulated flight must not divide by ~0.
ANG_ACC_SCALE_FLOOR = 0.05
RATE_SCALE_FLOOR = 0.01
#: 1.4826 x MAD estimates the standard deviation of Gaussian data.
MAD_TO_STD = 1.4826
#: Standard-deviation floor in FeatureSpec.fit (a constant channel must not divide by 0).
STD_FLOOR = 1e-6
#: Window mean thrust below which the share is not defined (motors stopped).
MIN_MEAN_THRUST = 1e-6

NIF_CHANNELS = ("p_dot", "q_dot", "r_dot", "w1_sq", "w2_sq", "w3_sq", "w4_sq")
CF_CHANNELS = ("roll", "pitch", "p", "q", "r", "w1", "w2", "w3", "w4")
#: Motor counts a spec may ask for (tricopter to dodecacopter).
MIN_MOTORS, MAX_MOTORS = 3, 12


def nif_channels(n_motors: int = 4) -> tuple[str, ...]:
    """NIF channel names for ``n_motors`` motors (p_dot, q_dot, r_dot, w1_sq .. wn_sq)."""
    return NIF_CHANNELS[:3] + tuple(f"w{k}_sq" for k in range(1, n_motors + 1))


def cf_channels(n_motors: int = 4) -> tuple[str, ...]:
    """CF channel names for ``n_motors`` motors (roll, pitch, p, q, r, w1 .. wn)."""
    return CF_CHANNELS[:5] + tuple(f"w{k}" for k in range(1, n_motors + 1))


TRANSFORMS = ("scale_free", "raw")
SPEED_SOURCES = ("command", "esc_rpm", "auto")


@dataclass
class FeatureSpec:
    """How windows are built: everything a model file needs to rebuild its input.

    ``mean`` / ``std`` are per-channel standardisation statistics, ``None`` until :meth:`fit`.
    """

    features: str = "nif"  # "nif" | "cf"
    rate_hz: float = DEFAULT_RATE_HZ
    window: int = DEFAULT_WINDOW
    stride: int = DEFAULT_STRIDE
    channels: tuple[str, ...] = ()
    transform: str = "scale_free"  # "scale_free" | "raw"
    speed_source: str = "command"  # "command" | "esc_rpm" | "auto"
    trim_s: float = DEFAULT_TRIM_S
    max_gap_s: float = DEFAULT_MAX_GAP_S
    savgol_window_s: float = DEFAULT_SAVGOL_WINDOW_S
    mean: Optional[np.ndarray] = None
    std: Optional[np.ndarray] = None
    version: int = FEATURE_VERSION
    n_motors: int = 4

    def __post_init__(self) -> None:
        if self.features not in ("nif", "cf"):
            raise ValueError(f"features must be 'nif' or 'cf', not {self.features!r}")
        if isinstance(self.n_motors, bool) or not isinstance(self.n_motors, (int, np.integer)) \
                or not MIN_MOTORS <= int(self.n_motors) <= MAX_MOTORS:
            raise ValueError(f"n_motors must be an integer {MIN_MOTORS}..{MAX_MOTORS}, not {self.n_motors!r}")
        self.n_motors = int(self.n_motors)
        expected = nif_channels(self.n_motors) if self.features == "nif" else cf_channels(self.n_motors)
        if not self.channels:
            self.channels = expected
        self.channels = tuple(self.channels)
        if self.channels != expected:
            raise ValueError(f"{self.features} channels must be {expected}, not {self.channels}")
        if self.transform not in TRANSFORMS:
            raise ValueError(f"transform must be one of {TRANSFORMS}, not {self.transform!r}")
        if self.speed_source not in SPEED_SOURCES:
            raise ValueError(f"speed_source must be one of {SPEED_SOURCES}, not {self.speed_source!r}")
        if not (self.rate_hz > 0 and self.window >= 2 and self.stride >= 1):
            raise ValueError(f"bad rate/window/stride: {self.rate_hz}, {self.window}, {self.stride}")
        if self.version != FEATURE_VERSION:
            raise ValueError(f"feature version {self.version} is not supported (this is {FEATURE_VERSION})")
        self.rate_hz = float(self.rate_hz)
        self.window = int(self.window)
        self.stride = int(self.stride)
        for name in ("mean", "std"):
            v = getattr(self, name)
            if v is not None:
                v = np.asarray(v, dtype=np.float64).reshape(-1)
                if v.shape[0] != len(self.channels) or not np.all(np.isfinite(v)):
                    raise ValueError(f"{name} must be {len(self.channels)} finite numbers")
                setattr(self, name, v)
        if self.std is not None and np.any(self.std <= 0):
            raise ValueError("std must be positive")
        if (self.mean is None) != (self.std is None):
            raise ValueError("mean and std must both be set or both be None")

    @property
    def n_channels(self) -> int:
        return len(self.channels)

    @property
    def fitted(self) -> bool:
        return self.mean is not None and self.std is not None

    @property
    def window_s(self) -> float:
        """Duration covered by one window's samples (seconds)."""
        return (self.window - 1) / self.rate_hz

    def fit(self, X: np.ndarray) -> "FeatureSpec":
        """Fit per-channel mean/std on windows ``X`` (N, C, T); returns self."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 3 or X.shape[1] != self.n_channels or X.shape[0] == 0:
            raise ValueError(f"fit needs windows (N>0, {self.n_channels}, T), got {X.shape}")
        self.mean = X.mean(axis=(0, 2))
        self.std = np.maximum(X.std(axis=(0, 2)), STD_FLOOR)
        return self

    def normalise(self, X: np.ndarray) -> np.ndarray:
        """Standardise windows ``X`` (N, C, T) with the fitted statistics (float32)."""
        if not self.fitted:
            raise ValueError("FeatureSpec is not fitted: call fit() on training windows first")
        X = np.asarray(X)
        if X.ndim != 3 or X.shape[1] != self.n_channels:
            raise ValueError(f"normalise needs windows (N, {self.n_channels}, T), got {X.shape}")
        out = (X - self.mean[None, :, None]) / self.std[None, :, None]
        return out.astype(np.float32)

    def to_dict(self) -> dict:
        """JSON-safe dict (stored in ONNX metadata and profiles)."""
        return {
            "features": self.features,
            "rate_hz": self.rate_hz,
            "window": self.window,
            "stride": self.stride,
            "channels": list(self.channels),
            "transform": self.transform,
            "speed_source": self.speed_source,
            "trim_s": self.trim_s,
            "max_gap_s": self.max_gap_s,
            "savgol_window_s": self.savgol_window_s,
            "mean": None if self.mean is None else [float(x) for x in self.mean],
            "std": None if self.std is None else [float(x) for x in self.std],
            "version": self.version,
            # quad specs (every model and profile written before n-rotor windows) stay as they were
            **({"n_motors": self.n_motors} if self.n_motors != 4 else {}),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "FeatureSpec":
        """Inverse of :meth:`to_dict`; raises ValueError on a malformed dict."""
        if not isinstance(d, dict):
            raise ValueError(f"feature spec must be a dict, not {type(d).__name__}")
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown feature spec keys: {sorted(unknown)}")
        kw = dict(d)
        if "channels" in kw and kw["channels"] is not None:
            kw["channels"] = tuple(kw["channels"])
        try:
            return cls(**kw)
        except TypeError as e:  # wrong value types
            raise ValueError(f"bad feature spec: {e}") from None



@dataclass
class Windows:
    """Input windows of one flight, before standardisation.

    ``X`` (N, C, T) float32; ``t_start`` / ``t_end`` (N,) times of the first and last sample of
    each window on the log's clock; ``segment`` (N,) index of the segment it came from.
    ``reason`` says why there are none when N == 0.
    """

    X: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    segment: np.ndarray
    spec: FeatureSpec
    speed_source: str = "command"
    n_segments: int = 0
    segment_s: float = 0.0  # total duration of usable segments
    reason: str = ""
    scales: dict = field(default_factory=dict)  # per-flight robust scales used (scale_free)
    #: The resampled segments the windows were cut from (for the effectiveness estimate and the
    #: evidence, so a flight is resampled once); never serialised.
    segments: list = field(default_factory=list, repr=False)

    def __len__(self) -> int:
        return int(self.X.shape[0])



def robust_scale(x: np.ndarray, floor: float) -> np.ndarray:
    """Per-column 1.4826 x median absolute deviation, floored."""
    x = np.asarray(x, dtype=np.float64)
    if x.shape[0] == 0:
        return np.full(x.shape[1], floor)
    med = np.median(x, axis=0)
    return np.maximum(MAD_TO_STD * np.median(np.abs(x - med), axis=0), floor)


def _segment_matrix(seg: Segment, spec: FeatureSpec, scales: dict) -> np.ndarray:
    """(n, C) channel matrix of one segment, with the per-flight part of the transform."""
    if spec.features == "nif":
        acc = seg.ang_acc / scales["ang_acc"] if spec.transform == "scale_free" else seg.ang_acc
        return np.concatenate([acc, seg.w_sq], axis=1)
    rates = seg.rates / scales["rates"] if spec.transform == "scale_free" else seg.rates
    return np.concatenate([seg.attitude, rates, np.sqrt(np.clip(seg.w_sq, 0.0, None))], axis=1)


def _empty_windows(spec: FeatureSpec, source: str, reason: str, n_segments: int = 0,
                   segment_s: float = 0.0) -> Windows:
    return Windows(X=np.zeros((0, spec.n_channels, spec.window), np.float32), t_start=np.zeros(0),
                   t_end=np.zeros(0), segment=np.zeros(0, dtype=int), spec=spec, speed_source=source,
                   n_segments=n_segments, segment_s=segment_s, reason=reason)


def window_spans(times: list[np.ndarray], spec: FeatureSpec) -> tuple[np.ndarray, np.ndarray]:
    """(t_start, t_end) of the windows :func:`make_windows` cuts from segments with these
    ``times`` (``Segment.t``, or :func:`~flightlog_fd.prepared.segment_times`), without the
    windows themselves (what `fdlog info` needs to tell whether a log can be judged)."""
    t0, t1 = [], []
    for t in times:
        if len(t) >= spec.window:
            starts = np.arange(0, len(t) - spec.window + 1, spec.stride)
            t0.append(t[starts])
            t1.append(t[starts + spec.window - 1])
    return (np.concatenate(t0), np.concatenate(t1)) if t0 else (np.zeros(0), np.zeros(0))


def no_window_reason(flight: Flight, times: list[np.ndarray], spec: FeatureSpec) -> str:
    """Why segments with these ``times`` (of ``flight``) hold no window of ``spec``."""
    if not flight.airborne:
        return "the vehicle is never airborne in this log"
    longest = max((len(t) / spec.rate_hz for t in times), default=0.0)
    return (f"airborne {flight.airborne_s:.1f} s in all; after trimming {spec.trim_s:g} s at take-off and "
            f"landing and splitting at data gaps, the longest usable stretch is {longest:.1f} s and a "
            f"window needs {spec.window / spec.rate_hz:.1f} s")


def make_windows(flight, spec: Optional[FeatureSpec] = None, strict: bool = False) -> Windows:
    """Windows (before standardisation) of one flight (a Flight or a
    :class:`~flightlog_fd.prepared.PreparedFlight`, whose segments it then shares), following ``spec``.

    Returns an empty :class:`Windows` with ``reason`` set when the flight yields none, or raises
    NotDiagnosableError with that reason when ``strict``. Raises MissingDataError /
    UnsupportedVehicleError when a needed stream is absent or the vehicle is not a quadrotor.
    """
    spec = spec or FeatureSpec()
    prep = PreparedFlight.of(flight)
    flight = prep.flight
    segments = resample(prep, spec.rate_hz, spec.max_gap_s, spec.trim_s, spec.savgol_window_s,
                        need_attitude=(spec.features == "cf"), speed_source=spec.speed_source,
                        n_motors=spec.n_motors)
    source = segments[0].speed_source if segments else spec.speed_source
    seg_s = float(sum(len(s) for s in segments) / spec.rate_hz)
    usable = [i for i, s in enumerate(segments) if len(s) >= spec.window]
    if not usable:
        reason = no_window_reason(flight, [s.t for s in segments], spec)
        if strict:
            raise NotDiagnosableError(flight.path, reason)
        out = _empty_windows(spec, source, reason, len(segments), seg_s)
        out.segments = segments
        return out

    scales = {}
    if spec.transform == "scale_free":
        scales["ang_acc"] = robust_scale(np.concatenate([s.ang_acc for s in segments]), ANG_ACC_SCALE_FLOOR)
        scales["rates"] = robust_scale(np.concatenate([s.rates for s in segments]), RATE_SCALE_FLOOR)
    motor_ch = slice(3, 3 + spec.n_motors) if spec.features == "nif" else slice(5, 5 + spec.n_motors)

    xs, t0s, t1s, segidx = [], [], [], []
    T, S = spec.window, spec.stride
    for i in usable:
        seg = segments[i]
        F = _segment_matrix(seg, spec, scales)  # (n, C)
        W = sliding_window_view(F, T, axis=0)[::S]  # (N, C, T) view
        starts = np.arange(0, len(seg) - T + 1, S)
        xs.append(W)
        t0s.append(seg.t[starts])
        t1s.append(seg.t[starts + T - 1])
        segidx.append(np.full(starts.size, i, dtype=int))
    X = np.concatenate(xs, axis=0).astype(np.float32)
    if spec.transform == "scale_free":
        share = X[:, motor_ch, :].mean(axis=(1, 2), dtype=np.float64)
        X[:, motor_ch, :] /= np.maximum(share, MIN_MEAN_THRUST)[:, None, None].astype(np.float32)
    return Windows(X=X, t_start=np.concatenate(t0s), t_end=np.concatenate(t1s), segment=np.concatenate(segidx),
                   spec=spec, speed_source=source, n_segments=len(segments), segment_s=seg_s, reason="",
                   scales={k: v.tolist() for k, v in scales.items()}, segments=segments)


#: Label of a window that straddles a mid-flight fault onset (dropped in training).
AMBIGUOUS_LABEL = -1


def window_labels(flight: Flight, windows: Windows, truth: Optional[dict] = None) -> np.ndarray:
    """(N,) class per window from ``truth`` (default ``flight.truth``): 0 healthy, k = motor k
    damaged, -1 ambiguous. See :func:`labels_for_spans`."""
    truth = truth if truth is not None else flight.truth
    if not truth:
        raise ValueError(f"{flight.path}: flight has no truth (only simulated flights carry labels)")
    try:
        return labels_for_spans(truth, windows.t_start, windows.t_end)
    except ValueError as e:
        raise ValueError(f"{flight.path}: {e}") from None


def labels_for_spans(truth: dict, t_start: np.ndarray, t_end: np.ndarray) -> np.ndarray:
    """(N,) class per time span [t_start, t_end] (log clock) from a truth dict.

    ``truth["label"]`` (0..n, falling back on ``truth["motor"]``; n = ``truth["rotor_count"]``,
    default 4) applies from ``truth["onset_s"]`` (log-clock seconds; None or absent = from the
    start). Spans ending before the onset are healthy (0); spans straddling it are -1.
    """
    label = truth.get("label", truth.get("motor"))
    n = int(truth.get("rotor_count", 4))
    if label is None or int(label) not in range(n + 1):
        raise ValueError(f"truth label must be 0..{n}, not {label!r}")
    label = int(label)
    t_start = np.asarray(t_start, dtype=np.float64)
    t_end = np.asarray(t_end, dtype=np.float64)
    out = np.full(len(t_start), label, dtype=int)
    onset = truth.get("onset_s")
    if label == 0 or onset is None:
        return out
    onset = float(onset)
    out[t_end < onset] = 0
    out[(t_start < onset) & (t_end >= onset)] = AMBIGUOUS_LABEL
    return out
