"""A plug-in fault class: a tyre losing grip (an oil patch, a worn or iced tread), registered as
``grip_loss``. A benchmark definition file that names this module in ``plugins`` can draw it
(``[fault] classes = { grip_loss = … }`` with a ``grip_loss = [low, high]`` range of the fraction lost);
a run config sets one in a ``[[faults.plugin]]`` table::

    plugins = ["grip_fault"]
    [[faults.plugin]]
    fault_class = "grip_loss"
    target = "right"
    onset = 5.0
    size = 0.6            # 60 % of the tyre's sliding friction coefficient lost

Its physics is a new effect (:class:`GripEffect`) beside the class: from the onset, the right or left
tyre's sliding friction coefficient (MuJoCo ``geom_friction[:, 0]`` of its collision sphere, which
imposes its friction on the floor contact) is scaled by ``1 − size``; several on one tyre multiply. The
plants call only the effect's ``prepare``/``healthy``/``apply``/``truth``, so no plant module changes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import ftc_mj
from ftc_mj.plant.faults import WHEELS, Effect, Param, PlantFault


class GripEffect(Effect):
    """Each tyre's remaining fraction of its sliding friction coefficient (right first)."""

    columns = ("fault_grip_R", "fault_grip_L")

    def prepare(self, plant: Any) -> None:
        if plant.kind == "mujoco":
            plant.fault_memo["grip"] = plant.model.geom_friction[list(plant.layout.sphere_geoms), 0].copy()

    def healthy(self) -> list[float]:
        return [1.0, 1.0]

    def apply(self, plant: Any, state: list[float]) -> None:
        mu = plant.fault_memo["grip"]
        for i, geom in enumerate(plant.layout.sphere_geoms):
            plant.model.geom_friction[geom, 0] = state[i] * mu[i]

    def truth(self, state: list[float]) -> dict[str, float]:
        return dict(zip(self.columns, state, strict=True))


class GripLoss(PlantFault):
    """A tyre losing a fraction ``size`` of its sliding friction coefficient from ``onset`` on."""

    name = "grip_loss"
    component = "tyre"
    mode = "grip loss"
    targets = WHEELS
    unit = ""
    params: Mapping[str, Param] = {"lost": Param("", 0.0, 1.0, "fraction of the sliding friction lost",
                                                 high_open=True)}
    observed_by = ("speed", "yaw_rate", "position")
    drawn_as: Mapping[str, tuple[str, ...]] = {"grip_loss": ("grip_loss",)}
    effect = GripEffect()
    plants = ("mujoco",)

    def combine(self, state: list[float]) -> None:
        state[WHEELS.index(self.target)] *= 1.0 - self.size

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return ("fault_grip_R",) if target == "right" else ("fault_grip_L",)

    @classmethod
    def draw(cls, kind: str, sample: Any, sign: float) -> dict[str, float]:
        """The fraction lost, uniform in the definition's ``grip_loss`` range (no sign)."""
        return {"size": round(sample("grip_loss"), 4)}


ftc_mj.register_fault_class("grip_loss", GripLoss)
