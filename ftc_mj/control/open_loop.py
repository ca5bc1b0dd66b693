"""Open-loop wheel-rate commands: constant or a piecewise-linear schedule (plant checks, studies)."""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from ..fields import FiniteFloat
from .base import ControllerSettings, ControlOutput


class OpenLoopSettings(ControllerSettings):
    """Settings of the open-loop controller (``controller.kind = "open-loop"``)."""

    kind: Literal["open-loop"] = "open-loop"
    """Open-loop wheel-rate commands (a registered controller, :data:`ftc_mj.registry.controllers`)."""
    open_loop_omega: tuple[FiniteFloat, FiniteFloat] = (5.0, 5.0)
    """Constant wheel rates (rad/s) of the open-loop controller."""
    open_loop_schedule: Annotated[list[tuple[FiniteFloat, FiniteFloat, FiniteFloat]], Field(max_length=10_000)] = Field(
        default_factory=list)
    """Optional ``[t, omega_R, omega_L]`` breakpoints (piecewise-linear) for the open-loop controller."""


class OpenLoopController:
    """Commands constant rates, or interpolates ``[t, omega_R, omega_L]`` breakpoints (rad/s).

    Commands are clipped to ``±omega_max`` (rad/s) like every controller's.
    """

    def __init__(
        self,
        omega: tuple[float, float] = (5.0, 5.0),
        schedule: list[tuple[float, float, float]] | None = None,
        omega_max: float = np.inf,
    ) -> None:
        self.failures = 0
        self._omega = np.asarray(omega, dtype=float)
        self._omega_max = float(omega_max)
        sched = np.asarray(schedule or [], dtype=float).reshape(-1, 3)
        self._sched = sched if len(sched) else None

    def command(self, t: float) -> np.ndarray:
        """Wheel-rate command (rad/s) at time ``t`` (s)."""
        if self._sched is None:
            w = self._omega
        else:
            ts = self._sched[:, 0]
            w = np.array([np.interp(t, ts, self._sched[:, 1]), np.interp(t, ts, self._sched[:, 2])])
        return np.clip(w, -self._omega_max, self._omega_max)

    telemetry_columns: tuple[str, ...] = ()

    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        return ControlOutput(omega=self.command(t))
