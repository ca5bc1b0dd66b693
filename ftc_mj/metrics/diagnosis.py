"""Diagnosis scored as diagnostic competitions score it (DXC): at the level of component *and* mode.

For one run, :func:`diagnosis_metrics` compares the diagnoser's declarations (rebuilt from the trace,
:func:`~ftc_mj.estimation.diagnosis.diagnoses_from_trace`) with the configured faults' truth — each fault's
``(component, target, mode)`` is its class's (:mod:`ftc_mj.plant.faults`), so no translation table sits
between them — and counts the alarms (a channel's statistic above its threshold, declared or not). Over many
runs, :func:`confusion` tallies the mode-level confusion matrix and :func:`summary` the rates a benchmark
reports.

Observability (:func:`observable`) is decided from information alone, before anything is scored: a fault is
observable in a run when one of the measurements its class declares in ``observed_by`` is taken in the run
(``speed`` always, ``wheel_rates`` always — the encoders —, ``yaw_rate`` with a gyro, ``position`` with
position fixes or the pose handed to the controller). Unobservable faults are listed apart with their count.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..estimation.diagnosis import CHANNELS, diagnoses_from_trace
from ..model.diagnosis import Diagnosis
from ..plant.faults import FaultSpec, fault_class

NONE = ("none", "", "")
"""The key of "no fault" (a no-fault run's truth) and of "nothing declared"."""
MATCH_TOLERANCE_S = 0.5
"""A declaration earlier than a fault's onset by more than this (s) cannot be that fault's."""


def measurements_of(sensors: Any, pose: bool = True) -> tuple[str, ...]:
    """The measurements a run takes: ``speed`` and ``wheel_rates`` always, ``yaw_rate`` with a gyro
    (``sensors.yaw_rate_sigma``), ``position`` with position fixes or the pose (``pose``) the loop hands on."""
    out = ["speed", "wheel_rates"]
    if getattr(sensors, "yaw_rate_sigma", None) is not None:
        out.append("yaw_rate")
    if pose or getattr(sensors, "position_sigma", None) is not None:
        out.append("position")
    return tuple(out)


def observable(spec: FaultSpec, measurements: Iterable[str]) -> bool:
    """A fault is observable when a measurement its class declares (``observed_by``) is taken."""
    return bool(set(fault_class(spec.fault_class).observed_by) & set(measurements))


def true_key(spec: FaultSpec) -> tuple[str, str, str]:
    """``(component, target, mode)`` of a configured fault (its class's component and mode)."""
    cls = fault_class(spec.fault_class)
    return cls.component, spec.target, cls.mode


def true_size(spec: FaultSpec, trace: Mapping[str, np.ndarray], row: int, nominal: float) -> float:
    """The truth a declared size is compared with, in the :class:`Diagnosis` unit of its mode: the remaining
    radius fraction of the tyre at ``row`` (from the trace), the remaining servo fraction, the sensor's offset
    (m/s, rad/s) or growth rate (per s); NaN for a dropout (whose declared size is a duration so far)."""
    component, target, mode = true_key(spec)
    if component == "tyre":
        return float(trace[f"R_{target[0].upper()}"][row]) / nominal
    if component == "servo":
        return 1.0 - spec.size
    if mode == "dropout":
        return float("nan")
    return spec.size


def _fault_entry(spec: FaultSpec, found: list[Diagnosis], trace: Mapping[str, np.ndarray], nominal: float,
                 measured: tuple[str, ...], others: set[tuple[str, str]] | None = None) -> dict[str, Any]:
    """One true fault's scoring: its first declaration after the onset (detection); the diagnoser's final
    belief on the fault's component and target — its last declaration on them, else the first declaration
    after the onset — is the one compared (``declared``): isolated when its mode is right too (the delay: to
    the first declaration of that key); its size against the truth. Declarations on the component and target of
    another true fault of the run (``others``) are that fault's, not this one's."""
    key = true_key(spec)
    t = np.asarray(trace["t"], float)
    after = [d for d in found if d.declared >= spec.onset - MATCH_TOLERANCE_S
             and (d.key[:2] == key[:2] or d.key[:2] not in (others or set()))]
    on_it = [d for d in after if d.key[:2] == key[:2]]
    final = on_it[-1] if on_it else (after[0] if after else None)
    correct = [d for d in after if d.key == key] if final is not None and final.key == key else []
    e: dict[str, Any] = {"fault_class": spec.fault_class, "component": key[0], "target": key[1], "mode": key[2],
                         "onset": spec.onset, "observable": observable(spec, measured), "in_run": bool(
                             t.size and spec.onset <= t[-1]),
                         "detection_delay": (after[0].declared - spec.onset) if after else None,
                         "isolated": bool(correct),
                         "isolation_delay": (correct[0].declared - spec.onset) if correct else None,
                         "declared": "/".join(final.key) if final is not None else None}
    if correct:
        row = int(min(np.searchsorted(t, correct[-1].declared), t.size - 1))
        truth = true_size(spec, trace, row, nominal)
        e["size_true"] = truth
        e["size_declared"] = correct[-1].size
        e["size_error"] = correct[-1].size - truth if np.isfinite(truth) else None
    return e


def _episodes(flag: np.ndarray) -> int:
    """How many times ``flag`` (bool per row) goes up, counting a first row already up."""
    return int(np.sum(flag[1:] & ~flag[:-1]) + (1 if flag.size and flag[0] else 0))


def alarm_episodes(trace: Mapping[str, np.ndarray]) -> dict[str, int]:
    """How many times each channel's alarm went up (0 → 1) in the run."""
    return {c: _episodes(np.nan_to_num(np.asarray(trace.get(f"diag_alarm_{c}", []), float)) > 0.5) for c in CHANNELS}


DEGRADED_EVENT = "degraded mode from the first alarm"
"""The start of the event the degraded mode (:mod:`ftc_mj.reconfiguration.degraded`) writes when an alarm opens a
radius interval for the controller."""


def _changes(x: np.ndarray) -> int:
    """How many times the finite values of ``x`` change from row to row."""
    x = x[np.isfinite(x)]
    return int(np.sum(np.abs(np.diff(x)) > 1e-9)) if x.size else 0


def alarms_acted_upon(trace: Mapping[str, np.ndarray], events: Sequence[Any] = ()) -> dict[str, int]:
    """The alarms that changed the controller's model or mode in a run (issue 41, point 4), by what moved: the
    policy's state (``reconfig_state``: a hold, a hand-over, a revert), the controller's radii leaving the ones it
    started with (``R_*_model``: the policy's radius switch, the degraded mode's hand-over), the degraded mode's
    radius interval opened by an alarm (its event), the accommodation's mode and actuator model
    (``accommodation_mode``, ``actuator_effectiveness_*``) and the excitation dither added while a fault is
    suspected (``excitation``). Each counts its changes (episodes for the radii and the dither); a healthy run
    whose detectors stay quiet has none."""
    def col(name: str) -> np.ndarray:
        return np.asarray(trace.get(name, np.zeros(0)), float)

    radii = [col(f"R_{s}_model") for s in "RL"]
    moved = np.zeros(radii[0].size, bool)
    for r in radii:
        if r.size:
            moved |= np.nan_to_num(np.abs(r - r[0]), nan=0.0) > 1e-9
    texts = [str(e.get("text", "")) if isinstance(e, Mapping) else str(getattr(e, "text", "")) for e in events]
    return {
        "policy": _changes(col("reconfig_state")),
        "model_radii": _episodes(moved),
        "degraded": sum(text.startswith(DEGRADED_EVENT) for text in texts),
        "accommodation": _changes(col("accommodation_mode")) + sum(
            _changes(col(f"actuator_effectiveness_{s}")) for s in "RL"),
        "excitation": _episodes(np.nan_to_num(np.abs(col("excitation")), nan=0.0) > 0.0),
    }


def diagnosis_metrics(trace: Mapping[str, np.ndarray], faults: Sequence[FaultSpec], sensors: Any,
                      nominal_radius: float, events: Sequence[Any] = ()) -> dict[str, Any]:
    """The run's diagnosis metrics (``metrics.json``; empty without a diagnoser's columns): every declaration,
    every true fault's detection, isolation and size error, the declarations no true fault explains, the
    alarm episodes per channel and the alarms acted upon (:func:`alarms_acted_upon`, from the trace and the
    run's ``events``)."""
    if "diag_count" not in trace or not np.any(np.isfinite(np.asarray(trace["diag_count"], float))):
        return {}
    found = diagnoses_from_trace(trace)
    measured = measurements_of(sensors)
    entries = [_fault_entry(s, found, trace, nominal_radius, measured,
                            {true_key(o)[:2] for o in faults if o is not s}) for s in faults]
    keys = {true_key(s): s.onset for s in faults}
    false = [d for d in found if d.key not in keys or d.declared < keys[d.key] - MATCH_TOLERANCE_S]
    alarms = alarm_episodes(trace)
    acted = alarms_acted_upon(trace, events)
    return {
        "diagnoses": [d.as_dict() for d in found],
        "diagnosis_faults": entries,
        "diagnosis_isolated_all": bool(all(e["isolated"] for e in entries if e["observable"] and e["in_run"])),
        "diagnosis_false_declarations": len(false),
        "diagnosis_first_false_time": min((d.declared for d in false), default=None),
        "diagnosis_alarms": alarms,
        "diagnosis_alarm_episodes": int(sum(alarms.values())),
        "diagnosis_acted_upon": acted,
        "diagnosis_alarms_acted_upon": int(sum(acted.values())),
    }


def run_key(entry: Mapping[str, Any]) -> tuple[str, str, str]:
    """The true key of a scored fault entry."""
    return str(entry["component"]), str(entry["target"]), str(entry["mode"])


def confusion(runs: Iterable[Mapping[str, Any]]) -> Counter[tuple[tuple[str, str, str], str]]:
    """The mode-level confusion matrix over runs' metrics: ``(true key, declared "component/target/mode" or
    "none")`` → count, over observable faults in the run (the diagnoser's final belief on each, see
    :func:`diagnosis_metrics`), and
    ``(NONE, declared)`` for every declaration of a no-fault run."""
    out: Counter[tuple[tuple[str, str, str], str]] = Counter()
    for m in runs:
        entries = m.get("diagnosis_faults")
        if entries is None:
            continue
        for e in entries:
            if e["observable"] and e["in_run"]:
                out[(run_key(e), e["declared"] or "none")] += 1
        if not entries:
            declared = m.get("diagnoses") or []
            out[(NONE, "/".join((declared[0]["component"], declared[0]["target"], declared[0]["mode"]))
                 if declared else "none")] += 1
    return out


def summary(runs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Rates over runs' metrics: isolation correct among observable faulted entries, the unobservable ones
    apart, false declarations per hour of no-fault runs and per run, and the median delays (s)."""
    faulted = [e for m in runs for e in (m.get("diagnosis_faults") or []) if e["in_run"]]
    obs = [e for e in faulted if e["observable"]]
    clean = [m for m in runs if m.get("diagnosis_faults") == []]
    hours = sum(float(m.get("sim_time_s") or 0.0) for m in clean) / 3600.0
    false_runs = sum(1 for m in clean if m.get("diagnosis_false_declarations"))
    iso = [e["isolation_delay"] for e in obs if e["isolation_delay"] is not None]
    det = [e["detection_delay"] for e in obs if e["detection_delay"] is not None]
    return {
        "faulted": len(obs), "unobservable": [e["fault_class"] for e in faulted if not e["observable"]],
        "isolated": sum(1 for e in obs if e["isolated"]),
        "isolation_rate": (sum(1 for e in obs if e["isolated"]) / len(obs)) if obs else None,
        "no_fault_runs": len(clean), "no_fault_runs_with_false_declaration": false_runs,
        "false_declarations_per_hour": (sum(m.get("diagnosis_false_declarations") or 0 for m in clean) / hours
                                        if hours > 0 else None),
        "detection_delay_median": float(np.median(det)) if det else None,
        "isolation_delay_median": float(np.median(iso)) if iso else None,
    }


DIAGNOSIS_SCORE_COLUMNS: tuple[str, ...] = (
    "diag_true", "diag_declared", "diag_isolation", "diag_observable", "diag_detection_delay",
    "diag_isolation_delay", "diag_size_error", "diag_false_declarations", "diag_alarm_episodes",
    "diag_acted_upon")
"""The benchmark's diagnosis scores of a draw (:func:`diagnosis_scores`)."""


def diagnosis_scores(trace: Mapping[str, np.ndarray], faults: Sequence[FaultSpec], sensors: Any,
                     nominal_radius: float, events: Sequence[Any] = ()) -> dict[str, Any]:
    """A draw's diagnosis scores (:data:`DIAGNOSIS_SCORE_COLUMNS`), for its *first* fault in the run: its key
    ``component/target/mode`` (``none`` without a fault), the first declaration after its onset, the verdict
    ``correct`` (component, target and mode right), ``wrong``, ``none`` (nothing declared) or ``n/a`` (no
    fault; a diagnoser-less run: every score ``None``), whether it is observable, the delays (s), the size
    error (the mode's unit), the declarations no fault explains, the alarm episodes and the alarms acted upon
    (``diag_acted_upon``: :func:`alarms_acted_upon`, the run's ``events`` for the degraded mode's)."""
    m = diagnosis_metrics(trace, faults, sensors, nominal_radius, events)
    if not m:
        return dict.fromkeys(DIAGNOSIS_SCORE_COLUMNS)
    entries = [e for e in m["diagnosis_faults"] if e["in_run"]]
    first = min(entries, key=lambda e: e["onset"]) if entries else None
    declared = m["diagnoses"]
    out: dict[str, Any] = {
        "diag_true": "/".join(run_key(first)) if first else "none",
        "diag_declared": (first["declared"] if first else ("/".join((declared[0]["component"], declared[0]["target"],
                                                                       declared[0]["mode"])) if declared else None)),
        "diag_isolation": ("n/a" if first is None else "correct" if first["isolated"]
                           else "wrong" if first["declared"] else "none"),
        "diag_observable": None if first is None else first["observable"],
        "diag_detection_delay": None if first is None else first["detection_delay"],
        "diag_isolation_delay": None if first is None else first["isolation_delay"],
        "diag_size_error": None if first is None else first.get("size_error"),
        "diag_false_declarations": m["diagnosis_false_declarations"],
        "diag_alarm_episodes": m["diagnosis_alarm_episodes"],
        "diag_acted_upon": m["diagnosis_alarms_acted_upon"],
    }
    return out
