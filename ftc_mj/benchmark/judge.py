"""The ``progress`` success rule (``[judge] rule = "progress"``, benchmark ``ftc-v2``): a run succeeds only if the
robot keeps making the progress along the path that the damaged robot can physically make, or — where it cannot
track at all — stops safely.

Every draw is labelled from its truth (:mod:`~ftc_mj.benchmark.attainability`: the drawn plant read from the MJCF,
the drawn faults, the path): ``trackable`` or ``stop-only``.

*Trackable.* From :data:`~ftc_mj.metrics.path.RECOVERED_AFTER_S` (5 s) after the last onset (a fault-free run: from
5 s) to the end, the run completed (status ``ok``), never tipped, stayed within
:data:`~ftc_mj.metrics.outcome.OFF_PATH_M` (0.5 m) of the path, *and* its progress along the path
(:func:`~ftc_mj.metrics.path.path_progress`: the arc length of the truth's projection, unwrapped, continuous
through a figure-eight's crossing) is at least ``progress_fraction`` (0.8) × the attainable speed
(:func:`~ftc_mj.benchmark.attainability.drive_capacity` of the robot after all its faults) × the window's length.

*Stop-only.* The *disabling onset* ``t_d``: the first onset after which the faults so far make the draw stop-only.
Before it — from 5 s to ``t_d``, leaving out 5 s after each earlier onset — the run is within 0.5 m of the path and
progresses (≥ ``progress_fraction`` × the speed attainable before ``t_d`` × that time); after it, never tipped,
within ``corridor`` (2 m) of the path, and at rest (|v| < ``stop_speed``, 0.1 m/s) from ``t_d + stop_within`` (5 s)
to the end. A robot that never starts fails both: it makes no progress.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..config import RunConfig
from ..metrics.outcome import OFF_PATH_M
from ..metrics.path import RECOVERED_AFTER_S, path_progress
from ..metrics.record import RunRecord
from .attainability import STOP_ONLY, Capacity, drive_capacity, drive_robot, drive_state
from .definition import JudgeRule

JUDGE_COLUMNS = ("label", "attainable_speed", "progress", "progress_needed", "disabling_onset")
"""The keys :func:`judge_run` adds to a score row (``None`` under the ``near-path`` rule)."""


def draw_capacity(cfg: RunConfig, record: RunRecord, rule: JudgeRule, until: float = math.inf) -> Capacity:
    """:func:`~ftc_mj.benchmark.attainability.drive_capacity` of ``cfg``'s drawn robot after its faults with onset
    ≤ ``until`` (s), on the reference path of ``record``."""
    return drive_capacity(drive_robot(cfg), drive_state(cfg, until), record.path_curvatures, record.reference_speed,
                          record.plant_half_track, record.context.omega_max, rule.trackable_speed_fraction)


def disabling_onset(cfg: RunConfig, record: RunRecord, rule: JudgeRule, onsets: list[float]) -> float | None:
    """The first of ``onsets`` (s, sorted) after which the faults so far leave the draw stop-only (None: none)."""
    for t0 in onsets:
        if draw_capacity(cfg, record, rule, t0).label == STOP_ONLY:
            return t0
    return None


def _progress_between(s: np.ndarray, t: np.ndarray, t0: float, t1: float) -> float:
    """Progress (m) from ``t0`` to ``t1`` (s), interpolated in the per-row progress ``s`` (m)."""
    return float(np.interp(t1, t, s) - np.interp(t0, t, s))


def judge_trackable(tr: dict[str, np.ndarray], s: np.ndarray, cap: Capacity, last_onset: float, ok: bool,
                    rule: JudgeRule) -> dict[str, Any]:
    """Success of a trackable run (module docstring): ``ok`` (completed, not tipped, within 0.5 m from 5 s after the
    last onset) and progress ≥ the needed progress (m)."""
    t = np.asarray(tr["t"], float)
    t0, t1 = last_onset + RECOVERED_AFTER_S, float(t[-1])
    needed = rule.progress_fraction * cap.speed * max(t1 - t0, 0.0)
    made = _progress_between(s, t, t0, t1) if t1 > t0 else 0.0
    return {"success": bool(ok and made >= needed), "progress": made, "progress_needed": needed}


def judge_stop(tr: dict[str, np.ndarray], s: np.ndarray, before: Capacity, t_d: float, earlier: list[float],
               alive: bool, rule: JudgeRule) -> dict[str, Any]:
    """Success of a stop-only run (module docstring) whose disabling onset is ``t_d`` (s): tracking and progress
    before it (``earlier``: the onsets before it, whose 5 s transients are left out), then a safe stop; ``alive``:
    completed and never tipped."""
    t = np.asarray(tr["t"], float)
    ct, v = np.abs(np.asarray(tr["cross_track_error"], float)), np.abs(np.asarray(tr["v"], float))
    pre = (t >= RECOVERED_AFTER_S) & (t < t_d)
    for e in earlier:
        pre &= ~((t >= e) & (t < e + RECOVERED_AFTER_S))
    t0 = min(RECOVERED_AFTER_S, t_d)
    needed = rule.progress_fraction * before.speed * (t_d - t0)
    made = _progress_between(s, t, t0, t_d)
    tracked = bool(np.all(np.isfinite(ct[pre]) & (ct[pre] <= OFF_PATH_M))) and made >= needed
    post = t >= t_d
    rest = t >= t_d + rule.stop_within
    stopped = bool(rest.any() and np.all(v[rest] < rule.stop_speed))
    inside = bool(np.all(np.isfinite(ct[post]) & (ct[post] <= rule.corridor)))
    return {"success": bool(alive and tracked and stopped and inside), "progress": made, "progress_needed": needed}


def judge_run(cfg: RunConfig, record: RunRecord, tr: dict[str, np.ndarray], onsets: list[float], near_path: bool,
              alive: bool, rule: JudgeRule) -> dict[str, Any]:
    """The score row's ``success`` under the ``progress`` rule and :data:`JUDGE_COLUMNS` (module docstring);
    ``onsets``: the run's fault onsets (s, sorted); ``alive``: completed, never tipped; ``near_path``: ``alive``
    and within 0.5 m from 5 s after the last onset (the ``near-path`` rule's success)."""
    from ..wiring.control import build_reference

    t = np.asarray(tr["t"], float)
    if t.size == 0:
        return {"success": False, **dict.fromkeys(JUDGE_COLUMNS)}
    s = path_progress(build_reference(cfg), t, tr["x"], tr["y"])
    t_d = disabling_onset(cfg, record, rule, onsets)
    if t_d is None:
        cap = draw_capacity(cfg, record, rule, float(t[-1]))  # the faults of the run (a shorter run: fewer)
        out = judge_trackable(tr, s, cap, max(onsets, default=0.0), near_path, rule)
    else:
        earlier = [o for o in onsets if o < t_d]
        cap = draw_capacity(cfg, record, rule, max(earlier)) if earlier else draw_capacity(cfg, record, rule, -1.0)
        out = judge_stop(tr, s, cap, t_d, earlier, alive, rule)
    return {**out, "label": "stop-only" if t_d is not None else "trackable", "attainable_speed": cap.speed,
            "disabling_onset": t_d}
