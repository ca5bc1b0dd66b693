"""The plant's settings, declared once: the ``[robot]``, ``[plant]`` and ``[model]`` sections as pydantic
models (the run config composes them, :mod:`ftc_mj.config.sections`), and the ``[faults]`` and ``[sensors]``
sections' models re-exported from where they live (:mod:`ftc_mj.plant.faults`, :mod:`ftc_mj.model.sensors`).

The plant is built from these models alone (never from the whole run config); only the wiring
(:mod:`ftc_mj.wiring.plant`) takes them out of a run config.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BeforeValidator,
    SerializerFunctionWrapHandler,
    Strict,
    field_validator,
    model_serializer,
)

from .. import resources
from ..fields import (
    DEFAULT_MODEL_FILE,
    OMEGA_MAX,
    AngleDeg,
    FiniteFloat,
    Flag,
    Fraction,
    Length,
    NonNegFloat,
    PosFloat,
    StrictModel,
    ranged,
)
from ..model.sensors import SensorSettings
from .faults.sensor import SensorFaultSettings
from .faults.servo import ActuatorFaultSettings
from .faults.settings import FaultSettings

__all__ = ["ActuatorFaultSettings", "FaultSettings", "ModelSettings", "PlantSettings", "RobotSettings",
           "SensorFaultSettings", "SensorSettings", "plant_geometry"]


class RobotSettings(StrictModel):
    """Nominal design shared by plant and model unless overridden there."""

    wheel_radius: Length = 2.0
    """Nominal wheel radius R0 (m)."""
    half_track: Length = 1.0
    """Half track b (m): wheel centre to axle midpoint; track width is 2b."""
    omega_max: ranged(0.0, 1.0e4, lo_open=True, unit="rad/s") = OMEGA_MAX
    """Wheel-rate limit (rad/s), symmetric."""


class PlantSettings(StrictModel):
    """Truth plant (MuJoCo). ``None`` means: take the value from ``robot``."""

    model_file: Annotated[str, BeforeValidator(lambda v: str(v) if isinstance(v, Path) else v), Strict()] = (
        DEFAULT_MODEL_FILE)
    """The MJCF robot: ``builtin:<name>`` for a model shipped in the package (the same robot on every
    machine, :mod:`ftc_mj.resources`), else a file path, stored absolute (relative paths are taken from
    the working directory) so that a resolved config re-runs from any directory."""
    variant: Literal["suspended", "rigid"] = "suspended"
    timestep: ranged(1.0e-5, 0.05, unit="s") = 0.001
    """Physics step (s)."""
    wheel_radius: Length | None = None
    half_track: Length | None = None
    chassis_mass: PosFloat | None = None
    """Chassis mass (kg); ``None`` keeps the MJCF value."""
    wheel_mass: PosFloat | None = None
    """Mass of one wheel (kg); ``None`` keeps the MJCF value."""
    tyre_friction: PosFloat | None = None
    """Sliding friction coefficient of the tyres; ``None`` keeps the MJCF value."""
    caster_friction: NonNegFloat = 0.0
    """Sliding friction of the caster(s); 0 = frictionless (the kinematic model's assumption)."""
    actuator_gain: PosFloat | None = None
    """Velocity-actuator gain kv (N m s/rad); ``None`` keeps the MJCF value."""
    payload_mass: ranged(0.0, 1.0e4, unit="kg") = 0.0
    """Mass (kg) of a payload fixed to the chassis (a uniform 0.4 m ball); 0 = none (the MJCF robot as it is).
    It adds to the chassis weight *after* the struts' preload is set, so they sag under it, and it moves the
    centre of mass, hence the load each tyre and the caster carry and the lift-off lateral acceleration."""
    payload_offset: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (0.0, 0.0, 0.0)
    """Position (m) of the payload's centre in the chassis frame: forward of the axle midpoint, to the left,
    and up from the hub height (the chassis frame's origin; negative = below the axle)."""
    initial_pose: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (0.0, 0.0, 0.0)
    """Initial (x, y, psi) of the axle midpoint (m, m, rad)."""
    start_moving: Flag = True
    """Start in steady motion at the reference's speed and yaw rate at t = 0 (the paper's runs begin on the
    path at 10 m/s); False = start from rest."""
    reseat_hub: Flag = True
    """Levelling suspension (suspended variant): on every radius change move the hub and its strut's spring
    reference by the radius change, so the tyre stays on the ground with the same load and the chassis level.
    ``False``: passive struts (a shrunken tyre hangs on its spring and the chassis rolls)."""
    kind: Literal["mujoco", "kinematic"] = "mujoco"
    """``mujoco``: the physical truth plant; ``kinematic``: the ideal kinematic model integrated exactly (RK4)."""
    wheel_load_fraction: Fraction = 0.7
    """Share of the chassis weight carried by the two wheel slides (suspended variant); the caster takes the rest.
    The builder sets the slide spring preload and the chassis centre of mass (x) from it."""
    slip_limit: PosFloat = 0.3
    """Longitudinal tyre slip speed (m/s) above which the plant raises the ``SLIP`` flag."""
    tilt_limit_deg: AngleDeg = 10.0
    """Roll or pitch (deg) above which the plant raises the ``LARGE_ROLL`` flag."""
    tipped_limit_deg: AngleDeg = 60.0
    """Roll or pitch (deg) above which the plant raises the ``TIPPED`` flag."""

    @model_serializer(mode="wrap")
    def _omit_no_payload(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``payload_mass``/``payload_offset`` when there is no payload: a run without one
        keeps the identity (run id, study key) it had before the payload existed."""
        data = handler(self)
        if not data.get("payload_mass"):
            data.pop("payload_mass", None)
            data.pop("payload_offset", None)
        return data

    @field_validator("model_file")
    @classmethod
    def _model_exists(cls, v: str) -> str:
        """A ``builtin:<name>`` model shipped in the package, else an existing file, stored absolute."""
        if not v.strip() or "\0" in v:
            raise ValueError("must be a non-empty path without NUL bytes (or builtin:<name>)")
        if resources.is_builtin_model(v):
            resources.model_path(v)  # ValueError naming the built-in models
            return v
        p = Path(v)
        try:
            p = p.absolute()
            found = p.is_file()
        except OSError as err:  # e.g. a name too long for the file system
            raise ValueError(f"cannot use {str(v)[:80]}: {err.strerror}") from None
        if not found:
            raise ValueError(f"model file not found: {v}")
        return str(p)


class ModelSettings(StrictModel):
    """What the filters and controllers assume. ``None`` means: take the value from ``robot``."""

    half_track: Length | None = None
    wheel_radius: Length | None = None


def plant_geometry(plant: PlantSettings, robot: RobotSettings) -> tuple[float, float]:
    """The plant's nominal wheel radius and half track (m): its own values, else the robot's."""
    return plant.wheel_radius or robot.wheel_radius, plant.half_track or robot.half_track
