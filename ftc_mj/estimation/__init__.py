"""FDI filters (paper §3): EKF, UKF and IMM over [x, y, psi, R_R, R_L], plus the fault-decision layer.

Entry points: :func:`build_estimator` and :func:`build_fault_decision` (from a
:class:`~ftc_mj.config.RunConfig`: the factories, the only modules here that read the application
config), the filters' ``from_settings`` (from their own settings, without a run config) and the
components' own constructors (``UKF(setup)``, ``FaultDecision(settings, R0, rule)``). The filters step
through the compiled kernels of :mod:`.kernels`.
Every estimator's ``step(u, z)`` returns a :class:`FilterOutput`.
"""

from .base import Estimator, FilterOutput, Hypothesis, Measurement
from .decision import DecisionRule, DecisionState, DecisionStep, FaultDecision
from .decision_factory import build_fault_decision
from .ekf import EKF
from .factory import build_estimator
from .imm import IMM
from .setup import FilterSetup
from .ukf import UKF

__all__ = [
    "EKF",
    "IMM",
    "UKF",
    "DecisionRule",
    "DecisionState",
    "DecisionStep",
    "Estimator",
    "FaultDecision",
    "FilterOutput",
    "FilterSetup",
    "Hypothesis",
    "Measurement",
    "build_estimator",
    "build_fault_decision",
]
