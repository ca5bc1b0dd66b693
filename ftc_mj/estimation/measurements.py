"""A step's measurement as the filters see it: the usable channels of a :class:`~.base.Measurement`
(speed, yaw rate, x, y, heading — those the configured sensors provide and that are finite), the scalar
arguments of a compiled step, and the measurement Jacobian of a batch of states."""

from __future__ import annotations

import math

import numpy as np

from ..model.kinematics import KinematicModel, numpy_rates_jacobian
from .base import Measurement
from .kernels.layout import HEADING, POS_X, POS_Y, SPEED, YAW
from .setup import FilterSetup

_SPEED_ONLY = (SPEED,)


def channels(setup: FilterSetup, meas: Measurement) -> tuple[list[float], list[float], tuple[int, ...], bool]:
    """The finite channels of ``meas`` that the configured sensor set provides: values (SI units), noise
    variances, channel codes (in the order speed, yaw rate, x, y, heading), and whether a channel that should
    have been there was non-finite and dropped. The heading of a pose fix is a channel when the fix has one
    (``meas.heading``) and the filter knows its noise (``setup.heading_sigma``)."""
    if setup.yaw_rate_sigma is None and setup.position_sigma is None:  # speed sensor only (the paper's set)
        v = meas.speed
        if v is not None and type(v) is float and math.isfinite(v):
            return [v], [setup.speed_sigma * setup.speed_sigma], _SPEED_ONLY, False
    z: list[float] = []
    r: list[float] = []
    kinds: list[int] = []
    dropped = False

    def add(value: float | None, sigma: float, kind: int) -> None:
        nonlocal dropped
        if value is None:
            return
        try:
            v = float(value)
        except (TypeError, ValueError):
            dropped = True
            return
        if not math.isfinite(v):
            dropped = True
            return
        z.append(v)
        r.append(sigma * sigma)
        kinds.append(kind)

    add(meas.speed, setup.speed_sigma, SPEED)
    if setup.yaw_rate_sigma is not None:
        add(meas.yaw_rate, setup.yaw_rate_sigma, YAW)
    if setup.position_sigma is not None and meas.position is not None:
        pos = np.asarray(meas.position, dtype=float).ravel()
        if pos.size != 2 or not np.all(np.isfinite(pos)):
            dropped = True
        else:
            add(pos[0], setup.position_sigma, POS_X)
            add(pos[1], setup.position_sigma, POS_Y)
    if setup.heading_sigma is not None and meas.heading is not None:
        add(meas.heading, setup.heading_sigma, HEADING)
    return z, r, tuple(kinds), dropped


def kernel_inputs(
    setup: FilterSetup, u: np.ndarray, meas: Measurement
) -> tuple[float, float, float, float, float, float, float, int, bool]:
    """Per-step arguments of a compiled step (:mod:`.kernels`) after its two buffers: wheel rates
    ``u0, u1`` (rad/s), the channel values ``z0..z4`` (first ``m`` used, zero padded), the channel
    bit mask and the dropped flag. Plain scalars: cheaper to pass to numba than small arrays."""
    u = np.asarray(u, dtype=float)
    u0, u1 = (u if u.shape == (2,) else u.reshape(2)).tolist()
    z, _, kinds, dropped = channels(setup, meas)
    z0, z1, z2, z3, z4 = (*z, 0.0, 0.0, 0.0, 0.0, 0.0)[:5]
    return u0, u1, z0, z1, z2, z3, z4, kinds_mask(kinds), dropped


_MASKS: dict[tuple[int, ...], int] = {}


def kinds_mask(kinds: tuple[int, ...]) -> int:
    """Bit mask of channel codes (bit k = code k), the compiled kernels' form of a channel tuple."""
    mask = _MASKS.get(kinds)
    if mask is None:
        mask = _MASKS[kinds] = sum(1 << k for k in kinds)
    return mask


def measure_jacobian(model: KinematicModel, X: np.ndarray, u: np.ndarray, kinds: tuple[int, ...]) -> np.ndarray:
    """Measurement Jacobian (M, m, 5) at states ``X`` (M, 5) for wheel rates ``u`` (rad/s), from the AD
    rates Jacobian (rows: d V/dx (m/s per unit), d psidot/dx (rad/s per unit), then the pose rows: unit rows
    of x, y, psi)."""
    Hr = numpy_rates_jacobian(model, X, u)  # (M, 2, 5): rows d V/dx, d psidot/dx
    M = X.shape[0]
    H = np.zeros((M, len(kinds), 5))
    for row, k in enumerate(kinds):
        if k in (SPEED, YAW):
            H[:, row, :] = Hr[:, k, :]
        else:
            H[:, row, k - POS_X] = 1.0
    return H
