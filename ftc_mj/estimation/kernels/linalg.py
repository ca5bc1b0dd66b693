"""Small dense linear algebra for the compiled filter steps (matrices of at most 5x5).

Each routine reproduces numpy's LAPACK call bit for bit where the filters rely on it (Cholesky in
OpenBLAS's summation order, LU with LAPACK's pivoting) so that the compiled filters agree with the
numpy reference in ``tests/support/numpy_filters.py`` to round-off.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import njit
from .layout import EIG_FLOOR, LOG_2PI


@njit(cache=True, error_model="numpy")
def chol(A: np.ndarray, c: float, L: np.ndarray) -> None:
    """Lower Cholesky factor ``L`` of ``c·A`` (5x5), as numpy's LAPACK call: a non-positive pivot fills
    ``L`` with NaN; a NaN entry propagates without failing (OpenBLAS ``potf2`` semantics)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            L[i, j] = 0.0
    for j in range(n):
        # diagonal: dot product in OpenBLAS's order (two partial sums over blocks of four)
        t1 = 0.0
        t2 = 0.0
        k = 0
        while k + 4 <= j:
            t1 += L[j, k] * L[j, k] + L[j, k + 2] * L[j, k + 2]
            t2 += L[j, k + 1] * L[j, k + 1] + L[j, k + 3] * L[j, k + 3]
            k += 4
        while k < j:
            t1 += L[j, k] * L[j, k]
            k += 1
        ajj = c * A[j, j] - (t1 + t2)
        if ajj <= 0.0:
            for a in range(n):
                for b in range(n):
                    L[a, b] = np.nan
            return
        ajj = math.sqrt(ajj)
        L[j, j] = ajj
        r = 1.0 / ajj
        for i in range(j + 1, n):
            s = 0.0
            for k in range(j):
                s += L[i, k] * L[j, k]
            L[i, j] = (c * A[i, j] - s) * r


@njit(cache=True, error_model="numpy")
def lu(A: np.ndarray, LU: np.ndarray, piv: np.ndarray) -> None:
    """LU factors with partial pivoting (LAPACK ``getrf``: first largest pivot) of ``A`` (m, m)."""
    m = A.shape[0]
    for i in range(m):
        piv[i] = i
        for j in range(m):
            LU[i, j] = A[i, j]
    for k in range(m):
        p = k
        best = abs(LU[k, k])
        for i in range(k + 1, m):
            if abs(LU[i, k]) > best:
                best = abs(LU[i, k])
                p = i
        if p != k:
            for j in range(m):
                t = LU[k, j]
                LU[k, j] = LU[p, j]
                LU[p, j] = t
            t2 = piv[k]
            piv[k] = piv[p]
            piv[p] = t2
        d = LU[k, k]
        if d != 0.0:
            r = 1.0 / d
            for i in range(k + 1, m):
                LU[i, k] *= r
        for i in range(k + 1, m):
            f = LU[i, k]
            for j in range(k + 1, m):
                LU[i, j] -= f * LU[k, j]


@njit(cache=True, error_model="numpy")
def lu_solve(LU: np.ndarray, piv: np.ndarray, b: np.ndarray, x: np.ndarray) -> None:
    """Solve ``A x = b`` from the factors of :func:`lu`."""
    m = LU.shape[0]
    for i in range(m):
        s = b[piv[i]]
        for j in range(i):
            s -= LU[i, j] * x[j]
        x[i] = s
    for i in range(m - 1, -1, -1):
        s = x[i]
        for j in range(i + 1, m):
            s -= LU[i, j] * x[j]
        x[i] = s / LU[i, i]


@njit(cache=True, error_model="numpy")
def gaussian(y: np.ndarray, S: np.ndarray, SI: np.ndarray) -> tuple[float, float]:
    """``S⁻¹`` (into ``SI``), NIS ``yᵀS⁻¹y`` and log N(y; 0, S) for one innovation (as the numpy reference's
    ``gaussian_terms``)."""
    m = y.shape[0]
    if m == 1:
        s = S[0, 0]
        SI[0, 0] = 1.0 / s
        nis = y[0] * y[0] / s
        logdet = math.log(s)
    else:
        LU = np.empty((m, m))
        piv = np.empty(m, np.int64)
        lu(S, LU, piv)
        e = np.zeros(m)
        col = np.empty(m)
        for j in range(m):
            e[j] = 1.0
            lu_solve(LU, piv, e, col)
            e[j] = 0.0
            for i in range(m):
                SI[i, j] = col[i]
        nis = 0.0
        for i in range(m):
            for j in range(m):
                nis += y[i] * SI[i, j] * y[j]
        logdet = 0.0
        for i in range(m):
            logdet += math.log(abs(LU[i, i]))
    return nis, -0.5 * (nis + logdet + m * LOG_2PI)


@njit(cache=True, error_model="numpy")
def eig_floor(P: np.ndarray, out: np.ndarray) -> None:
    """Nearest symmetric matrix with eigenvalues ≥ ``EIG_FLOOR`` (non-finite entries → 0), as the
    numpy reference, into ``out`` (may be ``P``)."""
    n = P.shape[0]
    A = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            a = P[i, j] if math.isfinite(P[i, j]) else 0.0
            b = P[j, i] if math.isfinite(P[j, i]) else 0.0
            A[i, j] = 0.5 * (a + b)
    w, V = np.linalg.eigh(A)
    B = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += V[i, k] * max(w[k], EIG_FLOOR) * V[j, k]
            B[i, j] = s
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (B[i, j] + B[j, i])


@njit(cache=True, error_model="numpy")
def symmetrise(P: np.ndarray) -> None:
    """``P ← (P + Pᵀ)/2`` for each member, in place."""
    for j in range(P.shape[0]):
        for a in range(5):
            for b in range(a, 5):
                v = 0.5 * (P[j, a, b] + P[j, b, a])
                P[j, a, b] = v
                P[j, b, a] = v


@njit(cache=True, error_model="numpy")
def mat_mul(A: np.ndarray, B: np.ndarray, out: np.ndarray, transpose_b: bool = False) -> None:
    """``out = A B`` (``A Bᵀ`` with ``transpose_b``) for 5x5 matrices (sums in index order)."""
    for a in range(5):
        for b in range(5):
            s = 0.0
            for k in range(5):
                s += A[a, k] * (B[b, k] if transpose_b else B[k, b])
            out[a, b] = s
