"""Report-level metrics derived from a run's trace, beyond ``metrics.json``: the quantities the
paper's claims talk about (settling of the radius estimate after a fault, innovation peaks at the
fault, time until the robot leaves the path, IMM mode identification, command switching).

All functions take a trace as a mapping of numpy columns (the in-memory trace or a
``trace.parquet`` read back) and return plain floats (``None`` = not applicable / never).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..estimation.imm import IMMSettings
from ..plant.faults import schedule_onset

if TYPE_CHECKING:
    from ..config import RunConfig

SETTLE_TOL = 0.1
"""A radius estimate has settled when its error stays within this (m) ..."""
SETTLE_HOLD = 1.0
"""... for at least this long (s)."""
OFF_PATH = 2.0
"""The robot is off the path when |cross-track error| exceeds this (m) (= the track width 2b)."""
EARLY_WINDOW = 5.0
"""Window (s) after a fault onset for the 'early' radius RMSE (speed of reaching the estimate)."""
PEAK_WINDOW = 1.0
"""Window (s) after an onset searched for the innovation peak."""
PEAK_AVG = 10
"""Innovations are averaged over this many samples (0.1 s at 100 Hz) before the peak search."""
MODE_HOLD = 0.5
"""An IMM has identified a mode when it is the most probable one for at least this long (s)."""
SWITCH_MIN = 1.0
"""A command reversal counts only if the step is larger than this (rad/s)."""
LIMIT_TOL = 1e-3

#: Expected IMM mode (1-based) after each switch time, per scenario and bank size. Mode numbers
#: follow the paper: 1 no fault, 2 right 50 %, 3 left 50 %, 4 both 50 %, 5 linear left puncture.
EXPECTED_MODES: dict[tuple[str, int], list[tuple[float, int]]] = {
    ("scenario1", 4): [(0.0, 1)],
    ("scenario2", 4): [(0.0, 1), (10.0, 3)],
    ("scenario3", 4): [(0.0, 1), (5.0, 3), (10.0, 4)],
    ("scenario1", 5): [(0.0, 1)],
    ("scenario2", 5): [(0.0, 1), (10.0, 3)],
    ("scenario3", 5): [(0.0, 1), (5.0, 3), (10.0, 4)],
    ("scenario4", 5): [(0.0, 1), (10.0, 5)],
}


def _col(trace: Mapping[str, Any], name: str) -> np.ndarray | None:
    if name not in trace:
        return None
    return np.asarray(trace[name], dtype=float)


def _rms(a: np.ndarray) -> float | None:
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a**2))) if a.size else None


def settle_delay(t: np.ndarray, err: np.ndarray, t_on: float, tol: float = SETTLE_TOL,
                 hold: float = SETTLE_HOLD) -> float | None:
    """Delay after ``t_on`` until ``|err| <= tol`` holds for ``hold`` seconds (or to the end of the run,
    if that is at least half of ``hold``); ``None`` if it never settles."""
    after = t >= t_on
    if not after.any():
        return None
    ta, ea = t[after], np.abs(err[after])
    ok = np.isfinite(ea) & (ea <= tol)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.01
    need = max(1, int(round(hold / dt)))
    run = 0
    for i in range(ok.size):
        run = run + 1 if ok[i] else 0
        if run >= need:
            return float(ta[i - need + 1] - t_on)
    if run >= max(1, need // 2):  # settled in the last moments of the run
        return float(ta[ok.size - run] - t_on)
    return None


def innovation_peak_z(t: np.ndarray, inn: np.ndarray, std: np.ndarray, t_on: float,
                      window: float = PEAK_WINDOW, avg: int = PEAK_AVG) -> float | None:
    """Peak of the ``avg``-sample mean innovation in ``[t_on, t_on + window]``, in units of the standard
    deviation of such a mean before the fault (``median(std) / sqrt(avg)``). About 3 for noise alone;
    a fault visible in the innovations gives much more."""
    ok = np.isfinite(inn)
    if ok.sum() < avg:
        return None
    inn0 = np.where(ok, inn, 0.0)
    kernel = np.ones(avg) / avg
    mean = np.convolve(inn0, kernel, mode="full")[: inn.size]  # trailing mean ending at each sample
    before = (t < t_on) & np.isfinite(std)
    sd = float(np.median(std[before])) if before.any() else float(np.nanmedian(std))
    if not np.isfinite(sd) or sd <= 0:
        return None
    win = (t >= t_on) & (t <= t_on + window)
    if not win.any():
        return None
    return float(np.max(np.abs(mean[win])) / (sd / np.sqrt(avg)))


def first_time(t: np.ndarray, mask: np.ndarray) -> float | None:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else None


def mode_delays(t: np.ndarray, probs: np.ndarray, schedule: list[tuple[float, int]],
                hold: float = MODE_HOLD) -> tuple[list[float | None], float | None]:
    """For each (switch time, expected mode): delay until that mode is the most probable for ``hold``
    seconds (before the next switch); and the overall fraction of samples with the expected mode
    on top. ``probs`` is (n, M)."""
    if probs.size == 0 or not np.isfinite(probs).any():
        return [None] * len(schedule), None
    top = np.argmax(np.nan_to_num(probs, nan=-1.0), axis=1) + 1
    expected = np.zeros(t.size, dtype=int)
    for ts, mode in schedule:
        expected[t >= ts] = mode
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.01
    need = max(1, int(round(hold / dt)))
    delays: list[float | None] = []
    for i, (ts, mode) in enumerate(schedule):
        t_end = schedule[i + 1][0] if i + 1 < len(schedule) else np.inf
        seg = (t >= ts) & (t < t_end)
        ok = top[seg] == mode
        ts_seg = t[seg]
        run, found = 0, None
        for j in range(ok.size):
            run = run + 1 if ok[j] else 0
            if run >= min(need, ok.size):
                found = float(ts_seg[j - run + 1] - ts)
                break
        delays.append(found)
    return delays, float(np.mean(top == expected))


def command_switching(t: np.ndarray, cmd: np.ndarray, omega_max: float) -> tuple[float, float]:
    """(reversals per second, limit-to-limit switches per second) of one wheel's command, counted
    on the command's changes (held values are skipped)."""
    c = cmd[np.isfinite(cmd)]
    dur = max(float(t[-1] - t[0]), 1e-9) if t.size > 1 else 1.0
    if c.size < 3:
        return 0.0, 0.0
    d = np.diff(c)
    d = d[np.abs(d) > SWITCH_MIN]
    rev = int(np.sum(np.sign(d[1:]) != np.sign(d[:-1]))) if d.size > 1 else 0
    lim = np.where(c >= omega_max * (1 - LIMIT_TOL), 1, np.where(c <= -omega_max * (1 - LIMIT_TOL), -1, 0))
    lim = lim[lim != 0]
    sw = int(np.sum(lim[1:] != lim[:-1])) if lim.size > 1 else 0
    return rev / dur, sw / dur


def derived_metrics(trace: Mapping[str, Any], scenario: str, onsets: Mapping[str, float | None],
                    n_modes: int = 0, omega_max: float = np.radians(1000.0)) -> dict[str, Any]:
    """The report's extra metrics for one run (see the module docstring for the definitions):
    ``onsets`` are the fault onsets (s) by wheel, ``omega_max`` the wheel-rate limit (rad/s)."""
    t = _col(trace, "t")
    m: dict[str, Any] = {}
    if t is None or t.size == 0:
        return m
    on_R, on_L = onsets.get("right"), onsets.get("left")
    ons = sorted({o for o in (on_R, on_L) if o is not None})
    m["onsets_after_end"] = sum(1 for o in ons if o > float(t[-1]))  # as the run metrics' "after end"
    ons = [o for o in ons if o <= float(t[-1])]
    m["onsets_in_run"] = len(ons)
    t_on = ons[0] if ons else None
    _radius_metrics(m, trace, t, on_R, on_L, ons, t_on)
    _plant_response(m, trace, t, ons)
    _domain_metrics(m, trace, t, t_on)
    if n_modes:
        _mode_metrics(m, trace, t, scenario, n_modes)
    _tracking_metrics(m, trace, t, t_on)
    _command_metrics(m, trace, t, t_on, omega_max)
    return m


def _radius_metrics(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, on_R: float | None,
                    on_L: float | None, ons: list[float], t_on: float | None) -> None:
    """Radius-estimate settling (s) and RMSEs (m), innovation consistency and peaks (z) into ``m``."""
    RRh, RLh, RR, RL = (_col(trace, c) for c in ("R_R_hat", "R_L_hat", "R_R", "R_L"))
    have_est = RRh is not None and RLh is not None and np.isfinite(RRh).any()
    RRh, RLh, RR, RL = (_col(trace, c) for c in ("R_R_hat", "R_L_hat", "R_R", "R_L"))
    have_est = RRh is not None and RLh is not None and np.isfinite(RRh).any()
    if have_est and RR is not None and RL is not None:
        eR, eL = RRh - RR, RLh - RL
        for wheel, e, on in (("R", eR, on_R), ("L", eL, on_L)):
            m[f"settle_delay_{wheel}"] = settle_delay(t, e, on) if on is not None else None
            if t_on is not None:
                m[f"radius_rmse_{wheel}_after_fault"] = _rms(e[t >= t_on])
                m[f"radius_rmse_{wheel}_early"] = _rms(e[(t >= t_on) & (t <= t_on + EARLY_WINDOW)])
            else:
                m[f"settle_delay_{wheel}"] = settle_delay(t, e, 0.0)
        m["radius_rmse_mean"] = _rms(np.concatenate([eR, eL]))
        inn, sd = _col(trace, "innovation"), _col(trace, "innovation_std")
        if inn is not None and sd is not None:
            ok = np.isfinite(inn) & np.isfinite(sd)
            inside = np.abs(inn) <= 2.0 * sd
            if t_on is not None:
                aft, bef = ok & (t >= t_on), ok & (t < t_on)
                m["innovation_in_2sigma_after_fault"] = float(np.mean(inside[aft])) if aft.any() else None
                m["innovation_in_2sigma_before_fault"] = float(np.mean(inside[bef])) if bef.any() else None
                m["innovation_std_median_after_fault"] = float(np.median(sd[aft])) if aft.any() else None
            m["innovation_std_median"] = float(np.median(sd[ok])) if ok.any() else None
            for i, o in enumerate(ons, start=1):
                m[f"innovation_peak_z_{i}"] = innovation_peak_z(t, inn, sd, o)
            # noise-only reference: the same statistic on a fault-free window
            m["innovation_peak_z_ref"] = innovation_peak_z(t, inn, sd, 2.0) if t[-1] > 3.5 else None


def _plant_response(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, ons: list[float]) -> None:
    """Speed drop (m/s) measured and predicted by the kinematic model in the 0.3 s after each onset, and
    the largest |slip| in the 2 s after it, into ``m``."""
    RR, RL = _col(trace, "R_R"), _col(trace, "R_L")
    v = _col(trace, "v")
    wR, wL = _col(trace, "omega_R"), _col(trace, "omega_L")
    slips = [c for c in (_col(trace, "slip_R"), _col(trace, "slip_L")) if c is not None]
    for i, o in enumerate(ons, start=1):
        pre, post = (t >= o - 0.3) & (t < o), (t >= o) & (t < o + 0.3)
        if v is not None and pre.any() and post.any():
            m[f"speed_drop_{i}"] = float(np.nanmean(v[pre]) - np.nanmean(v[post]))
            if RR is not None and RL is not None and wR is not None and wL is not None:
                k0, k1 = int(np.flatnonzero(pre)[-1]), int(np.flatnonzero(post)[-1])
                m[f"kinematic_speed_drop_{i}"] = float(0.5 * ((RR[k0] - RR[k1]) * wR[k0] + (RL[k0] - RL[k1]) * wL[k0]))
        win = (t >= o) & (t <= o + 2.0)
        if slips and win.any():
            m[f"slip_max_after_fault_{i}"] = float(max(np.nanmax(np.abs(sl[win])) for sl in slips))


def _domain_metrics(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, t_on: float | None) -> None:
    """When (s) the plant first stays out of the kinematic model's domain, the radius RMSEs (m) over
    the samples after the onset inside it, and the final radius estimates (m), into ``m``."""
    flags = _col(trace, "plant_flags")
    RRh, RLh, RR, RL = (_col(trace, c) for c in ("R_R_hat", "R_L_hat", "R_R", "R_L"))
    have_est = RRh is not None and RLh is not None and np.isfinite(RRh).any()
    if flags is not None:
        bad = np.nan_to_num(flags) != 0
        # first time (after the first onset, or from the start without a fault) the plant stays out of the
        # kinematic model's domain for MODE_HOLD seconds
        dt = float(np.median(np.diff(t))) if t.size > 1 else 0.01
        need = max(1, int(round(MODE_HOLD / dt)))
        run, start = 0, None
        t_from = t_on if t_on is not None else 0.0
        for k in np.flatnonzero(t >= t_from):
            run = run + 1 if bad[k] else 0
            if run >= need:
                start = float(t[k - need + 1])
                break
        m["first_out_of_domain_time"] = start
        if t_on is not None and have_est and RR is not None and RL is not None:
            aft = (t >= t_on) & ~bad
            m["out_of_domain_fraction_after_fault"] = float(np.mean(bad[t >= t_on])) if (t >= t_on).any() else None
            m["radius_rmse_R_after_fault_in_domain"] = _rms((RRh - RR)[aft]) if aft.any() else None
            m["radius_rmse_L_after_fault_in_domain"] = _rms((RLh - RL)[aft]) if aft.any() else None
    if have_est:
        m["R_R_hat_final"] = float(RRh[-1])
        m["R_L_hat_final"] = float(RLh[-1])


def _mode_metrics(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, scenario: str, n_modes: int) -> None:
    """IMM mode identification: delay (s) until each expected mode is on top, the fraction of samples
    with the expected mode on top, the final spread of the mode probabilities, into ``m``."""
    probs = np.column_stack([np.asarray(trace[f"mode_prob_{j + 1}"], dtype=float) for j in range(n_modes)
                             if f"mode_prob_{j + 1}" in trace]) if "mode_prob_1" in trace else np.zeros((0, 0))
    sched = EXPECTED_MODES.get((scenario, n_modes))
    if sched is not None and probs.size:
        sched = [(ts, md) for ts, md in sched if ts <= t[-1]]
        delays, frac = mode_delays(t, probs, sched)
        for i, d in enumerate(delays):
            m[f"mode_delay_{i}"] = d
        m["mode_correct_fraction"] = frac
        if probs.size:
            m["mode_prob_spread_final"] = float(np.nanmax(probs[-1]) - np.nanmin(probs[-1]))


def _tracking_metrics(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, t_on: float | None) -> None:
    """When (s) the robot first leaves the path, and how long (s) it stays on it after the onset, into ``m``."""
    ct = _col(trace, "cross_track_error")
    if ct is not None:
        m["time_off_path"] = first_time(t, np.abs(ct) > OFF_PATH)
        m["time_on_path_after_fault"] = None
        if t_on is not None:
            off = m["time_off_path"]
            m["time_on_path_after_fault"] = (float(t[-1]) - t_on) if off is None else max(0.0, off - t_on)


def _command_metrics(m: dict[str, Any], trace: Mapping[str, Any], t: np.ndarray, t_on: float | None,
                     omega_max: float) -> None:
    """Command reversals and limit-to-limit switches (1/s), time fractions at the wheel-rate limit, into ``m``."""
    cR, cL = _col(trace, "omega_R_cmd"), _col(trace, "omega_L_cmd")
    if cR is not None and cL is not None:
        rR, sR = command_switching(t, cR, omega_max)
        rL, sL = command_switching(t, cL, omega_max)
        m["cmd_reversals_per_s"] = rR + rL
        m["cmd_limit_switches_per_s"] = sR + sL
        atR = np.abs(cR) >= omega_max * (1 - LIMIT_TOL)
        atL = np.abs(cL) >= omega_max * (1 - LIMIT_TOL)
        m["omega_R_at_limit_fraction"] = float(np.mean(atR))
        m["omega_L_at_limit_fraction"] = float(np.mean(atL))
        if t_on is not None:
            aft = t >= t_on
            m["omega_at_limit_fraction_after_fault"] = float(np.mean(atR[aft] | atL[aft])) if aft.any() else None
            m["omega_both_at_limit_fraction_after_fault"] = float(np.mean(atR[aft] & atL[aft])) if aft.any() \
                else None


def onsets_from_faults(right: list[Any], left: list[Any], R0: float) -> dict[str, float | None]:
    """First time each wheel's radius schedule departs from nominal (``None`` = healthy):
    :func:`~ftc_mj.plant.faults.schedule_onset`, the rule of the run metrics."""
    return {"right": schedule_onset(right, R0), "left": schedule_onset(left, R0)}


def onsets_of_config(cfg_dict: Mapping[str, Any]) -> dict[str, float | None]:
    """Fault onsets from a resolved ``config.toml`` (as a dict) or ``RunConfig.model_dump()``."""
    faults = cfg_dict.get("faults", {}) or {}
    robot = cfg_dict.get("robot", {}) or {}
    plant = cfg_dict.get("plant", {}) or {}
    R0 = float(plant.get("wheel_radius") or robot.get("wheel_radius", 2.0))
    return onsets_from_faults(list(faults.get("right", [])), list(faults.get("left", [])), R0)


def required_wheel_rate(V: np.ndarray, psidot: np.ndarray, R_R: np.ndarray, R_L: np.ndarray,
                        b: float) -> np.ndarray:
    """Largest |wheel rate| (rad/s) with which the kinematic model follows speed ``V`` (m/s) and yaw
    rate ``psidot`` (rad/s) on wheels of radii ``R_R``, ``R_L`` (m), half track ``b`` (m):
    ``max(|V + b ψ̇| / R_R, |V − b ψ̇| / R_L)`` per sample."""
    from ..model.kinematics import inverse_rates

    wR, wL = inverse_rates(V, psidot, R_R, R_L, b)
    return np.maximum(np.abs(wR), np.abs(wL))


def reference_feasibility(cfg: RunConfig, trace: Mapping[str, Any], t_from: float | None) -> dict[str, Any]:
    """Whether the reference can be followed within the wheel-rate limit with the *true* radii at
    every sample from ``t_from`` (s) on: ``reference_omega_required_recovered`` (rad/s, the largest
    rate :func:`required_wheel_rate` asks for) and ``reference_feasible_recovered`` (bool); empty when
    ``t_from`` is None or after the end."""
    from ..wiring.control import build_reference

    t = _col(trace, "t")
    R_R, R_L = _col(trace, "R_R"), _col(trace, "R_L")
    if t_from is None or t is None or R_R is None or R_L is None or not (t >= t_from).any():
        return {}
    win = t >= t_from
    ref = build_reference(cfg).at(t[win])
    req = float(np.max(required_wheel_rate(ref.V, ref.psidot, R_R[win], R_L[win], cfg.plant_half_track)))
    return {"reference_omega_required_recovered": req,
            "reference_feasible_recovered": bool(req <= cfg.robot.omega_max)}


def report_metrics(cfg: RunConfig, trace: Mapping[str, Any]) -> dict[str, Any]:
    """Every report metric of one run: :func:`derived_metrics` and, for the window of
    ``cross_track_max_recovered`` (from ``RECOVERY_S`` after the first onset), :func:`reference_feasibility`."""
    from ..metrics.run import RECOVERY_S
    from ..sim.record import fault_onsets

    n_modes = cfg.estimator.bank_size if isinstance(cfg.estimator, IMMSettings) else 0
    onsets = fault_onsets(cfg)
    m = derived_metrics(trace, cfg.name, onsets, n_modes, cfg.robot.omega_max)
    first = min((o for o in onsets.values() if o is not None), default=None)
    m.update(reference_feasibility(cfg, trace, None if first is None else first + RECOVERY_S))
    return m
