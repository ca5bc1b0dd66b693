"""Unscented Kalman filter (paper §3): Julier sigma points (κ = ``estimator.kappa``, 0.001), Euler
prediction through the kinematic model of all 11 sigma points.

The maths is that of filterpy 2.0.0's ``UnscentedKalmanFilter`` with ``JulierSigmaPoints(5, kappa)``,
including 2.0's regeneration of the sigma points from the prior before the update, so a test compares
the two to round-off (:mod:`.kernels.kalman`).
"""

from __future__ import annotations

from typing import Literal

from ..fields import StrictModel, ranged
from .settings import EstimatorSettings
from .single import SingleFilter


class SigmaPointSettings(StrictModel):
    """The sigma points of a UKF (the UKF's and an IMM bank's of UKF members)."""

    kappa: ranged(-5.0, 1.0e3, lo_open=True) = 0.001
    """Julier sigma-point parameter."""


class UKFSettings(EstimatorSettings, SigmaPointSettings):
    """Settings of the UKF (``estimator.kind = "ukf"``): the filter model's, the sigma points' and the
    decision's."""

    kind: Literal["ukf"] = "ukf"
    """The unscented Kalman filter (a registered estimator, :data:`ftc_mj.registry.estimators`)."""


class UKF(SingleFilter):
    """UKF over [x, y, psi, R_R, R_L] at ``1 / setup.dt``: ``UKF(setup).step(u, z) -> FilterOutput``."""

    member = "ukf"
    Settings = UKFSettings
