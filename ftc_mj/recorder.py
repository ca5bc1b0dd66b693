"""Write one run's Rerun recording (``run.rrd``) from buffered telemetry, column-wise.

The simulation loop buffers its telemetry in arrays and calls :func:`write_rrd` **once** at the end
of a run. Every entity is sent with ``RecordingStream.send_columns`` (one call per entity, never a
per-step ``log()``), which costs a few milliseconds for a 40 s run instead of seconds (DESIGN §8).

Each run gets its own ``rr.RecordingStream(app_id, recording_id=run_id)`` (never the global stream,
so parallel runs cannot mix) with a file sink; the blueprint is saved in the same file. The file is
written to a temporary name in the same directory and moved into place with :func:`os.replace`
only after the stream has been flushed and closed, so a reader never sees a half-written file and
a failing write leaves no final file.

Timelines
---------
``sim_time``
    duration, integer nanoseconds (``timedelta64[ns]``; float seconds are rounded differently by
    different Rerun calls, TECHNOTES §1.1 pitfall).
``step``
    sequence, the estimator-step index (row of the trace). Solves and events get the index of the
    last trace row at or before their time.

Entities
--------
3D scene (world frame, z up, metres):

- ``/world/ground`` (static ``Boxes3D``), ``/world/reference`` (static ``LineStrips3D``).
- ``/world/path``: the actual path as a growing ``LineStrips3D``, one row every 0.5 s (2 Hz) whose
  points are decimated to 10 Hz, plus a final row at the last sample.
- ``/world/robot``: ``Transform3D`` columns, every row: translation ``(x, y, z)`` (``z`` from the
  trace if present, else 0 = robot frame on the ground under the axle midpoint) and the rotation
  from ``psi`` (and ``roll``/``pitch`` if present; ZYX order).
- ``/world/robot/chassis``: static ``Boxes3D``.
- ``/world/robot/wheel_right``, ``/world/robot/wheel_left``: ``Cylinders3D`` whose radii are the
  **true** current radii ``R_R``/``R_L``; one row at the start, then a row whenever the radius has
  moved by more than 0.1 mm since the last row, limited to 10 Hz, and the last sample.
- ``/world/prediction``: the NMPC predicted path ``[x, y]`` of each solve (``LineStrips3D``, one
  row per solve, at the solve time).

Time series (``Scalars``; one sample per trace row unless stated):

- ``/radius/right/{truth,estimate,upper,lower}``, ``/radius/left/...``: ``R_R``, ``R_R_hat``,
  ``R_R_hat ± 2 R_R_std`` (same for the left wheel).
- ``/innovation/{value,upper,lower}``: ``innovation``, ``± 2 innovation_std``.
- ``/innovation/nis`` (if ``nis`` is in the trace).
- ``/wheel_rate/right/{measured,command}``, ``/wheel_rate/left/{measured,command}``: ``omega_*``,
  ``omega_*_cmd``.
- ``/wheel_rate/limits``: two series ``[+omega_max, -omega_max]`` at the first and last time.
- ``/imm/mode_prob_k`` for ``k = 1..M`` (``M = max(n_modes, mode_prob_* columns in the trace)``).
- ``/tracking/cross_track_error``.
- ``/speed/{truth,measured}``: ``v``, ``v_meas``.
- ``/yaw_rate/{truth,measured}`` (if ``yaw_rate``/``yaw_rate_meas`` are in the trace).
- ``/attitude/{roll,pitch,z}`` (if present).
- ``/radius/{right,left}/model``: ``R_*_model``, the radii the controller was handed (if present).
- ``/fault/detected`` (if ``fault_detected`` is present; 0/1).
- ``/reconfiguration/state`` (if ``reconfig_state`` is present; 0 nominal, 1 hold, 2 handed over,
  3 reverted). Every hand-over, hold and revert is also an ``/events`` line.
- ``/solver/{solve_time_ms,iterations,status}``: **only at solve times** (not forward-filled).
  Taken from ``solves`` if given, else from the trace rows where ``solve_time_ms`` is finite.
  ``status`` is 1 for a solve that converged, 0 for a failed one, and 0.5 for a fallback.

Text:

- ``/events``: ``TextLog`` (``info``/``warn``/``error`` → ``INFO``/``WARN``/``ERROR``) at the event
  times; solver failures from ``solves`` are added as ``WARN`` events automatically.

Blueprint (saved in the file): left column a 3D overview of the whole reference (fixed eye), a 3D
close-up in the robot frame (origin ``/world/robot``, so it follows the robot) and the events log;
right a 2-column grid: right radius, left radius (shared y range from truth and estimate, the ±2σ
lines may leave it while the filter is uncertain), innovation ±2σ (tab: NIS), wheel rates with
commands and ±limit, IMM mode probabilities (only for IMM runs), cross-track error, speed (tabs:
yaw rate, attitude, fault flag), NMPC solve time (tabs: iterations, status). Time panel on
``sim_time`` with the cursor at the end of the run.

:func:`read_scalar_series` reads one scalar entity back (tests and integration checks);
:func:`open_viewer` opens a recording in the native Rerun viewer (``ftc-mj view RUN_DIR``);
:func:`synthetic_run` makes a plausible scenario-2-like telemetry set (tests, benchmark, docs).
"""

from __future__ import annotations

import contextlib
import functools
import os
import shutil
import subprocess
import sys
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ftc_mj.errors import BadInput, RunFailed
from ftc_mj.io import atomic_path

__all__ = [
    "Event",
    "RobotGeometry",
    "Solve",
    "check_display",
    "check_recording",
    "open_viewer",
    "read_scalar_series",
    "synthetic_run",
    "write_rrd",
]

REQUIRED_COLUMNS: tuple[str, ...] = (
    "t", "x", "y", "psi", "v", "v_meas", "R_R", "R_L", "R_R_hat", "R_L_hat", "R_R_std", "R_L_std",
    "innovation", "innovation_std", "omega_R", "omega_L", "omega_R_cmd", "omega_L_cmd",
    "cross_track_error",
)
"""Trace columns :func:`write_rrd` needs (DESIGN §6 ``trace.parquet`` minimum)."""

PATH_RATE_HZ = 2.0
"""Rows per second of the growing ``/world/path`` strip."""
PATH_POINT_RATE_HZ = 10.0
"""Points per second kept in the ``/world/path`` strip."""
WHEEL_RATE_HZ = 10.0
"""Largest row rate of the wheel cylinders."""
WHEEL_RADIUS_TOL = 1e-4
"""Radius change (m) that triggers a new wheel-cylinder row."""

_OK_STATUSES = frozenset({"ok", "success", "succeeded", "solve_succeeded", "solved_to_acceptable_level",
                          "solved", "converged", "optimal"})
TEXT_LEVELS = {"info": rr.TextLogLevel.INFO, "warn": rr.TextLogLevel.WARN, "warning": rr.TextLogLevel.WARN,
           "error": rr.TextLogLevel.ERROR, "debug": rr.TextLogLevel.DEBUG}

# colours (RGB)
_TRUTH = [230, 200, 40]
_EST = [40, 140, 240]
_BOUND = [150, 150, 150]
_MEAS = [120, 200, 120]
_CMD = [240, 110, 40]
_LIMIT = [220, 40, 40]
_MODE_COLORS = [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
                [140, 86, 75], [227, 119, 194], [127, 127, 127]]


@dataclass(frozen=True)
class Solve:
    """One NMPC solve as the recorder sees it.

    ``predicted`` is the predicted state trajectory ``(K, 3)`` of ``[x, y, psi]`` (m, m, rad);
    ``status`` is the solver's return status (``"ok"``/``"Solve_Succeeded"``… count as converged);
    ``fallback`` is True when the controller fell back (e.g. to the previous plan) after a failure.
    """

    t: float
    predicted: np.ndarray
    solve_time_ms: float
    iterations: int
    status: str
    fallback: bool = False
    success: bool | None = None
    """The controller's own verdict; ``None`` = judge from ``status``."""

    @property
    def ok(self) -> bool:
        """True if the solve converged and no fallback was used."""
        if self.fallback:
            return False
        if self.success is not None:
            return self.success
        return self.status.strip().lower() in _OK_STATUSES


@dataclass(frozen=True)
class Event:
    """A discrete event shown in the text log: fault onsets, decisions, solver failures, filter
    resets, plant domain flags. ``level`` is ``'info'``, ``'warn'`` or ``'error'``."""

    t: float
    level: str
    text: str


@dataclass(frozen=True)
class RobotGeometry:
    """Sizes (m) used to draw the robot; the robot frame is x forward, y left, z up.

    Without a ``z`` trace column the robot frame sits on the ground under the axle midpoint, and each
    wheel is drawn touching the ground (centre height = its current radius); the chassis box centre is
    at ``(chassis_offset_x, 0, chassis_height)`` (``chassis_height`` ``None`` = the nominal radius).
    With a ``z`` column the robot frame is the chassis body frame at height ``z`` and the wheel
    centres are at ``(0, ∓half_track, axle_offset_z)`` in it (the chassis box at
    ``(chassis_offset_x, 0, 0)``).
    """

    half_track: float = 1.0
    wheel_width: float = 0.3
    chassis_half_sizes: tuple[float, float, float] = (1.2, 0.7, 0.25)
    nominal_radius: float = 2.0
    chassis_offset_x: float = 0.0
    chassis_height: float | None = None
    axle_offset_z: float = 0.0


# ------------------------------------------------------------------------------------------------
# helpers


def seconds_to_ns(t: np.ndarray) -> np.ndarray:
    """Seconds → ``timedelta64[ns]`` (integer ns, rounded once)."""
    return np.round(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64).astype("timedelta64[ns]")


def _steps_for(times: np.ndarray, t_trace: np.ndarray) -> np.ndarray:
    """Index of the last trace row at or before each time (clipped to the trace)."""
    idx = np.searchsorted(t_trace, np.asarray(times, dtype=np.float64) + 1e-9, side="right") - 1
    return np.clip(idx, 0, len(t_trace) - 1).astype(np.int64)


def _quat_xyzw(psi: np.ndarray, roll: np.ndarray | None, pitch: np.ndarray | None) -> np.ndarray:
    """ZYX (yaw, pitch, roll) Euler angles → quaternions ``(n, 4)`` in xyzw order."""
    hy = 0.5 * psi
    if roll is None and pitch is None:
        q = np.zeros((len(psi), 4))
        q[:, 2] = np.sin(hy)
        q[:, 3] = np.cos(hy)
        return q
    hr = 0.5 * (roll if roll is not None else np.zeros_like(psi))
    hp = 0.5 * (pitch if pitch is not None else np.zeros_like(psi))
    cr, sr, cp, sp, cy, sy = np.cos(hr), np.sin(hr), np.cos(hp), np.sin(hp), np.cos(hy), np.sin(hy)
    return np.stack([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ], axis=1)


def _change_rows(r: np.ndarray, t: np.ndarray, tol: float, min_dt: float) -> np.ndarray:
    """Rows where ``r`` moved by more than ``tol`` since the last kept row, at most one per ``min_dt``
    seconds; always the first and the last row. Loops only over candidate rows (few)."""
    n = len(r)
    keep = [0]
    cand = np.flatnonzero(np.abs(np.diff(r)) > 0.0) + 1
    last_r, last_t = r[0], t[0]
    for i in cand:
        if abs(r[i] - last_r) > tol and t[i] - last_t >= min_dt - 1e-9:
            keep.append(int(i))
            last_r, last_t = r[i], t[i]
    if keep[-1] != n - 1:
        keep.append(n - 1)
    return np.asarray(keep, dtype=np.int64)


@functools.lru_cache(maxsize=256)
def series_style(color: tuple[int, ...], name: str, width: float) -> rr.SeriesLines:
    """A ``SeriesLines`` style, built once per process (the Arrow conversion is most of its cost)."""
    return rr.SeriesLines(colors=[list(color)], names=[name], widths=[width])


def strips_column(strips: list[np.ndarray]) -> rr.ComponentColumnList:
    """``LineStrips3D`` columns, one strip per row, built as one Arrow array (30x faster than letting
    Rerun convert a list of arrays strip by strip)."""
    import pyarrow as pa
    from rerun.components import LineStrip3DBatch

    typ = LineStrip3DBatch._ARROW_DATATYPE
    flat = np.ascontiguousarray(np.concatenate(strips).astype(np.float32, copy=False).ravel())
    offsets = np.zeros(len(strips) + 1, dtype=np.int32)
    np.cumsum([len(s) for s in strips], out=offsets[1:])
    inner = pa.FixedSizeListArray.from_arrays(pa.array(flat, type=pa.float32()), type=typ.value_type)
    arr = pa.ListArray.from_arrays(pa.array(offsets), inner, type=typ)
    return rr.LineStrips3D.columns(strips=arr).partition(np.ones(len(strips), dtype=np.int64))


def growing_path(x: np.ndarray, y: np.ndarray, t: np.ndarray, z: float = 0.02) -> tuple[np.ndarray, list[np.ndarray]]:
    """The actual path as a growing strip: rows (trace indices) every ``1 / PATH_RATE_HZ`` s plus the last
    one, and for each the ``(k, 3)`` float32 points (m) up to it, decimated to ``PATH_POINT_RATE_HZ``,
    at height ``z``."""
    n = len(t)
    dt = float(np.median(np.diff(t))) if n > 1 else 0.01
    dt = dt if dt > 0 else 0.01
    pstep = max(1, int(round(1.0 / (PATH_POINT_RATE_HZ * dt))))
    rstep = max(1, int(round(1.0 / (PATH_RATE_HZ * dt))))
    rows = np.arange(0, n, rstep, dtype=np.int64)
    if rows[-1] != n - 1:
        rows = np.append(rows, n - 1)
    pts = np.stack([x, y, np.full(n, z)], axis=1).astype(np.float32)
    strips = []
    for i in rows:
        sel = np.arange(0, i + 1, pstep)
        if sel[-1] != i:
            sel = np.append(sel, i)
        strips.append(pts[sel])
    return rows, strips


def _finite_range(*arrays: np.ndarray, pad: float = 0.1) -> tuple[float, float] | None:
    """A padded y-axis range covering the finite values of the arrays, or None."""
    vals = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in arrays])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return None
    lo, hi = float(vals.min()), float(vals.max())
    span = max(hi - lo, 1e-3 * max(abs(hi), 1.0))
    return lo - pad * span, hi + pad * span


def _mode_count(trace: Mapping[str, np.ndarray], n_modes: int) -> int:
    k = 0
    while f"mode_prob_{k + 1}" in trace:
        k += 1
    return max(int(n_modes), k)


def _validate(trace: Mapping[str, np.ndarray]) -> int:
    missing = [c for c in REQUIRED_COLUMNS if c not in trace]
    if missing:
        raise ValueError(f"trace is missing columns: {', '.join(missing)}")
    n = len(trace["t"])
    if n == 0:
        raise ValueError("trace is empty")
    bad = [k for k, v in trace.items() if np.ndim(v) != 1 or np.shape(v)[0] != n]
    if bad:
        raise ValueError(f"trace columns of unequal length or not 1-D (t has {n} rows): {', '.join(bad)}")
    t = np.asarray(trace["t"], dtype=np.float64)
    if n > 1 and not np.all(np.diff(t) >= 0):
        raise ValueError("trace column t is not non-decreasing")
    return n


# ------------------------------------------------------------------------------------------------
# blueprint


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


def _blueprint(trace: Mapping[str, np.ndarray], n_modes: int, has_solves: bool,
               reference_path: np.ndarray | None) -> rrb.Blueprint:
    """Layout: 3D overview, 3D robot close-up and events on the left; a 2-column grid of time-series
    views on the right (some slots are tabs). The time cursor starts at the end of the run."""
    # one y range for both radius plots (truth and estimate, not the ±2σ bounds, which can be huge
    # while the filter is uncertain), at least ±10 % of the largest radius
    rad = _finite_range(trace["R_R"], trace["R_L"], trace["R_R_hat"], trace["R_L_hat"], pad=0.15)
    if rad is not None:
        mid, half = 0.5 * (rad[0] + rad[1]), 0.5 * (rad[1] - rad[0])
        half = max(half, 0.1 * max(abs(rad[0]), abs(rad[1]), 1e-3))
        rad = (mid - half, mid + half)
    rad_axis = rrb.ScalarAxis(range=rad) if rad is not None else None
    legend = rrb.PlotLegend(corner="RightTop")

    def ts(origin: str, name: str, **kw: object) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(origin=origin, name=name, plot_legend=legend, **kw)  # type: ignore[arg-type]

    # 3D overview eye: the whole reference (or path) from a high oblique viewpoint
    xy = (np.asarray(reference_path, dtype=np.float64)[:, :2] if reference_path is not None
          and len(reference_path) else np.stack([trace["x"], trace["y"]], axis=1))
    overview = overview_eye(xy)
    r0 = float(np.nanmax(np.abs(np.asarray(trace["R_R"], dtype=np.float64)))) if len(trace["R_R"]) else 1.0
    d = 4.0 * max(r0, 0.05)
    close = rrb.EyeControls3D(position=[-1.3 * d, -1.1 * d, 0.9 * d], look_target=[0.0, 0.0, 0.5 * r0],
                              eye_up=[0, 0, 1])

    series: list[rrb.View | rrb.Container] = [
        ts("/radius/right", "Right radius R_R (m): truth, estimate ±2σ, controller's model", axis_y=rad_axis),
        ts("/radius/left", "Left radius R_L (m): truth, estimate ±2σ, controller's model", axis_y=rad_axis),
    ]
    inn = ts("/innovation", "Speed innovation (m/s) ±2σ",
             contents=["/innovation/value", "/innovation/upper", "/innovation/lower"])
    if "nis" in trace:
        series.append(rrb.Tabs(inn, ts("/innovation/nis", "NIS"), active_tab=0))
    else:
        series.append(inn)
    series.append(ts("/wheel_rate", "Wheel rates (rad/s): measured, command, ±limit"))
    if n_modes:
        series.append(ts("/imm", "IMM mode probabilities", axis_y=rrb.ScalarAxis(range=(-0.02, 1.02))))
    series.append(ts("/tracking", "Cross-track error (m)"))
    speed = [ts("/speed", "Speed (m/s): truth, measured")]
    if "yaw_rate" in trace or "yaw_rate_meas" in trace:
        speed.append(ts("/yaw_rate", "Yaw rate (rad/s)"))
    if any(k in trace for k in ("roll", "pitch", "z")):
        speed.append(ts("/attitude", "Roll, pitch (rad), chassis z (m)"))
    if "fault_detected" in trace:
        speed.append(ts("/fault", "Fault detected (0/1)", axis_y=rrb.ScalarAxis(range=(-0.05, 1.05))))
    if "reconfig_state" in trace:
        speed.append(ts("/reconfiguration", "Reconfiguration (0 nominal, 1 hold, 2 handed over, 3 reverted)",
                        axis_y=rrb.ScalarAxis(range=(-0.1, 3.1))))
    series.append(rrb.Tabs(*speed, active_tab=0) if len(speed) > 1 else speed[0])
    if has_solves:
        series.append(rrb.Tabs(
            ts("/solver/solve_time_ms", "NMPC solve time (ms)"),
            ts("/solver/iterations", "NMPC iterations"),
            ts("/solver/status", "NMPC status (1 ok, 0.5 fallback, 0 failed)",
               axis_y=rrb.ScalarAxis(range=(-0.05, 1.05))),
            active_tab=0))
    left = rrb.Vertical(
        rrb.Spatial3DView(origin="/world", name="3D overview: reference, path, NMPC prediction",
                          eye_controls=overview, line_grid=rrb.LineGrid3D(visible=False)),
        rrb.Spatial3DView(origin="/world/robot", contents="/world/**", name="3D robot (wheel radii = true radii)",
                          eye_controls=close, line_grid=rrb.LineGrid3D(visible=False)),
        rrb.TextLogView(origin="/events", name="Events"),
        row_shares=[5, 4, 3],
    )
    right = rrb.Grid(*series, grid_columns=2)
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[2, 3]),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="following"),
        collapse_panels=True,
    )


# ------------------------------------------------------------------------------------------------
# writer


def write_rrd(path: Path, trace: Mapping[str, np.ndarray], *, run_id: str, app_id: str = "ftc-mj",
              solves: list[Solve] | None = None, events: list[Event] | None = None,
              reference_path: np.ndarray | None = None, geometry: RobotGeometry | None = None,
              omega_max: float = 17.4533, n_modes: int = 0) -> None:
    """Write one run's recording to ``path`` (atomically; see the module docstring for entities).

    ``trace`` holds equal-length columns, one row per estimator step (SI units, radians);
    ``reference_path`` is ``(N, 2)`` or ``(N, 3)`` (m); ``omega_max`` is the wheel-rate limit
    (rad/s); ``n_modes`` the number of IMM modes (0 = not an IMM run, unless the trace has
    ``mode_prob_*`` columns). Raises ``ValueError`` for a malformed trace (nothing is written).
    """
    path = Path(path)
    n = _validate(trace)
    geometry = geometry or RobotGeometry()
    solves = list(solves or [])
    events = list(events or [])
    m = _mode_count(trace, n_modes)
    has_solves = bool(solves) or ("solve_time_ms" in trace
                                  and bool(np.isfinite(np.asarray(trace["solve_time_ms"])).any()))
    with recording_file(path, app_id, run_id, _blueprint(trace, m, has_solves, reference_path)) as rec:
        _log_all(rec, trace, n, solves, events, reference_path, geometry, omega_max, m)


@contextlib.contextmanager
def recording_file(path: Path, app_id: str, recording_id: str, blueprint: rrb.Blueprint
                   ) -> Iterator[rr.RecordingStream]:
    """A recording stream of its own with a file sink and ``blueprint``, writing a temporary file beside
    ``path`` (:func:`ftc_mj.io.atomic_path`) that is renamed onto ``path`` once the stream is flushed and
    closed; on any error nothing appears under ``path``."""
    with atomic_path(Path(path)) as tmp:
        rec = rr.RecordingStream(app_id, recording_id=recording_id)
        try:
            rec.save(tmp, default_blueprint=blueprint)
            yield rec
            rec.flush()
        finally:
            rec.disconnect()


def _log_all(rec: rr.RecordingStream, trace: Mapping[str, np.ndarray], n: int, solves: list[Solve],
             events: list[Event], reference_path: np.ndarray | None, geometry: RobotGeometry,
             omega_max: float, m: int) -> None:
    """Send every entity (static styles first, then one ``send_columns`` per entity)."""
    t = np.asarray(trace["t"], dtype=np.float64)
    T = seconds_to_ns(t)
    steps = np.arange(n, dtype=np.int64)
    idx_all = [rr.TimeColumn("sim_time", duration=T), rr.TimeColumn("step", sequence=steps)]

    def col(name: str) -> np.ndarray:
        return np.asarray(trace[name], dtype=np.float64)

    def idx_rows(rows: np.ndarray) -> list[rr.TimeColumn]:
        return [rr.TimeColumn("sim_time", duration=T[rows]), rr.TimeColumn("step", sequence=rows)]

    def idx_times(times: np.ndarray) -> list[rr.TimeColumn]:
        return [rr.TimeColumn("sim_time", duration=seconds_to_ns(times)),
                rr.TimeColumn("step", sequence=_steps_for(times, t))]

    def style(entity: str, color: list[int], name: str, width: float = 1.5) -> None:
        rec.log(entity, series_style(tuple(color), name, width), static=True)

    def scalars(entity: str, values: np.ndarray, color: list[int], name: str, width: float = 1.5) -> None:
        style(entity, color, name, width)
        rec.send_columns(entity, indexes=idx_all, columns=rr.Scalars.columns(scalars=values))

    # ---- 3D scene --------------------------------------------------------------------------------
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    x, y, psi = col("x"), col("y"), col("psi")
    has_z = "z" in trace
    xy_ext = np.stack([x, y], axis=1)
    if reference_path is not None and len(reference_path):
        ref = np.asarray(reference_path, dtype=np.float64)
        ref3 = np.column_stack([ref[:, 0], ref[:, 1], ref[:, 2] if ref.shape[1] > 2 else np.zeros(len(ref))])
        rec.log("/world/reference", rr.LineStrips3D([ref3], radii=[0.08], colors=[[200, 200, 200]]),
                static=True)
        xy_ext = np.vstack([xy_ext, ref[:, :2]])
    xy_ext = xy_ext[np.all(np.isfinite(xy_ext), axis=1)]
    if len(xy_ext):
        lo, hi = xy_ext.min(axis=0), xy_ext.max(axis=0)
        margin = 0.1 * max(float(np.max(hi - lo)), 1.0) + 2.0 * geometry.nominal_radius
        cen, half = 0.5 * (lo + hi), 0.5 * (hi - lo) + margin
        rec.log("/world/ground", rr.Boxes3D(centers=[[cen[0], cen[1], -0.01]],
                                            half_sizes=[[half[0], half[1], 0.01]],
                                            colors=[[55, 58, 62]], fill_mode="solid"), static=True)

    z = col("z") if has_z else np.zeros(n)
    roll = col("roll") if "roll" in trace else None
    pitch = col("pitch") if "pitch" in trace else None
    rec.send_columns("/world/robot", indexes=idx_all,
                     columns=rr.Transform3D.columns(translation=np.stack([x, y, z], axis=1),
                                                    quaternion=_quat_xyzw(psi, roll, pitch)))
    g = geometry
    chassis_z = 0.0 if has_z else (g.chassis_height if g.chassis_height is not None else g.nominal_radius)
    rec.log("/world/robot/chassis",
            rr.Boxes3D(half_sizes=[list(g.chassis_half_sizes)], centers=[[g.chassis_offset_x, 0.0, chassis_z]],
                       colors=[[200, 80, 40]], fill_mode="solid"), static=True)
    axle = rr.RotationAxisAngle(axis=[1.0, 0.0, 0.0], degrees=90.0)   # cylinder axis (local z) along y
    for side, rcol, sign, color in (("right", "R_R", -1.0, [40, 160, 255]), ("left", "R_L", 1.0, [255, 200, 40])):
        r = col(rcol)
        rows = _change_rows(r, t, WHEEL_RADIUS_TOL, 1.0 / WHEEL_RATE_HZ)
        k = len(rows)
        cz = np.full(k, g.axle_offset_z) if has_z else r[rows]
        centers = np.column_stack([np.zeros(k), np.full(k, sign * g.half_track), cz])
        ent = f"/world/robot/wheel_{side}"
        rec.log(ent, rr.Cylinders3D.from_fields(rotation_axis_angles=[axle], colors=[color], fill_mode="solid",
                                                lengths=[g.wheel_width]), static=True)
        rec.send_columns(ent, indexes=idx_rows(rows),
                         columns=rr.Cylinders3D.columns(radii=r[rows], centers=centers))

    path_rows, strips = growing_path(x, y, t)
    rec.log("/world/path", rr.LineStrips3D.from_fields(radii=[0.06], colors=[[60, 220, 90]]), static=True)
    rec.send_columns("/world/path", indexes=idx_rows(path_rows),
                     columns=strips_column(strips))

    # ---- NMPC solves ----------------------------------------------------------------------------
    if solves:
        ts = np.array([s.t for s in solves], dtype=np.float64)
        order = np.argsort(ts, kind="stable")
        solves = [solves[i] for i in order]
        ts = ts[order]
        pred = []
        for s in solves:
            p = np.asarray(s.predicted, dtype=np.float64).reshape(-1, np.shape(s.predicted)[-1])
            pred.append(np.column_stack([p[:, 0], p[:, 1], np.full(len(p), 0.05)]).astype(np.float32))
        rec.log("/world/prediction", rr.LineStrips3D.from_fields(radii=[0.1], colors=[[230, 60, 230]]),
                static=True)
        rec.send_columns("/world/prediction", indexes=idx_times(ts),
                         columns=strips_column(pred))
        st_ms = np.array([s.solve_time_ms for s in solves], dtype=np.float64)
        iters = np.array([s.iterations for s in solves], dtype=np.float64)
        status = np.array([1.0 if s.ok else (0.5 if s.fallback else 0.0) for s in solves])
        solve_idx = idx_times(ts)
        events = events + [Event(s.t, "warn", f"NMPC solve failed: status {s.status}, {s.iterations} iterations"
                                 + (", fallback used" if s.fallback else ""))
                           for s in solves if not s.ok]
    elif "solve_time_ms" in trace:
        rows = np.flatnonzero(np.isfinite(col("solve_time_ms")))
        st_ms = col("solve_time_ms")[rows]
        iters = col("solver_iterations")[rows] if "solver_iterations" in trace else np.full(len(rows), np.nan)
        status = (np.where(col("solver_ok")[rows] > 0.5, 1.0, 0.0) if "solver_ok" in trace
                  else np.ones(len(rows)))
        solve_idx = idx_rows(rows)
    else:
        rows = np.zeros(0, dtype=np.int64)
        st_ms = iters = status = np.zeros(0)
        solve_idx = idx_rows(rows)
    if len(st_ms):
        for ent, vals, color, name in (("/solver/solve_time_ms", st_ms, _EST, "solve time (ms)"),
                                       ("/solver/iterations", iters, _CMD, "iterations"),
                                       ("/solver/status", status, _MEAS, "status (1 ok, 0.5 fallback, 0 fail)")):
            style(ent, color, name)
            rec.send_columns(ent, indexes=solve_idx, columns=rr.Scalars.columns(scalars=vals))

    # ---- time series ------------------------------------------------------------------------------
    for side, s in (("right", "R"), ("left", "L")):
        est, std = col(f"R_{s}_hat"), col(f"R_{s}_std")
        scalars(f"/radius/{side}/truth", col(f"R_{s}"), _TRUTH, f"R_{s} truth", 2.0)
        scalars(f"/radius/{side}/estimate", est, _EST, f"R_{s} estimate", 2.0)
        scalars(f"/radius/{side}/upper", est + 2.0 * std, _BOUND, "+2σ", 1.0)
        scalars(f"/radius/{side}/lower", est - 2.0 * std, _BOUND, "-2σ", 1.0)
        if f"R_{s}_model" in trace:
            scalars(f"/radius/{side}/model", col(f"R_{s}_model"), _CMD, f"R_{s} controller model", 1.5)
    inn, inn_std = col("innovation"), col("innovation_std")
    scalars("/innovation/value", inn, _EST, "innovation", 1.0)
    scalars("/innovation/upper", 2.0 * inn_std, _BOUND, "+2σ", 1.0)
    scalars("/innovation/lower", -2.0 * inn_std, _BOUND, "-2σ", 1.0)
    if "nis" in trace:
        scalars("/innovation/nis", col("nis"), _CMD, "NIS", 1.0)
    for side, s, c in (("right", "R", [40, 160, 255]), ("left", "L", [255, 200, 40])):
        scalars(f"/wheel_rate/{side}/measured", col(f"omega_{s}"), c, f"ω_{s} measured", 1.5)
        scalars(f"/wheel_rate/{side}/command", col(f"omega_{s}_cmd"), _CMD if s == "R" else [200, 60, 200],
                f"ω_{s} command", 1.0)
    rec.log("/wheel_rate/limits", rr.SeriesLines(colors=[_LIMIT, _LIMIT], names=["+ω_max", "-ω_max"],
                                                 widths=[1.0, 1.0]), static=True)
    lim_rows = np.array([0, n - 1], dtype=np.int64) if n > 1 else np.array([0], dtype=np.int64)
    rec.send_columns("/wheel_rate/limits", indexes=idx_rows(lim_rows),
                     columns=rr.Scalars.columns(
                         scalars=np.tile([omega_max, -omega_max], len(lim_rows))).partition(
                             np.full(len(lim_rows), 2, np.int64)))
    for k in range(1, m + 1):
        name = f"mode_prob_{k}"
        if name in trace:
            scalars(f"/imm/{name}", col(name), _MODE_COLORS[(k - 1) % len(_MODE_COLORS)], f"mode {k}", 1.5)
    scalars("/tracking/cross_track_error", col("cross_track_error"), _EST, "cross-track error", 1.5)
    scalars("/speed/truth", col("v"), _TRUTH, "v truth", 1.5)
    scalars("/speed/measured", col("v_meas"), _MEAS, "v measured", 1.0)
    if "yaw_rate" in trace:
        scalars("/yaw_rate/truth", col("yaw_rate"), _TRUTH, "yaw rate truth", 1.5)
    if "yaw_rate_meas" in trace:
        scalars("/yaw_rate/measured", col("yaw_rate_meas"), _MEAS, "yaw rate measured", 1.0)
    for name, c in (("roll", _EST), ("pitch", _CMD), ("z", _TRUTH)):
        if name in trace:
            scalars(f"/attitude/{name}", col(name), c, name, 1.0)
    if "fault_detected" in trace:
        scalars("/fault/detected", col("fault_detected"), _LIMIT, "fault detected", 1.5)
    if "reconfig_state" in trace:
        scalars("/reconfiguration/state", col("reconfig_state"), _EST, "reconfiguration state", 1.5)

    # ---- events -----------------------------------------------------------------------------------
    if events:
        events = sorted(events, key=lambda e: e.t)
        et = np.array([e.t for e in events], dtype=np.float64)
        levels = [str(TEXT_LEVELS.get(e.level.strip().lower(), rr.TextLogLevel.INFO)) for e in events]
        rec.send_columns("/events", indexes=idx_times(et),
                         columns=rr.TextLog.columns(text=[e.text for e in events], level=levels))


# ------------------------------------------------------------------------------------------------
# synthetic data (tests, benchmark, docs screenshot)


def synthetic_run(duration: float = 40.0, *, rate_hz: float = 100.0, solve_rate_hz: float = 10.0,
                  horizon: int = 20, n_modes: int = 3, fault_time: float = 10.0, seed: int = 0,
                  ) -> tuple[dict[str, np.ndarray], list[Solve], list[Event], np.ndarray]:
    """A plausible scenario-2-like run (right tyre deflating from 2.0 m to 1.0 m over 1 s at
    ``fault_time`` while tracking a 50 m circle at 10 m/s) for tests, benchmarks and screenshots.

    Returns ``(trace, solves, events, reference_path)``; the trace has every column
    :func:`write_rrd` understands, solver columns filled on solve rows only (NaN elsewhere).
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration * rate_hz))
    t = np.arange(n) / rate_hz
    R0, b, Rc, V = 2.0, 1.0, 50.0, 10.0
    R_R = np.where(t < fault_time, R0, np.maximum(R0 - 1.0 * (t - fault_time), 1.0))
    R_L = np.full(n, R0)
    w = V / Rc
    err = 0.6 * np.exp(-np.maximum(t - fault_time, 0.0) / 4.0) * (t >= fault_time) * np.sin(0.8 * t)
    psi = w * t + np.pi / 2
    rad = Rc + err
    x, y = rad * np.cos(w * t), rad * np.sin(w * t)
    v = V + 0.3 * np.sin(0.5 * t) * (t >= fault_time)
    yaw_rate = np.full(n, w) + 0.05 * np.gradient(err, t)
    omega_L = (v - yaw_rate * b) / R_L
    omega_R = (v + yaw_rate * b) / R_R
    tau = np.maximum(t - fault_time, 0.0)
    R_R_hat = np.where(t < fault_time, R0 + 0.01 * np.sin(t), 1.0 + (R0 - 1.0) * np.exp(-tau / 1.5))
    R_L_hat = R0 + 0.01 * np.sin(0.7 * t)
    R_R_std = 0.02 + 0.3 * np.exp(-t) + 0.15 * np.exp(-tau / 2.0) * (t >= fault_time)
    R_L_std = 0.02 + 0.3 * np.exp(-t)
    innovation_std = np.full(n, 0.5) + 0.05 * np.exp(-t)
    innovation = rng.normal(0.0, 0.5, n)
    trace: dict[str, np.ndarray] = {
        "t": t, "x": x, "y": y, "psi": psi, "v": v, "v_meas": v + rng.normal(0.0, 0.5, n),
        "R_R": R_R, "R_L": R_L, "R_R_hat": R_R_hat, "R_L_hat": R_L_hat, "R_R_std": R_R_std,
        "R_L_std": R_L_std, "innovation": innovation, "innovation_std": innovation_std,
        "omega_R": omega_R + rng.normal(0.0, 0.02, n), "omega_L": omega_L + rng.normal(0.0, 0.02, n),
        "omega_R_cmd": omega_R, "omega_L_cmd": omega_L, "cross_track_error": err,
        "yaw_rate": yaw_rate, "yaw_rate_meas": yaw_rate + rng.normal(0.0, 0.01, n),
        "roll": np.where(t < fault_time, 0.0, -np.arcsin((R0 - R_R) / (2 * b))),
        "pitch": np.zeros(n), "z": 0.5 * (R_R + R_L), "nis": innovation**2 / innovation_std**2,
        "fault_detected": (t >= fault_time + 0.8).astype(np.float64),
        # safe reconfiguration: nominal, hold after the declaration, hand-over 0.5 s later
        "reconfig_state": np.select([t < fault_time + 0.8, t < fault_time + 1.3], [0.0, 1.0], 2.0),
        "R_L_model": np.full(n, R0),
    }
    trace["R_R_model"] = np.where(trace["reconfig_state"] == 2.0, np.maximum(R_R_hat, 0.05), R0)
    if n_modes:
        logits = np.zeros((n, n_modes))
        logits[:, 0] = np.where(t < fault_time + 0.5, 4.0, -2.0)
        if n_modes > 1:
            logits[:, 1] = np.where(t < fault_time + 0.5, 0.0, 4.0)
        p = np.exp(logits)
        p /= p.sum(axis=1, keepdims=True)
        for k in range(n_modes):
            trace[f"mode_prob_{k + 1}"] = p[:, k]
    every = max(1, int(round(rate_hz / solve_rate_hz)))
    rows = np.arange(0, n, every)
    solves: list[Solve] = []
    st = np.full(n, np.nan)
    it = np.full(n, np.nan)
    ok = np.full(n, np.nan)
    for i in rows:
        tk = t[i] + np.arange(horizon) * 0.1
        pred = np.column_stack([Rc * np.cos(w * tk), Rc * np.sin(w * tk), w * tk + np.pi / 2])
        pred[:, :2] += np.array([x[i] - pred[0, 0], y[i] - pred[0, 1]]) * np.exp(-np.arange(horizon) / 5)[:, None]
        fail = bool(abs(t[i] - (fault_time + 0.3)) < 0.5 / solve_rate_hz)
        s = Solve(t=float(t[i]), predicted=pred, solve_time_ms=float(8.0 + rng.gamma(2.0, 1.0)),
                  iterations=int(8 + rng.integers(0, 10)) if not fail else 3000,
                  status="Maximum_Iterations_Exceeded" if fail else "Solve_Succeeded", fallback=fail)
        solves.append(s)
        st[i], it[i], ok[i] = s.solve_time_ms, s.iterations, float(s.ok)
    trace["solve_time_ms"], trace["solver_iterations"], trace["solver_ok"] = st, it, ok
    events = [
        Event(0.0, "info", "run started: scenario2 (synthetic), UKF, feedback on"),
        Event(fault_time, "warn", "fault onset: right tyre deflating 2.0 m -> 1.0 m over 1 s"),
        Event(fault_time + 0.8, "warn", "decision: fault isolated on the RIGHT wheel"),
        Event(fault_time + 2.0, "info", "reconfiguration: feeding back R_R_hat"),
        Event(duration - 1.0 / rate_hz, "info", "run finished"),
    ]
    ang = np.linspace(0.0, 2 * np.pi, 361)
    reference = np.column_stack([Rc * np.cos(ang), Rc * np.sin(ang)])
    return trace, solves, events, reference


# ------------------------------------------------------------------------------------------------
# reading back / viewing


def read_scalar_series(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """Read one ``Scalars`` entity back from a ``.rrd``: ``(t, values)`` sorted by time.

    ``t`` is ``sim_time`` in seconds (float64). ``values`` is ``(n,)`` when every row holds one
    scalar, else ``(n, k)``. Static chunks are ignored. Raises ``KeyError`` if the entity has no
    ``Scalars`` data.
    """
    import pyarrow as pa
    from rerun.chunk import RrdReader

    entity = "/" + entity.strip("/")
    chunks = (RrdReader(str(path)).stream()
              .filter(content=entity, components="Scalars:scalars", is_static=False).to_chunks())
    ts: list[np.ndarray] = []
    vs: list[list[list[float]]] = []
    for ch in chunks:
        if str(ch.entity_path) != entity:
            continue
        rb = ch.to_record_batch()
        if "Scalars:scalars" not in rb.schema.names:
            continue
        ts.append(rb.column("sim_time").cast(pa.int64()).to_numpy(zero_copy_only=False))
        vs.extend(rb.column("Scalars:scalars").to_pylist())
    if not ts:
        raise KeyError(f"no Scalars data for {entity} in {path}")
    t_ns = np.concatenate(ts)
    order = np.argsort(t_ns, kind="stable")
    widths = {len(v) for v in vs}
    if widths == {1}:
        values = np.array([v[0] for v in vs], dtype=np.float64)
    else:
        values = np.array(vs, dtype=np.float64)
    return t_ns[order] * 1e-9, values[order]


def _rerun_executable() -> str:
    """The ``rerun`` CLI of the installed rerun-sdk (next to the interpreter, else on PATH)."""
    cand = Path(sys.executable).parent / "rerun"
    if cand.exists():
        return str(cand)
    found = shutil.which("rerun")
    if found is None:
        raise RunFailed("the rerun viewer executable was not found (is rerun-sdk installed?)")
    return found


def check_recording(path: Path) -> Path:
    """The ``.rrd`` of a run directory (its ``run.rrd``) or the file itself, if Rerun can read a recording
    from it; else :class:`~ftc_mj.errors.BadInput` naming ``RUN_DIR``."""
    from rerun.chunk import RrdReader

    p = Path(path)
    try:
        if p.is_dir():
            p = p / "run.rrd"
        found = p.is_file()
    except (OSError, ValueError) as err:
        raise BadInput(f"RUN_DIR: cannot use {str(path)[:80]}: {getattr(err, 'strerror', None) or err}") from None
    if not found:
        raise BadInput(f"RUN_DIR: recording not found: {p}")
    try:
        ok = bool(RrdReader(str(p)).recordings())
    except (RuntimeError, OSError, ValueError) as err:
        raise BadInput(f"RUN_DIR: {p} is not a Rerun recording ({str(err).splitlines()[0][:100]})") from None
    if not ok:
        raise BadInput(f"RUN_DIR: {p} holds no recording")
    return p


def check_display(headless_hint: str) -> None:
    """Raise :class:`~ftc_mj.errors.RunFailed` (one line naming ``headless_hint``, the command that renders
    a screenshot instead) when the native viewer has no display to open on (Linux without ``DISPLAY``
    or ``WAYLAND_DISPLAY``)."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise RunFailed(f"no display for the Rerun viewer (DISPLAY is not set); for a headless screenshot run: "
                        f"{headless_hint}")


def open_viewer(path: Path, *, wait: bool = True, extra_args: Iterable[str] = ()) -> None:
    """Open a recording in the native Rerun viewer.

    ``path`` is a ``.rrd`` file or a run directory (its ``run.rrd`` is opened). Raises
    :class:`~ftc_mj.errors.BadInput` if the file does not exist. With ``wait`` (default) blocks until
    the viewer is closed and raises :class:`~ftc_mj.errors.RunFailed` if it exits with an error.
    """
    p = Path(path)
    if p.is_dir():
        p = p / "run.rrd"
    if not p.is_file():
        raise BadInput(f"recording not found: {p}")
    cmd = [_rerun_executable(), str(p), *extra_args]
    if not wait:
        subprocess.Popen(cmd, start_new_session=True)
        return
    rc = subprocess.run(cmd, check=False).returncode
    if rc != 0:
        raise RunFailed(f"the Rerun viewer exited with code {rc} (no display?)")
