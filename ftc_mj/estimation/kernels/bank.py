"""What the single-filter and the IMM steps share: a bank's measurement update (EKF or UKF members) and its
outputs, the χ² gate on pose fixes (:func:`pose_gate`), and the divergence bookkeeping (NIS dwell, radius
clipping on a reset).

Each step is compiled once per member kind (the kind is a closure constant and numba prunes the other
kind's branches), so a run compiles only its filter's code. The update is one function per kind
(:func:`ekf_bank_update`, :func:`ukf_bank_update`), called by both steps: one call level between a step and
:mod:`.kalman` (numba optimises every function's module with its callees linked in, so each level adds
compile time; measured with ``benchmarks/bench_first_run.py``, this one is within the run-to-run noise).
Module-level functions, not closures: a closure captured by a cached step would make numba's cache miss
in every new process.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import njit
from .kalman import ekf_update, ukf_update
from .layout import (
    C_BAD_NIS,
    C_DIV_STEPS,
    C_POSE_REJECTIONS,
    C_POSE_STREAK,
    C_POSE_STREAK_MAX,
    C_REJECTIONS,
    C_STEPS,
    N_CHANNELS,
    P_MIN_RADIUS,
    P_POSE_GATE,
    P_R0,
    POS_X,
    POS_Y,
)
from .linalg import gaussian

MODEL_DIGEST = "d5385545ce3b5bff"
"""Digest of :mod:`.generated` this module's compiled code includes (see :mod:`ftc_mj.estimation.codegen`)."""


@njit(cache=True, error_model="numpy")
def update_outputs(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                             np.ndarray]:
    """Empty outputs of the measurement update of ``n`` members with ``m`` channels (the last arguments
    of :func:`.kalman.ekf_update` and :func:`.kalman.ukf_update`): posterior ``Xn`` (n, 5), ``Pn``
    (n, 5, 5), predicted measurements ``Zp`` and innovations ``Y`` (n, m), their covariances ``S``
    (n, m, m), NIS and log-likelihoods (n,)."""
    return (np.empty((n, 5)), np.empty((n, 5, 5)), np.empty((n, m)), np.empty((n, m)), np.empty((n, m, m)),
            np.empty(n), np.empty(n))


@njit(cache=True, error_model="numpy")
def ekf_bank_update(buf: np.ndarray, rvar_at: int, Xp: np.ndarray, Pp: np.ndarray, u: np.ndarray, prm: np.ndarray,
                    kinds: np.ndarray, z: np.ndarray):
    """The EKF measurement update of the predicted members ``Xp`` (n, 5), ``Pp`` (n, 5, 5) with the channels
    ``kinds`` and values ``z`` (SI units), the channel variances at ``buf[rvar_at:rvar_at + N_CHANNELS]``. Returns the
    outputs of :func:`update_outputs`, filled (shared by the single-filter and the IMM steps)."""
    Xn, Pn, Zp, Y, S, nisv, llv = update_outputs(Xp.shape[0], kinds.shape[0])
    ekf_update(Xp, Pp, u, prm, kinds, z, buf[rvar_at:rvar_at + N_CHANNELS], Xn, Pn, Zp, Y, S, nisv, llv)
    return Xn, Pn, Zp, Y, S, nisv, llv


@njit(cache=True, error_model="numpy")
def ukf_bank_update(buf: np.ndarray, rvar_at: int, Xp: np.ndarray, Pp: np.ndarray, u: np.ndarray, prm: np.ndarray,
                    c: float, W: np.ndarray, kinds: np.ndarray, z: np.ndarray):
    """:func:`ekf_bank_update` for UKF members (``c, W``: the unscented scaling and weights)."""
    Xn, Pn, Zp, Y, S, nisv, llv = update_outputs(Xp.shape[0], kinds.shape[0])
    ukf_update(Xp, Pp, u, prm, c, W, kinds, z, buf[rvar_at:rvar_at + N_CHANNELS], Xn, Pn, Zp, Y, S, nisv, llv)
    return Xn, Pn, Zp, Y, S, nisv, llv


@njit(cache=True, error_model="numpy")
def pose_gate(cnt: np.ndarray, prm: np.ndarray, rvar: np.ndarray, gateP: np.ndarray, Xp: np.ndarray, Pp: np.ndarray,
              w: np.ndarray, kinds: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The χ² gate on a pose fix's position: the channels to update with and whether the position was rejected.

    The fix's x, y are tested against the predictive density of the bank's members ``Xp`` (n, 5), ``Pp``
    (n, 5, 5) mixed with weights ``w`` (one member: weight 1): NIS ``yᵀS⁻¹y``, ``y`` the fix minus the
    mixture's mean, ``S`` the mixture's covariance plus the fix's noise ``rvar``. Above the χ² quantile
    ``prm[P_POSE_GATE]`` (2 dof; +inf: no gate) x, y are dropped and counted; the step's other channels — the
    fix's heading among them: no pose fault moves it, and it keeps the dead reckoning straight while the
    position is gated — are kept. During a streak of rejections the covariance is the one of the streak's first
    fix (kept in ``gateP``), not the prediction's, which grows while no fix is taken in: else the gate would
    open by itself after a second or so of dead reckoning and let a jump through. Once a streak has lasted
    ``cnt[C_POSE_STREAK_MAX]`` steps the next fix is fused whatever its NIS (with the covariance grown over the
    streak, the filter moves most of the way to it): a lasting offset (or a filter that has lost its pose)
    cannot lock the filter out of its pose sensor for ever."""
    m = kinds.shape[0]
    first = -1
    for i in range(m):
        if kinds[i] == POS_X:
            first = i
    thr = prm[P_POSE_GATE]
    if first < 0 or thr == np.inf:
        return kinds, z, False
    xm = np.zeros(2)
    for a in range(2):
        for j in range(Xp.shape[0]):
            xm[a] += w[j] * Xp[j, a]
    if cnt[C_POSE_STREAK] == 0:  # the streak's reference covariance: this fix's prediction
        for a in range(2):
            for b in range(2):
                s = 0.0
                for j in range(Xp.shape[0]):
                    s += w[j] * (Pp[j, a, b] + (Xp[j, a] - xm[a]) * (Xp[j, b] - xm[b]))
                gateP[a, b] = s
    S = np.empty((2, 2))
    y = np.empty(2)
    for a in range(2):
        for b in range(2):
            S[a, b] = gateP[a, b] + (rvar[POS_X + a] if a == b else 0.0)
        y[a] = z[first + a] - xm[a]
    nis, _ = gaussian(y, S, np.empty((2, 2)))
    if nis <= thr:
        cnt[C_POSE_STREAK] = 0
        return kinds, z, False
    if cnt[C_POSE_STREAK] != 0 and cnt[C_STEPS] + 1 - cnt[C_POSE_STREAK] >= cnt[C_POSE_STREAK_MAX]:
        cnt[C_POSE_STREAK] = 0  # the streak's end: the fix is fused
        return kinds, z, False
    if cnt[C_POSE_STREAK] == 0:
        cnt[C_POSE_STREAK] = cnt[C_STEPS] + 1
    cnt[C_POSE_REJECTIONS] += 1
    keep = np.empty(m - 2, np.int64)
    zk = np.empty(m - 2)
    n = 0
    for i in range(m):
        if kinds[i] != POS_X and kinds[i] != POS_Y:
            keep[n] = kinds[i]
            zk[n] = z[i]
            n += 1
    return keep, zk, True


@njit(cache=True, error_model="numpy")
def count_step(cnt: np.ndarray, rejected: bool) -> None:
    """Count the step, and its rejection."""
    if rejected:
        cnt[C_REJECTIONS] += 1
    cnt[C_STEPS] += 1


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
