"""The benchmark's score of one finished run: :func:`score_run` (config, trace, events) → flat dict.

Every score reuses the run metrics (:mod:`ftc_mj.metrics`); what is new is the fault truth of every
fault class (tyre, actuator, sensor), the isolation verdict against it, and the per-draw bounds.

Path
    ``contouring_max`` / ``contouring_rms`` (m): |cross-track error| from
    :data:`~ftc_mj.metrics.path.RECOVERED_AFTER_S` after the *last* fault onset (a fault-free run: from
    that long after the start) — :func:`~ftc_mj.metrics.path.path_following_metrics`.
Safety
    ``tipped``; ``liftoff_s`` (s a wheel was off the ground outside the
    :data:`~ftc_mj.metrics.run.FAULT_TRANSIENT_S` after every onset) — :func:`~ftc_mj.metrics.run.plant_metrics`.
``success``
    Under the version's rule (``[judge]``, :class:`~ftc_mj.benchmark.definition.JudgeRule`). ``near-path``
    (``ftc-v1``): the run completed, did not tip over, and ``contouring_max`` ≤
    :data:`~ftc_mj.metrics.outcome.OFF_PATH_M`. ``progress`` (``ftc-v2``): :mod:`~ftc_mj.benchmark.judge` — the
    draw's label (``trackable``/``stop-only``, from physics), progress along the path or a safe stop; it adds
    ``label``, ``attainable_speed`` (m/s), ``progress`` and ``progress_needed`` (m) and ``disabling_onset`` (s),
    ``None`` under ``near-path``.
FDI (runs with an estimator)
    ``false_alarm``: a declaration before the first onset (any, without a fault); ``detected``: a
    declaration starts after the first onset; ``detection_delay`` (s) from the first onset;
    ``isolation``: the wheel of the last declaration after the first onset against the truth —
    ``correct`` (the faults are punctures and it names exactly the punctured wheels), ``unknown``
    (declared, wheel unknown), ``wrong`` (anything else: a healthy wheel, or any wheel when a fault is
    not a puncture — the filters model radius faults only, so a sensor or actuator fault declared as a
    puncture is a false isolation), ``none`` (nothing declared after the onset), ``n/a`` (no fault).
Diagnosis (runs with a diagnoser)
    ``diag_*`` at component-and-mode level — :func:`~ftc_mj.metrics.diagnosis.diagnosis_scores`.
Reconfiguration
    ``reconfig_delay`` (s): first hand-over after the first onset —
    :func:`~ftc_mj.metrics.run.reconfiguration_metrics`.
Bounds
    ``lorden_delay_bound`` (s): Lorden's lower bound on the delay of any rule with the mean time between false
    alarms the run's decision rule has (:func:`bound_arl0`: the rule's no-fault alarm rate *measured* on the
    MuJoCo plant after the launch with the draw's sensor set — with or without the gyro —, shipped with the
    package by ``benchmarks/calibration.py``, :mod:`~ftc_mj.metrics.alarm_rates`; the configured
    ``estimator.decision.arl0`` only for a rule or settings not measured) for this draw's first change: the
    first time the cumulative Kullback–Leibler information of the change reaches ``log(ARL0 / dt)``
    (:func:`~ftc_mj.metrics.fdi.lorden_delays`);
    the change is the true plant's departure from the nominal model in the speed, the yaw rate and the pose fixes
    (:func:`~ftc_mj.metrics.fdi.cumulative_kl`: every measurement the method has, so that no detector can come in
    under it) or, for a sensor bias/drift, the injected offset over the sensor's σ. ``None`` when it is
    not reached within :data:`~ftc_mj.metrics.fdi.KL_PROFILE_S` (a dropout or an actuator fault the wheel-rate
    inputs explain).
    ``tyre_alarm_delay`` (s): the first *alarm* of the diagnoser's tyre detectors after the first onset — the
    first row from the onset on with the ``tyre_R`` or ``tyre_L`` channel's statistic at or above its threshold
    (``diag_alarm_tyre_*``, declared or not; 0 when one is already up at the onset) — beside
    ``detection_delay``, the first *declaration* (after the rule's dwell and confirmation): Lorden's bound
    bounds the delay of an alarm of a detector at a false-alarm rate, which is the alarm's, not the
    declaration's (:func:`tyre_alarm_delay`); ``None`` without a fault, a diagnoser or such an alarm.
    ``tyre_alarm_bound`` (s): the same bound at the tyre alarms' own measured no-fault rate
    (:func:`tyre_alarm_arl0`: the fast detector's CUSUM when it runs), which ``tyre_alarm_delay`` is judged against.
    ``radius_pcrb_R/L`` (m): the posterior Cramér–Rao bound at the end of the run on each radius for the
    model that generated the data (radii constant between the truth's changes,
    :func:`~ftc_mj.estimation.pcrb.data_model_bound`), as the run recorded it once (the trace's
    ``R_*_pcrb_const_std``, from the run record's filter setup; ``None`` for a trace without it), beside the
    filter's final error ``radius_error_R/L`` (m).

The scorer reads the run's resolved record (:class:`~ftc_mj.metrics.record.RunRecord`: filter setup, reference
path, rates) instead of rebuilding those facts from the config.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import RunConfig
from ..metrics.alarm_rates import RULE_SETTINGS, measured_arl0, tyre_change_arl0
from ..metrics.detection import WHEEL_OF_CODE, declared_wheel_codes
from ..metrics.diagnosis import DIAGNOSIS_SCORE_COLUMNS, diagnosis_scores
from ..metrics.fdi import KL_PROFILE_S, cumulative_kl, lorden_delays
from ..metrics.outcome import OFF_PATH_M
from ..metrics.path import path_following_metrics
from ..metrics.record import RunRecord
from ..metrics.run import plant_metrics, reconfiguration_metrics
from ..metrics.series import first_time, starts
from ..plant.faults import SensorFault, fault_class, fault_list, wheel_schedules
from ..sim.record import build_record
from .definition import JudgeRule
from .judge import JUDGE_COLUMNS, judge_run

SCORE_COLUMNS = ("success", "contouring_max", "contouring_rms", "tipped", "liftoff_s", "false_alarm", "detected",
                 "detection_delay", "isolation", "reconfig_delay", "lorden_delay_bound", "tyre_alarm_delay",
                 "tyre_alarm_bound", "radius_pcrb_R",
                 "radius_pcrb_L", "radius_error_R", "radius_error_L", "solver_fallbacks", "status", *JUDGE_COLUMNS,
                 *DIAGNOSIS_SCORE_COLUMNS)
"""The keys :func:`score_run` returns (``None`` where a score does not apply)."""


def fault_truth(cfg: RunConfig) -> list[dict[str, Any]]:
    """Every configured fault (:func:`~ftc_mj.plant.faults.records.fault_list`: class, target, onset in s, size
    in the class's unit) as a dict with ``end`` (s) — when a radius fault's schedule stops changing, the onset
    otherwise — in onset order."""
    R0 = cfg.plant_wheel_radius
    ends = {w: s.end_time for w, s in zip(("right", "left"), wheel_schedules(cfg.faults, R0), strict=True)}
    out = [{"fault_class": f.fault_class, "target": f.target, "onset": f.onset, "size": f.size,
            "end": ends[f.target] if fault_class(f.fault_class).radius_fault else f.onset}
           for f in fault_list(cfg.faults, R0)]
    return sorted(out, key=lambda f: f["onset"])


def isolation_verdict(code: np.ndarray, t: np.ndarray, faults: list[dict[str, Any]]) -> str:
    """``correct`` / ``unknown`` / ``wrong`` / ``none`` / ``n/a`` (module docstring) of the declared-wheel
    codes ``code`` per step at times ``t`` (s)."""
    if not faults:
        return "n/a"
    after = t >= faults[0]["onset"]
    declared = code[after & (code > 0)]
    if declared.size == 0:
        return "none"
    last = WHEEL_OF_CODE.get(int(declared[-1]))
    if last == "unknown":
        return "unknown"
    if any(not fault_class(f["fault_class"]).radius_fault for f in faults):
        return "wrong"
    wheels = {f["target"] for f in faults}
    truth = "both" if wheels == {"right", "left"} else wheels.pop()
    return "correct" if last == truth else "wrong"


def fdi_scores(trace: dict[str, np.ndarray], faults: list[dict[str, Any]]) -> dict[str, Any]:
    """False alarm, detection, its delay (s) and the isolation verdict of a run with an estimator."""
    t = np.asarray(trace["t"], float)
    code = declared_wheel_codes(trace)
    t0 = faults[0]["onset"] if faults else math.inf
    begin = starts(code > 0)
    t_det = first_time(begin & (t >= t0), t) if faults else None
    return {"false_alarm": bool(np.any(begin & (t < t0))), "detected": t_det is not None if faults else None,
            "detection_delay": None if t_det is None else t_det - t0,
            "isolation": isolation_verdict(code, t, faults)}


TYRE_ALARMS = ("diag_alarm_tyre_R", "diag_alarm_tyre_L", "diag_alarm_tyre_change")
"""The trace's alarm flags of the diagnoser's tyre detectors (1 while the channel's statistic is at or above
its threshold): the two rolling-ratio channels and the fast detector (absent from a trace written before it)."""


def tyre_alarm_delay(trace: dict[str, np.ndarray], faults: list[dict[str, Any]]) -> float | None:
    """Seconds from the first fault's onset to the first row from it on with a tyre detector's alarm up
    (:data:`TYRE_ALARMS`); ``None`` without a fault, without the columns (no diagnoser) or without such an alarm."""
    if not faults or not all(c in trace for c in TYRE_ALARMS[:2]):
        return None
    t = np.asarray(trace["t"], float)
    up = np.zeros(t.size, bool)
    for c in TYRE_ALARMS:
        if c in trace:
            up |= np.nan_to_num(np.asarray(trace[c], float)) > 0.5
    t0 = faults[0]["onset"]
    hit = np.flatnonzero(up & (t >= t0))
    return float(t[hit[0]] - t0) if hit.size else None


def sensor_kl(cfg: RunConfig, trace: dict[str, np.ndarray], fault: dict[str, Any]) -> np.ndarray:
    """Cumulative KL information (nats per row) of a sensor fault from its onset: ``Σ ½ (offset/σ)²`` with the
    injected offset (m/s or rad/s, its class's
    :meth:`~ftc_mj.plant.faults.base.SensorFault.offset_profile`) and the sensor's σ; empty for a class that
    carries no information (a dropout). A pose fault's offset (m) displaces the fixes of σ ``position_sigma``,
    which come at ``position_rate``: its information per row is that of a fix times the fixes per row."""
    s = cfg.sensors
    sigma = {"speed": s.speed_sigma, "yaw_rate": s.yaw_rate_sigma, "pose": s.position_sigma}.get(fault["target"])
    per_row = s.position_rate / cfg.estimator.rate if fault["target"] == "pose" else 1.0
    t = np.asarray(trace["t"], float)
    t = t[(t >= fault["onset"] - 1e-9) & (t < fault["onset"] + KL_PROFILE_S)]
    dt = 1.0 / cfg.estimator.rate
    offset = None if sigma is None or t.size == 0 else fault_class(fault["fault_class"]).offset_profile(  # type: ignore[attr-defined]
        fault["size"], t - fault["onset"] + dt)
    return np.zeros(0) if offset is None else np.cumsum(0.5 * per_row * (offset / sigma) ** 2)


def bound_arl0(cfg: RunConfig) -> float:
    """The mean time between false alarms (s) Lorden's bound is taken at: that measured for the run's decision
    rule (``auto``: ``mode`` for an IMM, ``sigma`` otherwise) under no fault after the launch, with or without the
    gyro as the run has (:func:`~ftc_mj.metrics.alarm_rates.measured_arl0`), else ``estimator.decision.arl0``."""
    rule = cfg.estimator.decision.rule
    if rule == "auto":
        rule = "mode" if str(cfg.estimator.kind).startswith("imm") else "sigma"
    return _measured_arl0(cfg, rule)


def tyre_alarm_arl0(cfg: RunConfig) -> float:
    """The mean time between false alarms (s) of the diagnoser's tyre alarms: with its fast detector
    (``diagnosis.tyre_change`` and a filter), its CUSUM's measured after the launch with the run's sensor set under
    the benchmark's drawn conditions (:func:`~ftc_mj.metrics.alarm_rates.tyre_change_arl0`) — the rolling-ratio
    channels raised no alarm in 1200 s of healthy draws, so the CUSUM's rate dominates the union's —,
    else the decision rule's (:func:`bound_arl0`)."""
    if getattr(cfg.diagnosis, "tyre_change", False) and cfg.estimator.kind != "none":
        return _measured_arl0(cfg, "tyre_change")
    return bound_arl0(cfg)


def _measured_arl0(cfg: RunConfig, rule: str) -> float:
    """``rule``'s no-fault mean time between alarms (s) measured with the run's sensor set and decision settings
    (``tyre_change``: the diagnoser's fast tyre detector's), else the configured ``estimator.decision.arl0``."""
    d = cfg.estimator.decision
    settings, gyro = {k: float(getattr(d, k)) for k in RULE_SETTINGS}, cfg.sensors.yaw_rate_sigma is not None
    measured = tyre_change_arl0(gyro, settings) if rule == "tyre_change" else measured_arl0(rule, gyro, settings)
    return d.arl0 if measured is None else measured


def bound_scores(cfg: RunConfig, record: RunRecord, trace: dict[str, np.ndarray],
                 faults: list[dict[str, Any]]) -> dict[str, Any]:
    """Lorden's delay bounds (s) for the first change at the decision rule's and at the tyre alarms' no-fault
    rates, and the radius PCRB at the end (m; module docstring)."""
    out: dict[str, Any] = {"lorden_delay_bound": None, "tyre_alarm_bound": None}
    dt = 1.0 / cfg.estimator.rate
    if faults:
        f = faults[0]
        K = (sensor_kl(cfg, trace, f) if issubclass(fault_class(f["fault_class"]), SensorFault)
             else np.asarray(cumulative_kl(record.setup, trace, f["onset"]), float))
        if K.size:
            d = lorden_delays(K, np.array([bound_arl0(cfg), tyre_alarm_arl0(cfg)]), dt)
            out["lorden_delay_bound"] = float(d[0]) if math.isfinite(d[0]) else None
            out["tyre_alarm_bound"] = float(d[1]) if math.isfinite(d[1]) else None
    out.update(radius_bound(record, trace))
    return out


def radius_bound(record: RunRecord, trace: dict[str, np.ndarray]) -> dict[str, Any]:
    """The PCRB σ (m) of each radius at the last row for the model that made the data, as the run recorded it
    (the trace's ``R_*_pcrb_const_std``: the bound is computed once per run, by the loop), and the filter's
    final errors (m); ``None`` without an estimator, and for the bound of a trace that did not record it."""
    keys = ("radius_pcrb_R", "radius_pcrb_L", "radius_error_R", "radius_error_L")
    if record.estimator == "none" or not np.any(np.isfinite(trace.get("R_R_hat", np.array([np.nan])))):
        return dict.fromkeys(keys)
    errors = {"radius_error_R": float(abs(trace["R_R_hat"][-1] - trace["R_R"][-1])),
              "radius_error_L": float(abs(trace["R_L_hat"][-1] - trace["R_L"][-1]))}
    if "R_R_pcrb_const_std" not in trace:
        return {"radius_pcrb_R": None, "radius_pcrb_L": None, **errors}
    return {"radius_pcrb_R": float(trace["R_R_pcrb_const_std"][-1]),
            "radius_pcrb_L": float(trace["R_L_pcrb_const_std"][-1]), **errors}


def _text(e: Any) -> str:
    return str(e.get("text", "")) if isinstance(e, dict) else str(getattr(e, "text", ""))


def score_run(config: RunConfig, trace: dict[str, np.ndarray], events: Sequence[Any],
              status: str = "ok", record: RunRecord | None = None, rule: JudgeRule | None = None
              ) -> dict[str, float | str | bool | None]:
    """The scores of one finished run (module docstring; keys :data:`SCORE_COLUMNS`). ``trace``: the columns
    :mod:`ftc_mj.sim` writes; ``events``: the run's events (``Event`` objects or ``{t, level, text}``
    dicts); ``status``: the run's (``ok``, ``failed``, ``unstable``) — only ``ok`` can succeed; ``record``: the
    run's resolved record (``SimResult.record``, ``record.json``; built from ``config`` when not given); ``rule``: the
    version's success rule (``near-path`` when not given)."""
    cfg = config
    record = build_record(cfg) if record is None else record
    tr = {k: np.asarray(v) for k, v in trace.items()}
    t = np.asarray(tr["t"], float)
    faults = [f for f in fault_truth(cfg) if t.size and f["onset"] <= t[-1]]
    onsets = {f"f{i}": f["onset"] for i, f in enumerate(faults)}
    path = path_following_metrics(record, tr, onsets)
    plant = plant_metrics(tr, {}, onsets, 1.0 / cfg.estimator.rate)
    cmax = path.get("contouring_max_recovered", math.nan)
    out: dict[str, Any] = {
        "status": status,
        "contouring_max": cmax, "contouring_rms": path.get("contouring_rms_recovered", math.nan),
        "tipped": plant["tipped"], "liftoff_s": plant["liftoff_time_post_transient_s"],
        "success": bool(status == "ok" and not plant["tipped"] and math.isfinite(cmax) and cmax <= OFF_PATH_M),
        "solver_fallbacks": sum(_text(e).startswith("solver fallback") for e in events),
    }
    with_filter = cfg.estimator.kind != "none" and "fault_detected" in tr
    out.update(fdi_scores(tr, faults) if with_filter else
               {"false_alarm": None, "detected": None, "detection_delay": None, "isolation": None})
    rc = reconfiguration_metrics(tr, faults[0]["onset"] if faults else None)
    out["reconfig_delay"] = rc.get("reconfig_handover_delay")
    out.update(bound_scores(cfg, record, tr, faults))
    out["tyre_alarm_delay"] = tyre_alarm_delay(tr, faults)
    if rule is not None and rule.rule == "progress":
        alive = bool(status == "ok" and not plant["tipped"])
        out.update(judge_run(cfg, record, tr, [f["onset"] for f in faults], out["success"], alive, rule))
    else:
        out.update(dict.fromkeys(JUDGE_COLUMNS))
    out.update(diagnosis_scores(tr, fault_list(cfg.faults, cfg.plant_wheel_radius), cfg.sensors,
                                cfg.model_wheel_radius, events))
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}
