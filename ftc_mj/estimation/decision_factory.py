"""The built-in decision rules, registered by name (:data:`ftc_mj.registry.decision_rules`), and the
fault-decision layer of a run: the one place the decision layer reads the application config.

A registered factory takes the rule's own settings (the ``[estimator.decision]`` section) and the
:class:`~ftc_mj.context.RunContext`; a rule registered with the meta ``calibrate="cusum"`` or ``"glr"``
also gets the threshold of that change detector, calibrated here for ``decision.arl0`` at the nominal
operating point of the run's residual generator (:mod:`.residual`) on its reference path
(:func:`calibrated_threshold`) — a rule does not read the path itself — and one registered with
``detectors=True`` (the built-in ``cusum`` and ``glr``) also the run's
:class:`~.residual.ChangeDetectors`.
"""

from __future__ import annotations

from ..config import DecisionConfig, RunConfig, run_context
from ..context import RunContext
from ..registry import BUILTIN, decision_rules
from .calibration import NominalPoint, arl0_threshold, nominal_point
from .change import glr_window_steps
from .decision import AutoRule, ChangeRule, DecisionRule, FaultDecision, ModeRule, SigmaRule
from .factory import setup_from_config
from .residual import ChangeDetectors, residual_setup
from .rule_statistics import RuleStatistics


def _sigma(settings: DecisionConfig, context: RunContext) -> SigmaRule:
    return SigmaRule(settings, context.nominal_radii[0])


def _mode(settings: DecisionConfig, context: RunContext) -> ModeRule:
    return ModeRule(settings, context.nominal_radii[0])


def _auto(settings: DecisionConfig, context: RunContext) -> AutoRule:
    return AutoRule(settings, context.nominal_radii[0])


def _change(name: str):  # noqa: ANN202 - a factory of the registry contract
    def factory(settings: DecisionConfig, context: RunContext, threshold: float,
                detectors: ChangeDetectors) -> ChangeRule:
        return ChangeRule(name, settings.dwell, threshold, detectors, settings.min_drop, settings.change_holdoff,
                          settings.glr_window)
    factory.__name__ = f"_{name}"
    return factory


decision_rules.register("sigma", _sigma, origin=BUILTIN)
decision_rules.register("mode", _mode, origin=BUILTIN)
decision_rules.register("auto", _auto, origin=BUILTIN)
decision_rules.register("cusum", _change("cusum"), origin=BUILTIN, calibrate="cusum", detectors=True)
decision_rules.register("glr", _change("glr"), origin=BUILTIN, calibrate="glr", detectors=True)


def reference_rates(cfg: RunConfig) -> tuple[float, float]:
    """The run's reference's steady speed (m/s) and yaw rate (rad/s); a line has no yaw rate."""
    ref = cfg.reference
    psidot = 0.0 if ref.kind == "line" else ref.speed / ref.radius * (1.0 if ref.direction == "ccw" else -1.0)
    return ref.speed, psidot


def nominal_point_of(cfg: RunConfig) -> NominalPoint:
    """The run's residual generator (:func:`.residual.residual_setup`) at its reference's steady speed and
    yaw rate with nominal radii (:func:`.calibration.nominal_point`)."""
    return nominal_point(residual_setup(setup_from_config(cfg)), *reference_rates(cfg))


def glr_window_of(cfg: RunConfig) -> int:
    """GLR window (filter steps) of the run: ``decision.glr_window`` (s) at ``estimator.rate``."""
    return glr_window_steps(cfg.estimator.decision.glr_window, cfg.estimator.rate)


def calibrated_threshold(cfg: RunConfig, kind: str) -> float:
    """Threshold (log-likelihood-ratio units) of the ``cusum`` or ``glr`` rule of the run ``cfg`` for
    ``decision.arl0`` (s) between false alarms."""
    d = cfg.estimator.decision
    return arl0_threshold(kind, nominal_point_of(cfg), arl0=d.arl0, shift=d.cusum_shift,
                          window=glr_window_of(cfg), rate=cfg.estimator.rate)


def build_decision_rule(cfg: RunConfig) -> DecisionRule:
    """The registered rule ``estimator.decision.rule`` of the run (a plug-in's of the old contract is
    called with the run config)."""
    d = cfg.estimator.decision
    entry = decision_rules.get(d.rule)
    kind = entry.meta.get("calibrate")
    extra = (calibrated_threshold(cfg, kind),) if kind is not None and not entry.legacy else ()
    if entry.meta.get("detectors") and not entry.legacy:
        extra = (*extra, build_change_detectors(cfg))
    return decision_rules.create(d.rule, d, run_context(cfg), *extra, run_config=cfg)


def build_change_detectors(cfg: RunConfig) -> ChangeDetectors:
    """The run's residual generator with its CUSUM and GLR (:mod:`.residual`)."""
    d = cfg.estimator.decision
    return ChangeDetectors(setup_from_config(cfg), d.cusum_shift, d.isolation_llr, glr_window_of(cfg))


def build_rule_statistics(cfg: RunConfig) -> RuleStatistics:
    """Every rule's per-step statistics for the run's filter."""
    return RuleStatistics(setup_from_config(cfg), cfg.estimator.decision, cfg.estimator.rate, glr_window_of(cfg))


def build_fault_decision(cfg: RunConfig, rule: DecisionRule | None = None) -> FaultDecision:
    """The run's fault-decision layer: its rule (``rule``, else :func:`build_decision_rule`) and, when
    ``decision.statistics`` is on or the rule sets ``needs_statistics``, every rule's statistics."""
    d = cfg.estimator.decision
    impl = rule if rule is not None else build_decision_rule(cfg)
    needs = bool(getattr(impl, "needs_statistics", False))
    stats = build_rule_statistics(cfg) if d.statistics or needs else None
    return FaultDecision(d, cfg.model_wheel_radius, impl, stats)


