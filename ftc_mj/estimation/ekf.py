"""Extended Kalman filter (paper §3): Euler prediction through the kinematic model, Jacobians of the
step and of the measurements from CasADi's automatic differentiation of the single model definition
(:mod:`ftc_mj.model.kinematics`), evaluated through a numpy transcription generated once.

The maths is that of filterpy 2.0.0's ``ExtendedKalmanFilter`` (``F`` evaluated at the posterior
before the Euler step, Joseph-form covariance update), so a test compares the two to round-off.
See :mod:`._single` for the numerical-health rules.
A step runs as one compiled call (:mod:`._kernels`, numba); ``backend="numpy"`` runs the numpy
reference code of :mod:`._core` instead (same results to round-off).
"""

from __future__ import annotations

from ._single import SingleFilter


class EKF(SingleFilter):
    """EKF over [x, y, psi, R_R, R_L] at ``estimator.rate``: ``EKF(cfg).step(u, z) -> FilterOutput``."""

    member = "ekf"
