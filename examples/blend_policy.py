"""A plug-in reconfiguration policy to score on the benchmark (docs/tutorial-benchmark.md).

``blend``: the nominal radii until a wheel is declared faulty and isolated, then, on the isolated wheels,
the nominal radius moved a fraction ``weight`` of the way to the filter's estimate (clamped to
[``estimator.min_radius``, nominal], m). ``weight = 1`` hands the estimate over whole, as ``direct`` does.
``blend_policy.toml`` beside this file names it as a benchmark method.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

import ftc_mj
from ftc_mj.reconfiguration import ReconfigurationSettings


class BlendSettings(BaseModel):
    """``reconfiguration.options`` of the ``blend`` policy."""

    model_config = ConfigDict(extra="forbid")
    weight: float = Field(0.5, ge=0, le=1)
    """Fraction of the way from the nominal radius to the estimate handed to the controller."""


class Blend(ftc_mj.ReconfigurationPolicy):
    """Nominal radii until a declared, isolated fault; then nominal + ``weight`` (estimate − nominal) on the
    isolated wheels (m)."""

    def __init__(self, settings: ReconfigurationSettings, context: ftc_mj.RunContext) -> None:
        super().__init__(settings, context)
        self.weight = BlendSettings.model_validate(settings.options).weight

    def radii(self, t: float, out: ftc_mj.FilterOutput | None, decision: ftc_mj.DecisionState | None,
              filter_reset: bool, omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        wheels = {"right": (True, False), "left": (False, True), "both": (True, True)}
        if out is None or decision is None or decision.wheel not in wheels:
            self.state = 0  # nominal radii
            return self.nominal.copy()
        self.state = 2  # handed over
        est = np.clip(out.x[3:5], self.floor, self.nominal)
        return np.where(wheels[decision.wheel], self.nominal + self.weight * (est - self.nominal), self.nominal)


ftc_mj.register_policy("blend", Blend, settings=BlendSettings)
