"""The change detectors' null model of the physical robot (:mod:`ftc_mj.estimation.null_model`): relative to the
nominal radius and the sensor σ, one step behind the estimator, and white on a truth it describes."""

from __future__ import annotations

import numpy as np

from ftc_mj.estimation import Measurement
from ftc_mj.estimation.null_model import BLIND_RATIO, G, NullModel
from ftc_mj.model.kinematics import KinematicModel
from ftc_mj.wiring.decision import build_change_detectors, physical_null_model
from tests.estimation.filters import decision_cfg


def test_a_rescaled_robot_gets_the_same_rule() -> None:
    """Twice the radius at half the wheel rates (the same speed and yaw rate): the same demand in g, the slip σ
    the same fraction of the radius, and the same channels dropped for sensors of the same σ."""
    small, big = NullModel(R0=2.0, b=1.0, dt=0.01), NullModel(R0=4.0, b=1.0, dt=0.01)
    for u in (np.array([5.05, 4.95]), np.array([5.4, 4.6]), np.array([5.6, 4.3])):
        q = small.demand(u, np.array([2.0, 2.0]))
        assert q == big.demand(u / 2.0, np.array([4.0, 4.0]))
        assert small.slip_sigma(q) / 2.0 == big.slip_sigma(q) / 4.0
        for ch, sigma in (("speed", 0.5), ("yaw", 0.01)):
            assert small.drops(q, u, sigma, ch) == big.drops(q, u / 2.0, sigma * 1.0, ch)


def test_demand_in_g_and_dropping_against_the_sensor_sigma() -> None:
    """10 m/s at 0.4 rad/s is 4 m/s² of lateral acceleration; a channel is dropped exactly when its slip σ
    exceeds BLIND_RATIO sensor σ, so a precise gyro is dropped where a coarse speed sensor is kept."""
    nm = NullModel(R0=2.0, b=1.0, dt=0.01)
    u = np.array([(10.0 + 0.4) / 2.0, (10.0 - 0.4) / 2.0])
    q = nm.demand(u, np.array([2.0, 2.0]))
    assert abs(q - 4.0 / G) < 1e-12
    gain_yaw = np.hypot(*u) * 0.5
    assert nm.drops(q, u, 0.01, "yaw") == (nm.slip_sigma(q) * gain_yaw > BLIND_RATIO * 0.01)
    assert nm.drops(q, u, 0.01, "yaw") and not nm.drops(q, u, 0.5, "speed")
    assert not nm.drops(q, u, None, "yaw")


def test_the_physical_detectors_are_white_on_a_truth_measured_at_the_rates_of_its_instant() -> None:
    """The loop hands the detectors the rates measured one step before the measurement. On a fault-free truth
    whose speed and yaw rate are those of the rates of the same instant (the physical robot's; gentle turns,
    0.1 g) the physical detectors' whitened innovations are white with variance 1 less the slip floor's share
    (0.03 % of R0 per wheel at 0.1 g: 0.93 on the 0.01 rad/s gyro channel, 1.00 on the speed channel; 6000
    samples, standard error 0.018): within [0.85, 1.08], lag-1 correlation below 0.06."""
    cfg = decision_cfg("glr", 0.01)
    m = KinematicModel(b=1.0, dt=0.01)
    rng = np.random.default_rng(4)
    n = 6000
    t = np.arange(n) * 0.01
    u = np.stack([5.05 + 0.05 * np.sin(1.3 * t), 4.95 + 0.05 * np.sin(1.3 * t + 0.4)], axis=1)
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    det = build_change_detectors(cfg)
    assert physical_null_model(cfg) and det.null_model is not None  # the method's default
    E = []
    for k in range(n):
        x = m.step(x, u[k])
        z = Measurement(speed=float(m.speed(x, u[k])) + 0.5 * rng.normal(),
                        yaw_rate=float(m.yaw_rate(x, u[k])) + 0.01 * rng.normal())
        det.step(k * 0.01, u[k - 1] if k else u[0], z)
        if k >= 100:
            E.append(det.white.copy())
    E = np.array(E)
    assert np.all((E.var(axis=0) > 0.85) & (E.var(axis=0) < 1.08))
    lag1 = np.mean(E[1:] * E[:-1], axis=0) / np.mean(E * E, axis=0)
    assert np.all(np.abs(lag1) < 0.06)


def test_the_slip_knots_are_interpolated_as_numpy_interpolates() -> None:
    """:func:`~ftc_mj.estimation.null_model.interp_knots` (the filter step's scalar path) is ``np.interp`` bitwise:
    at the knots, one ulp either side of them, across and beyond their range, at ±inf and NaN."""
    from ftc_mj.estimation.null_model import SLIP_FRACTION, interp_knots

    qs, ss = zip(*SLIP_FRACTION, strict=True)
    knots = np.array(qs)
    rng = np.random.default_rng(5)
    grid = np.concatenate([rng.uniform(-0.2, 0.8, 20000), rng.exponential(0.3, 20000), knots,
                           np.nextafter(knots, 2.0), np.nextafter(knots, -2.0), [0.0, -0.0, np.inf, -np.inf, np.nan]])
    fast = np.array([interp_knots(float(q), SLIP_FRACTION) for q in grid])
    assert fast.tobytes() == np.interp(grid, qs, ss).tobytes()
