"""LGL nodes, quadrature, differentiation and barycentric interpolation."""

import numpy as np
import pytest

from ftc_mj.control.lgl import barycentric_interpolate, differentiation_matrix, lgl, lgl_nodes, lgl_weights


@pytest.mark.parametrize("n", [4, 7, 50])
def test_nodes_basic(n: int) -> None:
    x = lgl_nodes(n)
    assert x[0] == -1.0 and x[-1] == 1.0
    assert np.all(np.diff(x) > 0)
    np.testing.assert_allclose(x, -x[::-1], atol=1e-14)
    np.testing.assert_allclose(lgl_weights(n).sum(), 2.0, rtol=1e-13)


@pytest.mark.parametrize("n", [4, 7, 50])
def test_quadrature_exact(n: int) -> None:
    x, w, _ = lgl(n)
    for deg in range(0, 2 * n - 2):  # up to 2n - 3
        exact = 0.0 if deg % 2 else 2.0 / (deg + 1)
        np.testing.assert_allclose(w @ x**deg, exact, atol=1e-12, err_msg=f"deg {deg}")
    # degree 2n-2 is not integrated exactly (shows the test has teeth)
    if n <= 7:
        assert abs(w @ x ** (2 * n - 2) - 2.0 / (2 * n - 1)) > 1e-8


@pytest.mark.parametrize("n", [4, 7, 50])
def test_differentiation_exact(n: int) -> None:
    x, _, D = lgl(n)
    np.testing.assert_allclose(D @ np.ones(n), 0.0, atol=1e-12)
    # Legendre/Chebyshev-type basis stays well scaled at high degree: use T_k(x) = cos(k acos x)
    for k in range(1, n):
        f = np.cos(k * np.arccos(x))
        df = k * np.sin(k * np.arccos(x)) / np.sqrt(np.clip(1 - x**2, 1e-300, None))
        df[0] = (-1) ** (k + 1) * k**2
        df[-1] = k**2
        tol = 1e-9 * max(1.0, k**2)
        np.testing.assert_allclose(D @ f, df, atol=tol, err_msg=f"T_{k}")
    # monomials for the small cases
    if n <= 7:
        for deg in range(n):
            np.testing.assert_allclose(D @ x**deg, deg * x ** max(deg - 1, 0) * (deg > 0), atol=1e-11)


@pytest.mark.parametrize("n", [4, 7, 50])
def test_interpolation_exact(n: int) -> None:
    x = lgl_nodes(n)
    xq = np.linspace(-1, 1, 37)
    for k in range(n):
        f = np.cos(k * np.arccos(x))
        np.testing.assert_allclose(
            barycentric_interpolate(x, f, xq), np.cos(k * np.arccos(xq)), atol=1e-11, err_msg=f"T_{k}"
        )
    # exact at the nodes, and vector-valued
    vals = np.stack([x**2, np.sin(x)], axis=1)
    np.testing.assert_allclose(barycentric_interpolate(x, vals, x), vals, atol=0)


def test_differentiation_matrix_generic_nodes() -> None:
    x = np.array([-1.0, -0.2, 0.5, 1.0])
    D = differentiation_matrix(x)
    np.testing.assert_allclose(D @ x**3, 3 * x**2, atol=1e-12)
