"""The resolved parameters of one filter: :class:`FilterSetup` (model, rate, noise, health rules).

A filter is built from these, and these from the filter's own settings — the ``[estimator]`` section,
the sensors' noise and the model geometry — by :meth:`FilterSetup.from_sections`; the factory
(:mod:`.factory`) validates plain tables and takes the geometry from the run context.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..model.kinematics import KinematicModel


class EstimatorSettings(Protocol):
    """What a filter reads of the ``[estimator]`` section (SI units)."""

    rate: float
    initial_radii: tuple[float, float] | None
    p0_sigma: Sequence[float]
    q_diffusion: Sequence[float]
    kappa: float
    nis_gate: float
    divergence_nis: float
    divergence_dwell: float
    reset_inflation: float
    min_radius: float


class SensorSettings(Protocol):
    """The measurement noise a filter must match (σ in SI units; ``None`` = channel absent)."""

    speed_sigma: float
    yaw_rate_sigma: float | None
    position_sigma: float | None


@dataclass(frozen=True)
class FilterSetup:
    """Resolved parameters (SI units) of one filter."""

    model: KinematicModel
    dt: float
    """Filter step (s)."""
    x0: np.ndarray
    """Initial state [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    P0: np.ndarray
    """Initial 5x5 covariance (units of the state, squared)."""
    Q: np.ndarray
    """Process noise per step, 5x5 (units of the state, squared): :func:`process_noise` of the
    settings' diffusion per second."""
    nominal_radius: float
    """Model's nominal wheel radius R0 (m)."""
    speed_sigma: float
    """Speed noise σ (m/s)."""
    yaw_rate_sigma: float | None
    """Yaw-rate noise σ (rad/s); ``None`` = no gyro."""
    position_sigma: float | None
    """Position-fix noise σ (m); ``None`` = no fixes."""
    kappa: float
    """Julier sigma-point parameter κ."""
    nis_gate: float
    """NIS above which an update is rejected."""
    divergence_nis: float
    """NIS level that counts towards divergence."""
    divergence_steps: int
    """Steps above ``divergence_nis`` that trigger a reset."""
    reset_inflation: float
    """Covariance after a reset, as a multiple of ``P0``."""
    min_radius: float
    """Smallest radius a reset or a ramp keeps (m)."""

    @classmethod
    def from_sections(cls, est: EstimatorSettings, sen: SensorSettings, *, wheel_radius: float,
                      half_track: float, initial_pose: Sequence[float]) -> FilterSetup:
        """The filter of the validated ``[estimator]`` and ``[sensors]`` sections, a model of nominal
        wheel radius ``R0`` and half track ``b`` (m), starting at ``initial_pose`` (m, m, rad)."""
        dt = 1.0 / est.rate
        R0 = float(wheel_radius)
        radii = est.initial_radii if est.initial_radii is not None else (R0, R0)
        x0 = np.array([*initial_pose, radii[0], radii[1]], dtype=float)
        return cls(
            model=KinematicModel(b=float(half_track), dt=dt),
            dt=dt,
            x0=x0,
            P0=np.diag(np.square(np.asarray(est.p0_sigma, float))),
            Q=process_noise(est.q_diffusion, dt),
            nominal_radius=R0,
            divergence_steps=max(1, int(round(est.divergence_dwell * est.rate))),
            **{name: getattr(sen, name) for name in _SENSOR_FIELDS},
            **{name: getattr(est, name) for name in _ESTIMATOR_FIELDS},
        )


def process_noise(diffusion: Sequence[float], dt: float) -> np.ndarray:
    """Per-step process-noise covariance ``diag(diffusion · dt)`` of a diffusion per second (units²/s)
    over a step ``dt`` (s). Computed as ``(√(diffusion/dt) · dt)²`` — the same number — so that the
    default diffusion at 100 Hz reproduces the former ``diag((q · dt)²)`` bit for bit."""
    return np.diag(np.square(np.sqrt(np.asarray(diffusion, float) / dt) * dt))


_SENSOR_FIELDS = ("speed_sigma", "yaw_rate_sigma", "position_sigma")
"""Fields of :class:`FilterSetup` taken as they are from the sensors' settings."""
_ESTIMATOR_FIELDS = ("kappa", "nis_gate", "divergence_nis", "reset_inflation", "min_radius")
"""Fields of :class:`FilterSetup` taken as they are from the ``[estimator]`` settings."""
