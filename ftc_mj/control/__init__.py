"""Trajectory-tracking controllers (paper §3): LGL pseudospectral NMPC, linear MPC, robust NMPC,
open loop, the path-following NMPC; the reference paths; LGL helpers. Each controller kind's settings model
is declared beside it (``NMPCSettings`` in :mod:`.nmpc`, …; the MPCs' shared ones in :mod:`.spec`); the
wiring that builds them from the run config is :mod:`ftc_mj.wiring.control`."""

from .base import Controller, ControllerSettings, ControlOutput
from .lgl import (
    barycentric_interpolate,
    barycentric_weights,
    differentiation_matrix,
    interpolation_matrix,
    lgl,
    lgl_nodes,
    lgl_weights,
)
from .lmpc import LinearMPC, LinearMPCSettings
from .nmpc import NMPC, NMPCSettings
from .open_loop import OpenLoopController, OpenLoopSettings
from .pathfollow import PathFollowingNMPC, PathFollowingNMPCSettings, path_following_spec
from .pathfollow_spec import PathFollowingSettings, PathFollowingSpec, RobotLimits, path_following_problem
from .reference import CircleReference, FigureEightReference, LineReference, ReferenceSettings, RefSample
from .robust import RobustNMPC, RobustNMPCSettings, RobustSettings
from .spec import MPCSettings, PluginControllerSettings, ProblemSpec, tracking_problem

__all__ = [
    "NMPC",
    "CircleReference",
    "ControlOutput",
    "Controller",
    "ControllerSettings",
    "FigureEightReference",
    "LineReference",
    "LinearMPC",
    "LinearMPCSettings",
    "MPCSettings",
    "NMPCSettings",
    "OpenLoopController",
    "OpenLoopSettings",
    "PathFollowingNMPC",
    "PathFollowingNMPCSettings",
    "PathFollowingSettings",
    "PathFollowingSpec",
    "PluginControllerSettings",
    "ProblemSpec",
    "RefSample",
    "ReferenceSettings",
    "RobotLimits",
    "RobustNMPC",
    "RobustNMPCSettings",
    "RobustSettings",
    "barycentric_interpolate",
    "barycentric_weights",
    "differentiation_matrix",
    "interpolation_matrix",
    "lgl",
    "lgl_nodes",
    "lgl_weights",
    "path_following_problem",
    "path_following_spec",
    "tracking_problem",
]


_FACTORY_NAMES = ("build_controller", "build_reference", "controller_from_settings", "problem_spec", "tracking_problem")


def __getattr__(name: str) -> object:
    """The factory's names, imported on first use: the factory reads the application config, which composes
    settings declared in this package (:mod:`.excitation`), so importing it here would be a cycle."""
    if name in _FACTORY_NAMES:
        from . import factory
        return getattr(factory, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
