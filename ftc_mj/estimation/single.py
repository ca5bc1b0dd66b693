"""A single EKF or UKF (common to :mod:`.ekf` and :mod:`.ukf`): one compiled call per step.

One step = predict with the measured wheel rates, then update with the finite measurement channels,
with the numerical-health rules of :mod:`.kernels.single` (gating, symmetrising, covariance repair,
divergence resets).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..context import RunContext
from .base import FilterOutput, Measurement
from .buffers import Counter, FilterBuffers, HealthCounters
from .kernels.layout import C_STEPS
from .kernels.single import single_step_ekf, single_step_ukf
from .measurements import kernel_inputs
from .setup import FilterSettings, FilterSetup, setup_from_settings


class SingleFilter(HealthCounters):
    """Base of :class:`~ftc_mj.estimation.EKF` and :class:`~ftc_mj.estimation.UKF`, built from its
    resolved parameters ``setup`` (:class:`.setup.FilterSetup`); :meth:`from_context` (the registered
    factory) and :meth:`from_settings` build it from the filter's own settings, :attr:`Settings`."""

    member = "ukf"
    Settings = FilterSettings
    """The filter's settings model (the ``[estimator]`` section composes it)."""

    @classmethod
    def from_context(cls, settings: FilterSettings, context: RunContext) -> SingleFilter:
        """The filter of its settings in a run (the sensors' noise, the geometry and the initial pose from
        the run context): the factory the registry calls."""
        return cls(FilterSetup.from_context(settings, context))

    @classmethod
    def from_settings(cls, settings: FilterSettings | Any = None, sensors: Any = None, **geometry: Any) -> SingleFilter:
        """The filter built from its own settings, without a run config: ``settings`` and ``sensors`` as
        models or plain tables (one-line errors), ``geometry`` the keywords ``wheel_radius``, ``half_track``
        (m) and ``initial_pose`` (m, m, rad) of :func:`.setup.setup_from_settings`. It gives the same
        estimates as the filter of a run with those settings."""
        return cls(setup_from_settings(settings, sensors, model=cls.Settings, **geometry)[1])

    def __init__(self, setup: FilterSetup) -> None:
        self.setup = setup
        self._st = FilterBuffers(self.setup, 1)
        self._x = self._st.X[0]  # views: the state lives in the buffers the compiled step works on
        self._P = self._st.P[0]
        self._x[:] = self.setup.x0
        self._P[:] = self.setup.P0
        self._step = single_step_ekf if self.member == "ekf" else single_step_ukf  # compiled per kind

    # ---------------------------------------------------------------- state access
    @property
    def x(self) -> np.ndarray:
        """Current estimate [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
        return self._x

    @x.setter
    def x(self, value: np.ndarray) -> None:
        self._x[:] = np.asarray(value, float).reshape(5)

    @property
    def P(self) -> np.ndarray:
        """Current 5x5 covariance."""
        return self._P

    @P.setter
    def P(self, value: np.ndarray) -> None:
        self._P[:] = np.asarray(value, float).reshape(5, 5)

    t_steps = Counter(C_STEPS, "Steps taken.")

    def set_state(self, x: np.ndarray, P: np.ndarray) -> None:
        """Overwrite the estimate (m, m, rad, m, m) and its 5x5 covariance."""
        self.x = x
        self.P = P

    # ---------------------------------------------------------------- step
    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """Predict with wheel rates ``u`` = [omega_R, omega_L] (rad/s), update with ``z``."""
        st = self._st
        nis, sp_innov, sp_std, m, rejected, reset, pose_rej = self._step(st.buf, st.cnt,
                                                                         *kernel_inputs(self.setup, u, z))
        return FilterOutput(
            x=self._x.copy(), P=self._P.copy(), innovation=st.y_of[m].copy(), S=st.S_of[m].copy(), nis=nis,
            speed_innovation=sp_innov, speed_innovation_std=sp_std, rejected=rejected, reset=reset,
            pose_rejected=pose_rej,
        )
