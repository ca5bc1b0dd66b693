"""The kinematic quantities of :class:`~ftc_mj.plant.truth.Truth` from a MuJoCo state (``qpos``/``qvel``).

Pure functions on Python floats (lists from ``qpos.tolist()``: at the estimator rate this is cheaper than
numpy for these short vectors). Frames: world z up; chassis x forward, y left; the free joint's linear
velocity is in the world frame and its angular velocity in the chassis frame. SI units, radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .truth import LARGE_ROLL, LIFTOFF, SCRAPE, SLIP, TIPPED

Rotation = tuple[float, float, float, float, float, float, float, float, float]
"""A rotation matrix (world <- chassis), row by row: ``r00, r01, r02, r10, …, r22``."""


def wrap_angle(a: float) -> float:
    """``a`` (rad) wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def chassis_rotation(quat: Sequence[float]) -> Rotation:
    """The rotation matrix (world <- chassis) of the quaternion ``(w, x, y, z)``, normalised first."""
    w, qx, qy, qz = quat
    nq = math.sqrt(w * w + qx * qx + qy * qy + qz * qz) or 1.0
    w, qx, qy, qz = w / nq, qx / nq, qy / nq, qz / nq
    return (
        1 - 2 * (qy * qy + qz * qz),
        2 * (qx * qy - w * qz),
        2 * (qx * qz + w * qy),
        2 * (qx * qy + w * qz),
        1 - 2 * (qx * qx + qz * qz),
        2 * (qy * qz - w * qx),
        2 * (qx * qz - w * qy),
        2 * (qy * qz + w * qx),
        1 - 2 * (qx * qx + qy * qy),
    )


def attitude(rot: Rotation) -> tuple[float, float, float]:
    """Roll, pitch (ZYX Euler angles, pitch > 0 = nose down) and the heading in (-pi, pi] (rad) of ``rot``."""
    r00, _, _, r10, _, _, r20, r21, r22 = rot
    roll = math.atan2(r21, r22)
    pitch = math.asin(max(-1.0, min(1.0, -r20)))
    return roll, pitch, math.atan2(r10, r00)


def world_rate(rot: Rotation, body_rate: Sequence[float]) -> tuple[float, float, float]:
    """The chassis angular velocity (rad/s) in the world frame from its body-frame value ``body_rate``."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    lx, ly, lz = body_rate
    return (r00 * lx + r01 * ly + r02 * lz,
            r10 * lx + r11 * ly + r12 * lz,
            r20 * lx + r21 * ly + r22 * lz)


def axle_motion(rot: Rotation, pos: Sequence[float], vel: Sequence[float], spin: Sequence[float],
                psi: float, hub_y: Sequence[float], slide: Sequence[float], slide_rate: Sequence[float],
                omegas: Sequence[float], radii: Sequence[float]) -> tuple[float, float, float, list[float]]:
    """Position ``x, y`` (m) and forward speed ``v`` (m/s) of the axle midpoint, and the longitudinal slip
    speeds (m/s) of the right and left tyre.

    Args:
        rot: the chassis rotation; ``pos``, ``vel``: chassis origin position (m) and velocity (m/s);
            ``spin``: chassis angular velocity in the world (rad/s); ``psi``: unwrapped heading (rad).
        hub_y: lateral hub offsets (m); ``slide``, ``slide_rate``: slide positions (m) and rates (m/s);
            ``omegas``: wheel rates relative to the hub (rad/s); ``radii``: tyre radii (m).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
    px, py, pz = pos
    vx, vy, vz = vel
    wx, wy, wz = spin
    c, s = math.cos(psi), math.sin(psi)
    hubs = []
    slips = []
    for i in (0, 1):
        ay, az = hub_y[i], slide[i]
        # hub offset in world: R (0, ay, az)
        ox, oy, oz = r01 * ay + r02 * az, r11 * ay + r12 * az, r21 * ay + r22 * az
        hx, hy, hz = px + ox, py + oy, pz + oz
        # hub velocity: v + w x o + R e_z qdot
        hvx = vx + (wy * oz - wz * oy) + r02 * slide_rate[i]
        hvy = vy + (wz * ox - wx * oz) + r12 * slide_rate[i]
        hvz = vz + (wx * oy - wy * ox) + r22 * slide_rate[i]
        # wheel angular velocity: chassis + R e_y * omega
        Wx = wx + r01 * omegas[i]
        Wy = wy + r11 * omegas[i]
        r = radii[i]
        # lowest point of the sphere: hub - r e_z; velocity = v_hub + W x (0, 0, -r)
        cvx = hvx - r * Wy
        cvy = hvy + r * Wx
        slips.append(-(cvx * c + cvy * s))
        hubs.append((hx, hy, hz, hvx, hvy, hvz))
    x = 0.5 * (hubs[0][0] + hubs[1][0])
    y = 0.5 * (hubs[0][1] + hubs[1][1])
    v = 0.5 * ((hubs[0][3] + hubs[1][3]) * c + (hubs[0][4] + hubs[1][4]) * s)
    return x, y, v, slips


def domain_flags(contact_R: bool, contact_L: bool, scraping: bool, roll: float, pitch: float, upright: float,
                 slips: Sequence[float], tilt_limit: float, tipped_limit: float, slip_limit: float) -> int:
    """The non-sticky flags of :mod:`ftc_mj.plant.truth`: ``LIFTOFF`` (a tyre without floor contact),
    ``SCRAPE``, ``LARGE_ROLL`` and ``TIPPED`` (roll or pitch, rad, beyond the limits, rad, or the chassis
    upside down: ``upright`` = r22 < 0) and ``SLIP`` (a slip speed beyond ``slip_limit``, m/s)."""
    flags = 0
    if not (contact_R and contact_L):
        flags |= LIFTOFF
    if scraping:
        flags |= SCRAPE
    tilt = max(abs(roll), abs(pitch))
    if tilt > tilt_limit:
        flags |= LARGE_ROLL
    if tilt > tipped_limit or upright < 0.0:
        flags |= TIPPED
    if abs(slips[0]) > slip_limit or abs(slips[1]) > slip_limit:
        flags |= SLIP
    return flags
