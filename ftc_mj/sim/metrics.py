"""Run metrics (``metrics.json``) computed from a trace: estimation accuracy and consistency,
fault-decision results, tracking, actuation and solver statistics.

A value that does not apply to the run is ``None`` (JSON ``null``; NaN floats are written as
``null`` too), never a fake 0. Times are in s from the start of the run, radii in m.

Estimation (runs with an estimator)
    ``radius_rmse_R/L``, ``radius_final_error_R/L`` (m); ``innovation_in_2sigma`` (fraction of speed
    innovations inside ±2σ); ``position_final_error`` (m); ``filter_resets``, ``filter_rejections``.
Consistency (:mod:`ftc_mj.estimation.consistency`, Bar-Shalom §5.4), averaged over the run's steps
    ``radius_nees_mean``: mean of ``eᵀ P⁻¹ e`` over the radius error with the full 2×2 radius
    covariance (``R_R_std, R_L_std, R_RL_cov``; 2 dof, expected 2 for a consistent filter).
    ``nees_mean``: the same for the full state ``[x, y, psi, R_R, R_L]`` (heading error wrapped to
    ±π; 5 dof). ``nis_mean``: NIS per measurement dimension, Σ NIS / Σ channels (steps with a
    position fix have 3 or 4 channels, the others 1 or 2; expected 1). Each has a ``*_test`` dict:
    ``lo``/``hi`` (two-sided 95 % χ² bounds of the average for ``n_eff`` independent samples),
    ``n_eff`` (= ``samples / tau``), ``samples`` (finite steps), ``tau`` (integrated autocorrelation
    time of the statistic, steps), ``dof``. Successive NEES values are strongly correlated (``tau``
    of tens to hundreds of steps), so one run is few samples; pool runs with
    :func:`~ftc_mj.estimation.consistency.combine`.
Fault decision (runs with an estimator; the trace's ``fault_detected`` and ``declared_wheel``)
    A wheel is faulty from its scheduled onset (:func:`fault_onsets`) on. An onset after the run's
    last step is *after the end*: listed in ``onsets`` with ``status = "after end"`` and neither
    detected nor missed (it counts for no other key either). Onsets at the same time form one
    onset (wheel ``both``).
    ``onsets``: one dict per onset, in time order, with ``wheel``, ``time``, ``status`` (``in run`` /
    ``after end``) and, for onsets in the run, over its *window* (from the onset to the next onset or
    the end of the run):

    - ``detection_time``: the first *declaration event* in the window — a declaration starts, or
      the declared wheel changes (e.g. ``left`` → ``both`` when the second wheel fails). A
      declaration already active at the onset and unchanged is no detection (it is a false alarm,
      or the previous fault's); ``detection_delay`` = ``detection_time - time``;
      ``missed_detection``: no declaration event in the window;
    - ``isolation_time``: the first step of the window at which the declared wheel *becomes* the
      true faulty set (``left``, ``both``, …; ``unknown`` never is); ``time_to_correct_isolation``
      = it minus ``time`` (None if that never happens in the window);
    - ``false_isolations``: declaration events in the window whose declared wheel names a wheel
      that is not faulty (``right`` or ``both`` while only the left is);
    - ``declared_at_onset``: the declared wheel at the onset step (None if nothing).

    Top level: ``fault_onset_time``, ``detection_time``, ``detection_delay``, ``missed_detection``,
    ``time_to_correct_isolation`` are those of the first onset in the run (None without one);
    ``missed_detections``: onsets in the run that were missed; ``false_alarms``: declarations that
    began before the first onset in the run (all of them in a run without a fault; one still
    active at the onset included); ``false_alarm`` = ``false_alarms > 0``; ``false_isolations``: of
    all onsets; ``isolation_correct_fraction``: fraction of the steps from the first onset on at
    which the declared wheel equals the true faulty set; ``isolated_wheel``: declared wheel at the
    end (None if nothing declared); ``true_fault_wheel``: faulty set at the end (None without a
    fault in the run); ``isolation_correct``: ``isolated_wheel == true_fault_wheel`` (None without
    a fault); ``first_declaration_time`` (any declaration, None if none); ``declarations`` (count
    of declarations); ``radius_anomaly_s``: time a radius estimate spent above nominal beyond the
    decision's thresholds (not a puncture, never declared).
    ``severity_R/L`` (fractional radius loss 0..1 of the last decision) are added by
    :func:`~ftc_mj.sim.run.run_metrics`. Without an estimator only ``onsets`` (no detection keys).
Path following (:func:`~ftc_mj.sim.path_metrics.path_following_metrics`, every run)
    ``contouring_rms_recovered``, ``contouring_max_recovered`` (m, from 5 s after the *last* onset),
    ``speed_mean_after_fault``, ``speed_mean_final``, ``feasible_speed_final``, ``speed_ratio_final``,
    ``lateral_accel_max``, ``lateral_bound_time_s`` (see that module).
Tracking (m, the cross-track error is positive left of the path)
    ``cross_track_rms``, ``cross_track_max`` (of |error|), ``cross_track_final`` over the whole run;
    ``*_settled`` from ``settle_time`` (5 s) on; ``cross_track_rms_after_fault``,
    ``cross_track_max_after_fault`` from the first onset in the run, ``cross_track_max_recovered``
    from :data:`RECOVERY_S` after it (NaN if the run ends before; all three absent without a fault).
Actuation
    ``omega_at_limit_fraction`` (fraction of steps with a wheel-rate command within
    :data:`LIMIT_TOL` of ``omega_max``) and ``omega_at_limit_s`` (s); ``command_total_variation_per_s``
    (Σ |Δ command| of both wheels per second of run, rad/s²: the chatter metric);
    ``command_step_max`` (rad/s, the largest change of either wheel's command between consecutive
    controller samples; the MPCs bound it by ``omega_rate_max / rate`` when
    ``controller.rate_bound_from_applied``) and ``command_at_rate_limit_s`` (s, controller periods that
    began with a step within :data:`LIMIT_TOL` of that bound or beyond it).
Solver
    ``solve_time_ms`` {``median``, ``p95``, ``max``} (wall clock, ms; NaN without solves);
    ``solves_over_period`` (solves longer than the control period); ``solver_iterations_median``;
    ``solver_failures``: solver fallbacks (failed, over-budget or erroring solves, non-finite
    inputs), which do not end a run.
Plant (the MuJoCo plant's flags of leaving the kinematic model's domain)
    ``plant_out_of_domain_fraction`` (fraction of steps with a flag), ``plant_flags`` (bit set of
    all flags seen), ``tipped``, ``liftoff_time_s`` (s with a wheel off the ground),
    ``liftoff_time_post_transient_s`` (the same without the :data:`FAULT_TRANSIENT_S` after each
    onset), ``max_abs_roll_deg`` (°), ``max_abs_slip`` (largest |longitudinal slip speed| of a tyre, m/s).
Reconfiguration (trace ``reconfig_state``)
    ``reconfig_handovers``, ``reconfig_holds``, ``reconfig_reverts`` (entries into each state),
    ``reconfig_first_handover_time`` (s, None if none), ``reconfig_handover_delay`` (from the first
    onset, s; None without a fault, a hand-over, or for a hand-over before the fault; for ``direct`` and
    ``truth``, which hand radii over at every controller sample: to the first sample at or after it),
    ``reconfig_handed_fraction`` (fraction of steps handed over).
Failures
    ``exceptions``: exceptions of a component that ended the run (0 or 1; the run's ``status`` is
    then ``failed`` and ``error``/``error_where`` say what and where, added by
    :func:`~ftc_mj.sim.run.run_metrics`) — counted apart from ``solver_failures``.
Run
    ``sim_time_s`` (simulated time, s); :func:`~ftc_mj.sim.run.run_metrics` adds the run's identity
    (``run_id``, ``scenario``, ``estimator``, ``controller``, ``policy``, ``sensing``, ``seed``, …),
    ``status``, ``wall_time_s`` and ``realtime_factor``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import RunConfig
from ..estimation.consistency import ChiSquareTest, anees, anis, nees
from ..plant import LIFTOFF, TIPPED
from ..plant.faults import schedule_onset
from .columns import COVARIANCE_COLUMNS, STATE, WHEEL_CODES
from .path_metrics import path_following_metrics

LIMIT_TOL = 1e-3  # a command within 0.1 % of the bound counts as "at the limit"
RECOVERY_S = 5.0
"""``cross_track_max_recovered`` is the largest |cross-track error| from this long (s) after the first
fault onset to the end (scenario 2: t ≥ 15 s, the paper's "stays on the path" window)."""
FAULT_TRANSIENT_S = 1.0
"""A step puncture makes the tyre skid and hop for about 0.1 s; lift-off within this time (s) after a
fault onset is the fault's, not the controller's (``liftoff_time_post_transient_s`` excludes it)."""
WHEEL_OF_CODE = {code: wheel for wheel, code in WHEEL_CODES.items()}


def fault_onsets(cfg: RunConfig) -> dict[str, float | None]:
    """First time (s) each wheel's scheduled radius departs from nominal (:func:`schedule_onset`);
    None = no fault."""
    R0 = cfg.plant_wheel_radius
    return {"right": schedule_onset(cfg.faults.right, R0), "left": schedule_onset(cfg.faults.left, R0)}


def _nanstat(a: np.ndarray, fn: Any) -> float:
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return float(fn(a)) if a.size else float("nan")


def _rms(a: np.ndarray) -> float:
    return _nanstat(a, lambda v: np.sqrt(np.mean(v**2)))


def _first(mask: np.ndarray, t: np.ndarray) -> float | None:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else None


def _starts(mask: np.ndarray) -> np.ndarray:
    """Steps where ``mask`` becomes true (true at step 0 counts as a start)."""
    return mask & ~np.concatenate([[False], mask[:-1]])


# ---------------------------------------------------------------------------- consistency
def state_errors(trace: dict[str, np.ndarray]) -> np.ndarray:
    """Estimate minus truth (n, 5) over ``[x, y, psi, R_R, R_L]`` (m, m, rad, m, m), heading wrapped to ±π."""
    e = np.stack([trace[f"{s}_hat"] - trace[s] for s in STATE], axis=1)
    e[:, 2] = (e[:, 2] + np.pi) % (2.0 * np.pi) - np.pi
    return e


def state_covariance(trace: dict[str, np.ndarray]) -> np.ndarray:
    """The filter's 5×5 covariance per row (n, 5, 5) rebuilt from the ``*_std`` and covariance columns
    (NaN where a column is missing)."""
    n = len(trace["t"])
    P = np.full((n, 5, 5), np.nan)
    for i, s in enumerate(STATE):
        if f"{s}_std" in trace:
            P[:, i, i] = np.asarray(trace[f"{s}_std"], float) ** 2
    for (i, j), name in COVARIANCE_COLUMNS.items():
        if name in trace:
            P[:, i, j] = P[:, j, i] = np.asarray(trace[name], float)
    return P


def _test_metrics(name: str, test: ChiSquareTest) -> dict[str, Any]:
    return {f"{name}_mean": test.value, f"{name}_test": test.as_dict()}


def consistency_metrics(trace: dict[str, np.ndarray]) -> dict[str, Any]:
    """``radius_nees_mean``, ``nees_mean``, ``nis_mean`` and their ``*_test`` dicts (module docstring)."""
    e = state_errors(trace)
    P = state_covariance(trace)
    m: dict[str, Any] = {}
    m.update(_test_metrics("radius_nees", anees(nees(e[:, 3:], P[:, 3:, 3:]), 2)))
    m.update(_test_metrics("nees", anees(nees(e, P), 5)))
    dims = trace["nis_dof"] if "nis_dof" in trace else np.isfinite(trace["nis"]).astype(float)
    m.update(_test_metrics("nis", anis(trace["nis"], dims)))
    return m


# ---------------------------------------------------------------------------- fault decision
def declared_wheel_codes(trace: dict[str, np.ndarray]) -> np.ndarray:
    """Per step, the declared wheel's :data:`~ftc_mj.sim.columns.WHEEL_CODES` code (0 = nothing declared);
    a declaration without a ``declared_wheel`` code (or column) is of ``unknown`` wheel."""
    det = np.nan_to_num(trace["fault_detected"]) > 0.5
    code = np.nan_to_num(trace["declared_wheel"]).astype(np.int64) if "declared_wheel" in trace else 0
    return np.where(det, np.where(code > 0, code, WHEEL_CODES["unknown"]), 0)


def _isolation(code: np.ndarray, faulty: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per step: the declared wheel equals the faulty set (correct), and it names a healthy wheel (wrong)."""
    dR, dL = np.isin(code, (1, 3)), np.isin(code, (2, 3))
    named = (code > 0) & (code != WHEEL_CODES["unknown"])
    return named & (dR == faulty[0]) & (dL == faulty[1]), (dR & ~faulty[0]) | (dL & ~faulty[1])


def _label(right: bool, left: bool) -> str | None:
    return "both" if right and left else "right" if right else "left" if left else None


def onset_groups(onsets: dict[str, float | None]) -> list[tuple[float, tuple[bool, bool]]]:
    """Distinct onset times in order, each with the (right, left) wheels whose fault starts then."""
    times = sorted({o for o in onsets.values() if o is not None})
    return [(o, (onsets["right"] == o, onsets["left"] == o)) for o in times]


def onset_metrics(t: np.ndarray, code: np.ndarray, faulty: tuple[np.ndarray, np.ndarray],
                  window: np.ndarray) -> dict[str, Any]:
    """Detection and isolation of one onset (module docstring) over the steps in ``window``.

    ``code``: declared wheel per step; ``faulty``: per step, whether the right / left wheel is faulty;
    ``window``: steps from the onset to the next onset or the end.
    """
    correct, wrong = _isolation(code, faulty)
    # declaration events: a declaration starts, or the declared wheel changes
    event = (code > 0) & (code != np.concatenate([[0], code[:-1]]))
    k0 = int(np.flatnonzero(window)[0])
    t_det = _first(event & window, t)
    t_iso = _first(_starts(correct) & window, t)
    return {
        "detection_time": t_det,
        "detection_delay": None if t_det is None else t_det - float(t[k0]),
        "missed_detection": t_det is None,
        "isolation_time": t_iso,
        "time_to_correct_isolation": None if t_iso is None else t_iso - float(t[k0]),
        "false_isolations": int(np.sum(event & wrong & window)),
        "declared_at_onset": WHEEL_OF_CODE.get(int(code[k0])),
    }


def onset_entries(t: np.ndarray, onsets: dict[str, float | None], code: np.ndarray | None) -> list[dict[str, Any]]:
    """The ``onsets`` list: wheel, time and status of each onset, with :func:`onset_metrics` for those
    in the run when the declared-wheel codes are given."""
    groups = onset_groups(onsets)
    faulty = tuple(t >= (onsets[w] if onsets[w] is not None else np.inf) for w in ("right", "left"))
    entries: list[dict[str, Any]] = []
    for i, (o, ws) in enumerate(groups):
        in_run = bool(t.size) and o <= float(t[-1])
        entry: dict[str, Any] = {"wheel": _label(*ws), "time": o, "status": "in run" if in_run else "after end"}
        if in_run and code is not None:
            nxt = groups[i + 1][0] if i + 1 < len(groups) else np.inf
            entry.update(onset_metrics(t, code, faulty, (t >= o) & (t < nxt)))
        entries.append(entry)
    return entries


def fdi_metrics(trace: dict[str, np.ndarray], onsets: dict[str, float | None]) -> dict[str, Any]:
    """Fault-decision metrics of a run (keys in the module docstring)."""
    t = trace["t"]
    code = declared_wheel_codes(trace)
    entries = onset_entries(t, onsets, code)
    in_run = [e for e in entries if e["status"] == "in run"]
    first = in_run[0] if in_run else {}
    t0 = first.get("time", np.inf)
    faulty = (t >= (onsets["right"] if onsets["right"] is not None else np.inf),
              t >= (onsets["left"] if onsets["left"] is not None else np.inf))
    correct, _ = _isolation(code, faulty)
    false_alarms = int(np.sum(_starts(code > 0) & (t < t0)))
    true_end = _label(bool(faulty[0][-1]), bool(faulty[1][-1])) if in_run else None
    iso_end = WHEEL_OF_CODE.get(int(code[-1])) if code.size else None
    return {
        "onsets": entries,
        "fault_onset_time": first.get("time"),
        "true_fault_wheel": true_end,
        "detection_time": first.get("detection_time"),
        "detection_delay": first.get("detection_delay"),
        "missed_detection": first.get("missed_detection"),
        "time_to_correct_isolation": first.get("time_to_correct_isolation"),
        "missed_detections": sum(e["missed_detection"] for e in in_run) if in_run else None,
        "false_alarms": false_alarms,
        "false_alarm": false_alarms > 0,
        "false_isolations": sum(e["false_isolations"] for e in in_run) if in_run else None,
        "isolation_correct_fraction": float(np.mean(correct[t >= t0])) if in_run else None,
        "isolated_wheel": iso_end,
        "isolation_correct": (iso_end == true_end) if in_run else None,
        "first_declaration_time": _first(code > 0, t),
        "declarations": int(np.sum(_starts(code > 0))),
    }


def compute_metrics(
    cfg: RunConfig,
    trace: dict[str, np.ndarray],
    onsets: dict[str, float | None],
    counters: dict[str, float],
    *,
    settle_time: float = 5.0,
) -> dict[str, Any]:
    """Metrics of one run. ``onsets`` are the scheduled fault onset times per wheel (None = healthy).

    Tracking statistics ``cross_track_*`` are over the whole run; ``*_settled`` ones exclude the
    first ``settle_time`` seconds (initial transients).
    """
    t = trace["t"]
    m: dict[str, Any] = {}
    dt = 1.0 / cfg.estimator.rate
    t_end = float(t[-1] + dt) if t.size else 0.0
    onsets_in_run = {w: (o if o is not None and t.size and o <= t[-1] else None) for w, o in onsets.items()}
    has_est = bool(np.any(np.isfinite(trace["R_R_hat"])))  # a run with a filter (none: NaN estimates)
    # ---------------------------------------------------------------- estimation
    if has_est:
        eR = trace["R_R_hat"] - trace["R_R"]
        eL = trace["R_L_hat"] - trace["R_L"]
        m["radius_rmse_R"] = _rms(eR)
        m["radius_rmse_L"] = _rms(eL)
        m["radius_final_error_R"] = float(eR[-1])
        m["radius_final_error_L"] = float(eL[-1])
        inn, sd = trace["innovation"], trace["innovation_std"]
        ok = np.isfinite(inn) & np.isfinite(sd)
        m["innovation_in_2sigma"] = float(np.mean(np.abs(inn[ok]) <= 2.0 * sd[ok])) if ok.any() else float("nan")
        m.update(consistency_metrics(trace))
        m["position_final_error"] = float(np.hypot(trace["x_hat"][-1] - trace["x"][-1],
                                                   trace["y_hat"][-1] - trace["y"][-1]))
        m["filter_resets"] = int(counters.get("filter_resets", 0))
        m["filter_rejections"] = int(counters.get("filter_rejections", 0))
        # ------------------------------------------------------------ fault decision
        m.update(fdi_metrics(trace, onsets))
        if "radius_anomaly" in trace:
            m["radius_anomaly_s"] = float(np.sum(np.nan_to_num(trace["radius_anomaly"]) > 0.5) * dt)
    else:
        m["onsets"] = onset_entries(t, onsets, None)
    m["exceptions"] = int(counters.get("exceptions", 0))
    # ---------------------------------------------------------------- tracking
    ct = trace["cross_track_error"]
    m["cross_track_rms"] = _rms(ct)
    m["cross_track_max"] = _nanstat(np.abs(ct), np.max)
    m["cross_track_final"] = float(ct[-1]) if ct.size else float("nan")
    late = t >= settle_time
    m["cross_track_rms_settled"] = _rms(ct[late])
    m["cross_track_max_settled"] = _nanstat(np.abs(ct[late]), np.max) if late.any() else float("nan")
    t_on_any = min((o for o in onsets_in_run.values() if o is not None), default=None)
    if t_on_any is not None:
        after = t >= t_on_any
        m["cross_track_rms_after_fault"] = _rms(ct[after])
        m["cross_track_max_after_fault"] = _nanstat(np.abs(ct[after]), np.max) if after.any() else float("nan")
        rec = t >= t_on_any + RECOVERY_S
        m["cross_track_max_recovered"] = _nanstat(np.abs(ct[rec]), np.max) if rec.any() else float("nan")
    # ---------------------------------------------------------------- actuation
    wmax = cfg.robot.omega_max
    cmdR, cmdL = trace["omega_R_cmd"], trace["omega_L_cmd"]
    at_lim = (np.abs(cmdR) >= wmax * (1 - LIMIT_TOL)) | (np.abs(cmdL) >= wmax * (1 - LIMIT_TOL))
    m["omega_at_limit_fraction"] = float(np.mean(at_lim)) if at_lim.size else float("nan")
    m["omega_at_limit_s"] = float(np.sum(at_lim) * dt)
    dur = max(float(t[-1] - t[0]), 1e-9) if t.size > 1 else 1.0
    tv = np.nansum(np.abs(np.diff(cmdR))) + np.nansum(np.abs(np.diff(cmdL)))
    m["command_total_variation_per_s"] = float(tv / dur)
    # command steps between controller samples (the trace holds each command): largest, and time (s) in
    # controller periods that began with a step at (or, with the first input free, beyond) the MPC's
    # rate bound omega_rate_max / rate
    steps = np.fmax(np.abs(np.diff(cmdR)), np.abs(np.diff(cmdL)))
    step_lim = cfg.controller.omega_rate_max / cfg.controller.rate
    m["command_step_max"] = _nanstat(steps, np.max)
    m["command_at_rate_limit_s"] = float(np.sum(steps >= step_lim * (1 - LIMIT_TOL)) / cfg.controller.rate)
    # ---------------------------------------------------------------- solver
    st = trace["solve_time_ms"]
    st = st[np.isfinite(st)]
    m["solve_time_ms"] = {
        "median": float(np.median(st)) if st.size else float("nan"),
        "p95": float(np.percentile(st, 95)) if st.size else float("nan"),
        "max": float(np.max(st)) if st.size else float("nan"),
    }
    m["solves_over_period"] = int(np.sum(st > 1e3 / cfg.controller.rate))
    it = trace["solver_iterations"]
    m["solver_iterations_median"] = _nanstat(it, np.median)
    m["solver_failures"] = int(counters.get("solver_failures", 0))
    # ---------------------------------------------------------------- plant domain
    flags = np.nan_to_num(trace["plant_flags"]).astype(np.int64)
    m["plant_out_of_domain_fraction"] = float(np.mean(flags != 0)) if flags.size else 0.0
    m["plant_flags"] = int(counters.get("plant_flags", 0))
    m["tipped"] = bool(np.any(flags & TIPPED))
    lift = (flags & LIFTOFF) != 0
    m["liftoff_time_s"] = float(np.sum(lift) * dt)
    transient = np.zeros_like(lift)
    for o in onsets_in_run.values():
        if o is not None:
            transient |= (t >= o) & (t < o + FAULT_TRANSIENT_S)
    m["liftoff_time_post_transient_s"] = float(np.sum(lift & ~transient) * dt)
    # ---------------------------------------------------------------- reconfiguration
    st = np.nan_to_num(trace["reconfig_state"], nan=-1.0).astype(np.int64) if "reconfig_state" in trace else None
    if st is not None and st.size:
        enter = np.concatenate([[st[0] != 0], st[1:] != st[:-1]])
        m["reconfig_handovers"] = int(np.sum(enter & (st == 2)))
        m["reconfig_holds"] = int(np.sum(enter & (st == 1)))
        m["reconfig_reverts"] = int(np.sum(enter & (st == 3)))
        t_hand = _first(enter & (st == 2), t)
        m["reconfig_first_handover_time"] = t_hand
        m["reconfig_handover_delay"] = (None if t_hand is None or t_on_any is None or t_hand < t_on_any
                                        else t_hand - t_on_any)
        if bool(np.all(st == 2)) and t_on_any is not None:
            # radii handed over at every controller sample (direct, truth): the first sample at or after the onset
            sample = np.isfinite(trace["solve_time_ms"]) if "solve_time_ms" in trace else np.ones(st.size, bool)
            t_next = _first((st == 2) & sample & (t >= t_on_any - 1e-9), t)
            m["reconfig_handover_delay"] = None if t_next is None else max(t_next - t_on_any, 0.0)
        m["reconfig_handed_fraction"] = float(np.mean(st == 2))
    m["max_abs_roll_deg"] = float(np.degrees(_nanstat(np.abs(trace["roll"]), np.max)))
    m["max_abs_slip"] = _nanstat(np.abs(np.concatenate([trace["slip_R"], trace["slip_L"]])), np.max)
    m["sim_time_s"] = t_end
    m.update(path_following_metrics(cfg, trace, onsets))
    return m
