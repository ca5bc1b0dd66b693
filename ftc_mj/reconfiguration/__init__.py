"""How the estimated radii reach the controller: the reconfiguration policies (which radii the
controller's model uses at each solve) and the robust NMPC's scenario weights from the filter.

Public API::

    policy = build_policy(cfg, with_estimator=True)     # the registered policy cfg.reconfiguration.policy names
    policy = SafePolicy(resolved_reconfiguration(cfg), run_context(cfg))  # from its settings ("auto" resolved)
    weighting = build_scenario_weighting(cfg)           # None unless a robust NMPC is re-weighted by the filter
    degraded = build_degraded_mode(cfg)                 # None unless pf-nmpc with the safe policy (the default)
"""

from __future__ import annotations

from .degraded import DegradedMode, NoSlipCheck
from .factory import build_degraded_mode, build_policy, build_scenario_weighting, resolved_reconfiguration
from .policies import (
    DirectPolicy,
    NominalPolicy,
    ReconfigState,
    ReconfigurationPolicy,
    SafePolicy,
    TruthPolicy,
)
from .scenario_weights import ScenarioWeighting, posterior_weights

__all__ = [
    "DegradedMode",
    "DirectPolicy",
    "NoSlipCheck",
    "NominalPolicy",
    "ReconfigState",
    "ReconfigurationPolicy",
    "SafePolicy",
    "ScenarioWeighting",
    "TruthPolicy",
    "build_degraded_mode",
    "build_policy",
    "build_scenario_weighting",
    "posterior_weights",
    "resolved_reconfiguration",
]
