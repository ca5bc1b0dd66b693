"""An ideal truth plant: the kinematic model itself, integrated exactly at the physics step.

Same interface as :class:`ftc_mj.plant.robot.Plant` (``reset``, ``time``, ``set_command``, ``advance``,
``set_wheel_radius``, ``truth``), selected with ``plant.kind = "kinematic"`` through
:func:`~ftc_mj.wiring.plant.build_plant`. Useful as a model-exact reference for filters and controllers (no
slip, no roll, no actuator lag: the wheel rates are the clipped commands).

Integration: while radii and commands are constant the pose follows the exact arc of
:func:`ftc_mj.model.kinematics.body_rates`' speed and yaw rate (closed form, any number of steps at once); in
windows where a fault schedule changes, each physics step is one RK4 step of
:func:`ftc_mj.model.kinematics.pose_rates` with the radii of that step (held over the step, as in the MuJoCo plant).
"""

from __future__ import annotations

import math

import numpy as np

from ..model.kinematics import body_rates, inverse_rates, pose_rates
from .base import PlantClock
from .faults.records import wheel_schedules
from .faults.tyre import EPS_T, RadiusSchedule, wheel_index
from .settings import FaultSettings, PlantSettings, RobotSettings, plant_geometry
from .truth import Truth


class KinematicPlant(PlantClock):
    """The kinematic model as a plant (see module docstring); settings as for :class:`~ftc_mj.plant.robot.Plant`
    (of the plant settings it reads the timestep, the geometry overrides and the initial pose; of the servo
    faults it takes ``lock``: a locked wheel's rate is 0 whatever the command)."""

    kind = "kinematic"
    model = None
    data = None

    def __init__(self, plant: PlantSettings, robot: RobotSettings, faults: FaultSettings) -> None:
        self.settings = plant
        self.dt: float = float(plant.timestep)
        self.nominal_radius, self.half_track = (float(v) for v in plant_geometry(plant, robot))
        self.omega_max: float = float(robot.omega_max)
        self.initial_pose: tuple[float, float, float] = tuple(float(v) for v in plant.initial_pose)  # type: ignore[assignment]
        self.schedules: tuple[RadiusSchedule, RadiusSchedule] = wheel_schedules(faults, self.nominal_radius)
        self._locked = (False, False)
        self._setup_faults(faults)
        self.reset()

    def reset(self) -> None:
        """Back to t = 0 at ``plant.initial_pose``, commands zero, radii from the schedules at t = 0."""
        x0, y0, psi0 = self.initial_pose
        self._pose = [x0, y0, psi0]
        self._k = 0
        self._cmd = [0.0, 0.0]
        self._radius = [s.value(EPS_T) for s in self.schedules]
        self._restart_faults()

    @property
    def frozen(self) -> bool:
        """Always False (the kinematic plant cannot diverge)."""
        return False

    @property
    def command(self) -> tuple[float, float]:
        """The (clipped) commands ``(omega_R, omega_L)`` (rad/s)."""
        return self._cmd[0], self._cmd[1]

    def set_command(self, omega_R: float, omega_L: float) -> None:
        """Wheel rates (rad/s), clipped to ``±omega_max``; NaN becomes 0."""
        lim = self.omega_max
        out = []
        for w in (float(omega_R), float(omega_L)):
            out.append(0.0 if w != w else max(-lim, min(lim, w)))
        self._cmd = out
        if self._locked != (False, False):
            self._cmd = [0.0 if lk else w for w, lk in zip(out, self._locked, strict=True)]

    def hold_wheels(self, lock: tuple[bool, bool]) -> None:
        """Hold each locked wheel at rate 0 whatever the command (a wheel lock,
        :class:`~ftc_mj.plant.faults.servo.ServoEffect`; without a servo the configuration admits no other
        servo fault)."""
        self._locked = lock
        self.set_command(*self._cmd)

    def set_motion(self, v: float, yaw_rate: float) -> None:
        """Start in steady motion: wheel rates (rad/s) giving forward speed ``v`` (m/s) and ``yaw_rate`` (rad/s)."""
        wR, wL = inverse_rates(v, yaw_rate, self._radius[0], self._radius[1], self.half_track)
        self.set_command(wR, wL)

    def set_wheel_radius(self, wheel: str, r: float, reseat: bool = True) -> None:
        """Set a wheel's radius (m) now; ``reseat`` has no meaning here and is accepted for interface parity."""
        r = float(r)
        if not (math.isfinite(r) and r > 0):
            raise ValueError(f"wheel radius must be finite and > 0, got {r}")
        self._radius[wheel_index(wheel)] = r

    def _arc(self, T: float) -> None:
        """Move along the exact arc of the held commands and radii for ``T`` seconds."""
        x, y, psi = self._pose
        V, w = body_rates(self._radius[0], self._radius[1], self._cmd[0], self._cmd[1], self.half_track)
        h = 0.5 * w * T
        sinc = math.sin(h) / h if abs(h) > 1e-12 else 1.0 - h * h / 6.0
        mid = psi + h
        self._pose = [x + V * T * sinc * math.cos(mid), y + V * T * sinc * math.sin(mid), psi + w * T]

    def _rk4(self, dt: float) -> None:
        """One classical Runge-Kutta step of ``dt`` seconds of the pose kinematics (radii held over the step)."""
        b, (R_R, R_L), (wR, wL) = self.half_track, self._radius, self._cmd

        def f(p: np.ndarray) -> np.ndarray:
            return np.array(pose_rates(p[2], R_R, R_L, wR, wL, b, math))

        p = np.array(self._pose)
        k1 = f(p)
        k2 = f(p + 0.5 * dt * k1)
        k3 = f(p + 0.5 * dt * k2)
        k4 = f(p + dt * k3)
        self._pose = (p + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)).tolist()

    def _advance(self, n: int) -> None:
        """Advance ``n`` physics steps with the held commands, applying the fault schedules per step."""
        if n <= 0:
            return
        k0, dt = self._k, self.dt
        t0 = k0 * dt + EPS_T
        t1 = (k0 + n - 1) * dt + EPS_T
        sR, sL = self.schedules
        for i, s in enumerate(self.schedules):
            if s.active and t0 <= s.end_time + dt:
                self._radius[i] = s.value(t0)
        if not (sR.changing(t0, t1) or sL.changing(t0, t1)):
            self._arc(n * dt)
        else:
            for j in range(n):
                t = (k0 + j) * dt + EPS_T
                self._radius[0] = sR.value(t)
                self._radius[1] = sL.value(t)
                self._rk4(dt)
        self._k = k0 + n

    def truth(self) -> Truth:
        """The state at :attr:`time`: pose, speed and yaw rate of the kinematic model; wheel rates = commands; no
        roll, pitch, slip or flags; ``z_chassis`` = nominal radius."""
        x, y, psi = self._pose
        V, w = body_rates(self._radius[0], self._radius[1], self._cmd[0], self._cmd[1], self.half_track)
        return Truth(
            t=self.time,
            x=x,
            y=y,
            psi=psi,
            v=float(V),
            yaw_rate=float(w),
            omega_R=self._cmd[0],
            omega_L=self._cmd[1],
            R_R=self._radius[0],
            R_L=self._radius[1],
            roll=0.0,
            pitch=0.0,
            z_chassis=self.nominal_radius,
            slip_R=0.0,
            slip_L=0.0,
            contact_R=True,
            contact_L=True,
            flags=0,
        )
