"""The built-in estimators, registered by name (:data:`ftc_mj.registry.estimators`).

Every factory takes the run config and returns an :class:`~ftc_mj.estimation.base.Estimator`
(``None`` for ``none``: the run has no filter). :func:`build_estimator` builds the configured one.
"""

from __future__ import annotations

from ..config import RunConfig, run_context
from ..registry import BUILTIN, estimators
from .base import Estimator
from .ekf import EKF
from .imm import IMM
from .ukf import UKF

estimators.register("ekf", EKF, origin=BUILTIN)
estimators.register("ukf", UKF, origin=BUILTIN)
estimators.register("imm-ekf", lambda cfg: IMM(cfg, member="ekf"), origin=BUILTIN)
estimators.register("imm-ukf", lambda cfg: IMM(cfg, member="ukf"), origin=BUILTIN)
estimators.register("none", lambda cfg: None, origin=BUILTIN)


def build_estimator(cfg: RunConfig) -> Estimator | None:
    """The estimator ``cfg.estimator.kind`` names: ``ekf`` → :class:`EKF`, ``ukf`` → :class:`UKF`,
    ``imm-ekf``/``imm-ukf`` → :class:`IMM` with EKF/UKF members (the bank ``estimator.imm_bank``, else
    the paper's of ``estimator.imm_models`` members; variant ``estimator.imm_variant``), ``none`` →
    ``None`` (the loop runs without a filter), or a registered plug-in's."""
    return estimators.create(cfg.estimator.kind, cfg.estimator, run_context(cfg), run_config=cfg)
