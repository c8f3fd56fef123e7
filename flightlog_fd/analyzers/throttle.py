"""The throttle as evidence: a weak rotor's lost thrust must be made up, so the hover throttle rises.

Input: the flight's mean thrust command over the profile's (``ShareFit.throttle_ratio``),
and the command shares. Per motor, its LLR is what adding the throttle to the command-share fit
adds (:func:`flightlog_fd.analyzers.command_shares.fits_for` with and without it), so the
decision counts the shares once and the throttle once. Noise: the airframe's relative throttle
drift (the profile's measured spread pooled with ``THROTTLE_DRIFT_SIGMA``).
Limits: needs a profile (without one the hover throttle of a healthy airframe is unknown); a new
payload or battery moves the throttle too, which is why it only weighs together with a one-rotor
command pattern.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from .base import Analyzer, AnalyzerResult, Context, Finding
from .command_shares import fits_for


@dataclass
class ThrottleResult(AnalyzerResult):
    """The throttle analyzer's result; ``ratio``: the flight's throttle over the profile's (None
    when it abstained)."""

    ratio: Optional[float] = None


class Throttle(Analyzer):
    id = "throttle"
    description = "the throttle against calibration (a weak rotor's lost thrust is made up)"
    requires = ("motors",)
    reliability_keys = ("profile",)

    def analyze(self, ctx: Context) -> AnalyzerResult:
        share_fit = ctx.share_fit
        ratio = None if share_fit is None else share_fit.throttle_ratio
        if ratio is None:
            return ThrottleResult(self.id, abstained="no calibration profile: the healthy throttle is unknown")
        if share_fit.baseline == "before onset" or (share_fit.baseline == "profile" and share_fit.drifting() is not None):
            return ThrottleResult(self.id, abstained="the commands drift after the onset")
        plain, full = fits_for(ctx, with_throttle=False), fits_for(ctx, with_throttle=True)
        if plain is None or full is None:
            return ThrottleResult(self.id, abstained="the command shares are not finite")
        # more load on every motor is not evidence by itself: the throttle weighs for motor k only
        # as far as the command pattern already points at k (never more than the shares do)
        return ThrottleResult(self.id, [
            Finding(self.id, k + 1, "throttle", ratio, "x calibration", None, 1.0, "up",
                    min(f.llr - p.llr, max(p.llr, 0.0)), f"{ratio:.2f}x")
            for k, (p, f) in enumerate(zip(plain[1], full[1]))], ratio=ratio)
