"""What every truth plant shares: its clock (physics steps of ``dt`` seconds), its current wheel radii and
the servo faults it applies at their onset steps."""

from __future__ import annotations

from abc import ABC, abstractmethod

from .actuator_faults import NEVER, ActuatorFaults, actuator_truth
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
    actuator_faults: ActuatorFaults
    """The run's servo faults (:mod:`~ftc_mj.plant.actuator_faults`; empty = none)."""
    _fault_next: int = NEVER
    """The physics step at which the next servo fault starts."""
    _servo: tuple[tuple[float, float], tuple[bool, bool]] = ((1.0, 1.0), (False, False))
    """The servo state applied: each wheel's effectiveness and lock (right first)."""

    def advance(self, n: int) -> None:
        """Advance ``n`` physics steps (``n * dt`` seconds) with the held commands, the fault schedules
        applied at every physics step in which they change and each servo fault from its onset step (the
        window is split there; without one due in the window this costs one comparison)."""
        k_end = self._k + int(n)
        while self._fault_next < k_end:
            self._advance(self._fault_next - self._k)
            self._servo = self.actuator_faults.state(self._k)
            self._apply_servo(*self._servo)
            self._fault_next = self.actuator_faults.next_step(self._k)
        self._advance(k_end - self._k)

    def _restart_servo_faults(self) -> None:
        """At reset: healthy servos (if the run has servo faults), the first fault's step due."""
        if self.actuator_faults:
            self._servo = ((1.0, 1.0), (False, False))
            self._apply_servo(*self._servo)
        self._fault_next = self.actuator_faults.next_step(-1)

    @abstractmethod
    def _advance(self, n: int) -> None:
        """Advance ``n`` physics steps (none for ``n <= 0``) with the servo state in force."""

    @abstractmethod
    def _apply_servo(self, eff: tuple[float, float], lock: tuple[bool, bool]) -> None:
        """Put each wheel's servo effectiveness (fraction) and lock in force."""

    def fault_truth(self) -> dict[str, float]:
        """The servo state that acted in the last physics step, as trace values
        (:data:`~ftc_mj.plant.actuator_faults.ACTUATOR_COLUMNS`)."""
        return actuator_truth(*self._servo)

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
