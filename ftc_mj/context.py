"""What a component may know of the run beyond its own settings: :class:`RunContext`.

Components (filters, decision rules, controllers, reconfiguration policies, reference paths) are
built from *their own* settings plus this small context — the rates, the robot's nominal geometry,
the seed — never from the whole application config. Only the factory modules
(``ftc_mj/*/factory.py``) read the application config; they build the context with
:func:`ftc_mj.config.run_context`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class RunContext:
    """The run-level facts a component may depend on (SI units, radians)."""

    seed: int
    """The run's seed (components that draw random numbers derive their stream from it)."""
    duration: float
    """Simulated time (s)."""
    physics_dt: float
    """Physics step (s)."""
    estimator_dt: float
    """Estimator period (s): ``1 / estimator.rate``."""
    controller_dt: float
    """Controller period (s): ``1 / controller.rate``."""
    nominal_radii: tuple[float, float]
    """Wheel radii ``(R_R, R_L)`` the model assumes when healthy (m)."""
    half_track: float
    """Half the distance between the wheels the model assumes, ``b`` (m)."""
    omega_max: float
    """Largest wheel rate the robot's servos can command (rad/s)."""
    initial_pose: tuple[float, float, float]
    """Initial ``(x, y, psi)`` of the axle midpoint (m, m, rad)."""
    sensors: Any = None
    """The sensors' settings (``speed_sigma``, ``yaw_rate_sigma``, ``position_sigma``, … in SI units;
    ``None`` σ = channel absent): the measurement model a filter must match."""
    estimator_rate: float | None = None
    """Estimator rate (Hz) as configured (``None``: ``1 / estimator_dt``); a component dividing by the
    rate uses this, which ``1 / estimator_dt`` does not always give back to the last bit."""
    controller_rate: float | None = None
    """Controller rate (Hz) as configured (``None``: ``1 / controller_dt``)."""
    min_radius: float | None = None
    """Smallest wheel radius (m) the estimator reports (``estimator.min_radius``): the floor of the radii
    a reconfiguration policy hands to the controller."""

    def __post_init__(self) -> None:
        if self.estimator_rate is None:
            object.__setattr__(self, "estimator_rate", 1.0 / self.estimator_dt)
        if self.controller_rate is None:
            object.__setattr__(self, "controller_rate", 1.0 / self.controller_dt)
