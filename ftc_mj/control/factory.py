"""Build the configured controller."""

from __future__ import annotations

from ..config import RunConfig
from .base import Controller
from .collocation import ProblemSpec
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController
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


def build_controller(cfg: RunConfig, reference) -> Controller:
    """``cfg.controller.kind``: ``nmpc`` → :class:`NMPC`, ``lmpc`` → :class:`LinearMPC`,
    ``open-loop`` → :class:`OpenLoopController`, ``robust-nmpc`` → :class:`RobustNMPC`."""
    c = cfg.controller
    R0 = cfg.model_wheel_radius
    if c.kind == "open-loop":
        return OpenLoopController(c.open_loop_omega, c.open_loop_schedule or None, cfg.robot.omega_max)
    spec = problem_spec(cfg)
    if c.kind == "lmpc":
        return LinearMPC(spec, reference, qpsol=c.lmpc_qpsol, time_budget=c.time_budget, nominal_radii=(R0, R0))
    if c.kind == "robust-nmpc":
        rb = c.robust
        return RobustNMPC(spec, reference, rb.scenarios, rb.weights, rb.robust_horizon_nodes, rb.objective,
                          prune_below=rb.prune_below, solver=c.solver, max_iter=c.max_iter,
                          time_budget=c.time_budget, nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)
    return NMPC(spec, reference, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                nominal_radii=(R0, R0), cold_time_budget=c.cold_time_budget)
