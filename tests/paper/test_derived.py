"""Report metrics derived from a trace: settling, innovation peaks, IMM mode delays, command
switching, reference feasibility, onsets after the end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.config import OMEGA_MAX, load_config
from ftc_mj.paper.claims.thresholds import PEAK_Z
from ftc_mj.paper.derived import (
    command_switching,
    derived_metrics,
    innovation_peak_z,
    mode_delays,
    reference_feasibility,
    required_wheel_rate,
    settle_delay,
)


def test_settle_delay() -> None:
    t = np.arange(0, 20, 0.01)
    err = np.where(t < 12.0, 1.0, 0.01)
    assert settle_delay(t, err, 10.0) == pytest.approx(2.0, abs=0.011)
    assert settle_delay(t, np.ones_like(t), 10.0) is None
    # a transient dip below the tolerance that does not hold does not count
    err2 = np.where((t > 11) & (t < 11.2), 0.0, err)
    assert settle_delay(t, err2, 10.0) == pytest.approx(2.0, abs=0.011)


def test_innovation_peak_z_separates_a_step_from_noise() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0, 20, 0.01)
    inn = rng.normal(0, 0.5, t.size)
    sd = np.full(t.size, 0.5)
    z_noise = innovation_peak_z(t, inn, sd, 10.0)
    inn_fault = inn + np.where((t >= 10) & (t < 10.5), 2.5, 0.0)
    z_fault = innovation_peak_z(t, inn_fault, sd, 10.0)
    assert z_noise is not None and z_fault is not None
    assert z_noise < PEAK_Z < z_fault


def test_mode_delays() -> None:
    t = np.arange(0, 20, 0.01)
    p = np.zeros((t.size, 4))
    p[:, 0] = 1.0
    late = t >= 10.3
    p[late, 0], p[late, 2] = 0.0, 1.0
    delays, frac = mode_delays(t, p, [(0.0, 1), (10.0, 3)])
    assert delays[0] == pytest.approx(0.0)
    assert delays[1] == pytest.approx(0.3, abs=0.011)
    assert frac == pytest.approx(1 - 0.3 / 20, abs=0.002)


def test_command_switching_counts_bang_bang() -> None:
    t = np.arange(0, 10, 0.01)
    wmax = 17.45
    square = np.where((np.arange(t.size) // 50) % 2 == 0, wmax, -wmax)  # switches every 0.5 s
    rev, sw = command_switching(t, square, wmax)
    assert sw == pytest.approx(2.0, rel=0.05)
    assert rev == pytest.approx(2.0, rel=0.15)  # n steps give n - 1 reversals
    smooth = np.full(t.size, 5.0)
    assert command_switching(t, smooth, wmax) == (0.0, 0.0)


def test_required_wheel_rate_is_the_inverse_kinematics() -> None:
    # V = 10 m/s, ψ̇ = 0.2 rad/s, b = 1 m: ω_R = 10.2 / R_R, ω_L = 9.8 / R_L
    req = required_wheel_rate(np.array([10.0]), np.array([0.2]), np.array([2.0]), np.array([0.1]), 1.0)
    assert req[0] == pytest.approx(98.0)
    req = required_wheel_rate(np.array([10.0]), np.array([0.2]), np.array([1.0]), np.array([1.0]), 1.0)
    assert req[0] == pytest.approx(10.2)


def _trace(R_L_end: float, duration: float = 40.0) -> dict[str, np.ndarray]:
    t = np.arange(0.0, duration, 0.01)
    R_L = np.where(t < 10.0, 2.0, np.maximum(2.0 - 0.1 * (t - 10.0), R_L_end))
    return {"t": t, "R_R": np.full_like(t, 2.0), "R_L": R_L}


def test_reference_feasibility_after_the_fault() -> None:
    # scenario 4's ramp reaches 0.1 m: the circle needs ω_L = 9.8 / 0.1 = 98 rad/s > 17.45 rad/s
    cfg = load_config("scenario4")
    m = reference_feasibility(cfg, _trace(0.1), 15.0)
    assert m["reference_feasible_recovered"] is False
    assert m["reference_omega_required_recovered"] == pytest.approx(98.0, rel=1e-6)
    # stopping the ramp at 1 m keeps it feasible (9.8 rad/s)
    m = reference_feasibility(cfg, _trace(1.0), 15.0)
    assert m["reference_feasible_recovered"] is True
    assert m["reference_omega_required_recovered"] < OMEGA_MAX
    assert reference_feasibility(cfg, _trace(1.0), None) == {}


def test_onsets_after_the_end_are_counted_and_not_used() -> None:
    t = np.arange(0.0, 8.0, 0.01)
    tr = {"t": t, "R_R": np.full_like(t, 2.0), "R_L": np.full_like(t, 2.0), "R_R_hat": np.full_like(t, 2.0),
          "R_L_hat": np.full_like(t, 2.0), "innovation": np.zeros_like(t), "innovation_std": np.full_like(t, 0.5)}
    m = derived_metrics(tr, "scenario3", {"left": 5.0, "right": 10.0})
    assert m["onsets_after_end"] == 1
    assert "innovation_peak_z_1" in m and "innovation_peak_z_2" not in m
    assert math.isfinite(m["radius_rmse_L_after_fault"])
