"""The built-in estimator kinds, in one table: :data:`BUILTIN_ESTIMATORS`.

Each entry names a kind's factory (its class's ``from_context``: settings model and
:class:`~ftc_mj.context.RunContext` in, an :class:`~ftc_mj.estimation.base.Estimator` out) and its settings
model. The wiring registers every entry (:mod:`ftc_mj.wiring.estimation`) and the application config's
``[estimator]`` union has one member per entry (:data:`ftc_mj.config.sections.ESTIMATOR_KINDS`), so a new
built-in estimator is its module (the class and its ``Settings``) plus its line here.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, NamedTuple

from .ekf import EKF
from .imm import IMM
from .settings import EstimatorSettings, NoFilterSettings
from .ukf import UKF


class Kind(NamedTuple):
    """A built-in estimator kind."""

    factory: Callable[..., Any]
    """``factory(settings, context)``: the filter (``None`` for ``none``: the run has no filter)."""
    settings: type[EstimatorSettings]
    """Its settings model: its member of the ``[estimator]`` section."""


def no_filter(settings: NoFilterSettings, context: object) -> None:
    """No filter: the run has no estimator (nor a decision, nor a policy that needs one)."""
    return None


BUILTIN_ESTIMATORS: dict[str, Kind] = {
    "ekf": Kind(EKF.from_context, EKF.Settings),
    "ukf": Kind(UKF.from_context, UKF.Settings),
    "imm-ekf": Kind(functools.partial(IMM.from_context, member="ekf"), IMM.MEMBER_SETTINGS["ekf"]),
    "imm-ukf": Kind(functools.partial(IMM.from_context, member="ukf"), IMM.MEMBER_SETTINGS["ukf"]),
    "none": Kind(no_filter, NoFilterSettings),
}
"""Name → (factory, settings model) of every built-in estimator kind."""
