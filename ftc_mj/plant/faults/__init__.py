"""The fault classes, one module each kind: tyre punctures (:mod:`.tyre`), servo faults (:mod:`.servo`),
sensor faults (:mod:`.sensor`), plug-in classes' tables (:mod:`.plugin`); what a class is (:mod:`.base`);
the plant faults of a run over time (:mod:`.plant`); every configured fault as a record (:mod:`.records`).

Importing this package registers the built-in classes in :data:`ftc_mj.registry.fault_classes` (the
registry imports it on first use); a plug-in module registers its own with
``ftc_mj.register_fault_class(name, cls)`` (docs/plugins.md).
"""

from __future__ import annotations

from .base import (
    NEVER,
    WHEELS,
    Effect,
    FaultClass,
    Param,
    PlantFault,
    SensorFault,
    all_classes,
    drawn_classes,
    fault_class,
    onset_step,
)
from .plant import PlantFaults
from .plugin import PluginFaultSettings
from .records import (
    FaultSpec,
    fault_list,
    faults_of,
    plant_faults_of,
    sensor_faults_of,
    table_faults,
    wheel_schedules,
)
from .sensor import SENSOR_CLASSES, SENSOR_COLUMNS, SENSORS, SensorFaults, SensorFaultSettings
from .servo import ACTUATOR_COLUMNS, LOCK_SOLIMP, LOCK_TORQUE, SERVO_CLASSES, ActuatorFaultSettings, ServoEffect
from .settings import FaultSettings
from .tyre import EPS_T, Breakpoints, Puncture, RadiusSchedule, schedule_onset, wheel_index

__all__ = [
    "ACTUATOR_COLUMNS", "EPS_T", "LOCK_SOLIMP", "LOCK_TORQUE", "NEVER", "SENSORS", "SENSOR_CLASSES", "SENSOR_COLUMNS",
    "SERVO_CLASSES", "WHEELS", "ActuatorFaultSettings", "Breakpoints", "Effect", "FaultClass", "FaultSettings",
    "FaultSpec", "Param", "PlantFault", "PlantFaults", "PluginFaultSettings", "Puncture", "RadiusSchedule",
    "SensorFault", "SensorFaultSettings", "SensorFaults", "ServoEffect", "all_classes", "drawn_classes", "fault_class",
    "fault_list", "faults_of", "onset_step", "plant_faults_of", "schedule_onset", "sensor_faults_of", "table_faults",
    "wheel_index", "wheel_schedules",
]
