"""The plant and its sensors from the application config (was ``ftc_mj.plant.factory``).

:func:`build_plant` takes a run config apart into the plant, robot and fault settings; :func:`build_sensors`
into the sensor settings, the seed and the faults; :func:`plant_from_settings` validates those sections on
their own (no run config is built), for use without a run.
"""

from __future__ import annotations

from typing import Any

from ..config import RunConfig, section
from ..plant.kinematic import KinematicPlant
from ..plant.robot import Plant
from ..plant.sensors import Sensors
from ..plant.settings import FaultSettings, PlantSettings, RobotSettings


def make_plant(plant: PlantSettings, robot: RobotSettings, faults: FaultSettings) -> Plant | KinematicPlant:
    """The plant ``plant.kind`` selects: ``"mujoco"`` -> :class:`Plant`, ``"kinematic"`` -> :class:`KinematicPlant`."""
    if plant.kind == "kinematic":
        return KinematicPlant(plant, robot, faults)
    return Plant(plant, robot, faults)


def build_plant(cfg: RunConfig) -> Plant | KinematicPlant:
    """The truth plant of the run ``cfg`` (``cfg.plant.kind`` selects it)."""
    return make_plant(cfg.plant, cfg.robot, cfg.faults)


def build_sensors(cfg: RunConfig) -> Sensors:
    """The run's sensors: their noise settings, the run's seed and the faults acting on their readings."""
    return Sensors(cfg.sensors, cfg.seed, cfg.faults)


def plant_from_settings(plant: Any = None, robot: Any = None, faults: Any = None) -> Plant | KinematicPlant:
    """The truth plant built from its own settings, without a run config: the ``[plant]``, ``[robot]`` and
    ``[faults]`` sections (models, plain tables or ``None`` = the defaults; :class:`~ftc_mj.errors.BadInput`
    naming the field). The same plant a run with these sections gets."""
    return make_plant(section(PlantSettings, plant, "plant"), section(RobotSettings, robot, "robot"),
                      section(FaultSettings, faults, "faults"))
