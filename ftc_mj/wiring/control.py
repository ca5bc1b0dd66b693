"""The built-in controllers and reference paths, registered by name with their settings models, and the config
readers that build them.

Every registered controller factory follows the component contract ``factory(settings, context,
reference, *extra)``: ``settings`` the ``[controller]`` section (the settings model of its kind, declared
beside the controller), ``context`` the :class:`~ftc_mj.context.RunContext` (the controller period, the
model's nominal radii and half track, the robot's input limit) and the reference to track. MPCs are
registered ``reusable`` (they have ``reset()`` and the simulation keeps one built solver per process and
structure), and ``retargetable`` (they have ``set_reference``: the reference — for the path-following NMPC also
its desired speed and the robot's limits — is a parameter of their problem, so one built controller serves every
reference, :func:`retarget_controller`) and ``rate_bounded`` (their
first input stays within ``omega_rate_max / rate`` of the command in force, so the loop clips an excitation
dither to that bound); ``robot_limits``: the factory also takes the
robot's :class:`~ftc_mj.control.pathfollow_spec.RobotLimits` (derived from the plant model by the sim layer)
as ``limits``; ``radius_intervals``: the controller has ``set_radius_interval`` (the degraded mode,
:mod:`ftc_mj.reconfiguration.degraded`). Reference factories take ``(settings, context)``: the
``[reference]`` section and the context (the path starts at its ``initial_pose``). Each built-in is
registered with ``section=`` its settings model (listed by ``ftc-mj components``).

:func:`build_controller` and :func:`build_reference` are the only readers of the application config for the
control components.
"""

from __future__ import annotations

from typing import Any

from ..config import RunConfig, from_sections, run_context
from ..context import RunContext
from ..control.base import Controller
from ..control.lmpc import LinearMPC, LinearMPCSettings
from ..control.nmpc import NMPC, NMPCSettings
from ..control.open_loop import OpenLoopController, OpenLoopSettings
from ..control.pathfollow import PathFollowingNMPC, PathFollowingNMPCSettings, path_following_spec
from ..control.pathfollow_spec import RobotLimits
from ..control.reference import (
    CircleReference,
    FigureEightReference,
    LineReference,
    Reference,
    ReferenceSettings,
)
from ..control.robust import RobustNMPC, RobustNMPCSettings
from ..control.spec import ProblemSpec, tracking_problem
from ..registry import BUILTIN, controllers, references


def problem_spec(cfg: RunConfig) -> ProblemSpec:
    """The MPC problem numbers of ``cfg`` (:func:`~ftc_mj.control.spec.tracking_problem` of its controller
    section, an MPC's, and its run context)."""
    return tracking_problem(cfg.controller, run_context(cfg))


@controllers.register("open-loop", origin=BUILTIN, section=OpenLoopSettings)
def open_loop(settings: OpenLoopSettings, context: RunContext, reference: object) -> OpenLoopController:
    """Constant wheel rates ``open_loop_omega`` or the schedule ``open_loop_schedule`` (rad/s), clipped to the
    robot's ``omega_max``."""
    return OpenLoopController(settings.open_loop_omega, settings.open_loop_schedule or None, context.omega_max)


@controllers.register("lmpc", origin=BUILTIN, reusable=True, retargetable=True, rate_bounded=True,
                      section=LinearMPCSettings)
def linear_mpc(settings: LinearMPCSettings, context: RunContext, reference: object) -> LinearMPC:
    """The linear MPC on the tracking problem (QP solver ``lmpc_qpsol``)."""
    return LinearMPC(tracking_problem(settings, context), reference, qpsol=settings.lmpc_qpsol,
                     time_budget=settings.time_budget, nominal_radii=context.nominal_radii)


@controllers.register("nmpc", origin=BUILTIN, reusable=True, retargetable=True, rate_bounded=True,
                      section=NMPCSettings)
def nmpc(settings: NMPCSettings, context: RunContext, reference: object) -> NMPC:
    """The LGL pseudospectral NMPC on the tracking problem (solver ``solver``)."""
    c = settings
    return NMPC(tracking_problem(c, context), reference, solver=c.solver, max_iter=c.max_iter,
                time_budget=c.time_budget, nominal_radii=context.nominal_radii, cold_time_budget=c.cold_time_budget)


@controllers.register("robust-nmpc", origin=BUILTIN, reusable=True, retargetable=True, rate_bounded=True,
                      section=RobustNMPCSettings)
def robust_nmpc(settings: RobustNMPCSettings, context: RunContext, reference: object) -> RobustNMPC:
    """The multi-stage robust NMPC over the radius scenarios of ``robust`` on the tracking problem."""
    c, rb = settings, settings.robust
    return RobustNMPC(tracking_problem(c, context), reference, rb.scenarios, rb.weights, rb.robust_horizon_nodes,
                      rb.objective, prune_below=rb.prune_below, solver=c.solver, max_iter=c.max_iter,
                      time_budget=c.time_budget, nominal_radii=context.nominal_radii,
                      cold_time_budget=c.cold_time_budget)


@controllers.register("pf-nmpc", origin=BUILTIN, reusable=True, retargetable=True, rate_bounded=True, robot_limits=True,
                      radius_intervals=True, section=PathFollowingNMPCSettings)
def path_following_nmpc(settings: PathFollowingNMPCSettings, context: RunContext, reference: Reference,
                        limits: RobotLimits | None = None) -> PathFollowingNMPC:
    """The path-following NMPC on :func:`~ftc_mj.control.pathfollow.path_following_spec` at the reference's
    speed (solver ``solver``)."""
    c = settings
    spec = path_following_spec(c, context, reference.speed, limits)
    return PathFollowingNMPC(spec, reference, solver=c.solver, max_iter=c.max_iter, time_budget=c.time_budget,
                             nominal_radii=context.nominal_radii, cold_time_budget=c.cold_time_budget)


def retarget_controller(ctl: Any, cfg: RunConfig, reference: Reference, limits: RobotLimits | None = None) -> None:
    """Give a reused ``retargetable`` controller the reference of ``cfg``'s run: the path-following NMPC also the
    problem numbers of that run (its desired speed and the robot's ``limits``), which are parameters of its
    built problem (:meth:`~ftc_mj.control.pathfollow.PathFollowingNMPC.set_reference`)."""
    if isinstance(ctl, PathFollowingNMPC):
        ctl.set_reference(reference, path_following_spec(cfg.controller, run_context(cfg), reference.speed, limits))
    else:
        ctl.set_reference(reference)


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
@references.register("circle", origin=BUILTIN, section=ReferenceSettings)
def circle(settings: ReferenceSettings, context: RunContext) -> CircleReference:
    """The circle of ``radius`` (m) at ``speed`` (m/s) in ``direction``, from the initial pose."""
    return CircleReference(settings.radius, settings.speed, settings.direction, context.initial_pose)


@references.register("line", origin=BUILTIN, section=ReferenceSettings)
def line(settings: ReferenceSettings, context: RunContext) -> LineReference:
    """The straight line at ``speed`` (m/s) from the initial pose."""
    return LineReference(settings.speed, context.initial_pose)


@references.register("figure8", origin=BUILTIN, section=ReferenceSettings)
def figure_eight(settings: ReferenceSettings, context: RunContext) -> FigureEightReference:
    """The figure-eight of lobe ``radius`` (m) at ``speed`` (m/s) in ``direction``, from the initial pose."""
    return FigureEightReference(settings.radius, settings.speed, settings.direction, context.initial_pose)


def build_reference(cfg: RunConfig) -> Reference:
    """The reference ``cfg.reference.kind`` names (``circle``, ``line``, ``figure8`` or a registered
    plug-in's), built from ``cfg.reference`` and the run context: it starts at ``cfg.plant.initial_pose``."""
    return references.create(cfg.reference.kind, cfg.reference, run_context(cfg), run_config=cfg)
