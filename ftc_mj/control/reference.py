"""Reference paths parametrised by arc length, and their constant-speed time law.

Every path — circle, straight line, figure-eight — is a function of the arc length ``s`` (m)
measured from the initial pose ``(x0, y0, psi0)`` (m, m, rad)::

    geometry(s) -> PathSample(x, y, heading, curvature)

with ``d(x, y)/ds = (cos heading, sin heading)`` and ``d heading/ds = curvature`` (1/m, positive
turning left); the heading is continuous (unwrapped). ``geometry`` is written against a math
namespace ``lib`` (``numpy`` or ``casadi``, as :func:`~ftc_mj.model.kinematics.pose_rates`), so the
same lines give the vectorised numeric path and the symbolic one an NLP optimises over; a new path
needs nothing else.

The time law of the time-parametrised controllers is derived from the geometry: ``at(t)`` is the
path at ``s = V t`` traversed at the constant speed ``V`` (m/s), with yaw rate ``V curvature``
(rad/s). It is vectorised over ``t`` (s).

Cross-track sign convention: ``cross_track(x, y)`` is the signed distance (m) from the path,
**positive to the left** of the direction of travel (for a counter-clockwise circle: inside).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from types import ModuleType
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np
from pydantic import Field

from ..fields import Options, PosFloat, StrictModel, component, options_of
from ..lazy import lazy_module

ca = lazy_module("casadi")


class ReferenceSettings(StrictModel):
    """The reference path and its time law (the ``[reference]`` section): one model for every path kind —
    the built-in paths read the fields their geometry has (``line`` no ``radius``), a plug-in its ``options``."""

    kind: component("references") = "circle"
    """A registered reference path (:data:`ftc_mj.registry.references`). Built-in: ``circle``, ``line``,
    ``figure8``."""
    radius: PosFloat = 50.0
    """Circle radius (m) (figure-eight: lobe radius)."""
    speed: PosFloat = 10.0
    """Speed along the path (m/s)."""
    direction: Literal["ccw", "cw"] = "ccw"
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in reference (its registered settings model); built-in references take none."""

    _options = options_of("references", "kind")


class RefSample(NamedTuple):
    """Reference values at one or many times (arrays broadcast like ``t``)."""

    x: np.ndarray
    y: np.ndarray
    psi: np.ndarray
    V: np.ndarray
    psidot: np.ndarray


class PathSample(NamedTuple):
    """A path at one or many arc lengths: position (m), heading (rad, unwrapped), curvature (1/m)."""

    x: Any
    y: Any
    heading: Any
    curvature: Any


class Path(Protocol):
    """What a path-following controller needs from a path."""

    speed: float

    def geometry(self, s: Any, lib: ModuleType = np) -> PathSample: ...


class Reference(Path, Protocol):
    """What the controllers need from a reference: the path and its time law."""

    def at(self, t: np.ndarray | float) -> RefSample: ...

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray: ...

    def path_points(self, n: int = 200) -> np.ndarray: ...


def _select(lib: ModuleType, cond: Any, a: Any, b: Any) -> Any:
    """``a`` where ``cond`` else ``b``, in numpy or casadi."""
    return np.where(cond, a, b) if lib is np else ca.if_else(cond, a, b)


def _full(lib: ModuleType, like: Any, value: float) -> Any:
    """``value`` shaped like ``like`` (a constant path quantity as a function of ``s``)."""
    return np.full(np.shape(like), value) if lib is np else 0.0 * like + value


class _TimeLaw:
    """``at(t)``: the path at ``s = speed t`` traversed at constant speed (for a class with ``geometry``
    and ``speed``)."""

    speed: float
    geometry: Callable[..., PathSample]

    def at(self, t: np.ndarray | float) -> RefSample:
        """Position (m), heading (rad), speed (m/s) and yaw rate (rad/s) of the time law at ``t`` (s)."""
        t = np.asarray(t, dtype=float)
        g = self.geometry(self.speed * t)
        return RefSample(g.x, g.y, g.heading, np.full_like(t, self.speed), self.speed * g.curvature)


class CircleReference(_TimeLaw):
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
    def length(self) -> float:
        """Arc length of one lap (m)."""
        return 2 * math.pi * self.radius

    @property
    def period(self) -> float:
        """Lap time (s)."""
        return self.length / self.speed

    def geometry(self, s: Any, lib: ModuleType = np) -> PathSample:
        """Point, heading and curvature ``sign/radius`` at arc length ``s`` (m)."""
        k = self.sign / self.radius
        th = self.theta0 + k * s
        return PathSample(self.center[0] + self.radius * lib.cos(th), self.center[1] + self.radius * lib.sin(th),
                          self.psi0 + k * s, _full(lib, s, k))

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        d = np.hypot(np.asarray(x, float) - self.center[0], np.asarray(y, float) - self.center[1])
        return self.sign * (self.radius - d)

    def path_points(self, n: int = 200) -> np.ndarray:
        """(n, 2) points of one lap (m), for drawing."""
        return np.stack(self.geometry(np.linspace(0, self.length, n))[:2], axis=1)


class LineReference(_TimeLaw):
    """A straight line from the initial pose along its heading."""

    def __init__(self, speed: float = 10.0, initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        if speed <= 0:
            raise ValueError("speed must be > 0")
        self.speed = float(speed)
        self.x0, self.y0, self.psi0 = (float(v) for v in initial_pose)
        self.cos0, self.sin0 = math.cos(self.psi0), math.sin(self.psi0)  # the direction (kept: NLP parameters)

    def geometry(self, s: Any, lib: ModuleType = np) -> PathSample:
        """Point at arc length ``s`` (m); constant heading, zero curvature."""
        return PathSample(self.x0 + self.cos0 * s, self.y0 + self.sin0 * s,
                          _full(lib, s, self.psi0), _full(lib, s, 0.0))

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        dx = np.asarray(x, float) - self.x0
        dy = np.asarray(y, float) - self.y0
        return -math.sin(self.psi0) * dx + math.cos(self.psi0) * dy

    def path_points(self, n: int = 200, length: float = 400.0) -> np.ndarray:
        """(n, 2) points (m) of the first ``length`` metres."""
        return np.stack(self.geometry(np.linspace(0, length, n))[:2], axis=1)


class FigureEightReference(_TimeLaw):
    """Two tangent circles of radius ``radius`` (m) meeting at the initial pose.

    First lap of the lobe on the ``direction`` side (ccw: left), then the opposite lobe in the
    opposite sense; heading is continuous (it turns +2π then −2π per figure-eight), the curvature
    switches sign at the crossing point.
    """

    def __init__(self, radius: float = 50.0, speed: float = 10.0, direction: str = "ccw",
                 initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Lobes of ``radius`` (m) at ``speed`` (m/s); the first lobe on the ``direction`` side of ``initial_pose``."""
        other = "cw" if direction == "ccw" else "ccw"
        self.lobes = (
            CircleReference(radius, speed, direction, initial_pose),
            CircleReference(radius, speed, other, initial_pose),
        )
        self.speed = float(speed)
        self.lap_length = self.lobes[0].length
        self.lap = self.lobes[0].period

    @property
    def length(self) -> float:
        """Arc length (m) of the full figure-eight."""
        return 2 * self.lap_length

    @property
    def period(self) -> float:
        """Time (s) for the full figure-eight."""
        return 2 * self.lap

    def geometry(self, s: Any, lib: ModuleType = np) -> PathSample:
        """The first lobe for ``s mod length < lap_length``, else the second; lobe 2 starts at the heading
        lobe 1 ends with (``psi0 ± 2π``) and turns back to ``psi0``."""
        sm = s - self.length * lib.floor(s / self.length)
        a = self.lobes[0].geometry(sm, lib)
        b = self.lobes[1].geometry(sm - self.lap_length, lib)
        turn = 2 * math.pi * self.lobes[0].sign
        first = sm < self.lap_length
        return PathSample(*(_select(lib, first, u, v) for u, v in zip(a, (b.x, b.y, b.heading + turn, b.curvature),
                                                                         strict=True)))

    def cross_track(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Signed distance (m) to the nearer lobe, positive left of that lobe's direction of travel."""
        e1 = self.lobes[0].cross_track(x, y)
        e2 = self.lobes[1].cross_track(x, y)
        return np.where(np.abs(e1) <= np.abs(e2), e1, e2)

    def path_points(self, n: int = 200) -> np.ndarray:
        """(n, 2) points (m) of one full figure-eight."""
        return np.stack(self.geometry(np.linspace(0, self.length, n))[:2], axis=1)


def path_errors(path: Path, x: np.ndarray, y: np.ndarray, s: np.ndarray,
                at: PathSample | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Contouring and lag error (m) of the points ``(x, y)`` relative to the path points at ``s``.

    ``e_c = −sin θ (x − x_p) + cos θ (y − y_p)`` (positive to the left of the path tangent) and
    ``e_l = cos θ (x − x_p) + sin θ (y − y_p)`` (positive ahead of the path point), with
    ``(x_p, y_p, θ) = geometry(s)`` — or ``at``, that geometry when the caller has it already.
    """
    g = path.geometry(np.asarray(s, dtype=float)) if at is None else at
    dx, dy = np.asarray(x, float) - g.x, np.asarray(y, float) - g.y
    c, sn = np.cos(g.heading), np.sin(g.heading)
    return -sn * dx + c * dy, c * dx + sn * dy


def project(path: Path, x: float, y: float, s_guess: float, window: float, step: float = 0.5,
            newton: int = 3) -> float:
    """Arc length (m) of the path point nearest ``(x, y)`` within ``s_guess ± window`` (m).

    A sampled search every ``step`` metres picks the nearest sample (the one nearest ``s_guess`` on a
    tie), then Newton steps on the lag error ``e_l(s) = 0`` refine it: ``de_l/ds = κ e_c − 1``, so
    ``s ← s + e_l / (1 − κ e_c)`` (steps limited to one sample spacing).
    """
    n = max(int(math.ceil(window / step)), 1)
    cand = s_guess + step * np.arange(-n, n + 1)
    g = path.geometry(cand)
    d2 = (g.x - x) ** 2 + (g.y - y) ** 2 + 1e-12 * np.abs(cand - s_guess)
    s = float(cand[int(np.argmin(d2))])
    for _ in range(newton):
        g = path.geometry(np.array([s]))
        ec, el = path_errors(path, np.array([x]), np.array([y]), np.array([s]), g)
        k = float(g.curvature[0])
        den = 1.0 - k * float(ec[0])
        if den <= 1e-6:
            break
        s += float(np.clip(float(el[0]) / den, -step, step))
    return s
