"""Build the configured controller."""

from __future__ import annotations

import dataclasses

from ..config import RunConfig
from .base import Controller
from .collocation import ProblemSpec
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController
from .pathfollow import PathFollowingNMPC, PathFollowingSpec, RobotLimits


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


def build_controller(cfg: RunConfig, reference, limits: RobotLimits | None = None) -> Controller:
    """``cfg.controller.kind``: ``nmpc`` → :class:`NMPC`, ``lmpc`` → :class:`LinearMPC`,
    ``open-loop`` → :class:`OpenLoopController`, ``pf-nmpc`` → :class:`PathFollowingNMPC` (with the robot's
    ``limits``, see :func:`path_following_spec`)."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    if c.kind == "open-loop":
        return OpenLoopController(c.open_loop_omega, c.open_loop_schedule or None, cfg.robot.omega_max)
    if c.kind == "pf-nmpc":
        return PathFollowingNMPC(path_following_spec(cfg, limits), reference, solver=c.solver, max_iter=c.max_iter,
                                 time_budget=c.time_budget, nominal_radii=(R0, R0),
                                 cold_time_budget=c.cold_time_budget)
    spec = problem_spec(cfg)
    if c.kind == "lmpc":
        return LinearMPC(spec, reference, qpsol=c.lmpc_qpsol, time_budget=c.time_budget, nominal_radii=(R0, R0))
    return NMPC(spec, reference, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)
