"""The built-in decision rules, registered by name (:data:`ftc_mj.registry.decision_rules`) with their
settings model (:class:`~ftc_mj.estimation.decision_settings.DecisionSettings`), and the fault-decision layer
of a run from the application config.

A registered factory takes the rule's own settings (the ``[estimator.decision]`` section) and the
:class:`~ftc_mj.context.RunContext`; a rule registered with the meta ``calibrate="cusum"`` or ``"glr"``
also gets the threshold of that change detector, calibrated here for ``decision.arl0`` at the nominal
operating points of the run's residual generator (:mod:`~ftc_mj.estimation.residual`) on its reference
path (:func:`calibrated_threshold`) — a rule does not read the path itself — and one registered with
``detectors=True`` (the built-in ``cusum`` and ``glr``) also the run's
:class:`~ftc_mj.estimation.residual.ChangeDetectors`.
"""

from __future__ import annotations

from ..config import RunConfig, run_context
from ..context import RunContext
from ..estimation.calibration import NominalPoint, arl0_threshold, nominal_point, physical_offset
from ..estimation.change import glr_window_steps
from ..estimation.decision import AutoRule, ChangeRule, DecisionRule, FaultDecision, ModeRule, SigmaRule
from ..estimation.residual import ChangeDetectors, residual_setup
from ..estimation.rule_statistics import DecisionSettings, RuleStatistics
from ..estimation.setup import FilterSetup
from ..registry import BUILTIN, decision_rules
from .estimation import setup_from_config


def _sigma(settings: DecisionSettings, context: RunContext) -> SigmaRule:
    return SigmaRule(settings, context.nominal_radii[0])


def _mode(settings: DecisionSettings, context: RunContext) -> ModeRule:
    return ModeRule(settings, context.nominal_radii[0])


def _auto(settings: DecisionSettings, context: RunContext) -> AutoRule:
    return AutoRule(settings, context.nominal_radii[0])


def _change(name: str):  # noqa: ANN202 - a factory of the registry contract
    def factory(settings: DecisionSettings, context: RunContext, threshold: float,
                detectors: ChangeDetectors) -> ChangeRule:
        return ChangeRule(name, settings, threshold, detectors)
    factory.__name__ = f"_{name}"
    return factory


decision_rules.register("sigma", _sigma, origin=BUILTIN, section=DecisionSettings)
decision_rules.register("mode", _mode, origin=BUILTIN, section=DecisionSettings)
decision_rules.register("auto", _auto, origin=BUILTIN, section=DecisionSettings)
decision_rules.register("cusum", _change("cusum"), origin=BUILTIN, section=DecisionSettings, calibrate="cusum",
                        detectors=True)
decision_rules.register("glr", _change("glr"), origin=BUILTIN, section=DecisionSettings, calibrate="glr",
                        detectors=True)


def reference_operating_points(cfg: RunConfig) -> tuple[tuple[float, float], ...]:
    """The steady (speed (m/s), yaw rate (rad/s)) pairs the run's reference holds, in the order it holds them:
    a line one, with no yaw rate; a circle (and a plug-in path, taken as a circle of ``reference.radius``) one,
    ``±speed / radius`` (ccw positive); a figure-eight two, its first lobe's (the ``direction`` side) and then
    the opposite lobe's, whose yaw rate has the other sign."""
    ref = cfg.reference
    if ref.kind == "line":
        return ((ref.speed, 0.0),)
    psidot = ref.speed / ref.radius * (1.0 if ref.direction == "ccw" else -1.0)
    if ref.kind == "figure8":
        return ((ref.speed, psidot), (ref.speed, -psidot))
    return ((ref.speed, psidot),)


def reference_rates(cfg: RunConfig) -> tuple[float, float]:
    """The run's reference's speed (m/s) and yaw rate (rad/s) at its start (the first of
    :func:`reference_operating_points`)."""
    return reference_operating_points(cfg)[0]


def _setup(cfg: RunConfig, setup: FilterSetup | None) -> FilterSetup:
    """The run's filter setup: ``setup`` when the caller has it (the run record's, resolved once per run),
    else resolved from the config."""
    return setup if setup is not None else setup_from_config(cfg)


def nominal_points_of(cfg: RunConfig, setup: FilterSetup | None = None) -> tuple[NominalPoint, ...]:
    """The run's residual generator (:func:`~ftc_mj.estimation.residual.residual_setup`) of its filter setup
    (``setup``, else resolved from ``cfg``) at each steady operating point of its reference
    (:func:`reference_operating_points`) with nominal radii (:func:`~ftc_mj.estimation.calibration.nominal_point`)."""
    setup = residual_setup(_setup(cfg, setup))
    return tuple(nominal_point(setup, *rates) for rates in reference_operating_points(cfg))


def nominal_point_of(cfg: RunConfig) -> NominalPoint:
    """The run's residual generator at its reference's starting operating point (:func:`nominal_points_of`)."""
    return nominal_points_of(cfg)[0]


def glr_window_of(cfg: RunConfig) -> int:
    """GLR window (filter steps) of the run: ``decision.glr_window`` (s) at ``estimator.rate``."""
    return glr_window_steps(cfg.estimator.decision.glr_window, cfg.estimator.rate)


def nominal_threshold(cfg: RunConfig, kind: str, setup: FilterSetup | None = None) -> float:
    """Threshold (log-likelihood-ratio units) of the ``cusum`` or ``glr`` rule of the run ``cfg`` for
    ``decision.arl0`` (s) between false alarms on ``N(0, I)`` innovations
    (:func:`~ftc_mj.estimation.calibration.arl0_threshold`): the largest of the thresholds calibrated at each
    operating point of the reference (a figure-eight's two lobes), so the mean time between false alarms is
    at least ``arl0`` on every part of the path."""
    d = cfg.estimator.decision
    return max(arl0_threshold(kind, point, arl0=d.arl0, shift=d.cusum_shift, window=glr_window_of(cfg),
                              rate=cfg.estimator.rate) for point in nominal_points_of(cfg, setup))


def calibrated_threshold(cfg: RunConfig, kind: str, setup: FilterSetup | None = None) -> float:
    """Threshold (log-likelihood-ratio units) of the ``cusum`` or ``glr`` rule of the run: the
    :func:`nominal_threshold` plus, under the physical null model (:func:`physical_null_model`), the offset
    measured for the detector and the run's sensor set on the physical robot
    (:func:`~ftc_mj.estimation.calibration.physical_offset`: its mean time between false alarms equals the design's
    there). The offset depends on the sensors the method has, never on the simulator that runs."""
    h = nominal_threshold(cfg, kind, setup)
    if physical_null_model(cfg):
        h += physical_offset(kind, cfg.sensors.yaw_rate_sigma is not None)
    return h


def build_decision_rule(cfg: RunConfig, setup: FilterSetup | None = None) -> DecisionRule:
    """The registered rule ``estimator.decision.rule`` of the run (a plug-in's of the old contract is
    called with the run config); ``setup``: the run's filter setup, if the caller has it."""
    d = cfg.estimator.decision
    entry = decision_rules.get(d.rule)
    kind = entry.meta.get("calibrate")
    extra = (calibrated_threshold(cfg, kind, setup),) if kind is not None and not entry.legacy else ()
    if entry.meta.get("detectors") and not entry.legacy:
        extra = (*extra, build_change_detectors(cfg, setup))
    return decision_rules.create(d.rule, d, run_context(cfg), *extra, run_config=cfg)


def physical_null_model(cfg: RunConfig) -> bool:
    """The run's change detectors whiten under the physical robot's null model
    (:mod:`~ftc_mj.estimation.null_model`): the method's declared ``estimator.decision.null_model``, never the
    plant that runs (a method does not know which simulator it is on)."""
    return cfg.estimator.decision.null_model == "physical"


def build_change_detectors(cfg: RunConfig, setup: FilterSetup | None = None, *, glr: bool = True
                           ) -> ChangeDetectors:
    """The run's residual generator with its CUSUM and (``glr``) its GLR (:mod:`~ftc_mj.estimation.residual`)."""
    d = cfg.estimator.decision
    return ChangeDetectors(_setup(cfg, setup), d.cusum_shift, d.isolation_llr, glr_window_of(cfg),
                           physical_null_model(cfg), glr)


def build_rule_statistics(cfg: RunConfig, setup: FilterSetup | None = None) -> RuleStatistics:
    """Every rule's per-step statistics for the run's filter."""
    return RuleStatistics(_setup(cfg, setup), cfg.estimator.decision, cfg.estimator.rate, glr_window_of(cfg),
                          physical_null_model(cfg))


def build_fault_decision(cfg: RunConfig, rule: DecisionRule | None = None, *,
                         setup: FilterSetup | None = None) -> FaultDecision:
    """The run's fault-decision layer: its rule (``rule``, else :func:`build_decision_rule`) and, when
    ``decision.statistics`` is on or the rule sets ``needs_statistics``, every rule's statistics; ``setup``:
    the run's filter setup (the run record's), else each part resolves it from the config."""
    d = cfg.estimator.decision
    impl = rule if rule is not None else build_decision_rule(cfg, setup)
    needs = bool(getattr(impl, "needs_statistics", False))
    stats = build_rule_statistics(cfg, setup) if d.statistics or needs else None
    return FaultDecision(d, cfg.model_wheel_radius, impl, stats)


