"""Which wheel radii the controller's model uses at each solve (feedback on/off, DESIGN §3, §9).

The paper closes the loop directly: the latest filter estimate goes to the NMPC at every solve.
On a physical plant that can run away (DESIGN §9), so a ``safe`` policy is offered beside it.
"""

from __future__ import annotations

import numpy as np

from ..config import RunConfig
from ..estimation.base import FilterOutput


class RadiusFeedback:
    """Turns filter outputs into the radii [R_R, R_L] (m) handed to the controller."""

    def __init__(self, cfg: RunConfig) -> None:
        self.enabled = cfg.feedback and cfg.estimator.kind != "none"
        self.policy = cfg.reconfig.policy
        self.nominal = np.full(2, cfg.model_wheel_radius)
        self.min_radius = cfg.reconfig.min_radius if self.policy == "safe" else cfg.estimator.min_radius
        self.max_sigma = cfg.reconfig.max_sigma
        self.max_step = cfg.reconfig.max_rate / cfg.controller.rate
        self._current = self.nominal.copy()

    def radii(self, out: FilterOutput | None, fault_isolated: bool, filter_healthy: bool) -> np.ndarray:
        """Radii for the next solve. ``fault_isolated``: the decision layer has isolated a fault;
        ``filter_healthy``: no divergence reset since the last solve."""
        if not self.enabled or out is None:
            return self.nominal.copy()
        est = np.asarray(out.x[3:5], dtype=float)
        if self.policy == "direct":
            # The paper's policy; only a physical floor (a radius must stay positive) is imposed.
            if not np.all(np.isfinite(est)):
                return self._current.copy()
            self._current = np.maximum(est, self.min_radius)
            return self._current.copy()
        # safe policy
        sig = np.sqrt(np.clip(np.diag(out.P)[3:5], 0.0, None))
        if not filter_healthy or not np.all(np.isfinite(est)):
            target = self.nominal
        elif fault_isolated and float(np.max(sig)) < self.max_sigma:
            target = np.clip(est, self.min_radius, self.nominal)
        else:
            target = self._current if fault_isolated else self.nominal
        step = np.clip(target - self._current, -self.max_step, self.max_step)
        self._current = self._current + step
        return self._current.copy()

