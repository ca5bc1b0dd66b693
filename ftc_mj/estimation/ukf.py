"""Unscented Kalman filter (paper §3): Julier sigma points (κ = ``estimator.kappa``, 0.001), Euler
prediction through the kinematic model of all 11 sigma points.

The maths is that of filterpy 2.0.0's ``UnscentedKalmanFilter`` with ``JulierSigmaPoints(5, kappa)``,
including 2.0's regeneration of the sigma points from the prior before the update, so a test compares
the two to round-off (:mod:`.kernels.kalman`).
"""

from __future__ import annotations

from .single import SingleFilter


class UKF(SingleFilter):
    """UKF over [x, y, psi, R_R, R_L] at ``1 / setup.dt``: ``UKF(setup).step(u, z) -> FilterOutput``."""

    member = "ukf"
