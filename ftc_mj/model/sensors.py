"""The robot's sensors and their noise: :class:`SensorSettings`.

One declaration serves both sides of the loop: the truth plant's sensors draw their seeded noise with
these standard deviations, and the filters' measurement model assumes the same ones (a filter must
match the sensors it is given). SI units and radians.
"""

from __future__ import annotations

from ..fields import NonNegFloat, PosFloat, StrictModel


class SensorSettings(StrictModel):
    """Sensors with seeded Gaussian noise. ``None`` sigma = that sensor is absent."""

    speed_sigma: PosFloat = 0.5
    """Speed sensor noise (m/s), the paper's value."""
    yaw_rate_sigma: PosFloat | None = None
    """Yaw-rate gyro noise (rad/s); unset = no gyro."""
    position_sigma: PosFloat | None = None
    """Position fix noise (m) on x and y; unset = no position fix."""
    position_rate: PosFloat = 1.0
    """Rate of position fixes (Hz)."""
    encoder_sigma: NonNegFloat = 0.0
    """Wheel-encoder rate noise (rad/s) on the measured wheel rates fed to the filters."""
    pose_sigma: NonNegFloat = 0.0
    """Noise (m, and rad for heading) on the pose handed to the controller; 0 = true pose."""
