"""The built-in estimators, registered by name (:data:`ftc_mj.registry.estimators`), and the one place
the estimation package reads the application config.

Every registered factory takes the filter's own settings (the ``[estimator]`` section) and the
:class:`~ftc_mj.context.RunContext` (sensors' noise, nominal wheel radius, half track, initial pose)
and returns an :class:`~ftc_mj.estimation.base.Estimator` (``None`` for ``none``: the run has no
filter). :func:`build_estimator` builds the configured one for the loop. ``EKF.from_settings``,
``UKF.from_settings`` and ``IMM.from_settings`` (attached here, since validating plain tables needs the
config schema) build a filter from plain tables without a run config.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..config import EstimatorConfig, RunConfig, SensorSettings, run_context, section
from ..context import RunContext
from ..registry import BUILTIN, estimators
from .base import Estimator
from .ekf import EKF
from .imm import IMM
from .setup import FilterSetup
from .single import SingleFilter
from .ukf import UKF

Table = EstimatorConfig | Mapping[str, Any] | None


def filter_setup(settings: EstimatorConfig, context: RunContext) -> FilterSetup:
    """A filter's resolved parameters from its ``[estimator]`` settings and the run context (the
    sensors' noise, the model's nominal wheel radius and half track (m), the initial pose)."""
    return FilterSetup.from_sections(settings, context.sensors, wheel_radius=context.nominal_radii[0],
                                     half_track=context.half_track, initial_pose=context.initial_pose)


def setup_from_config(cfg: RunConfig) -> FilterSetup:
    """The resolved parameters of the filter of the run ``cfg``."""
    return filter_setup(cfg.estimator, run_context(cfg))


def _ekf(settings: EstimatorConfig, context: RunContext) -> EKF:
    return EKF(filter_setup(settings, context))


def _ukf(settings: EstimatorConfig, context: RunContext) -> UKF:
    return UKF(filter_setup(settings, context))


def _imm_ekf(settings: EstimatorConfig, context: RunContext) -> IMM:
    return IMM(filter_setup(settings, context), settings, "ekf")


def _imm_ukf(settings: EstimatorConfig, context: RunContext) -> IMM:
    return IMM(filter_setup(settings, context), settings, "ukf")


def _none(settings: EstimatorConfig, context: RunContext) -> None:
    return None


estimators.register("ekf", _ekf, origin=BUILTIN)
estimators.register("ukf", _ukf, origin=BUILTIN)
estimators.register("imm-ekf", _imm_ekf, origin=BUILTIN)
estimators.register("imm-ukf", _imm_ukf, origin=BUILTIN)
estimators.register("none", _none, origin=BUILTIN)


def build_estimator(cfg: RunConfig) -> Estimator | None:
    """The estimator ``cfg.estimator.kind`` names: ``ekf`` → :class:`EKF`, ``ukf`` → :class:`UKF`,
    ``imm-ekf``/``imm-ukf`` → :class:`IMM` with EKF/UKF members (the bank ``estimator.imm_bank``, else
    the paper's of ``estimator.imm_models`` members; variant ``estimator.imm_variant``), ``none`` →
    ``None`` (the loop runs without a filter), or a registered plug-in's."""
    return estimators.create(cfg.estimator.kind, cfg.estimator, run_context(cfg), run_config=cfg)


def setup_from_settings(estimator: Table = None, sensors: SensorSettings | Mapping[str, Any] | None = None, *,
                        wheel_radius: float = 2.0, half_track: float = 1.0,
                        initial_pose: Sequence[float] = (0.0, 0.0, 0.0)) -> tuple[EstimatorConfig, FilterSetup]:
    """The validated ``[estimator]`` section and the filter's resolved parameters, from the sections
    (objects or plain tables, one-line errors; ``None`` = the paper's values: its ``Q`` and ``P0``,
    speed σ 0.5 m/s, no gyro, no position fix), the model's nominal wheel radius and half track (m)
    and the initial pose (m, m, rad)."""
    est = section(EstimatorConfig, estimator, "estimator")
    sen = section(SensorSettings, sensors, "sensors")
    return est, FilterSetup.from_sections(est, sen, wheel_radius=wheel_radius, half_track=half_track,
                                          initial_pose=initial_pose)


def _single_from_settings(cls: type[SingleFilter], estimator: Table = None,
                          sensors: SensorSettings | Mapping[str, Any] | None = None, **geometry: Any) -> SingleFilter:
    """The filter built from its own settings, without a run config (see :func:`setup_from_settings`
    for the arguments); it gives the same estimates as the filter of a run with those settings."""
    return cls(setup_from_settings(estimator, sensors, **geometry)[1])


def _imm_from_settings(cls: type[IMM], member: str = "ukf", estimator: Table = None,
                       sensors: SensorSettings | Mapping[str, Any] | None = None, **geometry: Any) -> IMM:
    """The IMM built from its own settings, without a run config (the bank, transition matrix and
    variant from ``estimator``; the rest as :func:`setup_from_settings`)."""
    est, setup = setup_from_settings(estimator, sensors, **geometry)
    return cls(setup, est, member)


SingleFilter.from_settings = classmethod(_single_from_settings)  # type: ignore[attr-defined]
IMM.from_settings = classmethod(_imm_from_settings)  # type: ignore[attr-defined]
