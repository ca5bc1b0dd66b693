"""Two components written outside ftc-mj and registered with it: an estimator and a policy.

Name this module in a config (``plugins = ["my_components"]``) or on the command line
(``ftc-mj run scenario2 --plugin my_components --estimator textbook-ekf``); importing it registers
both, in the client and in every Dask worker (it must be importable there: same folder on
``sys.path`` for a LocalCluster, an installed package on a remote cluster).

Both follow the factory contract of ``docs/plugins.md``: built from their own config section
(``settings``: ``estimator`` / ``reconfiguration``, whose ``options`` table holds the plug-in's own
settings) and the small run context (``context``: rates, nominal geometry, initial pose, sensors).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

import ftc_mj
from ftc_mj.config import ReconfigurationConfig
from ftc_mj.context import RunContext
from ftc_mj.estimation.settings import PluginEstimatorSettings
from ftc_mj.model.kinematics import KinematicModel


class TextbookEKFSettings(BaseModel):
    """``estimator.options`` of the ``textbook-ekf``."""

    model_config = ConfigDict(extra="forbid")
    q_scale: float = Field(1.0, gt=0)
    """Factor on the configured process noise ``Q``."""


class TextbookEKF:
    """A plain EKF over ``[x, y, psi, R_R, R_L]``: Euler prediction through the kinematic model, the
    speed (and yaw-rate, if the config has a gyro) measurement, no gating or resets."""

    def __init__(self, settings: PluginEstimatorSettings, context: RunContext) -> None:
        dt = context.estimator_dt
        self.model = KinematicModel(b=context.half_track, dt=dt)
        self.x = np.array([*context.initial_pose, *context.nominal_radii], dtype=float)
        self.P = np.diag(np.square(settings.p0_sigma))
        q_scale = TextbookEKFSettings.model_validate(settings.options).q_scale
        self.Q = q_scale * np.diag(np.asarray(settings.q_diffusion) * dt)
        sen = context.sensors
        self.r = [sen.speed_sigma**2] + ([sen.yaw_rate_sigma**2] if sen.yaw_rate_sigma else [])

    def step(self, u: np.ndarray, z: ftc_mj.Measurement) -> ftc_mj.FilterOutput:
        F = self.model.step_jacobian(self.x, u)
        self.x = self.model.step(self.x, u)
        self.P = F @ self.P @ F.T + self.Q
        m = len(self.r) if z.yaw_rate is not None else 1
        H = self.model.measurement_jacobian(self.x, u)[:m]
        zp = np.array([self.model.speed(self.x, u), self.model.yaw_rate(self.x, u)])[:m]
        y = np.array([z.speed, z.yaw_rate])[:m].astype(float) - zp
        S = H @ self.P @ H.T + np.diag(self.r[:m])
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ y
        self.P = (np.eye(5) - K @ H) @ self.P
        return ftc_mj.FilterOutput(x=self.x.copy(), P=self.P.copy(), innovation=y, S=S,
                                   nis=float(y @ np.linalg.solve(S, y)), speed_innovation=float(y[0]),
                                   speed_innovation_std=float(np.sqrt(S[0, 0])))


class LateHandoverSettings(BaseModel):
    """``reconfiguration.options`` of the ``late-handover`` policy."""

    model_config = ConfigDict(extra="forbid")
    delay: float = Field(1.0, ge=0)
    """Time (s) a declared, isolated fault must have stood before its radii are handed over."""


class LateHandover(ftc_mj.ReconfigurationPolicy):
    """Nominal radii until ``delay`` s after the first declaration, while a wheel is isolated; then the
    isolated wheels' estimates, clamped to [``estimator.min_radius``, nominal] (m)."""

    def __init__(self, settings: ReconfigurationConfig, context: RunContext) -> None:
        super().__init__(settings, context)
        self.delay = LateHandoverSettings.model_validate(settings.options).delay

    def radii(self, t: float, out: ftc_mj.FilterOutput | None, decision: ftc_mj.DecisionState | None,
              filter_reset: bool, omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        isolated = {"right": (True, False), "left": (False, True), "both": (True, True)}
        if out is None or decision is None or decision.wheel not in isolated or t - decision.time < self.delay:
            self.state = 0  # nominal radii
            return self.nominal.copy()
        self.state = 2  # handed over
        est = np.clip(out.x[3:5], self.floor, self.nominal)
        return np.where(isolated[decision.wheel], est, self.nominal)


ftc_mj.register_estimator("textbook-ekf", TextbookEKF, settings=TextbookEKFSettings)
ftc_mj.register_policy("late-handover", LateHandover, settings=LateHandoverSettings)
