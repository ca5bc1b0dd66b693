"""The plant faults of a run over time: :class:`PlantFaults` groups the run's
:class:`~ftc_mj.plant.faults.base.PlantFault` objects by their effect, tells the plant the physics step at
which the next one starts, and gives each effect's state at a step. The plants call only
:meth:`PlantFaults.state`, :meth:`~PlantFaults.apply`, :meth:`~PlantFaults.truth` and
:meth:`~PlantFaults.next_step`, so a new effect touches neither them nor their base class."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .base import NEVER, Effect, PlantFault, onset_step


class PlantFaults:
    """The plant faults of a run (in configuration order) and their effects.

    Args:
        faults: the run's plant faults.
        dt: the physics step (s).
    """

    __slots__ = ("faults", "dt", "effects", "columns", "_steps", "_onsets")

    def __init__(self, faults: Sequence[PlantFault], dt: float) -> None:
        self.faults = tuple(faults)
        self.dt = float(dt)
        effects: list[Effect] = []
        for f in self.faults:
            if not any(f.effect is e for e in effects):
                effects.append(f.effect)
        self.effects = tuple(effects)
        """The effects of the run's faults, in the order of their first fault."""
        self.columns: tuple[str, ...] = tuple(c for e in self.effects for c in e.columns)
        """The trace columns of the effects (none without a plant fault)."""
        self._onsets = [onset_step(f.onset, self.dt) for f in self.faults]
        self._steps = sorted(set(self._onsets))

    def __bool__(self) -> bool:
        return bool(self.faults)

    def prepare(self, plant: Any) -> None:
        """Let each effect remember the healthy plant it restores."""
        for e in self.effects:
            e.prepare(plant)

    def next_step(self, k: int) -> int:
        """The first physics step after ``k`` at which a fault starts (:data:`NEVER` if none does)."""
        for s in self._steps:
            if s > k:
                return s
        return NEVER

    def healthy(self) -> list[Any]:
        """Each effect's state without a fault."""
        return [e.healthy() for e in self.effects]

    def state(self, k: int) -> list[Any]:
        """Each effect's state at physics step ``k``: the faults started by then combined in order."""
        states = self.healthy()
        for f, step in zip(self.faults, self._onsets, strict=True):
            if step <= k:
                f.combine(states[next(i for i, e in enumerate(self.effects) if e is f.effect)])
        return states

    def apply(self, plant: Any, states: list[Any]) -> None:
        """Put each effect's state in force on ``plant``."""
        for e, s in zip(self.effects, states, strict=True):
            e.apply(plant, s)

    def truth(self, states: list[Any]) -> dict[str, float]:
        """The trace values of the effects' states (:attr:`columns`)."""
        out: dict[str, float] = {}
        for e, s in zip(self.effects, states, strict=True):
            out.update(e.truth(s))
        return out
