"""What the single-filter and the IMM steps share: predict/update of a bank by member kind, and the
divergence bookkeeping (NIS dwell, radius clipping on a reset)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kalman import ekf_predict, ekf_update, ukf_predict, ukf_update
from .layout import C_BAD_NIS, C_DIV_STEPS, P_MIN_RADIUS, P_R0

MODEL_DIGEST = "d5385545ce3b5bff"
"""Digest of :mod:`.generated` this module's compiled code includes (see :mod:`ftc_mj.estimation.codegen`)."""


@njit(cache=True, error_model="numpy")
def predict_bank(ekf: bool, X: np.ndarray, P: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float,
                 W: np.ndarray, Q: np.ndarray, Xp: np.ndarray, Pp: np.ndarray) -> None:
    """EKF or UKF prediction of every member into ``Xp`` (n, 5), ``Pp`` (n, 5, 5); wheel rates ``u`` (rad/s)."""
    if ekf:
        ekf_predict(X, P, u, prm, Q, Xp, Pp)
    else:
        ukf_predict(X, P, u, prm, c, W, Q, Xp, Pp)


@njit(cache=True, error_model="numpy")
def update_bank(ekf: bool, Xp: np.ndarray, Pp: np.ndarray, u: np.ndarray, prm: np.ndarray, c: float,
                W: np.ndarray, kinds: np.ndarray, z: np.ndarray, rvar: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """EKF or UKF update of every member with the ``m`` channels ``kinds``/``z`` (SI units): posterior
    ``Xn`` (n, 5), ``Pn`` (n, 5, 5), predicted measurements ``Zp`` and innovations ``Y`` (n, m), their
    covariances ``S`` (n, m, m), NIS and log-likelihoods (n,)."""
    n = Xp.shape[0]
    m = kinds.shape[0]
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
    return Xn, Pn, Zp, Y, S, nisv, llv


@njit(cache=True, error_model="numpy")
def speed_std(s00: float) -> float:
    """``sqrt(max(s00, 0))`` of the speed innovation variance (m²/s² → m/s), NaN staying NaN as Python's max."""
    return math.sqrt(0.0 if 0.0 > s00 else s00)


@njit(cache=True, error_model="numpy")
def nis_dwell(cnt: np.ndarray, nis: float, div_nis: float) -> bool:
    """Count steps with NIS above the divergence level; True once they last ``divergence_dwell``."""
    if math.isfinite(nis) and nis > div_nis:
        cnt[C_BAD_NIS] += 1
    elif math.isfinite(nis):
        cnt[C_BAD_NIS] = 0
    return cnt[C_BAD_NIS] >= cnt[C_DIV_STEPS]


@njit(cache=True, error_model="numpy")
def clip_radii(x: np.ndarray, prm: np.ndarray) -> None:
    """Clip the radii of a reset state ``x`` to ``[min_radius, 10 R0]`` (m)."""
    for a in (3, 4):
        x[a] = min(max(x[a], prm[P_MIN_RADIUS]), 10.0 * prm[P_R0])
