"""Reference paths with a constant-speed time law: circle, straight line, figure-eight.

Every reference starts *at* the initial pose ``(x0, y0, psi0)`` (m, m, rad) and is traversed at the
constant speed ``V`` (m/s). ``at(t)`` is vectorised over ``t`` (s) and returns ``x, y`` (m), a
continuous (unwrapped) heading ``psi`` (rad), the speed ``V`` (m/s) and the yaw rate ``psidot``
(rad/s).

Cross-track sign convention: ``cross_track(x, y)`` is the signed distance (m) from the path,
**positive to the left** of the direction of travel (for a counter-clockwise circle: inside).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import numpy as np

from ..config import RunConfig
from ..registry import BUILTIN, references


class RefSample(NamedTuple):
    """Reference values at one or many times (arrays broadcast like ``t``)."""

    x: np.ndarray
    y: np.ndarray
    psi: np.ndarray
    V: np.ndarray
    psidot: np.ndarray


class Reference(Protocol):
    """What the controllers need from a reference."""

    speed: float

    def at(self, t: np.ndarray | float) -> RefSample: ...

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray: ...

    def path_points(self, n: int = 200) -> np.ndarray: ...


class CircleReference:
    """A circle of radius ``radius`` (m) through the initial pose, tangent to its heading.

    ``direction="ccw"`` puts the centre ``radius`` to the left of the initial pose (robot at the
    origin heading +x: centre (0, radius)); ``"cw"`` to the right.
    """

    def __init__(
        self,
        radius: float = 50.0,
        speed: float = 10.0,
        direction: str = "ccw",
        initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        if radius <= 0 or speed <= 0:
            raise ValueError("radius and speed must be > 0")
        self.radius = float(radius)
        self.speed = float(speed)
        self.sign = 1.0 if direction == "ccw" else -1.0
        x0, y0, psi0 = (float(v) for v in initial_pose)
        self.psi0 = psi0
        s = self.sign
        self.center = np.array([x0 - s * self.radius * math.sin(psi0), y0 + s * self.radius * math.cos(psi0)])
        self.theta0 = psi0 - s * math.pi / 2  # polar angle of the start point seen from the centre
        self.omega = s * self.speed / self.radius  # yaw rate (rad/s), signed

    @property
    def period(self) -> float:
        """Lap time (s)."""
        return 2 * math.pi * self.radius / self.speed

    def at(self, t: np.ndarray | float) -> RefSample:
        t = np.asarray(t, dtype=float)
        th = self.theta0 + self.omega * t
        x = self.center[0] + self.radius * np.cos(th)
        y = self.center[1] + self.radius * np.sin(th)
        psi = self.psi0 + self.omega * t
        return RefSample(x, y, psi, np.full_like(t, self.speed), np.full_like(t, self.omega))

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        d = np.hypot(np.asarray(x, float) - self.center[0], np.asarray(y, float) - self.center[1])
        return self.sign * (self.radius - d)

    def path_points(self, n: int = 200) -> np.ndarray:
        """(n, 2) points of one lap (m), for drawing."""
        return np.stack(self.at(np.linspace(0, self.period, n))[:2], axis=1)


class LineReference:
    """A straight line from the initial pose along its heading."""

    def __init__(self, speed: float = 10.0, initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        if speed <= 0:
            raise ValueError("speed must be > 0")
        self.speed = float(speed)
        self.x0, self.y0, self.psi0 = (float(v) for v in initial_pose)

    def at(self, t: np.ndarray | float) -> RefSample:
        t = np.asarray(t, dtype=float)
        c, s = math.cos(self.psi0), math.sin(self.psi0)
        return RefSample(
            self.x0 + c * self.speed * t,
            self.y0 + s * self.speed * t,
            np.full_like(t, self.psi0),
            np.full_like(t, self.speed),
            np.zeros_like(t),
        )

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        dx = np.asarray(x, float) - self.x0
        dy = np.asarray(y, float) - self.y0
        return -math.sin(self.psi0) * dx + math.cos(self.psi0) * dy

    def path_points(self, n: int = 200, length: float = 400.0) -> np.ndarray:
        """(n, 2) points (m) of the first ``length`` metres."""
        return np.stack(self.at(np.linspace(0, length / self.speed, n))[:2], axis=1)


class FigureEightReference:
    """Two tangent circles of radius ``radius`` (m) meeting at the initial pose.

    First lap of the lobe on the ``direction`` side (ccw: left), then the opposite lobe in the
    opposite sense; heading is continuous (it turns +2π then −2π per period), the yaw rate switches
    sign at the crossing point.
    """

    def __init__(
        self,
        radius: float = 50.0,
        speed: float = 10.0,
        direction: str = "ccw",
        initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        other = "cw" if direction == "ccw" else "ccw"
        self.lobes = (
            CircleReference(radius, speed, direction, initial_pose),
            CircleReference(radius, speed, other, initial_pose),
        )
        self.speed = float(speed)
        self.lap = self.lobes[0].period

    @property
    def period(self) -> float:
        """Time (s) for the full figure-eight."""
        return 2 * self.lap

    def at(self, t: np.ndarray | float) -> RefSample:
        t = np.asarray(t, dtype=float)
        tm = np.mod(t, self.period)
        first = tm < self.lap
        a = self.lobes[0].at(tm)
        b = self.lobes[1].at(tm - self.lap)
        # psi: lobe 1 ends at psi0 ± 2π, lobe 2 starts from there and returns to psi0
        psi_b = b.psi + self.lobes[0].omega * self.lap
        out = [np.where(first, u, v) for u, v in zip(a, (b.x, b.y, psi_b, b.V, b.psidot), strict=True)]
        return RefSample(*out)

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Signed distance (m) to the nearer lobe, positive left of that lobe's direction of travel."""
        e1 = self.lobes[0].cross_track(x, y)
        e2 = self.lobes[1].cross_track(x, y)
        return np.where(np.abs(e1) <= np.abs(e2), e1, e2)

    def path_points(self, n: int = 200) -> np.ndarray:
        """(n, 2) points (m) of one full figure-eight."""
        return np.stack(self.at(np.linspace(0, self.period, n))[:2], axis=1)


def _start(cfg: RunConfig) -> tuple[float, float, float]:
    return tuple(cfg.plant.initial_pose)  # type: ignore[return-value]


references.register("circle", lambda cfg: CircleReference(cfg.reference.radius, cfg.reference.speed,
                                                           cfg.reference.direction, _start(cfg)), origin=BUILTIN)
references.register("line", lambda cfg: LineReference(cfg.reference.speed, _start(cfg)), origin=BUILTIN)
references.register("figure8", lambda cfg: FigureEightReference(cfg.reference.radius, cfg.reference.speed,
                                                                cfg.reference.direction, _start(cfg)), origin=BUILTIN)


def build_reference(cfg: RunConfig) -> Reference:
    """The reference ``cfg.reference.kind`` names (``circle``, ``line``, ``figure8`` or a registered
    plug-in's), starting at ``cfg.plant.initial_pose``."""
    return references.build(cfg.reference.kind, cfg)
