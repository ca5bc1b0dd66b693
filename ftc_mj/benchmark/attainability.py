"""What the damaged robot of a draw can still do, from the draw's truth and the robot's MJCF alone: the speed it can
physically make along the path (:func:`drive_capacity`) and the draw's label, ``trackable`` or ``stop-only``
(:attr:`Capacity.label`). The scorer computes both (never the method, never from a run): they depend on the drawn plant,
the drawn faults and the path only, not on the CPU.

The physics (SI units), quasi-steady, level ground, wheels of radius ``R_i`` driven by velocity servos of torque
limit ``τ_max`` (the MJCF's ``forcerange``), scaled by each servo's remaining effectiveness ``e_i`` (a loss: its
drawn fraction; an unresponsive servo: 0):

*Force a tyre can push with*: ``F_i = min(e_i τ_max / R_i, μ N_in(a))`` — the servo's torque at the tyre, or its
traction, the sliding friction ``μ`` (the drawn ``tyre_friction``) times the inner tyre's load ``N_in = N_0 − k a``
at lateral acceleration ``a`` (static load ``N_0`` and load transfer ``k`` from
:func:`~ftc_mj.plant.limits.lateral_accel_limits` of the drawn plant: its masses, payload and friction).

*Force the path demands of each tyre* at speed ``v`` on curvature ``κ`` (``a = v² |κ|``): the couple that turns
the robot, ``β a`` with ``β = M x_G / (2 b)`` (the centre of mass ``x_G`` ahead of the axle: the lateral tyre
forces act at the axle, so the yaw moment ``M a x_G`` is a couple of longitudinal forces at ± the half track
``b``; read from the yaw compliance ``c = M x_G R² / (2 b² k_v)`` as ``β = c b k_v / R²``), plus a control reserve
``M a_r / 2`` (:data:`RESERVE_ACCEL`: what each tyre needs to correct the speed and heading at all). A locked wheel
adds its tyre's sliding friction ``μ N_0`` to the other tyre's demand (the other motor drags it).

*Largest lateral acceleration* of a wheel: ``a_i = min((e_i τ_max/R_i − r − d)/β, (μ N_0 − r − d)/(β + μ k),
a_lift)`` (``r`` the reserve, ``d`` the drag of a locked other wheel, ``a_lift`` the lift-off limit), the two first
from ``β a + r + d ≤ F_i``; the robot's is the smaller of its turning wheels'. Negative: no speed at all.

*Speed the damaged robot can make* on the path: the smallest over the path's curvatures of ``√(a_max / |κ|)``
(unbounded on a line), the wheel-rate limit's speed with the damaged radii
(:func:`~ftc_mj.model.kinematics.max_path_speed`, as :func:`~ftc_mj.metrics.path.feasible_speed`; a locked wheel
slides, so the healthy radius stands for it there), and the desired speed.

*Label*: ``trackable`` when that speed is at least ``trackable_speed_fraction`` of the desired speed (the path at a
reduced but non-zero speed), ``stop-only`` otherwise: a lock whose other motor cannot beat the locked tyre's friction
(``τ_max / R = 1500 N m / 2 m = 750 N`` against ``μ N_0``: 907–1789 N on ftc-v2's dev draws 0–99, whose static
tyre loads are 1260–1520 N), an unresponsive servo (no force at all: no couple, no reserve). Faults of other
components (sensors, plug-in classes) leave the drive as it is.

*Not modelled*: the outer tyre's extra load (bounding both tyres by the inner one's load is conservative); the
load shift of a punctured robot's tilt (either way); rolling resistance and the yaw moment a dragged locked tyre adds
(both would make a draw harder). A trackable draw the ``oracle`` row fails is listed on the page: there the rule or the
oracle is wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import RunConfig
from ..model.kinematics import max_path_speed
from ..plant.builder import build_model
from ..plant.faults import fault_class, fault_list, wheel_schedules
from ..plant.limits import lateral_accel_limits

RESERVE_ACCEL = 0.1
"""Acceleration (m/s²) each tyre must still be able to give half the robot's mass beyond the path's couple: the
least authority that corrects speed and heading (a tyre that can give none cannot track, whatever the path)."""
TRACKABLE = "trackable"
STOP_ONLY = "stop-only"


@dataclass(frozen=True)
class DriveRobot:
    """The drawn robot's drive numbers read from its compiled MJCF (SI units)."""

    torque_max: float
    """Servo torque limit (N m)."""
    friction: float
    """Tyre sliding friction μ."""
    wheel_load: float
    """Static load of one tyre ``N_0`` (N)."""
    load_transfer: float
    """``k`` (N s²/m): inner-tyre load lost per m/s² of lateral acceleration."""
    couple: float
    """``β = M x_G / (2 b)`` (kg): each tyre's longitudinal force per m/s² of lateral acceleration."""
    reserve: float
    """``M a_r / 2`` (N): each tyre's control reserve."""
    liftoff: float
    """Lift-off lateral acceleration (m/s²)."""


@dataclass(frozen=True)
class DriveState:
    """The servos and tyres after a set of faults: remaining effectiveness, lock and radius (m) per wheel (right,
    left)."""

    effectiveness: tuple[float, float] = (1.0, 1.0)
    locked: tuple[bool, bool] = (False, False)
    radius: tuple[float, float] | None = None


@dataclass(frozen=True)
class Capacity:
    """What the damaged robot can make on the path: speed (m/s), label and why."""

    speed: float
    label: str
    reason: str


def drive_robot(cfg: RunConfig) -> DriveRobot:
    """The drive numbers of ``cfg``'s drawn plant (module docstring), from its compiled MJCF."""
    model = build_model(cfg.plant, cfg.robot)
    lim = lateral_accel_limits(model)
    R = float(model.geom("wheel_left").size[0])
    b = 0.5 * abs(float(model.body("hub_left").pos[1] - model.body("hub_right").pos[1]))
    kv = float(model.actuator("act_left").gainprm[0])
    mass = float(np.sum(model.body_mass))
    return DriveRobot(torque_max=float(model.actuator("act_left").forcerange[1]),
                      friction=float(model.geom("wheel_left").friction[0]), wheel_load=lim.wheel_load,
                      load_transfer=lim.load_transfer, couple=abs(lim.yaw_compliance) * b * kv / (R * R),
                      reserve=0.5 * mass * RESERVE_ACCEL, liftoff=lim.liftoff)


def drive_state(cfg: RunConfig, until: float = math.inf) -> DriveState:
    """The servos and final tyre radii after every fault of ``cfg`` with onset ≤ ``until`` (s): a loss multiplies
    the wheel's effectiveness by its remaining fraction (size = lost fraction), an unresponsive servo makes it 0, a
    lock holds the wheel; a tyre fault sets the wheel's final scheduled radius. Other components: no change."""
    R0 = cfg.plant_wheel_radius
    eff, lock, radius = [1.0, 1.0], [False, False], [R0, R0]
    finals = [s.final for s in wheel_schedules(cfg.faults, R0)]
    for f in fault_list(cfg.faults, R0):
        if f.onset > until or f.target not in ("right", "left"):
            continue
        i = 0 if f.target == "right" else 1
        cls = fault_class(f.fault_class)
        if cls.component == "tyre":
            radius[i] = finals[i]
        elif cls.component == "servo" and cls.mode == "lock":
            lock[i] = True
        elif cls.component == "servo":
            eff[i] *= 0.0 if cls.mode == "unresponsive" else 1.0 - float(f.size)
    return DriveState((eff[0], eff[1]), (lock[0], lock[1]), (radius[0], radius[1]))


def wheel_accel_limit(robot: DriveRobot, effectiveness: float, radius: float, drag: float) -> float:
    """Largest lateral acceleration (m/s²) at which one tyre covers the path's couple, its reserve and ``drag`` (N,
    a locked other tyre's friction) with its servo's torque and its traction (module docstring); negative when it
    cannot cover them even at rest."""
    need = robot.reserve + drag
    by_torque = (effectiveness * robot.torque_max / radius - need) / robot.couple
    by_traction = (robot.friction * robot.wheel_load - need) / (robot.couple + robot.friction * robot.load_transfer)
    return min(by_torque, by_traction, robot.liftoff)


def drive_capacity(robot: DriveRobot, state: DriveState, curvatures: Any, desired: float, half_track: float,
                   omega_max: float, trackable_fraction: float) -> Capacity:
    """The speed (m/s) the damaged robot ``state`` can make on a path of ``curvatures`` (1/m) asked at ``desired``
    (m/s), with the wheel-rate limit ``omega_max`` (rad/s) and the true ``half_track`` (m), and its label (module
    docstring: the maths)."""
    R = state.radius
    assert R is not None
    drag = [robot.friction * robot.wheel_load if state.locked[1 - i] else 0.0 for i in (0, 1)]
    if all(state.locked):
        return Capacity(0.0, STOP_ONLY, "both wheels locked")
    a_max = min(wheel_accel_limit(robot, state.effectiveness[i], R[i], drag[i])
                for i in (0, 1) if not state.locked[i])
    if a_max < 0.0:
        why = ("the other motor's force does not beat the locked tyre's friction "
               f"{drag[0] + drag[1]:.0f} N" if any(state.locked) else "a servo cannot give its tyre any force")
        return Capacity(0.0, STOP_ONLY, why)
    k = np.abs(np.asarray(curvatures, float))
    v_force = float(np.min(np.sqrt(a_max / k[k > 0]))) if np.any(k > 0) else math.inf
    kin = [R[i] if not state.locked[i] else max(R) for i in (0, 1)]
    v_kin = float(np.min(max_path_speed(np.asarray(curvatures, float), kin[0], kin[1], half_track, omega_max)))
    speed = min(v_force, v_kin, desired)
    if speed < trackable_fraction * desired:
        return Capacity(speed, STOP_ONLY, f"{speed:.2f} m/s below {trackable_fraction:g} of the desired speed")
    return Capacity(speed, TRACKABLE, "")
