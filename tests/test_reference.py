"""Reference paths: geometry, time law, consistency of heading and yaw rate."""

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.control.reference import CircleReference, FigureEightReference, LineReference, build_reference


def test_default_circle() -> None:
    ref = build_reference(RunConfig())
    assert isinstance(ref, CircleReference)
    np.testing.assert_allclose(ref.center, [0.0, 50.0])
    s = ref.at(0.0)
    np.testing.assert_allclose([s.x, s.y, s.psi], [0, 0, 0], atol=1e-12)
    t = np.linspace(0, 40, 401)
    r = ref.at(t)
    np.testing.assert_allclose(r.x, 50 * np.sin(0.2 * t), atol=1e-9)
    np.testing.assert_allclose(r.y, 50 * (1 - np.cos(0.2 * t)), atol=1e-9)
    np.testing.assert_allclose(r.psi, 0.2 * t, atol=1e-12)  # unwrapped
    np.testing.assert_allclose(r.V, 10.0)
    np.testing.assert_allclose(r.psidot, 0.2)
    np.testing.assert_allclose(ref.cross_track(r.x, r.y), 0, atol=1e-9)
    assert ref.cross_track(0.0, 1.0) > 0  # left of travel (inside) is positive
    np.testing.assert_allclose(ref.cross_track(0.0, -5.0), -5.0)
    assert ref.path_points(50).shape == (50, 2)


def _check_consistent(ref, t: np.ndarray) -> None:
    r = ref.at(t)
    dt = t[1] - t[0]
    vx = np.gradient(r.x, dt)
    vy = np.gradient(r.y, dt)
    sl = slice(2, -2)
    np.testing.assert_allclose(vx[sl], (r.V * np.cos(r.psi))[sl], atol=2e-3 * ref.speed)
    np.testing.assert_allclose(vy[sl], (r.V * np.sin(r.psi))[sl], atol=2e-3 * ref.speed)
    assert np.max(np.abs(np.diff(r.psi))) < 10 * dt  # continuous heading
    inner = np.abs(np.gradient(r.psidot, dt)) < 1e-9
    np.testing.assert_allclose(np.gradient(r.psi, dt)[inner][2:-2], r.psidot[inner][2:-2], atol=1e-6)


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_circle_direction_and_pose(direction: str) -> None:
    pose = (3.0, -2.0, 0.7)
    ref = CircleReference(20.0, 5.0, direction, pose)
    s = ref.at(0.0)
    np.testing.assert_allclose([s.x, s.y, s.psi], pose, atol=1e-12)
    assert np.sign(ref.omega) == (1 if direction == "ccw" else -1)
    _check_consistent(ref, np.linspace(0, 30, 30001))
    # left-of-travel point has positive cross-track
    left = np.array(pose[:2]) + 0.5 * np.array([-np.sin(pose[2]), np.cos(pose[2])])
    assert ref.cross_track(*left) > 0


def test_line() -> None:
    ref = LineReference(2.0, (1.0, 1.0, np.pi / 2))
    r = ref.at(np.array([0.0, 1.0]))
    np.testing.assert_allclose(r.x, [1, 1], atol=1e-12)
    np.testing.assert_allclose(r.y, [1, 3])
    assert ref.cross_track(0.0, 2.0) > 0  # heading +y: left is -x
    _check_consistent(ref, np.linspace(0, 10, 1001))


def test_figure_eight() -> None:
    ref = FigureEightReference(10.0, 2.0)
    T = ref.period
    t = np.linspace(0, 2 * T, 40001)
    _check_consistent(ref, t)
    r = ref.at(np.array([0.0, T / 2, T]))
    np.testing.assert_allclose(r.x, 0, atol=1e-9)
    np.testing.assert_allclose(r.y, 0, atol=1e-9)
    np.testing.assert_allclose(r.psi, [0, 2 * np.pi, 0], atol=1e-9)
    rr = ref.at(t)
    np.testing.assert_allclose(ref.cross_track(rr.x, rr.y), 0, atol=1e-9)
    assert ref.at(T / 4).psidot > 0 and ref.at(3 * T / 4).psidot < 0
    cfg = RunConfig()
    cfg.reference.kind = "figure8"
    assert isinstance(build_reference(cfg), FigureEightReference)
    cfg.reference.kind = "line"
    assert isinstance(build_reference(cfg), LineReference)
