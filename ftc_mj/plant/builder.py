"""Build the compiled MuJoCo model of the truth plant from the MJCF file and the plant and robot settings.

The MJCF (``plant.model_file``; by default ``builtin:diffdrive.xml``, the robot shipped in
``ftc_mj/data/models/``, :mod:`ftc_mj.resources`) is loaded through :class:`mujoco.MjSpec`; static edits from the
plant and robot settings (variant, wheel radius, half track, masses, friction, actuator gain, rate limit, timestep)
are applied to the spec, then it is compiled once. Runtime changes (punctures) never recompile: they edit
``geom_size`` in place (see :meth:`ftc_mj.plant.robot.Plant.set_wheel_radius`).

Every element is looked up by name; the names are listed in :data:`REQUIRED_NAMES`.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from ..errors import BadInput
from ..resources import model_path
from .settings import PlantSettings, RobotSettings, plant_geometry

GRAVITY = 9.81
"""Standard gravity (m/s^2) used for the spring preload; the MJCF's ``option/gravity`` must agree."""

SIDES = ("right", "left")

REQUIRED_NAMES: dict[str, tuple[str, ...]] = {
    "body": ("chassis", "hub_right", "hub_left", "tyre_right", "tyre_left"),
    "geom": ("floor", "wheel_right", "wheel_left", "wheel_right_visual", "wheel_left_visual", "caster"),
    "joint": ("root", "hinge_right", "hinge_left", "slide_right", "slide_left"),
    "actuator": ("act_right", "act_left"),
}
"""Names the plant relies on (the MJCF contract)."""


def _bad(path: Path, why: str) -> BadInput:
    first = str(why).strip().splitlines()[0] if str(why).strip() else "invalid model"
    return BadInput(f"plant.model_file: {path}: {first}")


def load_spec(path: Path | str) -> mujoco.MjSpec:
    """Parse the MJCF file (a path, or ``builtin:<name>`` for a shipped model) into an ``MjSpec``; a
    missing or unparsable file raises :class:`BadInput`."""
    try:
        p = model_path(str(path))
    except ValueError as err:
        raise _bad(Path(str(path)), str(err)) from None
    if not p.is_file():
        raise _bad(p, "file not found")
    try:
        spec = mujoco.MjSpec.from_file(str(p))
    except Exception as err:  # mujoco raises ValueError for parse errors
        raise _bad(p, str(err)) from None
    for kind, names in REQUIRED_NAMES.items():
        getter = getattr(spec, kind)
        for name in names:
            if getter(name) is None:
                raise _bad(p, f"missing {kind} named {name!r}")
    return spec


def _edit_spec(spec: mujoco.MjSpec, plant: PlantSettings, robot: RobotSettings) -> None:
    """Apply the static settings edits to ``spec`` in place (units: m, kg, rad/s, N m s/rad, s)."""
    R, b = (float(v) for v in plant_geometry(plant, robot))
    spec.option.timestep = float(plant.timestep)
    m_c = _edit_chassis(spec, plant, R, b)
    lam = float(plant.wheel_load_fraction)
    for side, y in (("right", -b), ("left", b)):
        _edit_wheel(spec, plant, robot, side, y, R)
        _edit_slide(spec, plant, side, 0.5 * lam * m_c * GRAVITY)
    caster = spec.geom("caster")
    mu_c = float(plant.caster_friction)
    caster.friction = [mu_c, 0.0, 0.0]
    caster.condim = 1 if mu_c == 0.0 else 3
    _add_payload(spec, plant)


PAYLOAD_RADIUS = 0.2
"""Radius (m) of the uniform ball whose inertia a payload gets (a compact load; its mass matters, not its shape)."""


def _add_payload(spec: mujoco.MjSpec, plant: PlantSettings) -> None:
    """A payload of ``plant.payload_mass`` (kg) at ``plant.payload_offset`` (m, chassis frame) as a body welded to
    the chassis, with a uniform ball's inertia and a drawn-only geom; nothing without a mass (the model stays the
    MJCF's, bit for bit)."""
    m = float(getattr(plant, "payload_mass", 0.0) or 0.0)
    if m <= 0.0:
        return
    offset = [float(v) for v in plant.payload_offset]
    body = spec.body("chassis").add_body(name="payload", pos=offset, ipos=[0.0, 0.0, 0.0], mass=m,
                                         inertia=[0.4 * m * PAYLOAD_RADIUS ** 2] * 3)
    body.add_geom(name="payload_visual", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[PAYLOAD_RADIUS, 0, 0],
                  contype=0, conaffinity=0, rgba=[0.9, 0.7, 0.1, 1.0], density=0.0)


def _edit_chassis(spec: mujoco.MjSpec, plant: PlantSettings, R: float, b: float) -> float:
    """Put the chassis origin at hub height ``R`` (m) with everything below it at its height above ground,
    the axle drawn across the half track ``b`` (m), the mass (kg) and the centre of mass between axle and
    caster; returns the chassis mass (kg)."""
    chassis = spec.body("chassis")
    R_file = float(chassis.pos[2])  # the file's nominal hub height = its wheel radius
    dz = R - R_file

    chassis.pos = [chassis.pos[0], chassis.pos[1], R]
    for g in spec.geoms:
        if g.parent is not None and g.parent.name == "chassis" and g.name not in ("axle_visual",):
            ft = np.array(g.fromto, dtype=float)
            if np.all(np.isfinite(ft)):
                g.fromto = [ft[0], ft[1], ft[2] - dz, ft[3], ft[4], ft[5] - dz]
            else:
                g.pos = [g.pos[0], g.pos[1], g.pos[2] - dz]
    axle = spec.geom("axle_visual")
    if axle is not None:
        axle.fromto = [0.0, -(b - 0.2), 0.0, 0.0, b - 0.2, 0.0]

    m_c_file = float(chassis.mass)
    m_c = float(plant.chassis_mass or m_c_file)
    ipos = np.array(chassis.ipos, dtype=float)
    ipos[2] -= dz
    # Centre of mass between axle and caster so that the slides carry `lambda` of the chassis weight and the caster
    # the rest, whatever the masses (moment balance about the axle: W c_x = (1 - lambda) W x_caster).
    lam = float(plant.wheel_load_fraction)
    x_caster = float(spec.geom("caster").pos[0])
    ipos[0] = (1.0 - lam) * x_caster
    chassis.ipos = ipos
    chassis.inertia = np.array(chassis.inertia, dtype=float) * (m_c / m_c_file)
    chassis.mass = m_c
    return m_c


def _edit_wheel(spec: mujoco.MjSpec, plant: PlantSettings, robot: RobotSettings, side: str, y: float,
                R: float) -> None:
    """One wheel: hub at lateral offset ``y`` (m), tyre of radius ``R`` (m) with its mass (kg) and disc
    inertia, friction, drawn size, and its servo's gain (N m s/rad) and rate range (rad/s)."""
    hub = spec.body(f"hub_{side}")
    hub.pos = [0.0, y, 0.0]
    tyre = spec.body(f"tyre_{side}")
    m_w = float(plant.wheel_mass or tyre.mass)
    tyre.mass = m_w
    tyre.inertia = [m_w * R * R / 4.0, m_w * R * R / 2.0, m_w * R * R / 4.0]  # uniform disc
    sphere = spec.geom(f"wheel_{side}")
    sphere.size = [R, 0.0, 0.0]
    if plant.tyre_friction is not None:
        sphere.friction = [float(plant.tyre_friction), sphere.friction[1], sphere.friction[2]]
    visual = spec.geom(f"wheel_{side}_visual")
    visual.size = [R, visual.size[1], 0.0]
    spoke = spec.geom(f"wheel_{side}_spoke")
    if spoke is not None:
        spoke.size = [0.9 * R, spoke.size[1], spoke.size[2]]
    act = spec.actuator(f"act_{side}")
    if plant.actuator_gain is not None:
        kv = float(plant.actuator_gain)
        gp = np.array(act.gainprm, dtype=float)
        bp = np.array(act.biasprm, dtype=float)
        gp[0], bp[2] = kv, -kv
        act.gainprm, act.biasprm = gp, bp
    act.ctrlrange = [-float(robot.omega_max), float(robot.omega_max)]


def _edit_slide(spec: mujoco.MjSpec, plant: PlantSettings, side: str, F: float) -> None:
    """The wheel's slide: deleted on the rigid variant, else its spring preloaded to push the hub down with
    ``F`` (N) at q = 0 (force = -k (q - springref))."""
    slide = spec.joint(f"slide_{side}")
    if plant.variant == "rigid":
        spec.delete(slide)
        return
    k = float(np.atleast_1d(slide.stiffness)[0])
    if k <= 0:
        raise BadInput(f"plant.model_file: slide_{side} needs a positive stiffness")
    slide.springref = -F / k


def build_model(plant: PlantSettings, robot: RobotSettings) -> mujoco.MjModel:
    """Load ``plant.model_file``, apply the settings' static edits and compile.

    Raises :class:`~ftc_mj.errors.BadInput` (message starting with ``plant.model_file``) when the file is missing,
    unparsable, lacks a required name, or does not compile.
    """
    spec = load_spec(plant.model_file)
    _edit_spec(spec, plant, robot)
    try:
        return spec.compile()
    except Exception as err:
        raise _bad(Path(plant.model_file), f"does not compile: {err}") from None
