"""What every truth plant shares: its clock (physics steps of ``dt`` seconds) and its current wheel radii."""

from __future__ import annotations

from .truth import describe_flags


class PlantClock:
    """Base of the truth plants: ``dt`` (s), the step count ``_k`` and the radii ``_radius`` (m) that a
    subclass keeps, read through :attr:`time`, :attr:`steps` and :attr:`radii`."""

    kind = ""
    """``"mujoco"`` or ``"kinematic"`` (the ``plant.kind`` that selects the plant)."""
    describe_flags = staticmethod(describe_flags)
    dt: float
    _k: int
    _radius: list[float]

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
