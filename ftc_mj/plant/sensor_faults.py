"""Faults of the speed sensor and the yaw-rate gyro: bias, drift and dropout.

Each fault acts on one sensor's reading from ``onset`` for ``duration`` seconds (s), on top of the
truth and the sensor's Gaussian noise (the noise draws are the same with or without faults, so a
faulty run differs from its healthy twin by the fault alone):

- ``bias`` (``size`` m/s or rad/s): a constant offset — a speed sensor whose wheel or scale is
  mis-calibrated by a constant, a gyro whose zero-rate output jumped (a shock, a temperature step).
  The reading's mean shifts by ``size``; its noise is unchanged.
- ``drift`` (``size`` m/s² or rad/s²): an offset growing linearly from 0 at the onset, ``size (t −
  onset)`` — a gyro's bias instability or a warming sensor's zero drift.
- ``dropout``: the sensor delivers nothing — a loose connector, a bus that drops frames. The reading
  is NaN; the simulation loop hands the filter the channels still present (predict only when none is).

Faults on one sensor add (their offsets sum; a dropout hides them). At a sample time ``t`` (s) a fault
acts when ``onset ≤ t < onset + duration`` (to 1 ns).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .settings import SensorFaultSettings

SENSORS = ("speed", "yaw_rate")
"""The sensors that can fail (``faults.sensor[i].sensor``)."""

SENSOR_COLUMNS: dict[str, tuple[str, str]] = {s: (f"fault_{s}_offset", f"fault_{s}_dropout") for s in SENSORS}
"""Trace columns of a run with faults of each sensor: the injected offset (m/s or rad/s; 0 without one)
and the dropout flag (1 while the samples are missing, else 0)."""

_EPS_T = 1e-9


class SensorFaults:
    """The sensor faults of a run as a function of the sample time (module docstring).

    Args:
        faults: the ``[[faults.sensor]]`` tables (:class:`~ftc_mj.plant.settings.SensorFaultSettings`).
    """

    __slots__ = ("faults", "sensors")

    def __init__(self, faults: Sequence[SensorFaultSettings]) -> None:
        self.faults = tuple(faults)
        self.sensors = tuple(s for s in SENSORS if any(f.sensor == s for f in self.faults))
        """The sensors with a fault, in :data:`SENSORS` order."""

    def __bool__(self) -> bool:
        return bool(self.faults)

    def effect(self, sensor: str, t: float) -> tuple[float, bool]:
        """The offset (m/s or rad/s) added to ``sensor``'s reading at ``t`` (s) and whether it is missing."""
        offset = 0.0
        missing = False
        for f in self.faults:
            if f.sensor != sensor or not f.onset <= t + _EPS_T < f.onset + f.duration:
                continue
            if f.kind == "bias":
                offset += float(f.size)  # type: ignore[arg-type]
            elif f.kind == "drift":
                offset += float(f.size) * max(t - f.onset, 0.0)  # type: ignore[arg-type]
            else:
                missing = True
        return offset, missing

    def apply(self, t: float, speed: float, yaw_rate: float | None) -> tuple[float, float | None]:
        """The readings at ``t`` (s) with the faults: offsets added, a missing sample NaN."""
        off, missing = self.effect("speed", t)
        speed = math.nan if missing else speed + off
        if yaw_rate is not None:
            off, missing = self.effect("yaw_rate", t)
            yaw_rate = math.nan if missing else yaw_rate + off
        return speed, yaw_rate

    def truth(self, t: float) -> dict[str, float]:
        """The trace values (:data:`SENSOR_COLUMNS` of the faulty sensors) at ``t`` (s)."""
        out: dict[str, float] = {}
        for s in self.sensors:
            off, missing = self.effect(s, t)
            off_col, drop_col = SENSOR_COLUMNS[s]
            out[off_col], out[drop_col] = off, float(missing)
        return out
