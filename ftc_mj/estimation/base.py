"""What every estimator returns at each step, and the interface the simulation loop relies on.

The protocol (the loop calls ``step`` once per estimator period, after reading the sensors):

- ``step(u, z) -> FilterOutput``: predict over one period ``dt = 1 / estimator.rate`` with the
  wheel rates ``u = [omega_R, omega_L]`` (rad/s) measured at the previous step, then update with
  the measurement ``z`` (:class:`Measurement`, SI units) of this step;
- optional counters ``resets`` and ``rejections`` (ints; 0 if absent) end up in ``metrics.json``, and with a
  pose sensor ``pose_rejections`` (fixes the χ² gate rejected);
- a multiple-model estimator declares its ``hypotheses`` (:class:`Hypothesis`, one per mode, in the
  order of ``FilterOutput.mode_probs``) and puts them on every output, so that a decision rule reads
  what its modes mean instead of guessing from their number.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass
class Measurement:
    """One estimator step's sensor data (SI units). ``None`` = not available this step."""

    speed: float | None
    """Measured forward speed of the axle midpoint (m/s); ``None`` while the speed sensor drops out."""
    yaw_rate: float | None = None
    """Measured yaw rate (rad/s); ``None`` without a gyro or while it drops out."""
    position: np.ndarray | None = None
    """Measured (x, y) position fix (m)."""
    heading: float | None = None
    """Measured heading of the pose fix (rad, any turn: the filter wraps the innovation); ``None`` without."""


@dataclass(frozen=True)
class Hypothesis:
    """What one member of a multiple-model bank assumes about the wheel radii.

    ``frac_R``/``frac_L``: radius as a fraction of nominal (a step to that radius; 1 = healthy);
    ``ramp``: instead, the left radius deflates linearly (at ``estimator.ramp_rate``). Built from a
    configured bank's :class:`~ftc_mj.estimation.imm.HypothesisSettings` (whose defaults are the only ones).
    """

    name: str
    frac_R: float
    frac_L: float
    ramp: bool

    @property
    def wheel(self) -> str | None:
        """Faulty wheel(s) under this hypothesis: ``None``, ``'right'``, ``'left'`` or ``'both'``."""
        r = self.frac_R < 1.0
        left = self.frac_L < 1.0 or self.ramp
        if r and left:
            return "both"
        if r:
            return "right"
        if left:
            return "left"
        return None


@dataclass
class FilterOutput:
    """The estimator's state after one predict + update step.

    ``innovation``/``S`` are over the measurements used this step, in the order speed, yaw rate,
    x, y, heading (those present and not gated). ``speed_innovation``/``speed_innovation_std`` are the speed channel's
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
    hypotheses: tuple[Hypothesis, ...] | None = None
    """What each mode of ``mode_probs`` assumes (same order), else None."""
    model_x: np.ndarray | None = None
    """IMM per-model estimates (M, 5), else None."""
    rejected: bool = False
    """The measurement was rejected (non-finite or gated) and only the prediction was kept."""
    reset: bool = False
    """The filter detected divergence this step and reset itself."""
    pose_rejected: bool = False
    """This step's pose fix's position failed the filter's χ² gate and was not used (the other channels were)."""


class Estimator(Protocol):
    """A recursive estimator stepped at the filter rate (see the module docstring)."""

    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """Predict with wheel rates ``u`` = [omega_R, omega_L] (rad/s) and update with ``z``."""
        ...
