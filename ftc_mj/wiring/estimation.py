"""The built-in estimators, registered by name (:data:`ftc_mj.registry.estimators`), and the filter of a run
from the application config.

Every registered factory takes the filter's own settings (the ``[estimator]`` section: the model of its
``kind``, :data:`ftc_mj.config.sections.ESTIMATOR_KINDS`, or a plug-in's
:class:`~ftc_mj.estimation.settings.PluginEstimatorSettings`) and the :class:`~ftc_mj.context.RunContext`
(sensors' noise, nominal wheel radius, half track, initial pose) and returns an
:class:`~ftc_mj.estimation.base.Estimator` (``None`` for ``none``: the run has no filter). A built-in
is registered here, from its line of :data:`~ftc_mj.estimation.kinds.BUILTIN_ESTIMATORS`, with its class's
``from_context`` and its settings model as ``section`` (listed by ``ftc-mj components``): a new built-in
estimator is its module under :mod:`ftc_mj.estimation` (the class and its ``Settings``) plus its line in
that table, which also makes its model a member of the ``[estimator]`` section.
"""

from __future__ import annotations

from ..config import RunConfig, run_context
from ..estimation.base import Estimator
from ..estimation.kinds import BUILTIN_ESTIMATORS
from ..estimation.setup import FilterSetup
from ..registry import BUILTIN, estimators

for _name, _kind in BUILTIN_ESTIMATORS.items():
    estimators.register(_name, _kind.factory, origin=BUILTIN, section=_kind.settings)


def setup_from_config(cfg: RunConfig) -> FilterSetup:
    """The resolved parameters of the filter of the run ``cfg``."""
    return FilterSetup.from_context(cfg.estimator, run_context(cfg))


def build_estimator(cfg: RunConfig) -> Estimator | None:
    """The estimator ``cfg.estimator.kind`` names: ``ekf`` → :class:`EKF`, ``ukf`` → :class:`UKF`,
    ``imm-ekf``/``imm-ukf`` → :class:`IMM` with EKF/UKF members (the bank ``estimator.imm_bank``, else
    the paper's of ``estimator.imm_models`` members; variant ``estimator.imm_variant``), ``none`` →
    ``None`` (the loop runs without a filter), or a registered plug-in's."""
    return estimators.create(cfg.estimator.kind, cfg.estimator, run_context(cfg), run_config=cfg)
