"""Where the plant finds its parts in a compiled MuJoCo model: ids and addresses looked up by name.

Every element is found by the name the MJCF contract gives it (:data:`ftc_mj.plant.builder.REQUIRED_NAMES`),
once per model; the plant then indexes ``qpos``/``qvel``/``geom_size`` with these numbers at every step.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from .builder import SIDES


@dataclass(frozen=True)
class ModelLayout:
    """Ids and addresses of the robot's parts in one compiled model (right wheel first in every pair)."""

    sphere_geoms: tuple[int, int]
    """The tyres' collision spheres."""
    visual_geoms: tuple[int, int]
    """The drawn tyres."""
    spoke_geoms: tuple[int, int]
    """The drawn spokes (-1: none)."""
    visual_ratio: float
    """Drawn tyre radius / collision radius (kept when a radius changes)."""
    spoke_ratio: float
    """Spoke length / collision radius (0 without spokes)."""
    root_q: int
    """``qpos`` address of the free joint (position, then the quaternion w, x, y, z)."""
    root_v: int
    """``qvel`` address of the free joint (linear velocity in the world, angular velocity in the body)."""
    hinge_v: tuple[int, int]
    """``qvel`` addresses of the wheel hinges (rad/s)."""
    slide_q: tuple[int, int] | None
    """``qpos`` addresses of the suspension slides (m); ``None`` on the rigid variant."""
    slide_v: tuple[int, int] | None
    """``qvel`` addresses of the slides (m/s); ``None`` on the rigid variant."""
    slide_range: tuple[tuple[float, float], tuple[float, float]] | None
    """Joint ranges (m) of the slides; ``None`` on the rigid variant."""
    hub_y: tuple[float, float]
    """Lateral offsets (m) of the hubs in the chassis frame."""
    actuators: tuple[int, int]
    """The wheel-rate servos."""
    scrape_geoms: frozenset[int]
    """Colliding geoms of the chassis and hubs (not the caster, not the tyres): touching the floor = scrape."""


def model_layout(m: mujoco.MjModel, variant: str) -> ModelLayout:
    """The layout of ``m``, built for ``variant`` (``"suspended"`` has slides, ``"rigid"`` has none)."""
    sphere = (m.geom("wheel_right").id, m.geom("wheel_left").id)
    visual = (m.geom("wheel_right_visual").id, m.geom("wheel_left_visual").id)
    spokes = []
    for side in SIDES:
        try:
            spokes.append(m.geom(f"wheel_{side}_spoke").id)
        except KeyError:
            spokes.append(-1)
    root = m.joint("root")
    if variant == "suspended":
        js = (m.joint("slide_right"), m.joint("slide_left"))
        slide_q = (int(js[0].qposadr[0]), int(js[1].qposadr[0]))
        slide_v = (int(js[0].dofadr[0]), int(js[1].dofadr[0]))
        slide_range = tuple((float(j.range[0]), float(j.range[1])) for j in js)
    else:
        slide_q = slide_v = slide_range = None
    return ModelLayout(
        sphere_geoms=sphere,
        visual_geoms=visual,
        spoke_geoms=(spokes[0], spokes[1]),
        visual_ratio=float(m.geom_size[visual[0], 0] / m.geom_size[sphere[0], 0]),
        spoke_ratio=float(m.geom_size[spokes[0], 0] / m.geom_size[sphere[0], 0]) if spokes[0] >= 0 else 0.0,
        root_q=int(root.qposadr[0]),
        root_v=int(root.dofadr[0]),
        hinge_v=(int(m.joint("hinge_right").dofadr[0]), int(m.joint("hinge_left").dofadr[0])),
        slide_q=slide_q,
        slide_v=slide_v,
        slide_range=slide_range,  # type: ignore[arg-type]
        hub_y=(float(m.body("hub_right").pos[1]), float(m.body("hub_left").pos[1])),
        actuators=(m.actuator("act_right").id, m.actuator("act_left").id),
        scrape_geoms=_scrape_geoms(m, sphere),
    )


def _scrape_geoms(m: mujoco.MjModel, sphere: tuple[int, int]) -> frozenset[int]:
    """Colliding geoms of the chassis and hubs other than the floor, the caster and the tyres ``sphere``."""
    excluded = {m.geom("floor").id, m.geom("caster").id, *sphere}
    bodies = {m.body("chassis").id, m.body("hub_right").id, m.body("hub_left").id}
    return frozenset(
        g
        for g in range(m.ngeom)
        if g not in excluded
        and (m.geom_contype[g] or m.geom_conaffinity[g])
        and m.geom_bodyid[g] != 0
        and m.geom_bodyid[g] in bodies
    )
