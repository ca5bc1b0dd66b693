"""A filter bank's state in the two flat arrays the compiled steps read and write, and the attributes
(views, counters) through which the filter classes expose it."""

from __future__ import annotations

import math

import numpy as np

from .kernels.layout import (
    C_BAD_NIS,
    C_DIV_STEPS,
    C_N,
    C_POSE_REJECTIONS,
    C_POSE_STREAK_MAX,
    C_REJECTIONS,
    C_RESETS,
    HEADING,
    N_COUNTERS,
    N_PRM,
    P_B,
    P_DIV_NIS,
    P_DT,
    P_GATE,
    P_INFLATION,
    P_KAPPA,
    P_MIN_RADIUS,
    P_POSE_GATE,
    P_R0,
    POS_X,
    POS_Y,
    SPEED,
    YAW,
    layout,
)
from .setup import FilterSetup


class FilterBuffers:
    """State, constants and per-step outputs of a bank of ``n`` filters in two flat arrays.

    ``buf`` (float64, offsets :func:`.kernels.layout.layout`) and ``cnt`` (int64, indices ``C_*``) are what a
    compiled step reads and writes; the attributes are views of ``buf`` (see :func:`.kernels.layout.layout`):
    ``X`` (n, 5), ``P`` (n, 5, 5), ``mu``, ``loglik`` (n,), ``x`` (5,), ``Pc`` (5, 5), ``y`` (5,), ``S`` (5, 5),
    ``ulast`` (2,), the constants ``Q``, ``P0``, ``x0``, ``rvar`` (noise variance by channel code), ``Pi``
    (n, n), ``pin_value``/``pin`` (n, 2), ``keep``/``reset_var`` (n, 5, 5), ``ramp`` (n,), ``gateP`` (3, 3) and
    ``prm``.
    """

    def __init__(self, setup: FilterSetup, n: int) -> None:
        lay = layout(n)
        self.n = n
        self.buf = np.zeros(lay.size)
        self.cnt = np.zeros(N_COUNTERS, dtype=np.int64)

        def view(offset: int, *shape: int) -> np.ndarray:
            return self.buf[offset:offset + math.prod(shape)].reshape(shape)

        self.X, self.P = view(lay.X, n, 5), view(lay.P, n, 5, 5)
        self.mu, self.loglik = view(lay.mu, n), view(lay.loglik, n)
        self.x, self.Pc = view(lay.x, 5), view(lay.Pc, 5, 5)
        self.y, self.S, self.ulast = view(lay.y, 5), view(lay.S, 5, 5), view(lay.ulast, 2)
        self.Q, self.P0, self.x0 = view(lay.Q, 5, 5), view(lay.P0, 5, 5), view(lay.x0, 5)
        self.rvar, self.Pi = view(lay.rvar, 5), view(lay.Pi, n, n)
        self.pin_value, self.pin = view(lay.pin_value, n, 2), view(lay.pin, n, 2)
        self.keep, self.reset_var = view(lay.keep, n, 5, 5), view(lay.reset_var, n, 5, 5)
        self.ramp, self.prm = view(lay.ramp, n), view(lay.prm, N_PRM)
        self.gateP = view(lay.gateP, 3, 3)
        # the innovation and its covariance over m channels, by m (views made once, not per step)
        self.y_of = [self.y[:m] for m in range(6)]
        self.S_of = [self.S[:m, :m] for m in range(6)]
        self.Q[:], self.P0[:], self.x0[:] = setup.Q, setup.P0, setup.x0
        # variances as the channel assembly computes them (sigma * sigma)
        for code, sigma in ((SPEED, setup.speed_sigma), (YAW, setup.yaw_rate_sigma),
                            (POS_X, setup.position_sigma), (POS_Y, setup.position_sigma),
                            (HEADING, setup.heading_sigma)):
            self.rvar[code] = math.nan if sigma is None else sigma * sigma
        prm = self.prm
        prm[P_DT], prm[P_B] = setup.dt, setup.model.b
        prm[P_KAPPA] = math.nan if setup.kappa is None else setup.kappa  # read by sigma-point steps only
        prm[P_GATE], prm[P_DIV_NIS] = setup.nis_gate, setup.divergence_nis
        prm[P_INFLATION], prm[P_MIN_RADIUS], prm[P_R0] = setup.reset_inflation, setup.min_radius, setup.nominal_radius
        prm[P_POSE_GATE] = setup.pose_gate_quantile
        self.cnt[C_DIV_STEPS] = setup.divergence_steps
        self.cnt[C_POSE_STREAK_MAX] = setup.pose_gate_steps
        self.cnt[C_N] = n


class Counter:
    """Attribute that is the integer ``self._st.cnt[index]`` (counted by the compiled steps)."""

    def __init__(self, index: int, doc: str = "") -> None:
        self.index = index
        self.__doc__ = doc

    def __get__(self, obj: object, objtype: type | None = None) -> int:
        return int(obj._st.cnt[self.index])  # type: ignore[union-attr]

    def __set__(self, obj: object, value: int) -> None:
        obj._st.cnt[self.index] = value  # type: ignore[attr-defined]


class BufferView:
    """Attribute that is the view ``self._st.<name>`` of a filter's buffers: reading gives the live
    array (it changes with every step), assigning copies the value into it (shape-checked)."""

    def __init__(self, name: str, doc: str = "") -> None:
        self.name = name
        self.__doc__ = doc

    def __get__(self, obj: object, objtype: type | None = None) -> np.ndarray:
        return getattr(obj._st, self.name)  # type: ignore[union-attr]

    def __set__(self, obj: object, value: np.ndarray) -> None:
        view = getattr(obj._st, self.name)  # type: ignore[attr-defined]
        view[...] = np.asarray(value, dtype=float).reshape(view.shape)


class HealthCounters:
    """``resets``/``rejections`` (and the internal NIS-dwell counter) kept in ``self._st.cnt``, where the
    compiled steps count them."""

    _st: FilterBuffers
    resets = Counter(C_RESETS, "Divergence resets so far.")
    rejections = Counter(C_REJECTIONS, "Steps whose measurement was rejected (non-finite channel, NIS above gate).")
    pose_rejections = Counter(C_POSE_REJECTIONS, "Pose fixes whose position the χ² gate rejected (the step's other "
                                                 "channels used).")
    _bad_nis_steps = Counter(C_BAD_NIS, "Consecutive steps with NIS above the divergence level.")
