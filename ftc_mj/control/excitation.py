"""Persistent excitation for fault isolation: a dither of the wheel-rate ratio.

With speed-only sensing and a constant wheel-rate ratio only the radius combination
``R_R ω_R + R_L ω_L`` is observable (:mod:`~ftc_mj.estimation.observability`). Varying the ratio —
``ω_R (1 + δ)``, ``ω_L (1 - δ)`` — changes the observed combination over time and so makes the
split observable, at the cost of a small yaw wobble (the mean speed is unchanged to first order).
The loop applies it only while a fault is suspected but not isolated, and clips to the limits.
"""

from __future__ import annotations

import math


def ratio_dither(t: float, amplitude: float, period: float) -> float:
    """Relative ratio dither δ(t) = a sin(2π t / T) (dimensionless; ``t``, ``period`` in s)."""
    return amplitude * math.sin(2.0 * math.pi * t / period)
