"""What the speed measurement can tell about the two wheel radii, from the filter's own covariance.

The speed sensor measures ``V = (R_R ω_R + R_L ω_L) / 2``: at one instant only the radius
combination along ``w = [ω_R, ω_L] / |ω|`` is observed; the orthogonal *split* direction
``d = [ω_L, -ω_R] / |ω|`` (one radius up, the other down, same speed) is not. With a constant
wheel-rate ratio (a steady circle) it stays unobservable for ever; it becomes observable when the
ratio varies or when a yaw-rate or position measurement is added. The filter's covariance carries
that information: its variance along ``d`` grows with the radius process noise while nothing
informs it, and shrinks when something does. Both directions are unit vectors, so both standard
deviations are in metres of radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_EQUAL = (math.sqrt(0.5), math.sqrt(0.5))


@dataclass(frozen=True)
class RadiusDirections:
    """The observed (``w``) and split (``d``) radius directions and the filter's σ along each."""

    w: tuple[float, float]
    """Unit vector of the radius combination the speed measures, ∝ [ω_R, ω_L]."""
    d: tuple[float, float]
    """Unit vector of the unobservable split, ∝ [ω_L, -ω_R]."""
    sum_std: float
    """σ (m) of ``w · [R_R, R_L]``."""
    split_std: float
    """σ (m) of ``d · [R_R, R_L]``."""


def radius_directions(P: np.ndarray, omega: np.ndarray | None = None) -> RadiusDirections:
    """Split the 2x2 radius block of the 5x5 covariance ``P`` (states [x, y, psi, R_R, R_L]) along
    the directions set by the wheel rates ``omega`` = [ω_R, ω_L] (rad/s); equal rates if ``None`` or
    (near) zero. Non-finite covariance gives infinite σ (nothing is known)."""
    if omega is None:
        w = _EQUAL
    else:
        a, b = float(omega[0]), float(omega[1])
        n = math.hypot(a, b)
        w = (a / n, b / n) if n > 1e-6 and math.isfinite(n) else _EQUAL
    d = (w[1], -w[0])
    p11, p12, p22 = float(P[3, 3]), float(P[3, 4]), float(P[4, 4])
    var_w = w[0] * w[0] * p11 + 2.0 * w[0] * w[1] * p12 + w[1] * w[1] * p22
    var_d = d[0] * d[0] * p11 + 2.0 * d[0] * d[1] * p12 + d[1] * d[1] * p22
    sw = math.sqrt(max(var_w, 0.0)) if math.isfinite(var_w) else math.inf
    sd = math.sqrt(max(var_d, 0.0)) if math.isfinite(var_d) else math.inf
    return RadiusDirections(w=w, d=d, sum_std=sw, split_std=sd)
