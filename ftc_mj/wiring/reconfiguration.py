"""Reconfiguration policies, the degraded mode and the scenario weights of a run, from the application
config (the built-in policies register themselves with their settings model in
:mod:`ftc_mj.reconfiguration.policies`)."""

from __future__ import annotations

from ..config import ReconfigurationConfig, RunConfig, run_context
from ..reconfiguration.degraded import DegradedMode, DragEvidence
from ..reconfiguration.policies import ReconfigurationPolicy
from ..reconfiguration.scenario_weights import ScenarioWeighting
from ..registry import controllers, policies


def build_policy(cfg: RunConfig, with_estimator: bool = True) -> ReconfigurationPolicy:
    """The policy ``cfg.reconfiguration.policy`` names, built from the ``[reconfiguration]`` section and the
    run context; in a run without an estimator (``with_estimator=False``) ``none`` unless the policy is
    registered with ``needs_estimator=False``."""
    name = cfg.reconfiguration.policy
    if not with_estimator and policies.get(name).meta.get("needs_estimator", True):
        name = "none"
    return policies.create(name, resolved_reconfiguration(cfg), run_context(cfg), run_config=cfg)


def resolved_reconfiguration(cfg: RunConfig) -> ReconfigurationConfig:
    """The ``[reconfiguration]`` section with its ``auto`` settings resolved for this run:
    ``condition_on_healthy = "auto"`` is on with a controller registered with ``radius_intervals``."""
    rc = cfg.reconfiguration
    if rc.condition_on_healthy != "auto":
        return rc
    return rc.model_copy(update={"condition_on_healthy": _takes_intervals(cfg)})


def _takes_intervals(cfg: RunConfig) -> bool:
    """Whether the run's controller is registered to take radius intervals (``radius_intervals``)."""
    return bool(controllers.get(cfg.controller.kind).meta.get("radius_intervals", False))


def build_scenario_weighting(cfg: RunConfig) -> ScenarioWeighting | None:
    """The filter's re-weighting of the robust NMPC's scenarios (``controller.robust.weighting =
    "posterior"``), or ``None`` when the controller's weights stay as configured (another controller,
    fixed weights, or no filter)."""
    c = cfg.controller
    if c.kind != "robust-nmpc" or c.robust.weighting == "fixed" or cfg.estimator.kind == "none":
        return None
    return ScenarioWeighting(c.robust)


def build_degraded_mode(cfg: RunConfig) -> DegradedMode | None:
    """The degraded robust mode (``reconfiguration.degraded``) or ``None``: it needs a filter and a controller
    registered with ``radius_intervals``; ``auto`` runs it with the ``safe`` policy and a sensor that tells the
    wheels apart (a yaw-rate gyro or position fixes: with speed only one wheel's estimate bounds nothing), armed
    by the evidence on the measurements that the tyres can be dragged
    (:class:`~ftc_mj.reconfiguration.degraded.DragEvidence`) — never by which simulator runs; ``on`` with any
    policy but ``none`` and ``truth``, armed from the start. The first alarm is the decision's
    ``k_sigma``/``min_drop`` departure."""
    rc = cfg.reconfiguration
    d = rc.degraded
    takes = _takes_intervals(cfg)
    separates = cfg.sensors.yaw_rate_sigma is not None or cfg.sensors.position_sigma is not None
    if d.mode == "auto":
        wanted = rc.policy == "safe" and separates
    else:
        wanted = d.mode == "on" and rc.policy not in ("none", "truth")
    if not takes or not wanted or cfg.estimator.kind == "none":
        return None
    ctx = run_context(cfg)
    evidence = None
    if d.mode == "auto":
        window = max(1, round(0.5 * d.skid_window * cfg.estimator.rate))
        evidence = DragEvidence(window, cfg.sensors.encoder_sigma, ctx.omega_max)
    return DegradedMode(d, ctx, cfg.estimator.decision.k_sigma, cfg.estimator.decision.min_drop,
                        rc.max_rate, rc.max_sigma, evidence)
