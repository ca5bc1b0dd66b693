"""Extended Kalman filter (paper §3): Euler prediction through the kinematic model, Jacobians of the
step and of the measurements from CasADi's automatic differentiation of the single model definition
(:mod:`ftc_mj.model.kinematics`), compiled from generated code (:mod:`.kernels.generated`).

The maths is that of filterpy 2.0.0's ``ExtendedKalmanFilter`` (``F`` evaluated at the posterior
before the Euler step, Joseph-form covariance update), so a test compares the two to round-off.
"""

from __future__ import annotations

from .single import SingleFilter


class EKF(SingleFilter):
    """EKF over [x, y, psi, R_R, R_L] at ``1 / setup.dt``: ``EKF(setup).step(u, z) -> FilterOutput``."""

    member = "ekf"
