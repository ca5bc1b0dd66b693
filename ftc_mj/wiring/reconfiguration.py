"""Reconfiguration policies, the degraded mode and the scenario weights of a run, from the application
config (the built-in policies register themselves with their settings model in
:mod:`ftc_mj.reconfiguration.policies`)."""

from __future__ import annotations

from ..config import ReconfigurationConfig, RunConfig, run_context
from ..control.pathfollow_spec import RobotLimits
from ..control.reference import Path
from ..control.stop import SafeStop, StopLimits
from ..reconfiguration.accommodation import Accommodation
from ..reconfiguration.degraded import DegradedMode, DragEvidence
from ..reconfiguration.oracle import TruthDiagnoses
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


def build_accommodation(cfg: RunConfig, limits: RobotLimits, path: Path) -> Accommodation | None:
    """The accommodation of every diagnosed mode (``reconfiguration.accommodation.mode = "all"``) or ``None``
    (``radii``: the policy's radii only), with its safe stop along ``path`` within the nominal robot's
    ``limits`` (lift-off lateral acceleration, braking trade), the model's half track, the robot's wheel-rate
    bound and the controller's rate bounds."""
    a = cfg.reconfiguration.accommodation
    if a.mode != "all":
        return None
    c = cfg.controller
    pf = getattr(c, "path_following", None)
    lon = pf.max_longitudinal_accel if pf is not None else getattr(c, "max_longitudinal_accel", None)
    stop_limits = StopLimits(
        half_track=cfg.model_half_track, omega_max=float(cfg.robot.omega_max),
        omega_rate_max=float(getattr(c, "omega_rate_max", float("inf"))), sample_time=1.0 / c.rate,
        liftoff_accel=limits.liftoff_accel, braking_trade=limits.braking_trade, max_longitudinal_accel=lon)
    return Accommodation(a, SafeStop(a.stop, stop_limits, path))


def build_diagnosis_source(cfg: RunConfig) -> TruthDiagnoses | None:
    """Where the accommodation's declarations come from: the truth (:class:`TruthDiagnoses`) in an oracle run
    (``oracle = true``); ``None`` otherwise: the loop hands the accommodation its diagnoser's declarations in
    force (:func:`~ftc_mj.model.diagnosis.in_force`; the config refuses ``all`` with neither)."""
    return TruthDiagnoses(cfg.faults, cfg.plant_wheel_radius) if cfg.oracle else None
