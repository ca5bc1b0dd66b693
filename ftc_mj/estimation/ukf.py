"""Unscented Kalman filter (paper §3): Julier sigma points (κ = ``estimator.kappa``, 0.001), Euler
prediction through the kinematic model, all 11 sigma points propagated in one vectorised call.

The maths is that of filterpy 2.0.0's ``UnscentedKalmanFilter`` with ``JulierSigmaPoints(5, kappa)``,
including 2.0's regeneration of the sigma points from the prior before the update,
so a test compares the two to round-off. See :mod:`._core` for the shared maths and
:mod:`._single` for the numerical-health rules (gating, symmetrising, resets).
A step runs as one compiled call (:mod:`._kernels`, numba); ``backend="numpy"`` runs the numpy
reference code of :mod:`._core` instead (same results to round-off).
"""

from __future__ import annotations

from ._single import SingleFilter


class UKF(SingleFilter):
    """UKF over [x, y, psi, R_R, R_L] at ``estimator.rate``: ``UKF(cfg).step(u, z) -> FilterOutput``."""

    member = "ukf"
