"""The observation of :class:`~ftc_mj.envs.DiffDriveEnv`: one flat float64 vector of named entries.

The sensors are what the closed loop's controller and filter receive at a controller sample
(:class:`~ftc_mj.plant.SensorReading`; the pose is the one the loop's controller would get, so that with
``sensors.pose_source = "sensor"`` an agent sees what a benchmark method sees, never the true pose), the
reference point is the path's time law at that time, and,
with ``observe_filter``, the filter's estimate and the fault decision follow. A value a sensor did not
produce (no gyro configured, no position fix due, a sample dropped as NaN) is written as 0.0 and its
sensor's ``*_valid`` entry is 0.0 (1.0 when every value of that sensor is finite): the vector has the
same shape whatever the configuration, and a policy must read the mask, never a 0.0 alone.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from ..control.reference import Reference
from ..estimation.base import FilterOutput
from ..estimation.change import WHEEL_CODES
from ..estimation.decision import DecisionState
from ..estimation.diagnosis import DiagnosisStep
from ..estimation.diagnosis.base import COMPONENT_CODES, MODE_CODES, TARGET_CODES
from ..plant import SensorReading

SENSOR_GROUPS: dict[str, tuple[str, ...]] = {
    "speed": ("v_meas",),
    "yaw_rate": ("yaw_rate_meas",),
    "position": ("x_fix", "y_fix"),
    "encoders": ("omega_R_meas", "omega_L_meas"),
    "pose": ("x_pose", "y_pose", "psi_pose"),
}
"""Sensor -> its entries: speed (m/s), gyro yaw rate (rad/s), position fix (m), encoder wheel rates
(rad/s), the pose a controller is handed (m, m, rad; :meth:`~ftc_mj.sim.loop.ClosedLoop.controller_pose`): with
``sensors.pose_source = "truth"`` the true pose + ``sensors.pose_sigma`` noise, with ``"sensor"`` what a benchmark
method's controller gets from the pose sensor — the filter's pose estimate, without a filter the last fix held —
never the truth."""
REFERENCE = ("x_ref", "y_ref", "psi_ref", "v_ref", "yaw_rate_ref")
"""The reference's position (m), heading (rad), speed (m/s) and yaw rate (rad/s) at the sample time."""
SENSOR_NAMES: tuple[str, ...] = ("t", *(n for g in SENSOR_GROUPS.values() for n in g),
                                 *(f"{g}_valid" for g in SENSOR_GROUPS), *REFERENCE)
"""The entries without the filter: time (s), the sensors, one validity flag per sensor, the reference."""
STATE = ("x", "y", "psi", "R_R", "R_L")
FILTER_NAMES: tuple[str, ...] = (*(f"{s}_hat" for s in STATE), *(f"{s}_std" for s in STATE),
                                 "fault_detected", "fault_suspected", "declared_wheel", "radius_anomaly",
                                 "R_R_model", "R_L_model", "reconfig_state", "filter_valid")
"""With ``observe_filter`` (then :data:`DIAGNOSIS_NAMES` follow): the estimate (m, m, rad, m, m) and its σ,
the decision (0/1 flags, the declared wheel's code 0 none, 1 right, 2 left, 3 both, 4 unknown), the radii (m)
the reconfiguration policy chose for the controller, the policy's state (0 nominal, 1 hold, 2 handed over,
3 reverted), and ``filter_valid`` (0.0 for a run without a filter: then the estimate and decision entries are
0.0)."""
DIAGNOSIS_NAMES: tuple[str, ...] = ("diag_component", "diag_target", "diag_mode", "diag_size", "diag_onset",
                                    "diag_count", "diag_alarms", "diag_valid")
"""With ``observe_filter``, after the filter's entries: the diagnoser's latest declaration (codes of its
component, target and mode — :data:`~ftc_mj.estimation.diagnosis.base.COMPONENT_CODES` … —, 0 when nothing is
declared; its size in the mode's unit and onset, s), the number of declarations, the number of channels in
alarm at this step, and ``diag_valid`` (0.0 for a run without a diagnoser: then all of them are 0.0)."""
_FLAGS = {"t", "fault_detected", "fault_suspected", "declared_wheel", "radius_anomaly", "reconfig_state",
          "filter_valid", "diag_component", "diag_target", "diag_mode", "diag_count", "diag_alarms", "diag_valid",
          *(f"{g}_valid" for g in SENSOR_GROUPS)}


def observation_names(observe_filter: bool) -> tuple[str, ...]:
    """The names of the observation's entries, in order."""
    return SENSOR_NAMES + (FILTER_NAMES + DIAGNOSIS_NAMES if observe_filter else ())


def observation_space(observe_filter: bool) -> spaces.Box:
    """The Box of the observation: flags and codes in [0, 1] or [0, 4], time ≥ 0, the rest unbounded."""
    names = observation_names(observe_filter)
    high = {"declared_wheel": float(max(WHEEL_CODES.values())), "reconfig_state": 3.0, "t": np.inf,
            "diag_component": float(max(COMPONENT_CODES.values())), "diag_target": float(max(TARGET_CODES.values())),
            "diag_mode": float(max(MODE_CODES.values())), "diag_count": np.inf, "diag_alarms": np.inf}
    low = np.array([0.0 if n in _FLAGS else -np.inf for n in names])
    hi = np.array([high.get(n, 1.0) if n in _FLAGS else np.inf for n in names])
    return spaces.Box(low, hi, dtype=np.float64)


def sensor_values(t: float, rd: SensorReading, reference: Reference, pose: np.ndarray | None = None) -> list[float]:
    """The sensor part of the observation at ``t`` (s): values (NaN and absent → 0.0), validity flags,
    reference point. ``pose``: the controller's pose (m, m, rad; default the reading's ``pose``, the truth's
    with ``pose_source = "truth"``)."""
    pose = rd.pose if pose is None else pose
    raw = {"v_meas": rd.speed, "yaw_rate_meas": rd.yaw_rate,
           "x_fix": None if rd.position is None else rd.position[0],
           "y_fix": None if rd.position is None else rd.position[1],
           "omega_R_meas": rd.omega_R, "omega_L_meas": rd.omega_L,
           "x_pose": pose[0], "y_pose": pose[1], "psi_pose": pose[2]}
    ok = {n: v is not None and bool(np.isfinite(v)) for n, v in raw.items()}
    values = [float(raw[n]) if ok[n] else 0.0 for g in SENSOR_GROUPS.values() for n in g]
    valid = [float(all(ok[n] for n in g)) for g in SENSOR_GROUPS.values()]
    r = reference.at(t)
    return [t, *values, *valid, *(float(v) for v in (r.x, r.y, r.psi, r.V, r.psidot))]


def filter_values(out: FilterOutput | None, ds: DecisionState | None, model_radii: np.ndarray,
                  policy_state: float) -> list[float]:
    """The filter part of the observation: estimate and σ, decision, the policy's radii (m) and state."""
    policy = [float(model_radii[0]), float(model_radii[1]), float(policy_state)]
    if out is None or ds is None:
        return [0.0] * (2 * len(STATE) + 4) + policy + [0.0]
    std = np.sqrt(np.maximum(np.diag(out.P), 0.0))
    decision = [float(ds.detected), float(ds.suspected), float(WHEEL_CODES[ds.wheel]), float(ds.anomaly)]
    return [*(float(v) for v in out.x[:len(STATE)]), *(float(v) for v in std[:len(STATE)]), *decision,
            *policy, 1.0]


def diagnosis_values(step: DiagnosisStep | None) -> list[float]:
    """The diagnosis part of the observation (:data:`DIAGNOSIS_NAMES`) from the diagnoser's latest step."""
    if step is None:
        return [0.0] * len(DIAGNOSIS_NAMES)
    alarms = float(sum(step.alarms.values()))
    if not step.declared:
        return [0.0] * 5 + [0.0, alarms, 1.0]
    d = step.declared[-1]
    size = float(d.size) if np.isfinite(d.size) else 0.0
    return [float(COMPONENT_CODES[d.component]), float(TARGET_CODES[d.target]), float(MODE_CODES[d.mode]), size,
            float(d.onset), float(len(step.declared)), alarms, 1.0]
