"""The built-in estimators, registered by name (:data:`ftc_mj.registry.estimators`), and the filter of a run
from the application config.

Every registered factory takes the filter's own settings (the ``[estimator]`` section: the model of its
``kind``, :data:`ftc_mj.config.sections.ESTIMATOR_KINDS`, or a plug-in's
:class:`~ftc_mj.estimation.settings.PluginEstimatorSettings`) and the :class:`~ftc_mj.context.RunContext`
(sensors' noise, nominal wheel radius, half track, initial pose) and returns an
:class:`~ftc_mj.estimation.base.Estimator` (``None`` for ``none``: the run has no filter). A built-in
registers its class's ``from_context`` with its settings model as ``section`` (listed by ``ftc-mj
components``): a new built-in estimator is its module under :mod:`ftc_mj.estimation` (the class, its
``Settings`` with its ``kind``) plus one ``estimators.register`` line here and its model's line in
:data:`~ftc_mj.config.sections.ESTIMATOR_KINDS` (without that line its table validates as a plug-in's: the
filter model's settings, the decision, ``options``).
"""

from __future__ import annotations

import functools

from ..config import RunConfig, run_context
from ..context import RunContext
from ..estimation.base import Estimator
from ..estimation.ekf import EKF
from ..estimation.imm import IMM
from ..estimation.settings import NoFilterSettings
from ..estimation.setup import FilterSetup
from ..estimation.ukf import UKF
from ..registry import BUILTIN, estimators


def _none(settings: NoFilterSettings, context: RunContext) -> None:
    """No filter: the run has no estimator (nor a decision, nor a policy that needs one)."""
    return None


estimators.register("ekf", EKF.from_context, origin=BUILTIN, section=EKF.Settings)
estimators.register("ukf", UKF.from_context, origin=BUILTIN, section=UKF.Settings)
estimators.register("imm-ekf", functools.partial(IMM.from_context, member="ekf"), origin=BUILTIN,
                    section=IMM.MEMBER_SETTINGS["ekf"])
estimators.register("imm-ukf", functools.partial(IMM.from_context, member="ukf"), origin=BUILTIN,
                    section=IMM.MEMBER_SETTINGS["ukf"])
estimators.register("none", _none, origin=BUILTIN, section=NoFilterSettings)


def setup_from_config(cfg: RunConfig) -> FilterSetup:
    """The resolved parameters of the filter of the run ``cfg``."""
    return FilterSetup.from_context(cfg.estimator, run_context(cfg))


def build_estimator(cfg: RunConfig) -> Estimator | None:
    """The estimator ``cfg.estimator.kind`` names: ``ekf`` → :class:`EKF`, ``ukf`` → :class:`UKF`,
    ``imm-ekf``/``imm-ukf`` → :class:`IMM` with EKF/UKF members (the bank ``estimator.imm_bank``, else
    the paper's of ``estimator.imm_models`` members; variant ``estimator.imm_variant``), ``none`` →
    ``None`` (the loop runs without a filter), or a registered plug-in's."""
    return estimators.create(cfg.estimator.kind, cfg.estimator, run_context(cfg), run_config=cfg)
