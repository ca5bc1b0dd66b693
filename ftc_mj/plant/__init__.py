"""The truth plant: MuJoCo robot (or the ideal kinematic model), tyre-fault schedules, servo faults
(:mod:`.actuator_faults`), noisy sensors and their faults (:mod:`.sensor_faults`); every configured fault as
a record: :func:`.faults.fault_list`.

Public API::

    plant = build_plant(cfg)            # Plant (MuJoCo) or KinematicPlant, by cfg.plant.kind
    plant = plant_from_settings({"kind": "kinematic"}, robot=None, faults={"left": [[10, 2], [10, 1]]})
    plant = Plant(cfg.plant, cfg.robot, cfg.faults)   # from the sections (any objects with their fields)
    sensors = Sensors(cfg.sensors, seed=cfg.seed)
    plant.set_command(wR, wL); plant.advance(10); tr = plant.truth(); z = sensors.read(tr)
"""

from __future__ import annotations

from .builder import build_model, load_spec
from .factory import build_plant, make_plant, plant_from_settings
from .faults import RadiusSchedule
from .kinematic import KinematicPlant
from .robot import Plant
from .sensors import SensorReading, Sensors
from .truth import (
    FLAG_NAMES,
    LARGE_ROLL,
    LIFTOFF,
    NAN,
    PHYSICS_WARNING,
    SCRAPE,
    SLIP,
    TIPPED,
    UNSTABLE,
    Truth,
    flag_names,
)

__all__ = [
    "FLAG_NAMES",
    "LARGE_ROLL",
    "LIFTOFF",
    "NAN",
    "PHYSICS_WARNING",
    "SCRAPE",
    "SLIP",
    "TIPPED",
    "UNSTABLE",
    "KinematicPlant",
    "Plant",
    "RadiusSchedule",
    "SensorReading",
    "Sensors",
    "Truth",
    "build_model",
    "build_plant",
    "flag_names",
    "load_spec",
    "make_plant",
    "plant_from_settings",
]
