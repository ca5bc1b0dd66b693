"""The built-in controllers and reference paths, registered by name, and the config readers that build them.

Every registered controller factory follows the component contract ``factory(settings, context,
reference, *extra)``: ``settings`` the ``[controller]`` section, ``context`` the
:class:`~ftc_mj.context.RunContext` (the controller period, the model's nominal radii and half track, the
robot's input limit) and the reference to track. MPCs are registered ``reusable`` (they have ``reset()``
and the simulation keeps one built solver per process and structure) and ``rate_bounded`` (their first
input stays within ``omega_rate_max / rate`` of the command in force, so the loop clips an excitation
dither to that bound); ``robot_limits``: the factory also takes the robot's
:class:`~ftc_mj.control.pathfollow_spec.RobotLimits` (derived from the plant model by the sim layer) as
``limits``; ``radius_intervals``: the controller has ``set_radius_interval`` (the degraded mode,
:mod:`ftc_mj.reconfiguration.degraded`). Reference factories take ``(settings, context)``: the
``[reference]`` section and the context (the path starts at its ``initial_pose``).

:func:`build_controller` and :func:`build_reference` are the only readers of the application config in
:mod:`ftc_mj.control`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..config import RunConfig, from_sections, run_context
from ..context import RunContext
from ..registry import BUILTIN, controllers, references
from .base import Controller
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController
from .pathfollow import PathFollowingNMPC
from .pathfollow_spec import PathFollowingSpec, RobotLimits
from .reference import CircleReference, FigureEightReference, LineReference, Reference
from .robust import RobustNMPC
from .spec import ProblemSpec


def tracking_problem(settings: Any, context: RunContext) -> ProblemSpec:
    """The MPC problem numbers from the ``[controller]`` settings (weights, nodes, horizon, rate bounds) and
    the run context (the model's half track (m), the robot's ``omega_max`` (rad/s), the controller period (s))."""
    c = settings
    return ProblemSpec(
        nodes=c.nodes,
        horizon=c.horizon,
        half_track=context.half_track,
        omega_max=context.omega_max,
        omega_rate_max=c.omega_rate_max,
        q_pose=c.q_pose,
        q_speed=c.q_speed,
        q_yaw_rate=c.q_yaw_rate,
        rate_penalty=c.rate_penalty,
        max_lateral_accel=c.max_lateral_accel,
        max_longitudinal_accel=c.max_longitudinal_accel,
        sample_time=context.controller_dt,
        rate_bound_from_applied=c.rate_bound_from_applied,
        rate_penalty_first_step=c.rate_penalty_first_step,
    )


def problem_spec(cfg: RunConfig) -> ProblemSpec:
    """The MPC problem numbers of ``cfg`` (:func:`tracking_problem` of its controller section and run context)."""
    return tracking_problem(cfg.controller, run_context(cfg))


@controllers.register("open-loop", origin=BUILTIN)
def open_loop(settings: Any, context: RunContext, reference: object) -> OpenLoopController:
    """Constant wheel rates ``open_loop_omega`` or the schedule ``open_loop_schedule`` (rad/s), clipped to the
    robot's ``omega_max``."""
    return OpenLoopController(settings.open_loop_omega, settings.open_loop_schedule or None, context.omega_max)


@controllers.register("lmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def linear_mpc(settings: Any, context: RunContext, reference: object) -> LinearMPC:
    """The linear MPC on :func:`tracking_problem` (QP solver ``lmpc_qpsol``)."""
    return LinearMPC(tracking_problem(settings, context), reference, qpsol=settings.lmpc_qpsol,
                     time_budget=settings.time_budget, nominal_radii=context.nominal_radii)


@controllers.register("nmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def nmpc(settings: Any, context: RunContext, reference: object) -> NMPC:
    """The LGL pseudospectral NMPC on :func:`tracking_problem` (solver ``solver``)."""
    c = settings
    return NMPC(tracking_problem(c, context), reference, solver=c.solver, max_iter=c.max_iter,
                time_budget=c.time_budget, nominal_radii=context.nominal_radii, cold_time_budget=c.cold_time_budget)


@controllers.register("robust-nmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def robust_nmpc(settings: Any, context: RunContext, reference: object) -> RobustNMPC:
    """The multi-stage robust NMPC over the radius scenarios of ``robust`` on :func:`tracking_problem`."""
    c, rb = settings, settings.robust
    return RobustNMPC(tracking_problem(c, context), reference, rb.scenarios, rb.weights, rb.robust_horizon_nodes,
                      rb.objective, prune_below=rb.prune_below, solver=c.solver, max_iter=c.max_iter,
                      time_budget=c.time_budget, nominal_radii=context.nominal_radii,
                      cold_time_budget=c.cold_time_budget)


def path_following_spec(settings: Any, context: RunContext, desired_speed: float,
                        limits: RobotLimits | None = None) -> PathFollowingSpec:
    """The path-following problem of the ``[controller]`` settings at ``desired_speed`` (m/s, the reference's),
    with the cost terms of ``path_following`` (its own actuation-rate weight, not ``controller.rate_penalty``):
    the bound on the robot's lateral acceleration is ``path_following.max_lateral_accel`` if set, else
    ``lateral_accel_margin`` × the robot's lift-off limit in ``limits`` (which the sim layer derives from the
    plant model); the yaw compliance and the braking trade-off of ``limits`` are used when switched on.
    ``ValueError`` when neither bound nor limits are given."""
    pf = settings.path_following
    bound = pf.max_lateral_accel
    if bound is None:
        if limits is None:
            raise ValueError("controller.path_following: the pf-nmpc needs the robot's lift-off limit "
                             "(derived by the sim layer) or an explicit max_lateral_accel")
        bound = pf.lateral_accel_margin * float(limits.liftoff_accel)
    lim = limits or RobotLimits(liftoff_accel=bound)
    V = desired_speed
    problem = dataclasses.replace(tracking_problem(settings, context), max_lateral_accel=bound,
                                  max_longitudinal_accel=pf.max_longitudinal_accel, rate_penalty=pf.rate_penalty)
    return PathFollowingSpec(
        problem=problem, desired_speed=V, q_contour=pf.q_contour, q_lag=pf.q_lag, q_heading=pf.q_heading,
        q_progress=pf.q_progress, progress_rate_penalty=pf.progress_rate_penalty,
        max_progress_speed=pf.max_progress_speed or 2.0 * V,
        yaw_compliance=lim.yaw_compliance if pf.compensate_yaw_compliance else 0.0,
        braking_trade=lim.braking_trade if pf.braking_trade else 0.0,
        sample_time=context.controller_dt, slack_penalty=pf.slack_penalty, max_lag=pf.max_lag,
    )


@controllers.register("pf-nmpc", origin=BUILTIN, reusable=True, rate_bounded=True, robot_limits=True,
                      radius_intervals=True)
def path_following_nmpc(settings: Any, context: RunContext, reference: Reference,
                        limits: RobotLimits | None = None) -> PathFollowingNMPC:
    """The path-following NMPC on :func:`path_following_spec` at the reference's speed (solver ``solver``)."""
    c = settings
    spec = path_following_spec(c, context, reference.speed, limits)
    return PathFollowingNMPC(spec, reference, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                             nominal_radii=context.nominal_radii, cold_time_budget=c.cold_time_budget)


def controller_from_settings(controller: Any, reference: object, *, robot: Any = None,
                             model: Any = None) -> Controller:
    """The controller built from its own settings, without a run config: the ``[controller]`` section
    (its ``kind`` names the registered controller), the ``[robot]`` (input limits) and ``[model]``
    (geometry the controller assumes) sections — objects, plain tables or ``None`` = the defaults;
    :class:`~ftc_mj.errors.BadInput` naming the field — and the reference to track."""
    cfg = from_sections(controller=controller, robot=robot, model=model)
    return build_controller(cfg, reference)


def build_controller(cfg: RunConfig, reference: object, limits: RobotLimits | None = None) -> Controller:
    """The controller ``cfg.controller.kind`` names (``nmpc`` → :class:`NMPC`, ``lmpc`` →
    :class:`LinearMPC`, ``open-loop`` → :class:`OpenLoopController`, ``pf-nmpc`` →
    :class:`PathFollowingNMPC`, ``robust-nmpc`` → :class:`RobustNMPC`, or a registered plug-in's), built from
    ``cfg.controller``, the run context and ``reference``; ``limits`` goes to a factory registered with
    ``robot_limits``."""
    kind = cfg.controller.kind
    kwargs = {"limits": limits} if controllers.get(kind).meta.get("robot_limits", False) else {}
    return controllers.create(kind, cfg.controller, run_context(cfg), reference, run_config=cfg, **kwargs)


# ---------------------------------------------------------------------------------------------- references
@references.register("circle", origin=BUILTIN)
def circle(settings: Any, context: RunContext) -> CircleReference:
    """The circle of ``radius`` (m) at ``speed`` (m/s) in ``direction``, from the initial pose."""
    return CircleReference(settings.radius, settings.speed, settings.direction, context.initial_pose)


@references.register("line", origin=BUILTIN)
def line(settings: Any, context: RunContext) -> LineReference:
    """The straight line at ``speed`` (m/s) from the initial pose."""
    return LineReference(settings.speed, context.initial_pose)


@references.register("figure8", origin=BUILTIN)
def figure_eight(settings: Any, context: RunContext) -> FigureEightReference:
    """The figure-eight of lobe ``radius`` (m) at ``speed`` (m/s) in ``direction``, from the initial pose."""
    return FigureEightReference(settings.radius, settings.speed, settings.direction, context.initial_pose)


def build_reference(cfg: RunConfig) -> Reference:
    """The reference ``cfg.reference.kind`` names (``circle``, ``line``, ``figure8`` or a registered
    plug-in's), built from ``cfg.reference`` and the run context: it starts at ``cfg.plant.initial_pose``."""
    return references.create(cfg.reference.kind, cfg.reference, run_context(cfg), run_config=cfg)
