"""Compiled (numba) cores of the FDI filters: one call per filter step.

Why: a filter step is a few hundred flops on 5x5 matrices; in numpy it is dominated by the overhead of
some fifty small array calls (~150-250 µs per UKF step, several times that for an IMM). Here the whole
step — predict, update, gating, symmetrising, divergence check, reset, covariance repair and, for an
IMM, mixing, mode probabilities and combination — is one compiled call on preallocated buffers.

What: the maths of :mod:`._core` (filterpy 2.0.0's, see there), written as loops over the members of a
bank of ``n`` filters (``n = 1`` for a single EKF/UKF). The numpy classes in :mod:`._core` stay the
reference implementation; ``tests/test_estimation_numba.py`` runs both on the same data and requires
agreement to round-off (the summation orders of BLAS and of these loops differ in the last bits).
The kinematic model is not typed here: the block between the ``GENERATED`` markers is generated from the
single CasADi definition in :mod:`ftc_mj.model.kinematics` (``python -m ftc_mj.estimation._codegen``;
a test fails while it is out of date).

State, constants and outputs of a bank live in one float64 buffer (offsets: :func:`layout`) and one
int64 buffer (indices ``C_*``), so that a step passes two arrays to the compiled code: numba's call
overhead grows with the number of array arguments. The Python classes expose views of these buffers.
Compiled code is cached on disk (``cache=True``, ``__pycache__`` next to this file); no fastmath, so
results are bit-for-bit reproducible from run to run. ``error_model="numpy"``: a division by zero gives
inf/NaN as in numpy (then a reset) instead of raising.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

SPEED, YAW, POS_X, POS_Y = 0, 1, 2, 3
"""Measurement channel codes, in the order the channels are stacked (speed, yaw rate, x, y)."""
LOG_2PI = math.log(2.0 * math.pi)
EIG_FLOOR = 1e-12
"""Smallest eigenvalue (in units of the state, squared) kept when repairing a covariance."""
MU_FLOOR = 1e-300
"""Smallest IMM mode probability (no mode is ever impossible, as filterpy's likelihood floor)."""
N_SIGMA = 11
"""Julier sigma points of the 5-state filter: 2n + 1."""

# int64 buffer: counters, then constants
C_RESETS, C_REJECTIONS, C_BAD_NIS, C_STEPS, C_DIV_STEPS, C_EKF, C_HYP, C_N = range(8)
N_COUNTERS = 8

# float scalars at ``layout(n).prm``
P_DT, P_B, P_KAPPA, P_GATE, P_DIV_NIS, P_INFLATION, P_MIN_RADIUS, P_R0, P_RAMP_STEP = range(9)
N_PRM = 9

Layout = namedtuple(
    "Layout",
    "X P mu loglik x Pc y S ulast Q P0 x0 rvar Pi pin_value pin keep reset_var ramp prm size",
)
"""Offsets into the float buffer of a bank of ``n`` filters (``size`` = its length)."""


@njit(cache=True, error_model="numpy")
def layout(n: int) -> Layout:
    """Offsets of the float buffer of ``n`` members: state, per-step outputs, then constants.

    ``X`` (n, 5) and ``P`` (n, 5, 5) member states; ``mu``/``loglik`` (n,) IMM mode probabilities and
    last accepted log-likelihoods; ``x``/``Pc`` combined estimate (IMM); ``y`` (4,) and ``S`` (4, 4)
    innovation and its covariance of the last step (first ``m`` channels); ``ulast`` last finite wheel
    rates; constants ``Q``, ``P0``, ``x0``, ``rvar`` (noise variance per channel code), IMM transition
    ``Pi`` (n, n) and hypothesis data, and the scalars ``prm`` (``P_*``).
    """
    o = 0
    X = o
    o += 5 * n
    P = o
    o += 25 * n
    mu = o
    o += n
    loglik = o
    o += n
    x = o
    o += 5
    Pc = o
    o += 25
    y = o
    o += 4
    S = o
    o += 16
    ulast = o
    o += 2
    Q = o
    o += 25
    P0 = o
    o += 25
    x0 = o
    o += 5
    rvar = o
    o += 4
    Pi = o
    o += n * n
    pin_value = o
    o += 2 * n
    pin = o
    o += 2 * n
    keep = o
    o += 25 * n
    reset_var = o
    o += 25 * n
    ramp = o
    o += n
    prm = o
    o += N_PRM
    return Layout(X, P, mu, loglik, x, Pc, y, S, ulast, Q, P0, x0, rvar, Pi, pin_value, pin, keep, reset_var,
                  ramp, prm, o)


# ---- BEGIN GENERATED: kinematic model (python -m ftc_mj.estimation._codegen; do not edit) ----
@njit(cache=True, error_model="numpy")
def _kin_step(a0, a1, a2, a3, out0):
    """CasADi Function 'step' at one point."""
    w0 = a0[0]
    w1 = a2
    w2 = 0.5
    w3 = a0[3]
    w4 = a1[0]
    w5 = (w3*w4)
    w6 = a0[4]
    w7 = a1[1]
    w8 = (w6*w7)
    w5 = (w5+w8)
    w2 = (w2*w5)
    w5 = a0[2]
    w8 = np.cos(w5)
    w8 = (w2*w8)
    w8 = (w1*w8)
    w0 = (w0+w8)
    o0_0 = w0
    w0 = a0[1]
    w8 = np.sin(w5)
    w2 = (w2*w8)
    w2 = (w1*w2)
    w0 = (w0+w2)
    o0_1 = w0
    w4 = (w3*w4)
    w7 = (w6*w7)
    w4 = (w4-w7)
    w7 = a3
    w7 = (2.0*w7)
    w4 = (w4/w7)
    w1 = (w1*w4)
    w5 = (w5+w1)
    o0_2 = w5
    o0_3 = w3
    o0_4 = w6
    out0[0] = o0_0
    out0[1] = o0_1
    out0[2] = o0_2
    out0[3] = o0_3
    out0[4] = o0_4


@njit(cache=True, error_model="numpy")
def _kin_F(a0, a1, a2, a3, out0):
    """CasADi Function 'F' at one point."""
    w0 = 1.0
    o0_0 = w0
    o0_1 = w0
    w1 = a2
    w2 = 0.5
    w3 = a0[3]
    w4 = a1[0]
    w3 = (w3*w4)
    w5 = a0[4]
    w6 = a1[1]
    w5 = (w5*w6)
    w3 = (w3+w5)
    w3 = (w2*w3)
    w5 = a0[2]
    w7 = np.sin(w5)
    w7 = (w3*w7)
    w7 = (w1*w7)
    w7 = (-w7)
    o0_2 = w7
    w7 = np.cos(w5)
    w3 = (w3*w7)
    w3 = (w1*w3)
    o0_3 = w3
    o0_4 = w0
    w3 = np.cos(w5)
    w7 = (w2*w4)
    w8 = (w3*w7)
    w8 = (w1*w8)
    o0_5 = w8
    w5 = np.sin(w5)
    w7 = (w5*w7)
    w7 = (w1*w7)
    o0_6 = w7
    w7 = a3
    w7 = (2.0*w7)
    w4 = (w4/w7)
    w4 = (w1*w4)
    o0_7 = w4
    o0_8 = w0
    w2 = (w2*w6)
    w3 = (w3*w2)
    w3 = (w1*w3)
    o0_9 = w3
    w5 = (w5*w2)
    w5 = (w1*w5)
    o0_10 = w5
    w6 = (w6/w7)
    w1 = (w1*w6)
    w1 = (-w1)
    o0_11 = w1
    o0_12 = w0
    out0[0, 0] = o0_0
    out0[0, 1] = 0.0
    out0[0, 2] = o0_2
    out0[0, 3] = o0_5
    out0[0, 4] = o0_9
    out0[1, 0] = 0.0
    out0[1, 1] = o0_1
    out0[1, 2] = o0_3
    out0[1, 3] = o0_6
    out0[1, 4] = o0_10
    out0[2, 0] = 0.0
    out0[2, 1] = 0.0
    out0[2, 2] = o0_4
    out0[2, 3] = o0_7
    out0[2, 4] = o0_11
    out0[3, 0] = 0.0
    out0[3, 1] = 0.0
    out0[3, 2] = 0.0
    out0[3, 3] = o0_8
    out0[3, 4] = 0.0
    out0[4, 0] = 0.0
    out0[4, 1] = 0.0
    out0[4, 2] = 0.0
    out0[4, 3] = 0.0
    out0[4, 4] = o0_12


@njit(cache=True, error_model="numpy")
def _kin_rates(a0, a1, a2, out0):
    """CasADi Function 'rates' at one point."""
    w0 = 0.5
    w1 = a0[3]
    w2 = a1[0]
    w3 = (w1*w2)
    w4 = a0[4]
    w5 = a1[1]
    w6 = (w4*w5)
    w3 = (w3+w6)
    w0 = (w0*w3)
    o0_0 = w0
    w1 = (w1*w2)
    w4 = (w4*w5)
    w1 = (w1-w4)
    w4 = a2
    w4 = (2.0*w4)
    w1 = (w1/w4)
    o0_1 = w1
    out0[0] = o0_0
    out0[1] = o0_1


@njit(cache=True, error_model="numpy")
def _kin_H(a0, a1, a2, out0):
    """CasADi Function 'H' at one point."""
    w0 = 0.5
    w1 = a1[0]
    w2 = (w0*w1)
    o0_0 = w2
    w2 = a2
    w2 = (2.0*w2)
    w1 = (w1/w2)
    o0_1 = w1
    w1 = a1[1]
    w0 = (w0*w1)
    o0_2 = w0
    w1 = (w1/w2)
    w1 = (-w1)
    o0_3 = w1
    out0[0, 0] = 0.0
    out0[0, 1] = 0.0
    out0[0, 2] = 0.0
    out0[0, 3] = o0_0
    out0[0, 4] = o0_2
    out0[1, 0] = 0.0
    out0[1, 1] = 0.0
    out0[1, 2] = 0.0
    out0[1, 3] = o0_1
    out0[1, 4] = o0_3
# ---- END GENERATED ----


# ---------------------------------------------------------------------------- small linear algebra
@njit(cache=True, error_model="numpy")
def _chol(A: np.ndarray, c: float, L: np.ndarray) -> None:
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
def _lu(A: np.ndarray, LU: np.ndarray, piv: np.ndarray) -> None:
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
def _lu_solve(LU: np.ndarray, piv: np.ndarray, b: np.ndarray, x: np.ndarray) -> None:
    """Solve ``A x = b`` from the factors of :func:`_lu`."""
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
def _gaussian(y: np.ndarray, S: np.ndarray, SI: np.ndarray) -> tuple[float, float]:
    """``S⁻¹`` (into ``SI``), NIS ``yᵀS⁻¹y`` and log N(y; 0, S) for one innovation (:func:`._core.gaussian_terms`)."""
    m = y.shape[0]
    if m == 1:
        s = S[0, 0]
        SI[0, 0] = 1.0 / s
        nis = y[0] * y[0] / s
        logdet = math.log(s)
    else:
        LU = np.empty((m, m))
        piv = np.empty(m, np.int64)
        _lu(S, LU, piv)
        e = np.zeros(m)
        col = np.empty(m)
        for j in range(m):
            e[j] = 1.0
            _lu_solve(LU, piv, e, col)
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
def _eig_floor(P: np.ndarray, out: np.ndarray) -> None:
    """Nearest symmetric matrix with eigenvalues ≥ ``EIG_FLOOR`` (non-finite entries → 0), as
    :func:`._core.eig_floor`, into ``out`` (may be ``P``)."""
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
def _channels(mask: int, z0: float, z1: float, z2: float, z3: float) -> tuple[np.ndarray, np.ndarray]:
    """Channel codes present in the bit mask ``mask`` (bit k = channel code k), in stacking order, and
    their values (the first ``m`` of ``z0..z3``)."""
    m = 0
    for k in range(4):
        m += (mask >> k) & 1
    kinds = np.empty(m, np.int64)
    i = 0
    for k in range(4):
        if (mask >> k) & 1:
            kinds[i] = k
            i += 1
    z = np.empty(m)
    for i, v in enumerate((z0, z1, z2, z3)):
        if i < m:
            z[i] = v
    return kinds, z


@njit(cache=True, error_model="numpy")
def _measure(x: np.ndarray, u: np.ndarray, b: float, kinds: np.ndarray, rates: np.ndarray, out: np.ndarray) -> None:
    """Predicted measurements of state ``x`` for the channels ``kinds`` (:func:`._core.measure`)."""
    _kin_rates(x, u, b, rates)
    for i in range(kinds.shape[0]):
        k = kinds[i]
        if k == SPEED:
            out[i] = rates[0]
        elif k == YAW:
            out[i] = rates[1]
        elif k == POS_X:
            out[i] = x[0]
        else:
            out[i] = x[1]


# ---------------------------------------------------------------------------- UKF
@njit(cache=True, error_model="numpy")
def _weights(kappa: float) -> tuple[float, np.ndarray]:
    """Julier weights (11,) and the scale ``n + κ`` of the 5-state filter."""
    c = 5 + kappa
    W = np.full(N_SIGMA, 0.5 / c)
    W[0] = kappa / c
    return c, W


@njit(cache=True, error_model="numpy")
def _sigma_points(X: np.ndarray, P: np.ndarray, c: float, sig: np.ndarray) -> np.ndarray:
    """Sigma points (n, 11, 5) of a bank into ``sig``; returns the covariances used: ``P``, or — when a
    factorisation failed and every entry is finite — all members eigen-floored (the batched rule of
    :meth:`._core.UKFCore.sigma_points`; non-finite NaNs propagate into a reset)."""
    n = X.shape[0]
    L = np.empty((n, 5, 5))
    last = 0.0
    for j in range(n):
        _chol(P[j], c, L[j])
        last += L[j, 4, 4]
    if not math.isfinite(last) and math.isfinite(P.sum()):
        Pr = np.empty_like(P)
        for j in range(n):
            _eig_floor(P[j], Pr[j])
            _chol(Pr[j], c, L[j])
        P = Pr
    for j in range(n):
        for a in range(5):
            sig[j, 0, a] = X[j, a]
        for i in range(5):
            for a in range(5):
                sig[j, 1 + i, a] = X[j, a] + L[j, a, i]
                sig[j, 6 + i, a] = X[j, a] - L[j, a, i]
    return P


@njit(cache=True, error_model="numpy")
def ukf_predict(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float, W: np.ndarray,
                Q: np.ndarray, Xp: np.ndarray, Pp: np.ndarray) -> None:
    """Unscented transform of the Euler step plus ``Q`` for a bank (:meth:`._core.UKFCore.predict`);
    ``c``, ``W`` from :func:`_weights`."""
    n = X.shape[0]
    sig = np.empty((n, N_SIGMA, 5))
    _sigma_points(X, P, c, sig)
    sf = np.empty((N_SIGMA, 5))
    d = np.empty((N_SIGMA, 5))
    for j in range(n):
        for k in range(N_SIGMA):
            _kin_step(sig[j, k], u, prm[P_DT], prm[P_B], sf[k])
        for a in range(5):
            s = 0.0
            for k in range(N_SIGMA):
                s += W[k] * sf[k, a]
            Xp[j, a] = s
        for k in range(N_SIGMA):
            for a in range(5):
                d[k, a] = sf[k, a] - Xp[j, a]
        for a in range(5):
            for b in range(5):
                s = 0.0
                for k in range(N_SIGMA):
                    s += d[k, a] * W[k] * d[k, b]
                Pp[j, a, b] = s + Q[a, b]


@njit(cache=True, error_model="numpy")
def ukf_update(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float, W: np.ndarray,
               kinds: np.ndarray, z: np.ndarray, rvar: np.ndarray, Xn: np.ndarray, Pn: np.ndarray, Zp: np.ndarray,
               Y: np.ndarray, S: np.ndarray, nis: np.ndarray, ll: np.ndarray) -> None:
    """Measurement update of a bank from sigma points regenerated at the prior (:meth:`._core.UKFCore.update`):
    posterior ``Xn``, ``Pn``, predicted measurements ``Zp`` and innovations ``Y`` (n, m), their covariances
    ``S`` (n, m, m), NIS and log-likelihoods (n,)."""
    n = X.shape[0]
    m = kinds.shape[0]
    sig = np.empty((n, N_SIGMA, 5))
    P = _sigma_points(X, P, c, sig)
    sh = np.empty((N_SIGMA, m))
    dz = np.empty((N_SIGMA, m))
    rates = np.empty(2)
    Pxz = np.empty((5, m))
    K = np.empty((5, m))
    SI = np.empty((m, m))
    SKT = np.empty((m, 5))
    for j in range(n):
        for k in range(N_SIGMA):
            _measure(sig[j, k], u, prm[P_B], kinds, rates, sh[k])
        zp = Zp[j]
        for i in range(m):
            s = 0.0
            for k in range(N_SIGMA):
                s += W[k] * sh[k, i]
            zp[i] = s
        for k in range(N_SIGMA):
            for i in range(m):
                dz[k, i] = sh[k, i] - zp[i]
        for i in range(m):
            for i2 in range(m):
                s = 0.0
                for k in range(N_SIGMA):
                    s += dz[k, i] * W[k] * dz[k, i2]
                S[j, i, i2] = s + (rvar[kinds[i]] if i == i2 else 0.0)
        for a in range(5):
            for i in range(m):
                s = 0.0
                for k in range(N_SIGMA):
                    s += (sig[j, k, a] - X[j, a]) * W[k] * dz[k, i]
                Pxz[a, i] = s
        for i in range(m):
            Y[j, i] = z[i] - zp[i]
        nis[j], ll[j] = _gaussian(Y[j], S[j], SI)
        for a in range(5):
            for i in range(m):
                s = 0.0
                for i2 in range(m):
                    s += Pxz[a, i2] * SI[i2, i]
                K[a, i] = s
        for a in range(5):
            s = 0.0
            for i in range(m):
                s += K[a, i] * Y[j, i]
            Xn[j, a] = X[j, a] + s
        # P⁺ = P - K (S Kᵀ)
        for i in range(m):
            for a in range(5):
                s = 0.0
                for i2 in range(m):
                    s += S[j, i, i2] * K[a, i2]
                SKT[i, a] = s
        for a in range(5):
            for b in range(5):
                s = 0.0
                for i in range(m):
                    s += K[a, i] * SKT[i, b]
                Pn[j, a, b] = P[j, a, b] - s


# ---------------------------------------------------------------------------- EKF
@njit(cache=True, error_model="numpy")
def ekf_predict(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, Q: np.ndarray,
                Xp: np.ndarray, Pp: np.ndarray) -> None:
    """``F`` (AD Jacobian at the posterior), Euler step, ``P⁻ = F P Fᵀ + Q`` (:meth:`._core.EKFCore.predict`)."""
    n = X.shape[0]
    F = np.empty((5, 5))
    FP = np.empty((5, 5))
    for j in range(n):
        _kin_F(X[j], u, prm[P_DT], prm[P_B], F)
        _kin_step(X[j], u, prm[P_DT], prm[P_B], Xp[j])
        for a in range(5):
            for b in range(5):
                s = 0.0
                for k in range(5):
                    s += F[a, k] * P[j, k, b]
                FP[a, b] = s
        for a in range(5):
            for b in range(5):
                s = 0.0
                for k in range(5):
                    s += FP[a, k] * F[b, k]
                Pp[j, a, b] = s + Q[a, b]


@njit(cache=True, error_model="numpy")
def ekf_update(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, kinds: np.ndarray, z: np.ndarray,
               rvar: np.ndarray, Xn: np.ndarray, Pn: np.ndarray, Zp: np.ndarray, Y: np.ndarray, S: np.ndarray,
               nis: np.ndarray, ll: np.ndarray) -> None:
    """Linearised update at the prior, Joseph form (:meth:`._core.EKFCore.update`); outputs as :func:`ukf_update`."""
    n = X.shape[0]
    m = kinds.shape[0]
    Hr = np.empty((2, 5))
    H = np.empty((m, 5))
    PHT = np.empty((5, m))
    rates = np.empty(2)
    SI = np.empty((m, m))
    K = np.empty((5, m))
    IKH = np.empty((5, 5))
    T = np.empty((5, 5))
    for j in range(n):
        _kin_H(X[j], u, prm[P_B], Hr)
        for i in range(m):
            k = kinds[i]
            for a in range(5):
                if k == SPEED or k == YAW:
                    H[i, a] = Hr[k, a]
                else:
                    H[i, a] = 1.0 if a == k - POS_X else 0.0
        for a in range(5):
            for i in range(m):
                s = 0.0
                for b in range(5):
                    s += P[j, a, b] * H[i, b]
                PHT[a, i] = s
        for i in range(m):
            for i2 in range(m):
                s = 0.0
                for a in range(5):
                    s += H[i, a] * PHT[a, i2]
                S[j, i, i2] = s + (rvar[kinds[i]] if i == i2 else 0.0)
        _measure(X[j], u, prm[P_B], kinds, rates, Zp[j])
        for i in range(m):
            Y[j, i] = z[i] - Zp[j, i]
        nis[j], ll[j] = _gaussian(Y[j], S[j], SI)
        for a in range(5):
            for i in range(m):
                s = 0.0
                for i2 in range(m):
                    s += PHT[a, i2] * SI[i2, i]
                K[a, i] = s
        for a in range(5):
            s = 0.0
            for i in range(m):
                s += K[a, i] * Y[j, i]
            Xn[j, a] = X[j, a] + s
        # Joseph form: (I - KH) P (I - KH)ᵀ + K R Kᵀ
        for a in range(5):
            for b in range(5):
                s = 0.0
                for i in range(m):
                    s += K[a, i] * H[i, b]
                IKH[a, b] = (1.0 if a == b else 0.0) - s
        for a in range(5):
            for b in range(5):
                s = 0.0
                for k in range(5):
                    s += IKH[a, k] * P[j, k, b]
                T[a, b] = s
        for a in range(5):
            for b in range(5):
                s = 0.0
                for k in range(5):
                    s += T[a, k] * IKH[b, k]
                r = 0.0
                for i in range(m):
                    r += K[a, i] * rvar[kinds[i]] * K[b, i]
                Pn[j, a, b] = s + r


# ---------------------------------------------------------------------------- whole steps
@njit(cache=True, error_model="numpy")
def _symmetrise(P: np.ndarray) -> None:
    """``P ← (P + Pᵀ)/2`` for each member, in place."""
    for j in range(P.shape[0]):
        for a in range(5):
            for b in range(a, 5):
                v = 0.5 * (P[j, a, b] + P[j, b, a])
                P[j, a, b] = v
                P[j, b, a] = v


@njit(cache=True, error_model="numpy")
def _nis_dwell(cnt: np.ndarray, nis: float, div_nis: float) -> bool:
    """Count steps with NIS above the divergence level; True once they last ``divergence_dwell``."""
    if math.isfinite(nis) and nis > div_nis:
        cnt[C_BAD_NIS] += 1
    elif math.isfinite(nis):
        cnt[C_BAD_NIS] = 0
    return cnt[C_BAD_NIS] >= cnt[C_DIV_STEPS]


@njit(cache=True, error_model="numpy")
def _clip_radii(x: np.ndarray, prm: np.ndarray) -> None:
    for a in (3, 4):
        x[a] = min(max(x[a], prm[P_MIN_RADIUS]), 10.0 * prm[P_R0])


@njit(cache=True, error_model="numpy")
def single_step(buf: np.ndarray, cnt: np.ndarray, u0: float, u1: float, z0: float, z1: float, z2: float,
                z3: float, mask: int, dropped: bool) -> tuple[float, float, float, int, bool, bool]:
    """One step of a single EKF/UKF (:meth:`._single.SingleFilter.step`) on its buffers, in place.

    ``u0, u1`` wheel rates (rad/s), ``z0..z3`` the values of the channels in ``mask`` (bit k = channel code
    k; the first ``m`` used, SI units); ``dropped`` a channel was non-finite. Returns ``(NIS, speed
    innovation (m/s), its std (m/s), m, rejected, reset)``; the state, the innovation ``y[:m]`` and its
    covariance ``S[:m, :m]`` are in ``buf``.
    """
    lay = layout(1)
    x = buf[lay.X:lay.X + 5]
    P = buf[lay.P:lay.P + 25].reshape((5, 5))
    ulast = buf[lay.ulast:lay.ulast + 2]
    prm = buf[lay.prm:lay.prm + N_PRM]
    Q = buf[lay.Q:lay.Q + 25].reshape((5, 5))
    rvar = buf[lay.rvar:lay.rvar + 4]
    if math.isfinite(u0 + u1):
        ulast[0] = u0
        ulast[1] = u1
    u = ulast
    x_prev = x.copy()
    ekf = cnt[C_EKF] != 0
    c, W = _weights(prm[P_KAPPA])
    X1 = x.reshape((1, 5))
    P1 = P.reshape((1, 5, 5))
    Xp = np.empty((1, 5))
    Pp = np.empty((1, 5, 5))
    if ekf:
        ekf_predict(X1, P1, u, prm, Q, Xp, Pp)
    else:
        ukf_predict(X1, P1, u, prm, c, W, Q, Xp, Pp)
    kinds, z = _channels(mask, z0, z1, z2, z3)
    m = kinds.shape[0]
    rejected = dropped
    nis = sp_innov = sp_std = np.nan
    Xs, Ps = Xp, Pp
    if m > 0:
        Xn = np.empty((1, 5))
        Pn = np.empty((1, 5, 5))
        Zp = np.empty((1, m))
        Y = np.empty((1, m))
        S = np.empty((1, m, m))
        nisv = np.empty(1)
        llv = np.empty(1)
        if ekf:
            ekf_update(Xp, Pp, u, prm, kinds, z, rvar, Xn, Pn, Zp, Y, S, nisv, llv)
        else:
            ukf_update(Xp, Pp, u, prm, c, W, kinds, z, rvar, Xn, Pn, Zp, Y, S, nisv, llv)
        nis = nisv[0]
        y_out = buf[lay.y:lay.y + 4]
        S_out = buf[lay.S:lay.S + 16].reshape((4, 4))
        for i in range(m):
            y_out[i] = Y[0, i]
            for i2 in range(m):
                S_out[i, i2] = S[0, i, i2]
        if kinds[0] == SPEED:
            sp_innov = Y[0, 0]
            s00 = S[0, 0, 0]
            sp_std = math.sqrt(0.0 if 0.0 > s00 else s00)  # Python's max(s00, 0.0): NaN stays NaN
        if nis <= prm[P_GATE]:  # False for NaN
            Xs, Ps = Xn, Pn
        else:
            rejected = True
    _symmetrise(Ps)
    xs = Xs[0]
    Pm = Ps[0]
    # divergence: unhealthy (non-finite, non-positive variance) or NIS too high for too long
    healthy = math.isfinite(xs.sum() + Pm.sum())
    if healthy:
        dmin = Pm[0, 0]
        for a in range(1, 5):
            dmin = min(dmin, Pm[a, a])
        healthy = dmin > 0.0
    reset = True if not healthy else _nis_dwell(cnt, nis, prm[P_DIV_NIS])
    if reset:
        cnt[C_RESETS] += 1
        cnt[C_BAD_NIS] = 0
        src = x_prev if np.all(np.isfinite(x_prev)) else buf[lay.x0:lay.x0 + 5]
        for a in range(5):
            x[a] = src[a]
        _clip_radii(x, prm)
        P0 = buf[lay.P0:lay.P0 + 25].reshape((5, 5))
        for a in range(5):
            for b in range(5):
                P[a, b] = prm[P_INFLATION] * P0[a, b]
    else:
        if ekf:  # the UKF's next Cholesky repairs a non-PD covariance itself; the EKF checks every step
            L = np.empty((5, 5))
            _chol(Pm, 1.0, L)
            if math.isnan(L[4, 4]):
                _eig_floor(Pm, Pm)
        for a in range(5):
            x[a] = xs[a]
            for b in range(5):
                P[a, b] = Pm[a, b]
    if rejected:
        cnt[C_REJECTIONS] += 1
    cnt[C_STEPS] += 1
    return nis, sp_innov, sp_std, m, rejected, reset


@njit(cache=True, error_model="numpy")
def _combine(X: np.ndarray, P: np.ndarray, mu: np.ndarray, x: np.ndarray, Pc: np.ndarray) -> None:
    """IMM step 5: ``x = Σ μ_j xʲ``, ``P = Σ μ_j (Pʲ + (xʲ - x)(xʲ - x)ᵀ)`` (:meth:`.imm.IMM._combine`)."""
    n = X.shape[0]
    for a in range(5):
        s = 0.0
        for j in range(n):
            s += mu[j] * X[j, a]
        x[a] = s
    d = np.empty((n, 5))
    for j in range(n):
        for a in range(5):
            d[j, a] = X[j, a] - x[a]
    for a in range(5):
        for b in range(5):
            s = 0.0
            for j in range(n):
                s += mu[j] * P[j, a, b]
            t = 0.0
            for j in range(n):
                t += d[j, a] * mu[j] * d[j, b]
            Pc[a, b] = s + t


@njit(cache=True, error_model="numpy")
def imm_combine(buf: np.ndarray, n: int) -> None:
    """Combined estimate and covariance of the bank in ``buf`` (used after a state is set from Python)."""
    lay = layout(n)
    _combine(buf[lay.X:lay.X + 5 * n].reshape((n, 5)), buf[lay.P:lay.P + 25 * n].reshape((n, 5, 5)),
             buf[lay.mu:lay.mu + n], buf[lay.x:lay.x + 5], buf[lay.Pc:lay.Pc + 25].reshape((5, 5)))


@njit(cache=True, error_model="numpy")
def imm_step(buf: np.ndarray, cnt: np.ndarray, u0: float, u1: float, z0: float, z1: float, z2: float, z3: float,
             mask: int, dropped: bool) -> tuple[float, float, float, int, bool, bool]:
    """One IMM cycle (:meth:`.imm.IMM.step`) on the bank's buffers, in place; arguments and result as
    :func:`single_step` (``y``, ``S`` and NIS are those of the mixture predictive density)."""
    n = cnt[C_N]
    lay = layout(n)
    X = buf[lay.X:lay.X + 5 * n].reshape((n, 5))
    P = buf[lay.P:lay.P + 25 * n].reshape((n, 5, 5))
    mu = buf[lay.mu:lay.mu + n]
    ulast = buf[lay.ulast:lay.ulast + 2]
    prm = buf[lay.prm:lay.prm + N_PRM]
    Q = buf[lay.Q:lay.Q + 25].reshape((5, 5))
    rvar = buf[lay.rvar:lay.rvar + 4]
    Pi = buf[lay.Pi:lay.Pi + n * n].reshape((n, n))
    if math.isfinite(u0) and math.isfinite(u1):
        ulast[0] = u0
        ulast[1] = u1
    u = ulast
    X_prev = X.copy()
    c, W = _weights(prm[P_KAPPA])
    # 1. mixing probabilities c̄_j = Σ_i Π_ij μ_i, ω_ij = Π_ij μ_i / c̄_j
    cbar = np.empty(n)
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += mu[i] * Pi[i, j]
        cbar[j] = s
    # 2. mixed initial conditions
    X0 = np.empty((n, 5))
    P0 = np.empty((n, 5, 5))
    d = np.empty((n, 5))
    w = np.empty(n)
    for j in range(n):
        for i in range(n):
            w[i] = Pi[i, j] * mu[i] / cbar[j]
        for a in range(5):
            s = 0.0
            for i in range(n):
                s += w[i] * X[i, a]
            X0[j, a] = s
        for i in range(n):
            for a in range(5):
                d[i, a] = X[i, a] - X0[j, a]
        for a in range(5):
            for b in range(5):
                s = 0.0
                for i in range(n):
                    s += w[i] * P[i, a, b]
                t = 0.0
                for i in range(n):
                    t += d[i, a] * w[i] * d[i, b]
                P0[j, a, b] = s + t
    hyp = cnt[C_HYP] != 0
    if hyp:  # impose each member's radius hypothesis on its mixed initial condition
        pin_value = buf[lay.pin_value:lay.pin_value + 2 * n].reshape((n, 2))
        pin = buf[lay.pin:lay.pin + 2 * n].reshape((n, 2))
        keep = buf[lay.keep:lay.keep + 25 * n].reshape((n, 5, 5))
        reset_var = buf[lay.reset_var:lay.reset_var + 25 * n].reshape((n, 5, 5))
        for j in range(n):
            for r in range(2):
                if pin[j, r] != 0.0:
                    X0[j, 3 + r] = pin_value[j, r]
            for a in range(5):
                for b in range(5):
                    P0[j, a, b] = P0[j, a, b] * keep[j, a, b] + reset_var[j, a, b]
    # 3. mode-matched filtering
    Xp = np.empty((n, 5))
    Pp = np.empty((n, 5, 5))
    ekf = cnt[C_EKF] != 0
    if ekf:
        ekf_predict(X0, P0, u, prm, Q, Xp, Pp)
    else:
        ukf_predict(X0, P0, u, prm, c, W, Q, Xp, Pp)
    if hyp:
        ramp = buf[lay.ramp:lay.ramp + n]
        for j in range(n):
            if ramp[j] != 0.0:
                v = Xp[j, 4] - prm[P_RAMP_STEP]
                Xp[j, 4] = v if not v < prm[P_MIN_RADIUS] else prm[P_MIN_RADIUS]  # np.maximum: NaN stays
    kinds, z = _channels(mask, z0, z1, z2, z3)
    m = kinds.shape[0]
    rejected = dropped
    Xs, Ps = Xp, Pp
    mu_new = cbar.copy()
    nis = sp_innov = sp_std = np.nan
    if m > 0:
        Xn = np.empty((n, 5))
        Pn = np.empty((n, 5, 5))
        Zp = np.empty((n, m))
        Y = np.empty((n, m))
        S = np.empty((n, m, m))
        nisv = np.empty(n)
        llv = np.empty(n)
        if ekf:
            ekf_update(Xp, Pp, u, prm, kinds, z, rvar, Xn, Pn, Zp, Y, S, nisv, llv)
        else:
            ukf_update(Xp, Pp, u, prm, c, W, kinds, z, rvar, Xn, Pn, Zp, Y, S, nisv, llv)
        # mixture predictive density of z (weights c̄): innovation and S of the bank
        zbar = np.empty(m)
        dzp = np.empty((n, m))
        for i in range(m):
            s = 0.0
            for j in range(n):
                s += cbar[j] * Zp[j, i]
            zbar[i] = s
        for j in range(n):
            for i in range(m):
                dzp[j, i] = Zp[j, i] - zbar[i]
        y_out = buf[lay.y:lay.y + 4]
        S_mix = buf[lay.S:lay.S + 16].reshape((4, 4))[:m, :m]
        for i in range(m):
            for i2 in range(m):
                s = 0.0
                for j in range(n):
                    s += cbar[j] * S[j, i, i2]
                t = 0.0
                for j in range(n):
                    t += dzp[j, i] * cbar[j] * dzp[j, i2]
                S_mix[i, i2] = s + t
        y = np.empty(m)
        for i in range(m):
            y[i] = z[i] - zbar[i]
            y_out[i] = y[i]
        if m == 1:
            nis = y[0] * y[0] / S_mix[0, 0]
        else:
            Sc = S_mix.copy()
            LU = np.empty((m, m))
            piv = np.empty(m, np.int64)
            _lu(Sc, LU, piv)
            sol = np.empty(m)
            _lu_solve(LU, piv, y, sol)
            nis = 0.0
            for i in range(m):
                nis += y[i] * sol[i]
        if kinds[0] == SPEED:
            sp_innov = y[0]
            s00 = S_mix[0, 0]
            sp_std = math.sqrt(0.0 if 0.0 > s00 else s00)
        # 4. mode probabilities (accepted when some finite member's NIS passes the gate)
        any_ok = False
        best = np.inf
        llmax = -np.inf
        for j in range(n):
            if math.isfinite(llv[j]):
                any_ok = True
                best = min(best, nisv[j])
                llmax = max(llmax, llv[j])
        if any_ok and best <= prm[P_GATE]:
            Xs, Ps = Xn, Pn
            loglik = buf[lay.loglik:lay.loglik + n]
            wsum = 0.0
            for j in range(n):
                lj = llv[j] if math.isfinite(llv[j]) else -np.inf
                loglik[j] = lj
                mu_new[j] = cbar[j] * math.exp(lj - llmax)
                wsum += mu_new[j]
            for j in range(n):
                mu_new[j] = mu_new[j] / wsum
        else:
            rejected = True
    _symmetrise(Ps)
    reset = True if not math.isfinite(Xs.sum() + Ps.sum()) else _nis_dwell(cnt, nis, prm[P_DIV_NIS])
    if reset:
        cnt[C_RESETS] += 1
        cnt[C_BAD_NIS] = 0
        x0 = buf[lay.x0:lay.x0 + 5]
        P0c = buf[lay.P0:lay.P0 + 25].reshape((5, 5))
        for j in range(n):
            for a in range(5):
                X[j, a] = X_prev[j, a] if math.isfinite(X_prev[j, a]) else x0[a]
            _clip_radii(X[j], prm)
            for a in range(5):
                for b in range(5):
                    P[j, a, b] = prm[P_INFLATION] * P0c[a, b]
    else:
        for j in range(n):
            bad = False
            for a in range(5):
                bad = bad or Ps[j, a, a] <= 0.0
            if bad:  # (non-PD otherwise: repaired at the next Cholesky)
                _eig_floor(Ps[j], Ps[j])
            for a in range(5):
                X[j, a] = Xs[j, a]
                for b in range(5):
                    P[j, a, b] = Ps[j, a, b]
    total = 0.0
    for j in range(n):
        v = mu_new[j]
        mu_new[j] = MU_FLOOR if v < MU_FLOOR else v  # np.maximum: NaN stays
        total += mu_new[j]
    for j in range(n):
        mu[j] = mu_new[j] / total
    _combine(X, P, mu, buf[lay.x:lay.x + 5], buf[lay.Pc:lay.Pc + 25].reshape((5, 5)))
    if rejected:
        cnt[C_REJECTIONS] += 1
    cnt[C_STEPS] += 1
    return nis, sp_innov, sp_std, m, rejected, reset
