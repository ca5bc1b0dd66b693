"""KinematicPlant: the ideal plant integrates the kinematic model exactly, with the Plant interface."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.model.kinematics import inverse_rates
from ftc_mj.plant import KinematicPlant
from ftc_mj.wiring.plant import build_plant


def kcfg() -> RunConfig:
    cfg = RunConfig()
    cfg.plant.kind = "kinematic"
    return cfg


def test_full_circle_closes_exactly() -> None:
    p = build_plant(kcfg())
    assert isinstance(p, KinematicPlant)
    wR, wL = inverse_rates(10.0, 0.2, 2.0, 2.0, 1.0)
    p.set_command(wR, wL)
    n = 31416  # 31.416 s at 1 ms: one lap is 2 pi / 0.2 = 31.4159 s
    p.advance(n)
    tr = p.truth()
    assert tr.psi == pytest.approx(0.2 * n * 1e-3)
    # the pose lies exactly on the circle of radius 50 centred at (0, 50)
    assert math.hypot(tr.x, tr.y - 50.0) == pytest.approx(50.0, abs=1e-9)
    assert tr.v == pytest.approx(10.0) and tr.yaw_rate == pytest.approx(0.2)


def test_bulk_arc_equals_stepwise_rk4() -> None:
    cfg = kcfg()
    cfg.faults.left = [(0.5, 2.0), (1.5, 1.0)]  # ramp: RK4 per step inside, arcs outside
    a = build_plant(cfg)
    b = build_plant(cfg)
    for p in (a, b):
        p.set_command(3.0, 2.5)
    a.advance(2000)
    for _ in range(2000):
        b.advance(1)
    ta, tb = a.truth(), b.truth()
    assert (ta.x, ta.y, ta.psi) == pytest.approx((tb.x, tb.y, tb.psi), abs=1e-9)
    assert ta.R_L == pytest.approx(1.0)


def test_ramp_matches_fine_reference() -> None:
    """RK4 at 1 ms against a 0.1 ms Euler reference of the same model (radius held per 1 ms step)."""
    cfg = kcfg()
    cfg.faults.left = [(0.0, 2.0), (2.0, 1.0)]
    p = build_plant(cfg)
    p.set_command(2.0, 2.0)
    p.advance(2000)
    tr = p.truth()
    x = np.zeros(3)
    for k in range(2000):
        RL = 2.0 - 0.5 * k * 1e-3
        for _ in range(10):
            V = 0.5 * (2.0 * 2.0 + RL * 2.0)
            w = (2.0 * 2.0 - RL * 2.0) / 2.0
            x += 1e-4 * np.array([V * math.cos(x[2]), V * math.sin(x[2]), w])
    assert (tr.x, tr.y, tr.psi) == pytest.approx(tuple(x), abs=2e-3)


def test_interface_parity() -> None:
    cfg = kcfg()
    cfg.plant.initial_pose = (1.0, 2.0, 0.3)
    cfg.faults.right = [(0.0, 1.5)]
    p = build_plant(cfg)
    tr = p.truth()
    assert (tr.x, tr.y, tr.psi, tr.R_R, tr.R_L, tr.flags) == (1.0, 2.0, 0.3, 1.5, 2.0, 0)
    p.set_command(100.0, float("nan"))
    assert p.command == (p.omega_max, 0.0)
    p.set_wheel_radius("left", 1.0, reseat=False)
    assert p.radii == (1.5, 1.0)
    p.advance(10)
    assert p.time == pytest.approx(0.01)
    p.reset()
    assert p.time == 0.0 and p.radii == (1.5, 2.0)
