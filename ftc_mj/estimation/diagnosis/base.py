"""What a diagnoser is handed at each estimator step (:class:`DiagnosisInput`), what it returns
(:class:`DiagnosisStep`), the protocol the loop calls (:class:`Diagnoser`) and the trace columns and codes
that carry its declarations and alarms (:data:`DIAGNOSIS_COLUMNS`).

A *declaration* is a :class:`~ftc_mj.model.diagnosis.Diagnosis` (component, target, mode, size with its σ,
onset, declaration time, statistic and threshold). An *alarm* is one of the diagnoser's statistics above
its threshold at a step, declared or not: the loop writes every alarm flag and statistic to the trace, so
that a scorer counts the alarms that moved nothing as well as the declarations.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ...model.diagnosis import COMPONENT_MODES, COMPONENT_TARGETS, Diagnosis
from ..base import Measurement

COMPONENT_CODES: dict[str, int] = {"": 0, **{c: i + 1 for i, c in enumerate(COMPONENT_MODES)}}
"""Trace code of each component (0: nothing declared)."""
TARGET_CODES: dict[str, int] = {"": 0, **{t: i + 1 for i, t in enumerate(
    dict.fromkeys(t for ts in COMPONENT_TARGETS.values() for t in ts))}}
"""Trace code of each target (0: nothing declared)."""
MODE_CODES: dict[str, int] = {"": 0, **{m: i + 1 for i, m in enumerate(
    dict.fromkeys(m for ms in COMPONENT_MODES.values() for m in ms))}}
"""Trace code of each mode (0: nothing declared)."""

CHANNELS: tuple[str, ...] = ("tyre_R", "tyre_L", "servo_R", "servo_L", "lock_R", "lock_L", "speed", "gyro",
                             "speed_dropout", "gyro_dropout", "pose", "pose_dropout", "tyre_change")
"""The built-in diagnoser's residual channels, one statistic and one alarm flag each in the trace
(``tyre_change``: the fast tyre detector of :mod:`.change`, which detects and declares nothing)."""

OFFSET_COLUMNS: tuple[str, ...] = ("diag_offset_x", "diag_offset_y", "diag_offset_sigma_x", "diag_offset_sigma_y")
"""The latest declaration's :attr:`~ftc_mj.model.diagnosis.Diagnosis.offset` ``(dx, dy)`` and its σ per axis (m,
world frame); NaN for a record without one."""

DECLARATION_COLUMNS: tuple[str, ...] = (
    "diag_component", "diag_target", "diag_mode", "diag_size", "diag_sigma", "diag_onset", "diag_declared",
    "diag_statistic", "diag_threshold", "diag_count", *OFFSET_COLUMNS)
"""The latest declaration of the run at each row (codes :data:`COMPONENT_CODES`, :data:`TARGET_CODES`,
:data:`MODE_CODES`; size and σ in the mode's unit; onset and declaration time in s; its statistic and
threshold; its offset vector and σ per axis, :data:`OFFSET_COLUMNS`) and the number of declarations so far
(``diag_count``): a new declaration is a row where the count grows, so the records are rebuilt from the trace
alone (:func:`diagnoses_from_trace`)."""

DIAGNOSIS_COLUMNS: tuple[str, ...] = (*DECLARATION_COLUMNS, *(f"diag_stat_{c}" for c in CHANNELS),
                                      *(f"diag_alarm_{c}" for c in CHANNELS), "diag_alarms")
"""Every trace column of the diagnosis: the declaration columns, each channel's statistic (its threshold is
the declaration's for that channel, in the channel's unit: docs/fdi.md) and alarm flag (0/1), and
``diag_alarms``, the number of channels in alarm at the row."""

DIAGNOSIS_INTEGER_COLUMNS: tuple[str, ...] = (
    "diag_component", "diag_target", "diag_mode", "diag_count", "diag_alarms",
    *(f"diag_alarm_{c}" for c in CHANNELS))
"""The integer codes, flags and counts among :data:`DIAGNOSIS_COLUMNS`."""


@dataclass(frozen=True)
class DiagnosisInput:
    """What the loop measured at one estimator step (SI units; ``None``: not available at this step).

    Attributes:
        t: time of the step (s).
        omega: encoder wheel rates ``[ω_R, ω_L]`` (rad/s).
        command: the wheel-rate command in force on the plant since the previous step ``[ω_R, ω_L]``
            (rad/s, after any dither); ``None`` before the first command.
        speed: the speed sensor's reading (m/s); ``None`` when it delivered nothing.
        yaw_rate: the gyro's reading (rad/s); ``None`` without a gyro or when it delivered nothing.
        pose: a pose fix ``[x, y, ψ]`` (m, m, rad) due at this step, else ``None``.
        pose_sigma: its noise σ (m, and rad for ψ).
        radii: the filter's radius estimates ``[R_R, R_L]`` (m), ``None`` without a filter.
        filter_input: what the filter stepped on this step, ``(u, z)``: the wheel rates it predicted with (rad/s)
            and the measurement it was updated with (the readings with the diagnosed sensor offsets removed and
            excluded channels absent); ``None`` without a filter.
    """

    t: float
    omega: np.ndarray
    command: np.ndarray | None
    speed: float | None
    yaw_rate: float | None
    pose: np.ndarray | None
    pose_sigma: float
    radii: np.ndarray | None = None
    filter_input: tuple[np.ndarray, Measurement] | None = None


@dataclass
class DiagnosisStep:
    """A diagnoser's output at one step: every channel's statistic and alarm flag, the declarations made at
    this step (usually none) and all declarations so far (oldest first)."""

    statistics: dict[str, float] = field(default_factory=dict)
    alarms: dict[str, bool] = field(default_factory=dict)
    new: list[Diagnosis] = field(default_factory=list)
    declared: list[Diagnosis] = field(default_factory=list)


class Diagnoser(Protocol):
    """A diagnoser stepped once per estimator step by the loop (docs/plugins.md)."""

    def step(self, z: DiagnosisInput) -> DiagnosisStep:
        """The statistics, alarms and declarations after the measurements ``z`` of this step."""
        ...


def code_of(codes: dict[str, int], code: float) -> str:
    """The name of a trace ``code`` in ``codes`` (``""`` for 0 or an unknown code)."""
    names = {v: k for k, v in codes.items()}
    return names.get(int(code), "") if np.isfinite(code) else ""


def diagnoses_from_trace(trace: dict[str, np.ndarray]) -> list[Diagnosis]:
    """The declarations of a run rebuilt from its trace's :data:`DECLARATION_COLUMNS` (none without them):
    one at each row where ``diag_count`` grows. A tyre declared outside (0, 1] of its radius — a trace written
    before the record bounded tyre sizes — is left out: no tyre has that size."""
    if "diag_count" not in trace:
        return []
    count = np.nan_to_num(np.asarray(trace["diag_count"], float), nan=0.0)
    rows = np.flatnonzero(np.diff(np.concatenate([[0.0], count])) > 0)
    out = []
    for i in rows:
        component = code_of(COMPONENT_CODES, trace["diag_component"][i])
        if component == "tyre" and not 0.0 < float(trace["diag_size"][i]) <= 1.0:
            continue
        out.append(Diagnosis(
            component=component,
            target=code_of(TARGET_CODES, trace["diag_target"][i]),
            mode=code_of(MODE_CODES, trace["diag_mode"][i]),
            **{k: float(trace[f"diag_{k}"][i]) for k in ("size", "sigma", "onset", "declared", "statistic",
                                                        "threshold")},
            **offset_from_trace(trace, i)))
    return out


def offset_from_trace(trace: dict[str, np.ndarray], i: int) -> dict[str, tuple[float, float]]:
    """Row ``i``'s declaration offset and its σ (:data:`OFFSET_COLUMNS`) as :class:`Diagnosis` keywords; none
    when the trace has no such columns (written before them) or the record had no offset (NaN)."""
    if any(c not in trace for c in OFFSET_COLUMNS):
        return {}
    x, y, sx, sy = (float(trace[c][i]) for c in OFFSET_COLUMNS)
    if not np.isfinite(x):
        return {}
    return {"offset": (x, y), "offset_sigma": (sx, sy)}
