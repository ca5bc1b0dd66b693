"""FDI filters (paper §3): EKF, UKF and IMM over [x, y, psi, R_R, R_L], plus the fault-decision layer.

Entry points: :func:`build_estimator` (from a :class:`~ftc_mj.config.RunConfig`) and
:class:`FaultDecision`. Every estimator's ``step(u, z)`` returns a :class:`FilterOutput`.
"""

from .base import Estimator, FilterOutput, Measurement
from .decision import DecisionState, FaultDecision
from .ekf import EKF
from .factory import build_estimator
from .imm import IMM, Hypothesis
from .ukf import UKF

__all__ = [
    "EKF",
    "IMM",
    "UKF",
    "DecisionState",
    "Estimator",
    "FaultDecision",
    "FilterOutput",
    "Hypothesis",
    "Measurement",
    "build_estimator",
]
