"""Run metrics (DESIGN §6 ``metrics.json``) computed from a trace: estimation accuracy and
consistency, fault-decision results, tracking, actuation and solver statistics."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import RunConfig
from ..plant import LIFTOFF, TIPPED
from .path_metrics import path_following_metrics

LIMIT_TOL = 1e-3  # a command within 0.1 % of the bound counts as "at the limit"
RECOVERY_S = 5.0
"""``cross_track_max_recovered`` is the largest |cross-track error| from this long (s) after the first
fault onset to the end (scenario 2: t ≥ 15 s, the paper's "stays on the path" window)."""
FAULT_TRANSIENT_S = 1.0
"""A step puncture makes the tyre skid and hop for about 0.1 s; lift-off within this time (s) after a
fault onset is the fault's, not the controller's (``liftoff_time_post_transient_s`` excludes it)."""


def fault_onsets(cfg: RunConfig) -> dict[str, float | None]:
    """First time (s) each wheel's scheduled radius departs from nominal; None = no fault.

    Before its first breakpoint a schedule is at the nominal radius, so a departure at breakpoint
    ``i`` starts at breakpoint ``i-1`` (the start of a ramp, or the same time for a step).
    """
    R0 = cfg.plant_wheel_radius
    onsets: dict[str, float | None] = {}
    for wheel, bps in (("right", cfg.faults.right), ("left", cfg.faults.left)):
        onsets[wheel] = None
        for i, (t, r) in enumerate(bps):
            if abs(r - R0) > 1e-9:
                onsets[wheel] = bps[i - 1][0] if i > 0 else t
                break
    return onsets


def _nanstat(a: np.ndarray, fn: Any) -> float:
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return float(fn(a)) if a.size else float("nan")


def _rms(a: np.ndarray) -> float:
    return _nanstat(a, lambda v: np.sqrt(np.mean(v**2)))


def _first(mask: np.ndarray, t: np.ndarray) -> float | None:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else None


def compute_metrics(
    cfg: RunConfig,
    trace: dict[str, np.ndarray],
    onsets: dict[str, float | None],
    counters: dict[str, float],
    *,
    settle_time: float = 5.0,
) -> dict[str, Any]:
    """Metrics of one run. ``onsets`` are the true fault onset times per wheel (None = healthy).

    Tracking statistics ``cross_track_*`` are over the whole run; ``*_settled`` ones exclude the
    first ``settle_time`` seconds (initial transients).
    """
    t = trace["t"]
    m: dict[str, Any] = {}
    has_est = cfg.estimator.kind != "none" and np.any(np.isfinite(trace["R_R_hat"]))
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
        m["nis_mean"] = _nanstat(trace["nis"], np.mean)
        sR, sL = trace["R_R_std"], trace["R_L_std"]
        with np.errstate(invalid="ignore", divide="ignore"):
            nees = (eR / sR) ** 2 + (eL / sL) ** 2  # diagonal approximation of the radius NEES (2 dof)
        m["radius_nees_mean"] = _nanstat(nees, np.mean)
        m["position_final_error"] = float(np.hypot(trace["x_hat"][-1] - trace["x"][-1],
                                                   trace["y_hat"][-1] - trace["y"][-1]))
        m["filter_resets"] = int(counters.get("filter_resets", 0))
        m["filter_rejections"] = int(counters.get("filter_rejections", 0))
        # ------------------------------------------------------------ fault decision
        det = np.nan_to_num(trace["fault_detected"]) > 0.5
        t_det = _first(det, t)
        faulty = [w for w, o in onsets.items() if o is not None]
        t_on = min((o for o in onsets.values() if o is not None), default=None)
        m["fault_onset_time"] = t_on
        m["true_fault_wheel"] = ("both" if len(faulty) == 2 else faulty[0]) if faulty else None
        m["detection_time"] = t_det
        if t_on is None:
            m["false_alarm"] = t_det is not None
            m["detection_delay"] = None
            m["missed_detection"] = False
        else:
            m["false_alarm"] = bool(np.any(det & (t < t_on)))
            later = det & (t >= t_on)
            t_det_after = _first(later, t)
            m["detection_delay"] = None if t_det_after is None else t_det_after - t_on
            m["missed_detection"] = t_det_after is None
        # falling edges of the decision flag count separate declarations
        m["declarations"] = int(np.sum(det[1:] & ~det[:-1]) + (1 if det.size and det[0] else 0))
    # ---------------------------------------------------------------- tracking
    ct = trace["cross_track_error"]
    m["cross_track_rms"] = _rms(ct)
    m["cross_track_max"] = _nanstat(np.abs(ct), np.max)
    m["cross_track_final"] = float(ct[-1]) if ct.size else float("nan")
    late = t >= settle_time
    m["cross_track_rms_settled"] = _rms(ct[late])
    m["cross_track_max_settled"] = _nanstat(np.abs(ct[late]), np.max) if late.any() else float("nan")
    t_on_any = min((o for o in onsets.values() if o is not None), default=None)
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
    dt = 1.0 / cfg.estimator.rate
    m["omega_at_limit_s"] = float(np.sum(at_lim) * dt)
    dur = max(float(t[-1] - t[0]), 1e-9) if t.size > 1 else 1.0
    tv = np.nansum(np.abs(np.diff(cmdR))) + np.nansum(np.abs(np.diff(cmdL)))
    m["command_total_variation_per_s"] = float(tv / dur)
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
    for o in onsets.values():
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
        m["reconfig_handed_fraction"] = float(np.mean(st == 2))
    m["max_abs_roll_deg"] = float(np.degrees(_nanstat(np.abs(trace["roll"]), np.max)))
    m["max_abs_slip"] = _nanstat(np.abs(np.concatenate([trace["slip_R"], trace["slip_L"]])), np.max)
    m["sim_time_s"] = float(t[-1] + 1.0 / cfg.estimator.rate) if t.size else 0.0
    m.update(path_following_metrics(cfg, trace, onsets))
    return m
