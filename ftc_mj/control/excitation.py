"""Persistent excitation for fault isolation: a yaw-rate dither at constant speed, and its settings
(:class:`ExcitationSettings`, the ``[reconfiguration.excitation]`` section).

With speed-only sensing only the radius combination ``R_R ω_R + R_L ω_L`` is observed at each
instant (:mod:`~ftc_mj.estimation.observability`); the split between the radii is seen only through
``ω_R − ω_L``, i.e. through turning. A dither of the commanded yaw rate, ``δψ̇(t) = a sin(2π t/T)``,
changes ``ω_R − ω_L`` and so the observed combination. It is added to the controller's command as

    Δω_R = +δψ̇ b / R_R,   Δω_L = −δψ̇ b / R_L

with the radii the controller assumes, which leaves the model's speed ``(R_R ω_R + R_L ω_L)/2``
unchanged and adds exactly ``δψ̇`` to its yaw rate (lateral acceleration ``V δψ̇``). The loop
applies it only while a fault is suspected but not isolated, and clips to the wheel-rate limits and
to the MPC's bound on the step from the command in force.
"""

from __future__ import annotations

import math

import numpy as np

from ..fields import Flag, PosFloat, StrictModel, ranged


class ExcitationSettings(StrictModel):
    """Yaw-rate dither while a fault is suspected but not isolated (off by default).

    With speed-only sensing the split between the radii is seen only through turning
    (``ω_R − ω_L``). The dither adds ``δψ̇ = amplitude · sin(2π t / period)`` to the commanded yaw
    rate at constant model speed (:func:`yaw_dither`, :func:`dither_wheel_rates`); at 10 m/s every 0.1 rad/s of
    amplitude is 1 m/s² of extra lateral acceleration (the robot starts lifting a wheel at 3.9 m/s² in a
    quasi-steady turn, :mod:`ftc_mj.plant.limits`; the circle itself needs 2)."""

    enabled: Flag = False
    amplitude: ranged(0.0, 1.0, lo_open=True, unit="rad/s") = 0.05
    """Yaw-rate dither amplitude (rad/s)."""
    period: PosFloat = 2.0
    """Dither period (s)."""


def yaw_dither(t: float, amplitude: float, period: float) -> float:
    """Yaw-rate dither δψ̇(t) = a sin(2π t / T) (rad/s; ``t``, ``period`` in s)."""
    return amplitude * math.sin(2.0 * math.pi * t / period)


def dither_wheel_rates(omega: np.ndarray, dpsi: float, radii: np.ndarray, half_track: float,
                       omega_max: float, previous: np.ndarray | None = None, max_step: float = np.inf
                       ) -> np.ndarray:
    """Wheel rates (rad/s) ``omega`` = [ω_R, ω_L] with the yaw-rate dither ``dpsi`` (rad/s) added at
    constant model speed, for model radii ``radii`` (m) and half track ``half_track`` (m); clipped to
    ±``omega_max``.

    With ``previous`` (rad/s, the command in force, within ±``omega_max``) the result is also clipped
    to ``previous ± max_step`` (rad/s) per wheel: the MPC's first input already meets that bound, and
    the dither must not carry the applied command past it (where this clip acts, the dither is not at
    constant speed)."""
    d = dpsi * half_track / np.asarray(radii, dtype=float)
    out = np.clip(np.asarray(omega, dtype=float) + d * np.array([1.0, -1.0]), -omega_max, omega_max)
    if previous is not None:
        prev = np.asarray(previous, dtype=float)
        out = np.clip(out, prev - max_step, prev + max_step)
    return out
