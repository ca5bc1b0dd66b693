"""What the single-filter and the IMM steps share: a bank's measurement update (EKF or UKF members) and its
outputs, and the divergence bookkeeping (NIS dwell, radius clipping on a reset).

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
from .layout import C_BAD_NIS, C_DIV_STEPS, C_REJECTIONS, C_STEPS, P_MIN_RADIUS, P_R0

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
    ``kinds`` and values ``z`` (SI units), the channel variances at ``buf[rvar_at:rvar_at + 4]``. Returns the
    outputs of :func:`update_outputs`, filled (shared by the single-filter and the IMM steps)."""
    Xn, Pn, Zp, Y, S, nisv, llv = update_outputs(Xp.shape[0], kinds.shape[0])
    ekf_update(Xp, Pp, u, prm, kinds, z, buf[rvar_at:rvar_at + 4], Xn, Pn, Zp, Y, S, nisv, llv)
    return Xn, Pn, Zp, Y, S, nisv, llv


@njit(cache=True, error_model="numpy")
def ukf_bank_update(buf: np.ndarray, rvar_at: int, Xp: np.ndarray, Pp: np.ndarray, u: np.ndarray, prm: np.ndarray,
                    c: float, W: np.ndarray, kinds: np.ndarray, z: np.ndarray):
    """:func:`ekf_bank_update` for UKF members (``c, W``: the unscented scaling and weights)."""
    Xn, Pn, Zp, Y, S, nisv, llv = update_outputs(Xp.shape[0], kinds.shape[0])
    ukf_update(Xp, Pp, u, prm, c, W, kinds, z, buf[rvar_at:rvar_at + 4], Xn, Pn, Zp, Y, S, nisv, llv)
    return Xn, Pn, Zp, Y, S, nisv, llv


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
