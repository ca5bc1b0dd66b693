"""The lateral acceleration at which the robot starts to lift its inner wheel, from the compiled MJCF.

Quasi-steady turn at lateral acceleration ``a`` (m/s², towards the centre) while braking at ``a_x``
(m/s²), wheels rolling without slip, frictionless caster (it carries load but no lateral force).
Every number is read by name from the compiled model (``ftc_mj/plant/builder.py`` applies the
settings' edits first): body masses and centres of mass (``chassis``, ``hub_*``, ``tyre_*``, and
``payload`` when there is one), the half
track ``b`` (``hub_*`` positions), the tyre radius ``R`` (``wheel_*`` spheres) and friction ``μ``, the
tyres' axle inertia ``I``, the caster position ``x_c``, the servo gain ``k_v`` (``act_*``).

*Static loads.* Moment balance about the axle: the caster carries ``N_c = M g x_G / x_c`` (``x_G``:
the robot's centre of mass ahead of the axle), each tyre ``N_0 = (M g − N_c) / 2``. Braking moves
``M a_x h_G / x_c`` onto the caster (``h_G``: height of the centre of mass), half from each tyre.

*Load transfer.* The roll moment of the inertial forces about the ground line under the axle,
``a Σ m_i h_i`` (``h_i``: height of body ``i``'s centre of mass), plus the gyroscopic moment of the
spinning wheels, ``Σ I ω Ω = a Σ I / R`` (``ω = V/R``, ``a = V Ω``), is carried by the tyres:
``N_in = N_0 − k a − M a_x h_G / (2 x_c)`` with ``k = (Σ m_i h_i + Σ I/R) / (2 b)``.

*Rollover limit* ``a_roll = N_0 / k``: the inner tyre's load reaches zero (no braking).

*Traction limit* ``a_trac(a_x)``: the inner tyre reaches its friction circle first. The caster takes no
lateral force, so the tyres' lateral force ``M a`` acts at the axle while the inertial force acts at
``x_G`` ahead of it; the yaw moment ``M a x_G`` is balanced by a couple of longitudinal tyre forces
``M a x_G / (2 b)`` (the robot understeers), to which the inner tyre adds its half of the braking
force, ``M a_x / 2``. With the lateral force shared in proportion to the loads, ``F_y,in = M a N_in /
(N_in + N_out)``, the limit is the smallest ``a`` with ``F_x,in² + F_y,in² = (μ N_in)²``. Once the inner
tyre slides it skids and hops: that is the onset of lift-off measured on the plant
(``tests/plant/test_limits.py``, ``docs/findings.md``). ``a_trac`` falls almost linearly with ``a_x``;
``braking_trade`` is its secant slope up to :data:`BRAKING_REF`.

*Yaw compliance* ``c``: the velocity servos carry the couple's torque ``F_x R`` with a rate error
``F_x R / k_v`` each, opposite on the two wheels, so the robot's yaw rate lags the commanded one by
``(R_R² + R_L²) F_x / (2 b k_v) = c a``, with the nominal tyres ``c = M x_G R² / (2 b² k_v)`` (s/m).
The kinematic model's lateral acceleration ``V psidot`` of the *commanded* rates is therefore
``(1 + c V)`` times the robot's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from .builder import GRAVITY, SIDES

BRAKING_REF = 2.0
"""Braking deceleration (m/s²) up to which ``braking_trade`` is the secant slope of the traction limit."""


@dataclass(frozen=True)
class LateralLimits:
    """Quasi-steady acceleration limits of the robot and the numbers they come from."""

    rollover: float
    """Inner tyre load zero (m/s²)."""
    traction: float
    """Inner tyre at its friction circle, no braking (m/s²)."""
    braking_trade: float
    """Loss of the traction limit per m/s² of braking (dimensionless)."""
    wheel_load: float
    """Static load of one tyre ``N_0`` (N)."""
    load_transfer: float
    """``k``: inner-tyre load lost per m/s² of lateral acceleration (N s²/m)."""
    yaw_compliance: float
    """``c`` (s/m): commanded minus actual yaw rate per m/s² of lateral acceleration, with the nominal tyres (it
    scales with ``R_R² + R_L²``)."""

    @property
    def liftoff(self) -> float:
        """The binding limit without braking (m/s²): the smaller of the two."""
        return min(self.rollover, self.traction)


@dataclass(frozen=True)
class _Robot:
    """The numbers of the derivation (SI units, see the module docstring)."""

    M: float
    x_G: float
    h_G: float
    b: float
    mu: float
    N0: float
    k: float
    x_c: float

    def traction(self, a_x: float, a_max: float) -> float:
        """Smallest lateral ``a`` in ``(0, a_max]`` at which the inner tyre's force demand reaches ``μ N_in``
        while braking at ``a_x`` (bisection: the demand grows and the load falls with ``a``)."""
        dN = self.M * a_x * self.h_G / (2.0 * self.x_c)

        def excess(a: float) -> float:
            n_in = self.N0 - self.k * a - dN
            fx = self.M * a * self.x_G / (2.0 * self.b) + 0.5 * self.M * a_x
            return math.hypot(fx, self.M * a * n_in / (2.0 * (self.N0 - dN))) - self.mu * n_in

        lo, hi = 0.0, a_max
        if excess(hi) <= 0.0:
            return a_max
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if excess(mid) < 0.0 else (lo, mid)
        return 0.5 * (lo + hi)


def lateral_accel_limits(model: mujoco.MjModel) -> LateralLimits:
    """The limits of the level robot at its rest pose ``qpos0`` with its nominal tyres (see the module
    docstring for the maths). ``model`` is a compiled model of the built-in ``diffdrive.xml``."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    g = GRAVITY
    axle = data.xpos[model.body("chassis").id]
    heading = data.xmat[model.body("chassis").id].reshape(3, 3)[:, 0]
    bodies = [model.body("chassis").id] + [model.body(f"{p}_{s}").id for p in ("hub", "tyre") for s in SIDES]
    payload = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "payload")  # plant.payload_mass > 0
    bodies += [payload] if payload >= 0 else []
    mass = np.array([model.body_mass[i] for i in bodies])
    com = np.array([data.xipos[i] for i in bodies])
    M = float(mass.sum())
    x_G = float(mass @ ((com - axle) @ heading)) / M
    sum_mh = float(mass @ com[:, 2])
    gyro = 0.0
    for s in SIDES:
        tyre = model.body(f"tyre_{s}").id
        gyro += float(model.body_inertia[tyre][1]) / float(model.geom(f"wheel_{s}").size[0])
    b = 0.5 * abs(float(data.xpos[model.body("hub_left").id][1] - data.xpos[model.body("hub_right").id][1]))
    x_c = float((data.geom_xpos[model.geom("caster").id] - axle) @ heading)
    R = float(model.geom("wheel_left").size[0])
    kv = float(model.actuator("act_left").gainprm[0])
    N0 = 0.5 * (M * g - M * g * x_G / x_c)
    k = (sum_mh + gyro) / (2.0 * b)
    robot = _Robot(M=M, x_G=x_G, h_G=sum_mh / M, b=b, mu=float(model.geom("wheel_left").friction[0]), N0=N0,
                   k=k, x_c=x_c)
    a_roll = N0 / k
    a0 = robot.traction(0.0, a_roll)
    return LateralLimits(rollover=a_roll, traction=a0,
                         braking_trade=(a0 - robot.traction(BRAKING_REF, a_roll)) / BRAKING_REF,
                         wheel_load=N0, load_transfer=k, yaw_compliance=M * x_G * R * R / (2.0 * b * b * kv))


@dataclass(frozen=True)
class ServoLimits:
    """What one velocity servo's torque limit ``τ_max`` (N m) allows the robot, with its nominal gain and limit
    (a servo left with the fraction ``e`` of both allows ``e`` times each: the torque scales, the loads do
    not)."""

    lateral: float
    """Lateral acceleration (m/s²) at which the yaw couple's tyre force ``M a x_G / (2 b)`` (module docstring,
    *Yaw compliance*) needs ``τ_max`` of one wheel: ``a_s = 2 b τ_max / (M x_G R) = τ_max R / (b k_v c)``."""
    longitudinal: float
    """Longitudinal acceleration (m/s²) at which one wheel's half of the force ``M a_x`` plus its tyre's spin
    inertia ``I a_x / R`` needs ``τ_max``: ``a_x,s = τ_max / (M R / 2 + I / R)`` (both wheels share it: a
    differential drive that pushed harder on one side would turn)."""


def servo_limits(model: mujoco.MjModel) -> ServoLimits:
    """The servo-torque limits of the level robot with its nominal tyres (:class:`ServoLimits`); ``model`` is a
    compiled model of the built-in ``diffdrive.xml``."""
    lat = lateral_accel_limits(model)
    R = float(model.geom("wheel_left").size[0])
    act = model.actuator("act_left")
    kv, tau = float(act.gainprm[0]), float(act.forcerange[1])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    b = 0.5 * abs(float(data.xpos[model.body("hub_left").id][1] - data.xpos[model.body("hub_right").id][1]))
    M = float(np.sum(model.body_mass))
    inertia = float(model.body_inertia[model.body("tyre_left").id][1])
    return ServoLimits(lateral=tau * R / (b * kv * lat.yaw_compliance), longitudinal=tau / (0.5 * M * R + inertia / R))
