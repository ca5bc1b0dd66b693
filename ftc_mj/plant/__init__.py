"""The truth plant: MuJoCo robot (or the ideal kinematic model), noisy sensors, and the fault classes that
act on them (:mod:`.faults`: tyre punctures, servo faults, sensor faults, plug-in classes); the plant's
settings models (:mod:`.settings`).

Public API (the names load their module on first use, so the settings models import no MuJoCo)::

    plant = Plant(cfg.plant, cfg.robot, cfg.faults)   # from its settings models
    plant = KinematicPlant(cfg.plant, cfg.robot, cfg.faults)
    sensors = Sensors(cfg.sensors, seed=cfg.seed, faults=cfg.faults)
    plant.set_command(wR, wL); plant.advance(10); tr = plant.truth(); z = sensors.read(tr)

The plant of a run config (``plant.kind`` selects it): :func:`ftc_mj.wiring.plant.build_plant`.
"""

from __future__ import annotations

import importlib
from typing import Any

_NAMES = {
    "build_model": "builder", "load_spec": "builder", "RadiusSchedule": "faults", "KinematicPlant": "kinematic",
    "Plant": "robot", "SensorReading": "sensors", "Sensors": "sensors",
    **dict.fromkeys(("FLAG_NAMES", "LARGE_ROLL", "LIFTOFF", "NAN", "PHYSICS_WARNING", "SCRAPE", "SLIP", "TIPPED",
                     "UNSTABLE", "Truth", "flag_names"), "truth"),
}

__all__ = sorted(_NAMES)


def __getattr__(name: str) -> Any:
    if name in _NAMES:
        return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
