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

Several faults on one wheel combine (:class:`ServoEffect`): the effectivenesses of active losses
multiply, an unresponsive servo makes it 0, and a lock holds whatever the servo does. The kinematic
plant (no servo: its wheel rates are the commands) takes ``lock`` only: a locked wheel's rate is 0.

The faults act from the first physics step at or after their onset (the plant splits its
``advance`` there, so a window without a change costs one integer comparison).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

from pydantic import model_validator

from ... import registry
from ...fields import FLOAT_BOUND, StrictModel, ranged
from .base import WHEELS, Effect, Param, PlantFault, Sample

LOCK_TORQUE = 1.0e5
"""Holding torque (N m) of a locked wheel's dry friction (``dof_frictionloss``)."""
LOCK_SOLIMP = 0.999
"""Impedance of the lock's friction constraint (MuJoCo ``solimp`` d0 = d_width; the default 0.9 lets the
wheel creep at 0.04 rad/s, this at 4e-5–6e-4 rad/s); its time constant is 2 physics steps (``solref``)."""

ACTUATOR_COLUMNS: tuple[str, ...] = ("fault_effectiveness_R", "fault_effectiveness_L", "fault_lock_R",
                                     "fault_lock_L")
"""Trace columns of a run with servo faults: each wheel's servo effectiveness (fraction of its nominal gain
and torque limit acting, 1 healthy, 0 unresponsive) and whether it is locked (0/1)."""

FaultTime = ranged(0.0, FLOAT_BOUND, unit="s")
"""A fault's onset (s): any time from 0; one after the end of a run never happens in it."""


class ActuatorFaultSettings(StrictModel):
    """One fault of a wheel's velocity servo (``[[faults.actuator]]``), permanent from ``onset``.

    ``loss``: loss of effectiveness, the servo's gain and its torque limit both scaled by
    ``effectiveness``; ``lock``: the wheel is held at zero rate (a seized bearing or gearbox);
    ``unresponsive``: the servo applies no torque and the wheel turns freely. The physics of each:
    :mod:`ftc_mj.plant.faults.servo`.
    """

    wheel: Literal["right", "left"]
    kind: Literal["loss", "lock", "unresponsive"]
    onset: FaultTime
    effectiveness: ranged(0.0, 1.0, hi_open=True) | None = None
    """``loss`` only: the fraction of the servo's gain and torque limit that remains, in [0, 1)."""

    @model_validator(mode="after")
    def _effectiveness_for_loss(self) -> ActuatorFaultSettings:
        """``effectiveness`` is given for a ``loss`` and for nothing else."""
        if self.kind == "loss" and self.effectiveness is None:
            raise ValueError("effectiveness: a 'loss' needs the remaining fraction in [0, 1)")
        if self.kind != "loss" and self.effectiveness is not None:
            raise ValueError(f"effectiveness: only a 'loss' has one, not a {self.kind!r}")
        return self

    @property
    def target(self) -> str:
        """What the fault hits: the wheel."""
        return self.wheel

    @property
    def fault_class(self) -> str:
        """The registered class of this table (:data:`SERVO_CLASSES` by ``kind``)."""
        return SERVO_CLASSES[self.kind].name


class ServoEffect(Effect):
    """The servo state of both wheels: each one's effectiveness (fraction) and lock, right first."""

    columns = ACTUATOR_COLUMNS

    def prepare(self, plant: Any) -> None:
        """On the MuJoCo plant: the healthy servos (gain kv, bias −kv, torque limits) and hinges (dry
        friction, its constraint's impedance and time constant) that the faults change."""
        if plant.kind != "mujoco":
            return
        m, act, hinge = plant.model, list(plant.layout.actuators), list(plant.layout.hinge_v)
        plant.fault_memo["servo"] = (m.actuator_gainprm[act, 0].copy(), m.actuator_biasprm[act, 2].copy(),
                                     m.actuator_forcerange[act].copy(), m.dof_frictionloss[hinge].copy(),
                                     m.dof_solimp[hinge].copy(), m.dof_solref[hinge].copy())

    def healthy(self) -> tuple[list[float], list[bool]]:
        return [1.0, 1.0], [False, False]

    def apply(self, plant: Any, state: tuple[list[float], list[bool]]) -> None:
        """MuJoCo: scale each wheel's servo gain and torque limit by its effectiveness; hold a locked wheel's
        hinge by a stiff dry friction of :data:`LOCK_TORQUE` N m (in the model, in place). Kinematic: a
        locked wheel's rate is 0."""
        eff, lock = state
        if plant.kind != "mujoco":
            plant.hold_wheels((lock[0], lock[1]))
            return
        m = plant.model
        kv, bias, limits, friction, solimp, solref = plant.fault_memo["servo"]
        for i in (0, 1):
            a, e, dof = plant.layout.actuators[i], eff[i], plant.layout.hinge_v[i]
            m.actuator_gainprm[a, 0] = e * kv[i]
            m.actuator_biasprm[a, 2] = e * bias[i]
            m.actuator_forcerange[a] = e * limits[i]
            if lock[i]:
                m.dof_frictionloss[dof] = LOCK_TORQUE
                m.dof_solimp[dof, :2] = LOCK_SOLIMP
                m.dof_solref[dof] = (2.0 * plant.dt, 1.0)
            else:
                m.dof_frictionloss[dof], m.dof_solimp[dof], m.dof_solref[dof] = friction[i], solimp[i], solref[i]

    def truth(self, state: tuple[list[float], list[bool]]) -> dict[str, float]:
        eff, lock = state
        return dict(zip(ACTUATOR_COLUMNS, (eff[0], eff[1], float(lock[0]), float(lock[1])), strict=True))


SERVO = ServoEffect()


class ServoFault(PlantFault):
    """A fault of one wheel's servo (``[[faults.actuator]]``); its size is the fraction of the servo lost."""

    component = "servo"
    targets = WHEELS
    unit = ""
    observed_by = ("wheel_rates",)
    effect = SERVO
    plants = ("mujoco",)
    Settings = ActuatorFaultSettings
    params: Mapping[str, Param] = {"lost": Param("", 0.0, 1.0, "the fraction of the servo lost (1 − effectiveness)",
                                                 low_open=True)}

    @property
    def size(self) -> float:
        return 1.0

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return (f"fault_effectiveness_{'R' if target == 'right' else 'L'}",)

    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        return {"size": 0.0}

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        """A ``[[faults.actuator]]`` table."""
        faults.setdefault("actuator", []).append({"wheel": target, "kind": cls.mode, "onset": onset})


class ActuatorLoss(ServoFault):
    """Loss of effectiveness: the servo's gain and torque limit scaled by ``effectiveness``."""

    name = "actuator_loss"
    mode = "loss"
    config = '`[[faults.actuator]]` `kind = "loss"`'
    params: Mapping[str, Param] = {
        "lost": Param("", 0.0, 1.0, "the fraction of the servo lost (1 − effectiveness)", low_open=True),
        "effectiveness": Param("", 0.0, 1.0, "the fraction of gain and torque limit that remains", high_open=True)}
    drawn_as: Mapping[str, tuple[str, ...]] = {"actuator_loss": ("effectiveness",)}

    @property
    def size(self) -> float:
        return 1.0 - float(self.settings.effectiveness)

    def combine(self, state: tuple[list[float], list[bool]]) -> None:
        state[0][WHEELS.index(self.target)] *= float(self.settings.effectiveness)

    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        """The remaining effectiveness."""
        return {"size": round(sample("effectiveness"), 4)}

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        faults.setdefault("actuator", []).append({"wheel": target, "kind": cls.mode, "onset": onset,
                                                  "effectiveness": drawn["size"]})

    @classmethod
    def check_range(cls, name: str, low: float, high: float) -> None:
        eff = cls.params["effectiveness"]
        if not (eff.contains(low) and eff.contains(high)):
            raise ValueError(f"{name}: must lie in {eff.interval()}")


class WheelLock(ServoFault):
    """The wheel is held at zero rate (a seized bearing or gearbox, an engaged parking brake)."""

    name = "wheel_lock"
    mode = "lock"
    config = '`[[faults.actuator]]` `kind = "lock"`'
    drawn_as: Mapping[str, tuple[str, ...]] = {"wheel_lock": ()}
    plants = ("mujoco", "kinematic")

    def combine(self, state: tuple[list[float], list[bool]]) -> None:
        state[1][WHEELS.index(self.target)] = True

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        return (f"fault_lock_{'R' if target == 'right' else 'L'}",)


class ActuatorUnresponsive(ServoFault):
    """The servo applies no torque (effectiveness 0); the wheel rolls free."""

    name = "actuator_unresponsive"
    mode = "unresponsive"
    config = '`[[faults.actuator]]` `kind = "unresponsive"`'
    drawn_as: Mapping[str, tuple[str, ...]] = {"actuator_unresponsive": ()}

    def combine(self, state: tuple[list[float], list[bool]]) -> None:
        state[0][WHEELS.index(self.target)] *= 0.0


SERVO_CLASSES: dict[str, type[ServoFault]] = {c.mode: c for c in (ActuatorLoss, WheelLock, ActuatorUnresponsive)}
"""The servo fault classes by the ``kind`` of their ``[[faults.actuator]]`` table."""

for _cls in SERVO_CLASSES.values():
    registry.fault_classes.register(_cls.name, _cls, origin=registry.BUILTIN)
