"""Faults of the speed sensor and the yaw-rate gyro (bias, drift, dropout) and of the pose sensor (bias, jump,
dropout).

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

The pose sensor's fix ``(x, y, psi)`` (:mod:`ftc_mj.model.sensors`) takes an offset of ``size`` metres as a
displacement of its position by ``size`` m along the 45° diagonal (north-east for ``size > 0``: the offset a
wrong datum or a lever arm gives, in the world frame) with its heading untouched:

- ``bias`` (m): a constant displacement for the whole run — a mis-surveyed base station or antenna offset.
- ``jump`` (m): a displacement for ``duration`` seconds, then the fix returns — a multipath or re-acquisition
  step (a GNSS receiver settling on a wrong solution).
- ``dropout``: no fix is delivered (the filter predicts; the controller's pose is its estimate, or without a
  filter the last fix held).

Faults on one sensor add (their offsets sum; a dropout hides them). At a sample time ``t`` (s) a fault
acts when ``onset ≤ t < onset + duration`` (to 1 ns). The classes: ``speed_bias``, ``speed_drift``,
``speed_dropout``, ``gyro_bias``, ``gyro_drift``, ``gyro_dropout``, ``pose_bias``, ``pose_jump``,
``pose_dropout`` (:data:`SENSOR_CLASSES`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import model_validator

from ... import registry
from ...fields import FiniteFloat, StrictModel, ranged
from .base import Param, Sample, SensorFault
from .servo import FaultTime

SENSORS = ("speed", "yaw_rate", "pose")
"""The sensors that can fail (``faults.sensor[i].sensor``)."""
SENSOR_MODES: dict[str, tuple[str, ...]] = {"speed": ("bias", "drift", "dropout"),
                                            "yaw_rate": ("bias", "drift", "dropout"),
                                            "pose": ("bias", "jump", "dropout")}
"""The fault modes of each sensor."""
POSE_DIRECTION = (math.sqrt(0.5), math.sqrt(0.5))
"""The unit vector (world x, y) along which a pose fault's offset displaces the fix."""

SENSOR_COLUMNS: dict[str, tuple[str, str]] = {s: (f"fault_{s}_offset", f"fault_{s}_dropout") for s in SENSORS}
"""Trace columns of a run with faults of each sensor: the injected offset (m/s, rad/s or m; 0 without one)
and the dropout flag (1 while the samples are missing, else 0)."""

_EPS_T = 1e-9
_PREFIX = {"speed": "speed", "yaw_rate": "gyro", "pose": "pose"}
_UNIT = {"speed": "m/s", "yaw_rate": "rad/s", "pose": "m"}
_COMPONENT = {"speed": "speed sensor", "yaw_rate": "gyro", "pose": "pose sensor"}
_OBSERVED_BY = {"speed": ("speed",), "yaw_rate": ("yaw_rate",), "pose": ("position",)}


class SensorFaultSettings(StrictModel):
    """One fault of a sensor (``[[faults.sensor]]``) from ``onset`` for ``duration`` seconds.

    ``bias``: a constant offset ``size`` (m/s for the speed sensor, rad/s for the gyro, m for the pose sensor);
    ``drift``: an offset growing at ``size`` per second (m/s², rad/s²) from 0 at the onset; ``jump`` (pose
    sensor): a displacement of ``size`` m for ``duration`` s; ``dropout``: the samples are missing (NaN in the
    reading, no pose fix; the filters update with the channels present). The physics of each:
    :mod:`ftc_mj.plant.faults.sensor`.
    """

    sensor: Literal["speed", "yaw_rate", "pose"]
    kind: Literal["bias", "drift", "jump", "dropout"]
    onset: FaultTime
    size: FiniteFloat | None = None
    """``bias``: the offset (m/s or rad/s); ``drift``: its growth rate (m/s² or rad/s²); not for ``dropout``."""
    duration: ranged(0.0, 1.0e9, lo_open=True, unit="s") = 1.0e9
    """How long the fault lasts (s); the default outlasts any run (at most 3600 s)."""

    @model_validator(mode="after")
    def _size_for_offsets(self) -> SensorFaultSettings:
        """A mode of the sensor (:data:`SENSOR_MODES`); ``size`` is given for an offset and not for a ``dropout``."""
        if self.kind not in SENSOR_MODES[self.sensor]:
            raise ValueError(f"kind: {self.kind!r} is not a fault of the {self.sensor} sensor "
                             f"({', '.join(SENSOR_MODES[self.sensor])})")
        if self.kind != "dropout" and self.size is None:
            raise ValueError(f"size: a {self.kind!r} needs its size (m/s or rad/s; per second for a drift)")
        if self.kind == "dropout" and self.size is not None:
            raise ValueError("size: a 'dropout' has no size (its samples are missing)")
        return self

    @property
    def target(self) -> str:
        """What the fault hits: the sensor."""
        return self.sensor

    @property
    def fault_class(self) -> str:
        """The registered class of this table (``speed_bias``, ``gyro_dropout`` …)."""
        return f"{_PREFIX[self.sensor]}_{self.kind}"


class BuiltinSensorFault(SensorFault):
    """A built-in sensor fault (``[[faults.sensor]]``) of the sensor :attr:`sensor`."""

    sensor: str = "speed"
    Settings = SensorFaultSettings

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return SENSOR_COLUMNS[target][:1]

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        """A ``[[faults.sensor]]`` table."""
        table: dict[str, Any] = {"sensor": target, "kind": cls.mode, "onset": onset}
        if cls.mode == "dropout":
            table["duration"] = drawn["duration"]
        else:
            table["size"] = drawn["size"]
        faults.setdefault("sensor", []).append(table)


class Bias(BuiltinSensorFault):
    """A constant offset on the reading."""

    mode = "bias"

    def reading(self, elapsed: float) -> tuple[float, bool]:
        return float(self.settings.size), False

    @classmethod
    def offset_profile(cls, size: float, elapsed: Any) -> Any:
        return size * np.ones_like(elapsed)


class Drift(BuiltinSensorFault):
    """An offset growing linearly from 0 at the onset."""

    mode = "drift"

    def reading(self, elapsed: float) -> tuple[float, bool]:
        return float(self.settings.size) * max(elapsed, 0.0), False

    @classmethod
    def offset_profile(cls, size: float, elapsed: Any) -> Any:
        return size * elapsed


class Jump(Bias):  # a bias's constant offset (reading, offset profile) over the jump's duration
    """A displacement for a while, then the fix returns."""

    mode = "jump"

    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        """The jump's size (m, random sign) and duration (s)."""
        return {"size": round(sign * sample(kind), 5), "duration": round(sample(f"{kind}_duration"), 3)}

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        """A ``[[faults.sensor]]`` table with its size and duration."""
        faults.setdefault("sensor", []).append({"sensor": target, "kind": cls.mode, "onset": onset,
                                                "size": drawn["size"], "duration": drawn["duration"]})


class Dropout(BuiltinSensorFault):
    """The samples are missing (NaN)."""

    mode = "dropout"
    params: Mapping[str, Param] = {"duration": Param("s", 0.0, 1.0e9, "how long the samples are missing",
                                                     low_open=True)}

    @property
    def size(self) -> float:
        return self.duration

    def reading(self, elapsed: float) -> tuple[float, bool]:
        return 0.0, True

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return SENSOR_COLUMNS[target][1:]

    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        """The dropout's duration (s)."""
        return {"size": 0.0, "duration": round(sample("dropout_duration"), 3)}


def _sensor_class(base: type[BuiltinSensorFault], sensor: str) -> type[BuiltinSensorFault]:
    """``base`` on ``sensor``: its name, component, unit, ranges and drawn name."""
    name = f"{_PREFIX[sensor]}_{base.mode}"
    unit = {"bias": _UNIT[sensor], "drift": _UNIT[sensor] + "²", "jump": _UNIT[sensor], "dropout": "s"}[base.mode]
    params = getattr(base, "params", None) or {
        "size": Param(unit, -1.0e6, 1.0e6, "the offset's growth rate" if base.mode == "drift" else "the offset")}
    if base.mode == "jump":
        params = {**params, "duration": Param("s", 0.0, 1.0e9, "how long the fix is displaced", low_open=True)}
    ranges = {"dropout": ("dropout_duration",), "jump": (name, f"{name}_duration")}.get(base.mode, (name,))
    attrs = {"name": name, "sensor": sensor, "component": _COMPONENT[sensor],
             "targets": (sensor,), "unit": unit, "params": params, "observed_by": _OBSERVED_BY[sensor],
             "drawn_as": {name: ranges}, "__doc__": f"The {sensor} sensor: {base.__doc__[0].lower()}{base.__doc__[1:]}",
             "config": f'`[[faults.sensor]]` `sensor = "{sensor}"`, `kind = "{base.mode}"`'}
    return type("".join(p.capitalize() for p in name.split("_")), (base,), attrs)


_MODE_CLASSES = {"bias": Bias, "drift": Drift, "jump": Jump, "dropout": Dropout}
SENSOR_CLASSES: dict[str, type[BuiltinSensorFault]] = {
    c.name: c for c in (_sensor_class(_MODE_CLASSES[m], s) for s in SENSORS for m in SENSOR_MODES[s])}
"""The sensor fault classes by name (the ``fault_class`` of a ``[[faults.sensor]]`` table)."""

for _cls in SENSOR_CLASSES.values():
    registry.fault_classes.register(_cls.name, _cls, origin=registry.BUILTIN)


class SensorFaults:
    """The sensor faults of a run as a function of the sample time (module docstring).

    Args:
        faults: the run's sensor faults (:class:`~ftc_mj.plant.faults.base.SensorFault` objects).
    """

    __slots__ = ("faults", "sensors")

    def __init__(self, faults: Sequence[SensorFault]) -> None:
        self.faults = tuple(faults)
        self.sensors = tuple(s for s in SENSORS if any(f.target == s for f in self.faults))
        """The sensors with a fault, in :data:`SENSORS` order."""

    def __bool__(self) -> bool:
        return bool(self.faults)

    def effect(self, sensor: str, t: float) -> tuple[float, bool]:
        """The offset (m/s or rad/s) added to ``sensor``'s reading at ``t`` (s) and whether it is missing."""
        offset = 0.0
        missing = False
        for f in self.faults:
            if f.target != sensor or not f.onset <= t + _EPS_T < f.onset + f.duration:
                continue
            off, gone = f.reading(t - f.onset)
            if gone:
                missing = True
            else:
                offset += off
        return offset, missing

    def apply(self, t: float, speed: float, yaw_rate: float | None) -> tuple[float, float | None]:
        """The readings at ``t`` (s) with the faults: offsets added, a missing sample NaN."""
        off, missing = self.effect("speed", t)
        speed = math.nan if missing else speed + off
        if yaw_rate is not None:
            off, missing = self.effect("yaw_rate", t)
            yaw_rate = math.nan if missing else yaw_rate + off
        return speed, yaw_rate

    def pose(self, t: float, fix: np.ndarray) -> np.ndarray | None:
        """The pose sensor's fix ``[x, y, psi]`` (m, m, rad) at ``t`` (s) with the faults: displaced by the
        offsets along :data:`POSE_DIRECTION`, ``None`` while it drops out."""
        off, missing = self.effect("pose", t)
        if missing:
            return None
        if off:
            fix = fix + np.array([off * POSE_DIRECTION[0], off * POSE_DIRECTION[1], 0.0])
        return fix

    def truth(self, t: float) -> dict[str, float]:
        """The trace values (:data:`SENSOR_COLUMNS` of the faulty sensors) at ``t`` (s)."""
        out: dict[str, float] = {}
        for s in self.sensors:
            off, missing = self.effect(s, t)
            off_col, drop_col = SENSOR_COLUMNS[s]
            out[off_col], out[drop_col] = off, float(missing)
        return out
