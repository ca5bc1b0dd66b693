"""One step of a single EKF or UKF with its numerical-health rules, as one compiled call.

Health rules (a run never dies of a filter): non-finite channels are dropped (the step counts as a
rejection); a pose fix that fails the χ² gate (:func:`.bank.pose_gate`) is dropped and counted apart, the
step updating with its other channels; an update whose NIS exceeds ``nis_gate`` is not applied (a rejection); ``P`` is
symmetrised after every step and, for the EKF, eigen-floored if it stops being positive definite (the
UKF's next Cholesky repairs it itself); divergence (non-finite or non-positive variances, or NIS above
``divergence_nis`` for ``divergence_dwell`` s) resets the filter to its last finite estimate (radii
clipped to ``[min_radius, 10 R0]``) with covariance ``reset_inflation · P0``.
"""

from __future__ import annotations

import math

import numpy as np

from .bank import clip_radii, count_step, ekf_bank_update, nis_dwell, pose_gate, speed_std, ukf_bank_update
from .jit import njit
from .kalman import channels, ekf_predict, ukf_predict, weights
from .layout import (
    C_BAD_NIS,
    C_RESETS,
    N_CHANNELS,
    N_PRM,
    P_DIV_NIS,
    P_GATE,
    P_INFLATION,
    P_KAPPA,
    SPEED,
    Layout,
    layout,
)
from .linalg import chol, eig_floor, symmetrise

MODEL_DIGEST = "d5385545ce3b5bff"
"""Digest of :mod:`.generated` this module's compiled code includes (see :mod:`ftc_mj.estimation.codegen`)."""


@njit(cache=True, error_model="numpy")
def _posterior(buf: np.ndarray, lay: Layout, Y: np.ndarray, S: np.ndarray, nisv: np.ndarray, kinds: np.ndarray,
               prm: np.ndarray) -> tuple[float, float, float, bool]:
    """After the measurement update: writes ``y[:m]``, ``S[:m, :m]`` into ``buf`` and returns the NIS, the
    speed innovation and its std (m/s; NaN without a speed channel) and whether the update passes the
    gate."""
    m = kinds.shape[0]
    nis = nisv[0]
    y_out = buf[lay.y:lay.y + N_CHANNELS]
    S_out = buf[lay.S:lay.S + N_CHANNELS * N_CHANNELS].reshape((N_CHANNELS, N_CHANNELS))
    for i in range(m):
        y_out[i] = Y[0, i]
        for i2 in range(m):
            S_out[i, i2] = S[0, i, i2]
    sp_innov = sp_std = np.nan
    if kinds[0] == SPEED:
        sp_innov = Y[0, 0]
        sp_std = speed_std(S[0, 0, 0])
    return nis, sp_innov, sp_std, nis <= prm[P_GATE]  # False for NaN


@njit(cache=True, error_model="numpy")
def _diverged(cnt: np.ndarray, xs: np.ndarray, Pm: np.ndarray, nis: float, prm: np.ndarray) -> bool:
    """Unhealthy (non-finite, non-positive variance) or NIS too high for too long."""
    healthy = math.isfinite(xs.sum() + Pm.sum())
    if healthy:
        dmin = Pm[0, 0]
        for a in range(1, 5):
            dmin = min(dmin, Pm[a, a])
        healthy = dmin > 0.0
    return True if not healthy else nis_dwell(cnt, nis, prm[P_DIV_NIS])


@njit(cache=True, error_model="numpy")
def _reset(buf: np.ndarray, lay: Layout, cnt: np.ndarray, x: np.ndarray, P: np.ndarray, x_prev: np.ndarray,
           prm: np.ndarray) -> None:
    """Reset to the last finite estimate (else ``x0``), radii clipped, covariance ``reset_inflation · P0``."""
    cnt[C_RESETS] += 1
    cnt[C_BAD_NIS] = 0
    src = x_prev if np.all(np.isfinite(x_prev)) else buf[lay.x0:lay.x0 + 5]
    for a in range(5):
        x[a] = src[a]
    clip_radii(x, prm)
    P0 = buf[lay.P0:lay.P0 + 25].reshape((5, 5))
    for a in range(5):
        for b in range(5):
            P[a, b] = prm[P_INFLATION] * P0[a, b]


@njit(cache=True, error_model="numpy")
def _repair(Pm: np.ndarray) -> None:
    """The EKF's covariance eigen-floored if it is not positive definite (the UKF's next Cholesky
    repairs a non-PD covariance itself)."""
    L = np.empty((5, 5))
    chol(Pm, 1.0, L)
    if math.isnan(L[4, 4]):
        eig_floor(Pm, Pm)


@njit(cache=True, error_model="numpy")
def _store(x: np.ndarray, P: np.ndarray, xs: np.ndarray, Pm: np.ndarray) -> None:
    """Store the step's estimate."""
    for a in range(5):
        x[a] = xs[a]
        for b in range(5):
            P[a, b] = Pm[a, b]


def _single_step(ekf: bool):
    """The compiled step of a single EKF (``ekf``) or UKF: one function per kind, so that a run compiles
    only its filter's (``ekf`` is a closure constant; numba prunes the other kind's branches)."""

    @njit(cache=True, error_model="numpy")
    def step(buf: np.ndarray, cnt: np.ndarray, u0: float, u1: float, z0: float, z1: float, z2: float,
             z3: float, z4: float, mask: int, dropped: bool) -> tuple[float, float, float, int, bool, bool, bool]:
        """One step of the single filter on its buffers, in place.

        ``u0, u1`` wheel rates (rad/s), ``z0..z4`` the values of the channels in ``mask`` (bit k = channel
        code k; the first ``m`` used, SI units); ``dropped`` a channel was non-finite. Returns ``(NIS,
        speed innovation (m/s), its std (m/s), m, rejected, reset, pose fix rejected)``; the state, the
        innovation ``y[:m]`` and its covariance ``S[:m, :m]`` are in ``buf``.
        """
        lay = layout(1)
        x = buf[lay.X:lay.X + 5]
        P = buf[lay.P:lay.P + 25].reshape((5, 5))
        ulast = buf[lay.ulast:lay.ulast + 2]
        prm = buf[lay.prm:lay.prm + N_PRM]
        if math.isfinite(u0 + u1):
            ulast[0] = u0
            ulast[1] = u1
        u = ulast
        x_prev = x.copy()
        c, W = weights(prm[P_KAPPA])
        Xp = np.empty((1, 5))
        Pp = np.empty((1, 5, 5))
        Q = buf[lay.Q:lay.Q + 25].reshape((5, 5))
        if ekf:
            ekf_predict(x.reshape((1, 5)), P.reshape((1, 5, 5)), u, prm, Q, Xp, Pp)
        else:
            ukf_predict(x.reshape((1, 5)), P.reshape((1, 5, 5)), u, prm, c, W, Q, Xp, Pp)
        kinds, z = channels(mask, z0, z1, z2, z3, z4)
        kinds, z, pose_rejected = pose_gate(cnt, prm, buf[lay.rvar:lay.rvar + N_CHANNELS],
                                            buf[lay.gateP:lay.gateP + 9].reshape((3, 3)), Xp, Pp, np.ones(1),
                                            kinds, z)
        m = kinds.shape[0]
        rejected = dropped
        nis = sp_innov = sp_std = np.nan
        Xs, Ps = Xp, Pp
        if m > 0:
            if ekf:
                Xn, Pn, Zp, Y, S, nisv, llv = ekf_bank_update(buf, lay.rvar, Xp, Pp, u, prm, kinds, z)
            else:
                Xn, Pn, Zp, Y, S, nisv, llv = ukf_bank_update(buf, lay.rvar, Xp, Pp, u, prm, c, W, kinds, z)
            nis, sp_innov, sp_std, accept = _posterior(buf, lay, Y, S, nisv, kinds, prm)
            if accept:
                Xs, Ps = Xn, Pn
            else:
                rejected = True
        symmetrise(Ps)
        reset = _diverged(cnt, Xs[0], Ps[0], nis, prm)
        if reset:
            _reset(buf, lay, cnt, x, P, x_prev, prm)
        else:
            if ekf:
                _repair(Ps[0])
            _store(x, P, Xs[0], Ps[0])
        count_step(cnt, rejected)
        return nis, sp_innov, sp_std, m, rejected, reset, pose_rejected

    return step


single_step_ekf = _single_step(True)
single_step_ukf = _single_step(False)
