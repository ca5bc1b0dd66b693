"""Extended Kalman filter (paper §3): Euler prediction through the kinematic model, Jacobians of the
step and of the measurements from CasADi's automatic differentiation of the single model definition
(:mod:`ftc_mj.model.kinematics`), compiled from generated code (:mod:`.kernels.generated`).

The maths is that of filterpy 2.0.0's ``ExtendedKalmanFilter`` (``F`` evaluated at the posterior
before the Euler step, Joseph-form covariance update), so a test compares the two to round-off.
"""

from __future__ import annotations

from typing import Literal

from .settings import EstimatorSettings
from .single import SingleFilter


class EKFSettings(EstimatorSettings):
    """Settings of the EKF (``estimator.kind = "ekf"``): the filter model's and the decision's."""

    kind: Literal["ekf"] = "ekf"
    """The extended Kalman filter (a registered estimator, :data:`ftc_mj.registry.estimators`)."""


class EKF(SingleFilter):
    """EKF over [x, y, psi, R_R, R_L] at ``1 / setup.dt``: ``EKF(setup).step(u, z) -> FilterOutput``."""

    member = "ekf"
    Settings = EKFSettings
