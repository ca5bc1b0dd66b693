"""Every configured fault as an object of its class (:func:`faults_of`) and as a record
(:func:`fault_list`: class, target, onset, size), the truth a scorer judges FDI against."""

from __future__ import annotations

from dataclasses import dataclass

from .base import FaultClass, PlantFault, SensorFault, fault_class
from .sensor import SENSOR_CLASSES
from .servo import SERVO_CLASSES
from .settings import FaultSettings
from .tyre import Puncture, RadiusSchedule, WheelSchedule, schedule_onset


@dataclass(frozen=True)
class FaultSpec:
    """One configured fault: its class (a registered name, :data:`ftc_mj.registry.fault_classes`), what it
    hits (``"right"``/``"left"`` wheel, ``"speed"``/``"yaw_rate"`` sensor), its onset (s) and its size in
    the class's unit: the radius lost (m, nominal minus the radius farthest from it; positive = deflated)
    of a puncture; the fraction of the servo lost (1 − effectiveness; 1 for a lock or an unresponsive
    servo); the bias (m/s, rad/s), the drift rate (m/s², rad/s²) or the dropout's duration (s) of a sensor
    fault; a plug-in class's size."""

    fault_class: str
    target: str
    onset: float
    size: float

    def describe(self) -> str:
        """``actuator_loss on left, size 0.5`` (with the unit when the size has one)."""
        unit = fault_class(self.fault_class).unit
        return f"{self.fault_class} on {self.target}, size {self.size:g}{' ' + unit if unit else ''}"


def wheel_schedules(faults: FaultSettings, nominal: float) -> tuple[RadiusSchedule, RadiusSchedule]:
    """The radius schedules ``(right, left)`` of the fault settings around the ``nominal`` radius (m)."""
    return (RadiusSchedule(faults.right, nominal, "faults.right"),
            RadiusSchedule(faults.left, nominal, "faults.left"))


def faults_of(faults: FaultSettings, nominal_radius: float) -> list[FaultClass]:
    """Every fault of the settings (``[faults]``) around the plant's ``nominal_radius`` (m) as an object of
    its class: the punctures (right, then left; a wheel whose schedule never departs from nominal has
    none), then :func:`table_faults`."""
    out: list[FaultClass] = []
    for wheel, bps in (("right", faults.right), ("left", faults.left)):
        if schedule_onset(bps, nominal_radius) is not None:
            out.append(Puncture(WheelSchedule(wheel=wheel, breakpoints=bps, nominal=nominal_radius)))
    return out + table_faults(faults)


def table_faults(faults: FaultSettings) -> list[FaultClass]:
    """The faults of the settings' tables: servo, sensor and plug-in faults in the order configured."""
    out: list[FaultClass] = [SERVO_CLASSES[a.kind](a) for a in faults.actuator]
    out += [SENSOR_CLASSES[f.fault_class](f) for f in faults.sensor]
    return out + [fault_class(p.fault_class)(p) for p in faults.plugin]


def fault_list(faults: FaultSettings, nominal_radius: float) -> list[FaultSpec]:
    """Every fault of the settings as a record (:func:`faults_of`'s order)."""
    return [FaultSpec(f.name, f.target, f.onset, f.size) for f in faults_of(faults, nominal_radius)]


def plant_faults_of(faults: FaultSettings) -> list[PlantFault]:
    """The faults acting on the plant through an effect (servo and plug-in plant faults; the plants apply
    the punctures' radius schedules themselves), in configuration order."""
    return [f for f in table_faults(faults) if isinstance(f, PlantFault)]


def sensor_faults_of(faults: FaultSettings | None) -> list[SensorFault]:
    """The faults acting on the sensors' readings, in configuration order (none for ``None``)."""
    return [] if faults is None else [f for f in table_faults(faults) if isinstance(f, SensorFault)]
