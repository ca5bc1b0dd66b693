"""The robot's sensors and their noise: :class:`SensorSettings`.

One declaration serves both sides of the loop: the truth plant's sensors draw their seeded noise with
these standard deviations, and the filters' measurement model assumes the same ones (a filter must
match the sensors it is given). SI units and radians.

The *pose sensor* delivers fixes of ``(x, y, psi)`` at ``position_rate``: its ``x, y`` are the filter's
position measurements (σ ``position_sigma``), its heading has σ ``heading_sigma``; pose faults (bias, jump,
dropout: :mod:`ftc_mj.plant.faults.sensor`) hit the fix, hence the filter and the controller alike.
``pose_source`` says where the controller's pose comes from: ``truth`` (the paper's idealisation: the true
pose plus ``pose_sigma`` noise, untouched by sensor faults) or ``sensor`` (the pose sensor, as a real robot
has it: docs/benchmark.md, "Information rule").
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import SerializerFunctionWrapHandler, model_serializer, model_validator

from ..fields import NonNegFloat, PosFloat, StrictModel

POSE_SOURCES = ("truth", "sensor")
"""Where the controller's pose comes from (``sensors.pose_source``)."""


class SensorSettings(StrictModel):
    """Sensors with seeded Gaussian noise. ``None`` sigma = that sensor is absent."""

    speed_sigma: PosFloat = 0.5
    """Speed sensor noise (m/s), the paper's value."""
    yaw_rate_sigma: PosFloat | None = None
    """Yaw-rate gyro noise (rad/s); unset = no gyro."""
    position_sigma: PosFloat | None = None
    """Pose-sensor noise (m) on the fix's x and y (the filter's position measurement); unset = no pose sensor."""
    position_rate: PosFloat = 1.0
    """Rate of the pose sensor's fixes (Hz)."""
    heading_sigma: PosFloat | None = None
    """Pose-sensor noise (rad) on the fix's heading; unset = ``position_sigma`` per metre (two antennas 1 m
    apart would give about that)."""
    encoder_sigma: NonNegFloat = 0.0
    """Wheel-encoder rate noise (rad/s) on the measured wheel rates fed to the filters."""
    pose_sigma: NonNegFloat = 0.0
    """Noise (m, and rad for heading) on the pose handed to the controller with ``pose_source = "truth"``;
    0 = true pose."""
    pose_source: Literal["truth", "sensor"] = "truth"
    """The controller's pose: ``truth`` (the true pose + ``pose_sigma`` noise; the paper's scenarios) or
    ``sensor`` (the pose sensor: the filter's pose estimate, which has taken in the fixes so far; without a
    filter the last fix held; needs ``position_sigma``)."""

    @model_validator(mode="after")
    def _sensor_needs_fixes(self) -> SensorSettings:
        """A pose from the pose sensor needs the sensor."""
        if self.pose_source == "sensor" and self.position_sigma is None:
            raise ValueError("pose_source: 'sensor' needs the pose sensor (set sensors.position_sigma)")
        return self

    @model_serializer(mode="wrap")
    def _omit_defaults(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``heading_sigma`` unset and ``pose_source = "truth"``: a run that uses neither keeps
        the identity (run id, study key) it had before they existed."""
        data = handler(self)
        if data.get("heading_sigma") is None:
            data.pop("heading_sigma", None)
        if data.get("pose_source") == "truth":
            data.pop("pose_source", None)
        return data

    @property
    def fix_heading_sigma(self) -> float:
        """The pose fix's heading noise (rad): ``heading_sigma``, else ``position_sigma`` per metre."""
        if self.heading_sigma is not None:
            return float(self.heading_sigma)
        return float(self.position_sigma or 0.0)
