"""Tyre punctures: piecewise-linear wheel-radius profiles against time (:class:`RadiusSchedule`), their
configuration (``[faults] right/left``: :data:`Breakpoints`) and the fault class :class:`Puncture`.

A schedule is a list of ``(t, r)`` breakpoints (s, m). Before the first breakpoint the radius is the nominal one;
between breakpoints it is interpolated linearly; after the last it is held. Two breakpoints at the same time make a
step (the value jumps; the schedule is right-continuous, so at the step time the new value already holds). If the
first breakpoint's radius differs from the nominal radius, that is a step at the first breakpoint's time.

Scenario 4's ramp ``R_L(t) = 2 - 0.1 (t - 10)`` down to 0.1 m is ``[(10, 2.0), (29, 0.1)]``.

Evaluation is pure Python on scalars (a ``bisect`` plus one interpolation, well under 1 µs), and
:meth:`RadiusSchedule.changing` tells the plant whether the radius can differ between two times, so the plant can
step the physics in one call when nothing changes (the plants apply the schedules themselves: a radius is
their state, not an effect on top of it).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Iterable, Mapping, Sequence
from typing import Annotated, Any, Literal

from pydantic import Field

from ... import registry
from ...errors import BadInput
from ...fields import FiniteFloat, StrictModel
from .base import WHEELS, FaultClass, Param, Sample

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


Breakpoints = Annotated[list[tuple[FiniteFloat, FiniteFloat]], Field(max_length=10_000)]
"""One wheel's radius schedule in the configuration: ``[t, radius]`` breakpoints (s, m)."""


def check_schedule(v: Breakpoints) -> Breakpoints:
    """``v`` if its times (s) are finite, non-negative and non-decreasing with at most two breakpoints at
    one time (a step), and its radii (m) finite and positive; else ``ValueError`` saying which."""
    last = -math.inf
    for t, r in v:
        if not (math.isfinite(t) and math.isfinite(r)):
            raise ValueError("breakpoints must be finite")
        if t < 0:
            raise ValueError(f"breakpoint time {t} is negative")
        if r <= 0:
            raise ValueError(f"radius {r} must be > 0")
        if t < last:
            raise ValueError(f"breakpoint times must be non-decreasing ({t} after {last})")
        last = t
    times = [t for t, _ in v]
    for i in range(len(times) - 2):
        if times[i] == times[i + 1] == times[i + 2]:
            raise ValueError(f"more than two breakpoints at t={times[i]}")
    return v


class WheelSchedule(StrictModel):
    """One wheel's configured schedule: the wheel, its breakpoints (s, m) and the nominal radius (m)."""

    wheel: Literal["right", "left"]
    breakpoints: Breakpoints
    nominal: FiniteFloat


class Puncture(FaultClass):
    """A tyre losing radius: a step (a blow-out) or a ramp (a slow leak) of the wheel's radius schedule.
    Its size is the radius lost (m, nominal minus the radius farthest from it; positive = deflated)."""

    name = "puncture"
    component = "tyre"
    mode = "puncture"
    targets = WHEELS
    unit = "m"
    params: Mapping[str, Param] = {
        "radius_lost": Param("m", -100.0, 100.0, "nominal minus the radius farthest from it"),
        "remaining_fraction": Param("", 0.0, 1.0, "benchmark: remaining radius over nominal", low_open=True),
        "ramp_rate": Param("m/s", 0.0, 100.0, "benchmark: radius lost per second by a ramp", low_open=True)}
    observed_by = ("speed", "yaw_rate", "position")
    radius_fault = True
    drawn_as: Mapping[str, tuple[str, ...]] = {"puncture_step": ("puncture_fraction",),
                                               "puncture_ramp": ("ramp_final_fraction", "ramp_rate")}
    Settings = WheelSchedule
    config = "`faults.right` / `faults.left` breakpoints"

    @property
    def target(self) -> str:
        return str(self.settings.wheel)

    @property
    def onset(self) -> float:
        return schedule_onset(self.settings.breakpoints, self.settings.nominal)  # type: ignore[return-value]

    @property
    def size(self) -> float:
        R0 = self.settings.nominal
        return R0 - max((float(r) for _, r in self.settings.breakpoints), key=lambda r: abs(r - R0))

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return ("R_R",) if target == "right" else ("R_L",)

    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        """A step: the remaining radius fraction; a ramp: the final fraction and the rate (m/s)."""
        if kind == "puncture_step":
            return {"size": round(sample("puncture_fraction"), 4)}
        size = round(sample("ramp_final_fraction"), 4)
        return {"size": size, "rate": round(sample("ramp_rate"), 4)}

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        """The wheel's schedule: a step to ``size`` × nominal at the onset, or a ramp down to it at ``rate``."""
        f, R0 = drawn["size"], nominal
        end = onset if kind == "puncture_step" else onset + (1.0 - f) * R0 / drawn["rate"]
        faults[target] = [[onset, R0], [end, f * R0]]

    @classmethod
    def check_range(cls, name: str, low: float, high: float) -> None:
        """Remaining radius fractions must be > 0."""
        if name != "ramp_rate" and low <= 0:
            raise ValueError("puncture_fraction: remaining radius fractions must be > 0")


registry.fault_classes.register(Puncture.name, Puncture, origin=registry.BUILTIN)
