"""Legendre–Gauss–Lobatto (LGL) nodes, weights, differentiation and barycentric interpolation.

All quantities live on the reference interval ``tau ∈ [-1, 1]``; map to a horizon
``[t0, tf]`` with ``t = t0 + (tau + 1) (tf - t0) / 2`` (time derivatives scale by ``2 / (tf - t0)``,
integrals by ``(tf - t0) / 2``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def _legendre(n: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(P_n(x), P_{n-1}(x))`` by the three-term recurrence."""
    p_prev = np.ones_like(x)
    if n == 0:
        return p_prev, np.zeros_like(x)
    p = x.copy()
    for k in range(2, n + 1):
        p_prev, p = p, ((2 * k - 1) * x * p - (k - 1) * p_prev) / k
    return p, p_prev


@lru_cache(maxsize=32)
def _lgl_cached(n: int) -> tuple[np.ndarray, np.ndarray]:
    if n < 2:
        raise ValueError("LGL needs at least 2 nodes")
    m = n - 1  # polynomial degree P_m; interior nodes are the roots of P_m'
    # Chebyshev–Gauss–Lobatto initial guess, then Newton on (1 - x^2) P_m'(x) = 0 in the form used
    # by Greg von Winckel's lglnodes: x <- x - (x P_m - P_{m-1}) / (n P_m).
    x = -np.cos(np.pi * np.arange(n) / m)
    for _ in range(100):
        p, p_prev = _legendre(m, x)
        dx = (x * p - p_prev) / (n * p)
        x = x - dx
        if np.max(np.abs(dx)) < 1e-15:
            break
    x[0], x[-1] = -1.0, 1.0
    p, _ = _legendre(m, x)
    w = 2.0 / (m * n * p**2)
    return x, w


def lgl_nodes(n: int) -> np.ndarray:
    """The ``n`` LGL nodes on [-1, 1], ascending (−1 and 1 included)."""
    return _lgl_cached(n)[0].copy()


def lgl_weights(n: int) -> np.ndarray:
    """Gauss–Lobatto quadrature weights for the ``n`` nodes (exact for degree ≤ 2n − 3)."""
    return _lgl_cached(n)[1].copy()


def barycentric_weights(nodes: np.ndarray) -> np.ndarray:
    """Barycentric weights ``1 / prod_{k≠j}(x_j − x_k)``, normalised to max |w| = 1."""
    x = np.asarray(nodes, dtype=float)
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    # product of many O(1) numbers: work in logs to avoid under/overflow for large n
    sign = np.prod(np.sign(diff), axis=1)
    logw = -np.sum(np.log(np.abs(diff)), axis=1)
    w = sign * np.exp(logw - logw.max())
    return w


def differentiation_matrix(nodes: np.ndarray) -> np.ndarray:
    """``D`` with ``(D f)(x_i) = p'(x_i)`` for the interpolant ``p`` of ``f`` at the nodes.

    Off-diagonal entries from the barycentric weights, diagonal by the negative-sum trick
    (rows of ``D`` annihilate constants exactly).
    """
    x = np.asarray(nodes, dtype=float)
    w = barycentric_weights(x)
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    D = (w[None, :] / w[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


def lgl(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(nodes, weights, D)`` for ``n`` LGL nodes."""
    x = lgl_nodes(n)
    return x, lgl_weights(n), differentiation_matrix(x)


def barycentric_interpolate(
    nodes: np.ndarray, values: np.ndarray, x_new: np.ndarray, weights: np.ndarray | None = None
) -> np.ndarray:
    """Evaluate the Lagrange interpolant through ``(nodes, values)`` at ``x_new`` (2nd barycentric form).

    ``values`` may be (n,) or (n, k) (columns interpolated independently); returns (m,) or (m, k).
    Exact at the nodes. Intended for points inside [nodes[0], nodes[-1]] — extrapolation of a
    high-degree interpolant is unstable, so callers should clamp.
    """
    x = np.asarray(nodes, dtype=float)
    f = np.asarray(values, dtype=float)
    xn = np.atleast_1d(np.asarray(x_new, dtype=float))
    w = barycentric_weights(x) if weights is None else np.asarray(weights, dtype=float)
    diff = xn[:, None] - x[None, :]
    exact = diff == 0.0
    diff[exact] = 1.0
    C = w[None, :] / diff
    C /= C.sum(axis=1, keepdims=True)
    rows, cols = np.nonzero(exact)
    C[rows, :] = 0.0
    C[rows, cols] = 1.0
    return C @ f


def interpolation_matrix(nodes: np.ndarray, x_new: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Matrix ``C`` (m, n) with ``C @ values`` = the interpolant at ``x_new``."""
    n = len(nodes)
    return barycentric_interpolate(nodes, np.eye(n), x_new, weights)
