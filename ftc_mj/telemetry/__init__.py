"""What a run records: its trace (columns in :mod:`ftc_mj.telemetry.columns`) and, beside it, the
controller solves, the events and the robot's drawn geometry defined here.

Plain data, without Rerun: the simulation loop fills these records, and only writing a recording
(:mod:`ftc_mj.rerun`) loads rerun-sdk. This module imports nothing of the package (the trace's
column schema, which names the estimators' statistics, is imported from ``columns`` explicitly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_OK_STATUSES = frozenset({"ok", "success", "succeeded", "solve_succeeded", "solved_to_acceptable_level",
                          "solved", "converged", "optimal"})


@dataclass(frozen=True)
class Solve:
    """One controller solve as a run records it (and the recorder draws it).

    ``predicted`` is the predicted state trajectory ``(K, 3)`` of ``[x, y, psi]`` (m, m, rad);
    ``status`` is the solver's return status (``"ok"``/``"Solve_Succeeded"``… count as converged);
    ``fallback`` is True when the controller fell back (e.g. to the previous plan) after a failure.
    """

    t: float
    predicted: np.ndarray
    solve_time_ms: float
    iterations: int
    status: str
    fallback: bool = False
    success: bool | None = None
    """The controller's own verdict; ``None`` = judge from ``status``."""

    @property
    def ok(self) -> bool:
        """True if the solve converged and no fallback was used."""
        if self.fallback:
            return False
        if self.success is not None:
            return self.success
        return self.status.strip().lower() in _OK_STATUSES


@dataclass(frozen=True)
class Event:
    """A discrete event shown in the text log: fault onsets, decisions, solver failures, filter
    resets, plant domain flags. ``level`` is ``'info'``, ``'warn'`` or ``'error'``."""

    t: float
    level: str
    text: str


@dataclass(frozen=True)
class RobotGeometry:
    """Sizes (m) used to draw the robot; the robot frame is x forward, y left, z up.

    Without a ``z`` trace column the robot frame sits on the ground under the axle midpoint, and each
    wheel is drawn touching the ground (centre height = its current radius); the chassis box centre is
    at ``(chassis_offset_x, 0, chassis_height)`` (``chassis_height`` ``None`` = the nominal radius).
    With a ``z`` column the robot frame is the chassis body frame at height ``z`` and the wheel
    centres are at ``(0, ∓half_track, axle_offset_z)`` in it (the chassis box at
    ``(chassis_offset_x, 0, 0)``).
    """

    half_track: float = 1.0
    wheel_width: float = 0.3
    chassis_half_sizes: tuple[float, float, float] = (1.2, 0.7, 0.25)
    nominal_radius: float = 2.0
    chassis_offset_x: float = 0.0
    chassis_height: float | None = None
    axle_offset_z: float = 0.0
