"""The numbers of the tracking problem and the bound and penalty of its first input.

The problem itself (cost, constraints, the LGL transcription) is described in
:mod:`ftc_mj.control.transcription`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ProblemSpec:
    """Numbers that define the tracking problem (units in the field comments)."""

    nodes: int = 50
    horizon: float = 5.0  # s
    half_track: float = 1.0  # m
    omega_max: float = np.radians(1000.0)  # rad/s
    omega_rate_max: float = 20.0  # rad/s^2
    q_pose: float = 10.0
    q_speed: float = 1.0
    q_yaw_rate: float = 1.0
    rate_penalty: float = 0.0
    max_lateral_accel: float | None = None  # m/s^2; None = no bound (the paper's problem)
    max_longitudinal_accel: float | None = None  # m/s^2; None = no bound
    sample_time: float = 0.1  # s, controller period T_s (the command is held that long)
    rate_bound_from_applied: bool = True  # |U(t0) - u_prev| <= omega_rate_max T_s; False = free first input
    rate_penalty_first_step: bool = False  # rate_penalty also covers U(t0) - u_prev (with the bound on)


def first_input_bounds(spec: ProblemSpec, u_prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``lo ≤ U(t0) ≤ hi`` (rad/s, each (2,) [omega_R, omega_L]) on the plan's first input.

    ``u_prev`` (rad/s) is the input in force before ``t0``; the bound is
    ``|U(t0) − u_prev| ≤ omega_rate_max T_s`` intersected with ``|U(t0)| ≤ omega_max``, with ``u_prev``
    first clipped to the input bounds so that the interval is never empty. ``None``: no first-step
    bound (only ``|U(t0)| ≤ omega_max``).
    """
    om = spec.omega_max
    if u_prev is None:
        return np.full(2, -om), np.full(2, om)
    u = np.asarray(u_prev, dtype=float).ravel()
    if u.shape != (2,) or not np.all(np.isfinite(u)):
        raise ValueError(f"u_applied must be two finite wheel rates (rad/s), got {u_prev!r}")
    u = np.clip(u, -om, om)
    step = spec.omega_rate_max * spec.sample_time
    return np.maximum(u - step, -om), np.minimum(u + step, om)



def first_step_penalty(spec: ProblemSpec, u_prev: np.ndarray | None) -> float:
    """Weight ``c`` of the first-step penalty ``c ‖U(t0) − u_prev‖²`` (rad/s)⁻² per unit cost:
    ``rate_penalty T_s ‖(U(t0) − u_prev)/T_s‖² = (rate_penalty / T_s) ‖U(t0) − u_prev‖²``; 0 without
    ``u_prev``, without the rate penalty or with ``rate_penalty_first_step`` off."""
    return 0.0 if u_prev is None or not spec.rate_penalty_first_step else spec.rate_penalty / spec.sample_time

