"""The ``[faults]`` section: :class:`FaultSettings`, composed of each fault class's own table."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, SerializerFunctionWrapHandler, field_validator, model_serializer

from ...fields import StrictModel
from .plugin import PluginFaultSettings
from .sensor import SensorFaultSettings
from .servo import ActuatorFaultSettings
from .tyre import Breakpoints, check_schedule


class FaultSettings(StrictModel):
    """The injected faults: tyre punctures, servo faults, sensor faults and faults of plug-in classes.

    ``right``/``left``: piecewise-linear wheel-radius schedules, lists of ``[t, radius]`` breakpoints.
    Before the first breakpoint the radius is the nominal one; after the last it is held. A step is
    two breakpoints at the same time. Empty = no fault on that wheel. ``actuator``/``sensor``/``plugin``:
    lists of :class:`~ftc_mj.plant.faults.servo.ActuatorFaultSettings` /
    :class:`~ftc_mj.plant.faults.sensor.SensorFaultSettings` /
    :class:`~ftc_mj.plant.faults.plugin.PluginFaultSettings` tables. Empty lists are left out of the
    resolved config, so a run without such faults has the identity (run id, study key) it had before
    they existed.
    """

    right: Breakpoints = Field(default_factory=list)
    left: Breakpoints = Field(default_factory=list)
    actuator: Annotated[list[ActuatorFaultSettings], Field(max_length=100)] = Field(default_factory=list)
    sensor: Annotated[list[SensorFaultSettings], Field(max_length=100)] = Field(default_factory=list)
    plugin: Annotated[list[PluginFaultSettings], Field(max_length=100)] = Field(default_factory=list)

    @field_validator("right", "left")
    @classmethod
    def _valid_schedule(cls, v: Breakpoints) -> Breakpoints:
        """Each wheel's schedule checked by :func:`~ftc_mj.plant.faults.tyre.check_schedule`."""
        return check_schedule(v)

    @model_serializer(mode="wrap")
    def _omit_empty(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``actuator``/``sensor``/``plugin`` when they are empty."""
        data = handler(self)
        for name in ("actuator", "sensor", "plugin"):
            if not data.get(name):
                data.pop(name, None)
        return data
