"""Numbers and helpers the control tests share: the default problem's nominal radii, the offset start,
the left-wheel puncture schedule, a config with a generous time budget."""

from __future__ import annotations

import math

import numpy as np

from ftc_mj.config import RunConfig

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
    """Config with controller overrides; a generous time budget so that a loaded CI machine does not
    turn a slow solve into a (correctly counted) fallback. Budget handling: test_over_budget_falls_back."""
    cfg = RunConfig()
    cfg.controller.time_budget = 5.0
    for k, v in ctl.items():
        setattr(cfg.controller, k, v)
    return cfg


def check_bounds(res) -> None:
    """Every applied and commanded wheel rate of a kinematic loop within ±omega_max."""
    assert np.max(np.abs(res.omega)) <= OMEGA_MAX + 1e-6
    for o in res.outputs:
        assert np.all(np.abs(o.omega) <= OMEGA_MAX + 1e-6)
