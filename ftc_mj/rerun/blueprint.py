"""The layout of one run's recording, saved in ``run.rrd`` as its default blueprint.

Left column: a 3D overview of the whole reference (fixed eye), a 3D close-up in the robot frame
(origin ``/world/robot``, so it follows the robot) and the events log. Right: a 2-column grid of
time-series views — right radius, left radius (one y range from truth and estimate; the ±2σ lines
may leave it while the filter is uncertain), innovation ±2σ (tab: NIS), wheel rates with commands and
±limit, IMM mode probabilities (IMM runs only), cross-track error, speed (tabs: yaw rate, attitude,
fault flag, reconfiguration state, the injected servo and sensor faults), path following (if
recorded), NMPC solve time (tabs: iterations, status). The time panel is on ``sim_time`` with the
cursor at the end of the run.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import rerun.blueprint as rrb

from ftc_mj.telemetry.columns import FAULT_TRUTH_COLUMNS

PF_FIRST_COLUMN = "pf_progress"
"""The trace column whose presence marks a path-following run (its views are added)."""
_LEGEND = rrb.PlotLegend(corner="RightTop")
_UNIT_AXIS = rrb.ScalarAxis(range=(-0.05, 1.05))


def overview_eye(xy: np.ndarray) -> rrb.EyeControls3D:
    """A 3D eye that sees all finite points ``(N, 2)`` (m) from a high oblique viewpoint to the south."""
    xy = np.asarray(xy, dtype=np.float64)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if len(xy):
        c = 0.5 * (xy.min(axis=0) + xy.max(axis=0))
        ext = float(max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1]), 1.0))
    else:
        c, ext = np.zeros(2), 10.0
    return rrb.EyeControls3D(position=[c[0] - 0.1 * ext, c[1] - 0.9 * ext, 0.8 * ext],
                             look_target=[c[0], c[1], 0.0], eye_up=[0, 0, 1])


def run_blueprint(trace: Mapping[str, np.ndarray], n_modes: int, has_solves: bool,
                  reference_path: np.ndarray | None) -> rrb.Blueprint:
    """The layout of a run's recording (module docstring): ``trace`` columns decide which optional views
    appear, ``n_modes`` > 0 adds the IMM view, ``has_solves`` the solver tabs; ``reference_path``
    ``(N, 2+)`` (m, or None: the path) frames the 3D overview."""
    right = rrb.Grid(*_series_views(trace, n_modes, has_solves), grid_columns=2)
    return rrb.Blueprint(
        rrb.Horizontal(_scene_column(trace, reference_path), right, column_shares=[2, 3]),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="following"),
        collapse_panels=True,
    )


def _ts(origin: str, name: str, **kw: object) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(origin=origin, name=name, plot_legend=_LEGEND, **kw)  # type: ignore[arg-type]


def _finite_range(*arrays: np.ndarray, pad: float = 0.1) -> tuple[float, float] | None:
    """A padded y-axis range covering the finite values of the arrays (``pad`` × span each side), or None."""
    vals = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in arrays])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return None
    lo, hi = float(vals.min()), float(vals.max())
    span = max(hi - lo, 1e-3 * max(abs(hi), 1.0))
    return lo - pad * span, hi + pad * span


def _radius_axis(trace: Mapping[str, np.ndarray]) -> rrb.ScalarAxis | None:
    """One y range (m) for both radius plots: truth and estimate (not the ±2σ bounds, which can be huge
    while the filter is uncertain), at least ±10 % of the largest radius."""
    rad = _finite_range(trace["R_R"], trace["R_L"], trace["R_R_hat"], trace["R_L_hat"], pad=0.15)
    if rad is None:
        return None
    mid, half = 0.5 * (rad[0] + rad[1]), 0.5 * (rad[1] - rad[0])
    half = max(half, 0.1 * max(abs(rad[0]), abs(rad[1]), 1e-3))
    return rrb.ScalarAxis(range=(mid - half, mid + half))


def _series_views(trace: Mapping[str, np.ndarray], n_modes: int, has_solves: bool
                  ) -> list[rrb.View | rrb.Container]:
    """The time-series slots of the right-hand grid, in order."""
    rad_axis = _radius_axis(trace)
    series: list[rrb.View | rrb.Container] = [
        _ts("/radius/right", "Right radius R_R (m): truth, estimate ±2σ, controller's model", axis_y=rad_axis),
        _ts("/radius/left", "Left radius R_L (m): truth, estimate ±2σ, controller's model", axis_y=rad_axis),
    ]
    inn = _ts("/innovation", "Speed innovation (m/s) ±2σ",
              contents=["/innovation/value", "/innovation/upper", "/innovation/lower"])
    series.append(rrb.Tabs(inn, _ts("/innovation/nis", "NIS"), active_tab=0) if "nis" in trace else inn)
    series.append(_ts("/wheel_rate", "Wheel rates (rad/s): measured, command, ±limit"))
    if n_modes:
        series.append(_ts("/imm", "IMM mode probabilities", axis_y=rrb.ScalarAxis(range=(-0.02, 1.02))))
    series.append(_ts("/tracking", "Cross-track error (m)"))
    series.append(_motion_tabs(trace))
    if PF_FIRST_COLUMN in trace:
        series.append(rrb.Tabs(
            _ts("/path_following/speed", "Path following: desired, planned and progress speed (m/s)"),
            _ts("/path_following", "Path following: contouring and lag error (m)",
                contents=["/path_following/contouring_error", "/path_following/lag_error"]),
            _ts("/path_following/lateral_accel", "Path following: planned lateral acceleration and bound (m/s²)"),
            _ts("/path_following/progress", "Path following: progress s (m)"),
            active_tab=0))
    if has_solves:
        series.append(rrb.Tabs(
            _ts("/solver/solve_time_ms", "NMPC solve time (ms)"),
            _ts("/solver/iterations", "NMPC iterations"),
            _ts("/solver/status", "NMPC status (1 ok, 0.5 fallback, 0 failed)", axis_y=_UNIT_AXIS),
            active_tab=0))
    return series


def _motion_tabs(trace: Mapping[str, np.ndarray]) -> rrb.View | rrb.Container:
    """Speed, with tabs for yaw rate, attitude, the fault flag and the reconfiguration state if recorded."""
    speed = [_ts("/speed", "Speed (m/s): truth, measured")]
    if "yaw_rate" in trace or "yaw_rate_meas" in trace:
        speed.append(_ts("/yaw_rate", "Yaw rate (rad/s)"))
    if any(k in trace for k in ("roll", "pitch", "z")):
        speed.append(_ts("/attitude", "Roll, pitch (rad), chassis z (m)"))
    if "fault_detected" in trace:
        speed.append(_ts("/fault", "Fault detected (0/1)", axis_y=_UNIT_AXIS))
    if "reconfig_state" in trace:
        speed.append(_ts("/reconfiguration", "Reconfiguration (0 nominal, 1 hold, 2 handed over, 3 reverted)",
                         axis_y=rrb.ScalarAxis(range=(-0.1, 3.1))))
    if "accommodation_mode" in trace:
        speed.append(_ts("/accommodation", "Accommodation (0 nominal, 1 accommodated, 2 safe stop, 3 at rest); "
                                           "servo effectiveness", axis_y=rrb.ScalarAxis(range=(-0.1, 3.1))))
    if any(c in trace for c in FAULT_TRUTH_COLUMNS):
        speed.append(_ts("/injected", "Injected faults: servo effectiveness, lock (0/1), sensor offsets "
                                      "(m/s, rad/s), dropout (0/1)"))
    return rrb.Tabs(*speed, active_tab=0) if len(speed) > 1 else speed[0]


def _scene_column(trace: Mapping[str, np.ndarray], reference_path: np.ndarray | None) -> rrb.Vertical:
    """The 3D overview (whole reference, or path, from a high oblique viewpoint), the robot close-up
    (eye at 4 wheel radii) and the events log."""
    xy = (np.asarray(reference_path, dtype=np.float64)[:, :2] if reference_path is not None
          and len(reference_path) else np.stack([trace["x"], trace["y"]], axis=1))
    r0 = float(np.nanmax(np.abs(np.asarray(trace["R_R"], dtype=np.float64)))) if len(trace["R_R"]) else 1.0
    d = 4.0 * max(r0, 0.05)
    close = rrb.EyeControls3D(position=[-1.3 * d, -1.1 * d, 0.9 * d], look_target=[0.0, 0.0, 0.5 * r0],
                              eye_up=[0, 0, 1])
    return rrb.Vertical(
        rrb.Spatial3DView(origin="/world", name="3D overview: reference, path, NMPC prediction",
                          eye_controls=overview_eye(xy), line_grid=rrb.LineGrid3D(visible=False)),
        rrb.Spatial3DView(origin="/world/robot", contents="/world/**", name="3D robot (wheel radii = true radii)",
                          eye_controls=close, line_grid=rrb.LineGrid3D(visible=False)),
        rrb.TextLogView(origin="/events", name="Events"),
        row_shares=[5, 4, 3],
    )
