"""Tyre-puncture fault profiles (piecewise-linear wheel radius against time), and every configured fault as a
record (:func:`fault_list`: punctures, servo faults, sensor faults), the truth a scorer judges FDI against.

A schedule is a list of ``(t, r)`` breakpoints (s, m). Before the first breakpoint the radius is the nominal one;
between breakpoints it is interpolated linearly; after the last it is held. Two breakpoints at the same time make a
step (the value jumps; the schedule is right-continuous, so at the step time the new value already holds). If the
first breakpoint's radius differs from the nominal radius, that is a step at the first breakpoint's time.

Scenario 4's ramp ``R_L(t) = 2 - 0.1 (t - 10)`` down to 0.1 m is ``[(10, 2.0), (29, 0.1)]``.

Evaluation is pure Python on scalars (a ``bisect`` plus one interpolation, well under 1 µs), and
:meth:`RadiusSchedule.changing` tells the plant whether the radius can differ between two times, so the plant can
step the physics in one call when nothing changes.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from ..errors import BadInput
from .settings import FaultSettings

EPS_T = 1e-9
"""Tolerance (s): schedules are looked up at ``k * dt + EPS_T`` so that breakpoints on step times are hit
robustly."""

_WHEEL_INDEX = {"right": 0, "r": 0, "R": 0, "left": 1, "l": 1, "L": 1}


def wheel_index(wheel: str) -> int:
    """0 for ``"right"``/``"R"``, 1 for ``"left"``/``"L"``; ``ValueError`` otherwise."""
    try:
        return _WHEEL_INDEX[wheel]
    except KeyError:
        raise ValueError(f"wheel must be 'right' or 'left' (or 'R'/'L'), got {wheel!r}") from None


def schedule_onset(breakpoints: Sequence[Sequence[float]], nominal: float) -> float | None:
    """The fault onset of one wheel's schedule: the first time (s) its radius departs from ``nominal``
    (m) by more than 1 nm; ``None`` = no fault. The one definition of an onset (metrics, reports).

    Before its first breakpoint a schedule is at the nominal radius, so a departure at breakpoint ``i``
    starts at breakpoint ``i-1`` (the start of a ramp, or the same time for a step). The time may lie
    after the end of a run.
    """
    for i, (t, r) in enumerate(breakpoints):
        if abs(float(r) - nominal) > 1e-9:
            return float(breakpoints[i - 1][0]) if i > 0 else float(t)
    return None


class RadiusSchedule:
    """Piecewise-linear radius ``r(t)`` (m) of one wheel.

    Args:
        breakpoints: ``[(t, r), ...]`` with times (s) non-decreasing and >= 0, radii (m) > 0, at most two
            breakpoints at one time. Empty = no fault (constant nominal radius).
        nominal: radius (m) before the first breakpoint.
        name: label used in error messages (e.g. ``faults.left``).

    Raises:
        BadInput: (a ``ValueError``) for an invalid schedule.
    """

    __slots__ = ("nominal", "name", "_t", "_r", "_intervals", "_t_end")

    def __init__(self, breakpoints: Iterable[Sequence[float]], nominal: float, name: str = "faults") -> None:
        nominal = float(nominal)
        if not (math.isfinite(nominal) and nominal > 0):
            raise BadInput(f"{name}: nominal radius {nominal} must be finite and > 0")
        pts: list[tuple[float, float]] = []
        for i, bp in enumerate(breakpoints):
            if len(bp) != 2:
                raise BadInput(f"{name}[{i}]: a breakpoint is [t, radius]")
            t, r = float(bp[0]), float(bp[1])
            if not (math.isfinite(t) and math.isfinite(r)):
                raise BadInput(f"{name}[{i}]: breakpoints must be finite")
            if t < 0:
                raise BadInput(f"{name}[{i}]: breakpoint time {t} is negative")
            if r <= 0:
                raise BadInput(f"{name}[{i}]: radius {r} must be > 0")
            if pts and t < pts[-1][0]:
                raise BadInput(f"{name}[{i}]: breakpoint times must be non-decreasing ({t} after {pts[-1][0]})")
            if len(pts) >= 2 and pts[-1][0] == pts[-2][0] == t:
                raise BadInput(f"{name}[{i}]: more than two breakpoints at t={t}")
            pts.append((t, r))
        self.nominal = nominal
        self.name = name
        self._t = [p[0] for p in pts]
        self._r = [p[1] for p in pts]
        # Intervals [a, b] over which the value changes: ramps (a < b) and steps (a == b).
        iv: list[tuple[float, float]] = []
        if pts and pts[0][1] != nominal:
            iv.append((pts[0][0], pts[0][0]))
        for (t0, r0), (t1, r1) in zip(pts, pts[1:], strict=False):
            if r0 != r1:
                iv.append((t0, t1))
        self._intervals = iv
        self._t_end = iv[-1][1] if iv else -math.inf

    # ------------------------------------------------------------------ queries
    @property
    def breakpoints(self) -> list[tuple[float, float]]:
        """The validated breakpoints ``[(t, r), ...]`` (s, m)."""
        return list(zip(self._t, self._r, strict=True))

    @property
    def active(self) -> bool:
        """True if the radius ever departs from a constant (the schedule has a change)."""
        return bool(self._intervals)

    @property
    def end_time(self) -> float:
        """Time (s) after which the radius is constant (``-inf`` if it never changes)."""
        return self._t_end

    @property
    def final(self) -> float:
        """Radius (m) held after the last breakpoint."""
        return self._r[-1] if self._r else self.nominal

    def value(self, t: float) -> float:
        """Radius (m) at time ``t`` (s); right-continuous at steps."""
        ts = self._t
        if not ts or t < ts[0]:
            return self.nominal
        if t >= ts[-1]:
            return self._r[-1]
        i = bisect_right(ts, t) - 1
        t0, t1 = ts[i], ts[i + 1]
        r0 = self._r[i]
        return r0 + (self._r[i + 1] - r0) * (t - t0) / (t1 - t0)

    __call__ = value

    def changing(self, t0: float, t1: float) -> bool:
        """True if ``value`` may differ between any two times in ``[t0, t1]`` (s), i.e. the plant must apply the
        schedule step by step over that window. A step at exactly ``t0`` is not a change within the window (its new
        value already holds at ``t0``)."""
        if t0 > self._t_end:
            return False
        for a, b in self._intervals:
            if a == b:
                if t0 < a <= t1:
                    return True
            elif a < t1 and b > t0:
                return True
        return False

    def __repr__(self) -> str:
        return f"RadiusSchedule({self.breakpoints!r}, nominal={self.nominal})"


def wheel_schedules(faults: FaultSettings, nominal: float) -> tuple[RadiusSchedule, RadiusSchedule]:
    """The radius schedules ``(right, left)`` of the fault settings around the ``nominal`` radius (m)."""
    return (RadiusSchedule(faults.right, nominal, "faults.right"),
            RadiusSchedule(faults.left, nominal, "faults.left"))


FAULT_UNITS: dict[str, str] = {
    "puncture": "m", "actuator_loss": "", "wheel_lock": "", "actuator_unresponsive": "",
    "speed_bias": "m/s", "speed_drift": "m/s²", "speed_dropout": "s",
    "gyro_bias": "rad/s", "gyro_drift": "rad/s²", "gyro_dropout": "s",
}
"""Every fault class and the unit of its :attr:`FaultSpec.size` (``""``: a fraction)."""

_ACTUATOR_CLASS = {"loss": "actuator_loss", "lock": "wheel_lock", "unresponsive": "actuator_unresponsive"}
_SENSOR_PREFIX = {"speed": "speed", "yaw_rate": "gyro"}


@dataclass(frozen=True)
class FaultSpec:
    """One configured fault: its class (a key of :data:`FAULT_UNITS`), what it hits (``"right"``/``"left"``
    wheel, ``"speed"``/``"yaw_rate"`` sensor), its onset (s) and its size in the class's unit: the radius
    lost (m, nominal minus the radius farthest from it; positive = deflated) of a puncture; the fraction of
    the servo lost (1 − effectiveness; 1 for a lock or an unresponsive servo); the bias (m/s, rad/s), the
    drift rate (m/s², rad/s²) or the dropout's duration (s) of a sensor fault."""

    fault_class: str
    target: str
    onset: float
    size: float

    def describe(self) -> str:
        """``actuator_loss on left, size 0.5`` (with the unit when the size has one)."""
        unit = FAULT_UNITS[self.fault_class]
        return f"{self.fault_class} on {self.target}, size {self.size:g}{' ' + unit if unit else ''}"


def fault_list(faults: FaultSettings, nominal_radius: float) -> list[FaultSpec]:
    """Every fault of the settings (``[faults]``) around the plant's ``nominal_radius`` (m): the punctures
    (right, then left; a wheel whose schedule never departs from nominal has none), then the servo faults
    and the sensor faults in the order they are configured."""
    out: list[FaultSpec] = []
    for wheel, bps in (("right", faults.right), ("left", faults.left)):
        onset = schedule_onset(bps, nominal_radius)
        if onset is not None:
            farthest = max((float(r) for _, r in bps), key=lambda r: abs(r - nominal_radius))
            out.append(FaultSpec("puncture", wheel, onset, nominal_radius - farthest))
    for a in faults.actuator:
        lost = 1.0 - float(a.effectiveness) if a.kind == "loss" else 1.0  # type: ignore[arg-type]
        out.append(FaultSpec(_ACTUATOR_CLASS[a.kind], a.wheel, float(a.onset), lost))
    for f in faults.sensor:
        size = float(f.duration) if f.kind == "dropout" else float(f.size)  # type: ignore[arg-type]
        out.append(FaultSpec(f"{_SENSOR_PREFIX[f.sensor]}_{f.kind}", f.sensor, float(f.onset), size))
    return out
