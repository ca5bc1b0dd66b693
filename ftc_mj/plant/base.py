"""What every truth plant shares: its clock (physics steps of ``dt`` seconds), its current wheel radii and
the plant faults it applies at their onset steps (:class:`~ftc_mj.plant.faults.plant.PlantFaults`: each
fault class's effect puts its state in force, so a new effect touches no plant)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

from .faults.base import NEVER
from .faults.plant import PlantFaults
from .faults.records import plant_faults_of
from .faults.settings import FaultSettings
from .truth import describe_flags


class PlantClock(ABC):
    """Base of the truth plants: ``dt`` (s), the step count ``_k`` and the radii ``_radius`` (m) that a
    subclass keeps, read through :attr:`time`, :attr:`steps` and :attr:`radii`."""

    kind = ""
    """``"mujoco"`` or ``"kinematic"`` (the ``plant.kind`` that selects the plant)."""
    describe_flags = staticmethod(describe_flags)
    dt: float
    _k: int
    _radius: list[float]
    plant_faults: PlantFaults
    """The run's plant faults (servo and plug-in plant faults; empty = none)."""
    fault_memo: dict[str, Any]
    """What the faults' effects keep of the healthy plant (by effect), to restore it."""
    _fault_next: int = NEVER
    """The physics step at which the next plant fault starts."""
    _fault_state: list[Any]
    """The effects' states applied (:meth:`PlantFaults.state`)."""

    def _setup_faults(self, faults: FaultSettings) -> None:
        """The plant faults of the settings, their effects told the healthy plant (before any acts)."""
        self.plant_faults = PlantFaults(plant_faults_of(faults), self.dt)
        self.fault_memo = {}
        self.plant_faults.prepare(self)
        self._fault_state = self.plant_faults.healthy()

    def advance(self, n: int) -> None:
        """Advance ``n`` physics steps (``n * dt`` seconds) with the held commands, the fault schedules
        applied at every physics step in which they change and each plant fault from its onset step (the
        window is split there; without one due in the window this costs one comparison)."""
        k_end = self._k + int(n)
        while self._fault_next < k_end:
            self._advance(self._fault_next - self._k)
            self._fault_state = self.plant_faults.state(self._k)
            self.plant_faults.apply(self, self._fault_state)
            self._fault_next = self.plant_faults.next_step(self._k)
        self._advance(k_end - self._k)

    def _restart_faults(self) -> None:
        """At reset: the healthy plant (if the run has plant faults), the first fault's step due."""
        if self.plant_faults:
            self._fault_state = self.plant_faults.healthy()
            self.plant_faults.apply(self, self._fault_state)
        self._fault_next = self.plant_faults.next_step(-1)

    @abstractmethod
    def _advance(self, n: int) -> None:
        """Advance ``n`` physics steps (none for ``n <= 0``) with the plant faults' state in force."""

    def fault_truth(self) -> dict[str, float]:
        """The plant faults' state that acted in the last physics step, as trace values
        (:attr:`PlantFaults.columns`)."""
        return self.plant_faults.truth(self._fault_state)

    @property
    def time(self) -> float:
        """Simulation time (s): number of physics steps taken times the timestep."""
        return self._k * self.dt

    @property
    def steps(self) -> int:
        """Physics steps taken since ``reset``."""
        return self._k

    @property
    def radii(self) -> tuple[float, float]:
        """Current true radii ``(R_R, R_L)`` (m)."""
        return self._radius[0], self._radius[1]
