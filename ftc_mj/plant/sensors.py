"""Sensors with seeded Gaussian noise on top of the plant's truth.

Every :meth:`Sensors.read` draws the same fixed block of standard normals, whichever sensors are configured, so
a run is deterministic for a given config and seed, and switching a sensor on or off does not change the noise
sequence of the others (e.g. adding a gyro leaves the speed noise identical). Sensor faults
(:mod:`~ftc_mj.plant.faults.sensor`: bias, drift, dropout of the speed sensor or the gyro, bias, jump,
dropout of the pose sensor, and plug-in sensor fault classes) act on top of the noise and draw nothing.

The pose sensor's fix ``(x, y, psi)`` is due at ``position_rate``: its ``x, y`` noise are the position fix's
draws, its heading noise the draw the controller's ``pose_sigma`` noise uses (a run's pose source uses one
of the two), so the noise of every other sensor is the same with or without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.sensors import SensorSettings
from .faults.records import sensor_faults_of
from .faults.sensor import SensorFaults
from .faults.settings import FaultSettings
from .truth import Truth

_N_DRAWS = 9  # speed, yaw rate, position x, position y, omega_R, omega_L, pose x, pose y, pose psi

_EPS_T = 1e-9  # s, tolerance on the position-fix schedule


@dataclass(slots=True)
class SensorReading:
    """One sample of all sensors at time ``t`` (s).

    Attributes:
        t: sample time (s).
        speed: forward speed of the axle midpoint + N(0, speed_sigma^2) (m/s), + a fault's offset; NaN while
            the sensor drops out.
        yaw_rate: gyro, yaw rate + N(0, yaw_rate_sigma^2) (rad/s), + a fault's offset; NaN while it drops out;
            ``None`` without a gyro.
        position: ``[x, y]`` + N(0, position_sigma^2 I) (m) when a fix is due at ``position_rate``, displaced by a
            pose fault; else (or while the pose sensor drops out) ``None``.
        omega_R, omega_L: encoder wheel rates + N(0, encoder_sigma^2) (rad/s).
        pose: the true ``[x, y, psi]`` (m, m, rad), + N(0, pose_sigma^2 I) when ``pose_sigma > 0`` (the controller's
            pose with ``pose_source = "truth"``).
        pose_fix: the pose sensor's ``[x, y, psi]`` fix (m, m, rad; its ``x, y`` are :attr:`position`, its heading
            + N(0, heading σ²)) when one is delivered; else ``None``.
    """

    t: float
    speed: float
    yaw_rate: float | None
    position: np.ndarray | None
    omega_R: float
    omega_L: float
    pose: np.ndarray
    pose_fix: np.ndarray | None = None


class Sensors:
    """The run's sensors with their own seeded ``numpy.random.Generator``.

    Args:
        settings: the sensor settings (noise levels in SI units; ``None`` = sensor absent;
            :class:`~ftc_mj.model.sensors.SensorSettings`).
        seed: seed of the generator; the same settings and seed give the same readings.
        faults: the fault settings, of which the faults acting on the readings are taken (none by default).
    """

    def __init__(self, settings: SensorSettings, seed: int, faults: FaultSettings | None = None) -> None:
        self.settings = settings
        self.seed = int(seed)
        self.faults = SensorFaults(sensor_faults_of(faults))
        self._faulty = bool(self.faults)  # read at every sample: a plain attribute, not a __bool__ call
        self._fix_period = 1.0 / float(settings.position_rate)
        self._heading_sigma = settings.fix_heading_sigma
        self.reset()

    def reset(self) -> None:
        """Restart the noise sequence and the position-fix schedule (first fix at t = 0)."""
        self.rng = np.random.Generator(np.random.PCG64(self.seed))
        self._next_fix = 0.0

    def read(self, truth: Truth, t: float | None = None) -> SensorReading:
        """Sample all sensors from ``truth`` at time ``t`` (s; default ``truth.t``)."""
        c = self.settings
        t = truth.t if t is None else float(t)
        e = self.rng.standard_normal(_N_DRAWS).tolist()
        speed = truth.v + c.speed_sigma * e[0]
        yaw = None if c.yaw_rate_sigma is None else truth.yaw_rate + c.yaw_rate_sigma * e[1]
        if self._faulty:
            speed, yaw = self.faults.apply(t, speed, yaw)
        position = fix = None
        if c.position_sigma is not None and t + _EPS_T >= self._next_fix:
            fix = np.array([truth.x + c.position_sigma * e[2], truth.y + c.position_sigma * e[3],
                            truth.psi + self._heading_sigma * e[8]])
            if self._faulty:
                fix = self.faults.pose(t, fix)
            position = None if fix is None else fix[:2].copy()
            # next fix: the first multiple of the period after t
            self._next_fix = (math.floor((t + _EPS_T) / self._fix_period) + 1) * self._fix_period
        s = c.encoder_sigma
        wR = truth.omega_R + s * e[4]
        wL = truth.omega_L + s * e[5]
        ps = c.pose_sigma
        if ps > 0:
            pose = np.array([truth.x + ps * e[6], truth.y + ps * e[7], truth.psi + ps * e[8]])
        else:
            pose = np.array([truth.x, truth.y, truth.psi])
        return SensorReading(t=t, speed=speed, yaw_rate=yaw, position=position, omega_R=wR, omega_L=wL, pose=pose,
                             pose_fix=fix)
