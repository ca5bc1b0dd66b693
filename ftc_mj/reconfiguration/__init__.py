"""How the estimated radii reach the controller: the reconfiguration policies (which radii the
controller's model uses at each solve) and the robust NMPC's scenario weights from the filter.

Each component takes its own settings model, declared beside it (:class:`ReconfigurationSettings`,
:class:`DegradedSettings`); the package reads no application config::

    policy = SafePolicy(ReconfigurationSettings(max_rate=1.0), context)   # from its settings and a RunContext

A run's policy, degraded mode and scenario weighting are built from its config by
:mod:`ftc_mj.wiring.reconfiguration` (``build_policy``, ``build_degraded_mode``, ``build_scenario_weighting``).
"""

from __future__ import annotations

from .degraded import DegradedMode, DegradedSettings, NoSlipCheck
from .policies import (
    DirectPolicy,
    NominalPolicy,
    ReconfigState,
    ReconfigurationPolicy,
    ReconfigurationSettings,
    SafePolicy,
    TruthPolicy,
)
from .scenario_weights import ScenarioWeighting, posterior_weights

__all__ = [
    "DegradedMode",
    "DegradedSettings",
    "DirectPolicy",
    "NoSlipCheck",
    "NominalPolicy",
    "ReconfigState",
    "ReconfigurationPolicy",
    "ReconfigurationSettings",
    "SafePolicy",
    "ScenarioWeighting",
    "TruthPolicy",
    "posterior_weights",
]
