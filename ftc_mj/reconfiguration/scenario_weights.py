"""Scenario weights of the robust NMPC from the filter: the bridge between passive and active FTC.

The robust multi-stage NMPC (:mod:`~ftc_mj.control.robust`) hedges over a fixed set of radius
scenarios ``r_i`` (S, 2). With ``controller.robust.weighting = "posterior"`` the loop re-weights them
before every solve with what the filter knows. Its radius estimate is Gaussian, ``N(r̂, P_r)``
(``P_r`` the 2×2 radius block of the filter's covariance); with a uniform prior over the scenarios
the posterior probability of scenario ``i`` is

    p_i ∝ N(r_i; r̂, P_r + σ_t² I),

where the tolerance ``σ_t`` (``posterior_tolerance``, m) widens each scenario to a neighbourhood
(the true radii need not sit on a scenario, e.g. during a slow deflation) and keeps one sharp filter
from switching the weights at every sample. The weights handed over are ``(1 − ε) p + ε / S``
(``ε = posterior_floor``): no scenario is dismissed outright.

What this does: before a fault the nominal scenario takes the weight and the controller tracks like
the nominal NMPC (no price of robustness). With speed only, ``P_r`` is wide along the radius split
the speed cannot see, so a left and a right puncture keep comparable weights and the controller
stays robust to both; with a yaw-rate gyro the posterior isolates the wheel and the robust NMPC
behaves as the reconfigured one, without a hand-over rule. The controller never sees the filter:
it receives the weights through :meth:`~ftc_mj.control.robust.RobustNMPC.set_scenario_weights`.
"""

from __future__ import annotations

import numpy as np

from ..control.robust import RobustSettings, scenario_radii
from ..estimation.base import FilterOutput


def posterior_weights(mean: np.ndarray, cov: np.ndarray, radii_s: np.ndarray, tolerance: float,
                      floor: float = 0.0) -> np.ndarray:
    """Posterior scenario probabilities (module docstring).

    Parameters
    ----------
    mean : (2,)
        Estimated radii [R_R, R_L] (m).
    cov : (2, 2)
        Their covariance (m²).
    radii_s : (S, 2)
        Scenario radii (m).
    tolerance : float
        σ_t (m) added in every direction.
    floor : float
        Share ε in [0, 1) spread uniformly.

    Returns
    -------
    (S,) weights summing to 1.
    """
    C = np.asarray(cov, dtype=float) + tolerance**2 * np.eye(2)
    d = np.asarray(radii_s, dtype=float) - np.asarray(mean, dtype=float)[None, :]
    log_p = -0.5 * np.einsum("si,ij,sj->s", d, np.linalg.inv(C), d)
    p = np.exp(log_p - log_p.max())
    p /= p.sum()
    return (1.0 - floor) * p + floor / len(p)


class ScenarioWeighting:
    """Weights for the robust NMPC at each controller sample (``weighting = "posterior"``), from the robust
    NMPC's settings (its scenarios, ``posterior_tolerance`` and ``posterior_floor``)."""

    def __init__(self, settings: RobustSettings) -> None:
        self.fractions = np.asarray(settings.scenarios, dtype=float)
        self.tolerance = settings.posterior_tolerance
        self.floor = settings.posterior_floor

    def weights(self, out: FilterOutput | None, model_radii: np.ndarray) -> np.ndarray | None:
        """Posterior weights (S,) of the scenarios around ``model_radii`` (m) given the filter output;
        ``None`` (the configured weights) before the first filter step or for a non-finite estimate."""
        if out is None:
            return None
        mean, cov = np.asarray(out.x[3:5], dtype=float), np.asarray(out.P[3:5, 3:5], dtype=float)
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            return None
        return posterior_weights(mean, cov, scenario_radii(self.fractions, model_radii), self.tolerance,
                                 self.floor)
