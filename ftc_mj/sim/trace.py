"""The trace writer: one preallocated row per estimator step, filled by the loop's named steps.

The columns are those of :mod:`ftc_mj.telemetry.columns` (SI units and radians), plus the
controller's own ``telemetry_columns`` and one ``mode_prob_<j>`` per IMM mode. Every cell starts
as NaN; a step writes only the cells it produced (an estimate on every step with a filter, the
solver's statistics on controller samples only), so a NaN means "not produced at this step". The
plant's flags (``plant_flags``, a bit set written on every row) are an integer column instead.
Nothing is logged call by call: the arrays are handed over whole at the end of the run.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..control.base import ControlOutput
from ..estimation.base import FilterOutput
from ..estimation.diagnosis.base import COMPONENT_CODES, MODE_CODES, TARGET_CODES
from ..plant import SensorReading, Truth
from ..telemetry.columns import BASE_COLUMNS, COVARIANCE_COLUMNS, STATE, WHEEL_CODES


class TraceWriter:
    """The trace of one run: ``n`` rows of the base columns, ``extra`` columns (a controller's
    telemetry), ``n_modes`` mode-probability columns and the ``faults`` truth columns of the run's servo and
    sensor faults, written row by row."""

    def __init__(self, n: int, extra: Sequence[str] = (), n_modes: int = 0, faults: Sequence[str] = ()) -> None:
        self.extra = tuple(extra)
        self.n_modes = n_modes
        self.columns: dict[str, np.ndarray] = {c: np.full(n, np.nan) for c in (*BASE_COLUMNS, *self.extra,
                                                                              *faults)}
        self.columns["plant_flags"] = np.zeros(n, dtype=np.int64)
        for j in range(n_modes):
            self.columns[f"mode_prob_{j + 1}"] = np.full(n, np.nan)

    def truth(self, k: int, t: float, tr: Truth, rd: SensorReading, u_meas: np.ndarray) -> None:
        """Time (s), the true state and the sensor readings of row ``k``."""
        c = self.columns
        c["t"][k] = t
        c["x"][k], c["y"][k], c["psi"][k] = tr.x, tr.y, tr.psi
        c["v"][k], c["yaw_rate"][k] = tr.v, tr.yaw_rate
        c["R_R"][k], c["R_L"][k] = tr.R_R, tr.R_L
        c["omega_R"][k], c["omega_L"][k] = tr.omega_R, tr.omega_L
        c["omega_R_meas"][k], c["omega_L_meas"][k] = u_meas
        c["v_meas"][k] = rd.speed
        if rd.yaw_rate is not None:
            c["yaw_rate_meas"][k] = rd.yaw_rate
        if rd.position is not None:
            c["x_meas"][k], c["y_meas"][k] = rd.position
        c["roll"][k], c["pitch"][k], c["z"][k] = tr.roll, tr.pitch, tr.z_chassis
        c["slip_R"][k], c["slip_L"][k] = tr.slip_R, tr.slip_L
        c["plant_flags"][k] = int(tr.flags)

    def fault_truth(self, k: int, values: dict[str, float]) -> None:
        """The injected faults' state at row ``k`` (the ``fault_*`` truth columns, in their units)."""
        c = self.columns
        for name, value in values.items():
            c[name][k] = value

    def cross_track(self, k: int, error: float) -> None:
        """Signed distance (m) of the true position to the reference path, positive left of it."""
        self.columns["cross_track_error"][k] = error

    def estimate(self, k: int, out: FilterOutput) -> None:
        """Estimate, σ of each state, off-diagonal covariances and the innovation statistics of row ``k``."""
        c = self.columns
        P = out.P
        for i, name in enumerate(STATE):
            c[f"{name}_hat"][k] = out.x[i]
            c[f"{name}_std"][k] = np.sqrt(max(P[i, i], 0.0))
        for (i, j), name in COVARIANCE_COLUMNS.items():
            c[name][k] = 0.5 * (P[i, j] + P[j, i])
        c["innovation"][k] = out.speed_innovation
        c["innovation_std"][k] = out.speed_innovation_std
        c["nis"][k] = out.nis
        c["nis_dof"][k] = float(np.size(out.innovation)) if np.isfinite(out.nis) else 0.0

    def decision(self, k: int, ds: object, mode_probs: np.ndarray | None) -> None:
        """The fault decision of row ``k`` (a :class:`~ftc_mj.estimation.DecisionState`): declared and
        suspected flags, declared wheel, anomaly, split σ (m), every rule's statistic, IMM mode probabilities."""
        c = self.columns
        c["fault_detected"][k] = float(ds.detected)
        c["fault_suspected"][k] = float(ds.suspected)
        c["declared_wheel"][k] = float(WHEEL_CODES[ds.wheel])
        c["radius_anomaly"][k] = float(ds.anomaly)
        c["radius_split_std"][k] = ds.split_std
        for name, value in ds.statistics.items():
            c[name][k] = value
        if mode_probs is not None:
            for j in range(self.n_modes):
                c[f"mode_prob_{j + 1}"][k] = mode_probs[j]

    def diagnosis(self, k: int, step: object) -> None:
        """The diagnoser's output at row ``k`` (a :class:`~ftc_mj.estimation.diagnosis.DiagnosisStep`): every
        channel's statistic and alarm flag (the channels of :data:`~ftc_mj.estimation.diagnosis.CHANNELS`), the
        number in alarm, and the latest declaration with the count."""
        c = self.columns
        for name, value in step.statistics.items():  # a plug-in's own channels count in diag_alarms only
            if f"diag_stat_{name}" in c:
                c[f"diag_stat_{name}"][k] = value
        for name, alarm in step.alarms.items():
            if f"diag_alarm_{name}" in c:
                c[f"diag_alarm_{name}"][k] = float(alarm)
        c["diag_alarms"][k] = float(sum(step.alarms.values()))
        c["diag_count"][k] = float(len(step.declared))
        if step.declared:
            d = step.declared[-1]
            c["diag_component"][k] = COMPONENT_CODES[d.component]
            c["diag_target"][k] = TARGET_CODES[d.target]
            c["diag_mode"][k] = MODE_CODES[d.mode]
            for key in ("size", "sigma", "onset", "declared", "statistic", "threshold"):
                c[f"diag_{key}"][k] = getattr(d, key)
        else:
            c["diag_component"][k] = c["diag_target"][k] = c["diag_mode"][k] = 0.0

    def excitation(self, k: int, dither: float) -> None:
        """The yaw-rate dither (rad/s) added to the command of row ``k``."""
        self.columns["excitation"][k] = dither

    def solve(self, k: int, cmd: ControlOutput) -> None:
        """The controller's telemetry and its solve's time (ms), iterations and success at a controller sample."""
        c = self.columns
        for name in self.extra:
            c[name][k] = cmd.telemetry.get(name, np.nan)
        c["solve_time_ms"][k] = cmd.solve_time * 1e3
        c["solver_iterations"][k] = cmd.iterations
        c["solver_ok"][k] = float(cmd.success and not cmd.fallback)

    def held(self, k: int, reconfig_state: float, omega: np.ndarray, model_radii: np.ndarray) -> None:
        """What holds on every row: the policy's state, the command in force (rad/s) and the radii (m) the
        controller assumed."""
        c = self.columns
        c["reconfig_state"][k] = reconfig_state
        c["omega_R_cmd"][k], c["omega_L_cmd"][k] = omega[0], omega[1]
        c["R_R_model"][k], c["R_L_model"][k] = model_radii

    def first_rows(self, rows: int) -> dict[str, np.ndarray]:
        """The columns cut to their first ``rows`` rows (a run that ended early)."""
        return {name: v[:rows] for name, v in self.columns.items()}
