"""The trace writer: one preallocated row per estimator step, filled by the loop's named steps.

The columns are those of :mod:`ftc_mj.telemetry.columns` (SI units and radians), plus the
controller's own ``telemetry_columns`` and one ``mode_prob_<j>`` per IMM mode. Every cell starts
as NaN; a step writes only the cells it produced (an estimate on every step with a filter, the
solver's statistics on controller samples only), so a NaN means "not produced at this step". The
plant's flags (``plant_flags``, a bit set written on every row) are an integer column instead.
Nothing is logged call by call: the arrays are handed over whole at the end of the run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..control.base import ControlOutput
from ..estimation.base import FilterOutput
from ..estimation.diagnosis.base import COMPONENT_CODES, MODE_CODES, OFFSET_COLUMNS, TARGET_CODES
from ..plant import SensorReading, Truth
from ..telemetry.columns import BASE_COLUMNS, COVARIANCE_COLUMNS, POSE_GATE_COLUMN, STATE, WHEEL_CODES

N_STATE = len(STATE)
ESTIMATE_COLUMNS: tuple[str, ...] = (*(f"{s}_hat" for s in STATE), *(f"{s}_std" for s in STATE),
                                     *COVARIANCE_COLUMNS.values())
"""The columns :meth:`TraceWriter.estimate` writes as one block: estimates, σ, upper off-diagonal covariances."""
_DIAG = np.arange(N_STATE)
_UPPER = tuple(np.array(ix) for ix in zip(*COVARIANCE_COLUMNS, strict=True))  # (i…, j…) of P[i, j], i < j
_LOWER = _UPPER[::-1]


class TraceWriter:
    """The trace of one run: ``n`` rows of the base columns, ``extra`` columns (a controller's
    telemetry), ``n_modes`` mode-probability columns, the ``faults`` truth columns of the run's servo and
    sensor faults and, with ``pose_gate`` (a filter and a pose sensor), ``pose_rejected``, written row by row.

    Per-step costs are kept out of Python where a column allows it: the estimate's 20 columns are rows of one
    block written with three vector assignments (:meth:`estimate`), and ``cross_track_error``, a function of the
    true position only, is computed for all rows written so far, vectorised, whenever :attr:`columns` is read
    (``cross_track``: the reference's ``cross_track(x, y)``; ``None``: written by :meth:`cross_track` only)."""

    def __init__(self, n: int, extra: Sequence[str] = (), n_modes: int = 0, faults: Sequence[str] = (),
                 cross_track: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 pose_gate: bool = False) -> None:
        self.extra = tuple(extra)
        self.n_modes = n_modes
        self._est = np.full((len(ESTIMATE_COLUMNS), n), np.nan)
        est = dict(zip(ESTIMATE_COLUMNS, self._est, strict=True))  # row views of the block
        self._cols: dict[str, np.ndarray] = {c: est[c] if c in est else np.full(n, np.nan)
                                             for c in (*BASE_COLUMNS, *self.extra, *faults)}
        if pose_gate:
            self._cols[POSE_GATE_COLUMN] = np.full(n, np.nan)
        self._cols["plant_flags"] = np.zeros(n, dtype=np.int64)
        for j in range(n_modes):
            self._cols[f"mode_prob_{j + 1}"] = np.full(n, np.nan)
        self._cross_track = cross_track
        self._written = 0  # rows whose truth is written
        self._ct_done = 0  # rows whose cross-track error is computed
        self._diag: dict[tuple[str, str], np.ndarray | None] = {}  # :meth:`_diagnosis_column`'s lookups

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """The columns (name → array of ``n`` rows), the cross-track error filled for every row written."""
        if self._cross_track is not None and self._ct_done < self._written:
            a, b = self._ct_done, self._written
            c = self._cols
            c["cross_track_error"][a:b] = self._cross_track(c["x"][a:b], c["y"][a:b])
            self._ct_done = b
        return self._cols

    def truth(self, k: int, t: float, tr: Truth, rd: SensorReading, u_meas: np.ndarray) -> None:
        """Time (s), the true state and the sensor readings of row ``k``."""
        c = self._cols
        self._written = max(self._written, k + 1)
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
        c = self._cols
        for name, value in values.items():
            c[name][k] = value

    def cross_track(self, k: int, error: float) -> None:
        """Signed distance (m) of the true position to the reference path, positive left of it."""
        self._cols["cross_track_error"][k] = error

    def estimate(self, k: int, out: FilterOutput) -> None:
        """Estimate, σ of each state, off-diagonal covariances and the innovation statistics of row ``k``."""
        c, E, P = self._cols, self._est, out.P
        E[:N_STATE, k] = out.x[:N_STATE]
        d = P[_DIAG, _DIAG]
        E[N_STATE:2 * N_STATE, k] = np.sqrt(np.where(d < 0.0, 0.0, d))  # max(d, 0) (NaN kept)
        E[2 * N_STATE:, k] = 0.5 * (P[_UPPER] + P[_LOWER])
        c["innovation"][k] = out.speed_innovation
        c["innovation_std"][k] = out.speed_innovation_std
        c["nis"][k] = out.nis
        c["nis_dof"][k] = float(np.size(out.innovation)) if np.isfinite(out.nis) else 0.0

    def pose_gate(self, k: int, rejected: bool) -> None:
        """Row ``k`` had a pose fix: 1.0 if the filter's χ² gate rejected it, 0.0 if the fix was fused."""
        self._cols[POSE_GATE_COLUMN][k] = float(rejected)

    def decision(self, k: int, ds: object, mode_probs: np.ndarray | None) -> None:
        """The fault decision of row ``k`` (a :class:`~ftc_mj.estimation.DecisionState`): declared and
        suspected flags, declared wheel, anomaly, split σ (m), every rule's statistic, IMM mode probabilities."""
        c = self._cols
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
        c = self._cols  # not :attr:`columns`: the cross-track error is filled when the columns are read
        for name, value in step.statistics.items():  # a plug-in's own channels count in diag_alarms only
            col = self._diagnosis_column("stat", name)
            if col is not None:
                col[k] = value
        for name, alarm in step.alarms.items():
            col = self._diagnosis_column("alarm", name)
            if col is not None:
                col[k] = float(alarm)
        c["diag_alarms"][k] = float(sum(step.alarms.values()))
        c["diag_count"][k] = float(len(step.declared))
        if step.declared:
            d = step.declared[-1]
            c["diag_component"][k] = COMPONENT_CODES[d.component]
            c["diag_target"][k] = TARGET_CODES[d.target]
            c["diag_mode"][k] = MODE_CODES[d.mode]
            for key in ("size", "sigma", "onset", "declared", "statistic", "threshold"):
                c[f"diag_{key}"][k] = getattr(d, key)
            vector = (*d.offset, *d.offset_sigma) if d.offset is not None else (np.nan,) * 4
            for name, value in zip(OFFSET_COLUMNS, vector, strict=True):
                c[name][k] = value
        else:
            c["diag_component"][k] = c["diag_target"][k] = c["diag_mode"][k] = 0.0

    def _diagnosis_column(self, kind: str, channel: str) -> np.ndarray | None:
        """The ``diag_<kind>_<channel>`` column, ``None`` if the trace has none (looked up once per channel)."""
        key = (kind, channel)
        if key not in self._diag:
            self._diag[key] = self._cols.get(f"diag_{kind}_{channel}")
        return self._diag[key]

    def write(self, k: int, name: str, value: float) -> None:
        """One cell: column ``name`` (added by the caller to :attr:`columns`) at row ``k``."""
        self._cols[name][k] = value

    def excitation(self, k: int, dither: float) -> None:
        """The yaw-rate dither (rad/s) added to the command of row ``k``."""
        self._cols["excitation"][k] = dither

    def solve(self, k: int, cmd: ControlOutput) -> None:
        """The controller's telemetry and its solve's time (ms), iterations and success at a controller sample."""
        c = self._cols
        for name in self.extra:
            c[name][k] = cmd.telemetry.get(name, np.nan)
        c["solve_time_ms"][k] = cmd.solve_time * 1e3
        c["solver_iterations"][k] = cmd.iterations
        c["solver_ok"][k] = float(cmd.success and not cmd.fallback)

    def held(self, k: int, reconfig_state: float, omega: np.ndarray, model_radii: np.ndarray) -> None:
        """What holds on every row: the policy's state, the command in force (rad/s) and the radii (m) the
        controller assumed."""
        c = self._cols
        c["reconfig_state"][k] = reconfig_state
        c["omega_R_cmd"][k], c["omega_L_cmd"][k] = omega[0], omega[1]
        c["R_R_model"][k], c["R_L_model"][k] = model_radii

    def first_rows(self, rows: int) -> dict[str, np.ndarray]:
        """The columns cut to their first ``rows`` rows (a run that ended early)."""
        return {name: v[:rows] for name, v in self.columns.items()}
