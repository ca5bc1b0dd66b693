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
from .kalman import ekf_update, ukf_update, wrap_angle
from .layout import (
    C_BAD_NIS,
    C_DIV_STEPS,
    C_HEADING_STREAK,
    C_POSE_REJECTIONS,
    C_POSE_STREAK,
    C_POSE_STREAK_MAX,
    C_REJECTIONS,
    C_STEPS,
    HEADING,
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
def _gate_group(cnt: np.ndarray, prm: np.ndarray, rvar: np.ndarray, gateP: np.ndarray, Xp: np.ndarray,
                Pp: np.ndarray, w: np.ndarray, kinds: np.ndarray, z: np.ndarray, lo: int, hi: int, streak: int
                ) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`pose_gate` for the fix's channels of codes ``lo..hi`` (its position, or its heading), its current
    streak of rejections begun at step ``cnt[streak] - 1`` (0: none): the channels left and whether these were
    rejected."""
    m = kinds.shape[0]
    k = 0
    for i in range(m):
        if lo <= kinds[i] <= hi:
            k += 1
    if k == 0 or prm[P_POSE_GATE + k - 1] == np.inf:
        return kinds, z, False
    xm = np.zeros(3)
    for a in range(lo - POS_X, hi - POS_X + 1):
        for j in range(Xp.shape[0]):
            xm[a] += w[j] * Xp[j, a]
    if cnt[streak] == 0:  # the streak's reference covariance: this fix's prediction
        for a in range(lo - POS_X, hi - POS_X + 1):
            for b in range(lo - POS_X, hi - POS_X + 1):
                s = 0.0
                for j in range(Xp.shape[0]):
                    s += w[j] * (Pp[j, a, b] + (Xp[j, a] - xm[a]) * (Xp[j, b] - xm[b]))
                gateP[a, b] = s
    S = np.empty((k, k))
    y = np.empty(k)
    first = m - k if kinds[m - 1] == hi else m - k - 1  # the heading (code 4) follows x, y
    for i in range(k):
        c = kinds[first + i]
        for i2 in range(k):
            S[i, i2] = gateP[c - POS_X, kinds[first + i2] - POS_X] + (rvar[c] if i == i2 else 0.0)
        y[i] = z[first + i] - xm[c - POS_X]
        if c == HEADING:
            y[i] = wrap_angle(y[i])
    nis, _ = gaussian(y, S, np.empty((k, k)))
    ended = cnt[streak] != 0 and cnt[C_STEPS] + 1 - cnt[streak] >= cnt[C_POSE_STREAK_MAX]  # the streak's limit
    if nis <= prm[P_POSE_GATE + k - 1] or ended:
        cnt[streak] = 0
        return kinds, z, False
    if cnt[streak] == 0:
        cnt[streak] = cnt[C_STEPS] + 1
    keep = np.empty(m - k, np.int64)
    zk = np.empty(m - k)
    n = 0
    for i in range(m):
        if not lo <= kinds[i] <= hi:
            keep[n] = kinds[i]
            zk[n] = z[i]
            n += 1
    return keep, zk, True


@njit(cache=True, error_model="numpy")
def pose_gate(cnt: np.ndarray, prm: np.ndarray, rvar: np.ndarray, gateP: np.ndarray, Xp: np.ndarray, Pp: np.ndarray,
              w: np.ndarray, kinds: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The χ² gate on a pose fix: the channels to update with and whether (part of) the fix was rejected.

    The fix's position (x, y) and its heading are gated apart (a position jump leaves the heading of a
    two-antenna fix good): each against the predictive density of the bank's members ``Xp`` (n, 5), ``Pp``
    (n, 5, 5) mixed with weights ``w`` (one member: weight 1) — NIS ``yᵀS⁻¹y``, ``y`` the fix minus the
    mixture's mean (heading wrapped), ``S`` the mixture's covariance plus the fix's noise ``rvar``. Above the
    χ² quantile of its ``k`` channels (``prm[P_POSE_GATE + k - 1]``; +inf: no gate) the part is dropped (the
    step's other channels are kept) and the fix counted. During a streak of rejections the covariance is the
    one of the streak's first fix (kept in ``gateP``), not the prediction's, which grows while no fix is taken
    in: else the gate would open by itself after a second or so of dead reckoning and let a jump through. Once a
    streak has lasted ``cnt[C_POSE_STREAK_MAX]`` steps the next fix is fused whatever its NIS: a lasting offset
    (or a filter that has lost its pose) cannot lock the filter out of its pose sensor for ever."""
    kinds, z, pos_rejected = _gate_group(cnt, prm, rvar, gateP, Xp, Pp, w, kinds, z, POS_X, POS_Y, C_POSE_STREAK)
    kinds, z, head_rejected = _gate_group(cnt, prm, rvar, gateP, Xp, Pp, w, kinds, z, HEADING, HEADING,
                                          C_HEADING_STREAK)
    rejected = pos_rejected or head_rejected
    if rejected:
        cnt[C_POSE_REJECTIONS] += 1
    return kinds, z, rejected


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
