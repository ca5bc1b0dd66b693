"""Detection and isolation metrics of the fault decision (``metrics.json``), computed from the trace's
``fault_detected`` and ``declared_wheel`` columns of a run with an estimator; times in s from the
start of the run.

A wheel is faulty from its scheduled onset (the run record's ``onsets``,
:func:`~ftc_mj.sim.record.fault_onsets`) on. An onset after the run's last step is *after the end*:
listed in ``onsets`` with ``status = "after end"`` and neither detected nor missed (it counts for no
other key either). Onsets at the same time form one onset (wheel ``both``).
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
``radius_loss_estimate_final_R/L`` (the decision's severity at the last step: fractional radius
loss ``1 - R_hat/R0``, 0..1, of the filter's final estimate; ``severity_R/L`` before 2026-12) are added by
:func:`~ftc_mj.sim.run.run_metrics`. Without an estimator only ``onsets`` (no detection keys).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..telemetry.columns import WHEEL_CODES
from .onsets import onset_groups, wheel_label
from .series import first_time, starts

WHEEL_OF_CODE = {code: wheel for wheel, code in WHEEL_CODES.items()}
"""The wheel named by each :data:`~ftc_mj.telemetry.columns.WHEEL_CODES` code."""


def declared_wheel_codes(trace: dict[str, np.ndarray]) -> np.ndarray:
    """Per step, the declared wheel's :data:`~ftc_mj.telemetry.columns.WHEEL_CODES` code (0 = nothing declared);
    a declaration without a ``declared_wheel`` code (or column) is of ``unknown`` wheel."""
    det = np.nan_to_num(trace["fault_detected"]) > 0.5
    code = np.nan_to_num(trace["declared_wheel"]).astype(np.int64) if "declared_wheel" in trace else 0
    return np.where(det, np.where(code > 0, code, WHEEL_CODES["unknown"]), 0)


def _isolation(code: np.ndarray, faulty: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per step: the declared wheel equals the faulty set (correct), and it names a healthy wheel (wrong)."""
    dR, dL = np.isin(code, (1, 3)), np.isin(code, (2, 3))
    named = (code > 0) & (code != WHEEL_CODES["unknown"])
    return named & (dR == faulty[0]) & (dL == faulty[1]), (dR & ~faulty[0]) | (dL & ~faulty[1])


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
    t_det = first_time(event & window, t)
    t_iso = first_time(starts(correct) & window, t)
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
        entry: dict[str, Any] = {"wheel": wheel_label(*ws), "time": o, "status": "in run" if in_run else "after end"}
        if in_run and code is not None:
            nxt = groups[i + 1][0] if i + 1 < len(groups) else np.inf
            entry.update(onset_metrics(t, code, faulty, (t >= o) & (t < nxt)))
        entries.append(entry)
    return entries


def detection_metrics(trace: dict[str, np.ndarray], onsets: dict[str, float | None]) -> dict[str, Any]:
    """Fault-decision metrics of a run: detection and isolation per onset and over the run (keys in the
    module docstring)."""
    t = trace["t"]
    code = declared_wheel_codes(trace)
    entries = onset_entries(t, onsets, code)
    in_run = [e for e in entries if e["status"] == "in run"]
    first = in_run[0] if in_run else {}
    t0 = first.get("time", np.inf)
    faulty = (t >= (onsets["right"] if onsets["right"] is not None else np.inf),
              t >= (onsets["left"] if onsets["left"] is not None else np.inf))
    correct, _ = _isolation(code, faulty)
    false_alarms = int(np.sum(starts(code > 0) & (t < t0)))
    true_end = wheel_label(bool(faulty[0][-1]), bool(faulty[1][-1])) if in_run else None
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
        "first_declaration_time": first_time(code > 0, t),
        "declarations": int(np.sum(starts(code > 0))),
    }
