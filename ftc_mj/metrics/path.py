"""Path-following metrics of a run (``metrics.json``), for any controller: contouring error after the
recovery, speed after the fault against the speed the damaged robot can still reach, time at the
lateral-acceleration bound.

The contouring error is the trace's ``cross_track_error`` (signed distance to the geometric path), so
a time-parametrised and a path-following controller are measured alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..control.reference import Path, project
from ..model.kinematics import max_path_speed
from .record import RunRecord

RECOVERED_AFTER_S = 5.0
"""``contouring_*_recovered`` start this long (s) after the *last* fault onset (a fault-free run: after
this long from the start)."""
PROGRESS_SAMPLE_S = 0.1
"""Time (s) between the trace rows :func:`path_progress` projects (it interpolates between them)."""
PROGRESS_MARGIN_M = 1.0
"""Least half-width (m) of the arc-length window searched around the previous projection."""
FINAL_WINDOW_S = 5.0
"""``speed_mean_final`` averages the speed over the last this many seconds (s)."""
BOUND_TOL = 0.01
"""A planned lateral acceleration within this fraction of its bound counts as "at the bound"."""


def feasible_speed(record: RunRecord, R_R: float, R_L: float) -> float:
    """The largest speed (m/s) at which the robot with radii ``R_R, R_L`` (m) can follow the whole reference
    path within its wheel-rate limit (:func:`~ftc_mj.model.kinematics.max_path_speed` at the path's curvature,
    the record's ``path_curvatures``), capped at the desired speed of the reference."""
    V = max_path_speed(np.asarray(record.path_curvatures, float), R_R, R_L, record.plant_half_track,
                       record.context.omega_max)
    return float(min(np.min(V), record.reference_speed))


def path_following_metrics(record: RunRecord, trace: dict[str, np.ndarray],
                           onsets: dict[str, float | None]) -> dict[str, Any]:
    """``contouring_rms_recovered``, ``contouring_max_recovered`` (m, from :data:`RECOVERED_AFTER_S` after the
    last onset), ``speed_mean_after_fault`` (m/s, from the first onset; the whole run without a fault),
    ``speed_mean_final`` (m/s, last :data:`FINAL_WINDOW_S`), ``feasible_speed_final`` (m/s, for the final true
    radii) and their ratio ``speed_ratio_final``, ``lateral_accel_max`` (m/s², largest |v yaw_rate| of the robot
    after the first onset), ``lateral_bound_time_s`` (s, controller samples with the planned lateral acceleration
    at its bound times the control period; NaN for a controller without that telemetry)."""
    t = trace["t"]
    m: dict[str, Any] = {}
    if t.size == 0:
        return m
    times = [o for o in onsets.values() if o is not None]
    first, last = (min(times), max(times)) if times else (0.0, 0.0)
    ct = np.abs(trace["cross_track_error"])
    rec = (t >= last + RECOVERED_AFTER_S) & np.isfinite(ct)
    m["contouring_rms_recovered"] = float(np.sqrt(np.mean(ct[rec] ** 2))) if rec.any() else float("nan")
    m["contouring_max_recovered"] = float(ct[rec].max()) if rec.any() else float("nan")
    v, after = trace["v"], t >= first
    m["speed_mean_after_fault"] = float(np.mean(v[after])) if after.any() else float("nan")
    final = t >= t[-1] - FINAL_WINDOW_S
    m["speed_mean_final"] = float(np.mean(v[final]))
    m["feasible_speed_final"] = feasible_speed(record, float(trace["R_R"][-1]), float(trace["R_L"][-1]))
    m["speed_ratio_final"] = m["speed_mean_final"] / m["feasible_speed_final"]
    lat = np.abs(v * trace["yaw_rate"])[after]
    m["lateral_accel_max"] = float(np.nanmax(lat)) if lat.size else float("nan")
    if "pf_lateral_accel" in trace and "pf_lateral_bound" in trace:
        a, bound = np.abs(trace["pf_lateral_accel"]), trace["pf_lateral_bound"]
        ok = np.isfinite(a) & np.isfinite(bound)
        at_bound = np.sum(a[ok] >= (1.0 - BOUND_TOL) * bound[ok])
        m["lateral_bound_time_s"] = float(at_bound / record.context.controller_rate)
    else:
        m["lateral_bound_time_s"] = float("nan")
    return m


def path_progress(path: Path, t: np.ndarray, x: np.ndarray, y: np.ndarray, s0: float = 0.0) -> np.ndarray:
    """Progress along ``path`` (m) per trace row: the arc length of the projection of the true position ``(x, y)``
    (m) at times ``t`` (s), tracked locally from the previous projection — never a global nearest point — so it is
    unwrapped on a closed path (it keeps growing lap after lap) and continuous through a figure-eight's crossing
    (the other branch is a lobe's length away in arc length, far outside the window).

    Every :data:`PROGRESS_SAMPLE_S` a row is projected (:func:`~ftc_mj.control.reference.project`) within
    ``s_prev ± max(2 d, PROGRESS_MARGIN_M)`` of the previous projection ``s_prev`` (``d``: the distance (m) moved
    since, so a robot at 20 m/s stays inside the window); the first row from ``s0`` (the path starts at the
    initial pose); the rows between are interpolated linearly in time."""
    t, x, y = (np.asarray(a, float) for a in (t, x, y))
    if t.size == 0:
        return np.zeros(0)
    keep = [0]
    for k in range(1, t.size):
        if t[k] - t[keep[-1]] >= PROGRESS_SAMPLE_S - 1e-9 or k == t.size - 1:
            keep.append(k)
    s = np.empty(len(keep))
    s[0] = project(path, float(x[0]), float(y[0]), s0, PROGRESS_MARGIN_M, step=0.25)
    for j in range(1, len(keep)):
        a, b = keep[j - 1], keep[j]
        d = float(np.hypot(x[b] - x[a], y[b] - y[a]))
        s[j] = project(path, float(x[b]), float(y[b]), float(s[j - 1]), max(2.0 * d, PROGRESS_MARGIN_M), step=0.25)
    return np.interp(t, t[keep], s)
