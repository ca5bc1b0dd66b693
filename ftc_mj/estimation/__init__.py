"""FDI filters (paper §3): EKF, UKF and IMM over [x, y, psi, R_R, R_L], plus the fault-decision layer.

Each component declares its settings model beside it (each estimator kind's: ``EKFSettings``,
``UKFSettings``, ``IMMEKFSettings``, ``IMMUKFSettings``, ``NoFilterSettings``, ``PluginEstimatorSettings``;
their parts :class:`FilterSettings`, :class:`IMMSettings`; :class:`DecisionSettings`); the package reads no
application config. Entry points: the filters'
``from_settings`` (from their own settings, without a run config), ``from_context`` (in a run: the
registered factories) and the components' own constructors (``UKF(setup)``,
``FaultDecision(settings, R0, rule)``); a run's components are built from its config by
:mod:`ftc_mj.wiring.estimation` and :mod:`ftc_mj.wiring.decision`. The filters step through the compiled
kernels of :mod:`.kernels`.
Every estimator's ``step(u, z)`` returns a :class:`FilterOutput`.
"""

from .base import Estimator, FilterOutput, Hypothesis, Measurement
from .decision import DecisionRule, DecisionState, DecisionStep, FaultDecision
from .decision_settings import DecisionSettings
from .ekf import EKF
from .imm import IMM, HypothesisSettings, IMMSettings
from .setup import FilterSettings, FilterSetup
from .ukf import UKF

__all__ = [
    "EKF",
    "IMM",
    "UKF",
    "DecisionRule",
    "DecisionSettings",
    "DecisionState",
    "DecisionStep",
    "Estimator",
    "FaultDecision",
    "FilterOutput",
    "FilterSettings",
    "FilterSetup",
    "Hypothesis",
    "HypothesisSettings",
    "IMMSettings",
    "Measurement",
]
