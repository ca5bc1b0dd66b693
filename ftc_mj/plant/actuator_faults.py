"""Faults of the wheels' velocity servos: loss of effectiveness, a locked wheel, an unresponsive servo.

Each wheel is driven by a velocity servo (MuJoCo ``<velocity>`` actuator): torque
``τ = kv (ω_cmd − ω)`` clipped to ``±τ_max`` (the shipped robot: kv = 10 000 N m s/rad, τ_max =
1500 N m). A fault changes that law from its onset on, for the rest of the run:

- ``loss`` (effectiveness ``e`` in [0, 1)): the drive delivers only the fraction ``e`` of its torque
  — a motor with demagnetised magnets or shorted windings (torque constant scaled by ``e``), or a
  current limit reduced by an overheating driver. Both the gain and the limit scale:
  ``τ = e kv (ω_cmd − ω)`` clipped to ``±e τ_max``, so the available torque is ``e τ_max`` (a 50 % loss
  halves it) and a wheel loaded by ``τ_load`` lags its command by ``τ_load / (e kv)``.
- ``unresponsive``: the servo applies no torque (a cut power line or a dead driver): ``e = 0``. The
  wheel still rolls with the ground, resisted only by its bearing's damping.
- ``lock``: the wheel cannot turn (a seized bearing or gearbox, an engaged parking brake): a dry
  friction (Coulomb) torque on the hinge — MuJoCo's joint ``frictionloss`` — of :data:`LOCK_TORQUE`,
  40 times the largest torque the tyre can put on the wheel (≈ 1250 N × 2 m = 2500 N m) and far above
  the servo's 1500 N m, so the wheel stays put and the tyre skids. The friction constraint is made
  stiff (:data:`LOCK_SOLIMP`, time constant 2 physics steps) so that its creep is small: measured on the
  shipped robot, the locked wheel turns at most 6e-4 rad/s from 50 ms after a lock at 10 m/s.

Several faults on one wheel combine: the effectivenesses of active losses multiply, an unresponsive
servo makes it 0, and a lock holds whatever the servo does. The kinematic plant (no servo: its
wheel rates are the commands) takes ``lock`` only: a locked wheel's rate is 0.

The faults act from the first physics step at or after their onset (the plant splits its
``advance`` there, so a window without a change costs one integer comparison).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence

from .settings import ActuatorFaultSettings

LOCK_TORQUE = 1.0e5
"""Holding torque (N m) of a locked wheel's dry friction (``dof_frictionloss``)."""
LOCK_SOLIMP = 0.999
"""Impedance of the lock's friction constraint (MuJoCo ``solimp`` d0 = d_width; the default 0.9 lets the
wheel creep at 0.04 rad/s, this at 4e-5–6e-4 rad/s); its time constant is 2 physics steps (``solref``)."""

ACTUATOR_COLUMNS: tuple[str, ...] = ("fault_effectiveness_R", "fault_effectiveness_L", "fault_lock_R",
                                     "fault_lock_L")
"""Trace columns of a run with servo faults: each wheel's servo effectiveness (fraction of its nominal gain
and torque limit acting, 1 healthy, 0 unresponsive) and whether it is locked (0/1)."""

NEVER = sys.maxsize
"""The physics step of a change that never comes."""

_WHEELS = ("right", "left")


def onset_step(onset: float, dt: float) -> int:
    """The first physics step ``k`` whose time ``k dt`` (s) is at or after ``onset`` (s), to 1 ns."""
    return max(0, math.ceil((onset - 1e-9) / dt))


class ActuatorFaults:
    """The servo faults of a run as a function of time (module docstring).

    Args:
        faults: the ``[[faults.actuator]]`` tables (:class:`~ftc_mj.plant.settings.ActuatorFaultSettings`).
        dt: the physics step (s).
    """

    __slots__ = ("faults", "dt", "_steps")

    def __init__(self, faults: Sequence[ActuatorFaultSettings], dt: float) -> None:
        self.faults = tuple(faults)
        self.dt = float(dt)
        self._steps = sorted({onset_step(f.onset, self.dt) for f in self.faults})

    def __bool__(self) -> bool:
        return bool(self.faults)

    def next_step(self, k: int) -> int:
        """The first physics step after ``k`` at which a fault starts (:data:`NEVER` if none does)."""
        for s in self._steps:
            if s > k:
                return s
        return NEVER

    def state(self, k: int) -> tuple[tuple[float, float], tuple[bool, bool]]:
        """Each wheel's servo effectiveness (fraction, right first) and lock at physics step ``k``."""
        eff = [1.0, 1.0]
        dead = [False, False]
        lock = [False, False]
        for f in self.faults:
            if onset_step(f.onset, self.dt) > k:
                continue
            i = _WHEELS.index(f.wheel)
            if f.kind == "loss":
                eff[i] *= float(f.effectiveness)  # type: ignore[arg-type]
            elif f.kind == "unresponsive":
                dead[i] = True
            else:
                lock[i] = True
        eff = [0.0 if dead[i] else eff[i] for i in (0, 1)]
        return (eff[0], eff[1]), (lock[0], lock[1])


def actuator_truth(eff: tuple[float, float], lock: tuple[bool, bool]) -> dict[str, float]:
    """The trace values (:data:`ACTUATOR_COLUMNS`) of an applied servo state."""
    return dict(zip(ACTUATOR_COLUMNS, (eff[0], eff[1], float(lock[0]), float(lock[1])), strict=True))
