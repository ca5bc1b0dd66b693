"""Radius feedback policies (DESIGN §3, §9): what the controller's model is handed."""

from __future__ import annotations

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.estimation.base import FilterOutput
from ftc_mj.sim.reconfig import RadiusFeedback


def _out(rR: float, rL: float, sigma: float) -> FilterOutput:
    P = np.diag([0.1, 0.1, 0.01, sigma**2, sigma**2])
    return FilterOutput(x=np.array([0, 0, 0, rR, rL]), P=P, innovation=np.zeros(1), S=np.eye(1), nis=0.0,
                        speed_innovation=0.0, speed_innovation_std=1.0)


def test_feedback_off_is_nominal() -> None:
    fb = RadiusFeedback(load_config("scenario2", {"feedback": False}))
    np.testing.assert_array_equal(fb.radii(_out(2.0, 1.0, 0.01), True, True), [2.0, 2.0])


def test_direct_is_latest_estimate_with_positive_floor() -> None:
    cfg = load_config("scenario2")
    fb = RadiusFeedback(cfg)
    np.testing.assert_array_equal(fb.radii(_out(2.1, 1.0, 0.5), False, True), [2.1, 1.0])
    np.testing.assert_array_equal(fb.radii(_out(2.1, -0.3, 0.5), False, True), [2.1, cfg.estimator.min_radius])
    # a non-finite estimate keeps the previous radii
    np.testing.assert_array_equal(fb.radii(_out(np.nan, 1.0, 0.5), False, True), [2.1, cfg.estimator.min_radius])


def test_safe_policy_gates_bounds_and_rate_limits() -> None:
    cfg = load_config("scenario2", {"reconfig.policy": "safe"})
    fb = RadiusFeedback(cfg)
    step = cfg.reconfig.max_rate / cfg.controller.rate
    # not isolated yet: nominal, whatever the estimate
    np.testing.assert_array_equal(fb.radii(_out(2.0, 1.0, 0.01), False, True), [2.0, 2.0])
    # isolated but uncertain: still nominal
    np.testing.assert_array_equal(fb.radii(_out(2.0, 1.0, 0.5), True, True), [2.0, 2.0])
    # isolated and confident: moves towards the estimate at max_rate, clamped to [min_radius, nominal]
    r = fb.radii(_out(2.4, 1.0, 0.01), True, True)
    np.testing.assert_allclose(r, [2.0, 2.0 - step])
    for _ in range(200):
        r = fb.radii(_out(2.4, 1.0, 0.01), True, True)
    np.testing.assert_allclose(r, [2.0, 1.0])
    # filter divergence: back towards nominal, rate-limited
    np.testing.assert_allclose(fb.radii(_out(2.0, 1.0, 0.01), True, False), [2.0, 1.0 + step])
