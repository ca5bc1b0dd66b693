"""Path-following metrics of a run (``metrics.json``), for any controller: contouring error after the
recovery, speed after the fault against the speed the damaged robot can still reach, time at the
lateral-acceleration bound.

The contouring error is the trace's ``cross_track_error`` (signed distance to the geometric path), so
a time-parametrised and a path-following controller are measured alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import RunConfig
from ..model.kinematics import max_path_speed
from ..wiring.control import build_reference

RECOVERED_AFTER_S = 5.0
"""``contouring_*_recovered`` start this long (s) after the *last* fault onset (a fault-free run: after
this long from the start)."""
FINAL_WINDOW_S = 5.0
"""``speed_mean_final`` averages the speed over the last this many seconds (s)."""
BOUND_TOL = 0.01
"""A planned lateral acceleration within this fraction of its bound counts as "at the bound"."""


def feasible_speed(cfg: RunConfig, R_R: float, R_L: float) -> float:
    """The largest speed (m/s) at which the robot with radii ``R_R, R_L`` (m) can follow the whole reference
    path within its wheel-rate limit (:func:`~ftc_mj.model.kinematics.max_path_speed` at the path's curvature,
    sampled every 0.5 m over one period or 400 m), capped at the desired ``reference.speed``."""
    ref = build_reference(cfg)
    length = float(getattr(ref, "length", 400.0))
    k = ref.geometry(np.linspace(0.0, length, int(length / 0.5) + 1)).curvature
    V = max_path_speed(np.unique(k), R_R, R_L, cfg.plant_half_track, cfg.robot.omega_max)
    return float(min(np.min(V), cfg.reference.speed))


def path_following_metrics(cfg: RunConfig, trace: dict[str, np.ndarray],
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
    m["feasible_speed_final"] = feasible_speed(cfg, float(trace["R_R"][-1]), float(trace["R_L"][-1]))
    m["speed_ratio_final"] = m["speed_mean_final"] / m["feasible_speed_final"]
    lat = np.abs(v * trace["yaw_rate"])[after]
    m["lateral_accel_max"] = float(np.nanmax(lat)) if lat.size else float("nan")
    if "pf_lateral_accel" in trace and "pf_lateral_bound" in trace:
        a, bound = np.abs(trace["pf_lateral_accel"]), trace["pf_lateral_bound"]
        ok = np.isfinite(a) & np.isfinite(bound)
        m["lateral_bound_time_s"] = float(np.sum(a[ok] >= (1.0 - BOUND_TOL) * bound[ok]) / cfg.controller.rate)
    else:
        m["lateral_bound_time_s"] = float("nan")
    return m
