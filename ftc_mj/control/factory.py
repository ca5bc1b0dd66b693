"""The built-in controllers, registered by name (:data:`ftc_mj.registry.controllers`).

Every factory takes the run config and the reference and returns a
:class:`~ftc_mj.control.base.Controller`; MPCs are registered ``reusable`` (they have ``reset()``
and the simulation keeps one built solver per process and structure) and ``rate_bounded`` (their
first input stays within ``omega_rate_max / rate`` of the command in force, so the loop clips an
excitation dither to that bound).
"""

from __future__ import annotations

from typing import Any

from ..config import RunConfig, from_sections
from ..registry import BUILTIN, controllers
from .base import Controller
from .collocation import ProblemSpec
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController


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


def controller_from_settings(controller: Any, reference: object, *, robot: Any = None,
                             model: Any = None) -> Controller:
    """The controller built from its own settings, without a run config: the ``[controller]`` section
    (its ``kind`` names the registered controller), the ``[robot]`` (input limits) and ``[model]``
    (geometry the controller assumes) sections — objects, plain tables or ``None`` = the defaults;
    :class:`~ftc_mj.errors.BadInput` naming the field — and the reference to track."""
    cfg = from_sections(controller=controller, robot=robot, model=model)
    return build_controller(cfg, reference)


def build_controller(cfg: RunConfig, reference: object) -> Controller:
    """The controller ``cfg.controller.kind`` names (``nmpc`` → :class:`NMPC`, ``lmpc`` →
    :class:`LinearMPC`, ``open-loop`` → :class:`OpenLoopController`, or a registered plug-in's)."""
    return controllers.build(cfg.controller.kind, cfg, reference)
