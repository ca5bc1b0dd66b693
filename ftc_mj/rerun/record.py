"""Write one run's Rerun recording (``run.rrd``) from buffered telemetry, column-wise.

The simulation loop buffers its telemetry in arrays and calls :func:`write_rrd` **once** at the end
of a run. Every entity is sent with ``RecordingStream.send_columns`` (one call per entity, never a
per-step ``log()``; ``benchmarks/bench_recorder.py`` times both ways). The file is
written by :func:`~ftc_mj.rerun.stream.recording_file` (its own stream, atomic rename); the layout
is :func:`~ftc_mj.rerun.blueprint.run_blueprint`.

Timelines
---------
``sim_time``
    duration, integer nanoseconds (:func:`~ftc_mj.rerun.stream.seconds_to_ns`).
``step``
    sequence, the estimator-step index (row of the trace). Solves and events get the index of the
    last trace row at or before their time.

Entities
--------
3D scene (world frame, z up, metres), by :func:`_log_scene`, :func:`_log_robot`, :func:`_log_wheels`,
:func:`_log_path`:

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
  ``R_R_hat ± 2 R_R_std`` (same for the left wheel); ``/radius/{right,left}/model``: ``R_*_model``,
  the radii the controller was handed (if present) — :func:`_log_radii`.
- ``/innovation/{value,upper,lower}``: ``innovation``, ``± 2 innovation_std``; ``/innovation/nis``
  (if ``nis`` is in the trace) — :func:`_log_innovation`.
- ``/wheel_rate/right/{measured,command}``, ``/wheel_rate/left/{measured,command}``: ``omega_*``,
  ``omega_*_cmd``; ``/wheel_rate/limits``: two series ``[+omega_max, -omega_max]`` at the first and
  last time — :func:`_log_wheel_rates`.
- ``/imm/mode_prob_k`` for ``k = 1..M`` (``M = max(n_modes, mode_prob_* columns in the trace)``) —
  :func:`_log_modes`.
- ``/tracking/cross_track_error``; ``/speed/{truth,measured}``: ``v``, ``v_meas``;
  ``/yaw_rate/{truth,measured}`` (if ``yaw_rate``/``yaw_rate_meas`` are in the trace);
  ``/attitude/{roll,pitch,z}`` (if present); ``/fault/detected`` (if ``fault_detected`` is present;
  0/1); ``/reconfiguration/state`` (if ``reconfig_state`` is present; 0 nominal, 1 hold, 2 handed
  over, 3 reverted); ``/accommodation/{mode,effectiveness_R,effectiveness_L}`` (if ``accommodation_mode`` is
  present; 0 nominal, 1 accommodated, 2 safe stop, 3 at rest; the servo effectiveness of the controller's
  actuator model) — :func:`_log_motion` and :func:`_log_modes`.
- ``/injected/<name>``: the injected servo and sensor faults' truth, trace columns ``fault_<name>``
  (:data:`~ftc_mj.telemetry.columns.FAULT_TRUTH_COLUMNS`, present only in a run with such a fault):
  servo effectiveness and lock per wheel, sensor offsets and dropout flags — :func:`_log_injected`.
- ``/path_following/{progress,contouring_error,lag_error}``, ``/path_following/speed/{desired,planned,
  progress}``, ``/path_following/lateral_accel/{planned,bound}``, ``/path_following/slack``: the
  path-following NMPC's telemetry (trace columns ``pf_*``, if present), only at solve times —
  :func:`_log_path_following`.
- ``/solver/{solve_time_ms,iterations,status}``: **only at solve times** (not forward-filled).
  Taken from ``solves`` if given, else from the trace rows where ``solve_time_ms`` is finite.
  ``status`` is 1 for a solve that converged, 0 for a failed one, and 0.5 for a fallback —
  :func:`_log_solves`.

Text: ``/events``: ``TextLog`` (``info``/``warn``/``error`` → ``INFO``/``WARN``/``ERROR``) at the
event times; solver failures from ``solves`` are added as ``WARN`` events automatically.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from ftc_mj.telemetry import Event, RobotGeometry, Solve
from ftc_mj.telemetry.columns import FAULT_TRUTH_COLUMNS

from .blueprint import run_blueprint
from .stream import growing_path, recording_file, seconds_to_ns, send_events, send_series, strips_column

__all__ = ["PF_SERIES", "REQUIRED_COLUMNS", "write_rrd"]

REQUIRED_COLUMNS: tuple[str, ...] = (
    "t", "x", "y", "psi", "v", "v_meas", "R_R", "R_L", "R_R_hat", "R_L_hat", "R_R_std", "R_L_std",
    "innovation", "innovation_std", "omega_R", "omega_L", "omega_R_cmd", "omega_L_cmd",
    "cross_track_error",
)
"""Trace columns :func:`write_rrd` needs (the minimum columns of ``trace.parquet``)."""

WHEEL_RATE_HZ = 10.0
"""Largest row rate of the wheel cylinders (Hz)."""
WHEEL_RADIUS_TOL = 1e-4
"""Radius change (m) that triggers a new wheel-cylinder row."""

# colours (RGB)
_TRUTH = [230, 200, 40]
_EST = [40, 140, 240]
_BOUND = [150, 150, 150]
_MEAS = [120, 200, 120]
_CMD = [240, 110, 40]
_LIMIT = [220, 40, 40]
PF_SERIES: tuple[tuple[str, str, list[int], str], ...] = (
    ("pf_progress", "/path_following/progress", [40, 140, 240], "progress s"),
    ("pf_contouring_error", "/path_following/contouring_error", [40, 140, 240], "contouring error"),
    ("pf_lag_error", "/path_following/lag_error", [240, 110, 40], "lag error"),
    ("pf_speed_desired", "/path_following/speed/desired", [230, 200, 40], "desired speed"),
    ("pf_speed_planned", "/path_following/speed/planned", [40, 140, 240], "planned speed"),
    ("pf_progress_speed", "/path_following/speed/progress", [120, 200, 120], "progress speed"),
    ("pf_lateral_accel", "/path_following/lateral_accel/planned", [40, 140, 240], "planned lateral acceleration"),
    ("pf_lateral_bound", "/path_following/lateral_accel/bound", [220, 40, 40], "bound"),
    ("pf_slack", "/path_following/slack", [150, 150, 150], "slack of the bound"),
    ("pf_degraded", "/path_following/degraded/mode", [220, 40, 40], "degraded mode (1 = radius interval)"),
    ("pf_corner_slack", "/path_following/degraded/slack", [150, 150, 150], "slack of the interval's bound"),
    ("pf_skid", "/path_following/degraded/skid", [240, 110, 40], "no-slip test fails (1 right + 2 left)"),
    ("pf_R_R_lo", "/path_following/degraded/R_R/lo", [40, 140, 240], "R_R interval low"),
    ("pf_R_R_hi", "/path_following/degraded/R_R/hi", [40, 140, 240], "R_R interval high"),
    ("pf_R_L_lo", "/path_following/degraded/R_L/lo", [240, 110, 40], "R_L interval low"),
    ("pf_R_L_hi", "/path_following/degraded/R_L/hi", [240, 110, 40], "R_L interval high"),
)
"""(trace column, entity, colour, name) of the path-following NMPC's series (logged at solve rows only)."""
_MODE_COLORS = [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
                [140, 86, 75], [227, 119, 194], [127, 127, 127]]


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
    _validate(trace)
    geometry = geometry or RobotGeometry()
    solves = list(solves or [])
    m = _mode_count(trace, n_modes)
    has_solves = bool(solves) or ("solve_time_ms" in trace
                                  and bool(np.isfinite(np.asarray(trace["solve_time_ms"])).any()))
    with recording_file(path, app_id, run_id, run_blueprint(trace, m, has_solves, reference_path)) as rec:
        sink = _Sink(rec, trace)
        _log_scene(sink, reference_path, geometry)
        _log_robot(sink, geometry)
        _log_wheels(sink, geometry)
        _log_path(sink)
        failures = _log_solves(sink, solves)
        _log_radii(sink)
        _log_innovation(sink)
        _log_wheel_rates(sink, omega_max)
        _log_modes(sink, m)
        _log_motion(sink)
        _log_injected(sink)
        _log_path_following(sink)
        _log_events(sink, list(events or []) + failures)


def _validate(trace: Mapping[str, np.ndarray]) -> int:
    """The trace's row count; ``ValueError`` for a missing column, an empty or ragged trace, or ``t``
    decreasing."""
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


def _mode_count(trace: Mapping[str, np.ndarray], n_modes: int) -> int:
    """IMM modes to draw: ``n_modes`` or the number of consecutive ``mode_prob_k`` columns, the larger."""
    k = 0
    while f"mode_prob_{k + 1}" in trace:
        k += 1
    return max(int(n_modes), k)


@dataclass
class _Sink:
    """The recording stream and the trace's timelines every logger sends against."""

    rec: rr.RecordingStream
    trace: Mapping[str, np.ndarray]

    def __post_init__(self) -> None:
        self.t = np.asarray(self.trace["t"], dtype=np.float64)
        self.n = len(self.t)
        self.T = seconds_to_ns(self.t)
        self.idx_all = [rr.TimeColumn("sim_time", duration=self.T),
                        rr.TimeColumn("step", sequence=np.arange(self.n, dtype=np.int64))]

    def col(self, name: str) -> np.ndarray:
        """Trace column ``name`` as float64."""
        return np.asarray(self.trace[name], dtype=np.float64)

    def idx_rows(self, rows: np.ndarray) -> list[rr.TimeColumn]:
        """Time columns of the trace rows ``rows``."""
        return [rr.TimeColumn("sim_time", duration=self.T[rows]), rr.TimeColumn("step", sequence=rows)]

    def idx_times(self, times: np.ndarray) -> list[rr.TimeColumn]:
        """Time columns at ``times`` (s), each with the step of the last trace row at or before it."""
        return [rr.TimeColumn("sim_time", duration=seconds_to_ns(times)),
                rr.TimeColumn("step", sequence=_steps_for(times, self.t))]

    def scalars(self, entity: str, values: np.ndarray, color: list[int], name: str, width: float = 1.5) -> None:
        """A scalar entity with one value per trace row."""
        send_series(self.rec, entity, self.idx_all, values, color, name, width)


def _steps_for(times: np.ndarray, t_trace: np.ndarray) -> np.ndarray:
    """Index of the last trace row at or before each time (clipped to the trace)."""
    idx = np.searchsorted(t_trace, np.asarray(times, dtype=np.float64) + 1e-9, side="right") - 1
    return np.clip(idx, 0, len(t_trace) - 1).astype(np.int64)


def _quat_xyzw(psi: np.ndarray, roll: np.ndarray | None, pitch: np.ndarray | None) -> np.ndarray:
    """ZYX (yaw, pitch, roll) Euler angles (rad) → quaternions ``(n, 4)`` in xyzw order."""
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


def _log_scene(sink: _Sink, reference_path: np.ndarray | None, geometry: RobotGeometry) -> None:
    """World axes (z up), the static reference strip and a ground box under path and reference with a
    margin of 10 % of the extent (at least 1 m) plus two wheel radii."""
    rec = sink.rec
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    xy_ext = np.stack([sink.col("x"), sink.col("y")], axis=1)
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


def _log_robot(sink: _Sink, geometry: RobotGeometry) -> None:
    """The robot frame (pose at every row) and its static chassis box (on the axle when there is no
    ``z`` column, else at the frame's origin)."""
    trace = sink.trace
    z = sink.col("z") if "z" in trace else np.zeros(sink.n)
    roll = sink.col("roll") if "roll" in trace else None
    pitch = sink.col("pitch") if "pitch" in trace else None
    sink.rec.send_columns("/world/robot", indexes=sink.idx_all,
                          columns=rr.Transform3D.columns(
                              translation=np.stack([sink.col("x"), sink.col("y"), z], axis=1),
                              quaternion=_quat_xyzw(sink.col("psi"), roll, pitch)))
    g = geometry
    chassis_z = 0.0 if "z" in trace else (g.chassis_height if g.chassis_height is not None else g.nominal_radius)
    sink.rec.log("/world/robot/chassis",
                 rr.Boxes3D(half_sizes=[list(g.chassis_half_sizes)], centers=[[g.chassis_offset_x, 0.0, chassis_z]],
                            colors=[[200, 80, 40]], fill_mode="solid"), static=True)


def _log_wheels(sink: _Sink, geometry: RobotGeometry) -> None:
    """The wheel cylinders with the true radii (m), at the rows :func:`_change_rows` keeps."""
    g, has_z = geometry, "z" in sink.trace
    axle = rr.RotationAxisAngle(axis=[1.0, 0.0, 0.0], degrees=90.0)   # cylinder axis (local z) along y
    for side, rcol, sign, color in (("right", "R_R", -1.0, [40, 160, 255]), ("left", "R_L", 1.0, [255, 200, 40])):
        r = sink.col(rcol)
        rows = _change_rows(r, sink.t, WHEEL_RADIUS_TOL, 1.0 / WHEEL_RATE_HZ)
        k = len(rows)
        cz = np.full(k, g.axle_offset_z) if has_z else r[rows]
        centers = np.column_stack([np.zeros(k), np.full(k, sign * g.half_track), cz])
        ent = f"/world/robot/wheel_{side}"
        sink.rec.log(ent, rr.Cylinders3D.from_fields(rotation_axis_angles=[axle], colors=[color], fill_mode="solid",
                                                     lengths=[g.wheel_width]), static=True)
        sink.rec.send_columns(ent, indexes=sink.idx_rows(rows),
                              columns=rr.Cylinders3D.columns(radii=r[rows], centers=centers))


def _log_path(sink: _Sink) -> None:
    """The actual path as a growing strip (:func:`~ftc_mj.rerun.stream.growing_path`)."""
    path_rows, strips = growing_path(sink.col("x"), sink.col("y"), sink.t)
    sink.rec.log("/world/path", rr.LineStrips3D.from_fields(radii=[0.06], colors=[[60, 220, 90]]), static=True)
    sink.rec.send_columns("/world/path", indexes=sink.idx_rows(path_rows), columns=strips_column(strips))


def _log_solves(sink: _Sink, solves: list[Solve]) -> list[Event]:
    """The NMPC predictions and the solver series at solve times (from ``solves``, else from the trace's
    solve rows); returns a ``WARN`` event per failed solve."""
    failures: list[Event] = []
    if solves:
        ts = np.array([s.t for s in solves], dtype=np.float64)
        order = np.argsort(ts, kind="stable")
        solves = [solves[i] for i in order]
        ts = ts[order]
        pred = []
        for s in solves:
            p = np.asarray(s.predicted, dtype=np.float64).reshape(-1, np.shape(s.predicted)[-1])
            pred.append(np.column_stack([p[:, 0], p[:, 1], np.full(len(p), 0.05)]).astype(np.float32))
        sink.rec.log("/world/prediction", rr.LineStrips3D.from_fields(radii=[0.1], colors=[[230, 60, 230]]),
                     static=True)
        sink.rec.send_columns("/world/prediction", indexes=sink.idx_times(ts), columns=strips_column(pred))
        st_ms = np.array([s.solve_time_ms for s in solves], dtype=np.float64)
        iters = np.array([s.iterations for s in solves], dtype=np.float64)
        status = np.array([1.0 if s.ok else (0.5 if s.fallback else 0.0) for s in solves])
        solve_idx = sink.idx_times(ts)
        failures = [Event(s.t, "warn", f"NMPC solve failed: status {s.status}, {s.iterations} iterations"
                          + (", fallback used" if s.fallback else "")) for s in solves if not s.ok]
    else:
        st_ms, iters, status, solve_idx = _trace_solves(sink)
    if len(st_ms):
        for ent, vals, color, name in (("/solver/solve_time_ms", st_ms, _EST, "solve time (ms)"),
                                       ("/solver/iterations", iters, _CMD, "iterations"),
                                       ("/solver/status", status, _MEAS, "status (1 ok, 0.5 fallback, 0 fail)")):
            send_series(sink.rec, ent, solve_idx, vals, color, name, 1.5)
    return failures


def _trace_solves(sink: _Sink) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[rr.TimeColumn]]:
    """Solve time (ms), iterations, status and time columns of the trace rows with a finite
    ``solve_time_ms`` (none if the trace has no such column)."""
    if "solve_time_ms" not in sink.trace:
        rows = np.zeros(0, dtype=np.int64)
        return np.zeros(0), np.zeros(0), np.zeros(0), sink.idx_rows(rows)
    trace, col = sink.trace, sink.col
    rows = np.flatnonzero(np.isfinite(col("solve_time_ms")))
    st_ms = col("solve_time_ms")[rows]
    iters = col("solver_iterations")[rows] if "solver_iterations" in trace else np.full(len(rows), np.nan)
    status = (np.where(col("solver_ok")[rows] > 0.5, 1.0, 0.0) if "solver_ok" in trace
              else np.ones(len(rows)))
    return st_ms, iters, status, sink.idx_rows(rows)


def _log_radii(sink: _Sink) -> None:
    """True, estimated (±2σ) and controller-model radii (m) of both wheels."""
    col = sink.col
    for side, s in (("right", "R"), ("left", "L")):
        est, std = col(f"R_{s}_hat"), col(f"R_{s}_std")
        sink.scalars(f"/radius/{side}/truth", col(f"R_{s}"), _TRUTH, f"R_{s} truth", 2.0)
        sink.scalars(f"/radius/{side}/estimate", est, _EST, f"R_{s} estimate", 2.0)
        sink.scalars(f"/radius/{side}/upper", est + 2.0 * std, _BOUND, "+2σ", 1.0)
        sink.scalars(f"/radius/{side}/lower", est - 2.0 * std, _BOUND, "-2σ", 1.0)
        if f"R_{s}_model" in sink.trace:
            sink.scalars(f"/radius/{side}/model", col(f"R_{s}_model"), _CMD, f"R_{s} controller model", 1.5)


def _log_innovation(sink: _Sink) -> None:
    """The speed innovation (m/s) with ±2σ, and the NIS if recorded."""
    inn, inn_std = sink.col("innovation"), sink.col("innovation_std")
    sink.scalars("/innovation/value", inn, _EST, "innovation", 1.0)
    sink.scalars("/innovation/upper", 2.0 * inn_std, _BOUND, "+2σ", 1.0)
    sink.scalars("/innovation/lower", -2.0 * inn_std, _BOUND, "-2σ", 1.0)
    if "nis" in sink.trace:
        sink.scalars("/innovation/nis", sink.col("nis"), _CMD, "NIS", 1.0)


def _log_wheel_rates(sink: _Sink, omega_max: float) -> None:
    """Measured and commanded wheel rates (rad/s) and the ±``omega_max`` limit at the first and last time."""
    for side, s, c in (("right", "R", [40, 160, 255]), ("left", "L", [255, 200, 40])):
        sink.scalars(f"/wheel_rate/{side}/measured", sink.col(f"omega_{s}"), c, f"ω_{s} measured", 1.5)
        sink.scalars(f"/wheel_rate/{side}/command", sink.col(f"omega_{s}_cmd"),
                     _CMD if s == "R" else [200, 60, 200], f"ω_{s} command", 1.0)
    sink.rec.log("/wheel_rate/limits", rr.SeriesLines(colors=[_LIMIT, _LIMIT], names=["+ω_max", "-ω_max"],
                                                      widths=[1.0, 1.0]), static=True)
    n = sink.n
    lim_rows = np.array([0, n - 1], dtype=np.int64) if n > 1 else np.array([0], dtype=np.int64)
    sink.rec.send_columns("/wheel_rate/limits", indexes=sink.idx_rows(lim_rows),
                          columns=rr.Scalars.columns(
                              scalars=np.tile([omega_max, -omega_max], len(lim_rows))).partition(
                                  np.full(len(lim_rows), 2, np.int64)))


def _log_modes(sink: _Sink, m: int) -> None:
    """The IMM mode probabilities ``mode_prob_1 … mode_prob_m`` present in the trace."""
    for k in range(1, m + 1):
        name = f"mode_prob_{k}"
        if name in sink.trace:
            sink.scalars(f"/imm/{name}", sink.col(name), _MODE_COLORS[(k - 1) % len(_MODE_COLORS)], f"mode {k}", 1.5)


def _log_motion(sink: _Sink) -> None:
    """Cross-track error (m), speed (m/s), yaw rate (rad/s), attitude (rad, m), the fault flag and the
    reconfiguration state — each optional one only if the trace has it."""
    trace, col, scalars = sink.trace, sink.col, sink.scalars
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
    if "accommodation_mode" in trace:
        scalars("/accommodation/mode", col("accommodation_mode"), _EST, "accommodation mode", 1.5)
        for side, c in (("R", _TRUTH), ("L", _CMD)):
            scalars(f"/accommodation/effectiveness_{side}", col(f"actuator_effectiveness_{side}"), c,
                    f"actuator model: servo effectiveness {side}", 1.0)
    _log_diagnosis(sink)


def _log_diagnosis(sink: _Sink) -> None:
    """The diagnoser's channels in alarm and declarations so far (counts), as ``/diagnosis/alarms`` and
    ``/diagnosis/declarations`` (the declarations themselves are events), when the trace has them."""
    if "diag_alarms" in sink.trace and np.isfinite(sink.col("diag_alarms")).any():
        sink.scalars("/diagnosis/alarms", sink.col("diag_alarms"), _LIMIT, "channels in alarm", 1.5)
        sink.scalars("/diagnosis/declarations", sink.col("diag_count"), _EST, "declarations", 1.5)


def _log_injected(sink: _Sink) -> None:
    """The injected faults' truth columns present in the trace, as ``/injected/<name>``."""
    for k, name in enumerate(c for c in FAULT_TRUTH_COLUMNS if c in sink.trace):
        color = _MODE_COLORS[k % len(_MODE_COLORS)]
        sink.scalars(f"/injected/{name.removeprefix('fault_')}", sink.col(name), color, name, 1.5)


def _log_path_following(sink: _Sink) -> None:
    """The path-following NMPC's series (:data:`PF_SERIES`) at the rows where they are finite (solves)."""
    for name, entity, color, label in PF_SERIES:
        if name in sink.trace:
            rows = np.flatnonzero(np.isfinite(sink.col(name)))
            send_series(sink.rec, entity, sink.idx_rows(rows), sink.col(name)[rows], color, label, 1.5)


def _log_events(sink: _Sink, events: list[Event]) -> None:
    """The events (given and solver failures) in time order as ``/events``."""
    if events:
        events = sorted(events, key=lambda e: e.t)
        send_events(sink.rec, "/events", sink.idx_times(np.array([e.t for e in events], dtype=np.float64)), events)
