"""Kalman steps of a bank of filters: UKF and EKF predict and update (filterpy 2.0.0's maths).

Written as loops over the members of a bank (the numpy reference in ``tests/support/numpy_filters.py``
gives the same formulas in matrix form; the tests require agreement to round-off):

* UKF (``UnscentedKalmanFilter`` + ``JulierSigmaPoints``): sigma points ``x ± columns of L`` with
  ``LLᵀ = (n+κ)P``; predict = unscented transform of the Euler step plus ``Q``; the update
  *regenerates* the sigma points from the prior ``(x⁻, P⁻)`` (filterpy 2.0 behaviour);
  ``S = Σ W (h-ẑ)(h-ẑ)ᵀ + R``, ``K = Pxz S⁻¹``, ``P⁺ = P⁻ - K S Kᵀ``.
* EKF (``ExtendedKalmanFilter``, ``F`` = AD Jacobian at the posterior): ``P⁻ = F P Fᵀ + Q``;
  Joseph-form update ``P⁺ = (I-KH)P⁻(I-KH)ᵀ + K R Kᵀ``.

Units: states (m, m, rad, m, m), wheel rates (rad/s), speed (m/s), yaw rate (rad/s), position (m), heading
(rad). A heading innovation is wrapped to [-π, π) (:func:`wrap_angle`): the filter's heading is continuous
(it counts turns), a heading fix is an angle.
"""

from __future__ import annotations

import math

import numpy as np

from .generated import kin_F, kin_H, kin_rates, kin_step
from .jit import njit
from .layout import HEADING, N_CHANNELS, N_SIGMA, P_B, P_DT, POS_X, POS_Y, SPEED, YAW
from .linalg import chol, eig_floor, gaussian, mat_mul

MODEL_DIGEST = "d5385545ce3b5bff"
"""Digest of :mod:`.generated` this module's compiled code includes (see :mod:`ftc_mj.estimation.codegen`)."""


@njit(cache=True, error_model="numpy")
def channels(mask: int, z0: float, z1: float, z2: float, z3: float, z4: float) -> tuple[np.ndarray, np.ndarray]:
    """Channel codes present in the bit mask ``mask`` (bit k = channel code k), in stacking order, and
    their values (the first ``m`` of ``z0..z4``)."""
    m = 0
    for k in range(N_CHANNELS):
        m += (mask >> k) & 1
    kinds = np.empty(m, np.int64)
    i = 0
    for k in range(N_CHANNELS):
        if (mask >> k) & 1:
            kinds[i] = k
            i += 1
    z = np.empty(m)
    for i, v in enumerate((z0, z1, z2, z3, z4)):
        if i < m:
            z[i] = v
    return kinds, z


@njit(cache=True, error_model="numpy")
def wrap_angle(a: float) -> float:
    """The angle ``a`` (rad) wrapped to [-π, π)."""
    return a - 2.0 * math.pi * math.floor((a + math.pi) / (2.0 * math.pi))


@njit(cache=True, error_model="numpy")
def measure(x: np.ndarray, u: np.ndarray, b: float, kinds: np.ndarray, rates: np.ndarray, out: np.ndarray) -> None:
    """Predicted measurements of state ``x`` for the channels ``kinds`` ."""
    kin_rates(x, u, b, rates)
    for i in range(kinds.shape[0]):
        k = kinds[i]
        if k == SPEED:
            out[i] = rates[0]
        elif k == YAW:
            out[i] = rates[1]
        elif k == POS_X:
            out[i] = x[0]
        elif k == POS_Y:
            out[i] = x[1]
        else:
            out[i] = x[2]


# ---------------------------------------------------------------------------- UKF
@njit(cache=True, error_model="numpy")
def weights(kappa: float) -> tuple[float, np.ndarray]:
    """Julier weights (11,) and the scale ``n + κ`` of the 5-state filter."""
    c = 5 + kappa
    W = np.full(N_SIGMA, 0.5 / c)
    W[0] = kappa / c
    return c, W


@njit(cache=True, error_model="numpy")
def sigma_points(X: np.ndarray, P: np.ndarray, c: float, sig: np.ndarray) -> np.ndarray:
    """Sigma points (n, 11, 5) of a bank into ``sig``; returns the covariances used: ``P``, or — when a
    factorisation failed and every entry is finite — all members eigen-floored (the batched rule of
    the numpy reference; non-finite NaNs propagate into a reset)."""
    n = X.shape[0]
    L = np.empty((n, 5, 5))
    last = 0.0
    for j in range(n):
        chol(P[j], c, L[j])
        last += L[j, 4, 4]
    if not math.isfinite(last) and math.isfinite(P.sum()):
        Pr = np.empty_like(P)
        for j in range(n):
            eig_floor(P[j], Pr[j])
            chol(Pr[j], c, L[j])
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
def unscented_moments(W: np.ndarray, pts: np.ndarray, mean: np.ndarray, dev: np.ndarray, cov: np.ndarray) -> None:
    """Weighted moments of points (sigma points, or a mixture's component means): the mean
    ``Σ W_k p_k`` of ``pts`` (N, d) into ``mean`` (d,), the deviations from it into ``dev`` (N, d) and
    ``Σ W_k dev_k dev_kᵀ`` into ``cov`` (d, d)."""
    N, dim = pts.shape
    for a in range(dim):
        s = 0.0
        for k in range(N):
            s += W[k] * pts[k, a]
        mean[a] = s
    for k in range(N):
        for a in range(dim):
            dev[k, a] = pts[k, a] - mean[a]
    for a in range(dim):
        for b in range(dim):
            s = 0.0
            for k in range(N):
                s += dev[k, a] * W[k] * dev[k, b]
            cov[a, b] = s


@njit(cache=True, error_model="numpy")
def innovate(kinds: np.ndarray, z: np.ndarray, j: int, Zp: np.ndarray, S: np.ndarray, C: np.ndarray, X: np.ndarray,
             Y: np.ndarray, Xn: np.ndarray, SI: np.ndarray, K: np.ndarray, nis: np.ndarray, ll: np.ndarray) -> None:
    """Member ``j``'s innovation ``Y[j] = z - Zp[j]`` (a heading's wrapped), its NIS and log-likelihood under
    ``S[j]``, the gain ``K = C S⁻¹`` (``C`` the state-measurement cross covariance, (5, m)) and the mean
    ``Xn[j] = X[j] + K Y[j]``."""
    m = z.shape[0]
    for i in range(m):
        Y[j, i] = z[i] - Zp[j, i]
        if kinds[i] == HEADING:
            Y[j, i] = wrap_angle(Y[j, i])
    nis[j], ll[j] = gaussian(Y[j], S[j], SI)
    for a in range(5):
        for i in range(m):
            s = 0.0
            for i2 in range(m):
                s += C[a, i2] * SI[i2, i]
            K[a, i] = s
    for a in range(5):
        s = 0.0
        for i in range(m):
            s += K[a, i] * Y[j, i]
        Xn[j, a] = X[j, a] + s


@njit(cache=True, error_model="numpy")
def ukf_predict(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float, W: np.ndarray,
                Q: np.ndarray, Xp: np.ndarray, Pp: np.ndarray) -> None:
    """Unscented transform of the Euler step plus ``Q`` for a bank;
    ``c``, ``W`` from :func:`weights`."""
    n = X.shape[0]
    sig = np.empty((n, N_SIGMA, 5))
    sigma_points(X, P, c, sig)
    sf = np.empty((N_SIGMA, 5))
    d = np.empty((N_SIGMA, 5))
    C = np.empty((5, 5))
    for j in range(n):
        for k in range(N_SIGMA):
            kin_step(sig[j, k], u, prm[P_DT], prm[P_B], sf[k])
        unscented_moments(W, sf, Xp[j], d, C)
        for a in range(5):
            for b in range(5):
                Pp[j, a, b] = C[a, b] + Q[a, b]


@njit(cache=True, error_model="numpy")
def ukf_update(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float, W: np.ndarray,
               kinds: np.ndarray, z: np.ndarray, rvar: np.ndarray, Xn: np.ndarray, Pn: np.ndarray, Zp: np.ndarray,
               Y: np.ndarray, S: np.ndarray, nis: np.ndarray, ll: np.ndarray) -> None:
    """Measurement update of a bank from sigma points regenerated at the prior:
    posterior ``Xn``, ``Pn``, predicted measurements ``Zp`` and innovations ``Y`` (n, m), their covariances
    ``S`` (n, m, m), NIS and log-likelihoods (n,)."""
    n = X.shape[0]
    m = kinds.shape[0]
    sig = np.empty((n, N_SIGMA, 5))
    P = sigma_points(X, P, c, sig)
    sh = np.empty((N_SIGMA, m))
    dz = np.empty((N_SIGMA, m))
    rates = np.empty(2)
    Pxz = np.empty((5, m))
    K = np.empty((5, m))
    SI = np.empty((m, m))
    SKT = np.empty((m, 5))
    C = np.empty((m, m))
    for j in range(n):
        for k in range(N_SIGMA):
            measure(sig[j, k], u, prm[P_B], kinds, rates, sh[k])
        unscented_moments(W, sh, Zp[j], dz, C)
        for i in range(m):
            for i2 in range(m):
                S[j, i, i2] = C[i, i2] + (rvar[kinds[i]] if i == i2 else 0.0)
        for a in range(5):
            for i in range(m):
                s = 0.0
                for k in range(N_SIGMA):
                    s += (sig[j, k, a] - X[j, a]) * W[k] * dz[k, i]
                Pxz[a, i] = s
        innovate(kinds, z, j, Zp, S, Pxz, X, Y, Xn, SI, K, nis, ll)
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
    """``F`` (AD Jacobian at the posterior), Euler step, ``P⁻ = F P Fᵀ + Q``."""
    n = X.shape[0]
    F = np.empty((5, 5))
    FP = np.empty((5, 5))
    FPF = np.empty((5, 5))
    for j in range(n):
        kin_F(X[j], u, prm[P_DT], prm[P_B], F)
        kin_step(X[j], u, prm[P_DT], prm[P_B], Xp[j])
        mat_mul(F, P[j], FP)
        mat_mul(FP, F, FPF, True)
        for a in range(5):
            for b in range(5):
                Pp[j, a, b] = FPF[a, b] + Q[a, b]


@njit(cache=True, error_model="numpy")
def ekf_update(X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, kinds: np.ndarray, z: np.ndarray,
               rvar: np.ndarray, Xn: np.ndarray, Pn: np.ndarray, Zp: np.ndarray, Y: np.ndarray, S: np.ndarray,
               nis: np.ndarray, ll: np.ndarray) -> None:
    """Linearised update at the prior, Joseph form; outputs as :func:`ukf_update`."""
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
    TIKH = np.empty((5, 5))
    for j in range(n):
        kin_H(X[j], u, prm[P_B], Hr)
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
        measure(X[j], u, prm[P_B], kinds, rates, Zp[j])
        innovate(kinds, z, j, Zp, S, PHT, X, Y, Xn, SI, K, nis, ll)
        # Joseph form: (I - KH) P (I - KH)ᵀ + K R Kᵀ
        for a in range(5):
            for b in range(5):
                s = 0.0
                for i in range(m):
                    s += K[a, i] * H[i, b]
                IKH[a, b] = (1.0 if a == b else 0.0) - s
        mat_mul(IKH, P[j], T)
        mat_mul(T, IKH, TIKH, True)
        for a in range(5):
            for b in range(5):
                s = TIKH[a, b]
                r = 0.0
                for i in range(m):
                    r += K[a, i] * rvar[kinds[i]] * K[b, i]
                Pn[j, a, b] = s + r
