"""Where a filter bank's state lives: the channel codes, the flat-buffer layout and its indices.

A bank of ``n`` filters (``n = 1`` for a single EKF/UKF) keeps its state, constants and per-step outputs
in one float64 buffer (offsets: :func:`layout`) and one int64 buffer (indices ``C_*``), so that a
compiled step takes two arrays: numba's call overhead grows with the number of array arguments.
"""

from __future__ import annotations

import math
from collections import namedtuple

from .jit import njit

SPEED, YAW, POS_X, POS_Y, HEADING = 0, 1, 2, 3, 4
"""Measurement channel codes, in the order the channels are stacked (speed, yaw rate, x, y, heading). The pose
channels (x, y, heading: codes ``POS_X`` and up) measure the state's first three entries directly."""
N_CHANNELS = 5
"""Channel codes (the most channels a step can have)."""
LOG_2PI = math.log(2.0 * math.pi)
EIG_FLOOR = 1e-12
"""Smallest eigenvalue (in units of the state, squared) kept when repairing a covariance."""
MU_FLOOR = 1e-300
"""Smallest IMM mode probability (no mode is ever impossible, as filterpy's likelihood floor)."""
N_SIGMA = 11
"""Julier sigma points of the 5-state filter: 2n + 1."""

# int64 buffer: counters, then constants. Slot 5 held the member kind (EKF or UKF); the kind now selects
# the compiled step itself (:mod:`.single`, :mod:`.imm`), so the slot is unused. The indices stay: the
# kernels' cached machine code has them built in, and their source files do not change with this one.
# Slots 8-10: the pose fixes the gate rejected, the longest streak of rejections (steps), the step (+1) at which the
# current streak of rejected fixes began (0: none).
C_RESETS, C_REJECTIONS, C_BAD_NIS, C_STEPS, C_DIV_STEPS, _C_UNUSED, C_HYP, C_N = range(8)
C_POSE_REJECTIONS, C_POSE_STREAK_MAX, C_POSE_STREAK = 8, 9, 10
N_COUNTERS = 11

# float scalars at ``layout(n).prm``
# (``P_POSE_GATE``: the pose gate's χ² quantile of 2 dof, the fix's x, y; +inf: no gate)
P_DT, P_B, P_KAPPA, P_GATE, P_DIV_NIS, P_INFLATION, P_MIN_RADIUS, P_R0, P_RAMP_STEP, P_POSE_GATE = range(10)
N_PRM = 10

Layout = namedtuple(
    "Layout",
    "X P mu loglik x Pc y S ulast Q P0 x0 rvar Pi pin_value pin keep reset_var ramp gateP prm size",
)
"""Offsets into the float buffer of a bank of ``n`` filters (``size`` = its length)."""


@njit(cache=True, error_model="numpy")
def layout(n: int) -> Layout:
    """Offsets of the float buffer of ``n`` members: state, per-step outputs, then constants.

    ``X`` (n, 5) and ``P`` (n, 5, 5) member states; ``mu``/``loglik`` (n,) IMM mode probabilities and
    last accepted log-likelihoods; ``x``/``Pc`` combined estimate (IMM); ``y`` (5,) and ``S`` (5, 5)
    innovation and its covariance of the last step (first ``m`` channels); ``ulast`` last finite wheel
    rates; constants ``Q``, ``P0``, ``x0``, ``rvar`` (noise variance per channel code), IMM transition
    ``Pi`` (n, n) and hypothesis data, the pose gate's covariance ``gateP`` (3, 3; its x, y block used) of
    the predicted pose at the start of a streak of rejected fixes, and the scalars ``prm`` (``P_*``).
    """
    sizes = (5 * n, 25 * n, n, n, 5, 25, 5, 25, 2, 25, 25, 5, 5, n * n, 2 * n, 2 * n, 25 * n, 25 * n, n, 9, N_PRM)
    o = [0]
    for size in sizes:
        o.append(o[-1] + size)
    return Layout(o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], o[8], o[9], o[10], o[11], o[12], o[13], o[14],
                  o[15], o[16], o[17], o[18], o[19], o[20], o[21])
