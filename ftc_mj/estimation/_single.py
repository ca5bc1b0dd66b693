"""A single EKF or UKF with the numerical-health layer (common to :mod:`.ekf` and :mod:`.ukf`).

One step = predict with the measured wheel rates, then update with the finite measurement channels.
Health rules (a run never dies of a filter):

* non-finite channels are dropped; a step with a dropped channel, or whose NIS exceeds
  ``estimator.nis_gate``, counts as a *rejection* (the gated update is not applied);
* ``P`` is symmetrised after every step and eigen-floored if it stops being positive definite;
* *divergence* (non-finite state/covariance, or NIS above ``divergence_nis`` for
  ``divergence_dwell`` seconds) triggers a *reset*: the last finite estimate (radii clipped to
  ``[min_radius, 10 R0]``) with covariance ``reset_inflation · P0``.

A step is one call of the compiled kernel :func:`._kernels.single_step` (``backend="numba"``, the
default) or the numpy reference code below (``backend="numpy"``); both work on the same buffers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Self

import numpy as np

from ..config import EstimatorConfig, RunConfig, SensorConfig
from ._core import (
    SPEED,
    Counter,
    EKFCore,
    FilterBuffers,
    FilterSetup,
    HealthCounters,
    UKFCore,
    assemble,
    chol,
    eig_floor,
    healthy,
    kernel_inputs,
    resolve_backend,
)
from ._kernels import C_STEPS, single_step
from .base import FilterOutput, Measurement

_EMPTY_Y = np.zeros(0)
_EMPTY_S = np.zeros((0, 0))


class SingleFilter(HealthCounters):
    """Base of :class:`~ftc_mj.estimation.EKF` and :class:`~ftc_mj.estimation.UKF`.

    ``backend``: ``"numba"`` (compiled step) or ``"numpy"`` (reference); default
    :data:`._core.DEFAULT_BACKEND`.
    """

    member = "ukf"

    def __init__(self, cfg: RunConfig | None = None, setup: FilterSetup | None = None, *,
                 backend: str | None = None) -> None:
        if setup is None and cfg is None:
            raise TypeError(f"{type(self).__name__}: give a run config or a FilterSetup (or use from_settings)")
        self.setup = setup if setup is not None else FilterSetup.from_config(cfg)  # type: ignore[arg-type]
        self.backend = resolve_backend(backend)
        self.core: UKFCore | EKFCore = UKFCore(self.setup) if self.member == "ukf" else EKFCore(self.setup)
        self._st = FilterBuffers(self.setup, 1, self.member)
        self._x = self._st.X[0]  # views: the state lives in the buffers the compiled step works on
        self._P = self._st.P[0]
        self._x[:] = self.setup.x0
        self._P[:] = self.setup.P0
        self._u_last = np.zeros(2)
        # the UKF's next Cholesky repairs a non-PD covariance itself; the EKF checks every step
        self._check_pd = isinstance(self.core, EKFCore)

    @classmethod
    def from_settings(cls, estimator: EstimatorConfig | Mapping[str, Any] | None = None,
                      sensors: SensorConfig | Mapping[str, Any] | None = None, *, wheel_radius: float = 2.0,
                      half_track: float = 1.0, initial_pose: Sequence[float] = (0.0, 0.0, 0.0),
                      backend: str | None = None) -> Self:
        """The filter built from its own settings, without a run config: the ``[estimator]`` and
        ``[sensors]`` sections (objects or plain tables; ``None`` = the paper's values), the model's
        nominal wheel radius and half track (m) and the initial pose (m, m, rad); see
        :meth:`FilterSetup.from_settings`. It gives the same estimates as the filter of a run with
        those settings."""
        setup = FilterSetup.from_settings(estimator, sensors, wheel_radius=wheel_radius, half_track=half_track,
                                          initial_pose=initial_pose)
        return cls(setup=setup, backend=backend)

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
    def _inputs(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape != (2,):
            u = u.reshape(2)
        if math.isfinite(u[0] + u[1]):
            self._u_last = u
            return u
        return self._u_last

    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """Predict with wheel rates ``u`` = [omega_R, omega_L] (rad/s), update with ``z``."""
        return self._step_numba(u, z) if self.backend == "numba" else self._step_numpy(u, z)

    def _step_numba(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        st = self._st
        nis, sp_innov, sp_std, m, rejected, reset = single_step(st.buf, st.cnt, *kernel_inputs(self.setup, u, z))
        return FilterOutput(
            x=self._x.copy(), P=self._P.copy(), innovation=st.y_of[m].copy(), S=st.S_of[m].copy(), nis=nis,
            speed_innovation=sp_innov, speed_innovation_std=sp_std, rejected=rejected, reset=reset,
        )

    def _step_numpy(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        u = self._inputs(u)
        x_prev = self._x.copy()
        core = self.core
        x, P = core.predict1(x_prev, self._P, u)
        a = assemble(self.setup, z)
        rejected = a.dropped
        nis = sp_innov = sp_std = math.nan
        if a.z.size:
            xn, Pn, y, S, nis = core.update1(x, P, u, a)
            if a.kinds[0] == SPEED:
                sp_innov, sp_std = float(y[0]), math.sqrt(max(float(S[0, 0]), 0.0))
            if nis <= self.setup.nis_gate:  # False for NaN
                x, P = xn, Pn
            else:
                rejected = True
        else:
            y, S = _EMPTY_Y, _EMPTY_S
        P = 0.5 * (P + P.T)
        reset = self._check_divergence(x, P, nis)
        if reset:
            x, P = self._reset_state(x_prev)
        elif self._check_pd and math.isnan(chol(P)[-1, -1]):
            P = eig_floor(P)
        self._x[:], self._P[:] = x, P
        if rejected:
            self.rejections += 1
        self.t_steps += 1
        return FilterOutput(
            x=x.copy(), P=P.copy(), innovation=y, S=S, nis=nis,
            speed_innovation=sp_innov, speed_innovation_std=sp_std, rejected=rejected, reset=reset,
        )

    def _check_divergence(self, X: np.ndarray, P: np.ndarray, nis: float) -> bool:
        if not healthy(X, P):
            return True
        if math.isfinite(nis) and nis > self.setup.divergence_nis:
            self._bad_nis_steps += 1
        elif math.isfinite(nis):
            self._bad_nis_steps = 0
        return self._bad_nis_steps >= self.setup.divergence_steps

    def _reset_state(self, x_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.resets += 1
        self._bad_nis_steps = 0
        x = x_prev.copy() if np.all(np.isfinite(x_prev)) else self.setup.x0.copy()
        R0 = self.setup.nominal_radius
        x[3:5] = np.clip(x[3:5], self.setup.min_radius, 10.0 * R0)
        return x, self.setup.reset_inflation * self.setup.P0.copy()
