"""Trajectory-tracking controllers (paper §3): LGL pseudospectral NMPC, linear MPC, robust NMPC,
open loop, the path-following NMPC; the reference paths; LGL helpers."""

from .base import Controller, ControlOutput
from .lgl import (
    barycentric_interpolate,
    barycentric_weights,
    differentiation_matrix,
    interpolation_matrix,
    lgl,
    lgl_nodes,
    lgl_weights,
)
from .lmpc import LinearMPC
from .nmpc import NMPC
from .open_loop import OpenLoopController
from .pathfollow import PathFollowingNMPC
from .pathfollow_spec import PathFollowingSpec, RobotLimits
from .reference import CircleReference, FigureEightReference, LineReference, RefSample
from .robust import RobustNMPC
from .spec import ProblemSpec

__all__ = [
    "NMPC",
    "CircleReference",
    "ControlOutput",
    "Controller",
    "FigureEightReference",
    "LineReference",
    "LinearMPC",
    "OpenLoopController",
    "PathFollowingNMPC",
    "PathFollowingSpec",
    "ProblemSpec",
    "RefSample",
    "RobotLimits",
    "RobustNMPC",
    "barycentric_interpolate",
    "barycentric_weights",
    "build_controller",
    "build_reference",
    "controller_from_settings",
    "differentiation_matrix",
    "interpolation_matrix",
    "lgl",
    "lgl_nodes",
    "lgl_weights",
    "problem_spec",
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
