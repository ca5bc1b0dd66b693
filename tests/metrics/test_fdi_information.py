"""The pose fixes' share of a change's information (:func:`ftc_mj.metrics.fdi.pose_information`) and what it
does to Lorden's bound: closed forms on hand-made traces."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.metrics.fdi import cumulative_kl, lorden_delays
from ftc_mj.sim.record import build_record

SIGMA_P = 0.1  # m: the fixes' position σ; their heading σ is then 0.1 rad (σ_p per metre)
N, K_ON, FIX_EVERY = 400, 200, 10


def _setup(pose: bool):
    data = {"sensors": {"position_sigma": SIGMA_P, "position_rate": 10.0}} if pose else {}
    return build_record(RunConfig.model_validate(data)).setup


def _straight(setup, eps: float) -> dict[str, np.ndarray]:
    """Straight ahead at ω = 5 rad/s on both wheels, the speed and yaw rate exactly the nominal model's (no
    speed or gyro information), the true position falling behind the dead reckoning by ``eps`` of the speed
    from the onset row on; a fix every 10 rows."""
    dt, R0 = setup.dt, setup.nominal_radius
    t = np.arange(N) * dt
    V0 = R0 * 5.0
    k = np.arange(N)
    x = V0 * dt * np.where(k <= K_ON, k, K_ON + (1.0 - eps) * (k - K_ON))
    fix = np.where(k % FIX_EVERY == 0, x, np.nan)
    return {"t": t, "v": np.full(N, V0), "yaw_rate": np.zeros(N), "omega_R": np.full(N, 5.0),
            "omega_L": np.full(N, 5.0), "x": x, "y": np.zeros(N), "psi": np.zeros(N), "x_meas": fix}


def test_a_pose_only_change_carries_the_fixes_information_in_closed_form() -> None:
    """The fixes' mean leaves the dead reckoning by δ_i = ε V0 i dt at row i after the onset: each fix adds
    ½ δ_i² / σ_p², nothing between fixes; the speed and yaw rate carry none. Without the pose sensor the
    same trace has no information at all, so its bound is never reached."""
    setup = _setup(pose=True)
    eps = 0.05
    trace = _straight(setup, eps)
    K = np.asarray(cumulative_kl(setup, trace, trace["t"][K_ON]))
    i = np.arange(K.size)
    delta = eps * setup.nominal_radius * 5.0 * i * setup.dt
    expected = np.cumsum(np.where((K_ON + i) % FIX_EVERY == 0, 0.5 * delta**2 / SIGMA_P**2, 0.0))
    assert K == pytest.approx(expected, rel=1e-9, abs=1e-12)
    plain = np.asarray(cumulative_kl(_setup(pose=False), trace, trace["t"][K_ON]))
    assert np.all(plain == 0.0)
    arl0 = np.array([100.0])
    assert np.isinf(lorden_delays(plain, arl0, setup.dt)[0]) and np.isfinite(lorden_delays(K, arl0, setup.dt)[0])


def test_a_turn_through_the_heading_wrap_carries_no_information() -> None:
    """A healthy left turn whose true heading wraps from +π to −π and whose pose is exactly the dead
    reckoning: the heading residual is taken modulo 2π, so the information is 0 (to round-off) instead of
    ½ (2π / 0.1)² ≈ 1974 nats at every fix after the wrap."""
    setup = _setup(pose=True)
    dt, R0, b = setup.dt, setup.nominal_radius, setup.model.b
    wR, wL = 5.5, 4.5
    V0, yr0 = R0 * (wR + wL) / 2.0, R0 * (wR - wL) / (2.0 * b)
    psi_unwrapped = np.pi - 1.0 + yr0 * dt * np.arange(N)
    x = np.concatenate(([0.0], np.cumsum(V0 * dt * np.cos(psi_unwrapped[:-1]))))
    y = np.concatenate(([0.0], np.cumsum(V0 * dt * np.sin(psi_unwrapped[:-1]))))
    psi = (psi_unwrapped + np.pi) % (2.0 * np.pi) - np.pi
    assert np.any(np.diff(psi[50:]) < -np.pi)  # the trace wraps after the onset row
    trace = {"t": np.arange(N) * dt, "v": np.full(N, V0), "yaw_rate": np.full(N, yr0), "omega_R": np.full(N, wR),
             "omega_L": np.full(N, wL), "x": x, "y": y, "psi": psi,
             "x_meas": np.where(np.arange(N) % FIX_EVERY == 0, x, np.nan)}
    K = np.asarray(cumulative_kl(setup, trace, trace["t"][50]))
    assert K.size > 0 and K[-1] == pytest.approx(0.0, abs=1e-12)
