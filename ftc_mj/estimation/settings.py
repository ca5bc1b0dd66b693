"""The settings every estimator kind shares (:class:`EstimatorSettings`: the filter model's and the fault
decision's), and the two kinds without a filter class of their own: ``none`` (:class:`NoFilterSettings`) and a
plug-in (:class:`PluginEstimatorSettings`). The filters' kinds declare theirs beside them
(:class:`~.ekf.EKFSettings`, :class:`~.ukf.UKFSettings`, :class:`~.imm.IMMEKFSettings`,
:class:`~.imm.IMMUKFSettings`); the ``[estimator]`` section is their union, discriminated by ``kind``.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from ..fields import Options, component, drop_empty_options, options_of
from .decision_settings import DecisionSettings
from .setup import FilterSettings


class EstimatorSettings(FilterSettings):
    """The ``[estimator]`` section's common part: the filter model's settings and the fault decision's. Each
    kind's model adds its own and fixes ``kind``."""

    decision: DecisionSettings = Field(default_factory=DecisionSettings)
    """The fault decision on the filter's outputs (``[estimator.decision]``)."""

    @model_validator(mode="before")
    @classmethod
    def _no_options(cls, data: Any) -> Any:
        """A built-in kind takes no plug-in ``options`` (an empty table, as older resolved configs hold, is
        dropped)."""
        return drop_empty_options(cls, data, "estimator")


class NoFilterSettings(EstimatorSettings):
    """No filter (``estimator.kind = "none"``): the loop still steps at ``rate`` (the trace's rows) and the
    run record still resolves the filter model of these settings for its bounds (paper §3's PCRB inputs)."""

    kind: Literal["none"] = "none"
    """No estimator: the run has no filter (nor a decision, nor a policy that needs one)."""


class PluginEstimatorSettings(EstimatorSettings):
    """Settings of a plug-in estimator (a kind a plug-in module registered): the filter model's settings the
    loop and the run record read, the decision's, and the plug-in's own ``options``, checked against the
    settings model it was registered with."""

    kind: component("estimators")
    """A registered estimator (:data:`ftc_mj.registry.estimators`)."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of the plug-in estimator (its registered settings model)."""

    _options = options_of("estimators", "kind")
