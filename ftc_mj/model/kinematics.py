"""The kinematic model of the differential-drive robot, defined once.

State ``x = [x, y, psi, R_R, R_L]`` (m, m, rad, m, m), input ``u = [omega_R, omega_L]`` (rad/s),
parameter ``b`` = half track (m, wheel centre to axle midpoint; DESIGN §1)::

    V      = (R_R omega_R + R_L omega_L) / 2
    psidot = (R_R omega_R - R_L omega_L) / (2 b)
    xdot   = V cos psi,   ydot = V sin psi,   Rdot = 0

:func:`pose_rates` is the single definition. It is written against a math namespace (``numpy`` or
``casadi``), so the same lines give the vectorised numeric evaluation (all sigma points of a UKF in
one call), the CasADi symbolic expression used by the MPCs, and, through CasADi's automatic
differentiation, every Jacobian. Nothing else in the package writes these equations again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from types import ModuleType
from typing import Any

import casadi as ca
import numpy as np

STATE_NAMES: tuple[str, ...] = ("x", "y", "psi", "R_R", "R_L")
INPUT_NAMES: tuple[str, ...] = ("omega_R", "omega_L")
NX = 5
NU = 2


def body_rates(R_R: Any, R_L: Any, omega_R: Any, omega_L: Any, b: Any) -> tuple[Any, Any]:
    """Forward speed ``V`` (m/s) of the axle midpoint and yaw rate (rad/s) from wheel rates."""
    V = 0.5 * (R_R * omega_R + R_L * omega_L)
    psidot = (R_R * omega_R - R_L * omega_L) / (2.0 * b)
    return V, psidot


def pose_rates(
    psi: Any, R_R: Any, R_L: Any, omega_R: Any, omega_L: Any, b: Any, lib: ModuleType = np
) -> tuple[Any, Any, Any]:
    """Time derivatives ``(xdot, ydot, psidot)`` of the pose; ``lib`` is ``numpy`` or ``casadi``."""
    V, psidot = body_rates(R_R, R_L, omega_R, omega_L, b)
    return V * lib.cos(psi), V * lib.sin(psi), psidot


def inverse_rates(V: Any, psidot: Any, R_R: Any, R_L: Any, b: Any) -> tuple[Any, Any]:
    """Wheel rates ``(omega_R, omega_L)`` (rad/s) that give speed ``V`` and yaw rate ``psidot``."""
    return (V + b * psidot) / R_R, (V - b * psidot) / R_L


@dataclass(frozen=True)
class KinematicModel:
    """The kinematic model with half track ``b`` (m) and filter step ``dt`` (s).

    Numeric methods take stacked arrays: states of shape ``(..., 5)`` and inputs of shape
    ``(..., 2)`` broadcast against each other, so one call propagates a batch of sigma points.
    Symbolic methods return CasADi ``Function`` objects built from the same :func:`pose_rates`.
    """

    b: float = 1.0
    dt: float = 0.01
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # ---------------------------------------------------------------- numeric (numpy)
    def derivative(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Continuous-time ``xdot`` (..., 5) for states (..., 5) and inputs (..., 2)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        xd, yd, pd = pose_rates(x[..., 2], x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b, np)
        zeros = np.zeros_like(xd)
        return np.stack([xd, yd, pd, zeros, zeros], axis=-1)

    def step(self, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Euler step ``x + dt f(x, u)`` (the paper's filter prediction)."""
        return np.asarray(x, dtype=float) + (self.dt if dt is None else dt) * self.derivative(x, u)

    def speed(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Measurement function of the speed sensor: ``V`` (m/s) for states (..., 5)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        return body_rates(x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b)[0]

    def yaw_rate(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Measurement function of the yaw-rate gyro (rad/s) for states (..., 5)."""
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        return body_rates(x[..., 3], x[..., 4], u[..., 0], u[..., 1], self.b)[1]

    def step_jacobian(self, x: np.ndarray, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        """``d step / d x`` (5x5) at one state, from CasADi automatic differentiation."""
        J = self.casadi_step_jacobian()(np.asarray(x, float), np.asarray(u, float), self.dt if dt is None else dt)
        return np.asarray(J)

    def measurement_jacobian(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``d [V, psidot] / d x`` (2x5) at one state, from CasADi automatic differentiation."""
        return np.asarray(self.casadi_rates_jacobian()(np.asarray(x, float), np.asarray(u, float)))

    # ---------------------------------------------------------------- symbolic (CasADi)
    @cached_property
    def _symbols(self) -> tuple[ca.SX, ca.SX, ca.SX]:
        return ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("dt")

    def casadi_derivative(self) -> ca.Function:
        """``f(x[5], u[2]) -> xdot[5]`` as a CasADi Function (SX)."""
        if "f" not in self._cache:
            x, u, _ = self._symbols
            xd, yd, pd = pose_rates(x[2], x[3], x[4], u[0], u[1], self.b, ca)
            self._cache["f"] = ca.Function("f", [x, u], [ca.vertcat(xd, yd, pd, 0, 0)], ["x", "u"], ["xdot"])
        return self._cache["f"]

    def casadi_step(self) -> ca.Function:
        """``step(x, u, dt) -> x + dt f(x, u)`` as a CasADi Function."""
        if "step" not in self._cache:
            x, u, dt = self._symbols
            self._cache["step"] = ca.Function(
                "step", [x, u, dt], [x + dt * self.casadi_derivative()(x, u)], ["x", "u", "dt"], ["x_next"]
            )
        return self._cache["step"]

    def casadi_step_jacobian(self) -> ca.Function:
        """``F(x, u, dt) = d step / d x`` by automatic differentiation."""
        if "F" not in self._cache:
            x, u, dt = self._symbols
            nxt = self.casadi_step()(x, u, dt)
            self._cache["F"] = ca.Function("F", [x, u, dt], [ca.jacobian(nxt, x)], ["x", "u", "dt"], ["F"])
        return self._cache["F"]

    def casadi_rates(self) -> ca.Function:
        """``rates(x, u) -> [V, psidot]`` as a CasADi Function."""
        if "rates" not in self._cache:
            x, u, _ = self._symbols
            V, pd = body_rates(x[3], x[4], u[0], u[1], self.b)
            self._cache["rates"] = ca.Function("rates", [x, u], [ca.vertcat(V, pd)], ["x", "u"], ["Vpsidot"])
        return self._cache["rates"]

    def casadi_rates_jacobian(self) -> ca.Function:
        """``d [V, psidot] / d x`` by automatic differentiation."""
        if "H" not in self._cache:
            x, u, _ = self._symbols
            self._cache["H"] = ca.Function(
                "H", [x, u], [ca.jacobian(self.casadi_rates()(x, u), x)], ["x", "u"], ["H"]
            )
        return self._cache["H"]
