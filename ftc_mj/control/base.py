"""What every controller returns at each solve, the interface the simulation loop relies on, and the one
setting every controller kind has (its rate)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from pydantic import model_validator

from ..fields import StrictModel, drop_empty_options, ranged


class ControllerSettings(StrictModel):
    """The settings every controller kind shares (the ``[controller]`` section's common part; each kind's
    model, beside its controller, adds its own and fixes ``kind``)."""

    rate: ranged(0.0, 1.0e3, lo_open=True, unit="Hz") = 10.0
    """Control rate (Hz); commands are held (zero-order hold) between solves."""

    @model_validator(mode="before")
    @classmethod
    def _no_options(cls, data: Any) -> Any:
        """A built-in kind takes no plug-in ``options``: an empty table is dropped, any other is an error
        naming ``options`` (a model with an ``options`` field, a plug-in's, keeps it)."""
        return drop_empty_options(cls, data, "controller")


@dataclass
class ControlOutput:
    """One controller sample. ``omega`` is applied under zero-order hold until the next sample."""

    omega: np.ndarray
    """Wheel-rate command [omega_R, omega_L] (rad/s), always within the input bounds."""
    success: bool = True
    """The solver reported success (or the controller needs no solver)."""
    status: str = "ok"
    iterations: int = 0
    solve_time: float = 0.0
    """Wall time of the solve (s)."""
    fallback: bool = False
    """The shifted previous plan was used because the solve failed or overran its budget."""
    predicted: np.ndarray | None = None
    """Predicted trajectory (K, 3) of [x, y, psi] over the horizon, if the controller has one."""
    predicted_t: np.ndarray | None = field(default=None)
    """Times (s, absolute) of the rows of ``predicted``."""
    predicted_omega: np.ndarray | None = field(default=None)
    """Planned wheel rates (K, 2) [omega_R, omega_L] (rad/s) at ``predicted_t``, if any."""
    telemetry: dict[str, float] = field(default_factory=dict)
    """Controller-specific values of this sample for the trace, keyed by the names the controller lists
    in ``telemetry_columns`` (SI units; a name missing here is NaN in that row)."""


class Controller(Protocol):
    """A sampled controller.

    ``telemetry_columns`` names the trace columns the controller fills through
    :attr:`ControlOutput.telemetry` (empty for most controllers)."""

    failures: int
    telemetry_columns: tuple[str, ...]

    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        """Compute the command at time ``t`` (s) from the pose [x, y, psi] and the model radii
        [R_R, R_L] (m) the controller should assume. ``u_applied`` is the wheel-rate command
        [omega_R, omega_L] (rad/s) in force on the plant just before ``t`` (including any excitation
        added after the previous solve); ``None`` before the first command."""
        ...
