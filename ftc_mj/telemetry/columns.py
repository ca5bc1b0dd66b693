"""Columns of ``trace.parquet``: one row per estimator step, SI units and radians.

Truth: ``x, y, psi, v, yaw_rate, R_R, R_L, omega_R, omega_L, roll, pitch, z, slip_R, slip_L,
plant_flags``; sensors: ``v_meas, yaw_rate_meas, omega_*_meas``; estimator: ``*_hat`` (the estimate
of each state), ``*_std`` (σ of each state: m, m, rad, m, m), the off-diagonal covariances
:data:`COVARIANCE_COLUMNS` (``R_RL_cov``, m², between the radii; ``cov_<a>_<b>`` between the others),
so that any NEES can be recomputed from the trace alone, ``innovation, innovation_std`` (speed
channel, m/s), ``nis`` (normalised innovation squared over all channels of the step), ``nis_dof``
(channels in that update: 1 speed, +1 gyro, +2 on a position fix, +1 its heading; 0 = no update),
``fault_detected, fault_suspected`` (a fault is evident but its wheel is not identified),
``declared_wheel`` (:data:`WHEEL_CODES`: the wheel the decision currently declares),
``radius_anomaly`` (1 while a radius estimate lies above nominal beyond the decision's thresholds:
not a puncture), ``radius_split_std`` (m, σ of the unobservable radius split), ``mode_prob_k``;
reconfiguration: ``reconfig_state`` (0 nominal, 1 hold, 2 handed over, 3 reverted), ``excitation``
(yaw-rate dither, rad/s, NaN when off); controller: ``omega_*_cmd, R_*_model`` (radii the
controller assumed), ``solve_time_ms, solver_iterations, solver_ok`` (on controller samples, NaN
elsewhere); ``cross_track_error`` (m, positive = left of the path);
``x_meas, y_meas`` (position fixes, NaN between them); the posterior Cramér–Rao bound of the
filters' model along the true trajectory, ``R_R_pcrb_std, R_L_pcrb_std, radius_split_pcrb_std``
(m, :mod:`ftc_mj.estimation.pcrb`); every fault-decision rule's statistic
(:data:`~ftc_mj.estimation.rule_statistics.STAT_COLUMNS`: ``sigma_stat, mode_stat, cusum_stat,
glr_stat`` with their ``*_wheel`` isolation codes, ``glr_drop`` (m), ``glr_onset`` (s), …).
Only in a run with such faults, the injected faults' truth (:data:`FAULT_TRUTH_COLUMNS`):
``fault_effectiveness_R/L`` (fraction of each servo's gain and torque limit acting), ``fault_lock_R/L``
(0/1), ``fault_speed_offset`` (m/s), ``fault_yaw_rate_offset`` (rad/s), ``fault_pose_offset`` (m),
``fault_speed_dropout``, ``fault_yaw_rate_dropout``, ``fault_pose_dropout`` (0/1). Only in a run with a filter
and a pose sensor, :data:`POSE_GATE_COLUMN` ``pose_rejected``: on a row with a pose fix 1 if the filter's χ²
gate rejected it, 0 if it was fused (NaN without a fix).
"""

from __future__ import annotations

from ..estimation.change import WHEEL_CODES
from ..estimation.diagnosis.base import (
    COMPONENT_CODES,
    DIAGNOSIS_COLUMNS,
    DIAGNOSIS_INTEGER_COLUMNS,
    MODE_CODES,
    TARGET_CODES,
)
from ..estimation.pcrb import PCRB_COLUMNS
from ..estimation.rule_statistics import STAT_COLUMNS
from ..plant.faults import ACTUATOR_COLUMNS, SENSOR_COLUMNS
from ..plant.truth import FLAG_NAMES

STATE = ("x", "y", "psi", "R_R", "R_L")
"""Estimator state order; ``<name>_hat`` and ``<name>_std`` columns follow it."""

COVARIANCE_COLUMNS: dict[tuple[int, int], str] = {
    (i, j): ("R_RL_cov" if (i, j) == (3, 4) else f"cov_{STATE[i]}_{STATE[j]}")
    for i in range(5) for j in range(i + 1, 5)
}
"""Upper off-diagonal entries ``P[i, j]`` of the 5×5 state covariance and their trace columns."""


FAULT_TRUTH_COLUMNS: tuple[str, ...] = (*ACTUATOR_COLUMNS, *(c for cols in SENSOR_COLUMNS.values() for c in cols))
"""The injected servo and sensor faults' truth columns (present only in a run with such a fault; the
punctures' truth is ``R_R``/``R_L``)."""

POSE_GATE_COLUMN = "pose_rejected"
"""A pose fix rejected by the filter's χ² gate (1) or fused (0) on its row (a run with a filter and a pose sensor)."""

__all__ = ["BASE_COLUMNS", "COVARIANCE_COLUMNS", "FAULT_TRUTH_COLUMNS", "INTEGER_COLUMNS", "POSE_GATE_COLUMN", "STATE",
           "WHEEL_CODES"]

BASE_COLUMNS: tuple[str, ...] = (
    "t", "x", "y", "psi", "v", "yaw_rate", "v_meas", "yaw_rate_meas", "R_R", "R_L",
    "R_R_hat", "R_L_hat", "R_R_std", "R_L_std", "x_hat", "y_hat", "psi_hat", "x_std", "y_std", "psi_std",
    *COVARIANCE_COLUMNS.values(),
    "innovation", "innovation_std", "nis", "nis_dof",
    "omega_R", "omega_L", "omega_R_meas", "omega_L_meas", "omega_R_cmd", "omega_L_cmd",
    "R_R_model", "R_L_model", "cross_track_error", "roll", "pitch", "z", "slip_R", "slip_L",
    "plant_flags", "fault_detected", "fault_suspected", "declared_wheel", "radius_anomaly", "radius_split_std",
    "reconfig_state", "excitation", "solve_time_ms", "solver_iterations", "solver_ok",
    "x_meas", "y_meas", *PCRB_COLUMNS, *STAT_COLUMNS, *DIAGNOSIS_COLUMNS,
)

CODED_COLUMNS: dict[str, str] = {
    "plant_flags": "bitmask of the plant leaving the kinematic model's domain: " + ", ".join(
        f"{bit} {name}" for bit, name in FLAG_NAMES.items()) + " (NAN, UNSTABLE, PHYSICS_WARNING are sticky)",
    "reconfig_state": "reconfiguration policy state: 0 nominal radii, 1 hold (radii in use kept), "
                      "2 handed over (estimates in use), 3 reverted (to the last trusted radii)",
    "fault_detected": "1 while the fault decision declares a fault, else 0 (NaN without an estimator)",
    "fault_suspected": "1 while a fault is evident but its wheel is not identified, else 0",
    "solver_ok": "1 a controller sample whose solve converged without fallback, 0 otherwise; NaN between samples",
    "declared_wheel": "wheel the fault decision declares: " + ", ".join(
        f"{code} {name or 'nothing declared'}" for name, code in WHEEL_CODES.items()),
    "excitation": "yaw-rate dither added to the command (rad/s); NaN when off",
    "cross_track_error": "signed distance to the reference path (m), positive = left of it",
    "diag_component": "component of the latest diagnosis: " + ", ".join(
        f"{code} {name or 'nothing declared'}" for name, code in COMPONENT_CODES.items()),
    "diag_target": "target of the latest diagnosis: " + ", ".join(
        f"{code} {name or 'nothing declared'}" for name, code in TARGET_CODES.items()),
    "diag_mode": "mode of the latest diagnosis: " + ", ".join(
        f"{code} {name or 'nothing declared'}" for name, code in MODE_CODES.items()),
    "diag_count": "number of diagnoses declared so far (a new one where it grows)",
    "diag_alarms": "number of diagnosis channels in alarm (statistic above its threshold), declared or not",
}
"""Meaning of the trace's coded columns, also stored in the Parquet schema metadata of ``trace.parquet``."""

INTEGER_COLUMNS: tuple[str, ...] = (
    "plant_flags", "fault_detected", "fault_suspected", "declared_wheel", "radius_anomaly", "reconfig_state",
    "solver_ok", "solver_iterations", "nis_dof", *(c for c in STAT_COLUMNS if c.endswith("_wheel")),
    *DIAGNOSIS_INTEGER_COLUMNS,
)
"""Integer codes, flags and counts: stored in ``trace.parquet`` as integers with nulls where the run
produced no value (in memory ``plant_flags`` is an int64 column, the others floats with NaN)."""


def trace_schema_metadata() -> dict[str, str]:
    """Parquet key-value metadata of ``trace.parquet``: units and the coded columns (JSON)."""
    import json

    return {"ftc_mj.units": "SI units and radians; one row per estimator step",
            "ftc_mj.columns": json.dumps(CODED_COLUMNS)}
