"""One cycle of an interacting-multiple-model bank (Bar-Shalom's five steps), as one compiled call.

For ``n`` mode-matched filters with transition matrix ``Π`` (``Π[i, j]`` = P(i → j)): 1. mixing
probabilities; 2. mixed initial conditions (then, in the hypothesis variant, each member's radius
hypothesis re-imposed); 3. mode-matched prediction and update; 4. mode probabilities from the members'
log-likelihoods; 5. combination. The bank's innovation, its covariance and NIS are those of the mixture
predictive density of the measurement. Health rules as :mod:`.single`, over the whole bank.
"""

from __future__ import annotations

import math

import numpy as np

from .bank import clip_radii, count_step, ekf_bank_update, nis_dwell, pose_gate, speed_std, ukf_bank_update
from .jit import njit
from .kalman import channels, ekf_predict, ukf_predict, unscented_moments, weights, wrap_angle
from .layout import (
    C_BAD_NIS,
    C_HYP,
    C_N,
    C_RESETS,
    HEADING,
    MU_FLOOR,
    N_CHANNELS,
    N_PRM,
    P_DIV_NIS,
    P_GATE,
    P_INFLATION,
    P_KAPPA,
    P_MIN_RADIUS,
    P_RAMP_STEP,
    SPEED,
    Layout,
    layout,
)
from .linalg import eig_floor, lu, lu_solve, symmetrise

MODEL_DIGEST = "d5385545ce3b5bff"
"""Digest of :mod:`.generated` this module's compiled code includes (see :mod:`ftc_mj.estimation.codegen`)."""


@njit(cache=True, error_model="numpy")
def combine(X: np.ndarray, P: np.ndarray, mu: np.ndarray, x: np.ndarray, Pc: np.ndarray) -> None:
    """Gaussian mixture moments (step 5, also the mixing and the bank's predictive density):
    ``x = Σ μ_j xʲ``, ``P = Σ μ_j (Pʲ + (xʲ - x)(xʲ - x)ᵀ)`` of ``n`` components of dimension ``d``
    (``X`` (n, d), ``P`` (n, d, d)) into ``x`` (d,), ``Pc`` (d, d)."""
    n, dim = X.shape
    d = np.empty((n, dim))
    spread = np.empty((dim, dim))
    unscented_moments(mu, X, x, d, spread)  # Σ μ_j (xʲ - x)(xʲ - x)ᵀ
    for a in range(dim):
        for b in range(dim):
            s = 0.0
            for j in range(n):
                s += mu[j] * P[j, a, b]
            Pc[a, b] = s + spread[a, b]


@njit(cache=True, error_model="numpy")
def imm_combine(buf: np.ndarray, n: int) -> None:
    """Combined estimate and covariance of the bank in ``buf`` (used after a state is set from Python)."""
    lay = layout(n)
    combine(buf[lay.X:lay.X + 5 * n].reshape((n, 5)), buf[lay.P:lay.P + 25 * n].reshape((n, 5, 5)),
            buf[lay.mu:lay.mu + n], buf[lay.x:lay.x + 5], buf[lay.Pc:lay.Pc + 25].reshape((5, 5)))


@njit(cache=True, error_model="numpy")
def mixing_probabilities(mu: np.ndarray, Pi: np.ndarray) -> np.ndarray:
    """Step 1: ``c̄_j = Σ_i Π_ij μ_i``."""
    n = mu.shape[0]
    cbar = np.empty(n)
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += mu[i] * Pi[i, j]
        cbar[j] = s
    return cbar


@njit(cache=True, error_model="numpy")
def mix(X: np.ndarray, P: np.ndarray, mu: np.ndarray, Pi: np.ndarray, cbar: np.ndarray
        ) -> tuple[np.ndarray, np.ndarray]:
    """Step 2: mixed initial conditions ``x⁰ʲ = Σ_i ω_ij xⁱ``, ``P⁰ʲ = Σ_i ω_ij (Pⁱ + (xⁱ - x⁰ʲ)(xⁱ - x⁰ʲ)ᵀ)``
    with ``ω_ij = Π_ij μ_i / c̄_j``: (n, 5), (n, 5, 5)."""
    n = X.shape[0]
    X0 = np.empty((n, 5))
    P0 = np.empty((n, 5, 5))
    w = np.empty(n)
    for j in range(n):
        for i in range(n):
            w[i] = Pi[i, j] * mu[i] / cbar[j]
        combine(X, P, w, X0[j], P0[j])  # the mixture of the members with weights ω_·j
    return X0, P0


@njit(cache=True, error_model="numpy")
def impose_hypotheses(buf: np.ndarray, n: int, X0: np.ndarray, P0: np.ndarray) -> None:
    """Impose each member's radius hypothesis on its mixed initial condition ``(X0, P0)``, in place:
    pinned radius means (m), and variance ``hypothesis_sigma²`` without correlation for pinned and
    ramp radii (the masks ``keep``/``reset_var`` of the buffers)."""
    lay = layout(n)
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


@njit(cache=True, error_model="numpy")
def _ramp(ramp: np.ndarray, Xp: np.ndarray, prm: np.ndarray) -> None:
    """Ramp members' predicted left radius deflates: ``R_L ← max(R_L - ramp_rate·dt, min_radius)`` (m)."""
    for j in range(Xp.shape[0]):
        if ramp[j] != 0.0:
            v = Xp[j, 4] - prm[P_RAMP_STEP]
            Xp[j, 4] = v if not v < prm[P_MIN_RADIUS] else prm[P_MIN_RADIUS]  # np.maximum: NaN stays


@njit(cache=True, error_model="numpy")
def _mixture_innovation(buf: np.ndarray, lay: Layout, kinds: np.ndarray, z: np.ndarray, cbar: np.ndarray,
                        Zp: np.ndarray, S: np.ndarray) -> tuple[float, float, float]:
    """Innovation and covariance of the mixture predictive density of ``z`` (weights ``c̄``), written to
    ``y[:m]``, ``S[:m, :m]`` of ``buf``; returns its NIS, the speed innovation and its std (m/s)."""
    m = kinds.shape[0]
    zbar = np.empty(m)
    y_out = buf[lay.y:lay.y + N_CHANNELS]
    S_mix = buf[lay.S:lay.S + N_CHANNELS * N_CHANNELS].reshape((N_CHANNELS, N_CHANNELS))[:m, :m]
    combine(Zp, S, cbar, zbar, S_mix)
    y = np.empty(m)
    for i in range(m):
        y[i] = z[i] - zbar[i]
        if kinds[i] == HEADING:
            y[i] = wrap_angle(y[i])
        y_out[i] = y[i]
    if m == 1:
        nis = y[0] * y[0] / S_mix[0, 0]
    else:
        Sc = S_mix.copy()
        LU = np.empty((m, m))
        piv = np.empty(m, np.int64)
        lu(Sc, LU, piv)
        sol = np.empty(m)
        lu_solve(LU, piv, y, sol)
        nis = 0.0
        for i in range(m):
            nis += y[i] * sol[i]
    sp_innov = sp_std = np.nan
    if kinds[0] == SPEED:
        sp_innov = y[0]
        sp_std = speed_std(S_mix[0, 0])
    return nis, sp_innov, sp_std


@njit(cache=True, error_model="numpy")
def _mode_probabilities(loglik: np.ndarray, cbar: np.ndarray, nisv: np.ndarray, llv: np.ndarray, gate: float,
                        mu_new: np.ndarray) -> bool:
    """Step 4: ``μ_j ∝ c̄_j exp(log Λ_j - max log Λ)`` into ``mu_new`` and the members' log-likelihoods
    into ``loglik``, when some finite member's NIS passes the gate; returns whether it did."""
    n = cbar.shape[0]
    any_ok = False
    best = np.inf
    llmax = -np.inf
    for j in range(n):
        if math.isfinite(llv[j]):
            any_ok = True
            best = min(best, nisv[j])
            llmax = max(llmax, llv[j])
    if not (any_ok and best <= gate):
        return False
    wsum = 0.0
    for j in range(n):
        lj = llv[j] if math.isfinite(llv[j]) else -np.inf
        loglik[j] = lj
        mu_new[j] = cbar[j] * math.exp(lj - llmax)
        wsum += mu_new[j]
    for j in range(n):
        mu_new[j] = mu_new[j] / wsum
    return True


@njit(cache=True, error_model="numpy")
def _reset(buf: np.ndarray, lay: Layout, cnt: np.ndarray, X: np.ndarray, P: np.ndarray, X_prev: np.ndarray,
           prm: np.ndarray) -> None:
    """Reset every member to its last finite estimate (entry by entry, else ``x0``), radii clipped,
    covariance ``reset_inflation · P0``."""
    cnt[C_RESETS] += 1
    cnt[C_BAD_NIS] = 0
    x0 = buf[lay.x0:lay.x0 + 5]
    P0c = buf[lay.P0:lay.P0 + 25].reshape((5, 5))
    for j in range(X.shape[0]):
        for a in range(5):
            X[j, a] = X_prev[j, a] if math.isfinite(X_prev[j, a]) else x0[a]
        clip_radii(X[j], prm)
        for a in range(5):
            for b in range(5):
                P[j, a, b] = prm[P_INFLATION] * P0c[a, b]


@njit(cache=True, error_model="numpy")
def _keep(X: np.ndarray, P: np.ndarray, Xs: np.ndarray, Ps: np.ndarray) -> None:
    """Store the members' estimates; a member with a non-positive variance is eigen-floored (non-PD
    otherwise: repaired at the next Cholesky)."""
    for j in range(X.shape[0]):
        bad = False
        for a in range(5):
            bad = bad or Ps[j, a, a] <= 0.0
        if bad:
            eig_floor(Ps[j], Ps[j])
        for a in range(5):
            X[j, a] = Xs[j, a]
            for b in range(5):
                P[j, a, b] = Ps[j, a, b]


@njit(cache=True, error_model="numpy")
def _floor_normalise(mu_new: np.ndarray, mu: np.ndarray) -> None:
    """``μ = max(μ_new, MU_FLOOR) / Σ`` (no mode is ever impossible; NaN stays as np.maximum)."""
    total = 0.0
    for j in range(mu.shape[0]):
        v = mu_new[j]
        mu_new[j] = MU_FLOOR if v < MU_FLOOR else v
        total += mu_new[j]
    for j in range(mu.shape[0]):
        mu[j] = mu_new[j] / total


def _imm_step(ekf: bool):
    """The compiled IMM cycle of a bank of EKF (``ekf``) or UKF members: one function per kind, so that a
    run compiles only its members' (``ekf`` is a closure constant; numba prunes the other kind's
    branches)."""

    @njit(cache=True, error_model="numpy")
    def step(buf: np.ndarray, cnt: np.ndarray, u0: float, u1: float, z0: float, z1: float, z2: float, z3: float,
             z4: float, mask: int, dropped: bool) -> tuple[float, float, float, int, bool, bool, bool]:
        """One IMM cycle on the bank's buffers, in place; arguments and result as the single filter's
        step (:mod:`.single`; ``y``, ``S`` and NIS are those of the mixture predictive density)."""
        n = cnt[C_N]
        lay = layout(n)
        X = buf[lay.X:lay.X + 5 * n].reshape((n, 5))
        P = buf[lay.P:lay.P + 25 * n].reshape((n, 5, 5))
        mu = buf[lay.mu:lay.mu + n]
        ulast = buf[lay.ulast:lay.ulast + 2]
        prm = buf[lay.prm:lay.prm + N_PRM]
        if math.isfinite(u0) and math.isfinite(u1):
            ulast[0] = u0
            ulast[1] = u1
        u = ulast
        X_prev = X.copy()
        c, W = weights(prm[P_KAPPA])
        cbar = mixing_probabilities(mu, buf[lay.Pi:lay.Pi + n * n].reshape((n, n)))
        X0, P0 = mix(X, P, mu, buf[lay.Pi:lay.Pi + n * n].reshape((n, n)), cbar)
        hyp = cnt[C_HYP] != 0
        if hyp:
            impose_hypotheses(buf, n, X0, P0)
        Xp = np.empty((n, 5))
        Pp = np.empty((n, 5, 5))
        Q = buf[lay.Q:lay.Q + 25].reshape((5, 5))
        if ekf:  # step 3
            ekf_predict(X0, P0, u, prm, Q, Xp, Pp)
        else:
            ukf_predict(X0, P0, u, prm, c, W, Q, Xp, Pp)
        if hyp:
            _ramp(buf[lay.ramp:lay.ramp + n], Xp, prm)
        kinds, z = channels(mask, z0, z1, z2, z3, z4)
        kinds, z, pose_rejected = pose_gate(cnt, prm, buf[lay.rvar:lay.rvar + N_CHANNELS],
                                            buf[lay.gateP:lay.gateP + 9].reshape((3, 3)), Xp, Pp, cbar, kinds, z)
        m = kinds.shape[0]
        rejected = dropped
        Xs, Ps = Xp, Pp
        mu_new = cbar.copy()
        nis = sp_innov = sp_std = np.nan
        if m > 0:
            if ekf:
                Xn, Pn, Zp, Y, S, nisv, llv = ekf_bank_update(buf, lay.rvar, Xp, Pp, u, prm, kinds, z)
            else:
                Xn, Pn, Zp, Y, S, nisv, llv = ukf_bank_update(buf, lay.rvar, Xp, Pp, u, prm, c, W, kinds, z)
            nis, sp_innov, sp_std = _mixture_innovation(buf, lay, kinds, z, cbar, Zp, S)
            if _mode_probabilities(buf[lay.loglik:lay.loglik + n], cbar, nisv, llv, prm[P_GATE], mu_new):
                Xs, Ps = Xn, Pn
            else:
                rejected = True
        symmetrise(Ps)
        reset = True if not math.isfinite(Xs.sum() + Ps.sum()) else nis_dwell(cnt, nis, prm[P_DIV_NIS])
        if reset:
            _reset(buf, lay, cnt, X, P, X_prev, prm)
        else:
            _keep(X, P, Xs, Ps)
        _floor_normalise(mu_new, mu)
        combine(X, P, mu, buf[lay.x:lay.x + 5], buf[lay.Pc:lay.Pc + 25].reshape((5, 5)))
        count_step(cnt, rejected)
        return nis, sp_innov, sp_std, m, rejected, reset, pose_rejected

    return step


imm_step_ekf = _imm_step(True)
imm_step_ukf = _imm_step(False)
