"""The built-in controllers, registered by name (:data:`ftc_mj.registry.controllers`).

Every factory takes the run config and the reference and returns a
:class:`~ftc_mj.control.base.Controller`; MPCs are registered ``reusable`` (they have ``reset()``
and the simulation keeps one built solver per process and structure) and ``rate_bounded`` (their
first input stays within ``omega_rate_max / rate`` of the command in force, so the loop clips an
excitation dither to that bound); ``robot_limits``: the factory takes the robot's
:class:`~ftc_mj.control.pathfollow.RobotLimits` (derived from the plant model by the sim layer) as
``limits``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..config import RunConfig, from_sections
from ..registry import BUILTIN, controllers
from .base import Controller
from .collocation import ProblemSpec
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController
from .pathfollow import PathFollowingNMPC, PathFollowingSpec, RobotLimits
from .robust import RobustNMPC


def problem_spec(cfg: RunConfig) -> ProblemSpec:
    """The MPC problem numbers of ``cfg`` (model half track, robot input limits, controller weights and
    period)."""
    c = cfg.controller
    return ProblemSpec(
        nodes=c.nodes,
        horizon=c.horizon,
        half_track=cfg.model_half_track,
        omega_max=cfg.robot.omega_max,
        omega_rate_max=c.omega_rate_max,
        q_pose=c.q_pose,
        q_speed=c.q_speed,
        q_yaw_rate=c.q_yaw_rate,
        rate_penalty=c.rate_penalty,
        max_lateral_accel=c.max_lateral_accel,
        max_longitudinal_accel=c.max_longitudinal_accel,
        sample_time=1.0 / c.rate,
        rate_bound_from_applied=c.rate_bound_from_applied,
        rate_penalty_first_step=c.rate_penalty_first_step,
    )


@controllers.register("open-loop", origin=BUILTIN)
def open_loop(cfg: RunConfig, reference: object) -> OpenLoopController:
    """Constant wheel rates ``controller.open_loop_omega`` or the schedule ``open_loop_schedule``."""
    c = cfg.controller
    return OpenLoopController(c.open_loop_omega, c.open_loop_schedule or None, cfg.robot.omega_max)


@controllers.register("lmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def linear_mpc(cfg: RunConfig, reference: object) -> LinearMPC:
    """The linear MPC on :func:`problem_spec` (QP solver ``controller.lmpc_qpsol``)."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    return LinearMPC(problem_spec(cfg), reference, qpsol=c.lmpc_qpsol, time_budget=c.time_budget,
                     nominal_radii=(R0, R0))


@controllers.register("nmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def nmpc(cfg: RunConfig, reference: object) -> NMPC:
    """The LGL pseudospectral NMPC on :func:`problem_spec` (solver ``controller.solver``)."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    return NMPC(problem_spec(cfg), reference, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)


@controllers.register("robust-nmpc", origin=BUILTIN, reusable=True, rate_bounded=True)
def robust_nmpc(cfg: RunConfig, reference: object) -> RobustNMPC:
    """The multi-stage robust NMPC over the radius scenarios of ``controller.robust`` on :func:`problem_spec`."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    rb = c.robust
    return RobustNMPC(problem_spec(cfg), reference, rb.scenarios, rb.weights, rb.robust_horizon_nodes, rb.objective,
                      prune_below=rb.prune_below, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                      nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)


def path_following_spec(cfg: RunConfig, limits: RobotLimits | None = None) -> PathFollowingSpec:
    """The path-following problem of ``cfg``: the bound on the robot's lateral acceleration is
    ``controller.path_following.max_lateral_accel`` if set, else ``lateral_accel_margin`` × the robot's lift-off
    limit in ``limits`` (which the sim layer derives from the plant model); the yaw compliance and the braking
    trade-off of ``limits`` are used when switched on. ``ValueError`` when neither bound nor limits are given."""
    pf = cfg.controller.path_following
    bound = pf.max_lateral_accel
    if bound is None:
        if limits is None:
            raise ValueError("controller.path_following: the pf-nmpc needs the robot's lift-off limit "
                             "(derived by the sim layer) or an explicit max_lateral_accel")
        bound = pf.lateral_accel_margin * float(limits.liftoff_accel)
    lim = limits or RobotLimits(liftoff_accel=bound)
    V = cfg.reference.speed
    problem = dataclasses.replace(problem_spec(cfg), max_lateral_accel=bound,
                                  max_longitudinal_accel=pf.max_longitudinal_accel)
    return PathFollowingSpec(
        problem=problem, desired_speed=V, q_contour=pf.q_contour, q_lag=pf.q_lag, q_heading=pf.q_heading,
        q_progress=pf.q_progress, progress_rate_penalty=pf.progress_rate_penalty,
        max_progress_speed=pf.max_progress_speed or 2.0 * V,
        yaw_compliance=lim.yaw_compliance if pf.compensate_yaw_compliance else 0.0,
        braking_trade=lim.braking_trade if pf.braking_trade else 0.0,
        sample_time=1.0 / cfg.controller.rate, slack_penalty=pf.slack_penalty,
    )


@controllers.register("pf-nmpc", origin=BUILTIN, reusable=True, rate_bounded=True, robot_limits=True)
def path_following_nmpc(cfg: RunConfig, reference: object, limits: RobotLimits | None = None) -> PathFollowingNMPC:
    """The path-following NMPC on :func:`path_following_spec` (solver ``controller.solver``)."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    return PathFollowingNMPC(path_following_spec(cfg, limits), reference, solver=c.solver, max_iter=c.max_iter,
                             time_budget=c.time_budget, nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)


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
    :class:`PathFollowingNMPC`, ``robust-nmpc`` → :class:`RobustNMPC`, or a registered plug-in's);
    ``limits`` goes to a factory registered with ``robot_limits``."""
    if controllers.get(cfg.controller.kind).meta.get("robot_limits", False):
        return controllers.build(cfg.controller.kind, cfg, reference, limits=limits)
    return controllers.build(cfg.controller.kind, cfg, reference)
