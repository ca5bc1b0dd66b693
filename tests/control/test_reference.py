"""Reference paths: geometry, time law, consistency of heading and yaw rate."""

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.control.reference import CircleReference, FigureEightReference, LineReference, path_errors, project
from ftc_mj.wiring.control import build_reference


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


# ------------------------------------------------------------------ arc-length parametrisation
PATHS = {
    "circle-ccw": lambda: CircleReference(20.0, 5.0, "ccw", (3.0, -2.0, 0.7)),
    "circle-cw": lambda: CircleReference(20.0, 5.0, "cw", (3.0, -2.0, 0.7)),
    "line": lambda: LineReference(4.0, (1.0, 2.0, -0.4)),
    "figure8": lambda: FigureEightReference(15.0, 3.0, "ccw", (0.0, 0.0, 0.3)),
}


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_circle_geometry_is_the_analytic_arc(direction: str) -> None:
    """Arc length s from the pose (x0, y0, psi0) on a circle of radius R turning with sign σ: position
    p0 + σR (sin(psi0 + σs/R) − sin psi0, cos psi0 − cos(psi0 + σs/R)), heading psi0 + σs/R, curvature σ/R."""
    x0, y0, p0, R = 3.0, -2.0, 0.7, 20.0
    sg = 1.0 if direction == "ccw" else -1.0
    path = CircleReference(R, 5.0, direction, (x0, y0, p0))
    s = np.linspace(0.0, 3 * 2 * np.pi * R, 997)  # three laps: the heading keeps growing (unwrapped)
    g = path.geometry(s)
    np.testing.assert_allclose(g.x, x0 + sg * R * (np.sin(p0 + sg * s / R) - np.sin(p0)), atol=1e-9)
    np.testing.assert_allclose(g.y, y0 + sg * R * (np.cos(p0) - np.cos(p0 + sg * s / R)), atol=1e-9)
    np.testing.assert_allclose(g.heading, p0 + sg * s / R, atol=1e-12)
    np.testing.assert_allclose(g.curvature, sg / R)
    assert path.length == pytest.approx(2 * np.pi * R)


def test_line_and_figure_eight_geometry_analytic() -> None:
    line = LineReference(4.0, (1.0, 2.0, -0.4))
    g = line.geometry(np.array([0.0, 10.0]))
    np.testing.assert_allclose([g.x[1], g.y[1]], [1.0 + 10 * np.cos(-0.4), 2.0 + 10 * np.sin(-0.4)], atol=1e-12)
    np.testing.assert_allclose(g.heading, -0.4)
    np.testing.assert_allclose(g.curvature, 0.0)
    R = 15.0
    f8 = FigureEightReference(R, 3.0)  # pose at the origin heading +x: lobe 1 centred (0, R), lobe 2 (0, -R)
    L = 2 * np.pi * R
    g = f8.geometry(np.array([L / 4, L / 2, L, 1.5 * L, 2 * L, 2 * L + L / 4]))
    np.testing.assert_allclose(g.x, [R, 0, 0, 0, 0, R], atol=1e-9)
    np.testing.assert_allclose(g.y, [R, 2 * R, 0, -2 * R, 0, R], atol=1e-9)
    np.testing.assert_allclose(g.heading, [np.pi / 2, np.pi, 2 * np.pi, np.pi, 0.0, np.pi / 2], atol=1e-9)
    s = np.linspace(0.0, 2 * L, 4001)[1:-1]
    k = f8.geometry(s).curvature
    np.testing.assert_allclose(k[s < L - 1e-9], 1.0 / R)
    np.testing.assert_allclose(k[s > L + 1e-9], -1.0 / R)
    assert f8.length == pytest.approx(2 * L)


@pytest.mark.parametrize("name", sorted(PATHS))
def test_geometry_is_an_arc_length_parametrisation(name: str) -> None:
    """|d(x, y)/ds| = 1, the tangent's angle is the heading and dθ/ds the curvature, by central differences
    with h = 1 mm (truncation h² κ² / 6 < 1e-8 for κ ≤ 1/15 m; round-off ~1e-16 · 100 m / h = 1e-11);
    the heading is continuous."""
    path = PATHS[name]()
    h = 1e-3
    s = np.linspace(0.5, 400.0, 3001)
    s = s[np.abs(np.mod(s, 2 * np.pi * 15.0)) > 2 * h] if name == "figure8" else s  # not across the lobe switch
    gp, gm, g = path.geometry(s + h), path.geometry(s - h), path.geometry(s)
    dx, dy = (gp.x - gm.x) / (2 * h), (gp.y - gm.y) / (2 * h)
    np.testing.assert_allclose(np.hypot(dx, dy), 1.0, atol=1e-8)
    np.testing.assert_allclose(np.cos(g.heading), dx, atol=1e-8)
    np.testing.assert_allclose(np.sin(g.heading), dy, atol=1e-8)
    np.testing.assert_allclose((gp.heading - gm.heading) / (2 * h), g.curvature, atol=1e-8)
    fine = path.geometry(np.linspace(0.0, 400.0, 400001))
    assert np.max(np.abs(np.diff(fine.heading))) < 1e-3 * 0.07 + 1e-12  # Δs κ_max


@pytest.mark.parametrize("name", sorted(PATHS))
def test_casadi_geometry_equals_numpy(name: str) -> None:
    """The same ``geometry`` lines evaluated symbolically (what the NLP optimises over) and numerically."""
    import casadi as ca

    path = PATHS[name]()
    s = np.linspace(0.0, 300.0, 61)
    sym = ca.SX.sym("s", s.size)
    f = ca.Function("g", [sym], list(path.geometry(sym, ca)))
    for a, b in zip(f(s), path.geometry(s), strict=True):
        np.testing.assert_allclose(np.asarray(a).ravel(), b, atol=1e-12)


@pytest.mark.parametrize("name", sorted(PATHS))
def test_time_law_is_the_path_at_speed_times_t(name: str) -> None:
    path = PATHS[name]()
    t = np.linspace(0.0, 60.0, 601)
    r, g = path.at(t), path.geometry(path.speed * t)
    for a, b in ((r.x, g.x), (r.y, g.y), (r.psi, g.heading), (r.psidot, path.speed * g.curvature)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(r.V, path.speed)


@pytest.mark.parametrize("name", sorted(PATHS))
def test_projection_recovers_the_foot_point(name: str) -> None:
    """A point d metres along the left normal of the path point at s* projects back to s* (Newton on the lag
    error, to 1e-9 m) with contouring error d and lag error 0; the search starts 3.13 m away from s*."""
    path = PATHS[name]()
    for s_star, d in ((37.0, 0.8), (120.0, -2.5), (200.0, 0.0)):
        g = path.geometry(np.array([s_star]))
        x = g.x[0] - d * np.sin(g.heading[0])
        y = g.y[0] + d * np.cos(g.heading[0])
        s = project(path, x, y, s_star + 3.13, 20.0)  # off the 0.5 m search grid: Newton must finish
        assert s == pytest.approx(s_star, abs=1e-9)
        ec, el = path_errors(path, np.array([x]), np.array([y]), np.array([s]))
        assert ec[0] == pytest.approx(d, abs=1e-9) and el[0] == pytest.approx(0.0, abs=1e-9)
