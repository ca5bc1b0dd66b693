"""Trajectory-tracking controllers (paper §3): LGL pseudospectral NMPC, linear MPC,
open loop, the path-following NMPC; the reference paths; LGL helpers."""

from .base import Controller, ControlOutput
from .collocation import ProblemSpec
from .factory import build_controller, controller_from_settings, problem_spec
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
from .nmpc import NMPC, OptiNMPC
from .open_loop import OpenLoopController
from .pathfollow import PathFollowingNMPC, PathFollowingSpec
from .reference import CircleReference, FigureEightReference, LineReference, RefSample, build_reference

__all__ = [
    "NMPC",
    "CircleReference",
    "ControlOutput",
    "Controller",
    "FigureEightReference",
    "LineReference",
    "LinearMPC",
    "OpenLoopController",
    "OptiNMPC",
    "PathFollowingNMPC",
    "PathFollowingSpec",
    "ProblemSpec",
    "RefSample",
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
]
