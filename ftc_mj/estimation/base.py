"""What every estimator returns at each step, and the interface the simulation loop relies on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass
class Measurement:
    """One estimator step's sensor data (SI units). ``None`` = not available this step."""

    speed: float
    """Measured forward speed of the axle midpoint (m/s)."""
    yaw_rate: float | None = None
    """Measured yaw rate (rad/s)."""
    position: np.ndarray | None = None
    """Measured (x, y) position fix (m)."""


@dataclass
class FilterOutput:
    """The estimator's state after one predict + update step.

    ``innovation``/``S`` are over the measurements used this step, in the order speed, yaw rate,
    x, y (those present). ``speed_innovation``/``speed_innovation_std`` are the speed channel's
    innovation and sqrt of its innovation variance (the paper's plotted quantity).
    """

    x: np.ndarray
    """State estimate [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    P: np.ndarray
    """5x5 covariance."""
    innovation: np.ndarray
    S: np.ndarray
    nis: float
    """Normalised innovation squared yᵀ S⁻¹ y of this step."""
    speed_innovation: float
    speed_innovation_std: float
    mode_probs: np.ndarray | None = None
    """IMM mode probabilities (M,), else None."""
    model_x: np.ndarray | None = None
    """IMM per-model estimates (M, 5), else None."""
    rejected: bool = False
    """The measurement was rejected (non-finite or gated) and only the prediction was kept."""
    reset: bool = False
    """The filter detected divergence this step and reset itself."""


class Estimator(Protocol):
    """A recursive estimator stepped at the filter rate."""

    resets: int
    rejections: int

    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """Predict with wheel rates ``u`` = [omega_R, omega_L] (rad/s) and update with ``z``."""
        ...
