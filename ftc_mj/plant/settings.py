"""What the plant reads of its settings: the ``[plant]``, ``[robot]``, ``[faults]`` and ``[sensors]`` sections.

The plant is built from these sections alone (never from the whole run config): the protocols below name
the fields each part reads, so any object with them (the config's pydantic sections, a test's namespace)
will do. Only :mod:`ftc_mj.plant.factory` takes them out of a run config.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol


class RobotSettings(Protocol):
    """The nominal design (``[robot]``): what plant and model share unless the plant overrides it."""

    wheel_radius: float
    """Nominal wheel radius (m)."""
    half_track: float
    """Wheel centre to axle midpoint (m)."""
    omega_max: float
    """Symmetric wheel-rate limit (rad/s)."""


class PlantSettings(Protocol):
    """The truth plant (``[plant]``); ``None`` for ``wheel_radius``/``half_track`` means the robot's value."""

    kind: str
    """``"mujoco"`` (physics) or ``"kinematic"`` (the ideal model)."""
    model_file: str
    """The MJCF robot (a path or ``builtin:<name>``)."""
    variant: str
    """``"suspended"`` (wheels on sprung slides) or ``"rigid"``."""
    timestep: float
    """Physics step (s)."""
    wheel_radius: float | None
    """Wheel radius (m) overriding the robot's."""
    half_track: float | None
    """Half track (m) overriding the robot's."""
    initial_pose: Sequence[float]
    """Initial ``(x, y, psi)`` of the axle midpoint (m, m, rad)."""
    reseat_hub: bool
    """Levelling suspension: the hub follows a radius change."""
    slip_limit: float
    """Longitudinal slip speed (m/s) above which ``SLIP`` is raised."""
    tilt_limit_deg: float
    """Roll or pitch (deg) above which ``LARGE_ROLL`` is raised."""
    tipped_limit_deg: float
    """Roll or pitch (deg) above which ``TIPPED`` is raised."""
    chassis_mass: float | None
    """Chassis mass (kg); ``None`` keeps the MJCF value."""
    wheel_mass: float | None
    """Mass of one wheel (kg); ``None`` keeps the MJCF value."""
    tyre_friction: float | None
    """Sliding friction coefficient of the tyres; ``None`` keeps the MJCF value."""
    caster_friction: float
    """Sliding friction coefficient of the caster (0 = frictionless)."""
    actuator_gain: float | None
    """Velocity-servo gain kv (N m s/rad); ``None`` keeps the MJCF value."""
    wheel_load_fraction: float
    """Share of the chassis weight on the two wheel slides (the caster takes the rest)."""
    payload_mass: float
    """Payload fixed to the chassis (kg); 0 = none."""
    payload_offset: Sequence[float]
    """Payload centre in the chassis frame (m): forward, left, up from the hub height."""


class ActuatorFaultSettings(Protocol):
    """One servo fault (``[[faults.actuator]]``, :mod:`ftc_mj.plant.actuator_faults`)."""

    wheel: str
    """``"right"`` or ``"left"``."""
    kind: str
    """``"loss"``, ``"lock"`` or ``"unresponsive"``."""
    onset: float
    """Time (s) from which the fault acts."""
    effectiveness: float | None
    """``loss``: the remaining fraction of the servo's gain and torque limit, in [0, 1)."""


class SensorFaultSettings(Protocol):
    """One sensor fault (``[[faults.sensor]]``, :mod:`ftc_mj.plant.sensor_faults`)."""

    sensor: str
    """``"speed"`` or ``"yaw_rate"``."""
    kind: str
    """``"bias"``, ``"drift"`` or ``"dropout"``."""
    onset: float
    """Time (s) from which the fault acts."""
    size: float | None
    """Bias (m/s or rad/s) or drift rate (m/s² or rad/s²); ``None`` for a dropout."""
    duration: float
    """Time (s) the fault lasts."""


class FaultSettings(Protocol):
    """The faults (``[faults]``): ``[t, radius]`` breakpoints (s, m) of each wheel's radius, the servo faults
    and the sensor faults."""

    right: Sequence[Sequence[float]]
    left: Sequence[Sequence[float]]
    actuator: Sequence[ActuatorFaultSettings]
    sensor: Sequence[SensorFaultSettings]


class SensorSettings(Protocol):
    """The sensors (``[sensors]``): noise standard deviations in SI units, ``None`` = sensor absent."""

    speed_sigma: float
    """Speed noise (m/s)."""
    yaw_rate_sigma: float | None
    """Gyro noise (rad/s)."""
    position_sigma: float | None
    """Position-fix noise (m) on x and y."""
    position_rate: float
    """Rate of position fixes (Hz)."""
    encoder_sigma: float
    """Wheel-encoder rate noise (rad/s)."""
    pose_sigma: float
    """Noise on the pose handed to the controller (m and rad)."""


def plant_geometry(plant: PlantSettings, robot: RobotSettings) -> tuple[float, float]:
    """The plant's nominal wheel radius and half track (m): its own values, else the robot's."""
    return plant.wheel_radius or robot.wheel_radius, plant.half_track or robot.half_track
