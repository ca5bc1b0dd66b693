"""The plant from the application config: the only module of :mod:`ftc_mj.plant` that reads it.

:func:`build_plant` takes a run config apart into the plant, robot and fault settings;
:func:`plant_from_settings` validates those sections on their own (no run config is built), for use without a
run. (The sensors need no factory: ``Sensors(cfg.sensors, cfg.seed)`` is already their own settings and the seed.)
"""

from __future__ import annotations

from typing import Any

from ..config import FaultConfig, PlantConfig, RobotConfig, RunConfig, section
from .kinematic import KinematicPlant
from .robot import Plant
from .settings import FaultSettings, PlantSettings, RobotSettings


def make_plant(plant: PlantSettings, robot: RobotSettings, faults: FaultSettings) -> Plant | KinematicPlant:
    """The plant ``plant.kind`` selects: ``"mujoco"`` -> :class:`Plant`, ``"kinematic"`` -> :class:`KinematicPlant`."""
    if plant.kind == "kinematic":
        return KinematicPlant(plant, robot, faults)
    return Plant(plant, robot, faults)


def build_plant(cfg: RunConfig) -> Plant | KinematicPlant:
    """The truth plant of the run ``cfg`` (``cfg.plant.kind`` selects it)."""
    return make_plant(cfg.plant, cfg.robot, cfg.faults)


def plant_from_settings(plant: Any = None, robot: Any = None, faults: Any = None) -> Plant | KinematicPlant:
    """The truth plant built from its own settings, without a run config: the ``[plant]``, ``[robot]`` and
    ``[faults]`` sections (objects, plain tables or ``None`` = the defaults; :class:`~ftc_mj.errors.BadInput`
    naming the field). The same plant a run with these sections gets."""
    return make_plant(section(PlantConfig, plant, "plant"), section(RobotConfig, robot, "robot"),
                      section(FaultConfig, faults, "faults"))
