"""Numbers and helpers the control tests share: the default problem's nominal radii, the offset start,
the left-wheel puncture schedule, a config with a generous time budget."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ftc_mj.config import RunConfig, from_sections, run_context
from ftc_mj.control.pathfollow_spec import (
    PathFollowingSettings,
    PathFollowingSpec,
    RobotLimits,
    path_following_problem,
)
from ftc_mj.control.spec import MPCSettings, ProblemSpec, tracking_problem

NOMINAL = (2.0, 2.0)
"""Nominal wheel radii (m) of the default robot."""
OFFSET_POSE = (0.0, -5.0, 0.0)
"""Start 5 m outside the default circle (m, m, rad)."""
OMEGA_MAX = math.radians(1000.0)
"""The default wheel-rate bound (rad/s)."""


def left_step(t: float) -> tuple[float, float]:
    """50 % left-wheel puncture at t = 10 s: radii (m) at time ``t`` (s)."""
    return (2.0, 1.0) if t >= 10.0 else (2.0, 2.0)


def cfg_with(**ctl) -> RunConfig:
    """Config with controller settings (``kind`` among them, default ``nmpc``); an MPC gets a generous time
    budget so that a loaded CI machine does not turn a slow solve into a (correctly counted) fallback. Budget
    handling: test_over_budget_falls_back."""
    budget = {} if ctl.get("kind") == "open-loop" else {"time_budget": 5.0}
    return from_sections(controller={**budget, **ctl})


def problem(**settings) -> ProblemSpec:
    """The tracking problem of the MPC settings ``settings`` (the others their defaults) in the default run's
    context (half track 1 m, ``omega_max`` 1000 deg/s, controller period 0.1 s)."""
    return tracking_problem(MPCSettings(**settings), run_context(RunConfig()))


def pf_spec(tracking: ProblemSpec, **fields) -> PathFollowingSpec:
    """The path-following problem of the default path-following settings at 10 m/s on the grid and robot of
    ``tracking`` (kept as it is: its bounds and rate penalty are the test's), without the robot's compliance
    and braking trade-off, with ``fields`` replaced."""
    spec = path_following_problem(tracking, PathFollowingSettings(max_lateral_accel=3.0), 10.0,
                                  RobotLimits(liftoff_accel=3.0, yaw_compliance=0.0, braking_trade=0.0))
    return dataclasses.replace(spec, problem=tracking, **fields)


def check_bounds(res) -> None:
    """Every applied and commanded wheel rate of a kinematic loop within ±omega_max."""
    assert np.max(np.abs(res.omega)) <= OMEGA_MAX + 1e-6
    for o in res.outputs:
        assert np.all(np.abs(o.omega) <= OMEGA_MAX + 1e-6)
