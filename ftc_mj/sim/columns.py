"""Columns of ``trace.parquet``: one row per estimator step, SI units and radians.

Truth: ``x, y, psi, v, yaw_rate, R_R, R_L, omega_R, omega_L, roll, pitch, z, slip_R, slip_L,
plant_flags``; sensors: ``v_meas, yaw_rate_meas, omega_*_meas``; estimator: ``*_hat`` (the estimate
of each state), ``*_std`` (σ of each state: m, m, rad, m, m), the off-diagonal covariances
:data:`COVARIANCE_COLUMNS` (``R_RL_cov``, m², between the radii; ``cov_<a>_<b>`` between the others),
so that any NEES can be recomputed from the trace alone, ``innovation, innovation_std`` (speed
channel, m/s), ``nis`` (normalised innovation squared over all channels of the step), ``nis_dof``
(channels in that update: 1 speed, +1 gyro, +2 on a position fix; 0 = no update),
``fault_detected, fault_suspected`` (a fault is evident but its wheel is not identified),
``declared_wheel`` (:data:`WHEEL_CODES`: the wheel the decision currently declares),
``radius_anomaly`` (1 while a radius estimate lies above nominal beyond the decision's thresholds:
not a puncture), ``radius_split_std`` (m, σ of the unobservable radius split), ``mode_prob_k``;
reconfiguration: ``reconfig_state`` (0 nominal, 1 hold, 2 handed over, 3 reverted), ``excitation``
(yaw-rate dither, rad/s, NaN when off); controller: ``omega_*_cmd, R_*_model`` (radii the
controller assumed), ``solve_time_ms, solver_iterations, solver_ok`` (on controller samples, NaN
elsewhere); ``cross_track_error`` (m, positive = left of the path).
"""

from __future__ import annotations

STATE = ("x", "y", "psi", "R_R", "R_L")
"""Estimator state order; ``<name>_hat`` and ``<name>_std`` columns follow it."""

COVARIANCE_COLUMNS: dict[tuple[int, int], str] = {
    (i, j): ("R_RL_cov" if (i, j) == (3, 4) else f"cov_{STATE[i]}_{STATE[j]}")
    for i in range(5) for j in range(i + 1, 5)
}
"""Upper off-diagonal entries ``P[i, j]`` of the 5×5 state covariance and their trace columns."""

WHEEL_CODES: dict[str | None, int] = {None: 0, "right": 1, "left": 2, "both": 3, "unknown": 4}
"""``declared_wheel`` codes: nothing declared, right, left, both, fault of unknown wheel."""

BASE_COLUMNS: tuple[str, ...] = (
    "t", "x", "y", "psi", "v", "yaw_rate", "v_meas", "yaw_rate_meas", "R_R", "R_L",
    "R_R_hat", "R_L_hat", "R_R_std", "R_L_std", "x_hat", "y_hat", "psi_hat", "x_std", "y_std", "psi_std",
    *COVARIANCE_COLUMNS.values(),
    "innovation", "innovation_std", "nis", "nis_dof",
    "omega_R", "omega_L", "omega_R_meas", "omega_L_meas", "omega_R_cmd", "omega_L_cmd",
    "R_R_model", "R_L_model", "cross_track_error", "roll", "pitch", "z", "slip_R", "slip_L",
    "plant_flags", "fault_detected", "fault_suspected", "declared_wheel", "radius_anomaly", "radius_split_std",
    "reconfig_state", "excitation", "solve_time_ms", "solver_iterations", "solver_ok",
)
