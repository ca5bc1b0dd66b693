"""Run metrics (``metrics.json``) computed from a trace: estimation accuracy and consistency, tracking,
actuation, solver, plant and reconfiguration statistics; with the fault decision's
(:mod:`.detection`) and the path-following metrics (:mod:`.path`), :func:`compute_metrics` gives a
run's metrics.

A value that does not apply to the run is ``None`` (JSON ``null``; NaN floats are written as
``null`` too), never a fake 0. Times are in s from the start of the run, radii in m.

Estimation (runs with an estimator)
    ``radius_rmse_R/L``, ``radius_final_error_R/L`` (m); ``innovation_in_2sigma`` (fraction of speed
    innovations inside ±2σ); ``position_estimate_final_error`` (m, the filter's position estimate
    against the truth at the end); ``filter_resets``, ``filter_rejections`` (and with a pose sensor
    ``filter_pose_rejections``).
Consistency (:mod:`ftc_mj.estimation.consistency`, Bar-Shalom §5.4), averaged over the run's steps
    ``radius_nees_mean``: mean of ``eᵀ P⁻¹ e`` over the radius error with the full 2×2 radius
    covariance (``R_R_std, R_L_std, R_RL_cov``; 2 dof, expected 2 for a consistent filter).
    ``nees_mean``: the same for the full state ``[x, y, psi, R_R, R_L]`` (heading error wrapped to
    ±π; 5 dof). ``nis_mean``: NIS per measurement dimension, Σ NIS / Σ channels (steps with a
    position fix have 3 or 4 channels, 4 or 5 with its heading, the others 1 or 2; expected 1). Each has a
    ``*_test`` dict:
    ``lo``/``hi`` (two-sided 95 % χ² bounds of the average for ``n_eff`` independent samples),
    ``n_eff`` (= ``samples / tau``), ``samples`` (finite steps), ``tau`` (integrated autocorrelation
    time of the statistic, steps), ``dof``. Successive NEES values are strongly correlated (``tau``
    of tens to hundreds of steps), so one run is few samples; pool runs with
    :func:`~ftc_mj.estimation.consistency.combine`.
Fault decision (:func:`~ftc_mj.metrics.detection.detection_metrics`, runs with an estimator)
    ``onsets`` and the detection and isolation keys; without an estimator only ``onsets``.
Path following (:func:`~ftc_mj.metrics.path.path_following_metrics`, every run)
    ``contouring_rms_recovered``, ``contouring_max_recovered`` (m, from 5 s after the *last* onset of any fault),
    ``speed_mean_after_fault``, ``speed_mean_final``, ``feasible_speed_final``, ``speed_ratio_final``,
    ``lateral_accel_max``, ``lateral_bound_time_s`` (see that module).
Tracking (m, the cross-track error is positive left of the path)
    ``cross_track_rms``, ``cross_track_max`` (of |error|), ``cross_track_final`` over the whole run;
    ``*_settled`` from ``settle_time`` (5 s) on; ``cross_track_rms_after_fault``,
    ``cross_track_max_after_fault`` from the first onset of any fault in the run, ``cross_track_max_recovered``
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
    ``status`` (did the simulation complete), the physical outcome (``outcome``, ``outcome_rule``,
    ``outcome_cross_track_m``, ``wheel_lifted``: :mod:`ftc_mj.metrics.outcome`), ``wall_time_s`` and
    ``realtime_factor``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..estimation.consistency import ChiSquareTest, anees, anis, nees
from ..plant import LIFTOFF, TIPPED
from ..telemetry.columns import COVARIANCE_COLUMNS, STATE
from .detection import detection_metrics, onset_entries
from .path import path_following_metrics
from .record import RunRecord
from .series import first_time, nanstat, rms

LIMIT_TOL = 1e-3
"""A command within this fraction (0.1 %) of its bound counts as "at the limit"."""
RECOVERY_S = 5.0
"""``cross_track_max_recovered`` is the largest |cross-track error| from this long (s) after the first
fault onset to the end (scenario 2: t ≥ 15 s, the paper's "stays on the path" window)."""
FAULT_TRANSIENT_S = 1.0
"""A step puncture makes the tyre skid and hop for about 0.1 s; lift-off within this time (s) after a
fault onset is the fault's, not the controller's (``liftoff_time_post_transient_s`` excludes it)."""


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


def estimation_metrics(trace: dict[str, np.ndarray], counters: dict[str, float]) -> dict[str, Any]:
    """Radius errors (m), speed innovations inside ±2σ, consistency, final position error (m), filter
    resets and rejections of a run with an estimator."""
    m: dict[str, Any] = {}
    eR = trace["R_R_hat"] - trace["R_R"]
    eL = trace["R_L_hat"] - trace["R_L"]
    m["radius_rmse_R"] = rms(eR)
    m["radius_rmse_L"] = rms(eL)
    m["radius_final_error_R"] = float(eR[-1])
    m["radius_final_error_L"] = float(eL[-1])
    inn, sd = trace["innovation"], trace["innovation_std"]
    ok = np.isfinite(inn) & np.isfinite(sd)
    m["innovation_in_2sigma"] = float(np.mean(np.abs(inn[ok]) <= 2.0 * sd[ok])) if ok.any() else float("nan")
    m.update(consistency_metrics(trace))
    m["position_estimate_final_error"] = float(np.hypot(trace["x_hat"][-1] - trace["x"][-1],
                                               trace["y_hat"][-1] - trace["y"][-1]))
    m["filter_resets"] = int(counters.get("filter_resets", 0))
    m["filter_rejections"] = int(counters.get("filter_rejections", 0))
    if "filter_pose_rejections" in counters:  # a run with a pose sensor
        m["filter_pose_rejections"] = int(counters["filter_pose_rejections"])
    return m


def tracking_metrics(t: np.ndarray, ct: np.ndarray, settle_time: float, t_on: float | None) -> dict[str, Any]:
    """Cross-track error ``ct`` (m) statistics: over the run, from ``settle_time`` (s), and with a fault in
    the run (first onset ``t_on``, s) after it and from :data:`RECOVERY_S` after it."""
    m: dict[str, Any] = {}
    m["cross_track_rms"] = rms(ct)
    m["cross_track_max"] = nanstat(np.abs(ct), np.max)
    m["cross_track_final"] = float(ct[-1]) if ct.size else float("nan")
    late = t >= settle_time
    m["cross_track_rms_settled"] = rms(ct[late])
    m["cross_track_max_settled"] = nanstat(np.abs(ct[late]), np.max) if late.any() else float("nan")
    if t_on is not None:
        after = t >= t_on
        m["cross_track_rms_after_fault"] = rms(ct[after])
        m["cross_track_max_after_fault"] = nanstat(np.abs(ct[after]), np.max) if after.any() else float("nan")
        rec = t >= t_on + RECOVERY_S
        m["cross_track_max_recovered"] = nanstat(np.abs(ct[rec]), np.max) if rec.any() else float("nan")
    return m


def actuation_metrics(record: RunRecord, trace: dict[str, np.ndarray], dt: float) -> dict[str, Any]:
    """Time at the wheel-rate limit, the command's total variation (rad/s²), its largest step between
    controller samples (rad/s) and the time in periods that began at the MPC's rate bound (s); ``dt`` is
    the estimator period (s); the limits and the controller rate from the run's ``record``."""
    m: dict[str, Any] = {}
    t = trace["t"]
    wmax = record.context.omega_max
    rate = record.context.controller_rate
    cmdR, cmdL = trace["omega_R_cmd"], trace["omega_L_cmd"]
    at_lim = (np.abs(cmdR) >= wmax * (1 - LIMIT_TOL)) | (np.abs(cmdL) >= wmax * (1 - LIMIT_TOL))
    m["omega_at_limit_fraction"] = float(np.mean(at_lim)) if at_lim.size else float("nan")
    m["omega_at_limit_s"] = float(np.sum(at_lim) * dt)
    dur = max(float(t[-1] - t[0]), 1e-9) if t.size > 1 else 1.0
    tv = np.nansum(np.abs(np.diff(cmdR))) + np.nansum(np.abs(np.diff(cmdL)))
    m["command_total_variation_per_s"] = float(tv / dur)
    # command steps between controller samples (the trace holds each command): largest, and time (s) in
    # controller periods that began with a step at (or, with the first input free, beyond) the MPC's
    # rate bound omega_rate_max / rate (NaN for a controller without one, the open loop)
    steps = np.fmax(np.abs(np.diff(cmdR)), np.abs(np.diff(cmdL)))
    m["command_step_max"] = nanstat(steps, np.max)
    m["command_at_rate_limit_s"] = (float("nan") if record.omega_rate_max is None else
                                    float(np.sum(steps >= record.omega_rate_max / rate * (1 - LIMIT_TOL)) / rate))
    return m


def solver_metrics(trace: dict[str, np.ndarray], counters: dict[str, float], rate: float) -> dict[str, Any]:
    """Solve times (ms: median, p95, max), solves longer than the control period ``1 / rate`` (s),
    the median iterations and the solver failures."""
    m: dict[str, Any] = {}
    st = trace["solve_time_ms"]
    st = st[np.isfinite(st)]
    m["solve_time_ms"] = {
        "median": float(np.median(st)) if st.size else float("nan"),
        "p95": float(np.percentile(st, 95)) if st.size else float("nan"),
        "max": float(np.max(st)) if st.size else float("nan"),
    }
    m["solves_over_period"] = int(np.sum(st > 1e3 / rate))
    m["solver_iterations_median"] = nanstat(trace["solver_iterations"], np.median)
    m["solver_failures"] = int(counters.get("solver_failures", 0))
    return m


def plant_metrics(trace: dict[str, np.ndarray], counters: dict[str, float], onsets_in_run: dict[str, float | None],
                  dt: float) -> dict[str, Any]:
    """Time outside the kinematic model's domain, the flags seen, tipping (and the first time tipped, s) and
    lift-off time (s; also without the :data:`FAULT_TRANSIENT_S` after each onset in the run); ``dt`` is the
    estimator period (s)."""
    m: dict[str, Any] = {}
    t = trace["t"]
    flags = np.nan_to_num(trace["plant_flags"]).astype(np.int64)
    m["plant_out_of_domain_fraction"] = float(np.mean(flags != 0)) if flags.size else 0.0
    m["plant_flags"] = int(counters.get("plant_flags", 0))
    tipped = (flags & TIPPED) != 0
    m["tipped"] = bool(np.any(tipped))
    m["tip_time_s"] = float(t[np.argmax(tipped)]) if m["tipped"] else None
    lift = (flags & LIFTOFF) != 0
    m["liftoff_time_s"] = float(np.sum(lift) * dt)
    transient = np.zeros_like(lift)
    for o in onsets_in_run.values():
        if o is not None:
            transient |= (t >= o) & (t < o + FAULT_TRANSIENT_S)
    m["liftoff_time_post_transient_s"] = float(np.sum(lift & ~transient) * dt)
    return m


def reconfiguration_metrics(trace: dict[str, np.ndarray], t_on: float | None) -> dict[str, Any]:
    """Entries into each policy state, the first hand-over (s) and its delay after the first onset
    ``t_on`` (s), and the fraction of steps handed over (module docstring); empty without the column."""
    m: dict[str, Any] = {}
    t = trace["t"]
    st = np.nan_to_num(trace["reconfig_state"], nan=-1.0).astype(np.int64) if "reconfig_state" in trace else None
    if st is None or not st.size:
        return m
    enter = np.concatenate([[st[0] != 0], st[1:] != st[:-1]])
    m["reconfig_handovers"] = int(np.sum(enter & (st == 2)))
    m["reconfig_holds"] = int(np.sum(enter & (st == 1)))
    m["reconfig_reverts"] = int(np.sum(enter & (st == 3)))
    t_hand = first_time(enter & (st == 2), t)
    m["reconfig_first_handover_time"] = t_hand
    m["reconfig_handover_delay"] = (None if t_hand is None or t_on is None or t_hand < t_on
                                    else t_hand - t_on)
    if bool(np.all(st == 2)) and t_on is not None:
        # radii handed over at every controller sample (direct, truth): the first sample at or after the onset
        sample = np.isfinite(trace["solve_time_ms"]) if "solve_time_ms" in trace else np.ones(st.size, bool)
        t_next = first_time((st == 2) & sample & (t >= t_on - 1e-9), t)
        m["reconfig_handover_delay"] = None if t_next is None else max(t_next - t_on, 0.0)
    m["reconfig_handed_fraction"] = float(np.mean(st == 2))
    return m


def compute_metrics(
    record: RunRecord,
    trace: dict[str, np.ndarray],
    counters: dict[str, float],
    *,
    settle_time: float = 5.0,
    other_onsets: Sequence[float] = (),
) -> dict[str, Any]:
    """Metrics of one run (keys in the module docstring) from its resolved ``record`` (the scheduled fault
    onset times per wheel, s, None = healthy; the rates and limits) and its ``trace``; ``counters`` are the
    loop's counts (filter resets, solver failures, …); ``other_onsets``: the onsets (s) of the run's servo and
    sensor faults.

    Tracking statistics ``cross_track_*`` are over the whole run; ``*_settled`` ones exclude the
    first ``settle_time`` seconds (initial transients). What is measured *after the fault* — the tracking after
    it and its recovery, the lift-off outside each onset's transient, the path-following recovery — counts from
    every fault's onset, tyre, servo or sensor (as the benchmark's scorer does); the fault decision's detection
    and the policy's hand-over delay from the tyres' (the radii are what they watch).
    """
    t = trace["t"]
    m: dict[str, Any] = {}
    onsets = record.onsets
    dt = record.context.estimator_dt
    t_end = float(t[-1] + dt) if t.size else 0.0
    every = {**onsets, **{f"other_{i}": o for i, o in enumerate(other_onsets)}}
    every_in_run = {k: (o if o is not None and t.size and o <= t[-1] else None) for k, o in every.items()}
    t_on_any = min((every_in_run[w] for w in onsets if every_in_run[w] is not None), default=None)  # the tyres'
    t_first = min((o for o in every_in_run.values() if o is not None), default=None)
    if bool(np.any(np.isfinite(trace["R_R_hat"]))):  # a run with a filter (none: NaN estimates)
        m.update(estimation_metrics(trace, counters))
        m.update(detection_metrics(trace, onsets))
        if "radius_anomaly" in trace:
            m["radius_anomaly_s"] = float(np.sum(np.nan_to_num(trace["radius_anomaly"]) > 0.5) * dt)
    else:
        m["onsets"] = onset_entries(t, onsets, None)
    m["exceptions"] = int(counters.get("exceptions", 0))
    m.update(tracking_metrics(t, trace["cross_track_error"], settle_time, t_first))
    m.update(actuation_metrics(record, trace, dt))
    m.update(solver_metrics(trace, counters, record.context.controller_rate))
    m.update(plant_metrics(trace, counters, every_in_run, dt))
    m.update(reconfiguration_metrics(trace, t_on_any))
    m["max_abs_roll_deg"] = float(np.degrees(nanstat(np.abs(trace["roll"]), np.max)))
    m["max_abs_slip"] = nanstat(np.abs(np.concatenate([trace["slip_R"], trace["slip_L"]])), np.max)
    m["sim_time_s"] = t_end
    m.update(path_following_metrics(record, trace, every))
    return m
